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
The wire codec: CDR bytes of the messages robots publish to and from numpy, without ROS.

The nodes read and write their topics with it (:mod:`observer_ros.ros.messages`), the bag
tools their recorded messages (:mod:`observer_ros.bags.storage`); it imports no rclpy, so
the bag tools run without ROS.

``sensor_msgs/JointState`` and ``std_msgs/Float64MultiArray`` messages of one topic almost
always share one layout (same joint names, same frame id, same lengths): only the stamp and
the values change. :func:`decode` parses one message of each layout byte by byte, checks
which messages share it (every byte but the stamp and the doubles) and reads all of them
with one numpy view; messages of other layouts are parsed one by one. :func:`encode` fills
a serialized template the same way. The results equal ``rosbags``' own (de)serializer.

The messages robots publish are read by field path (:class:`FieldReader`,
:func:`decode_fields`; :class:`FieldWriter` writes commands): ``sensor_msgs/JointState`` by
joint name and field, ``std_msgs/Float64MultiArray`` by index, and the fixed-layout types of
:data:`FIXED_LAYOUTS` (``sensor_msgs/Imu``, ``nav_msgs/Odometry``, the stamped geometry
messages, ``geometry_msgs/Twist``, ``std_msgs/Float64``), whose doubles sit at fixed places
after the header's strings: one length read per string, then one ``struct`` call for the
wanted doubles. A quaternion offers its ``roll``, ``pitch`` and ``yaw`` as derived fields.
"""

from dataclasses import dataclass
import math
from operator import itemgetter
import struct
from typing import Optional, Sequence

import numpy as np

JOINT_STATE = 'sensor_msgs/msg/JointState'
FLOAT64_MULTI_ARRAY = 'std_msgs/msg/Float64MultiArray'
MESSAGE_TYPES = {'joint_state': JOINT_STATE, 'float64_multi_array': FLOAT64_MULTI_ARRAY}
JOINT_STATE_FIELDS = ('position', 'velocity', 'effort')
#: Little-endian plain CDR encapsulation header.
HEADER = b'\x00\x01\x00\x00'
ORIGIN = len(HEADER)


class DecodeError(ValueError):
    """A message that does not hold the expected vector."""


@dataclass(frozen=True)
class Layout:
    """Where a message keeps its stamp and its double arrays, and what makes its layout."""

    names: tuple
    arrays: dict  # field -> (byte offset of the first double, count)
    size: int
    #: ``(start, end)`` byte ranges that define the layout: the encapsulation kind, counts,
    #: lengths and string bytes. Stamps, doubles, alignment padding and trailing bytes are
    #: free (serializers leave padding uninitialised: it differs between equal messages).
    fixed: tuple = ()


class _Parser:
    """Walk a serialized message, noting the ranges that define its layout."""

    def __init__(self, raw) -> None:
        self.raw = raw
        self.offset = ORIGIN
        self.fixed = [(0, 2)]

    def align(self, alignment: int) -> None:
        self.offset += (-(self.offset - ORIGIN)) % alignment

    def keep(self, start: int, end: int) -> None:
        if self.fixed[-1][1] == start:
            self.fixed[-1] = (self.fixed[-1][0], end)
        else:
            self.fixed.append((start, end))

    def count(self) -> int:
        self.align(4)
        (value,) = struct.unpack_from('<I', self.raw, self.offset)
        self.keep(self.offset, self.offset + 4)
        self.offset += 4
        return value

    def string(self) -> str:
        length = self.count()
        start = self.offset
        self.offset += length
        if self.offset > len(self.raw):
            raise DecodeError('truncated message')
        self.keep(start, self.offset)
        return bytes(self.raw[start:self.offset - 1]).decode('utf-8')

    def doubles(self) -> tuple:
        count = self.count()
        if count:
            self.align(8)
        start = self.offset
        self.offset += 8 * count
        return start, count


def parse_layout(raw, kind: str) -> Layout:
    """Parse one serialized message's layout (``kind``: joint_state | float64_multi_array)."""
    if bytes(raw[:2]) != HEADER[:2]:
        raise DecodeError('not little-endian plain CDR')
    parser = _Parser(raw)
    try:
        if kind == 'joint_state':
            parser.offset += 8  # stamp
            parser.string()  # frame_id
            names = [parser.string() for _ in range(parser.count())]
            arrays = {field: parser.doubles() for field in JOINT_STATE_FIELDS}
        else:
            for _ in range(parser.count()):  # layout.dim: label, size, stride
                parser.string()
                parser.count()
                parser.count()
            parser.count()  # data_offset
            arrays = {'data': parser.doubles()}
            names = []
    except (struct.error, UnicodeDecodeError) as e:
        raise DecodeError(f'truncated or corrupt message ({e})') from e
    if parser.offset > len(raw):
        raise DecodeError('truncated message')
    return Layout(tuple(names), arrays, len(raw), tuple(parser.fixed))


