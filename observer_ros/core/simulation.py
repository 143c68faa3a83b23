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

"""Exact plant simulation: zero-order hold of the input, optional seeded noise."""

from collections import OrderedDict
from typing import Optional

import numpy as np

from observer_ros.core.discretize import van_loan, zero_order_hold
from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import covariance_from_flat, vector_from_flat
from observer_ros.core.model import model_feedthrough, StateSpaceModel

_CACHE_SIZE = 64


def _square_root(covariance: np.ndarray) -> np.ndarray:
    """Symmetric square root of a positive semi-definite matrix (singular allowed)."""
    values, vectors = np.linalg.eigh(covariance)
    return vectors * np.sqrt(np.clip(values, 0.0, None))


def input_limits_from_flat(values, n_inputs: int,
                           parameter: str = 'input_limits') -> Optional[np.ndarray]:
    """
    Parse input limits into an ``(m, 2)`` array, or None.

    Parameters
    ----------
    values : sequence of float, shape (0,), (2,) or (2 m,)
        Empty (no limits), ``[min, max]`` for all inputs, or
        ``[min_1, max_1, ..., min_m, max_m]``.
    n_inputs : int
        ``m``.
    parameter : str
        Name used in error messages.

    Returns
    -------
    numpy.ndarray, shape (m, 2), or None

    Raises
    ------
    ConfigError
        Naming ``parameter``: wrong length, non-finite entry, or ``min >= max``.

    Examples
    --------
    >>> from observer_ros.core.simulation import input_limits_from_flat
    >>> input_limits_from_flat([-1, 1], 2).tolist()
    [[-1.0, 1.0], [-1.0, 1.0]]
    >>> input_limits_from_flat([1, -1], 1)
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: input_limits: expected min < max, got [1.0, -1.0]

    """
    if values is None or len(values) == 0:
        return None
    vector = vector_from_flat(parameter, values, len(values))
    if vector.size == 2:
        limits = np.tile(vector, (n_inputs, 1))
    elif vector.size == 2 * n_inputs:
        limits = vector.reshape(n_inputs, 2)
    else:
        raise ConfigError(parameter, f'expected 2 values (min, max) or {2 * n_inputs} '
                          f'(min, max per input), got {vector.size}')
    if np.any(limits[:, 0] >= limits[:, 1]):
        raise ConfigError(parameter, f'expected min < max, got {vector.tolist()}')
    return limits


