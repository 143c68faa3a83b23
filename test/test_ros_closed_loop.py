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
The one-process closed loop over DDS, in lockstep, for every shipped config with feedback.

Checks that ``x_hat`` converges to ``x_true`` at the designed rate, that the loop is stable,
that the node's estimates equal the core estimator run offline on the same samples bit for
bit, that lockstep runs repeat exactly, and that a step reference is tracked.
"""

import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.qos import ReliabilityPolicy

from observer_ros.core.evaluation import align, decay_rate, settling_time
from observer_ros.ros.recorder import RECORDER_DEPTH
from ros_support import offline_estimates, overrides, run_lockstep

CLOSED_LOOP_CONFIGS = ['seed001_third_order.yaml', 'seed001_third_order_chen.yaml',
                       'seed001_fourth_order_chen.yaml', 'seed003_full_order.yaml',
                       'kalman_noisy.yaml']


@pytest.mark.parametrize('config', CLOSED_LOOP_CONFIGS)
def test_estimate_converges_at_the_designed_rate_and_loop_is_stable(config):
    system, recorder, arrays, counters = run_lockstep(config, samples=400)
    assert counters['samples'] == 400
    assert counters.get('lockstep_timeouts', 0) == 0
    assert counters['commands_on_time'] == 399
    stamps, truth, estimate = align(*arrays['x_true'], *arrays['x_hat'])
    assert len(stamps) == 400
    times = (stamps - stamps[0]) / 1e9
    error = np.linalg.norm(truth - estimate, axis=1)
    poles = system.observer.design.achieved_poles
    rate = decay_rate(poles, system.model.dt)
    settle = settling_time(poles, system.model.dt)
    if system.observer.design.kind == 'kalman':
        # Noisy plant: the error settles at the filter's noise floor.
        floor = np.sqrt(np.trace(system.observer.make_estimator().design.step(
            system.plant.period_ns).covariance))
        late = error[times > settle]
        assert np.sqrt(np.mean(late ** 2)) < 2.0 * floor
    else:
        window = (times >= settle) & (error > 1e-9 * error[0])
        t1, t2 = times[window][0], times[window][-1]
        e1, e2 = error[window][0], error[window][-1]
        measured = np.log(e1 / e2) / (t2 - t1)
        assert measured >= 0.7 * rate, (measured, rate)
        assert error[-1] < 1e-6 * max(error[0], 1e-3)
    # The loop is stable: after its transient the state decays (to the noise level for the
    # noisy plant).
    norms = np.linalg.norm(truth, axis=1)
    assert norms[-40:].max() < 0.25 * norms.max()
    assert np.all(system.loop.closed_loop_poles.real < 0)
    # The node computed exactly what the core computes from the same samples.
    offline_stamps, offline = offline_estimates(system, recorder)
    assert np.array_equal(offline_stamps, arrays['x_hat'][0])
    assert np.array_equal(offline, arrays['x_hat'][1])


def test_lockstep_runs_are_bit_identical():
    first = run_lockstep('kalman_noisy.yaml', samples=150)[2]
    second = run_lockstep('kalman_noisy.yaml', samples=150)[2]
    for topic in ('y', 'u', 'x_true', 'x_hat'):
        assert np.array_equal(first[topic][0], second[topic][0]), topic
        assert np.array_equal(first[topic][1], second[topic][1]), topic


def test_step_reference_is_tracked_with_the_reference_gain():
    system, _, arrays, _ = run_lockstep('seed001_third_order.yaml', samples=800,
                                        reference=[1.0])
    assert system.feedback.reference_gain is not None
    y = arrays['y'][1][:, 0]
    assert abs(y[-1] - 1.0) < 1e-2
    assert np.abs(y[-50:] - 1.0).max() < 2e-2


def test_ros2_control_style_float64_command_topic():
    extra = overrides(topics__u_cmd__type='float64_multi_array')
    system, _, arrays, counters = run_lockstep('seed003_full_order.yaml', samples=300,
                                               extra=extra)
    assert counters.get('lockstep_timeouts', 0) == 0
    truth = arrays['x_true'][1]
    assert np.linalg.norm(truth[-1]) < 0.05 * np.linalg.norm(truth[0])


def test_events_executor_runs_the_same_lockstep_loop():
    # closed_loop --executor events: rclpy's EventsExecutor gives the very same run.
    config = 'seed001_fourth_order_chen.yaml'
    single = run_lockstep(config, samples=150)
    events = run_lockstep(config, samples=150, executor='events')
    assert events[3]['commands_on_time'] == 149
    for topic in ('y', 'u', 'x_true', 'x_hat'):
        assert np.array_equal(events[2][topic][0], single[2][topic][0]), topic
        assert np.array_equal(events[2][topic][1], single[2][topic][1]), topic


def test_qos_override_of_one_topic_stays_on_it_and_the_recorder_follows_it():
    # rclpy writes overrides into the profile it is given: a shared profile once carried this
    # override to u and x_true. The recorder subscribes best effort where a publisher offers
    # it (a reliable subscription would not match) and reliable elsewhere.
    extra = [Parameter('qos_overrides./y.publisher.reliability', value='best_effort')]
    _, recorder, arrays, _ = run_lockstep('seed003_full_order.yaml', samples=120, extra=extra)
    offered = {topic: qos.reliability for topic, qos in recorder.qos.items()}
    assert offered.pop('y') == ReliabilityPolicy.BEST_EFFORT
    assert set(offered.values()) == {ReliabilityPolicy.RELIABLE}
    assert {qos.depth for qos in recorder.qos.values()} == {RECORDER_DEPTH}
    for topic in ('y', 'u', 'x_true', 'x_hat'):
        assert len(arrays[topic][0]) == 120, topic