def _fixed_mask(layout: Layout) -> np.ndarray:
    """Bytes that must equal the template's for a message to share its layout."""
    mask = np.zeros(layout.size, dtype=bool)
    for start, end in layout.fixed:
        mask[start:end] = True
    return mask


def joint_order(given: Sequence[str], wanted: Sequence[str]) -> list:
    """
    Return where each wanted joint sits among a JointState's names: the one name rule.

    Extra joints are ignored and order does not matter (``/joint_states`` of a real robot);
    a wanted joint named twice makes the message malformed, since which of its values is
    meant is unknown. The nodes (:class:`observer_ros.ros.messages.VectorCodec`) and the
    bag tools (:func:`decode`, :class:`MessageReader`) read names with it.

    Parameters
    ----------
    given : sequence of str
        The message's ``name`` field.
    wanted : sequence of str
        The joints to read, in vector order.

    Returns
    -------
    list of int
        The position in ``given`` of each wanted name.

    Raises
    ------
    DecodeError
        A wanted joint is missing or named more than once.

    Examples
    --------
    >>> joint_order(['wrist', 'y2', 'y1'], ['y1', 'y2'])
    [2, 1]
    >>> joint_order(['y1', 'y1'], ['y1'])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.ros.cdr.DecodeError: joints ['y1'] named more than once ...

    """
    index: dict = {}
    repeated = []
    for position, name in enumerate(given):
        if index.setdefault(name, position) != position:
            repeated.append(name)
    missing = [name for name in wanted if name not in index]
    if missing:
        raise DecodeError(f'joints {missing} missing (the message has {list(given)})')
    repeated = [name for name in wanted if name in repeated]
    if repeated:
        raise DecodeError(f'joints {repeated} named more than once (the message has '
                          f'{list(given)})')
    return [index[name] for name in wanted]


def _select(layout: Layout, kind: str, field: str, names: Sequence[str],
            indices: Optional[Sequence[int]] = None) -> tuple:
    """
    Return ``(offset, count, order)`` of the wanted values in a layout.

    ``indices`` (Float64MultiArray): the wanted entries of ``data`` (any length holding
    them), instead of every entry (``names`` then counts them).
    """
    if kind == 'joint_state':
        offset, count = layout.arrays[field]
        if count != len(layout.names):
            raise DecodeError(f'{len(layout.names)} names but {count} {field} values')
        return offset, count, joint_order(layout.names, names)
    offset, count = layout.arrays['data']
    if indices is not None:
        if count <= max(indices):
            raise DecodeError(f'expected at least {max(indices) + 1} values in data, got '
                              f'{count}')
        return offset, count, list(indices)
    if count != len(names):
        raise DecodeError(f'expected {len(names)} values in data, got {count}')
    return offset, count, list(range(count))


