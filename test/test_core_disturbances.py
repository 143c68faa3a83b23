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
Disturbance models with the core simulator: load estimates, sensor bias, rejection, errors.

The plant is a DC motor ``J q'' = -b q' + u + load`` (J = 0.25, b = 0.5): position measured,
effort input, a constant load torque stepping in as an input disturbance.
"""

import numpy as np
import pytest
from scipy.linalg import expm

from observer_ros.app.report import design_summary
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.disturbances import augment
from observer_ros.core.errors import ConfigError
from observer_ros.core.feedback_law import StateFeedbackLaw
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.simulation import PlantSimulator
from observer_ros.core.units import NANOSECONDS
from observer_ros.tools.design_observer import main as design_main

PERIOD_NS = 10_000_000
LOAD, STEP_TIME = 0.5, 1.0

MOTOR = {'model.A': [0.0, 1.0, 0.0, -2.0], 'model.B': [0.0, 4.0], 'model.C': [1.0, 0.0],
         'model.state_names': ['q', 'q_dot'], 'model.input_names': ['effort'],
         'model.disturbances': ['constant'], 'model.disturbance_entries': ['input:effort'],
         'model.disturbance_names': ['load'], 'plant.rate_hz': 100.0,
         'plant.disturbance': [LOAD], 'plant.disturbance_time': STEP_TIME}

OBSERVERS = {
    'full_order': {'observer.poles': ['-10', '-12', '-14']},
    'reduced_order': {'observer.poles': ['-10', '-12']},
    'chen': {'observer.poles': ['-10', '-12']},
    'kalman': {'observer.process_noise': [0.0, 1e-4], 'observer.measurement_noise': [1e-6],
               'observer.disturbance_noise': [1.0]},
}


def _run(system, samples, law=None, u_open=lambda t: 0.0):
    """Simulate plant and observer; return times, true and estimated augmented states."""
    plant = system.plant
    simulator = PlantSimulator(system.model, plant.initial_state, plant.process_noise,
                               plant.measurement_noise, plant.seed, plant.input_limits,
                               plant.disturbance, plant.disturbance_time)
    estimator = system.observer.make_estimator()
    times, truth, estimates = [], [], []
    u = np.zeros(system.model.n_inputs)
    for k in range(samples):
        t = k * PERIOD_NS / NANOSECONDS
        estimate = estimator.update(k * PERIOD_NS, simulator.measure(), u).copy()
        times.append(t)
        truth.append(simulator.x.copy())
        estimates.append(estimate)
        u = law.command(estimate) if law is not None else np.array([u_open(t)])
        simulator.step(u, PERIOD_NS / NANOSECONDS)
    return np.array(times), np.array(truth), np.array(estimates)


@pytest.mark.parametrize('kind', sorted(OBSERVERS))
def test_load_estimate_converges_inside_the_designed_envelope(kind):
    params = dict(MOTOR, **OBSERVERS[kind], **{'observer.type': kind,
                                               'observer.initial_state': [0.0, 0.0, 0.0]})
    system = validate_parameters(params)
    assert system.model.state_names == ('q', 'q_dot', 'load')
    times, truth, estimate = _run(system, 300, u_open=lambda t: 0.2 * np.sin(3.0 * t))
    error = truth - estimate
    before = times < STEP_TIME
    assert np.abs(error[before]).max() < 1e-9  # exact start: no error before the load
    # The designed error dynamics of one period: ||e_k|| <= cond(V) rho^k ||e_0||.
    step = system.observer.make_estimator().design.step(PERIOD_NS)
    rho = np.abs(step.poles).max()
    if kind != 'kalman':  # the placed poles, sampled; Kalman: the DARE filter of the period
        slowest = system.observer.design.achieved_poles.real.max()
        assert rho == pytest.approx(np.exp(slowest * PERIOD_NS / NANOSECONDS), rel=1e-6)
    _, vectors = np.linalg.eig(step.error)
    constant = np.linalg.cond(vectors)
    after = ~before
    k = np.arange(after.sum())
    # The first sample after the step already saw one update: its error is e_0.
    e0 = np.linalg.norm(error[after][0])
    envelope = constant * rho ** k * e0 * (1 + 1e-9) + 1e-12
    load_error = np.abs(error[after][:, 2])
    assert (load_error <= envelope).all()
    assert load_error[0] > 0.1 * LOAD  # the load did step
    assert load_error[-1] < 1e-3 * LOAD  # and the estimate got there: 2 s after the step
    assert estimate[-1, 2] == pytest.approx(LOAD, abs=1e-3)


def test_reduced_order_and_chen_need_n_plus_disturbance_states_minus_p_poles():
    for kind in ('reduced_order', 'chen'):
        with pytest.raises(ConfigError, match=r'^observer.poles: .*expected 2 poles.*, got 3'):
            validate_parameters(dict(MOTOR, **{'observer.type': kind,
                                               'observer.poles': ['-10', '-12', '-14']}))
    with pytest.raises(ConfigError, match=r'^observer.poles: expected 3 poles'):
        validate_parameters(dict(MOTOR, **{'observer.poles': ['-10', '-12']}))


def test_kalman_needs_the_disturbance_noise_and_its_count():
    params = dict(MOTOR, **OBSERVERS['kalman'], **{'observer.type': 'kalman'})
    del params['observer.disturbance_noise']
    with pytest.raises(ConfigError, match=r'^observer.disturbance_noise: expected 1 values .*'
                                          r"\['load'\]"):
        validate_parameters(params)
    with pytest.raises(ConfigError, match=r'^observer.disturbance_noise: expected 1 values '
                                          r'\(one per disturbance state\), got 2'):
        validate_parameters(dict(params, **{'observer.disturbance_noise': [1.0, 2.0]}))


def test_sensor_bias_is_estimated_and_removed_from_x_hat():
    # Mass-spring-damper, position sensor with a 0.3 bias from the start.
    params = {'model.A': [0.0, 1.0, -4.0, -2.0], 'model.B': [0.0, 1.0], 'model.C': [1.0, 0.0],
              'model.state_names': ['position', 'velocity'],
              'model.output_names': ['position_sensor'],
              'model.disturbances': ['constant'],
              'model.disturbance_entries': ['output:position_sensor'],
              'model.disturbance_names': ['bias'], 'observer.poles': ['-8', '-9', '-10'],
              'plant.rate_hz': 100.0, 'plant.initial_state': [0.5, 0.0],
              'plant.disturbance': [0.3]}
    system = validate_parameters(params)
    times, truth, estimate = _run(system, 400, u_open=lambda t: np.sin(2.0 * t))
    late = times > 3.0
    measured = truth[:, 0] + truth[:, 2]  # what the sensor says
    assert np.abs(estimate[late, 2] - 0.3).max() < 1e-4
    assert np.abs(estimate[late, 0] - truth[late, 0]).max() < 1e-4
    assert np.abs(measured[late] - estimate[late, 0]).min() > 0.29  # the bias is gone


def test_disturbance_rejection_regulates_the_position_under_the_load():
    params = dict(MOTOR, **OBSERVERS['full_order'], **{'feedback.poles': ['-3', '-4'],
                                                       'plant.initial_state': [0.2, 0.0]})
    plain = validate_parameters(params)
    rejecting = validate_parameters(dict(params, **{'feedback.disturbance_rejection': True}))
    assert rejecting.feedback.estimate_gain[0, 2] == 1.0
    assert plain.feedback.estimate_gain[0, 2] == 0.0
    results = {}
    for name, system in (('plain', plain), ('rejecting', rejecting)):
        law = StateFeedbackLaw(system.feedback.estimate_gain)
        times, truth, _ = _run(system, 1000, law=law)
        results[name] = truth
    # With rejection the load is cancelled: q back to 0 (below 1e-6 after settling).
    assert np.abs(results['rejecting'][-100:, 0]).max() < 1e-6
    # Without it the offset is the predicted one: x_ss = -(A - B K)^-1 B load.
    plant = plain.augmentation.plant
    closed = plant.a - plant.b @ plain.feedback.design.gain
    predicted = -np.linalg.solve(closed, plant.b[:, 0] * LOAD)
    assert results['plain'][-1, 0] == pytest.approx(predicted[0], rel=1e-6)
    assert abs(predicted[0]) > 0.01


def test_shipped_config_and_design_report(tmp_path, capsys):
    from conftest import CONFIG_DIR
    path = CONFIG_DIR / 'dc_motor_load.yaml'
    system = validate_parameters(load_parameter_file(str(path)), strict=True)
    summary = design_summary(system)
    assert summary['disturbances'] == [{
        'name': 'load', 'kind': 'constant', 'entry': 'input effort', 'frequency': 0.0,
        'states': ['load'], 'state_indices': [2], 'modes': [[0.0, 0.0]]}]
    assert summary['feedback.disturbance_gain'] == [[1.0]]
    assert summary['observer.slowest_pole'] == pytest.approx([-10.0, 0.0], abs=1e-9)
    # The loop's poles: A - B K and the observer's; the generator mode 0 is left out.
    closed = sorted(complex(re, im).real for re, im in summary['closed_loop_poles'])
    assert closed == pytest.approx([-14.0, -12.0, -10.0, -4.0, -3.0], abs=1e-6)
    written = tmp_path / 'designed.yaml'
    assert design_main([str(path), '--write', str(written)]) == 0
    out = capsys.readouterr().out
    assert 'Disturbances: 1 state after the 2 plant states' in out
    again = validate_parameters(load_parameter_file(str(written)), strict=True)
    assert again.observer.design.gain.shape == (3, 1)  # the gain covers the load state
    np.testing.assert_allclose(again.observer.design.gain, system.observer.design.gain, rtol=1e-12)
    assert 'load: constant at input effort, states load (x_hat entries 2)' in out
    assert 'disturbance estimates converge like the slowest observer pole [-10]' in out
    assert 'K_d (disturbance rejection' in out


def test_ramp_and_sinusoid_generators_continuous_and_discrete():
    motor = StateSpaceModel.from_flat([0, 1, 0, -2], [0, 4], [1, 0])
    model = augment(motor, ['ramp', 'sinusoid'], [], [], [3.0], ['drift', 'hum'])
    assert model.augmented.state_names == ('x1', 'x2', 'drift', 'drift_rate', 'hum',
                                           'hum_rate')
    assert np.allclose(np.linalg.eigvals(model.augmented.a[4:, 4:]), [3j, -3j])
    dt = 0.01
    discrete = StateSpaceModel(a=expm(motor.a * dt), b=motor.b * dt, c=motor.c, d=motor.d,
                               dt=dt, state_names=motor.state_names,
                               input_names=motor.input_names, output_names=motor.output_names)
    sampled = augment(discrete, ['ramp', 'sinusoid'], [], [], [3.0]).augmented
    assert np.allclose(sampled.a[2:4, 2:4], [[1.0, dt], [0.0, 1.0]])
    assert np.allclose(sampled.a[4:, 4:], expm(np.array([[0.0, 1.0], [-9.0, 0.0]]) * dt))
    # The sampled continuous augmented model is the discrete augmented one (same generator).
    continuous = augment(motor, ['ramp', 'sinusoid'], [], [], [3.0]).augmented
    assert np.allclose(expm(continuous.a * dt)[2:, 2:], sampled.a[2:, 2:])


def test_matrix_entry_uses_the_given_column():
    motor = StateSpaceModel.from_flat([0, 1, 0, -2], [0, 4], [1, 0])
    model = augment(motor, ['constant'], ['matrix'], [1.0, 0.0])
    assert model.augmented.a[:2, 2].tolist() == [1.0, 0.0]
    assert not model.matched()


@pytest.mark.parametrize('extra, message', [
    ({'model.A': [0.0, 1.0, -2.0, -3.0], 'model.C': [0.0, 1.0]},
     r"^model.disturbances: the constant 'load' is not observable: the plant has a "
     r'transmission zero at s = 0 from input effort'),
    ({'model.disturbance_entries': ['output']},
     r"^model.disturbances: the constant 'load' is not observable: it cannot be told apart "
     r'from the plant mode at s = 0'),
    ({'model.A': [0.0, 1.0, -4.0, 0.0], 'model.disturbances': ['sinusoid'],
      'model.disturbance_frequencies': [2.0]},
     r"^model.disturbance_frequencies: 2 rad/s of the sinusoid 'load' equals the plant "
     r'poles s = 0\+2j, 0-2j'),
    ({'model.disturbances': ['sinusoid']},
     r'^model.disturbance_frequencies: expected 1 frequencies in rad/s \(one per '
     r'sinusoid\), got 0'),
    ({'model.disturbance_frequencies': [2.0]},
     r'^model.disturbance_frequencies: expected 0 frequencies'),
    ({'model.disturbances': ['sinusoid'], 'model.disturbance_frequencies': [-1.0]},
     r'^model.disturbance_frequencies: expected frequencies > 0 rad/s, got -1.0'),
    ({'model.disturbance_names': ['load', 'drift']},
     r'^model.disturbance_names: expected 1 names \(one per disturbance in disturbances\), '
     r'got 2'),
    ({'model.disturbance_names': ['q']},
     r'^model.disturbance_names: state names must be unique'),
    ({'model.disturbances': ['step']},
     r"^model.disturbances: entry 0: expected constant, ramp or sinusoid, got 'step'"),
    ({'model.disturbance_entries': ['input:torque']},
     r"^model.disturbance_entries: entry 0: no input named 'torque'"),
    ({'model.disturbance_entries': ['input', 'input']},
     r'^model.disturbance_entries: expected 1 entries'),
    ({'model.disturbance_entries': ['matrix'], 'model.disturbance_matrix': [1.0]},
     r'^model.disturbance_matrix: expected 2x1'),
    ({'model.disturbances': [], 'plant.disturbance': []},
     r'^model.disturbance_entries: given without model.disturbances'),
    ({'plant.disturbance': [0.5, 1.0]},
     r'^plant.disturbance: expected 1 values, got 2 \(one per disturbance state: load\)'),
])
def test_disturbance_errors_name_the_parameter(extra, message):
    params = dict(MOTOR, **OBSERVERS['full_order'], **extra)
    with pytest.raises(ConfigError, match=message) as caught:
        validate_parameters(params)
    assert '\n' not in str(caught.value)


def test_disturbance_noise_without_disturbances_and_rejection_without_a_matched_load():
    plain = {key: value for key, value in MOTOR.items()
             if not key.startswith(('model.disturbance', 'plant.disturbance'))}
    with pytest.raises(ConfigError, match=r'^observer.disturbance_noise: the model has no '
                                          r'disturbances'):
        validate_parameters(dict(plain, **{'observer.disturbance_noise': [1.0]}))
    with pytest.raises(ConfigError, match=r'^feedback.disturbance_rejection: expected a model '
                                          r'with a matched input disturbance'):
        validate_parameters(dict(plain, **{'feedback.poles': ['-3', '-4'],
                                           'feedback.disturbance_rejection': True}))
    bias = dict(MOTOR, **{'model.A': [0.0, 1.0, -4.0, -2.0],
                          'model.disturbance_entries': ['output'],
                          'feedback.poles': ['-3', '-4'],
                          'feedback.disturbance_rejection': True})
    with pytest.raises(ConfigError, match=r'^feedback.disturbance_rejection: expected a '
                                          r'matched input disturbance'):
        validate_parameters(bias)


def test_sinusoid_at_a_transmission_zero_is_named():
    # y = (s^2 + 4) / ((s + 1)(s + 2)(s + 3)) u: a 2 rad/s hum at the input never reaches y.
    model = StateSpaceModel.from_matrices(
        [[-6, -11, -6], [1, 0, 0], [0, 1, 0]], [[1], [0], [0]], [[1, 0, 4]])
    with pytest.raises(ConfigError, match=r"^disturbances: the sinusoid \(2 rad/s\) 'hum' is "
                                          r'not observable: the plant has a transmission zero '
                                          r'at s = 0\+2j, 0-2j from input u1'):
        augment(model, ['sinusoid'], [], [], [2.0], ['hum'])
    assert augment(model, ['sinusoid'], [], [], [3.0], ['hum']).n_disturbance_states == 2


def test_time_varying_kalman_estimates_the_load():
    params = dict(MOTOR, **OBSERVERS['kalman'], **{
        'observer.type': 'kalman', 'observer.time_varying': True,
        'observer.initial_covariance': [1e-6, 1e-6, 1.0],
        'observer.initial_state': [0.0, 0.0, 0.0]})
    system = validate_parameters(params)
    with pytest.raises(ConfigError, match=r'^observer.initial_covariance: expected 3 '):
        validate_parameters(dict(params, **{'observer.initial_covariance': [1.0, 1.0]}))
    _, _, estimate = _run(system, 300)
    assert estimate[-1, 2] == pytest.approx(LOAD, abs=1e-3)
