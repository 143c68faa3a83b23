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
The shipped robot-joint recipe (``config/robot_joint.yaml``, README Recipe) run three ways.

A DC motor joint ``shoulder`` behind a gearbox with an unknown load torque (a constant input
disturbance, picked up at :data:`LOAD_TIME`), position measured, effort commanded as a
``Float64MultiArray``; the observer estimates ``q``, ``q_dot`` and the load and publishes them
on ``joint_states_hat``; the servo (integral action on ``q``) tracks a position step. It runs
(1) in lockstep as ``closed_loop`` (one process), (2) as three console-script processes in
lockstep remapped to ``/joint_states`` and the command topic, and (3) offline over a
robot-style bag of the same run, with the same numbers.
"""

import subprocess

import numpy as np
import pytest
from rclpy.node import Node
from rosbags.rosbag2 import Writer
from sensor_msgs.msg import JointState

from bag_support import (float64_array, FLOAT64_MULTI_ARRAY, JOINT_STATE, joint_state,
                         serialize, STORAGES, TYPESTORE)
from conftest import CONFIG_DIR, console_script
from observer_ros.bags.replay import replay_bag
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.design.integral import augmented_pair
from observer_ros.core.evaluation import align
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.recorder import TopicRecorder
from ros_support import (
    executor_with, NodeProcess, patient_lockstep, PROCESS_START, ros_context, run_lockstep,
    spin_until)

CONFIG = 'robot_joint.yaml'
SAMPLES = 800
#: The position reference (rad) and the payload's load torque (N m) the plant applies.
STEP, LOAD, LOAD_TIME = 1.0, -2.0, 2.0
#: After this many seconds the position error is below 1e-6 (slowest loop pole -6).
SETTLED = 6.0
#: Seconds after the load step when the load estimate is within 1e-6 (slowest pole -20).
LOAD_SETTLED = 1.5
#: The robot's topics: joint states, and the effort on the forward command controller's topic.
JOINT_STATES, COMMANDS = '/joint_states', '/effort_controller/commands'
#: Where the simulated robot takes the servo's command (see README, Recipe).
SERVO_COMMAND = '/shoulder_servo/commands'


@pytest.fixture(scope='module')
def lockstep():
    """Run the recipe in lockstep as ``closed_loop`` does: ``(system, arrays, counters)``."""
    system, _, arrays, counters = run_lockstep(CONFIG, SAMPLES, reference=[STEP])
    return system, arrays, counters


def times_of(stamps):
    """Seconds since the first sample."""
    return (stamps - stamps[0]) / 1e9


def test_recipe_config_is_the_documented_joint():
    system = validate_parameters(load_parameter_file(str(CONFIG_DIR / CONFIG)), strict=True)
    assert system.model.state_names == ('q', 'q_dot', 'load')
    assert system.parameters['topics.u.type'] == 'float64_multi_array'
    plant = system.augmentation.plant
    # J = 0.25 kg m^2, b = 0.5 N m s/rad: q_dot' = -(b / J) q_dot + u / J.
    assert plant.a.tolist() == [[0.0, 1.0], [0.0, -2.0]] and plant.b.ravel().tolist() == [0, 4]
    # The load is a state of the simulated plant (it enters through B like the effort).
    assert system.plant.disturbance.tolist() == [LOAD] and system.plant.input_offset is None
    joints = system.observer.joint_states
    assert joints.names == ('shoulder',)
    assert (joints.position, joints.velocity, joints.effort) == ((0,), (1,), (2,))


def test_integral_action_with_a_load_model_feeds_back_k_and_zero_on_the_estimate():
    system = validate_parameters(load_parameter_file(str(CONFIG_DIR / CONFIG)))
    feedback = system.feedback
    integral = feedback.integral
    # Designed on the plant (n = 2), not on the augmented model with the load state.
    a, b = augmented_pair(system.augmentation.plant, integral.outputs)
    closed = a - b @ np.hstack([integral.gain, -integral.integral_gain])
    assert np.allclose(np.sort(np.linalg.eigvals(closed).real), [-9.0, -8.0, -6.0])
    np.testing.assert_allclose(integral.gain, [[43.5, 5.25]], rtol=1e-9)  # README, Recipe
    np.testing.assert_allclose(integral.integral_gain, [[108.0]], rtol=1e-9)
    # [K, 0]: the integrator, not a load cancellation, removes the offset.
    assert feedback.estimate_gain.shape == (1, 3)
    np.testing.assert_array_equal(feedback.estimate_gain, np.hstack([integral.gain, [[0.0]]]))
    # The node applies exactly that to the three-state x_hat, and integrates the measured y.
    with ros_context('--params-file', str(CONFIG_DIR / CONFIG)) as context:
        node = StateFeedbackNode(context=context)
        try:
            np.testing.assert_array_equal(node.feedback_part.law.gain, feedback.estimate_gain)
            np.testing.assert_array_equal(node.feedback_part.law.integral.gain,
                                          integral.integral_gain)
            assert node.measurement_subscription is not None
            estimate = np.array([0.25, -1.0, -2.0])  # q, q_dot, load
            node.feedback_part.law.integral.measure(0, [0.25])
            command = node.feedback_part.law.command(estimate, np.array([STEP]), 0)
            assert command[0] == pytest.approx(-(integral.gain @ estimate[:2])[0])
        finally:
            node.destroy_node()


def test_lockstep_closed_loop_tracks_the_step_under_the_load(lockstep):
    system, arrays, counters = lockstep
    assert counters.get('lockstep_timeouts', 0) == 0
    # Every unstamped (Float64MultiArray) command that ended a lockstep wait was the one
    # computed from the previous sample, and is counted as such.
    assert counters['commands_on_time'] == SAMPLES - 1
    stamps, truth, estimate = align(*arrays['x_true'], *arrays['x_hat'])
    assert truth.shape == estimate.shape == (SAMPLES, 3)
    times = times_of(stamps)
    assert np.all(truth[times < LOAD_TIME - 1e-9, 2] == 0.0)
    assert np.all(truth[times >= LOAD_TIME - 1e-9, 2] == LOAD)
    # The load estimate converges to the applied load.
    late = times > LOAD_TIME + LOAD_SETTLED
    assert np.abs(estimate[late, 2] - LOAD).max() < 1e-6
    # Zero steady-state error under the load; the servo holds the load: u = -load.
    y, u = arrays['y'][1][:, 0], arrays['u'][1][:, 0]
    assert np.abs(y[times >= SETTLED] - STEP).max() < 1e-6
    assert np.abs(y - STEP).max() > 0.5  # it did move: from 0 to the step
    assert u[-1] == pytest.approx(-LOAD, abs=1e-6)
    # README's table (Recipe: measured): the dip under the load, the peak effort, and when
    # the load estimate and the position come within 1e-6.
    dip = STEP - y[times >= LOAD_TIME].min()
    assert 0.05 < dip < 0.07 and np.abs(u).max() < 4.5, (dip, np.abs(u).max())
    load_error = np.abs(estimate[:, 2] - truth[:, 2])
    assert times[np.nonzero(load_error >= 1e-6)[0][-1] + 1] < LOAD_TIME + 1.0
    assert times[np.nonzero(np.abs(y - STEP) >= 1e-6)[0][-1] + 1] < 4.5


def robot_process(executable, *args):
    """Start a console-script node on the recipe with the robot's topic names."""
    remaps = ['-r', f'y:={JOINT_STATES}', '-r', f'u:={COMMANDS}', '-r', f'u_cmd:={SERVO_COMMAND}']
    return NodeProcess(executable, '--ros-args', '--params-file', str(CONFIG_DIR / CONFIG),
                       *remaps, *patient_lockstep(executable), *args)


