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
The safety promises of the feedback watchdog and the plant simulator, over real DDS.

In-process nodes on both executors. A promise of the form "not before" is checked from the
outside on the steady clock (``time.monotonic``): from when the test published to when it
received. A bound of the form "at most this late" is checked where the node measures it
(the watchdog's wait from the estimate it accepted to the safe command it sent), since on a
loaded machine the test's own receiving can lag by tens of milliseconds either way, and it
allows on top the time the process waited for a CPU meanwhile (:func:`cpu_wait_ns`: about
none on a machine that is not overloaded). The promised bounds are the module constants
doc/guarantees.md cites.
"""

import re
import time

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.parameter_client import AsyncParameterClient
from rosgraph_msgs.msg import Clock as ClockMessage
from sensor_msgs.msg import JointState

from conftest import CONFIG_DIR
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.units import NANOSECONDS
from observer_ros.nodes.observer_controller import ObserverControllerNode
from observer_ros.nodes.plant_part import START_POLL
from observer_ros.nodes.plant_simulator import PlantSimulatorNode
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.executors import EXECUTORS, make_executor
from observer_ros.ros.messages import ns_to_stamp, stamp_to_ns
from ros_support import (
    cpu_wait_ns, logged_since, NodeProcess, overrides, PROCESS_START, ros_context)

SEED003 = CONFIG_DIR / 'seed003_full_order.yaml'

#: feedback.timeout of these tests.
TIMEOUT = 0.2
#: The promise (doc/guarantees.md): the first safe command within feedback.timeout plus
#: this many seconds after the last accepted estimate, plus the time the node's process
#: waited for a CPU meanwhile (none to speak of on a machine that is not overloaded).
WATCHDOG_MARGIN = 0.010
SAFE_COMMAND = [0.25]
SAFE_PERIOD = 0.05
ESTIMATE = [0.1, 0.2]
#: Period of the estimates and of the test's /clock.
STEP = 0.01
#: Seconds to wait for a message within one process (bounded waits cost nothing when it
#: comes; on a loaded machine the test's own receiving lags).
DELIVERY = 5.0


def stamp_of(message) -> int:
    """Stamp of a JointState in nanoseconds."""
    return stamp_to_ns(message.header.stamp)


def spin_for(executor, seconds: float, each=None) -> None:
    """Spin for ``seconds``; call ``each()`` every :data:`STEP` seconds meanwhile."""
    deadline = time.monotonic() + seconds
    next_step = time.monotonic()
    while time.monotonic() < deadline:
        if each is not None and time.monotonic() >= next_step:
            each()
            next_step += STEP
        executor.spin_once(timeout_sec=0.002)


def spin_until(executor, predicate, timeout: float, each=None) -> bool:
    """Spin until ``predicate()`` or ``timeout`` seconds; ``each`` as in :func:`spin_for`."""
    deadline = time.monotonic() + timeout
    next_step = time.monotonic()
    while not predicate():
        now = time.monotonic()
        if now > deadline:
            return False
        if each is not None and now >= next_step:
            each()
            next_step += STEP
        executor.spin_once(timeout_sec=0.002)
    return True


class FeedbackBench:
    """
    A state_feedback node and a test node feeding it x_hat (and /clock with sim time).

    ``controller``: an observer_controller fed ``u`` and ``y`` instead, whose estimates
    the watchdog waits for.
    """

    def __init__(self, context, executor: str, sim_time: bool = False,
                 controller: bool = False, **values) -> None:
        settings = dict(feedback__timeout=TIMEOUT, feedback__safe_command=SAFE_COMMAND,
                        feedback__safe_command_period=SAFE_PERIOD, **values)
        extra = overrides(**settings)
        if sim_time:
            extra.append(Parameter('use_sim_time', value=True))
        node_class = ObserverControllerNode if controller else StateFeedbackNode
        self.feedback = node_class(context=context, parameter_overrides=extra)
        self.node = Node('bench', context=context)
        self.controller = controller
        self.x_hat = self.node.create_publisher(JointState, 'y' if controller else 'x_hat', 10)
        self.u = self.node.create_publisher(JointState, 'u', 10)
        self.reference = self.node.create_publisher(JointState, 'reference', 10)
        self.clock = self.node.create_publisher(ClockMessage, '/clock', 10)
        self.commands = []  # (monotonic receive time, stamp ns, values)
        # The node's own account of each safe command, recorded as it sends: [steady ns when
        # sent, steady ns when the last estimate was accepted, cpu_wait_ns() then, outages
        # so far (the stale counter), the stamp it got].
        self.safe_sent = []
        feedback = self.feedback.feedback_part  # the node's feedback part
        send, publish = feedback.send_safe_command, feedback.publisher.publish

        def recorded_send():
            self.safe_sent.append([time.monotonic_ns(), feedback.last_estimate_ns,
                                   cpu_wait_ns(), feedback.command_counters['stale'], None])
            send()

        def recorded_publish(raw):
            if self.safe_sent and self.safe_sent[-1][4] is None:
                self.safe_sent[-1][4] = feedback.feedback_codecs['u_cmd'].decode(raw)[0]
            publish(raw)
        feedback.send_safe_command = recorded_send
        feedback.publisher.publish = recorded_publish
        # The last estimate published: monotonic time, cpu_wait_ns() just before.
        self.published_at, self.cpu_wait_at = None, 0
        self.command_subscription = self.node.create_subscription(
            JointState, 'u_cmd', lambda m: self.commands.append(
                (time.monotonic(), stamp_of(m), list(m.position))), 100)
        self.executor = make_executor(executor, context)
        for node in (self.feedback, self.node):
            self.executor.add_node(node)
        self.sim_ns = 100 * NANOSECONDS
        self.clock_running = sim_time
        self.stamp_ns = 50 * NANOSECONDS
        assert spin_until(self.executor, lambda: self.x_hat.get_subscription_count() > 0
                          and self.command_subscription.get_publisher_count() > 0
                          and (not sim_time or self.clock.get_subscription_count() > 0), 10.0)
        if sim_time:
            assert spin_until(self.executor, lambda: self.feedback.get_clock().now()
                              .nanoseconds > 0, 5.0, self.tick), 'no /clock at the node'

    def destroy(self) -> None:
        """Destroy the nodes and the executor."""
        for node in (self.feedback, self.node):
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()

    def tick(self) -> None:
        """Advance the test's /clock by one step (when it runs)."""
        if self.clock_running:
            self.sim_ns += round(STEP * NANOSECONDS)
            self.publish_clock()

    def publish_clock(self) -> None:
        """Publish the test's simulated time on /clock."""
        message = ClockMessage()
        ns_to_stamp(message.clock, self.sim_ns)
        self.clock.publish(message)

    def publish_estimate(self, values=ESTIMATE) -> int:
        """Publish one x_hat (the controller: u and y) with a new stamp; return the stamp."""
        self.stamp_ns += round(STEP * NANOSECONDS)
        message = JointState(name=['x1', 'x2'], position=[float(v) for v in values])
        ns_to_stamp(message.header.stamp, self.stamp_ns)
        if self.controller:
            message.name, message.position = ['y1'], [float(values[0])]
            applied = JointState(name=['u1'], position=[0.0])
            ns_to_stamp(applied.header.stamp, self.stamp_ns)
            self.u.publish(applied)
        self.cpu_wait_at = cpu_wait_ns()
        self.published_at = time.monotonic()
        self.x_hat.publish(message)
        return self.stamp_ns

    def received(self, stamp_ns: int) -> list:
        """Commands received with ``stamp_ns``."""
        return [command for command in self.commands if command[1] == stamp_ns]

    def run_estimates(self, count: int = 10) -> float:
        """Publish ``count`` estimates, one per step; return when the last one's command came."""
        stamp = None
        for _ in range(count):
            self.tick()
            stamp = self.publish_estimate()
            spin_for(self.executor, STEP)
        assert spin_until(self.executor, lambda: self.received(stamp), DELIVERY, self.tick), (
            'no command for the last estimate')
        return self.received(stamp)[0][0]

    def outage_delay(self, at_outage=None) -> tuple:
        """
        Run estimates, stop them; return the delays (s) to the first safe command.

        ``(received, sent, cpu wait)``: from the test's publishing of the last estimate to its
        receiving the safe command; the node's wait from accepting that estimate to sending
        it; how long the process waited for a CPU from that publishing to that sending.
        ``at_outage()`` runs right after the last estimate's command arrived.
        """
        feedback = self.feedback.feedback_part
        stale = feedback.command_counters['stale']
        self.run_estimates()
        published, cpu_wait = self.published_at, self.cpu_wait_at
        if at_outage is not None:
            at_outage()
        assert spin_until(self.executor, lambda: feedback.command_counters['stale'] > stale,
                          TIMEOUT + DELIVERY, self.tick), 'no outage after the last estimate'
        # The outage's first safe command, sent on going stale; the one outage came after the
        # last estimate, none while they came every STEP.
        sent_ns, accepted_ns, cpu_wait_then, _, stamp = next(
            sent for sent in self.safe_sent if sent[3] == stale + 1)
        assert feedback.command_counters['stale'] == stale + 1 and (
            accepted_ns == feedback.last_estimate_ns), 'an outage while estimates were arriving'
        assert spin_until(self.executor, lambda: self.received(stamp), DELIVERY, self.tick), (
            'the safe command never arrived')
        self.first_safe = self.received(stamp)[0]
        return (self.first_safe[0] - published, (sent_ns - accepted_ns) / NANOSECONDS,
                max(0, cpu_wait_then - cpu_wait) / NANOSECONDS)

    def safe_stamps_after(self, first_stamp: int, seconds: float) -> tuple:
        """
        Stamps of the safe commands sent in ``seconds`` of node clock from ``first_stamp``.

        Waits (bounded) until a command stamped after that window has been received. Returns
        the stamps and how long the process waited for a CPU meanwhile (s): a repeat due
        while the node waits longer than a period is skipped, not sent twice.
        """
        end = first_stamp + round(seconds * NANOSECONDS)
        before = cpu_wait_ns()
        assert spin_until(self.executor, lambda: any(
            c[1] >= end for c in self.commands), seconds + 5.0), 'the repeats stopped'
        window = [c for c in self.commands if first_stamp <= c[1] < end]
        assert all(c[2] == SAFE_COMMAND for c in window), window
        return [c[1] for c in window], max(0, cpu_wait_ns() - before) / NANOSECONDS


@pytest.fixture
def bench_factory():
    """Yield a function building a :class:`FeedbackBench` in a private context."""
    made = []

    def build(executor, sim_time=False, controller=False, **values):
        context_manager = ros_context('--params-file', str(SEED003))
        context = context_manager.__enter__()
        made.append(context_manager)
        bench = FeedbackBench(context, executor, sim_time, controller, **values)
        made.append(bench)
        return bench

    yield build
    for item in reversed(made):
        if isinstance(item, FeedbackBench):
            item.destroy()
        else:
            item.__exit__(None, None, None)


def assert_within_promise(delays, timeout: float = TIMEOUT) -> None:
    """
    Check the delays of :meth:`FeedbackBench.outage_delay`.

    None early as the test saw it or as the node measured it; each within the promise as the
    node measured it, plus the time its process waited for a CPU meanwhile.
    """
    text = ', '.join(f'{1e3 * r:.1f} ms (sent after {1e3 * s:.1f} ms, {1e3 * w:.1f} ms of it '
                     f'waiting for a CPU)' for r, s, w in delays)
    for received, sent, waited in delays:
        assert received >= timeout and sent >= timeout, text
        assert sent <= timeout + WATCHDOG_MARGIN + waited, text


@pytest.mark.parametrize('controller', [False, True],
                         ids=['state_feedback', 'observer_controller'])
@pytest.mark.parametrize('executor', EXECUTORS)
def test_first_safe_command_within_the_promised_bound_then_repeated(
        bench_factory, executor, controller):
    # The observer-controller's watchdog waits for its own estimates (y stops).
    bench = bench_factory(executor, controller=controller)
    delays, repeats = [], []
    for _ in range(5):
        delays.append(bench.outage_delay())
        # Repeated every feedback.safe_command_period while the outage lasts: 10 in 10
        # periods of the node clock that stamps them (a repeat due while the node waits for
        # a CPU longer than a period is skipped, not sent twice).
        repeats.append(bench.safe_stamps_after(bench.first_safe[1], 10 * SAFE_PERIOD))
    assert_within_promise(delays)
    for stamps, waited in repeats:
        assert 8 - int(waited / SAFE_PERIOD) <= len(stamps) <= 11, (stamps, waited)
    assert bench.feedback.feedback_part.command_counters['stale'] == 5
    # x_hat back: the commands resume at once and the repeats stop.
    count = len(bench.commands)
    bench.run_estimates(count=3)
    assert not bench.feedback.feedback_part.stale
    spin_for(bench.executor, 3 * SAFE_PERIOD)
    late = [c for c in bench.commands[count:] if c[2] == SAFE_COMMAND]
    assert len(late) <= 1, late  # at most one repeat already on its way


def test_run_time_timeout_and_repeat_period_take_effect(bench_factory):
    bench = bench_factory('events')
    client = AsyncParameterClient(bench.node, 'state_feedback')
    assert client.wait_for_services(timeout_sec=5.0)
    future = client.set_parameters_atomically(overrides(
        feedback__timeout=TIMEOUT / 2, feedback__safe_command_period=SAFE_PERIOD / 2))
    assert spin_until(bench.executor, future.done, 5.0)
    assert future.result().result.successful, future.result().result.reason
    delays = [bench.outage_delay() for _ in range(3)]
    assert_within_promise(delays, TIMEOUT / 2)
    stamps, waited = bench.safe_stamps_after(bench.first_safe[1], 10 * SAFE_PERIOD)
    assert 16 - int(waited / (SAFE_PERIOD / 2)) <= len(stamps) <= 21, (stamps, waited)


@pytest.mark.parametrize('executor', EXECUTORS)
def test_sim_time_clock_jump_back_does_not_delay_the_safe_command(bench_factory, executor):
    bench = bench_factory(executor, sim_time=True)

    def jump_back():
        bench.sim_ns -= 11 * NANOSECONDS
        bench.publish_clock()

    delays = [bench.outage_delay(jump_back) for _ in range(3)]
    assert_within_promise(delays)
    # Stamped with the node clock, which went back.
    safe = [c for c in bench.commands if c[2] == SAFE_COMMAND][-1]
    assert safe[1] < 100 * NANOSECONDS


@pytest.mark.parametrize('executor', EXECUTORS)
def test_sim_time_clock_stop_still_gives_the_safe_command(bench_factory, executor):
    bench = bench_factory(executor, sim_time=True)
    frozen = []

    def stop_clock():
        bench.clock_running = False
        frozen.append(bench.sim_ns)

    delays = []
    for _ in range(3):
        delays.append(bench.outage_delay(stop_clock))
        bench.clock_running = True
    assert_within_promise(delays)
    # The safe command carries the node clock: the last /clock before it stopped.
    safe = [c for c in bench.commands if c[2] == SAFE_COMMAND]
    assert frozen[-1] in {c[1] for c in safe}
    # The next estimate resumes the feedback, stamped like the estimate.
    bench.clock_running = True
    stamp = bench.publish_estimate()
    assert spin_until(bench.executor, lambda: bench.received(stamp), 2.0, bench.tick)
    assert bench.received(stamp)[0][2] != SAFE_COMMAND
    assert not bench.feedback.feedback_part.stale


@pytest.mark.parametrize('executor', EXECUTORS)
def test_no_non_finite_command_is_ever_published(bench_factory, executor):
    # A gain of 1e12 (allowed, and A - B K stable) turns a huge but valid estimate into an
    # infinite or NaN command, and a plain one into a command beyond topics.u_cmd.limit.
    bench = bench_factory(executor, feedback__poles=[], feedback__gain=[1e12, 1e12],
                          topics__x_hat__limit=1e300, topics__u_cmd__limit=100.0)
    gain = np.array([[1e12, 1e12]])
    cases = {'infinite': [1e300, 1e300], 'nan': [1e300, -1e300], 'beyond limit': [1.0, 0.0],
             'fine': [1e-11, 2e-11]}
    stamps = {name: bench.publish_estimate(values) for name, values in cases.items()}
    assert spin_until(bench.executor, lambda: all(bench.received(s) for s in stamps.values()),
                      5.0)
    values = np.array([c[2] for c in bench.commands])
    assert np.all(np.isfinite(values)) and np.abs(values).max() <= 100.0
    for name in ('infinite', 'nan', 'beyond limit'):  # stamped like their estimates
        assert bench.received(stamps[name])[0][2] == SAFE_COMMAND, name
    np.testing.assert_allclose(bench.received(stamps['fine'])[0][2],
                               -gain @ cases['fine'], rtol=1e-12)
    assert bench.feedback.counters['unsafe_command'] == 3
    assert bench.feedback.counters['commands'] == 4


@pytest.mark.parametrize('executor', EXECUTORS)
def test_estimates_and_references_beyond_their_limits_are_dropped(bench_factory, executor):
    bench = bench_factory(executor, topics__x_hat__limit=1e3, topics__reference__limit=10.0,
                          topics__u_cmd__limit=100.0)
    gain = bench.feedback.feedback_part.law.gain
    beyond = bench.publish_estimate([1e4, 0.0])
    bench.reference.publish(JointState(name=['y1'], position=[100.0]))
    assert spin_until(bench.executor, lambda: bench.feedback.counters['out_of_range'] == 2,
                      5.0)
    assert bench.feedback.feedback_part.reference is None
    big, fine = bench.publish_estimate([10.0, 0.0]), bench.publish_estimate([1.0, 0.0])
    assert spin_until(bench.executor, lambda: bench.received(big) and bench.received(fine),
                      5.0)
    assert not bench.received(beyond)
    assert bench.received(big)[0][2] == SAFE_COMMAND  # -K x = -103.3: beyond the limit
    np.testing.assert_allclose(bench.received(fine)[0][2], -gain @ [1.0, 0.0], rtol=1e-12)
    assert bench.feedback.counters['unsafe_command'] == 1


def test_feedback_safety_parameters_are_validated():
    params = load_parameter_file(str(SEED003))
    for name, value, reason in (
            ('feedback.safe_command_period', 0.0, 'feedback.safe_command_period: expected'),
            ('feedback.safe_command', [200.0], 'feedback.safe_command: [200.0] lies outside '
             'topics.u_cmd.limit'),
            ('plant.command_timeout', 0.01, 'plant.command_timeout: expected more than one '
             'sample period'),
            ('plant.safe_input', [2.0], 'plant.safe_input: [2.0] lies outside '
             'plant.input_limits'),
            ('plant.start_timeout', -1.0, 'plant.start_timeout: expected seconds')):
        changed = dict(params, **{name: value, 'topics.u_cmd.limit': 100.0,
                                  'plant.input_limits': [-1.0, 1.0]})
        with pytest.raises(ConfigError, match='^' + re.escape(reason)):
            validate_parameters(changed)


class PlantBench:
    """A plant_simulator node and a test node that can play its peers."""

    def __init__(self, context, executor: str, **values) -> None:
        self.plant = PlantSimulatorNode(context=context, parameter_overrides=overrides(**values))
        self.created = time.monotonic()
        self.node = Node('plant_bench', context=context)
        self.samples = {'y': [], 'u': [], 'x_true': []}  # (receive time, stamp, values)
        self.x_true = self.subscribe('x_true')
        self.executor = make_executor(executor, context)
        for node in (self.plant, self.node):
            self.executor.add_node(node)
        self.answer = None  # values to answer each y with on u_cmd, stamped like the y
        self.command_publisher = None

    def subscribe(self, topic: str):
        """Record ``topic`` (y answers with ``self.answer`` when set)."""
        def on_message(message):
            self.samples[topic].append((time.monotonic(), stamp_of(message),
                                        list(message.position)))
            if topic == 'y' and self.answer is not None:
                self.command(stamp_of(message), self.answer)
        return self.node.create_subscription(JointState, topic, on_message, 100)

    def command(self, stamp_ns: int, values) -> None:
        """Publish one u_cmd; remember when (and cpu_wait_ns() then)."""
        self.cpu_wait_at = cpu_wait_ns()
        self.last_command = time.monotonic()
        message = JointState(name=['u1'], position=[float(v) for v in values])
        ns_to_stamp(message.header.stamp, stamp_ns)
        self.command_publisher.publish(message)

    def be_the_loop(self) -> None:
        """Subscribe y and u and publish u_cmd, as observer and feedback would."""
        self.y = self.subscribe('y')
        self.u = self.subscribe('u')
        self.command_publisher = self.node.create_publisher(JointState, 'u_cmd', 10)

    def destroy(self) -> None:
        """Destroy the nodes and the executor."""
        for node in (self.plant, self.node):
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()


@pytest.fixture
def plant_factory():
    """Yield a function building a :class:`PlantBench` in a private context."""
    made = []

    def build(executor, **values):
        context_manager = ros_context('--params-file', str(SEED003))
        made.append(context_manager)
        bench = PlantBench(context_manager.__enter__(), executor, **values)
        made.append(bench)
        return bench

    yield build
    for item in reversed(made):
        if isinstance(item, PlantBench):
            item.destroy()
        else:
            item.__exit__(None, None, None)


COMMAND = [0.7]
SAFE_INPUT = [-0.3]
COMMAND_TIMEOUT = 0.1
PERIOD = 0.01
#: The promise (doc/guarantees.md): the safe input from the first sample after
#: plant.command_timeout, i.e. within the timeout plus one sample period plus this margin,
#: plus the time the plant's process waited for a CPU meanwhile.
PLANT_MARGIN = 0.010
#: The real-time plant's warning at an outage: how long it had been without a command.
PLANT_WARNING = r'^no u_cmd for ([0-9.]+) s \(plant\.command_timeout = 0\.5 s, steady clock'


def record_decisions(plant) -> list:
    """
    Record the plant part's choice at each sample as it makes it.

    ``(steady ns, steady ns of the latest command's arrival, a command applied,
    cpu_wait_ns())``.
    """
    decisions = []
    decide = plant._command_in_effect

    def recorded() -> tuple:
        result = decide()
        decisions.append((time.monotonic_ns(), plant.command_arrival_ns, result[1],
                          cpu_wait_ns()))
        return result
    plant._command_in_effect = recorded
    return decisions


@pytest.mark.parametrize('executor', EXECUTORS)
def test_plant_applies_the_safe_input_after_the_command_timeout_and_resumes(plant_factory,
                                                                            executor):
    bench = plant_factory(executor, plant__command_timeout=COMMAND_TIMEOUT,
                          plant__safe_input=SAFE_INPUT, topics__u_cmd__limit=10.0)
    bench.be_the_loop()
    decisions = record_decisions(bench.plant.plant_part)
    spin = bench.executor
    assert spin_until(spin, lambda: len(bench.samples['u']) >= 5, 10.0)
    # Before the first command: the safe input. A command beyond topics.u_cmd.limit: dropped.
    assert all(u[2] == SAFE_INPUT for u in bench.samples['u'])
    bench.command(0, [20.0])
    assert spin_until(spin, lambda: bench.plant.counters['out_of_range'] == 1, 5.0)
    delays, ages, waits = [], [], []
    for outage in range(3):
        bench.answer = COMMAND
        count = len(bench.samples['u'])
        assert spin_until(spin, lambda: len(bench.samples['u']) > count + 20, 5.0)
        applied = [u[2] for u in bench.samples['u'][count:]]
        assert applied[-15:] == [COMMAND] * 15, applied  # resumed with the next command
        bench.answer = None
        last, cpu_wait = bench.last_command, bench.cpu_wait_at
        count, decided = len(bench.samples['u']), len(decisions)
        assert spin_until(spin, lambda: any(
            u[2] == SAFE_INPUT for u in bench.samples['u'][count:]), 5.0), (
            'the plant kept applying the last command')
        first_safe = next(u for u in bench.samples['u'][count:] if u[2] == SAFE_INPUT)
        delays.append(first_safe[0] - last)
        now, arrival, _, cpu_wait_then = next(d for d in decisions[decided:] if not d[2])
        ages.append((now - arrival) / NANOSECONDS)
        waits.append(max(0, cpu_wait_then - cpu_wait) / NANOSECONDS)
        assert bench.plant.counters['command_timeouts'] == outage + 1
    text = ', '.join(f'{1e3 * d:.1f} ms (decided after {1e3 * a:.1f} ms, {1e3 * w:.1f} ms of '
                     f'it waiting for a CPU)' for d, a, w in zip(delays, ages, waits))
    assert min(delays) >= COMMAND_TIMEOUT and min(ages) > COMMAND_TIMEOUT, text
    assert all(age <= COMMAND_TIMEOUT + PERIOD + PLANT_MARGIN + waited
               for age, waited in zip(ages, waits)), text


def test_lockstep_plant_counts_the_command_timeout_in_simulated_time(plant_factory):
    # Commands for samples 0 ... 9, then none: every sample waits plant.lockstep_timeout and
    # advances; the command of sample 9 arrived at t_9 and is used while t_k - t_9 <= 0.02 s
    # (samples 10 and 11), then the safe input; answering again from sample 14 resumes it.
    # The wall-clock lockstep_timeout is long enough for an answer on a loaded machine.
    bench = plant_factory('single', plant__lockstep=True, plant__samples=20,
                          plant__lockstep_timeout=0.5, plant__command_timeout=0.02,
                          plant__safe_input=SAFE_INPUT)
    bench.be_the_loop()
    period_ns = bench.plant.period_ns

    def answer(message):
        index = stamp_of(message) // period_ns - 1
        if index < 10 or index >= 14:
            bench.command(stamp_of(message), [0.01 * index])
    bench.node.create_subscription(JointState, 'y', answer, 100)
    assert spin_until(bench.executor, bench.plant.finished.done, 30.0)
    spin_for(bench.executor, 0.1)
    applied = {stamp // period_ns - 1: values[0] for _, stamp, values in bench.samples['u']}
    assert sorted(applied) == list(range(20))
    expected = ([SAFE_INPUT[0]] + [0.01 * k for k in range(9)] + [0.09] * 2
                + [SAFE_INPUT[0]] * 3 + [0.01 * k for k in range(14, 19)])
    np.testing.assert_allclose([applied[k] for k in range(20)], expected, rtol=0, atol=1e-15)
    assert bench.plant.counters['command_timeouts'] == 1
    assert bench.plant.counters['lockstep_timeouts'] == 4


@pytest.mark.parametrize('executor', EXECUTORS)
def test_real_time_plant_publishes_nothing_before_its_peers(plant_factory, executor):
    bench = plant_factory(executor, plant__start_timeout=0.0)
    spin_for(bench.executor, 1.0)
    assert bench.plant.counters['samples'] == 0 and not bench.samples['x_true']
    assert not bench.plant.started
    assert len(bench.plant.missing_peers()) == 2
    bench.y = bench.subscribe('y')
    spin_for(bench.executor, 0.5)
    assert not bench.plant.started and not bench.samples['x_true']
    assert bench.plant.missing_peers() == [
        'a publisher on /u_cmd (plant.wait_for_command)']
    bench.command_publisher = bench.node.create_publisher(JointState, 'u_cmd', 10)
    assert spin_until(bench.executor, lambda: len(bench.samples['y']) >= 3, 5.0)
    # Sample 0 reached the subscriber: nothing was published into the void.
    assert bench.samples['y'][0][1] == bench.plant.start_ns
    assert bench.samples['x_true'][0][1] == bench.plant.start_ns
    assert bench.plant.counters.get('started_without_peers', 0) == 0


@pytest.mark.parametrize('settle', [0.4, 0.0])
def test_real_time_plant_waits_its_settle_time_after_the_peers_match(plant_factory, settle):
    # Discovery goes on after the first match (the other topics, the other direction); the
    # first sample waits plant.settle_time after the peers are there, and 0 starts at once.
    bench = plant_factory('events', plant__settle_time=settle)
    bench.y = bench.subscribe('y')
    bench.command_publisher = bench.node.create_publisher(JointState, 'u_cmd', 10)
    assert spin_until(bench.executor, lambda: not bench.plant.missing_peers(), 5.0)
    matched = time.monotonic()
    assert spin_until(bench.executor, lambda: bench.samples['y'], 5.0)
    waited = bench.samples['y'][0][0] - matched
    assert waited >= settle - START_POLL, waited
    if settle == 0.0:
        assert waited < 0.3, waited  # no settling: the next poll, on a loaded machine too
    assert bench.samples['y'][0][1] == bench.plant.start_ns


def test_plant_start_timeout_starts_anyway_with_a_warning(plant_factory):
    bench = plant_factory('events', plant__start_timeout=0.3)
    assert spin_until(bench.executor, lambda: bench.samples['x_true'], 5.0)
    first = bench.samples['x_true'][0][0]
    assert first - bench.created >= 0.3
    assert bench.plant.counters['started_without_peers'] == 1


def test_killed_feedback_process_leaves_the_plant_on_its_safe_input_until_restarted():
    # The three console-script processes in real time. The plant publishes nothing until the
    # observer and this test subscribe to y and state_feedback publishes u_cmd; when
    # state_feedback is killed it applies plant.safe_input after plant.command_timeout, and
    # the restarted node's commands take over again. A stable plant: seed 003's, on the safe
    # input alone, leaves topics.y.limit within seconds, before a restarted process is up on
    # a loaded machine, and then no estimate comes to take it back.
    path = str(CONFIG_DIR / 'seed001_fourth_order_chen.yaml')
    safe = '[0.123]'
    with ros_context() as context:
        listener = Node('listener', context=context)
        samples = {'u': [], 'x_true': []}
        subscriptions = {topic: listener.create_subscription(
            JointState, topic, lambda m, t=topic: samples[t].append(
                (time.monotonic(), list(m.position))), 1000) for topic in samples}
        listener.create_subscription(JointState, 'y', lambda m: None, 10)
        executor = make_executor('single', context)
        executor.add_node(listener)
        plant_args = ['--ros-args', '--params-file', path, '-p', 'plant.lockstep_subscribers:=2',
                      '-p', f'plant.safe_input:={safe}', '-p', 'plant.start_timeout:=0.0']
        processes = {'plant': NodeProcess('plant_simulator', *plant_args)}
        try:
            assert spin_until(executor, lambda: all(
                s.get_publisher_count() > 0 for s in subscriptions.values()), PROCESS_START)
            spin_for(executor, 1.0)
            assert not samples['x_true'], 'the plant started without its peers'
            for name in ('observer', 'state_feedback'):
                processes[name] = NodeProcess(name, '--ros-args', '--params-file', path)
            assert spin_until(executor, lambda: len(samples['u']) > 100 and all(
                u != [0.123] for _, u in samples['u'][-20:]), PROCESS_START), (
                samples['u'][-5:])
            running, plant = len(samples['u']), processes['plant'].process.pid
            cpu_wait, killed_wall = cpu_wait_ns(plant), time.time()
            killed = time.monotonic()
            processes['state_feedback'].process.kill()
            processes['state_feedback'].stop()
            assert spin_until(executor, lambda: samples['u'][-1][1] == [0.123], 5.0)
            waited = max(0, cpu_wait_ns(plant) - cpu_wait) / NANOSECONDS
            # The commands went on until the kill; when the safe input came the plant says
            # (its steady clock; the test's receiving lags on a loaded machine).
            assert [0.123] not in [u for t, u in samples['u'][running:] if t <= killed]
            processes['state_feedback'] = NodeProcess('state_feedback', '--ros-args',
                                                      '--params-file', path)
            assert spin_until(executor, lambda: samples['u'][-1][1] != [0.123],
                              PROCESS_START)
        finally:
            outcomes = {name: process.stop() for name, process in processes.items()}
            executor.remove_node(listener)
            listener.destroy_node()
            executor.shutdown()
    for name, (code, _, err) in outcomes.items():
        assert code == 0, (name, err)
    ages = [float(age) for age, in logged_since(outcomes['plant'][2], killed_wall,
                                                PLANT_WARNING)]
    # The warning rounds the age to 1 ms: 'no u_cmd for 0.500 s' is an age just above the
    # timeout (the plant's own test is age > timeout, in ns of its steady clock).
    assert ages and 0.5 <= ages[0] <= 0.5 + PERIOD + PLANT_MARGIN + waited, (ages, waited)
    assert 'u_cmd is back' in outcomes['plant'][2]
