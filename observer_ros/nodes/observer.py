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
``observer``: subscribe ``y`` and ``u``, publish the state estimate ``x_hat``.

A model without inputs (``model.B`` empty, m = 0) subscribes ``y`` only: each measurement
advances the estimate at once (nothing waits for an input).

With ``observer.joint_names`` every published ``x_hat`` is also published on
``joint_states_hat`` as a ``sensor_msgs/JointState`` with the same stamp, its ``position``,
``velocity`` and ``effort`` filled from the states ``observer.joint_<field>_states`` choose.

Also publishes ``innovation`` (``y - C x_hat_prior``) and, for an observer type with a
covariance (its capabilities say so: the Kalman filters), ``x_hat_covariance`` (``P``, n x n
row-major), ``innovation_covariance`` (``S``, p x p) and ``nis`` (``v^T S^-1 v``), each
stamped like the ``x_hat`` it belongs to; its health (configuration, inputs, estimator:
:mod:`observer_ros.ros.diagnostics`) on ``/diagnostics``; offers ``~/reset``
(``std_srvs/Trigger``). With ``observer.publish_rate`` it also publishes, at that rate on its
clock, the estimate (and covariance) predicted to that time.
"""

from collections import Counter
from functools import partial
import time
from typing import Optional

import numpy as np
from rclpy.clock import Clock, ClockType
from sensor_msgs.msg import JointState
from std_srvs.srv import Trigger

from observer_ros.app.health import sources_check
from observer_ros.config import OBSERVER
from observer_ros.core.errors import ConfigError, ObserverRosError
from observer_ros.core.estimators.intervals import IntervalDesigns
from observer_ros.core.placement_methods import preload_methods
from observer_ros.core.rules import within_limit
from observer_ros.core.units import NANOSECONDS, rate_to_period_ns
from observer_ros.ros.diagnostics import monitor, NodeHealth
from observer_ros.ros.messages import (
    JointStatesEncoder, MalformedMessage, source_codecs, topic_codec)
from observer_ros.ros.odometry import OdometryPublisher
from observer_ros.ros.parameters import ConfiguredNode


#: How long a node-clock reading serves the clock tolerance check (see ``_clock_for``).
CLOCK_REUSE_NS = 100_000_000

#: Topics an observer type with a covariance adds to x_hat and the innovation.
COVARIANCE_TOPICS = ('x_hat_covariance', 'innovation_covariance', 'nis')

#: Errors a per-interval design may raise on a sample (the sample is dropped and counted).
STEP_ERRORS = (ObserverRosError, np.linalg.LinAlgError, ValueError, ArithmeticError)


class ObserverPart:
    """
    The observer part of a node: one :class:`~observer_ros.core.streaming.EventStream` to topics.

    Held (as ``observer_part``) by the observer (:class:`ObserverWiring`) and by the
    one-process observer-controller, beside its feedback part. Its verbs: :meth:`vet`,
    :meth:`build`, :meth:`apply`, :meth:`pause`, :meth:`resume`; per message
    :meth:`on_measurement`, :meth:`on_source` and :meth:`on_input`. It makes its publishers,
    subscriptions, timers and ``~/reset`` through its node, so a managed node records them.

    The path from a measurement to ``x_hat`` is kept lean: the stream's step is prepared
    once per sample (after the estimate is out, or when the input it needs arrives), the
    health counts and the secondary topics (innovation, covariances, NIS,
    ``joint_states_hat``) come after ``x_hat``, and a secondary topic nobody subscribes is
    neither encoded nor published (its subscriber count is refreshed by the publisher's
    matched events, off the message path).

    Parameters
    ----------
    node : ConfiguredNode or ManagedNode
        The node it publishes, subscribes, logs and reads its configuration through.
    hooks : object, optional
        What a node that acts on the estimates adds (the observer-controller's command):
        ``measured(stamp, y)`` before a measurement is taken, ``estimated(samples)`` before
        ``x_hat`` is published (the command first) and ``published(state)`` with what it
        returned once the estimates are out.
    primary : tuple of str
        The topics published whether subscribed or not (``x_hat`` for the observer; none
        for the controller, whose answer is ``u_cmd``).

    """

    def __init__(self, node, hooks=None, primary: tuple = ('x_hat',)) -> None:
        self.node = node
        self.hooks = hooks
        self.primary = primary

    def build(self, system, inputs: Optional[bool] = None) -> None:
        """
        Make the estimator, publishers, subscriptions, timers and ``~/reset``.

        ``inputs``: whether ``u`` is subscribed (None: when the model has inputs).
        """
        node = self.node
        self.vet(system)
        setup = system.observer
        if 'method' in setup.kind.argument_names():  # placement; the method may change
            preload_methods()  # no placement method may import a module on a callback path
        self.stream = setup.take_stream()
        self._design_expected_interval(system)
        covariance = setup.kind.capabilities.covariance
        topics = ('y', 'u', 'x_hat', 'innovation') + (COVARIANCE_TOPICS if covariance else ())
        if inputs is None:
            inputs = system.model.n_inputs > 0
        self.inputs = inputs
        self.codecs = {topic: topic_codec(system, topic) for topic in topics}
        self.n_states, self.x_hat_codec = system.model.n_states, self.codecs['x_hat']
        #: The decoders of the busiest messages, looked up once.
        self._decode_y = self.codecs['y'].decode_values
        self._decode_u = self.codecs['u'].decode_values
        self.node_counters: Counter = Counter()
        #: Whether each published topic has a subscriber (kept by matched events).
        self.listened = {}
        self.publishers_ = {topic: self._publisher(topic) for topic in topics[2:]}
        self.x_hat_publisher = self.publishers_['x_hat']
        self.joint_states = None  # (encoder, publisher) of joint_states_hat, when configured
        if setup.joint_states is not None:
            self.joint_states = (JointStatesEncoder(setup.joint_states),
                                 self._publisher('joint_states_hat', JointState))
        self.odometry = setup.odometry and OdometryPublisher(self.node, setup.odometry)
        self.limits = {topic: system.topics[topic].limit for topic in topics}
        # Measurement sources (observer.sources), each on its topic; else y with every output.
        self.sources = source_codecs(system)
        self.source_drops = {name: Counter() for name in self.sources}
        for name, (topic, codec) in self.sources.items():
            node.topic_subscription(codec.message_class, topic, partial(self.on_source, name))
        if not self.sources:
            node.topic_subscription(self.codecs['y'].message_class, 'y', self.on_measurement)
        if inputs:
            node.topic_subscription(self.codecs['u'].message_class, 'u', self.on_input)
        node.create_service(Trigger, '~/reset', self._on_reset)
        self.input_wait_ns = setup.input_wait_ns
        #: observer.unstamped_input: next_measurement holds an unstamped u for the next y.
        self.hold_unstamped = setup.unstamped_input == 'next_measurement'
        self.wait_timer = node.create_timer(  # the steady clock is time.monotonic_ns's
            max(self.input_wait_ns, 1) / NANOSECONDS, self._on_wait_expired,
            clock=Clock(clock_type=ClockType.STEADY_TIME))
        self._clock_floor = (0, 0)
        self.wait_timer.cancel()
        self._waiting_for = None
        monitors = {'y': monitor(system, 'y', 0.0)} if not self.sources else {
            name: monitor(system, name, 0.0, rated=False) for name in self.sources}
        if inputs:
            monitors['u'] = monitor(system, 'u', 0.0, minimum_only=True)
        self.health = NodeHealth(node, monitors, self.counters, estimator=True,
                                 extra=self._sources_check if setup.keeps_history else None)
        rate = setup.publish_rate
        self.prediction_timer = (node.create_timer(1.0 / rate, self._on_prediction_time)
                                 if rate else None)
        self._last_published_ns = -1
        design = setup.design
        node.get_logger().info(
            f'{design.kind} observer of order {design.order}, poles '
            f'{[complex(p) for p in design.achieved_poles]}'
            + (' (designed again for each new sample interval)'
               if setup.designs_per_interval else ''))

    def _publisher(self, topic: str, message_class: Optional[type] = None):
        """Make the publisher of ``topic``; a secondary one keeps :attr:`listened` current."""
        message_class = message_class or self.codecs[topic].message_class
        if topic in self.primary:
            self.listened[topic] = True
            return self.node.topic_publisher(message_class, topic)
        publisher = self.node.topic_publisher(
            message_class, topic, matched=partial(self._on_matched, topic))
        self.listened.setdefault(topic, None)  # None: ask the count once
        return publisher

    def _on_matched(self, topic: str, status) -> None:
        """Note a subscription matched or gone: ``topic`` is published while one is there."""
        self.listened[topic] = status.current_count > 0

    def _listened(self, topic: str) -> bool:
        """Whether ``topic`` has a subscriber (asked once, when no matched event came yet)."""
        listened = self.listened.get(topic)
        if listened is None:
            publisher = (self.joint_states[1] if topic == 'joint_states_hat'
                         else self.publishers_[topic])
            listened = self.listened[topic] = publisher.get_subscription_count() > 0
        return listened

    def _design_expected_interval(self, system) -> None:
        """Make the design of the expected sample interval now, not at the second sample."""
        estimator = self.stream.estimator
        if not isinstance(estimator, IntervalDesigns):
            return
        period_ns = rate_to_period_ns(system.sample_rate_hz)
        try:
            estimator.intervals.peek(period_ns)
        except ObserverRosError as e:
            self.node.get_logger().warning(
                f'no design for the expected sample interval ({period_ns} ns, from '
                f'diagnostics.expected_rate or the plant rate): {e}')

    def pause(self) -> None:
        """Deactivation: stop the timers; the estimator restarts at the next activation."""
        self.wait_timer.cancel()
        self._waiting_for = None
        if self.prediction_timer is not None:
            self.prediction_timer.cancel()
        self.stream.reset(keep_inputs=False)  # inputs of before would pair with new samples
        self._last_published_ns = -1

    def resume(self) -> None:
        """Activation: predictions (``observer.publish_rate``) start again."""
        if self.prediction_timer is not None:
            self.prediction_timer.reset()

    def counters(self) -> Counter:
        """Stream and node counters together."""
        return self.stream.counters + self.node_counters

    def vet(self, system) -> None:
        """Refuse configurations without an observer, or whose sampled steps fail."""
        system.required_observer('the observer node')
        stream = getattr(self, 'stream', None)
        if stream is None:
            return
        # Design the new observer now for the intervals in use, so that a change the
        # sampled design cannot take is refused here instead of failing on a sample.
        intervals = stream.estimator.recent_intervals()
        try:
            system.observer.make_estimator().try_intervals(intervals)
        except STEP_ERRORS as e:
            raise ConfigError(system.observer.design_source, f'the observer cannot be sampled '
                              f'at the running intervals ({[dt / 1e9 for dt in intervals]} '
                              f's): {e}') from e

    def apply(self, previous, system) -> None:
        """Switch gains without touching the estimate (no jump in x_hat)."""
        estimator, setup = self.stream.estimator, system.observer
        estimator.adopt(setup.make_estimator())
        self.health.restart_nis()
        estimator.initial_state = setup.initial_state
        self.stream.clock_tolerance_ns = setup.clock_tolerance_ns

    def _now_ns(self) -> int:
        now = self.node.get_clock().now().nanoseconds
        self._clock_floor = (now, time.monotonic_ns())
        return now

    def _clock_for(self, stamp_ns: int) -> Optional[int]:
        """
        Return a node-clock reading good enough to judge ``stamp_ns`` against the tolerance.

        Reading the clock costs more than the rest of an update, so a reading at most
        :data:`CLOCK_REUSE_NS` old is used while the stamp is within the tolerance of it:
        the clock has only moved on since, so the stamp is within the tolerance of now too.
        Otherwise the clock is read again (a backward ``/clock`` jump is seen within that
        time).
        """
        tolerance = self.stream.clock_tolerance_ns
        if not tolerance:
            return None  # the check is off
        floor, taken = self._clock_floor
        if (stamp_ns - floor <= tolerance
                and time.monotonic_ns() - taken < CLOCK_REUSE_NS):
            return floor
        return self._now_ns()

    def _decode(self, topic: str, message, codec=None, on_arrival: bool = True):
        """
        Decode a message: ``(stamp, values, stamp given)``; ``(None, None, None)`` if malformed.

        A zero stamp (``None``) is replaced by the arrival time when ``on_arrival``.
        """
        codec = codec or self.codecs[topic]
        try:
            stamp, vector = codec.decode_values(message)
        except MalformedMessage as e:
            self._malformed(topic, e)
            return None, None, None
        given = stamp
        if stamp is None and on_arrival:
            stamp = self._arrival_stamp(topic, codec)
        return stamp, vector, given

    def _malformed(self, topic: str, error: MalformedMessage) -> None:
        """Count and report (once) a malformed message on ``topic``."""
        self.node_counters['malformed'] += 1
        if topic in self.source_drops:
            self.source_drops[topic]['malformed'] += 1
        self.node.warn_once(f'malformed {topic}', f'dropped a malformed message: {error}')

    def _arrival_stamp(self, topic: str, codec) -> int:
        """Return the stamp of a message with a zero stamp: its arrival on the node clock."""
        if codec.stamped:
            self.node.warn_once(f'zero stamp {topic}',
                                f'{topic}: messages with a zero stamp are stamped on arrival')
        return self._now_ns()

    def _tick(self, topic: str, stamp) -> None:
        """Count a message in the health of its topic (after the answer is out)."""
        if topic in self.health.monitors:
            self.health.tick(topic, stamp)

    def on_measurement(self, message) -> None:
        """
        Take a ``y``: the estimate out first, then the bookkeeping.

        The node's busiest message: :meth:`_decode` and :meth:`run` are written out here,
        then :meth:`_answered` (the same steps in the same order, fewer calls).
        """
        try:
            stamp, y = self._decode_y(message)
        except MalformedMessage as e:
            self._malformed('y', e)
            return
        given = stamp
        if stamp is None:
            stamp = self._arrival_stamp('y', self.codecs['y'])
        if self.hooks is not None:
            self.hooks.measured(stamp, y)
        stream = self.stream
        try:
            samples = stream.add_measurement(stamp, y, self._clock_for(stamp),
                                             time.monotonic_ns())
        except STEP_ERRORS as e:
            samples = self._step_failed(e)
        self._answered(samples, 'y', given)

    def on_source(self, name: str, message) -> None:
        """Take a message of the measurement source ``name``."""
        topic, codec = self.sources[name]
        stamp, y, given = self._decode(name, message, codec)
        if y is not None:
            noise = getattr(self.stream.estimator, 'message_noise', None)  # noise: message
            if noise is not None:
                noise.take(name, stamp, message)
            self.run(self.stream.add_measurement, stamp, y, self._clock_for(stamp),
                     time.monotonic_ns(), name)
            self._tick(name, given)

    def _sources_check(self, now_ns: int) -> list:
        """Return the ``sources`` check: per source counts, age, re-runs and the history in use."""
        report = self.stream.source_report(self.node.get_clock().now().nanoseconds)
        return [sources_check(report, self.source_drops, self.stream.engine.history_depth())]

    def on_input(self, message) -> None:
        """
        Take a ``u`` (the estimates it releases are published).

        The steps of :meth:`_decode` and :meth:`run` written out, then :meth:`_answered`,
        as for ``y``.
        """
        try:
            stamp, u = self._decode_u(message)
        except MalformedMessage as e:
            self._malformed('u', e)
            return
        given = stamp
        if stamp is None and not self.hold_unstamped:
            stamp = self._arrival_stamp('u', self.codecs['u'])
        stream = self.stream
        try:
            if stamp is None:  # observer.unstamped_input: next_measurement
                samples = stream.hold_input(u, self._now_ns())
            else:
                samples = stream.add_input(stamp, u, self._clock_for(stamp))
        except STEP_ERRORS as e:
            samples = self._step_failed(e)
        self._answered(samples, 'u', given)

    def _on_wait_expired(self) -> None:
        self.wait_timer.cancel()
        self._waiting_for = None
        self.run(self.stream.flush, True)

    def run(self, call, *args) -> None:
        """Make one stream call and publish what it produced; a failing step drops a sample."""
        try:
            samples = call(*args)
        except STEP_ERRORS as e:
            samples = self._step_failed(e)
        self._answered(samples)

    def _answered(self, samples: list, topic: Optional[str] = None, given=None) -> None:
        """
        Publish what a stream call produced; then arm the input wait and count ``topic``.

        What follows every stream call, the answer first: the estimates published (or the
        stream's events warned), the wait for a late input armed or cancelled, and the
        message counted in its topic's health (``given``: its stamp as received).
        """
        stream = self.stream
        if samples:
            self.publish(samples)
        elif stream.events:
            self._warn_events()
        if self._waiting_for is not None or stream.waiting() is not None:
            self._arm_wait_timer()
        if topic is not None:
            health = self.health
            if topic in health.monitors:
                health.tick(topic, given)

    def _step_failed(self, error: Exception) -> list:
        """Count and report a failed step; the estimator restarts. Returns no estimates."""
        self.node_counters['step_failed'] += 1
        self.node.warn_once('step failed', f'dropped a measurement: the observer step for '
                            f'its interval failed ({error}); the estimator restarts')
        self.stream.estimator.restart()
        return []

    def _arm_wait_timer(self) -> None:
        """Let the first waiting measurement wait ``observer.input_wait`` from its arrival."""
        waiting = self.stream.waiting()
        if waiting is None:
            if self._waiting_for is not None:
                self.wait_timer.cancel()
                self._waiting_for = None
            return
        sequence, arrival = waiting
        if sequence == self._waiting_for:
            return
        remaining = arrival + self.input_wait_ns - time.monotonic_ns()
        if remaining <= 0:
            self._on_wait_expired()
            return
        self._waiting_for = sequence
        self.wait_timer.cancel()
        self.wait_timer.timer_period_ns = remaining
        self.wait_timer.reset()

    def publish(self, samples) -> None:
        """
        Publish the estimates ``samples``: the answer first, then what can wait.

        With hooks, the command of each estimate goes out before ``x_hat`` (a plant waits
        for it); ``x_hat`` is published when it is the node's answer or has a subscriber.
        """
        hooks = self.hooks
        state = hooks.estimated(samples) if hooks is not None else None
        if 'x_hat' in self.primary or self.listened['x_hat'] or self._listened('x_hat'):
            publish, encode = self.x_hat_publisher.publish, self.x_hat_codec.encode
            for sample in samples:  # x_hat first: a controller waits for it
                publish(encode(sample.stamp_ns, sample.estimate))
        if self.odometry:  # outputs.odometry: the robot stack's answer (and /tf)
            for sample in samples:
                self.odometry.publish(sample)
        self._publish_rest(samples)
        if hooks is not None:
            hooks.published(state)

    def _publish_rest(self, samples) -> None:
        """Publish what follows x_hat: events, joint states, innovation, covariances, NIS."""
        if self.joint_states is not None and self._listened('joint_states_hat'):
            for sample in samples:
                self._publish_joint_states(sample.stamp_ns, sample.estimate)
        if self.stream.events:
            self._warn_events()
        listened = self.listened
        for sample in samples:
            stamp = sample.stamp_ns
            self._last_published_ns = max(self._last_published_ns, stamp)
            # An update with some of the outputs has no p-vector innovation to publish.
            whole = getattr(sample, 'outputs', None) is None
            if whole:
                if listened['innovation'] is not False:  # False: nobody subscribes
                    self._publish_on('innovation', stamp, sample.innovation)
                self.health.sample(sample.innovation, sample.nis, sample.covariance)
            if sample.covariance is not None:
                self._publish_on('x_hat_covariance', stamp, sample.covariance)
            if whole and sample.innovation_covariance is not None:
                self._publish_on('innovation_covariance', stamp, sample.innovation_covariance)
                self._publish_on('nis', stamp, (sample.nis,))
        if self.hooks is None or self.hooks.prepares_after_publish:
            self.stream.prepare()  # the next step's known part, now that x_hat is out

    def _warn_events(self) -> None:
        """Warn (once per kind) of the stream's events and clear them."""
        events = self.stream.events
        for kind, text in events:
            self.node.warn_once(kind, text)
        events.clear()

    def _publish_joint_states(self, stamp: int, estimate) -> None:
        """Publish ``joint_states_hat`` of an estimate just published on ``x_hat``."""
        encoder, publisher = self.joint_states
        publisher.publish(encoder.encode(stamp, estimate))

    def _publish_on(self, topic: str, stamp: int, values) -> None:
        """Publish ``values`` on one of the estimate's topics, if it has one and a subscriber."""
        if topic not in self.publishers_ or not self._listened(topic):
            return
        values = np.ravel(np.asarray(values, dtype=float))
        if not within_limit(values, self.limits[topic]):
            self.node_counters['out_of_range'] += 1
            self.node.warn_once(f'{topic} out of range', f'{topic} not published: a value is '
                                f'beyond topics.{topic}.limit = {self.limits[topic]:g}')
            return
        self.publishers_[topic].publish(self.codecs[topic].encode(stamp, values))

    def _on_prediction_time(self) -> None:
        """``observer.publish_rate``: the estimate predicted to now, stamped now."""
        now = self.node.get_clock().now().nanoseconds
        stream = self.stream
        if stream.estimator.stamp_ns is None or now <= self._last_published_ns:
            return
        prediction = stream.predict(now)
        if not within_limit(prediction.estimate, self.limits['x_hat']):
            self.node_counters['out_of_range'] += 1
            return
        self.x_hat_publisher.publish(self.x_hat_codec.encode(now, prediction.estimate))
        if self.joint_states is not None and self._listened('joint_states_hat'):
            self._publish_joint_states(now, prediction.estimate)
        if prediction.covariance is not None:
            self._publish_on('x_hat_covariance', now, prediction.covariance)
        self.node_counters['predictions'] += 1
        self._last_published_ns = now

    def _on_reset(self, request, response):
        self.stream.reset()
        self.node_counters['resets'] += 1
        self._arm_wait_timer()
        response.success = True
        response.message = 'estimator restarted from observer.initial_state'
        return response


class ObserverWiring:
    """
    The observer's wiring: its observer part, whose ``x_hat`` is the node's answer.

    :class:`ObserverNode` builds it in its constructor, the managed variant
    (made from its spec by :func:`observer_ros.nodes.main.managed_class`) on ``configure``.
    The part's state is reachable from the node (``node.stream``, ``node.codecs``...).
    """

    #: The attributes :meth:`build` sets (a managed node drops them on cleanup).
    PARTS = ('observer_part', 'health', 'diagnostics')

    def build(self, system) -> None:
        """Make the observer part (estimator, topics, timers, ``~/reset``) and the health."""
        self.observer_part = part = ObserverPart(self)
        part.build(system)
        self.health = part.health
        self.diagnostics = part.health.publisher

    def vet_system(self, system) -> None:
        """Refuse configurations without an observer, or whose sampled steps fail."""
        (self.__dict__.get('observer_part') or ObserverPart(self)).vet(system)

    def apply_system(self, previous, system) -> None:
        """Switch gains without touching the estimate (no jump in x_hat)."""
        self.observer_part.apply(previous, system)

    def pause(self) -> None:
        """Deactivation: stop the timers; the estimator restarts at the next activation."""
        self.observer_part.pause()

    def resume(self) -> None:
        """Activation: predictions (``observer.publish_rate``) start again."""
        self.observer_part.resume()

    def counters(self) -> Counter:
        """Stream and node counters together."""
        return self.observer_part.counters()

    def subscribes_input(self, system) -> bool:
        """Whether ``u`` is subscribed (the running part's choice once built)."""
        part = self.__dict__.get('observer_part')
        if part is not None and getattr(part, 'inputs', None) is not None:
            return part.inputs
        return system.model.n_inputs > 0

    @property
    def stream(self):
        """The observer part's event stream."""
        return self.observer_part.stream

    @property
    def codecs(self) -> dict:
        """The observer part's codecs, by topic."""
        return self.observer_part.codecs

    @property
    def sources(self) -> dict:
        """The observer part's measurement sources: ``{name: (topic, codec)}``."""
        return self.observer_part.sources

    @property
    def source_drops(self) -> dict:
        """The observer part's drops per measurement source: ``{name: Counter}``."""
        return self.observer_part.source_drops

    @property
    def node_counters(self) -> Counter:
        """The observer part's own counts (malformed, out of range, predictions...)."""
        return self.observer_part.node_counters

    @property
    def publishers_(self) -> dict:
        """The observer part's publishers, by topic."""
        return self.observer_part.publishers_


class ObserverNode(ObserverWiring, ConfiguredNode):
    """The observer node, configured and running from its construction."""

    def __init__(self, node_name: str = 'observer', **kwargs) -> None:
        super().__init__(node_name, OBSERVER, **kwargs)
        self.build(self.system)
