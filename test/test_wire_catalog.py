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
The wire catalog: one table of message types, asked by the schema, the codecs and the tools.

A message type is one entry: a type made up in this test and registered here is a
measurement source of the parameter schema, decoded and encoded by field path, and read
from a bag written in the test, with no other file touched. The two covariance-stamped
geometry types are entries of the table like any other.
"""

import math
import re

import numpy as np
import pytest
from rosbags.rosbag2 import Writer
from rosbags.typesys import get_types_from_msg, get_typestore, Stores
import yaml

from observer_ros.bags.replay import replay_bag
from observer_ros.bags.signals import read_signals, SignalSpec
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.config.schema import FIELD_MESSAGE_TYPES, source_specs
from observer_ros.core.errors import ConfigError
from observer_ros.wire import (
    FieldPathError, FieldReader, FieldWriter, find, FixedLayout, lookup, MessageType,
    register, unregister)

WALL_START_NS = 1_700_000_000 * 10**9
PERIOD_NS = 10_000_000

#: A made-up message type: a header and two wheel speeds.
WHEEL_SPEEDS = 'observer_test_msgs/msg/WheelSpeeds'
WHEEL_SPEEDS_MSG = 'std_msgs/Header header\nfloat64 left\nfloat64 right\n'
JOINTS = ['wheel_left_joint', 'wheel_right_joint']


@pytest.fixture
def wheel_speeds():
    """Register the made-up type for one test: the one entry that adds a type."""
    entry = register(MessageType('wheel_speeds', WHEEL_SPEEDS,
                                 FixedLayout(stamped=True, strings=1, doubles=('left', 'right'))))
    yield entry
    unregister('wheel_speeds')


def typestore_with_wheel_speeds():
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(WHEEL_SPEEDS_MSG, WHEEL_SPEEDS))
    return store


def stamp(store, stamp_ns):
    return store.types['std_msgs/msg/Header'](
        stamp=store.types['builtin_interfaces/msg/Time'](sec=stamp_ns // 10**9,
                                                         nanosec=stamp_ns % 10**9),
        frame_id='base_link')


def drive_section(sources):
    """Return a differential drive's parameters: wheel speeds from ``sources``, (v, w) given."""
    return {'/**': {'ros__parameters': {
        'model': {'A': [-10.0, 0.0, 0.0, -10.0], 'B': [303.0, -24.2, 303.0, 24.2],
                  'C': [1.0, 0.0, 0.0, 1.0], 'state_names': ['wl', 'wr'],
                  'input_names': ['v_cmd', 'w_cmd'], 'output_names': list(JOINTS)},
        'observer': {'type': 'kalman', 'process_noise': [1.0, 1.0],
                     'initial_state': [0.0, 0.0], 'sources': list(sources)},
        'topics': {'u': {'type': 'twist', 'fields': ['linear.x', 'angular.z']}},
        'sources': sources}}}


def write_parameters(path, sources):
    path.write_text(yaml.safe_dump(drive_section(sources)))
    return path


