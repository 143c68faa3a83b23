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
Observer type ``full_order``: the Luenberger observer of order n, from poles or a gain.

Runtime: :class:`~observer_ros.core.estimators.full_order.FullOrderStep` in the
:class:`~observer_ros.core.estimators.ConstantGainEstimator` (the poles re-placed as
``exp(lambda dt)`` for each interval of a continuous model).
"""

from observer_ros.core.design.full_order import design_full_order
from observer_ros.core.estimators import ConstantGainEstimator
from observer_ros.core.estimators.full_order import FullOrderStep
from observer_ros.core.observers import ObserverType, register
from observer_ros.core.observers.common import FORM, POLE_ARGUMENTS, poles_or_gain


def design(model, values):
    """Design from ``poles`` (or the error specification) or check a given ``gain``."""
    poles, gain = poles_or_gain(model, values, model.n_states, 'full_order')
    if poles is None and gain is None:
        return None
    return design_full_order(model, None if gain is not None else poles, gain,
                             values['method'])


def estimator(design, values, initial_state=None, interval_resolution_ns=0):
    """Return the constant-``G`` estimator of a full-order design."""
    return ConstantGainEstimator(FullOrderStep(design, values['method']), initial_state,
                                 interval_resolution_ns=interval_resolution_ns)


TYPE = register(ObserverType(
    'full_order', 'Luenberger observer of order n', POLE_ARGUMENTS + (FORM,), design,
    estimator))
