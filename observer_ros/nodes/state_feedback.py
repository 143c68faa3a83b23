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
``state_feedback``: ``u_cmd = sat(-K x_hat + N r + K_i z)`` from ``x_hat`` and ``reference``.

With integral action (``feedback.integral_poles`` or ``feedback.integral_gain``) it also
subscribes ``y``: ``z`` integrates ``r - y_i`` of the measured outputs chosen by
``feedback.integral_outputs`` (see :mod:`observer_ros.core.feedback_law` for the accumulation
and the anti-windup). A run-time change of the gains, outputs or period resets ``z`` to zero;
a change of anything else keeps it.

With ``model.disturbances`` the estimate carries the disturbance states after the plant's:
``K`` acts on the plant states, and with ``feedback.disturbance_rejection`` each matched
input disturbance estimate is subtracted from its input (``u = -K x_hat - d_hat + N r``,
the gain ``[K, K_d]`` of :attr:`~observer_ros.config.FeedbackSettings.estimate_gain`).

The command carries the stamp of the estimate it was computed from, so a lockstep plant can
tell it apart. An ``x_hat`` or ``reference`` beyond ``topics.<topic>.limit`` is dropped and
counted (``out_of_range``); a command that comes out non-finite or beyond
``topics.u_cmd.limit`` is replaced by ``feedback.safe_command`` (counted as
``unsafe_command``, still stamped like its estimate).

