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

"""Without a history, the one row kept: a jump ahead taken with the state before it."""

from collections import Counter
from typing import Optional

import numpy as np

from observer_ros.core.events.records import Event, JUMP_FACTOR, LATE, Row, Source
from observer_ros.core.rules import in_sequence


class NewestRollback:
    """
    Without a history, the one row kept: a jump ahead taken with the state before it (a part).

    The engine holds this part when it keeps no history, a
    :class:`~observer_ros.core.events.history.History` otherwise; both answer the same verbs.
    """

    #: Nothing is kept, nothing is collected: the history's attributes, empty.
    entries: tuple = ()
    retired = None

    def __init__(self, engine) -> None:
        self.engine = engine
        consumer = engine.consumer
        self.can_roll_back = hasattr(consumer, 'save') and hasattr(consumer, 'load')
        #: ``(state before the newest row, that row)`` after a jump ahead (see the package
        #: notes), else None; and the interval of the last row taken.
        self._rollback: Optional[tuple] = None
        self._last_interval = 0
        self.per_source: dict = {}
        self.max_lag: Counter = Counter()

    def measurement(self, spec: Source, stamp_ns: int, vector: np.ndarray,
                    now_ns: Optional[int], arrival_ns: int) -> list:
        """Take a sample of :meth:`EventEngine.add_measurement` without a history."""
        engine = self.engine
        if not engine.accept(spec, stamp_ns, vector, now_ns):
            return []
        if not engine.queue:  # the common case: the queue's routine for a queue of one
            previous = engine.consumer.stamp_ns
            if (previous is not None and in_sequence(stamp_ns - previous, engine.max_gap_ns)
                    and engine.ready(stamp_ns if engine.pairs_at_stamp else previous)):
                produced = self.take(Row(spec.name, stamp_ns, vector,
                                         engine.input_for(previous), stamp_ns - previous,
                                         arrival_ns))
                return produced + engine.process(force=False) if engine.queue else produced
        engine._enqueue(spec.name, stamp_ns, vector.copy(), arrival_ns)
        return engine.process(force=False)

    def order(self, queue: list, event: Event) -> None:
        """Queue ``event`` in arrival order: the ordering rule without a history."""
        queue.append(event)

    def oldest_previous(self, previous: Optional[int]) -> Optional[int]:
        """Return the earliest stamp whose held input may be needed (the newest row's)."""
        rollback = self._rollback
        return previous if rollback is None else rollback[1].stamp_ns - rollback[1].interval_ns

    def input_arrived(self, stamp_ns: int, previous: Optional[int]) -> list:
        """Take the newest row again if a late input changes it (see :meth:`_retake_for_input`)."""
        if self._rollback is not None and stamp_ns < previous:
            return self._retake_for_input(stamp_ns)
        return []

    def taken(self, event: Event, u: np.ndarray, interval: int) -> list:
        """Take an admitted measurement, or insert a late one before the newest row."""
        if interval == LATE:
            return self._insert_before_newest(event)
        return self.take(Row(event.source, event.stamp_ns, event.values, u, interval,
                             event.arrival_ns))

    def admit_back(self, event: Event, previous: int, step: int) -> Optional[int]:
        """Apply the stamp rules to a repeated stamp or a small step back: dropped, or LATE."""
        engine = self.engine
        stamp = event.stamp_ns
        if step == 0:
            engine.counters['duplicate'] += 1
            engine.events.append(('duplicate', f'dropped a measurement with a repeated '
                                  f'stamp ({stamp} ns)'))
            return None
        rollback = self._rollback
        if rollback is not None and stamp > rollback[1].stamp_ns - rollback[1].interval_ns:
            return LATE  # after a jump ahead: inserted before it (the package notes)
        engine.counters['out_of_order'] += 1
        engine.events.append(('out_of_order', f'dropped a measurement older than the '
                              f'previous one ({stamp} < {previous} ns)'))
        return None

    def restarted(self, stamp_ns: int) -> None:
        """Nothing to forget at a restart without a history."""

    def clear(self) -> None:
        """Forget the row kept (the consumer starts again)."""
        self._rollback, self._last_interval = None, 0

    def depth(self) -> tuple:
        """No history: ``(0, 0)``."""
        return 0, 0

    def source_counts(self, name: str) -> tuple:
        """Return ``(counts, (last stamp, 0) or None)`` of the one source: the engine's own."""
        counters = self.engine.counters
        counts = Counter({key: counters[key] for key in (
            'malformed', 'out_of_range', 'future_stamp', 'duplicate', 'out_of_order')})
        counts['received'] = counters['measurements']
        stamp = self.engine.consumer.stamp_ns
        return counts, None if stamp is None else (stamp, 0)

    def take(self, row: Row) -> list:
        """
        Take a measurement's row without a history (the one rule kept: the module notes).

        A row whose interval exceeds :data:`JUMP_FACTOR` times the one before it is taken
        with the consumer's state before it kept, for :meth:`_insert_before_newest`.
        """
        interval = row.interval_ns
        if self.can_roll_back and interval > JUMP_FACTOR * self._last_interval > 0:
            self._rollback = (self.engine.consumer.save(), row)
        else:
            self._rollback = None
        self._last_interval = interval
        return self.engine.consumer.take(row)

    def jumps_ahead(self, interval_ns: int) -> bool:
        """Whether :meth:`take` keeps the state before a row of this interval (fast paths ask)."""
        return self.can_roll_back and interval_ns > JUMP_FACTOR * self._last_interval > 0

    def took_steadily(self, interval_ns: int) -> None:
        """Note a row a fast path took itself, as :meth:`take` notes it (not a jump ahead)."""
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
        consumer = self.engine.consumer
        consumer.load(state)
        consumer.take(Row(event.source, stamp, event.values, self.engine.input_for(previous),
                          stamp - previous, event.arrival_ns, rerun=True))
        if consumer.stamp_ns is None:  # the consumer restarted from its initial state
            newest = newest._replace(u=self.engine.zero_input, interval_ns=0, rerun=True)
        else:
            newest = newest._replace(u=self.engine.input_for(stamp),
                                     interval_ns=newest.stamp_ns - stamp, rerun=True)
        self._rollback = (consumer.save(), newest)
        self._last_interval = newest.interval_ns
        produced = consumer.take(newest)
        counters = self.engine.counters
        counters['reruns'] += 1
        counters['rerun_rows'] += 2
        counters['corrected'] += len(produced)
        return produced

    def _retake_for_input(self, stamp_ns: int) -> list:
        """
        Take the newest row again when a late input is the one held at its previous stamp.

        Without a history, while :meth:`take` keeps the state before the newest row; the
        counterpart of :meth:`_rerun_for_input`.
        """
        state, newest = self._rollback
        previous = newest.stamp_ns - newest.interval_ns
        index = self.engine.inputs.index_at(previous)
        if index < 0 or self.engine.inputs.stamps[index] != stamp_ns:
            return []  # a later input is held there, or it is stamped after the previous one
        self.engine.consumer.load(state)
        self.engine.counters['input_reruns'] += 1
        return self.engine.consumer.take(newest._replace(u=self.engine.input_for(previous),
                                                         rerun=True))
