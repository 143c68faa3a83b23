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
Runtime estimators: the protocol, the constant-gain engine and the interval cache they share.

:class:`Estimator` is the protocol the stream drives; :class:`ConstantGainEstimator` runs
one matrix per sample interval from a step design (each type's own, in its package under
:mod:`observer_ros.core.observers`). A type with a filter of its own (the time-varying Kalman
filter) implements :class:`Estimator` in its package;
:func:`observer_ros.core.observers.make_estimator` builds the estimator of any design.
"""

from observer_ros.core.estimators.constant_gain import (
    ConstantGainEstimator, StepDesign, StepMatrices)
from observer_ros.core.estimators.intervals import IntervalCache
from observer_ros.core.estimators.protocol import (
    Estimator, model_feedthrough, Prediction, SteadySteps, SubsetUpdates, without_feedthrough)

__all__ = ['ConstantGainEstimator', 'Estimator', 'IntervalCache', 'Prediction', 'SteadySteps',
           'StepDesign', 'StepMatrices', 'SubsetUpdates', 'model_feedthrough',
           'without_feedthrough']
