# Copyright 2026 observer_ros contributors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Designs at an operating point of a nonlinear model, and the sampled closed loop run there.

:func:`linearize` gives the :class:`~observer_ros.core.model.StateSpaceModel` of the
equations at an operating point ``(x0, u0)``, exactly (SymPy's derivatives, evaluated in
double precision), so that the linear designs (``feedback.poles``, the observer types) are
made there; :func:`simulate_observer_controller` runs the sampled closed loop of a plant, an
estimator of the equations and the law ``u = u0 - K (x_hat - x0)`` designed at that point
(the deviation of an angle state wrapped to ``(-pi, pi]``). :func:`arm_joint` is the
example of ``doc/arm_joint.md``: a pendulum-like joint with gravity.
"""

from dataclasses import dataclass
import math
from typing import Optional, Sequence

import numpy as np

from observer_ros.core.angles import wrap_angles
from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import vector_from_flat
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.nonlinear.linearize import linearize as exact_linearization
from observer_ros.core.nonlinear.model import NonlinearModel
from observer_ros.core.nonlinear.simulation import NonlinearPlantSimulator
from observer_ros.core.units import NANOSECONDS, seconds_to_ns

__all__ = ['ClosedLoopRun', 'EQUILIBRIUM_RTOL', 'arm_joint', 'linearize',
           'simulate_observer_controller']

#: An operating point is an equilibrium when ``|f(x0, u0)|`` (``|f(x0, u0) - x0|`` for a
#: discrete model) is at most this times the largest of 1, ``|x0|`` and ``|u0|``.
EQUILIBRIUM_RTOL = 1e-9


def linearize(model: NonlinearModel, operating_state, operating_input=(),
              equilibrium: bool = True) -> StateSpaceModel:
    """
    Return the linear model of the equations at an equilibrium ``(x0, u0)``, exactly.

    ``A = df/dx``, ``B = df/du``, ``C = dh/dx``, ``D = dh/du`` at the operating point, from
    SymPy's derivatives of the equations evaluated in double precision (no finite
    differences); the names and ``dt`` are the model's. The linear model describes the
    deviations ``x - x0``, ``u - u0``, ``y - h(x0, u0)``.

    Parameters
    ----------
    model : NonlinearModel
    operating_state : array_like, shape (n,)
        ``x0``.
    operating_input : array_like, shape (m,)
        ``u0``.
    equilibrium : bool
        Refuse a point that is not an equilibrium (``f(x0, u0) = 0``, or ``x0`` for a
        discrete model, to :data:`EQUILIBRIUM_RTOL`): a law ``u0 - K (x - x0)`` would not
        hold the plant there.

    Returns
    -------
    StateSpaceModel

    Raises
    ------
    ConfigError
        Naming ``operating_state`` or ``operating_input`` (wrong length, not finite), or
        ``operating_input`` when the point is not an equilibrium (with ``f(x0, u0)`` and the
        input that holds the point where there is one input per moving state), or
        ``operating_state`` when a derivative is not finite there
        (:func:`~observer_ros.core.nonlinear.linearize.linearize`, the one linearization).

    Examples
    --------
    The arm joint at 45 degrees, held by the torque of gravity there:

    >>> arm = arm_joint()
    >>> q0 = np.pi / 4
    >>> tau0 = 1.0 * 9.81 * 0.5 * np.sin(q0)
    >>> linear = linearize(arm, [q0, 0.0], [tau0])
    >>> linear.a.round(4).tolist(), linear.b.tolist(), linear.c.tolist()
    ([[0.0, 1.0], [-13.8734, -0.4]], [[0.0], [4.0]], [[1.0, 0.0]])
    >>> linearize(arm, [q0, 0.0], [0.0])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: operating_input: (x0, u0) is not an equilibrium: \
