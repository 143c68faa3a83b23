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
The Odometry the observer gives back: named states, ``P`` in the Odometry layout, frames.

The mapping (ROS-free), its serialization (read back by rosbags' own deserializer), the
parameters' errors, the ``/tf`` transform where ``tf2_msgs`` is installed (a fake module
here) and its clean skip where not, and ``replay`` writing the topic to its output bag.
"""

import math
import sys
import types

import numpy as np
import pytest
from rosbags.rosbag2 import Reader
from test_angles import HEADING, IMU_SOURCE, write_turning_imu_bag

from bag_support import STORAGES, TYPESTORE
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.replay_outputs import write_replay
from observer_ros.config import validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.odometry import odometry_mapping
from observer_ros.ros.odometry import OdometryPublisher, TF_TOPIC
from observer_ros.wire.odometry import OdometryEncoder, TransformEncoder

STATES = ['px', 'py', 'heading', 'v', 'w', 'bias']
FULL = {'x': 'px', 'y': 'py', 'yaw': 'heading', 'vx': 'v', 'wz': 'w'}


def random_covariance(n, seed=1):
    root = np.random.default_rng(seed).normal(size=(n, n))
    return root @ root.T + n * np.eye(n)


def test_the_pose_twist_and_covariance_come_from_the_named_states():
    p = random_covariance(6)
    x = np.array([1.0, -2.0, 2.5, 0.4, -0.3, 9.0])
    values = odometry_mapping(STATES, FULL, absent_variance=1e6).values(x, p)
    assert values.pose[:3] == (1.0, -2.0, 0.0)
    assert values.pose[3:] == (0.0, 0.0, math.sin(1.25), math.cos(1.25))
    assert values.twist == (0.4, 0.0, 0.0, 0.0, 0.0, -0.3)
    pose_rows, states = [0, 1, 5], [0, 1, 2]
    np.testing.assert_array_equal(values.pose_covariance[np.ix_(pose_rows, pose_rows)],
                                  p[np.ix_(states, states)])
    np.testing.assert_array_equal(values.twist_covariance[np.ix_([0, 5], [0, 5])],
                                  p[np.ix_([3, 4], [3, 4])])
    # Where no state is named: zero off the diagonal and the stated variance on it.
    blocks = ((values.pose_covariance, pose_rows), (values.twist_covariance, [0, 5]))
    for block, present in blocks:
        absent = [k for k in range(6) if k not in present]
        assert block[np.ix_(absent, absent)].tolist() == (1e6 * np.eye(len(absent))).tolist()
        assert not block[np.ix_(absent, present)].any()


def test_absent_states_give_zero_and_an_estimator_without_p_the_stated_variance():
    mapping = odometry_mapping(STATES, {'x': 'px', 'vx': 'v'})
    values = mapping.values(np.arange(6.0), None)
    assert values.pose == (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
    assert values.twist == (3.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert not values.pose_covariance.any() and not values.twist_covariance.any()


def test_the_odometry_and_the_transform_are_what_rosbags_reads_back():
    p = random_covariance(6)
    x = np.array([1.0, -2.0, -3.0, 0.4, -0.3, 9.0])
    values = odometry_mapping(STATES, FULL).values(x, p)
    raw = OdometryEncoder('odom', 'base_footprint').encode(
        1_700_000_000_123_456_789, values.pose, values.pose_covariance, values.twist,
        values.twist_covariance)
    message = TYPESTORE.deserialize_cdr(raw, 'nav_msgs/msg/Odometry')
    stamp = (message.header.stamp.sec, message.header.stamp.nanosec)
    assert stamp == (1_700_000_000, 123_456_789)
    assert (message.header.frame_id, message.child_frame_id) == ('odom', 'base_footprint')
    orientation = message.pose.pose.orientation
    assert math.atan2(2 * orientation.w * orientation.z,
                      1 - 2 * orientation.z ** 2) == pytest.approx(-3.0, abs=1e-15)
    assert message.pose.covariance.tolist() == values.pose_covariance.ravel().tolist()
    assert message.twist.covariance.tolist() == values.twist_covariance.ravel().tolist()
    assert message.twist.twist.angular.z == -0.3
    tf = TYPESTORE.deserialize_cdr(TransformEncoder('odom', 'base_link').encode(
        5, values.pose[:3], values.pose[3:]), 'tf2_msgs/msg/TFMessage')
    (transform,) = tf.transforms
    assert (transform.header.frame_id, transform.child_frame_id) == ('odom', 'base_link')
    assert transform.transform.translation.y == -2.0
    assert transform.transform.rotation.z == values.pose[5]


BASE = {**HEADING, **IMU_SOURCE, 'model.state_names': ['yaw', 'rate'],
        'outputs.odometry.topic': 'odom', 'outputs.odometry.yaw': 'yaw',
        'outputs.odometry.wz': 'rate'}


@pytest.mark.parametrize('change, parameter, what', [
    ({'outputs.odometry.yaw': 'theta'}, 'outputs.odometry.yaw', "'theta' is no state"),
    ({'outputs.odometry.x': 'yaw'}, 'outputs.odometry.yaw', "state 'yaw' gives x"),
    ({'outputs.odometry.yaw': '', 'outputs.odometry.wz': ''}, 'outputs.odometry.x',
     'at least one'),
    ({'outputs.odometry.frame_id': ''}, 'outputs.odometry.frame_id', 'non-empty frame id'),
    ({'outputs.odometry.child_frame_id': 'odom'}, 'outputs.odometry.child_frame_id',
     'other than'),
    ({'outputs.odometry.absent_variance': -1.0}, 'outputs.odometry.absent_variance', ''),
    ({'outputs.odometry.publish_tf': 'yes'}, 'outputs.odometry.publish_tf', ''),
])
def test_a_bad_odometry_parameter_is_refused_by_name(change, parameter, what):
    with pytest.raises(ConfigError, match=rf'^{parameter}: .*{what}'):
        validate_parameters({**BASE, **change})


class FakeNode:
    """What OdometryPublisher asks of a node: two ways to make a publisher."""

    def __init__(self):
        self.published = {}

    def topic_publisher(self, message_class, topic):
        return self._publisher(topic)

    def output_publisher(self, message_class, topic, depth):
        assert message_class.__name__ == 'TFMessage' and depth == 100
        return self._publisher(topic)

    def _publisher(self, topic):
        sent = self.published.setdefault(topic, [])
        return types.SimpleNamespace(publish=sent.append)


class Sample:
    stamp_ns, estimate, covariance = 7, np.array([0.5, 0.25]), np.diag([0.01, 0.04])


def test_without_tf2_msgs_the_transform_is_skipped_cleanly(monkeypatch):
    monkeypatch.setitem(sys.modules, 'tf2_msgs', None)  # not installed, whatever is here
    monkeypatch.setitem(sys.modules, 'tf2_msgs.msg', None)
    output = validate_parameters(BASE).observer.odometry
    node = FakeNode()
    publisher = OdometryPublisher(node, output)
    publisher.publish(Sample())
    assert publisher.transforms is None and 'tf2_msgs' in publisher.tf_skipped
    assert list(node.published) == ['odom']
    message = TYPESTORE.deserialize_cdr(node.published['odom'][0], 'nav_msgs/msg/Odometry')
    assert message.twist.twist.angular.z == 0.25 and message.twist.covariance[35] == 0.04
    assert message.pose.covariance[35] == 0.01


def test_with_tf2_msgs_the_odom_to_base_link_transform_is_published(monkeypatch):
    package = types.ModuleType('tf2_msgs')
    package.msg = types.ModuleType('tf2_msgs.msg')
    package.msg.TFMessage = type('TFMessage', (), {})
    monkeypatch.setitem(sys.modules, 'tf2_msgs', package)
    monkeypatch.setitem(sys.modules, 'tf2_msgs.msg', package.msg)
    node = FakeNode()
    publisher = OdometryPublisher(node, validate_parameters(BASE).observer.odometry)
    publisher.publish(Sample())
    assert publisher.tf_skipped is None and sorted(node.published) == [TF_TOPIC, 'odom']
    (transform,) = TYPESTORE.deserialize_cdr(node.published[TF_TOPIC][0],
                                             'tf2_msgs/msg/TFMessage').transforms
    assert (transform.header.frame_id, transform.child_frame_id) == ('odom', 'base_link')
    assert transform.transform.rotation.z == pytest.approx(math.sin(0.25), abs=1e-16)
    off = OdometryPublisher(FakeNode(), validate_parameters(
        {**BASE, 'outputs.odometry.publish_tf': False}).observer.odometry)
    assert off.transforms is None and off.tf_skipped == 'publish_tf is false'


@pytest.mark.parametrize('storage', sorted(STORAGES))
def test_replay_writes_the_odometry_topic_to_its_output_bag(tmp_path, storage):
    write_turning_imu_bag(tmp_path / 'turning', storage)
    system = validate_parameters({**BASE, 'outputs.odometry.topic': 'odometry/filtered',
                                  'outputs.odometry.child_frame_id': 'imu_link'})
    result = replay_bag(tmp_path / 'turning', system, y_topic='/imu/data')
    write_replay(result, bag=str(tmp_path / 'out'), storage=storage)
    with Reader(tmp_path / 'out') as reader:
        connections = [c for c in reader.connections if c.topic == '/odometry/filtered']
        assert [c.msgtype for c in connections] == ['nav_msgs/msg/Odometry']
        messages = [TYPESTORE.deserialize_cdr(raw, 'nav_msgs/msg/Odometry')
                    for _, _, raw in reader.messages(connections=connections)]
    assert len(messages) == len(result.stamps_ns) > 50
    for message, stamp, x, p in zip(messages, result.stamps_ns, result.estimates,
                                    result.covariances):
        assert message.header.stamp.sec * 10**9 + message.header.stamp.nanosec == stamp
        assert message.child_frame_id == 'imu_link'
        q = message.pose.pose.orientation
        assert math.atan2(2 * q.w * q.z, 1 - 2 * q.z ** 2) == pytest.approx(x[0], abs=1e-12)
        assert message.twist.twist.angular.z == x[1]
        assert message.pose.covariance[35] == p[0, 0] and message.twist.covariance[35] == p[1, 1]
