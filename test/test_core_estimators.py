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
Runtime estimators on the fourth-order plant of seed 001, sampled exactly.

The plant runs in the seed's coordinates (``A = O A O^-1``, ``B = O B``, ``C = C O^-1``
with ``O`` the observability matrix) from ``x0 = [3, 2, -3, -1]``. Each test computes the
per-interval error matrix itself, from the sampled plant and the requested poles, without
the estimator's ``last_step.error``, and checks that the estimation error ``x - x_hat`` at
every sample is the product of those matrices applied to the initial error, to ``1e-9``
of the initial error norm.

The placements use the shifted pair ``Ad - I`` (computed as ``A * integral expm``, without
cancellation) and poles ``expm1(lambda T)``: for short intervals ``Ad`` is close to ``I``
and the plain Ackermann formula on ``(Ad, ...)`` loses about ``cond(O) * eps``, which is
1e-10 relative at 1 ms, more than the test allows.
"""

import numpy as np
import pytest
import scipy.linalg
import scipy.optimize
import scipy.signal

from observer_ros.core import make_estimator
from observer_ros.core.errors import StampError
from observer_ros.core.estimators.constant_gain import ConstantGainEstimator
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers.chen.design import design_chen
from observer_ros.core.observers.full_order.design import design_full_order
from observer_ros.core.observers.kalman.design import design_kalman
from observer_ros.core.observers.reduced_order.design import design_reduced_order
from observer_ros.core.simulation import PlantSimulator
from observer_ros.core.streaming import EventStream
from observer_ros.core.units import NANOSECONDS

X0 = np.array([3.0, 2.0, -3.0, -1.0])
PERIODS_MS = [1, 10, 50]
EXACT_RTOL = 1e-9
FULL_POLES = [-8.0, -10.0, -12.0, -14.0]
CHEN_POLES = [-10.0, -12.0, -14.0]
REDUCED_POLES = [-10.0, -10.0, -10.0]
KALMAN_Q = np.eye(4)
KALMAN_R = np.array([[0.01]])


# --------------------------------------------------------------------------------------
# Independent reference computations.
# --------------------------------------------------------------------------------------

def obsv(a, c):
    """Return the observability matrix ``[C; C A; ...]``."""
    rows = [c]
    for _ in range(a.shape[0] - 1):
        rows.append(rows[-1] @ a)
    return np.vstack(rows)


def seed_plant():
    """Return the seed's fourth-order plant in observability coordinates."""
    a, b, c, _ = scipy.signal.zpk2ss([-2 + 2j, -2 - 2j], [-1, -1.5 + 2j, -1.5 - 2j, -3],
                                     2.344)
    o = obsv(a, c)
    inverse = np.linalg.inv(o)
    return StateSpaceModel.from_matrices(o @ a @ inverse, o @ b, c @ inverse)


def sampled(a, b, dt):
    """Return ``(Ad - I, Bd)`` of the zero-order hold, ``Ad - I`` free of cancellation."""
    n, m = b.shape
    block = np.zeros((n + n + m, n + n + m))
    block[:n, :n] = a * dt
    block[:n, n:2 * n] = np.eye(n) * dt
    block[:n, 2 * n:] = b * dt
    exponential = scipy.linalg.expm(block)
    integral = exponential[:n, n:2 * n]
    return a @ integral, exponential[:n, 2 * n:]


def ackermann_observer(a, c, poles):
    """Return ``L`` (single output) with ``eig(A - L C) = poles`` by Ackermann's formula."""
    n = a.shape[0]
    coefficients = np.real(np.poly(poles))
    polynomial = np.zeros_like(a)
    for coefficient in coefficients:
        polynomial = polynomial @ a + coefficient * np.eye(n)
    return polynomial @ np.linalg.solve(obsv(a, c), np.eye(n)[:, -1:])


def reduced_error_matrix(model, dt, poles):
    """``e -> Q^-1 [0; (Phi_bb - L Phi_ab) e_b]`` with ``Phi = Q Ad Q^-1``, ``Q = obsv``."""
    q = obsv(model.a, model.c)
    q_inverse = np.linalg.inv(q)
    delta = q @ sampled(model.a, model.b, dt)[0] @ q_inverse
    gain = ackermann_observer(delta[1:, 1:], delta[:1, 1:], np.expm1(np.multiply(poles, dt)))
    block = np.zeros_like(delta)
    block[1:, 1:] = np.eye(3) + delta[1:, 1:] - gain @ delta[:1, 1:]
    return q_inverse @ block @ q


