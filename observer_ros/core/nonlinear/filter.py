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
What the extended and unscented Kalman filters share: state, stamps, sources and angles.

:class:`NonlinearFilter` implements the estimator protocol
(:class:`~observer_ros.core.estimators.Estimator` with
:class:`~observer_ros.core.estimators.SubsetUpdates`), so the event engine runs it like the
linear time-varying filter: every source at its own rate with its own rows of ``h`` and its
block of ``R``, late measurements through the history (:meth:`snapshot` / :meth:`restore`),
predict-only sources (an update with no output) and predictions between samples
(:meth:`prediction`). A subclass says how the mean and covariance are carried over an
interval (:meth:`NonlinearFilter.propagate`) and how a measurement corrects them
(:meth:`NonlinearFilter.correct`).

Angles: the model's angle outputs have their innovations wrapped to ``(-pi, pi]`` and its
angle states are kept in ``(-pi, pi]`` after every update and prediction.

A step whose numbers are not finite (the model left a function's domain, ``S`` is not
positive definite) is dropped: the filter keeps the estimate, covariance and stamp it had,
counts it in ``counters['nonfinite']`` and notes it in :attr:`events`; it never returns NaN.
"""

from collections import Counter
import math
from typing import Optional

import numpy as np

from observer_ros.core.angles import Angles, wrap_angles
from observer_ros.core.errors import ConfigError, StampError
from observer_ros.core.estimators.protocol import (
    Estimator, PinnedInitialState, Prediction, SubsetUpdates)
from observer_ros.core.flat_matrices import covariance_from_flat
from observer_ros.core.nonlinear.model import NonlinearModel
from observer_ros.core.observers.kalman.time_varying import parse_initial_covariance
from observer_ros.core.units import NANOSECONDS

__all__ = ['NonlinearFilter', 'DEFAULT_MAX_STEP', 'rk4', 'rk4_steps']

#: The longest integration step (s) of a continuous model's prediction by default: an
#: interval of T seconds is integrated in ceil(T / max_step) equal steps of RK4.
DEFAULT_MAX_STEP = 0.001

#: An interval is cut into ``ceil(T / max_step - SLACK)`` steps: an interval a rounding
#: above a whole number of steps takes no extra step.
SLACK = 1e-9


def rk4_steps(seconds: float, max_step: float) -> tuple:
    """
    Return ``(count, h)``: the equal RK4 steps of an interval (filters and plant alike).

    Examples
    --------
    >>> rk4_steps(0.01, 0.001)
    (10, 0.001)
    >>> rk4_steps(0.0025, 0.001)
    (3, 0.0008333333333333334)

    """
    count = max(1, math.ceil(seconds / max_step - SLACK))
    return count, seconds / count


def rk4(f, x: np.ndarray, u: np.ndarray, count: int, h: float) -> np.ndarray:
    """
    Integrate ``x' = f(x, u)`` by the classical RK4 in ``count`` steps of ``h`` seconds.

    ``x`` is one state or rows of states (the unscented filter's sigma points).

    Examples
    --------
    >>> rk4(lambda x, u: -x, np.array([1.0]), np.zeros(0), 10, 0.1).round(6).tolist()
    [0.36788]

    """
    half, sixth = 0.5 * h, h / 6.0
    for _ in range(count):
        k1 = f(x, u)
        k2 = f(x + half * k1, u)
        k3 = f(x + half * k2, u)
        k4 = f(x + h * k3, u)
        x = x + sixth * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
    return x


def finite(x: np.ndarray, p: np.ndarray) -> bool:
    """Say whether every entry of an estimate and its covariance is finite: sums first."""
    if math.isfinite(x @ x) and math.isfinite(p.sum()):
        return True
    return bool(np.isfinite(x).all() and np.isfinite(p).all())  # an overflow of the sum


def keep_in_range(x: np.ndarray, states: tuple) -> np.ndarray:
    """Wrap the angle ``states`` of ``x`` to ``(-pi, pi]`` in place (floats, no arrays)."""
    for index in states:
        value = x[index]
        if not -math.pi < value <= math.pi:
            x[index] = float(wrap_angles(value))
    return x


class NonlinearFilter(PinnedInitialState, SubsetUpdates, Estimator):
    """
    The running state of a nonlinear Kalman filter; subclasses give the two steps.

    Parameters
    ----------
    model : NonlinearModel
    process_noise : array_like, shape (n,) or (n, n)
        ``Q``: the intensity of a continuous model (``P' = F P + P F^T + Q``), the
        per-sample covariance of a discrete one; n diagonal values or n x n row-major.
    measurement_noise : array_like, shape (p,) or (p, p)
        ``R`` of every output; a source takes its block. Positive definite.
    initial_covariance : array_like, optional
        ``P0`` (default: the identity).
    initial_state : array_like, shape (n,), optional
        ``x0`` (default: zero).
    max_step : float
        Longest integration step in seconds of a continuous model's prediction.

    Raises
    ------
    ConfigError
        Naming ``model``, ``process_noise``, ``measurement_noise``, ``initial_covariance``,
        ``initial_state`` or ``max_step``.

    """

    #: The blocks of ``R`` the samples brought (:class:`~observer_ros.core.message_noise.
    #: SampleNoise`, set where a source takes its noise from its messages), or None.
    message_noise = None
    _stamp_taken = None

    def __init__(self, model: NonlinearModel, process_noise, measurement_noise,
                 initial_covariance=None, initial_state=None,
                 max_step: float = DEFAULT_MAX_STEP) -> None:
        if not isinstance(model, NonlinearModel):
            raise ConfigError('model', f'expected a NonlinearModel, got {type(model).__name__}')
        self.model = model
        self.n_states, self.n_inputs = model.n_states, model.n_inputs
        self.n_outputs = model.n_outputs
        n = self.n_states
        self.process_noise = covariance_from_flat('process_noise', np.ravel(process_noise), n)
        self.measurement_noise = covariance_from_flat(
            'measurement_noise', np.ravel(measurement_noise), self.n_outputs)
        if self.n_outputs and np.linalg.eigvalsh(self.measurement_noise).min() <= 0.0:
            raise ConfigError('measurement_noise', 'expected a positive definite matrix')
        self.initial_covariance = parse_initial_covariance(initial_covariance, n)
        if isinstance(max_step, bool) or not isinstance(max_step, (int, float)) or not (
                math.isfinite(max_step) and max_step > 0.0):
            raise ConfigError('max_step', f'expected a step > 0 s, got {max_step!r}')
        self.max_step = float(max_step)
        self._pinned = None
        self.initial_state = initial_state
        angles = Angles(model.angle_states, model.angle_outputs)
        self.angles = angles if angles else None
        self.counters: Counter = Counter()
        self.events: list = []
        self._blocks: dict = {}
        self.reset()

    # --- state -----------------------------------------------------------------------------

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
        """Last innovation ``y - h(x-)`` (angle outputs wrapped)."""
        return self._innovation.copy()

    @property
    def covariance(self) -> np.ndarray:
        """``P[k|k]``, symmetric."""
        return self._p

    @property
    def innovation_covariance(self) -> Optional[np.ndarray]:
        """``S`` of the last update (None before the first, or after a dropped one)."""
        return self._s

    @property
    def nis(self) -> Optional[float]:
        """``v^T S^-1 v`` of the last update (None before the first)."""
        return self._nis

    @property
    def last_interval_ns(self) -> int:
        """The interval of the last step in nanoseconds (0 at a first sample)."""
        return self._last_interval

    def several_sources_problem(self) -> Optional[str]:
        """None: any outputs make an update (the covariance says what they leave unseen)."""
        return None

    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """None: the filter updates with any outputs."""
        return None

    def keep_angles(self, angles) -> None:
        """
        Keep ``angles`` (:class:`~observer_ros.core.angles.Angles`) besides the model's own.

        The model declares its angles (``angle_states``, ``angle_outputs``); these are added.
        """
        if angles:
            mine = self.angles or Angles()
            self.angles = Angles(tuple(sorted(set(mine.states) | set(angles.states))),
                                 tuple(sorted(set(mine.outputs) | set(angles.outputs))))

    # --- the two steps a subclass gives ----------------------------------------------------

    def propagate(self, x: np.ndarray, p: np.ndarray, interval_ns: int,
                  u: np.ndarray) -> tuple:
        """Return ``(x, P)`` carried over ``interval_ns`` with ``u`` held (NaN: dropped)."""
        raise NotImplementedError

    def correct(self, x: np.ndarray, p: np.ndarray, y: np.ndarray, u: np.ndarray,
                outputs: tuple) -> Optional[tuple]:
        """Return ``(x, P, innovation, S, nis)`` updated with ``y`` of ``outputs``, or None."""
        raise NotImplementedError

    # --- shared helpers ----------------------------------------------------------------------

    def steps(self, interval_ns: int) -> tuple:
        """Return ``(count, h)``: the RK4 steps of an interval and their length in seconds."""
        return rk4_steps(interval_ns / NANOSECONDS, self.max_step)

    def noise_block(self, outputs: tuple) -> np.ndarray:
        """Return the block of ``R`` of ``outputs`` (cached)."""
        block = self._blocks.get(outputs)
        if block is None:
            index = list(outputs)
            block = np.ascontiguousarray(self.measurement_noise[np.ix_(index, index)])
            self._blocks[outputs] = block
        if self.message_noise is not None:  # the sample's own block, where it brought one
            return self.message_noise.block(self._stamp_taken, outputs, block)
        return block

    def wrap_outputs(self, residual: np.ndarray, outputs: tuple) -> np.ndarray:
        """Wrap the entries of the angle outputs of ``residual`` (``(q,)`` or ``(k, q)``)."""
        angles = self.angles
        if angles is None:
            return residual
        positions = angles.positions(outputs)
        if positions:
            index = list(positions)
            residual[..., index] = wrap_angles(residual[..., index])
        return residual

    def wrap_states(self, residual: np.ndarray) -> np.ndarray:
        """Wrap the entries of the angle states of ``residual`` (``(n,)`` or ``(k, n)``)."""
        angles = self.angles
        if angles is not None and angles.states:
            index = list(angles.states)
            residual[..., index] = wrap_angles(residual[..., index])
        return residual

    # --- the protocol --------------------------------------------------------------------

    def advance(self, stamp_ns: int, y: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Take a sample of every output whose values are checked already; return ``x[k|k]``."""
        return self.advance_outputs(stamp_ns, y, u, tuple(range(self.n_outputs)))

    def advance_outputs(self, stamp_ns: int, y: np.ndarray, u: np.ndarray,
                        outputs: tuple) -> np.ndarray:
        """
        Take the values ``y`` of ``outputs`` at ``stamp_ns``; return the estimate.

        The prediction over the interval since the last sample with ``u`` held, then the
        update with the rows of ``h`` and the block of ``R`` of ``outputs`` (none: the
        prediction is kept). A step that is not finite is dropped (see the module).

        Raises
        ------
        StampError
            The stamp is not after the previous sample's.

        """
        outputs = tuple(outputs)
        self._stamp_taken = stamp_ns
        if self._stamp is None:
            x_prior, p_prior, interval = self._prior_x, self._prior_p, 0
        else:
            interval = stamp_ns - self._stamp
            if interval <= 0:
                raise StampError(f'stamp {stamp_ns} ns is not after the previous sample '
                                 f'({self._stamp} ns)')
            x_prior, p_prior = self.propagate(self._x, self._p, interval, u)
        result = None
        if finite(x_prior, p_prior):
            if self.angles is not None:
                keep_in_range(x_prior, self.angles.states)
            if outputs:
                result = self.correct(x_prior, p_prior, np.asarray(y, dtype=float), u, outputs)
            else:
                result = (x_prior, p_prior, np.zeros(0), np.zeros((0, 0)), 0.0)
        if result is None or not finite(result[0], result[1]):
            return self._drop(stamp_ns, outputs)
        x, p, innovation, s, nis = result
        if self.angles is not None:
            keep_in_range(x, self.angles.states)
        self._x, self._p = x, 0.5 * (p + p.T)
        self._innovation, self._s, self._nis = innovation, s, float(nis)
        self._stamp, self._last_interval = stamp_ns, interval
        return self._x

    def _drop(self, stamp_ns: int, outputs: tuple) -> np.ndarray:
        """Keep the state as it was; count and note a step that was not finite."""
        self.counters['nonfinite'] += 1
        self.events.append(('nonfinite', f'the step to {stamp_ns} ns (outputs '
                                         f'{[self.model.output_names[i] for i in outputs]}) '
                                         f'was not finite and was dropped; the estimate of '
                                         f'{self._stamp} ns is kept'))
        self._innovation = np.zeros(len(outputs))
        self._s = self._nis = None
        return self._x

    def prediction(self, estimate: np.ndarray, covariance: Optional[np.ndarray],
                   interval_ns: int, u: np.ndarray) -> Prediction:
        """Return ``x`` and ``P`` carried over ``interval_ns`` with ``u`` (0: as given)."""
        estimate = np.array(estimate, dtype=float)
        if interval_ns <= 0:
            return Prediction(0, estimate, covariance)
        x, p = self.propagate(estimate, np.asarray(covariance, dtype=float), int(interval_ns),
                              np.asarray(u, dtype=float))
        if not finite(x, p):
            self.counters['nonfinite'] += 1
            return Prediction(0, estimate, covariance)
        if self.angles is not None:
            self.angles.keep(x)
        return Prediction(0, x, 0.5 * (p + p.T))

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
        self._s = self._nis = None
        self._stamp = None
        self._last_interval = 0

    def restart(self) -> None:
        """Forget the stamps; the next sample updates the estimate held, ``P0`` added to ``P``."""
        self._prior_x = self._x.copy()
        self._prior_p = self._p + self.initial_covariance
        self._stamp = None

    def snapshot(self) -> tuple:
        """Return the running state, for :meth:`restore`."""
        return (self._x.copy(), self._p.copy(), self._innovation.copy(), self._s, self._nis,
                self._stamp, self._prior_x.copy(), self._prior_p.copy(), self._last_interval)

    def restore(self, state: tuple) -> None:
        """Return to a state taken by :meth:`snapshot`."""
        (x, p, innovation, self._s, self._nis, self._stamp, prior_x, prior_p,
         self._last_interval) = state
        self._x, self._p, self._innovation = x.copy(), p.copy(), innovation.copy()
        self._prior_x, self._prior_p = prior_x.copy(), prior_p.copy()

    def adopt(self, other: Estimator) -> None:
        """Take the model, noises, ``P0`` and step of ``other``; keep ``x``, ``P`` and stamps."""
        if type(other) is not type(self):
            raise ValueError(f'adopt: expected a {type(self).__name__}, got '
                             f'{type(other).__name__}')
        if (other.n_states, other.n_inputs, other.n_outputs) != (
                self.n_states, self.n_inputs, self.n_outputs):
            raise ValueError('adopt: the other filter has other dimensions')
        self.model, self.angles = other.model, other.angles
        self.process_noise, self.measurement_noise = other.process_noise, other.measurement_noise
        self.initial_covariance, self.max_step = other.initial_covariance, other.max_step
        self._blocks = {}