def test_a_type_added_in_the_test_is_a_source_a_codec_and_a_bag_topic(tmp_path, wheel_speeds):
    # The schema offers it as a source type, from the table.
    assert FIELD_MESSAGE_TYPES['wheel_speeds'] == WHEEL_SPEEDS
    (type_spec,) = [spec for spec in source_specs('wheels') if spec.name.endswith('.type')]
    assert 'wheel_speeds' in type_spec.choices
    # Encoded and decoded by field path, as rosbags serializes it.
    store = typestore_with_wheel_speeds()
    message = store.types[WHEEL_SPEEDS](header=stamp(store, 2_500_000_001), left=1.25,
                                        right=-0.5)
    raw = bytes(store.serialize_cdr(message, WHEEL_SPEEDS))
    read = FieldReader('wheel_speeds', ['right', 'left']).read(raw)
    assert read == (2_500_000_001, [-0.5, 1.25])
    written = FieldWriter(WHEEL_SPEEDS, ['left', 'right']).write(7, [3.0, 4.0])
    back = store.deserialize_cdr(written, WHEEL_SPEEDS)
    assert (back.left, back.right, back.header.stamp.nanosec) == (3.0, 4.0, 7)
    with pytest.raises(FieldPathError, match="'middle' is no field of observer_test_msgs/msg/"
                                             'WheelSpeeds; it has left, right'):
        FieldReader('wheel_speeds', ['middle'])
    # A source of the configuration, its path checked against the entry.
    wheels = {'wheels': {'topic': '/wheels', 'type': 'wheel_speeds', 'fields': ['left', 'right'],
                         'outputs': list(JOINTS), 'measurement_noise': [0.01, 0.01]}}
    system = validate_parameters(load_parameter_file(str(write_parameters(
        tmp_path / 'wheels.yaml', wheels))), strict=True)
    assert system.observer.sources.msgtypes == (WHEEL_SPEEDS,)
    wrong = {'wheels': dict(wheels['wheels'], fields=['left', 'middle'])}
    with pytest.raises(ConfigError, match="^sources.wheels.fields: 'middle' is no field of "
                                          'observer_test_msgs/msg/WheelSpeeds'):
        validate_parameters(load_parameter_file(str(write_parameters(
            tmp_path / 'wrong.yaml', wrong))), strict=True)
    # Read from a bag written here: the replay of the made-up type equals the replay of the
    # same speeds recorded as JointState sources, estimate for estimate.
    joint_sources = {'wheels': {'topic': '/joint_states', 'type': 'joint_state',
                                'fields': [f'velocity.{joint}' for joint in JOINTS],
                                'outputs': list(JOINTS), 'measurement_noise': [0.01, 0.01]}}
    bag = write_drive_bag(tmp_path / 'bag', store)
    made_up = replay_bag(bag, tmp_path / 'wheels.yaml', u_topic='/cmd_vel')
    joints = replay_bag(bag, write_parameters(tmp_path / 'joints.yaml', joint_sources),
                        u_topic='/cmd_vel')
    assert len(made_up.stamps_ns) > 40
    assert np.array_equal(made_up.stamps_ns, joints.stamps_ns)
    assert np.array_equal(made_up.estimates, joints.estimates)
    ((_, data),) = read_signals(bag, [SignalSpec.parse('/wheels:right')])
    assert data.stamps_ns[0] == WALL_START_NS and data.values.shape == (60, 1)


def test_a_registered_type_leaves_the_table_as_it_was(wheel_speeds):
    with pytest.raises(ValueError, match='registered already'):
        register(wheel_speeds)
    unregister('wheel_speeds')
    assert find(WHEEL_SPEEDS) is None and 'wheel_speeds' not in FIELD_MESSAGE_TYPES
    register(wheel_speeds)  # for the fixture to remove


def write_drive_bag(path, store, samples=60):
    """``/cmd_vel`` (Twist) and the same wheel speeds as WheelSpeeds and as JointState."""
    types = store.types
    rng = np.random.default_rng(3)
    with Writer(path, version=9) as writer:
        commands = writer.add_connection('/cmd_vel', 'geometry_msgs/msg/Twist', typestore=store)
        wheels = writer.add_connection('/wheels', WHEEL_SPEEDS, typestore=store)
        joints = writer.add_connection('/joint_states', 'sensor_msgs/msg/JointState',
                                       typestore=store)
        vector = types['geometry_msgs/msg/Vector3']
        for index in range(samples):
            logged = WALL_START_NS + index * PERIOD_NS
            command = types['geometry_msgs/msg/Twist'](
                linear=vector(x=0.2 + 0.1 * math.sin(index / 10), y=0.0, z=0.0),
                angular=vector(x=0.0, y=0.0, z=0.5 * math.cos(index / 15)))
            writer.write(commands, logged - 1000,
                         store.serialize_cdr(command, command.__msgtype__))
            left, right = rng.normal(0.0, 0.1, size=2)
            speeds = types[WHEEL_SPEEDS](header=stamp(store, logged), left=left, right=right)
            writer.write(wheels, logged, store.serialize_cdr(speeds, WHEEL_SPEEDS))
            state = types['sensor_msgs/msg/JointState'](
                header=stamp(store, logged), name=JOINTS, position=np.zeros(2),
                velocity=np.array([left, right]), effort=np.zeros(0))
            writer.write(joints, logged + 1, store.serialize_cdr(state, state.__msgtype__))
    return path


