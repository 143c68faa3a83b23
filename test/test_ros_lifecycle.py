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
The managed (lifecycle) observer and state feedback over DDS.

Transitions go through the nodes' ``change_state`` and ``get_state`` services from a client
node, as ``ros2 lifecycle set`` sends them; messages through real publishers and
subscriptions; configure errors are read from the node's log.
"""

from lifecycle_msgs.msg import Transition
from lifecycle_msgs.srv import ChangeState, GetState
import numpy as np
import pytest
from rclpy.lifecycle import TransitionCallbackReturn
from rclpy.node import Node
from sensor_msgs.msg import JointState

from conftest import CONFIG_DIR
from observer_ros.config import (
    CONTROLLER, FEEDBACK, node_parameters, OBSERVER, validate_parameters)
from observer_ros.config import load_parameter_file
from observer_ros.core.streaming import EventStream
from observer_ros.nodes.main import node_class
from observer_ros.nodes.plant_simulator import PlantSimulatorNode
from ros_support import (
    executor_with, NodeProcess, overrides, PROCESS_START, ros_context, spin_until)
from test_ros_nodes import (
    Driver, joint_state, PERIOD_NS, plant_samples, SEED003, set_parameters, START_NS)

ObserverLifecycleNode = node_class('observer_lifecycle')
StateFeedbackLifecycleNode = node_class('state_feedback_lifecycle')
ObserverControllerLifecycleNode = node_class('observer_controller_lifecycle')

TRANSITIONS = {'configure': Transition.TRANSITION_CONFIGURE,
               'activate': Transition.TRANSITION_ACTIVATE,
               'deactivate': Transition.TRANSITION_DEACTIVATE,
               'cleanup': Transition.TRANSITION_CLEANUP,
               'shutdown': Transition.TRANSITION_INACTIVE_SHUTDOWN,
               'shutdown from active': Transition.TRANSITION_ACTIVE_SHUTDOWN}

#: seed 003 switched to a steady-state Kalman filter (a structural change).
KALMAN = {'observer__type': 'kalman', 'observer__poles': [],
          'observer__process_noise': [0.0, 0.04], 'observer__measurement_noise': [0.0001]}


class Lifecycle:
    """A client of one node's lifecycle services, like ``ros2 lifecycle``."""

    def __init__(self, client_node, executor, node_name: str, timeout: float = 5.0) -> None:
        self.executor = executor
        self.change_client = client_node.create_client(ChangeState, f'{node_name}/change_state')
        self.get = client_node.create_client(GetState, f'{node_name}/get_state')
        assert self.change_client.wait_for_service(timeout_sec=timeout)
        assert self.get.wait_for_service(timeout_sec=timeout)

    def _call(self, client, request):
        future = client.call_async(request)
        self.executor.spin_until_future_complete(future, timeout_sec=5.0)
        assert future.done(), f'{client.srv_name} gave no answer'
        return future.result()

    def change(self, transition: str) -> bool:
        """Request a transition (``ros2 lifecycle set <node> <transition>``); its success."""
        request = ChangeState.Request()
        request.transition.id = TRANSITIONS[transition]
        return self._call(self.change_client, request).success

    def state(self) -> str:
        """Return the node's state label (``ros2 lifecycle get <node>``)."""
        return self._call(self.get, GetState.Request()).current_state.label


def drive(driver, executor, node, samples, expect_estimates):
    """Publish ``u`` and ``y`` of each sample; wait for estimates or for the node's drops."""
    dropped = node.dropped_while_inactive
    for index, (stamp, u, y) in enumerate(samples):
        driver.u.publish(joint_state(stamp, ['u1'], u))
        driver.y.publish(joint_state(stamp, ['y1'], y))
        if expect_estimates is None:  # inactive: both messages arrive and are dropped
            assert spin_until(executor, lambda: node.dropped_while_inactive >= dropped + 2 * (
                index + 1), 5.0), 'the inactive node never received the messages'
        else:
            assert spin_until(executor, lambda: len(driver.estimates) >= expect_estimates
                              + index + 1, 5.0), f'no estimate for sample {index}'


def expected_estimates(system, samples):
    """Run a fresh estimator over ``samples`` (what a freshly started observer publishes)."""
    stream = EventStream(system.observer.make_estimator(), 10**9)
    estimates = []
    for stamp, u, y in samples:
        stream.add_input(stamp, u)
        estimates += [sample.estimate.copy() for sample in stream.add_measurement(stamp, y)]
    return np.array(estimates)