f(x0, u0) = [0.0, -13.87...]; ...

    """
    x0 = vector_from_flat('operating_state', np.ravel(operating_state), model.n_states)
    u0 = vector_from_flat('operating_input', np.ravel(operating_input), model.n_inputs)
    if equilibrium:
        drift = model.f(x0, u0) - (x0 if model.is_discrete else 0.0)
        scale = max(1.0, float(np.abs(x0).max(initial=0.0)), float(np.abs(u0).max(initial=0.0)))
        if not np.all(np.abs(drift) <= EQUILIBRIUM_RTOL * scale):
            raise ConfigError('operating_input', f'(x0, u0) is not an equilibrium: f(x0, u0) '
                              f'= {drift.tolist()}; expected 0 (give the input that holds '
                              f'x0, or a state where one does)')
    return exact_linearization(model, x0, u0)


def arm_joint(mass: float = 1.0, length: float = 0.5, gravity: float = 9.81,
              damping: float = 0.1) -> NonlinearModel:
    """
    Return the arm joint example: a link with gravity, driven by a torque, read by an encoder.

    States ``q`` (rad, an angle, 0 hanging down) and ``dq`` (rad/s), input ``tau`` (N m),
    output ``encoder`` (``q``, an angle):
    ``ddq = (tau - m g l sin(q) - b dq) / (m l^2)``, with the constants ``m`` (kg),
    ``l`` (m), ``g`` (m/s^2) and ``b`` (N m s/rad).

    Examples
    --------
    >>> arm_joint().f([np.pi / 2, 0.0], [0.0]).round(3).tolist()
    [0.0, -19.62]

    """
    return NonlinearModel(
        ['q', 'dq'], {'q': 'dq', 'dq': '(tau - m * g * l * sin(q) - b * dq) / (m * l ** 2)'},
        {'encoder': 'q'}, inputs=['tau'],
        constants={'m': mass, 'l': length, 'g': gravity, 'b': damping},
        angle_states=['q'], angle_outputs=['encoder'])


@dataclass(frozen=True)
class ClosedLoopRun:
    """
    The record of :func:`simulate_observer_controller`, one row per sample.

    Attributes
    ----------
    stamps_ns : numpy.ndarray, shape (k,)
    states : numpy.ndarray, shape (k, n)
        The plant's state at each sample (before the command of the sample acts).
    estimates : numpy.ndarray, shape (k, n)
        ``x_hat`` after the sample's update.
    commands : numpy.ndarray, shape (k, m)
        ``u`` computed at the sample, held until the next one (as the plant applies it).
    outputs : numpy.ndarray, shape (k, p)
        The measurements.

    """

    stamps_ns: np.ndarray
    states: np.ndarray
    estimates: np.ndarray
    commands: np.ndarray
    outputs: np.ndarray


def simulate_observer_controller(plant: NonlinearPlantSimulator, estimator, gain,
                                 operating_state, operating_input, period: float,
                                 samples: int,
                                 angle_states: Optional[Sequence[int]] = None) -> ClosedLoopRun:
    """
    Run the sampled closed loop: measure, estimate, ``u = u0 - K (x_hat - x0)``, hold.

    At each sample ``k`` (stamp ``k T``): the plant's output ``y_k``, the estimator's update
    with ``y_k`` and the input held over the interval before, the command
    ``u_k = u0 - K (x_hat_k - x0)`` (angle states' deviations wrapped to ``(-pi, pi]``),
    held by the plant over the next ``T`` (saturated to its limits). The command before
    the first sample is ``u0``. The lockstep loop of the nodes (``plant.lockstep``), without
    transport.

    Parameters
    ----------
    plant : NonlinearPlantSimulator or PlantSimulator
        The linear plant too (the same interface; no angle states).
    estimator : Estimator
        Any estimator of the protocol (an :class:`~observer_ros.core.nonlinear.ExtendedKalman`
        of the same equations, a linear observer of the deviations...).
    gain : array_like, shape (m, n)
        ``K``, designed at the operating point (:func:`linearize`, ``design_feedback``).
    operating_state, operating_input : array_like, shapes (n,) and (m,)
    period : float
        ``T`` in seconds.
    samples : int
    angle_states : sequence of int, optional
        States whose deviation is wrapped; default the plant model's ``angle_states`` (none
        for a linear model).

    Returns
    -------
    ClosedLoopRun

    Raises
    ------
    ConfigError
        Naming ``gain``, ``operating_state``, ``operating_input``, ``period`` or
        ``samples``.

    """
    model = plant.model
    n, m = model.n_states, model.n_inputs
    gain = np.atleast_2d(np.asarray(gain, dtype=float))
    if gain.shape != (m, n):
        raise ConfigError('gain', f'expected {m}x{n} ({m * n} values), got shape {gain.shape}')
    x0 = vector_from_flat('operating_state', np.ravel(operating_state), n)
    u0 = vector_from_flat('operating_input', np.ravel(operating_input), m)
    if isinstance(period, bool) or not (isinstance(period, (int, float)) and
                                        math.isfinite(period) and period > 0.0):
        raise ConfigError('period', f'expected a period > 0 s, got {period!r}')
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise ConfigError('samples', f'expected a count >= 1, got {samples!r}')
    angles = list(getattr(model, 'angle_states', ()) if angle_states is None
                  else angle_states)
    period_ns = seconds_to_ns(period, 'period')
    records = {name: [] for name in ('stamps', 'states', 'estimates', 'commands', 'outputs')}
    held = u0.copy()
    for k in range(samples):
        stamp = k * period_ns
        y = plant.measure(held)
        records['states'].append(plant.x.copy())
        x_hat = np.array(estimator.update(stamp, y, held), dtype=float)
        deviation = x_hat - x0
        if angles:
            deviation[angles] = wrap_angles(deviation[angles])
        held = plant.saturate(u0 - gain @ deviation)
        for name, value in (('stamps', stamp), ('estimates', x_hat), ('commands', held),
                            ('outputs', y)):
            records[name].append(value)
        plant.step(held, period_ns / NANOSECONDS)
    return ClosedLoopRun(np.array(records['stamps'], dtype=np.int64),
                         np.array(records['states']), np.array(records['estimates']),
                         np.array(records['commands']).reshape(samples, m),
                         np.array(records['outputs']))
