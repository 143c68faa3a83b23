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
The plant simulation of a nonlinear model: ``x' = f(x, u)`` integrated by RK4, ``y = h(x, u)``.

:class:`NonlinearPlantSimulator` has the interface of
:class:`~observer_ros.core.simulation.PlantSimulator` (``step``, ``measure``, ``saturate``,
``applied``, ``x``, ``elapsed``), so whatever runs the linear plant runs this one.

Integrator and accuracy: an interval ``T`` with the input held (zero-order hold) is
integrated by the classical Runge-Kutta method of order 4 in ``ceil(T / max_step)`` equal
steps (``max_step`` 1 ms by default, the filters' own rule), a local error of order
``h^5`` and a global one of order ``h^4``: on a linear model the result is the exact
zero-order-hold discretization to about ``(|A| h)^5 / 120`` per step (below 1e-9 relative
for ``|A| h <= 0.01``; ``test_a_linear_model_as_expressions_simulates_as_the_linear_plant``).
A discrete model (``dt > 0``) takes ``x+ = f(x, u)`` once per step.

Noise: the process noise of a continuous model is an intensity ``Q``, added once at the end
of the interval as ``w ~ N(0, Q T)`` (Euler-Maruyama, first order in ``T``); of a discrete
model the covariance of ``w[k]``. The measurement noise is ``v ~ N(0, R)`` at each sample.

The designs at an operating point and the closed loop run there are in
:mod:`observer_ros.core.nonlinear.operating_point`.
"""

import math
from typing import Optional

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import covariance_from_flat, vector_from_flat
from observer_ros.core.nonlinear.filter import DEFAULT_MAX_STEP, rk4, rk4_steps
from observer_ros.core.nonlinear.model import NonlinearModel
from observer_ros.core.simulation import input_limits_from_flat

__all__ = ['NonlinearPlantSimulator']


def _square_root(covariance: np.ndarray) -> np.ndarray:
    """Symmetric square root of a positive semi-definite matrix (singular allowed)."""
    values, vectors = np.linalg.eigh(covariance)
    return vectors * np.sqrt(np.clip(values, 0.0, None))


class NonlinearPlantSimulator:
    """
    Simulate ``x' = f(x, u) + w``, ``y = h(x, u) + v`` (see the module for the integrator).

    Parameters
    ----------
    model : NonlinearModel
        Continuous (any interval) or discrete (one step of ``f`` per call).
    initial_state : array_like, shape (n,), optional
        Zero by default.
    process_noise : array_like, shape (n,) or (n * n,), optional
        Continuous model: intensity ``Q``; discrete model: covariance of ``w[k]``.
    measurement_noise : array_like, shape (p,) or (p * p,), optional
        Covariance of ``v`` at each sample.
    seed : int, optional
        Seed of the noise generator (``numpy.random.default_rng``).
    input_limits : array_like, shape (m, 2) or flat (2,) or (2 m,), optional
        Saturation ``[min, max]`` applied to every input.
    max_step : float
        Longest RK4 step in seconds (continuous model).
    input_offset : array_like, shape (m,), optional
        A constant disturbance ``d`` added to the saturated input.

    Attributes
    ----------
    x : numpy.ndarray, shape (n,)
        The current state.
    elapsed : float
        Simulated seconds.

    Raises
    ------
    ConfigError
        Naming ``model``, ``initial_state``, ``process_noise``, ``measurement_noise``,
        ``input_limits``, ``max_step`` or ``input_offset``.

    Examples
    --------
    A pendulum released at 0.5 rad, 100 steps of 10 ms:

    >>> model = NonlinearModel(['q', 'dq'], {'q': 'dq', 'dq': '-g / l * sin(q)'},
    ...                        {'angle': 'q'}, constants={'g': 9.81, 'l': 1.0})
    >>> plant = NonlinearPlantSimulator(model, initial_state=[0.5, 0.0])
    >>> for _ in range(100):
    ...     x = plant.step([], 0.01)
    >>> plant.measure().round(4).tolist()
    [-0.4992]

    """

    def __init__(self, model: NonlinearModel, initial_state=None, process_noise=None,
                 measurement_noise=None, seed: Optional[int] = None, input_limits=None,
                 max_step: float = DEFAULT_MAX_STEP, input_offset=None) -> None:
        if not isinstance(model, NonlinearModel):
            raise ConfigError('model', f'expected a NonlinearModel, got {type(model).__name__}')
        self.model = model
        n = model.n_states
        self.x = (np.zeros(n) if initial_state is None
                  else vector_from_flat('initial_state', initial_state, n))
        self.q = (None if process_noise is None or len(process_noise) == 0
                  else covariance_from_flat('process_noise', np.ravel(process_noise), n))
        self.r_root = (None if measurement_noise is None or len(measurement_noise) == 0
                       else _square_root(covariance_from_flat(
                           'measurement_noise', np.ravel(measurement_noise),
                           model.n_outputs)))
        self.rng = np.random.default_rng(seed)
        self.input_limits = (None if input_limits is None else
                             input_limits_from_flat(np.ravel(input_limits), model.n_inputs))
        self.input_offset = (None if input_offset is None or len(input_offset) == 0 else
                             vector_from_flat('input_offset', input_offset, model.n_inputs))
        if isinstance(max_step, bool) or not isinstance(max_step, (int, float)) or not (
                math.isfinite(max_step) and max_step > 0.0):
            raise ConfigError('max_step', f'expected a step > 0 s, got {max_step!r}')
        self.max_step = float(max_step)
        self.elapsed = 0.0
        self._noise_roots: dict = {}

    def saturate(self, u) -> np.ndarray:
        """Clip ``u`` (shape ``(m,)``) to the input limits (if any)."""
        u = np.asarray(u, dtype=float).reshape(self.model.n_inputs)
        if self.input_limits is None:
            return u
        return np.clip(u, self.input_limits[:, 0], self.input_limits[:, 1])

    def applied(self, u) -> np.ndarray:
        """Return the input the plant receives for a command ``u``: saturated, offset added."""
        applied = self.saturate(u)
        if self.input_offset is not None:
            applied = applied + self.input_offset
        return applied

    def step(self, u, dt: float) -> np.ndarray:
        """
        Advance ``dt`` seconds (one period of a discrete model) with ``u`` held.

        Returns
        -------
        numpy.ndarray, shape (n,)
            The new state.

        Raises
        ------
        ConfigError
            Naming ``dt`` (not a finite interval > 0 for a continuous model); ``model`` when
            the state stops being finite (the dynamics left a function's domain or
            diverged), with the time and the state before the step.

        """
        model = self.model
        u = self.applied(u)
        x = self.x
        if model.is_discrete:
            seconds = model.dt
            new = model.f(x, u)
        else:
            seconds = float(dt)
            if not (math.isfinite(seconds) and seconds > 0.0):
                raise ConfigError('dt', f'expected an interval > 0 s, got {dt!r}')
            new = rk4(model.f, x, u, *rk4_steps(seconds, self.max_step))
        if self.q is not None:
            new = new + self._noise_root(seconds) @ self.rng.standard_normal(model.n_states)
        if not np.isfinite(new).all():
            raise ConfigError('model', f'the state is not finite after the step from '
                              f'{self.elapsed:g} s (x = {x.tolist()}, u = {u.tolist()}): '
                              "the dynamics left a function's domain or diverged")
        self.x = new
        self.elapsed += seconds
        return self.x

    def _noise_root(self, seconds: float) -> np.ndarray:
        root = self._noise_roots.get(seconds)
        if root is None:
            scale = 1.0 if self.model.is_discrete else seconds
            root = _square_root(self.q * scale)
            if len(self._noise_roots) < 64:
                self._noise_roots[seconds] = root
        return root

    def measure(self, u=None) -> np.ndarray:
        """
        Return ``h(x, u) + v`` at the current state, shape ``(p,)``.

        ``u``: the input applied at this sample (saturated and offset as :meth:`step` applies
        it); zero when not given (a model whose ``h`` uses no input).
        """
        model = self.model
        applied = (np.zeros(model.n_inputs) if u is None else self.applied(u))
        y = model.h(self.x, applied)
        if self.r_root is not None:
            y = y + self.r_root @ self.rng.standard_normal(model.n_outputs)
        return y