def own_entities(node) -> set:
    """Topic and service names of the node's publishers, subscriptions and services."""
    return ({p.topic_name for p in node.publishers} | {s.topic_name for s in node.subscriptions}
            | {s.srv_name for s in node.services})


def test_only_the_managed_variants_declare_autostart():
    for role in (OBSERVER, FEEDBACK, CONTROLLER):
        assert 'autostart' not in {spec.name for spec in node_parameters(role)}
        assert 'autostart' in {spec.name for spec in node_parameters(role, managed=True)}


@pytest.mark.parametrize('executor_name', ['events', 'single'])
def test_observer_transitions_output_cleanup_and_reconfigure(executor_name):
    system = validate_parameters(load_parameter_file(str(SEED003)))
    samples = plant_samples(system, 12)
    with ros_context('--params-file', str(SEED003)) as context:
        observer = ObserverLifecycleNode(context=context)
        driver = Driver(context)
        idle = own_entities(observer)
        with executor_with(context, observer, driver.node,
                           executor_name=executor_name) as executor:
            lifecycle = Lifecycle(driver.node, executor, 'observer')
            assert lifecycle.state() == 'unconfigured'
            assert not hasattr(observer, 'stream') and '/x_hat' not in idle
            assert lifecycle.change('configure') and lifecycle.state() == 'inactive'
            assert spin_until(executor, lambda: driver.y.get_subscription_count() >= 1
                              and driver.u.get_subscription_count() >= 1
                              and driver.node.count_publishers('x_hat') >= 1, 10.0)
            # Inactive: the measurements arrive and are dropped; no x_hat.
            drive(driver, executor, observer, samples[:3], None)
            spin_until(executor, lambda: bool(driver.estimates), 0.2)
            assert driver.estimates == []
            # Active: the estimates are those of a fresh estimator over the samples since.
            assert lifecycle.change('activate') and lifecycle.state() == 'active'
            drive(driver, executor, observer, samples[3:6], 0)
            got = np.array([list(m.position) for m in driver.estimates])
            assert np.array_equal(got, expected_estimates(system, samples[3:6]))
            # Run-time changes while active are vetted as in the plain node.
            poles = list(observer.get_parameter('observer.poles').value)
            design = observer.stream.estimator.design
            result = set_parameters(executor, driver.node, 'observer',
                                    observer__poles=['1', '2'])
            assert not result.successful and 'observer.poles' in result.reason
            assert list(observer.get_parameter('observer.poles').value) == poles
            assert observer.stream.estimator.design is design
            result = set_parameters(executor, driver.node, 'observer',
                                    observer__poles=['-20+5j', '-20-5j'])
            assert result.successful, result.reason
            assert observer.stream.estimator.design is not design
            result = set_parameters(executor, driver.node, 'observer', model__A=[0.0] * 4)
            assert not result.successful and 'model.A: read-only while /observer is ' \
                'configured' in result.reason, result.reason
            # Inactive again: nothing more is published; activate restarts the estimator.
            assert lifecycle.change('deactivate') and lifecycle.state() == 'inactive'
            drive(driver, executor, observer, samples[6:8], None)
            spin_until(executor, lambda: len(driver.estimates) > 3, 0.2)
            assert len(driver.estimates) == 3
            # Cleanup releases everything configure made; a structural change is then taken.
            assert lifecycle.change('cleanup') and lifecycle.state() == 'unconfigured'
            assert own_entities(observer) == idle
            assert list(observer.timers) == [] and not hasattr(observer, 'stream')
            result = set_parameters(executor, driver.node, 'observer', **KALMAN)
            assert result.successful, result.reason
            assert lifecycle.change('configure') and lifecycle.change('activate')
            assert '/x_hat_covariance' in own_entities(observer)
            driver.estimates.clear()
            drive(driver, executor, observer, samples[8:], 0)
            kalman = validate_parameters(dict(system.parameters, **{
                name.replace('__', '.'): value for name, value in KALMAN.items()}))
            got = np.array([list(m.position) for m in driver.estimates])
            assert np.array_equal(got, expected_estimates(kalman, samples[8:]))
            assert lifecycle.change('deactivate') and lifecycle.change('shutdown')
            assert lifecycle.state() == 'finalized'
            assert own_entities(observer) == idle


