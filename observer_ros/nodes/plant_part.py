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
The plant part of the plant simulator node: the simulated model, its samples, its commands.

:class:`PlantPart` is what :class:`~observer_ros.nodes.plant_simulator.PlantSimulatorNode`
holds and calls (see that module for the node's topics, timing and lockstep).
"""

from collections import Counter
import time

import numpy as np
from rclpy.clock import Clock, ClockType
from rclpy.task import Future
from rosgraph_msgs.msg import Clock as ClockMessage

from observer_ros.core.model import model_feedthrough
from observer_ros.core.rules import within_limit
from observer_ros.core.simulation import simulator_of
from observer_ros.core.units import NANOSECONDS, seconds_to_ns
from observer_ros.ros.diagnostics import monitor, NodeHealth
from observer_ros.ros.messages import MalformedMessage, ns_to_stamp, VectorCodec
from observer_ros.ros.qos import publisher_qos


#: Wall-clock seconds between two looks for the peers the plant waits for at start.
START_POLL = 0.02


class PlantPart:
    """
    The plant part of a node: the simulated model, its samples and the commands it applies.

    Held (as ``plant_part``) by :class:`PlantSimulatorNode`. Its verbs: :meth:`build`
    (the simulator, publishers, ``u_cmd``, the start and lockstep timers, through its node);
    per message :meth:`on_command`; per sample :meth:`publish_sample`. A sample publishes
    ``y`` first (what an observer waits for), then ``u`` and ``x_true``; with a feedthrough
    ``D`` it publishes ``u`` before ``y``, stamped alike, so an observer that takes ``D u``
    off ``y`` has the input in effect when ``y`` arrives. ``x_true`` is published only while
    a subscription is matched (the publisher's matched events); its counts and the health
    come after the sample is out. ``finished`` completes after ``plant.samples`` samples.
    """

    def __init__(self, node) -> None:
        self.node = node

    def build(self, system) -> None:
        """Make the simulator, the publishers, ``u_cmd`` and the start (and lockstep) timers."""
        plant = system.plant
        self.simulator = simulator_of(
            system.model, plant.initial_state, plant.process_noise, plant.measurement_noise,
            plant.seed, plant.input_limits, plant.disturbance, plant.disturbance_time,
            input_offset=plant.input_offset)
        self.period_ns = plant.period_ns
        self.period = self.period_ns / NANOSECONDS
        self.samples = plant.samples
        self.lockstep = plant.lockstep
        self.lockstep_timeout = plant.lockstep_timeout
        self.lockstep_subscribers = plant.lockstep_subscribers
        self.autonomous = system.model.n_inputs == 0
        self.wait_for_command = plant.wait_for_command and not self.autonomous
        self.start_timeout = plant.start_timeout
        self.settle_ns = seconds_to_ns(plant.settle_time)
        self.command_timeout_ns = seconds_to_ns(plant.command_timeout)
        self.safe_input = self.simulator.saturate(plant.safe_input)
        self.hold_without_command = plant.hold_without_command and not self.autonomous
        #: Whether the interval after the current sample is held (no command in effect).
        self.holding = False
        self.command_limit = system.topics['u_cmd'].limit
        topics = ('y', 'x_true') if self.autonomous else ('y', 'u', 'x_true')
        self.codecs = {topic: VectorCodec.for_topic(system, topic)
                       for topic in topics + ('u_cmd',)}
        #: Whether x_true has a subscriber (kept by the publisher's matched events).
        self.x_true_listened = None
        self.publishers_ = {topic: self.node.topic_publisher(
            self.codecs[topic].message_class, topic,
            matched=self._on_x_true_matched if topic == 'x_true' else None)
            for topic in topics}
        self.limits = {topic: system.topics[topic].limit for topic in topics}
        #: With a feedthrough D, u goes out before y (stamped alike): D u needs it there.
        self.u_first = model_feedthrough(system.model) is not None
        self.command_subscription = None if self.autonomous else self.node.topic_subscription(
            self.codecs['u_cmd'].message_class, 'u_cmd', self.on_command)
        self.command = None
        self.command_stamp = None
        #: When the latest command arrived: ``time.monotonic_ns()`` (the steady clock) in real
        #: time, the current sample's stamp in lockstep.
        self.command_arrival_ns = None
        self.command_lost = False
        self.started = False
        self.index = 0
        self.stamp_ns = 0
        #: The stamp of the previous sample (the one a command on time was computed from).
        self.previous_stamp_ns = -self.period_ns
        #: Real time: the period count ``k`` of the last sample (stamp ``start + k * period``).
        self.period_index = -1
        self.counters: Counter = Counter()
        self.finished = Future()
        self.health = NodeHealth(
            self.node, {'u_cmd': monitor(system, 'u_cmd', plant.command_timeout,
                                         required=self.wait_for_command, minimum_only=True)},
            lambda: self.counters)
        self.steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.peers_seen_ns = None
        self.waiting_since_ns = self.steady.now().nanoseconds
        if self.lockstep:
            self.clock_publisher = self.node.create_publisher(ClockMessage, '/clock',
                                                              publisher_qos())
            self.awaiting = None
            self.timeout_timer = self.node.create_timer(
                self.lockstep_timeout, self._on_timeout, clock=self.steady, autostart=False)
        self.start_timer = self.node.create_timer(START_POLL, self._try_start,
                                                  clock=self.steady)

    def _on_x_true_matched(self, status) -> None:
        """Note a subscription on x_true matched or gone (published only while one is)."""
        self.x_true_listened = status.current_count > 0

    def on_command(self, message) -> None:
        """Take a ``u_cmd`` (dropped and counted when malformed or out of range)."""
        try:
            stamp, command = self.codecs['u_cmd'].decode(message)
        except MalformedMessage as e:
            self.counters['malformed'] += 1
            self.node.warn_once('malformed u_cmd', f'dropped a malformed command: {e}')
            return
        if not within_limit(command, self.command_limit):
            self.health.tick('u_cmd', stamp)
            self.counters['out_of_range'] += 1
            self.node.warn_once('u_cmd out of range', f'dropped u_cmd {command.tolist()}: a '
                                f'value exceeds topics.u_cmd.limit = {self.command_limit:g} '
                                f'in magnitude')
            return
        self.command, self.command_stamp = command, stamp
        self.command_arrival_ns = self.stamp_ns if self.lockstep else time.monotonic_ns()
        if self.command_lost:
            self.command_lost = False
            self.node.get_logger().info('u_cmd is back: applying the commands again')
        if self.lockstep and self.awaiting is not None and stamp in (self.awaiting, None):
            # An unstamped command (Float64MultiArray) ending the wait is the one computed
            # from the awaited sample: counted as such in commands_on_time.
            self.command_stamp = self.awaiting
            self.awaiting = None
            self.timeout_timer.cancel()
            self._advance()
        self.health.tick('u_cmd', stamp)  # after the next sample is out

    def _command_in_effect(self) -> tuple:
        """Return ``(input, is a command)``: the latest command, or the safe input."""
        if self.autonomous:
            return self.safe_input, False  # no input at all (m = 0)
        if self.command is None:
            return self.safe_input, False
        now = self.stamp_ns if self.lockstep else time.monotonic_ns()
        age = now - self.command_arrival_ns
        if age <= self.command_timeout_ns:
            return self.command, True
        if not self.command_lost:
            self.command_lost = True
            self.counters['command_timeouts'] += 1
            self.node.get_logger().warning(
                f'no u_cmd for {age / NANOSECONDS:.3f} s (plant.command_timeout = '
                f'{self.command_timeout_ns / NANOSECONDS:g} s, '
                f'{"simulated" if self.lockstep else "steady clock"}): applying '
                f'plant.safe_input {self.safe_input.tolist()} until the next command')
        self.counters['safe_input_samples'] += 1
        return self.safe_input, False

    def publish_sample(self) -> None:
        """
        Publish sample ``index`` at ``stamp_ns`` and apply the command in effect.

        ``y = C x + D u`` with ``u`` the input applied from this sample on, stamped like
        ``y``: ``y`` goes out first (the observer waits for it), then ``u``, then
        ``x_true`` (while subscribed); with a feedthrough ``u`` goes out before ``y``.
        ``y = C x`` without a feedthrough. The counts come after.
        """
        command, commanded = self._command_in_effect()
        self.holding = self.hold_without_command and not commanded
        simulator = self.simulator
        y = simulator.measure(command)
        applied = simulator.saturate(command)
        if self.u_first:
            self._publish_within('u', applied)
            self._publish_within('y', y)
        else:
            self._publish_within('y', y)
            if not self.autonomous:
                self._publish_within('u', applied)
        listened = self.x_true_listened
        if listened is None:  # no matched event yet: ask once
            listened = self.x_true_listened = (
                self.publishers_['x_true'].get_subscription_count() > 0)
        if listened:
            self._publish_within('x_true', simulator.x)
        self.applied = applied
        if commanded:
            if 'first_command_sample' not in self.counters:
                self.counters['first_command_sample'] = self.index
            if self.command_stamp == self.previous_stamp_ns:
                self.counters['commands_on_time'] += 1
        self.counters['samples'] += 1

    def _publish_within(self, topic: str, vector) -> None:
        """Publish ``vector`` on ``topic`` unless it is not finite or beyond its limit."""
        limit = self.limits[topic]
        if not within_limit(np.asarray(vector, dtype=float), limit):
            self.counters['out_of_range'] += 1
            self.node.warn_once(f'{topic} out of range', f'{topic} not published: a value is '
                                f'not finite or beyond topics.{topic}.limit = {limit:g} (the '
                                f'simulated plant diverges)')
            return
        self.publishers_[topic].publish(self.codecs[topic].encode(self.stamp_ns, vector))

    def _finish_if_done(self) -> bool:
        if self.samples and self.index >= self.samples:
            if not self.finished.done():
                counters = self.counters
                self.node.get_logger().info(
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
        elapsed = self.node.get_clock().now().nanoseconds - self.start_ns
        period_index = max(0, elapsed) // self.period_ns
        periods = period_index - self.period_index
        if periods <= 0:
            return  # the previous tick came late, in this period already: its sample stands
        if self.index:
            if periods > 1:
                self.counters['skipped_periods'] += periods - 1
            self._simulate(periods)
        self.period_index = period_index
        self.previous_stamp_ns = self.stamp_ns
        self.stamp_ns = self.start_ns + period_index * self.period_ns
        self.publish_sample()
        self.index += 1

    def _simulate(self, periods: int) -> None:
        """Advance the plant ``periods`` sample periods with the applied input held."""
        if self.holding:  # plant.hold_without_command: no command in effect, braked
            self.counters['held_samples'] += periods
            return
        if self.simulator.model.is_discrete:
            for _ in range(periods):  # a discrete model advances one period per step
                self.simulator.step(self.applied, self.period)
        else:
            self.simulator.step(self.applied, periods * self.period_ns / NANOSECONDS)

    def missing_peers(self) -> list:
        """Return what the plant still waits for before its first sample (empty: nothing)."""
        missing = []
        subscribers = self.publishers_['y'].get_subscription_count()
        if subscribers < self.lockstep_subscribers:
            missing.append(f'{self.lockstep_subscribers} subscriber(s) on '
                           f'{self.publishers_["y"].topic_name} (plant.lockstep_subscribers; '
                           f'{subscribers} so far)')
        if self.wait_for_command and self.command_subscription.get_publisher_count() == 0:
            missing.append(f'a publisher on {self.command_subscription.topic_name} '
                           f'(plant.wait_for_command)')
        return missing

    def _try_start(self) -> None:
        now = self.steady.now().nanoseconds
        missing = self.missing_peers()
        if missing:
            self.peers_seen_ns = None
            waited = (now - self.waiting_since_ns) / NANOSECONDS
            if not self.start_timeout or waited < self.start_timeout:
                return
            self.counters['started_without_peers'] += 1
            self.node.get_logger().warning(
                f'starting without {" and ".join(missing)}: plant.start_timeout = '
                f'{self.start_timeout:g} s passed')
        elif self._settling(now):
            return
        self.start_timer.cancel()
        self.started = True
        if self.lockstep:
            self._lockstep_sample()
        else:
            self.start_ns = self.node.get_clock().now().nanoseconds
            self.tick_timer = self.node.create_timer(self.period, self._tick)
            self._tick()

    def _settling(self, now_ns: int) -> bool:
        """Whether the peers have been matched for less than ``plant.settle_time``."""
        if self.peers_seen_ns is None:
            self.peers_seen_ns = now_ns
        return now_ns - self.peers_seen_ns < self.settle_ns

    def _lockstep_sample(self) -> None:
        if self._finish_if_done():
            return
        self.previous_stamp_ns = self.stamp_ns
        self.stamp_ns = (self.index + 1) * self.period_ns
        clock = ClockMessage()
        ns_to_stamp(clock.clock, self.stamp_ns)
        self.clock_publisher.publish(clock)
        self.publish_sample()
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
        self.node.get_logger().warning(
            f'lockstep: no command for sample {self.index} (stamp {self.awaiting} ns) within '
            f'plant.lockstep_timeout = {self.lockstep_timeout} s; advancing with the input in '
            f'effect')
        self.awaiting = None
        self._advance()
