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

"""Runtime estimators: one loop (:class:`Estimator`), one step design per observer type."""

from observer_ros.core.design.chen import ChenDesign
from observer_ros.core.design.common import ObserverDesign
from observer_ros.core.design.kalman import KalmanDesign
from observer_ros.core.design.reduced_order import ReducedOrderDesign
from observer_ros.core.estimators.base import Estimator, StepDesign, StepMatrices
from observer_ros.core.estimators.chen import ChenStep
from observer_ros.core.estimators.full_order import FullOrderStep
from observer_ros.core.estimators.kalman import KalmanStep
from observer_ros.core.estimators.reduced_order import ReducedOrderStep


def step_design_for(design: ObserverDesign, method: str = 'auto') -> StepDesign:
    """Return the runtime step design matching an observer design of any type."""
    if isinstance(design, KalmanDesign):
        return KalmanStep(design)
    if isinstance(design, ChenDesign):
        return ChenStep(design)
    if isinstance(design, ReducedOrderDesign):
        return ReducedOrderStep(design, method)
    return FullOrderStep(design, method)


def make_estimator(design: ObserverDesign, initial_state=None, method: str = 'auto',
                   interval_resolution_ns: int = 0) -> Estimator:
    """Build the runtime :class:`Estimator` for an observer design."""
    return Estimator(step_design_for(design, method), initial_state,
                     interval_resolution_ns=interval_resolution_ns)


__all__ = ['ChenStep', 'Estimator', 'FullOrderStep', 'KalmanStep', 'ReducedOrderStep',
           'StepDesign', 'StepMatrices', 'make_estimator', 'step_design_for']
