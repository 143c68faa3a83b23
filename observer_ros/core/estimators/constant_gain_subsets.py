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

"""Updates of the constant-gain estimator with some of the outputs (SubsetUpdates)."""

from typing import Optional

import numpy as np

from observer_ros.core.errors import StampError
from observer_ros.core.estimators.intervals import IntervalCache
from observer_ros.core.estimators.protocol import SubsetUpdates
from observer_ros.core.estimators.steps import output_term, PredictOnlyStep, StepDesign


class ConstantGainSubsets(SubsetUpdates):
    """The constant-gain estimator's updates with some of the outputs (several sources)."""

    def _subset_outputs(self, design: StepDesign) -> Optional[tuple]:
        """Return the outputs of a subset's design (None: every output)."""
        for outputs, (subset, _) in self._subsets.items():
            if subset is design:
                return outputs
        return None

    def several_sources_problem(self) -> Optional[str]:
        """Say why the step design takes no several sources (None: it does)."""
        return self.design.several_sources_problem()

    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """Say why ``outputs`` alone cannot be updated with: the step design's answer."""
        if len(outputs) == self.n_outputs:
            return None
        problem = self.design.several_sources_problem()
        if problem is not None or not outputs:
            return problem
        return self.design.subset_problem(tuple(outputs))

    def _subset(self, outputs: tuple) -> tuple:
        """``(step design, interval cache)`` of an update with ``outputs`` (made on first use)."""
        subset = self._subsets.get(outputs)
        if subset is None:
            design = (PredictOnlyStep(self.design) if not outputs
                      else self.design.for_outputs(outputs))
            subset = (design, IntervalCache(design.step, self.intervals.size,
                                            self.intervals.resolution_ns))
            self._subsets[outputs] = subset
        return subset

    def advance_outputs(self, stamp_ns: int, y: np.ndarray, u: np.ndarray,
                        outputs: tuple) -> np.ndarray:
        """
        Take the values ``y`` of ``outputs``: the step designed for those outputs alone.

        Each subset of outputs has its own step design (:meth:`StepDesign.for_outputs`: a
        gain placed, or a Riccati equation solved, for those rows of ``C``), made on first
        use and cached per interval like the one of every output. Every output:
        :meth:`advance`; none: the prediction.
        """
        if len(outputs) == self.n_outputs:
            return self.advance(stamp_ns, y, u)
        design, cache = self._subset(outputs)
        self._prepared = None
        if self._stamp is None:
            return self._start_at(stamp_ns, y, design)
        dt_ns = stamp_ns - self._stamp
        if dt_ns <= 0:
            raise StampError(
                f'stamp {stamp_ns} ns is not after the previous sample ({self._stamp} ns)')
        step = cache.get(dt_ns)
        n = self.n_states
        known = self._known_part(step, u)
        angles = self.angles
        if angles is None:
            result = known + output_term(step, y)
        else:
            result = known + output_term(step, angles.near(y, -known[n:], outputs))
            angles.keep(result[:n])
        self._result = result
        self._x = result[:n]
        self._innovation = result[n:]
        self._stamp = stamp_ns
        self._step = step
        self._subset_step = (step, dt_ns)
        return self._x
