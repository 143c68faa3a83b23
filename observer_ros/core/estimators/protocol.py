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
What every runtime estimator offers: the protocol :class:`StateEstimator`.

:class:`~observer_ros.core.streaming.StreamEstimator` (the pairing and stamp rules of the
node and the bag replay) drives any estimator through it. Two implementations exist: the
constant-``G`` :class:`~observer_ros.core.estimators.base.Estimator` (one matrix per sample
interval; every Luenberger type and the steady-state Kalman filter) and the stateful
:class:`~observer_ros.core.observers.kalman.time_varying.TimeVaryingKalman`, which carries
its covariance. Optional capabilities (a batch path, a prepared steady step) have defaults
here that say "not offered"; the stream asks before it uses them.
"""

from abc import ABC, abstractmethod
import math
from typing import NamedTuple, Optional

import numpy as np

from observer_ros.core.errors import ConfigError


class Prediction(NamedTuple):
    """
    An estimate predicted to a stamp: ``x_hat`` and, with a covariance, ``P``.

    Attributes
    ----------
    stamp_ns : int
    estimate : numpy.ndarray, shape (n,)
    covariance : numpy.ndarray or None, shape (n, n)

    Examples
    --------
    >>> Prediction(5, [1.0], None).stamp_ns
    5

    """

    stamp_ns: int
    estimate: np.ndarray
    covariance: Optional[np.ndarray]


def rounded_interval(dt_ns: int, resolution_ns: int) -> int:
    """Return ``dt_ns`` rounded to the nearest multiple of ``resolution_ns`` (> 0), >= one."""
    return max(1, (dt_ns + resolution_ns // 2) // resolution_ns) * resolution_ns


class RoundedIntervals:
    """
    ``interval_resolution_ns`` for an estimator that designs or samples per interval (a mixin).

    The value is checked (an integer >= 0) and kept in ``_resolution_ns``; a change calls
    ``_forget_intervals()``, which the estimator implements to drop what it made for the old
    rounding. Put it before :class:`StateEstimator` in the bases.
    """

    _resolution_ns = 0

    @property
    def interval_resolution_ns(self) -> int:
        """Intervals are rounded to multiples of this before they are designed (0: exact)."""
        return self._resolution_ns

    @interval_resolution_ns.setter
    def interval_resolution_ns(self, value: int) -> None:
        value = int(value)
        if value < 0:
            raise ConfigError('interval_resolution_ns', f'expected >= 0, got {value}')
        if value != self._resolution_ns:
            self._resolution_ns = value
            self._forget_intervals()

    def _forget_intervals(self) -> None:
        raise NotImplementedError


class StateEstimator(ABC):
    """
    A discrete-time state estimator driven by stamped samples.

    Attributes
    ----------
    n_states, n_inputs, n_outputs : int
    supports_batch : bool
        Whether :meth:`advance_many` runs many steady samples at once (equal, bit for bit, to
        :meth:`advance` one by one).

    Notes
    -----
    :meth:`update` (checked) and :meth:`advance` (values already checked) take the
    measurement ``y`` stamped ``stamp_ns`` and the input ``u`` held since the previous
    sample; the first sample (and the first after :meth:`reset` or :meth:`restart`) starts
    the estimate. :meth:`predict` looks ahead without changing anything.

    Examples
    --------
    >>> from observer_ros.core import design_kalman, make_estimator, StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> filter_ = make_estimator(design_kalman(model, [0.0, 1.0], [0.01]), time_varying=True)
    >>> isinstance(filter_, StateEstimator), filter_.supports_batch
    (True, False)

    """

    n_states: int
    n_inputs: int
    n_outputs: int
    supports_batch = False

    @property
    @abstractmethod
    def stamp_ns(self) -> Optional[int]:
        """Stamp of the last sample taken, None before the first one."""

    @property
    @abstractmethod
    def estimate(self) -> np.ndarray:
        """Current estimate ``x_hat``, shape ``(n,)`` (a copy)."""

    @property
    @abstractmethod
    def innovation(self) -> np.ndarray:
        """Last innovation ``y - C x_prior``, shape ``(p,)``."""

    @property
    def covariance(self) -> Optional[np.ndarray]:
        """Covariance of the estimate, ``(n, n)``; None for observers without one."""
        return None

    @property
    def innovation_covariance(self) -> Optional[np.ndarray]:
        """Covariance ``S`` of the last innovation, ``(p, p)``; None without one."""
        return None

    @property
    def nis(self) -> Optional[float]:
        """Normalised innovation squared ``v^T S^-1 v`` of the last sample, or None."""
        covariance = self.innovation_covariance
        if covariance is None:
            return None
        innovation = self.innovation
        try:
            value = float(innovation @ np.linalg.solve(covariance, innovation))
        except np.linalg.LinAlgError:
            return math.inf
        return value

    @property
    def result(self) -> Optional[np.ndarray]:
        """``[x_hat; innovation]`` of the last step when the estimator keeps one, or None."""
        return None

    @abstractmethod
    def update(self, stamp_ns: int, y, u) -> np.ndarray:
        """Take ``y`` at ``stamp_ns`` with ``u`` held since the last sample (checked)."""

    @abstractmethod
    def advance(self, stamp_ns: int, y: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Take a sample whose values are checked already; return the estimate."""

    def predict(self, stamp_ns: int, u: np.ndarray) -> Prediction:
        """
        Return the estimate predicted to ``stamp_ns`` with ``u`` held; change nothing.

        Before the first sample, or for a stamp not after the last one, the current
        estimate (and covariance).
        """
        stamp = self.stamp_ns
        interval = 0 if stamp is None or stamp_ns <= stamp else stamp_ns - stamp
        prediction = self.prediction(self.estimate, self.covariance, interval, u)
        return prediction._replace(stamp_ns=int(stamp_ns))

    @abstractmethod
    def prediction(self, estimate: np.ndarray, covariance: Optional[np.ndarray],
                   interval_ns: int, u: np.ndarray) -> Prediction:
        """
        Return ``estimate`` (and ``covariance``) carried over ``interval_ns`` with ``u``.

        ``x = Ad x + Bd u`` and ``P = Ad P Ad^T + Qd``; an interval of 0 changes nothing.
        The one arithmetic of every prediction (live and batch), so they agree bit for bit.
        """

    @property
    def last_interval_ns(self) -> int:
        """The interval of the last step in nanoseconds (0 at a first sample)."""
        return 0

    @abstractmethod
    def reset(self, initial_state=None) -> None:
        """Forget everything and start again as configured (``initial_state`` pins it)."""

    @abstractmethod
    def restart(self) -> None:
        """Forget the stamps; the next sample starts from the estimate held."""

    @abstractmethod
    def snapshot(self) -> tuple:
        """Return the running state, for :meth:`restore`."""

    @abstractmethod
    def restore(self, state: tuple) -> None:
        """Return to a state taken by :meth:`snapshot`."""

    @abstractmethod
    def adopt(self, other: 'StateEstimator') -> None:
        """
        Take the design of ``other`` (same kind and sizes) and keep the running state.

        How a run-time change of gains, poles or noises reaches a running estimator: the
        estimate, the stamps (and a covariance) go on, so ``x_hat`` does not jump.
        """

    @abstractmethod
    def recent_intervals(self) -> list:
        """Return the last few distinct sample intervals (ns) the estimator stepped over."""

    @property
    def initial_state(self) -> Optional[np.ndarray]:
        """The pinned initial estimate, or None when the first measurement starts it."""
        return None

    @initial_state.setter
    def initial_state(self, values) -> None:
        raise NotImplementedError

    @property
    def interval_resolution_ns(self) -> int:
        """Intervals are rounded to multiples of this before they are designed (0: exact)."""
        return 0

    @interval_resolution_ns.setter
    def interval_resolution_ns(self, value: int) -> None:
        raise NotImplementedError

    def try_intervals(self, intervals_ns) -> None:
        """Design (or sample) for each interval now; raise what a sample would raise."""

    def prepare(self, u: np.ndarray, limits: Optional[tuple] = None) -> None:
        """Make the next step's known part now, where the estimator can (default: not)."""

    def advance_prepared(self, stamp_ns: int, y: float, u: np.ndarray) -> Optional[tuple]:
        """Take a prepared steady one-output step (default: not offered, None)."""
        return None

    def advance_many(self, stamps_ns, outputs, inputs) -> tuple:
        """Run many steady samples at once (only when :attr:`supports_batch`)."""
        raise NotImplementedError(f'{type(self).__name__} has no batch path')
