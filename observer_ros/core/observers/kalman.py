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
Observer type ``kalman``: the Kalman filter, steady-state or time-varying.

Design: the steady-state gain from the Riccati equations
(:func:`~observer_ros.core.design.kalman.design_kalman`), which the report, the closed-loop
analysis and ``controller_tf`` use. Runtime: with ``time_varying`` false (the default) the
constant-``G`` :class:`~observer_ros.core.estimators.kalman.KalmanStep` (the DARE solved for
each interval); with ``time_varying`` true the
:class:`~observer_ros.core.estimators.time_varying_kalman.TimeVaryingKalman`, which
propagates its covariance over each actual interval from ``initial_covariance``.
"""

from observer_ros.core.arguments import Argument, array, BOOL
from observer_ros.core.design.kalman import design_kalman
from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators import ConstantGainEstimator
from observer_ros.core.estimators.kalman import KalmanStep
from observer_ros.core.estimators.time_varying_kalman import (
    parse_initial_covariance, TimeVaryingKalman)
from observer_ros.core.observers import ObserverType, register, ReportItem
from observer_ros.core.observers.common import FORM

PROCESS_NOISE = array('process_noise', 'Kalman Q: n diagonal values or n x n row-major. '
                      'Continuous model: intensity (discretized per interval); discrete model: '
                      'covariance.', dynamic=True)
MEASUREMENT_NOISE = array('measurement_noise', 'Kalman R: p diagonal values or p x p '
                          'row-major; covariance of each sampled measurement (continuous '
                          'model: intensity for the CARE design).', dynamic=True)
DISTURBANCE_NOISE = array('disturbance_noise', 'Kalman with model.disturbances: process '
                          'noise of the disturbance states, one diagonal value each '
                          '(intensity or covariance like process_noise, which then covers '
                          'the plant states only): how fast the disturbances may wander.',
                          dynamic=True)
TIME_VARYING = Argument('time_varying', BOOL, False,
                        'Kalman: propagate the covariance over each actual interval (Joseph '
                        'form) instead of the steady-state filter of each interval.')
INITIAL_COVARIANCE = array('initial_covariance', 'Time-varying Kalman: P0, n diagonal values '
                           'or n x n row-major (default: the identity); the first measurement '
                           'updates (initial_state, P0). n counts the disturbance states of '
                           'model.disturbances.', dynamic=True)


def vet(model, given):
    """Refuse a gain or poles with a Kalman filter (its gain comes from the noises)."""
    if given.get('gain') or given.get('poles'):
        raise ConfigError('gain', 'a Kalman filter takes its gain from process_noise and '
                          'measurement_noise; leave gain and poles empty')


def design(model, values):
    """Return the steady-state Kalman design of ``Q`` and ``R`` (None when neither given)."""
    q, r = values['process_noise'], values['measurement_noise']
    if not q and not r:
        return None
    if not q or not r:
        missing = 'process_noise' if not q else 'measurement_noise'
        raise ConfigError(missing, 'a Kalman filter needs both noise covariances')
    parse_initial_covariance(values['initial_covariance'], model.n_states)  # checked now
    return design_kalman(model, q, r)


def estimator(design, values, initial_state=None, interval_resolution_ns=0):
    """Return the steady-state (constant-``G``) or the time-varying filter."""
    if values['time_varying']:
        return TimeVaryingKalman(design.model, design.process_noise, design.measurement_noise,
                                 values['initial_covariance'], initial_state,
                                 interval_resolution_ns)
    return ConstantGainEstimator(KalmanStep(design), initial_state,
                                 interval_resolution_ns=interval_resolution_ns)


def report(design):
    """Return the Riccati solution and, for a discrete model, the filter gain ``M``."""
    items = [ReportItem('covariance', 'P', design.covariance)]
    if design.filter_gain is not None:
        items.append(ReportItem('filter_gain', 'M (filter gain; L = A M)', design.filter_gain))
    return tuple(items)


TYPE = register(ObserverType(
    'kalman', 'Kalman filter (steady-state, or time-varying with observer.time_varying)',
    (PROCESS_NOISE, MEASUREMENT_NOISE, DISTURBANCE_NOISE, TIME_VARYING, INITIAL_COVARIANCE,
     FORM), design,
    estimator, report, vet))
