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
Observer, feedback and Kalman designs: given gains, MIMO invariants, Riccati residuals.

Exactness of an observer realization ``xi' = Ar xi + By y + Bu u``,
``x_hat = Cr xi + Dy y + Du u`` is checked without using the design's internals: with
``V`` the solution of ``V A - Ar V = By C`` (unique when ``Ar`` and ``A`` share no
eigenvalue), the observer reproduces ``x`` exactly from ``xi(0) = V x(0)`` if and only if
``V B = By D + Bu``, ``Cr V + Dy C = I`` and ``Dy D + Du = 0``; its error is then
``Cr expm(Ar t) (xi(0) - V x(0))``.
"""

import warnings

import control
import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
import scipy.optimize
import scipy.signal

from conftest import match
from observer_ros.core.design.feedback import design_feedback
from observer_ros.core.discretize import van_loan, zero_order_hold
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.loop_analysis.closed_loop import closed_loop_matrix, closed_loop_poles
from observer_ros.core.loop_analysis.diophantine import diophantine_controller
from observer_ros.core.loop_analysis.observer_controller import (
    controller_state_space, controller_transfer_function, UnstableControllerWarning)
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers.chen.design import design_chen
from observer_ros.core.observers.chen.sylvester import MAX_CONDITION
from observer_ros.core.observers.full_order.design import design_full_order
from observer_ros.core.observers.kalman.design import design_kalman, design_sampled_kalman
from observer_ros.core.observers.reduced_order.design import (
    design_reduced_order, measured_first_transform, partition_model)


def assert_same_roots(achieved, wanted, rtol=1e-8):
    """Assert two multisets of distinct roots agree after optimal matching."""
    wanted = np.asarray(wanted, dtype=complex)
    np.testing.assert_allclose(match(achieved, wanted), wanted, rtol=rtol, atol=rtol)


def random_model(seed, n_states, n_inputs, n_outputs, with_d=False, dt=0.0):
    """Return a seeded random model (``C`` dense, so it selects no states)."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n_states, n_states))
    if dt:
        a *= 0.9 / max(1.0, np.abs(np.linalg.eigvals(a)).max())
    b = rng.standard_normal((n_states, n_inputs))
    c = rng.standard_normal((n_outputs, n_states))
    d = rng.standard_normal((n_outputs, n_inputs)) if with_d else None
    return StateSpaceModel.from_matrices(a, b, c, d, dt=dt)


def realization_map(model, realization):
    """Return ``V`` with ``V A - Ar V = By C`` (the observer state as a function of ``x``)."""
    return scipy.linalg.solve_sylvester(-realization.a, model.a, realization.b_y @ model.c)


def assert_exact_realization(model, realization):
    """Assert the observer reproduces ``x`` exactly; return ``V``."""
    v = realization_map(model, realization)
    scale = max(1.0, np.abs(v).max())
    np.testing.assert_allclose(v @ model.a - realization.a @ v, realization.b_y @ model.c,
                               atol=1e-10 * scale)
    np.testing.assert_allclose(v @ model.b, realization.b_y @ model.d + realization.b_u,
                               atol=1e-10 * scale)
    np.testing.assert_allclose(realization.c @ v + realization.d_y @ model.c,
                               np.eye(model.n_states), atol=1e-10 * scale)
    np.testing.assert_allclose(realization.d_y @ model.d + realization.d_u, 0.0,
                               atol=1e-10 * scale)
    return v


def simulate_plant_and_observer(model, realization, x0, xi0, u, times):
    """
    Return ``(x(t), x_hat(t))`` for a constant input, plant and observer exactly (expm).

    The augmented state is ``[x; xi; u]`` with ``u' = 0``.
    """
    n, m = model.n_states, model.n_inputs
    r = realization.a.shape[0]
    big = np.zeros((n + r + m, n + r + m))
    big[:n, :n] = model.a
    big[:n, n + r:] = model.b
    big[n:n + r, :n] = realization.b_y @ model.c
    big[n:n + r, n:n + r] = realization.a
    big[n:n + r, n + r:] = realization.b_y @ model.d + realization.b_u
    start = np.concatenate([x0, xi0, u])
    states, estimates = [], []
    for t in times:
        z = scipy.linalg.expm(big * t) @ start
        x, xi = z[:n], z[n:n + r]
        y = model.c @ x + model.d @ u
        states.append(x)
        estimates.append(realization.c @ xi + realization.d_y @ y + realization.d_u @ u)
    return np.array(states), np.array(estimates)


# --------------------------------------------------------------------------------------
# Given gains.
# --------------------------------------------------------------------------------------

