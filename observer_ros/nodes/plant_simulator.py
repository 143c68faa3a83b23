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
``plant_simulator``: the model simulated exactly, publishing ``y``, ``u`` and ``x_true``.

At sample ``k`` (time ``t_k``) it publishes ``y`` and ``x_true`` of the current state and the
input ``u`` it applies from ``t_k`` to ``t_(k+1)``, all stamped ``t_k``; the applied input is
the latest command received on ``u_cmd`` (zero before the first), saturated to
``plant.input_limits``. So in a closed loop the command computed from sample ``k-1`` acts
over the interval after sample ``k``.

Real time: a timer on the node clock ticks at ``plant.rate_hz``. Lockstep
(``plant.lockstep: true``): the plant publishes ``/clock`` itself and moves to the next
sample only once the command computed from the current sample (stamped ``t_k``) has arrived,
or after ``plant.lockstep_timeout`` wall-clock seconds with a warning; runs are deterministic
and as fast as the nodes answer.
"""

from collections import Counter

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.task import Future
from rosgraph_msgs.msg import Clock as ClockMessage

from observer_ros.core.config import PLANT
from observer_ros.core.simulation import PlantSimulator
from observer_ros.ros.diagnostics import DiagnosticsPublisher
from observer_ros.ros.messages import MalformedMessage, ns_to_stamp, VectorCodec
from observer_ros.ros.parameters import ConfiguredNode, publisher_qos, run_node

#: Wall-clock seconds the lockstep plant waits after its peers are discovered.
LOCKSTEP_SETTLE = 0.5

NANOSECONDS = 1_000_000_000


class PlantSimulatorNode(ConfiguredNode):
    """The plant simulator node. ``finished`` completes after ``plant.samples`` samples."""

    def __init__(self, node_name: str = 'plant_simulator', **kwargs) -> None:
        super().__init__(node_name, PLANT, **kwargs)
        system = self.system
        plant = system.plant
        params = system.parameters
        self.simulator = PlantSimulator(
            system.model, plant.initial_state, plant.process_noise, plant.measurement_noise,
            plant.seed, plant.input_limits)
        self.period_ns = plant.period_ns
        self.period = self.period_ns / NANOSECONDS
        self.samples = params['plant.samples']
        self.lockstep = params['plant.lockstep']
        self.lockstep_timeout = params['plant.lockstep_timeout']
        self.lockstep_subscribers = params['plant.lockstep_subscribers']
        self.codecs = {topic: VectorCodec.for_topic(system, topic)
                       for topic in ('y', 'u', 'x_true', 'u_cmd')}
        self.publishers_ = {topic: self.topic_publisher(self.codecs[topic].message_class, topic)
                            for topic in ('y', 'u', 'x_true')}
        self.topic_subscription(self.codecs['u_cmd'].message_class, 'u_cmd', self._on_command)
        self.command = None
        self.command_stamp = None
        self.index = 0
        self.stamp_ns = 0
        self.counters: Counter = Counter()
        self.finished = Future()
        self.diagnostics = DiagnosticsPublisher(self, lambda: self.counters)
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        if self.lockstep:
            self.clock_publisher = self.create_publisher(ClockMessage, '/clock', publisher_qos())
            self.awaiting = None
            self.peers_seen_ns = None
            self.start_timer = self.create_timer(0.05, self._try_start, clock=steady)
            self.timeout_timer = self.create_timer(self.lockstep_timeout, self._on_timeout,
                                                   clock=steady)
            self.timeout_timer.cancel()
        else:
            self.start_ns = self.get_clock().now().nanoseconds
            self.tick_timer = self.create_timer(self.period, self._tick)

    def _on_command(self, message) -> None:
        try:
            stamp, command = self.codecs['u_cmd'].decode(message)
        except MalformedMessage as e:
            self.counters['malformed'] += 1
            self.warn_once('malformed u_cmd', f'dropped a malformed command: {e}')
            return
        self.command, self.command_stamp = command, stamp
        if self.lockstep and self.awaiting is not None and stamp in (self.awaiting, None):
            self.awaiting = None
            self.timeout_timer.cancel()
            self._advance()

    def _publish_sample(self) -> None:
        """Publish sample ``index`` at ``stamp_ns`` and apply the latest command."""
        y = self.simulator.measure()
        self.publishers_['x_true'].publish(
            self.codecs['x_true'].encode(self.stamp_ns, self.simulator.x))
        if self.command is None:
            applied = self.simulator.saturate(np.zeros(self.simulator.model.n_inputs))
        else:
            applied = self.simulator.saturate(self.command)
            if 'first_command_sample' not in self.counters:
                self.counters['first_command_sample'] = self.index
            if self.command_stamp == self.stamp_ns - self.period_ns:
                self.counters['commands_on_time'] += 1
        self.applied = applied
        self.publishers_['u'].publish(self.codecs['u'].encode(self.stamp_ns, applied))
        self.publishers_['y'].publish(self.codecs['y'].encode(self.stamp_ns, y))
        self.counters['samples'] += 1

    def _finish_if_done(self) -> bool:
        if self.samples and self.index >= self.samples:
            if not self.finished.done():
                counters = self.counters
                self.get_logger().info(
                    f'simulated {self.index} samples; {counters["commands_on_time"]} applied '
                    f'the command computed from the previous sample (first command at sample '
                    f'{counters.get("first_command_sample", "none")})')
                self.finished.set_result(self.index)
            return True
        return False

    def _tick(self) -> None:
        if self._finish_if_done():
            self.tick_timer.cancel()
            return
        self.stamp_ns = self.start_ns + self.index * self.period_ns
        self._publish_sample()
        self.simulator.step(self.applied, self.period)
        self.index += 1

    def _try_start(self) -> None:
        ready = (self.count_subscribers(self.publishers_['y'].topic_name)
                 >= self.lockstep_subscribers
                 and self.count_publishers(self.resolve_topic_name('u_cmd')) > 0)
        now = Clock(clock_type=ClockType.STEADY_TIME).now().nanoseconds
        if not ready:
            self.peers_seen_ns = None
            return
        if self.peers_seen_ns is None:
            self.peers_seen_ns = now
        if now - self.peers_seen_ns >= LOCKSTEP_SETTLE * NANOSECONDS:
            self.start_timer.cancel()
            self._lockstep_sample()

    def _lockstep_sample(self) -> None:
        if self._finish_if_done():
            return
        self.stamp_ns = (self.index + 1) * self.period_ns
        clock = ClockMessage()
        ns_to_stamp(clock.clock, self.stamp_ns)
        self.clock_publisher.publish(clock)
        self._publish_sample()
        self.awaiting = self.stamp_ns
        self.timeout_timer.reset()

    def _advance(self) -> None:
        self.simulator.step(self.applied, self.period)
        self.index += 1
        self._lockstep_sample()

    def _on_timeout(self) -> None:
        self.timeout_timer.cancel()
        if self.awaiting is None:
            return
        self.counters['lockstep_timeouts'] += 1
        self.get_logger().warning(
            f'lockstep: no command for sample {self.index} (stamp {self.awaiting} ns) within '
            f'plant.lockstep_timeout = {self.lockstep_timeout} s; advancing with the last one')
        self.awaiting = None
        self._advance()


def plant_done(node: PlantSimulatorNode):
    """Predicate ending the spin when ``plant.samples`` are done (never when it is 0)."""
    return node.finished.done if node.samples else None


def main(args=None) -> int:
    """Entry point of ``ros2 run observer_ros plant_simulator``."""
    return run_node(PlantSimulatorNode, 'plant_simulator', args, done=plant_done)
