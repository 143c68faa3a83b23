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
A model written as equations in a parameter file, through replay and play_bag.

``config/nonlinear/diff_drive_ekf.yaml``: a differential-drive base's own equations, three sources
(``/joint_states``, ``/imu/data`` and a camera's ``PoseWithCovarianceStamped`` 100 ms late)
each measured by the model's expressions of its outputs. A bag written here from the
nonlinear plant (RK4 at 1 ms) goes through ``replay`` with the extended and the unscented
filter and with a steady-state Kalman filter designed at the operating point (the nonlinear
prediction), and through the unchanged observer node fed by ``play_bag``.
"""

import math

import numpy as np
import pytest
from rosbags.rosbag2 import Writer

from bag_support import serialize, STORAGES, TYPES, TYPESTORE
from conftest import CONFIG_DIR
from observer_ros.bags.replay import replay_bag
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.nonlinear import ExtendedKalman, UnscentedKalman
from observer_ros.core.nonlinear.prediction import NonlinearPrediction
from ros_support import executor_with, ros_context, spin_until

CONFIG = CONFIG_DIR / 'nonlinear' / 'diff_drive_ekf.yaml'
TOPICS = ('/joint_states', '/imu/data', '/camera/pose', '/cmd_vel')
START_NS = 1_700_000_000 * 10**9
PERIOD_NS = 10_000_000
CAMERA_LATENCY_NS = 100_000_000
SUBSTEPS = 10


def _header(stamp_ns, frame_id):
    stamp = TYPES['builtin_interfaces/msg/Time'](sec=int(stamp_ns // 10**9),
                                                 nanosec=int(stamp_ns % 10**9))
    return TYPES['std_msgs/msg/Header'](stamp=stamp, frame_id=frame_id)


def _vector(x=0.0, y=0.0, z=0.0):
    return TYPES['geometry_msgs/msg/Vector3'](x=x, y=y, z=z)


def _rk4(model, x, u, seconds, substeps=SUBSTEPS):
    h = seconds / substeps
    for _ in range(substeps):
        k1 = model.f(x, u)
        k2 = model.f(x + h / 2 * k1, u)
        k3 = model.f(x + h / 2 * k2, u)
        k4 = model.f(x + h * k3, u)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


def _pose(stamp_ns, values):
    x, y, yaw = values
    pose = TYPES['geometry_msgs/msg/Pose'](
        position=TYPES['geometry_msgs/msg/Point'](x=x, y=y, z=0.0),
        orientation=TYPES['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=math.sin(yaw / 2),
                                                          w=math.cos(yaw / 2)))
    return TYPES['geometry_msgs/msg/PoseWithCovarianceStamped'](
        header=_header(stamp_ns, 'map'),
        pose=TYPES['geometry_msgs/msg/PoseWithCovariance'](pose=pose,
                                                           covariance=np.zeros(36)))


def write_base_bag(path, samples=200, storage='mcap'):
    """
    Record the nonlinear base as ``ros2 bag record`` of :data:`TOPICS` does; return the truth.

    Wheels at 100 Hz, the IMU at 50 Hz on the same stamps, the camera at 10 Hz logged
    100 ms after its stamp (after the wheel samples of those 100 ms), the commands
    unstamped, logged just before the sample they act from. The base turns through
    +-pi, so the camera's yaw wraps.
    """
    model = validate_parameters(load_parameter_file(str(CONFIG))).model.nonlinear
    rng = np.random.default_rng(30)
    x = np.zeros(5)
    truth, pending = [], []
    zeros9 = np.zeros(9)
    with Writer(path, version=9, storage_plugin=STORAGES[storage]) as writer:
        add = {topic: writer.add_connection(topic, msgtype, typestore=TYPESTORE)
               for topic, msgtype in zip(TOPICS, (
                   'sensor_msgs/msg/JointState', 'sensor_msgs/msg/Imu',
                   'geometry_msgs/msg/PoseWithCovarianceStamped', 'geometry_msgs/msg/Twist'))}
        for index in range(samples):
            stamp = START_NS + index * PERIOD_NS
            u = np.array([0.5 + 0.3 * math.sin(index / 15), 2.0 + 0.4 * math.cos(index / 20)])
            writer.write(add['/cmd_vel'], stamp - 1000, serialize(TYPES[
                'geometry_msgs/msg/Twist'](linear=_vector(x=u[0]), angular=_vector(z=u[1]))))
            y = model.h(x, u) + rng.normal(0.0, 1e-3, size=6)
            truth.append(x.copy())
            writer.write(add['/joint_states'], stamp, serialize(TYPES[
                'sensor_msgs/msg/JointState'](
                    header=_header(stamp, ''),
                    name=['left_wheel_joint', 'right_wheel_joint', 'caster_joint'],
                    position=np.zeros(3), velocity=np.array([y[0], y[1], 0.0]),
                    effort=np.zeros(0))))
            if index % 2 == 0:
                writer.write(add['/imu/data'], stamp, serialize(TYPES['sensor_msgs/msg/Imu'](
                    header=_header(stamp, 'imu_link'),
                    orientation=TYPES['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0,
                                                                      w=1.0),
                    orientation_covariance=zeros9, angular_velocity=_vector(z=y[2]),
                    angular_velocity_covariance=zeros9, linear_acceleration=_vector(),
                    linear_acceleration_covariance=zeros9)))
            if index % 10 == 0:
                pending.append((stamp, y[3:]))
            while pending and pending[0][0] + CAMERA_LATENCY_NS <= stamp:
                taken, values = pending.pop(0)
                writer.write(add['/camera/pose'], stamp + 500_000,
                             serialize(_pose(taken, values)))
            x = _rk4(model, x, u, PERIOD_NS / 1e9)
    return np.array(truth)


def _config(tmp_path, kind):
    text = CONFIG.read_text().replace("type: 'extended_kalman'", f"type: '{kind}'")
    path = tmp_path / f'{kind}.yaml'
    path.write_text(text)
    return path


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
@pytest.mark.parametrize('kind, filter_class', [('extended_kalman', ExtendedKalman),
                                                ('unscented_kalman', UnscentedKalman)])
def test_a_bag_of_the_nonlinear_base_replays_with_the_late_camera(tmp_path, storage, kind,
                                                                  filter_class):
    bag = tmp_path / 'base'
    truth = write_base_bag(bag, storage=storage)
    result = replay_bag(bag, _config(tmp_path, kind), u_topic='/cmd_vel')
    stream = result.system.make_stream()
    assert isinstance(stream.estimator, filter_class)
    assert stream.estimator.model is result.system.model.nonlinear
    counters = result.counters
    # 200 wheel samples, 100 IMU samples on wheel stamps and 20 camera poses 100 ms late,
    # each inserted in stamp order by a re-run.
    assert counters['reruns'] >= 19 and counters.get('too_old', 0) == 0
    assert counters.get('malformed', 0) == 0 and counters.get('nonfinite', 0) == 0
    assert np.all(np.isfinite(result.estimates))
    assert np.all(np.abs(result.estimates[:, 2]) <= math.pi)
    last = result.stamps_ns == result.stamps_ns[-1]
    error = result.estimates[last][-1] - truth[-1]
    error[2] = math.remainder(error[2], 2 * math.pi)
    assert np.all(np.abs(error) < [0.02, 0.02, 0.02, 0.05, 0.05]), error
    # The heading went through +-pi: the camera's yaw wrapped, the estimate followed.
    assert truth[-1, 2] > math.pi and result.estimates[-1, 2] < 0.0


def test_a_linear_type_replays_the_bag_with_the_nonlinear_prediction(tmp_path):
    # The steady-state Kalman filter designed at the operating point, the camera updating
    # (100 ms late), the wheels and the IMU predict-only: x_prior integrates f.
    bag = tmp_path / 'base'
    truth = write_base_bag(bag, samples=300)
    config = tmp_path / 'kalman.yaml'
    config.write_text(CONFIG.read_text().replace("type: 'extended_kalman'", "type: 'kalman'")
                      .replace('        timeout: 0.1\n',
                               '        timeout: 0.1\n        predict_only: true\n'))
    result = replay_bag(bag, config, u_topic='/cmd_vel')
    assert isinstance(result.system.make_stream().estimator, NonlinearPrediction)
    assert result.counters['reruns'] >= 29 and result.counters.get('too_old', 0) == 0
    error = result.estimates[-1] - truth[-1]
    error[2] = math.remainder(error[2], 2 * math.pi)
    assert np.all(np.abs(error) < 2e-3), error


def test_the_live_node_fed_by_play_bag_equals_the_replay_of_what_it_was_given(tmp_path):
    from observer_ros.nodes.observer import ObserverNode
    from observer_ros.ros.recorder import TopicRecorder
    from ros_support import NodeProcess
    bag = tmp_path / 'base'
    write_base_bag(bag, samples=80)
    offline = replay_bag(bag, CONFIG, u_topic='/cmd_vel')
    calls = []
    with ros_context('--params-file', str(CONFIG), '-p', 'use_sim_time:=true',
                     '-r', 'u:=/cmd_vel') as context:
        observer = ObserverNode(context=context)
        stream = observer.stream
        assert isinstance(stream.estimator, ExtendedKalman)
        add_input, add_measurement = stream.add_input, stream.add_measurement

        def recorded_input(stamp_ns, u, *args):
            calls.append(('u', stamp_ns, np.array(u, dtype=float)))
            return add_input(stamp_ns, u, *args)

        def recorded_measurement(stamp_ns, y, now_ns=None, arrival_ns=0, source='y'):
            calls.append((source, stamp_ns, np.array(y, dtype=float)))
            return add_measurement(stamp_ns, y, now_ns, arrival_ns, source)
        stream.add_input, stream.add_measurement = recorded_input, recorded_measurement
        recorder = TopicRecorder(observer.system, ['x_hat'], context=context)
        with executor_with(context, observer, recorder) as executor:
            player = NodeProcess('play_bag', str(bag), '--paced-by', 'x_hat', '--trigger',
                                 *TOPICS[:3])
            finished = spin_until(executor, lambda: player.process.poll() is not None, 90.0)
            code, out, err = player.stop()
            assert finished and code == 0, err
            spin_until(executor, lambda: recorder.count('x_hat') >= len(offline.stamps_ns),
                       5.0)
            stamps, estimates = recorder.arrays('x_hat')
        assert observer.counters().get('nonfinite', 0) == 0
    assert f'{len(offline.stamps_ns)} answered, 0 unanswered' in out
    assert np.array_equal(stamps, offline.stamps_ns)
    clean = offline.system.make_stream()
    expected = []
    for source, stamp, values in calls:
        expected += (clean.add_input(stamp, values) if source == 'u'
                     else clean.add_measurement(stamp, values, source=source))
    assert np.array_equal(estimates, np.array([sample.estimate for sample in expected]))