def full_error_matrix(model, dt, poles):
    """``(I - M C) Ad`` with ``eig`` at ``exp(lambda dt)`` (current-estimator form)."""
    delta = sampled(model.a, model.b, dt)[0]
    ad = np.eye(4) + delta
    gain = ackermann_observer(delta, model.c @ ad, np.expm1(np.multiply(poles, dt)))
    return (np.eye(4) - gain @ model.c) @ ad


def chen_error_matrix(model, dt, f, gain):
    """``[C; T]^-1 [0; F_d T]`` with ``T Ad - F_d T = L_d C`` (``F_d``, ``L_d`` sampled)."""
    f_delta, l_d = sampled(f, gain, dt)
    f_d = np.eye(f.shape[0]) + f_delta
    ad = np.eye(4) + sampled(model.a, model.b, dt)[0]
    t = scipy.linalg.solve_sylvester(-f_d, ad, l_d @ model.c)
    inverse = np.linalg.inv(np.vstack([model.c, t]))
    return inverse[:, 1:] @ f_d @ t


def kalman_reference(model, dt, q, r):
    """Return ``(E, P, M, Qd, Ad)`` of the sampled steady-state filter (Lyapunov ``Qd``)."""
    ad = np.eye(4) + sampled(model.a, model.b, dt)[0]
    stationary = scipy.linalg.solve_continuous_lyapunov(model.a, -q)
    qd = stationary - ad @ stationary @ ad.T
    qd = 0.5 * (qd + qd.T)
    p = scipy.linalg.solve_discrete_are(ad.T, model.c.T, qd, r)
    m = p @ model.c.T @ np.linalg.inv(model.c @ p @ model.c.T + r)
    return (np.eye(4) - m @ model.c) @ ad, p, m, qd, ad


def run_and_compare(estimator, model, intervals_ns, error_matrix, inputs=None):
    """
    Run plant and estimator; return ``(actual errors, predicted errors)`` per sample.

    ``error_matrix(dt_ns)`` gives the designed matrix of each interval; the prediction
    starts from the error right after the first (initializing) sample.
    """
    plant = PlantSimulator(model, initial_state=X0)
    estimator.update(0, plant.measure(), np.zeros(1))
    predicted = plant.x - estimator.estimate
    actual_errors, predicted_errors = [predicted.copy()], [predicted.copy()]
    stamp = 0
    for index, dt_ns in enumerate(intervals_ns):
        u = np.zeros(1) if inputs is None else inputs[index]
        plant.step(u, dt_ns / NANOSECONDS)
        stamp += int(dt_ns)
        estimator.update(stamp, plant.measure(), u)
        predicted = error_matrix(int(dt_ns)) @ predicted
        actual_errors.append(plant.x - estimator.estimate)
        predicted_errors.append(predicted)
    return np.array(actual_errors), np.array(predicted_errors)


def assert_exact(actual, predicted):
    """Assert every sample's error equals the prediction to ``EXACT_RTOL`` of ``|e0|``."""
    scale = np.linalg.norm(predicted[0])
    assert scale > 0.1
    deviation = np.linalg.norm(actual - predicted, axis=1).max()
    assert deviation <= EXACT_RTOL * scale, deviation / scale


def cached(function):
    """Memoize ``function(dt_ns)``."""
    store = {}

    def wrapper(dt_ns):
        if dt_ns not in store:
            store[dt_ns] = function(dt_ns)
        return store[dt_ns]
    return wrapper


@pytest.fixture(scope='module')
def plant():
    """Return the seed plant."""
    return seed_plant()


@pytest.fixture(scope='module')
def reduced_design(plant):
    """Return the seed's reduced-order design (L = [23, 117.75, -347])."""
    design = design_reduced_order(plant, poles=REDUCED_POLES, coordinates='observability')
    np.testing.assert_allclose(design.gain.ravel(), [23.0, 117.75, -347.0], rtol=1e-8)
    return design


# --------------------------------------------------------------------------------------
# The plant simulation the checks rely on.
# --------------------------------------------------------------------------------------

