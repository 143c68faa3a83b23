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

"""Recorded streams through the engine: the value rules over arrays, steady pairing."""

from collections import Counter

import numpy as np

from observer_ros.core.events.records import MEASUREMENT, SteadyRows
from observer_ros.core.rules import ahead_of_clock, rows_within


class RecordedEvents:
    """Whole recordings through the engine's rules (the replay of a bag)."""

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
