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
Namespaces and several observers: loops side by side, observers of two types on one y/u.

The nodes run as console scripts in their own processes, the way ``ros2 run`` starts them
(``--ros-args -r __ns:=/robot1``); recorders and a ``/diagnostics`` listener in the test
process listen over DDS. ``y``, ``u`` and ``x_hat`` are relative names, so they move into
the namespace; ``/diagnostics`` and ``/clock`` are absolute and stay global.
"""

import numpy as np

from conftest import CONFIG_DIR
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.evaluation import align
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.plant_simulator import PlantSimulatorNode
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.recorder import TopicRecorder
from ros_support import (
    DiagnosticsListener, executor_with, NodeProcess, overrides, ros_context, spin_until)

SEED003 = str(CONFIG_DIR / 'seed003_full_order.yaml')
KALMAN = str(CONFIG_DIR / 'kalman_noisy.yaml')
GLOBAL_TOPICS = ('/diagnostics', '/clock', '/parameter_events', '/rosout')


def _endpoint_names(node) -> set:
    names = {p.topic_name for p in node.publishers} | {s.topic_name for s in node.subscriptions}
    return {name for name in names if '/_action/' not in name}


def test_node_topics_are_relative_and_diagnostics_and_clock_global():
    with ros_context('--params-file', SEED003, '-r', '__ns:=/robot1') as context:
        sim_time = overrides(use_sim_time=True)
        nodes = [PlantSimulatorNode(context=context, parameter_overrides=overrides(
                     plant__lockstep=True)),
                 ObserverNode(context=context, parameter_overrides=sim_time),
                 StateFeedbackNode(context=context, parameter_overrides=sim_time)]
        try:
            names = {node.get_name(): _endpoint_names(node) for node in nodes}
            namespaces = {node.get_fully_qualified_name() for node in nodes}
        finally:
            for node in nodes:
                node.destroy_node()
    assert namespaces == {'/robot1/plant_simulator', '/robot1/observer',
                          '/robot1/state_feedback'}
    for node, topics in names.items():
        assert '/diagnostics' in topics, node
        outside = {t for t in topics if not t.startswith('/robot1/')} - set(GLOBAL_TOPICS)
        assert not outside, (node, outside)
    assert '/clock' in names['plant_simulator']  # the lockstep plant's clock is global
    assert '/clock' in names['observer']  # use_sim_time: the global clock
    assert {'/robot1/y', '/robot1/u', '/robot1/x_true', '/robot1/u_cmd'} <= names[
        'plant_simulator']
    assert {'/robot1/y', '/robot1/u', '/robot1/x_hat', '/robot1/innovation'} <= names['observer']
    assert {'/robot1/x_hat', '/robot1/reference', '/robot1/u_cmd'} <= names['state_feedback']


def _converged(recorder, settle_s: float, rms: bool = False) -> tuple:
    """
    Return (error after ``settle_s`` seconds, error at the start, true states).

    The error after: its largest norm, or with ``rms`` its root mean square (noisy plants).
    """
    stamps, truth, estimate = align(*recorder.arrays('x_true'), *recorder.arrays('x_hat'))
    times = (stamps - stamps[0]) / 1e9
    error = np.linalg.norm(truth - estimate, axis=1)
    late = error[times >= settle_s]
    return (np.sqrt(np.mean(late ** 2)) if rms else late.max()), error[0], truth


def test_two_namespaced_closed_loops_run_side_by_side_without_cross_talk():
    system = validate_parameters(load_parameter_file(SEED003))
    initial = {'/robot1': [0.5, -0.5], '/robot2': [-1.0, 1.0]}
    samples = 120
    with ros_context() as context:
        # The recorders subscribe to y too: each plant waits for its observer and recorder.
        recorders = {ns: TopicRecorder(system, ('y', 'x_true', 'x_hat'), node_name='recorder',
                                       namespace=ns, context=context) for ns in initial}
        listener = DiagnosticsListener(context=context)
        processes = [NodeProcess(
            'closed_loop', '--ros-args', '--params-file', SEED003, '-r', f'__ns:={ns}',
            '-p', f'plant.initial_state:={state}', '-p', 'observer.initial_state:=[0.0, 0.0]',
            '-p', 'plant.lockstep_subscribers:=2', '-p', 'diagnostics.period:=0.2')
            for ns, state in initial.items()]
        try:
            with executor_with(context, listener, *recorders.values()) as executor:
                done = spin_until(executor, lambda: all(
                    r.count('x_hat') >= samples and r.count('x_true') >= samples
                    for r in recorders.values()) and all(
                    listener.count(f'{ns}/observer: inputs') for ns in initial), 40.0)
                assert done, ({ns: r.count('x_hat') for ns, r in recorders.items()},
                              [p.stop() for p in processes])
                topics = {name for name, _ in recorders['/robot1'].get_topic_names_and_types()}
                publishers = {ns: {info.node_namespace + '/' + info.node_name for info in
                                   r.get_publishers_info_by_topic(f'{ns}/x_hat')}
                              for ns, r in recorders.items()}
        finally:
            outcomes = [process.stop() for process in processes]
    for code, _, err in outcomes:
        assert code == 0, err
    for ns in initial:
        assert {f'{ns}/{t}' for t in ('y', 'u', 'u_cmd', 'x_hat', 'x_true')} <= topics
        assert publishers[ns] == {f'{ns}/observer'}, publishers
        inputs = listener.latest(f'{ns}/observer: inputs')[2]
        assert not {'duplicate', 'out_of_order', 'future_stamp'} & set(inputs), inputs
        assert listener.count(f'{ns}/state_feedback: inputs')
        assert listener.count(f'{ns}/plant_simulator: inputs')
    assert not {'/y', '/u', '/x_hat', '/x_true', '/u_cmd'} & topics
    results = {ns: _converged(r, 0.6) for ns, r in recorders.items()}
    for ns, (late, start, truth) in results.items():
        # Each estimate starts at zero, away from its own plant, and converges to it.
        assert start > 0.2, (ns, start)
        assert late < 0.05 * start, (ns, late, start)
    first = results['/robot1'][2][0]
    second = results['/robot2'][2][0]
    assert np.linalg.norm(first - second) > 0.5  # the two plants are really different


def test_two_observers_of_different_types_on_one_measurement():
    system = validate_parameters(load_parameter_file(KALMAN))
    pinned = ['-p', 'observer.initial_state:=[0.0, 0.0]']
    observers = {
        'kalman_observer': ['-r', 'x_hat:=x_hat_kalman', '-r', 'innovation:=innovation_kalman'],
        'full_order_observer': ['-p', 'observer.type:=full_order',
                                '-p', "observer.poles:=['-8', '-9']",
                                '-r', 'x_hat:=x_hat_full_order',
                                '-r', 'innovation:=innovation_full_order']}
    estimates = {'kalman_observer': 'x_hat_kalman', 'full_order_observer': 'x_hat_full_order'}
    samples = 300
    with ros_context() as context:
        # The recorders subscribe to y too: the plant waits for them and the two observers.
        recorders = {name: TopicRecorder(system, ('y', 'x_true', 'x_hat'),
                                         node_name=f'rec_{name}',
                                         context=context,
                                         cli_args=['--ros-args', '-r', f'x_hat:={topic}'])
                     for name, topic in estimates.items()}
        # All at once: the plant starts when both observers and both recorders are there.
        processes = [NodeProcess('observer', '--ros-args', '--params-file', KALMAN,
                                 '-r', f'__node:={name}', *pinned, *args)
                     for name, args in observers.items()]
        processes.append(NodeProcess(
            'plant_simulator', '--ros-args', '--params-file', KALMAN,
            '-p', 'plant.wait_for_command:=false', '-p', 'plant.lockstep_subscribers:=4'))
        try:
            with executor_with(context, *recorders.values()) as executor:
                done = spin_until(executor, lambda: all(
                    r.count('x_hat') >= samples for r in recorders.values()), 30.0)
                assert done, [p.stop() for p in processes]
                owners = {name: {info.node_name for info in
                                 r.get_publishers_info_by_topic(f'/{estimates[name]}')}
                          for name, r in recorders.items()}
                nis = {info.node_name for info in
                       recorders['kalman_observer'].get_publishers_info_by_topic('/nis')}
                y_readers = {info.node_name for info in
                             recorders['kalman_observer'].get_subscriptions_info_by_topic('/y')}
        finally:
            outcomes = [process.stop() for process in processes]
    for code, _, err in outcomes:
        assert code == 0, err
    assert owners == {name: {name} for name in estimates}
    assert nis == {'kalman_observer'}
    assert y_readers == set(estimates) | {f'rec_{name}' for name in estimates}
    for name, recorder in recorders.items():
        # The Kalman filter's own poles are slow (-2.9 +- 3.5j) and the plant is noisy.
        # The plant starts at [1, 0], both estimates at [0, 0]: an initial error of 1 (a
        # recorder matched late may miss the first estimates, so not read off the record).
        initial = np.linalg.norm(system.parameters['plant.initial_state'])
        late, _, _ = _converged(recorder, 2.0, rms=True)
        assert late < 0.1 * initial, (name, late)
