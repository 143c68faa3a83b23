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
Spin a node of benchmarks 4 and 5 on a chosen executor.

``python -m benchmarks.ros_runner KIND [--executor NAME] --ros-args ...``, ``KIND`` one of
``observer``, ``relay``, ``raw_relay``, ``raw_relay_u``, ``observer_controller`` (benchmark 4),
``state_feedback`` and ``plant_simulator`` (benchmark 5; the package's own nodes, so that no
installed console script has to be found: the same code runs from a pip set-up and a colcon
workspace).
"""

import sys

from rclpy.node import Node
from sensor_msgs.msg import JointState

from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.observer_controller import ObserverControllerNode
from observer_ros.nodes.plant_simulator import plant_done, PlantSimulatorNode
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.qos import publisher_qos, subscription_qos
from observer_ros.ros.run import run_node


def ignore(message) -> None:
    """Take a message and do nothing with it (a relay's ``u``)."""


class Relay(Node):
    """
    Subscribe ``y``, copy the JointState, publish it on ``relay``: a plain rclpy node.

    It also subscribes ``u`` (serialized, ignored), so that it receives what the observer
    receives in a round of benchmark 4: a ``y`` and the ``u`` after it.
    """

    def __init__(self, **kwargs) -> None:
        super().__init__('relay', **kwargs)
        self.publisher = self.create_publisher(JointState, 'relay', publisher_qos())
        self.create_subscription(JointState, 'y', self._on_message, subscription_qos())
        self.create_subscription(JointState, 'u', ignore, subscription_qos(), raw=True)

    def _on_message(self, message: JointState) -> None:
        self.publisher.publish(JointState(header=message.header, name=list(message.name),
                                          position=list(message.position)))


class RawRelay(Node):
    """
    Subscribe ``y`` serialized, publish the same bytes on ``relay``: rclpy's transport floor.

    No message object is built either way (``raw=True`` and ``publish(bytes)``), so nothing
    in Python costs less per message than this.
    """

    def __init__(self, node_name: str = 'raw_relay', **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        publisher = self.create_publisher(JointState, 'relay', publisher_qos())
        self.create_subscription(JointState, 'y', publisher.publish, subscription_qos(),
                                 raw=True)


class RawInputRelay(RawRelay):
    """
    The raw relay that also subscribes ``u`` serialized and does nothing with it.

    The floor for the observer in benchmark 4: it receives the same traffic (a ``y``, then
    the ``u`` the probe sends after the estimate), so the two processes' CPU per round
    compare the same number of messages.
    """

    def __init__(self, **kwargs) -> None:
        super().__init__('raw_relay_u', **kwargs)
        self.create_subscription(JointState, 'u', ignore, subscription_qos(), raw=True)


#: What ``python -m benchmarks.ros_runner KIND`` spins.
NODES = {'observer': ObserverNode, 'relay': Relay, 'raw_relay': RawRelay,
         'raw_relay_u': RawInputRelay,
         'state_feedback': StateFeedbackNode, 'plant_simulator': PlantSimulatorNode,
         'observer_controller': ObserverControllerNode}


def main() -> int:
    """Spin until interrupted, as the package's nodes do (same executor loop)."""
    if len(sys.argv) < 2 or sys.argv[1] not in NODES:
        print(f'ros_runner: error: expected one of {", ".join(NODES)} first', file=sys.stderr)
        return 2
    kind = sys.argv[1]
    return run_node(NODES[kind], 'ros_runner', [sys.argv[0], *sys.argv[2:]],
                    done=plant_done if kind == 'plant_simulator' else None)


if __name__ == '__main__':
    sys.exit(main())
