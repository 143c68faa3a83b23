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
An estimator run on stamped measurement and input events: the stream of the node and replay.

:class:`EventStream` drives an :class:`~observer_ros.core.estimators.Estimator` with the
rows of an :class:`~observer_ros.core.events.EventEngine`, where the value, clock, stamp and
pairing rules are written once; the observer node (event by event) and the offline bag
replay (:meth:`EventStream.replay`, a whole recording) both run it, so they give identical
estimates. The stream adds what concerns the estimates: an estimate or innovation beyond
its :class:`ValueLimits` is never returned (the estimator restarts from its initial state
instead), and the ``delayed`` form.

Bad stamps never crash and never produce NaN: duplicates and small backward steps are
dropped and counted; a backward jump or a gap longer than ``max_gap_ns`` restarts the
estimator from the new sample; a sample stamped further ahead of the receiver's clock than
``clock_tolerance_ns`` is dropped. Values that are not finite or exceed the limits are
dropped and counted.

Several measurement sources at their own rates, and late measurements: given
``sources`` (:class:`~observer_ros.core.sources.MeasurementSource`) and a ``history_ns``, the
engine keeps a history and the stream updates the estimator with the outputs that arrived
(:class:`~observer_ros.core.estimators.SubsetUpdates`, asked by capability; an estimator
without it takes one source only). A measurement older than the newest one but inside the
history is inserted in stamp order and the estimates after it computed again; what it
returns is the corrected newest estimate, at the newest stamp, marked ``corrected``
(:class:`~observer_ros.core.estimates.SourceSample`). Samples of two sources with one stamp
make one update with the outputs of both. See :mod:`observer_ros.core.events`.

A model with a feedthrough ``D`` (:attr:`~observer_ros.core.estimators.Estimator.feedthrough`)
measures ``y = C x + D u``: the stream takes ``D u`` off each measurement with the input in
effect at the measurement's stamp, the engine's pairing rule applied at that stamp (the
latest input stamped at or before it: ``EventEngine.held_input``), while the prediction
over the interval keeps the input of the interval. A measurement waits for an input stamped
at or after its own stamp, as it waits for the input of its interval (a flush takes the
latest one at hand), so the live stream and a replay give the same estimates; with a
history a late input re-runs the rows it changes. The input is then the one applied at that
sample, stamped with it (what the plant simulator publishes on ``u``, before ``y``), not a
command computed from the estimate. The fast paths are off with a feedthrough.

