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
Integral action in ``state_feedback``: offset-free tracking under a constant input load.

A DC motor joint (``q' = q_dot``, ``q_dot' = -10 q_dot + 20 (u + d)``) measured in position,
with an unknown constant load ``d`` (``plant.input_offset``). The core closed loop (plant,
observer and servo law, with the lockstep nodes' one-sample command delay) and the
``closed_loop`` nodes in lockstep over DDS: a step reference is tracked with zero steady-state
error; without integral action the offset is the one the model predicts; with saturation the
anti-windup keeps the overshoot within the unsaturated one plus
:data:`OVERSHOOT_ALLOWANCE` of the step.
"""

import numpy as np
import pytest
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
import yaml

from observer_ros.config import PARAMETER_SPECS, validate_parameters
from observer_ros.core.design.integral import augmented_pair
from observer_ros.core.errors import ConfigError
from observer_ros.core.feedback_law import IntegralAction, StateFeedbackLaw
from observer_ros.core.simulation import PlantSimulator
from observer_ros.nodes.state_feedback import feedback_law, StateFeedbackNode
from observer_ros.ros.messages import ns_to_stamp
from ros_support import overrides, ros_context, run_lockstep

MOTOR = {'model.A': [0.0, 1.0, 0.0, -10.0], 'model.B': [0.0, 20.0], 'model.C': [1.0, 0.0],
         'model.state_names': ['q', 'q_dot'], 'model.input_names': ['shoulder_effort'],
         'model.output_names': ['shoulder'], 'observer.poles': ['-30', '-35'],
         'feedback.poles': ['-8', '-9'], 'plant.rate_hz': 100.0, 'plant.input_offset': [-0.5]}
SERVO = {**MOTOR, 'feedback.integral_poles': ['-6']}
LIMITS = {'feedback.input_limits': [-0.8, 0.8], 'plant.input_limits': [-0.8, 0.8]}
STEP = 1.0
#: Documented bound: saturated overshoot <= unsaturated overshoot + this fraction of the step.
OVERSHOOT_ALLOWANCE = 0.01
#: The error after this many seconds is below 1e-6 (slowest pole -6: e^(-6 t)).
SETTLED = 4.0


def simulate(params, samples, reference=STEP, anti_windup=True):
    """
    Run plant, observer and feedback law as the lockstep nodes do; return (system, y, u, law).

    Sample ``k`` is stamped ``(k + 1) T``; the plant applies the command computed from the
    previous sample (the safe input before the first), as ``plant_simulator`` in lockstep.
    """
    system = validate_parameters(params)
    settings = system.plant
    plant = PlantSimulator(system.model, settings.initial_state, None, None, 0,
                           settings.input_limits, settings.disturbance,
                           settings.disturbance_time, input_offset=settings.input_offset)
    stream = system.make_stream()
    law = feedback_law(system)
    if law.integral is not None:
        law.integral.anti_windup = anti_windup
    period_ns = settings.period_ns
    command, outputs, inputs = None, [], []
    for k in range(samples):
        stamp = (k + 1) * period_ns
        y = plant.measure()
        applied = plant.saturate(settings.safe_input if command is None else command)
        estimates = stream.add_input(stamp, applied) + stream.add_measurement(stamp, y)
        if law.integral is not None:
            law.integral.measure(stamp, y)
        for sample in estimates:
            command = law.command(sample.estimate, np.array([reference]), sample.stamp_ns)
        plant.step(applied, period_ns / 1e9)
        outputs.append(y[0])
        inputs.append(applied[0])
    return system, np.array(outputs), np.array(inputs), law


def predicted_output(system, reference, offset):
    """
    Steady-state ``y`` of the sampled loop ``u = -K x_hat + N r`` under an input offset.

    The fixed point of the exact ZOH plant ``x = Ad x + Bd (u + d)`` and the observer step
    ``x_hat = G_x x_hat + G_u u + G_y C x``.
    """
    model, period_ns = system.model, system.plant.period_ns
    step = system.observer.make_estimator().design.step(period_ns)
    n, m = model.n_states, model.n_inputs
    g_x, g_u, g_y = step.g[:n, :n], step.g[:n, n:n + m], step.g[:n, n + m:]
    k, feedforward = system.feedback.design.gain, system.feedback.reference_gain @ reference
    top = np.hstack([np.eye(n) - step.ad, step.bd @ k])
    bottom = np.hstack([-g_y @ model.c, np.eye(n) - g_x + g_u @ k])
    right = np.concatenate([step.bd @ (feedforward + offset), g_u @ feedforward])
    x = np.linalg.solve(np.vstack([top, bottom]), right)[:n]
    return model.c @ x


def settled(y, period=0.01):
    """Return the samples after :data:`SETTLED` seconds."""
    return y[int(SETTLED / period):]


def test_an_empty_reference_gain_gives_no_n_with_integral_action_as_its_text_says():
    # The description said "empty: unit DC gain when the plant is square" while with
    # integral action an empty value gives no N.
    assert validate_parameters(SERVO).feedback.reference_gain is None
    assert validate_parameters(MOTOR).feedback.reference_gain is not None
    text = PARAMETER_SPECS['feedback.reference_gain'].description
    assert 'without integral action, N for unit DC gain from r to y when the plant is square' \
        in text
    assert 'with integral action (feedback.integral_poles or integral_gain) no N r term' in text


def test_design_places_the_augmented_poles():
    system = validate_parameters(SERVO)
    integral = system.feedback.integral
    a, b = augmented_pair(system.model, integral.outputs)
    closed = a - b @ np.hstack([integral.gain, -integral.integral_gain])
    assert np.allclose(np.sort(np.linalg.eigvals(closed).real), [-9, -8, -6])
    assert system.feedback.reference_gain is None  # the servo form: u = -K x_hat + K_i z
    assert np.allclose(system.loop.closed_loop_poles.real, [-9, -8, -6, -35, -30])


def test_a_step_is_tracked_without_offset_under_a_constant_load():
    system, y, u, law = simulate(SERVO, 600)
    assert np.abs(settled(y) - STEP).max() < 1e-6
    # At rest (q = r, q_dot = 0) the command cancels the load: u = -d.
    assert u[-1] == pytest.approx(-system.plant.input_offset[0], abs=1e-6)
    assert law.integral.skipped == 0  # no limits: the integrator always ran


def test_without_integral_action_the_offset_is_the_predicted_one():
    system, y, _, _ = simulate(MOTOR, 600)
    predicted = predicted_output(system, np.array([STEP]), system.plant.input_offset)
    offset = STEP - y[-1]
    assert offset > 0.1  # the load pulls the joint back: a real offset
    assert y[-1] == pytest.approx(predicted[0], abs=1e-9)
    assert np.abs(settled(y) - predicted[0]).max() < 1e-6


def test_anti_windup_keeps_the_overshoot_of_the_unsaturated_loop():
    _, free, _, _ = simulate(SERVO, 800)
    _, clipped, inputs, law = simulate({**SERVO, **LIMITS}, 800)
    _, wound, _, _ = simulate({**SERVO, **LIMITS}, 800, anti_windup=False)
    # The integrator stopped at the limit (without it the command is clipped for long).
    assert 0.79 < np.abs(inputs).max() <= 0.8 and law.integral.skipped > 0
    overshoot = {name: max(0.0, y.max() - STEP) / STEP
                 for name, y in (('free', free), ('clipped', clipped), ('wound', wound))}
    assert overshoot['clipped'] <= overshoot['free'] + OVERSHOOT_ALLOWANCE, overshoot
    assert overshoot['wound'] > 0.2, overshoot  # what the anti-windup prevents
    assert np.abs(clipped[-100:] - STEP).max() < 1e-6


@pytest.mark.parametrize('extra, parameter, text', [
    ({'model.C': [1.0, 0.0, 0.0, 1.0], 'model.output_names': ['q', 'v']},
     'feedback.integral_outputs', 'non-square plant'),
    ({'model.C': [1.0, 0.0, 0.0, 1.0], 'model.output_names': ['q', 'v'],
      'feedback.integral_outputs': ['q', 'v'], 'feedback.integral_poles': ['-6', '-7']},
     'feedback.integral_outputs', 'need at least as many inputs'),
    ({'feedback.integral_outputs': ['elbow']}, 'feedback.integral_outputs',
     "'elbow' is no output"),
    ({'feedback.integral_poles': ['-6', '-7']}, 'feedback.integral_poles', 'expected 1 poles'),
    ({'feedback.integral_poles': ['6']}, 'feedback.integral_poles', 'not stable'),
    ({'feedback.integral_poles': ['-1+1j']}, 'feedback.integral_poles', 'no conjugate'),
    ({'feedback.integral_gain': [1.0]}, 'feedback.integral_gain', 'either'),
    ({'feedback.gain': [8.7, 0.65], 'feedback.poles': [], 'feedback.integral_gain': [-21.6],
      'feedback.integral_poles': []}, 'feedback.integral_gain', 'unstable'),
])
def test_bad_integral_action_is_named(extra, parameter, text):
    params = {**SERVO, **extra}
    with pytest.raises(ConfigError, match=text) as caught:
        validate_parameters(params)
    assert caught.value.parameter == parameter


def test_given_gains_equal_the_placed_ones():
    placed = validate_parameters(SERVO).feedback.integral
    given = validate_parameters({**MOTOR, 'feedback.poles': [],
                                 'feedback.gain': placed.gain.ravel().tolist(),
                                 'feedback.integral_gain': placed.integral_gain.ravel().tolist()})
    assert np.allclose(given.feedback.integral.achieved_poles, placed.achieved_poles)


def test_discrete_models_accumulate_with_their_period():
    law = StateFeedbackLaw([[0.0]], integral=IntegralAction([[2.0]], [0], period=0.5))
    law.integral.measure(0, [1.0])
    law.command(np.zeros(1), np.array([3.0]), 0)
    # One step: z = 0.5 * (3 - 1), whatever the stamps say.
    assert law.command(np.zeros(1), np.array([3.0]), 7)[0] == pytest.approx(2.0)
    law.command(np.zeros(1), np.array([3.0]), 3)  # time went back: the integral restarts
    assert law.integral.state.tolist() == [0.0]


def write_params(tmp_path, values):
    """Write a flat mapping as a ``/**: ros__parameters:`` file."""
    nested = {}
    for name, value in values.items():
        section, key = name.split('.', 1)
        nested.setdefault(section, {})[key] = value
    path = tmp_path / 'servo.yaml'
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': nested}}))
    return path


def test_closed_loop_nodes_track_the_step_without_offset(tmp_path):
    path = write_params(tmp_path, SERVO)
    system, _, arrays, counters = run_lockstep(str(path), samples=500, reference=[STEP])
    assert counters.get('lockstep_timeouts', 0) == 0
    assert counters['commands_on_time'] == 499
    y = arrays['y'][1][:, 0]
    assert np.abs(settled(y) - STEP).max() < 1e-6
    _, core, inputs, _ = simulate(SERVO, 500)
    assert np.array_equal(y, core)  # the nodes computed what the core computes
    assert np.array_equal(arrays['u'][1][:, 0], inputs)


def test_a_refused_gain_change_keeps_the_integrator_and_an_accepted_one_resets_it():
    values = {name.replace('.', '__'): value for name, value in SERVO.items()
              if name.split('.')[0] in ('model', 'feedback')}
    with ros_context() as context:
        node = StateFeedbackNode(context=context, parameter_overrides=overrides(**values))
        try:
            assert node.measurement_subscription is not None  # integral action reads y
            integral = node.feedback_part.law.integral
            for k in range(5):
                integral.measure(k, [0.0])
                node.feedback_part.law.command(np.zeros(2), np.array([1.0]), k)
            assert integral.state[0] > 0
            before = integral.state.copy()
            result = node.set_parameters([Parameter('feedback.integral_poles', value=['6'])])
            assert not result[0].successful and 'feedback.integral_poles' in result[0].reason
            assert node.feedback_part.law.integral is integral
            assert np.array_equal(integral.state, before)
            result = node.set_parameters([Parameter('feedback.timeout', value=0.25)])
            assert result[0].successful and node.feedback_part.law.integral is integral  # z kept
            result = node.set_parameters([Parameter('feedback.integral_poles', value=['-5'])])
            assert result[0].successful
            # New gains: z starts afresh.
            assert node.feedback_part.law.integral.state.tolist() == [0.0]
            assert node.feedback_part.law.integral.gain[0, 0] != integral.gain[0, 0]
        finally:
            node.destroy_node()


def test_integral_action_switched_on_at_run_time_watches_y():
    # feedback.integral_poles can be set while the node runs: the y subscription it then
    # needs gets its health check too, and every y is counted there.
    values = {name.replace('.', '__'): value for name, value in MOTOR.items()
              if name.split('.')[0] in ('model', 'feedback')}
    with ros_context() as context:
        node = StateFeedbackNode(context=context, parameter_overrides=overrides(**values))
        try:
            assert node.measurement_subscription is None and 'y' not in node.health.monitors
            result = node.set_parameters([Parameter('feedback.integral_poles', value=['-6'])])
            assert result[0].successful, result[0].reason
            assert node.measurement_subscription is not None
            message = JointState(name=['shoulder'], position=[0.25])
            ns_to_stamp(message.header.stamp, 10_000_000)
            node._on_measurement(serialize_message(message))
            assert node.health.monitors['y'].count == 1
            assert node.feedback_part.law.integral is not None
        finally:
            node.destroy_node()


#: A joint on a spring (no integrator, so a constant position bias is observable) whose
#: position sensor reads ``BIAS`` too high; the bias is modelled (``model.disturbances``).
BIASED = {'model.A': [0.0, 1.0, -4.0, -2.0], 'model.B': [0.0, 4.0], 'model.C': [1.0, 0.0],
          'model.state_names': ['q', 'q_dot'], 'model.input_names': ['shoulder_effort'],
          'model.output_names': ['shoulder'], 'model.disturbances': ['constant'],
          'model.disturbance_entries': ['output:shoulder'], 'model.disturbance_names': ['bias'],
          'observer.poles': ['-20', '-22', '-24'], 'feedback.poles': ['-8', '-9'],
          'feedback.integral_poles': ['-6'], 'plant.rate_hz': 100.0}
BIAS = 0.3


def test_a_sensor_bias_is_taken_out_of_the_integrated_output():
    # The plant's bias state is BIAS from the start: every reading is q + BIAS. Integral
    # action integrates r - (y - bias_hat), so the true q goes to the reference (before,
    # the biased reading did, leaving q off by the bias).
    system, y, _, law = simulate({**BIASED, 'plant.disturbance': [BIAS]}, 600)
    assert law.integral.output_bias is not None
    true_output = y - BIAS
    assert np.abs(settled(true_output) - STEP).max() < 1e-6
    assert system.augmentation.output_bias((0,)).tolist() == [[0.0, 0.0, 1.0]]


def test_closed_loop_nodes_take_the_sensor_bias_out(tmp_path):
    path = write_params(tmp_path, {**BIASED, 'plant.disturbance': [BIAS]})
    _, _, arrays, counters = run_lockstep(str(path), samples=500, reference=[STEP])
    assert counters.get('lockstep_timeouts', 0) == 0
    q = arrays['x_true'][1][:, 0]
    assert np.abs(settled(q) - STEP).max() < 1e-6