class JointStatesHat(Node):
    """Keep every ``/joint_states_hat`` message."""

    def __init__(self, **kwargs) -> None:
        super().__init__('joint_states_hat_listener', **kwargs)
        self.messages = []
        self.subscription = self.create_subscription(JointState, '/joint_states_hat',
                                                     self.messages.append, 1000)


def test_three_processes_equal_the_lockstep_loop_and_publish_joint_states_hat(lockstep):
    system, one_process, _ = lockstep
    topics = ('y', 'u', 'x_true', 'x_hat')
    remaps = ('-r', f'y:={JOINT_STATES}', '-r', f'u:={COMMANDS}')
    with ros_context(*remaps) as context:
        recorder = TopicRecorder(system, topics, context=context)
        hat = JointStatesHat(context=context)
        helper = Node('reference_publisher', context=context)
        reference = helper.create_publisher(JointState, 'reference', 10)
        helper.create_timer(0.01, lambda: reference.publish(
            JointState(name=['shoulder'], position=[STEP])))
        with executor_with(context, recorder, hat, helper) as executor:
            sim_time = ('-p', 'use_sim_time:=true')
            processes = [robot_process('observer', *sim_time),
                         robot_process('state_feedback', *sim_time)]
            x_hat = next(s for s in recorder.subscriptions if s.topic_name == '/x_hat')
            try:
                # Before the plant starts: the observer publishes x_hat and joint_states_hat,
                # the state feedback listens to x_hat and to the reference.
                assert spin_until(executor, lambda: x_hat.get_publisher_count() > 0
                                  and hat.subscription.get_publisher_count() > 0
                                  and recorder.count_subscribers('/x_hat') >= 2
                                  and reference.get_subscription_count() > 0,
                                  PROCESS_START), (
                    [p.stop() for p in processes])
                processes.append(robot_process(
                    'plant_simulator', '-p', 'plant.lockstep:=true',
                    '-p', f'plant.samples:={SAMPLES}', '-p', 'plant.lockstep_subscribers:=3'))
                plant = processes[-1].process
                spin_until(executor, lambda: plant.poll() is not None, 60.0)
                spin_until(executor, lambda: recorder.count('x_hat') >= SAMPLES
                           and len(hat.messages) >= SAMPLES, 2.0)
                assert plant.poll() == 0, processes[-1].stop()
            finally:
                outcomes = [process.stop() for process in processes]
            arrays = {topic: recorder.arrays(topic) for topic in topics}
            messages = list(hat.messages)
    for code, _, err in outcomes:
        assert code == 0, err
    assert 'lockstep: no command' not in outcomes[-1][2]
    for topic in topics:
        assert len(arrays[topic][0]) == SAMPLES, topic
        assert np.array_equal(arrays[topic][1], one_process[topic][1]), topic
        if topic != 'u':  # u is unstamped: the recorder stamps it on arrival
            assert np.array_equal(arrays[topic][0], one_process[topic][0]), topic
    # joint_states_hat: joint 'shoulder' with q, q_dot and the load, stamped like x_hat.
    assert len(messages) == SAMPLES
    stamps = np.array([m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in messages])
    np.testing.assert_array_equal(stamps, arrays['x_hat'][0])
    assert all(list(m.name) == ['shoulder'] for m in messages)
    fields = np.array([[m.position[0], m.velocity[0], m.effort[0]] for m in messages])
    np.testing.assert_array_equal(fields, arrays['x_hat'][1])
    assert fields[-1, 2] == pytest.approx(LOAD, abs=1e-6)


