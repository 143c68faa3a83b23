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

With several measurement sources (:class:`~observer_ros.core.estimators.SubsetUpdates`)
an update takes the rows of ``C`` and the block of ``R`` of the outputs that arrived; with
none, the prediction is kept.

The first sample is an update of the prior ``(x0, P0)``: ``x0`` is ``initial_state`` (zero
when not given) and ``P0`` the initial covariance. At a fixed rate ``P`` and ``K`` converge to
the steady-state filter's
(:func:`~observer_ros.core.observers.kalman.design.design_sampled_kalman`).

References
----------
R. E. Kalman, "A new approach to linear filtering and prediction problems", 1960;
R. S. Bucy and P. D. Joseph, Filtering for Stochastic Processes, 1968 (the Joseph form).
"""

from typing import Optional

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs

from observer_ros.core.analysis import require_seen
from observer_ros.core.discretize import IntervalSampler
from observer_ros.core.errors import ConfigError, StampError
from observer_ros.core.estimators.intervals import IntervalCache, IntervalDesigns
from observer_ros.core.estimators.protocol import (
    Estimator, model_feedthrough, PinnedInitialState, Prediction, SubsetUpdates)
from observer_ros.core.flat_matrices import covariance_from_flat
from observer_ros.core.model import StateSpaceModel


def parse_initial_covariance(values, n_states: int) -> np.ndarray:
    """
    Return ``P0`` from ``values`` (n diagonal values or n x n row-major; empty: identity).

    Raises
    ------
    ConfigError
        ``initial_covariance``: another size, or not positive definite.

    """
    if values is None or not np.size(values):
        return np.eye(n_states)
    matrix = covariance_from_flat('initial_covariance', np.ravel(values), n_states)
    if np.linalg.eigvalsh(matrix).min() <= 0.0:
        raise ConfigError('initial_covariance', 'expected a positive definite matrix')
    return matrix


class TimeVaryingKalman(IntervalDesigns, PinnedInitialState, SubsetUpdates, Estimator):
    """
    Kalman filter whose covariance follows the actual sample intervals.

    Parameters
    ----------
    model : StateSpaceModel
        A feedthrough ``D`` is taken off each measurement first (:meth:`update` with
        ``u_now``; :func:`~observer_ros.core.estimators.protocol.without_feedthrough`).
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

    Raises
    ------
    UnobservableError
        A mode no output sees that does not decay (the one rule,
        :func:`~observer_ros.core.analysis.require_seen`): its covariance would grow
        without bound.
    ConfigError
        ``D`` not zero, ``process_noise``, ``measurement_noise`` or ``initial_covariance``
        of the wrong size or not a covariance.

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

    #: The blocks of ``R`` the samples brought (:class:`~observer_ros.core.message_noise.
    #: SampleNoise`, set where a source takes its noise from its messages), or None.
    message_noise = None

    def __init__(self, model: StateSpaceModel, process_noise, measurement_noise,
                 initial_covariance=None, initial_state=None,
                 interval_resolution_ns: int = 0) -> None:
        require_seen(model, detectable=True)  # the one rule: P would grow without bound
        self.model = model
        self.feedthrough = model_feedthrough(model)
        self.n_states, self.n_inputs = model.n_states, model.n_inputs
        self.n_outputs = model.n_outputs
        n = self.n_states
        self.process_noise = covariance_from_flat('process_noise', np.ravel(process_noise), n)
        self.measurement_noise = covariance_from_flat(
            'measurement_noise', np.ravel(measurement_noise), self.n_outputs)
        if np.linalg.eigvalsh(self.measurement_noise).min() <= 0.0:
            raise ConfigError('measurement_noise', 'expected a positive definite matrix')
        self.initial_covariance = parse_initial_covariance(initial_covariance, n)
        self._pinned = None
        self.initial_state = initial_state
        self._sampler = self._new_sampler()
        self.intervals = IntervalCache(self._sample, resolution_ns=interval_resolution_ns,
                                       constant=model.dt > 0.0)
        self._identity = np.eye(n)
        self._c_row = self.model.c[0].copy() if self.n_outputs == 1 else None
        self._r_value = float(self.measurement_noise[0, 0])
        self._rhs = np.empty((self.n_outputs, n + 1), order='F')
        self._subsets: dict = {}
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

    def _unpack_one(self) -> None:
        one = self._one
        if one is not None:
            self._one = None
            innovation, variance, k = one
            self._innovation = np.array([innovation])
            self._s = np.array([[variance]])
            self._k = k.reshape(-1, 1)

    @property
    def innovation(self) -> np.ndarray:
        """Last innovation ``y - C x-``."""
        if self._one is not None:
            self._unpack_one()
        return self._innovation.copy()

    @property
    def covariance(self) -> np.ndarray:
        """``P[k|k]``, symmetric positive definite."""
        return self._p

    @property
    def innovation_covariance(self) -> Optional[np.ndarray]:
        """``S`` of the last update (None before the first)."""
        if self._one is not None:
            self._unpack_one()
        return self._s

    @property
    def nis(self) -> Optional[float]:
        """``v^T S^-1 v`` of the last update (None before the first)."""
        return self._nis

    @property
    def gain(self) -> Optional[np.ndarray]:
        """The filter gain ``K`` of the last update, ``(n, p)``."""
        self._unpack_one()
        return self._k

    # --- the filter ----------------------------------------------------------------------

    def _new_sampler(self) -> Optional[IntervalSampler]:
        if self.model.dt > 0.0:
            return None
        return IntervalSampler(self.model.a, self.model.b, self.process_noise)

    def _sample(self, key_ns: int) -> tuple:
        """
        ``(Ad, Bd, Qd)`` of an interval: a discrete model's own (key 0), else sampled.

        A continuous model is sampled exactly (``expm``) at its first interval; another is
        composed from a step and a multiple of a grid sampled exactly
        (:class:`~observer_ros.core.discretize.IntervalSampler`: equal within a few units
        in the last place, and no ``expm`` per jittered interval).
        """
        if self._sampler is None:
            return self.model.a, self.model.b, self.process_noise
        return self._sampler.sample(key_ns)

    def _forget_intervals(self) -> None:
        self._sampler = self._new_sampler()

    def _measure(self, x_prior: np.ndarray, p_prior: np.ndarray, y: np.ndarray,
                 rows: Optional[tuple] = None) -> None:
        """Update ``(x-, P-)`` with ``y``: every output, or the ``rows`` of :meth:`_rows`."""
        if rows is None:
            c, r, c_row, r_value, rhs = (self.model.c, self.measurement_noise, self._c_row,
                                         self._r_value, self._rhs)
        else:
            c, r, c_row, r_value, rhs = rows
        if c_row is not None:
            self._measure_one(x_prior, p_prior, y, c_row, r_value)
            return
        if not len(c):
            self._predict_only(x_prior, p_prior)
            return
        n_states = self.n_states
        right = rhs if rhs is not None else np.empty((len(c), n_states + 1), order='F')
        cp = right[:, :n_states]
        np.matmul(c, p_prior, out=cp)  # C P- = (P- C^T)^T
        innovation = y - c @ x_prior
        right[:, n_states] = innovation
        s = cp @ c.T
        s += r
        # LAPACK directly (numpy's linalg wrappers cost several times the call on p x p):
        # S = L L^T (its lower triangle read), then S^-1 [C P- | v] in one solve: K^T and
        # S^-1 v for the NIS.
        factor, info = dpotrf(s, lower=1, clean=0)
        if info:
            raise np.linalg.LinAlgError(
                f'the innovation covariance S = C P- C^T + R is not positive definite '
                f'(dpotrf info {info})')
        solved, info = dpotrs(factor, right, lower=1)
        k_t = solved[:, :n_states]
        k = k_t.T  # P- C^T S^-1
        nis = innovation @ solved[:, n_states]
        # Joseph form, as in _measure_one: left = (I - K C) P-, then left (I - K C)^T
        # + K R K^T = left - (left C^T - K R) K^T.
        left = p_prior - k @ cp
        p = left - (left @ c.T - k @ r) @ k_t
        p += p.T
        p *= 0.5
        s += s.T
        s *= 0.5
        self._x = x_prior + k @ innovation
        self._p = p
        self._innovation, self._s, self._k, self._nis = innovation, s, k, float(nis)
        self._one = None

    def _measure_one(self, x_prior: np.ndarray, p_prior: np.ndarray, y: np.ndarray,
                     c: np.ndarray, r: float) -> None:
        """:meth:`_measure` for one output: the same steps on vectors, ``S`` a number."""
        pc = p_prior @ c
        variance = float(c @ pc) + r
        k = pc / variance
        innovation = float(y[0]) - float(c @ x_prior)
        outer = np.multiply.outer
        # Joseph form, as in _measure: left = (I - K C) P-, then left (I - K C)^T + K R K^T
        # = left - (left C^T - R K) K^T.
        left = p_prior - outer(k, pc)
        p = left - outer(left @ c - k * r, k)
        p += p.T
        p *= 0.5
        self._x = x_prior + k * innovation
        self._p = p
        self._one = (innovation, variance, k)  # the arrays of the properties, when read
        self._nis = innovation * innovation / variance

    def _predict_only(self, x_prior: np.ndarray, p_prior: np.ndarray) -> None:
        """Keep the prediction ``(x-, P-)``: an update with no output."""
        self._x = x_prior
        self._p = 0.5 * (p_prior + p_prior.T)
        self._innovation = np.zeros(0)
        self._s, self._k = np.zeros((0, 0)), np.zeros((self.n_states, 0))
        self._nis, self._one = 0.0, None

    def _rows(self, outputs: tuple) -> tuple:
        """
        ``(C_s, R_s, c_row, r_value, rhs)`` of some outputs (cached): the rows of C and R.

        ``rhs``: the work array of the solve, ``(p_s, n + 1)`` Fortran-ordered.
        """
        rows = self._subsets.get(outputs)
        if rows is None:
            index = list(outputs)
            c = np.ascontiguousarray(self.model.c[index])
            r = np.ascontiguousarray(self.measurement_noise[np.ix_(index, index)])
            one = len(index) == 1
            rows = (c, r, c[0].copy() if one else None, float(r[0, 0]) if one else 0.0,
                    np.empty((len(index), self.n_states + 1), order='F'))
            self._subsets[outputs] = rows
        return rows

    def _noise_rows(self, stamp_ns: int, outputs: tuple) -> tuple:
        """:meth:`_rows` of ``outputs`` with the ``R`` the sample at ``stamp_ns`` brought."""
        c, r, c_row, _, rhs = self._rows(outputs)
        r = self.message_noise.block(stamp_ns, outputs, r)
        return c, r, c_row, float(r[0, 0]), rhs

    def advance(self, stamp_ns: int, y: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Take a sample whose values are checked already; return ``x[k|k]``."""
        x_prior, p_prior = self._prior(stamp_ns, u)
        angles = self.angles
        rows = None
        if self.message_noise is not None and self.message_noise.has(stamp_ns):
            rows = self._noise_rows(stamp_ns, tuple(range(self.n_outputs)))
        if angles is None:
            self._measure(x_prior, p_prior, y, rows)
        else:  # y moved by whole turns to the predicted branch: the innovation is wrapped
            self._measure(x_prior, p_prior, angles.near(y, self.model.c @ x_prior), rows)
            self._x = angles.keep(np.array(self._x, dtype=float))
        self._stamp = stamp_ns
        return self._x

    def keep_angles(self, angles) -> None:
        """
        Wrap the innovations of angle outputs and keep angle states in ``(-pi, pi]``.

        Each update moves an angle output by whole turns to the branch of its prediction
        ``C x-`` (the innovation is then wrapped) and wraps the angle states of ``x[k|k]``;
        predictions wrap them too. ``P`` is unchanged by a whole turn.
        """
        self.angles = angles if angles else None

    def _prior(self, stamp_ns: int, u: np.ndarray) -> tuple:
        """``(x-, P-)`` at ``stamp_ns``: the prior, or the estimate predicted over the interval."""
        if self._stamp is None:
            self._last_interval = 0
            return self._prior_x, self._prior_p
        dt_ns = stamp_ns - self._stamp
        if dt_ns <= 0:
            raise StampError(f'stamp {stamp_ns} ns is not after the previous sample '
                             f'({self._stamp} ns)')
        intervals = self.intervals
        ad, bd, qd = (intervals.last if dt_ns == intervals.last_dt_ns
                      else intervals.get(dt_ns))
        p_prior = ad @ self._p @ ad.T
        p_prior += qd
        self._last_interval = dt_ns
        return ad @ self._x + bd @ u, p_prior

    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """None: the filter updates with any rows of ``C`` (its covariance says the rest)."""
        return None

    def advance_outputs(self, stamp_ns: int, y: np.ndarray, u: np.ndarray,
                        outputs: tuple) -> np.ndarray:
        """
        Take the values ``y`` of ``outputs``: the update with those rows of ``C`` and ``R``.

        Every output: :meth:`advance`; none: the prediction ``(x-, P-)`` is kept.
        """
        if len(outputs) == self.n_outputs:
            return self.advance(stamp_ns, y, u)
        x_prior, p_prior = self._prior(stamp_ns, u)
        rows = self._rows(outputs)
        if self.message_noise is not None and self.message_noise.has(stamp_ns):
            rows = self._noise_rows(stamp_ns, outputs)
        angles = self.angles
        if angles is None:
            self._measure(x_prior, p_prior, y, rows)
        else:
            self._measure(x_prior, p_prior, angles.near(y, rows[0] @ x_prior, outputs), rows)
            self._x = angles.keep(np.array(self._x, dtype=float))
        self._stamp = stamp_ns
        return self._x

    def prediction(self, estimate: np.ndarray, covariance: Optional[np.ndarray],
                   interval_ns: int, u: np.ndarray) -> Prediction:
        """Return ``x`` and ``P`` carried over ``interval_ns`` with ``u`` (0: unchanged)."""
        if interval_ns <= 0:
            return Prediction(0, np.array(estimate, dtype=float), covariance)
        ad, bd, qd = self.intervals.peek(interval_ns)
        p = ad @ covariance @ ad.T + qd
        predicted = ad @ estimate + bd @ np.asarray(u, dtype=float)
        if self.angles is not None:
            self.angles.keep(predicted)
        return Prediction(0, predicted, 0.5 * (p + p.T))

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
        self._s = self._k = self._nis = self._one = None
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
        """
        Return the running state, for :meth:`restore`.

        The innovation is kept as it is (the filter replaces it, never changes it, and hands
        out copies); the prior ``(x0, P0)`` only where the next sample starts from it (no
        stamp yet): after a first sample it is not read until a reset or a restart sets it.
        """
        if self._one is not None:
            self._unpack_one()
        stamp = self._stamp
        if stamp is not None:
            return (self._x.copy(), self._p.copy(), self._innovation, self._s, self._k,
                    self._nis, stamp, None, None)
        return (self._x.copy(), self._p.copy(), self._innovation, self._s, self._k,
                self._nis, stamp, self._prior_x.copy(), self._prior_p.copy())

    def restore(self, state: tuple) -> None:
        """Return to a state taken by :meth:`snapshot`."""
        (x, p, innovation, self._s, self._k, self._nis, self._stamp, prior_x,
         prior_p) = state
        self._x, self._p, self._innovation = x.copy(), p.copy(), innovation.copy()
        self._one = None
        if prior_x is not None:  # else the prior is not read before a reset or restart
            self._prior_x, self._prior_p = prior_x.copy(), prior_p.copy()

    def adopt(self, other: Estimator) -> None:
        """Take the noises, ``P0`` and resolution of ``other``; keep ``x``, ``P`` and stamps."""
        if not isinstance(other, TimeVaryingKalman):
            raise ValueError(f'adopt: expected a TimeVaryingKalman, got {type(other).__name__}')
        if (other.n_states, other.n_inputs, other.n_outputs) != (
                self.n_states, self.n_inputs, self.n_outputs):
            raise ValueError('adopt: the other filter has other dimensions')
        self.model = other.model
        self.feedthrough = other.feedthrough
        self.process_noise, self.measurement_noise = other.process_noise, other.measurement_noise
        self._c_row, self._r_value = other._c_row, other._r_value
        self._rhs = np.empty_like(other._rhs, order='F')
        self._subsets = {}
        self.initial_covariance = other.initial_covariance
        self._sampler = self._new_sampler()
        self.intervals.clear(recent=False)
        self.interval_resolution_ns = other.interval_resolution_ns
