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
Runtime: :class:`~observer_ros.core.estimators.chen.ChenStep`.
"""

from observer_ros.core.arguments import Argument, INTEGER
from observer_ros.core.design.chen import design_chen
from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators import ConstantGainEstimator
from observer_ros.core.estimators.chen import ChenStep
from observer_ros.core.observers import ObserverType, register, ReportItem
from observer_ros.core.observers.common import POLE_ARGUMENTS, requested_poles

#: Largest seed ``numpy.random.default_rng`` takes from a ROS integer parameter.
SEED_MAX = 2 ** 63 - 1

SEED = Argument('chen_seed', INTEGER, 0,
                'Chen, several outputs, observer.gain empty: seed of the candidate choices of '
                'L (the best-conditioned [C; T] is kept); no effect with one output '
                '(0 ... 2^63 - 1).',
                dynamic=True, low=0, high=SEED_MAX, unit='a seed')


def design(model, values):
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


def estimator(design, values, initial_state=None, interval_resolution_ns=0):
    """Return the constant-``G`` estimator of a Chen design."""
    return ConstantGainEstimator(ChenStep(design), initial_state,
                                 interval_resolution_ns=interval_resolution_ns)


def report(design):
    """Return ``F``, ``T`` and the conditioning of ``[C; T]``."""
    return (ReportItem('f', 'F', design.f), ReportItem('t', 'T (T A - F T = L C)', design.t),
            ReportItem('condition', 'cond([C; T])', design.condition))


TYPE = register(ObserverType(
    'chen', "Chen's reduced-order observer (Sylvester equation)", POLE_ARGUMENTS + (SEED,),
    design, estimator, report))
