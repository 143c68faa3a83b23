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
The plant simulation of a nonlinear model, against references written here in plain numpy.

- The RK4 of the simulator equals an RK4 of the differential-drive equations written by
  hand (same steps), to 1e-12 relative, over intervals of any length.
- A linear model written as equations simulates as the linear plant (exact zero-order hold)
  to 1e-9 relative.
- Noise is reproducible by its seed; bad input is refused by its name.
- The linearization at an operating point equals the derivatives written by hand.
- The arm joint with gravity under the EKF and the law designed at its operating point
  converges from an initial error of 30 degrees, either side.
- The EKF's prediction with one Jacobian a step (``covariance_prediction='midpoint'``)
  keeps the RK4's mean bit for bit and is second order in the step for the covariance.
"""

import doctest
import math

import numpy as np
import pytest

from conftest import REPOSITORY
from observer_ros.config import validate_parameters
from observer_ros.config.loader import load_parameter_file
from observer_ros.config.nonlinear import read_nonlinear_model
from observer_ros.core.design.feedback import design_feedback
from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.nonlinear import (
    differential_drive, ExtendedKalman, linear_as_expressions, UnscentedKalman)
from observer_ros.core.nonlinear import filter as filters, operating_point, simulation
from observer_ros.core.nonlinear.ekf import integrate, integrate_midpoint
from observer_ros.core.nonlinear.model import NonlinearModel
from observer_ros.core.nonlinear.operating_point import (
    arm_joint, linearize, simulate_observer_controller)
from observer_ros.core.nonlinear.simulation import NonlinearPlantSimulator
from observer_ros.core.observers.kalman.time_varying import TimeVaryingKalman
from observer_ros.core.simulation import PlantSimulator

WHEEL_RADIUS, TRACK = 0.05, 0.3


def base_dynamics(x, u):
    """Return the differential drive's dynamics, written by hand."""
    _, _, yaw, v, w = x
    return np.array([v * math.cos(yaw), v * math.sin(yaw), w, u[0], u[1]])


def reference_rk4(x, u, seconds, max_step):
    """Integrate by a plain RK4 in ceil(T / max_step) equal steps."""
    count = max(1, math.ceil(seconds / max_step - 1e-9))
    h = seconds / count
    for _ in range(count):
        k1 = base_dynamics(x, u)
        k2 = base_dynamics(x + h / 2 * k1, u)
        k3 = base_dynamics(x + h / 2 * k2, u)
        k4 = base_dynamics(x + h * k3, u)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    return x


@pytest.mark.parametrize('max_step', [0.001, 0.004])
def test_the_simulation_equals_a_numpy_rk4_of_the_differential_drive(max_step):
    rng = np.random.default_rng(30)
    x0 = np.array([0.1, -0.2, 3.0, 0.8, 0.6])
    plant = NonlinearPlantSimulator(differential_drive(WHEEL_RADIUS, TRACK), x0,
                                    max_step=max_step)
    x = x0.copy()
    worst = 0.0
    for _ in range(200):
        u = rng.normal(0.0, 1.0, 2)
        interval = rng.uniform(0.0005, 0.03)
        simulated = plant.step(u, interval)
        x = reference_rk4(x, u, interval, max_step)
        worst = max(worst, np.abs(simulated - x).max() / np.abs(x).max())
        measured = plant.measure(u)
        v, w = x[3], x[4]
        expected = [(v - w * TRACK / 2) / WHEEL_RADIUS, (v + w * TRACK / 2) / WHEEL_RADIUS,
                    w, x[0], x[1], x[2]]
        np.testing.assert_allclose(measured, expected, rtol=1e-12, atol=1e-12)
    assert worst < 1e-12
    assert plant.elapsed > 2.0


