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
Odometry from named states: the pose, the twist and their covariances a robot stack reads.

``nav_msgs/Odometry`` carries a planar robot's pose (x, y, yaw as a quaternion) in its
``header.frame_id`` (``odom``) and its twist (forward and lateral speed, yaw rate) in its
``child_frame_id`` (``base_link``), each with a 6x6 covariance in the order x, y, z,
roll, pitch, yaw (linear x, y, z, angular x, y, z for the twist). :class:`OdometryMapping`
says which state gives each of ``x``, ``y``, ``yaw``, ``vx``, ``vy``, ``wz`` (any may be
absent) and makes the message's values of an estimate and its covariance ``P``: the rows
and columns of ``P`` of the named states, and where a state is absent zero and the stated
``absent_variance`` on the diagonal. The twist is taken as the states give it: name states
that are speeds in the robot's own frame (``v``, ``w`` of a differential drive). No ROS:
:mod:`observer_ros.wire.odometry` serializes what it gives.
"""

from dataclasses import dataclass
import math
from typing import Mapping, Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError

#: The quantities an Odometry takes from states, in the order of its parameters.
ODOMETRY_STATES = ('x', 'y', 'yaw', 'vx', 'vy', 'wz')

#: Their rows in the 6x6 covariances: the pose's (x, y, yaw) and the twist's (vx, vy, wz).
POSE_ROWS = {'x': 0, 'y': 1, 'yaw': 5}
TWIST_ROWS = {'vx': 0, 'vy': 1, 'wz': 5}

__all__ = ['ODOMETRY_STATES', 'OdometryMapping', 'OdometryValues', 'odometry_mapping']


@dataclass(frozen=True)
class OdometryValues:
    """
    The values of one Odometry message.

    Attributes
    ----------
    pose : tuple of float
        ``x, y, z, qx, qy, qz, qw``.
    pose_covariance : numpy.ndarray, shape (6, 6)
    twist : tuple of float
        ``vx, vy, vz, wx, wy, wz``.
    twist_covariance : numpy.ndarray, shape (6, 6)

    """

    pose: tuple
    pose_covariance: np.ndarray
    twist: tuple
    twist_covariance: np.ndarray


@dataclass(frozen=True)
class OdometryMapping:
    """
    Which state gives each quantity of an Odometry (None: absent).

    Attributes
    ----------
    states : dict
        ``{quantity: state index or None}`` for each of :data:`ODOMETRY_STATES`.
    absent_variance : float
        The variance on the diagonal where a quantity has no state (and everywhere on the
        diagonal for an estimator without a covariance).

    Examples
    --------
    >>> mapping = odometry_mapping(['px', 'py', 'heading', 'v', 'w'],
    ...                            {'x': 'px', 'y': 'py', 'yaw': 'heading', 'vx': 'v',
    ...                             'wz': 'w'})
    >>> values = mapping.values(np.array([1.0, 2.0, math.pi / 2, 0.5, 0.1]),
    ...                         np.diag([0.1, 0.2, 0.3, 0.4, 0.5]))
    >>> [round(value, 6) for value in values.pose]
    [1.0, 2.0, 0.0, 0.0, 0.0, 0.707107, 0.707107]
    >>> values.twist, float(values.pose_covariance[5, 5]), float(values.twist_covariance[5, 5])
    ((0.5, 0.0, 0.0, 0.0, 0.0, 0.1), 0.3, 0.5)

    """

    states: dict
    absent_variance: float = 0.0

    def values(self, estimate: np.ndarray, covariance: Optional[np.ndarray]) -> OdometryValues:
        """
        Return the Odometry of an estimate ``(n,)`` and its covariance ``(n, n)`` (or None).

        The yaw becomes the quaternion ``(0, 0, sin(yaw / 2), cos(yaw / 2))``.
        """
        states = self.states

        def value(name):
            index = states[name]
            return 0.0 if index is None else float(estimate[index])

        half = 0.5 * value('yaw')
        pose = (value('x'), value('y'), 0.0, 0.0, 0.0, math.sin(half), math.cos(half))
        twist = (value('vx'), value('vy'), 0.0, 0.0, 0.0, value('wz'))
        return OdometryValues(pose, self._block(POSE_ROWS, covariance), twist,
                              self._block(TWIST_ROWS, covariance))

    def _block(self, rows: dict, covariance: Optional[np.ndarray]) -> np.ndarray:
        block = np.zeros((6, 6))
        block[np.diag_indices(6)] = self.absent_variance
        present = [(row, self.states[name]) for name, row in rows.items()
                   if self.states[name] is not None]
        if covariance is None or not present:
            return block
        places = [row for row, _ in present]
        index = [state for _, state in present]
        block[np.ix_(places, places)] = np.asarray(covariance)[np.ix_(index, index)]
        return block


def odometry_mapping(state_names: Sequence[str], named: Mapping[str, str],
                     absent_variance: float = 0.0,
                     parameter: str = 'outputs.odometry') -> OdometryMapping:
    """
    Return the mapping of the states named for each quantity (empty or missing: absent).

    Parameters
    ----------
    state_names : sequence of str
        The model's states.
    named : mapping of str to str
        ``{quantity: state name}`` for quantities of :data:`ODOMETRY_STATES`.
    absent_variance : float
        ``>= 0`` and finite.
    parameter : str
        The prefix of the parameters, for the errors (``outputs.odometry.yaw``).

    Raises
    ------
    ConfigError
        Naming ``<parameter>.<quantity>``: a name that is no state, a state named for two
        quantities, a quantity that is not one of :data:`ODOMETRY_STATES`, none named;
        ``<parameter>.absent_variance``: negative or not finite.

    Examples
    --------
    >>> odometry_mapping(['x', 'v'], {'x': 'x', 'yaw': 'theta'})
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: outputs.odometry.yaw: 'theta' is no state; expected \
one of ['x', 'v'] (or empty: no state gives yaw)

    """
    states, owner = {}, {}
    unknown = sorted(set(named) - set(ODOMETRY_STATES))
    if unknown:
        raise ConfigError(f'{parameter}.{unknown[0]}', f'expected one of {list(ODOMETRY_STATES)}')
    for quantity in ODOMETRY_STATES:
        name = named.get(quantity) or ''
        if not name:
            states[quantity] = None
            continue
        if name not in state_names:
            raise ConfigError(f'{parameter}.{quantity}', f'{name!r} is no state; expected one '
                              f'of {list(state_names)} (or empty: no state gives {quantity})')
        if name in owner:
            raise ConfigError(f'{parameter}.{quantity}', f'state {name!r} gives '
                              f'{owner[name]} already; expected another state')
        owner[name] = quantity
        states[quantity] = list(state_names).index(name)
    if not owner:
        raise ConfigError(f'{parameter}.x', f'expected the states of at least one of '
                          f'{list(ODOMETRY_STATES)}, got none')
    variance = absent_variance
    if isinstance(variance, bool) or not isinstance(variance, (int, float)) or not (
            math.isfinite(variance) and variance >= 0.0):
        raise ConfigError(f'{parameter}.absent_variance', f'expected a finite variance >= 0, '
                          f'got {variance!r}')
    return OdometryMapping(states, float(variance))
