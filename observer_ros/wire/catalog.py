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
The one table of message types: each type the package reads or writes is one entry here.

A :class:`MessageType` says everything the rest of the package asks about a type: the
short name a parameter gives (``imu``), the ROS type (``sensor_msgs/msg/Imu``), its layout
(a :class:`~observer_ros.wire.layouts.FixedLayout` of doubles at fixed places, read by
field path, or a :class:`~observer_ros.wire.layouts.VectorLayout` whose vector a vector
reader takes whole), its header stamp, its field paths, whether it may carry the inputs,
and its Python class (imported only when asked, where ROS's message packages exist). The
parameter schema, the codecs of the nodes, the bag tools and the player ask this table;
none of them names a type. Adding a type is one :func:`register` call (one entry of
:data:`BUILT_IN`), as ``test_wire_catalog.py`` shows with a type made in the test.
"""

from collections.abc import Mapping
from dataclasses import dataclass
import importlib
from typing import Sequence, Union

from observer_ros.wire.angles import ANGLES
from observer_ros.wire.layouts import (
    FieldPathError, FixedLayout, JOINT_STATE_FIELDS, JointStateLayout, MultiArrayLayout,
    VectorLayout)

JOINT_STATE = 'sensor_msgs/msg/JointState'
FLOAT64_MULTI_ARRAY = 'std_msgs/msg/Float64MultiArray'


def leaves(prefix: str, names: Sequence[str]) -> tuple:
    """Return ``prefix.name`` of each name (the names alone without a prefix)."""
    return tuple(f'{prefix}.{name}' if prefix else name for name in names)


def indexed(prefix: str, count: int) -> tuple:
    """Return the paths of a fixed-size array: ``prefix[0]`` ... ``prefix[count - 1]``."""
    return tuple(f'{prefix}[{k}]' for k in range(count))


def under(prefix: str, paths: tuple) -> tuple:
    """Return ``paths`` inside the field ``prefix``."""
    return tuple(f'{prefix}.{path}' for path in paths)


XYZ = ('x', 'y', 'z')
#: The doubles of a ``geometry_msgs/Pose`` and a ``geometry_msgs/Twist``, in wire order.
POSE = leaves('position', XYZ) + leaves('orientation', XYZ + ('w',))
TWIST = leaves('linear', XYZ) + leaves('angular', XYZ)


class MessageClassError(LookupError):
    """A message type whose Python class is not installed here."""


@dataclass(frozen=True)
class MessageType:
    """
    One message type: its names, its layout and what it can do.

    Attributes
    ----------
    name : str
        The short name parameters give (``sources.<name>.type``, ``topics.<topic>.type``).
    msgtype : str
        The ROS type, ``pkg/msg/Name``.
    layout : FixedLayout or VectorLayout
        Where its values sit: read by field path (fixed), or as a whole vector.
    commands : bool
        Whether it may carry the inputs (``topics.u.type``) read by ``topics.u.fields``;
        a vector type always may.

    """

    name: str
    msgtype: str
    layout: Union[FixedLayout, VectorLayout]
    commands: bool = False

    @property
    def stamped(self) -> bool:
        """Whether its messages start with a header stamp."""
        return self.layout.stamped

    @property
    def vector(self) -> bool:
        """Whether a vector reader takes it whole (``topics.<topic>.type``, no field paths)."""
        return isinstance(self.layout, VectorLayout)

    @property
    def named(self) -> bool:
        """Say whether it is a vector whose entries have joint names rather than indices."""
        return self.vector and self.layout.named

    @property
    def fields(self) -> tuple:
        """Its arrays (a vector type: the default first) or its doubles' paths, in order."""
        return self.layout.arrays if self.vector else self.layout.doubles

    def message_class(self) -> type:
        """Return its Python class (imported now); MessageClassError when not installed."""
        return message_class(self.msgtype)


#: The built-in types, in the order parameters list them.
BUILT_IN = (
    MessageType('joint_state', JOINT_STATE, JointStateLayout()),
    MessageType('float64_multi_array', FLOAT64_MULTI_ARRAY, MultiArrayLayout()),
    MessageType('float64', 'std_msgs/msg/Float64', FixedLayout(False, 0, ('data',))),
    MessageType('imu', 'sensor_msgs/msg/Imu', FixedLayout(
        True, 1, leaves('orientation', XYZ + ('w',)) + indexed('orientation_covariance', 9)
        + leaves('angular_velocity', XYZ) + indexed('angular_velocity_covariance', 9)
        + leaves('linear_acceleration', XYZ)
        + indexed('linear_acceleration_covariance', 9))),
    MessageType('odometry', 'nav_msgs/msg/Odometry', FixedLayout(
        True, 2, under('pose.pose', POSE) + indexed('pose.covariance', 36)
        + under('twist.twist', TWIST) + indexed('twist.covariance', 36))),
    MessageType('pose_stamped', 'geometry_msgs/msg/PoseStamped',
                FixedLayout(True, 1, under('pose', POSE))),
    MessageType('twist_stamped', 'geometry_msgs/msg/TwistStamped',
                FixedLayout(True, 1, under('twist', TWIST))),
    MessageType('wrench_stamped', 'geometry_msgs/msg/WrenchStamped', FixedLayout(
        True, 1, under('wrench', leaves('force', XYZ) + leaves('torque', XYZ)))),
    MessageType('point_stamped', 'geometry_msgs/msg/PointStamped',
                FixedLayout(True, 1, leaves('point', XYZ))),
    MessageType('vector3_stamped', 'geometry_msgs/msg/Vector3Stamped',
                FixedLayout(True, 1, leaves('vector', XYZ))),
    MessageType('twist', 'geometry_msgs/msg/Twist', FixedLayout(False, 0, TWIST),
                commands=True),
    # A motion-capture or localization pose, and a velocity estimate, with covariances.
    MessageType('pose_with_covariance_stamped', 'geometry_msgs/msg/PoseWithCovarianceStamped',
                FixedLayout(True, 1, under('pose.pose', POSE) + indexed('pose.covariance', 36))),
    MessageType('twist_with_covariance_stamped',
                'geometry_msgs/msg/TwistWithCovarianceStamped', FixedLayout(
                    True, 1, under('twist.twist', TWIST) + indexed('twist.covariance', 36))),
)

_BY_NAME: dict = {}
_BY_TYPE: dict = {}


def register(entry: MessageType) -> MessageType:
    """
    Add a message type to the table; every reader, writer, schema and tool then knows it.

    Raises
    ------
    ValueError
        Its short name or ROS type is in the table already.

    """
    if entry.name in _BY_NAME or entry.msgtype in _BY_TYPE:
        raise ValueError(f'message type {entry.name!r} ({entry.msgtype}): its name or type '
                         f'is registered already')
    _BY_NAME[entry.name] = _BY_TYPE[entry.msgtype] = entry
    return entry


def unregister(name: str) -> None:
    """Remove the type of short name ``name`` (one that :func:`register` added)."""
    entry = _BY_NAME.pop(name)
    del _BY_TYPE[entry.msgtype]


for _entry in BUILT_IN:
    register(_entry)


def message_types() -> tuple:
    """Return every registered :class:`MessageType`, in the order of registration."""
    return tuple(_BY_NAME.values())


class _TypeNames(Mapping):
    """``{short name: ROS type}`` of the registered types, as the table holds them now."""

    def __getitem__(self, name: str) -> str:
        return _BY_NAME[name].msgtype

    def __iter__(self):
        return iter(_BY_NAME)

    def __len__(self) -> int:
        return len(_BY_NAME)

    def __repr__(self) -> str:
        return repr(dict(self))


#: ``{short name: ROS type}`` of every registered type (kept up to date by :func:`register`).
TYPE_NAMES = _TypeNames()


def full_type_name(msgtype: str) -> str:
    """
    Return the full name of a message type: ``pkg/msg/Type`` from ``pkg/Type`` or a short name.

    Examples
    --------
    >>> full_type_name('sensor_msgs/Imu'), full_type_name('joint_state')
    ('sensor_msgs/msg/Imu', 'sensor_msgs/msg/JointState')

    """
    if msgtype in _BY_NAME:
        return _BY_NAME[msgtype].msgtype
    parts = msgtype.split('/')
    if len(parts) == 2:
        return f'{parts[0]}/msg/{parts[1]}'
    return msgtype


def find(msgtype: str):
    """Return the entry of a short name or ROS type (``pkg/msg/Name``, ``pkg/Name``), or None."""
    return _BY_TYPE.get(full_type_name(msgtype))


def lookup(msgtype: str) -> MessageType:
    """
    Return the entry of a short name or ROS type.

    Raises
    ------
    FieldPathError
        A type not in the table, listing the ones it has.

    """
    entry = find(msgtype)
    if entry is None:
        raise FieldPathError(f'message type {msgtype!r} is not read by field path; expected '
                             f'one of {list(_BY_TYPE)}')
    return entry


def vector_layout(kind: str) -> VectorLayout:
    """
    Return the layout of a vector type (``joint_state``, ``std_msgs/msg/Float64MultiArray``).

    Raises
    ------
    FieldPathError
        Not a type of the table, or one that is not read as a whole vector.

    """
    entry = lookup(kind)
    if not entry.vector:
        raise FieldPathError(f'message type {entry.msgtype} is read by field path, not as a '
                             f'vector; expected one of '
                             f'{[item.name for item in message_types() if item.vector]}')
    return entry.layout


def message_class(msgtype: str) -> type:
    """
    Return the Python class of a ROS type (``pkg/msg/Name``, ``pkg/Name``, ``pkg/srv/Name_Event``).

    Imported when asked, so the table itself needs no ROS.

    Raises
    ------
    MessageClassError
        The type's package or class is not installed here.

    """
    package, _, name = full_type_name(msgtype).rpartition('/')
    try:
        return getattr(importlib.import_module(package.replace('/', '.')), name)
    except (ImportError, AttributeError, TypeError, ValueError) as e:
        raise MessageClassError(f'message type {msgtype} is not installed here ({e})') from e


def quaternions(layout: FixedLayout) -> tuple:
    """Return the prefixes of the quaternions of a layout (``x, y, z, w`` in a row)."""
    doubles = layout.doubles
    return tuple(path[:-2] for k, path in enumerate(doubles)
                 if path.endswith('.x') and doubles[k + 1:k + 4] == leaves(
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
    layout = lookup(msgtype).layout
    if isinstance(layout, VectorLayout):
        return layout.paths()
    paths = list(layout.doubles)
    for prefix in quaternions(layout):
        at = paths.index(f'{prefix}.w') + 1
        paths[at:at] = leaves(prefix, ANGLES)
    return _summary(paths)


def refuse(path: str, msgtype: str, reason: str = '') -> FieldPathError:
    """Return the error of a path ``msgtype`` does not have, listing the ones it has."""
    return FieldPathError(f'{path!r} is no field of {msgtype}{reason}; it has '
                          f'{", ".join(field_names(msgtype))}')


#: The built-in types read by field path alone, and every built-in type (the ROS types).
FIXED_LAYOUTS = {entry.msgtype: entry.layout for entry in BUILT_IN if not entry.vector}
FIELD_TYPES = tuple(entry.msgtype for entry in BUILT_IN)

__all__ = ['BUILT_IN', 'FIELD_TYPES', 'FIXED_LAYOUTS', 'FLOAT64_MULTI_ARRAY', 'JOINT_STATE',
           'JOINT_STATE_FIELDS', 'MessageClassError', 'MessageType', 'POSE',
           'TWIST', 'TYPE_NAMES', 'XYZ', 'field_names', 'find', 'full_type_name', 'indexed',
           'leaves', 'lookup', 'message_class', 'message_types', 'quaternions', 'refuse',
           'register', 'under', 'unregister', 'vector_layout']
