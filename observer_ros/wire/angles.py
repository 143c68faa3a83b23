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

"""The roll, pitch and yaw of a quaternion: the derived fields of the field readers."""

import math
from operator import itemgetter


#: Derived fields of a quaternion (``orientation.yaw``): its roll, pitch and yaw angles.
ANGLES = ('roll', 'pitch', 'yaw')


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


def picker(steps: list):
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