class PlantSimulator:
    """
    Simulate ``x' = A x + B u + w``, ``y = C x + v`` exactly between samples.

    Parameters
    ----------
    model : StateSpaceModel
        Continuous (``dt == 0``: any interval) or discrete (one step per call).
    initial_state : array_like, shape (n,), optional
        Zero by default.
    process_noise : array_like, shape (n,) or (n * n,), optional
        Continuous model: intensity ``Q`` (discretized with Van Loan's method for each
        interval). Discrete model: covariance of ``w[k]``.
    measurement_noise : array_like, shape (p,) or (p * p,), optional
        Covariance of ``v`` at each sample.
    seed : int, optional
        Seed of the noise generator (``numpy.random.default_rng``).
    input_limits : array_like, shape (m, 2) or flat (2,) or (2 m,), optional
        Saturation ``[min, max]`` applied to every input (see
        :func:`input_limits_from_flat`).
    disturbance : array_like, shape (n_d,), optional
        Values written into the last ``n_d`` states (the disturbance states of an augmented
        model, :mod:`observer_ros.core.disturbances`) once ``disturbance_time`` seconds
        have been simulated: a disturbance step.
    disturbance_time : float
        Simulated seconds from the start (0: from the first sample on).
    input_offset : array_like, shape (m,), optional
        A constant disturbance ``d`` added to the saturated input: ``x' = A x + B (u + d)``.

    Attributes
    ----------
    x : numpy.ndarray, shape (n,)
        The current state.

    Raises
    ------
    ConfigError
        Naming ``initial_state``, ``process_noise``, ``measurement_noise`` or
        ``input_limits`` for a wrong size or value.

    Examples
    --------
    A double integrator pushed by a unit force for one second, 100 steps of 10 ms:

    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> plant = oc.PlantSimulator(model, initial_state=[0.0, 0.0])
    >>> for _ in range(100):
    ...     x = plant.step([1.0], 0.01)
    >>> x.round(9).tolist(), plant.measure().round(9).tolist()
    ([0.5, 1.0], [0.5])

    With seeded noise the run is reproducible:

    >>> noisy = oc.PlantSimulator(model, measurement_noise=[0.01], seed=3)
    >>> bool(noisy.measure()[0] == oc.PlantSimulator(
    ...     model, measurement_noise=[0.01], seed=3).measure()[0])
    True

    """

    def __init__(self, model: StateSpaceModel, initial_state=None, process_noise=None,
                 measurement_noise=None, seed: Optional[int] = None,
                 input_limits: Optional[np.ndarray] = None, disturbance=None,
                 disturbance_time: float = 0.0, input_offset=None) -> None:
        self.model = model
        self.x = (np.zeros(model.n_states) if initial_state is None
                  else vector_from_flat('initial_state', initial_state, model.n_states))
        self.q = (None if process_noise is None or len(process_noise) == 0
                  else covariance_from_flat('process_noise', process_noise, model.n_states))
        self.r_root = (None if measurement_noise is None or len(measurement_noise) == 0
                       else _square_root(covariance_from_flat(
                           'measurement_noise', measurement_noise, model.n_outputs)))
        self.rng = np.random.default_rng(seed)
        self.input_limits = (None if input_limits is None else
                             input_limits_from_flat(np.ravel(input_limits), model.n_inputs))
        self.input_offset = (None if input_offset is None or len(input_offset) == 0 else
                             vector_from_flat('input_offset', input_offset, model.n_inputs))
        self._cache: OrderedDict = OrderedDict()
        #: ``D`` when it is not zero, else None (``y = C x`` exactly as without one).
        self.feedthrough = model_feedthrough(model)
        self.elapsed = 0.0
        self.disturbance_time = float(disturbance_time)
        self._pending = (None if disturbance is None or len(disturbance) == 0
                         else np.asarray(disturbance, dtype=float).ravel())
        if self._pending is not None and self._pending.size > model.n_states:
            raise ConfigError('disturbance', f'expected at most {model.n_states} values, got '
                              f'{self._pending.size}')
        self._apply_due_disturbance()

    def _apply_due_disturbance(self) -> None:
        if self._pending is not None and self.elapsed >= self.disturbance_time - 1e-12:
            self.x = self.x.copy()
            self.x[self.x.size - self._pending.size:] = self._pending
            self._pending = None

    def _sampled(self, dt: float):
        key = dt
        entry = self._cache.get(key)
        if entry is None:
            if self.model.is_discrete:
                ad, bd, q = self.model.a, self.model.b, self.q
            else:
                ad, bd = zero_order_hold(self.model.a, self.model.b, dt)
                q = None if self.q is None else van_loan(self.model.a, self.q, dt)
            entry = (ad, bd, None if q is None else _square_root(q))
            self._cache[key] = entry
            if len(self._cache) > _CACHE_SIZE:
                self._cache.popitem(last=False)
        return entry

    def saturate(self, u) -> np.ndarray:
        """
        Clip ``u`` to the input limits (if any).

        Parameters
        ----------
        u : array_like, shape (m,)

        Returns
        -------
        numpy.ndarray, shape (m,)

        Examples
        --------
        >>> import observer_ros.core as oc
        >>> model = oc.StateSpaceModel.from_matrices([[-1]], [[1]], [[1]])
        >>> oc.PlantSimulator(model, input_limits=[-1, 1]).saturate([3.0]).tolist()
        [1.0]

        """
        u = np.asarray(u, dtype=float).reshape(self.model.n_inputs)
        if self.input_limits is None:
            return u
        return np.clip(u, self.input_limits[:, 0], self.input_limits[:, 1])

    def step(self, u, dt: float) -> np.ndarray:
        """
        Advance ``dt`` seconds (one period for a discrete model) with ``u`` held.

        Parameters
        ----------
        u : array_like, shape (m,)
            Saturated to the input limits, then held over the interval.
        dt : float
            Seconds (ignored for a discrete model, which advances one period).

        Returns
        -------
        numpy.ndarray, shape (n,)
            The new state (the simulator's own array).

        Examples
        --------
        >>> import observer_ros.core as oc
        >>> model = oc.StateSpaceModel.from_matrices([[0.5]], [[1]], [[1]], dt=0.1)
        >>> plant = oc.PlantSimulator(model, initial_state=[2.0])
        >>> plant.step([1.0], 0.1).tolist()
        [2.0]

        """
        ad, bd, q_root = self._sampled(float(dt))
        applied = self.applied(u)
        self.x = ad @ self.x + bd @ applied
        if q_root is not None:
            self.x = self.x + q_root @ self.rng.standard_normal(self.model.n_states)
        self.elapsed += self.model.dt if self.model.is_discrete else float(dt)
        self._apply_due_disturbance()
        return self.x

    def applied(self, u) -> np.ndarray:
        """Return the input the plant receives for a command ``u``: saturated, offset added."""
        applied = self.saturate(u)
        if self.input_offset is not None:
            applied = applied + self.input_offset
        return applied

    def measure(self, u=None) -> np.ndarray:
        """
        Output at the current state, with measurement noise if configured.

        Parameters
        ----------
        u : array_like, shape (m,), optional
            The input applied at this sample (the one :meth:`step` holds next), saturated and
            offset as :meth:`step` applies it; needed for a model with a feedthrough
            ``D != 0`` and not used without one.

        Returns
        -------
        numpy.ndarray, shape (p,)
            ``C x + D u + v``.

        Raises
        ------
        ConfigError
            Naming ``u``: missing for a model with a feedthrough.

        Examples
        --------
        >>> import observer_ros.core as oc
        >>> model = oc.StateSpaceModel.from_matrices([[-1]], [[1]], [[3]])
        >>> oc.PlantSimulator(model, initial_state=[2.0]).measure().tolist()
        [6.0]
        >>> direct = oc.StateSpaceModel.from_matrices([[-1]], [[1]], [[3]], [[0.5]])
        >>> oc.PlantSimulator(direct, initial_state=[2.0]).measure([4.0]).tolist()
        [8.0]

        """
        y = self.model.c @ self.x
        if self.feedthrough is not None:
            if u is None:
                raise ConfigError('u', 'the model has a feedthrough D != 0: give the input '
                                  'applied at this sample')
            y = y + self.feedthrough @ self.applied(u)
        if self.r_root is not None:
            y = y + self.r_root @ self.rng.standard_normal(self.model.n_outputs)
        return y


