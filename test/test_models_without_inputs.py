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
Models without inputs (``model.B`` empty, m = 0) and the estimated joint states.

A constant-velocity joint model measured in position: designed for every observer type,
estimated in the core, by the observer node over DDS with no ``u`` publisher (which also
publishes ``joint_states_hat``), and replayed from a robot-style ``/joint_states`` bag whose
recorded velocity ``replay --reference`` compares the estimate with.
"""

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
import yaml

from bag_support import JOINT_STATE, joint_state, serialize, STORAGES, TYPESTORE
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.replay_results import reference_rmse, StateReference
from observer_ros.config import validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.evaluation import settling_time
from observer_ros.core.model import StateSpaceModel
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.plant_simulator import PlantSimulatorNode
from observer_ros.ros.messages import JointStatesEncoder, ns_to_stamp, stamp_to_ns
from observer_ros.tools.design_observer import main as design_main
from observer_ros.tools.replay import main as replay_main
from ros_support import executor_with, overrides, ros_context, spin_until

PERIOD_NS = 10_000_000
#: Constant-velocity joint: q' = q_dot, q_dot' = 0, measured q (joint 'shoulder').
MODEL = {'model.A': [0.0, 1.0, 0.0, 0.0], 'model.B': [], 'model.C': [1.0, 0.0],
         'model.state_names': ['q', 'q_dot'], 'model.output_names': ['shoulder']}
TYPES = {'full_order': {'observer.poles': ['-20', '-25']},
         'reduced_order': {'observer.poles': ['-20']},
         'chen': {'observer.poles': ['-20']},
         'kalman': {'observer.process_noise': [0.0, 1.0], 'observer.measurement_noise': [1e-6]},
         'time_varying_kalman': {'observer.type': 'kalman', 'observer.time_varying': True,
                                 'observer.process_noise': [0.0, 1.0],
                                 'observer.measurement_noise': [1e-6],
                                 'observer.initial_covariance': [1.0, 1.0]}}


def params(kind, **extra):
    """Parameters of the constant-velocity model with an observer of ``kind``."""
    values = {**MODEL, 'observer.type': kind, **TYPES[kind]}
    values.update(extra)
    return values


@pytest.mark.parametrize('kind', sorted(TYPES))
def test_velocity_from_positions_alone_converges_for_every_type(kind):
    system = validate_parameters(params(kind))
    model = system.model
    assert (model.n_inputs, model.b.shape, model.d.shape) == (0, (2, 0), (1, 0))
    same = StateSpaceModel.from_matrices(model.a, [], model.c)
    assert same.b.shape == (2, 0) and same.input_names == ()
    stream = system.make_stream()
    velocity, samples = 0.7, []
    for k in range(150):  # nothing waits for an input: one estimate per measurement
        samples += stream.add_measurement(k * PERIOD_NS, [0.2 + velocity * k * 0.01])
        assert len(samples) == k + 1
    assert stream.pending == 0
    assert abs(samples[-1].estimate[1] - velocity) < 1e-6
    assert abs(samples[-1].estimate[0] - (0.2 + velocity * 1.49)) < 1e-9
    counters = stream.counters
    assert counters['no_input'] == counters['late_input'] == 0
    # The batch replay gives the same numbers from the measurements alone.
    again = system.make_stream().replay(np.zeros(0, np.int64), np.zeros((0, 0)),
                                        [s.stamp_ns for s in samples],
                                        [[0.2 + velocity * k * 0.01] for k in range(150)])
    assert np.array_equal(again.estimates, np.array([s.estimate for s in samples]))


@pytest.mark.parametrize('name, value, parameter, text', [
    ('feedback.poles', ['-1', '-2'], 'feedback.poles', 'no inputs'),
    ('plant.input_limits', [-1.0, 1.0], 'plant.input_limits', 'no inputs'),
    ('plant.lockstep', True, 'plant.lockstep', 'no command to wait for'),
    ('model.D', [1.0], 'model.D', 'expected 1x0'),
])
def test_what_needs_inputs_says_so(name, value, parameter, text):
    with pytest.raises(ConfigError, match=text) as caught:
        validate_parameters(params('full_order', **{name: value}))
    assert caught.value.parameter == parameter


@pytest.mark.parametrize('extra, parameter, text', [
    ({'observer.joint_names': ['shoulder'], 'observer.joint_velocity_states': ['q_ddot']},
     'observer.joint_velocity_states', "'q_ddot' is no state"),
    ({'observer.joint_names': ['a', 'b'], 'observer.joint_position_states': ['q']},
     'observer.joint_position_states', 'expected 2 states'),
    ({'observer.joint_position_states': ['q']}, 'observer.joint_position_states',
     'needs observer.joint_names'),
    ({'observer.joint_names': ['shoulder']}, 'observer.joint_names', 'at least one field'),
])
def test_joint_state_selection_is_validated(extra, parameter, text):
    with pytest.raises(ConfigError, match=text) as caught:
        validate_parameters(params('full_order', **extra))
    assert caught.value.parameter == parameter


def test_joint_states_take_state_names_or_indices():
    system = validate_parameters(params(
        'full_order', **{'observer.joint_names': ['shoulder', 'copy'],
                         'observer.joint_position_states': ['q', '0'],
                         'observer.joint_velocity_states': ['q_dot', '1']}))
    selection = system.observer.joint_states
    assert (selection.position, selection.velocity, selection.effort) == ((0, 0), (1, 1), ())
    raw = JointStatesEncoder(selection).encode(3_000_000_001, np.array([1.25, -4.0]))
    message = deserialize_message(raw, JointState)
    assert (message.header.stamp.sec, message.header.stamp.nanosec) == (3, 1)
    assert list(message.position) == [1.25, 1.25] and list(message.velocity) == [-4.0, -4.0]
    assert list(message.effort) == []


def test_observer_node_without_u_publishes_x_hat_and_joint_states_hat():
    values = params('full_order', **{'observer.joint_names': ['shoulder'],
                                     'observer.joint_position_states': ['q'],
                                     'observer.joint_velocity_states': ['q_dot']})
    system = validate_parameters(values)
    with ros_context() as context:
        observer = ObserverNode(context=context, parameter_overrides=overrides(
            **{name.replace('.', '__'): value for name, value in values.items()}))
        driver = Node('driver', context=context)
        y = driver.create_publisher(JointState, 'y', 10)
        estimates, joints = [], []
        driver.create_subscription(JointState, 'x_hat', estimates.append, 100)
        driver.create_subscription(JointState, 'joint_states_hat', joints.append, 100)
        with executor_with(context, observer, driver) as executor:
            assert observer.count_subscribers('u') == 0  # no input topic at all
            assert spin_until(executor, lambda: observer.count_publishers('y') >= 1
                              and observer.count_subscribers('joint_states_hat') >= 1
                              and observer.count_subscribers('x_hat') >= 1, 10.0)
            stream = system.make_stream()
            expected = []
            for k in range(60):
                stamp = 2_000_000_000 + k * PERIOD_NS
                message = JointState(name=['elbow', 'shoulder'], position=[9.0, 0.5 * k * 0.01])
                ns_to_stamp(message.header.stamp, stamp)
                y.publish(message)
                expected += stream.add_measurement(stamp, [0.5 * k * 0.01])
                assert spin_until(executor, lambda: len(joints) >= k + 1
                                  and len(estimates) >= k + 1, 5.0), k
    assert len(estimates) == len(joints) == len(expected) == 60
    for estimate, joint, sample in zip(estimates, joints, expected):
        assert estimate.header.stamp == joint.header.stamp
        stamp = joint.header.stamp.sec * 10**9 + joint.header.stamp.nanosec
        assert stamp == sample.stamp_ns
        assert list(joint.name) == ['shoulder']
        assert list(joint.position) == [sample.estimate[0]] == [estimate.position[0]]
        assert list(joint.velocity) == [sample.estimate[1]] == [estimate.position[1]]
        assert list(joint.effort) == []
    assert abs(joints[-1].velocity[0] - 0.5) < 1e-4  # 0.6 s after a start at rest


def test_autonomous_plant_and_observer_run_without_any_input_topic():
    values = params('full_order', **{'plant.initial_state': [0.1, 0.5], 'plant.samples': 40})
    system = validate_parameters(values)
    settings = overrides(**{name.replace('.', '__'): value for name, value in values.items()})
    with ros_context() as context:
        plant = PlantSimulatorNode(context=context, parameter_overrides=settings)
        observer = ObserverNode(context=context, parameter_overrides=settings)
        driver = Node('driver', context=context)
        estimates, truth, measured = [], [], []
        driver.create_subscription(JointState, 'x_hat', estimates.append, 100)
        driver.create_subscription(JointState, 'x_true', truth.append, 100)
        driver.create_subscription(JointState, 'y', measured.append, 100)
        with executor_with(context, plant, observer, driver) as executor:
            assert plant.command_subscription is None and 'u' not in plant.publishers_
            assert spin_until(executor, lambda: plant.finished.done() and len(estimates) >= 40
                              and len(truth) >= 40 and len(measured) >= 40, 15.0), (
                len(estimates), len(truth), len(measured))
            assert plant.count_publishers('u') == 0 and plant.count_subscribers('u_cmd') == 0
    counters = plant.counters
    assert counters['samples'] == 40 and counters.get('safe_input_samples', 0) == 0
    assert counters.get('started_without_peers', 0) == 0  # no command was waited for
    final = np.array(truth[-1].position)
    # The plant simulates the time between its stamps (whole periods, skipped ones too).
    span = (stamp_to_ns(truth[-1].header.stamp) - stamp_to_ns(truth[0].header.stamp)) / 1e9
    assert final == pytest.approx([0.1 + 0.5 * span, 0.5], abs=1e-12)
    # The node's estimates are the core's from the same measurements, bit for bit.
    stream, expected = system.make_stream(), []
    for message in measured:
        stamp = message.header.stamp.sec * 10**9 + message.header.stamp.nanosec
        expected += stream.add_measurement(stamp, list(message.position))
    assert [list(m.position) for m in estimates] == [s.estimate.tolist() for s in expected]
    assert np.array(estimates[-1].position) == pytest.approx(final, abs=1e-3)


def test_design_cli_prints_a_model_without_inputs_and_refuses_feedback(tmp_path, capsys):
    section = {'model': {'A': [0.0, 1.0, 0.0, 0.0], 'B': [], 'C': [1.0, 0.0]},
               'observer': {'type': 'reduced_order', 'poles': ['-20']}}
    file = tmp_path / 'cv.yaml'
    file.write_text(yaml.safe_dump({'/**': {'ros__parameters': section}}))
    assert design_main([str(file)]) == 0
    out = capsys.readouterr().out
    assert 'n = 2, m = 0, p = 1' in out and 'Fhat = Bb - L Ba = (empty: 1 x 0)' in out
    section['feedback'] = {'poles': ['-1', '-2']}
    file.write_text(yaml.safe_dump({'/**': {'ros__parameters': section}}))
    assert design_main([str(file)]) == 2
    assert capsys.readouterr().err.strip() == (
        'design_observer: error: feedback.poles: the model has no inputs (model.B is empty, '
        'm = 0): state feedback is not available')


def write_joint_bag(path, storage, samples=400):
    """Record a robot's /joint_states: joint 'shoulder' swinging, its velocity recorded."""
    from rosbags.rosbag2 import Writer
    times = np.arange(samples) * 0.01
    position = 0.4 * np.sin(2.0 * times)
    velocity = 0.8 * np.cos(2.0 * times)
    start = 1_700_000_000 * 10**9
    with Writer(path, version=9, storage_plugin=STORAGES[storage]) as writer:
        joints = writer.add_connection('/joint_states', JOINT_STATE, typestore=TYPESTORE)
        for k in range(samples):
            stamp = start + k * PERIOD_NS
            writer.write(joints, stamp + 2000, serialize(joint_state(
                stamp, ['wrist', 'shoulder'], [0.1, position[k]], [0.0, velocity[k]],
                [0.0, 0.3])))
    return velocity


