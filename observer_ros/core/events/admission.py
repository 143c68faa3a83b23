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

"""The value, clock and stamp rules an event meets on its way in (the engine's admission)."""

from math import inf, isfinite
from typing import Optional

import numpy as np

from observer_ros.core.events.records import Event, Source
from observer_ros.core.rules import (
    ahead_of_clock, in_sequence, rows_within, SHORT, within_limit)


class Admission:
    """The value and clock rules on arrival and the stamp rules in the queue."""

    def accept(self, source: Source, stamp_ns: int, vector: np.ndarray,
               now_ns: Optional[int]) -> bool:
        """Apply the value and clock rules to one sample; False (counted) when dropped."""
        tolerance = self.clock_tolerance_ns
        if vector.shape == (source.size,) and (not tolerance or now_ns is None or now_ns <= 0
                                               or stamp_ns - now_ns <= tolerance):
            # within_limit's rule, its common case inline for a short vector: a finite sum
            # says that every value is finite, and the extremes are then compared (a list of
            # a few floats: faster than numpy's dot product); anything else, a longer vector
            # too, goes to the rule itself below.
            limit = source.limit
            if source.size <= SHORT:
                values = vector.tolist()
                if isfinite(sum(values)) and (limit == inf or -limit <= min(values, default=0.0)
                                              and max(values, default=0.0) <= limit):
                    return True  # the common case in one test; the reasons follow
        if (vector.shape == (source.size,) and within_limit(vector, source.limit)
                and not ahead_of_clock(stamp_ns, now_ns, tolerance)):
            return True
        what = source.what
        per = self.timeline.per_source.get(source.name)
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

    def _admit(self, event: Event, previous: Optional[int]) -> Optional[int]:
        """
        Apply the stamp rules to a measurement: its interval, 0 to start here, None: dropped.

        Without a history a repeated stamp is a ``duplicate`` and a small step back is
        ``out_of_order``; with one, a measurement inside the history is :data:`LATE` (to
        insert) unless its source's sample at that stamp is there already.
        """
        if previous is None:
            return 0
        stamp = event.stamp_ns
        step = stamp - previous
        if in_sequence(step, self.max_gap_ns):
            return step
        if -self.max_gap_ns <= step <= 0:  # the part's rule: dropped, or LATE to insert
            return self.timeline.admit_back(event, previous, step)
        kind = 'restart_backward_jump' if step < 0 else 'restart_gap'
        self.counters[kind] += 1
        if step < 0:  # inputs of the abandoned timeline must not pair with the new one
            self.inputs.drop_after(stamp)
        self.timeline.restarted(stamp)
        self.events.append((kind, f'time jumped by {step / 1e9:.3f} s; the estimator '
                            f'restarts from this sample'))
        return 0