@pytest.mark.parametrize('executor_name', ['events', 'single'])
def test_feedback_sends_one_safe_command_on_deactivate_and_nothing_while_inactive(
        executor_name):
    extra = overrides(feedback__timeout=0.1, feedback__safe_command_period=0.05,
                      feedback__safe_command=[0.25])
    estimate = [0.3, -0.1]
    with ros_context('--params-file', str(SEED003)) as context:
        feedback = StateFeedbackLifecycleNode(context=context, parameter_overrides=extra)
        driver = Driver(context)
        with executor_with(context, feedback, driver.node,
                           executor_name=executor_name) as executor:
            lifecycle = Lifecycle(driver.node, executor, 'state_feedback')
            assert lifecycle.change('configure')
            gain = feedback.system.feedback.design.gain
            assert spin_until(executor, lambda: driver.x_hat.get_subscription_count() >= 1
                              and driver.node.count_publishers('u_cmd') >= 1, 10.0)
            driver.x_hat.publish(joint_state(START_NS, ['x1', 'x2'], estimate))
            assert spin_until(executor, lambda: feedback.dropped_while_inactive == 1, 5.0)
            assert lifecycle.change('activate')
            driver.x_hat.publish(joint_state(START_NS + PERIOD_NS, ['x1', 'x2'], estimate))
            assert spin_until(executor, lambda: len(driver.commands) == 1, 5.0)
            assert driver.commands[0].header.stamp.nanosec == PERIOD_NS
            np.testing.assert_allclose(driver.commands[0].position, -gain @ estimate,
                                       rtol=1e-12)
            # Deactivate: exactly one safe command, then silence well past the watchdog's
            # timeout and repeat period.
            assert lifecycle.change('deactivate')
            assert spin_until(executor, lambda: len(driver.commands) == 2, 5.0)
            assert list(driver.commands[1].position) == [0.25]
            spin_until(executor, lambda: len(driver.commands) > 2, 0.4)
            assert len(driver.commands) == 2 and feedback.counters['stale'] == 0
            driver.x_hat.publish(joint_state(START_NS + 2 * PERIOD_NS, ['x1', 'x2'], estimate))
            assert spin_until(executor, lambda: feedback.dropped_while_inactive == 2, 5.0)
            # Active again: the feedback resumes, and its watchdog with it.
            assert lifecycle.change('activate')
            driver.x_hat.publish(joint_state(START_NS + 3 * PERIOD_NS, ['x1', 'x2'], estimate))
            assert spin_until(executor, lambda: feedback.counters['stale'] == 1 and list(
                driver.commands[-1].position) == [0.25], 5.0)
            assert list(driver.commands[2].position) == pytest.approx(-gain @ estimate)


def test_controller_commands_while_active_one_safe_command_on_deactivate_and_cleans_up():
    extra = overrides(feedback__timeout=30.0, feedback__safe_command=[0.25])
    system = validate_parameters(load_parameter_file(str(SEED003)))
    samples = plant_samples(system, 8)
    with ros_context('--params-file', str(SEED003)) as context:
        node = ObserverControllerLifecycleNode(context=context, parameter_overrides=extra)
        driver = Driver(context)
        idle = own_entities(node)
        with executor_with(context, node, driver.node) as executor:
            lifecycle = Lifecycle(driver.node, executor, 'observer_controller')
            assert lifecycle.change('configure') and not driver.commands
            assert spin_until(executor, lambda: driver.y.get_subscription_count() >= 1
                              and driver.u.get_subscription_count() >= 1
                              and driver.node.count_publishers('u_cmd') >= 1
                              and driver.node.count_publishers('x_hat') >= 1, 10.0)
            drive(driver, executor, node, samples[:2], None)  # inactive: dropped
            assert lifecycle.change('activate')
            drive(driver, executor, node, samples[2:6], 0)
            estimates = expected_estimates(system, samples[2:6])
            assert spin_until(executor, lambda: len(driver.commands) == 4, 5.0)
            gain = system.feedback.design.gain
            assert np.array_equal(np.array([list(m.position) for m in driver.commands]),
                                  np.array([-gain @ x for x in estimates]))
            assert lifecycle.change('deactivate')
            assert spin_until(executor, lambda: len(driver.commands) == 5, 5.0)
            assert list(driver.commands[4].position) == [0.25]
            drive(driver, executor, node, samples[6:], None)
            assert len(driver.commands) == 5
            assert lifecycle.change('cleanup') and own_entities(node) == idle
            assert list(node.timers) == [] and not hasattr(node, 'feedback_part')


