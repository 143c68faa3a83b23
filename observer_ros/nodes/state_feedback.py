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
``state_feedback``: ``u_cmd = sat(-K x_hat + N r)`` from ``x_hat`` and ``reference``.

The command carries the stamp of the estimate it was computed from, so a lockstep plant can
tell it apart. When no ``x_hat`` has arrived for ``feedback.timeout`` seconds (node clock) the
node publishes ``feedback.safe_command`` instead, and says so once per outage.
"""

from collections import Counter

from observer_ros.core.config import FEEDBACK
from observer_ros.core.control import StateFeedbackLaw
from observer_ros.core.errors import ConfigError
from observer_ros.core.placement import preload_methods
from observer_ros.ros.diagnostics import DiagnosticsPublisher
from observer_ros.ros.messages import MalformedMessage, VectorCodec
from observer_ros.ros.parameters import ConfiguredNode, run_node

NANOSECONDS = 1_000_000_000


def feedback_law(system) -> StateFeedbackLaw:
    """Build the feedback law of a validated system."""
    feedback = system.feedback
    return StateFeedbackLaw(feedback.design.gain, feedback.reference_gain,
                            feedback.input_limits)


class StateFeedbackNode(ConfiguredNode):
    """The state-feedback node."""

    def __init__(self, node_name: str = 'state_feedback', **kwargs) -> None:
        super().__init__(node_name, FEEDBACK, **kwargs)
        preload_methods()  # no placement method may import a module on a callback path
        system = self.system
        self.vet_system(system)
        self.law = feedback_law(system)
        self.codecs = {topic: VectorCodec.for_topic(system, topic)
                       for topic in ('x_hat', 'reference', 'u_cmd')}
        self.counters: Counter = Counter()
        self.reference = None
        self.last_arrival_ns = self.get_clock().now().nanoseconds
        self.stale = False
        self.publisher = self.topic_publisher(self.codecs['u_cmd'].message_class, 'u_cmd')
        self.topic_subscription(self.codecs['x_hat'].message_class, 'x_hat', self._on_estimate)
        self.topic_subscription(self.codecs['reference'].message_class, 'reference',
                                self._on_reference)
        self.watchdog = self.create_timer(system.feedback.timeout / 2.0, self._check_stale)
        self.diagnostics = DiagnosticsPublisher(self, lambda: self.counters)
        self.get_logger().info(f'K = {system.feedback.design.gain.tolist()}')

    def vet_system(self, system) -> None:
        """Refuse configurations without a feedback gain."""
        if system.feedback is None:
            raise ConfigError('feedback.gain', 'the state_feedback node needs feedback.gain '
                              'or feedback.poles')

    def apply_system(self, previous, system) -> None:
        """Use the new gains from the next estimate on."""
        self.law = feedback_law(system)
        if system.feedback.timeout != previous.feedback.timeout:
            self.watchdog.cancel()
            self.watchdog = self.create_timer(system.feedback.timeout / 2.0, self._check_stale)

    def _decode(self, topic: str, message):
        try:
            return self.codecs[topic].decode(message)
        except MalformedMessage as e:
            self.counters['malformed'] += 1
            self.warn_once(f'malformed {topic}', f'dropped a malformed message: {e}')
            return None, None

    def _on_reference(self, message) -> None:
        _, reference = self._decode('reference', message)
        if reference is None:
            return
        if self.law.reference_gain is None:
            self.warn_once('no reference gain', 'reference ignored: no reference gain (the '
                           'plant is not square or has a zero at DC; set '
                           'feedback.reference_gain)')
        self.reference = reference

    def _on_estimate(self, message) -> None:
        stamp, estimate = self._decode('x_hat', message)
        if estimate is None:
            return
        now = self.get_clock().now().nanoseconds
        self.last_arrival_ns = now
        if self.stale:
            self.stale = False
            self.get_logger().info('x_hat is back: state feedback resumed')
        command = self.law.command(estimate, self.reference)
        self.counters['commands'] += 1
        self.publisher.publish(self.codecs['u_cmd'].encode(stamp or now, command))

    def _check_stale(self) -> None:
        now = self.get_clock().now().nanoseconds
        if now - self.last_arrival_ns <= self.system.feedback.timeout * NANOSECONDS:
            return
        if not self.stale:
            self.stale = True
            self.counters['stale'] += 1
            self.get_logger().warning(
                f'no x_hat for more than feedback.timeout = {self.system.feedback.timeout} s: '
                f'publishing the safe command {self.system.feedback.safe_command.tolist()}')
        self.publisher.publish(
            self.codecs['u_cmd'].encode(now, self.system.feedback.safe_command))


def main(args=None) -> int:
    """Entry point of ``ros2 run observer_ros state_feedback``."""
    return run_node(StateFeedbackNode, 'state_feedback', args)
