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

"""
Sampled steady-state Kalman filter in current (filter) form.

For a continuous model each interval is discretized exactly (zero-order hold, Van Loan for
the process noise intensity) and the DARE solved for that interval; a discrete model uses
its own ``Q`` and ``R``. The step reports the filtered covariance ``(I - M C) P``.

With several measurement sources each subset of outputs has its own steady filter: the DARE
of its rows of ``C`` and its block of ``R`` (:meth:`KalmanStep.for_outputs`), solved on first
use and cached per interval. A subset that leaves a mode unseen and not decaying has no
steady filter and is refused, naming the modes.
"""

from typing import Optional

import numpy as np

from observer_ros.core.discretize import van_loan
from observer_ros.core.estimators.constant_gain import StepDesign, StepMatrices
from observer_ros.core.observers.common import current_form
from observer_ros.core.observers.kalman.design import discrete_kalman, KalmanDesign


class KalmanStep(StepDesign):
    """Step design of the steady-state Kalman filter from a :class:`KalmanDesign`."""

    kind = 'kalman'

    def __init__(self, design: KalmanDesign) -> None:
        super().__init__(design.model)
        self.process_noise = design.process_noise
        self.measurement_noise = design.measurement_noise

    def design_step(self, ad, bd, dt) -> StepMatrices:
        """Solve the DARE of the sampled model and assemble the filter step."""
        model = self.model
        q = self.process_noise if model.is_discrete else van_loan(model.a, self.process_noise,
                                                                  dt)
        sampled = discrete_kalman(model, q, self.measurement_noise, a=ad)
        innovation = model.c @ sampled.covariance @ model.c.T + self.measurement_noise
        return current_form(ad, bd, model.c, sampled.filter_gain, sampled.achieved_poles,
                            sampled.filtered_covariance, 0.5 * (innovation + innovation.T))

    def several_sources_problem(self) -> Optional[str]:
        """None: a steady filter is made for each subset of outputs."""
        return None

    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """Say why ``outputs`` alone have no steady filter: modes unseen and not decaying."""
        return self.observability_problem(
            outputs, detectable=True,
            consequence=', so no steady-state Kalman filter of them alone exists')

    def for_outputs(self, outputs: tuple) -> 'KalmanStep':
        """Return the step design of these outputs: their rows of ``C``, their block of ``R``."""
        subset = super().for_outputs(outputs)
        index = list(outputs)
        subset.measurement_noise = np.ascontiguousarray(
            self.measurement_noise[np.ix_(index, index)])
        return subset
