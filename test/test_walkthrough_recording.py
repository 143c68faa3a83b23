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

"""The walkthrough's recording (scripts/record_robot.py) and the tools' repeated options."""

import importlib.util

import numpy as np
import pytest
from rosbags.highlevel import AnyReader
from rosbags.typesys import get_typestore, Stores

from conftest import REPOSITORY
from observer_ros.bags.reading import read_topic
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.tools.identify import main as identify
from observer_ros.tools.tune_kalman import main as tune_kalman

INPUTS = ['--inputs', '/cmd_vel:linear.x,angular.z']
WHEELS = '/joint_states:velocity:left_wheel_joint,right_wheel_joint'
IMU = '/imu/data:linear_acceleration.x,angular_velocity.z'


def record_robot():
    """Import scripts/record_robot.py (a script, not a module of the package)."""
    spec = importlib.util.spec_from_file_location(
        'record_robot', REPOSITORY / 'scripts' / 'record_robot.py')
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope='module')
def robot_bag(tmp_path_factory):
    path = tmp_path_factory.mktemp('walkthrough') / 'robot'
    assert record_robot().main([str(path), '--seconds', '40']) == 0
    return path


def test_the_recording_is_jittered_and_robot_like(robot_bag, capsys):
    joints = read_topic(robot_bag, '/joint_states', 'joint_state', 'velocity',
                        ['left_wheel_joint', 'right_wheel_joint'])
    intervals = np.diff(joints.stamps_ns) / 1e6
    assert len(joints.stamps_ns) == 2000
    # 20 ms +- 3 ms: far more than the 2 % the tools accept without --resample.
    assert 14.0 <= intervals.min() < 16.0 and 24.0 < intervals.max() <= 26.0
    assert np.mean(np.abs(intervals - 20.0) > 0.4) > 0.8


def read_messages(bag, topic):
    """Return the log times and messages of one topic of a bag."""
    with AnyReader([bag], default_typestore=get_typestore(Stores.ROS2_JAZZY)) as reader:
        connections = [c for c in reader.connections if c.topic == topic]
        return [(log_ns, reader.deserialize(raw, connection.msgtype))
                for connection, log_ns, raw in reader.messages(connections=connections)]


def test_each_command_closes_the_loop_on_the_latest_measurement(robot_bag):
    # The open-loop recording sent one command per 20 samples whatever the sensors read; a
    # velocity loop sends one before each sample but the first, computed from the latest
    # one: v_cmd = v_ref + k (v_ref - v_meas) with k = 1, v_meas the mean wheel velocity
    # / 10 and w_meas the gyro, so v_cmd + v_meas is 2 v_ref, constant while the reference
    # holds (the commands computed from samples 20 j .. 20 j + 19).
    commands = read_messages(robot_bag, '/cmd_vel')
    wheels = read_messages(robot_bag, '/joint_states')
    imu = read_messages(robot_bag, '/imu/data')
    assert len(commands) == len(wheels) - 1 == len(imu) - 1 == 1999
    sent = np.array([log_ns for log_ns, _ in commands])
    logged = np.array([log_ns for log_ns, _ in wheels])
    # Each command is sent between the sample it is computed from and the next one.
    assert np.all(logged[:-1] < sent) and np.all(sent < logged[1:])
    command = np.array([[m.linear.x, m.angular.z] for _, m in commands])
    measured = np.array([[np.mean(m.velocity) / 10.0 for _, m in wheels[:-1]],
                         [m.angular_velocity.z for _, m in imu[:-1]]]).T
    twice_reference = command + measured
    blocks = [twice_reference[start:start + 20] for start in range(0, 1999, 20)]
    assert max(np.ptp(block, axis=0).max() for block in blocks) < 1e-9
    # The command moves with the measurement noise within a reference's hold.
    assert min(np.std(command[start:start + 20], axis=0).min()
               for start in range(20, 1980, 20)) > 1e-3


def test_the_recording_refuses_bad_options(tmp_path, capsys):
    script = record_robot()
    with pytest.raises(SystemExit):
        script.main([str(tmp_path / 'bag'), '--jitter', '0.02'])
    assert '--jitter: expected 0 <= jitter < half the period (0.01 s), got 0.02' in \
        capsys.readouterr().err
    with pytest.raises(SystemExit):
        script.main([str(tmp_path / 'bag'), '--rate', '0'])
    assert '--rate: expected a positive number, got 0.0' in capsys.readouterr().err
    with pytest.raises(SystemExit):
        script.main([str(tmp_path / 'bag'), '--gain', '-1'])
    assert '--gain: expected a finite number >= 0, got -1.0' in capsys.readouterr().err


def test_identify_finds_the_accelerometer_feedthrough(robot_bag, tmp_path, capsys):
    model = tmp_path / 'robot.yaml'
    assert identify([str(robot_bag), '--order', '2', *INPUTS, '--outputs', WHEELS, IMU,
                     '--feedthrough', 'fit', '--resample', '50', '--continuous', '-o',
                     str(model)]) == 0
    found = validate_parameters(load_parameter_file(str(model)), strict=True).model
    poles = np.sort(np.linalg.eigvals(found.a).real)
    # The base's time constant is 0.2 s in both axes; the accelerometer's D is [5, 0].
    assert np.allclose(poles, [-5.0, -5.0], rtol=0.05)
    assert found.d[2, 0] == pytest.approx(5.0, rel=0.1)


def test_a_repeated_outputs_option_adds_its_topics(robot_bag, tmp_path, capsys):
    # --outputs A --outputs B used to keep B alone, silently: a model of the IMU only.
    base = [str(robot_bag), '--order', '2', *INPUTS, '--resample', '50']
    assert identify([*base, '--outputs', WHEELS, IMU]) == 0
    together = capsys.readouterr().out
    assert identify([*base, '--outputs', WHEELS, '--outputs', IMU]) == 0
    repeated = capsys.readouterr().out
    assert 'outputs left_wheel_joint, right_wheel_joint, linear_acceleration.x, ' \
        'angular_velocity.z;' in repeated
    assert repeated == together
    model = tmp_path / 'model.yaml'
    assert identify([*base, '--outputs', WHEELS, IMU, '-o', str(model)]) == 0
    capsys.readouterr()
    tuned = [str(robot_bag), str(model), '--resample', '50', '--accept-failed-checks']
    assert tune_kalman([*tuned, *INPUTS, '--outputs', WHEELS, IMU]) == 0
    together = capsys.readouterr().out
    assert tune_kalman([*tuned, '--inputs', '/cmd_vel:linear.x,angular.z', '--outputs', WHEELS,
                        '--outputs', IMU]) == 0
    assert capsys.readouterr().out == together
