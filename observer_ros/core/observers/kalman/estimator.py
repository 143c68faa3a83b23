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
"""

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
