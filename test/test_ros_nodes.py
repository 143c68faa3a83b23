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
The observer and state-feedback nodes in-process, over DDS, driven by a test publisher.

Run-time parameter changes go through the real ``set_parameters`` service; messages go
through real publishers and subscriptions.
"""

import math

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter_client import AsyncParameterClient
from rclpy.qos import qos_profile_sensor_data
from rclpy.serialization import deserialize_message, serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from bag_support import float64_array, joint_state as joint_state_cdr, serialize, TYPESTORE
from conftest import CONFIG_DIR
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.streaming import EventStream
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.messages import MalformedMessage, ns_to_stamp, VectorCodec
from ros_support import executor_with, overrides, ros_context, spin_until

SEED003 = CONFIG_DIR / 'seed003_full_order.yaml'
PERIOD_NS = 10_000_000
START_NS = 5_000_000_000


def joint_state(stamp_ns, names, values):
    """Build a stamped JointState with ``values`` in ``position``."""
    message = JointState(name=list(names), position=[float(v) for v in values])
    ns_to_stamp(message.header.stamp, stamp_ns)
    return message


class Driver:
    """A test node publishing ``y`` and ``u`` and collecting ``x_hat`` and ``u_cmd``."""

    def __init__(self, context, **kwargs) -> None:
        self.node = Node('driver', context=context, **kwargs)
        self.y = self.node.create_publisher(JointState, 'y', 10)
        self.u = self.node.create_publisher(JointState, 'u', 10)
        self.x_hat = self.node.create_publisher(JointState, 'x_hat', 10)
        self.estimates = []
        self.commands = []
        self.node.create_subscription(JointState, 'x_hat', self.estimates.append, 100)
        self.node.create_subscription(JointState, 'u_cmd', self.commands.append, 100)


def plant_samples(system, count, seed=0):
    """Return exact samples ``(stamp, u, y)`` of the plant under random inputs."""
    from observer_ros.core.simulation import PlantSimulator
    rng = np.random.default_rng(seed)
    plant = PlantSimulator(system.model, initial_state=[0.5, -0.5])
    samples = []
    for index in range(count):
        u = rng.uniform(-1.0, 1.0, size=1)
        samples.append((START_NS + index * PERIOD_NS, u, plant.measure().copy()))
        plant.step(u, PERIOD_NS / 1e9)
    return samples


@pytest.fixture
def observer_setup():
    """Yield the seed 003 system, an observer node, a driver and their executor."""
    system = validate_parameters(load_parameter_file(str(SEED003)))
    with ros_context('--params-file', str(SEED003)) as context:
        observer = ObserverNode(context=context)
        driver = Driver(context)
        with executor_with(context, observer, driver.node) as executor:
            assert spin_until(executor, lambda: observer.count_publishers('y') >= 1 and
                              driver.node.count_subscribers('x_hat') >= 1 and
                              observer.count_subscribers('x_hat') >= 1, 10.0)
            yield system, observer, driver, executor


def send(driver, executor, stamp, u, y, expect_estimates):
    """Publish ``u`` then ``y``; spin until ``expect_estimates`` estimates have arrived."""
    driver.u.publish(joint_state(stamp, ['u1'], u))
    driver.y.publish(joint_state(stamp, ['y1'], y))
    assert spin_until(executor, lambda: len(driver.estimates) >= expect_estimates, 5.0), (
        f'expected {expect_estimates} estimates, got {len(driver.estimates)}')


@pytest.mark.parametrize('kind', ['joint_state', 'float64_multi_array'])
def test_codec_reads_and_writes_the_bytes_rclpy_does(kind):
    codec = VectorCodec('y', kind, 'position', ['y1', 'y2'])
    raw = codec.encode(1_500_000_007, np.array([0.25, -3.0]))
    message = deserialize_message(raw, codec.message_class)
    assert message == codec.message(1_500_000_007, [0.25, -3.0])
    assert codec.encode(1_500_000_007, [0.25, -3.0]) == raw  # padding zeroed, not leaked
    stamp = 1_500_000_007 if kind == 'joint_state' else None
    for form in (raw, message):
        decoded = codec.decode(form)
        assert decoded[0] == stamp and decoded[1].tolist() == [0.25, -3.0]
    # Big-endian CDR (another architecture) goes through the general deserializer.
    stored = (joint_state_cdr(1_500_000_007, ['y1', 'y2'], [0.25, -3.0])
              if kind == 'joint_state' else float64_array([0.25, -3.0]))
    big = bytes(TYPESTORE.serialize_cdr(stored, stored.__msgtype__, little_endian=False))
    assert big[:2] == b'\x00\x00' and big != serialize(stored)
    decoded = codec.decode(big)
    assert decoded[0] == stamp and decoded[1].tolist() == [0.25, -3.0]
    for bad in (raw[:30], b'\x00\x00\x00\x00' + bytes(3)):
        with pytest.raises(MalformedMessage, match='^y: '):
            codec.decode(bad)


def test_malformed_measurements_are_dropped_and_counted(observer_setup):
    system, observer, driver, executor = observer_setup
    samples = plant_samples(system, 12)
    for index, (stamp, u, y) in enumerate(samples[:6]):
        send(driver, executor, stamp, u, y, index + 1)
    bad = [
        joint_state(samples[6][0], ['y1'], [math.nan]),            # NaN
        joint_state(samples[6][0], ['y1', 'y2'], [1.0]),           # lengths differ
        joint_state(samples[6][0], ['elbow'], [1.0]),              # missing joint
        joint_state(samples[6][0], ['y1'], [math.inf]),            # infinite
        serialize_message(joint_state(samples[6][0], ['y1'], [1.0]))[:30],  # truncated
        b'\x00\x00\x00\x00' + bytes(40),                            # undecodable
    ]
    for message in bad:
        driver.y.publish(message)
    assert spin_until(executor, lambda: observer.counters()['malformed'] >= len(bad), 5.0)
    for index, (stamp, u, y) in enumerate(samples[6:], start=6):
        send(driver, executor, stamp, u, y, index + 1)
    assert observer.counters()['malformed'] == len(bad)
    assert len(driver.estimates) == len(samples)
    # The estimates are those of the valid samples alone, bit for bit, and finite.
    stream = EventStream(system.observer.make_estimator(), 10**9)
    expected = []
    for stamp, u, y in samples:
        stream.add_input(stamp, u)
        expected += [s.estimate.copy() for s in stream.add_measurement(stamp, y)]
    got = np.array([list(m.position) for m in driver.estimates])
    assert np.all(np.isfinite(got))
    assert np.array_equal(got, np.array(expected))


def test_duplicate_and_old_measurements_are_dropped(observer_setup):
    system, observer, driver, executor = observer_setup
    samples = plant_samples(system, 4)
    for index, (stamp, u, y) in enumerate(samples[:3]):
        send(driver, executor, stamp, u, y, index + 1)
    driver.y.publish(joint_state(samples[2][0], ['y1'], samples[2][2]))  # duplicate
    driver.y.publish(joint_state(samples[1][0], ['y1'], samples[1][2]))  # out of order
    assert spin_until(executor, lambda: observer.counters()['duplicate'] == 1 and
                      observer.counters()['out_of_order'] == 1, 5.0)
    send(driver, executor, *samples[3], expect_estimates=4)
    assert len(driver.estimates) == 4


def set_parameters(executor, client_node, node_name, **values):
    """Set parameters of ``node_name`` in one atomic request through its service."""
    client = AsyncParameterClient(client_node, node_name)
    assert client.wait_for_services(timeout_sec=5.0)
    future = client.set_parameters_atomically(overrides(**values))
    executor.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.done(), 'set_parameters_atomically got no answer'
    return future.result().result


UNSTABLE_GAIN = [-30.0, -200.0]  # eig(A - L C) in the right half plane

REJECTED = {
    'unstable poles': ({'observer__poles': ['1', '2']}, 'not stable'),
    'unpaired complex pole': ({'observer__poles': ['-1+1j', '-2']}, 'conjugate'),
    'gain of the wrong size': ({'observer__poles': [], 'observer__gain': [1.0, 2.0, 3.0]},
                               'observer.gain: expected 2'),
    'non-finite gain': ({'observer__poles': [], 'observer__gain': [1.0, math.nan]},
                        'observer.gain'),
    'unstable gain': ({'observer__poles': [], 'observer__gain': UNSTABLE_GAIN},
                      'observer.gain'),
    'gain and poles': ({'observer__gain': [22.0, 59.0]}, 'not both'),
    'wrong type': ({'observer__poles': 3.5}, 'observer.poles: expected string_array'),
    'read-only model': ({'model__A': [0.0, 1.0, 0.0, 0.0]}, 'read-only'),
    'negative interval resolution': ({'observer__interval_resolution': -0.001},
                                     'observer.interval_resolution: expected seconds'),
    # before: accepted, and every 10 ms interval was designed as 0.5 s
    'interval resolution of a sample period or more': (
        {'observer__interval_resolution': 0.5}, 'observer.interval_resolution: expected 0 '
        '(exact intervals) or seconds below one sample period (0.01 s at 100 Hz, from the '
        '100 Hz assumed for a continuous model; set diagnostics.expected_rate), got 0.5'),
    'interval resolution with more digits than the range': (
        {'observer__interval_resolution': 1000000.001}, 'got 1000000.001'),
}


@pytest.mark.parametrize('case', sorted(REJECTED))
def test_rejected_parameter_change_keeps_everything(observer_setup, case):
    values, reason = REJECTED[case]
    system, observer, driver, executor = observer_setup
    samples = plant_samples(system, 4)
    for index, (stamp, u, y) in enumerate(samples[:2]):
        send(driver, executor, stamp, u, y, index + 1)
    design_before = observer.stream.estimator.design
    before = {name: observer.get_parameter(name.replace('__', '.')).value for name in values}
    result = set_parameters(executor, driver.node, 'observer', **values)
    assert not result.successful
    assert reason in result.reason, result.reason
    for name, value in before.items():
        assert observer.get_parameter(name.replace('__', '.')).value == value
    assert observer.stream.estimator.design is design_before
    # Estimation goes on with the old gains.
    stream = EventStream(system.observer.make_estimator(), 10**9)
    expected = []
    for stamp, u, y in samples:
        stream.add_input(stamp, u)
        expected += [s.estimate.copy() for s in stream.add_measurement(stamp, y)]
    for index, (stamp, u, y) in enumerate(samples[2:], start=2):
        send(driver, executor, stamp, u, y, index + 1)
    got = np.array([list(m.position) for m in driver.estimates])
    assert np.array_equal(got, np.array(expected))


def test_accepted_parameter_change_has_no_jump(observer_setup):
    system, observer, driver, executor = observer_setup
    samples = plant_samples(system, 8)
    for index, (stamp, u, y) in enumerate(samples[:5]):
        send(driver, executor, stamp, u, y, index + 1)
    previous = np.array(driver.estimates[-1].position)
    new_poles = ['-20+5j', '-20-5j']
    result = set_parameters(executor, driver.node, 'observer', observer__poles=new_poles)
    assert result.successful, result.reason
    assert list(observer.get_parameter('observer.poles').value) == new_poles
    # The next estimate is the new gains' step from the current estimate: no restart, no jump.
    params = dict(system.parameters, **{'observer.poles': new_poles})
    new_system = validate_parameters(params)
    g = new_system.observer.make_estimator().step_matrices(PERIOD_NS).g
    stamp, u, y = samples[5]
    send(driver, executor, stamp, u, y, 6)
    n = 2
    expected = g[:n] @ np.concatenate([previous, samples[4][1], y])
    got = np.array(driver.estimates[-1].position)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-12)
    old_g = system.observer.make_estimator().step_matrices(PERIOD_NS).g
    assert not np.allclose(old_g[:n] @ np.concatenate([previous, samples[4][1], y]), got)
    assert observer.counters()['restart_gap'] == 0
    # The interval resolution changes at run time too, without touching the estimate.
    result = set_parameters(executor, driver.node, 'observer',
                            observer__interval_resolution=0.001)
    assert result.successful, result.reason
    assert observer.stream.estimator.interval_resolution_ns == 1_000_000
    assert np.array_equal(observer.stream.estimator.estimate, got)


def test_feedback_timeout_publishes_the_safe_command_once_per_outage():
    extra = overrides(feedback__timeout=0.2, feedback__safe_command=[0.25])
    with ros_context('--params-file', str(SEED003)) as context:
        feedback = StateFeedbackNode(context=context, parameter_overrides=extra)
        driver = Driver(context)
        gain = feedback.system.feedback.design.gain
        with executor_with(context, feedback, driver.node) as executor:
            assert spin_until(executor, lambda: feedback.count_publishers('x_hat') >= 1 and
                              driver.node.count_subscribers('x_hat') >= 1, 10.0)
            estimate = [0.3, -0.1]
            driver.commands.clear()
            driver.x_hat.publish(joint_state(START_NS, ['x1', 'x2'], estimate))
            assert spin_until(executor, lambda: any(
                m.header.stamp.sec == START_NS // 10**9 for m in driver.commands), 5.0)
            command = next(m for m in driver.commands
                           if m.header.stamp.sec == START_NS // 10**9)
            np.testing.assert_allclose(command.position, -gain @ estimate, rtol=1e-12)
            # Silence: the safe command follows, and the outage is counted once.
            assert spin_until(executor, lambda: feedback.counters['stale'] == 1 and list(
                driver.commands[-1].position) == [0.25], 5.0)
            spin_until(executor, lambda: False, 0.5)
            assert feedback.counters['stale'] == 1
            assert list(driver.commands[-1].position) == [0.25]
            # x_hat is back: feedback resumes.
            driver.x_hat.publish(joint_state(START_NS + PERIOD_NS, ['x1', 'x2'], estimate))
            assert spin_until(executor, lambda: not feedback.feedback_part.stale, 5.0)
            assert spin_until(executor, lambda: np.allclose(
                driver.commands[-1].position, -gain @ estimate), 5.0)


def test_feedback_gain_that_destabilises_the_loop_is_refused():
    with ros_context('--params-file', str(SEED003)) as context:
        feedback = StateFeedbackNode(context=context)
        client = Node('client', context=context)
        with executor_with(context, feedback, client) as executor:
            gain_before = feedback.feedback_part.law.gain.copy()
            result = set_parameters(executor, client, 'state_feedback',
                                    feedback__poles=[], feedback__gain=[0.0, 0.0])
            assert not result.successful
            assert 'feedback.gain' in result.reason and 'stable' in result.reason, result.reason
            assert np.array_equal(feedback.feedback_part.law.gain, gain_before)
            result = set_parameters(executor, client, 'state_feedback',
                                    feedback__poles=['-5', '-6'])
            assert result.successful, result.reason
            np.testing.assert_allclose(
                np.sort(np.linalg.eigvals(feedback.system.model.a - feedback.system.model.b
                                          @ feedback.feedback_part.law.gain).real), [-6.0, -5.0])


def test_observer_remapped_to_joint_states_with_extra_joints():
    # A robot stack: y comes from /joint_states, which carries more joints than the model
    # measures, in another order; the input arrives as an unstamped Float64MultiArray.
    system = validate_parameters(load_parameter_file(str(SEED003)))
    extra = overrides(topics__u__type='float64_multi_array')
    with ros_context('--params-file', str(SEED003), '-r', 'y:=/joint_states',
                     '-r', 'u:=/forward_command_controller/commands') as context:
        observer = ObserverNode(context=context, parameter_overrides=extra)
        driver = Driver(context, use_global_arguments=False)  # no remapping for the test
        joint_states = driver.node.create_publisher(JointState, '/joint_states', 10)
        commands = driver.node.create_publisher(
            Float64MultiArray, '/forward_command_controller/commands', 10)
        with executor_with(context, observer, driver.node) as executor:
            assert spin_until(executor, lambda: observer.count_publishers('/joint_states') >= 1
                              and driver.node.count_subscribers('x_hat') >= 1
                              and observer.count_subscribers('x_hat') >= 1, 10.0)
            commands.publish(Float64MultiArray(data=[0.0]))
            assert spin_until(executor, lambda: observer.counters()['inputs'] == 1, 5.0)
            samples = plant_samples(system, 30)
            for index, (stamp, _, y) in enumerate(samples):
                message = JointState(name=['wheel', 'y1', 'arm'], position=[9.0, y[0], -9.0])
                ns_to_stamp(message.header.stamp, stamp)
                joint_states.publish(message)
                assert spin_until(executor, lambda: len(driver.estimates) > index, 5.0)
    assert observer.counters()['malformed'] == 0
    stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in driver.estimates]
    assert stamps == [stamp for stamp, _, _ in samples]
    assert list(driver.estimates[0].name) == ['x1', 'x2']


def test_best_effort_publisher_and_reset_service(observer_setup):
    system, observer, driver, executor = observer_setup
    sensor = driver.node.create_publisher(JointState, 'y', qos_profile_sensor_data)
    samples = plant_samples(system, 6)
    for index, (stamp, u, y) in enumerate(samples[:3]):
        driver.u.publish(joint_state(stamp, ['u1'], u))
        sensor.publish(joint_state(stamp, ['y1'], y))
        assert spin_until(executor, lambda: len(driver.estimates) > index, 5.0)
    client = driver.node.create_client(Trigger, '/observer/reset')
    assert client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(Trigger.Request())
    executor.spin_until_future_complete(future, timeout_sec=5.0)
    assert future.result().success
    assert observer.counters()['resets'] == 1
    # After the reset the estimator starts again from observer.initial_state at the next
    # sample, exactly as a fresh one does.
    fresh = system.observer.make_estimator()
    stamp, u, y = samples[3]
    send(driver, executor, stamp, u, y, 4)
    expected = fresh.update(stamp, y, u)
    assert np.array_equal(np.array(driver.estimates[-1].position), expected)
