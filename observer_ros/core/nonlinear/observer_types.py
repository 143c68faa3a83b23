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
The extended and unscented Kalman filters as observer types of the registry.

:func:`nonlinear_type` makes the :class:`~observer_ros.core.observers.ObserverType` of a
filter class; the packages ``observer_ros.core.observers.extended_kalman`` and
``unscented_kalman`` name them (their entry points in the group
``observer_ros.observer_types``). With a model written as equations (``model.dynamics``,
:mod:`observer_ros.config.nonlinear`) the configuration's model is their linearization at
the operating point (:class:`~observer_ros.core.nonlinear.linearize.LinearizedModel`) and
the filter runs the equations it carries; otherwise the type runs the configuration's
linear model written as equations
(:func:`~observer_ros.core.nonlinear.model.linear_as_expressions`), and then equals the
time-varying Kalman filter to the integrator's accuracy. The design is the steady-state
Kalman design of ``Q`` and ``R`` on the (linearized) model, its ``P`` for the report.
"""

from dataclasses import replace

from observer_ros.core.arguments import Argument, DOUBLE, STRING
from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear.ekf import PREDICTIONS
from observer_ros.core.nonlinear.filter import DEFAULT_MAX_STEP
from observer_ros.core.nonlinear.linearize import nonlinear_model_of
from observer_ros.core.nonlinear.model import linear_as_expressions
from observer_ros.core.observers import Capabilities, ObserverType, ReportItem
from observer_ros.core.observers.kalman import (
    INITIAL_COVARIANCE, MEASUREMENT_NOISE, PROCESS_NOISE)
from observer_ros.core.observers.kalman.design import design_kalman
from observer_ros.core.observers.kalman.time_varying import parse_initial_covariance

__all__ = ['ALPHA', 'BETA', 'KAPPA', 'MAX_STEP', 'PREDICTION', 'check_sigma_points',
           'nonlinear_type']

MAX_STEP = Argument('max_step', DOUBLE, DEFAULT_MAX_STEP,
                    'EKF and UKF of a continuous model: longest RK4 step (seconds) of the '
                    'prediction of the mean and covariance over an interval.', low=1e-6,
                    high=10.0, unit='seconds')
ALPHA = Argument('ukf_alpha', DOUBLE, 1.0, 'UKF: spread of the sigma points, in (0, 1].',
                 low=0.0, high=1.0, low_open=True)
BETA = Argument('ukf_beta', DOUBLE, 2.0, 'UKF: weight of the centre point in the covariance '
                '(2 is optimal for a Gaussian).', low=-1e6, high=1e6)
KAPPA = Argument('ukf_kappa', DOUBLE, 0.0, 'UKF: secondary scaling of the sigma points '
                 '(ukf_alpha^2 (n + ukf_kappa) must be > 0).', low=-1e6, high=1e6)
PREDICTION = Argument('ekf_prediction', STRING, 'rk4',
                      'EKF of a continuous model: the covariance prediction, rk4 (the Riccati '
                      'equation by RK4, four Jacobians a step, fourth order) or midpoint '
                      '(Phi P Phi^T + Qd with one Jacobian a step, at its midpoint, second '
                      'order, 0.75 of the cost); the mean is RK4 in both.',
                      choices=PREDICTIONS)

#: The keyword of the filter's constructor for each argument of :data:`ALPHA` and the others
#: (their names carry ``ukf_``: another type's ``alpha`` means something else).
KEYWORDS = {'ukf_alpha': 'alpha', 'ukf_beta': 'beta', 'ukf_kappa': 'kappa',
            'ekf_prediction': 'covariance_prediction'}

#: What the filters can do.
CAPABILITIES = Capabilities(covariance=True, angles=True, needs_every_output=False,
                            linear_realization=False, several_sources=True,
                            needs_observable=False, equations=True)


def _vet(model, given):
    """Refuse a gain or poles (the gain comes from the noises)."""
    for name in ('gain', 'poles'):
        if given.get(name) is None or not len(given[name]):
            continue
        raise ConfigError(name, 'an extended or unscented Kalman filter takes its gain '
                          'from process_noise and measurement_noise; leave gain and poles '
                          'empty')


def equations_of(model):
    """Return the equations ``model`` carries (``model.dynamics``), else its linear ones."""
    return nonlinear_model_of(model) or linear_as_expressions(model)


def _report(design):
    """Return the steady-state covariance of the linear model."""
    return (ReportItem('covariance', 'P (steady state of the linear model)',
                       design.covariance),)


def _charged(given):
    return 'process_noise'


def check_sigma_points(model, values) -> None:
    """
    Refuse sigma points that do not spread: ``ukf_alpha^2 (n + ukf_kappa) <= 0``.

    Raises
    ------
    ConfigError
        ``ukf_kappa``.

    """
    spread = values['ukf_alpha'] ** 2 * (model.n_states + values['ukf_kappa'])
    if spread <= 0.0:
        raise ConfigError('ukf_kappa', f'expected alpha^2 (n + kappa) > 0 (n = '
                          f'{model.n_states}), got {spread:g}')


def nonlinear_type(name: str, summary: str, filter_class, extra=(),
                   priority: int = 150, check=None) -> ObserverType:
    """
    Return the observer type ``name`` whose estimator is ``filter_class``.

    Parameters
    ----------
    name : str
    summary : str
    filter_class : type
        :class:`~observer_ros.core.nonlinear.ekf.ExtendedKalman` or
        :class:`~observer_ros.core.nonlinear.ukf.UnscentedKalman`.
    extra : tuple of Argument
        Its own arguments besides the noises, ``initial_covariance`` and ``max_step``.
    priority : int
    check : callable, optional
        ``check(model, values)`` raises a ConfigError for values of ``extra`` that do not
        suit the model.

    """
    def design(model, values, disturbance=None):
        if disturbance is not None:
            raise ConfigError('disturbance_noise', f'{name} takes no model.disturbances; '
                              f'write the disturbance states into the model')
        q, r = values['process_noise'], values['measurement_noise']
        if not q and not r:
            return None
        if not q or not r:
            missing = 'process_noise' if not q else 'measurement_noise'
            raise ConfigError(missing, 'a Kalman filter needs both noise covariances')
        parse_initial_covariance(values['initial_covariance'], model.n_states)
        if nonlinear_model_of(model) is None:
            linear_as_expressions(model)  # D = 0, checked now
        if check is not None:
            check(model, values)
        return replace(design_kalman(model, q, r), kind=name)

    def estimator(design, values, initial_state=None, interval_resolution_ns=0):
        options = {KEYWORDS[argument.name]: values[argument.name] for argument in extra}
        return filter_class(equations_of(design.model), design.process_noise,
                            design.measurement_noise, values['initial_covariance'] or None,
                            initial_state, max_step=values['max_step'], **options)

    return ObserverType(
        name, summary, (PROCESS_NOISE, MEASUREMENT_NOISE, INITIAL_COVARIANCE, MAX_STEP)
        + tuple(extra), design=design, estimator=estimator, report=_report, vet=_vet,
        capabilities=CAPABILITIES, priority=priority, charged=_charged)
