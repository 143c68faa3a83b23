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
Vector messages: a JointState's or a Float64MultiArray's vector, many at a time or one.

``sensor_msgs/JointState`` and ``std_msgs/Float64MultiArray`` messages of one topic almost
always share one layout (same joint names, same frame id, same lengths): only the stamp and
the values change. :func:`decode` parses one message of each layout byte by byte, checks
which messages share it (every byte but the stamp and the doubles) and reads all of them
with one numpy view; messages of other layouts are parsed one by one. :func:`encode` fills
a serialized template the same way. The results equal ``rosbags``' own (de)serializer.
"""

from dataclasses import dataclass
import struct
from typing import Optional, Sequence

import numpy as np

from observer_ros.wire.catalog import full_type_name, vector_layout
from observer_ros.wire.layouts import (
    DecodeError, HEADER, joint_order, Layout, ORIGIN, Parser, STAMP)


def parse_layout(raw, kind: str) -> Layout:
    """
    Parse one serialized message's layout.

    ``kind``: a vector type of the catalog (``joint_state``, ``float64_multi_array``, or its
    ROS type), whose :class:`~observer_ros.wire.layouts.VectorLayout` walks the message.
    """
    shape = vector_layout(kind)
    if bytes(raw[:2]) != HEADER[:2]:
        raise DecodeError('not little-endian plain CDR')
    parser = Parser(raw)
    try:
        names, arrays = shape.walk(parser)
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


def _select(layout: Layout, kind: str, field: str, names: Sequence[str],
            indices: Optional[Sequence[int]] = None) -> tuple:
    """
    Return ``(offset, count, order)`` of the wanted values in a layout.

    ``indices`` (Float64MultiArray): the wanted entries of ``data`` (any length holding
    them), instead of every entry (``names`` then counts them).
    """
    if vector_layout(kind).named:
        offset, count = layout.arrays[field]
        if count != len(layout.names):
            raise DecodeError(f'{len(layout.names)} names but {count} {field} values')
        return offset, count, joint_order(layout.names, names)
    offset, count = layout.arrays[vector_layout(kind).array(field)]
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
    kind : str
        A vector type of the catalog (``joint_state``, ``float64_multi_array``).
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
    stamped = vector_layout(kind).stamped
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
        if stamped:
            seconds = rows[:, ORIGIN:ORIGIN + 4].copy().view('<i4').ravel().astype(np.int64)
            nanoseconds = rows[:, ORIGIN + 4:ORIGIN + 8].copy().view('<u4').ravel()
            stamps[members] = seconds * 1_000_000_000 + nanoseconds
        data = rows[:, offset:offset + 8 * count].copy().view('<f8').reshape(-1, count)
        values[members] = data[:, order]
        remaining = np.setdiff1d(remaining, members, assume_unique=True)
    return stamps, values, errors


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
        self.stamped = vector_layout(kind).stamped
        self.field = field
        self.names = list(names)
        self.indices = None if indices is None else list(indices)
        self._known: list = []
        self._last: Optional[_Known] = None
        self._last_bytes: tuple = ()

    def _layout(self, raw) -> _Known:
        last = self._last
        if last is not None and len(raw) == last.size:
            head, start, middle, tail = self._last_bytes
            if type(raw) is bytes:  # compared in place, without slicing copies
                if raw.startswith(head) and raw.startswith(middle, start) and raw.endswith(tail):
                    return last
            elif (raw[:len(head)] == head and raw[start:start + len(middle)] == middle
                  and raw[len(raw) - len(tail):] == tail):
                return last
        known = self._match(raw)
        self._last = known
        # The spans start at 0 and end at the size: the first is a prefix, the last a suffix.
        head, middle, tail = (bytes(raw[start:end]) for start, end in known.spans)
        self._last_bytes = (head, known.spans[1][0], middle, tail)
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
        stamp_end = ORIGIN + 8 if self.stamped else ORIGIN
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
        known = self._last  # the last layout seen, checked in place (see _layout)
        if not (type(raw) is bytes and known is not None and len(raw) == known.size
                and raw.startswith(self._last_bytes[0])
                and raw.startswith(self._last_bytes[2], self._last_bytes[1])
                and raw.endswith(self._last_bytes[3])):
            known = self._layout(raw)
        seconds = nanoseconds = 0
        if self.stamped:
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
        shape = vector_layout(kind)
        self.offset, count = layout.arrays[shape.array(field)]
        self.stamped = shape.stamped
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
        self.msgtype = full_type_name(kind)
        shape = vector_layout(kind)
        self.stamped = shape.stamped
        self.typestore = typestore or get_typestore(Stores.ROS2_JAZZY)
        self.width = len(names)
        template = shape.template(self.typestore.types, self.msgtype, names, field,
                                  np.zeros(len(names)))
        raw = bytes(self.typestore.serialize_cdr(template, self.msgtype))
        layout = parse_layout(raw, kind)
        self.offset, _ = layout.arrays[shape.array(field)]
        self.template = np.frombuffer(raw, dtype=np.uint8)

    def encode(self, stamps_ns, values) -> list:
        """Return one ``bytes`` per row of ``values`` ``(k, width)`` stamped ``stamps_ns``."""
        values = np.ascontiguousarray(values, dtype='<f8').reshape(-1, self.width)
        rows = np.tile(self.template, (values.shape[0], 1))
        if self.stamped:
            stamps_ns = np.asarray(stamps_ns, dtype=np.int64)
            seconds, nanoseconds = np.divmod(stamps_ns, 1_000_000_000)
            rows[:, ORIGIN:ORIGIN + 4] = seconds.astype('<i4')[:, None].view(np.uint8)
            rows[:, ORIGIN + 4:ORIGIN + 8] = nanoseconds.astype('<u4')[:, None].view(np.uint8)
        rows[:, self.offset:self.offset + 8 * self.width] = values.view(np.uint8)
        flat = rows.tobytes()
        size = self.template.size
        return [flat[start:start + size] for start in range(0, len(flat), size)]
