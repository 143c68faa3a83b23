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
from observer_ros.core.model import covariance_from_flat, StateSpaceModel, vector_from_flat

_CACHE_SIZE = 64


def _square_root(covariance: np.ndarray) -> np.ndarray:
    """Symmetric square root of a positive semi-definite matrix (singular allowed)."""
    values, vectors = np.linalg.eigh(covariance)
    return vectors * np.sqrt(np.clip(values, 0.0, None))


def input_limits_from_flat(values, n_inputs: int) -> Optional[np.ndarray]:
    """
    Parse input limits into an ``(m, 2)`` array, or None.

    Accepts empty (no limits), ``[min, max]`` for all inputs, or
    ``[min_1, max_1, ..., min_m, max_m]``.
    """
    if values is None or len(values) == 0:
        return None
    vector = vector_from_flat('input_limits', values, len(values))
    if vector.size == 2:
        limits = np.tile(vector, (n_inputs, 1))
    elif vector.size == 2 * n_inputs:
        limits = vector.reshape(n_inputs, 2)
    else:
        raise ConfigError('input_limits', f'expected 2 values (min, max) or {2 * n_inputs} '
                          f'(min, max per input), got {vector.size}')
    if np.any(limits[:, 0] >= limits[:, 1]):
        raise ConfigError('input_limits', f'expected min < max, got {vector.tolist()}')
    return limits


class PlantSimulator:
    """
    Simulate ``x' = A x + B u + w``, ``y = C x + v`` exactly between samples.

    Parameters
    ----------
    model : StateSpaceModel
        Continuous (``dt == 0``: any interval) or discrete (one step per call).
    initial_state : array_like, shape (n,), optional
    process_noise : array_like, optional
        Continuous model: intensity ``Q`` (discretized with Van Loan's method for each
        interval). Discrete model: covariance of ``w[k]``. ``n`` or ``n * n`` values.
    measurement_noise : array_like, optional
        Covariance of ``v`` at each sample, ``p`` or ``p * p`` values.
    seed : int, optional
        Seed of the noise generator (``numpy.random.default_rng``).
    input_limits : numpy.ndarray, shape (m, 2), optional
        Saturation applied to every input.

    """

    def __init__(self, model: StateSpaceModel, initial_state=None, process_noise=None,
                 measurement_noise=None, seed: Optional[int] = None,
                 input_limits: Optional[np.ndarray] = None) -> None:
        self.model = model
        self.x = (np.zeros(model.n_states) if initial_state is None
                  else vector_from_flat('plant.initial_state', initial_state, model.n_states))
        self.q = (None if process_noise is None or len(process_noise) == 0
                  else covariance_from_flat('plant.process_noise', process_noise,
                                            model.n_states))
        self.r_root = (None if measurement_noise is None or len(measurement_noise) == 0
                       else _square_root(covariance_from_flat(
                           'plant.measurement_noise', measurement_noise, model.n_outputs)))
        self.rng = np.random.default_rng(seed)
        self.input_limits = input_limits
        self._cache: OrderedDict = OrderedDict()

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
        """Clip ``u`` to the input limits (if any)."""
        u = np.asarray(u, dtype=float).reshape(self.model.n_inputs)
        if self.input_limits is None:
            return u
        return np.clip(u, self.input_limits[:, 0], self.input_limits[:, 1])

    def step(self, u, dt: float) -> np.ndarray:
        """Advance ``dt`` seconds (one period for a discrete model) with ``u`` held."""
        ad, bd, q_root = self._sampled(float(dt))
        self.x = ad @ self.x + bd @ self.saturate(u)
        if q_root is not None:
            self.x = self.x + q_root @ self.rng.standard_normal(self.model.n_states)
        return self.x

    def measure(self) -> np.ndarray:
        """Output at the current state, with measurement noise if configured."""
        y = self.model.c @ self.x
        if self.r_root is not None:
            y = y + self.r_root @ self.rng.standard_normal(self.model.n_outputs)
        return y
