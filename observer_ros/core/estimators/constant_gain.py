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
The constant-gain estimator: one matrix per sample interval, shared by the step designs.

Each observer type that reuses it is a *step design*: for a sample interval it returns one
matrix ``G`` with ``[x_hat_new; innovation] = G [x_hat_prev; u; y]``, where ``u`` is the
input held over the interval and ``y`` the measurement at its end.
:class:`ConstantGainEstimator` owns the state, the stamps and a cache of those matrices
keyed by the interval in integer nanoseconds (:class:`~.intervals.IntervalCache`), so a
steady rate costs one matrix-vector product per update and jittered stamps stay exact. For a
continuous model the poles are placed again for each new interval (:meth:`StepDesign.step`).
"""

from typing import Optional

import numpy as np

from observer_ros.core.errors import StampError
from observer_ros.core.estimators.constant_gain_steady import ConstantGainSteady
from observer_ros.core.estimators.constant_gain_subsets import ConstantGainSubsets
from observer_ros.core.estimators.intervals import (
    DEFAULT_CACHE_SIZE, IntervalCache, IntervalDesigns)
from observer_ros.core.estimators.protocol import (
    Estimator, model_feedthrough, PinnedInitialState, Prediction)
from observer_ros.core.estimators.steps import (
    assemble_step, least_norm_consistent, output_term, outputs_model, place_sampled,
    PredictOnlyStep, StepDesign, StepMatrices)

__all__ = ['ConstantGainEstimator', 'PREDICTION_CACHE', 'PredictOnlyStep', 'StepDesign',
           'StepMatrices', 'assemble_step', 'least_norm_consistent', 'output_term',
           'outputs_model', 'place_sampled']

#: Prediction intervals whose transition matrices are kept (:meth:`Estimator.predict`).
PREDICTION_CACHE = 64


class ConstantGainEstimator(IntervalDesigns, PinnedInitialState, ConstantGainSteady,
                            ConstantGainSubsets, Estimator):
    """
    The constant-gain estimator: one matrix ``G`` per sample interval, cached by interval.

    Parameters
    ----------
    design : StepDesign
        Produces the step matrices of each interval.
    initial_state : array_like, shape (n,), optional
        Pins the estimate at the first sample (reduced-order and Chen observers move it to
        the nearest point that agrees with ``y``). None (the default): the first
        measurement initialises the estimate, ``x_hat = C^+ y`` (the least-norm state that
        reproduces it).
    cache_size : int
        Distinct intervals kept (least recently used dropped).
    interval_resolution_ns : int
        Round every interval to a multiple of this many nanoseconds (at least one multiple)
        before its step matrices are looked up or designed; 0 keeps intervals exact. With
        jittered stamps and a continuous model it bounds the number of designs.

    Notes
    -----
    :meth:`update` takes the measurement ``y`` at ``stamp_ns`` and the input ``u`` held over
    the interval since the previous sample (with a feedthrough ``D``, also the input
    ``u_now`` in effect at ``stamp_ns``; :meth:`advance` and the fast paths take
    ``y - D u_now``: :func:`~.protocol.without_feedthrough`). The first update (and the
    first after a :meth:`restart`) initialises the estimate from ``y`` as described for
    ``initial_state``; its innovation is ``y - C x_prior`` with the prior the pinned initial
    state, zero, or (after a restart) the estimate held.


    Examples
    --------
    >>> from observer_ros.core import design_full_order, make_estimator, StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> estimator = make_estimator(design_full_order(model, poles=[-4, -5]))
    >>> estimator.update(0, [1.0], [0.0]).tolist()  # the first measurement starts it
    [1.0, 0.0]
    >>> x = estimator.update(10_000_000, [1.0], [0.0])  # 10 ms later
    >>> estimator.last_interval_ns
    10000000

    """

    def __init__(self, design: StepDesign, initial_state=None,
                 cache_size: int = DEFAULT_CACHE_SIZE, interval_resolution_ns: int = 0) -> None:
        self._fresh: Optional[list] = None  # see advance_prepared
        self.design = design
        model = design.model
        self.n_states, self.n_inputs = model.n_states, model.n_inputs
        self.n_outputs = model.n_outputs
        self.feedthrough = model_feedthrough(model)
        self._pinned: Optional[np.ndarray] = None
        self.initial_state = initial_state
        self.intervals = IntervalCache(self._design_step, cache_size, interval_resolution_ns)
        self._transitions = IntervalCache(self._transition, PREDICTION_CACHE)
        self._stamp: Optional[int] = None
        self._start, self._start_pinned = self._initial_prior()
        self._x = self._start.copy()
        self._innovation = np.zeros(self.n_outputs)
        self._step: Optional[StepMatrices] = None
        self._buffer = np.zeros(self.n_states + self.n_inputs)
        self._prepared: Optional[tuple] = None
        self._result: Optional[np.ndarray] = None
        self._subsets: dict = {}  # outputs -> (step design, interval cache) of a subset
        self._subset_step: Optional[tuple] = None  # (step, interval) of the last subset update

    # The state, the innovation and the last step's [x; innovation]. A prepared step
    # (advance_prepared) leaves them as a list of floats; they become arrays when first read,
    # which keeps array building out of the time between a measurement and its estimate.

    def _materialize(self) -> None:
        fresh = self._fresh
        if fresh is not None:
            self._fresh = None
            array = np.array(fresh)
            n = self.n_states
            self.__dict__.update(_x_array=array[:n], _innovation_array=array[n:],
                                 _result_array=array)

    @property
    def _x(self) -> np.ndarray:
        self._materialize()
        return self._x_array

    @_x.setter
    def _x(self, value) -> None:
        self._materialize()
        self._x_array = value

    @property
    def _innovation(self) -> np.ndarray:
        self._materialize()
        return self._innovation_array

    @_innovation.setter
    def _innovation(self, value) -> None:
        self._materialize()
        self._innovation_array = value

    @property
    def _result(self) -> Optional[np.ndarray]:
        self._materialize()
        return self._result_array

    @_result.setter
    def _result(self, value) -> None:
        self._materialize()
        self._result_array = value

    def _initial_prior(self) -> tuple:
        if self._pinned is None:
            return np.zeros(self.n_states), False
        return self._pinned.copy(), True

    @property
    def estimate(self) -> np.ndarray:
        """Current estimate ``x_hat`` (a copy)."""
        return self._x.copy()

    @property
    def innovation(self) -> np.ndarray:
        """Last innovation ``y - C x_hat_prior`` (zero before the second sample)."""
        return self._innovation.copy()

    @property
    def result(self) -> Optional[np.ndarray]:
        """``[x_hat; innovation]`` of the last step (not a copy: never modified), or None."""
        return self._result

    @property
    def stamp_ns(self) -> Optional[int]:
        """Stamp of the last accepted sample, None before the first one."""
        return self._stamp

    @property
    def covariance(self) -> Optional[np.ndarray]:
        """Kalman filters: covariance of the estimate after the last update."""
        return None if self._step is None else self._step.covariance

    @property
    def innovation_covariance(self) -> Optional[np.ndarray]:
        """Kalman filters: covariance ``S`` of the last innovation (None before a step)."""
        return None if self._step is None else self._step.innovation_covariance

    def prediction(self, estimate: np.ndarray, covariance: Optional[np.ndarray],
                   interval_ns: int, u: np.ndarray) -> Prediction:
        """
        Return ``estimate`` (and ``covariance``) carried over ``interval_ns`` with ``u``.

        ``x = Ad x + Bd u`` (and, for a Kalman filter, ``P = Ad P Ad^T + Qd``), with the
        sampled model of that interval (cached); an interval of 0 changes nothing.
        """
        if interval_ns <= 0:
            return Prediction(0, np.array(estimate, dtype=float), covariance)
        ad, bd, qd = self._transitions.peek(interval_ns)
        predicted = ad @ estimate + bd @ np.asarray(u, dtype=float)
        if self.angles is not None:
            self.angles.keep(predicted)
        if covariance is not None and qd is not None:
            covariance = ad @ covariance @ ad.T + qd
            covariance = 0.5 * (covariance + covariance.T)
        return Prediction(0, predicted, covariance)

    def _design_step(self, interval_ns: int) -> StepMatrices:
        return self.design.step(interval_ns)

    def _transition(self, interval_ns: int) -> tuple:
        return self.design.transition(interval_ns)

    @property
    def last_interval_ns(self) -> int:
        """The interval of the last step in nanoseconds (0 at a first sample)."""
        last = self.intervals.last_dt_ns
        subset = self._subset_step
        if subset is not None and self._step is subset[0]:
            return subset[1]
        return 0 if self._step is None or last is None else last

    def adopt(self, other: Estimator) -> None:
        """Take the step design of ``other`` (a constant-gain estimator); keep the state."""
        if not isinstance(other, ConstantGainEstimator):
            raise ValueError(f'adopt: expected a ConstantGainEstimator, got '
                             f'{type(other).__name__}')
        self.replace_design(other.design)
        self.interval_resolution_ns = other.interval_resolution_ns

    @property
    def last_step(self) -> Optional[StepMatrices]:
        """Step matrices used by the last update."""
        return self._step

    def _forget_intervals(self) -> None:
        """Drop the prepared step and the subsets' steps of the old rounding."""
        self._prepared = None
        self._subsets = {}

    def step_matrices(self, dt_ns: int) -> StepMatrices:
        """Return the (cached) step matrices for an interval in nanoseconds."""
        return self.intervals.get(dt_ns)

    def advance(self, stamp_ns: int, y: np.ndarray, u: np.ndarray) -> np.ndarray:
        """
        Update with inputs already checked: float arrays of the right size, finite.

        The one place where an estimate is computed; batch replays call it directly after
        checking whole arrays at once.
        """
        if self._stamp is None:
            return self._start_at(stamp_ns, y, self.design)
        dt_ns = stamp_ns - self._stamp
        if dt_ns <= 0:
            raise StampError(
                f'stamp {stamp_ns} ns is not after the previous sample ({self._stamp} ns)')
        intervals = self.intervals
        step = intervals.last if dt_ns == intervals.last_dt_ns else intervals.get(dt_ns)
        n = self.n_states
        prepared = self._prepared
        if (prepared is not None and prepared[0] is self._x and prepared[1] is u
                and prepared[2] is step):
            known = prepared[3]
        else:
            known = self._known_part(step, u)
        self._prepared = None
        angles = self.angles
        if angles is None:
            result = known + output_term(step, y)
        else:  # y moved by whole turns to the predicted branch (-known[n:] is C x_prior)
            result = known + output_term(step, angles.near(y, -known[n:]))
            angles.keep(result[:n])
        self._result = result
        self._x = result[:n]
        self._innovation = result[n:]
        self._stamp = stamp_ns
        self._step = step
        return self._x

    def _start_at(self, stamp_ns: int, y: np.ndarray, design: StepDesign) -> np.ndarray:
        """
        Start the estimate at a first sample (of ``design``'s outputs).

        Pinned: as the design makes it; unpinned: the point nearest the prior that gives
        ``y`` (the prior itself when there is no output).
        """
        prior = self._start
        c = design.model.c
        angles = self.angles
        if angles is not None:
            y = angles.near(y, c @ prior, self._subset_outputs(design))
        if self._start_pinned or not len(c):
            self._x = design.initial_estimate(prior, y)
        else:
            self._x = least_norm_consistent(c, prior, y)
        if angles is not None:
            self._x = angles.keep(np.array(self._x, dtype=float))
        self._innovation = y - c @ prior
        self._result = None
        self._stamp = stamp_ns
        return self._x

    def _known_part(self, step: StepMatrices, u: np.ndarray) -> np.ndarray:
        buffer = self._buffer
        n = self.n_states
        buffer[:n] = self._x
        buffer[n:] = u
        return step.g_known @ buffer

    def keep_angles(self, angles) -> None:
        """
        Wrap the innovations of angle outputs and keep angle states in ``(-pi, pi]``.

        Each update moves an angle output by whole turns to the branch of its prediction
        ``C x_prior`` (so its innovation is wrapped) and wraps the angle states of the new
        estimate; predictions wrap them too. Any constant-gain observer may: a model that
        :func:`~observer_ros.core.angles.check_angles` accepts is unchanged by a whole turn
        of an angle state, and the observer, exact for consistent data, follows it.
        The steady fast paths are then left for the general one.
        """
        self.angles = angles if angles else None
        self._prepared = None

    def reset(self, initial_state=None) -> None:
        """
        Forget the stamps and start again as configured.

        ``initial_state`` (n values) pins a new initial estimate first; without it the
        configured one (or, unpinned, the next measurement) starts the estimate.
        """
        if initial_state is not None:
            self.initial_state = initial_state
        self._start, self._start_pinned = self._initial_prior()
        self._x = self._start.copy()
        self._innovation = np.zeros(self.n_outputs)
        self._result = None
        self._stamp = None
        self._step = None

    def restart(self) -> None:
        """
        Forget the stamps; the next sample starts from the current estimate.

        The next measurement moves the estimate held to the nearest state that agrees with
        it (the interval is unknown, so nothing is propagated).
        """
        self._start, self._start_pinned = self._x.copy(), False
        self._stamp = None
        self._step = None

    def snapshot(self) -> tuple:
        """Return the estimator's running state, for :meth:`restore`."""
        return (self._x.copy(), self._innovation.copy(), self._stamp, self._step,
                self._start.copy(), self._start_pinned)

    def restore(self, state: tuple) -> None:
        """Return to a state taken by :meth:`snapshot` (the design and cache are kept)."""
        x, innovation, self._stamp, self._step, start, self._start_pinned = state
        self._x, self._innovation, self._start = x.copy(), innovation.copy(), start.copy()
        self._result = self._prepared = None

    def replace_design(self, design: StepDesign) -> None:
        """Switch to new gains keeping the estimate and stamps (no jump in ``x_hat``)."""
        if (design.model.n_states, design.model.n_inputs, design.model.n_outputs) != (
                self.n_states, self.n_inputs, self.n_outputs):
            raise ValueError('replace_design: the new design has other dimensions')
        self.design = design
        self.feedthrough = model_feedthrough(design.model)
        self.intervals.clear(recent=False)
        self._transitions.clear()
        self._prepared = None
        self._subsets = {}