# --- geometry_msgs/PoseWithCovarianceStamped and TwistWithCovarianceStamped ------------------

POSE_FIELDS = ['pose.pose.position.x', 'pose.pose.orientation.yaw', 'pose.covariance[0]',
               'pose.covariance[35]']
TWIST_FIELDS = ['twist.twist.linear.x', 'twist.twist.angular.z', 'twist.covariance[35]']


def test_the_covariance_stamped_types_are_entries_of_the_table():
    pose = lookup('pose_with_covariance_stamped')
    twist = lookup('geometry_msgs/TwistWithCovarianceStamped')
    assert pose.msgtype == 'geometry_msgs/msg/PoseWithCovarianceStamped' and pose.stamped
    assert twist.msgtype == 'geometry_msgs/msg/TwistWithCovarianceStamped' and twist.stamped
    assert not pose.vector and not twist.vector and not pose.commands
    assert len(pose.fields) == 7 + 36 and len(twist.fields) == 6 + 36


def test_the_covariance_stamped_types_round_trip_with_rclpy():
    from geometry_msgs.msg import PoseWithCovarianceStamped, TwistWithCovarianceStamped
    from rclpy.serialization import deserialize_message, serialize_message
    pose = PoseWithCovarianceStamped()
    pose.header.stamp.sec, pose.header.stamp.nanosec = 12, 345
    pose.header.frame_id = 'map'
    pose.pose.pose.position.x = 1.5
    pose.pose.pose.orientation.z, pose.pose.pose.orientation.w = math.sin(0.2), math.cos(0.2)
    pose.pose.covariance[0], pose.pose.covariance[35] = 0.01, 0.04
    stamp_ns, values = FieldReader('pose_with_covariance_stamped', POSE_FIELDS).read(
        serialize_message(pose))
    assert stamp_ns == 12_000_000_345
    assert values[0] == 1.5 and values[2:] == [0.01, 0.04]
    assert values[1] == pytest.approx(0.4, abs=1e-15)
    twist = TwistWithCovarianceStamped()
    twist.header.frame_id = 'odom'
    twist.twist.twist.linear.x, twist.twist.twist.angular.z = 0.3, -0.7
    twist.twist.covariance[35] = 0.09
    reader = FieldReader('geometry_msgs/msg/TwistWithCovarianceStamped', TWIST_FIELDS)
    assert reader.read(serialize_message(twist)) == (0, [0.3, -0.7, 0.09])
    # Written by field path, read back by rclpy.
    writer = FieldWriter('twist_with_covariance_stamped', TWIST_FIELDS)
    back = deserialize_message(writer.write(5_000_000_001, [0.25, 1.5, 0.5]),
                               TwistWithCovarianceStamped)
    assert (back.header.stamp.sec, back.header.stamp.nanosec) == (5, 1)
    assert (back.twist.twist.linear.x, back.twist.twist.angular.z) == (0.25, 1.5)
    assert back.twist.covariance[35] == 0.5 and sum(back.twist.covariance) == 0.5


