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
The four linear observer types on a nonlinear plant, with the nonlinear prediction.

Designed at the operating point, they run ``x_hat = x_prior + M (y - h(x_prior))``.

With a linear model written as equations each type gives its linear estimator's estimates
(jittered stamps, the first sample included) to 1e-9 relative: the prediction integrates
``f`` (RK4) where the linear one samples ``A`` exactly. On a pendulum swinging from 60
degrees the observer designed at the bottom tracks it where the same gain run on the
linearization does not. The time-varying Kalman filter and the delayed form are refused,
naming ``observer.time_varying`` and ``observer.form``.
"""

import math

import numpy as np
import pytest

from observer_ros.config import validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators.constant_gain import ConstantGainEstimator
from observer_ros.core.nonlinear.prediction import NonlinearPrediction

LINEAR = {'model.A': [0.0, 1.0, -2.0, -0.5], 'model.B': [0.0, 1.0], 'model.C': [1.0, 0.0],
          'model.state_names': ['x1', 'x2'], 'model.input_names': ['u1'],
          'model.output_names': ['angle']}
EQUATIONS = {'model.state_names': ['x1', 'x2'], 'model.input_names': ['u1'],
             'model.output_names': ['angle'], 'model.dynamics': ['x2', '-2 * x1 - 0.5 * x2 + u1'],
             'model.measurements': ['x1']}
TYPES = {'full_order': {'observer.poles': ['-4', '-5']},
         'kalman': {'observer.process_noise': [0.0, 1.0], 'observer.measurement_noise': [0.01]},
         'reduced_order': {'observer.poles': ['-4']},
         'chen': {'observer.poles': ['-4']}}


def _run(system, samples=200, seed=1):
    stream = system.make_stream()
    rng = np.random.default_rng(seed)
    returned = []
    for k in range(samples):
        stamp = k * 10_000_000 + int(rng.integers(0, 3_000_000))  # jittered
        returned += stream.add_input(stamp, [math.sin(k / 10)])
        returned += stream.add_measurement(stamp, [math.cos(k / 7)])
    return stream, np.array([sample.estimate for sample in returned])


@pytest.mark.parametrize('pinned', [{}, {'observer.initial_state': [0.2, -0.1]}])
@pytest.mark.parametrize('kind', sorted(TYPES))
def test_a_linear_model_as_equations_gives_the_linear_estimators_estimates(kind, pinned):
    linear_stream, linear = _run(validate_parameters({**LINEAR, 'observer.type': kind,
                                                      **TYPES[kind], **pinned}))
    stream, estimates = _run(validate_parameters({**EQUATIONS, 'observer.type': kind,
                                                  **TYPES[kind], **pinned}))
    assert type(linear_stream.estimator) is ConstantGainEstimator
    assert type(stream.estimator) is NonlinearPrediction
    # A Kalman filter's P is its design's at each interval; a placed gain carries none.
    assert (stream.estimator.covariance is None) == (linear_stream.estimator.covariance is None)
    if kind == 'kalman':
        assert np.allclose(stream.estimator.covariance, linear_stream.estimator.covariance,
                           rtol=1e-9, atol=0.0)
    assert linear.shape == estimates.shape == (200, 2)
    assert np.max(np.abs(estimates - linear)) <= 1e-9 * np.max(np.abs(linear))


PENDULUM = {'model.state_names': ['q', 'dq'], 'model.input_names': ['torque'],
            'model.output_names': ['angle'],
            'model.dynamics': ['dq', '-g / l * sin(q) - d * dq + torque'],
            'model.measurements': ['q'], 'model.constant_names': ['g', 'l', 'd'],
            'model.constant_values': [9.81, 1.0, 0.1], 'observer.initial_state': [0.0, 0.0]}


def _swing(system, seconds=4.0, start=math.radians(60.0)):
    """Run the observer on a pendulum released at ``start``; return the last errors."""
    model = validate_parameters({**PENDULUM, 'observer.type': 'extended_kalman',
                                 'observer.process_noise': [0.0, 1.0],
                                 'observer.measurement_noise': [0.01]}).model.nonlinear
    stream = system.make_stream()
    x, errors = np.array([start, 0.0]), []
    for k in range(int(seconds * 100)):
        stamp = k * 10_000_000
        stream.add_input(stamp, [0.0])
        estimate = stream.add_measurement(stamp, [x[0]])[-1].estimate
        errors.append(np.abs(estimate - x))
        for _ in range(10):  # RK4 at 1 ms
            h = 0.001
            k1 = model.f(x, [0.0])
            k2 = model.f(x + h / 2 * k1, [0.0])
            k3 = model.f(x + h / 2 * k2, [0.0])
            k4 = model.f(x + h * k3, [0.0])
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return np.array(errors)


@pytest.mark.parametrize('kind', ['full_order', 'kalman', 'reduced_order'])
def test_the_observer_designed_at_the_bottom_tracks_the_pendulum_swinging_from_60_degrees(
        kind):
    equations = validate_parameters({**PENDULUM, 'observer.type': kind, **TYPES[kind]})
    assert equations.model.a.tolist() == [[0.0, 1.0], [-9.81, -0.1]]  # at q = 0
    linearized = validate_parameters({
        'model.A': equations.model.a.ravel().tolist(),
        'model.B': equations.model.b.ravel().tolist(), 'model.C': [1.0, 0.0],
        'observer.initial_state': [0.0, 0.0], 'observer.type': kind, **TYPES[kind]})
    nonlinear_errors = _swing(equations)
    linear_errors = _swing(linearized)
    # The last second: the nonlinear prediction follows the swing closely, the same design
    # run on the linearization keeps an error from the model's sin(q) ~ q.
    assert nonlinear_errors[-100:, 1].max() < 0.01, nonlinear_errors[-100:].max(axis=0)
    assert linear_errors[-100:, 1].max() > 10 * nonlinear_errors[-100:, 1].max()


@pytest.mark.parametrize('change, parameter, what', [
    ({'observer.type': 'kalman', 'observer.time_varying': True, **TYPES['kalman']},
     'observer.time_varying', 'propagates its covariance with the linear model'),
    ({'observer.type': 'full_order', 'observer.form': 'delayed', **TYPES['full_order']},
     'observer.form', "expected 'current'"),
])
def test_what_cannot_take_the_nonlinear_prediction_is_refused_naming_the_parameter(
        change, parameter, what):
    with pytest.raises(ConfigError) as caught:
        validate_parameters({**PENDULUM, **change})
    assert caught.value.parameter == parameter, str(caught.value)
    assert what in caught.value.reason, caught.value.reason


def test_a_source_whose_gain_cannot_be_designed_alone_is_refused_as_for_the_linear_model():
    from test_nonlinear_config import SYSTEM
    with pytest.raises(ConfigError) as caught:
        validate_parameters({**SYSTEM, 'observer.type': 'kalman'})
    assert caught.value.parameter == 'observer.sources'
    assert "source 'wheels' (outputs ['wheel_left', 'wheel_right']) alone" in str(caught.value)
