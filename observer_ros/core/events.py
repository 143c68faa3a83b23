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
Stamped events to rows: the value, clock, stamp and pairing rules, each written once.

An event is one sample of a source: a measurement source (today one, ``y``, carrying every
output of the model) or an input source (today one, ``u``). :class:`EventEngine` turns the
events into :class:`Row` s ``(stamp, y, u, interval)`` for whatever consumes them (the
:class:`~observer_ros.core.streaming.EventStream` runs an estimator on each), and counts
every event it drops:

* on arrival, :meth:`EventEngine.accept` applies the value rules (the source's size, finite,
  within the :class:`~observer_ros.core.rules.ValueLimits`) and the clock rule (see
  :mod:`observer_ros.core.rules`);
* inputs are kept in stamp order (:class:`~observer_ros.core.rules.InputHistory`);
  measurements wait in one queue (:meth:`EventEngine._enqueue`, the one ordering rule:
  arrival order);
* :meth:`EventEngine.process`, the one processing routine, takes the queue in order and
  applies the stamp rules (:meth:`EventEngine._admit`: a repeated stamp or a small step back
  is dropped, a gap or a backward jump longer than ``max_gap_ns`` starts again) and the
  pairing rule: the input of the interval ending at measurement ``k`` is the latest one
  stamped at or before measurement ``k-1`` (``InputHistory.index_at``), so a future
  input never leaks into the past; a measurement whose input may still be on its way waits
  until an input stamped at or after the previous measurement arrives, or a flush. With a
  feedthrough (:attr:`EventEngine.pairs_at_stamp`) the consumer also needs the input in
  effect at the measurement's own stamp (the same rule at that stamp), so the measurement
  waits for an input stamped at or after it.