def decode(raws: Sequence[bytes], kind: str, field: str, names: Sequence[str]) -> tuple:
    """
    Decode serialized messages into stamps and vectors.

    Parameters
    ----------
    raws : sequence of bytes
        Serialized messages (CDR with its 4-byte header), as stored in a bag.
    kind : {'joint_state', 'float64_multi_array'}
    field : str
        JointState field holding the values.
    names : sequence of str
        Wanted joint names, in vector order (their count for Float64MultiArray).

    Returns
    -------
    stamps : numpy.ndarray of int64, shape (k,)
        Header stamps in nanoseconds (0 for Float64MultiArray or a zero stamp).
    values : numpy.ndarray, shape (k, len(names))
    errors : dict
        ``{index: reason}`` of messages that could not be decoded (their rows are NaN).

    """
    total = len(raws)
    width = len(names)
    stamps = np.zeros(total, dtype=np.int64)
    values = np.full((total, width), np.nan)
    errors: dict = {}
    lengths = np.fromiter((len(raw) for raw in raws), dtype=np.int64, count=total)
    remaining = np.arange(total)
    while remaining.size:
        first = int(remaining[0])
        try:
            layout = parse_layout(raws[first], kind)
            offset, count, order = _select(layout, kind, field, names)
        except DecodeError as e:
            errors[first] = str(e)
            remaining = remaining[1:]
            continue
        candidates = remaining[lengths[remaining] == layout.size]
        block = np.frombuffer(b''.join(raws[i] for i in candidates), dtype=np.uint8)
        block = block.reshape(candidates.size, layout.size)
        template = block[0]
        mask = _fixed_mask(layout)
        same = (block[:, mask] == template[mask]).all(axis=1)
        members = candidates[same]
        rows = block[same]
        if kind == 'joint_state':
            seconds = rows[:, ORIGIN:ORIGIN + 4].copy().view('<i4').ravel().astype(np.int64)
            nanoseconds = rows[:, ORIGIN + 4:ORIGIN + 8].copy().view('<u4').ravel()
            stamps[members] = seconds * 1_000_000_000 + nanoseconds
        data = rows[:, offset:offset + 8 * count].copy().view('<f8').reshape(-1, count)
        values[members] = data[:, order]
        remaining = np.setdiff1d(remaining, members, assume_unique=True)
    return stamps, values, errors


STAMP = struct.Struct('<iI')
#: A CDR string's length (with its NUL) or a sequence's count.
LENGTH = struct.Struct('<I')
#: A header's stamp and the length of its ``frame_id``.
STAMP_LENGTH = struct.Struct('<iII')


#: Layouts a :class:`MessageReader` remembers (several publishers on one topic).
READER_LAYOUTS = 8


@dataclass(frozen=True)
class _Known:
    """A layout a reader has seen: its fixed bytes and where the wanted values are."""

    size: int
    segments: tuple  # (start, bytes) that must match
    offset: int
    values: struct.Struct
    order: Optional[list]  # None: the values are the wanted ones, in order
    #: Byte ranges outside the stamp and the wanted values: ``(0, stamp start)``,
    #: ``(stamp end, offset)`` and ``(offset + value bytes, size)``. They hold every fixed
    #: byte, so a message equal to an earlier match there has this layout too.
    spans: tuple = ()

    def matches(self, raw) -> bool:
        return len(raw) == self.size and all(
            raw[start:start + len(expected)] == expected for start, expected in self.segments)


