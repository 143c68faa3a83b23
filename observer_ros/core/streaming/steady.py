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

"""The steady fast path of a stream: a prepared one-output step, taken as the engine would."""

import math
from typing import Optional

from observer_ros.core.estimates import EstimateSample
from observer_ros.core.rules import ahead_of_clock, in_sequence, within_limit


class SteadyPath:
    """The stream's steady fast path (estimators with SteadySteps)."""

    def prepare(self) -> None:
        """
        Let the estimator make the next step's known part now, if the input is there.

        Call it when nothing waits (after publishing an estimate): the next measurement then
        costs less. The estimates are the same whether it is called or not.
        """
        self._steady_key = self._prepared_at = None
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
        self._prepared_at = stamp
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
