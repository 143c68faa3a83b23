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
from typing import Optional

import numpy as np

from observer_ros.core.events.records import Event, HistoryEntry, Row, Source
from observer_ros.core.rules import in_sequence


class History:
    """The history (several sources or a history span): entries, re-runs, pruning."""

    def _add_to_history(self, spec: Source, stamp_ns: int, vector: np.ndarray,
                        now_ns: Optional[int], arrival_ns: int) -> list:
        """:meth:`add_measurement` with a history: the values in ascending output order."""
        self.per_source[spec.name]['received'] += 1
        if not self.accept(spec, stamp_ns, vector, now_ns):
            return []
        values = vector[spec.order] if spec.order is not None else vector.copy()
        if not self.queue:  # the common case: process()'s routine for a queue of one
            previous = self.consumer.stamp_ns
            if (previous is not None and in_sequence(stamp_ns - previous, self.max_gap_ns)
                    and self.ready(stamp_ns if self.pairs_at_stamp else previous)):
                self._sequence += 1
                event = Event(spec.name, stamp_ns, values, self._sequence, arrival_ns)
                return self._take_new(event, self.input_for(previous), stamp_ns - previous)
        self._enqueue(spec.name, stamp_ns, values, arrival_ns)
        return self.process(force=False)

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
