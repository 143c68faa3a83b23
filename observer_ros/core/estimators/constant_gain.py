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

import copy
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from observer_ros.core.analysis import observability_problem
from observer_ros.core.discretize import transition, zero_order_hold
from observer_ros.core.errors import DesignError, StampError
from observer_ros.core.estimators.intervals import (
    DEFAULT_CACHE_SIZE, IntervalCache, IntervalDesigns)
from observer_ros.core.estimators.protocol import (
    Estimator, model_feedthrough, PinnedInitialState, Prediction, SteadySteps, SubsetUpdates)
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement import place_observer
from observer_ros.core.poles import to_discrete
from observer_ros.core.units import NANOSECONDS

#: Prediction intervals whose transition matrices are kept (:meth:`Estimator.predict`).
PREDICTION_CACHE = 64


@dataclass(frozen=True)
class StepMatrices:
    """
    One sample interval of an estimator.

    Attributes
    ----------
    g : numpy.ndarray, shape (n + p, n + m + p)
        ``[x_hat_new; innovation] = g @ [x_hat_prev; u; y]``; the innovation is
        ``y - C x_hat_prior`` with the prediction ``x_hat_prior = Ad x_hat_prev + Bd u``.
        The estimators evaluate it as ``g_known @ [x_hat_prev; u] + g_y @ y`` (see
        :func:`output_term`), so that the first product can be made before ``y`` arrives.
    g_known, g_y : numpy.ndarray, shapes (n + p, n + m) and (n + p, p)
        The columns of ``g`` for ``[x_hat_prev; u]`` and for ``y`` (made from ``g``).
    error : numpy.ndarray, shape (n, n)
        Designed error dynamics ``e_new = error @ e_prev`` (``e = x - x_hat``).
    poles : numpy.ndarray of complex
        Designed discrete poles of the interval.
    covariance : numpy.ndarray or None, shape (n, n)
        Kalman only: covariance of ``x_hat`` after the update.
    ad, bd : numpy.ndarray or None, shapes (n, n) and (n, m)
        The sampled plant of the interval.
    innovation_covariance : numpy.ndarray or None, shape (p, p)
        Kalman only: ``S = C P_prior C^T + R``.

    """

    g: np.ndarray
    error: np.ndarray
    poles: np.ndarray
    covariance: Optional[np.ndarray] = None
    ad: Optional[np.ndarray] = None
    bd: Optional[np.ndarray] = None
    innovation_covariance: Optional[np.ndarray] = None
    g_known: np.ndarray = field(init=False, repr=False)
    g_y: np.ndarray = field(init=False, repr=False)
    g_y_column: Optional[np.ndarray] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        split = self.g.shape[1] - (self.g.shape[0] - self.error.shape[0])
        g_y = np.ascontiguousarray(self.g[:, split:])
        object.__setattr__(self, 'g_known', np.ascontiguousarray(self.g[:, :split]))
        object.__setattr__(self, 'g_y', g_y)
        object.__setattr__(self, 'g_y_column',
                           np.ascontiguousarray(g_y[:, 0]) if g_y.shape[1] == 1 else None)


def output_term(step: StepMatrices, y: np.ndarray) -> np.ndarray:
    """
    Return ``g_y @ y``, the measurement's part of a step, the same way on every path.

    With one output it is an elementwise product (no sum, so exact whatever computes it);
    the batch replay forms it for many samples at once and stays equal bit for bit.
    """
    column = step.g_y_column
    if column is not None:
        return column * y[0]
    return step.g_y @ y


def assemble_step(error: np.ndarray, input_gain: np.ndarray, output_gain: np.ndarray,
                  c: np.ndarray, ad: np.ndarray, bd: np.ndarray, poles: np.ndarray,
                  covariance: Optional[np.ndarray] = None,
                  innovation_covariance: Optional[np.ndarray] = None) -> StepMatrices:
    """Stack ``x_hat_new = error x + input_gain u + output_gain y`` with the innovation rows."""
    n_outputs = c.shape[0]
    top = np.hstack([error, input_gain, output_gain])
    bottom = np.hstack([-c @ ad, -c @ bd, np.eye(n_outputs)])
    return StepMatrices(g=np.ascontiguousarray(np.vstack([top, bottom])), error=error,
                        poles=poles, covariance=covariance, ad=ad, bd=bd,
                        innovation_covariance=innovation_covariance)


