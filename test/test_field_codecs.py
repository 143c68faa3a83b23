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
The messages robots publish, read by field path, against rclpy's own serialization.

For every type: random messages serialized by rclpy decode to the values read from the
rclpy message object (bit for bit; the derived angles against scipy's rotations), the
writer's bytes deserialize to what was written, truncated bytes and random bytes raise
MalformedMessage (never a crash, never a non-finite value), and a wrong field path names the
path, the type and the fields it has.
"""

import math

from hypothesis import assume, given, HealthCheck, settings, strategies as st
import numpy as np
import pytest
from rclpy.serialization import deserialize_message, serialize_message
from scipy.spatial.transform import Rotation

from observer_ros.ros.messages import FieldCodec, MalformedMessage, message_class
from observer_ros.wire import (
    decode_fields, field_names, FIELD_TYPES, FieldPathError, FieldReader, FIXED_LAYOUTS,
    parse_layout, quaternions)

SETTINGS = settings(max_examples=30, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])
FINITE = st.floats(allow_nan=False, allow_infinity=False, width=64)
TEXT = st.text(st.characters(blacklist_categories=['Cs'], blacklist_characters='\x00'),
               max_size=12)


def set_path(message, path: str, value) -> None:
    *parents, leaf = path.split('.')
    for name in parents:
        message = getattr(message, name)
    setattr(message, leaf, value)


def get_path(message, path: str):
    """Read a field path from a message object: the test's own reading, not the codec's."""
    *parents, leaf = path.split('.')
    for name in parents:
        message = getattr(message, name)
    if leaf.endswith(']'):
        name, index = leaf[:-1].split('[')
        return float(getattr(message, name)[int(index)])
    return float(getattr(message, leaf))


@st.composite
def fixed_messages(draw, msgtype: str):
    """Draw a message of a fixed-layout type and a choice of its field paths."""
    layout = FIXED_LAYOUTS[msgtype]
    message = message_class(msgtype)()
    arrays: dict = {}
    for path in layout.doubles:
        value = draw(FINITE)
        if path.endswith(']'):
            name = path[:path.index('[')]
            arrays.setdefault(name, []).append(value)
        else:
            set_path(message, path, value)
    for name, values in arrays.items():
        set_path(message, name, values)
    if layout.stamped:
        message.header.frame_id = draw(TEXT)
        message.header.stamp.sec = draw(st.integers(0, 2 ** 31 - 1))
        message.header.stamp.nanosec = draw(st.integers(0, 999_999_999))
    if msgtype.endswith('Odometry'):
        message.child_frame_id = draw(TEXT)
    paths = [p for p in field_names(msgtype) if '[' not in p]
    paths += [p for p in layout.doubles if '[' in p]
    fields = draw(st.lists(st.sampled_from(paths), min_size=1, max_size=6))
    return message, fields


def expected_values(message, fields) -> list:
    values = []
    for path in fields:
        prefix, _, leaf = path.rpartition('.')
        if leaf in ('roll', 'pitch', 'yaw'):
            values.append(None)  # checked against scipy below
        else:
            values.append(get_path(message, path))
    return values


@pytest.mark.parametrize('msgtype', sorted(FIXED_LAYOUTS))
@SETTINGS
@given(data=st.data())
def test_fixed_layout_types_decode_what_rclpy_serialized(msgtype, data):
    message, fields = data.draw(fixed_messages(msgtype))
    raw = serialize_message(message)
    reader = FieldReader(msgtype, fields)
    stamp, values = reader.read(raw)
    layout = FIXED_LAYOUTS[msgtype]
    if layout.stamped:
        assert stamp == message.header.stamp.sec * 10 ** 9 + message.header.stamp.nanosec
    else:
        assert stamp == 0
    for path, value, expected in zip(fields, values, expected_values(message, fields)):
        if expected is not None:
            assert value == expected or (math.isnan(value) and math.isnan(expected)), path
    stamps, batch, errors = decode_fields([raw, raw[:-1]], msgtype, fields)
    assert stamps[0] == stamp and list(errors) == [1]
    assert np.array_equal(batch[0], values) and np.isfinite(values).all()


@pytest.mark.parametrize('msgtype', sorted(FIXED_LAYOUTS))
@SETTINGS
@given(data=st.data())
def test_truncated_and_random_bytes_are_malformed_never_a_crash(msgtype, data):
    message, fields = data.draw(fixed_messages(msgtype))
    raw = serialize_message(message)
    codec = FieldCodec('topic', msgtype, fields)
    cut = data.draw(st.integers(0, len(raw) - 1))
    with pytest.raises(MalformedMessage, match='^topic: '):
        codec.decode(raw[:cut])
    garbage = b'\x00\x01\x00\x00' + data.draw(st.binary(max_size=len(raw) + 8))
    try:
        _, values = codec.decode(garbage)
    except MalformedMessage:
        return
    assert np.isfinite(values).all() and len(values) == len(fields)


@pytest.mark.filterwarnings('ignore:Gimbal lock detected')
@pytest.mark.parametrize('msgtype', sorted(
    t for t in FIXED_LAYOUTS if quaternions(FIXED_LAYOUTS[t])))
@SETTINGS
@given(data=st.data())
def test_the_derived_angles_equal_scipy_s_rotation(msgtype, data):
    prefix = quaternions(FIXED_LAYOUTS[msgtype])[0]
    quaternion = data.draw(st.lists(st.floats(-1, 1), min_size=4, max_size=4))
    scale = data.draw(st.sampled_from([1.0, 0.5, 3.0]))
    norm = math.sqrt(sum(q * q for q in quaternion))
    assume(norm > 0.1)
    yaw, pitch, roll = Rotation.from_quat(quaternion).as_euler('ZYX')
    assume(abs(pitch) < math.radians(89))  # away from gimbal lock
    message = message_class(msgtype)()
    for name, value in zip('xyzw', quaternion):
        set_path(message, f'{prefix}.{name}', value / norm * scale)
    fields = [f'{prefix}.yaw', f'{prefix}.pitch', f'{prefix}.roll']
    _, values = FieldCodec('pose', msgtype, fields).decode(serialize_message(message))
    wrapped = np.angle(np.exp(1j * (values - np.array([yaw, pitch, roll]))))  # -pi is pi
    np.testing.assert_allclose(wrapped, 0.0, atol=1e-9)
    _, from_object = FieldCodec('pose', msgtype, fields).decode(message)
    np.testing.assert_allclose(from_object, values, atol=1e-12)


@st.composite
def joint_states(draw):
    names = draw(st.lists(TEXT.filter(bool), min_size=1, max_size=5, unique=True))
    message = message_class('sensor_msgs/msg/JointState')(name=names)
    message.header.stamp.sec = draw(st.integers(0, 2 ** 31 - 1))
    message.header.frame_id = draw(TEXT)
    for field in ('position', 'velocity', 'effort'):
        if draw(st.booleans()):
            setattr(message, field, draw(st.lists(FINITE, min_size=len(names),
                                                  max_size=len(names))))
    filled = [field for field in ('position', 'velocity', 'effort')
              if len(getattr(message, field))]
    assume(filled)
    fields = draw(st.lists(st.tuples(st.sampled_from(filled), st.sampled_from(names)),
                           min_size=1, max_size=4, unique=True))
    return message, [f'{field}.{joint}' for field, joint in fields]


def content_end(raw: bytes) -> int:
    """Where a JointState's content ends (rclpy may add padding after it)."""
    offset, count = parse_layout(raw, 'joint_state').arrays['effort']
    return offset + 8 * count


@SETTINGS
@given(case=joint_states())
def test_joint_states_decode_by_field_and_joint_name(case):
    message, fields = case
    raw = serialize_message(message)
    stamp, values = FieldCodec('joints', 'sensor_msgs/msg/JointState', fields).decode(raw)
    expected = []
    for path in fields:
        field, joint = path.split('.', 1)
        expected.append(getattr(message, field)[list(message.name).index(joint)])
    assert values.tolist() == expected
    assert (stamp or 0) == message.header.stamp.sec * 10 ** 9
    assert FieldCodec('joints', 'sensor_msgs/msg/JointState', fields).decode(
        message)[1].tolist() == expected
    with pytest.raises(MalformedMessage):
        FieldCodec('joints', 'sensor_msgs/JointState', ['position.nobody']).decode(raw)
    with pytest.raises(MalformedMessage):
        FieldCodec('joints', 'joint_state', fields).decode(raw[:content_end(raw) - 1])


@SETTINGS
@given(data=st.lists(FINITE, min_size=1, max_size=8), labels=st.lists(TEXT, max_size=2),
       picks=st.data())
def test_float64_arrays_decode_by_index(data, labels, picks):
    std = __import__('std_msgs.msg', fromlist=['msg'])
    message = std.Float64MultiArray(data=data)
    message.layout.dim = [std.MultiArrayDimension(label=label, size=1, stride=1)
                          for label in labels]
    indices = picks.draw(st.lists(st.integers(0, len(data) - 1), min_size=1, max_size=4))
    fields = [f'data[{k}]' for k in indices]
    stamp, values = FieldCodec('u', 'std_msgs/msg/Float64MultiArray', fields).decode(
        serialize_message(message))
    assert stamp is None and values.tolist() == [data[k] for k in indices]
    with pytest.raises(MalformedMessage, match=f'at least {len(data) + 1} values'):
        FieldCodec('u', 'float64_multi_array', [f'data[{len(data)}]']).decode(
            serialize_message(message))
    one = std.Float64(data=data[0])
    assert FieldCodec('u', 'std_msgs/Float64', ['data']).decode(
        serialize_message(one))[1].tolist() == [data[0]]


@pytest.mark.parametrize('msgtype', sorted(FIXED_LAYOUTS))
def test_the_writer_s_bytes_deserialize_to_what_was_written(msgtype):
    layout = FIXED_LAYOUTS[msgtype]
    fields = list(layout.doubles[::3])
    values = [0.5 + k for k in range(len(fields))]
    codec = FieldCodec('u_cmd', msgtype, fields)
    message = deserialize_message(codec.encode(1_500_000_007, values), message_class(msgtype))
    assert [get_path(message, path) for path in fields] == values
    others = [path for path in layout.doubles if path not in fields]
    assert all(get_path(message, path) == 0.0 for path in others)
    if layout.stamped:
        assert (message.header.stamp.sec, message.header.stamp.nanosec) == (1, 500_000_007)
    assert codec.decode(codec.encode(7, values))[1].tolist() == values


def test_non_finite_values_and_bad_stamps_are_malformed():
    imu = message_class('sensor_msgs/msg/Imu')()
    imu.angular_velocity.z = math.nan
    codec = FieldCodec('imu0', 'sensor_msgs/Imu', ['angular_velocity.z'])
    with pytest.raises(MalformedMessage, match='^imu0: non-finite value'):
        codec.decode(serialize_message(imu))
    imu.angular_velocity.z = 1.0
    raw = bytearray(serialize_message(imu))
    raw[8:12] = (2_000_000_000).to_bytes(4, 'little')  # nanosec beyond a second
    with pytest.raises(MalformedMessage, match='nanosec must be < 1e9'):
        codec.decode(bytes(raw))


def test_big_endian_messages_take_the_general_deserializer():
    from rosbags.typesys import get_typestore, Stores
    store = get_typestore(Stores.ROS2_JAZZY)
    types = store.types
    header = types['std_msgs/msg/Header'](
        stamp=types['builtin_interfaces/msg/Time'](sec=5, nanosec=6), frame_id='odom')
    zero3 = types['geometry_msgs/msg/Vector3'](x=0.0, y=0.0, z=0.0)
    twist = types['geometry_msgs/msg/Twist'](
        linear=types['geometry_msgs/msg/Vector3'](x=1.25, y=0.0, z=0.0), angular=zero3)
    message = types['geometry_msgs/msg/TwistStamped'](header=header, twist=twist)
    raw = bytes(store.serialize_cdr(message, 'geometry_msgs/msg/TwistStamped',
                                    little_endian=False))
    codec = FieldCodec('odom', 'geometry_msgs/msg/TwistStamped', ['twist.linear.x'])
    assert codec.decode(raw) == (5_000_000_006, pytest.approx([1.25]))


@pytest.mark.parametrize('msgtype, path, listed', [
    ('sensor_msgs/msg/Imu', 'angular_velocity.w',
     "'angular_velocity.w' is no field of sensor_msgs/msg/Imu; it has orientation.x, "
     'orientation.y, orientation.z, orientation.w, orientation.roll, orientation.pitch, '
     'orientation.yaw, orientation_covariance[0..8], angular_velocity.x'),
    ('nav_msgs/Odometry', 'twist.linear.x',
     "'twist.linear.x' is no field of nav_msgs/msg/Odometry; it has pose.pose.position.x"),
    ('sensor_msgs/JointState', 'positions.elbow',
     "'positions.elbow' is no field of sensor_msgs/msg/JointState (expected <field>.<joint "
     'name>); it has position.<joint name>, velocity.<joint name>, effort.<joint name>'),
    ('std_msgs/msg/Float64MultiArray', 'data.1',
     "'data.1' is no field of std_msgs/msg/Float64MultiArray; it has data[<index>]"),
])
def test_a_wrong_field_path_names_the_path_the_type_and_its_fields(msgtype, path, listed):
    with pytest.raises(FieldPathError) as error:
        FieldCodec('source', msgtype, [path])
    assert str(error.value).startswith(listed)
    with pytest.raises(FieldPathError, match='is not read by field path; expected one of'):
        FieldReader('sensor_msgs/msg/LaserScan', ['ranges[0]'])
    with pytest.raises(FieldPathError, match="'orientation.yaw' is no field of .* that can be "
                                             'written'):
        FieldCodec('pose', 'sensor_msgs/Imu', ['orientation.yaw']).encode(0, [1.0])


def test_every_field_type_is_listed_with_its_fields():
    for msgtype in FIELD_TYPES:
        assert field_names(msgtype)
