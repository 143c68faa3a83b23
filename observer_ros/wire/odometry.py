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
The messages a mobile robot stack expects back: ``nav_msgs/Odometry`` and ``tf2_msgs/TFMessage``.

:class:`OdometryEncoder` serializes an Odometry (little-endian plain CDR, as the readers
of :mod:`~observer_ros.wire.fields` read it) with its ``header.frame_id`` and
``child_frame_id``; :class:`TransformEncoder` the ``frame_id -> child_frame_id`` transform
of the same pose as a ``TFMessage`` of one ``TransformStamped`` (what ``/tf`` carries).
The frame ids are serialized once, when the encoder is made; each message then costs one
``struct`` call. Imports nothing of the package but the layouts.
"""

import struct
from typing import Sequence

import numpy as np

from observer_ros.wire.layouts import HEADER, LENGTH, ORIGIN, STAMP

ODOMETRY = 'nav_msgs/msg/Odometry'
TF_MESSAGE = 'tf2_msgs/msg/TFMessage'

#: Doubles of an Odometry after its strings: pose (7), its covariance (36), twist (6) and
#: its covariance (36).
ODOMETRY_DOUBLES = 7 + 36 + 6 + 36

__all__ = ['ODOMETRY', 'ODOMETRY_DOUBLES', 'OdometryEncoder', 'TF_MESSAGE',
           'TransformEncoder', 'check_frame_id']


def check_frame_id(name: str, value) -> str:
    """
    Return a frame id that can be serialized; ValueError naming ``name`` otherwise.

    Examples
    --------
    >>> check_frame_id('frame_id', 'odom')
    'odom'

    """
    if not isinstance(value, str) or not value or '\x00' in value:
        raise ValueError(f'{name}: expected a non-empty frame id without NUL characters, got '
                         f'{value!r}')
    try:
        value.encode('utf-8')
    except UnicodeEncodeError as e:
        raise ValueError(f'{name}: expected a frame id in UTF-8, got {value!r} ({e})') from None
    return value


def _string(buffer: bytearray, text: str) -> None:
    """Append a CDR string (aligned to 4: its length with the NUL, the bytes, the NUL)."""
    buffer += bytes((-(len(buffer) - ORIGIN)) % 4)
    data = text.encode('utf-8') + b'\x00'
    buffer += LENGTH.pack(len(data)) + data


def _align8(buffer: bytearray) -> None:
    buffer += bytes((-(len(buffer) - ORIGIN)) % 8)


class OdometryEncoder:
    """
    Serialize ``nav_msgs/Odometry`` messages with fixed frame ids.

    Parameters
    ----------
    frame_id, child_frame_id : str
        ``header.frame_id`` (the pose's frame, ``odom``) and ``child_frame_id`` (the twist's,
        ``base_link``).

    Examples
    --------
    >>> from observer_ros.wire import FieldReader
    >>> encoder = OdometryEncoder('odom', 'base_link')
    >>> raw = encoder.encode(5, [1.0, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0], np.zeros(36),
    ...                      [0.5, 0.0, 0.0, 0.0, 0.0, 0.1], np.zeros(36))
    >>> FieldReader('odometry', ['pose.pose.position.y', 'twist.twist.angular.z']).read(raw)
    (5, [2.0, 0.1])

    """

    msgtype = ODOMETRY

    def __init__(self, frame_id: str, child_frame_id: str) -> None:
        self.frame_id = check_frame_id('frame_id', frame_id)
        self.child_frame_id = check_frame_id('child_frame_id', child_frame_id)
        buffer = bytearray(HEADER + bytes(8))
        _string(buffer, frame_id)
        _string(buffer, child_frame_id)
        _align8(buffer)
        self._prefix = bytes(buffer)
        self._doubles = struct.Struct(f'<{ODOMETRY_DOUBLES}d')

    def encode(self, stamp_ns: int, pose: Sequence[float], pose_covariance,
               twist: Sequence[float], twist_covariance) -> bytes:
        """
        Return the message: ``pose`` (x, y, z, qx, qy, qz, qw), ``twist`` (linear, angular).

        The covariances are 36 values each, row-major 6x6 (or ``(6, 6)`` arrays).
        """
        buffer = bytearray(self._prefix)
        STAMP.pack_into(buffer, ORIGIN, *divmod(int(stamp_ns), 1_000_000_000))
        values = [*map(float, pose), *np.ravel(pose_covariance).tolist(),
                  *map(float, twist), *np.ravel(twist_covariance).tolist()]
        if len(values) != ODOMETRY_DOUBLES:
            raise ValueError(f'odometry: expected 7 pose, 36 + 36 covariance and 6 twist '
                             f'values, got {len(values)} in all')
        return bytes(buffer) + self._doubles.pack(*values)


class TransformEncoder:
    """
    Serialize the ``frame_id -> child_frame_id`` transform as a ``tf2_msgs/TFMessage``.

    Examples
    --------
    >>> raw = TransformEncoder('odom', 'base_link').encode(7, [1.0, 2.0, 0.0],
    ...                                                   [0.0, 0.0, 0.0, 1.0])
    >>> len(raw)
    100

    """

    msgtype = TF_MESSAGE

    def __init__(self, frame_id: str, child_frame_id: str) -> None:
        self.frame_id = check_frame_id('frame_id', frame_id)
        self.child_frame_id = check_frame_id('child_frame_id', child_frame_id)
        buffer = bytearray(HEADER + LENGTH.pack(1))  # one transform in the sequence
        self._stamp_at = len(buffer)
        buffer += bytes(8)
        _string(buffer, frame_id)
        _string(buffer, child_frame_id)
        _align8(buffer)
        self._prefix = bytes(buffer)
        self._doubles = struct.Struct('<7d')

    def encode(self, stamp_ns: int, translation: Sequence[float],
               rotation: Sequence[float]) -> bytes:
        """Return the message: ``translation`` (x, y, z), ``rotation`` (x, y, z, w)."""
        buffer = bytearray(self._prefix)
        STAMP.pack_into(buffer, self._stamp_at, *divmod(int(stamp_ns), 1_000_000_000))
        return bytes(buffer) + self._doubles.pack(*map(float, translation),
                                                  *map(float, rotation))
