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
Vectors on the wire: one codec per message kind, used by every node and bag tool.

``sensor_msgs/JointState`` carries a named, stamped vector: the model's names are the joint
names and the values sit in one field (``position`` by default). Extra joints are ignored
and order does not matter, so ``/joint_states`` of a real robot works. ``std_msgs/
Float64MultiArray`` carries the bare vector in ``data`` and no stamp: the receiver stamps it
on arrival (ros2_control forward command controllers take this type).

Nodes subscribe and publish serialized messages (``raw=True``): the codec reads and writes
the CDR bytes directly (:mod:`observer_ros.wire`, the same code as the bag tools), which
skips building Python message objects on the hot path. Message objects are accepted too.

:class:`FieldCodec` reads the messages robots publish by field path (``sensor_msgs/Imu``
``angular_velocity.z``, ``nav_msgs/Odometry`` ``twist.twist.linear.x``, a pose's
``pose.orientation.yaw``...; see :class:`~observer_ros.wire.FieldReader`), with the
same rules: a malformed message raises :class:`MalformedMessage`, never gives NaN.
"""

import math
import struct
from typing import Optional, Sequence

import numpy as np
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import MultiArrayDimension

from observer_ros.config import Configuration
from observer_ros.config.schema import FIELD_MESSAGE_TYPES, topic_names
from observer_ros.core.units import NANOSECONDS
from observer_ros.wire import (
    ANGLES, by_field_path, DecodeError, FieldReader, FieldWriter, full_type_name, HEADER,
    joint_order, JOINT_STATE, JOINT_STATE_FIELDS, lookup, message_class, MessageReader,
    MessageWriter, ORIGIN, parse_layout, quaternion_angle, STAMP, vector_layout)


class MalformedMessage(ValueError):
    """A message that cannot give the expected vector (reason in the text)."""


#: How a serialized message in little-endian plain CDR starts (else: the general deserializer).
LITTLE_ENDIAN = HEADER[:2]

#: The latest stamp a ``builtin_interfaces/Time`` holds (``sec`` is an int32).
LATEST_STAMP_NS = (2 ** 31 - 1) * NANOSECONDS + NANOSECONDS - 1


def stamp_to_ns(stamp) -> int:
    """``builtin_interfaces/Time`` to integer nanoseconds."""
    return stamp.sec * NANOSECONDS + stamp.nanosec


def ns_to_stamp(stamp, nanoseconds: int) -> None:
    """Write integer nanoseconds into a ``builtin_interfaces/Time`` in place."""
    stamp.sec, stamp.nanosec = divmod(int(nanoseconds), NANOSECONDS)


def stamp_problem(seconds: int, nanoseconds: int) -> Optional[str]:
    """Why ``(sec, nanosec)`` is no usable time (None when it is one)."""
    if not 0 <= nanoseconds < NANOSECONDS:
        return f'invalid stamp sec={seconds}, nanosec={nanoseconds} (nanosec must be < 1e9)'
    if seconds < 0:
        return f'invalid stamp sec={seconds}, nanosec={nanoseconds} (before 1970: negative)'
    return None


def check_publishable_stamp(stamp_ns: int) -> int:
    """Return ``stamp_ns`` if a ``builtin_interfaces/Time`` holds it, else raise ValueError."""
    if not 0 <= stamp_ns <= LATEST_STAMP_NS:
        raise ValueError(f'stamp {stamp_ns} ns does not fit builtin_interfaces/Time '
                         f'(0 ... {LATEST_STAMP_NS} ns)')
    return stamp_ns


class WireDecoding:
    """
    What the decoders of a topic share: an array from the values, the general deserializer.

    A subclass has ``topic``, ``message_class`` and ``decode_values(message)``.
    """

    topic: str
    message_class: type

    def decode(self, message) -> tuple[Optional[int], np.ndarray]:
        """
        Return ``(stamp_ns, vector)``; the stamp is None when the message carries none.

        ``message`` is a message object or its serialized bytes. A zero stamp counts as
        none.

        Raises
        ------
        MalformedMessage
            Undecodable or truncated bytes, wrong length, a missing joint or index, a
            non-finite value, or a stamp that is no time (``nanosec >= 1e9``, negative
            ``sec``).

        """
        stamp, values = self.decode_values(message)
        return stamp, np.array(values, dtype=float)

    def _deserialize(self, raw: bytes) -> object:
        """Return the message object of bytes that are not little-endian plain CDR."""
        try:
            return deserialize_message(raw, self.message_class)
        except Exception as e:  # the type support raises plain RuntimeError / others
            raise MalformedMessage(f'{self.topic}: cannot deserialize ({e})') from None


class VectorCodec(WireDecoding):
    """
    Convert between one topic's messages and ``(stamp_ns, vector)``.

    Parameters
    ----------
    topic : str
        Topic key (``'y'``, ``'u'`` ...), used in error messages.
    kind : str
        A vector type of the wire catalog (``joint_state``, ``float64_multi_array``).
    field : {'position', 'velocity', 'effort'}
        JointState field holding the values.
    names : sequence of str
        Joint names, in vector order.
    shape : tuple of int, optional
        ``(rows, columns)`` of a matrix carried row-major: a Float64MultiArray then fills
        its layout (dimensions ``rows`` and ``columns`` with their sizes and strides).

    """

    def __init__(self, topic: str, kind: str, field: str, names: Sequence[str],
                 shape: Optional[tuple] = None) -> None:
        self.topic = topic
        self.kind = kind
        self.field = field
        self.names = list(names)
        self.shape = shape
        self.size = len(self.names)
        self._layout = vector_layout(kind)
        self.message_class = message_class(full_type_name(kind))
        self.stamped = self._layout.stamped
        self._order_cache: dict = {}
        self._reader = MessageReader(kind, field, self.names)
        self._writer = MessageWriter(serialize_message(self.message(0, [0.0] * self.size)),
                                     kind, field)

    @classmethod
    def for_topic(cls, system: Configuration, topic: str) -> 'VectorCodec':
        """Codec of a topic configured by ``topics.<topic>.*`` and the model names."""
        names = topic_names(system.model, topic)
        settings = system.topics[topic]
        side = math.isqrt(len(names))
        shape = (side, side) if topic.endswith('_covariance') else None
        return cls(topic, settings.type, settings.field, names, shape)

    def encode(self, stamp_ns: int, vector) -> bytes:
        """
        Serialize a message holding ``vector`` (stamped when the type has a header).

        Raises
        ------
        ValueError
            The stamp does not fit ``builtin_interfaces/Time`` (see :data:`LATEST_STAMP_NS`).

        """
        if self.stamped and not 0 <= stamp_ns <= LATEST_STAMP_NS:
            check_publishable_stamp(stamp_ns)  # raises, saying why
        return self._writer.write(stamp_ns, vector)

    def message(self, stamp_ns: int, vector) -> object:
        """Build a message object holding ``vector`` (stamped when the type has a header)."""
        values = [float(value) for value in vector]
        if not self._layout.named:
            message = self.message_class(**{self._layout.arrays[0]: values})
            if self.shape is not None:
                rows, columns = self.shape
                message.layout.dim = [
                    MultiArrayDimension(label='rows', size=rows, stride=rows * columns),
                    MultiArrayDimension(label='columns', size=columns, stride=columns)]
            return message
        message = self.message_class(name=self.names)
        ns_to_stamp(message.header.stamp, stamp_ns)
        setattr(message, self.field, values)
        return message

    def _order(self, joint_names) -> list:
        key = tuple(joint_names)
        order = self._order_cache.get(key)
        if order is None:
            try:
                order = joint_order(key, self.names)
            except DecodeError as e:
                raise MalformedMessage(f'{self.topic}: {e}') from None
            if len(self._order_cache) < 64:
                self._order_cache[key] = order
        return order

    def decode_values(self, message) -> tuple[Optional[int], list]:
        """Return what :meth:`decode` does, the values as a list of floats (no array)."""
        if isinstance(message, bytes):
            if not message.startswith(LITTLE_ENDIAN):  # big-endian or exotic: deserialize
                return self.decode_values(self._deserialize(message))
            try:
                seconds, nanoseconds, values = self._reader.read_parts(message)
            except DecodeError as e:
                raise MalformedMessage(f'{self.topic}: {e}') from None
            if self.stamped and (seconds < 0 or nanoseconds >= NANOSECONDS):
                self._check_stamp(seconds, nanoseconds)
            stamp = seconds * NANOSECONDS + nanoseconds or None
        elif not self._layout.named:
            values = [float(value) for value in getattr(message, self._layout.arrays[0])]
            if len(values) != self.size:
                raise MalformedMessage(
                    f'{self.topic}: expected {self.size} values in data, got {len(values)}')
            stamp = None
        else:
            given = getattr(message, self.field)
            if len(given) != len(message.name):
                raise MalformedMessage(
                    f'{self.topic}: JointState has {len(message.name)} names but '
                    f'{len(given)} {self.field} values')
            values = [float(given[i]) for i in self._order(message.name)]
            self._check_stamp(message.header.stamp.sec, message.header.stamp.nanosec)
            stamp = stamp_to_ns(message.header.stamp) or None
        # One sum proves every value finite (NaN and infinities propagate); only an
        # overflowing sum of finite values needs the value-by-value check.
        if not math.isfinite(sum(values)) and not all(map(math.isfinite, values)):
            raise MalformedMessage(f'{self.topic}: non-finite value in {values}')
        return stamp, values

    def _check_stamp(self, seconds: int, nanoseconds: int) -> None:
        problem = stamp_problem(seconds, nanoseconds)
        if problem:
            raise MalformedMessage(f'{self.topic}: {problem}')


class FieldCodec(WireDecoding):
    """
    Read (and, for fixed-layout types, write) chosen fields of one topic's messages.

    Parameters
    ----------
    topic : str
        Topic or source name, used in error messages.
    msgtype : str
        A type of :data:`observer_ros.wire.FIELD_TYPES`.
    fields : sequence of str
        Field paths, in vector order (see :class:`~observer_ros.wire.FieldReader`).

    Raises
    ------
    observer_ros.wire.FieldPathError
        A type not read by field path or a path it does not have, naming the path, the type
        and the fields it has.

    Examples
    --------
    >>> from sensor_msgs.msg import Imu
    >>> message = Imu()
    >>> message.header.stamp.sec, message.angular_velocity.z = 3, 0.25
    >>> codec = FieldCodec('imu0', 'sensor_msgs/msg/Imu', ['angular_velocity.z'])
    >>> codec.decode(serialize_message(message))
    (3000000000, array([0.25]))

    """

    def __init__(self, topic: str, msgtype: str, fields: Sequence[str]) -> None:
        self.topic = topic
        self._reader = FieldReader(msgtype, fields)
        self.msgtype = self._reader.msgtype
        self._entry = lookup(self.msgtype)
        self.fields = list(fields)
        self.size = len(self.fields)
        self.stamped = self._reader.stamped
        self._read = self._reader.read_little_endian
        self._writer: Optional[FieldWriter] = None
        self.message_class = message_class(self.msgtype)

    def decode_values(self, message) -> tuple[Optional[int], list]:
        """Return what :meth:`decode` does, the values as a list of floats (no array)."""
        if isinstance(message, bytes):
            if not message.startswith(LITTLE_ENDIAN):  # big-endian or exotic: deserialize
                return self.decode_values(self._deserialize(message))
            try:
                seconds, nanoseconds, values = self._read(message)
            except DecodeError as e:
                raise MalformedMessage(f'{self.topic}: {e}') from None
        else:
            seconds, nanoseconds, values = self._object_parts(message)
        if self.stamped and (seconds < 0 or nanoseconds >= NANOSECONDS):
            problem = stamp_problem(seconds, nanoseconds)
            if problem:
                raise MalformedMessage(f'{self.topic}: {problem}')
        if not math.isfinite(sum(values)) and not all(map(math.isfinite, values)):
            raise MalformedMessage(f'{self.topic}: non-finite value in {values}')
        return seconds * NANOSECONDS + nanoseconds or None, values

    def _object_parts(self, message) -> tuple:
        """``(sec, nanosec, values)`` of a message object, field by field."""
        values = []
        try:
            for path in self.fields:
                values.append(float(self._object_field(message, path)))
        except DecodeError as e:
            raise MalformedMessage(f'{self.topic}: {e}') from None
        except (IndexError, AttributeError, TypeError, ValueError) as e:
            raise MalformedMessage(f'{self.topic}: cannot read {path!r} ({e})') from None
        if not self.stamped:
            return 0, 0, values
        return message.header.stamp.sec, message.header.stamp.nanosec, values

    def _object_field(self, message, path: str):
        if self._entry.named:
            field, _, joint = path.partition('.')
            given = getattr(message, field)
            if len(given) != len(message.name):
                raise DecodeError(f'{len(message.name)} names but {len(given)} {field} '
                                  f'values')
            return given[joint_order(message.name, [joint])[0]]
        if self._entry.vector:
            array, _, index = path[:-1].partition('[')
            return getattr(message, array)[int(index)]
        *parents, leaf = path.split('.')
        for name in parents:
            message = getattr(message, name)
        if leaf in ANGLES:
            return quaternion_angle(leaf, message.x, message.y, message.z, message.w)
        if leaf.endswith(']'):
            name, _, index = leaf[:-1].partition('[')
            return getattr(message, name)[int(index)]
        return getattr(message, leaf)

    def encode(self, stamp_ns: int, vector) -> bytes:
        """
        Serialize a message with ``vector`` in the fields (others zero), stamped if it can be.

        Raises
        ------
        observer_ros.wire.FieldPathError
            A type that is not of fixed layout (JointState, Float64MultiArray: see
            :class:`VectorCodec`) or a derived field.
        ValueError
            The stamp does not fit ``builtin_interfaces/Time``.

        """
        if self._writer is None:
            self._writer = FieldWriter(self.msgtype, self.fields)
        if self.stamped:
            check_publishable_stamp(stamp_ns)
        return self._writer.write(stamp_ns, vector)


def topic_codec(system: Configuration, topic: str):
    """
    Return the codec of a vector topic: by field path where ``topics.<topic>.fields`` says.

    ``topics.u.fields`` (``linear.x``, ``angular.z`` of a ``geometry_msgs/Twist`` on
    ``/cmd_vel``; ``data[0]`` of a ``Float64MultiArray`` command) gives a
    :class:`FieldCodec` of ``topics.u.type``; any other topic a :class:`VectorCodec`.
    """
    settings = system.topics[topic]
    if by_field_path(settings.type, settings.fields):
        return FieldCodec(topic, FIELD_MESSAGE_TYPES[settings.type], settings.fields)
    return VectorCodec.for_topic(system, topic)


def source_codecs(system: Configuration) -> dict:
    """
    Return ``{source name: (topic, FieldCodec)}`` of the measurement sources, in order.

    Empty without ``observer.sources`` (one source, ``topics.y``).
    """
    sources = system.observer.sources
    if sources is None:
        return {}
    return {settings.name: (settings.topic, FieldCodec(settings.name, msgtype, settings.fields))
            for settings, msgtype in zip(sources.settings, sources.msgtypes)}


class JointStatesEncoder:
    """
    Serialize ``x_hat`` as a ``sensor_msgs/JointState`` with chosen states in its fields.

    Parameters
    ----------
    selection : observer_ros.config.JointStateSelection
        Joint names and, per field (``position``, ``velocity``, ``effort``), the state index
        of each joint (an empty tuple leaves that field empty).

    Examples
    --------
    >>> from rclpy.serialization import deserialize_message
    >>> from sensor_msgs.msg import JointState
    >>> from observer_ros.config import JointStateSelection
    >>> encoder = JointStatesEncoder(JointStateSelection(('shoulder',), (0,), (1,)))
    >>> message = deserialize_message(encoder.encode(5, [1.5, -2.0]), JointState)
    >>> message.name, list(message.position), list(message.velocity), list(message.effort)
    (['shoulder'], [1.5], [-2.0], [])

    """

    def __init__(self, selection) -> None:
        self.names = list(selection.names)
        self.fields = {field: list(getattr(selection, field)) for field in JOINT_STATE_FIELDS}
        template = JointState(name=self.names, **{
            field: [0.0] * len(indices) for field, indices in self.fields.items()})
        raw = serialize_message(template)
        layout = parse_layout(raw, JOINT_STATE)
        self._buffer = bytearray(len(raw))
        self._buffer[:ORIGIN] = HEADER
        for start, end in layout.fixed:
            self._buffer[start:end] = raw[start:end]
        self._parts = [(struct.Struct(f'<{len(indices)}d'), layout.arrays[field][0], indices)
                       for field, indices in self.fields.items() if indices]

    def encode(self, stamp_ns: int, estimate) -> bytes:
        """Return the message of ``estimate`` (shape ``(n,)``) stamped ``stamp_ns``."""
        check_publishable_stamp(stamp_ns)
        STAMP.pack_into(self._buffer, ORIGIN, *divmod(int(stamp_ns), NANOSECONDS))
        values = estimate.tolist() if isinstance(estimate, np.ndarray) else list(estimate)
        for packer, offset, indices in self._parts:
            packer.pack_into(self._buffer, offset, *[values[i] for i in indices])
        return bytes(self._buffer)
