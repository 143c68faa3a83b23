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
The time-varying Kalman filter: the covariance propagated over each actual interval.

For each sample interval ``dt`` the model is sampled exactly (zero-order hold; Van Loan's
method turns a continuous intensity ``Q`` into the interval's covariance ``Qd``; a discrete
model uses its own ``A``, ``B``, ``Q`` once per sample):

* predict: ``x- = Ad x + Bd u``, ``P- = Ad P Ad^T + Qd``;
* update, in Joseph form so that ``P`` stays symmetric positive definite:
  ``S = C P- C^T + R``, ``K = P- C^T S^-1``, ``v = y - C x-``, ``x = x- + K v``,
  ``P = (I - K C) P- (I - K C)^T + K R K^T``.

The first sample is an update of the prior ``(x0, P0)``: ``x0`` is ``initial_state`` (zero
when not given) and ``P0`` the initial covariance. At a fixed rate ``P`` and ``K`` converge to
the steady-state filter's (:func:`~observer_ros.core.design.kalman.design_sampled_kalman`).

References
----------
R. E. Kalman, "A new approach to linear filtering and prediction problems", 1960;
R. S. Bucy and P. D. Joseph, Filtering for Stochastic Processes, 1968 (the Joseph form).
"""

from collections import OrderedDict
import math
from typing import Optional

import numpy as np

from observer_ros.core.discretize import transition
from observer_ros.core.errors import ConfigError, StampError
from observer_ros.core.estimators.protocol import Prediction, StateEstimator
from observer_ros.core.model import covariance_from_flat, StateSpaceModel

NANOSECONDS = 1_000_000_000

#: Distinct intervals whose sampled model is kept.
CACHE_SIZE = 256


class TimeVaryingKalman(StateEstimator):
    """
    Kalman filter whose covariance follows the actual sample intervals.

    Parameters
    ----------
    model : StateSpaceModel
        Needs ``D = 0``.
    process_noise : array_like, shape (n, n)
        ``Q``: the intensity of a continuous model, the per-sample covariance of a discrete
        one.
    measurement_noise : array_like, shape (p, p)
        ``R``, the covariance of each measurement; positive definite.
    initial_covariance : array_like, shape (n, n), optional
        ``P0``; the identity when not given.
    initial_state : array_like, shape (n,), optional
        ``x0``; zero when not given.
    interval_resolution_ns : int
        Round intervals to multiples of this before sampling the model (0: exact).

    Examples
    --------
    >>> import numpy as np
    >>> from observer_ros.core.model import StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> kf = TimeVaryingKalman(model, np.diag([0.0, 1.0]), [[0.01]])
    >>> kf.update(0, [1.0], [0.0]).round(4).tolist()
    [0.9901, 0.0]
    >>> x = kf.update(10_000_000, [1.0], [0.0])
    >>> bool(np.all(np.linalg.eigvalsh(kf.covariance) > 0))
    True

    """

    supports_batch = False

    def __init__(self, model: StateSpaceModel, process_noise, measurement_noise,
                 initial_covariance=None, initial_state=None,
                 interval_resolution_ns: int = 0) -> None:
        if np.any(model.d != 0.0):
            raise ConfigError('D', 'the runtime estimators need D = 0')
        self.model = model
        self.n_states, self.n_inputs = model.n_states, model.n_inputs
        self.n_outputs = model.n_outputs
        n = self.n_states
        self.process_noise = covariance_from_flat('process_noise', np.ravel(process_noise), n)
        self.measurement_noise = covariance_from_flat(
            'measurement_noise', np.ravel(measurement_noise), self.n_outputs)
        if np.linalg.eigvalsh(self.measurement_noise).min() <= 0.0:
            raise ConfigError('measurement_noise', 'expected a positive definite matrix')
        self.initial_covariance = (np.eye(n) if initial_covariance is None else
                                   covariance_from_flat('initial_covariance',
                                                        np.ravel(initial_covariance), n))
        if np.linalg.eigvalsh(self.initial_covariance).min() <= 0.0:
            raise ConfigError('initial_covariance', 'expected a positive definite matrix')
        self._pinned = None
        self.initial_state = initial_state
        self._resolution_ns = 0
        self._last_key_dt = self._last_sampled = None
        self._cache: OrderedDict = OrderedDict()
        self._recent: OrderedDict = OrderedDict()
        self.interval_resolution_ns = interval_resolution_ns
        self._identity = np.eye(n)
        self.reset()

    # --- state -----------------------------------------------------------------------------

    @property
    def initial_state(self) -> Optional[np.ndarray]:
        """The pinned ``x0``, or None (zero is the prior then)."""
        return None if self._pinned is None else self._pinned.copy()

    @initial_state.setter
    def initial_state(self, values) -> None:
        if values is None:
            self._pinned = None
            return
        vector = np.asarray(values, dtype=float).reshape(-1)
        if vector.size != self.n_states or not np.isfinite(vector).all():
            raise ValueError(f'initial_state: expected {self.n_states} finite values, got '
                             f'{vector.tolist()}')
        self._pinned = vector

    @property
    def stamp_ns(self) -> Optional[int]:
        """Stamp of the last sample taken, None before the first one."""
        return self._stamp

    @property
    def estimate(self) -> np.ndarray:
        """Current estimate ``x[k|k]`` (a copy)."""
        return self._x.copy()

    @property
    def innovation(self) -> np.ndarray:
        """Last innovation ``y - C x-``."""
        return self._innovation.copy()

    @property
    def covariance(self) -> np.ndarray:
        """``P[k|k]``, symmetric positive definite."""
        return self._p

    @property
    def innovation_covariance(self) -> Optional[np.ndarray]:
        """``S`` of the last update (None before the first)."""
        return self._s

    @property
    def nis(self) -> Optional[float]:
        """``v^T S^-1 v`` of the last update (None before the first)."""
        return self._nis

    @property
    def gain(self) -> Optional[np.ndarray]:
        """The filter gain ``K`` of the last update, ``(n, p)``."""
        return self._k

    @property
    def interval_resolution_ns(self) -> int:
        """Intervals are rounded to multiples of this (0: exact)."""
        return self._resolution_ns

    @interval_resolution_ns.setter
    def interval_resolution_ns(self, value: int) -> None:
        value = int(value)
        if value < 0:
            raise ValueError(f'interval_resolution_ns: expected >= 0, got {value}')
        if value != self._resolution_ns:
            self._resolution_ns = value
            self._cache.clear()
            self._recent.clear()
            self._last_key_dt = self._last_sampled = None

    def recent_intervals(self) -> list:
        """Return the last few distinct intervals (ns) sampled, newest first."""
        return list(self._recent)[::-1]

    # --- the filter ----------------------------------------------------------------------

    def _sampled(self, dt_ns: int, remember: bool = True) -> tuple:
        if dt_ns == self._last_key_dt:
            return self._last_sampled
        sampled = self._lookup(dt_ns, remember)
        if remember:
            self._last_key_dt, self._last_sampled = dt_ns, sampled
        return sampled

    def _lookup(self, dt_ns: int, remember: bool) -> tuple:
        if self.model.is_discrete:
            key = 0
        else:
            key = dt_ns
            resolution = self._resolution_ns
            if resolution:
                key = max(1, (dt_ns + resolution // 2) // resolution) * resolution
        sampled = self._cache.get(key)
        if sampled is None:
            if self.model.is_discrete:
                sampled = (self.model.a, self.model.b, self.process_noise)
            else:
                sampled = transition(self.model, key / NANOSECONDS, self.process_noise)
            self._cache[key] = sampled
            if len(self._cache) > CACHE_SIZE:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(key)
        if not remember:
            return sampled
        self._recent[key] = None
        self._recent.move_to_end(key)
        if len(self._recent) > 4:
            self._recent.popitem(last=False)
        return sampled

    def try_intervals(self, intervals_ns) -> None:
        """Sample the model for each interval (ns) now."""
        for dt_ns in intervals_ns:
            self._sampled(int(dt_ns))

    def _measure(self, x_prior: np.ndarray, p_prior: np.ndarray, y: np.ndarray) -> None:
        c, r = self.model.c, self.measurement_noise
        pc = p_prior @ c.T
        s = c @ pc + r
        innovation = y - c @ x_prior
        if self.n_outputs == 1:  # S is a number: no factorisation
            variance = s[0, 0]
            k = pc / variance
            nis = innovation[0] * innovation[0] / variance
        else:
            s = 0.5 * (s + s.T)
            factor = np.linalg.cholesky(s)
            k = np.linalg.solve(factor.T, np.linalg.solve(factor, pc.T)).T  # P- C^T S^-1
            whitened = np.linalg.solve(factor, innovation)
            nis = whitened @ whitened
        correction = self._identity - k @ c
        p = correction @ p_prior @ correction.T + k @ r @ k.T  # Joseph form
        self._x = x_prior + k @ innovation
        self._p = 0.5 * (p + p.T)
        self._innovation, self._s, self._k, self._nis = innovation, s, k, float(nis)

    def update(self, stamp_ns: int, y, u) -> np.ndarray:
        """
        Take ``y`` at ``stamp_ns`` with ``u`` held since the last sample.

        Raises
        ------
        StampError
            The stamp is not after the previous sample's.
        ValueError
            Wrong sizes or non-finite values.

        """
        y = np.asarray(y, dtype=float).reshape(-1)
        u = np.asarray(u, dtype=float).reshape(-1)
        if y.size != self.n_outputs or not np.isfinite(y).all():
            raise ValueError(f'y: expected {self.n_outputs} finite values, got {y.tolist()}')
        if u.size != self.n_inputs or not np.isfinite(u).all():
            raise ValueError(f'u: expected {self.n_inputs} finite values, got {u.tolist()}')
        return self.advance(int(stamp_ns), y, u)

    def advance(self, stamp_ns: int, y: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Take a sample whose values are checked already; return ``x[k|k]``."""
        if self._stamp is None:
            self._measure(self._prior_x, self._prior_p, y)
            self._last_interval = 0
        else:
            dt_ns = stamp_ns - self._stamp
            if dt_ns <= 0:
                raise StampError(f'stamp {stamp_ns} ns is not after the previous sample '
                                 f'({self._stamp} ns)')
            ad, bd, qd = self._sampled(dt_ns)
            self._measure(ad @ self._x + bd @ u, ad @ self._p @ ad.T + qd, y)
            self._last_interval = dt_ns
        self._stamp = stamp_ns
        return self._x

    def prediction(self, estimate: np.ndarray, covariance: Optional[np.ndarray],
                   interval_ns: int, u: np.ndarray) -> Prediction:
        """Return ``x`` and ``P`` carried over ``interval_ns`` with ``u`` (0: unchanged)."""
        if interval_ns <= 0:
            return Prediction(0, np.array(estimate, dtype=float), covariance)
        ad, bd, qd = self._sampled(interval_ns, remember=False)
        p = ad @ covariance @ ad.T + qd
        return Prediction(0, ad @ estimate + bd @ np.asarray(u, dtype=float),
                          0.5 * (p + p.T))

    @property
    def last_interval_ns(self) -> int:
        """The interval of the last step in nanoseconds (0 at a first sample)."""
        return self._last_interval

    def reset(self, initial_state=None) -> None:
        """Start again from ``(x0, P0)`` at the next sample."""
        if initial_state is not None:
            self.initial_state = initial_state
        self._prior_x = (np.zeros(self.n_states) if self._pinned is None
                         else self._pinned.copy())
        self._prior_p = self.initial_covariance
        self._x = self._prior_x.copy()
        self._p = self.initial_covariance.copy()
        self._innovation = np.zeros(self.n_outputs)
        self._s = self._k = self._nis = None
        self._stamp = None
        self._last_interval = 0

    def restart(self) -> None:
        """
        Forget the stamps; the next sample updates the estimate held.

        Nothing is known of the input over the gap, so ``P0`` is added to the covariance
        before that update.
        """
        self._prior_x = self._x.copy()
        self._prior_p = self._p + self.initial_covariance
        self._stamp = None

    def snapshot(self) -> tuple:
        """Return the running state, for :meth:`restore`."""
        return (self._x.copy(), self._p.copy(), self._innovation.copy(), self._s, self._k,
                self._nis, self._stamp, self._prior_x.copy(), self._prior_p.copy())

    def restore(self, state: tuple) -> None:
        """Return to a state taken by :meth:`snapshot`."""
        (x, p, innovation, self._s, self._k, self._nis, self._stamp, prior_x,
         prior_p) = state
        self._x, self._p, self._innovation = x.copy(), p.copy(), innovation.copy()
        self._prior_x, self._prior_p = prior_x.copy(), prior_p.copy()

    def adopt(self, other: StateEstimator) -> None:
        """Take the noises, ``P0`` and resolution of ``other``; keep ``x``, ``P`` and stamps."""
        if not isinstance(other, TimeVaryingKalman):
            raise ValueError(f'adopt: expected a TimeVaryingKalman, got {type(other).__name__}')
        if (other.n_states, other.n_inputs, other.n_outputs) != (
                self.n_states, self.n_inputs, self.n_outputs):
            raise ValueError('adopt: the other filter has other dimensions')
        self.model = other.model
        self.process_noise, self.measurement_noise = other.process_noise, other.measurement_noise
        self.initial_covariance = other.initial_covariance
        self._cache.clear()
        self.interval_resolution_ns = other.interval_resolution_ns


def is_positive_definite(matrix: np.ndarray) -> bool:
    """Whether a symmetric matrix is positive definite (its Cholesky factor exists)."""
    try:
        np.linalg.cholesky(matrix)
    except np.linalg.LinAlgError:
        return False
    return bool(math.isfinite(float(np.trace(matrix))))
