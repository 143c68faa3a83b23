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
Vectorized CDR for the two vector message types, without ROS.

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
    """Where a message keeps its stamp and its double arrays."""

    names: tuple
    arrays: dict  # field -> (byte offset of the first double, count)
    size: int


def _align(offset: int, alignment: int) -> int:
    return offset + (-(offset - ORIGIN)) % alignment


def _string(raw, offset: int) -> tuple:
    offset = _align(offset, 4)
    (length,) = struct.unpack_from('<I', raw, offset)
    text = bytes(raw[offset + 4:offset + 4 + length - 1]).decode('utf-8')
    return text, offset + 4 + length


def _doubles(raw, offset: int) -> tuple:
    offset = _align(offset, 4)
    (count,) = struct.unpack_from('<I', raw, offset)
    offset += 4
    if count:
        offset = _align(offset, 8)
    return (offset, count), offset + 8 * count


def parse_layout(raw, kind: str) -> Layout:
    """Parse one serialized message's layout (``kind``: joint_state | float64_multi_array)."""
    if bytes(raw[:2]) != HEADER[:2]:
        raise DecodeError('not little-endian plain CDR')
    try:
        if kind == 'joint_state':
            _, offset = _string(raw, ORIGIN + 8)  # stamp, then frame_id
            (count,) = struct.unpack_from('<I', raw, _align(offset, 4))
            offset = _align(offset, 4) + 4
            names = []
            for _ in range(count):
                name, offset = _string(raw, offset)
                names.append(name)
            arrays = {}
            for field in JOINT_STATE_FIELDS:
                arrays[field], offset = _doubles(raw, offset)
        else:
            offset = _align(ORIGIN, 4)
            (dims,) = struct.unpack_from('<I', raw, offset)
            offset += 4
            for _ in range(dims):
                _, offset = _string(raw, offset)
                offset = _align(offset, 4) + 8  # size, stride
            offset = _align(offset, 4) + 4  # data_offset
            arrays = {}
            arrays['data'], offset = _doubles(raw, offset)
            names = []
    except (struct.error, UnicodeDecodeError) as e:
        raise DecodeError(f'truncated or corrupt message ({e})') from e
    if offset > len(raw):
        raise DecodeError('truncated message')
    return Layout(tuple(names), arrays, len(raw))


def _fixed_mask(layout: Layout, kind: str) -> np.ndarray:
    """Bytes that must equal the template's for a message to share its layout."""
    mask = np.ones(layout.size, dtype=bool)
    if kind == 'joint_state':
        mask[ORIGIN:ORIGIN + 8] = False
    for offset, count in layout.arrays.values():
        mask[offset:offset + 8 * count] = False
    return mask


def _order(layout: Layout, names: Sequence[str]) -> list:
    index = {name: position for position, name in enumerate(layout.names)}
    missing = [name for name in names if name not in index]
    if missing:
        raise DecodeError(f'joints {missing} missing (the message has {list(layout.names)})')
    return [index[name] for name in names]


def _select(layout: Layout, kind: str, field: str, names: Sequence[str]) -> tuple:
    """Return ``(offset, count, order)`` of the wanted values in a layout."""
    if kind == 'joint_state':
        offset, count = layout.arrays[field]
        if count != len(layout.names):
            raise DecodeError(f'{len(layout.names)} names but {count} {field} values')
        return offset, count, _order(layout, names)
    offset, count = layout.arrays['data']
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
        mask = _fixed_mask(layout, kind)
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