class StepDesign:
    """
    Base of the per-type step designs: turns a sample interval into :class:`StepMatrices`.

    Subclasses implement :meth:`design_step` for ``(Ad, Bd, discrete poles)``; this base
    discretizes continuous models exactly (zero-order hold) and maps the continuous poles
    to ``exp(lambda dt)``.
    """

    kind = 'base'

    def __init__(self, model: StateSpaceModel) -> None:
        self.model = model

    def step(self, dt_ns: int) -> StepMatrices:
        """Step matrices for an interval of ``dt_ns`` nanoseconds (ignored if discrete)."""
        model = self.model
        if model.is_discrete:
            return self.design_step(model.a, model.b, 0.0)
        dt = dt_ns / NANOSECONDS
        ad, bd = zero_order_hold(model.a, model.b, dt)
        return self.design_step(ad, bd, dt)

    def design_step(self, ad: np.ndarray, bd: np.ndarray, dt: float) -> StepMatrices:
        """
        Step matrices for the sampled plant ``(Ad, Bd)``.

        ``dt`` is the interval in seconds for a sampled continuous model, 0 for a discrete
        model (whose poles are already z-plane).
        """
        raise NotImplementedError

    #: Process noise for predicting a covariance (Kalman designs set it).
    process_noise: Optional[np.ndarray] = None

    def transition(self, dt_ns: int) -> tuple:
        """Return ``(Ad, Bd, Qd or None)`` over ``dt_ns`` (see :func:`~.discretize.transition`)."""
        return transition(self.model, dt_ns / NANOSECONDS, self.process_noise)

    def discrete_poles(self, continuous_or_discrete: np.ndarray, dt: float) -> np.ndarray:
        """``exp(lambda dt)`` for a sampled continuous model, the poles as given otherwise."""
        if self.model.is_discrete:
            return continuous_or_discrete
        return to_discrete(continuous_or_discrete, dt)

    def initial_estimate(self, initial_state: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Estimate at the first sample; reduced observers make it agree with ``y``."""
        return initial_state.copy()

    def several_sources_problem(self) -> Optional[str]:
        """
        Say why this design takes no several sources (None: it does).

        The base answer: the observer is built on every output (the reduced-order types
        are), so each update needs them all. A type that designs per subset of outputs
        overrides this, :meth:`subset_problem` and :meth:`for_outputs`.
        """
        return ('this observer needs every output at each update (it is built on all of '
                'them); it takes one measurement source with every output')

    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """Say why a step from ``outputs`` alone cannot be designed (None: it can)."""
        return self.several_sources_problem()

    def for_outputs(self, outputs: tuple) -> 'StepDesign':
        """
        Return the step design of an update with ``outputs`` alone (ascending indices).

        A copy of this design for the model with those rows of ``C`` (a type with more
        per-output data, a noise block, extends it).

        Raises
        ------
        DesignError
            What :meth:`subset_problem` says.

        """
        problem = self.subset_problem(outputs)
        if problem is not None:
            raise DesignError(problem)
        subset = copy.copy(self)
        subset.model = outputs_model(self.model, outputs)
        return subset

    def observability_problem(self, outputs: tuple, detectable: bool,
                              consequence: str) -> Optional[str]:
        """
        Say which modes ``outputs`` alone cannot see (None: none), by the one rule.

        :func:`observer_ros.core.analysis.observability_problem` for these rows of ``C``;
        ``detectable``: only the modes that do not decay count (a Kalman filter).
        """
        model = self.model
        return observability_problem(
            model.a, model.c[list(outputs)], detectable=detectable,
            discrete=model.is_discrete, state_names=model.state_names or None,
            what='(A, C) of these outputs', seen_from='them', consequence=consequence)


def outputs_model(model: StateSpaceModel, outputs: tuple) -> StateSpaceModel:
    """Return ``model`` with the rows of ``C`` and ``D`` (and names) of ``outputs`` only."""
    index = list(outputs)
    rows = len(index)
    return replace(model, c=np.ascontiguousarray(model.c[index]).reshape(rows, model.n_states),
                   d=np.ascontiguousarray(model.d[index]).reshape(rows, model.n_inputs),
                   output_names=tuple(model.output_names[k] for k in index)
                   if model.output_names else ())


class PredictOnlyStep(StepDesign):
    """
    The step of an update with no output: ``x_hat = Ad x_hat + Bd u`` (a predict-only source).

    For a Kalman design the step reports the nominal covariance ``Ad P Ad^T + Qd`` carried
    from the steady filtered ``P`` of the design with every output.
    """

    kind = 'predict_only'

    def __init__(self, base: StepDesign) -> None:
        super().__init__(outputs_model(base.model, ()))
        self.base = base
        self.process_noise = base.process_noise

    def design_step(self, ad, bd, dt) -> StepMatrices:
        """Assemble the prediction (no gain; the error dynamics are the plant's)."""
        n = ad.shape[0]
        covariance = None
        if self.process_noise is not None:
            full = self.base.design_step(ad, bd, dt)
            if full.covariance is not None:
                model = self.base.model
                qd = transition(model, dt if dt else model.dt, self.process_noise)[2]
                covariance = ad @ full.covariance @ ad.T + qd
                covariance = 0.5 * (covariance + covariance.T)
        return assemble_step(ad, bd, np.zeros((n, 0)), self.model.c, ad, bd,
                             np.linalg.eigvals(ad), covariance, np.zeros((0, 0)))


def place_sampled(a: np.ndarray, c: np.ndarray, poles: np.ndarray, method: str):
    """
    Return a verified observer gain for one sampled interval (:func:`place_observer`).

    Sampling can make distinct continuous poles coincide (fast poles all map to
    ``exp(lambda dt) = 0``), which a method such as ``'place'`` refuses; the interval is
    then placed with ``'auto'``, which picks a method that takes repeated poles. The
    result is verified either way.
    """
    try:
        return place_observer(a, c, poles, method)
    except DesignError:
        if method == 'auto':
            raise
        return place_observer(a, c, poles, 'auto')


def least_norm_consistent(c: np.ndarray, initial_state: np.ndarray, y: np.ndarray):
    """``x0 + C^+ (y - C x0)``: the point nearest ``x0`` whose output is ``y``."""
    correction = np.linalg.lstsq(c, y - c @ initial_state, rcond=None)[0]
    return initial_state + correction


class ConstantGainEstimator(IntervalDesigns, PinnedInitialState, SteadySteps, SubsetUpdates,
                            Estimator):
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

    def _subset_outputs(self, design: StepDesign) -> Optional[tuple]:
        """Return the outputs of a subset's design (None: every output)."""
        for outputs, (subset, _) in self._subsets.items():
            if subset is design:
                return outputs
        return None

    def several_sources_problem(self) -> Optional[str]:
        """Say why the step design takes no several sources (None: it does)."""
        return self.design.several_sources_problem()

    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """Say why ``outputs`` alone cannot be updated with: the step design's answer."""
        if len(outputs) == self.n_outputs:
            return None
        problem = self.design.several_sources_problem()
        if problem is not None or not outputs:
            return problem
        return self.design.subset_problem(tuple(outputs))

    def _subset(self, outputs: tuple) -> tuple:
        """``(step design, interval cache)`` of an update with ``outputs`` (made on first use)."""
        subset = self._subsets.get(outputs)
        if subset is None:
            design = (PredictOnlyStep(self.design) if not outputs
                      else self.design.for_outputs(outputs))
            subset = (design, IntervalCache(design.step, self.intervals.size,
                                            self.intervals.resolution_ns))
            self._subsets[outputs] = subset
        return subset

    def advance_outputs(self, stamp_ns: int, y: np.ndarray, u: np.ndarray,
                        outputs: tuple) -> np.ndarray:
        """
        Take the values ``y`` of ``outputs``: the step designed for those outputs alone.

        Each subset of outputs has its own step design (:meth:`StepDesign.for_outputs`: a
        gain placed, or a Riccati equation solved, for those rows of ``C``), made on first
        use and cached per interval like the one of every output. Every output:
        :meth:`advance`; none: the prediction.
        """
        if len(outputs) == self.n_outputs:
            return self.advance(stamp_ns, y, u)
        design, cache = self._subset(outputs)
        self._prepared = None
        if self._stamp is None:
            return self._start_at(stamp_ns, y, design)
        dt_ns = stamp_ns - self._stamp
        if dt_ns <= 0:
            raise StampError(
                f'stamp {stamp_ns} ns is not after the previous sample ({self._stamp} ns)')
        step = cache.get(dt_ns)
        n = self.n_states
        known = self._known_part(step, u)
        angles = self.angles
        if angles is None:
            result = known + output_term(step, y)
        else:
            result = known + output_term(step, angles.near(y, -known[n:], outputs))
            angles.keep(result[:n])
        self._result = result
        self._x = result[:n]
        self._innovation = result[n:]
        self._stamp = stamp_ns
        self._step = step
        self._subset_step = (step, dt_ns)
        return self._x

    def prepare(self, u: np.ndarray, limits: Optional[tuple] = None) -> None:
        """
        Make the next step's product with the estimate and the input ``u`` now.

        For an input known before the measurement that ends its interval: the next
        :meth:`advance` with this ``u`` (the same array) over an interval of the last
        length only adds the measurement's part. The result is the same either way.
        ``limits``, ``(largest |y|, largest |result entry|)``, lets
        :meth:`advance_prepared` say whether every ``y`` within the first keeps the result
        within the second.
        """
        step = self.intervals.last
        if self._stamp is None or step is None or self.angles is not None:
            return
        prepared = self._prepared
        if prepared is not None and prepared[0] is self._x and prepared[1] is u:
            return
        known = self._known_part(step, u)
        floats, bounded = None, False
        if self.n_outputs == 1:  # for advance_prepared: the same sums on Python floats
            floats = (known.tolist(), step.g_y_column.tolist())
            if limits is not None:
                reach = np.abs(known) + np.abs(step.g_y_column) * limits[0]
                bounded = bool(np.isfinite(reach).all() and reach.max() <= limits[1])
        self._prepared = (self._x, u, step, known, self.intervals.last_dt_ns, floats, bounded)

    def advance_prepared(self, stamp_ns: int, y: float, u: np.ndarray) -> Optional[tuple]:
        """
        Return ``([x_hat..., innovation...], bounded)`` of a prepared step, or None.

        The steady case of :meth:`advance` for one output: :meth:`prepare` was called with
        this ``u`` (the same array) and the interval has the last length. The numbers, as
        Python floats, are those :meth:`advance` gives (the same products and sums).
        ``bounded``: the result is known to lie within the limits given to :meth:`prepare`
        for any ``y`` within them. None when the steady case does not hold; the estimator
        is then untouched.
        """
        prepared = self._prepared
        if (self.angles is not None or prepared is None or prepared[5] is None
                or prepared[0] is not self._x
                or prepared[1] is not u or stamp_ns - self._stamp != prepared[4]
                or prepared[2] is not self.intervals.last):
            return None
        known, g_y = prepared[5]
        result = [k + g * y for k, g in zip(known, g_y)]  # known + output_term(step, [y])
        self._fresh = result  # x, innovation and result, as arrays when read
        self._stamp, self._step, self._prepared = stamp_ns, prepared[2], None
        return result, prepared[6]

    def advance_many(self, stamps_ns: np.ndarray, outputs: np.ndarray,
                     inputs: np.ndarray) -> tuple:
        """
        Run :meth:`advance` over increasing stamps at once; equal to it bit for bit.

        Row ``k`` of ``inputs`` is held from sample ``k-1`` to ``k``; every row must be
        checked already (finite, right sizes) and the stamps must increase. The products are
        the same matrix-vector products as :meth:`advance` (written into preallocated rows
        instead of new arrays), so the results are identical.

        Returns
        -------
        estimates : numpy.ndarray, shape (samples, n)
        innovations : numpy.ndarray, shape (samples, p)

        """
        count = len(stamps_ns)
        n, m = self.n_states, self.n_inputs
        results = np.empty((count, n + self.n_outputs))
        if count == 0:
            return results[:, :n], results[:, n:]
        if self.angles is not None:  # angles wrap each step: the general path, row by row
            for k in range(count):
                results[k, :n] = self.advance(int(stamps_ns[k]), outputs[k], inputs[k])
                results[k, n:] = self._innovation
            return results[:, :n], results[:, n:]
        results[0, :n] = self.advance(int(stamps_ns[0]), outputs[0], inputs[0])
        results[0, n:] = self._innovation
        work = np.empty((count, n + m))
        work[:, n:] = inputs
        steps = [self.step_matrices(dt) for dt in np.diff(stamps_ns).tolist()]
        if steps and all(step is steps[0] for step in steps) and self.n_outputs == 1:
            terms = outputs[:, :1] * steps[0].g_y_column  # output_term for every sample
        else:
            terms = [output_term(step, y) for step, y in zip(steps, outputs[1:])]
            terms.insert(0, None)
        dot, add = np.dot, np.add
        known = np.empty(n + self.n_outputs)
        for k in range(1, count):
            work[k, :n] = results[k - 1, :n]
            dot(steps[k - 1].g_known, work[k], out=known)
            add(known, terms[k], out=results[k])
        self._prepared = None
        if count > 1:
            self._x = results[-1, :n].copy()
            self._innovation = results[-1, n:].copy()
            self._result = None
            self._stamp = int(stamps_ns[-1])
            self._step = self.step_matrices(int(stamps_ns[-1] - stamps_ns[-2]))
        return results[:, :n], results[:, n:]

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