@pytest.mark.parametrize('factory, name, bad, fix, reason', [
    (ObserverLifecycleNode, 'observer', {'observer__poles': ['1', '2']},
     {'observer__poles': ['-8', '-9']}, 'observer.poles: '),
    (StateFeedbackLifecycleNode, 'state_feedback', {'feedback__poles': []},
     {'feedback__poles': ['-3', '-4']}, 'feedback.gain: the state_feedback node needs'),
    (ObserverControllerLifecycleNode, 'observer_controller', {'observer__poles': ['1', '2']},
     {'observer__poles': ['-8', '-9']}, 'observer.poles: '),
    (ObserverControllerLifecycleNode, 'observer_controller', {'feedback__poles': []},
     {'feedback__poles': ['-3', '-4']}, 'feedback.gain: the observer_controller node needs'),
])
def test_bad_configuration_fails_configure_naming_it_until_fixed(capfd, factory, name, bad,
                                                                 fix, reason):
    with ros_context('--params-file', str(SEED003)) as context:
        node = factory(context=context, parameter_overrides=overrides(**bad))
        driver = Driver(context)
        with executor_with(context, node, driver.node) as executor:
            lifecycle = Lifecycle(driver.node, executor, name)
            capfd.readouterr()
            assert not lifecycle.change('configure')
            assert lifecycle.state() == 'unconfigured'
            # The node's log (stderr and /rosout) says why, in one line naming the parameter.
            logged = [line for line in capfd.readouterr().err.splitlines()
                      if f'[{name}]: configure failed: ' in line]
            assert len(logged) == 1 and f'configure failed: {reason}' in logged[0], logged
            assert node.configure_error.startswith(reason)
            assert not lifecycle.change('activate') and lifecycle.state() == 'unconfigured'
            result = set_parameters(executor, driver.node, name, **fix)
            assert result.successful, result.reason
            assert lifecycle.change('configure') and lifecycle.state() == 'inactive'
            assert node.configure_error is None


def test_autostart_brings_both_nodes_to_active_and_shutdown_sends_the_safe_command():
    extra = overrides(autostart=True, feedback__timeout=30.0)
    system = validate_parameters(load_parameter_file(str(SEED003)))
    with ros_context('--params-file', str(SEED003)) as context:
        observer = ObserverLifecycleNode(context=context, parameter_overrides=extra)
        feedback = StateFeedbackLifecycleNode(context=context, parameter_overrides=extra)
        driver = Driver(context)
        with executor_with(context, observer, feedback, driver.node) as executor:
            for name in ('observer', 'state_feedback'):
                assert Lifecycle(driver.node, executor, name).state() == 'active'
            assert spin_until(executor, lambda: driver.y.get_subscription_count() >= 1
                              and driver.node.count_publishers('u_cmd') >= 1
                              and feedback.count_publishers('x_hat') >= 1, 10.0)
            samples = plant_samples(system, 3)
            drive(driver, executor, observer, samples, 0)
            assert spin_until(executor, lambda: len(driver.commands) == 3, 5.0)
            # Shutdown from active: the feedback's one safe command (zeros), then nothing.
            lifecycle = Lifecycle(driver.node, executor, 'state_feedback')
            assert lifecycle.change('shutdown from active')
            assert spin_until(executor, lambda: len(driver.commands) == 4, 5.0)
            assert list(driver.commands[3].position) == [0.0]
            spin_until(executor, lambda: len(driver.commands) > 4, 0.2)
            assert len(driver.commands) == 4 and lifecycle.state() == 'finalized'


def test_autostart_console_script_is_active_and_stops_cleanly():
    process = NodeProcess('observer_lifecycle', '--ros-args', '--params-file', str(SEED003),
                          '-p', 'autostart:=true', '-r', '__node:=managed_observer')
    try:
        with ros_context() as context:
            driver = Driver(context)
            with executor_with(context, driver.node) as executor:
                # A process: its start and discovery take seconds on a loaded machine.
                lifecycle = Lifecycle(driver.node, executor, 'managed_observer',
                                      timeout=PROCESS_START)
                assert lifecycle.state() == 'active'
    finally:
        code, _, err = process.stop()
    assert code == 0, err
    assert 'Traceback' not in err


