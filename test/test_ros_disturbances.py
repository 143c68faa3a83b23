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
The DC motor with a load step, over DDS: plant, observer and state feedback in lockstep.

``x_hat`` carries the load estimate as a third joint (``load``); the feedback cancels it, so
the position returns to 0 under the load.
"""

import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter

from conftest import CONFIG_DIR
from observer_ros.bags.replay import replay_bag
from observer_ros.core.evaluation import align
from observer_ros.nodes.state_feedback import StateFeedbackNode
from ros_support import executor_with, offline_estimates, ros_context, run_lockstep
from test_ros_nodes import set_parameters

SAMPLES = 600
LOAD, STEP_TIME = 0.5, 1.0


def test_load_estimate_on_x_hat_and_rejection_over_dds(tmp_path):
    bag = tmp_path / 'run'
    system, recorder, arrays, counters = run_lockstep('dc_motor_load.yaml', samples=SAMPLES,
                                                      bag=bag)
    assert counters.get('lockstep_timeouts', 0) == 0
    assert system.model.state_names == ('q', 'q_dot', 'load')
    stamps, truth, estimate = align(*arrays['x_true'], *arrays['x_hat'])
    assert truth.shape == estimate.shape == (SAMPLES, 3)
    times = (stamps - stamps[0]) / 1e9
    # The plant applied the load at 1 s; the estimate follows at the observer's rate
    # (slowest pole -10: 3 s later the error is far below 1e-6 of the step).
    assert np.all(truth[times < STEP_TIME - 1e-9, 2] == 0.0)
    assert np.all(truth[times >= STEP_TIME - 1e-9, 2] == LOAD)
    late = times > STEP_TIME + 3.0
    assert np.abs(estimate[late, 2] - LOAD).max() < 1e-6
    # u = -K x_hat - load_hat: the position regulates to 0 under the load.
    assert np.abs(truth[-50:, 0]).max() < 1e-5
    assert np.abs(truth[:, 0]).max() > 0.1  # it did move (initial 0.2)
    # The nodes computed what the core computes from the same samples.
    offline_stamps, offline = offline_estimates(system, recorder)
    assert np.array_equal(offline, arrays['x_hat'][1])
    assert np.array_equal(offline_stamps, arrays['x_hat'][0])
    # The bag replay reads the three-state x_hat and x_true (joints q, q_dot, load) alike.
    result = replay_bag(bag, CONFIG_DIR / 'dc_motor_load.yaml')
    assert np.array_equal(result.estimates, arrays['x_hat'][1])
    norms = result.error_norms()
    assert norms[-1] < 1e-6 and norms.max() > 0.1


def test_without_rejection_the_load_leaves_the_predicted_offset():
    extra = [Parameter('feedback.disturbance_rejection', value=False)]
    system, _, arrays, _ = run_lockstep('dc_motor_load.yaml', samples=SAMPLES, extra=extra)
    plant = system.augmentation.plant
    closed = plant.a - plant.b @ system.feedback.design.gain
    predicted = -np.linalg.solve(closed, plant.b[:, 0] * LOAD)
    assert abs(arrays['x_true'][1][-1, 0] - predicted[0]) < 1e-4 * abs(predicted[0])


def test_disturbance_rejection_is_validated_at_run_time():
    with ros_context('--params-file', str(CONFIG_DIR / 'dc_motor_load.yaml')) as context:
        feedback = StateFeedbackNode(context=context)
        client = Node('client', context=context)
        with executor_with(context, feedback, client) as executor:
            assert feedback.feedback_part.law.gain[0, 2] == 1.0  # [K, K_d]: the load is cancelled
            result = set_parameters(executor, client, 'state_feedback',
                                    feedback__disturbance_rejection=False)
            assert result.successful, result.reason
            assert feedback.feedback_part.law.gain[0, 2] == 0.0
            np.testing.assert_array_equal(feedback.feedback_part.law.gain[:, :2],
                                          feedback.system.feedback.design.gain)
    with ros_context('--params-file', str(CONFIG_DIR / 'seed003_full_order.yaml')) as context:
        feedback = StateFeedbackNode(context=context)
        client = Node('client', context=context)
        with executor_with(context, feedback, client) as executor:
            gain_before = feedback.feedback_part.law.gain.copy()
            result = set_parameters(executor, client, 'state_feedback',
                                    feedback__disturbance_rejection=True)
            assert not result.successful
            assert result.reason.startswith('feedback.disturbance_rejection: expected a model '
                                            'with a matched input disturbance'), result.reason
            assert np.array_equal(feedback.feedback_part.law.gain, gain_before)
