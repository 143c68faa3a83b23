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

"""The message types the wire codec knows: their names, layouts and field paths."""

from typing import Sequence

from observer_ros.wire.layouts import FieldPathError, FixedLayout
from observer_ros.wire.quaternions import ANGLES


JOINT_STATE = 'sensor_msgs/msg/JointState'
FLOAT64_MULTI_ARRAY = 'std_msgs/msg/Float64MultiArray'
MESSAGE_TYPES = {'joint_state': JOINT_STATE, 'float64_multi_array': FLOAT64_MULTI_ARRAY}
JOINT_STATE_FIELDS = ('position', 'velocity', 'effort')


def _leaves(prefix: str, names: Sequence[str]) -> tuple:
    return tuple(f'{prefix}.{name}' if prefix else name for name in names)


def _array(prefix: str, count: int) -> tuple:
    return tuple(f'{prefix}[{k}]' for k in range(count))


_XYZ = ('x', 'y', 'z')
_POSE = _leaves('position', _XYZ) + _leaves('orientation', _XYZ + ('w',))
_TWIST = _leaves('linear', _XYZ) + _leaves('angular', _XYZ)


def _under(prefix: str, paths: tuple) -> tuple:
    return tuple(f'{prefix}.{path}' for path in paths)


#: The fixed-layout types, by their full names.
FIXED_LAYOUTS = {
    'std_msgs/msg/Float64': FixedLayout(False, 0, ('data',)),
    'geometry_msgs/msg/Twist': FixedLayout(False, 0, _TWIST),
    'geometry_msgs/msg/TwistStamped': FixedLayout(True, 1, _under('twist', _TWIST)),
    'geometry_msgs/msg/WrenchStamped': FixedLayout(
        True, 1, _under('wrench', _leaves('force', _XYZ) + _leaves('torque', _XYZ))),
    'geometry_msgs/msg/PointStamped': FixedLayout(True, 1, _leaves('point', _XYZ)),
    'geometry_msgs/msg/Vector3Stamped': FixedLayout(True, 1, _leaves('vector', _XYZ)),
    'geometry_msgs/msg/PoseStamped': FixedLayout(True, 1, _under('pose', _POSE)),
    'sensor_msgs/msg/Imu': FixedLayout(
        True, 1, _leaves('orientation', _XYZ + ('w',)) + _array('orientation_covariance', 9)
        + _leaves('angular_velocity', _XYZ) + _array('angular_velocity_covariance', 9)
        + _leaves('linear_acceleration', _XYZ)
        + _array('linear_acceleration_covariance', 9)),
    'nav_msgs/msg/Odometry': FixedLayout(
        True, 2, _under('pose.pose', _POSE) + _array('pose.covariance', 36)
        + _under('twist.twist', _TWIST) + _array('twist.covariance', 36)),
}

#: Every type a :class:`FieldReader` reads, by full name (the short names of the vector
#: topics, ``joint_state`` and ``float64_multi_array``, are accepted too).
FIELD_TYPES = (JOINT_STATE, FLOAT64_MULTI_ARRAY) + tuple(FIXED_LAYOUTS)


def full_type_name(msgtype: str) -> str:
    """
    Return the full name of a message type: ``pkg/msg/Type`` from ``pkg/Type`` or a short name.

    Examples
    --------
    >>> full_type_name('sensor_msgs/Imu'), full_type_name('joint_state')
    ('sensor_msgs/msg/Imu', 'sensor_msgs/msg/JointState')

    """
    if msgtype in MESSAGE_TYPES:
        return MESSAGE_TYPES[msgtype]
    parts = msgtype.split('/')
    if len(parts) == 2:
        return f'{parts[0]}/msg/{parts[1]}'
    return msgtype


def quaternions(layout: FixedLayout) -> tuple:
    """Return the prefixes of the quaternions of a layout (``x, y, z, w`` in a row)."""
    doubles = layout.doubles
    return tuple(path[:-2] for k, path in enumerate(doubles)
                 if path.endswith('.x') and doubles[k + 1:k + 4] == _leaves(
                     path[:-2], ('y', 'z', 'w')))


def _summary(paths: Sequence[str]) -> list:
    """Paths with each array written once, as ``name[0..8]``."""
    shown, arrays = [], {}
    for path in paths:
        if path.endswith(']'):
            name = path[:path.index('[')]
            if name not in arrays:
                arrays[name] = len(shown)
                shown.append(name)
            shown[arrays[name]] = f'{name}[0..{path[path.index("[") + 1:-1]}]'
        else:
            shown.append(path)
    return shown


def field_names(msgtype: str) -> list:
    """
    Return the field paths a message type offers (arrays written ``name[0..8]``).

    Examples
    --------
    >>> field_names('geometry_msgs/msg/PointStamped')
    ['point.x', 'point.y', 'point.z']
    >>> field_names('geometry_msgs/PoseStamped')[-4:]
    ['pose.orientation.w', 'pose.orientation.roll', 'pose.orientation.pitch', \
'pose.orientation.yaw']

    """
    msgtype = full_type_name(msgtype)
    if msgtype == JOINT_STATE:
        return [f'{field}.<joint name>' for field in JOINT_STATE_FIELDS]
    if msgtype == FLOAT64_MULTI_ARRAY:
        return ['data[<index>]']
    layout = FIXED_LAYOUTS.get(msgtype)
    if layout is None:
        raise FieldPathError(f'message type {msgtype!r} is not read by field path; expected '
                             f'one of {list(FIELD_TYPES)}')
    paths = list(layout.doubles)
    for prefix in quaternions(layout):
        at = paths.index(f'{prefix}.w') + 1
        paths[at:at] = _leaves(prefix, ANGLES)
    return _summary(paths)


def refuse(path: str, msgtype: str, reason: str = '') -> FieldPathError:
    """Return the error of a path ``msgtype`` does not have, listing the ones it has."""
    return FieldPathError(f'{path!r} is no field of {msgtype}{reason}; it has '
                          f'{", ".join(field_names(msgtype))}')
