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
Observer type ``extended_kalman``: the extended Kalman filter of the model's equations.

The filter and its integrator: :mod:`observer_ros.core.nonlinear.ekf`; the type:
:func:`observer_ros.core.nonlinear.observer_types.nonlinear_type`.
"""

from observer_ros.core.nonlinear.ekf import ExtendedKalman
from observer_ros.core.nonlinear.observer_types import nonlinear_type, PREDICTION

NAME = 'extended_kalman'

TYPE = nonlinear_type(NAME, 'Extended Kalman filter (continuous-discrete: RK4 on the mean '
                      'and the Riccati equation, exact Jacobians)', ExtendedKalman,
                      extra=(PREDICTION,), priority=150)
