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
Observer type ``unscented_kalman``: the unscented Kalman filter of the model's equations.

The filter and its sigma points: :mod:`observer_ros.core.nonlinear.ukf`; the type:
:func:`observer_ros.core.nonlinear.observer_types.nonlinear_type`.
"""

from observer_ros.core.nonlinear.observer_types import (
    ALPHA, BETA, check_sigma_points, KAPPA, nonlinear_type)
from observer_ros.core.nonlinear.ukf import UnscentedKalman

NAME = 'unscented_kalman'

TYPE = nonlinear_type(NAME, 'Unscented Kalman filter (sigma points moved by RK4; alpha, '
                      'beta, kappa)', UnscentedKalman, (ALPHA, BETA, KAPPA), priority=140,
                      check=check_sigma_points)
