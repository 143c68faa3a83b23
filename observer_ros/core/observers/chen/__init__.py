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
Observer type ``chen``: Chen's reduced-order observer from the Sylvester equation.

``T A - F T = L C`` with ``eig(F)`` the poles; ``L`` given or drawn (``chen_seed``).
Design: :mod:`.design`. Runtime: :class:`~observer_ros.core.observers.chen.estimator.ChenStep`;
like every reduced-order observer, each update needs every output.
"""

import numpy as np

from observer_ros.core.arguments import Argument, INTEGER, SEED_MAX
from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators.constant_gain import ConstantGainEstimator
from observer_ros.core.observers import Capabilities, ObserverType, ReportItem
from observer_ros.core.observers.chen.design import design_chen
from observer_ros.core.observers.chen.estimator import ChenStep
from observer_ros.core.observers.common import (
    charged_poles_or_gain, POLE_ARGUMENTS, requested_poles)

NAME = 'chen'

SEED = Argument('chen_seed', INTEGER, 0,
                'Chen, several outputs, observer.gain empty: seed of the candidate choices of '
                'L (the best-conditioned [C; T] is kept); no effect with one output '
                '(0 ... 2^63 - 1).',
                tunable=True, low=0, high=SEED_MAX, unit='a seed')


def _design(model, values, disturbance=None):
    """Design from ``poles`` (the eigenvalues of ``F``) and ``gain`` or a drawn ``L``."""
    count = model.n_states - model.n_outputs
    poles = requested_poles(model, values, count)
    gain = values['gain'] or None  # Chen's L: with the poles, not instead of them
    if poles is None:
        if gain is not None:
            raise ConfigError('poles', f'a Chen observer needs its {count} poles (the '
                              f'eigenvalues of F) besides the gain L')
        return None
    return design_chen(model, poles, gain, values['chen_seed'])


def _estimator(design, values, initial_state=None, interval_resolution_ns=0):
    """Return the constant-``G`` estimator of a Chen design."""
    return ConstantGainEstimator(ChenStep(design), initial_state,
                                 interval_resolution_ns=interval_resolution_ns)


def _report(design):
    """Return ``F``, ``T`` and the conditioning of ``[C; T]``."""
    return (ReportItem('f', 'F', design.f), ReportItem('t', 'T (T A - F T = L C)', design.t),
            ReportItem('condition', 'cond([C; T])', design.condition))


def _pinned(design, values):
    """
    Return the arguments that pin a Chen design: with a given ``L``, that ``L`` and the poles.

    A designed ``L`` belongs to its own ``F`` (orthonormal ``T``), not to the diagonal ``F``
    a given ``L`` is used with: the poles (and ``chen_seed``) reproduce that design, so
    nothing is pinned.
    """
    if not values['gain']:
        return {}
    return {'gain': np.ravel(design.gain).tolist(), 'error_tolerance': None,
            'error_time': None}


TYPE = ObserverType(
    NAME, "Chen's reduced-order observer (Sylvester equation)", POLE_ARGUMENTS + (SEED,),
    design=_design, estimator=_estimator, report=_report,
    capabilities=Capabilities(covariance=False, angles=True, needs_every_output=True,
                              linear_realization=True, several_sources=False),
    priority=300, charged=charged_poles_or_gain, pinned=_pinned)
