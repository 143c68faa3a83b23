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
Measurements and inputs arriving as streams: pairing by stamp and stamp hygiene.

:class:`StreamEstimator` feeds a :class:`~observer_ros.core.estimators.StateEstimator` from
two streams, as the observer node and the offline bag replay both do (one set of rules, so
they give identical estimates). For the interval ending at measurement ``k`` the input is the
latest one stamped at or before measurement ``k-1``: a future input never leaks into the
past. A measurement whose input may still be on its way waits (``pending``) until an input
stamped at or after the previous measurement arrives, or until :meth:`flush`.

Bad stamps never crash and never produce NaN: duplicates and small backward steps are
dropped and counted; a backward jump or a gap longer than ``max_gap_ns`` restarts the
estimator from the new sample; a sample stamped further ahead of the receiver's clock than
``clock_tolerance_ns`` is dropped (it would otherwise make every real sample after it look
out of order). Values that are not finite or exceed the :class:`ValueLimits` are dropped
and counted, and an estimate or innovation beyond its limit is never returned: the
estimator restarts from its initial state instead.
"""

import bisect
from collections import Counter
from dataclasses import dataclass
import math
from typing import NamedTuple, Optional

import numpy as np

from observer_ros.core.estimators import Prediction, StateEstimator

#: Inputs kept at most (older ones are dropped once no interval can need them).
MAX_INPUTS = 10_000


@dataclass(frozen=True)
class ValueLimits:
    """
    Largest magnitudes a stream accepts (measurements, inputs) and returns (estimates).

    ``math.inf`` (the default) sets no limit; non-finite values are refused regardless.

    Attributes
    ----------
    measurement, input, estimate, innovation : float

    Examples
    --------
    >>> ValueLimits(measurement=1e9).input
    inf

    """

    measurement: float = math.inf
    input: float = math.inf  # noqa: A003 (the role's name)
    estimate: float = math.inf
    innovation: float = math.inf


def within_limit(vector: np.ndarray, limit: float) -> bool:
    """Whether every entry of ``vector`` is finite and of magnitude at most ``limit``."""
    square = vector @ vector  # one dot product decides the common case
    if square < math.inf and square <= limit * limit:  # limit * limit may overflow to inf
        return True
    return bool(np.isfinite(vector).all() and np.abs(vector).max() <= limit)


class EstimateSample(NamedTuple):
    """
    One published estimate: stamp, ``x_hat``, innovation and what a Kalman filter adds.

    ``covariance`` is ``P`` of the published estimate (``(n, n)``), ``innovation_covariance``
    the ``S`` of the innovation (``(p, p)``) and ``nis`` ``v^T S^-1 v``; None without them.
    """

    stamp_ns: int
    estimate: np.ndarray
    innovation: np.ndarray
    covariance: Optional[np.ndarray] = None
    innovation_covariance: Optional[np.ndarray] = None
    nis: Optional[float] = None


@dataclass(frozen=True)
class ReplayArrays:
    """
    Estimates of a batch replay, one row per published estimate.

    Attributes
    ----------
    stamps_ns : numpy.ndarray of int64, shape (k,)
    estimates : numpy.ndarray, shape (k, n)
    innovations : numpy.ndarray, shape (k, p)
    covariances : numpy.ndarray or None, shape (k, n, n)
        Kalman filters: ``P`` of each estimate.
    innovation_covariances : numpy.ndarray or None, shape (k, p, p)
        Kalman filters: ``S`` of each innovation.
    nis : numpy.ndarray or None, shape (k,)
        Kalman filters: the normalised innovation squared.

    """

    stamps_ns: np.ndarray
    estimates: np.ndarray
    innovations: np.ndarray
    covariances: Optional[np.ndarray] = None
    innovation_covariances: Optional[np.ndarray] = None
    nis: Optional[np.ndarray] = None


def replay_arrays(samples: list, n_states: int, n_outputs: int) -> ReplayArrays:
    """Stack estimate samples into :class:`ReplayArrays` (the Kalman arrays when all have)."""
    stamps = np.array([s.stamp_ns for s in samples], dtype=np.int64)
    estimates = np.array([s.estimate for s in samples]).reshape(-1, n_states)
    innovations = np.array([s.innovation for s in samples]).reshape(-1, n_outputs)
    covariances = innovation_covariances = nis = None
    if samples and all(s.covariance is not None for s in samples):
        covariances = np.array([s.covariance for s in samples])
    if samples and all(s.innovation_covariance is not None for s in samples):
        innovation_covariances = np.array([s.innovation_covariance for s in samples])
        nis = np.array([s.nis for s in samples], dtype=float)
    return ReplayArrays(stamps, estimates, innovations, covariances, innovation_covariances,
                        nis)


class StreamEstimator:
    """
    Pair stamped inputs with stamped measurements and run the estimator.

    Parameters
    ----------
    estimator : StateEstimator
    max_gap_ns : int
        A forward gap or backward jump longer than this restarts the estimator.
    input_stamped : bool
        False when inputs are stamped on arrival (unstamped messages): then no measurement
        waits for a later input.
    clock_tolerance_ns : int
        A sample stamped more than this ahead of the ``now_ns`` given with it is dropped
        (``future_stamp``); 0 turns the check off.
    limits : ValueLimits, optional
        Magnitude limits of the values (none by default).
    form : {'current', 'delayed'}
        ``current``: each measurement gives ``x[k|k]``. ``delayed``: it gives the prediction
        ``x[k+1|k]`` over the last interval with the input of the next one, once that input
        is known (it waits for it like a measurement), stamped with the measurement.

    Attributes
    ----------
    counters : collections.Counter
        ``measurements``, ``estimates``, ``duplicate``, ``out_of_order``,
        ``restart_gap``, ``restart_backward_jump``, ``no_input``, ``late_input``, ``inputs``,
        and the dropped samples: ``malformed`` (wrong size or not finite),
        ``out_of_range``, ``future_stamp``; ``estimate_reset`` counts estimates beyond
        their limit (not returned; the estimator restarted).
    events : list of (str, str)
        ``(kind, text)`` of notable events since the caller last cleared it.


    Examples
    --------
    >>> from observer_ros.core import design_full_order, make_estimator, StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> stream = StreamEstimator(make_estimator(design_full_order(model, poles=[-4, -5])),
    ...                          max_gap_ns=10 ** 9)
    >>> [s.stamp_ns for s in stream.add_input(0, [0.0]) + stream.add_measurement(0, [1.0])]
    [0]
    >>> [s.stamp_ns for s in stream.add_measurement(10_000_000, [1.0])]  # input of 0 held
    [10000000]
    >>> stream.add_measurement(20_000_000, [1.0])  # waits: the input of 10 ms may come
    []
    >>> [s.stamp_ns for s in stream.add_input(10_000_000, [0.5])]
    [20000000]

    """

    def __init__(self, estimator: StateEstimator, max_gap_ns: int, input_stamped: bool = True,
                 clock_tolerance_ns: int = 0, limits: Optional[ValueLimits] = None,
                 form: str = 'current') -> None:
        if form not in ('current', 'delayed'):
            raise ValueError(f"form: expected 'current' or 'delayed', got {form!r}")
        self.estimator = estimator
        self.max_gap_ns = int(max_gap_ns)
        self.input_stamped = input_stamped
        self.clock_tolerance_ns = int(clock_tolerance_ns)
        self.limits = limits or ValueLimits()
        self.form = form
        self._counters: Counter = Counter()
        self._steady = 0  # steady measurements not yet added to the counters
        self._steady_key: Optional[tuple] = None
        self.events: list = []
        self._input_stamps: list = []
        self._inputs: list = []
        self._pending: list = []
        self._awaiting: Optional[tuple] = None  # delayed form: (sample, sequence, arrival)
        self._sequence = 0
        self._zero_input = np.zeros(estimator.n_inputs)
        #: A model without inputs (m = 0): no measurement waits, none is short of an input.
        self._autonomous = estimator.n_inputs == 0
        self._inputs_absent = self._autonomous

    @property
    def counters(self) -> Counter:
        """Return the counts of the class description, up to date."""
        if self._steady:
            self._counters['measurements'] += self._steady
            self._counters['estimates'] += self._steady
            self._steady = 0
        return self._counters

    @property
    def pending(self) -> int:
        """Number of measurements (and delayed estimates) waiting for their input."""
        return len(self._pending) + (self._awaiting is not None)

    def reset(self) -> None:
        """Restart the estimator from its initial state; inputs are kept."""
        self.estimator.reset()
        self._pending.clear()
        self._awaiting = None

    # --- arrival rules -----------------------------------------------------------------

    def _acceptable(self, what: str, stamp_ns: int, vector: np.ndarray, size: int,
                    limit: float, now_ns: Optional[int]) -> bool:
        """Apply the value and clock rules to one sample; False (counted) when dropped."""
        tolerance = self.clock_tolerance_ns
        if (vector.shape == (size,) and within_limit(vector, limit)
                and not (tolerance and now_ns and stamp_ns - now_ns > tolerance)):
            return True  # the common case in one test; the reasons follow
        if vector.shape != (size,) or not np.isfinite(vector).all():
            self.counters['malformed'] += 1
            self.events.append(('malformed', f'dropped {what} {vector.tolist()}: expected '
                                f'{size} finite values'))
            return False
        if not within_limit(vector, limit):
            self.counters['out_of_range'] += 1
            self.events.append(('out_of_range', f'dropped {what} {vector.tolist()}: a value '
                                f'exceeds the limit {limit:g} in magnitude'))
            return False
        self.counters['future_stamp'] += 1
        self.events.append(('future_stamp', f'dropped {what} stamped '
                            f'{(stamp_ns - now_ns) / 1e9:.6g} s ahead of the clock '
                            f'(tolerance {tolerance / 1e9:g} s)'))
        return False

    def add_input(self, stamp_ns: int, u, now_ns: Optional[int] = None) -> list:
        """
        Store an input; return the estimates of measurements it releases.

        ``now_ns`` is the receiver's clock at arrival, for the clock tolerance (None: no
        check).
        """
        self.counters['inputs'] += 1
        stamp_ns = int(stamp_ns)
        vector = np.array(u, dtype=float).reshape(-1)
        if not self._acceptable('an input', stamp_ns, vector, self.estimator.n_inputs,
                                self.limits.input, now_ns):
            return []
        self._store_input(stamp_ns, vector)
        previous = self.estimator.stamp_ns
        if previous is None or stamp_ns >= previous - self.max_gap_ns:
            self._prune()  # not while a backward jump (a looping bag) is under way
        released = self._release(force=False)
        if not released:
            self.prepare()
        return released

    def _store_input(self, stamp_ns: int, vector: np.ndarray) -> None:
        """Keep an input in stamp order; a repeated stamp replaces the earlier input."""
        self._inputs_absent = self._autonomous
        index = bisect.bisect_left(self._input_stamps, stamp_ns)
        if index < len(self._input_stamps) and self._input_stamps[index] == stamp_ns:
            self._inputs[index] = vector
        else:
            self._input_stamps.insert(index, stamp_ns)
            self._inputs.insert(index, vector)

    def _store_inputs(self, stamps: np.ndarray, vectors: np.ndarray) -> None:
        """Store many inputs at once, as :meth:`_store_input` one by one would."""
        if self._input_stamps:
            for stamp, vector in zip(stamps.tolist(), vectors):
                self._store_input(stamp, vector)
            return
        if not len(stamps):
            return
        order = np.argsort(stamps, kind='stable')
        ordered = stamps[order]
        last = np.append(ordered[1:] != ordered[:-1], True)  # of equal stamps the later wins
        self._input_stamps = ordered[last].tolist()
        self._inputs = list(vectors[order][last])
        self._inputs_absent = self._autonomous

    def add_measurement(self, stamp_ns: int, y, now_ns: Optional[int] = None,
                        arrival_ns: int = 0) -> list:
        """
        Take a measurement; return the estimates produced now (possibly none).

        ``now_ns`` is the receiver's clock at arrival (see :meth:`add_input`);
        ``arrival_ns`` any monotonic arrival time the caller wants back from :meth:`waiting`
        (the node's steady clock, to bound the wait for the input).
        """
        self.counters['measurements'] += 1
        stamp_ns = int(stamp_ns)
        vector = np.asarray(y, dtype=float).reshape(-1)  # copied below if it has to wait
        if not self._acceptable('a measurement', stamp_ns, vector, self.estimator.n_outputs,
                                self.limits.measurement, now_ns):
            return []
        if not self._pending and self._awaiting is None:  # the common case, queue-free
            previous = self.estimator.stamp_ns
            if (previous is not None and 0 < stamp_ns - previous <= self.max_gap_ns
                    and self._ready(previous)):
                return self._emit(self._process(stamp_ns, vector,
                                                self._input_for(previous), previous),
                                  arrival_ns)
        self._sequence += 1
        self._pending.append((stamp_ns, vector.copy(), self._sequence, int(arrival_ns)))
        return self._release(force=False)

    def add_steady_measurement(self, stamp_ns: int, y: float,
                               now_ns: Optional[int] = None) -> Optional[list]:
        """
        Take a one-output measurement in the steady case; return ``[x_hat..., innovation...]``.

        The fast path of :meth:`add_measurement` (a node calls it first): nothing waits, the
        interval follows the previous one at the same length, its input is known and the
        estimator prepared it (:meth:`prepare`); the current form only. Then the same rules
        give the same numbers as :meth:`add_measurement` and the same counts, without
        building arrays. None when the steady case does not hold, or the value or stamp
        breaks a rule: nothing was changed or counted then, and :meth:`add_measurement` must
        take the measurement.
        """
        key = self._steady_key  # (previous stamp, its input, time-base offset) from prepare()
        estimator = self.estimator
        tolerance = self.clock_tolerance_ns
        if (key is None or self._pending or estimator.stamp_ns != key[0]
                or not -self.limits.measurement <= y <= self.limits.measurement
                or not 0 < stamp_ns - key[0] <= self.max_gap_ns
                or (tolerance and now_ns and stamp_ns - now_ns > tolerance)):
            return None
        prepared = estimator.advance_prepared(stamp_ns, y, key[1])
        if prepared is None:
            return None
        result, bounded = prepared
        limit = min(self.limits.estimate, self.limits.innovation)
        if not bounded and not (math.isfinite(sum(result)) and max(result) <= limit
                                and min(result) >= -limit):
            if not self._publishable(estimator.estimate, estimator.innovation):
                self.counters['measurements'] += 1  # counted and restarted, as live
                return []
        self._steady += 1  # a measurement and an estimate (see counters)
        if key[2] is not None:
            self._time_base_event(key[2])
        return result

    def waiting(self) -> Optional[tuple]:
        """
        ``(sequence, arrival_ns)`` of the first sample waiting for its input, or None.

        The sequence number tells one waiting sample from the next; ``arrival_ns`` is what
        was given to :meth:`add_measurement`.
        """
        if self._awaiting is not None:
            return self._awaiting[1:]
        return self._pending[0][2:] if self._pending else None

    def flush(self, first_only: bool = False) -> list:
        """
        Process waiting measurements with the inputs at hand.

        ``first_only``: only the first waits no longer; the ones after it are processed when
        their input is there (as :meth:`add_input` would).
        """
        if (self._pending or self._awaiting is not None) and not self._input_stamps:
            self._inputs_absent = True
        return self._release(force=True, first_only=first_only)

    # --- the rules -----------------------------------------------------------------------

    def _ready(self, previous: int) -> bool:
        """Say whether the input of the interval after ``previous`` is known (or never comes)."""
        if not self.input_stamped or self._inputs_absent:
            return True
        return bool(self._input_stamps) and self._input_stamps[-1] >= previous

    def _input_for(self, previous: int) -> np.ndarray:
        """Return the input of the interval after ``previous`` (latest at or before it)."""
        index = bisect.bisect_right(self._input_stamps, previous) - 1
        if index < 0:
            if self._autonomous:
                return self._zero_input
            if self._input_stamps:
                self.counters['late_input'] += 1
                if self._input_stamps[0] - previous > self.max_gap_ns:
                    self._time_base_event(self._input_stamps[0] - previous)
            else:
                self.counters['no_input'] += 1
            return self._zero_input
        if previous - self._input_stamps[index] > self.max_gap_ns:
            self._time_base_event(self._input_stamps[index] - previous)
        return self._inputs[index]

    def _time_base_event(self, offset_ns: int) -> None:
        self.events.append(('time_base', f'the inputs are stamped {offset_ns / 1e9:+.3f} s from '
                            f'the measurements, more than the gap limit: are y and u stamped '
                            f'in different time bases (simulation time and wall clock, or an '
                            f'unstamped u stamped on arrival)?'))

    def _interval_input(self, previous: int, force: bool) -> Optional[np.ndarray]:
        """
        Return the input of the interval after ``previous``, or None while it may come.

        ``force``: take the latest earlier one now (counted as ``late_input`` when the
        interval's own input is not there).
        """
        ready = self._ready(previous)
        if not (force or ready):
            return None
        if not ready:
            self.counters['late_input'] += 1
        return self._input_for(previous)

    def _release(self, force: bool, first_only: bool = False) -> list:
        """Process what waits, in order, as far as inputs allow (or all, with ``force``)."""
        produced = []
        while True:
            if self._awaiting is not None:
                sample, _, arrival = self._awaiting
                u = self._interval_input(sample.stamp_ns, force)
                if u is None:
                    break
                self._awaiting = None
                produced.append(self._delayed(sample, u))
                force = force and not first_only
                continue
            if not self._pending:
                break
            stamp, y, _, arrival = self._pending[0]
            previous = self.estimator.stamp_ns
            if previous is not None and 0 < stamp - previous <= self.max_gap_ns:
                u = self._interval_input(previous, force)
                if u is None:
                    break
            else:
                u = self._zero_input
            force = force and not first_only
            self._pending.pop(0)
            produced += self._emit(self._process(stamp, y, u, previous), arrival)
        return produced

    def _process(self, stamp: int, y: np.ndarray, u: np.ndarray,
                 previous: Optional[int]) -> Optional[EstimateSample]:
        """Apply the stamp rules and take one measurement; the current-form sample or None."""
        if not self._admit(stamp, previous):
            return None
        estimator = self.estimator
        estimate = estimator.advance(stamp, y, u)  # y and u were checked on arrival
        innovation = estimator.innovation
        if not self._publishable(estimate, innovation, estimator.result):
            return None
        self.counters['estimates'] += 1
        covariance = estimator.innovation_covariance
        return EstimateSample(stamp, estimate, innovation, estimator.covariance, covariance,
                              None if covariance is None else estimator.nis)

    def _emit(self, sample: Optional[EstimateSample], arrival: int) -> list:
        """Return what a processed measurement gives now (delayed form: maybe later)."""
        if sample is None:
            return []
        if self.form == 'current':
            return [sample]
        self._sequence += 1
        self._awaiting = (sample, self._sequence, arrival)
        return self._release(force=False)

    def _delayed(self, sample: EstimateSample, u: np.ndarray) -> EstimateSample:
        """Return the prediction ``x[k+1|k]`` of a current sample, with the next input ``u``."""
        estimator = self.estimator
        interval = estimator.last_interval_ns
        prediction = estimator.predict(sample.stamp_ns + interval, u)
        return sample._replace(estimate=prediction.estimate,
                               covariance=prediction.covariance)

    def predict(self, stamp_ns: int) -> Prediction:
        """
        Return the estimate predicted to ``stamp_ns`` with the latest input stamped by then.

        The estimator is not changed (``observer.publish_rate`` publishes these).
        """
        index = bisect.bisect_right(self._input_stamps, int(stamp_ns)) - 1
        u = self._inputs[index] if index >= 0 else self._zero_input
        return self.estimator.predict(int(stamp_ns), u)

    def prepare(self) -> None:
        """
        Let the estimator make the next step's known part now, if the input is there.

        Call it when nothing waits (after publishing an estimate): the next measurement then
        costs less. The estimates are the same whether it is called or not.
        """
        stamp = self.estimator.stamp_ns
        self._steady_key = None
        if (stamp is not None and not self._pending and self._awaiting is None
                and self._ready(stamp)):
            index = bisect.bisect_right(self._input_stamps, stamp) - 1
            limits = self.limits
            u = self._inputs[index] if index >= 0 else self._zero_input
            self.estimator.prepare(u, (limits.measurement, min(limits.estimate,
                                                               limits.innovation)))
            if self.form != 'current':
                return
            if index >= 0:  # what add_measurement would do
                offset = self._input_stamps[index] - stamp
                self._steady_key = (stamp, u, offset if -offset > self.max_gap_ns else None)
            elif self._autonomous:
                self._steady_key = (stamp, u, None)

    def _publishable(self, estimate: np.ndarray, innovation: np.ndarray,
                     result: Optional[np.ndarray] = None) -> bool:
        """
        Whether an estimate may be returned; else count it and restart the estimator.

        ``result``, both together, is checked at once against the smaller limit first.
        """
        limits = self.limits
        if result is not None and within_limit(result, min(limits.estimate,
                                                           limits.innovation)):
            return True
        if within_limit(estimate, limits.estimate) and within_limit(innovation,
                                                                    limits.innovation):
            return True
        self.counters['estimate_reset'] += 1
        self.events.append(('estimate_reset', f'an estimate beyond its limit '
                            f'({limits.estimate:g}, innovation {limits.innovation:g}) was not '
                            f'published; the estimator restarts from its initial state'))
        self.estimator.reset()
        return False

    def _admit(self, stamp: int, previous: Optional[int]) -> bool:
        """Apply the stamp rules to a measurement; False when it is dropped."""
        if previous is None:
            return True
        step = stamp - previous
        if step == 0:
            self.counters['duplicate'] += 1
            self.events.append(('duplicate', f'dropped a measurement with a repeated '
                                f'stamp ({stamp} ns)'))
            return False
        if -self.max_gap_ns <= step < 0:
            self.counters['out_of_order'] += 1
            self.events.append(('out_of_order', f'dropped a measurement older than the '
                                f'previous one ({stamp} < {previous} ns)'))
            return False
        if step < 0 or step > self.max_gap_ns:
            kind = 'restart_backward_jump' if step < 0 else 'restart_gap'
            self.counters[kind] += 1
            if step < 0:  # inputs of the abandoned timeline must not pair with the new one
                keep = bisect.bisect_right(self._input_stamps, stamp)
                del self._input_stamps[keep:]
                del self._inputs[keep:]
            self.events.append((kind, f'time jumped by {step / 1e9:.3f} s; the estimator '
                                f'restarts from this sample'))
            self.estimator.restart()
        return True

    # --- recorded streams ------------------------------------------------------------------

    def replay(self, input_stamps, inputs, stamps, outputs, input_arrivals=None,
               arrivals=None) -> ReplayArrays:
        """
        Run over whole recorded streams at once, as if every input had arrived in time.

        Gives what the node computes from the same messages when no input arrives later than
        the measurement after it (a recording played back): the same pairing and stamp
        rules (the live ones: :meth:`add_measurement` and :meth:`flush` run them), so the
        estimates are equal bit for bit. Rows with a non-finite value are dropped and
        counted as ``malformed``, rows beyond the :class:`ValueLimits` as ``out_of_range``,
        and, with arrival times and a clock tolerance, rows stamped too far ahead of their
        arrival as ``future_stamp`` (the arrival time plays the receiver's clock). An
        estimator with a batch path (:attr:`StateEstimator.supports_batch`) runs a recording
        without gaps or stamp faults through it, equal bit for bit to the live rules.

        Parameters
        ----------
        input_stamps : array_like of int, shape (k,)
            Input stamps in arrival order (equal stamps: the later one wins, as live).
        inputs : array_like, shape (k, m)
        stamps : array_like of int, shape (samples,)
            Measurement stamps in arrival order.
        outputs : array_like, shape (samples, p)
        input_arrivals, arrivals : array_like of int, optional
            Arrival (log) times. A recording with a backward jump (a looping bag) is then
            fed message by message in arrival order, as live; without them it is refused.

        Returns
        -------
        ReplayArrays

        Raises
        ------
        ValueError
            Lengths differ, or a backward jump without arrival times.

        """
        estimator = self.estimator
        n_outputs, n_inputs = estimator.n_outputs, estimator.n_inputs
        outputs = np.ascontiguousarray(outputs, dtype=float).reshape(-1, n_outputs)
        stamps = np.asarray(stamps, dtype=np.int64)
        input_stamps = np.asarray(input_stamps, dtype=np.int64)
        inputs = (np.ascontiguousarray(inputs, dtype=float).reshape(-1, n_inputs) if n_inputs
                  else np.zeros((len(input_stamps), 0)))  # m = 0: rows of nothing
        if len(stamps) != len(outputs) or len(input_stamps) != len(inputs):
            raise ValueError('replay: stamps and values differ in length')
        good_inputs, input_drops = self._row_filter(inputs, input_stamps, input_arrivals,
                                                    self.limits.input)
        good, drops = self._row_filter(outputs, stamps, arrivals, self.limits.measurement)
        jump = -self.max_gap_ns
        looping = ((np.diff(stamps[good]) < jump).any()
                   or (np.diff(input_stamps[good_inputs]) < jump).any())
        if looping:
            if arrivals is None or input_arrivals is None:
                raise ValueError('replay: the stamps jump backwards (a looping recording); '
                                 'give the arrival times to replay it message by message')
            return self._replay_in_arrival_order(
                input_stamps, inputs, stamps, outputs, input_arrivals, arrivals)
        counters = self.counters
        for key in drops:  # every kind named, zero included: replay reports them all
            counters[key] += input_drops[key] + drops[key]
        counters['inputs'] += len(input_stamps)
        counters['measurements'] += int((~good).sum())  # the dropped ones, as live
        self._store_inputs(input_stamps[good_inputs], inputs[good_inputs])
        if not self._input_stamps:
            self._inputs_absent = True  # as a live flush finds it: no input will come
        measured = stamps[good]
        steps = np.diff(measured)
        if (estimator.supports_batch and estimator.stamp_ns is None and len(measured)
                and (steps > 0).all() and (steps <= self.max_gap_ns).all()):
            steady = self._replay_steady(measured, outputs[good])
            if steady is not None:
                return steady
        samples = []
        for stamp, y in zip(measured.tolist(), outputs[good]):
            counters['measurements'] += 1
            self._pending.append((stamp, y, 0, 0))
            samples += self._release(force=True)  # every input is there: as live, in time
        return replay_arrays(samples, estimator.n_states, n_outputs)

    def _row_filter(self, values, stamps, arrivals, limit) -> tuple:
        """Rows the value and clock rules keep, and a Counter of the dropped ones."""
        finite = np.isfinite(values).all(axis=1)
        inside = finite & (np.abs(np.where(finite[:, None], values, 0.0)).max(
            axis=1, initial=0.0) <= limit)
        keep = inside.copy()
        if arrivals is not None and self.clock_tolerance_ns:
            now = np.asarray(arrivals, dtype=np.int64)
            future = inside & (now > 0) & (stamps - now > self.clock_tolerance_ns)
            keep &= ~future
        else:
            future = np.zeros(len(values), dtype=bool)
        drops = Counter({'malformed': int((~finite).sum()),
                         'out_of_range': int((finite & ~inside).sum()),
                         'future_stamp': int(future.sum())})
        return keep, drops

    def _replay_steady(self, stamps, outputs) -> Optional[ReplayArrays]:
        """
        Run measurements that all follow each other within the gap through the batch path.

        Every measurement is admitted, so each interval's input is known in advance: the
        latest input stamped at or before the previous measurement (zero before the first).
        None (estimator untouched) when an estimate leaves its limit: the caller then takes
        the sample-by-sample path, which restarts the estimator there as live.
        """
        estimator = self.estimator
        count = len(stamps)
        input_stamps = np.array(self._input_stamps, dtype=np.int64)
        inputs = (np.vstack(self._inputs) if self._inputs
                  else np.zeros((0, estimator.n_inputs)))
        pairing = np.searchsorted(input_stamps, stamps, side='right') - 1
        stack = np.vstack([self._zero_input, inputs])
        held = stack[np.concatenate([[-1], pairing[:-1]]) + 1]
        saved = estimator.snapshot()
        estimates, innovations = estimator.advance_many(stamps, outputs, held)
        limits = self.limits
        if not (_rows_within(estimates, limits.estimate)
                and _rows_within(innovations, limits.innovation)):
            estimator.restore(saved)
            return None
        counters = self.counters
        if len(input_stamps):
            counters['late_input'] += int((pairing[:-1] < 0).sum())
            if self.input_stamped:
                counters['late_input'] += int((stamps[:-1] > input_stamps[-1]).sum())
        elif not self._autonomous:
            counters['no_input'] += count - 1
        counters['measurements'] += count
        counters['estimates'] += count
        covariance = estimator.covariance
        s = estimator.innovation_covariance
        arrays = ReplayArrays(
            stamps.copy(), np.ascontiguousarray(estimates), np.ascontiguousarray(innovations),
            None if covariance is None else np.broadcast_to(covariance, (count,)
                                                            + covariance.shape),
            None if s is None else np.broadcast_to(s, (count,) + s.shape),
            None if s is None else np.einsum('ki,ij,kj->k', innovations, np.linalg.inv(s),
                                             innovations))
        if self.form == 'delayed':
            arrays = self._delayed_rows(arrays, stamps, stack, pairing)
        return arrays

    def _delayed_rows(self, arrays: ReplayArrays, stamps, stack, pairing) -> ReplayArrays:
        """Return batch rows in the delayed form, each predicted as :meth:`_delayed` does."""
        estimator = self.estimator
        intervals = np.concatenate([[0], np.diff(stamps)]).tolist()
        counters = self.counters
        if len(self._input_stamps) and self.input_stamped and stamps[-1] > self._input_stamps[-1]:
            counters['late_input'] += 1  # the last row's next input: the latest earlier one
        elif not len(self._input_stamps) and not self._autonomous:
            counters['no_input'] += 1
        estimates = np.empty_like(arrays.estimates)
        covariances = None if arrays.covariances is None else np.empty(arrays.covariances.shape)
        for k, (x, interval) in enumerate(zip(arrays.estimates, intervals)):
            covariance = None if covariances is None else arrays.covariances[k]
            u = stack[pairing[k] + 1]
            predicted = estimator.prediction(x, covariance, int(interval), u)
            estimates[k] = predicted.estimate
            if covariances is not None:
                covariances[k] = predicted.covariance
        return ReplayArrays(arrays.stamps_ns, estimates, arrays.innovations, covariances,
                            arrays.innovation_covariances, arrays.nis)

    def _replay_in_arrival_order(self, input_stamps, inputs, stamps, outputs, input_arrivals,
                                 arrivals) -> ReplayArrays:
        events = sorted(
            [(int(t), 0, k) for k, t in enumerate(np.asarray(input_arrivals).tolist())]
            + [(int(t), 1, k) for k, t in enumerate(np.asarray(arrivals).tolist())])
        samples = []
        for arrival, kind, index in events:
            add = self.add_input if kind == 0 else self.add_measurement
            values = inputs[index] if kind == 0 else outputs[index]
            stamp = int((input_stamps if kind == 0 else stamps)[index])
            samples += add(stamp, values, arrival)
        samples += self.flush()
        return replay_arrays(samples, self.estimator.n_states, self.estimator.n_outputs)

    def _prune(self) -> None:
        previous = self.estimator.stamp_ns
        if previous is None:
            keep_from = max(0, len(self._input_stamps) - MAX_INPUTS)
        else:
            keep_from = max(0, bisect.bisect_right(self._input_stamps, previous) - 1)
            keep_from = max(keep_from, len(self._input_stamps) - MAX_INPUTS)
        if keep_from:
            del self._input_stamps[:keep_from]
            del self._inputs[:keep_from]


def _rows_within(rows: np.ndarray, limit: float) -> bool:
    """Whether every entry of ``rows`` is finite and of magnitude at most ``limit``."""
    return bool(rows.size == 0 or (np.isfinite(rows).all() and np.abs(rows).max() <= limit))