SEED003 = StateSpaceModel.from_flat(a=[2, 3, -1, 4], b=[0, 1], c=[1, 0])
SEED000 = StateSpaceModel.from_flat(a=[0, 4, 0, -3, 0, 2, 0, 0, -2], b=[0, 0, 2],
                                    c=[1, 0, 0])


@pytest.mark.parametrize('gain', [[0, 0], [1, 0], [22, -40]])
def test_unstable_given_full_order_gain(gain):
    # eig(A - L C) of [[2, 3], [-1, 4]]: L = 0 leaves 3 +- 1.41j; the others stay unstable.
    assert np.linalg.eigvals(SEED003.a - np.reshape(gain, (2, 1)) @ SEED003.c).real.max() > 0
    with pytest.raises(DesignError, match='^gain: the given gain makes the observer'):
        design_full_order(SEED003, gain=gain)


def test_stable_given_full_order_gain():
    design = design_full_order(SEED003, gain=[22, 59])
    assert design.method == 'given' and design.residual == 0.0
    assert_same_roots(design.achieved_poles, [-8 + 6j, -8 - 6j])
    np.testing.assert_allclose(design.realization.a, SEED003.a - design.gain @ SEED003.c)


@pytest.mark.parametrize('gain', [[0, 0], [-1, 0]])
def test_unstable_given_reduced_order_gain(gain):
    # L = 0: Abb = [[0, 2], [0, -2]] has a pole at 0 (not in the open left half-plane).
    with pytest.raises(DesignError, match='unstable'):
        design_reduced_order(SEED000, gain=gain)


def test_stable_given_reduced_order_gain():
    design = design_reduced_order(SEED000, gain=[0.5, 0.5])
    assert design.method == 'given'
    assert_same_roots(design.achieved_poles, [-2 + 2j, -2 - 2j])
    assert_exact_realization(SEED000, design.realization)


def test_given_gain_discrete_model_needs_unit_circle():
    model = StateSpaceModel.from_flat(a=[1.1, 0.2, 0, 0.5], b=[0, 1], c=[1, 0], dt=0.1)
    with pytest.raises(DesignError, match='outside the unit circle'):
        design_full_order(model, gain=[0, 0])
    design = design_full_order(model, gain=[1.1, 0])
    assert np.all(np.abs(design.achieved_poles) < 1.0)


def test_unstable_requested_poles_are_refused():
    model = random_model(0, 4, 1, 2)
    with pytest.raises(DesignError, match='^poles: requested poles'):
        design_full_order(model, poles=[-1, -2, 0.5, -3])
    with pytest.raises(DesignError, match='^poles: requested poles'):
        design_reduced_order(model, poles=[-1, 1e-3])
    with pytest.raises(DesignError, match='^poles: requested poles'):
        design_chen(model, poles=[-1 + 1j, 0.1])
    discrete = random_model(0, 3, 1, 1, dt=0.1)
    with pytest.raises(DesignError, match='inside the unit circle'):
        design_full_order(discrete, poles=[0.5, 0.2, 1.2])


def test_feedback_given_gain_and_unstable_poles():
    model = StateSpaceModel.from_flat(a=[0, 1, 0, 0, 0, 1, 0, -24, -10], b=[0, 10, -80],
                                      c=[1, 0, 0])
    design = design_feedback(model, gain=[1.25, 1.25, 0.19375])
    assert design.method == 'given'
    assert_same_roots(design.achieved_poles, [-1 + 2j, -1 - 2j, -5])
    with pytest.raises(DesignError, match='^gain: the given K leaves A - B K unstable'):
        design_feedback(model, gain=[0, 0, 0])
    with pytest.raises(ConfigError, match='^poles: requested poles'):
        design_feedback(model, poles=[-1, -2, 3])
    with pytest.raises(ConfigError, match=r'^gain: expected 1x3'):
        design_feedback(model, gain=[1, 2])


def test_unobservable_model_is_refused_with_lost_modes():
    model = StateSpaceModel.from_flat(a=[-1, 0, 0, 0, 2, 0, 0, 0, 3], b=[1, 1, 1],
                                      c=[1, 1, 0])
    for design in (lambda: design_full_order(model, poles=[-1, -2, -3]),
                   lambda: design_reduced_order(model, poles=[-4, -5]),
                   lambda: design_chen(model, poles=[-4, -5])):
        with pytest.raises(DesignError, match=r'not observable: the modes 3 cannot be seen'):
            design()