def test_the_covariance_stamped_types_read_from_a_rosbags_bag(tmp_path):
    store = get_typestore(Stores.ROS2_JAZZY)
    types = store.types
    point = types['geometry_msgs/msg/Point']
    quaternion = types['geometry_msgs/msg/Quaternion']
    vector = types['geometry_msgs/msg/Vector3']
    with Writer(tmp_path / 'bag', version=9) as writer:
        poses = writer.add_connection('/mocap/pose',
                                      'geometry_msgs/msg/PoseWithCovarianceStamped',
                                      typestore=store)
        twists = writer.add_connection('/odom/twist',
                                       'geometry_msgs/msg/TwistWithCovarianceStamped',
                                       typestore=store)
        for index in range(5):
            stamped = stamp(store, WALL_START_NS + index * PERIOD_NS)
            covariance = np.arange(36, dtype=float) * index
            pose = types['geometry_msgs/msg/PoseWithCovarianceStamped'](
                header=stamped, pose=types['geometry_msgs/msg/PoseWithCovariance'](
                    pose=types['geometry_msgs/msg/Pose'](
                        position=point(x=float(index), y=0.0, z=0.0),
                        orientation=quaternion(x=0.0, y=0.0, z=0.0, w=1.0)),
                    covariance=covariance))
            twist = types['geometry_msgs/msg/TwistWithCovarianceStamped'](
                header=stamped, twist=types['geometry_msgs/msg/TwistWithCovariance'](
                    twist=types['geometry_msgs/msg/Twist'](
                        linear=vector(x=0.5 * index, y=0.0, z=0.0),
                        angular=vector(x=0.0, y=0.0, z=-index)),
                    covariance=covariance))
            log_ns = WALL_START_NS + index * PERIOD_NS + 500
            writer.write(poses, log_ns, store.serialize_cdr(pose, pose.__msgtype__))
            writer.write(twists, log_ns, store.serialize_cdr(twist, twist.__msgtype__))
    (_, pose_data), (_, twist_data) = read_signals(tmp_path / 'bag', [
        SignalSpec.parse('/mocap/pose:' + ','.join(POSE_FIELDS)),
        SignalSpec.parse('/odom/twist:' + ','.join(TWIST_FIELDS))])
    expected_stamps = WALL_START_NS + np.arange(5) * PERIOD_NS
    assert np.array_equal(pose_data.stamps_ns, expected_stamps)
    assert pose_data.values.tolist() == [[k, 0.0, 0.0, 35.0 * k] for k in range(5)]
    assert twist_data.values.tolist() == [[0.5 * k, -k, 35.0 * k] for k in range(5)]


def test_a_configuration_uses_the_covariance_stamped_types_and_refuses_bad_paths(tmp_path):
    sources = {
        'mocap': {'topic': '/mocap/pose', 'type': 'pose_with_covariance_stamped',
                  'fields': ['pose.pose.position.x'], 'outputs': [JOINTS[0]],
                  'measurement_noise': [0.01]},
        'odom': {'topic': '/odom/twist', 'type': 'twist_with_covariance_stamped',
                 'fields': ['twist.twist.angular.z'], 'outputs': [JOINTS[1]],
                 'measurement_noise': [0.01]}}
    system = validate_parameters(load_parameter_file(str(write_parameters(
        tmp_path / 'good.yaml', sources))), strict=True)
    assert system.observer.sources.msgtypes == (
        'geometry_msgs/msg/PoseWithCovarianceStamped',
        'geometry_msgs/msg/TwistWithCovarianceStamped')
    for name, path in (('mocap', 'pose.position.x'), ('odom', 'twist.angular.z'),
                       ('mocap', 'pose.covariance[36]')):
        wrong = {**sources, name: dict(sources[name], fields=[path])}
        with pytest.raises(ConfigError, match=rf"^sources\.{name}\.fields: '{re.escape(path)}' "
                                              rf'is no field of geometry_msgs/msg/'):
            validate_parameters(load_parameter_file(str(write_parameters(
                tmp_path / f'{name}.yaml', wrong))), strict=True)