class MessageReader:
    """
    Decode one serialized message at a time (the online path of :func:`decode`).

    The last few layouts are kept, newest first: a message that matches one byte for byte
    where the layout is defined is read with two ``struct`` calls; any other is parsed. The
    bytes of the last match outside the stamp and the values are kept as well: a message of
    the same publisher usually repeats them exactly (padding included), which is checked
    with three comparisons instead of one per fixed range.
    """

    def __init__(self, kind: str, field: str, names: Sequence[str],
                 indices: Optional[Sequence[int]] = None) -> None:
        self.kind = kind
        self.field = field
        self.names = list(names)
        self.indices = None if indices is None else list(indices)
        self._known: list = []
        self._last: Optional[_Known] = None
        self._last_bytes: tuple = ()

    def _layout(self, raw) -> _Known:
        last = self._last
        if last is not None and len(raw) == last.size:
            (a, b), (c, d), (e, f) = last.spans
            head, middle, tail = self._last_bytes
            if raw[a:b] == head and raw[c:d] == middle and raw[e:f] == tail:
                return last
        known = self._match(raw)
        self._last = known
        self._last_bytes = tuple(bytes(raw[start:end]) for start, end in known.spans)
        return known

    def _match(self, raw) -> _Known:
        for index, known in enumerate(self._known):
            if known.matches(raw):
                if index:
                    self._known.insert(0, self._known.pop(index))
                return known
        layout = parse_layout(raw, self.kind)
        offset, count, order = _select(layout, self.kind, self.field, self.names,
                                       self.indices)
        stamp_end = ORIGIN + 8 if self.kind == 'joint_state' else ORIGIN
        stamp_start = min(ORIGIN, stamp_end)
        spans = ((0, stamp_start), (stamp_end, offset), (offset + 8 * count, layout.size))
        known = _Known(layout.size, tuple((start, bytes(raw[start:end]))
                                          for start, end in layout.fixed),
                       offset, struct.Struct(f'<{count}d'),
                       None if order == list(range(count)) else order, spans)
        self._known = [known, *self._known[:READER_LAYOUTS - 1]]
        return known

    def read(self, raw: bytes) -> tuple:
        """
        Return ``(stamp_ns, values)``: the header stamp (0 without one) and the wanted values.

        Raises
        ------
        DecodeError
            Not little-endian plain CDR, truncated, or without the wanted values.

        """
        seconds, nanoseconds, values = self.read_parts(raw)
        return seconds * 1_000_000_000 + nanoseconds, values

    def read_parts(self, raw: bytes) -> tuple:
        """
        Return ``(sec, nanosec, values)`` as the message holds them (zeros without a header).

        ``values`` is a list in the wanted order. Raises DecodeError as :meth:`read` does.
        """
        known = self._layout(raw)
        seconds = nanoseconds = 0
        if self.kind == 'joint_state':
            seconds, nanoseconds = STAMP.unpack_from(raw, ORIGIN)
        values = known.values.unpack_from(raw, known.offset)
        order = known.order
        if order is None:  # the message holds exactly the wanted values, in order
            return seconds, nanoseconds, list(values)
        return seconds, nanoseconds, [values[i] for i in order]


class MessageWriter:
    """Serialize one vector at a time into a copy of a serialized template message."""

    def __init__(self, template: bytes, kind: str, field: str) -> None:
        layout = parse_layout(template, kind)
        self.offset, count = layout.arrays[field if kind == 'joint_state' else 'data']
        self.stamped = kind == 'joint_state'
        self._values = struct.Struct(f'<{count}d')
        self._buffer = bytearray(len(template))  # padding zeroed, whatever the template had
        self._buffer[:ORIGIN] = HEADER
        for start, end in layout.fixed:
            self._buffer[start:end] = template[start:end]

    def write(self, stamp_ns: int, values) -> bytes:
        """Return the template with ``stamp_ns`` (when it has a header) and ``values``."""
        if self.stamped:
            STAMP.pack_into(self._buffer, ORIGIN, *divmod(int(stamp_ns), 1_000_000_000))
        if isinstance(values, np.ndarray):  # Python floats pack faster than numpy scalars
            values = values.tolist()
        self._values.pack_into(self._buffer, self.offset, *values)
        return bytes(self._buffer)


class Encoder:
    """Serialize vectors of one topic into CDR messages, many at a time."""

    def __init__(self, kind: str, names: Sequence[str], field: str = 'position',
                 typestore: Optional[object] = None) -> None:
        from rosbags.typesys import get_typestore, Stores
        self.kind = kind
        self.msgtype = MESSAGE_TYPES[kind]
        self.typestore = typestore or get_typestore(Stores.ROS2_JAZZY)
        self.width = len(names)
        template = self._message(names, field)
        raw = bytes(self.typestore.serialize_cdr(template, self.msgtype))
        layout = parse_layout(raw, kind)
        self.offset, _ = layout.arrays[field if kind == 'joint_state' else 'data']
        self.template = np.frombuffer(raw, dtype=np.uint8)

    def _message(self, names, field):
        types = self.typestore.types
        zeros = np.zeros(len(names))
        if self.kind == 'float64_multi_array':
            layout = types['std_msgs/msg/MultiArrayLayout'](dim=[], data_offset=0)
            return types[self.msgtype](layout=layout, data=zeros)
        empty = np.zeros(0)
        header = types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=0, nanosec=0), frame_id='')
        arrays = {name: (zeros if name == field else empty) for name in JOINT_STATE_FIELDS}
        return types[self.msgtype](header=header, name=list(names), **arrays)

    def encode(self, stamps_ns, values) -> list:
        """Return one ``bytes`` per row of ``values`` ``(k, width)`` stamped ``stamps_ns``."""
        values = np.ascontiguousarray(values, dtype='<f8').reshape(-1, self.width)
        rows = np.tile(self.template, (values.shape[0], 1))
        if self.kind == 'joint_state':
            stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
            seconds, nanoseconds = np.divmod(stamps_ns, 1_000_000_000)
            rows[:, ORIGIN:ORIGIN + 4] = seconds.astype('<i4')[:, None].view(np.uint8)
            rows[:, ORIGIN + 4:ORIGIN + 8] = nanoseconds.astype('<u4')[:, None].view(np.uint8)
        rows[:, self.offset:self.offset + 8 * self.width] = values.view(np.uint8)
        flat = rows.tobytes()
        size = self.template.size
        return [flat[start:start + size] for start in range(0, len(flat), size)]


