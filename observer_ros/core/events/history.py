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

"""The history of processed measurements and the one re-run routine for late ones."""

import bisect
from collections import Counter
from typing import Optional

import numpy as np

from observer_ros.core.events.records import Event, HistoryEntry, LATE, Row, Source
from observer_ros.core.rules import in_sequence

#: ``new_tuple(Row, fields)`` makes a row of all eight fields without the named tuple's
#: Python-level ``__new__`` (a third of its cost; a row is made per update and re-run row).
new_tuple = tuple.__new__


class History:
    """
    The history of a stream of several sources, or of late measurements (a part).

    The engine holds this part when it keeps a history (:attr:`EventEngine.keeps_history`),
    a :class:`~observer_ros.core.events.rollback.NewestRollback` otherwise; both answer the
    same verbs (``measurement``, ``input_arrived``, ``order``, ``taken``, ``admit_back``,
    ``restarted``, ``clear``, ``depth``, ``source_counts``).
    """

    #: A fast path never takes a row with a history (see :meth:`NewestRollback.jumps_ahead`).
    can_roll_back = False

    def __init__(self, engine, sources: tuple) -> None:
        self.engine = engine
        self.entries: list = []
        #: None, or a list that collects each entry leaving the history (its estimate final:
        #: no later sample re-runs it), oldest first: the in-order estimates of a replay.
        self.retired: Optional[list] = None
        self._base_ns: Optional[int] = None  # the last entry pruned: the first one's previous
        self._floor_ns: Optional[int] = None  # a restart: nothing before it is inserted
        self.per_source = {source.name: Counter() for source in sources}
        self._last_seen: dict = {}
        self.max_lag: Counter = Counter()
        #: ``{source name: outputs of its rows alone}`` (None: every output), made once.
        self._row_outputs: dict = {}

    def order(self, queue: list, event: Event) -> None:
        """Queue ``event`` by stamp, then by arrival: the history's ordering rule."""
        bisect.insort(queue, event, key=lambda e: (e.stamp_ns, e.sequence))

    def input_arrived(self, stamp_ns: int, previous: Optional[int]) -> list:
        """Re-run the rows a late input changes (see :meth:`_rerun_for_input`)."""
        if previous is not None and (stamp_ns < previous or self.engine.pairs_at_stamp
                                     and stamp_ns == previous):
            return self._rerun_for_input(stamp_ns)
        return []

    def taken(self, event: Event, u: np.ndarray, interval: int) -> list:
        """Take an admitted measurement: a new newest entry, or a late one inserted."""
        if interval == LATE:
            return self._rerun(event)
        return self._take_new(event.source, event.stamp_ns, event.values, event.arrival_ns, u,
                              interval)

    def admit_back(self, event: Event, previous: int, step: int) -> Optional[int]:
        """Apply the stamp rules to a measurement at or before the newest, with a history."""
        engine = self.engine
        stamp, source = event.stamp_ns, event.source
        floor = self._floor_ns
        per = self.per_source[source]
        if stamp < previous - engine.history_ns or (floor is not None and stamp < floor):
            kind = 'too_old' if engine.history_ns else 'out_of_order'
            engine.counters[kind] += 1
            per[kind] += 1
            engine.events.append((kind, f'dropped a measurement of {source!r} stamped '
                                  f'{(previous - stamp) / 1e9:.6g} s before the newest one, '
                                  f'older than the history ({engine.history_ns / 1e9:g} s)'))
            return None
        entries = self.entries
        index = bisect.bisect_left(entries, stamp, key=lambda entry: entry.stamp_ns)
        if index == len(entries):  # no history to insert into (a failed step cleared it)
            engine.counters['out_of_order'] += 1
            per['out_of_order'] += 1
            return None
        if entries[index].stamp_ns == stamp and source in entries[index].parts:
            engine.counters['duplicate'] += 1
            per['duplicate'] += 1
            engine.events.append(('duplicate', f'dropped a measurement of {source!r} with a '
                                  f'repeated stamp ({stamp} ns)'))
            return None
        return LATE

    def restarted(self, stamp_ns: int) -> None:
        """Nothing before a restart at ``stamp_ns`` is re-run."""
        self._retire(len(self.entries))
        self._base_ns, self._floor_ns = None, stamp_ns

    def source_counts(self, name: str) -> tuple:
        """Return ``(counts, (last stamp, its arrival) or None)`` of a source."""
        return Counter(self.per_source[name]), self._last_seen.get(name)

    def jumps_ahead(self, interval_ns: int) -> bool:
        """Never: a row is kept in the history, not rolled back (the fast paths are off)."""
        return False

    def took_steadily(self, interval_ns: int) -> None:
        """Nothing to note: the fast paths are off with a history."""

    def measurement(self, spec: Source, stamp_ns: int, vector: np.ndarray,
                    now_ns: Optional[int], arrival_ns: int) -> list:
        """Take a sample of :meth:`EventEngine.add_measurement`, its latency off."""
        stamp_ns -= spec.latency_ns
        name = spec.name
        self.per_source[name]['received'] += 1
        engine = self.engine
        if not engine.accept(spec, stamp_ns, vector, now_ns):
            return []
        values = vector[spec.order] if spec.order is not None else vector.copy()
        if not engine.queue:  # the common case: process()'s routine for a queue of one
            previous = engine.consumer.stamp_ns
            if (previous is not None and in_sequence(stamp_ns - previous, engine.max_gap_ns)
                    and engine.ready(stamp_ns if engine.pairs_at_stamp else previous)):
                engine._sequence += 1  # the event's number, as if it had been queued
                return self._take_new(name, stamp_ns, values, arrival_ns,
                                      engine.input_for(previous), stamp_ns - previous)
        engine._enqueue(name, stamp_ns, values, arrival_ns)
        return engine.process(force=False)

    def _row(self, entry: HistoryEntry, u: np.ndarray, interval: int, rerun: bool) -> Row:
        """Return the row of a history entry: its samples fused in ascending output order."""
        parts = entry.parts
        if len(parts) == 1:
            ((name, (values, arrival)),) = parts.items()
            return new_tuple(Row, (name, entry.stamp_ns, values, u, interval, arrival,
                                   self._outputs_alone(name), rerun))
        names = sorted(parts, key=lambda key: self.engine.sources[key].sorted_outputs[0])
        pairs = sorted((index, value) for key in names for index, value in
                       zip(self.engine.sources[key].sorted_outputs, parts[key][0].tolist()))
        outputs = tuple(index for index, _ in pairs)
        values = np.array([value for _, value in pairs])
        name = '+'.join(names)
        arrival = max(part[1] for part in parts.values())
        return Row(name, entry.stamp_ns, values, u, interval, arrival,
                   None if len(outputs) == self.engine.n_outputs else outputs, rerun)

    def _outputs_alone(self, name: str) -> Optional[tuple]:
        """Return the outputs of a row of source ``name`` alone (None: every output)."""
        row_outputs = self._row_outputs
        if name not in row_outputs:
            outputs = self.engine.sources[name].sorted_outputs
            row_outputs[name] = None if len(outputs) == self.engine.n_outputs else outputs
        return row_outputs[name]

    def _take_entry(self, entry: HistoryEntry, row: Row) -> list:
        """Save the consumer's state, keep ``entry`` last in the history and take its row."""
        consumer = self.engine.consumer
        entry.state = consumer.save()
        self.entries.append(entry)
        try:
            produced = consumer.take(row)
        except Exception:  # noqa: B902 - whatever failed, the states kept may not follow on
            self.clear()
            raise
        entry.result = produced[-1] if produced else None
        if consumer.stamp_ns is None:  # the consumer restarted from its initial state
            self._retire(len(self.entries))
            self._base_ns = self._floor_ns = None
        return produced

    def _take_new(self, name: str, stamp_ns: int, values: np.ndarray, arrival_ns: int,
                  u: np.ndarray, interval: int) -> list:
        """Take a measurement of ``name`` that follows on (or starts): a new newest entry."""
        entry = HistoryEntry(stamp_ns, {name: (values, arrival_ns)})
        self.per_source[name]['used'] += 1
        self._last_seen[name] = (stamp_ns, arrival_ns)
        row_outputs = self._row_outputs  # made once per source (no call after the first)
        outputs = row_outputs[name] if name in row_outputs else self._outputs_alone(name)
        row = new_tuple(Row, (name, stamp_ns, values, u, interval, arrival_ns, outputs,
                              False))  # as _row's
        produced = self._take_entry(entry, row)
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
        self.max_lag[event.source] = max(self.max_lag[event.source], newest - stamp)
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
        self.engine.consumer.load(entries[index].state)
        del entries[index:]
        previous = entries[-1].stamp_ns if entries else self._base_ns
        produced: list = []
        engine = self.engine
        consumer, held_input, row_of, take = (engine.consumer, engine.held_input, self._row,
                                              self._take_entry)
        row_outputs = self._row_outputs
        for entry in again:
            stamp = entry.stamp_ns
            if previous is None or not entries and consumer.stamp_ns is None:
                u, interval = engine.zero_input, 0
            else:
                u, interval = held_input(previous), stamp - previous
            parts = entry.parts
            if len(parts) == 1 and next(iter(parts)) in row_outputs:  # _row's usual case
                ((name, (values, arrival)),) = parts.items()
                row = new_tuple(Row, (name, stamp, values, u, interval, arrival,
                                      row_outputs[name], True))
            else:
                row = row_of(entry, u, interval, True)
            produced = take(entry, row)
            previous = stamp
        counters = self.engine.counters
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
        if self.engine.pairs_at_stamp and entries and stamp_ns <= entries[-1].stamp_ns:
            index = bisect.bisect_left(entries, stamp_ns, key=lambda entry: entry.stamp_ns)
            inputs = self.engine.inputs
            if inputs.stamps[inputs.index_at(entries[index].stamp_ns)] == stamp_ns:
                self.engine.counters['input_reruns'] += 1
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
        index = self.engine.inputs.index_at(previous)
        if index < 0 or self.engine.inputs.stamps[index] != stamp_ns:
            return []  # a later input is held there: this one changes no row taken
        self.engine.counters['input_reruns'] += 1
        return self._run_again(first, None)

    def _prune(self) -> None:
        """Forget the entries older than the history (the newest is always kept)."""
        entries = self.entries
        if not entries:
            return
        horizon = entries[-1].stamp_ns - self.engine.history_ns
        if entries[0].stamp_ns >= horizon:
            return  # nothing older than the history (the entries are in stamp order)
        drop, newest = 1, len(entries) - 1  # the first goes (it is not the newest: see above)
        while drop < newest and entries[drop].stamp_ns < horizon:
            drop += 1
        self._base_ns = entries[drop - 1].stamp_ns
        self._retire(drop)

    def _retire(self, count: int) -> None:
        """Forget the oldest ``count`` entries, collected in :attr:`retired` when it is a list."""
        if self.retired is not None:
            self.retired.extend(self.entries[:count])
        del self.entries[:count]

    def oldest_previous(self, previous: Optional[int]) -> Optional[int]:
        """Return the earliest stamp whose held input a re-run may need (the pruning point)."""
        if self._base_ns is not None:
            return self._base_ns
        return self.entries[0].stamp_ns if self.entries else self.engine.consumer.stamp_ns

    def clear(self) -> None:
        """Forget the history (the consumer starts again: :meth:`EventStream.reset`)."""
        self._retire(len(self.entries))
        self._base_ns = self._floor_ns = None

    def depth(self) -> tuple:
        """Return ``(entries, span_ns)``: the history in use, and the stamps it spans."""
        entries = self.entries
        if not entries:
            return 0, 0
        return len(entries), entries[-1].stamp_ns - entries[0].stamp_ns