Several measurement sources and late measurements (the history). Each
:class:`~observer_ros.core.sources.MeasurementSource` names the outputs it carries; its
samples are rows with those ``outputs`` (``None``: every output). With several sources, or a
``history_ns`` above 0, the engine keeps a history (robot_localization's
``smooth_lagged_data``): every measurement processed in the last ``history_ns`` with the
consumer's state before it (:class:`HistoryEntry`), and the inputs it needs. Then the queue
is in stamp order (:meth:`EventEngine._enqueue`), and a measurement older than the newest
processed one (the ``out_of_order`` branch of :meth:`EventEngine._admit`) is no longer
dropped: :meth:`EventEngine._rerun` inserts it in stamp order (or fuses it with the
measurement of another source at the same stamp: one update with the outputs of both),
returns the consumer to its state before it and runs the rows after it again with their
inputs. What a re-run returns is what the newest row gives: the corrected newest estimate,
at the newest stamp (a row with ``rerun`` set). A measurement older than the history is
dropped and counted (``too_old``; ``out_of_order`` with a history of 0), as is one from a
source whose sample at that stamp is already in the history (``duplicate``). A source's
fixed latency moves its stamps back by it and takes the same path. With one source and no
history no history is kept, a late measurement is dropped (``out_of_order``), and the queue
is in arrival order, with one exception, the history's rule kept for one row: a measurement
stamped more than :data:`JUMP_FACTOR` times the interval before it ahead of the previous one
(an early-stamped outlier, or a real gap) is taken with the consumer's state before it kept
(:meth:`EventEngine._take`); a measurement stamped between the previous one and it is then
inserted before it (:meth:`EventEngine._insert_before_newest`): the consumer returns to that
state, takes the late measurement, then the newest again, and what it returns is the
corrected newest estimate, at the newest stamp, as with a history. So one early outlier never
silences the genuine samples after it; once their stamps pass it they follow on again.
"""

import bisect
from collections import Counter
from typing import Any, NamedTuple, Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.rules import (
    ahead_of_clock, in_sequence, InputHistory, rows_within, ValueLimits, within_limit)
from observer_ros.core.sources import check_sources, default_source, MeasurementSource

__all__ = ['Event', 'EventEngine', 'HistoryEntry', 'INPUT', 'InputHistory', 'MEASUREMENT',
           'MeasurementSource', 'PREDICTION', 'Row', 'RowCollector', 'Source', 'SourceStatus',
           'SteadyRows', 'ValueLimits', 'ahead_of_clock', 'in_sequence', 'rows_within',
           'within_limit']

#: The one measurement source and the one input source of today's configurations.
MEASUREMENT, INPUT = 'y', 'u'

#: Source of a queued prediction: an estimate waiting for the input after it (delayed form).
PREDICTION = 'prediction'

#: What :meth:`EventEngine._admit` says of a measurement to insert through the history.
LATE = -1

#: Without a history, a row whose interval exceeds this many times the interval before it is
#: taken with the consumer's state before it kept, so that the measurements stamped before
#: it (it may be an early-stamped outlier) are inserted, not dropped (the module notes).
JUMP_FACTOR = 2


class Source(NamedTuple):
    """
    A source of events: its name, role, size and value limit.

    ``outputs`` (measurement sources): the model outputs it carries, in its order;
    ``sorted_outputs`` in ascending order, ``order`` the permutation that puts its values in
    that order (None: they are), ``latency_ns`` its fixed latency.
    """

    name: str
    role: str
    size: int
    limit: float
    what: str
    outputs: tuple = ()
    sorted_outputs: tuple = ()
    order: Optional[list] = None
    latency_ns: int = 0


class Event(NamedTuple):
    """A queued event: source, stamp, values, sequence number and arrival time."""

    source: str
    stamp_ns: int
    values: Any
    sequence: int
    arrival_ns: int


class Row(NamedTuple):
    """
    What a consumer runs: a measurement ``y`` at ``stamp_ns`` with the input ``u`` held.

    ``interval_ns`` is the step from the previous row, 0 where the estimate starts (the
    first row, or after a gap or a backward jump). A ``PREDICTION`` row carries, in ``y``,
    the estimate to predict over the next interval with ``u``. ``outputs``: the ascending
    output indices ``y`` holds (None: every output, in order); ``source`` names its
    source(s), joined by ``+`` when the samples of several sources at one stamp are fused.
    ``rerun``: the row is taken again after a late measurement (see :meth:`EventEngine._rerun`).
    """

    source: str
    stamp_ns: int
    y: Any
    u: np.ndarray
    interval_ns: int
    arrival_ns: int
    outputs: Optional[tuple] = None
    rerun: bool = False


class HistoryEntry:
    """
    One processed stamp of the history: the samples taken there and what it gave.

    Attributes
    ----------
    stamp_ns : int
    parts : dict
        ``{source name: (values in ascending output order, arrival_ns)}``.
    state : object
        The consumer's state before the row (``consumer.save()``), to re-run from.
    result : object
        What the consumer's ``take`` gave last for the row (its last item, or None).
    """

    __slots__ = ('stamp_ns', 'parts', 'state', 'result')

    def __init__(self, stamp_ns: int, parts: dict) -> None:
        self.stamp_ns = stamp_ns
        self.parts = parts
        self.state = None
        self.result = None


class SourceStatus(NamedTuple):
    """
    What the engine knows of one measurement source (for its health).

    ``counts``: ``received``, ``used`` (taken in order or inserted), ``reruns`` (inserted
    late), and the drops by reason (``malformed``, ``out_of_range``, ``future_stamp``,
    ``duplicate``, ``too_old`` / ``out_of_order``); ``last_stamp_ns`` and
    ``last_arrival_ns`` of its last sample taken (None before one); ``age_ns`` the clock
    minus that stamp (None without a clock or a sample); ``stale`` when the age exceeds the
    source's timeout; ``max_lag_ns`` how far behind the newest stamp its latest insertion
    reached (the history depth it uses).
    """

    counts: Counter
    last_stamp_ns: Optional[int]
    last_arrival_ns: Optional[int]
    age_ns: Optional[int]
    stale: bool
    max_lag_ns: int


class RowCollector:
    """A consumer that keeps the rows (the engine alone: events in, rows out)."""

    def __init__(self) -> None:
        self.stamp_ns: Optional[int] = None
        self.rows: list = []

    def take(self, row: Row) -> list:
        """Keep ``row``; it is the last processed stamp now."""
        self.stamp_ns = row.stamp_ns
        self.rows.append(row)
        return [row]

    def save(self) -> Optional[int]:
        """Return the state to re-run from: the last processed stamp."""
        return self.stamp_ns

    def load(self, state: Optional[int]) -> None:
        """Return to a state of :meth:`save` (the rows taken are kept)."""
        self.stamp_ns = state


class SteadyRows(NamedTuple):
    """Rows of a recording whose stamps all follow on: the inputs of each interval."""

    held: np.ndarray
    following: np.ndarray
    counts: Counter
    following_counts: Counter


class EventEngine:
    """
    Turn stamped measurement and input events into rows, by the rules of the module.

    Parameters
    ----------
    n_outputs, n_inputs : int
        Sizes of the measurement source ``y`` and the input source ``u``.
    max_gap_ns : int
        A forward gap or backward jump longer than this starts the estimate again.
    input_stamped : bool
        False when inputs are stamped on arrival (unstamped messages): then no measurement
        waits for a later input.
    clock_tolerance_ns : int
        A sample stamped more than this ahead of the ``now_ns`` given with it is dropped
        (``future_stamp``); 0 turns the check off.
    limits : ValueLimits, optional
    consumer : optional
        Takes each row (``take(row) -> list``) and says the last stamp it processed
        (``stamp_ns``: the previous measurement of the stamp and pairing rules); with a
        history also ``save() -> state`` and ``load(state)``, to re-run from a state.
        Default: a :class:`RowCollector`.
    sources : sequence of MeasurementSource, optional
        The measurement sources (checked by
        :func:`~observer_ros.core.sources.check_sources`). Default: one source ``y`` with
        every output.
    history_ns : int
        How far back a late measurement is still inserted in stamp order (at most
        ``max_gap_ns``). With several sources or a history above 0 the engine keeps one
        (see the module notes); one source and 0 (the default): none, as before.
    output_names : sequence of str, optional
        Names of the outputs, for the messages about sources.

    Attributes
    ----------
    counters : collections.Counter
        ``measurements``, ``inputs``, ``duplicate``, ``out_of_order``, ``restart_gap``,
        ``restart_backward_jump``, ``no_input``, ``late_input``, and the dropped samples:
        ``malformed`` (wrong size or not finite), ``out_of_range``, ``future_stamp``; with
        a history ``too_old`` (dropped, older than the history), ``reruns`` (late
        measurements inserted), ``rerun_rows`` (rows taken again) and ``corrected`` (what
        the re-runs returned).
    events : list of (str, str)
        ``(kind, text)`` of notable events since the caller last cleared it.
    keeps_history : bool
        Whether the engine keeps a history (several sources, or ``history_ns`` above 0).
    entries : list of HistoryEntry
        The history, in stamp order (empty without one).

    Examples
    --------
    >>> engine = EventEngine(n_outputs=1, n_inputs=1, max_gap_ns=10 ** 9)
    >>> engine.add_input(0, [0.5]), engine.add_measurement(0, [1.0])[0].interval_ns
    ([], 0)
    >>> [(row.stamp_ns, row.u.tolist(), row.interval_ns)
    ...  for row in engine.add_measurement(10, [2.0])]  # the input stamped 0 is held
    [(10, [0.5], 10)]
    >>> engine.add_measurement(20, [2.0])  # waits: an input stamped 10 .. 20 may come
    []
    >>> [(row.stamp_ns, row.u.tolist()) for row in engine.add_input(10, [1.5])]
    [(20, [1.5])]

    """

    def __init__(self, n_outputs: int, n_inputs: int, max_gap_ns: int,
                 input_stamped: bool = True, clock_tolerance_ns: int = 0,
                 limits: Optional[ValueLimits] = None, consumer=None,
                 sources: Optional[Sequence[MeasurementSource]] = None,
                 history_ns: int = 0, output_names: Optional[Sequence[str]] = None) -> None:
        self.limits = limits or ValueLimits()
        self.max_gap_ns = int(max_gap_ns)
        self.history_ns = int(history_ns)
        if not 0 <= self.history_ns <= self.max_gap_ns:
            raise ConfigError('history', f'expected 0 ... {self.max_gap_ns / 1e9:g} s (the gap '
                              f'limit, beyond which the estimate starts again), got '
                              f'{self.history_ns / 1e9:g} s')
        given = sources is not None
        measured = check_sources(sources if given else (default_source(n_outputs),),
                                 n_outputs, self.history_ns, output_names)
        self.n_outputs = n_outputs
        self.sources = {}
        for source in measured:
            if source.name in (INPUT, PREDICTION):
                raise ConfigError('sources', f'the name {source.name!r} is taken (inputs are '
                                  f'{INPUT!r}); expected another source name')
            order = sorted(range(len(source.outputs)), key=lambda k: source.outputs[k])
            self.sources[source.name] = Source(
                source.name, 'measurement', len(source.outputs), self.limits.measurement,
                f'a measurement of {source.name!r}' if given else 'a measurement',
                tuple(source.outputs), source.sorted_outputs,
                None if order == list(range(len(order))) else order, int(source.latency_ns))
        self.sources[INPUT] = Source(INPUT, 'input', n_inputs, self.limits.input, 'an input')
        self.measurement_sources = measured
        self.keeps_history = self.history_ns > 0 or len(measured) > 1
        self.entries: list = []
        #: None, or a list that collects each entry leaving the history (its estimate final:
        #: no later sample re-runs it), oldest first: the in-order estimates of a replay.
        self.retired: Optional[list] = None
        #: Without a history: ``(state before the newest row, that row)`` after a jump ahead
        #: (see the module notes), else None; and the interval of the last row taken.
        self._rollback: Optional[tuple] = None
        self._last_interval = 0
        self._base_ns: Optional[int] = None  # the last entry pruned: the first one's previous
        self._floor_ns: Optional[int] = None  # a restart: nothing before it is inserted
        self.per_source = {source.name: Counter() for source in measured}
        self._last_seen: dict = {}
        self._max_lag: Counter = Counter()
        self.input_stamped = input_stamped
        self.clock_tolerance_ns = int(clock_tolerance_ns)
        self.consumer = consumer if consumer is not None else RowCollector()
        self._can_roll_back = (not self.keeps_history and hasattr(self.consumer, 'save')
                               and hasattr(self.consumer, 'load'))
        self.counters: Counter = Counter()
        self.events: list = []
        self.inputs = InputHistory()
        self.queue: list = []
        self._sequence = 0
        self.zero_input = np.zeros(n_inputs)
        #: A model without inputs (m = 0): no measurement waits, none is short of an input.
        self.autonomous = n_inputs == 0
        self.inputs_absent = self.autonomous
        #: A row also uses the input held at its own stamp (a model with a feedthrough ``D``:
        #: ``D u`` with the input in effect at the measurement), so a measurement waits for
        #: an input stamped at or after its own stamp (or a flush), and with a history a
        #: late input re-runs the rows from the first stamped at or after it (set by the
        #: consumer).
        self.pairs_at_stamp = False

    # --- arrival ---------------------------------------------------------------------------

    def accept(self, source: Source, stamp_ns: int, vector: np.ndarray,
               now_ns: Optional[int]) -> bool:
        """Apply the value and clock rules to one sample; False (counted) when dropped."""
        tolerance = self.clock_tolerance_ns
        if (vector.shape == (source.size,) and within_limit(vector, source.limit)
                and not ahead_of_clock(stamp_ns, now_ns, tolerance)):
            return True  # the common case in one test; the reasons follow
        what = source.what
        per = self.per_source.get(source.name) if self.keeps_history else None
        reason = ('malformed' if vector.shape != (source.size,)
                  or not rows_within(vector, source.limit)[0]
                  else 'out_of_range' if not within_limit(vector, source.limit)
                  else 'future_stamp')
        if per is not None:
            per[reason] += 1
        if reason == 'malformed':
            self.counters['malformed'] += 1
            self.events.append(('malformed', f'dropped {what} {vector.tolist()}: expected '
                                f'{source.size} finite values'))
            return False
        if reason == 'out_of_range':
            self.counters['out_of_range'] += 1
            self.events.append(('out_of_range', f'dropped {what} {vector.tolist()}: a value '
                                f'exceeds the limit {source.limit:g} in magnitude'))
            return False
        self.counters['future_stamp'] += 1
        self.events.append(('future_stamp', f'dropped {what} stamped '
                            f'{(stamp_ns - now_ns) / 1e9:.6g} s ahead of the clock '
                            f'(tolerance {tolerance / 1e9:g} s)'))
        return False

    def _source(self, name: str, role: str) -> Source:
        source = self.sources.get(name)
        if source is None or source.role != role:
            known = [s.name for s in self.sources.values() if s.role == role]
            raise ValueError(f'source: expected one of the {role} sources {known}, got '
                             f'{name!r}')
        return source

    def add_input(self, stamp_ns: int, u, now_ns: Optional[int] = None,
                  source: str = INPUT) -> list:
        """
        Store an input; return what the measurements it releases give.

        ``now_ns`` is the receiver's clock at arrival, for the clock tolerance (None: no
        check).
        """
        spec = self._source(source, 'input')
        self.counters['inputs'] += 1
        stamp_ns = int(stamp_ns)
        vector = np.array(u, dtype=float).reshape(-1)
        if not self.accept(spec, stamp_ns, vector, now_ns):
            return []
        self.inputs.store(stamp_ns, vector)
        self.inputs_absent = self.autonomous
        previous = self.consumer.stamp_ns
        rollback = self._rollback
        if previous is None or stamp_ns >= previous - self.max_gap_ns:
            # Not while a backward jump (a looping bag) is under way; with a history, keep
            # the inputs of its rows (without one, of the newest row that may be re-taken).
            self.inputs.prune(self._oldest_previous() if self.keeps_history
                              else previous if rollback is None
                              else rollback[1].stamp_ns - rollback[1].interval_ns)
        if self.keeps_history and previous is not None and (
                stamp_ns < previous or self.pairs_at_stamp and stamp_ns == previous):
            return self._rerun_for_input(stamp_ns) + self.process(force=False)
        if rollback is not None and stamp_ns < previous:
            return self._retake_for_input(stamp_ns) + self.process(force=False)
        return self.process(force=False)

    def add_measurement(self, stamp_ns: int, y, now_ns: Optional[int] = None,
                        arrival_ns: int = 0, source: str = MEASUREMENT) -> list:
        """
        Take a measurement; return what it (and what it releases) gives now.

        ``now_ns`` is the receiver's clock at arrival (see :meth:`add_input`);
        ``arrival_ns`` any monotonic arrival time the caller wants back from :meth:`waiting`.
        """
        spec = self._source(source, 'measurement')
        self.counters['measurements'] += 1
        stamp_ns = int(stamp_ns)
        vector = np.asarray(y, dtype=float).reshape(-1)  # copied below if it has to wait
        if self.keeps_history:
            return self._add_to_history(spec, stamp_ns - spec.latency_ns, vector, now_ns,
                                        int(arrival_ns))
        if not self.accept(spec, stamp_ns, vector, now_ns):
            return []
        if not self.queue:  # the common case: the queue's routine for a queue of one
            previous = self.consumer.stamp_ns
            if (previous is not None and in_sequence(stamp_ns - previous, self.max_gap_ns)
                    and self.ready(stamp_ns if self.pairs_at_stamp else previous)):
                produced = self._take(Row(source, stamp_ns, vector, self.input_for(previous),
                                          stamp_ns - previous, int(arrival_ns)))
                return produced + self.process(force=False) if self.queue else produced
        self._enqueue(source, stamp_ns, vector.copy(), int(arrival_ns))
        return self.process(force=False)

    def _add_to_history(self, spec: Source, stamp_ns: int, vector: np.ndarray,
                        now_ns: Optional[int], arrival_ns: int) -> list:
        """:meth:`add_measurement` with a history: the values in ascending output order."""
        self.per_source[spec.name]['received'] += 1
        if not self.accept(spec, stamp_ns, vector, now_ns):
            return []
        values = vector[spec.order] if spec.order is not None else vector.copy()
        self._enqueue(spec.name, stamp_ns, values, arrival_ns)
        return self.process(force=False)

    def _enqueue(self, source: str, stamp_ns: int, values, arrival_ns: int) -> None:
        """
        Queue an event: the ordering rule (the stamp rules come after).

        Arrival order; with a history, stamp order (then arrival order), so that what
        waits for its input is taken oldest first and a late sample goes ahead of it.
        """
        self._sequence += 1
        event = Event(source, stamp_ns, values, self._sequence, arrival_ns)
        if self.keeps_history:
            bisect.insort(self.queue, event, key=lambda e: (e.stamp_ns, e.sequence))
        else:
            self.queue.append(event)

    def await_input(self, stamp_ns: int, estimate, arrival_ns: int) -> None:
        """Queue, first, an estimate waiting for the input after ``stamp_ns`` (delayed form)."""
        self._sequence += 1
        self.queue.insert(0, Event(PREDICTION, stamp_ns, estimate, self._sequence, arrival_ns))

    def waiting(self) -> Optional[tuple]:
        """``(sequence, arrival_ns)`` of the first event waiting for its input, or None."""
        return (self.queue[0].sequence, self.queue[0].arrival_ns) if self.queue else None

    def flush(self, first_only: bool = False) -> list:
        """
        Process waiting events with the inputs at hand.

        ``first_only``: only the first waits no longer; the ones after it are processed when
        their input is there (as :meth:`add_input` would).
        """
        if self.queue and not self.inputs.stamps:
            self.inputs_absent = True
        return self.process(force=True, first_only=first_only)

    # --- the one processing routine ------------------------------------------------------

    def process(self, force: bool = False, first_only: bool = False) -> list:
        """
        Take the queue in order as far as the inputs allow (all of it, with ``force``).

        ``force``: an event whose input has not come takes the latest earlier one now
        (``late_input``); ``first_only``: only for the first event.
        """
        produced = []
        queue = self.queue
        while queue:
            event = queue[0]
            if event.source == PREDICTION:
                previous = event.stamp_ns
                u = self._interval_input(previous, force)
                if u is None:
                    break
                interval = 0
            else:
                previous = self.consumer.stamp_ns
                if self.pairs_at_stamp and not (force or self.ready(event.stamp_ns)):
                    break  # D u: the input in effect at this stamp may still be on its way
                if previous is not None and in_sequence(event.stamp_ns - previous,
                                                        self.max_gap_ns):
                    u = self._interval_input(previous, force)
                    if u is None:
                        break
                else:
                    u = self.zero_input
                interval = self._admit(event, previous)
            force = force and not first_only
            queue.pop(0)
            if interval is None:
                continue
            if self.keeps_history:
                produced += (self._rerun(event) if interval == LATE
                             else self._take_new(event, u, interval))
            elif interval == LATE:
                produced += self._insert_before_newest(event)
            elif event.source == PREDICTION:
                produced += self.consumer.take(Row(event.source, event.stamp_ns, event.values,
                                                   u, interval, event.arrival_ns))
            else:
                produced += self._take(Row(event.source, event.stamp_ns, event.values, u,
                                           interval, event.arrival_ns))
        return produced

    # --- one row kept without a history --------------------------------------------------

    def _take(self, row: Row) -> list:
        """
        Take a measurement's row without a history (the one rule kept: the module notes).

        A row whose interval exceeds :data:`JUMP_FACTOR` times the one before it is taken
        with the consumer's state before it kept, for :meth:`_insert_before_newest`.
        """
        interval = row.interval_ns
        if self._can_roll_back and interval > JUMP_FACTOR * self._last_interval > 0:
            self._rollback = (self.consumer.save(), row)
        else:
            self._rollback = None
        self._last_interval = interval
        return self.consumer.take(row)

    def jumps_ahead(self, interval_ns: int) -> bool:
        """Whether :meth:`_take` keeps the state before a row of this interval (fast paths ask)."""
        return self._can_roll_back and interval_ns > JUMP_FACTOR * self._last_interval > 0

    def took_steadily(self, interval_ns: int) -> None:
        """Note a row a fast path took itself, as :meth:`_take` notes it (not a jump ahead)."""
        self._rollback = None
        self._last_interval = interval_ns

    def _insert_before_newest(self, event: Event) -> list:
        """
        Insert a measurement stamped before the newest row, after the one before it.

        The consumer returns to its state before the newest row, takes the late measurement
        (with the input held at the previous stamp), then the newest row again (with the
        input held at the late stamp); returns what the newest row gives, the corrected
        newest estimate. The state after the late measurement is kept for the next one.
        """
        state, newest = self._rollback
        previous = newest.stamp_ns - newest.interval_ns
        stamp = event.stamp_ns
        consumer = self.consumer
        consumer.load(state)
        consumer.take(Row(event.source, stamp, event.values, self.input_for(previous),
                          stamp - previous, event.arrival_ns, rerun=True))
        if consumer.stamp_ns is None:  # the consumer restarted from its initial state
            newest = newest._replace(u=self.zero_input, interval_ns=0, rerun=True)
        else:
            newest = newest._replace(u=self.input_for(stamp),
                                     interval_ns=newest.stamp_ns - stamp, rerun=True)
        self._rollback = (consumer.save(), newest)
        self._last_interval = newest.interval_ns
        produced = consumer.take(newest)
        counters = self.counters
        counters['reruns'] += 1
        counters['rerun_rows'] += 2
        counters['corrected'] += len(produced)
        return produced

    def _retake_for_input(self, stamp_ns: int) -> list:
        """
        Take the newest row again when a late input is the one held at its previous stamp.

        Without a history, while :meth:`_take` keeps the state before the newest row; the
        counterpart of :meth:`_rerun_for_input`.
        """
        state, newest = self._rollback
        previous = newest.stamp_ns - newest.interval_ns
        index = self.inputs.index_at(previous)
        if index < 0 or self.inputs.stamps[index] != stamp_ns:
            return []  # a later input is held there, or it is stamped after the previous one
        self.consumer.load(state)
        self.counters['input_reruns'] += 1
        return self.consumer.take(newest._replace(u=self.input_for(previous), rerun=True))

    def _admit(self, event: Event, previous: Optional[int]) -> Optional[int]:
        """
        Apply the stamp rules to a measurement: its interval, 0 to start here, None: dropped.

        Without a history a repeated stamp is a ``duplicate`` and a small step back is
        ``out_of_order``; with one, a measurement inside the history is :data:`LATE` (to
        insert, :meth:`_rerun`) unless its source's sample at that stamp is there already.
        """
        if previous is None:
            return 0
        stamp = event.stamp_ns
        step = stamp - previous
        if in_sequence(step, self.max_gap_ns):
            return step
        if self.keeps_history and -self.max_gap_ns <= step <= 0:
            return self._admit_late(event, previous)
        if step == 0:
            self.counters['duplicate'] += 1
            self.events.append(('duplicate', f'dropped a measurement with a repeated '
                                f'stamp ({stamp} ns)'))
            return None
        if -self.max_gap_ns <= step < 0:
            rollback = self._rollback
            if rollback is not None and stamp > rollback[1].stamp_ns - rollback[1].interval_ns:
                return LATE  # after a jump ahead: inserted before it (the module notes)
            self.counters['out_of_order'] += 1
            self.events.append(('out_of_order', f'dropped a measurement older than the '
                                f'previous one ({stamp} < {previous} ns)'))
            return None
        kind = 'restart_backward_jump' if step < 0 else 'restart_gap'
        self.counters[kind] += 1
        if step < 0:  # inputs of the abandoned timeline must not pair with the new one
            self.inputs.drop_after(stamp)
        if self.keeps_history:  # nothing before the restart is re-run
            self._retire(len(self.entries))
            self._base_ns, self._floor_ns = None, stamp
        self.events.append((kind, f'time jumped by {step / 1e9:.3f} s; the estimator '
                            f'restarts from this sample'))
        return 0

    def _admit_late(self, event: Event, previous: int) -> Optional[int]:
        """Apply the stamp rules to a measurement at or before the newest, with a history."""
        stamp, source = event.stamp_ns, event.source
        floor = self._floor_ns
        per = self.per_source[source]
        if stamp < previous - self.history_ns or (floor is not None and stamp < floor):
            kind = 'too_old' if self.history_ns else 'out_of_order'
            self.counters[kind] += 1
            per[kind] += 1
            self.events.append((kind, f'dropped a measurement of {source!r} stamped '
                                f'{(previous - stamp) / 1e9:.6g} s before the newest one, '
                                f'older than the history ({self.history_ns / 1e9:g} s)'))
            return None
        entries = self.entries
        index = bisect.bisect_left(entries, stamp, key=lambda entry: entry.stamp_ns)
        if index == len(entries):  # no history to insert into (a failed step cleared it)
            self.counters['out_of_order'] += 1
            per['out_of_order'] += 1
            return None
        if entries[index].stamp_ns == stamp and source in entries[index].parts:
            self.counters['duplicate'] += 1
            per['duplicate'] += 1
            self.events.append(('duplicate', f'dropped a measurement of {source!r} with a '
                                f'repeated stamp ({stamp} ns)'))
            return None
        return LATE

    # --- the history -----------------------------------------------------------------------

    def _row(self, entry: HistoryEntry, u: np.ndarray, interval: int, rerun: bool) -> Row:
        """Return the row of a history entry: its samples fused in ascending output order."""
        parts = entry.parts
        if len(parts) == 1:
            ((name, (values, arrival)),) = parts.items()
            outputs = self.sources[name].sorted_outputs
        else:
            names = sorted(parts, key=lambda key: self.sources[key].sorted_outputs[0])
            pairs = sorted((index, value) for key in names for index, value in
                           zip(self.sources[key].sorted_outputs, parts[key][0].tolist()))
            outputs = tuple(index for index, _ in pairs)
            values = np.array([value for _, value in pairs])
            name = '+'.join(names)
            arrival = max(part[1] for part in parts.values())
        return Row(name, entry.stamp_ns, values, u, interval, arrival,
                   None if len(outputs) == self.n_outputs else outputs, rerun)

    def _take_entry(self, entry: HistoryEntry, u: np.ndarray, interval: int,
                    rerun: bool) -> list:
        """Save the consumer's state, keep ``entry`` last in the history and take its row."""
        entry.state = self.consumer.save()
        self.entries.append(entry)
        try:
            produced = self.consumer.take(self._row(entry, u, interval, rerun))
        except Exception:  # noqa: B902 - whatever failed, the states kept may not follow on
            self.clear_history()
            raise
        entry.result = produced[-1] if produced else None
        if self.consumer.stamp_ns is None:  # the consumer restarted from its initial state
            self._retire(len(self.entries))
            self._base_ns = self._floor_ns = None
        return produced

    def _take_new(self, event: Event, u: np.ndarray, interval: int) -> list:
        """Take a measurement that follows on (or starts): a new newest entry."""
        entry = HistoryEntry(event.stamp_ns, {event.source: (event.values, event.arrival_ns)})
        self.per_source[event.source]['used'] += 1
        self._last_seen[event.source] = (event.stamp_ns, event.arrival_ns)
        produced = self._take_entry(entry, u, interval, False)
        self._prune()
        return produced

    def _rerun(self, event: Event) -> list:
        """
        Insert a late measurement in stamp order and take the rows from it on again.

        The consumer returns to its state before the late stamp (or before the measurement
        of another source at that stamp, which the late one joins: one update with the
        outputs of both); each row after it is taken again with the input held at the
        previous stamp. Returns what the newest row gives (the corrected newest estimate).
        """
        entries = self.entries
        stamp = event.stamp_ns
        index = bisect.bisect_left(entries, stamp, key=lambda entry: entry.stamp_ns)
        part = (event.values, event.arrival_ns)
        newest = entries[-1].stamp_ns
        if entries[index].stamp_ns == stamp:
            entries[index].parts[event.source] = part
            produced = self._run_again(index, None)
        else:
            produced = self._run_again(index, HistoryEntry(stamp, {event.source: part}))
        per = self.per_source[event.source]
        per['used'] += 1
        per['reruns'] += 1
        self._max_lag[event.source] = max(self._max_lag[event.source], newest - stamp)
        if stamp >= self._last_seen.get(event.source, (stamp, 0))[0]:
            self._last_seen[event.source] = (stamp, event.arrival_ns)
        return produced

    def _run_again(self, index: int, first: Optional[HistoryEntry]) -> list:
        """
        Take the rows of the history from ``index`` on again, ``first`` (if any) before them.

        The one re-run routine: the consumer returns to the state saved before the entry at
        ``index``; each row is taken again with the input held at the previous stamp.
        """
        entries = self.entries
        again = entries[index:]
        if first is not None:
            again.insert(0, first)
        self.consumer.load(entries[index].state)
        del entries[index:]
        previous = entries[-1].stamp_ns if entries else self._base_ns
        produced: list = []
        for entry in again:
            if previous is None or not self.entries and self.consumer.stamp_ns is None:
                u, interval = self.zero_input, 0
            else:
                u, interval = self.held_input(previous), entry.stamp_ns - previous
            produced = self._take_entry(entry, u, interval, True)
            previous = entry.stamp_ns
        counters = self.counters
        counters['reruns'] += 1
        counters['rerun_rows'] += len(again)
        counters['corrected'] += len(produced)
        return produced

    def _rerun_for_input(self, stamp_ns: int) -> list:
        """
        Take the rows whose input a late input changes again (with a history).

        A row's input is the one held at its previous stamp, so an input stamped
        ``stamp_ns`` changes the rows whose previous stamp lies between it and the next
        input: they are taken again from the first. Nothing to do in the usual case, an
        input stamped at or after the newest measurement. With :attr:`pairs_at_stamp` (a
        feedthrough) a row also uses the input held at its own stamp, so the re-run starts
        at the first row stamped at or after the input, if that input is held there.
        """
        entries = self.entries
        if self.pairs_at_stamp and entries and stamp_ns <= entries[-1].stamp_ns:
            index = bisect.bisect_left(entries, stamp_ns, key=lambda entry: entry.stamp_ns)
            if self.inputs.stamps[self.inputs.index_at(entries[index].stamp_ns)] == stamp_ns:
                self.counters['input_reruns'] += 1
                return self._run_again(index, None)
        if not entries or stamp_ns >= entries[-1].stamp_ns:
            return []
        if self._base_ns is not None and self._base_ns >= stamp_ns:
            first, previous = 0, self._base_ns
        else:
            index = bisect.bisect_left(entries, stamp_ns, key=lambda entry: entry.stamp_ns)
            first = index + 1
            if first >= len(entries):
                return []
            previous = entries[index].stamp_ns
        index = self.inputs.index_at(previous)
        if index < 0 or self.inputs.stamps[index] != stamp_ns:
            return []  # a later input is held there: this one changes no row taken
        self.counters['input_reruns'] += 1
        return self._run_again(first, None)

    def _prune(self) -> None:
        """Forget the entries older than the history (the newest is always kept)."""
        entries = self.entries
        horizon = entries[-1].stamp_ns - self.history_ns if entries else 0
        drop = 0
        while drop < len(entries) - 1 and entries[drop].stamp_ns < horizon:
            drop += 1
        if drop:
            self._base_ns = entries[drop - 1].stamp_ns
            self._retire(drop)

    def _retire(self, count: int) -> None:
        """Forget the oldest ``count`` entries, collected in :attr:`retired` when it is a list."""
        if self.retired is not None:
            self.retired.extend(self.entries[:count])
        del self.entries[:count]

    def _oldest_previous(self) -> Optional[int]:
        """Return the earliest stamp whose held input a re-run may need (the pruning point)."""
        if self._base_ns is not None:
            return self._base_ns
        return self.entries[0].stamp_ns if self.entries else self.consumer.stamp_ns

    def clear_inputs(self) -> None:
        """Forget every input, as at the start (a restart in another time)."""
        self.inputs = InputHistory()
        self.inputs_absent = self.autonomous

    def clear_history(self) -> None:
        """Forget the history (the consumer starts again: :meth:`EventStream.reset`)."""
        self._retire(len(self.entries))
        self._base_ns = self._floor_ns = None
        self._rollback, self._last_interval = None, 0

    def history_depth(self) -> tuple:
        """Return ``(entries, span_ns)``: the history in use, and the stamps it spans."""
        entries = self.entries
        if not entries:
            return 0, 0
        return len(entries), entries[-1].stamp_ns - entries[0].stamp_ns

    def source_report(self, now_ns: Optional[int] = None) -> dict:
        """
        Return ``{source name: SourceStatus}``: counts, last sample, age and staleness.

        ``now_ns``: the receiver's clock, for the age and the timeout (None: no age).
        Without a history (one source, history 0) the one source's counts are the
        engine's own.
        """
        report = {}
        for source in self.measurement_sources:
            if self.keeps_history:
                counts = Counter(self.per_source[source.name])
                last = self._last_seen.get(source.name)
            else:
                counters = self.counters
                counts = Counter({key: counters[key] for key in (
                    'malformed', 'out_of_range', 'future_stamp', 'duplicate', 'out_of_order')})
                counts['received'] = counters['measurements']
                stamp = self.consumer.stamp_ns
                last = None if stamp is None else (stamp, 0)
            age = None if last is None or not now_ns else now_ns - last[0]
            stale = bool(source.timeout_ns and (last is None or age is not None
                                                and age > source.timeout_ns))
            report[source.name] = SourceStatus(
                +counts, None if last is None else last[0], None if last is None else last[1],
                age, stale, int(self._max_lag[source.name]))
        return report

    # --- the pairing rule ----------------------------------------------------------------

    def ready(self, previous: int) -> bool:
        """Say whether the input of the interval after ``previous`` is known (or never comes)."""
        if not self.input_stamped or self.inputs_absent:
            return True
        stamps = self.inputs.stamps
        return bool(stamps) and stamps[-1] >= previous

    def input_for(self, previous: int) -> np.ndarray:
        """Return the input of the interval after ``previous`` (latest at or before it)."""
        stamps = self.inputs.stamps
        index = self.inputs.index_at(previous)
        if index < 0:
            if self.autonomous:
                return self.zero_input
            if stamps:
                self.counters['late_input'] += 1
                if stamps[0] - previous > self.max_gap_ns:
                    self.time_base_event(stamps[0] - previous)
            else:
                self.counters['no_input'] += 1
            return self.zero_input
        if previous - stamps[index] > self.max_gap_ns:
            self.time_base_event(stamps[index] - previous)
        return self.inputs.values[index]

    def held_input(self, stamp_ns: int) -> np.ndarray:
        """Return the latest input stamped at or before ``stamp_ns`` (zero before the first)."""
        index = self.inputs.index_at(stamp_ns)
        return self.inputs.values[index] if index >= 0 else self.zero_input

    def time_base_event(self, offset_ns: int) -> None:
        """Note inputs stamped further from the measurements than the gap limit."""
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
        ready = self.ready(previous)
        if not (force or ready):
            return None
        if not ready:
            self.counters['late_input'] += 1
        return self.input_for(previous)

    # --- recorded streams ----------------------------------------------------------------

    def recorded_rows(self, values: np.ndarray, stamps: np.ndarray, arrivals,
                      limit: float) -> tuple:
        """Rows of a recording the value and clock rules keep, and a Counter of the dropped."""
        finite, inside = rows_within(values, limit)
        if arrivals is not None:
            future = inside & ahead_of_clock(stamps, np.asarray(arrivals, dtype=np.int64),
                                             self.clock_tolerance_ns)
        else:
            future = np.zeros(len(values), dtype=bool)
        drops = Counter({'malformed': int((~finite).sum()),
                         'out_of_range': int((finite & ~inside).sum()),
                         'future_stamp': int(np.sum(future))})
        return inside & ~future, drops

    def store_recorded_inputs(self, stamps: np.ndarray, inputs: np.ndarray) -> None:
        """Store a recording's inputs, as if every one had arrived before any measurement."""
        self.inputs.store_many(stamps, inputs)
        if len(stamps):
            self.inputs_absent = self.autonomous
        if not self.inputs.stamps:
            self.inputs_absent = True  # as a live flush finds it: no input will come

    def process_recorded(self, stamps: np.ndarray, outputs: np.ndarray) -> list:
        """Process recorded measurements one by one, every input there: as live, in time."""
        produced = []
        for stamp, y in zip(stamps.tolist(), outputs):
            self.counters['measurements'] += 1
            self._enqueue(MEASUREMENT, stamp, y, 0)
            produced += self.process(force=True)
        return produced

    def feed_in_arrival_order(self, input_stamps, inputs, stamps, outputs, input_arrivals,
                              arrivals) -> list:
        """Feed a recording event by event in arrival order, as live, then flush."""
        events = sorted(
            [(int(t), 0, k) for k, t in enumerate(np.asarray(input_arrivals).tolist())]
            + [(int(t), 1, k) for k, t in enumerate(np.asarray(arrivals).tolist())])
        produced = []
        for arrival, kind, index in events:
            if kind == 0:
                produced += self.add_input(int(input_stamps[index]), inputs[index], arrival)
            else:
                produced += self.add_measurement(int(stamps[index]), outputs[index], arrival)
        return produced + self.flush()

    def steady_rows(self, stamps: np.ndarray) -> SteadyRows:
        """
        Pair recorded measurements whose stamps all follow on, at once (a private fast path).

        What :meth:`process` gives for them with every input stored and nothing waiting:
        ``held[k]`` the input of the interval ending at ``k`` (row 0: zero) and
        ``following[k]`` the one after ``k`` (the delayed form's prediction), with the
        ``late_input`` / ``no_input`` counts of the lookups (not yet added: the caller adds
        them if it takes the rows). Equal to the general path, as the engine's tests hold.
        """
        stamps_in = self.inputs.stamps
        pairing = self.inputs.indices_at(stamps)
        stack = np.vstack([self.zero_input, *self.inputs.values])
        following = stack[pairing + 1]
        held = np.concatenate([self.zero_input[None, :], following[:-1]])
        # The lookup after each row, as input_for and _interval_input count it.
        late = np.zeros(len(stamps), dtype=np.int64)
        counts, key = Counter(), None
        if self.autonomous:
            pass
        elif stamps_in:
            key = 'late_input'
            late += pairing < 0
            if self.input_stamped:
                late += stamps > stamps_in[-1]
        else:
            key = 'no_input'
            late += 1
        if key is not None:
            counts[key] = int(late[:-1].sum())  # the key even at zero, as replay reports it
        following_counts = +Counter({key: int(late.sum())}) if key else Counter()
        return SteadyRows(held, following, counts, following_counts)