def test_a_linear_model_as_expressions_simulates_as_the_linear_plant():
    rng = np.random.default_rng(7)
    model = StateSpaceModel.from_matrices(
        [[0.0, 1.0, 0.0], [-4.0, -0.5, 1.0], [0.0, 0.0, -2.0]],
        [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]], [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    x0 = [0.3, -0.1, 0.5]
    linear = PlantSimulator(model, initial_state=x0)
    nonlinear = NonlinearPlantSimulator(linear_as_expressions(model), initial_state=x0)
    worst = 0.0
    for _ in range(300):
        u = rng.normal(0.0, 1.0, 2)
        interval = rng.choice([0.001, 0.01, 0.025, 0.0137])
        expected = linear.step(u, interval)
        simulated = nonlinear.step(u, interval)
        worst = max(worst, np.abs(simulated - expected).max() / np.abs(expected).max())
        np.testing.assert_allclose(nonlinear.measure(u), linear.measure(u), rtol=1e-9,
                                   atol=1e-9 * np.abs(expected).max())
    assert worst < 1e-9


def test_a_discrete_model_takes_f_once_per_step():
    model = NonlinearModel(['x'], {'x': '0.5 * x + u'}, {'y': 'x'}, inputs=['u'], dt=0.1)
    plant = NonlinearPlantSimulator(model, initial_state=[2.0])
    assert plant.step([1.0], 123.0).tolist() == [2.0]
    assert plant.elapsed == 0.1


def test_noise_is_reproducible_by_its_seed_and_has_its_covariance():
    model = NonlinearModel(['q', 'dq'], {'q': 'dq', 'dq': '-sin(q)'}, {'angle': 'q'})

    def run(seed):
        plant = NonlinearPlantSimulator(model, [0.1, 0.0], process_noise=[0.0, 0.04],
                                        measurement_noise=[0.01], seed=seed)
        return np.array([np.r_[plant.step([], 0.01), plant.measure()] for _ in range(50)])

    assert np.array_equal(run(3), run(3))
    assert not np.array_equal(run(3), run(4))
    quiet = NonlinearPlantSimulator(model, [0.1, 0.0], measurement_noise=[0.01], seed=1)
    readings = np.array([quiet.measure()[0] for _ in range(4000)])
    assert abs(readings.std() - 0.1) < 0.005


def test_input_limits_and_offset_apply_as_in_the_linear_plant():
    model = NonlinearModel(['x'], {'x': 'u'}, {'y': 'x'}, inputs=['u'])
    plant = NonlinearPlantSimulator(model, input_limits=[-1.0, 1.0], input_offset=[0.5])
    assert plant.applied([3.0]).tolist() == [1.5]
    plant.step([3.0], 0.1)
    assert plant.x[0] == pytest.approx(0.15, rel=1e-12)


@pytest.mark.parametrize('change, match', [
    ({'initial_state': [1.0]}, 'initial_state'),
    ({'process_noise': [1.0]}, 'process_noise'),
    ({'measurement_noise': [1.0, 2.0]}, 'measurement_noise'),
    ({'input_limits': [1.0, -1.0]}, 'input_limits'),
    ({'max_step': 0.0}, 'max_step'),
    ({'max_step': float('nan')}, 'max_step'),
])
def test_bad_arguments_are_refused_by_name(change, match):
    arguments = {'initial_state': [0.0, 0.0]}
    arguments.update(change)
    model = NonlinearModel(['q', 'dq'], {'q': 'dq', 'dq': 'u - sin(q)'}, {'angle': 'q'},
                           inputs=['u'])
    with pytest.raises(ConfigError, match=match):
        NonlinearPlantSimulator(model, **arguments)


def test_a_linear_model_object_is_refused():
    model = StateSpaceModel.from_matrices([[-1.0]], [[1.0]], [[1.0]])
    with pytest.raises(ConfigError, match='model: expected a NonlinearModel'):
        NonlinearPlantSimulator(model)


def test_a_state_that_leaves_the_domain_is_an_error_naming_the_model():
    model = NonlinearModel(['x'], {'x': 'sqrt(x)'}, {'y': 'x'})
    plant = NonlinearPlantSimulator(model, initial_state=[-1.0])
    with pytest.raises(ConfigError, match='model: the state is not finite after the step '
                       'from 0 s'):
        plant.step([], 0.01)
    assert plant.x.tolist() == [-1.0]
    with pytest.raises(ConfigError, match='dt: expected an interval > 0'):
        plant.step([], 0.0)


def test_the_module_examples_run():
    result = doctest.testmod(simulation, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted and not result.failed
    result = doctest.testmod(operating_point, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert not result.failed
    # the integrator and its step rule, shared by the plant and the filters
    result = doctest.testmod(filters, optionflags=doctest.NORMALIZE_WHITESPACE)
    assert result.attempted and not result.failed


MASS, LENGTH, GRAVITY, DAMPING = 1.0, 0.5, 9.81, 0.1
Q0 = math.radians(45.0)
TAU0 = MASS * GRAVITY * LENGTH * math.sin(Q0)


@pytest.mark.parametrize('q0', [0.0, Q0, 2.5])
def test_the_linearization_equals_the_derivatives_written_by_hand(q0):
    tau0 = MASS * GRAVITY * LENGTH * math.sin(q0)
    linear = linearize(arm_joint(MASS, LENGTH, GRAVITY, DAMPING), [q0, 0.0], [tau0])
    inertia = MASS * LENGTH ** 2
    np.testing.assert_allclose(
        linear.a, [[0.0, 1.0], [-MASS * GRAVITY * LENGTH * math.cos(q0) / inertia,
                                -DAMPING / inertia]], rtol=1e-15, atol=1e-15)
    np.testing.assert_allclose(linear.b, [[0.0], [1.0 / inertia]], rtol=1e-15)
    assert linear.c.tolist() == [[1.0, 0.0]] and linear.d.tolist() == [[0.0]]
    assert linear.state_names == ('q', 'dq') and linear.input_names == ('tau',)


def test_the_linearization_has_b_and_d_of_the_inputs():
    model = NonlinearModel(['x', 'v'], {'x': 'v', 'v': 'k * u - v'},
                           {'speed': 'v + 2 * u'}, inputs=['u'], constants={'k': 3.0})
    linear = linearize(model, [1.0, 0.0], [0.0])
    assert linear.b.tolist() == [[0.0], [3.0]] and linear.d.tolist() == [[2.0]]
    assert linearize(model, [1.0, 0.6], [0.2], equilibrium=False).a.tolist() == [
        [0.0, 1.0], [0.0, -1.0]]


@pytest.mark.parametrize('state, inputs, match', [
    ([Q0, 0.0], [0.0], 'operating_input: \\(x0, u0\\) is not an equilibrium'),
    ([Q0], [TAU0], 'operating_state'),
    ([Q0, 0.0], [TAU0, 1.0], 'operating_input'),
    ([Q0, float('nan')], [TAU0], 'operating_state'),
])
def test_a_bad_operating_point_is_refused_by_name(state, inputs, match):
    with pytest.raises(ConfigError, match=match):
        linearize(arm_joint(), state, inputs)


def run_arm(initial_error_degrees, process_noise=(0.0, 1e-4), measurement_noise=(1e-6,),
            samples=300, kind=ExtendedKalman):
    """Run the arm at 45 degrees under the filter and the law of poles -4, -5 at 100 Hz."""
    arm = arm_joint(MASS, LENGTH, GRAVITY, DAMPING)
    x0, u0 = [Q0, 0.0], [TAU0]
    feedback = design_feedback(linearize(arm, x0, u0), poles=[-4.0, -5.0])
    plant = NonlinearPlantSimulator(
        arm, [Q0 + math.radians(initial_error_degrees), 0.0], process_noise=process_noise,
        measurement_noise=measurement_noise, seed=30, input_limits=[-20.0, 20.0])
    estimator = kind(arm, [0.0, 1e-2], [1e-6],
                     initial_covariance=[math.radians(30.0) ** 2, 1.0], initial_state=x0)
    return simulate_observer_controller(plant, estimator, feedback.gain, x0, u0, 0.01,
                                        samples)


@pytest.mark.parametrize('kind', [ExtendedKalman, UnscentedKalman])
@pytest.mark.parametrize('initial_error', [30.0, -30.0])
def test_the_arm_joint_converges_from_an_initial_error_of_30_degrees(initial_error, kind):
    run = run_arm(initial_error, kind=kind)
    error = np.degrees(run.states[:, 0] - Q0)
    assert abs(error[0]) == pytest.approx(30.0)
    assert abs(error[100]) < 4.0  # 1 s: the design's slowest pole -4 leaves ~2 %-10 %
    assert np.abs(error[200:]).max() < 0.2  # 2 s on: noise only
    estimate_error = np.abs(run.estimates[200:] - run.states[200:])
    assert estimate_error[:, 0].max() < 3e-3 and estimate_error[:, 1].max() < 0.05
    assert np.abs(run.commands[200:, 0] - TAU0).max() < 0.2  # gravity's torque holds it


def test_the_loop_of_a_linear_model_as_expressions_equals_the_linear_loop():
    model = StateSpaceModel.from_matrices([[0.0, 1.0], [2.0, -0.5]], [[0.0], [1.0]],
                                          [[1.0, 0.0]])
    gain = design_feedback(model, poles=[-3.0, -4.0]).gain
    runs = []
    for plant, estimator in (
            (PlantSimulator(model, [0.4, 0.0]),
             TimeVaryingKalman(model, [0.0, 0.5], [1e-4], [1.0, 1.0])),
            (NonlinearPlantSimulator(linear_as_expressions(model), [0.4, 0.0]),
             ExtendedKalman(linear_as_expressions(model), [0.0, 0.5], [1e-4], [1.0, 1.0]))):
        runs.append(simulate_observer_controller(plant, estimator, gain, [0.0, 0.0], [0.0],
                                                 0.01, 300))
    linear, nonlinear = runs
    assert np.abs(linear.states[0]).max() == 0.4 and np.abs(linear.states[-1]).max() < 1e-2
    for name in ('states', 'estimates', 'commands'):
        assert relative(getattr(nonlinear, name), getattr(linear, name)) < 1e-9, name


def test_without_noise_the_arm_joint_settles_on_the_operating_point():
    run = run_arm(30.0, process_noise=(), measurement_noise=(), samples=600)
    assert np.abs(run.states[-1] - [Q0, 0.0]).max() < 1e-6
    assert np.abs(run.estimates[-1] - run.states[-1]).max() < 1e-6
    assert run.commands[-1, 0] == pytest.approx(TAU0, abs=1e-5)


@pytest.mark.parametrize('change, match', [
    ({'gain': [[1.0, 2.0, 3.0]]}, 'gain: expected 1x2'),
    ({'period': 0.0}, 'period'),
    ({'samples': 0}, 'samples'),
    ({'operating_state': [0.0]}, 'operating_state'),
])
def test_bad_loop_arguments_are_refused_by_name(change, match):
    arm = arm_joint()
    arguments = {'gain': [[1.0, 2.0]], 'operating_state': [0.0, 0.0],
                 'operating_input': [0.0], 'period': 0.01, 'samples': 10}
    arguments.update(change)
    ekf = ExtendedKalman(arm, [0.0, 1e-2], [1e-6])
    with pytest.raises(ConfigError, match=match):
        simulate_observer_controller(NonlinearPlantSimulator(arm), ekf, **arguments)


def test_the_example_file_holds_the_arm_joint_and_its_equilibrium():
    params = load_parameter_file(str(REPOSITORY / 'config' / 'nonlinear' / 'arm_joint.yaml'))
    model = read_nonlinear_model(params)
    arm = arm_joint(MASS, LENGTH, GRAVITY, DAMPING)
    rng = np.random.default_rng(5)
    for _ in range(20):
        x, u = rng.normal(0.0, 2.0, 2), rng.normal(0.0, 5.0, 1)
        np.testing.assert_allclose(model.f(x, u), arm.f(x, u), rtol=1e-15, atol=1e-15)
    assert model.angle_states == (0,) and model.angle_outputs == (0,)
    assert params['model.operating_point_states'] == [Q0, 0.0]
    assert params['model.operating_point_inputs'] == [TAU0]
    assert params['plant.initial_state'][0] - Q0 == pytest.approx(math.radians(30.0))
    linearize(model, params['model.operating_point_states'],
              params['model.operating_point_inputs'])


# --- the EKF's prediction with one Jacobian a step --------------------------------------


def relative(one, two):
    """Return the largest difference relative to the largest entry of ``two``."""
    return np.abs(one - two).max() / np.abs(two).max()


def test_the_midpoint_prediction_is_second_order_and_keeps_the_rk4_mean():
    model = differential_drive(WHEEL_RADIUS, TRACK)
    x, u = np.array([0.0, 0.0, 0.3, 2.0, 1.5]), np.array([0.1, 0.05])
    p = np.diag([0.01, 0.01, 0.0025, 0.01, 0.0025])
    q = np.diag([1e-6, 1e-6, 1e-6, 0.2, 0.3])
    reference = integrate(model.f_and_jacobian, x, p, q, u, 10000, 1e-4)
    errors = {}
    for step in (0.004, 0.002, 0.001):
        count = int(round(1.0 / step))
        mean, covariance = integrate_midpoint(model.f, model.f_and_jacobian, x, p, q, u,
                                              count, step)
        assert np.array_equal(mean, integrate(model.f_and_jacobian, x, p, q, u, count,
                                              step)[0])
        errors[step] = relative(covariance, reference[1])
    assert errors[0.001] < 1e-6
    assert 3.5 < errors[0.002] / errors[0.001] < 4.5  # second order
    assert 3.5 < errors[0.004] / errors[0.002] < 4.5


def test_the_midpoint_prediction_of_a_linear_model_is_the_second_order_series():
    a = np.array([[0.0, 1.0], [-4.0, -0.5]])
    model = linear_as_expressions(StateSpaceModel.from_matrices(a, [[0.0], [1.0]],
                                                                [[1.0, 0.0]]))
    p, q, h = np.array([[1.0, 0.2], [0.2, 0.5]]), np.diag([0.0, 0.3]), 0.001
    phi = np.eye(2) + a * h + a @ a * h * h / 2
    expected = phi @ p @ phi.T + q * h + (a @ q + q @ a.T) * h * h / 2
    _, covariance = integrate_midpoint(model.f, model.f_and_jacobian, np.zeros(2), p, q,
                                       np.zeros(1), 1, h)
    np.testing.assert_allclose(covariance, expected, rtol=1e-14, atol=1e-16)


def test_the_ekf_takes_the_midpoint_prediction_and_refuses_an_unknown_one():
    model = differential_drive(WHEEL_RADIUS, TRACK)
    arguments = ([0.0, 0.0, 0.0, 0.2, 0.3], [0.04, 0.04, 1e-4, 0.0025, 0.0025, 0.0004])
    filters = [ExtendedKalman(model, *arguments, covariance_prediction=prediction)
               for prediction in ('rk4', 'midpoint')]
    for k in range(50):
        for ekf in filters:
            ekf.advance_outputs(k * 10_000_000, np.array([20.0, 22.0]), np.array([0.1, 0.0]),
                                (0, 1))
    rk4, midpoint = filters
    assert relative(midpoint.estimate, rk4.estimate) < 1e-6
    assert 0.0 < relative(midpoint.covariance, rk4.covariance) < 1e-5
    rk4.adopt(midpoint)
    assert rk4.covariance_prediction == 'midpoint'
    with pytest.raises(ConfigError, match=r'covariance_prediction: expected one of '
                       r"\['rk4', 'midpoint'\]"):
        ExtendedKalman(model, *arguments, covariance_prediction='euler')


def test_observer_ekf_prediction_chooses_the_prediction_and_is_checked_by_name():
    params = {'model.A': [0.0, 1.0, -4.0, -0.5], 'model.B': [0.0, 1.0],
              'model.C': [1.0, 0.0], 'observer.type': 'extended_kalman',
              'observer.process_noise': [0.0, 0.5], 'observer.measurement_noise': [0.01]}
    assert validate_parameters(params).make_stream().estimator.covariance_prediction == 'rk4'
    chosen = validate_parameters(dict(params, **{'observer.ekf_prediction': 'midpoint'}))
    assert chosen.make_stream().estimator.covariance_prediction == 'midpoint'
    with pytest.raises(ConfigError) as caught:
        validate_parameters(dict(params, **{'observer.ekf_prediction': 'euler'}))
    assert caught.value.parameter == 'observer.ekf_prediction'
    assert 'expected one of rk4, midpoint' in caught.value.reason