def test_reactivation_pairs_no_input_of_before_the_deactivation():
    # Issue 27: after deactivate and activate the node warned "inputs are stamped -17.6 s
    # from the measurements... different time bases?": the reset kept the old inputs.
    system = validate_parameters(load_parameter_file(str(SEED003)))
    before = plant_samples(system, 3)
    gap_ns = 17_600_000_000  # the measurements after the re-activation, 17.6 s later
    with ros_context('--params-file', str(SEED003)) as context:
        observer = ObserverLifecycleNode(context=context)
        driver = Driver(context)
        with executor_with(context, observer, driver.node) as executor:
            lifecycle = Lifecycle(driver.node, executor, 'observer')
            assert lifecycle.change('configure') and lifecycle.change('activate')
            assert spin_until(executor, lambda: driver.y.get_subscription_count() >= 1
                              and driver.u.get_subscription_count() >= 1
                              and driver.node.count_publishers('x_hat') >= 1, 10.0)
            drive(driver, executor, observer, before, 0)
            assert lifecycle.change('deactivate') and lifecycle.change('activate')
            # Measurements without their inputs: each waits observer.input_wait, then goes on
            # with the inputs at hand, which are none, not those of 17.6 s before.
            for stamp, _, y in before:
                driver.y.publish(joint_state(stamp + gap_ns, ['y1'], y))
            assert spin_until(executor, lambda: len(driver.estimates) >= 6, 10.0)
            counters = observer.counters()
            assert counters['no_input'] >= 1, counters
            assert 'time_base' not in getattr(observer, '_warned', set())


@pytest.mark.parametrize('hold', [True, False])
def test_the_recipe_joint_is_held_until_the_managed_controller_commands(hold):
    # Issue 27: with lifecycle:=true the plant started after plant.start_timeout against an
    # unconfigured controller and the joint ran away under its load (-30 to -75 rad before
    # activation). With plant.hold_without_command it stays where it is until the first
    # command, then the activated controller servos it to the reference.
    settings = overrides(plant__hold_without_command=hold, plant__start_timeout=0.2,
                         plant__settle_time=0.0, plant__disturbance_time=0.0)
    with ros_context('--params-file', str(CONFIG_DIR / 'robot_joint.yaml')) as context:
        plant = PlantSimulatorNode(context=context, parameter_overrides=settings)
        controller = ObserverControllerLifecycleNode(
            context=context, parameter_overrides=overrides(feedback__timeout=30.0))
        helper = Node('reference_publisher', context=context)
        reference = helper.create_publisher(JointState, 'reference', 10)
        helper.create_timer(0.05, lambda: reference.publish(
            JointState(name=['shoulder'], position=[0.5])))
        with executor_with(context, plant, controller, helper) as executor:
            lifecycle = Lifecycle(helper, executor, 'observer_controller')
            # Unconfigured: no u_cmd publisher; the plant starts after its start timeout.
            assert spin_until(executor, lambda: plant.index >= 50, 30.0)
            position = plant.simulator.x[0]
            if not hold:
                assert position < -0.1, position  # the load drives the joint away
                return
            assert position == 0.0 and plant.counters['held_samples'] >= 49
            assert lifecycle.change('configure') and lifecycle.change('activate')
            released = plant.index
            assert spin_until(executor, lambda: plant.index >= released + 400, 60.0)
            assert abs(plant.simulator.x[0] - 0.5) < 1e-3, plant.simulator.x
            held, now = plant.counters['held_samples'], plant.index
            assert spin_until(executor, lambda: plant.index >= now + 50, 30.0)
            assert plant.counters['held_samples'] == held  # commanded: no longer held


def test_a_managed_node_knows_what_it_made_and_destroys_exactly_that_by_name():
    # Before, ManagedNode diffed vars(self) and its entity lists around configure; now it
    # records each entity configure creates under its name and releases those.
    with ros_context('--params-file', str(SEED003)) as context:
        node = ObserverControllerLifecycleNode(context=context)
        try:
            before = node.create_publisher(JointState, 'made_before', 10)
            assert node.made is None
            assert node.trigger_configure() == TransitionCallbackReturn.SUCCESS
            made = set(node.made)
            assert {'publisher u_cmd', 'publisher x_hat', 'subscription y', 'subscription u',
                    'subscription reference', 'publisher /diagnostics',
                    'timer _on_watchdog', 'service ~/reset'} <= made, sorted(made)
            assert 'publisher made_before' not in made
            # The node's state lives in its parts: those are what configure set.
            parts = {'observer_part', 'feedback_part', 'health', 'diagnostics'}
            assert node.made_attributes == parts
            assert 'system' not in node.made_attributes  # there before configure
            assert node.trigger_cleanup() == TransitionCallbackReturn.SUCCESS
            assert node.made is None and not hasattr(node, 'stream')
            topics = {publisher.topic_name for publisher in node.publishers}
            assert before in node.publishers and not topics & {'/u_cmd', '/x_hat'}
            assert list(node.timers) == [] and list(node.subscriptions) == []
            assert node.trigger_configure() == TransitionCallbackReturn.SUCCESS
            assert set(node.made) == made
        finally:
            node.destroy_node()