# --- fields by path: the messages robots publish ----------------------------------------------

#: Derived fields of a quaternion (``orientation.yaw``): its roll, pitch and yaw angles.
ANGLES = ('roll', 'pitch', 'yaw')


class FieldPathError(ValueError):
    """A field path that a message type does not have (the message lists the ones it has)."""


@dataclass(frozen=True)
class FixedLayout:
    """
    A message type whose doubles sit at fixed places after its strings.

    ``stamped``: it starts with a ``std_msgs/Header`` (stamp, ``frame_id``); ``strings``: how
    many strings come before the doubles (the ``frame_id`` and, for Odometry,
    ``child_frame_id``); ``doubles``: the path of each double, in wire order.
    """

    stamped: bool
    strings: int
    doubles: tuple


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


def _refuse(path: str, msgtype: str, reason: str = '') -> FieldPathError:
    return FieldPathError(f'{path!r} is no field of {msgtype}{reason}; it has '
                          f'{", ".join(field_names(msgtype))}')


#: A quaternion whose squared norm is outside this range is scaled before its angles.
QUATERNION_NORMS = (1e-200, 1e200)


def quaternion_angle(name: str, x: float, y: float, z: float, w: float) -> float:
    """
    Return the roll, pitch or yaw of a quaternion ``(x, y, z, w)`` (any norm).

    The Z-Y-X (yaw, pitch, roll) Euler angles, as tf2's ``getEulerYPR`` gives them away from
    a pitch of 90 degrees, in forms that do not need a unit quaternion (scaled first when
    its entries are huge or tiny, so that any finite quaternion gives a finite angle; the
    zero quaternion gives 0).

    Examples
    --------
    >>> round(quaternion_angle('yaw', 0.0, 0.0, math.sin(0.25), math.cos(0.25)), 12)
    0.5

    """
    return _ANGLE_OF[name](x, y, z, w)


def _scaled(angle, x: float, y: float, z: float, w: float) -> float:
    """``angle`` of a quaternion whose squared norm is out of :data:`QUATERNION_NORMS`."""
    largest = max(abs(x), abs(y), abs(z), abs(w))
    if not largest:
        return 0.0
    return angle(x / largest, y / largest, z / largest, w / largest)


def _yaw(x: float, y: float, z: float, w: float) -> float:
    yy, zz = y * y, z * z
    rest = w * w + x * x
    if not QUATERNION_NORMS[0] < rest + yy + zz < QUATERNION_NORMS[1]:
        return _scaled(_yaw, x, y, z, w)
    return math.atan2(2.0 * (w * z + x * y), rest - yy - zz)


def _roll(x: float, y: float, z: float, w: float) -> float:
    xx, yy = x * x, y * y
    rest = w * w + z * z
    if not QUATERNION_NORMS[0] < rest + xx + yy < QUATERNION_NORMS[1]:
        return _scaled(_roll, x, y, z, w)
    return math.atan2(2.0 * (w * x + y * z), rest - xx - yy)


