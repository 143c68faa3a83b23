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
The EKF and UKF as observer types: found in the entry-point group, run from parameters.

Until a configuration carries equations, the two types run on the configuration's linear
model written as equations; their streams then give the time-varying Kalman filter's
estimates and covariances to 1e-9, with every source at its own rate.
"""

import numpy as np
import pytest

from observer_ros.config import validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear import ExtendedKalman, UnscentedKalman
from observer_ros.core.observers import observer_type, observer_types, plugin_failures

MS = 1_000_000
PARAMETERS = {
    'model.A': [0.0, 1.0, 0.0, -4.0, -0.4, 1.0, 0.0, 0.0, -0.5],
    'model.B': [0.0, 1.0, 0.3], 'model.C': [1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
    'observer.process_noise': [0.0, 0.5, 0.1], 'observer.measurement_noise': [0.01, 0.04],
    'observer.initial_covariance': [1.0, 2.0, 0.5],
}


def test_the_types_are_registered_after_the_built_in_ones():
    names = [kind.name for kind in observer_types()]
    assert names[-2:] == ['extended_kalman', 'unscented_kalman'] and plugin_failures() == {}
    for name in names[-2:]:
        capabilities = observer_type(name).capabilities
        assert capabilities.covariance and capabilities.several_sources
        assert capabilities.angles and not capabilities.linear_realization


@pytest.mark.parametrize('name, kind', [('extended_kalman', ExtendedKalman),
                                        ('unscented_kalman', UnscentedKalman)])
def test_a_configured_type_equals_the_time_varying_kalman_filter(name, kind):
    reference = validate_parameters(dict(PARAMETERS, **{'observer.type': 'kalman',
                                                        'observer.time_varying': True}))
    configured = validate_parameters(dict(PARAMETERS, **{'observer.type': name}))
    streams = [reference.make_stream(), configured.make_stream()]
    assert isinstance(streams[1].estimator, kind)
    rng = np.random.default_rng(4)
    stamp, samples = 0, [[], []]
    for _ in range(200):
        stamp += int(rng.integers(1, 30)) * MS
        u, y = list(rng.normal(size=1)), list(rng.normal(size=2))
        for stream, out in zip(streams, samples):
            out += stream.add_input(stamp, u)
            out += stream.add_measurement(stamp, y)
    assert len(samples[0]) == len(samples[1]) >= 190
    for expected, got in zip(*samples):
        assert got.stamp_ns == expected.stamp_ns
        scale = np.max(np.abs(expected.estimate))
        assert np.max(np.abs(got.estimate - expected.estimate)) < 1e-9 * scale
        scale = np.max(np.abs(expected.covariance))
        assert np.max(np.abs(got.covariance - expected.covariance)) < 1e-9 * scale


@pytest.mark.parametrize('given, parameter, what', [
    ({'observer.max_step': 0.0}, 'observer.max_step', 'expected seconds in [1e-06, 10]'),
    ({'observer.ukf_alpha': 1.5, 'observer.type': 'unscented_kalman'}, 'observer.ukf_alpha',
     ''),
    ({'observer.ukf_kappa': -5.0, 'observer.type': 'unscented_kalman'}, 'observer.ukf_kappa',
     'expected alpha^2 (n + kappa) > 0'),
    ({'observer.poles': ['-1', '-2', '-3']}, 'observer.poles', 'takes its gain from'),
    ({'observer.measurement_noise': []}, 'observer.measurement_noise', 'needs both'),
    ({'model.D': [0.0, 1.0]}, 'model.D', 'expected D = 0'),
])
def test_bad_values_are_refused_naming_the_parameter(given, parameter, what):
    params = dict(PARAMETERS, **{'observer.type': 'extended_kalman'})
    params.update(given)
    with pytest.raises(ConfigError) as caught:
        validate_parameters(params)
    assert caught.value.parameter == parameter, str(caught.value)
    assert what in caught.value.reason
