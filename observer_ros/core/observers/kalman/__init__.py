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
(:func:`~observer_ros.core.observers.kalman.design.design_kalman`), which the report, the
closed-loop analysis and ``controller_tf`` use. Runtime: with ``time_varying`` false (the
default) the constant-``G`` :class:`~observer_ros.core.observers.kalman.estimator.KalmanStep`
(the DARE solved for each interval); with ``time_varying`` true the
:class:`~observer_ros.core.observers.kalman.time_varying.TimeVaryingKalman`, which
propagates its covariance over each actual interval from ``initial_covariance``. With
``model.disturbances`` the filter takes the process noise of the disturbance states from
``disturbance_noise`` (``process_noise`` then covers the plant states only).
"""

from observer_ros.core.arguments import Argument, array, BOOL
from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators.constant_gain import ConstantGainEstimator
from observer_ros.core.flat_matrices import covariance_from_flat
from observer_ros.core.observers import Capabilities, ObserverType, ReportItem
from observer_ros.core.observers.common import FORM
from observer_ros.core.observers.kalman.design import design_kalman
from observer_ros.core.observers.kalman.estimator import KalmanStep
from observer_ros.core.observers.kalman.time_varying import (
    parse_initial_covariance, TimeVaryingKalman)

NAME = 'kalman'

PROCESS_NOISE = array('process_noise', 'Kalman Q: n diagonal values or n x n row-major. '
                      'Continuous model: intensity (discretized per interval); discrete model: '
                      'covariance.', tunable=True)
MEASUREMENT_NOISE = array('measurement_noise', 'Kalman R: p diagonal values or p x p '
                          'row-major; covariance of each sampled measurement (continuous '
                          'model: intensity for the CARE design).', tunable=True)
DISTURBANCE_NOISE = array('disturbance_noise', 'Kalman with model.disturbances: process '
                          'noise of the disturbance states, one diagonal value each '
                          '(intensity or covariance like process_noise, which then covers '
                          'the plant states only): how fast the disturbances may wander.',
                          tunable=True)
TIME_VARYING = Argument('time_varying', BOOL, False,
                        'Kalman: propagate the covariance over each actual interval (Joseph '
                        'form) instead of the steady-state filter of each interval.')
INITIAL_COVARIANCE = array('initial_covariance', 'Time-varying Kalman: P0, n diagonal values '
                           'or n x n row-major (default: the identity); the first measurement '
                           'updates (initial_state, P0). n counts the disturbance states of '
                           'model.disturbances.', tunable=True)


def _vet(model, given):
    """Refuse a gain or poles with a Kalman filter (its gain comes from the noises)."""
    if given.get('gain') or len(given.get('poles', ())):
        raise ConfigError('gain', 'a Kalman filter takes its gain from process_noise and '
                          'measurement_noise; leave gain and poles empty')


def augmented_process_noise(model, values, disturbance) -> list:
    """
    Return ``Q`` of the augmented model: ``process_noise`` and ``disturbance_noise``.

    Raises
    ------
    ConfigError
        ``disturbance_noise`` missing or of the wrong count; ``process_noise`` not a
        covariance of the plant states.

    """
    if not values['disturbance_noise']:
        states = list(model.state_names[disturbance.plant.n_states:])
        raise ConfigError('disturbance_noise', f'expected '
                          f'{disturbance.n_disturbance_states} values (the process noise of '
                          f'the disturbance states {states}), got none')
    plant_q = covariance_from_flat('process_noise', values['process_noise'],
                                   disturbance.plant.n_states)
    return disturbance.augmented_process_noise(
        plant_q, values['disturbance_noise']).ravel().tolist()


def _design(model, values, disturbance=None):
    """Return the steady-state Kalman design of ``Q`` and ``R`` (None when neither given)."""
    q, r = values['process_noise'], values['measurement_noise']
    if disturbance is not None and q:
        q = augmented_process_noise(model, values, disturbance)
    if not q and not r:
        return None
    if not q or not r:
        missing = 'process_noise' if not q else 'measurement_noise'
        raise ConfigError(missing, 'a Kalman filter needs both noise covariances')
    parse_initial_covariance(values['initial_covariance'], model.n_states)  # checked now
    return design_kalman(model, q, r)


def _estimator(design, values, initial_state=None, interval_resolution_ns=0):
    """Return the steady-state (constant-``G``) or the time-varying filter."""
    if values['time_varying']:
        return TimeVaryingKalman(design.model, design.process_noise, design.measurement_noise,
                                 values['initial_covariance'], initial_state,
                                 interval_resolution_ns)
    return ConstantGainEstimator(KalmanStep(design), initial_state,
                                 interval_resolution_ns=interval_resolution_ns)


def _report(design):
    """Return the Riccati solution and, for a discrete model, the filter gain ``M``."""
    items = [ReportItem('covariance', 'P', design.covariance)]
    if design.filter_gain is not None:
        items.append(ReportItem('filter_gain', 'M (filter gain; L = A M)', design.filter_gain))
    return tuple(items)


def _charged(given):
    """Charge a failed design to ``process_noise`` (the noises make the gain)."""
    return 'process_noise'


TYPE = ObserverType(
    NAME, 'Kalman filter (steady-state, or time-varying with observer.time_varying)',
    (PROCESS_NOISE, MEASUREMENT_NOISE, DISTURBANCE_NOISE, TIME_VARYING, INITIAL_COVARIANCE,
     FORM), design=_design, estimator=_estimator, report=_report, vet=_vet,
    capabilities=Capabilities(covariance=True, angles=True, needs_every_output=False,
                              linear_realization=True, several_sources=True,
                              needs_observable=False,
                              disturbance_arguments=('disturbance_noise',)),
    priority=200, charged=_charged)
