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
Fields by path: the messages robots publish, read and written by field path.

The messages robots publish are read by field path (:class:`FieldReader`,
:func:`decode_fields`; :class:`FieldWriter` writes commands): ``sensor_msgs/JointState`` by
joint name and field, ``std_msgs/Float64MultiArray`` by index, and the types of fixed layout
of the catalog (:mod:`observer_ros.wire.catalog`: ``sensor_msgs/Imu``,
``nav_msgs/Odometry``, the stamped geometry messages, ``geometry_msgs/Twist``,
``std_msgs/Float64``), whose doubles sit at fixed places after the header's strings: one
length read per string, then one ``struct`` call for the wanted doubles. A quaternion
offers its ``roll``, ``pitch`` and ``yaw`` as derived fields. :func:`by_field_path` is the
one choice between a field reader and a vector reader.
"""

import struct
from typing import Sequence

import numpy as np

from observer_ros.wire.angles import ANGLES, picker
from observer_ros.wire.catalog import (
    find, full_type_name, lookup, message_types, quaternions, refuse)
from observer_ros.wire.layouts import (
    DecodeError, FieldPathError, FixedLayout, HEADER, LENGTH, ORIGIN, STAMP, STAMP_LENGTH)
from observer_ros.wire.vectors import MessageReader


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
                raise refuse(path, msgtype)
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
        self._pick = list if steps == [(k,) for k in range(len(read))] else picker(steps)
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
        A type of the catalog (:mod:`observer_ros.wire.catalog`): ``sensor_msgs/msg/Imu``;
        ``sensor_msgs/Imu`` and the short names (``imu``, ``joint_state``) are accepted.
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
    observer_ros.wire.layouts.FieldPathError: 'linear.w' is no field of geometry_msgs/msg/Twist; \
it has linear.x, linear.y, linear.z, angular.x, angular.y, angular.z

    """

    def __init__(self, msgtype: str, fields: Sequence[str]) -> None:
        self.msgtype = msgtype = full_type_name(msgtype)
        self.fields = list(fields)
        if not self.fields:
            raise FieldPathError(f'expected at least one field of {msgtype}, got none')
        entry = lookup(msgtype)  # raises, listing the types
        self.stamped = entry.stamped
        self._layout = layout = entry.layout
        if not entry.vector:
            self._readers = [(_FixedReader(msgtype, layout, self.fields), None)]
        elif layout.named:
            self._readers = self._joint_readers()
        else:
            indices = [self._index(path) for path in self.fields]
            self._readers = [(MessageReader(msgtype, layout.arrays[0], [], indices), None)]
        #: :meth:`read_parts` of a message known to be little-endian plain CDR.
        self.read_little_endian = (self._readers[0][0].read_parts if len(self._readers) == 1
                                   else self._read_several)

    def _index(self, path: str) -> int:
        """Return the index of ``data[<index>]`` (Float64MultiArray)."""
        array = f'{self._layout.arrays[0]}['
        index = path[len(array):-1]
        if path.startswith(array) and path.endswith(']') and index.isdigit():
            return int(index)
        raise refuse(path, self.msgtype)

    def _joint_readers(self) -> list:
        """One reader per JointState field, with the places of its joints in the vector."""
        by_field: dict = {}
        for position, path in enumerate(self.fields):
            field, _, joint = path.partition('.')
            if field not in self._layout.arrays or not joint:
                raise refuse(path, self.msgtype, ' (expected <field>.<joint name>)')
            by_field.setdefault(field, []).append((position, joint))
        return [(MessageReader(self.msgtype, field, [joint for _, joint in wanted]),
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
        entry = find(msgtype)
        if entry is None or entry.vector:
            fixed = [item.msgtype for item in message_types() if not item.vector]
            raise FieldPathError(f'message type {msgtype!r} is not written by field path; '
                                 f'expected one of {fixed}')
        layout = entry.layout
        index = {path: k for k, path in enumerate(layout.doubles)}
        for path in fields:
            if path not in index:
                raise refuse(path, msgtype, ' that can be written')
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


def by_field_path(msgtype: str, fields: Sequence[str]) -> bool:
    """
    Say whether a topic is read by field path: the one choice between the two readers.

    By field path (:class:`FieldReader`, the nodes' ``FieldCodec``) when field paths are
    given or the type holds no whole vector; else as a vector (:class:`MessageReader`, the
    nodes' ``VectorCodec``) of the type's ``topics.<topic>.field``.
    """
    return bool(fields) or not lookup(msgtype).vector


def topic_reader(msgtype: str, fields: Sequence[str], field: str, names: Sequence[str]):
    """
    Return the reader of a topic: by ``fields`` (:func:`by_field_path`), else its vector.

    Parameters
    ----------
    msgtype : str
        A type of the catalog (short name or ROS type).
    fields : sequence of str
        Field paths (``topics.u.fields``, ``sources.<name>.fields``); empty for a vector.
    field, names
        The array and the entries' names of a vector (``topics.<topic>.field``, the
        model's names).

    """
    if by_field_path(msgtype, fields):
        return FieldReader(msgtype, fields)
    return MessageReader(msgtype, field, names)
