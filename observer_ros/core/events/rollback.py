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

from observer_ros.core.events.records import Event, JUMP_FACTOR, Row


class NewestRollback:
    """The rule kept for one row without a history (the package notes)."""

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
