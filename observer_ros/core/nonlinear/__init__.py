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
Nonlinear models written as equations, and the filters that run them.

:func:`parse_expression` checks a user's expression against a whitelist (nothing is
evaluated); :class:`NonlinearModel` holds the equations of ``x' = f(x, u)`` and each
output's ``h(x, u)`` with their exact Jacobians (SymPy, generated once); the extended and
unscented Kalman filters (:mod:`~observer_ros.core.nonlinear.ekf`,
:mod:`~observer_ros.core.nonlinear.ukf`) run them in the event engine like any estimator;
:mod:`~observer_ros.core.nonlinear.simulation` simulates them as a plant, and
:mod:`~observer_ros.core.nonlinear.operating_point` linearizes them at an operating point
and runs the closed loop with a law designed there.
"""

from observer_ros.core.nonlinear.ekf import ExtendedKalman
from observer_ros.core.nonlinear.expressions import (
    Expression, ExpressionError, FUNCTIONS, parse_expression)
from observer_ros.core.nonlinear.filter import NonlinearFilter
from observer_ros.core.nonlinear.model import (
    differential_drive, linear_as_expressions, NonlinearModel)
from observer_ros.core.nonlinear.operating_point import (
    arm_joint, linearize, simulate_observer_controller)
from observer_ros.core.nonlinear.simulation import NonlinearPlantSimulator
from observer_ros.core.nonlinear.ukf import UnscentedKalman

__all__ = ['Expression', 'ExpressionError', 'ExtendedKalman', 'FUNCTIONS', 'NonlinearFilter',
           'NonlinearModel', 'NonlinearPlantSimulator', 'UnscentedKalman', 'arm_joint',
           'differential_drive', 'linear_as_expressions', 'linearize', 'parse_expression',
           'simulate_observer_controller']
