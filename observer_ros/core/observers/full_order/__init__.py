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

Design: :mod:`.design` (:func:`~observer_ros.core.observers.full_order.design.design_full_order`).
Runtime: :class:`~observer_ros.core.observers.full_order.estimator.FullOrderStep` in the
constant-``G`` :class:`~observer_ros.core.estimators.Estimator` (the poles re-placed as
``exp(lambda dt)`` for each interval of a continuous model).
"""

from observer_ros.core.estimators.constant_gain import ConstantGainEstimator
from observer_ros.core.observers import Capabilities, ObserverType
from observer_ros.core.observers.common import (
    charged_poles_or_gain, FORM, pinned_gain, POLE_ARGUMENTS, poles_or_gain)
from observer_ros.core.observers.full_order.design import design_full_order
from observer_ros.core.observers.full_order.estimator import FullOrderStep

NAME = 'full_order'


def _design(model, values, disturbance=None):
    """Design from ``poles`` (or the error specification) or check a given ``gain``."""
    poles, gain = poles_or_gain(model, values, model.n_states, NAME)
    if poles is None and gain is None:
        return None
    return design_full_order(model, None if gain is not None else poles, gain,
                             values['method'])


def _estimator(design, values, initial_state=None, interval_resolution_ns=0):
    """Return the constant-``G`` estimator of a full-order design."""
    return ConstantGainEstimator(FullOrderStep(design, values['method']), initial_state,
                                 interval_resolution_ns=interval_resolution_ns)


TYPE = ObserverType(
    NAME, 'Luenberger observer of order n', POLE_ARGUMENTS + (FORM,),
    design=_design, estimator=_estimator,
    # An update from some outputs: the pair (A, C_subset) designed per subset of sources.
    capabilities=Capabilities(covariance=False, angles=True, needs_every_output=False,
                              linear_realization=True, several_sources=True),
    priority=500, charged=charged_poles_or_gain, pinned=pinned_gain)
