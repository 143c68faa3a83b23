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
Spin the observer node, or a bare relay, on a chosen executor (benchmark 4).

``python -m benchmarks.ros_runner observer|relay [--executor NAME] --ros-args ...``
"""

import sys

from rclpy.node import Node
from sensor_msgs.msg import JointState

from observer_ros.nodes.observer import ObserverNode
from observer_ros.ros.parameters import publisher_qos, run_node, subscription_qos


class Relay(Node):
    """Subscribe ``y``, copy the JointState, publish it on ``relay``: the floor of latency."""

    def __init__(self) -> None:
        super().__init__('relay')
        self.publisher = self.create_publisher(JointState, 'relay', publisher_qos())
        self.create_subscription(JointState, 'y', self._on_message, subscription_qos())

    def _on_message(self, message: JointState) -> None:
        self.publisher.publish(JointState(header=message.header, name=list(message.name),
                                          position=list(message.position)))


def main() -> int:
    """Spin until interrupted, as the package's nodes do (same executor loop)."""
    kind = sys.argv[1]
    return run_node(ObserverNode if kind == 'observer' else Relay, 'ros_runner',
                    [sys.argv[0], *sys.argv[2:]])


if __name__ == '__main__':
    sys.exit(main())