def _pitch(x: float, y: float, z: float, w: float) -> float:
    norm = x * x + y * y + z * z + w * w
    if not QUATERNION_NORMS[0] < norm < QUATERNION_NORMS[1]:
        return _scaled(_pitch, x, y, z, w)
    return math.asin(max(-1.0, min(1.0, 2.0 * (w * y - z * x) / norm)))


_ANGLE_OF = {'roll': _roll, 'pitch': _pitch, 'yaw': _yaw}


def _picker(steps: list):
    """
    Return a function of the doubles read that gives the wanted fields, in order.

    Made once per reader: an ``itemgetter`` over the indexed doubles when no angle is asked
    for (no loop or test per message), else one list of indices and angle calls.
    """
    indices = [step[0] for step in steps if len(step) == 1]
    if len(indices) == len(steps):
        if len(indices) == 1:
            index = indices[0]
            return lambda v: [v[index]]
        getter = itemgetter(*indices)
        return lambda v: list(getter(v))
    calls = [(None, step[0]) if len(step) == 1 else (_ANGLE_OF[step[0]], *step[1:])
             for step in steps]
    return lambda v: [v[call[1]] if call[0] is None
                      else call[0](v[call[1]], v[call[2]], v[call[3]], v[call[4]])
                      for call in calls]


class _FixedReader:
    """Read wanted doubles of a fixed layout: one ``struct`` call after the strings."""

    def __init__(self, msgtype: str, layout: FixedLayout, fields: Sequence[str]) -> None:
        self.stamped = layout.stamped
        self.strings = layout.strings
        self.size = 8 * len(layout.doubles)
        index = {path: k for k, path in enumerate(layout.doubles)}
        wanted, recipe = [], []  # doubles to read; per field: a double or an angle
        for path in fields:
            prefix, _, leaf = path.rpartition('.')
            if path in index:
                recipe.append((index[path],))
            elif leaf in ANGLES and prefix in quaternions(layout):
                recipe.append((leaf, *(index[f'{prefix}.{q}'] for q in 'xyzw')))
            else:
                raise _refuse(path, msgtype)
            wanted += [k for k in recipe[-1] if isinstance(k, int)]
        read = sorted(set(wanted))
        form, at = ['<'], read[0]
        for k in read:
            form.append(f'{8 * (k - at)}x' if k > at else '')
            form.append('d')
            at = k + 1
        self.values = struct.Struct(''.join(form))
        self.skip = 8 * read[0]  # from the first double to the first one read
        place = {k: position for position, k in enumerate(read)}
        steps = [(place[step[0]],) if len(step) == 1
                 else (step[0], *(place[k] for k in step[1:])) for step in recipe]
        self._pick = list if steps == [(k,) for k in range(len(read))] else _picker(steps)
        self.read_parts = self._one_string if self.strings == 1 else self._any_strings

    def _one_string(self, raw) -> tuple:
        """Read a message with a header and no other string (all but Odometry)."""
        try:
            seconds, nanoseconds, length = STAMP_LENGTH.unpack_from(raw, ORIGIN)
            start = ORIGIN + 12 + length
            start += (ORIGIN - start) % 8
            if len(raw) < start + self.size:
                raise DecodeError(f'truncated message ({len(raw)} bytes, expected '
                                  f'{start + self.size})')
            return seconds, nanoseconds, self._pick(self.values.unpack_from(
                raw, start + self.skip))
        except struct.error as e:
            raise DecodeError(f'truncated message ({e})') from None

    def _any_strings(self, raw) -> tuple:
        """Read a message with any number of strings before its doubles."""
        try:
            offset = ORIGIN + 8 if self.stamped else ORIGIN
            for _ in range(self.strings):
                offset += (ORIGIN - offset) % 4
                offset += 4 + LENGTH.unpack_from(raw, offset)[0]
            start = offset + (ORIGIN - offset) % 8
            if len(raw) < start + self.size:
                raise DecodeError(f'truncated message ({len(raw)} bytes, expected '
                                  f'{start + self.size})')
            seconds, nanoseconds = STAMP.unpack_from(raw, ORIGIN) if self.stamped else (0, 0)
            return seconds, nanoseconds, self._pick(self.values.unpack_from(
                raw, start + self.skip))
        except struct.error as e:
            raise DecodeError(f'truncated message ({e})') from None


