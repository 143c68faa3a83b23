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
8. Message decoding: the cost of reading each message type's fields from its bytes.

For each type a node reads by field path, the cost of :class:`FieldCodec.decode_values` on
the serialized message (what a raw subscription hands over) against rclpy's own
``deserialize_message`` followed by reading the same fields, and against today's JointState
reader (:class:`VectorCodec`, the hot path of ``/joint_states``). Each comparison is timed in
one sitting, the two alternately, best of several rounds.
"""

from rclpy.serialization import deserialize_message, serialize_message

from benchmarks.common import per_call, Section
from observer_ros.ros.messages import FieldCodec, message_class, VectorCodec

#: Within this many times the JointState reader's cost (the issue's goal).
GOAL = 1.5

#: The types and the fields a robot configuration typically reads from them.
CASES = (
    ('sensor_msgs/msg/JointState', ('velocity.left_wheel', 'velocity.right_wheel')),
    ('std_msgs/msg/Float64MultiArray', ('data[0]', 'data[1]')),
    ('std_msgs/msg/Float64', ('data',)),
    ('sensor_msgs/msg/Imu', ('angular_velocity.z', 'linear_acceleration.x')),
    ('nav_msgs/msg/Odometry', ('twist.twist.linear.x', 'twist.twist.angular.z')),
    ('geometry_msgs/msg/PoseStamped', ('pose.position.x', 'pose.position.y',
                                       'pose.orientation.yaw')),
    ('geometry_msgs/msg/TwistStamped', ('twist.linear.x', 'twist.angular.z')),
    ('geometry_msgs/msg/WrenchStamped', ('wrench.force.z',)),
    ('geometry_msgs/msg/PointStamped', ('point.x', 'point.y')),
    ('geometry_msgs/msg/Vector3Stamped', ('vector.z',)),
    ('geometry_msgs/msg/Twist', ('linear.x', 'angular.z')),
)


def example(msgtype: str):
    """Return a message of ``msgtype`` as a robot publishes it (frame ids, a stamp)."""
    message = message_class(msgtype)()
    if msgtype.endswith('JointState'):
        message.name = ['left_wheel', 'right_wheel', 'caster']
        message.position, message.velocity = [0.1, 0.2, 0.3], [1.0, 2.0, 3.0]
        message.effort = [0.0, 0.0, 0.0]
    elif msgtype.endswith('MultiArray'):
        message.data = [1.0, 2.0, 3.0]
    if hasattr(message, 'header'):
        message.header.frame_id = 'base_link'
        message.header.stamp.sec, message.header.stamp.nanosec = 1_700_000_000, 123
    if hasattr(message, 'child_frame_id'):
        message.child_frame_id = 'base_footprint'
    if msgtype.endswith('PoseStamped'):
        message.pose.orientation.w = 1.0
    return message


def rclpy_reader(msgtype: str, fields):
    """Deserialize with rclpy and read the fields from the message object."""
    cls = message_class(msgtype)
    codec = FieldCodec('y', msgtype, fields)
    return lambda raw: codec.decode_values(deserialize_message(raw, cls))


def run(smoke: bool, figures) -> Section:
    """Measure and return the section."""
    section = Section(8, 'Message decoding', f'each type decoded within {GOAL}x of the '
                      "JointState reader; rclpy's deserialization as the baseline")
    repeat, rounds = (300, 2) if smoke else (20_000, 5)
    joint_state = serialize_message(example('sensor_msgs/msg/JointState'))
    baseline = VectorCodec('y', 'joint_state', 'velocity', ['left_wheel', 'right_wheel'])
    rows, worst = [], 0.0
    for msgtype, fields in CASES:
        raw = serialize_message(example(msgtype))
        codec = FieldCodec('y', msgtype, fields)
        ours = reference = ros = float('inf')
        general = rclpy_reader(msgtype, fields)
        for _ in range(rounds):  # alternately, so that the load of the machine hits all
            ours = min(ours, per_call(lambda: codec.decode_values(raw), repeat, 1))
            reference = min(reference, per_call(lambda: baseline.decode_values(joint_state),
                                                repeat, 1))
            ros = min(ros, per_call(lambda: general(raw), max(1, repeat // 5), 1))
        worst = max(worst, ours / reference)
        rows.append([f'`{msgtype}`', ', '.join(f'`{field}`' for field in fields),
                     f'{ours * 1e9:.0f} ns', f'{ros * 1e9:.0f} ns',
                     f'**{ros / ours:.1f}x** faster', f'{ours / reference:.2f}'])
    section.add(f'Serialized messages as a raw subscription receives them; '
                f'"JointState reader" = today\'s `/joint_states` path '
                f'({reference * 1e9:.0f} ns in the last round). Worst ratio to it: '
                f'**{worst:.2f}**.', '')
    section.table(['type', 'fields', 'field codec', 'rclpy deserialize + fields',
                   'rclpy / codec', 'codec / JointState reader'], rows)
    section.met = worst <= GOAL
    return section