# --------------------------------------------------------------------------------------
# Reduced-order observer with several outputs and a dense C.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('with_d', [False, True])
@pytest.mark.parametrize('seed', range(3))
def test_reduced_order_mimo_dense_c(seed, with_d):
    model = random_model(seed, 5, 2, 2, with_d=with_d)
    poles = [-3, -4 + 1j, -4 - 1j]
    design = design_reduced_order(model, poles=poles)
    assert design.order == 3 and design.gain.shape == (3, 2)
    # The first p rows of Q are C; Q is invertible and well conditioned (orthonormal rest).
    np.testing.assert_allclose(design.transform[:2], model.c)
    np.testing.assert_allclose(design.transform[2:] @ design.transform[2:].T, np.eye(3),
                               atol=1e-12)
    np.testing.assert_allclose(design.transform[2:] @ model.c.T, 0.0, atol=1e-12)
    # Partition: Q A Q^-1 in blocks.
    a_w = design.transform @ model.a @ np.linalg.inv(design.transform)
    np.testing.assert_allclose(design.partition.abb, a_w[2:, 2:], atol=1e-12)
    np.testing.assert_allclose(design.partition.aab, a_w[:2, 2:], atol=1e-12)
    error = design.partition.abb - design.gain @ design.partition.aab
    assert_same_roots(np.linalg.eigvals(error), poles)
    assert_same_roots(np.linalg.eigvals(design.realization.a), poles)
    v = assert_exact_realization(model, design.realization)
    # Exactness in continuous time, and the error of a wrong start decays with the poles.
    rng = np.random.default_rng(seed + 10)
    x0 = rng.standard_normal(5)
    u = rng.standard_normal(2)
    times = [0.0, 0.3, 1.0, 2.5]
    states, estimates = simulate_plant_and_observer(model, design.realization, x0, v @ x0, u,
                                                    times)
    np.testing.assert_allclose(estimates, states, atol=1e-9 * np.abs(states).max())
    xi0 = v @ x0 + rng.standard_normal(3)
    states, estimates = simulate_plant_and_observer(model, design.realization, x0, xi0, u,
                                                    times)
    for t, x, x_hat in zip(times, states, estimates):
        expected = design.realization.c @ scipy.linalg.expm(design.realization.a * t) @ (
            xi0 - v @ x0)
        np.testing.assert_allclose(x_hat - x, expected, atol=1e-9 * max(1.0, np.abs(x).max()))


def test_reduced_order_selection_c_keeps_state_order():
    model = StateSpaceModel.from_flat(a=np.arange(16.0) - 7.0, b=[1, 0, 0, 1],
                                      c=[0, 0, 2, 0, 1, 0, 0, 0])
    design = design_reduced_order(model, poles=[-5, -6])
    # Rows: C, then the unselected unit vectors e2, e4 in order.
    np.testing.assert_array_equal(design.transform[2:], [[0, 1, 0, 0], [0, 0, 0, 1]])
    assert_exact_realization(model, design.realization)


def test_reduced_order_refusals():
    model = random_model(0, 3, 1, 2)
    with pytest.raises(ConfigError,
                       match="^coordinates: 'observability' coordinates need a single output"):
        design_reduced_order(model, poles=[-1], coordinates='observability')
    with pytest.raises(ConfigError, match='^coordinates: expected one of'):
        design_reduced_order(model, poles=[-1], coordinates='modal')
    with pytest.raises(ConfigError, match='^poles: .*expected 1 poles, got 2'):
        design_reduced_order(model, poles=[-1, -2])
    redundant = StateSpaceModel.from_matrices(model.a, model.b, np.vstack([model.c[0]] * 2))
    with pytest.raises(DesignError, match='^C: .*full row rank'):
        design_reduced_order(redundant, poles=[-1])
    everything = StateSpaceModel.from_matrices(model.a, model.b, np.eye(3))
    with pytest.raises(DesignError, match='^C: .*nothing to estimate'):
        design_reduced_order(everything, poles=[])


# --------------------------------------------------------------------------------------
# Full order and Chen.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('with_d', [False, True])
@pytest.mark.parametrize('seed', range(3))
def test_full_order_mimo_exact(seed, with_d):
    model = random_model(seed, 4, 2, 2, with_d=with_d)
    poles = [-2, -3, -4 + 2j, -4 - 2j]
    design = design_full_order(model, poles=poles)
    assert_same_roots(np.linalg.eigvals(model.a - design.gain @ model.c), poles)
    v = assert_exact_realization(model, design.realization)
    np.testing.assert_allclose(v, np.eye(4), atol=1e-10)