class FieldReader:
    """
    Read chosen fields of one message type, by path, from serialized messages.

    Parameters
    ----------
    msgtype : str
        One of :data:`FIELD_TYPES` (``sensor_msgs/msg/Imu``; ``sensor_msgs/Imu`` and the short
        names ``joint_state``, ``float64_multi_array`` are accepted).
    fields : sequence of str
        Field paths, in the order of the vector read: ``angular_velocity.z``,
        ``twist.twist.linear.x``, ``pose.pose.orientation.yaw`` (the derived angle of a
        quaternion: ``roll``, ``pitch``, ``yaw``); for JointState ``<field>.<joint name>``
        (``position.shoulder``; the field is ``position``, ``velocity`` or ``effort``); for
        Float64MultiArray ``data[<index>]``; for Float64 ``data``.

    Attributes
    ----------
    msgtype : str
        The full type name.
    stamped : bool
        The type has a header stamp.

    Raises
    ------
    FieldPathError
        A type not read by field path, or a path the type does not have: the message names
        the path, the type and the fields it has.

    Examples
    --------
    >>> reader = FieldReader('geometry_msgs/Twist', ['angular.z', 'linear.x'])
    >>> raw = HEADER + struct.pack('<6d', 0.5, 0.0, 0.0, 0.0, 0.0, -1.5)
    >>> reader.read(raw)
    (0, [-1.5, 0.5])
    >>> FieldReader('geometry_msgs/msg/Twist', ['linear.w'])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.ros.cdr.FieldPathError: 'linear.w' is no field of geometry_msgs/msg/Twist; \
it has linear.x, linear.y, linear.z, angular.x, angular.y, angular.z

    """

    def __init__(self, msgtype: str, fields: Sequence[str]) -> None:
        self.msgtype = msgtype = full_type_name(msgtype)
        self.fields = list(fields)
        if not self.fields:
            raise FieldPathError(f'expected at least one field of {msgtype}, got none')
        self.stamped = msgtype != FLOAT64_MULTI_ARRAY and (
            msgtype == JOINT_STATE or FIXED_LAYOUTS.get(msgtype, FixedLayout(False, 0, ()))
            .stamped)
        if msgtype == JOINT_STATE:
            self._readers = self._joint_readers()
        elif msgtype == FLOAT64_MULTI_ARRAY:
            indices = [self._index(path) for path in self.fields]
            self._readers = [(MessageReader('float64_multi_array', 'data', [], indices), None)]
        else:
            layout = FIXED_LAYOUTS.get(msgtype)
            if layout is None:
                field_names(msgtype)  # raises, listing the types
            self._readers = [(_FixedReader(msgtype, layout, self.fields), None)]
        #: :meth:`read_parts` of a message known to be little-endian plain CDR.
        self.read_little_endian = (self._readers[0][0].read_parts if len(self._readers) == 1
                                   else self._read_several)

    def _index(self, path: str) -> int:
        """Return the index of ``data[<index>]`` (Float64MultiArray)."""
        if path.startswith('data[') and path.endswith(']') and path[5:-1].isdigit():
            return int(path[5:-1])
        raise _refuse(path, self.msgtype)

    def _joint_readers(self) -> list:
        """One reader per JointState field, with the places of its joints in the vector."""
        by_field: dict = {}
        for position, path in enumerate(self.fields):
            field, _, joint = path.partition('.')
            if field not in JOINT_STATE_FIELDS or not joint:
                raise _refuse(path, self.msgtype, ' (expected <field>.<joint name>)')
            by_field.setdefault(field, []).append((position, joint))
        return [(MessageReader('joint_state', field, [joint for _, joint in wanted]),
                 None if len(by_field) == 1 else [position for position, _ in wanted])
                for field, wanted in by_field.items()]

    def read_parts(self, raw) -> tuple:
        """
        Return ``(sec, nanosec, values)``: the stamp as held (zeros without one) and the fields.

        Raises
        ------
        DecodeError
            Not little-endian plain CDR, truncated, or without a wanted field (a joint
            missing, ``data`` too short).

        """
        if raw[:2] != HEADER[:2]:
            raise DecodeError('not little-endian plain CDR')
        return self.read_little_endian(raw)

    def _read_several(self, raw) -> tuple:
        """Read a JointState whose fields come from several of its arrays."""
        values = [0.0] * len(self.fields)
        for reader, places in self._readers:
            seconds, nanoseconds, part = reader.read_parts(raw)
            for place, value in zip(places, part):
                values[place] = value
        return seconds, nanoseconds, values

    def read(self, raw) -> tuple:
        """Return ``(stamp_ns, values)`` (0 without a stamp); raises as :meth:`read_parts`."""
        seconds, nanoseconds, values = self.read_parts(raw)
        return seconds * 1_000_000_000 + nanoseconds, values