@pytest.mark.parametrize('storage', sorted(STORAGES))
def test_replay_of_joint_states_reports_the_velocity_rmse(tmp_path, storage, capsys):
    velocity = write_joint_bag(tmp_path / 'robot', storage)
    file = tmp_path / 'cv.yaml'
    section = {'model': {'A': [0.0, 1.0, 0.0, 0.0], 'B': [], 'C': [1.0, 0.0],
                         'state_names': ['q', 'q_dot'], 'output_names': ['shoulder']},
               'observer': {'type': 'full_order', 'poles': ['-40', '-50']}}
    file.write_text(yaml.safe_dump({'/**': {'ros__parameters': section}}))
    result = replay_bag(tmp_path / 'robot', file, y_topic='/joint_states')
    assert len(result.stamps_ns) == 400 and result.counters.get('no_input', 0) == 0
    settle = settling_time(result.system.observer.design.achieved_poles)
    reference = StateReference.parse('q_dot=/joint_states:velocity:shoulder')
    rmse, count = reference_rmse(result, reference, settle)
    late = result.stamps_ns >= result.stamps_ns[0] + settle * 1e9
    direct = np.sqrt(np.mean((result.estimates[late, 1] - velocity[late]) ** 2))
    assert count == late.sum() and rmse == pytest.approx(direct, rel=1e-12)
    # The swing's acceleration -1.6 sin(2 t) drives the velocity error through
    # (s + l1) / (s^2 + l1 s + l2) of the continuous design: its RMS is what replay reports.
    l1, l2 = np.ravel(result.system.observer.design.gain)
    s = 2.0j
    predicted = 1.6 * abs((s + l1) / (s * s + l1 * s + l2)) / np.sqrt(2.0)
    assert rmse == pytest.approx(predicted, rel=0.1), (rmse, predicted)
    assert replay_main([str(tmp_path / 'robot'), str(file), '--y-topic', '/joint_states',
                        '--reference', 'q_dot=/joint_states:velocity:shoulder']) == 0
    line = [text for text in capsys.readouterr().out.splitlines()
            if text.startswith('q_dot: RMSE')]
    assert line == [f'q_dot: RMSE {rmse:.6g} against /joint_states velocity of shoulder '
                    f'({count} estimates, after {settle:g} s)']
    # A model without inputs takes no input topic; a bad --reference is named.
    assert replay_main([str(tmp_path / 'robot'), str(file), '--y-topic', '/joint_states',
                        '--u-topic', '/u']) == 2
    assert replay_main([str(tmp_path / 'robot'), str(file), '--y-topic', '/joint_states',
                        '--reference', 'q_dot=/joint_states:speed:shoulder']) == 2
    errors = capsys.readouterr().err.splitlines()
    assert errors[0].startswith('replay: error: --u-topic: the model has no inputs')
    assert errors[1].startswith('replay: error: --reference: expected a field in')