@pytest.mark.parametrize('with_d', [False, True])
@pytest.mark.parametrize('seed', range(3))
def test_chen_sylvester_residual_and_condition(seed, with_d):
    model = random_model(seed, 5, 2, 2, with_d=with_d)
    poles = [-6, -7 + 1j, -7 - 1j]
    design = design_chen(model, poles=poles, seed=seed)
    f, t, gain = design.f, design.t, design.gain
    assert f.shape == (3, 3) and t.shape == (3, 5) and gain.shape == (3, 2)
    assert np.isrealobj(f)
    assert_same_roots(np.linalg.eigvals(f), poles)
    residual = t @ model.a - f @ t - gain @ model.c
    assert np.linalg.norm(residual) <= 1e-12 * max(1.0, np.linalg.norm(t)) * np.linalg.norm(
        model.a)
    assert design.residual <= 1e-10
    stacked = np.vstack([model.c, t])
    assert design.condition == pytest.approx(np.linalg.cond(stacked), rel=1e-8)
    assert design.condition < MAX_CONDITION
    np.testing.assert_allclose(design.inverse @ stacked, np.eye(5), atol=1e-9)
    v = assert_exact_realization(model, design.realization)
    np.testing.assert_allclose(v, t, atol=1e-9 * max(1.0, np.abs(t).max()))


def test_chen_repeated_poles_single_output():
    # Repeated poles are chained as a Jordan block so that one column L can still excite F.
    model = random_model(1, 4, 1, 1)
    design = design_chen(model, poles=[-5, -5, -5])
    assert np.linalg.matrix_rank(control.ctrb(design.f, design.gain)) == 3
    np.testing.assert_allclose(np.poly(design.f), np.poly([-5, -5, -5]), rtol=1e-12)
    assert_exact_realization(model, design.realization)


def test_chen_refusals():
    model = StateSpaceModel.from_flat(a=[-3, 1, 0, 0, -1, 1, 0, 0, -2], b=[0, 0, 1],
                                      c=[1, 0, 0])
    with pytest.raises(DesignError, match='^poles: .*coincide with eigenvalues of A'):
        design_chen(model, poles=[-3, -10])
    with pytest.raises(DesignError, match=r'^gain: \(F, L\) is not controllable'):
        design_chen(model, poles=[-10, -12], gain=[1, 0])
    with pytest.raises(ConfigError, match='^poles: .*expected 2 poles, got 3'):
        design_chen(model, poles=[-10, -11, -12])
    with pytest.raises(ConfigError, match=r'^gain: expected 2x1'):
        design_chen(model, poles=[-10, -12], gain=[1, 2, 3])


# --------------------------------------------------------------------------------------
# Separation principle: closed-loop poles.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('kind', ['full_order', 'reduced_order', 'chen', 'kalman'])
@pytest.mark.parametrize('with_d', [False, True])
def test_closed_loop_poles_separate(kind, with_d):
    model = random_model(7, 5, 2, 2, with_d=with_d)
    feedback = design_feedback(model, poles=[-1, -1.5, -2, -0.5 + 1j, -0.5 - 1j])
    if kind == 'full_order':
        design = design_full_order(model, poles=[-3, -4, -5, -6, -7])
    elif kind == 'reduced_order':
        design = design_reduced_order(model, poles=[-3, -4 + 1j, -4 - 1j])
    elif kind == 'chen':
        design = design_chen(model, poles=[-3, -4 + 1j, -4 - 1j])
    else:
        design = design_kalman(model, np.ones(5), [0.1, 0.2])
    observer_poles = np.linalg.eigvals(design.realization.a)
    expected = np.concatenate([np.linalg.eigvals(model.a - model.b @ feedback.gain),
                               observer_poles])
    got = closed_loop_poles(model, design.realization, feedback.gain)
    assert got.size == model.n_states + design.order
    assert_same_roots(got, expected, rtol=1e-7)
    assert_same_roots(got, np.concatenate([feedback.requested_poles,
                                           design.achieved_poles]), rtol=1e-7)


def test_closed_loop_matrix_is_plant_plus_observer_under_feedback():
    # Simulating [x; xi] with u = -K x_hat: the estimate stays exact from a consistent start.
    model = random_model(2, 4, 1, 2)
    design = design_reduced_order(model, poles=[-3, -5])
    k = design_feedback(model, poles=[-1, -2, -2.5, -3]).gain
    v = realization_map(model, design.realization)
    x0 = np.array([1.0, -2.0, 0.5, 3.0])
    start = np.concatenate([x0, v @ x0])
    matrix = closed_loop_matrix(model, design.realization, k)
    for t in (0.5, 2.0):
        z = scipy.linalg.expm(matrix * t) @ start
        x, xi = z[:4], z[4:]
        x_hat = design.realization.c @ xi + design.realization.d_y @ (model.c @ x)
        np.testing.assert_allclose(x_hat, x, atol=1e-10)
        np.testing.assert_allclose(x, scipy.linalg.expm((model.a - model.b @ k) * t) @ x0,
                                   atol=1e-10)