def decode_fields(raws: Sequence[bytes], msgtype: str, fields: Sequence[str]) -> tuple:
    """
    Decode serialized messages of one type into stamps and the vectors of chosen fields.

    The batch form of :class:`FieldReader` (bags): message by message.

    Returns
    -------
    stamps : numpy.ndarray of int64, shape (k,)
        Header stamps in nanoseconds (0 without one).
    values : numpy.ndarray, shape (k, len(fields))
    errors : dict
        ``{index: reason}`` of messages that could not be decoded (their rows are NaN).

    Raises
    ------
    FieldPathError
        As :class:`FieldReader`.

    """
    reader = FieldReader(msgtype, fields)
    stamps = np.zeros(len(raws), dtype=np.int64)
    values = np.full((len(raws), len(reader.fields)), np.nan)
    errors: dict = {}
    for index, raw in enumerate(raws):
        try:
            stamps[index], values[index] = reader.read(raw)
        except DecodeError as e:
            errors[index] = str(e)
    return stamps, values, errors


class FieldWriter:
    """
    Serialize vectors into chosen fields of a fixed-layout message type (the others zero).

    For publishing commands as the robot takes them (``geometry_msgs/Twist`` on
    ``/cmd_vel``); stamped where the type has a header (``frame_id`` empty). Derived fields
    (``yaw``) cannot be written.

    Examples
    --------
    >>> writer = FieldWriter('geometry_msgs/Twist', ['linear.x', 'angular.z'])
    >>> FieldReader('geometry_msgs/Twist', ['angular.z']).read(writer.write(0, [0.5, -1.0]))
    (0, [-1.0])

    """

    def __init__(self, msgtype: str, fields: Sequence[str]) -> None:
        msgtype = full_type_name(msgtype)
        layout = FIXED_LAYOUTS.get(msgtype)
        if layout is None:
            raise FieldPathError(f'message type {msgtype!r} is not written by field path; '
                                 f'expected one of {list(FIXED_LAYOUTS)}')
        index = {path: k for k, path in enumerate(layout.doubles)}
        for path in fields:
            if path not in index:
                raise _refuse(path, msgtype, ' that can be written')
        buffer = bytearray(HEADER + bytes(8 if layout.stamped else 0))
        for _ in range(layout.strings):  # empty strings: a length of 1 and the NUL
            buffer += bytes((-(len(buffer) - ORIGIN)) % 4) + LENGTH.pack(1) + b'\x00'
        buffer += bytes((-(len(buffer) - ORIGIN)) % 8)
        self._start = len(buffer)
        buffer += bytes(8 * len(layout.doubles))
        self._buffer = buffer
        self.stamped = layout.stamped
        self._places = [self._start + 8 * index[path] for path in fields]
        self._double = struct.Struct('<d')

    def write(self, stamp_ns: int, values) -> bytes:
        """Return the message holding ``values`` in the fields, stamped ``stamp_ns``."""
        buffer = self._buffer
        if self.stamped:
            STAMP.pack_into(buffer, ORIGIN, *divmod(int(stamp_ns), 1_000_000_000))
        if isinstance(values, np.ndarray):
            values = values.tolist()
        pack = self._double.pack_into
        for place, value in zip(self._places, values):
            pack(buffer, place, value)
        return bytes(buffer)
