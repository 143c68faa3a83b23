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
Angles: a heading crossing +-pi moves the estimate by the step it made, not by a turn.

A turning base measures its heading in ``(-pi, pi]``: ``3.10``, then ``-3.13``. Without
``model.angle_outputs`` the observers took that as a jump of ``-6.2`` rad and the heading
estimate swung through the circle (``-0.3, -2.41, -3.47, -3.83`` for the steady Kalman
filter of these tests, noise-free); with it the innovation is wrapped and the estimate,
kept in ``(-pi, pi]``, equals (modulo 2 pi) the one of a measurement that never wrapped.
"""

import math

import numpy as np
import pytest
from rosbags.rosbag2 import Writer
import yaml

from bag_support import float64_array, serialize, STORAGES, TYPES, TYPESTORE
from observer_ros.bags.replay import replay_bag
from observer_ros.config import validate_parameters
from observer_ros.core import ConfigError, StateSpaceModel
from observer_ros.core.angles import Angles, check_angles, wrap_angles
from observer_ros.core.estimators.protocol import Estimator

PERIOD_NS = 100_000_000
START_NS = 1_700_000_000 * 10**9
#: A heading and its rate, the heading measured (an integrator: yaw' = w).
HEADING = {'model.A': [0.0, 1.0, 0.0, 0.0], 'model.B': [0.0, 1.0], 'model.C': [1.0, 0.0],
           'model.state_names': ['yaw', 'w'], 'model.output_names': ['yaw_meas']}
ANGLES = {'model.angle_states': ['yaw'], 'model.angle_outputs': ['yaw_meas']}
TYPES_OF_OBSERVER = {
    'kalman': {'observer.type': 'kalman', 'observer.process_noise': [0.0, 1.0],
               'observer.measurement_noise': [0.01]},
    'time_varying': {'observer.type': 'kalman', 'observer.time_varying': True,
                     'observer.process_noise': [0.0, 1.0], 'observer.measurement_noise': [0.01]},
    'full_order': {'observer.type': 'full_order', 'observer.poles': ['-5', '-6']},
    'reduced_order': {'observer.type': 'reduced_order', 'observer.poles': ['-5']},
    'chen': {'observer.type': 'chen', 'observer.poles': ['-5']},
}


def wrap(values):
    return wrap_angles(values)


def heading(count=40):
    """Return a heading turning at 0.5 rad/s from 2.8 rad (it crosses pi at 0.68 s), noisy."""
    rng = np.random.default_rng(5)
    return 2.8 + 0.5 * np.arange(count) * PERIOD_NS / 1e9 + rng.normal(0.0, 0.01, count)


def run(estimator, measured):
    return np.array([estimator.update(START_NS + k * PERIOD_NS, [value], [0.0]).copy()
                     for k, value in enumerate(measured)])


def test_wrap_angles_maps_to_the_half_open_interval():
    values = wrap_angles([math.pi, -math.pi, 3 * math.pi, 0.1 - 2 * math.pi, 7.0])
    np.testing.assert_allclose(values, [math.pi, math.pi, math.pi, 0.1, 7.0 - 2 * math.pi])
    assert np.all(values > -math.pi) and np.all(values <= math.pi)


@pytest.mark.parametrize('kind', sorted(TYPES_OF_OBSERVER))
def test_a_heading_crossing_pi_keeps_the_estimate_continuous(kind):
    unwrapped = heading()
    measured = wrap(unwrapped)
    observer = TYPES_OF_OBSERVER[kind]
    system = validate_parameters({**HEADING, **observer, **ANGLES})
    estimates = run(system.observer.make_estimator(), measured)
    yaw = estimates[:, 0]
    assert np.all(yaw > -math.pi) and np.all(yaw <= math.pi)
    assert np.abs(wrap(np.diff(yaw))).max() < 0.2  # steps of about 0.05 rad
    # The same observer given the heading that never wrapped: equal modulo 2 pi.
    reference = run(validate_parameters({**HEADING, **observer}).observer.make_estimator(),
                    unwrapped)
    np.testing.assert_allclose(wrap(yaw - reference[:, 0]), 0.0, atol=1e-9)
    np.testing.assert_allclose(estimates[:, 1], reference[:, 1], rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize('kind', ['kalman', 'time_varying', 'full_order'])
def test_without_angles_the_estimate_swings_through_the_circle(kind):
    # Today's behaviour without the parameters, which the docs warn about.
    measured = wrap(heading())
    system = validate_parameters({**HEADING, **TYPES_OF_OBSERVER[kind]})
    yaw = run(system.observer.make_estimator(), measured)[:, 0]
    assert np.abs(np.diff(yaw)).max() > 1.0


def test_predictions_keep_the_angle_in_range():
    system = validate_parameters({**HEADING, **TYPES_OF_OBSERVER['kalman'], **ANGLES})
    estimator = system.observer.make_estimator()
    run(estimator, [3.0, 3.05, 3.1])
    estimator.update(START_NS + 3 * PERIOD_NS, [3.1], [0.0])
    predicted = estimator.predict(START_NS + 30 * PERIOD_NS, np.array([0.0]))
    assert -math.pi < predicted.estimate[0] <= math.pi


@pytest.mark.parametrize('change, message', [
    ({'model.angle_states': ['w']}, r'^model.angle_states: state w cannot be kept in \(-pi, '
     r'pi\]: its column of A must be zero'),
    ({'model.angle_states': ['yaw'], 'model.angle_outputs': []}, r'^model.angle_states: state '
     r'yaw cannot be kept in \(-pi, pi\]: output yaw_meas \(not in angle_outputs\) sees it'),
    ({'model.angle_outputs': ['heading']}, r'^model.angle_outputs: '),
    ({'model.C': [0.5, 0.0]}, r'^model.angle_states: state yaw cannot be kept in \(-pi, pi\]: '
     r'the angle output yaw_meas sees 0.5 times it'),
])
def test_bad_angles_are_refused_naming_the_parameter(change, message):
    with pytest.raises(ConfigError, match=message):
        validate_parameters({**HEADING, **TYPES_OF_OBSERVER['kalman'], **ANGLES, **change})


def test_a_discrete_heading_needs_the_unit_column():
    model = StateSpaceModel.from_matrices([[1.0, 0.1], [0.0, 1.0]], [[0.0], [0.1]],
                                          [[1.0, 0.0]], dt=0.1)
    assert check_angles(model, [0], [0]) == Angles((0,), (0,))
    damped = StateSpaceModel.from_matrices([[0.9, 0.1], [0.0, 1.0]], [[0.0], [0.1]],
                                           [[1.0, 0.0]], dt=0.1)
    with pytest.raises(ConfigError, match=r'^angle_states: state x1 cannot be kept .* the unit '
                                          r'column'):
        check_angles(damped, [0], [0])


def test_an_estimator_that_cannot_keep_angles_refuses_them():
    class Plain:
        """An estimator of a plug-in type that says nothing about angles."""

    with pytest.raises(ConfigError, match=r'^angle_outputs: this estimator \(Plain\) cannot '
                                          r'wrap angles'):
        Estimator.keep_angles(Plain(), Angles((0,), (0,)))
    Estimator.keep_angles(Plain(), Angles())


# --- a source whose output is an angle: the yaw of an Imu quaternion, replayed ----------

IMU_SOURCE = {
    'model.C': [1.0, 0.0, 0.0, 1.0], 'model.B': [], 'model.output_names': ['imu_yaw', 'gyro_z'],
    'observer.type': 'kalman', 'observer.time_varying': True,
    'observer.process_noise': [1e-6, 1.0], 'observer.sources': ['imu', 'wheel'],
    'sources.imu.type': 'imu', 'sources.imu.topic': '/imu/data',
    'sources.imu.fields': ['orientation.yaw'], 'sources.imu.outputs': ['imu_yaw'],
    'sources.imu.measurement_noise': [1e-4],
    'sources.wheel.type': 'vector3_stamped', 'sources.wheel.topic': '/wheel/rate',
    'sources.wheel.fields': ['vector.z'], 'sources.wheel.outputs': ['gyro_z'],
    'sources.wheel.measurement_noise': [1e-4], 'observer.history': 0.1,
    'model.angle_states': ['yaw'], 'model.angle_outputs': ['imu_yaw'],
    'topics.x_true.type': 'float64_multi_array'}


def write_turning_imu_bag(path, storage, samples=60):
    """Record an Imu whose quaternion yaw crosses pi at 0.68 s, and a rate at twice its rate."""
    truth = 2.8 + 0.5 * np.arange(2 * samples) * (PERIOD_NS / 2) / 1e9
    zeros9 = np.zeros(9)
    with Writer(path, version=9, storage_plugin=STORAGES[storage]) as writer:
        imu = writer.add_connection('/imu/data', 'sensor_msgs/msg/Imu', typestore=TYPESTORE)
        rate = writer.add_connection('/wheel/rate', 'geometry_msgs/msg/Vector3Stamped',
                                     typestore=TYPESTORE)
        true = writer.add_connection('/x_true', 'std_msgs/msg/Float64MultiArray',
                                     typestore=TYPESTORE)
        for index, yaw in enumerate(truth):
            stamp = START_NS + index * PERIOD_NS // 2
            header = TYPES['std_msgs/msg/Header'](
                stamp=TYPES['builtin_interfaces/msg/Time'](sec=stamp // 10**9,
                                                           nanosec=stamp % 10**9),
                frame_id='base')
            vector = TYPES['geometry_msgs/msg/Vector3']
            writer.write(rate, stamp, serialize(TYPES['geometry_msgs/msg/Vector3Stamped'](
                header=header, vector=vector(x=0.0, y=0.0, z=0.5))))
            writer.write(true, stamp, serialize(float64_array([yaw, 0.5])))  # never wrapped
            if index % 2 == 0:
                writer.write(imu, stamp, serialize(TYPES['sensor_msgs/msg/Imu'](
                    header=header, orientation=TYPES['geometry_msgs/msg/Quaternion'](
                        x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)),
                    orientation_covariance=zeros9,
                    angular_velocity=vector(x=0.0, y=0.0, z=0.5),
                    angular_velocity_covariance=zeros9,
                    linear_acceleration=vector(x=0.0, y=0.0, z=0.0),
                    linear_acceleration_covariance=zeros9)))
    return truth


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
@pytest.mark.parametrize('kind', ['time_varying', 'kalman', 'full_order'])
def test_replay_of_an_imu_heading_crossing_pi(tmp_path, storage, kind):
    truth = write_turning_imu_bag(tmp_path / 'turning', storage)
    # The rate alone cannot see the heading: a design per subset takes it predict-only.
    observer = {'time_varying': {},
                'kalman': {'observer.time_varying': False, 'sources.wheel.predict_only': True},
                'full_order': {'observer.type': 'full_order', 'observer.poles': ['-5', '-6'],
                               'observer.process_noise': [],
                               'sources.imu.measurement_noise': [],
                               'sources.wheel.measurement_noise': [],
                               'sources.wheel.predict_only': True}}[kind]
    parameters = {**HEADING, **IMU_SOURCE, **observer}
    result = replay_bag(tmp_path / 'turning', validate_parameters(parameters))
    assert result.counters.get('malformed', 0) == 0 and len(result.estimates) >= 100
    yaw = result.estimates[:, 0]
    assert np.all(yaw > -math.pi) and np.all(yaw <= math.pi)
    # The first estimate comes from the rate alone (heading 0), the heading from the next.
    assert np.abs(wrap(np.diff(yaw[1:]))).max() < 0.2
    stamps = (result.stamps_ns - START_NS) // (PERIOD_NS // 2)
    assert np.abs(wrap(yaw[-10:] - truth[stamps[-10:]])).max() < 0.01
    # Compared with a truth that never wraps (a simulator's x_true), the error is no turn.
    assert result.error_norms()[5:].max() < 0.05
    # Without the angle parameters the same bag swings the heading through the circle.
    plain = {**parameters, 'model.angle_states': [], 'model.angle_outputs': []}
    swung = replay_bag(tmp_path / 'turning', validate_parameters(plain)).estimates[:, 0]
    assert np.abs(np.diff(swung)).max() > 1.0


def test_the_replay_command_keeps_the_heading(tmp_path, capsys):
    from observer_ros.tools.replay import main as replay_main
    write_turning_imu_bag(tmp_path / 'turning', 'mcap', samples=30)
    config = tmp_path / 'turning.yaml'
    parameters = {**HEADING, **IMU_SOURCE}
    tree: dict = {}
    for name, value in parameters.items():
        node = tree
        *parents, leaf = name.split('.')
        for part in parents:
            node = node.setdefault(part, {})
        node[leaf] = value
    config.write_text(yaml.safe_dump({'/**': {'ros__parameters': tree}}))
    csv = tmp_path / 'estimates.csv'
    assert replay_main([str(tmp_path / 'turning'), str(config), '--csv', str(csv)]) == 0
    rows = [line.split(',') for line in csv.read_text().splitlines()[1:]]
    header = csv.read_text().splitlines()[0].split(',')
    yaw = np.array([float(row[header.index('yaw')]) for row in rows])
    assert np.all(np.abs(yaw) <= math.pi) and np.abs(wrap(np.diff(yaw[1:]))).max() < 0.2
    assert 'replayed' in capsys.readouterr().out
