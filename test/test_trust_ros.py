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
No message or parameter crashes a node or corrupts its estimate: real nodes over DDS.

Each test reproduces a defect found by trying the package as an adversary would (stamps the
wire can carry, NOT_SET and retyped parameters, an input arriving after its measurement, a
measurement stamped ahead of the clock) and checks what is promised instead.
"""

import os
import subprocess
import sys
import time

import numpy as np
import pytest
from rclpy.exceptions import ParameterNotDeclaredException
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from conftest import CONFIG_DIR, REPOSITORY
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.executors import EXECUTORS, make_executor
from observer_ros.ros.messages import MalformedMessage
from ros_support import executor_with, ros_context, spin_until
from test_ros_nodes import Driver, joint_state, plant_samples, send, set_parameters
from test_ros_nodes import observer_setup  # noqa: F401 (the fixture)

SEED003 = CONFIG_DIR / 'seed003_full_order.yaml'
PERIOD_NS = 10_000_000

#: (sec, nanosec) stamps the wire carries that are no time: dropped and counted.
INVALID_STAMPS = [(2147483647, 4294967295), (2147483647, 1000000000), (5, 1000000000),
                  (-1, 0), (-2147483648, 999999999)]


def raw_joint_state(sec, nanosec, names, values):
    message = JointState(name=list(names), position=[float(v) for v in values])
    message.header.stamp.sec, message.header.stamp.nanosec = sec, nanosec
    return message


def clean_estimates(system, samples):
    stream = system.make_stream()
    out = []
    for stamp, u, y in samples:
        stream.add_input(stamp, u)
        out += stream.add_measurement(stamp, y)
    return np.array([s.estimate for s in out])


def test_every_invalid_stamp_is_dropped_and_counted_by_the_observer(observer_setup):  # noqa: F811
    system, observer, driver, executor = observer_setup
    samples = plant_samples(system, 8)
    for index, (stamp, u, y) in enumerate(samples[:4]):
        send(driver, executor, stamp, u, y, index + 1)
    for sec, nanosec in INVALID_STAMPS:  # before: struct.error killed the node
        driver.y.publish(raw_joint_state(sec, nanosec, ['y1'], [0.5]))
        driver.u.publish(raw_joint_state(sec, nanosec, ['u1'], [0.5]))
    bad = 2 * len(INVALID_STAMPS)
    assert spin_until(executor, lambda: observer.counters()['malformed'] >= bad, 5.0)
    for index, (stamp, u, y) in enumerate(samples[4:], start=4):
        send(driver, executor, stamp, u, y, index + 1)
    assert observer.counters()['malformed'] == bad
    got = np.array([list(m.position) for m in driver.estimates])
    assert np.array_equal(got, clean_estimates(system, samples))


def test_a_repeated_joint_name_is_dropped_and_counted(observer_setup):  # noqa: F811
    # before: ['y1', 'y1'] with [0.2, 999] was read as 999 (the last one won), x_hat jumped
    # by 528 and malformed stayed 0; the same for an input
    system, observer, driver, executor = observer_setup
    samples = plant_samples(system, 8)
    for index, (stamp, u, y) in enumerate(samples[:4]):
        send(driver, executor, stamp, u, y, index + 1)
    stamp = samples[4][0]
    driver.u.publish(joint_state(stamp, ['u1', 'u1'], [0.2, 999.0]))
    driver.y.publish(joint_state(stamp, ['y1', 'y1'], [0.2, 999.0]))
    assert spin_until(executor, lambda: observer.counters()['malformed'] >= 2, 5.0)
    for index, (stamp, u, y) in enumerate(samples[4:], start=4):
        send(driver, executor, stamp, u, y, index + 1)
    assert observer.counters()['malformed'] == 2
    got = np.array([list(m.position) for m in driver.estimates])
    assert np.array_equal(got, clean_estimates(system, samples))
    # The message objects the codec also takes follow the same rule.
    codec = observer.codecs['y']
    with pytest.raises(MalformedMessage, match=r"^y: joints \['y1'\] named more than once"):
        codec.decode(joint_state(stamp, ['y1', 'y1'], [0.2, 999.0]))
    # A repeated joint the model does not name is one of the ignored extra joints.
    assert codec.decode(joint_state(stamp, ['wrist', 'y1', 'wrist'], [1.0, 0.5, 2.0]))[
        1].tolist() == [0.5]


def test_the_latest_stamp_is_used_and_invalid_ones_dropped_by_state_feedback():
    with ros_context('--params-file', str(SEED003)) as context:
        feedback = StateFeedbackNode(context=context)
        driver = Driver(context)
        with executor_with(context, feedback, driver.node) as executor:
            assert spin_until(executor, lambda: feedback.count_publishers('x_hat') >= 1 and
                              driver.node.count_subscribers('u_cmd') >= 1, 10.0)
            for sec, nanosec in INVALID_STAMPS:  # before: struct.error killed the node
                driver.x_hat.publish(raw_joint_state(sec, nanosec, ['x1', 'x2'], [0.1, 0.2]))
            assert spin_until(executor, lambda: feedback.counters['malformed'] ==
                              len(INVALID_STAMPS), 5.0)
            latest = (2147483647, 999999999)
            driver.x_hat.publish(raw_joint_state(*latest, ['x1', 'x2'], [0.1, 0.2]))
            assert spin_until(executor, lambda: any(
                (m.header.stamp.sec, m.header.stamp.nanosec) == latest
                for m in driver.commands), 5.0)


def test_unsetting_or_retyping_a_parameter_is_refused_and_later_sets_still_work(
        observer_setup):  # noqa: F811
    system, observer, driver, executor = observer_setup
    for parameter in (Parameter('observer.initial_state', Parameter.Type.NOT_SET),
                      Parameter('observer.initial_state', value='zeros'),
                      Parameter('observer.poles', value=True)):
        result = observer.set_parameters([parameter])[0]
        assert not result.successful
        assert result.reason.startswith(parameter.name + ': '), result.reason
        assert observer.has_parameter(parameter.name)
    # before: NOT_SET was accepted, deleted the parameter and every later set failed
    result = set_parameters(executor, driver.node, 'observer',
                            observer__initial_state=[1, 2])  # integers are taken as doubles
    assert result.successful, result.reason
    value = observer.get_parameter('observer.initial_state')
    assert value.type_ == Parameter.Type.DOUBLE_ARRAY and value.value == [1.0, 2.0]
    assert observer.stream.estimator.initial_state.tolist() == [1.0, 2.0]
    assert observer.describe_parameter('model.A').type == Parameter.Type.DOUBLE_ARRAY.value
    assert observer.describe_parameter('observer.poles').type == (
        Parameter.Type.STRING_ARRAY.value)


def test_each_node_declares_only_its_own_parameters(observer_setup):  # noqa: F811
    _, observer, _, _ = observer_setup
    assert not observer.has_parameter('feedback.poles')
    assert not observer.has_parameter('plant.rate_hz')
    with pytest.raises(ParameterNotDeclaredException):  # before: accepted, did nothing
        observer.set_parameters([Parameter('feedback.poles', value=['-1', '-2'])])
    assert observer.has_parameter('topics.y.type') and observer.has_parameter('model.A')


def test_a_value_outside_its_range_is_refused_before_anything_changes():
    with ros_context('--params-file', str(SEED003)) as context:
        feedback = StateFeedbackNode(context=context)
        timeout = feedback.system.feedback.timeout
        for value in (3e10, 1e12, 1e300, 0.0, -1.0):  # before: 3e10 killed create_timer
            result = feedback.set_parameters([Parameter('feedback.timeout', value=value)])[0]
            assert not result.successful
            assert result.reason.startswith('feedback.timeout: expected seconds in'), (
                result.reason)
        assert feedback.system.feedback.timeout == timeout
        feedback.destroy_node()


def test_a_refused_run_time_set_says_the_value_given_and_keeps_the_old_one():
    with ros_context('--params-file', str(SEED003)) as context:
        feedback = StateFeedbackNode(context=context)
        driver = Driver(context)
        with executor_with(context, feedback, driver.node) as executor:
            timeout = feedback.get_parameter('feedback.timeout').value
            for value, reason in (
                    # before: "got 3600" (the offending digits hidden)
                    (3600.001, 'feedback.timeout: expected seconds in [0.001, 3600], got '
                               '3600.001'),
                    # before: accepted, and the safe command replaced most commands
                    (0.001, 'feedback.timeout: expected more than one sample period (0.01 '
                            's at 100 Hz, from the 100 Hz assumed for a continuous model; '
                            'set diagnostics.expected_rate), got 0.001: ')):
                result = set_parameters(executor, driver.node, 'state_feedback',
                                        feedback__timeout=value)
                assert not result.successful
                assert result.reason.startswith(reason), result.reason
                assert feedback.get_parameter('feedback.timeout').value == timeout
                assert feedback.system.feedback.timeout == timeout


def test_a_negative_chen_seed_is_refused():
    path = CONFIG_DIR / 'seed001_third_order_chen.yaml'
    with ros_context('--params-file', str(path)) as context:
        observer = ObserverNode(context=context)
        result = observer.set_parameters([Parameter('observer.chen_seed', value=-1)])[0]
        assert not result.successful  # before: numpy's ValueError killed the observer
        assert result.reason.startswith('observer.chen_seed: expected a seed in [0, ')
        observer.destroy_node()


def waited_estimates(system, samples, late) -> np.ndarray:
    """
    Run the stream as the node ran it: each measurement before the input it waits for.

    The measurement of each step in ``late`` waited out ``observer.input_wait`` and went on
    with the latest input at hand; its own input came afterwards.
    """
    stream = system.make_stream()
    out = stream.add_measurement(samples[0][0], samples[0][2])
    for index in range(1, len(samples)):
        out += stream.add_measurement(samples[index][0], samples[index][2])
        if index in late:
            out += stream.flush(first_only=True)
        out += stream.add_input(samples[index - 1][0], samples[index - 1][1])
    return np.array([s.estimate for s in out])


@pytest.mark.parametrize('executor_name', EXECUTORS)
def test_each_measurement_waits_for_its_input_up_to_input_wait(executor_name):
    # The input of each interval is sent 5 ms after the measurement that needs it (the wait
    # is 50 ms). Before, one timer started by an earlier wait fired early for later ones,
    # and about 10 % of the steps used the previous input. The promise is an ordering one: no
    # measurement stops waiting before observer.input_wait has passed since it arrived. On
    # a loaded machine an input may take longer than that to be taken: then the measurement
    # rightly goes on with the previous input, which the expected estimates reproduce.
    system = validate_parameters(load_parameter_file(str(SEED003)))
    samples = plant_samples(system, 40)
    input_wait_ns = round(system.parameters['observer.input_wait'] * 1e9)
    with ros_context('--params-file', str(SEED003)) as context:
        observer = ObserverNode(context=context)
        driver = Driver(context)
        executor = make_executor(executor_name, context)
        for node in (observer, driver.node):
            executor.add_node(node)
        waited = {}  # stamp of each measurement that stopped waiting: how long it waited (ns)
        flush = observer.stream.flush

        def timed_flush(first_only=False):
            waiting = observer.stream.waiting()
            if waiting is not None:
                waited[observer.stream.engine.queue[0].stamp_ns] = (
                    time.monotonic_ns() - waiting[1])
            return flush(first_only)
        observer.stream.flush = timed_flush
        try:
            assert spin_until(executor, lambda: observer.count_publishers('y') >= 1 and
                              driver.node.count_subscribers('x_hat') >= 1, 10.0)
            stamp, u, y = samples[0]
            driver.y.publish(joint_state(stamp, ['y1'], y))
            assert spin_until(executor, lambda: len(driver.estimates) == 1, 5.0)
            for index in range(1, len(samples)):
                stamp, _, y = samples[index]
                previous_stamp, previous_u, _ = samples[index - 1]
                driver.y.publish(joint_state(stamp, ['y1'], y))
                assert spin_until(executor, lambda: observer.stream.pending == 1 or
                                  len(driver.estimates) == index + 1, 5.0)
                spin_until(executor, lambda: False, 0.005)
                driver.u.publish(joint_state(previous_stamp, ['u1'], previous_u))
                assert spin_until(executor, lambda: len(driver.estimates) == index + 1, 5.0)
            # Without its input a measurement waits, then goes on with the latest one.
            last = samples[-1][0] + PERIOD_NS
            driver.y.publish(joint_state(last, ['y1'], [0.0]))
            assert spin_until(executor, lambda: len(driver.estimates) == len(samples) + 1,
                              5.0)
        finally:
            for node in (observer, driver.node):
                executor.remove_node(node)
                node.destroy_node()
            executor.shutdown()
    # The steps whose input came after the wait (none on a quiet machine).
    late = {index for index, sample in enumerate(samples) if sample[0] in waited}
    assert last in waited and len(waited) == len(late) + 1, (waited, late)
    assert min(waited.values()) >= input_wait_ns, waited
    counters = observer.counters()
    assert counters['late_input'] + counters['no_input'] == len(waited)
    assert len(late) < len(samples) - 1, late  # some measurement was released by its input
    got = np.array([list(m.position) for m in driver.estimates[:-1]])
    assert np.array_equal(got, waited_estimates(system, samples, late))


def test_the_waited_estimates_are_the_clean_ones_when_every_input_comes_in_time():
    system = validate_parameters(load_parameter_file(str(SEED003)))
    samples = plant_samples(system, 40)
    assert np.array_equal(waited_estimates(system, samples, set()),
                          clean_estimates(system, samples))
    assert not np.array_equal(waited_estimates(system, samples, {5}),
                              clean_estimates(system, samples))


def test_a_measurement_far_ahead_of_the_clock_does_not_silence_it(observer_setup):  # noqa: F811
    system, observer, driver, executor = observer_setup
    start = observer.get_clock().now().nanoseconds - 10 ** 9  # real samples, in the past
    samples = [(start + stamp - plant_samples(system, 1)[0][0], u, y)
               for stamp, u, y in plant_samples(system, 40)]
    for index, (stamp, u, y) in enumerate(samples[:10]):
        send(driver, executor, stamp, u, y, index + 1)
    ahead = observer.get_clock().now().nanoseconds + 900_000_000
    driver.y.publish(joint_state(ahead, ['y1'], samples[10][2]))
    assert spin_until(executor, lambda: observer.counters()['future_stamp'] == 1, 5.0)
    for index, (stamp, u, y) in enumerate(samples[10:], start=10):
        send(driver, executor, stamp, u, y, index + 1)  # before: dropped as out of order
    assert observer.counters()['out_of_order'] == 0
    got = np.array([list(m.position) for m in driver.estimates])
    assert np.array_equal(got, clean_estimates(system, samples))


def test_a_huge_measurement_is_dropped_and_the_estimate_is_untouched(observer_setup):  # noqa: F811
    system, observer, driver, executor = observer_setup
    samples = plant_samples(system, 30)
    for index, (stamp, u, y) in enumerate(samples[:10]):
        send(driver, executor, stamp, u, y, index + 1)
    driver.y.publish(joint_state(samples[10][0], ['y1'], [1e308]))  # before: x_hat 2.8e307
    assert spin_until(executor, lambda: observer.counters()['out_of_range'] == 1, 5.0)
    for index, (stamp, u, y) in enumerate(samples[10:], start=10):
        send(driver, executor, stamp, u, y, index + 1)
    got = np.array([list(m.position) for m in driver.estimates])
    assert np.array_equal(got, clean_estimates(system, samples))


def node_process(code, *ros_args):
    """Run ``code`` (building a node from the ROS arguments) in a fresh interpreter."""
    return subprocess.Popen(
        [sys.executable, '-c', code, '--ros-args', *ros_args], cwd=str(REPOSITORY),
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=dict(os.environ))


def test_the_placement_modules_are_loaded_before_the_first_callback():
    # before: the first observer.method:=varga imported python-control inside the
    # parameter callback, blocking the observer for 0.5-1.0 s. The placement methods need
    # slycot (Varga's, called directly) and SciPy's place_poles and linear_sum_assignment
    # (loaded without scipy.signal and scipy.optimize: test_scipy_parts); python-control is
    # no longer one of them (it brought matplotlib along: test_startup).
    parts = 'getattr(sys.modules.get("observer_ros.core.scipy_parts"), "_LOADED", {})'
    loaded = f'("slycot" in sys.modules and len({parts}) == 2)'
    none = f'("slycot" not in sys.modules and not {parts})'
    code = ('import sys, rclpy; rclpy.init(args=sys.argv); '
            f'assert {none}; '
            'from observer_ros.nodes.observer import ObserverNode; '
            'from observer_ros.nodes.state_feedback import StateFeedbackNode; '
            f'assert {none}; '
            f'o = ObserverNode(); print("observer", {loaded}); '
            f'f = StateFeedbackNode(); print("feedback", {loaded})')
    process = node_process(code, '--params-file', str(SEED003))
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert out.split() == ['observer', 'True', 'feedback', 'True']


def test_a_node_warns_about_unknown_keys_of_its_own_sections(tmp_path):
    path = tmp_path / 'typo.yaml'
    text = SEED003.read_text()
    path.write_text(text.replace("      poles: ['zeta=0.8, wn=10']",
                                 "      poles: ['zeta=0.8, wn=10']\n      polse: ['-1.0']"))
    assert 'polse' in path.read_text()
    code = ('import sys, rclpy; rclpy.init(args=sys.argv); '
            'from observer_ros.nodes.observer import ObserverNode; ObserverNode(); '
            'print("built", flush=True)')
    process = node_process(code, '--params-file', str(path))
    out, err = process.communicate(timeout=60)
    assert process.returncode == 0, err
    assert ('observer.polse in the parameter file is ignored: unknown parameter; did you '
            "mean 'observer.poles'? (every parameter: doc/parameters.md)") in err
    assert 'feedback.' not in err  # another node's section: no warning


@pytest.mark.parametrize('node_class', [ObserverNode, StateFeedbackNode])
def test_a_clock_that_is_no_time_is_dropped_with_sim_time(node_class):
    with ros_context('--params-file', str(SEED003)) as context:
        node = node_class(context=context,
                          parameter_overrides=[Parameter('use_sim_time', value=True)])
        driver = Driver(context)
        clock = driver.node.create_publisher(Clock, '/clock', 10)
        with executor_with(context, node, driver.node) as executor:
            assert spin_until(executor, lambda: clock.get_subscription_count() >= 1, 10.0)
            for count, (sec, nanosec) in enumerate(INVALID_STAMPS, start=1):
                message = Clock()  # before: ValueError in rclpy's time source killed the node
                message.clock.sec, message.clock.nanosec = sec, nanosec
                clock.publish(message)  # one at a time: the /clock subscription keeps one
                assert spin_until(executor, lambda: node.invalid_clock == count, 5.0)
            valid = Clock()
            valid.clock.sec = 42
            clock.publish(valid)
            assert spin_until(executor, lambda: node.get_clock().now().nanoseconds ==
                              42 * 10 ** 9, 5.0)


def test_the_plant_never_publishes_a_value_beyond_its_topic_limit():
    from observer_ros.nodes.plant_simulator import PlantSimulatorNode
    settings = [Parameter('plant.initial_state', value=[2.0, 0.0]),
                Parameter('topics.y.limit', value=1.0),
                Parameter('plant.wait_for_command', value=False),
                Parameter('plant.samples', value=150)]
    with ros_context('--params-file', str(SEED003)) as context:
        plant = PlantSimulatorNode(context=context, parameter_overrides=settings)
        driver = Driver(context)
        received = []
        driver.node.create_subscription(JointState, 'y', received.append, 200)
        with executor_with(context, plant, driver.node) as executor:
            assert spin_until(executor, plant.finished.done, 20.0)
            spin_until(executor, lambda: len(received) + plant.counters['out_of_range'] >=
                       150, 5.0)
    values = np.array([m.position[0] for m in received])
    assert plant.counters['out_of_range'] > 0 and len(values) > 0
    assert len(values) + plant.counters['out_of_range'] == 150
    assert np.abs(values).max() <= 1.0