def test_plant_simulator_is_exact(plant):
    simulator = PlantSimulator(plant, initial_state=X0)
    u = np.array([0.7])
    for _ in range(25):
        simulator.step(u, 0.04)
    block = np.zeros((5, 5))
    block[:4, :4] = plant.a
    block[:4, 4:] = plant.b
    expected = (scipy.linalg.expm(block * 1.0) @ np.concatenate([X0, u]))[:4]
    np.testing.assert_allclose(simulator.x, expected, rtol=1e-11, atol=1e-12)
    np.testing.assert_allclose(simulator.measure(), plant.c @ expected, rtol=1e-11)


def test_plant_simulator_noise_is_seeded(plant):
    runs = []
    for _ in range(2):
        simulator = PlantSimulator(plant, initial_state=X0, process_noise=[1, 1, 1, 1],
                                   measurement_noise=[0.01], seed=42)
        runs.append([np.concatenate([simulator.step([0.0], 0.01), simulator.measure()])
                     for _ in range(5)])
    np.testing.assert_array_equal(runs[0], runs[1])
    noiseless = PlantSimulator(plant, initial_state=X0)
    assert not np.allclose(runs[0][0][:4], noiseless.step([0.0], 0.01))


# --------------------------------------------------------------------------------------
# Reduced-order estimator of the seed.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('period_ms', PERIODS_MS)
def test_reduced_order_error_is_designed_product(plant, reduced_design, period_ms):
    dt = period_ms / 1000.0
    dt_ns = period_ms * 1_000_000
    estimator = make_estimator(reduced_design, initial_state=np.zeros(4))
    reference = cached(lambda ns: reduced_error_matrix(plant, ns / NANOSECONDS, REDUCED_POLES))
    steps = int(round(2.0 / dt))
    actual, predicted = run_and_compare(estimator, plant, [dt_ns] * steps, reference)
    # The first sample makes the estimate agree with y: x_hat = [3, 0, 0, 0].
    np.testing.assert_allclose(actual[0], X0 - [3.0, 0.0, 0.0, 0.0], atol=1e-12)
    assert_exact(actual, predicted)
    # Per-step error matrix: exp(-10 T) three times, and 0 for the measured direction.
    rho = np.exp(-10.0 * dt)
    wanted = np.poly([rho, rho, rho, 0.0])
    for matrix in (estimator.last_step.error, reference(dt_ns)):
        np.testing.assert_allclose(np.poly(matrix), wanted, rtol=0, atol=1e-12)
        eigenvalues = np.sort_complex(np.linalg.eigvals(matrix))
        assert abs(eigenvalues[0]) <= 1e-12
        np.testing.assert_allclose(eigenvalues[1:], rho, rtol=1e-4)
    np.testing.assert_allclose(estimator.last_step.poles, [rho] * 3, rtol=1e-12)


def test_reduced_order_error_norms_at_10ms(plant, reduced_design):
    estimator = make_estimator(reduced_design, initial_state=np.zeros(4))
    actual, _ = run_and_compare(estimator, plant, [10_000_000] * 200, lambda ns: np.eye(4))
    norms = np.linalg.norm(actual, axis=1)
    assert norms[100] == pytest.approx(2.04e-2, rel=1e-2)
    assert norms[200] == pytest.approx(5.6e-6, rel=1e-2)
    # The error converges: 0 in the measured coordinate, decaying in the others.
    assert np.all(np.abs(actual[:, 0]) <= 1e-12)
    assert norms[200] < norms[150] < norms[100]


def jittered_intervals(seed, period_ns, total_ns, jitter):
    """Return seeded random intervals ``period (1 +- jitter)`` summing to ``total_ns``."""
    rng = np.random.default_rng(seed)
    intervals, elapsed = [], 0
    while elapsed < total_ns:
        interval = int(round(period_ns * (1.0 + rng.uniform(-jitter, jitter))))
        interval = min(interval, total_ns - elapsed)
        intervals.append(interval)
        elapsed += interval
    return intervals


@pytest.mark.parametrize('seed', range(3))
def test_reduced_order_jitter(plant, reduced_design, seed):
    nominal = make_estimator(reduced_design, initial_state=np.zeros(4))
    steady, _ = run_and_compare(nominal, plant, [10_000_000] * 200, lambda ns: np.eye(4))
    intervals = jittered_intervals(seed, 10_000_000, 2 * NANOSECONDS, 0.5)
    assert sum(intervals) == 2 * NANOSECONDS
    assert len(set(intervals)) > 100
    estimator = make_estimator(reduced_design, initial_state=np.zeros(4))
    reference = cached(lambda ns: reduced_error_matrix(plant, ns / NANOSECONDS, REDUCED_POLES))
    actual, predicted = run_and_compare(estimator, plant, intervals, reference)
    assert_exact(actual, predicted)
    assert np.linalg.norm(actual[-1]) <= 2.0 * np.linalg.norm(steady[-1])


