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
The console-script nodes as separate processes, the way ``ros2 run`` starts them.

A recorder in the test process listens over DDS (same isolated domain).
"""

import subprocess

import numpy as np
import pytest

from conftest import CONFIG_DIR, console_script
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.evaluation import align, decay_rate, settling_time
from observer_ros.ros.recorder import TopicRecorder
from ros_support import (
    executor_with, NodeProcess, patient_lockstep, PROCESS_START, ros_context, run_lockstep,
    spin_until)

EXECUTABLES = ('plant_simulator', 'observer', 'state_feedback', 'observer_controller',
               'closed_loop')


@pytest.mark.parametrize('executable', EXECUTABLES)
def test_bad_configuration_exits_2_with_one_line(tmp_path, executable):
    bad = tmp_path / 'bad.yaml'
    bad.write_text((CONFIG_DIR / 'seed003_full_order.yaml').read_text().replace(
        'B: [0.0, 1.0]', 'B: [0.0, 1.0, 2.0]'))
    result = subprocess.run([console_script(executable), '--ros-args', '--params-file', str(bad)],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2, result.stderr
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f'{executable}: error: model.B: expected'), lines[0]


@pytest.mark.parametrize('executable', EXECUTABLES)
def test_unknown_executor_or_argument_exits_2_naming_it(executable):
    for args, expected in ((['--executor', 'fast'], "argument --executor: invalid choice: 'fast'"),
                           (['--fast'], 'unrecognized arguments: --fast')):
        result = subprocess.run([console_script(executable), *args, '--ros-args', '--params-file',
                                 str(CONFIG_DIR / 'seed003_full_order.yaml')],
                                capture_output=True, text=True, timeout=60)
        assert result.returncode == 2, result.stderr
        assert f'{executable}: error: {expected}' in result.stderr, result.stderr


def test_node_without_its_section_names_the_missing_parameter(tmp_path):
    result = subprocess.run(
        [console_script('state_feedback'), '--ros-args', '--params-file',
         str(CONFIG_DIR / 'seed000_reduced_order.yaml')],
        capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stderr.strip().startswith('state_feedback: error: feedback.gain'), (
        result.stderr)


@pytest.mark.parametrize('config', ['seed000_reduced_order.yaml', 'seed001_fourth_order.yaml',
                                    'seed004_error_spec.yaml'])
def test_real_time_plant_and_observer_processes(config):
    path = str(CONFIG_DIR / config)
    system = validate_parameters(load_parameter_file(path))
    settle = settling_time(system.observer.design.achieved_poles, system.model.dt)
    rate = decay_rate(system.observer.design.achieved_poles, system.model.dt)
    duration = settle + 1.0
    # Pinned at zero: the first measurement alone would already give this plant's state.
    pinned = f'observer.initial_state:={[0.0] * system.model.n_states}'
    with ros_context() as context:
        # The recorder subscribes y too, and the plant waits for two subscribers on y (the
        # observer's and the recorder's): it starts once it knows the recorder, so x_true is
        # recorded from its first sample (discovery can take seconds).
        recorder = TopicRecorder(system, ('x_true', 'x_hat', 'y'), context=context)
        x_hat = next(s for s in recorder.subscriptions if s.topic_name == '/x_hat')
        processes = [NodeProcess('observer', '--ros-args', '--params-file', path, '-p', pinned)]
        try:
            with executor_with(context, recorder) as executor:
                # The recorder is matched to x_hat before the plant starts, so it receives
                # the observer's first estimate (discovery can take seconds).
                assert spin_until(executor, lambda: x_hat.get_publisher_count() > 0,
                                  PROCESS_START), (
                    processes[0].stop())
                processes.append(
                    NodeProcess('plant_simulator', '--ros-args', '--params-file', path,
                                '-p', 'plant.wait_for_command:=false',
                                '-p', 'plant.lockstep_subscribers:=2'))
                started = spin_until(executor, lambda: recorder.count('x_hat') > 0 and
                                     recorder.count('x_true') > 0, PROCESS_START)
                assert started, [p.stop() for p in processes]
                # The plant's stamps are its simulated time, which falls behind the wall
                # clock on a loaded machine: wait for `duration` of them (bounded).

                def covered() -> bool:
                    stamps = recorder.stamps['x_hat']
                    return (stamps[-1] - stamps[0]) / 1e9 > duration

                assert spin_until(executor, covered, 3 * duration + 10.0)
                truth = recorder.arrays('x_true')
                estimate = recorder.arrays('x_hat')
        finally:
            outcomes = [process.stop() for process in processes]
    for code, _, err in outcomes:
        assert code == 0, err
    observer_start = estimate[0][0]
    stamps, truth, estimate = align(*truth, *estimate)
    assert len(stamps) > 0.8 * duration * system.plant.rate_hz
    assert np.all(np.diff(stamps) > 0)
    times = (stamps - observer_start) / 1e9
    error = np.linalg.norm(truth - estimate, axis=1)
    window = (times >= settle) & (error > 1e-9 * error.max())
    t1, t2 = times[window][0], times[window][-1]
    measured = np.log(error[window][0] / error[window][-1]) / (t2 - t1)
    assert measured >= 0.7 * rate, (measured, rate)
    assert error[-1] < 0.05 * error.max()


@pytest.mark.parametrize('executor', ['events', 'single'])
def test_three_processes_in_lockstep_equal_the_one_process_loop(executor):
    config = 'seed003_full_order.yaml'
    path = str(CONFIG_DIR / config)
    choice = ['--executor', executor]
    samples = 200
    system = validate_parameters(load_parameter_file(path))
    with ros_context() as context:
        recorder = TopicRecorder(system, ('y', 'u', 'x_true', 'x_hat'), context=context)
        with executor_with(context, recorder) as executor:
            sim_time = ['-p', 'use_sim_time:=true']
            processes = [
                NodeProcess('observer', *choice, '--ros-args', '--params-file', path, *sim_time),
                NodeProcess('state_feedback', *choice, '--ros-args', '--params-file', path,
                            *sim_time, *patient_lockstep('state_feedback'))]
            x_hat = next(s for s in recorder.subscriptions if s.topic_name == '/x_hat')
            try:
                # The lockstep plant waits for its own peers only: the recorder is matched to
                # the observer's x_hat first and sees the state feedback's x_hat subscription.
                assert spin_until(executor, lambda: x_hat.get_publisher_count() > 0
                                  and recorder.count_subscribers('/x_hat') >= 2, PROCESS_START)
                processes.append(NodeProcess(
                    'plant_simulator', *choice, '--ros-args', '--params-file', path,
                    '-p', 'plant.lockstep:=true', '-p', f'plant.samples:={samples}',
                    '-p', 'plant.lockstep_subscribers:=2',
                    *patient_lockstep('plant_simulator')))
                plant = processes[-1].process
                spin_until(executor, lambda: plant.poll() is not None, 60.0)
                spin_until(executor, lambda: recorder.count('x_hat') >= samples, 2.0)
                assert plant.poll() == 0, processes[-1].stop()
            finally:
                outcomes = [process.stop() for process in processes]
            arrays = {topic: recorder.arrays(topic) for topic in ('y', 'u', 'x_true', 'x_hat')}
    for code, _, err in outcomes:
        assert code == 0, err
    assert 'lockstep: no command' not in outcomes[-1][2]
    one_process = run_lockstep(config, samples)[2]
    for topic in ('y', 'u', 'x_true', 'x_hat'):
        assert len(arrays[topic][0]) == samples, topic
        assert np.array_equal(arrays[topic][0], one_process[topic][0]), topic
        assert np.array_equal(arrays[topic][1], one_process[topic][1]), topic
