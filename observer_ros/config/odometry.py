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
``outputs.odometry.*``: the ``nav_msgs/Odometry`` (and ``/tf``) the observer publishes.

:func:`odometry_output` checks the section against the model (each name a state, the frame
ids) and returns an :class:`OdometryOutput`: the topic, the frames, whether ``/tf`` is
wanted and the core's :class:`~observer_ros.core.odometry.OdometryMapping`. The node and
``replay`` both encode it with :mod:`observer_ros.wire.odometry`.
"""

from dataclasses import dataclass
from typing import Optional

from observer_ros.core.errors import ConfigError
from observer_ros.core.odometry import odometry_mapping, ODOMETRY_STATES, OdometryMapping
from observer_ros.wire.odometry import check_frame_id, OdometryEncoder, TransformEncoder

#: The parameters' prefix.
PREFIX = 'outputs.odometry'

__all__ = ['OdometryOutput', 'PREFIX', 'odometry_output']


@dataclass(frozen=True)
class OdometryOutput:
    """
    The checked ``outputs.odometry.*``.

    Attributes
    ----------
    topic, frame_id, child_frame_id : str
    publish_tf : bool
    mapping : OdometryMapping

    """

    topic: str
    frame_id: str
    child_frame_id: str
    publish_tf: bool
    mapping: OdometryMapping

    def encoder(self) -> OdometryEncoder:
        """Return the encoder of its Odometry messages."""
        return OdometryEncoder(self.frame_id, self.child_frame_id)

    def transform_encoder(self) -> TransformEncoder:
        """Return the encoder of its ``frame_id -> child_frame_id`` transforms."""
        return TransformEncoder(self.frame_id, self.child_frame_id)

    def encode(self, encoder: OdometryEncoder, stamp_ns: int, estimate, covariance) -> bytes:
        """Return the Odometry of an estimate (and its covariance, or None)."""
        values = self.mapping.values(estimate, covariance)
        return encoder.encode(stamp_ns, values.pose, values.pose_covariance, values.twist,
                              values.twist_covariance)

    def encode_transform(self, encoder: TransformEncoder, stamp_ns: int, estimate) -> bytes:
        """Return the ``/tf`` message of an estimate's pose."""
        pose = self.mapping.values(estimate, None).pose
        return encoder.encode(stamp_ns, pose[:3], pose[3:])


def odometry_output(section, state_names) -> Optional[OdometryOutput]:
    """
    Check ``outputs.odometry.*`` against the states; None without ``outputs.odometry.topic``.

    Raises
    ------
    ConfigError
        Naming the parameter: a state name that is no state (or named twice), no state
        named, an empty or unusable frame id, the two frames equal.

    """
    if not section.topic:
        return None
    for name in ('frame_id', 'child_frame_id'):
        try:
            check_frame_id(name, getattr(section, name))
        except ValueError as e:
            raise ConfigError(f'{PREFIX}.{name}', str(e).partition(': ')[2]) from None
    if section.frame_id == section.child_frame_id:
        raise ConfigError(f'{PREFIX}.child_frame_id', f'expected a frame other than '
                          f'{PREFIX}.frame_id ({section.frame_id!r}), got the same')
    named = {quantity: getattr(section, quantity) for quantity in ODOMETRY_STATES}
    mapping = odometry_mapping(list(state_names), named, section.absent_variance, PREFIX)
    return OdometryOutput(section.topic, section.frame_id, section.child_frame_id,
                          bool(section.publish_tf), mapping)