The watchdog runs on the steady clock, whatever ``use_sim_time`` says: ``feedback.timeout``
seconds of real time after the last accepted estimate arrived the node publishes
``feedback.safe_command`` (stamped with the node clock), then repeats it every
``feedback.safe_command_period`` seconds until the next accepted estimate. The timer is armed
by the first estimate and, when it fires while estimates kept coming, waits out the rest of
the timeout from the last one: an estimate only notes when it came (re-arming a timer for
every estimate woke the executor's timer thread once per message). So a ``/clock`` that
jumps back, stops or races does not change when the safe command comes. Before the first
accepted estimate the node publishes nothing (the plant applies its own safe input).
"""

from collections import Counter
import time
from typing import Optional

import numpy as np
from rclpy.clock import Clock, ClockType

from observer_ros.config import FEEDBACK
from observer_ros.core.errors import ConfigError
from observer_ros.core.feedback_law import IntegralAction, StateFeedbackLaw
from observer_ros.core.placement_methods import preload_methods
from observer_ros.core.rules import within_limit
from observer_ros.core.units import NANOSECONDS, seconds_to_ns
from observer_ros.ros.diagnostics import monitor, NodeHealth
from observer_ros.ros.messages import LATEST_STAMP_NS, MalformedMessage, VectorCodec
from observer_ros.ros.parameters import ConfiguredNode


def feedback_law(system) -> StateFeedbackLaw:
    """Build the feedback law of a validated system (with its integrator, if any)."""
    feedback = system.feedback
    design = feedback.integral
    integral = None if design is None else IntegralAction(
        design.integral_gain, design.outputs, system.model.dt,
        output_bias=system.augmentation.output_bias(design.outputs))
    return StateFeedbackLaw(feedback.estimate_gain, feedback.reference_gain,
                            feedback.input_limits, integral, operating_point(system.model))


def operating_point(model) -> Optional[tuple]:
    """``(x0, u0, angle states)`` of a model linearized from equations, else None."""
    equations = getattr(model, 'nonlinear', None)
    if equations is None:
        return None
    return model.operating_state, model.operating_input, equations.angle_states


def value_limits(system) -> dict:
    """``topics.<topic>.limit`` of the feedback node's topics."""
    return {topic: system.topics[topic].limit for topic in ('x_hat', 'reference', 'u_cmd', 'y')}


def _integral_key(system) -> Optional[tuple]:
    """Return what the integrator state depends on: it is reset when this changes."""
    design = system.feedback.integral
    if design is None:
        return None
    return (design.integral_gain.tobytes(), design.gain.tobytes(), design.outputs,
            system.model.dt)


class FeedbackPart:
    """
    The feedback part of a node: the law, ``reference``, the watchdog and ``u_cmd``.

    Held (as ``feedback_part``) by the state feedback (:class:`StateFeedbackWiring`, which
    feeds it the ``x_hat`` it subscribes) and by the one-process observer-controller
    (:mod:`observer_ros.nodes.observer_controller`, which feeds it its own estimates). Its
    verbs: :meth:`vet`, :meth:`build`, :meth:`apply`, :meth:`pause`; per estimate
    :meth:`command_for` turns it into the published command. It makes its publisher,
    subscription and timers through its node, so a managed node records them. Its counts
    are in :attr:`command_counters`; :attr:`sent` is the command in effect (the last
    published, ``feedback.safe_command`` before any).

    Parameters
    ----------
    node : ConfiguredNode or ManagedNode
        The node it publishes, subscribes, logs and reads its configuration through.
    stale_input : str
        What the watchdog waits for, named in its messages (``x_hat``, ``estimate``).

    """

    def __init__(self, node, stale_input: str = 'x_hat') -> None:
        self.node = node
        self.stale_input = stale_input

    def build(self, system) -> None:
        """Make the law, the ``u_cmd`` publisher, ``reference`` and the watchdog timers."""
        node = self.node
        preload_methods()  # no placement method may import a module on a callback path
        self.vet(system)
        self.law = feedback_law(system)
        self.feedback_limits = value_limits(system)
        self.feedback_codecs = {topic: VectorCodec.for_topic(system, topic)
                                for topic in ('x_hat', 'reference', 'u_cmd', 'y')}
        self.command_counters: Counter = Counter()
        self.reference = None
        #: ``time.monotonic_ns()`` when the last accepted estimate arrived (None: none yet).
        self.last_estimate_ns = None
        self.stale = False
        self.sent = system.feedback.safe_command
        self.publisher = node.topic_publisher(self.feedback_codecs['u_cmd'].message_class,
                                              'u_cmd')
        node.topic_subscription(self.feedback_codecs['reference'].message_class, 'reference',
                                self.on_reference)
        feedback = system.feedback
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.watchdog = node.create_timer(feedback.timeout, self._on_watchdog, clock=steady,
                                          autostart=False)
        self.repeat_timer = node.create_timer(feedback.safe_command_period,
                                              self._publish_safe_command, clock=steady,
                                              autostart=False)
        node.get_logger().info(f'K = {feedback.design.gain.tolist()}')
        if feedback.disturbance_gain is not None and feedback.disturbance_gain.any():
            node.get_logger().info(f'K_d = {feedback.disturbance_gain.tolist()} (disturbance '
                                   f'rejection)')

    def vet(self, system) -> None:
        """Refuse configurations without a feedback gain."""
        if system.model.n_inputs == 0:
            raise ConfigError('model.B', f'the {self.node.role} node needs a model with inputs; '
                              f'model.B is empty (m = 0)')
        if system.feedback is None:
            raise ConfigError('feedback.gain', f'the {self.node.role} node needs feedback.gain '
                              f'or feedback.poles')

    def apply(self, previous, system) -> None:
        """Use the new gains, limits and timing from now on."""
        old_integral = self.law.integral
        self.law = feedback_law(system)
        if old_integral is not None and _integral_key(previous) == _integral_key(system):
            self.law.integral = old_integral  # same integrator: keep z
        self.feedback_limits = value_limits(system)
        new, old = system.feedback, previous.feedback
        for timer, period, before in ((self.watchdog, new.timeout, old.timeout),
                                      (self.repeat_timer, new.safe_command_period,
                                       old.safe_command_period)):
            if period != before:
                timer.timer_period_ns = seconds_to_ns(period)
                if not timer.is_canceled():
                    timer.reset()  # the new period counts from now

    def decode_checked(self, topic: str, message):
        """Decode a feedback input; drop (and count) a malformed or out-of-range one."""
        try:
            stamp, vector = self.feedback_codecs[topic].decode(message)
        except MalformedMessage as e:
            self.command_counters['malformed'] += 1
            self.node.warn_once(f'malformed {topic}', f'dropped a malformed message: {e}')
            return None, None
        self.node.health.tick(topic, stamp)
        limit = self.feedback_limits[topic]
        if not within_limit(vector, limit):
            self.command_counters['out_of_range'] += 1
            self.node.warn_once(f'{topic} out of range',
                                f'dropped {topic} {vector.tolist()}: a value exceeds '
                                f'topics.{topic}.limit = {limit:g} in magnitude')
            return None, None
        return stamp, vector

    def on_reference(self, message) -> None:
        """Take a ``reference`` (dropped and counted when malformed or out of range)."""
        _, reference = self.decode_checked('reference', message)
        if reference is None:
            return
        if self.law.reference_gain is None and self.law.integral is None:
            self.node.warn_once('no reference gain', 'reference ignored: no reference gain (the '
                                'plant is not square or has a zero at DC; set '
                                'feedback.reference_gain)')
        self.reference = reference

    def command_for(self, stamp: int, estimate) -> np.ndarray:
        """
        Publish the command of an accepted estimate stamped ``stamp``; return it.

        Re-arms the watchdog (and ends a stale spell); a command that comes out non-finite
        or beyond ``topics.u_cmd.limit`` is replaced by ``feedback.safe_command``.
        """
        self.last_estimate_ns = time.monotonic_ns()
        stamp = stamp or self._now_stamp()
        computed = command = self.law.command(estimate, self.reference, stamp)
        unsafe = not within_limit(command, self.feedback_limits['u_cmd'])
        if unsafe:
            command = self.node.system.feedback.safe_command
        self.publisher.publish(self.feedback_codecs['u_cmd'].encode(stamp, command))
        # The bookkeeping after the command is out (nothing runs in between).
        if self.watchdog.is_canceled():  # else it is running and finds last_estimate_ns
            self._arm_watchdog(seconds_to_ns(self.node.system.feedback.timeout))
        if self.stale:
            self.stale = False
            self.repeat_timer.cancel()
            self.node.get_logger().info(f'{self.stale_input} is back: state feedback resumed')
        if unsafe:
            self.command_counters['unsafe_command'] += 1
            self.node.warn_once('unsafe command', f'the command {computed.tolist()} is '
                                f'non-finite or beyond topics.u_cmd.limit = '
                                f'{self.feedback_limits["u_cmd"]:g}: published '
                                f'feedback.safe_command instead')
        self.command_counters['commands'] += 1
        self.sent = command
        return command

    def integrate_measurement(self, stamp, y) -> None:
        """Keep a measurement for the integral action (nothing without it)."""
        if self.law.integral is not None:
            self.law.integral.measure(stamp or self._now_stamp(), y)

    def _now_stamp(self) -> int:
        """Return the node clock as a stamp: 0 (unstamped) beyond what a stamp holds."""
        now = self.node.get_clock().now().nanoseconds
        if now > LATEST_STAMP_NS:
            self.node.warn_once('clock beyond stamps', f'the node clock ({now} ns) lies beyond '
                                f'builtin_interfaces/Time: commands are stamped 0')
            return 0
        return now

    def _on_watchdog(self) -> None:
        if self.stale or self.last_estimate_ns is None:
            self.watchdog.cancel()
            return
        timeout = self.node.system.feedback.timeout
        waited = time.monotonic_ns() - self.last_estimate_ns
        timeout_ns = seconds_to_ns(timeout)
        if waited < timeout_ns:  # estimates came meanwhile: wait the rest from the last one
            self._arm_watchdog(timeout_ns - waited)
            return
        self.watchdog.cancel()
        self.stale = True
        self.command_counters['stale'] += 1
        self._publish_safe_command()  # first: the log write must not delay it
        self.repeat_timer.reset()
        self.node.get_logger().warning(
            f'no {self.stale_input} for {waited / NANOSECONDS:.3f} s (feedback.timeout = '
            f'{timeout} s, steady clock): publishing the safe command '
            f'{self.node.system.feedback.safe_command.tolist()} every '
            f'feedback.safe_command_period = {self.node.system.feedback.safe_command_period} s')

    def _arm_watchdog(self, period_ns: int) -> None:
        """Let the watchdog fire ``period_ns`` from now (steady clock)."""
        self.watchdog.timer_period_ns = period_ns
        self.watchdog.reset()

    def _publish_safe_command(self) -> None:
        if not self.stale:
            self.repeat_timer.cancel()
            return
        self.send_safe_command()

    def send_safe_command(self) -> None:
        """Publish ``feedback.safe_command`` once, stamped with the node clock (counted)."""
        self.command_counters['safe_commands'] += 1
        safe_command = self.node.system.feedback.safe_command
        self.publisher.publish(self.feedback_codecs['u_cmd'].encode(self._now_stamp(),
                                                                    safe_command))
        self.sent = safe_command  # the input in effect from now on

    def pause(self) -> None:
        """Deactivation: one safe command, then silence; the watchdog re-arms on activation."""
        self.send_safe_command()
        self.watchdog.cancel()
        self.repeat_timer.cancel()
        self.stale = False
        self.last_estimate_ns = None


class StateFeedbackWiring:
    """
    The state feedback's wiring: its feedback part between ``x_hat``, ``reference``, ``u_cmd``.

    :class:`StateFeedbackNode` builds it in its constructor, the managed variant
    (made from its spec by :func:`observer_ros.nodes.main.managed_class`) on ``configure``.
    """

    #: The attributes :meth:`build` sets (a managed node drops them on cleanup).
    PARTS = ('feedback_part', 'health', 'diagnostics', 'measurement_subscription')

    def build(self, system) -> None:
        """Make the feedback part (law, publisher, reference, watchdog), ``x_hat`` and health."""
        self.feedback_part = part = FeedbackPart(self)
        part.build(system)
        feedback = system.feedback
        self.health = NodeHealth(
            self, {'x_hat': monitor(system, 'x_hat', feedback.timeout, minimum_only=True),
                   'reference': monitor(system, 'reference', 0.0, required=False,
                                        rated=False)},
            lambda: part.command_counters)
        self.diagnostics = self.health.publisher
        self.topic_subscription(part.feedback_codecs['x_hat'].message_class, 'x_hat',
                                self._on_estimate)
        self.measurement_subscription = None
        self._subscribe_measurements(system)

    @property
    def counters(self) -> Counter:
        """The node's counts (the feedback part's ``command_counters``)."""
        return self.feedback_part.command_counters

    @property
    def codecs(self) -> dict:
        """The codecs of the node's topics."""
        return self.feedback_part.feedback_codecs

    def _subscribe_measurements(self, system) -> None:
        """Subscribe ``y`` once integral action needs it."""
        if system.feedback.integral is not None and self.measurement_subscription is None:
            self.health.watch('y', monitor(system, 'y', 0.0, minimum_only=True))
            self.measurement_subscription = self.topic_subscription(
                self.feedback_part.feedback_codecs['y'].message_class, 'y',
                self._on_measurement)

    def vet_system(self, system) -> None:
        """Refuse configurations without a feedback gain."""
        FeedbackPart(self).vet(system)

    def apply_system(self, previous, system) -> None:
        """Use the new gains, limits and timing from now on."""
        self.feedback_part.apply(previous, system)
        self._subscribe_measurements(system)

    def _on_estimate(self, message) -> None:
        part = self.feedback_part
        stamp, estimate = part.decode_checked('x_hat', message)
        if estimate is not None:
            part.command_for(stamp, estimate)

    def _on_measurement(self, message) -> None:
        part = self.feedback_part
        stamp, y = part.decode_checked('y', message)
        if y is not None:
            part.integrate_measurement(stamp, y)

    def pause(self) -> None:
        """Deactivation: one safe command, then silence; the watchdog re-arms on activation."""
        self.feedback_part.pause()


class StateFeedbackNode(StateFeedbackWiring, ConfiguredNode):
    """The state-feedback node, configured and running from its construction."""

    def __init__(self, node_name: str = 'state_feedback', **kwargs) -> None:
        super().__init__(node_name, FEEDBACK, **kwargs)
        self.build(self.system)
