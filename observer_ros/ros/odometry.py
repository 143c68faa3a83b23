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
The observer's ``nav_msgs/Odometry`` and its ``odom -> base_link`` transform on ``/tf``.

:class:`OdometryPublisher` is made from the checked ``outputs.odometry.*``
(:class:`~observer_ros.config.odometry.OdometryOutput`) and publishes, for each estimate,
the Odometry (serialized by :mod:`observer_ros.wire.odometry`) and, where ``tf2_msgs`` is
installed (a ROS 2 install) and ``outputs.odometry.publish_tf`` is true, the transform;
without ``tf2_msgs`` the transform is skipped and :attr:`OdometryPublisher.tf_skipped`
says why (the node logs it once).
"""

from typing import Optional

from observer_ros.wire import message_class, MessageClassError
from observer_ros.wire.odometry import ODOMETRY, TF_MESSAGE

#: The topic of the transforms (absolute: every node of a robot shares it).
TF_TOPIC = '/tf'

#: Depth of the ``/tf`` publisher's history (tf2_ros's TransformBroadcaster keeps 100).
TF_DEPTH = 100

__all__ = ['OdometryPublisher', 'TF_DEPTH', 'TF_TOPIC', 'transform_message_class']


def transform_message_class() -> tuple:
    """Return ``(TFMessage class, None)``, or ``(None, why)`` where tf2_msgs is missing."""
    try:
        return message_class(TF_MESSAGE), None
    except MessageClassError as e:
        return None, f'no /tf: {e}'


class OdometryPublisher:
    """
    Publish the Odometry (and ``/tf``) of each estimate.

    Parameters
    ----------
    node : ConfiguredNode
        Its ``topic_publisher`` makes the Odometry publisher, ``output_publisher`` the one
        of ``/tf`` (a managed node's are lifecycle publishers).
    output : OdometryOutput

    """

    def __init__(self, node, output) -> None:
        self.output = output
        self.encoder = output.encoder()
        self.publisher = node.topic_publisher(message_class(ODOMETRY), output.topic)
        self.transforms = None
        self.tf_skipped: Optional[str] = None if output.publish_tf else 'publish_tf is false'
        if output.publish_tf:
            tf_class, self.tf_skipped = transform_message_class()
            if tf_class is not None:
                self.transform_encoder = output.transform_encoder()
                self.transforms = node.output_publisher(tf_class, TF_TOPIC, TF_DEPTH)

    def publish(self, sample) -> None:
        """Publish the Odometry (and the transform) of one published estimate."""
        output, stamp = self.output, sample.stamp_ns
        self.publisher.publish(output.encode(self.encoder, stamp, sample.estimate,
                                             sample.covariance))
        if self.transforms is not None:
            self.transforms.publish(output.encode_transform(self.transform_encoder, stamp,
                                                            sample.estimate))
