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
A fuzz campaign over real DDS: every subscribed topic and every run-time parameter.

Hypothesis draws malformed messages (bytes, truncations, NaN, infinities, huge values, wrong
joints and lengths, stamps that are no time or lie ahead of the clock, duplicates) between
good samples, and parameter updates (wrong types, NOT_SET, out of range, unstable, wrong
sizes, and valid ones). Each node must stay alive, publish only finite values, count
exactly the bad messages it was sent, give the estimates and commands of a clean run, refuse
every invalid update with a reason naming a parameter and keep working as before it.
Bounded: a fixed number of examples, derandomized, no example database.
"""

import math

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

from conftest import CONFIG_DIR
from observer_ros.config import (
    CONTROLLER, DOUBLE, FEEDBACK, INTEGER, load_parameter_file, node_parameters, OBSERVER,
    PARAMETER_SPECS, STRING, STRING_ARRAY, validate_parameters)
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.observer_controller import ObserverControllerNode
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.messages import MalformedMessage, ns_to_stamp, stamp_to_ns, VectorCodec
from observer_ros.ros.parameters import coerced, type_problem
from ros_support import executor_with, ros_context, spin_until
from test_ros_nodes import Driver, plant_samples

SEED003 = CONFIG_DIR / 'seed003_full_order.yaml'
KALMAN = CONFIG_DIR / 'kalman_noisy.yaml'
PERIOD_NS = 10_000_000
CAMPAIGN = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))

#: Kinds of bad message and the counter each must raise.
BAD_KINDS = {'bytes': 'malformed', 'truncated': 'malformed', 'nan': 'malformed',
             'inf': 'malformed', 'huge': 'out_of_range', 'joints': 'malformed',
             'lengths': 'malformed', 'nanosec': 'malformed', 'negative': 'malformed',
             'future': 'future_stamp', 'duplicate': 'duplicate'}


def message(stamp_ns, names, values):
    result = JointState(name=list(names), position=[float(v) for v in values])
    ns_to_stamp(result.header.stamp, stamp_ns)
    return result


def content_length(raw, names):
    """Length of the shortest prefix of ``raw`` that still decodes (the rest is padding)."""
    codec = VectorCodec('fuzz', 'joint_state', 'position', names)
    for length in range(len(raw) + 1):
        try:
            codec.decode(raw[:length])
        except MalformedMessage:
            continue
        return length
    raise AssertionError('the message does not decode')


def bad_message(kind, names, stamp_ns, now_ns, data):
    """Return a serialized bad message of ``kind`` on a topic of joints ``names``."""
    size = len(names)
    good = message(stamp_ns, names, [0.5] * size)
    if kind == 'bytes':
        return data.draw(st.binary(max_size=80))
    if kind == 'truncated':  # cut into the content (the last bytes may be padding only)
        raw = serialize_message(good)
        return raw[:data.draw(st.integers(0, content_length(raw, names) - 1))]
    if kind in ('nan', 'inf', 'huge'):
        value = {'nan': math.nan, 'inf': data.draw(st.sampled_from([math.inf, -math.inf])),
                 'huge': data.draw(st.sampled_from([1e308, -1e10, 2e9, 1e300]))}[kind]
        good.position[data.draw(st.integers(0, size - 1))] = value
    elif kind == 'joints':
        good.name = [data.draw(st.sampled_from(['elbow', '', 'y', 'x']))] * size
    elif kind == 'lengths':
        good.position = [0.5] * data.draw(st.sampled_from([0, size + 1, size + 3]))
    elif kind == 'nanosec':
        good.header.stamp.nanosec = data.draw(st.integers(1_000_000_000, 2 ** 32 - 1))
    elif kind == 'negative':
        good.header.stamp.sec = data.draw(st.integers(-2 ** 31, -1))
    elif kind == 'future':
        ns_to_stamp(good.header.stamp, now_ns + data.draw(st.integers(10 ** 9, 10 ** 15)))
    return serialize_message(good)


@pytest.mark.parametrize('node_class', [ObserverNode, ObserverControllerNode])
def test_bad_messages_never_reach_the_estimate(node_class):
    # The observer-controller too: its commands are those of the clean estimates.
    system = validate_parameters(load_parameter_file(str(SEED003)))
    with ros_context('--params-file', str(SEED003)) as context:
        observer = node_class(context=context)
        driver = Driver(context)
        innovations = []
        driver.node.create_subscription(JointState, 'innovation', innovations.append, 100)
        with executor_with(context, observer, driver.node) as executor:
            assert spin_until(executor, lambda: observer.count_publishers('y') >= 1 and
                              observer.count_publishers('u') >= 1 and
                              driver.node.count_subscribers('x_hat') >= 1 and
                              driver.node.count_subscribers('innovation') >= 1, 10.0)
            clock = observer.get_clock()
            campaign = {'examples': 0, 'bad': 0}

            @CAMPAIGN
            @given(st.data())
            def example(data):
                # A fresh timeline per example, a second in the past of the node clock.
                observer.stream.reset()
                driver.estimates.clear()
                driver.commands.clear()
                innovations.clear()
                before = observer.counters()
                base = clock.now().nanoseconds - 10 ** 9
                samples = [(base + k * PERIOD_NS, u, y)
                           for k, (_, u, y) in enumerate(plant_samples(system, 12))]
                expected = {}
                for index, (stamp, u, y) in enumerate(samples):
                    for _ in range(data.draw(st.integers(0, 2))):
                        topic = data.draw(st.sampled_from(['y', 'u']))
                        kind = data.draw(st.sampled_from(sorted(BAD_KINDS)))
                        if kind == 'duplicate' and (topic == 'u' or index < 1):
                            continue  # a repeated input stamp replaces the input: not bad
                        names = ['y1'] if topic == 'y' else ['u1']
                        previous = samples[index - 1][0] if index else stamp
                        raw = bad_message(kind, names, previous, clock.now().nanoseconds,
                                          data)
                        (driver.y if topic == 'y' else driver.u).publish(raw)
                        expected[BAD_KINDS[kind]] = expected.get(BAD_KINDS[kind], 0) + 1
                        campaign['bad'] += 1
                        assert spin_until(executor, lambda: all(
                            observer.counters()[key] - before[key] >= count
                            for key, count in expected.items()), 5.0), expected
                    driver.u.publish(message(stamp, ['u1'], u))
                    driver.y.publish(message(stamp, ['y1'], y))
                    assert spin_until(executor, lambda: len(driver.estimates) > index and
                                      len(innovations) > index, 5.0)
                after = observer.counters()
                for key, count in expected.items():
                    assert after[key] - before[key] == count, key
                clean = system.make_stream()
                reference = []
                for stamp, u, y in samples:
                    clean.add_input(stamp, u)
                    reference += clean.add_measurement(stamp, y)
                got = np.array([list(m.position) for m in driver.estimates])
                assert np.isfinite(got).all()
                assert np.isfinite(np.array([list(m.position) for m in innovations])).all()
                assert [stamp_to_ns(m.header.stamp) for m in driver.estimates] == [
                    s.stamp_ns for s in reference]
                assert np.array_equal(got, np.array([s.estimate for s in reference]))
                if node_class is ObserverControllerNode:
                    assert spin_until(executor, lambda: len(driver.commands) >= len(got), 5.0)
                    commands = np.array([list(m.position) for m in driver.commands])
                    assert np.array_equal(commands, np.array(
                        [observer.feedback_part.law.command(s.estimate, None) for s in reference]))
                campaign['examples'] += 1

            example()
            assert campaign['examples'] == CAMPAIGN.max_examples and campaign['bad'] > 50


#: Bad kinds for nodes without stamp rules (state_feedback, the plant): every one is dropped.
UNSTAMPED_RULES = sorted(set(BAD_KINDS) - {'future', 'duplicate'})


def test_bad_estimates_and_references_never_reach_the_command():
    system = validate_parameters(load_parameter_file(str(SEED003)))
    law_names = system.model.state_names
    with ros_context('--params-file', str(SEED003)) as context:
        feedback = StateFeedbackNode(context=context)
        driver = Driver(context)
        reference = driver.node.create_publisher(JointState, 'reference', 10)
        with executor_with(context, feedback, driver.node) as executor:
            assert spin_until(executor, lambda: feedback.count_publishers('x_hat') >= 1 and
                              feedback.count_publishers('reference') >= 1 and
                              driver.node.count_subscribers('u_cmd') >= 1, 10.0)
            clock = feedback.get_clock()
            campaign = {'bad': 0}
            rng = np.random.default_rng(3)

            @CAMPAIGN
            @given(st.data())
            def example(data):
                before = dict(feedback.counters)
                expected = {}
                sent = []
                for index in range(8):
                    for _ in range(data.draw(st.integers(0, 2))):
                        topic = data.draw(st.sampled_from(['x_hat', 'reference']))
                        kind = data.draw(st.sampled_from(UNSTAMPED_RULES))
                        names = law_names if topic == 'x_hat' else system.model.output_names
                        raw = bad_message(kind, names, clock.now().nanoseconds - 10 ** 9,
                                          clock.now().nanoseconds, data)
                        (driver.x_hat if topic == 'x_hat' else reference).publish(raw)
                        expected[BAD_KINDS[kind]] = expected.get(BAD_KINDS[kind], 0) + 1
                        campaign['bad'] += 1
                        assert spin_until(executor, lambda: all(
                            feedback.counters[key] - before.get(key, 0) >= count
                            for key, count in expected.items()), 5.0), expected
                    estimate = rng.uniform(-1.0, 1.0, size=len(law_names))
                    stamp = clock.now().nanoseconds - 10 ** 9 + index
                    driver.x_hat.publish(message(stamp, law_names, estimate))
                    sent.append((stamp, feedback.feedback_part.law.command(estimate, None)))
                    assert spin_until(executor, lambda: any(
                        stamp_to_ns(m.header.stamp) == stamp for m in driver.commands), 5.0)
                for key, count in expected.items():
                    assert feedback.counters[key] - before.get(key, 0) == count, key
                assert feedback.feedback_part.reference is None  # no bad reference was taken
                by_stamp = {stamp_to_ns(m.header.stamp): np.array(m.position)
                            for m in driver.commands}
                for stamp, command in sent:
                    assert np.array_equal(by_stamp[stamp], command)
                assert all(np.isfinite(m.position).all() for m in driver.commands)

            example()
            assert campaign['bad'] > 30


def test_bad_commands_never_reach_the_plant():
    from observer_ros.nodes.plant_simulator import PlantSimulatorNode
    settings = [Parameter('plant.wait_for_command', value=False),
                Parameter('plant.command_timeout', value=3600.0)]
    system = validate_parameters(load_parameter_file(str(SEED003)))
    names = system.model.input_names
    with ros_context('--params-file', str(SEED003)) as context:
        plant = PlantSimulatorNode(context=context, parameter_overrides=settings)
        driver = Driver(context)
        command = driver.node.create_publisher(JointState, 'u_cmd', 10)
        applied = []
        driver.node.create_subscription(JointState, 'u', applied.append, 100)
        driver.node.create_subscription(JointState, 'y', lambda m: None, 10)  # starts the plant
        with executor_with(context, plant, driver.node) as executor:
            assert spin_until(executor, lambda: plant.count_publishers('u_cmd') >= 1 and
                              len(applied) > 0, 10.0)
            clock = plant.get_clock()
            campaign = {'bad': 0, 'good': 0}

            @CAMPAIGN
            @given(st.data())
            def example(data):
                before = dict(plant.counters)
                expected = {}
                good = [data.draw(st.floats(-1.0, 1.0))]
                command.publish(message(clock.now().nanoseconds, names, good))
                campaign['good'] += 1
                assert spin_until(executor, lambda: plant.command is not None and
                                  plant.command.tolist() == good, 5.0)
                for _ in range(data.draw(st.integers(1, 4))):
                    kind = data.draw(st.sampled_from(UNSTAMPED_RULES))
                    command.publish(bad_message(kind, names, clock.now().nanoseconds,
                                                clock.now().nanoseconds, data))
                    expected[BAD_KINDS[kind]] = expected.get(BAD_KINDS[kind], 0) + 1
                    campaign['bad'] += 1
                    assert spin_until(executor, lambda: all(
                        plant.counters[key] - before.get(key, 0) >= count
                        for key, count in expected.items()), 5.0), expected
                for key, count in expected.items():
                    assert plant.counters[key] - before.get(key, 0) == count, key
                assert plant.command.tolist() == good  # the last good command still applies
                # Judge a sample published after the command took effect: one stamped before
                # may still be in flight.
                published = plant.stamp_ns
                assert spin_until(executor, lambda: any(
                    stamp_to_ns(m.header.stamp) > published for m in applied), 5.0)
                later = [m for m in applied if stamp_to_ns(m.header.stamp) > published]
                assert list(later[0].position) == good
                assert all(np.isfinite(m.position).all() for m in applied)

            example()
            assert campaign['bad'] > 30


# --- parameters ---------------------------------------------------------------------------

FLOATS = st.one_of(st.sampled_from([0.0, -0.0, 1.0, -1.0, 1e-300, -1e300, 1e300, 1e12, 3e10,
                                    math.nan, math.inf, -math.inf]),
                   st.floats(-100.0, 100.0))
POLES = st.sampled_from(['-1', '-2', '-5', '-20', '1', '0', '-3+3j', '-3-3j', '-1e12',
                         'zeta=0.8, wn=10', 'zeta=nan, wn=10', 'x', '-1e-3', '0.5'])


def value_for(spec, data):
    """Draw a value for ``spec``: often of another type, out of range or of a wrong size."""
    other = data.draw(st.integers(0, 9)) == 0
    if other:
        return data.draw(st.sampled_from([Parameter.Type.NOT_SET, 'text', True, 7, [1, 2],
                                          2.5, ['a']]))
    if spec.value_type == DOUBLE:
        return data.draw(FLOATS)
    if spec.value_type == INTEGER:
        return data.draw(st.sampled_from([0, 1, 42, -1, 2 ** 63 - 1, -2 ** 63]))
    if spec.value_type == STRING:
        return data.draw(st.sampled_from(['auto', 'place', 'varga', 'acker', 'direct',
                                          'canonical', 'fast', '']))
    if spec.value_type == STRING_ARRAY:
        return data.draw(st.lists(POLES, max_size=4))
    return data.draw(st.lists(FLOATS, max_size=5))


def as_parameter(name, value):
    if value is Parameter.Type.NOT_SET:
        return Parameter(name, Parameter.Type.NOT_SET)
    return Parameter(name, value=value)


def predicted(node, parameters):
    """Return what the node should answer, ``(accepted, reason or None)``, from the schema."""
    merged = node.current_parameters()
    for parameter in parameters:
        spec = PARAMETER_SPECS[parameter.name]
        problem = type_problem(spec, coerced(spec, parameter))
        if problem:
            return False, problem
        merged[parameter.name] = coerced(spec, parameter).value
    try:
        node.vet_system(validate_parameters(merged))
    except (ConfigError, DesignError) as e:
        return False, str(e)
    return True, None


@pytest.mark.parametrize('config,node_role', [(SEED003, OBSERVER), (KALMAN, OBSERVER),
                                              (SEED003, FEEDBACK), (SEED003, CONTROLLER)])
def test_every_run_time_parameter_update_is_vetted(config, node_role):
    # The observer-controller is vetted as both nodes are and estimates as the observer.
    dynamic = [spec for spec in node_parameters(node_role) if spec.dynamic]
    role = FEEDBACK if node_role == FEEDBACK else OBSERVER
    system = validate_parameters(load_parameter_file(str(config)))
    with ros_context('--params-file', str(config)) as context:
        node = {OBSERVER: ObserverNode, FEEDBACK: StateFeedbackNode,
                CONTROLLER: ObserverControllerNode}[node_role](context=context)
        driver = Driver(context)
        with executor_with(context, node, driver.node) as executor:
            assert spin_until(executor, lambda: node.count_publishers(
                'y' if role == OBSERVER else 'x_hat') >= 1 and driver.node.count_subscribers(
                'x_hat' if role == OBSERVER else 'u_cmd') >= 1, 10.0)
            clock = node.get_clock()
            outcomes = {'accepted': 0, 'refused': 0}

            @CAMPAIGN
            @given(st.data())
            def example(data):
                chosen = data.draw(st.lists(st.sampled_from(dynamic), min_size=1, max_size=3,
                                            unique_by=lambda spec: spec.name))
                parameters = [as_parameter(spec.name, value_for(spec, data))
                              for spec in chosen]
                before = node.current_parameters()
                design = (node.stream.estimator.design if role == OBSERVER
                          else node.feedback_part.law)
                accepted, reason = predicted(node, parameters)
                result = node.set_parameters_atomically(parameters)
                assert result.successful == accepted, (parameters, result.reason, reason)
                if not accepted:
                    outcomes['refused'] += 1
                    assert result.reason == reason
                    name = result.reason.split(':', 1)[0]
                    assert name in PARAMETER_SPECS, result.reason
                    assert node.current_parameters() == before
                    assert (node.stream.estimator.design if role == OBSERVER
                            else node.feedback_part.law) is design
                else:
                    outcomes['accepted'] += 1
                check_still_working(node, role, driver, executor, clock)

            example()
            assert outcomes['accepted'] > 0 and outcomes['refused'] > 0, outcomes
    assert system is not None


def check_still_working(node, role, driver, executor, clock):
    """Check that the node computes what its current parameters say, with finite values."""
    current = validate_parameters(node.current_parameters())
    base = clock.now().nanoseconds - 10 ** 9
    if role == OBSERVER:
        node.stream.reset()
        driver.estimates.clear()
        samples = [(base + k * PERIOD_NS, u, y)
                   for k, (_, u, y) in enumerate(plant_samples(current, 4))]
        reference = current.make_stream()
        expected = []
        model = current.model
        for index, (stamp, u, y) in enumerate(samples):
            driver.u.publish(message(stamp, model.input_names, u))
            driver.y.publish(message(stamp, model.output_names, y))
            reference.add_input(stamp, u)
            expected += reference.add_measurement(stamp, y)
            assert spin_until(executor, lambda: len(driver.estimates) > index, 5.0), (
                node.counters(), node.current_parameters())
        got = np.array([list(m.position) for m in driver.estimates])
        assert np.isfinite(got).all()
        assert np.array_equal(got, np.array([s.estimate for s in expected]))
        return
    from observer_ros.nodes.state_feedback import feedback_law
    law = feedback_law(current)
    estimate = np.array([0.3, -0.2])
    stamp = base
    driver.commands.clear()
    driver.x_hat.publish(message(stamp, current.model.state_names, estimate))
    assert spin_until(executor, lambda: any(stamp_to_ns(m.header.stamp) == stamp
                                            for m in driver.commands), 5.0)
    command = next(m for m in driver.commands if stamp_to_ns(m.header.stamp) == stamp)
    assert np.isfinite(command.position).all()
    assert np.array_equal(np.array(command.position), law.command(estimate, None))
