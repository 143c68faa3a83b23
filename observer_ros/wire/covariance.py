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
The covariance a message gives of the fields a source reads: its block of ``R``.

``sensor_msgs/Imu``, ``nav_msgs/Odometry``, ``geometry_msgs/PoseWithCovarianceStamped`` and
``TwistWithCovarianceStamped`` carry the covariance of their values: a row-major 3x3 per
vector of an IMU (about x, y, z; the orientation's about the fixed axes, read as roll,
pitch, yaw), a 6x6 of a pose (x, y, z, roll, pitch, yaw) or a twist (linear x, y, z,
angular x, y, z). :class:`CovarianceReader` finds the rows and columns of the fields a
source reads (``twist.twist.linear.x``, ``pose.pose.orientation.yaw``) and gives their
``(k, k)`` block of each message, or says why it cannot be used:

- ``unknown``: element 0 of a covariance read is -1 (the ROS convention for "no estimate",
  ``sensor_msgs/Imu``);
- ``nonfinite``: a NaN or infinite entry;
- ``out_of_range``: an entry larger in magnitude than :data:`COVARIANCE_LIMIT` (the
  topics' limit of covariances: a variance of 1e308 overflows the filter's sums);
- ``not_positive_definite``: not symmetric (beyond rounding) or not positive definite (a
  zero variance, which many drivers leave, says nothing of the sample's quality).

Fields of two different covariances (a twist's and a pose's of one Odometry) have no
cross terms in the message: they are zero. Imports nothing of the package but the catalog.
"""

import math
from typing import Optional, Sequence

import numpy as np

from observer_ros.wire.angles import ANGLES
from observer_ros.wire.catalog import full_type_name, lookup
from observer_ros.wire.layouts import FieldPathError

XYZ = ('x', 'y', 'z')

#: ``{message type: {prefix of a vector: (covariance array, size, {leaf: row})}}``.
COVARIANCES = {
    'sensor_msgs/msg/Imu': {
        'orientation': ('orientation_covariance', 3, dict(zip(ANGLES, range(3)))),
        'angular_velocity': ('angular_velocity_covariance', 3, dict(zip(XYZ, range(3)))),
        'linear_acceleration': ('linear_acceleration_covariance', 3,
                                dict(zip(XYZ, range(3)))),
    },
}
_POSE = {'position': dict(zip(XYZ, range(3))), 'orientation': dict(zip(ANGLES, range(3, 6)))}
_TWIST = {'linear': dict(zip(XYZ, range(3))), 'angular': dict(zip(XYZ, range(3, 6)))}


def _six(prefix: str, parts: dict, covariance: str) -> dict:
    return {f'{prefix}.{part}': (covariance, 6, rows) for part, rows in parts.items()}


COVARIANCES['nav_msgs/msg/Odometry'] = {**_six('pose.pose', _POSE, 'pose.covariance'),
                                        **_six('twist.twist', _TWIST, 'twist.covariance')}
COVARIANCES['geometry_msgs/msg/PoseWithCovarianceStamped'] = _six(
    'pose.pose', _POSE, 'pose.covariance')
COVARIANCES['geometry_msgs/msg/TwistWithCovarianceStamped'] = _six(
    'twist.twist', _TWIST, 'twist.covariance')

#: The reasons a message's block is not used, in the order they are checked.
REASONS = ('unknown', 'nonfinite', 'out_of_range', 'not_positive_definite')

#: The largest magnitude an entry of a message's covariance may have (1e9 squared).
COVARIANCE_LIMIT = 1e18

#: An asymmetry above this times the largest entry makes a block not symmetric.
SYMMETRY_TOLERANCE = 1e-9

#: The value of element 0 of a covariance that says "no estimate" (the ROS convention).
UNKNOWN = -1.0


def covariance_types() -> tuple:
    """Return the message types whose covariance a source may take its noise from."""
    return tuple(COVARIANCES)


class CovarianceReader:
    """
    Read the block of the covariance of chosen fields from messages of one type.

    Parameters
    ----------
    msgtype : str
        One of :func:`covariance_types` (short names and ``pkg/Name`` accepted).
    fields : sequence of str
        The source's field paths, in its order (``twist.twist.linear.x``).

    Raises
    ------
    FieldPathError
        A type without a covariance, or a field it gives none of (a quaternion's ``w``),
        naming the field and the fields that have one.

    Examples
    --------
    >>> reader = CovarianceReader('nav_msgs/Odometry', ['twist.twist.angular.z',
    ...                                                   'twist.twist.linear.x'])
    >>> reader.paths
    ('twist.covariance[0]', 'twist.covariance[35]', 'twist.covariance[30]', \
'twist.covariance[5]')
    >>> reader.block([0.01, 0.04, 0.001, 0.001]).tolist()
    [[0.04, 0.001], [0.001, 0.01]]
    >>> reader.check([-1.0, 0.04, 0.001, 0.001])
    (None, 'unknown')

    """

    def __init__(self, msgtype: str, fields: Sequence[str]) -> None:
        self.msgtype = msgtype = full_type_name(msgtype)
        lookup(msgtype)  # an unknown type: the catalog's error, listing the types
        vectors = COVARIANCES.get(msgtype)
        if vectors is None:
            raise FieldPathError(f'message type {msgtype} carries no covariance; expected one '
                                 f'of {list(COVARIANCES)}')
        self.fields = tuple(fields)
        places = []  # per field: (covariance array, size, row)
        for path in self.fields:
            prefix, _, leaf = path.rpartition('.')
            found = vectors.get(prefix)
            if found is None or leaf not in found[2]:
                offered = [f'{name}.{part}' for name, (_, _, rows) in vectors.items()
                           for part in rows]
                raise FieldPathError(f'{msgtype} gives no covariance of {path!r}; it gives '
                                     f'one of {", ".join(offered)}')
            places.append((found[0], found[1], found[2][leaf]))
        arrays = sorted({array for array, _, _ in places})
        paths = [f'{array}[0]' for array in arrays]  # element 0: the "unknown" mark
        entries = []  # (i, j, index into paths)
        at = {path: k for k, path in enumerate(paths)}
        for i, (array_i, size, row) in enumerate(places):
            for j, (array_j, _, column) in enumerate(places):
                if array_i != array_j:
                    continue
                path = f'{array_i}[{row * size + column}]'
                if path not in at:
                    at[path] = len(paths)
                    paths.append(path)
                entries.append((i, j, at[path]))
        #: The paths to read (element 0 of each covariance first), for a field reader.
        self.paths = tuple(paths)
        self.n_marks = len(arrays)
        self._rows = np.array([i for i, _, _ in entries], dtype=int)
        self._columns = np.array([j for _, j, _ in entries], dtype=int)
        self._take = np.array([k for _, _, k in entries], dtype=int)
        self.size = len(self.fields)
        self._one = int(self._take[0])  # where the variance of a single field is read

    def check(self, values: Sequence[float]) -> tuple:
        """
        Return ``(block, None)`` of the values of :attr:`paths`, or ``(None, reason)``.

        ``reason`` is one of :data:`REASONS`.
        """
        if any(values[k] == UNKNOWN for k in range(self.n_marks)):
            return None, 'unknown'
        if not all(map(math.isfinite, values)):
            return None, 'nonfinite'
        if self.size == 1:  # one field, a variance: the same rules without the matrices
            variance = float(values[self._one])
            if abs(variance) > COVARIANCE_LIMIT:
                return None, 'out_of_range'
            if not variance > 0.0:
                return None, 'not_positive_definite'
            return np.array([[variance]]), None
        block = np.zeros((self.size, self.size))
        block[self._rows, self._columns] = np.asarray(values, dtype=float)[self._take]
        largest = float(np.abs(block).max())
        if largest > COVARIANCE_LIMIT:
            return None, 'out_of_range'
        if float(np.abs(block - block.T).max()) > SYMMETRY_TOLERANCE * largest:
            return None, 'not_positive_definite'
        block = 0.5 * (block + block.T)
        try:
            np.linalg.cholesky(block)
        except np.linalg.LinAlgError:
            return None, 'not_positive_definite'
        return block, None

    def block(self, values: Sequence[float]) -> Optional[np.ndarray]:
        """Return the ``(k, k)`` block of the values of :attr:`paths` (None: not usable)."""
        return self.check(values)[0]

    def read_object(self, message) -> list:
        """Return the values of :attr:`paths` of a message object (getattr, no ROS import)."""
        values = []
        for path in self.paths:
            *parents, leaf = path.split('.')
            node = message
            for name in parents:
                node = getattr(node, name)
            name, _, index = leaf[:-1].partition('[')
            values.append(float(getattr(node, name)[int(index)]))
        return values


__all__ = ['COVARIANCE_LIMIT', 'COVARIANCES', 'CovarianceReader', 'REASONS',
           'SYMMETRY_TOLERANCE', 'UNKNOWN',
           'covariance_types']