def simulator_of(model: StateSpaceModel, initial_state=None, process_noise=None,
                 measurement_noise=None, seed: Optional[int] = None,
                 input_limits: Optional[np.ndarray] = None, disturbance=None,
                 disturbance_time: float = 0.0, input_offset=None):
    """
    Return the simulator of ``model``: its equations where it carries them, else the linear one.

    A model linearized from equations (``model.dynamics``; a
    :class:`~observer_ros.core.nonlinear.linearize.LinearizedModel`) describes deviations from
    its operating point; the plant it stands for is the equations themselves, simulated by
    :class:`~observer_ros.core.nonlinear.simulation.NonlinearPlantSimulator` (imported only
    then: a linear plant loads no SymPy). The arguments are those of :class:`PlantSimulator`;
    a disturbance on equations is refused by the configuration before.
    """
    equations = getattr(model, 'nonlinear', None)
    if equations is None:
        return PlantSimulator(model, initial_state, process_noise, measurement_noise, seed,
                              input_limits, disturbance, disturbance_time,
                              input_offset=input_offset)
    if disturbance is not None:
        raise ConfigError('disturbance', 'a plant of equations (model.dynamics) takes no '
                          'disturbance generators; write the disturbance into the equations')
    from observer_ros.core.nonlinear.simulation import NonlinearPlantSimulator
    return NonlinearPlantSimulator(equations, initial_state, process_noise, measurement_noise,
                                   seed, input_limits, input_offset=input_offset)
