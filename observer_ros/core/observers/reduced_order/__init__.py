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
Observer type ``reduced_order``: the minimum-order (Ogata/Luenberger) observer of order n - p.

Design: :mod:`.design` (the measured-first transform and the observer of the unmeasured
part). Runtime: :class:`~observer_ros.core.observers.reduced_order.estimator.ReducedOrderStep`;
the estimate agrees with every measurement (``C x_hat = y``), so each update needs them all.
"""

from observer_ros.core.arguments import Argument, STRING
from observer_ros.core.estimators.constant_gain import ConstantGainEstimator
from observer_ros.core.observers import Capabilities, ObserverType, ReportItem
from observer_ros.core.observers.common import (
    charged_poles_or_gain, pinned_gain, POLE_ARGUMENTS, poles_or_gain)
from observer_ros.core.observers.reduced_order.design import COORDINATES, design_reduced_order
from observer_ros.core.observers.reduced_order.estimator import ReducedOrderStep

NAME = 'reduced_order'

COORDINATES_ARGUMENT = Argument(
    'coordinates', STRING, 'orthonormal',
    'Reduced order: orthonormal (C completed by an orthonormal null-space basis) | '
    'observability (the observability matrix, one output).', choices=COORDINATES)


def _design(model, values, disturbance=None):
    """Design from ``poles`` (or the error specification) or check a given ``gain``."""
    count = model.n_states - model.n_outputs
    poles, gain = poles_or_gain(model, values, count, NAME)
    if poles is None and gain is None:
        return None
    return design_reduced_order(model, None if gain is not None else poles, gain,
                                values['coordinates'], values['method'])


def _estimator(design, values, initial_state=None, interval_resolution_ns=0):
    """Return the constant-``G`` estimator of a reduced-order design."""
    return ConstantGainEstimator(ReducedOrderStep(design, values['method']), initial_state,
                                 interval_resolution_ns=interval_resolution_ns)


def _report(design):
    """Return the measured-first transform and the observer's matrices."""
    return (ReportItem('transform', 'Q (w = Q x)', design.transform),
            ReportItem('a_hat', 'Ahat = Abb - L Aab', design.a_hat),
            ReportItem('b_hat', 'Bhat = Ahat L + Aba - L Aaa', design.b_hat),
            ReportItem('f_hat', 'Fhat = Bb - L Ba', design.f_hat),
            ReportItem('c_hat', 'Chat', design.c_hat),
            ReportItem('d_hat', 'Dhat', design.d_hat))


TYPE = ObserverType(
    NAME, 'reduced-order observer of order n - p (Ogata)',
    POLE_ARGUMENTS + (COORDINATES_ARGUMENT,), design=_design, estimator=_estimator,
    report=_report,
    capabilities=Capabilities(covariance=False, angles=True, needs_every_output=True,
                              linear_realization=True, several_sources=False),
    priority=400, charged=charged_poles_or_gain, pinned=pinned_gain)