@pytest.mark.parametrize('resolution_ns', [10_000, 1_000_000])
def test_interval_resolution_rounds_intervals_and_bounds_designs(plant, reduced_design,
                                                                 resolution_ns):
    intervals = jittered_intervals(5, 10_000_000, NANOSECONDS, 0.1)
    assert len(set(intervals)) > 90
    rng = np.random.default_rng(6)
    ys = rng.standard_normal((len(intervals) + 1, 1))
    us = rng.standard_normal((len(intervals) + 1, 1))
    stamps = np.concatenate(([0], np.cumsum(intervals)))
    coarse = make_estimator(reduced_design, interval_resolution_ns=resolution_ns)
    designs = []
    design_step = coarse.design.step
    coarse.design.step = lambda dt_ns: designs.append(dt_ns) or design_step(dt_ns)
    got = update_loop(coarse, stamps, ys, us)
    # Each interval is designed for its nearest multiple of the resolution, once.
    rounded = [max(1, round(i / resolution_ns)) * resolution_ns for i in intervals]
    assert sorted(designs) == sorted(set(rounded))
    assert len(designs) <= 2_000_000 // resolution_ns + 2  # +-10 % jitter, the last interval
    # ... which is exactly the estimator on stamps whose intervals are those multiples.
    exact = make_estimator(reduced_design)
    expected = update_loop(exact, np.concatenate(([0], np.cumsum(rounded))), ys, us)
    assert np.array_equal(got, expected)
    # Changing the resolution forgets the designs of the old one; 0 is exact again.
    designs.clear()
    coarse.interval_resolution_ns = 0
    coarse.step_matrices(intervals[0])
    assert designs == [intervals[0]]
    with pytest.raises(ValueError, match='interval_resolution_ns'):
        coarse.interval_resolution_ns = -1


def test_reduced_order_with_input(plant, reduced_design):
    # The held input drives plant and estimator alike: the error does not see it.
    rng = np.random.default_rng(11)
    inputs = rng.uniform(-2.0, 2.0, size=(100, 1))
    estimator = make_estimator(reduced_design, initial_state=[1.0, -1.0, 0.5, 2.0])
    reference = cached(lambda ns: reduced_error_matrix(plant, ns / NANOSECONDS, REDUCED_POLES))
    actual, predicted = run_and_compare(estimator, plant, [20_000_000] * 100, reference,
                                        inputs)
    assert_exact(actual, predicted)


# --------------------------------------------------------------------------------------
# Full-order, Chen and Kalman estimators.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('period_ms', PERIODS_MS)
def test_full_order_error_is_designed_product(plant, period_ms):
    dt = period_ms / 1000.0
    design = design_full_order(plant, poles=FULL_POLES)
    estimator = make_estimator(design, initial_state=np.zeros(4))
    reference = cached(lambda ns: full_error_matrix(plant, ns / NANOSECONDS, FULL_POLES))
    rng = np.random.default_rng(period_ms)
    steps = int(round(1.0 / dt))
    inputs = rng.uniform(-1.0, 1.0, size=(steps, 1))
    actual, predicted = run_and_compare(estimator, plant, [period_ms * 1_000_000] * steps,
                                        reference, inputs)
    np.testing.assert_allclose(actual[0], X0, atol=1e-12)
    assert_exact(actual, predicted)
    eigenvalues = np.sort(np.linalg.eigvals(estimator.last_step.error).real)
    np.testing.assert_allclose(eigenvalues, np.sort(np.exp(np.multiply(FULL_POLES, dt))),
                               rtol=1e-9)


