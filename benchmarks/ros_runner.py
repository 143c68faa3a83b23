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
``observer``, ``relay``, ``raw_relay`` (benchmark 4) and ``matched_plant`` (benchmark 5).
"""

import sys

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from sensor_msgs.msg import JointState

from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.plant_simulator import (LOCKSTEP_SETTLE, NANOSECONDS, plant_done,
                                                PlantSimulatorNode)
from observer_ros.ros.parameters import publisher_qos, run_node, subscription_qos


class Relay(Node):
    """Subscribe ``y``, copy the JointState, publish it on ``relay``: a plain rclpy node."""

    def __init__(self) -> None:
        super().__init__('relay')
        self.publisher = self.create_publisher(JointState, 'relay', publisher_qos())
        self.create_subscription(JointState, 'y', self._on_message, subscription_qos())

    def _on_message(self, message: JointState) -> None:
        self.publisher.publish(JointState(header=message.header, name=list(message.name),
                                          position=list(message.position)))


class RawRelay(Node):
    """
    Subscribe ``y`` serialized, publish the same bytes on ``relay``: rclpy's transport floor.

    No message object is built either way (``raw=True`` and ``publish(bytes)``), so nothing
    in Python costs less per message than this.
    """

    def __init__(self) -> None:
        super().__init__('raw_relay')
        publisher = self.create_publisher(JointState, 'relay', publisher_qos())
        self.create_subscription(JointState, 'y', publisher.publish, subscription_qos(),
                                 raw=True)


class MatchedPlant(PlantSimulatorNode):
    """
    The real-time plant simulator, its first sample held until its peers are matched.

    ``plant_simulator`` starts sampling at once. Here sample 0 waits until ``y`` and ``u``
    each have a matched subscription (the observer) and ``u_cmd`` a matched publisher (the
    state feedback), then ``LOCKSTEP_SETTLE`` more for the far ends to match as well, so
    that benchmark 5 counts from a connected loop.
    """

    def __init__(self) -> None:
        super().__init__()
        self.tick_timer.cancel()
        self.command_subscription = next(
            s for s in self.subscriptions
            if s.topic_name == self.resolve_topic_name('u_cmd'))
        self.matched_ns = None
        self.match_timer = self.create_timer(0.01, self._wait_for_peers,
                                             clock=Clock(clock_type=ClockType.STEADY_TIME))

    def _wait_for_peers(self) -> None:
        matched = (self.publishers_['y'].get_subscription_count() > 0
                   and self.publishers_['u'].get_subscription_count() > 0
                   and self.command_subscription.get_publisher_count() > 0)
        now = Clock(clock_type=ClockType.STEADY_TIME).now().nanoseconds
        if not matched:
            self.matched_ns = None
            return
        if self.matched_ns is None:
            self.matched_ns = now
        if now - self.matched_ns >= LOCKSTEP_SETTLE * NANOSECONDS:
            self.match_timer.cancel()
            self.start_ns = self.get_clock().now().nanoseconds
            self.tick_timer.reset()


#: What ``python -m benchmarks.ros_runner KIND`` spins.
NODES = {'observer': ObserverNode, 'relay': Relay, 'raw_relay': RawRelay,
         'matched_plant': MatchedPlant}


def main() -> int:
    """Spin until interrupted, as the package's nodes do (same executor loop)."""
    if len(sys.argv) < 2 or sys.argv[1] not in NODES:
        print(f'ros_runner: error: expected one of {", ".join(NODES)} first', file=sys.stderr)
        return 2
    kind = sys.argv[1]
    return run_node(NODES[kind], 'ros_runner', [sys.argv[0], *sys.argv[2:]],
                    done=plant_done if kind == 'matched_plant' else None)


if __name__ == '__main__':
    sys.exit(main())
