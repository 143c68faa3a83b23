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
The bytes of a CDR message: its header, stamps and lengths, and how layouts are parsed.

What every reader and writer of :mod:`observer_ros.wire` shares: the encapsulation
header, the ``struct`` forms of a stamp and a length, the parsed :class:`Layout` of a
vector message, the :class:`FixedLayout` of a type whose doubles sit at fixed places,
and the one rule for joint names (:func:`joint_order`).
"""

from dataclasses import dataclass
import struct
from typing import Sequence


#: Little-endian plain CDR encapsulation header.
HEADER = b'\x00\x01\x00\x00'
ORIGIN = len(HEADER)
STAMP = struct.Struct('<iI')
#: A CDR string's length (with its NUL) or a sequence's count.
LENGTH = struct.Struct('<I')
#: A header's stamp and the length of its ``frame_id``.
STAMP_LENGTH = struct.Struct('<iII')


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


class Parser:
    """Walk a serialized message, noting the ranges that define its layout."""

    def __init__(self, raw) -> None:
        self.raw = raw
        self.offset = ORIGIN
        self.fixed = [(0, 2)]

    def align(self, alignment: int) -> None:
        """Skip the padding before a value of ``alignment`` bytes."""
        self.offset += (-(self.offset - ORIGIN)) % alignment

    def keep(self, start: int, end: int) -> None:
        """Note ``[start, end)`` as bytes that define the layout."""
        if self.fixed[-1][1] == start:
            self.fixed[-1] = (self.fixed[-1][0], end)
        else:
            self.fixed.append((start, end))

    def count(self) -> int:
        """Read a length or a sequence's length (it defines the layout)."""
        self.align(4)
        (value,) = struct.unpack_from('<I', self.raw, self.offset)
        self.keep(self.offset, self.offset + 4)
        self.offset += 4
        return value

    def string(self) -> str:
        """Read a text (its bytes define the layout)."""
        length = self.count()
        start = self.offset
        self.offset += length
        if self.offset > len(self.raw):
            raise DecodeError('truncated message')
        self.keep(start, self.offset)
        return bytes(self.raw[start:self.offset - 1]).decode('utf-8')

    def doubles(self) -> tuple:
        """Skip a sequence of doubles; return ``(offset of the first, count)``."""
        count = self.count()
        if count:
            self.align(8)
        start = self.offset
        self.offset += 8 * count
        return start, count


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
    observer_ros.wire.layouts.DecodeError: joints ['y1'] named more than once ...

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


#: The arrays of a ``sensor_msgs/JointState``, one value per joint each.
JOINT_STATE_FIELDS = ('position', 'velocity', 'effort')


class VectorLayout:
    """
    A message type that carries a whole vector in one of its arrays of doubles.

    Read by a vector reader (:class:`~observer_ros.wire.vectors.MessageReader`, whole
    bags with :func:`~observer_ros.wire.vectors.decode`): its layout is parsed once per
    publisher, then each message is read with one ``struct`` call. ``stamped``: it has a
    header stamp; ``arrays``: its arrays of doubles, the default first; ``named``: its
    entries are named (joint names), else counted (``data[<index>]``).
    """

    stamped = False
    arrays: tuple = ()
    named = False

    def walk(self, parser: Parser) -> tuple:
        """Walk a message with ``parser``; return its names and ``{array: (offset, count)}``."""
        raise NotImplementedError

    def array(self, field: str) -> str:
        """Return the array that holds the values of ``topics.<topic>.field`` ``field``."""
        return field if self.named else self.arrays[0]

    def paths(self) -> list:
        """Return the field paths it offers, as :func:`~.catalog.field_names` lists them."""
        raise NotImplementedError

    def template(self, types: dict, msgtype: str, names: Sequence[str], field: str, zeros):
        """Return a ``rosbags`` message of the type holding ``zeros`` in ``field``."""
        raise NotImplementedError


class JointStateLayout(VectorLayout):
    """``sensor_msgs/JointState``: a header, joint names and one array per field."""

    stamped = True
    arrays = JOINT_STATE_FIELDS
    named = True

    def walk(self, parser: Parser) -> tuple:
        """Walk a JointState; return its joint names and arrays."""
        parser.offset += 8  # stamp
        parser.string()  # frame_id
        names = [parser.string() for _ in range(parser.count())]
        return names, {field: parser.doubles() for field in JOINT_STATE_FIELDS}

    def paths(self) -> list:
        """Return ``<field>.<joint name>`` of each field."""
        return [f'{field}.<joint name>' for field in JOINT_STATE_FIELDS]

    def template(self, types: dict, msgtype: str, names: Sequence[str], field: str, zeros):
        """Return a JointState of ``names`` with ``zeros`` in ``field``, the others empty."""
        empty = zeros[:0]
        header = types['std_msgs/msg/Header'](
            stamp=types['builtin_interfaces/msg/Time'](sec=0, nanosec=0), frame_id='')
        arrays = {name: (zeros if name == field else empty) for name in JOINT_STATE_FIELDS}
        return types[msgtype](header=header, name=list(names), **arrays)


class MultiArrayLayout(VectorLayout):
    """``std_msgs/Float64MultiArray``: a layout (dimensions, offset) and ``data``; no stamp."""

    arrays = ('data',)

    def walk(self, parser: Parser) -> tuple:
        """Walk a Float64MultiArray; return no names and its ``data``."""
        for _ in range(parser.count()):  # layout.dim: label, size, stride
            parser.string()
            parser.count()
            parser.count()
        parser.count()  # data_offset
        return [], {'data': parser.doubles()}

    def paths(self) -> list:
        """Return ``data[<index>]``."""
        return ['data[<index>]']

    def template(self, types: dict, msgtype: str, names: Sequence[str], field: str, zeros):
        """Return a Float64MultiArray with ``zeros`` in ``data`` and an empty layout."""
        layout = types['std_msgs/msg/MultiArrayLayout'](dim=[], data_offset=0)
        return types[msgtype](layout=layout, data=zeros)