@pytest.mark.parametrize('period_ms', PERIODS_MS)
def test_chen_error_is_designed_product(plant, period_ms):
    dt = period_ms / 1000.0
    design = design_chen(plant, poles=CHEN_POLES, seed=3)
    estimator = make_estimator(design, initial_state=np.zeros(4))
    reference = cached(lambda ns: chen_error_matrix(plant, ns / NANOSECONDS, design.f,
                                                    design.gain))
    rng = np.random.default_rng(period_ms + 1)
    steps = int(round(1.0 / dt))
    inputs = rng.uniform(-1.0, 1.0, size=(steps, 1))
    actual, predicted = run_and_compare(estimator, plant, [period_ms * 1_000_000] * steps,
                                        reference, inputs)
    assert abs(plant.c @ actual[0]) <= 1e-12
    assert_exact(actual, predicted)
    expected = np.concatenate([[0.0], np.sort(np.exp(np.multiply(CHEN_POLES, dt)))])
    for matrix in (estimator.last_step.error, reference(period_ms * 1_000_000)):
        eigenvalues = np.sort(np.linalg.eigvals(matrix).real)
        np.testing.assert_allclose(eigenvalues, expected, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize('period_ms', PERIODS_MS)
def test_kalman_error_is_designed_product_and_dare_consistent(plant, period_ms):
    dt = period_ms / 1000.0
    dt_ns = period_ms * 1_000_000
    design = design_kalman(plant, KALMAN_Q.ravel(), KALMAN_R.ravel())
    estimator = make_estimator(design, initial_state=np.zeros(4))
    assert estimator.covariance is None
    matrix, p, m, qd, ad = kalman_reference(plant, dt, KALMAN_Q, KALMAN_R)
    rng = np.random.default_rng(period_ms + 2)
    steps = int(round(1.0 / dt))
    inputs = rng.uniform(-1.0, 1.0, size=(steps, 1))
    actual, predicted = run_and_compare(estimator, plant, [dt_ns] * steps,
                                        lambda ns: matrix, inputs)
    assert_exact(actual, predicted)
    step = estimator.last_step
    # The measurement columns of G are the filter gain M of the sampled DARE.
    np.testing.assert_allclose(step.g[:4, 5:], m, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(estimator.covariance, (np.eye(4) - m @ plant.c) @ p,
                               rtol=1e-8, atol=1e-14)
    # Steady state: the a-priori covariance rebuilt from the reported filtered one solves
    # the DARE of the sampled plant.
    filtered = estimator.covariance
    prior = ad @ filtered @ ad.T + qd
    innovation = plant.c @ prior @ plant.c.T + KALMAN_R
    residual = (ad @ prior @ ad.T - prior + qd
                - ad @ prior @ plant.c.T @ np.linalg.solve(innovation, plant.c @ prior @ ad.T))
    assert np.abs(residual).max() <= 1e-10 * np.abs(prior).max()
    np.testing.assert_allclose(prior, p, rtol=1e-8, atol=1e-14)
    np.testing.assert_allclose(filtered, filtered.T, atol=1e-14)
    assert np.linalg.eigvalsh(filtered).min() > 0.0


# --------------------------------------------------------------------------------------
# A discrete-time model: one step per sample, whatever the stamps.
# --------------------------------------------------------------------------------------

def test_discrete_model_reduced_order(plant):
    dt = 0.02
    delta, bd = sampled(plant.a, plant.b, dt)
    discrete = StateSpaceModel.from_matrices(np.eye(4) + delta, bd, plant.c, dt=dt)
    poles = np.exp(np.multiply(REDUCED_POLES, dt))
    design = design_reduced_order(discrete, poles=poles, coordinates='orthonormal')
    estimator = make_estimator(design, initial_state=np.zeros(4))
    reference = reduced_error_matrix(plant, dt, REDUCED_POLES)
    plant_sim = PlantSimulator(discrete, initial_state=X0)
    estimator.update(0, plant_sim.measure(), [0.0])
    error = plant_sim.x - estimator.estimate
    scale = np.linalg.norm(error)
    stamp, first = 0, None
    for interval in [5, 17, 1, 3000, 20] * 10:
        stamp += interval
        plant_sim.step([0.0], dt)
        estimator.update(stamp, plant_sim.measure(), [0.0])
        error = reference @ error
        assert np.linalg.norm(plant_sim.x - estimator.estimate - error) <= EXACT_RTOL * scale
        first = estimator.last_step.g if first is None else first
        np.testing.assert_array_equal(estimator.last_step.g, first)


# --------------------------------------------------------------------------------------
# Stamps, bad samples, reset, replace_design, run and the cache.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('second_stamp', [1_000, 999, 0, -5])
def test_stamp_error_for_equal_or_backward_stamps(plant, reduced_design, second_stamp):
    estimator = make_estimator(reduced_design)
    estimator.update(1_000, plant.c @ X0, [0.0])
    before = estimator.estimate
    with pytest.raises(StampError, match='not after the previous sample'):
        estimator.update(second_stamp, plant.c @ X0, [0.0])
    np.testing.assert_array_equal(estimator.estimate, before)
    assert estimator.stamp_ns == 1_000
    assert estimator.last_step is None
    estimator.update(1_000 + 10_000_000, plant.c @ X0, [0.0])
    assert estimator.stamp_ns == 1_000 + 10_000_000


@pytest.mark.parametrize('y, u', [([1.0, 2.0], [0.0]), ([], [0.0]), ([np.nan], [0.0]),
                                  ([np.inf], [0.0]), ([1.0], [0.0, 1.0]), ([1.0], [np.nan])])
@pytest.mark.parametrize('initialized', [False, True])
def test_bad_sample_leaves_estimate_unchanged(plant, reduced_design, y, u, initialized):
    estimator = make_estimator(reduced_design, initial_state=[0.5, 0.0, 0.0, 0.0])
    twin = make_estimator(reduced_design, initial_state=[0.5, 0.0, 0.0, 0.0])
    if initialized:
        for target in (estimator, twin):
            target.update(0, [3.0], [0.0])
            target.update(10_000_000, [2.9], [0.1])
    before, stamp = estimator.estimate, estimator.stamp_ns
    with pytest.raises(ValueError):
        estimator.update(20_000_000, y, u)
    np.testing.assert_array_equal(estimator.estimate, before)
    assert estimator.stamp_ns == stamp
    # The rejected sample left no trace: the next good one gives the twin's result.
    np.testing.assert_array_equal(estimator.update(30_000_000, [2.5], [0.2]),
                                  twin.update(30_000_000, [2.5], [0.2]))


def test_reset(plant, reduced_design):
    estimator = make_estimator(reduced_design, initial_state=np.zeros(4))
    run_and_compare(estimator, plant, [10_000_000] * 10, lambda ns: np.eye(4))
    estimator.reset([1.0, 1.0, 1.0, 1.0])
    assert estimator.stamp_ns is None and estimator.last_step is None
    np.testing.assert_array_equal(estimator.estimate, np.ones(4))
    # After a reset, stamps may start anywhere (even earlier).
    estimator.update(5, [2.0], [0.0])
    np.testing.assert_allclose(estimator.estimate, [2.0, 1.0, 1.0, 1.0], atol=1e-12)


def test_replace_design_keeps_estimate_continuous(plant, reduced_design):
    dt_ns = 10_000_000
    estimator = make_estimator(reduced_design, initial_state=np.zeros(4))
    simulator = PlantSimulator(plant, initial_state=X0)
    estimator.update(0, simulator.measure(), [0.0])
    for k in range(1, 31):
        simulator.step([0.0], dt_ns / NANOSECONDS)
        estimator.update(k * dt_ns, simulator.measure(), [0.0])
    before, stamp = estimator.estimate, estimator.stamp_ns
    faster = design_reduced_order(plant, poles=[-20, -20, -20], coordinates='observability')
    estimator.adopt(make_estimator(faster))
    np.testing.assert_array_equal(estimator.estimate, before)
    assert estimator.stamp_ns == stamp
    # The next interval runs the new design from the old estimate: no jump.
    error = simulator.x - estimator.estimate
    scale = np.linalg.norm(error)
    new_matrix = reduced_error_matrix(plant, dt_ns / NANOSECONDS, [-20, -20, -20])
    for k in range(31, 61):
        simulator.step([0.0], dt_ns / NANOSECONDS)
        estimator.update(k * dt_ns, simulator.measure(), [0.0])
        error = new_matrix @ error
        assert np.linalg.norm(simulator.x - estimator.estimate - error) <= EXACT_RTOL * scale
    np.testing.assert_allclose(estimator.last_step.poles, [np.exp(-0.2)] * 3, rtol=1e-12)
    other = design_full_order(StateSpaceModel.from_flat([-1, 0, 0, -2], [1, 1], [1, 1]),
                              poles=[-3, -4])
    with pytest.raises(ValueError, match='other dimensions'):
        estimator.adopt(make_estimator(other))


def update_loop(estimator, stamps, outputs, inputs) -> np.ndarray:
    """Update over recorded rows; row ``k`` of ``inputs`` is held from sample ``k-1`` to ``k``."""
    return np.array([estimator.update(int(stamp), y, u).copy()
                     for stamp, y, u in zip(stamps, outputs, inputs)])


def test_replay_equals_update_loop(plant, reduced_design):
    stamps = np.cumsum([0] + [10_000_000] * 20 + [13_000_000] * 5)
    rng = np.random.default_rng(5)
    outputs = rng.standard_normal((stamps.size, 1))
    inputs = rng.standard_normal((stamps.size, 1))
    # The input held over the interval ending at k is the one stamped at sample k-1.
    stream = EventStream(make_estimator(reduced_design), max_gap_ns=NANOSECONDS)
    batch = stream.replay(stamps[:-1], inputs[1:], stamps, outputs).estimates
    expected = update_loop(make_estimator(reduced_design), stamps, outputs, inputs)
    assert batch.shape == (stamps.size, 4)
    np.testing.assert_array_equal(batch, expected)


def test_cache_hit_at_steady_rate(plant, reduced_design):
    estimator = make_estimator(reduced_design)
    estimator.update(0, [3.0], [0.0])
    estimator.update(10_000_000, [2.9], [0.0])
    first = estimator.last_step
    for k in range(2, 12):
        estimator.update(k * 10_000_000, [2.9], [0.0])
        assert estimator.last_step is first
    assert estimator.step_matrices(10_000_000) is first
    estimator.update(11 * 10_000_000 + 7_000_000, [2.9], [0.0])
    assert estimator.last_step is not first
    estimator.update(12 * 10_000_000 + 7_000_000, [2.9], [0.0])
    assert estimator.last_step is first


def test_cache_evicts_least_recently_used(plant, reduced_design):
    estimator = ConstantGainEstimator(make_estimator(reduced_design).design, cache_size=2)
    a = estimator.step_matrices(10_000_000)
    b = estimator.step_matrices(20_000_000)
    assert estimator.step_matrices(10_000_000) is a
    estimator.step_matrices(30_000_000)
    assert estimator.step_matrices(10_000_000) is a
    c = estimator.step_matrices(20_000_000)
    assert c is not b
    np.testing.assert_array_equal(c.g, b.g)


# --------------------------------------------------------------------------------------
# Several outputs, dense C, jittered stamps: the step matrices are exact by construction.
# --------------------------------------------------------------------------------------

def stable_mimo_model(seed):
    """Return a seeded stable model with 5 states, 2 inputs and 2 outputs (dense C)."""
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((5, 5))
    a -= (np.linalg.eigvals(a).real.max() + 0.5) * np.eye(5)
    return StateSpaceModel.from_matrices(a, rng.standard_normal((5, 2)),
                                         rng.standard_normal((2, 5)))


MIMO_DESIGNS = {
    'full_order': lambda model: design_full_order(model, poles=[-3, -4, -5, -6 + 1j, -6 - 1j]),
    'reduced_order': lambda model: design_reduced_order(model, poles=[-3, -4 + 1j, -4 - 1j]),
    'chen': lambda model: design_chen(model, poles=[-3, -4 + 1j, -4 - 1j]),
    'kalman': lambda model: design_kalman(model, np.ones(5), [0.1, 0.2]),
}


@pytest.mark.parametrize('period_ms', [1, 10, 100])
@pytest.mark.parametrize('kind', sorted(MIMO_DESIGNS))
def test_mimo_step_matrices_are_exact(kind, period_ms):
    # x_hat_new = E x_hat + G_u u + G_y y is exact for every x, x_hat and u if and only if
    # E = (I - G_y C) Ad and G_u = (I - G_y C) Bd; the error then obeys e_new = E e.
    model = stable_mimo_model(period_ms)
    design = MIMO_DESIGNS[kind](model)
    estimator = make_estimator(design, initial_state=np.zeros(5))
    rng = np.random.default_rng(period_ms + 100)
    plant = PlantSimulator(model, initial_state=rng.standard_normal(5))
    estimator.update(0, plant.measure(), np.zeros(2))
    error = plant.x - estimator.estimate
    scale = np.linalg.norm(error)
    if kind in ('reduced_order', 'chen'):
        np.testing.assert_allclose(model.c @ error, 0.0, atol=1e-12)
    stamp = 0
    for _ in range(60):
        dt_ns = int(period_ms * 1_000_000 * (1.0 + rng.uniform(-0.3, 0.3)))
        u = rng.standard_normal(2)
        delta, bd = sampled(model.a, model.b, dt_ns / NANOSECONDS)
        ad = np.eye(5) + delta
        previous = error
        plant.step(u, dt_ns / NANOSECONDS)
        stamp += dt_ns
        estimator.update(stamp, plant.measure(), u)
        g = estimator.last_step.g
        error_block, input_block, output_block = g[:5, :5], g[:5, 5:7], g[:5, 7:]
        correction = np.eye(5) - output_block @ model.c
        np.testing.assert_allclose(error_block, correction @ ad, atol=1e-10)
        np.testing.assert_allclose(input_block, correction @ bd, atol=1e-10)
        np.testing.assert_allclose(g[5:], np.hstack([-model.c @ ad, -model.c @ bd, np.eye(2)]),
                                   atol=1e-12)
        np.testing.assert_allclose(estimator.innovation, model.c @ ad @ previous,
                                   atol=1e-9 * scale)
        error = error_block @ error
        assert np.linalg.norm(plant.x - estimator.estimate - error) <= EXACT_RTOL * scale
    dt = dt_ns / NANOSECONDS
    eigenvalues = np.linalg.eigvals(estimator.last_step.error)
    if kind == 'kalman':
        delta = sampled(model.a, model.b, dt)[0]
        ad = np.eye(5) + delta
        stationary = scipy.linalg.solve_continuous_lyapunov(model.a, -np.eye(5))
        qd = stationary - ad @ stationary @ ad.T
        r = np.diag([0.1, 0.2])
        p = scipy.linalg.solve_discrete_are(ad.T, model.c.T, 0.5 * (qd + qd.T), r)
        gain = p @ model.c.T @ np.linalg.inv(model.c @ p @ model.c.T + r)
        np.testing.assert_allclose(estimator.last_step.g[:5, 7:], gain, rtol=1e-7, atol=1e-12)
        return
    wanted = np.exp(np.asarray(design.requested_poles) * dt)
    if kind != 'full_order':
        wanted = np.concatenate([wanted, [0.0, 0.0]])
    rows, cols = scipy.optimize.linear_sum_assignment(
        np.abs(eigenvalues[:, None] - wanted[None, :]))
    np.testing.assert_allclose(eigenvalues[rows], wanted[cols], atol=1e-9)


def test_estimators_take_a_feedthrough():
    # Refused before (D: the runtime estimators need D = 0); test_core_feedthrough.py
    # checks the numbers of every type.
    rng = np.random.default_rng(0)
    model = StateSpaceModel.from_matrices(rng.standard_normal((3, 3)) - 3 * np.eye(3),
                                          np.ones((3, 1)), [[1.0, 0.0, 0.0]], [[0.5]])
    estimator = make_estimator(design_full_order(model, poles=[-4, -5, -6]))
    assert estimator.feedthrough.tolist() == [[0.5]]
    np.testing.assert_array_equal(estimator.update(0, [1.5], [0.0], [1.0]),
                                  [1.0, 0.0, 0.0])  # C^+ (y - D u_now)


def test_discrete_given_gain_with_singular_a():
    model = StateSpaceModel.from_flat(a=[0, 1, 0, 0], b=[0, 1], c=[1, 0], dt=0.1)
    design = design_full_order(model, gain=[0.5, 0.1])
    with pytest.raises(ValueError, match='^gain: '):
        make_estimator(design)


def test_advance_many_equals_advance_bit_for_bit(plant):
    # The batch replay path: same products, jittered stamps, Kalman covariance kept.
    rng = np.random.default_rng(4)
    stamps = np.cumsum(rng.integers(9_000_000, 11_000_000, size=300)).astype(np.int64)
    outputs = rng.standard_normal((300, plant.n_outputs))
    inputs = rng.standard_normal((300, plant.n_inputs))
    for design in (design_kalman(plant, np.ones(plant.n_states), [0.01]),
                   design_chen(plant, [-7.0, -8.0, -9.0]),
                   design_reduced_order(plant, [-6.0, -7.0, -8.0])):
        one, many = make_estimator(design), make_estimator(design)
        expected = [one.advance(int(s), y, u).copy() for s, y, u in zip(stamps, outputs, inputs)]
        estimates, innovations = many.advance_many(stamps, outputs, inputs)
        assert np.array_equal(estimates, expected)
        assert np.array_equal(innovations[-1], one.innovation)
        assert many.stamp_ns == one.stamp_ns
        assert np.array_equal(many.estimate, one.estimate)
        if design.kind == 'kalman':
            assert np.array_equal(many.covariance, one.covariance)
        # Both go on identically.
        assert np.array_equal(many.update(int(stamps[-1]) + 10_000_000, outputs[0], inputs[0]),
                              one.update(int(stamps[-1]) + 10_000_000, outputs[0], inputs[0]))