When the estimator offers :class:`~observer_ros.core.estimators.SteadySteps`, the stream
takes those fast paths where they apply (a prepared steady one-output step, a batch over a
recording whose stamps all follow on): a private optimisation, equal bit for bit to the
general path (``fast_paths=False`` turns it off; the tests hold the two equal). They are
off while the stream keeps a history.
"""

from collections import Counter
import math
from typing import NamedTuple, Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.estimates import (
    EstimateSample, replay_arrays, ReplayArrays, SourceSample)
from observer_ros.core.estimators import (
    Estimator, Prediction, SteadySteps, SubsetUpdates, without_feedthrough)
from observer_ros.core.events import EventEngine, INPUT, MEASUREMENT, PREDICTION
from observer_ros.core.rules import (
    ahead_of_clock, in_sequence, rows_within, ValueLimits, within_limit)
from observer_ros.core.sources import check_subsets, MeasurementSource

__all__ = ['EstimateSample', 'EventStream', 'RecordedEvent', 'ReplayArrays', 'SourceSample',
           'ValueLimits', 'replay_arrays']

#: The values of an update with no output (a predict-only source).
NO_VALUES = np.zeros(0)


class RecordedEvent(NamedTuple):
    """
    One recorded message, for :meth:`EventStream.replay_events`.

    ``source`` is ``'u'`` for an input or a measurement source's name; ``arrival_ns`` its
    arrival (log) time, the receiver's clock of the clock rule (0: no clock check).
    """

    source: str
    stamp_ns: int
    values: object
    arrival_ns: int = 0


def next_measurement_stamps(input_arrivals, measurement_arrivals,
                            measurement_stamps) -> tuple:
    """
    Stamp unstamped inputs as :meth:`EventStream.hold_input` does, for a recording.

    Each input is applied from the first measurement that arrives at or after it and is
    stamped with that measurement's stamp; of several inputs held for one measurement the
    last replaces the others, and an input after the last measurement is never applied.
    (``hold_input``'s other case, an input arriving when the receiver's clock equals the
    latest measurement's stamp, needs that clock, which a recording does not keep.)

    Parameters
    ----------
    input_arrivals : array_like of int, shape (k,)
        Arrival (log) order of the inputs, nondecreasing.
    measurement_arrivals : array_like of int, shape (m,)
        Arrival order of the measurements, nondecreasing, comparable with the inputs'.
    measurement_stamps : array_like of int, shape (m,)

    Returns
    -------
    kept : numpy.ndarray of int
        Indices of the inputs that are applied, in order.
    stamps : numpy.ndarray of int
        Their stamps.

    Examples
    --------
    >>> from observer_ros.core.streaming import next_measurement_stamps
    >>> next_measurement_stamps([5, 12, 13, 40], [10, 20, 30], [100, 200, 300])
    (array([0, 2]), array([100, 200]))

    """
    at = np.searchsorted(np.asarray(measurement_arrivals), np.asarray(input_arrivals),
                         side='left')
    last = np.append(at[1:] != at[:-1], True) if len(at) else np.zeros(0, dtype=bool)
    kept = np.flatnonzero(last & (at < len(measurement_stamps)))
    return kept, np.asarray(measurement_stamps, dtype=np.int64)[at[kept]]


class EventStream:
    """
    Run an estimator on stamped inputs and measurements, paired by the event engine.

    Parameters
    ----------
    estimator : Estimator
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
    fast_paths : bool
        Take the estimator's :class:`~observer_ros.core.estimators.SteadySteps` where they
        apply (the same numbers and counts; False: the general path only).
    sources : sequence of MeasurementSource, optional
        The measurement sources (default: one, ``y``, with every output). Several need an
        estimator with :class:`~observer_ros.core.estimators.SubsetUpdates`; each source
        alone is checked at once (:func:`~observer_ros.core.sources.check_subsets`).
    history_ns : int
        How far back (ns) a late measurement is inserted in stamp order and the estimates
        after it computed again; older ones are dropped (``too_old``). With several
        sources or a history the form must be ``current``.
    output_names : sequence of str, optional
        Names of the outputs, for the messages about sources (``y1``... otherwise).

    Attributes
    ----------
    engine : EventEngine
        The events and their rules (its ``consumer`` is this stream).
    counters : collections.Counter
        The engine's (``measurements``, ``duplicate``, ``out_of_order``, ``restart_gap``,
        ``restart_backward_jump``, ``no_input``, ``late_input``, ``inputs``, ``malformed``,
        ``out_of_range``, ``future_stamp``) and ``estimates``; ``estimate_reset`` counts
        estimates beyond their limit (not returned; the estimator restarted); with a history
        the engine's ``reruns``, ``rerun_rows``, ``too_old`` and ``corrected`` (the
        corrected estimates returned, besides ``estimates``); ``nonfinite``: the
        estimator's steps dropped as not finite (a nonlinear filter's own count).
    events : list of (str, str)
        ``(kind, text)`` of notable events since the caller last cleared it.

    Examples
    --------
    >>> from observer_ros.core import design_full_order, make_estimator, StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> stream = EventStream(make_estimator(design_full_order(model, poles=[-4, -5])),
    ...                      max_gap_ns=10 ** 9)
    >>> [s.stamp_ns for s in stream.add_input(0, [0.0]) + stream.add_measurement(0, [1.0])]
    [0]
    >>> [s.stamp_ns for s in stream.add_measurement(10_000_000, [1.0])]  # input of 0 held
    [10000000]
    >>> stream.add_measurement(20_000_000, [1.0])  # waits: the input of 10 ms may come
    []
    >>> [s.stamp_ns for s in stream.add_input(10_000_000, [0.5])]
    [20000000]

    """

    def __init__(self, estimator: Estimator, max_gap_ns: int, input_stamped: bool = True,
                 clock_tolerance_ns: int = 0, limits: Optional[ValueLimits] = None,
                 form: str = 'current', fast_paths: bool = True,
                 sources: Optional[Sequence[MeasurementSource]] = None,
                 history_ns: int = 0, output_names: Optional[Sequence[str]] = None) -> None:
        if form not in ('current', 'delayed'):
            raise ValueError(f"form: expected 'current' or 'delayed', got {form!r}")
        self.estimator = estimator
        self.limits = limits or ValueLimits()
        self.form = form
        self.engine = EventEngine(estimator.n_outputs, estimator.n_inputs, max_gap_ns,
                                  input_stamped, clock_tolerance_ns, self.limits,
                                  consumer=self, sources=sources, history_ns=history_ns,
                                  output_names=output_names)
        self.engine.pairs_at_stamp = estimator.feedthrough is not None
        self._updates: dict = {}  # outputs of a row -> outputs to update with
        self._owners: dict = {}  # output index -> its source
        if self.engine.keeps_history:
            self._check_sources(self.engine.measurement_sources, output_names)
        self._fast = (fast_paths and isinstance(estimator, SteadySteps)
                      and not self.engine.keeps_history and estimator.feedthrough is None)
        self._result_limit = min(self.limits.estimate, self.limits.innovation)
        self._steady = 0  # steady measurements not yet added to the counters
        self._steady_key: Optional[tuple] = None
        self._held_input: Optional[tuple] = None  # (u, now_ns) of hold_input
        self._last_measurement_ns: Optional[int] = None  # stamp of the latest measurement

    def _check_sources(self, sources: tuple, output_names: Optional[Sequence[str]]) -> None:
        """Refuse what the estimator cannot do with these sources (at start-up)."""
        if self.form != 'current':
            raise ConfigError('form', 'the delayed form takes one measurement source without '
                              'a history; expected current with several sources or a history')
        partial = len(sources) > 1
        if partial:
            estimator = self.estimator
            problem = (estimator.several_sources_problem()
                       if isinstance(estimator, SubsetUpdates) else
                       f'this estimator ({type(estimator).__name__}) updates with every output '
                       f'at once')
            if problem is not None:
                raise ConfigError('sources', f'{problem}; got {len(sources)} sources '
                                  f'{[source.name for source in sources]}')
            self._updates = check_subsets(self.estimator, sources, output_names)
        self._owners = {index: source for source in sources for index in source.outputs}

    def _update_outputs(self, outputs: tuple) -> tuple:
        """Return the outputs to update with when ``outputs`` came: them, or none (predict)."""
        problem = self.estimator.subset_problem(outputs)
        owners = {self._owners[index] for index in outputs}
        if problem is None:
            update = outputs
        elif all(source.predict_only for source in owners):
            update = ()
        else:  # check_subsets refused this at start-up; say so if it comes anyway
            names = sorted(source.name for source in owners)
            raise ConfigError('sources', f'sources {names} together: {problem}')
        self._updates[outputs] = update
        return update

    # --- what the engine and the callers read --------------------------------------------

    @property
    def stamp_ns(self) -> Optional[int]:
        """Stamp of the last measurement the estimator took (the engine's previous one)."""
        return self.estimator.stamp_ns

    @property
    def counters(self) -> Counter:
        """Return the counts of the class description, up to date."""
        counters = self.engine.counters
        dropped = getattr(self.estimator, 'counters', {}).get('nonfinite')
        if dropped:  # the estimator's steps dropped as not finite (a nonlinear filter)
            counters['nonfinite'] = dropped
        if self._steady:
            counters['measurements'] += self._steady
            counters['estimates'] += self._steady
            self._steady = 0
        return counters

    @property
    def events(self) -> list:
        """``(kind, text)`` of notable events since the caller last cleared the list."""
        return self.engine.events

    @property
    def max_gap_ns(self) -> int:
        """A forward gap or backward jump longer than this restarts the estimator."""
        return self.engine.max_gap_ns

    @property
    def clock_tolerance_ns(self) -> int:
        """Samples stamped further ahead of the clock than this are dropped (0: no check)."""
        return self.engine.clock_tolerance_ns

    @clock_tolerance_ns.setter
    def clock_tolerance_ns(self, value: int) -> None:
        self.engine.clock_tolerance_ns = int(value)

    @property
    def input_stamped(self) -> bool:
        """False when inputs are stamped on arrival (no measurement waits for a later one)."""
        return self.engine.input_stamped

    @input_stamped.setter
    def input_stamped(self, value: bool) -> None:
        self.engine.input_stamped = bool(value)

    @property
    def pending(self) -> int:
        """Number of measurements (and delayed estimates) waiting for their input."""
        return len(self.engine.queue)

    def waiting(self) -> Optional[tuple]:
        """
        ``(sequence, arrival_ns)`` of the first sample waiting for its input, or None.

        The sequence number tells one waiting sample from the next; ``arrival_ns`` is what
        was given to :meth:`add_measurement`.
        """
        return self.engine.waiting()

    def reset(self, keep_inputs: bool = True) -> None:
        """
        Restart the estimator from its initial state; the history is forgotten.

        ``keep_inputs``: the inputs are kept (``~/reset`` in a running loop: the input of the
        next interval is already here). False forgets them too, and an input held for the
        next measurement (:meth:`hold_input`): a lifecycle deactivation, after which the
        old inputs, seconds older than the next measurement, would be paired with it.
        """
        self.estimator.reset()
        self.engine.queue.clear()
        self.engine.clear_history()
        if not keep_inputs:
            self.engine.clear_inputs()
            self._held_input = self._last_measurement_ns = None
            self._steady_key = None

    def source_report(self, now_ns: Optional[int] = None) -> dict:
        """``{source name: SourceStatus}`` (see :meth:`EventEngine.source_report`)."""
        return self.engine.source_report(now_ns)

    def history(self) -> list:
        """
        Return the estimates of the history, oldest first, as computed with every sample so far.

        One per stamp of the history (the last one is the newest estimate); empty without a
        history. Rows whose estimate was not returned (beyond a limit) are left out.
        """
        return [entry.result for entry in self.engine.entries if entry.result is not None]

    def save(self) -> tuple:
        """Return the estimator's running state, to re-run from (the engine's history)."""
        return self.estimator.snapshot()

    def load(self, state: tuple) -> None:
        """Return the estimator to a state of :meth:`save`."""
        self.estimator.restore(state)

    # --- events ----------------------------------------------------------------------------

    def add_input(self, stamp_ns: int, u, now_ns: Optional[int] = None,
                  source: str = INPUT) -> list:
        """
        Store an input; return the estimates of measurements it releases.

        ``now_ns`` is the receiver's clock at arrival, for the clock tolerance (None: no
        check).
        """
        released = self.engine.add_input(stamp_ns, u, now_ns, source)
        if not released:
            self.prepare()
        return released

    def hold_input(self, u, now_ns: Optional[int] = None) -> list:
        """
        Stamp an unstamped input with the measurement it is applied from; return the estimates.

        The input is taken as applied from the first measurement stamped at its arrival
        (``now_ns``, the receiver's clock, equal to the latest measurement's stamp: a
        simulated clock that has not moved since that sample) or arriving after it (it is
        held until then; a later input replaces one still held), as a driver that applies
        the latest command at each sample does (``observer.unstamped_input:
        next_measurement``). Its pairing then does not depend on how late it arrived, where
        an input stamped on arrival is paired one more interval late for every sample
        period of delay.
        """
        if now_ns is not None and now_ns == self._last_measurement_ns:
            self._held_input = None
            return self.add_input(now_ns, u, now_ns)
        self._held_input = (u, now_ns)
        return []

    def add_measurement(self, stamp_ns: int, y, now_ns: Optional[int] = None,
                        arrival_ns: int = 0, source: str = MEASUREMENT) -> list:
        """
        Take a measurement; return the estimates produced now (possibly none).

        ``now_ns`` is the receiver's clock at arrival (see :meth:`add_input`);
        ``arrival_ns`` any monotonic arrival time the caller wants back from :meth:`waiting`
        (the node's steady clock, to bound the wait for the input). An input of
        :meth:`hold_input` is stored first, stamped ``stamp_ns``.
        """
        self._last_measurement_ns = stamp_ns
        held = self._held_input
        if held is not None:
            self._held_input = None
            released = self.add_input(stamp_ns, held[0], held[1])
            return released + self.add_measurement(stamp_ns, y, now_ns, arrival_ns, source)
        key = self._steady_key
        if (key is not None and type(y) is list and len(y) == 1 and type(y[0]) is float
                and source == MEASUREMENT):
            produced = self._steady_step(int(stamp_ns), y[0], now_ns, key)
            if produced is not None:
                return produced
        return self.engine.add_measurement(stamp_ns, y, now_ns, arrival_ns, source)

    def flush(self, first_only: bool = False) -> list:
        """
        Process waiting measurements with the inputs at hand.

        ``first_only``: only the first waits no longer; the ones after it are processed when
        their input is there (as :meth:`add_input` would).
        """
        return self.engine.flush(first_only)

    def predict(self, stamp_ns: int) -> Prediction:
        """
        Return the estimate predicted to ``stamp_ns`` with the latest input stamped by then.

        The estimator is not changed (``observer.publish_rate`` publishes these).
        """
        return self.estimator.predict(int(stamp_ns), self.engine.held_input(int(stamp_ns)))

    # --- rows ------------------------------------------------------------------------------

    def take(self, row) -> list:
        """Run the estimator on one row of the engine; return the estimates it gives now."""
        if row.source == PREDICTION:
            return [self._delayed(row.y, row.u)]
        estimator = self.estimator
        if row.interval_ns == 0 and estimator.stamp_ns is not None:
            estimator.restart()  # a gap or a backward jump: start from the estimate held
        outputs = row.outputs
        y = row.y
        d = estimator.feedthrough
        if outputs is None:
            if d is not None:  # D u with the input in effect at the measurement's stamp
                y = without_feedthrough(d, y, self.engine.held_input(row.stamp_ns))
            estimate = estimator.advance(row.stamp_ns, y, row.u)  # checked on arrival
        else:
            update = self._updates.get(outputs)
            if update is None:
                update = self._update_outputs(outputs)
            if d is not None and update:
                y = without_feedthrough(d, y, self.engine.held_input(row.stamp_ns), update)
            estimate = estimator.advance_outputs(row.stamp_ns, y if update else NO_VALUES,
                                                 row.u, update)
        innovation = estimator.innovation
        if not self._publishable(estimate, innovation,
                                 estimator.result if self._fast else None):
            return []
        covariance = estimator.innovation_covariance
        nis = None if covariance is None else estimator.nis
        if outputs is None and not row.rerun:
            self.engine.counters['estimates'] += 1
            sample = EstimateSample(row.stamp_ns, estimate, innovation, estimator.covariance,
                                    covariance, nis)
        else:
            if not row.rerun:
                self.engine.counters['estimates'] += 1
            sample = SourceSample(row.stamp_ns, estimate.copy(), innovation,
                                  estimator.covariance, covariance, nis,
                                  None if outputs is None else update, row.rerun)
        if self.form == 'current':
            return [sample]
        self.engine.await_input(row.stamp_ns, sample, row.arrival_ns)
        return []

    def _delayed(self, sample: EstimateSample, u: np.ndarray) -> EstimateSample:
        """Return the prediction ``x[k+1|k]`` of a current sample, with the next input ``u``."""
        estimator = self.estimator
        interval = estimator.last_interval_ns
        prediction = estimator.predict(sample.stamp_ns + interval, u)
        return sample._replace(estimate=prediction.estimate,
                               covariance=prediction.covariance)

    def _publishable(self, estimate: np.ndarray, innovation: np.ndarray,
                     result: Optional[np.ndarray] = None) -> bool:
        """
        Whether an estimate may be returned; else count it and restart the estimator.

        ``result``, both together, is checked at once against the smaller limit first.
        """
        limits = self.limits
        if result is not None and within_limit(result, self._result_limit):
            return True
        if within_limit(estimate, limits.estimate) and within_limit(innovation,
                                                                    limits.innovation):
            return True
        self.engine.counters['estimate_reset'] += 1
        self.engine.events.append(
            ('estimate_reset', f'an estimate beyond its limit ({limits.estimate:g}, '
             f'innovation {limits.innovation:g}) was not published; the estimator restarts '
             f'from its initial state'))
        self.estimator.reset()
        return False

    # --- the steady fast path (SteadySteps) ----------------------------------------------

    def prepare(self) -> None:
        """
        Let the estimator make the next step's known part now, if the input is there.

        Call it when nothing waits (after publishing an estimate): the next measurement then
        costs less. The estimates are the same whether it is called or not.
        """
        self._steady_key = None
        if not self._fast:
            return
        stamp = self.estimator.stamp_ns
        engine = self.engine
        if stamp is None or engine.queue or not engine.ready(stamp):
            return
        inputs = engine.inputs
        index = inputs.index_at(stamp)
        u = inputs.values[index] if index >= 0 else engine.zero_input
        self.estimator.prepare(u, (self.limits.measurement, self._result_limit))
        if self.form != 'current':
            return
        if index >= 0:  # what the engine's input_for would say about the time bases
            offset = inputs.stamps[index] - stamp
            self._steady_key = (stamp, u, offset if -offset > engine.max_gap_ns else None)
        elif engine.autonomous:
            self._steady_key = (stamp, u, None)

    def _steady_step(self, stamp_ns: int, y: float, now_ns: Optional[int],
                     key: tuple) -> Optional[list]:
        """
        Take a one-output measurement in the prepared steady case, or return None.

        The engine's rules for this case (value, clock, stamp in sequence, input known: see
        :meth:`prepare`) and the estimator's prepared step give the numbers and counts of
        the general path without building arrays. None when the case does not hold: nothing
        was changed or counted, and the engine takes the measurement.
        """
        estimator = self.estimator
        engine = self.engine
        if (engine.queue or estimator.stamp_ns != key[0]
                or not within_limit(y, self.limits.measurement)
                or not in_sequence(stamp_ns - key[0], engine.max_gap_ns)
                or ahead_of_clock(stamp_ns, now_ns, engine.clock_tolerance_ns)):
            return None
        interval = stamp_ns - key[0]
        if engine.jumps_ahead(interval):
            return None  # the engine keeps the state before it (an early outlier?)
        prepared = estimator.advance_prepared(stamp_ns, y, key[1])
        if prepared is None:
            return None
        engine.took_steadily(interval)
        result, bounded = prepared
        limit = self._result_limit
        if not bounded and not (math.isfinite(sum(result)) and max(result) <= limit
                                and min(result) >= -limit):
            if not self._publishable(estimator.estimate, estimator.innovation):
                engine.counters['measurements'] += 1  # counted and restarted, as general
                return []
        self._steady += 1  # a measurement and an estimate (see counters)
        if key[2] is not None:
            engine.time_base_event(key[2])
        n = estimator.n_states
        return [EstimateSample(stamp_ns, result[:n], result[n:], estimator.covariance,
                               estimator.innovation_covariance)]

    # --- recorded streams ------------------------------------------------------------------

    def replay(self, input_stamps, inputs, stamps, outputs, input_arrivals=None,
               arrivals=None) -> ReplayArrays:
        """
        Run over whole recorded streams at once, as if every input had arrived in time.

        Gives what the node computes from the same messages when no input arrives later than
        the measurement after it (a recording played back): the engine's rules, so the
        estimates are equal bit for bit. Rows with a non-finite value are dropped and
        counted as ``malformed``, rows beyond the :class:`ValueLimits` as ``out_of_range``,
        and, with arrival times and a clock tolerance, rows stamped too far ahead of their
        arrival as ``future_stamp`` (the arrival time plays the receiver's clock).

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
        estimator, engine = self.estimator, self.engine
        n_outputs, n_inputs = estimator.n_outputs, estimator.n_inputs
        if engine.keeps_history:
            return self._replay_history(input_stamps, inputs, stamps, outputs, input_arrivals,
                                        arrivals)
        outputs = np.ascontiguousarray(outputs, dtype=float).reshape(-1, n_outputs)
        stamps = np.asarray(stamps, dtype=np.int64)
        input_stamps = np.asarray(input_stamps, dtype=np.int64)
        inputs = (np.ascontiguousarray(inputs, dtype=float).reshape(-1, n_inputs) if n_inputs
                  else np.zeros((len(input_stamps), 0)))  # m = 0: rows of nothing
        if len(stamps) != len(outputs) or len(input_stamps) != len(inputs):
            raise ValueError('replay: stamps and values differ in length')
        good_inputs, input_drops = engine.recorded_rows(inputs, input_stamps, input_arrivals,
                                                        self.limits.input)
        good, drops = engine.recorded_rows(outputs, stamps, arrivals, self.limits.measurement)
        jump = -engine.max_gap_ns
        looping = ((np.diff(stamps[good]) < jump).any()
                   or (np.diff(input_stamps[good_inputs]) < jump).any())
        if looping:
            if arrivals is None or input_arrivals is None:
                raise ValueError('replay: the stamps jump backwards (a looping recording); '
                                 'give the arrival times to replay it message by message')
            samples = engine.feed_in_arrival_order(input_stamps, inputs, stamps, outputs,
                                                   input_arrivals, arrivals)
            return replay_arrays(samples, estimator.n_states, n_outputs)
        counters = self.counters
        for key in drops:  # every kind named, zero included: replay reports them all
            counters[key] += input_drops[key] + drops[key]
        counters['inputs'] += len(input_stamps)
        counters['measurements'] += int((~good).sum())  # the dropped ones, as live
        engine.store_recorded_inputs(input_stamps[good_inputs], inputs[good_inputs])
        measured = stamps[good]
        if (self._fast and estimator.stamp_ns is None and len(measured)
                and in_sequence(np.diff(measured), engine.max_gap_ns).all()):
            steady = self._replay_steady(measured, outputs[good])
            if steady is not None:
                return steady
        samples = engine.process_recorded(measured, outputs[good])
        return replay_arrays(samples, estimator.n_states, n_outputs)

    def replay_events(self, events, causes: Optional[list] = None) -> list:
        """
        Feed recorded messages in the order given (a bag's), as live, then flush.

        The way to replay several measurement sources: each :class:`RecordedEvent` goes to
        :meth:`add_input` or :meth:`add_measurement` with its arrival time as the
        receiver's clock, so the estimates equal those of the live stream fed the same
        messages in the same order, bit for bit.

        Parameters
        ----------
        events : iterable of RecordedEvent
        causes : list, optional
            Extended with the event that returned each estimate (None: the final flush).

        Returns
        -------
        list of EstimateSample
            What the stream returned, in order (corrected ones included).

        """
        samples: list = []
        for event in events:
            source, stamp, values, arrival = event
            now = int(arrival) or None
            if source == INPUT:
                produced = self.add_input(stamp, values, now)
            else:
                produced = self.add_measurement(stamp, values, now, int(arrival), source)
            samples += produced
            if causes is not None:
                causes += [event] * len(produced)
        produced = self.flush()
        if causes is not None:
            causes += [None] * len(produced)
        return samples + produced

    def _replay_history(self, input_stamps, inputs, stamps, outputs, input_arrivals,
                        arrivals) -> ReplayArrays:
        """:meth:`replay` with a history: message by message, in arrival order when given."""
        engine, estimator = self.engine, self.estimator
        if len(engine.measurement_sources) > 1:
            raise ValueError('replay: several measurement sources; give the recording to '
                             'replay_events, message by message')
        name = engine.measurement_sources[0].name
        n_inputs = estimator.n_inputs
        outputs = np.ascontiguousarray(outputs, dtype=float).reshape(-1, estimator.n_outputs)
        inputs = (np.ascontiguousarray(inputs, dtype=float).reshape(-1, n_inputs) if n_inputs
                  else np.zeros((len(input_stamps), 0)))
        input_stamps = np.asarray(input_stamps, dtype=np.int64)
        stamps = np.asarray(stamps, dtype=np.int64)
        if len(stamps) != len(outputs) or len(input_stamps) != len(inputs):
            raise ValueError('replay: stamps and values differ in length')
        if arrivals is not None and input_arrivals is not None:
            order = sorted(
                [(int(t), 0, k) for k, t in enumerate(np.asarray(input_arrivals).tolist())]
                + [(int(t), 1, k) for k, t in enumerate(np.asarray(arrivals).tolist())])
            events = [RecordedEvent(INPUT, int(input_stamps[k]), inputs[k], t) if kind == 0
                      else RecordedEvent(name, int(stamps[k]), outputs[k], t)
                      for t, kind, k in order]
            return replay_arrays(self.replay_events(events), estimator.n_states,
                                 estimator.n_outputs)
        good, drops = engine.recorded_rows(inputs, input_stamps, None, self.limits.input)
        counters = self.counters
        counters.update(drops)
        counters['inputs'] += len(input_stamps)
        engine.store_recorded_inputs(input_stamps[good], inputs[good])
        samples = self.replay_events(RecordedEvent(name, stamp, y)
                                     for stamp, y in zip(stamps.tolist(), outputs))
        return replay_arrays(samples, estimator.n_states, estimator.n_outputs)

    def _replay_steady(self, stamps, outputs) -> Optional[ReplayArrays]:
        """
        Run measurements that all follow each other within the gap through the batch path.

        Every measurement is admitted, so each interval's input is known in advance
        (:meth:`EventEngine.steady_rows`). None (estimator untouched) when an estimate
        leaves its limit: the caller then takes the general path, which restarts the
        estimator there. Kept as it was: a constant-gain Kalman filter's covariance rows are
        the steady ``P`` for every row, where the general path has none at the first sample
        (so its arrays have none at all).
        """
        estimator = self.estimator
        count = len(stamps)
        rows = self.engine.steady_rows(stamps)
        saved = estimator.snapshot()
        estimates, innovations = estimator.advance_many(stamps, outputs, rows.held)
        limits = self.limits
        if not (rows_within(estimates, limits.estimate)[1].all()
                and rows_within(innovations, limits.innovation)[1].all()):
            estimator.restore(saved)
            return None
        counters = self.counters
        counters.update(rows.counts)
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
            counters.update(rows.following_counts)
            arrays = self._delayed_rows(arrays, stamps, rows.following)
        return arrays

    def _delayed_rows(self, arrays: ReplayArrays, stamps, following) -> ReplayArrays:
        """Return batch rows in the delayed form, each predicted as :meth:`_delayed` does."""
        estimator = self.estimator
        intervals = np.concatenate([[0], np.diff(stamps)]).tolist()
        estimates = np.empty_like(arrays.estimates)
        covariances = None if arrays.covariances is None else np.empty(arrays.covariances.shape)
        for k, (x, interval) in enumerate(zip(arrays.estimates, intervals)):
            covariance = None if covariances is None else arrays.covariances[k]
            predicted = estimator.prediction(x, covariance, int(interval), following[k])
            estimates[k] = predicted.estimate
            if covariances is not None:
                covariances[k] = predicted.covariance
        return ReplayArrays(arrays.stamps_ns, estimates, arrays.innovations, covariances,
                            arrays.innovation_covariances, arrays.nis)
