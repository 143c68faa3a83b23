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

"""The pairing rule: which input a measurement's interval takes, and when it is known."""

from bisect import bisect_right
from typing import Optional

import numpy as np

from observer_ros.core.rules import InputHistory


class InputPairing:
    """The pairing rule of the engine: the input of each interval."""

    def ready(self, previous: int) -> bool:
        """Say whether the input of the interval after ``previous`` is known (or never comes)."""
        if not self.input_stamped or self.inputs_absent:
            return True
        stamps = self.inputs.stamps
        return bool(stamps) and stamps[-1] >= previous

    def input_for(self, previous: int) -> np.ndarray:
        """Return the input of the interval after ``previous`` (latest at or before it)."""
        stamps = self.inputs.stamps
        index = bisect_right(stamps, previous) - 1  # InputHistory.index_at, one call less
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
        inputs = self.inputs
        index = bisect_right(inputs.stamps, stamp_ns) - 1  # InputHistory.index_at, inline
        return inputs.values[index] if index >= 0 else self.zero_input

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

    def clear_inputs(self) -> None:
        """Forget every input, as at the start (a restart in another time)."""
        self.inputs = InputHistory()
        self.inputs_absent = self.autonomous
