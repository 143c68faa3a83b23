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

"""The event engine: stamped events in, rows out, by the parts of the package."""

from collections import Counter
from typing import Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.events.admission import Admission
from observer_ros.core.events.history import History
from observer_ros.core.events.inputs import InputPairing
from observer_ros.core.events.records import (
    Event, INPUT, MEASUREMENT, PREDICTION, Row, RowCollector, Source, SourceStatus)
from observer_ros.core.events.replay import RecordedEvents
from observer_ros.core.events.rollback import NewestRollback
from observer_ros.core.rules import in_sequence, InputHistory, ValueLimits
from observer_ros.core.sources import check_sources, default_source, MeasurementSource


class EventEngine(Admission, InputPairing, RecordedEvents):
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
    timeline : History or NewestRollback
        The part chosen by it: the history, or the one row kept without one.
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
        self.input_stamped = input_stamped
        self.clock_tolerance_ns = int(clock_tolerance_ns)
        self.consumer = consumer if consumer is not None else RowCollector()
        #: The part that keeps what was taken, chosen once: the history, or the one row.
        self.timeline = (History(self, measured) if self.keeps_history
                         else NewestRollback(self))
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

    def add_input(self, stamp_ns: int, u, now_ns: Optional[int] = None,
                  source: str = INPUT) -> list:
        """
        Store an input; return what the measurements it releases give.

        ``now_ns`` is the receiver's clock at arrival, for the clock tolerance (None: no
        check).
        """
        spec = self.sources.get(source)
        if spec is None or spec.role != 'input':
            spec = self._source(source, 'input')  # says what is expected
        self.counters['inputs'] += 1
        stamp_ns = int(stamp_ns)
        vector = np.array(u, dtype=float)
        if vector.ndim != 1:
            vector = vector.reshape(-1)
        if not self.accept(spec, stamp_ns, vector, now_ns):
            return []
        self.inputs.store(stamp_ns, vector)
        self.inputs_absent = self.autonomous
        previous = self.consumer.stamp_ns
        timeline = self.timeline
        if previous is None or stamp_ns >= previous - self.max_gap_ns:
            # Not while a backward jump (a looping bag) is under way; with a history, keep
            # the inputs of its rows (without one, of the newest row that may be re-taken).
            self.inputs.prune(timeline.oldest_previous(previous))
        arrived = timeline.input_arrived(stamp_ns, previous)
        if not self.queue:  # nothing waits: nothing more for process() to take
            return arrived
        return arrived + self.process(force=False)

    def add_measurement(self, stamp_ns: int, y, now_ns: Optional[int] = None,
                        arrival_ns: int = 0, source: str = MEASUREMENT) -> list:
        """
        Take a measurement; return what it (and what it releases) gives now.

        ``now_ns`` is the receiver's clock at arrival (see :meth:`add_input`);
        ``arrival_ns`` any monotonic arrival time the caller wants back from :meth:`waiting`.
        """
        spec = self.sources.get(source)
        if spec is None or spec.role != 'measurement':
            spec = self._source(source, 'measurement')  # says what is expected
        self.counters['measurements'] += 1
        stamp_ns = int(stamp_ns)
        vector = np.asarray(y, dtype=float)  # copied if it is kept
        if vector.ndim != 1:
            vector = vector.reshape(-1)
        return self.timeline.measurement(spec, stamp_ns, vector, now_ns, int(arrival_ns))

    def _enqueue(self, source: str, stamp_ns: int, values, arrival_ns: int) -> None:
        """
        Queue an event: the ordering rule (the stamp rules come after).

        Arrival order; with a history, stamp order (then arrival order), so that what
        waits for its input is taken oldest first and a late sample goes ahead of it.
        """
        self._sequence += 1
        self.timeline.order(self.queue, Event(source, stamp_ns, values, self._sequence,
                                              arrival_ns))

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
            if event.source == PREDICTION:  # the delayed form: never with a history
                produced += self.consumer.take(Row(event.source, event.stamp_ns, event.values,
                                                   u, interval, event.arrival_ns))
            else:
                produced += self.timeline.taken(event, u, interval)
        return produced

    def source_report(self, now_ns: Optional[int] = None) -> dict:
        """
        Return ``{source name: SourceStatus}``: counts, last sample, age and staleness.

        ``now_ns``: the receiver's clock, for the age and the timeout (None: no age).
        Without a history (one source, history 0) the one source's counts are the
        engine's own.
        """
        report = {}
        for source in self.measurement_sources:
            counts, last = self.timeline.source_counts(source.name)
            age = None if last is None or not now_ns else now_ns - last[0]
            stale = bool(source.timeout_ns and (last is None or age is not None
                                                and age > source.timeout_ns))
            report[source.name] = SourceStatus(
                +counts, None if last is None else last[0], None if last is None else last[1],
                age, stale, int(self.timeline.max_lag[source.name]))
        return report

    # --- the part chosen: what the engine says of it --------------------------------------

    @property
    def entries(self):
        """The history, in stamp order (empty without one): :class:`HistoryEntry` s."""
        return self.timeline.entries

    @property
    def retired(self) -> Optional[list]:
        """None, or a list that collects each entry leaving the history, oldest first."""
        return self.timeline.retired

    @retired.setter
    def retired(self, value: Optional[list]) -> None:
        self.timeline.retired = value

    @property
    def per_source(self) -> dict:
        """``{source name: Counter}`` with a history (empty without one)."""
        return self.timeline.per_source

    def clear_history(self) -> None:
        """Forget the history, or the row kept (the consumer starts again)."""
        self.timeline.clear()

    def history_depth(self) -> tuple:
        """Return ``(entries, span_ns)``: the history in use, and the stamps it spans."""
        return self.timeline.depth()

    def jumps_ahead(self, interval_ns: int) -> bool:
        """Whether a row of this interval is taken with the state before it kept (fast paths)."""
        return self.timeline.jumps_ahead(interval_ns)

    def took_steadily(self, interval_ns: int) -> None:
        """Note a row a fast path took itself (not a jump ahead)."""
        self.timeline.took_steadily(interval_ns)