@pytest.mark.parametrize('dt', [0.0, 0.05])
@pytest.mark.parametrize('kind', ['full_order', 'reduced_order', 'chen'])
def test_observer_controller_equals_diophantine(kind, dt):
    # For one output the controller of a given order is unique given the closed-loop poles:
    # G_oc from any observer realization equals S / R from A R + B S = A_cl.
    a = np.array([[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0],
                  [-18.75, -34.0, -21.25, -7.0]])
    b = np.array([[0.0], [2.344], [-7.032], [18.166]])
    c = np.array([[1.0, 0.0, 0.0, 0.0]])
    controller_poles = np.array([-1 + 2j, -1 - 2j, -3, -4])
    observer_poles = np.array([-10.0, -11.0, -12.0, -13.0])
    if kind != 'full_order':
        observer_poles = observer_poles[:3]
    if dt:
        ad, bd = zero_order_hold(a, b, dt)
        model = StateSpaceModel.from_matrices(ad, bd, c, dt=dt)
        controller_poles = np.exp(controller_poles * dt)
        observer_poles = np.exp(observer_poles * dt)
    else:
        model = StateSpaceModel.from_matrices(a, b, c)
    k = design_feedback(model, poles=controller_poles).gain
    if kind == 'full_order':
        design = design_full_order(model, poles=observer_poles)
    elif kind == 'reduced_order':
        design = design_reduced_order(model, poles=observer_poles)
    else:
        design = design_chen(model, poles=observer_poles)
    with warnings.catch_warnings():
        warnings.simplefilter('ignore', UnstableControllerWarning)
        state_space = controller_transfer_function(model, design.realization, k)
        polynomial = diophantine_controller(model, controller_poles, observer_poles)
    assert state_space.den.size == design.order + 1
    assert state_space.discrete == bool(dt)
    # The realization itself, evaluated pointwise, is the Diophantine controller ...
    a_c, b_c, c_c, d_c = controller_state_space(design.realization, k)
    points = [0.5j, 2.0 + 1.0j, 7.0] if not dt else np.exp(np.array([0.5j, 2.0 + 1.0j]) * dt)
    for point in points:
        response = -(c_c @ np.linalg.solve(point * np.eye(design.order) - a_c, b_c) + d_c)
        expected = np.polyval(polynomial.num, point) / np.polyval(polynomial.den, point)
        assert complex(response[0, 0]) == pytest.approx(expected, rel=1e-8)
    # ... and so must be its coefficients (monic denominator, numerator).
    np.testing.assert_allclose(state_space.den, polynomial.den, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(state_space.num, polynomial.num, rtol=1e-7, atol=1e-9)


def test_controller_transfer_function_needs_siso():
    model = random_model(0, 3, 2, 1)
    design = design_full_order(model, poles=[-2, -3, -4])
    k = design_feedback(model, poles=[-1, -2, -3]).gain
    with pytest.raises(DesignError, match='single-input single-output'):
        controller_transfer_function(model, design.realization, k)


def test_diophantine_refuses_pole_zero_cancellation():
    # Non-minimal realization: the mode -1 is not observable, G = 1 / (s + 2).
    model = StateSpaceModel.from_flat(a=[-1, 0, 0, -2], b=[1, 1], c=[0, 1])
    with pytest.raises(DesignError, match='share a root'):
        diophantine_controller(model, [-1, -2], [-3])


# --------------------------------------------------------------------------------------
# Kalman: CARE, DARE, control.dlqe, sampled designs.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('seed', range(3))
def test_kalman_care_residual(seed):
    model = random_model(seed, 4, 1, 2)
    rng = np.random.default_rng(seed)
    root = rng.standard_normal((4, 4))
    q = root @ root.T + 0.1 * np.eye(4)
    r = np.array([[0.5, 0.1], [0.1, 0.3]])
    design = design_kalman(model, q.ravel(), r.ravel())
    p = design.covariance
    assert design.method == 'care'
    np.testing.assert_allclose(p, p.T, atol=1e-10 * np.abs(p).max())
    assert np.linalg.eigvalsh(p).min() > 0.0
    residual = model.a @ p + p @ model.a.T + q - p @ model.c.T @ np.linalg.solve(r, model.c @ p)
    assert np.abs(residual).max() <= 1e-9 * max(1.0, np.abs(p).max())
    np.testing.assert_allclose(design.gain, p @ model.c.T @ np.linalg.inv(r), rtol=1e-9)
    assert np.linalg.eigvals(model.a - design.gain @ model.c).real.max() < 0.0
    gain, covariance, _ = control.lqe(model.a, np.eye(4), model.c, q, r)
    np.testing.assert_allclose(design.gain, gain, rtol=1e-7, atol=1e-9)
    np.testing.assert_allclose(p, covariance, rtol=1e-7, atol=1e-9)


@pytest.mark.parametrize('seed', range(3))
def test_kalman_dare_matches_dlqe_predictor_gain(seed):
    model = random_model(seed, 4, 1, 2, dt=0.05)
    q = np.diag([1.0, 0.5, 2.0, 0.1])
    r = np.diag([0.2, 0.4])
    design = design_kalman(model, np.diag(q), np.diag(r))
    assert design.method == 'dare'
    a, c, p, m = model.a, model.c, design.covariance, design.filter_gain
    innovation = c @ p @ c.T + r
    residual = a @ p @ a.T - p + q - a @ p @ c.T @ np.linalg.solve(innovation, c @ p @ a.T)
    assert np.abs(residual).max() <= 1e-10 * max(1.0, np.abs(p).max())
    np.testing.assert_allclose(m, p @ c.T @ np.linalg.inv(innovation), rtol=1e-9)
    # control.dlqe returns the predictor gain L = A M.
    gain, covariance, poles = control.dlqe(a, np.eye(4), c, q, r)
    np.testing.assert_allclose(design.gain, gain, rtol=1e-7, atol=1e-10)
    np.testing.assert_allclose(design.gain, a @ m, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(p, covariance, rtol=1e-7, atol=1e-10)
    assert_same_roots(design.achieved_poles, poles, rtol=1e-7)
    filtered = (np.eye(4) - m @ c) @ p
    np.testing.assert_allclose(design.filtered_covariance, filtered, atol=1e-10)


def test_sampled_kalman_is_the_exact_discretization():
    model = random_model(4, 3, 1, 1)
    q = np.diag([1.0, 2.0, 0.5])
    r = np.array([[0.05]])
    dt = 0.02
    design = design_sampled_kalman(model, np.diag(q), r.ravel(), dt)
    assert design.model.dt == dt and design.model.is_discrete
    np.testing.assert_allclose(design.model.a, scipy.linalg.expm(model.a * dt), rtol=1e-12)
    qd = fine_noise_integral(model.a, q, dt)
    np.testing.assert_allclose(design.process_noise, qd, rtol=1e-9, atol=1e-15)
    gain, covariance, _ = control.dlqe(design.model.a, np.eye(3), model.c, qd, r)
    np.testing.assert_allclose(design.gain, gain, rtol=1e-6)
    with pytest.raises(ConfigError, match='^model: expected a continuous model'):
        design_sampled_kalman(design.model, np.diag(q), r.ravel(), dt)


@pytest.mark.parametrize('dt', [0.0, 0.1])
def test_kalman_undetectable_is_refused(dt):
    # The unstable mode 1.5 (2 for the discrete model) is invisible from y = x2.
    a = [1.5, 0, 0, -1] if dt == 0 else [2.0, 0, 0, 0.5]
    model = StateSpaceModel.from_flat(a=a, b=[1, 1], c=[0, 1], dt=dt)
    mode = '1.5' if dt == 0 else '2'
    with pytest.raises(DesignError, match=rf'not detectable: the modes {mode} cannot be seen'):
        design_kalman(model, [1, 1], [1])


def test_kalman_noise_validation():
    model = random_model(0, 2, 1, 1)
    with pytest.raises(ConfigError, match='^measurement_noise: expected a positive definite'):
        design_kalman(model, [1, 1], [0])
    with pytest.raises(ConfigError, match='^process_noise: expected a symmetric'):
        design_kalman(model, [1, 2, 0, 1], [1])
    with pytest.raises(ConfigError, match='^process_noise: expected a positive semi'):
        design_kalman(model, [1, -1], [1])
    with pytest.raises(ConfigError, match='^process_noise: expected 2 diagonal'):
        design_kalman(model, [1, 1, 1], [1])


# --------------------------------------------------------------------------------------
# Sampling.
# --------------------------------------------------------------------------------------

def fine_noise_integral(a, q, dt):
    """``integral_0^dt expm(A s) Q expm(A s)^T ds`` by adaptive quadrature."""
    def integrand(s):
        propagator = scipy.linalg.expm(a * s)
        return propagator @ q @ propagator.T
    value, _ = scipy.integrate.quad_vec(integrand, 0.0, dt, epsabs=1e-15, epsrel=1e-12)
    return value


@pytest.mark.parametrize('dt', [1e-3, 0.05, 0.4, 1.5])
@pytest.mark.parametrize('seed', range(2))
def test_van_loan_against_quadrature(seed, dt):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((3, 3))
    root = rng.standard_normal((3, 3))
    q = root @ root.T
    qd = van_loan(a, q, dt)
    expected = fine_noise_integral(a, q, dt)
    np.testing.assert_allclose(qd, expected, rtol=1e-9, atol=1e-12 * np.abs(expected).max())
    np.testing.assert_array_equal(qd, qd.T)


def test_van_loan_singular_intensity_and_stable_lyapunov_form():
    # For Hurwitz A: Qd = S - Ad S Ad^T with A S + S A^T + Q = 0.
    a = np.array([[-1.0, 2.0], [0.0, -3.0]])
    q = np.array([[0.0, 0.0], [0.0, 4.0]])
    dt = 0.3
    s = scipy.linalg.solve_continuous_lyapunov(a, -q)
    ad = scipy.linalg.expm(a * dt)
    np.testing.assert_allclose(van_loan(a, q, dt), s - ad @ s @ ad.T, rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize('dt', [1e-3, 0.1, 2.0])
def test_zero_order_hold_against_quadrature(dt):
    rng = np.random.default_rng(3)
    a = rng.standard_normal((3, 3))
    b = rng.standard_normal((3, 2))
    ad, bd = zero_order_hold(a, b, dt)
    np.testing.assert_allclose(ad, scipy.linalg.expm(a * dt), rtol=1e-12)
    expected, _ = scipy.integrate.quad_vec(lambda s: scipy.linalg.expm(a * s) @ b, 0.0, dt,
                                           epsabs=1e-15, epsrel=1e-12)
    np.testing.assert_allclose(bd, expected, rtol=1e-9, atol=1e-13)


# --------------------------------------------------------------------------------------
# Reference gain.
# --------------------------------------------------------------------------------------

def steady_output(model, gain, reference_gain, r):
    """Equilibrium output of ``u = -K x + N r``, solved from the model equations."""
    closed = model.a - model.b @ gain
    forcing = model.b @ reference_gain @ r
    if model.is_discrete:
        x = np.linalg.solve(np.eye(model.n_states) - closed, forcing)
    else:
        x = np.linalg.solve(-closed, forcing)
    return model.c @ x + model.d @ (-gain @ x + reference_gain @ r)


@pytest.mark.parametrize('dt', [0.0, 0.1])
@pytest.mark.parametrize('with_d', [False, True])
def test_reference_gain_unit_dc_gain(with_d, dt):
    model = random_model(5, 4, 2, 2, with_d=with_d, dt=dt)
    poles = [-1, -2, -3, -4] if dt == 0 else [0.1, 0.2, 0.3, -0.4]
    design = design_feedback(model, poles=poles)
    assert design.reference_gain.shape == (2, 2)
    for r in (np.array([1.0, 0.0]), np.array([0.0, 1.0]), np.array([2.0, -3.0])):
        np.testing.assert_allclose(steady_output(model, design.gain, design.reference_gain, r),
                                   r, atol=1e-10)


def test_reference_gain_seed001_step_response():
    model = StateSpaceModel.from_flat(a=[0, 1, 0, 0, 0, 1, 0, -24, -10], b=[0, 10, -80],
                                      c=[1, 0, 0])
    design = design_feedback(model, poles=[-1 + 2j, -1 - 2j, -5])
    system = scipy.signal.StateSpace(model.a - model.b @ design.gain,
                                     model.b @ design.reference_gain, model.c, model.d)
    _, response = scipy.signal.step(system, T=np.linspace(0.0, 20.0, 401))
    assert response[-1] == pytest.approx(1.0, abs=1e-6)


def test_reference_gain_absent_when_not_square_or_zero_at_dc():
    non_square = random_model(0, 3, 1, 2)
    assert design_feedback(non_square, poles=[-1, -2, -3]).reference_gain is None
    # G(s) = s / (s^2 + 3 s + 2): a zero at s = 0, no reference gain can fix the DC gain.
    zero_at_dc = StateSpaceModel.from_flat(a=[0, 1, -2, -3], b=[0, 1], c=[0, 1])
    assert design_feedback(zero_at_dc, poles=[-4, -5]).reference_gain is None


# --------------------------------------------------------------------------------------
# Model construction errors.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('kwargs, message', [
    ({'a': [1, 2, 3], 'b': [1], 'c': [1]}, r'^A: expected a square matrix'),
    ({'a': np.eye(3).ravel(), 'b': [1, 2], 'c': [1, 0, 0]}, r'^B: expected 3xm'),
    ({'a': np.eye(3).ravel(), 'b': [1, 2, 3], 'c': [1, 0]}, r'^C: expected px3'),
    ({'a': np.eye(3).ravel(), 'b': [1, 2, 3], 'c': [1, 0, 0], 'd': [1, 2]},
     r'^D: expected 1x1 \(1 values, row-major\), got 2'),
    ({'a': np.eye(3).ravel(), 'b': [1, 2, 3], 'c': [1, 0, 0], 'dt': -0.1}, r'^dt: expected 0'),
    ({'a': np.eye(3).ravel(), 'b': [1, 2, 3], 'c': [1, 0, 0], 'dt': float('nan')},
     r'^dt: expected 0'),
    ({'a': [1, 0, float('nan'), 1], 'b': [1, 2], 'c': [1, 0]},
     r'^A: expected finite numbers, entry 2 is nan'),
    ({'a': [1, 0, 0, 1], 'b': [1, float('inf')], 'c': [1, 0]}, r'^B: expected finite'),
    ({'a': '1 0 0 1', 'b': [1, 2], 'c': [1, 0]}, r'^A: expected a list of numbers'),
    ({'a': [1, 0, 0, 1], 'b': [1, 2], 'c': [1, 0], 'state_names': ['x']},
     r'^state_names: expected 2 names, got 1'),
    ({'a': [1, 0, 0, 1], 'b': [1, 2], 'c': [1, 0], 'state_names': ['x', 'x']},
     r'^state_names: names must be unique'),
])
def test_model_shape_errors_name_the_argument(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        StateSpaceModel.from_flat(**kwargs)


def test_model_dimensions_inferred_from_flat_lists():
    model = StateSpaceModel.from_flat(a=np.arange(9.0), b=np.arange(6.0), c=np.arange(6.0),
                                      d=[1, 2, 3, 4], dt=0.1)
    assert (model.n_states, model.n_inputs, model.n_outputs) == (3, 2, 2)
    np.testing.assert_array_equal(model.b, [[0, 1], [2, 3], [4, 5]])
    np.testing.assert_array_equal(model.c, [[0, 1, 2], [3, 4, 5]])
    np.testing.assert_array_equal(model.d, [[1, 2], [3, 4]])
    assert model.is_discrete and model.state_names == ('x1', 'x2', 'x3')
    assert StateSpaceModel.from_flat([1, 0, 0, 1], [1, 2], [1, 0], d=[]).d.shape == (1, 1)


def test_from_matrices_keeps_the_matrices():
    rng = np.random.default_rng(0)
    a, b, c, d = (rng.standard_normal(shape) for shape in [(3, 3), (3, 2), (2, 3), (2, 2)])
    model = StateSpaceModel.from_matrices(a, b, c, d)
    for got, expected in zip((model.a, model.b, model.c, model.d), (a, b, c, d)):
        np.testing.assert_array_equal(got, expected)
    # A single input may be given as a flat vector.
    np.testing.assert_array_equal(
        StateSpaceModel.from_matrices(a, [1, 2, 3], c[:1]).b, [[1], [2], [3]])


@pytest.mark.parametrize('b, c, d, parameter', [
    (np.ones((4, 1)), np.ones((1, 3)), None, 'B'),
    (np.arange(6.0).reshape(2, 3), np.ones((1, 3)), None, 'B'),
    (np.ones((3, 1)), np.arange(6.0).reshape(3, 2), None, 'C'),
    (np.ones((3, 2)), np.ones((1, 3)), np.ones((2, 1)), 'D'),
])
def test_from_matrices_refuses_wrong_shapes(b, c, d, parameter):
    # A (2, 3) B for n = 3 is not an n x m matrix: it must be refused, not reshaped into
    # a (3, 2) matrix with scrambled entries.
    with pytest.raises(ConfigError, match=f'^{parameter}: expected') as info:
        StateSpaceModel.from_matrices(np.eye(3), b, c, d)
    assert info.value.parameter == parameter


def test_chen_draws_its_gain_for_large_models():
    # The Krylov rank test refused every random L beyond about 14 states; PBH does not.
    # Poles: a Kalman filter's for the unmeasured block, which keeps [C; T] well conditioned.
    rng = np.random.default_rng(8)
    n, p = 40, 4
    a = rng.standard_normal((n, n)) / np.sqrt(n) - 2.0 * np.eye(n)
    model = StateSpaceModel(a=a, b=rng.standard_normal((n, 1)), c=rng.standard_normal((p, n)),
                            d=np.zeros((p, 1)))
    blocks = partition_model(model, measured_first_transform(model, 'orthonormal'))
    poles = design_kalman(StateSpaceModel(a=blocks.abb, b=blocks.bb, c=blocks.aab,
                                          d=np.zeros((p, 1))),
                          np.ones(n - p), np.full(p, 0.01)).achieved_poles
    design = design_chen(model, poles)
    np.testing.assert_allclose(match(np.linalg.eigvals(design.f), poles), poles, rtol=1e-8)