def write_recorded_bag(path, arrays, storage):
    """
    Write the run as a robot records it: ``/joint_states`` and unstamped commands.

    Recorded on the simulation clock (``ros2 bag record --use-sim-time``): the joint states
    hold three joints (``shoulder`` measured, its velocity and effort too) stamped and logged
    at the sample time; the command in effect from a sample on is logged at that sample.
    """
    stamps, outputs = arrays['y']
    truth, inputs = arrays['x_true'][1], arrays['u'][1]
    with Writer(path, version=9, storage_plugin=STORAGES[storage]) as writer:
        joints = writer.add_connection(JOINT_STATES, JOINT_STATE, typestore=TYPESTORE)
        commands = writer.add_connection(COMMANDS, FLOAT64_MULTI_ARRAY, typestore=TYPESTORE)
        for stamp, y, x, u in zip(stamps.tolist(), outputs, truth, inputs):
            writer.write(commands, stamp, serialize(float64_array(u)))
            writer.write(joints, stamp, serialize(joint_state(
                stamp, ['elbow', 'shoulder', 'wrist'], [0.3, y[0], -0.1], [0.0, x[1], 0.0],
                [0.0, u[0], 0.0])))


@pytest.mark.parametrize('storage', sorted(STORAGES))
def test_replay_of_a_robot_bag_equals_the_online_estimates(lockstep, tmp_path, storage):
    _, arrays, _ = lockstep
    bag = tmp_path / 'robot'
    write_recorded_bag(bag, arrays, storage)
    result = replay_bag(bag, CONFIG_DIR / CONFIG, y_topic=JOINT_STATES, u_topic=COMMANDS)
    np.testing.assert_array_equal(result.stamps_ns, arrays['x_hat'][0])
    np.testing.assert_array_equal(result.estimates, arrays['x_hat'][1])


def test_replay_tool_writes_the_online_estimates(lockstep, tmp_path):
    _, arrays, _ = lockstep
    bag, csv = tmp_path / 'robot', tmp_path / 'x_hat.csv'
    write_recorded_bag(bag, arrays, 'mcap')
    run = subprocess.run([console_script('replay'), str(bag), str(CONFIG_DIR / CONFIG),
                          '--y-topic', JOINT_STATES, '--u-topic', COMMANDS, '--csv', str(csv)],
                         capture_output=True, text=True, timeout=60)
    assert run.returncode == 0, run.stderr
    lines = csv.read_text().splitlines()
    assert lines[0] == 'stamp_ns,event,q,q_dot,load,innovation_shoulder'
    rows = [line.split(',') for line in lines[1:]]
    np.testing.assert_array_equal([int(row[0]) for row in rows], arrays['x_hat'][0])
    assert {row[1] for row in rows} == {'y'}
    np.testing.assert_array_equal([[float(v) for v in row[2:5]] for row in rows],
                                  arrays['x_hat'][1])
