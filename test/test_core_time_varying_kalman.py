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
The time-varying Kalman filter against an independent reference, its limits and its NIS.

The reference is plain numpy written here: scipy's ``expm`` for the sampled model, a
quadrature-free Van Loan block for ``Qd`` and the textbook predict/update with the Joseph
form. The filter under test shares none of that code.
"""

import numpy as np
import pytest
import scipy.linalg
import scipy.stats

from conftest import CONFIG_DIR
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core import make_estimator, TimeVaryingKalman
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers.kalman.design import design_kalman, design_sampled_kalman
from observer_ros.core.simulation import PlantSimulator
from observer_ros.core.streaming import EventStream

PERIOD_NS = 10_000_000
MODEL = StateSpaceModel.from_matrices([[0.0, 1.0], [-4.0, -0.4]], [[0.0], [1.0]],
                                      [[1.0, 0.0]])
Q = np.diag([0.0, 0.5])
R = np.array([[0.01]])


#: Jitter: intervals drawn uniformly from 0.5 ... 1.5 periods; ``levels`` distinct values
#: keep long runs fast (each distinct interval is sampled once), None draws them freely.
JITTER_LEVELS = 41


def jittered_stamps(count, rng, start=10 ** 9, levels=JITTER_LEVELS):
    if levels is None:
        steps = (PERIOD_NS * rng.uniform(0.5, 1.5, size=count - 1)).astype(np.int64)
    else:
        grid = (PERIOD_NS * np.linspace(0.5, 1.5, levels)).astype(np.int64)
        steps = rng.choice(grid, size=count - 1)
    return np.concatenate([[start], start + np.cumsum(steps)])


def reference_filter(model, q, r, p0, stamps, ys, us):
    """Plain numpy Kalman filter (own sampling, own Joseph update)."""
    n, m = model.n_states, model.n_inputs
    c = model.c
    x, p = np.zeros(n), p0.copy()
    out = []
    for k, stamp in enumerate(stamps):
        if k:
            dt = (stamp - stamps[k - 1]) / 1e9
            block = np.zeros((n + m, n + m))
            block[:n, :n], block[:n, n:] = model.a * dt, model.b * dt
            phi = scipy.linalg.expm(block)
            ad, bd = phi[:n, :n], phi[:n, n:]
            van_loan = np.zeros((2 * n, 2 * n))
            van_loan[:n, :n], van_loan[:n, n:], van_loan[n:, n:] = -model.a, q, model.a.T
            gamma = scipy.linalg.expm(van_loan * dt)
            qd = gamma[n:, n:].T @ gamma[:n, n:]
            x = ad @ x + bd @ us[k - 1]
            p = ad @ p @ ad.T + 0.5 * (qd + qd.T)
        s = c @ p @ c.T + r
        gain = p @ c.T @ np.linalg.inv(s)
        x = x + gain @ (ys[k] - c @ x)
        joseph = np.eye(n) - gain @ c
        p = joseph @ p @ joseph.T + gain @ r @ gain.T
        out.append((x.copy(), p.copy()))
    return out


def simulate(model, stamps, q, r, seed):
    rng = np.random.default_rng(seed)
    plant = PlantSimulator(model, [1.0, -0.5], process_noise=np.ravel(q),
                           measurement_noise=np.ravel(r), seed=seed)
    ys, us, xs = [], [], []
    for k, stamp in enumerate(stamps):
        ys.append(plant.measure().copy())
        xs.append(plant.x.copy())
        u = rng.uniform(-1.0, 1.0, size=1)
        us.append(u)
        if k + 1 < len(stamps):
            plant.step(u, (stamps[k + 1] - stamp) / 1e9)
    return np.array(ys), np.array(us), np.array(xs)


def test_jittered_estimates_and_covariances_equal_an_independent_filter():
    rng = np.random.default_rng(7)
    stamps = jittered_stamps(400, rng, levels=None)  # every interval a new one
    ys, us, _ = simulate(MODEL, stamps, Q, R, 7)
    p0 = np.diag([2.0, 3.0])
    kf = TimeVaryingKalman(MODEL, Q, R, p0)
    reference = reference_filter(MODEL, Q, R, p0, stamps, ys, us)
    for k, stamp in enumerate(stamps):
        x = kf.update(int(stamp), ys[k], us[k - 1] if k else np.zeros(1))
        expected_x, expected_p = reference[k]
        np.testing.assert_allclose(x, expected_x, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(kf.covariance, expected_p, rtol=1e-9, atol=1e-14)


def test_at_a_fixed_rate_the_gain_converges_to_the_steady_state_filter():
    steady = design_sampled_kalman(MODEL, np.ravel(Q), np.ravel(R), PERIOD_NS / 1e9)
    kf = TimeVaryingKalman(MODEL, Q, R, np.eye(2) * 100.0)
    for k in range(3000):
        kf.update(k * PERIOD_NS, [0.0], [0.0])
    np.testing.assert_allclose(kf.gain, steady.filter_gain, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(kf.covariance, steady.filtered_covariance, rtol=1e-8,
                               atol=1e-14)


def test_the_covariance_stays_symmetric_positive_definite_on_an_ill_conditioned_model():
    # Time scales from 1 ms to 1000 s, a nearly unobservable direction and a tiny R: P's
    # eigenvalues span about 13 orders of magnitude.
    a = np.diag([-1e3, -1e-3, 0.0])
    a[2, 1] = 1e-4
    model = StateSpaceModel.from_matrices(a, [[1.0], [0.0], [0.0]], [[1.0, 1e-6, 1e-3]])
    kf = TimeVaryingKalman(model, np.diag([1e4, 1e-8, 1e-10]), [[1e-10]], np.eye(3) * 1e6)
    rng = np.random.default_rng(3)
    stamps = jittered_stamps(1_000_000, rng, levels=11)
    ys = rng.normal(size=len(stamps)) * 1e-5
    zero = np.zeros(1)
    worst = np.inf
    for k, stamp in enumerate(stamps.tolist()):
        kf.advance(stamp, ys[k:k + 1], zero)
        if k % 1000 == 0:
            p = kf.covariance
            assert np.array_equal(p, p.T)
            worst = min(worst, np.linalg.eigvalsh(p).min() / np.linalg.eigvalsh(p).max())
    assert np.linalg.eigvalsh(kf.covariance).min() > 0.0
    assert worst > 0.0


def test_measured_error_matches_the_covariance_with_jitter():
    rng = np.random.default_rng(11)
    stamps = jittered_stamps(100_000, rng)
    ys, us, xs = simulate(MODEL, stamps, Q, R, 11)
    kf = TimeVaryingKalman(MODEL, Q, R, np.eye(2))
    errors, traces = [], []
    for k, stamp in enumerate(stamps.tolist()):
        x = kf.advance(stamp, ys[k], us[k - 1] if k else np.zeros(1))
        if k >= 1000:  # after the start-up transient
            errors.append(np.sum((xs[k] - x) ** 2))
            traces.append(np.trace(kf.covariance))
    ratio = np.mean(errors) / np.mean(traces)
    assert 0.97 <= ratio <= 1.03, ratio


@pytest.mark.parametrize('r_scale,inside', [(1.0, True), (0.1, False)])
def test_nis_lies_in_its_chi_square_band_only_for_the_right_noise(r_scale, inside):
    rng = np.random.default_rng(5)
    stamps = jittered_stamps(20_000, rng)
    ys, us, _ = simulate(MODEL, stamps, Q, R, 5)
    kf = TimeVaryingKalman(MODEL, Q, R * r_scale, np.eye(2))
    nis = []
    for k, stamp in enumerate(stamps.tolist()):
        kf.advance(stamp, ys[k], us[k - 1] if k else np.zeros(1))
        nis.append(kf.nis)
    samples = np.array(nis[500:])
    count, p = len(samples), MODEL.n_outputs
    low, high = scipy.stats.chi2.ppf([0.005, 0.995], count * p) / count
    assert bool(low <= samples.mean() <= high) is inside, (samples.mean(), low, high)


def test_the_configured_type_runs_the_time_varying_filter_through_the_stream():
    params = load_parameter_file(str(CONFIG_DIR / 'kalman_time_varying.yaml'))
    system = validate_parameters(params)
    assert isinstance(system.observer.make_estimator(), TimeVaryingKalman)
    steady = validate_parameters(dict(params, **{'observer.time_varying': False}))
    assert not isinstance(steady.observer.make_estimator(), TimeVaryingKalman)
    rng = np.random.default_rng(2)
    stamps = jittered_stamps(200, rng)
    live = system.make_stream()
    out = []
    for k, stamp in enumerate(stamps.tolist()):
        out += live.add_input(stamp, [0.1])
        out += live.add_measurement(stamp, [np.sin(k / 10)])
    batch = system.make_stream()
    result = batch.replay(stamps, np.full((len(stamps), 1), 0.1), stamps,
                          np.sin(np.arange(len(stamps)) / 10)[:, None])
    assert np.array_equal(result.estimates, np.array([s.estimate for s in out]))
    assert np.array_equal(result.covariances, np.array([s.covariance for s in out]))
    assert np.array_equal(result.nis, np.array([s.nis for s in out]))
    assert result.covariances.shape == (200, 2, 2) and np.all(result.nis >= 0)


@pytest.mark.parametrize('kind', ['full_order', 'kalman', 'kalman_tv'])
def test_the_delayed_form_is_the_one_step_prediction(kind):
    name = 'seed003_full_order.yaml' if kind == 'full_order' else 'kalman_noisy.yaml'
    base = load_parameter_file(str(CONFIG_DIR / name))
    if kind == 'kalman_tv':
        base['observer.time_varying'] = True
    current = validate_parameters(base)
    delayed = validate_parameters(dict(base, **{'observer.form': 'delayed'}))
    stamps = jittered_stamps(60, np.random.default_rng(1))
    inputs = np.cos(np.arange(60) / 7)[:, None]
    outputs = np.sin(np.arange(60) / 5)[:, None]
    now = current.make_stream()
    later = delayed.make_stream()
    filtered, predicted = [], []
    for k, stamp in enumerate(stamps.tolist()):
        filtered += now.add_input(stamp, inputs[k]) + now.add_measurement(stamp, outputs[k])
        predicted += later.add_measurement(stamp, outputs[k]) + later.add_input(stamp, inputs[k])
    predicted += later.flush()
    assert [s.stamp_ns for s in predicted] == [s.stamp_ns for s in filtered]
    model = current.model
    for k, (a, b) in enumerate(zip(filtered, predicted)):
        interval = 0 if k == 0 else int(stamps[k] - stamps[k - 1])
        if interval:
            ad = scipy.linalg.expm(model.a * interval / 1e9)
            block = np.zeros((3, 3))
            block[:2, :2], block[:2, 2:] = model.a, model.b
            bd = scipy.linalg.expm(block * interval / 1e9)[:2, 2:]
            expected = ad @ a.estimate + bd @ inputs[k]
        else:
            expected = a.estimate
        np.testing.assert_allclose(b.estimate, expected, rtol=1e-10, atol=1e-12)
        assert np.array_equal(b.innovation, a.innovation)
    batch = delayed.make_stream().replay(stamps, inputs, stamps, outputs)
    assert np.array_equal(batch.estimates, np.array([s.estimate for s in predicted]))


def test_a_steady_kalman_design_reports_its_innovation_covariance_and_nis():
    design = design_kalman(MODEL, np.ravel(Q), np.ravel(R))
    stream = EventStream(make_estimator(design), 10 ** 9, input_stamped=False)
    samples = []
    for k in range(5):
        samples += stream.add_measurement(k * PERIOD_NS, [0.1 * k])
    last = samples[-1]
    assert last.innovation_covariance.shape == (1, 1) and last.nis >= 0.0
    expected = float(last.innovation @ np.linalg.solve(last.innovation_covariance,
                                                       last.innovation))
    assert last.nis == pytest.approx(expected, rel=1e-12)


def test_jittered_intervals_are_composed_from_a_few_exact_samplings(monkeypatch):
    # Log-time stamps make every interval new: one expm pair each cost 20x the filter on a
    # real bag (issue 29). The filter samples exactly once and composes the rest.
    import observer_ros.core.discretize as discretize
    calls = []
    real = discretize.zero_order_hold
    monkeypatch.setattr(discretize, 'zero_order_hold',
                        lambda *args: calls.append(args[2]) or real(*args))
    rng = np.random.default_rng(29)
    stamps = jittered_stamps(500, rng, levels=None)
    ys, us, _ = simulate(MODEL, stamps, Q, R, 29)
    kf = TimeVaryingKalman(MODEL, Q, R)
    for k, stamp in enumerate(stamps):
        kf.update(int(stamp), ys[k], us[k - 1] if k else np.zeros(1))
    assert len(np.unique(np.diff(stamps))) > 400
    # expm only at the whole milliseconds below the intervals (5 ... 14 ms), once each.
    assert len(calls) <= 10, len(calls)


@pytest.mark.parametrize('seed', range(6))
def test_a_composed_interval_equals_expm_within_a_few_ulps(seed):
    from observer_ros.core.discretize import IntervalSampler, transition
    rng = np.random.default_rng(seed)
    n, m = 2 + seed % 4, 1 + seed % 2
    a = rng.standard_normal((n, n)) * 3.0
    root = rng.standard_normal((n, n))
    q = root @ root.T
    b = rng.standard_normal((n, m))
    model = StateSpaceModel.from_matrices(a, b, np.eye(1, n))
    sampler = IntervalSampler(a, b, q)
    first = sampler.sample(PERIOD_NS)
    exact = transition(model, PERIOD_NS / 1e9, q)
    for got, want in zip(first, exact):  # whole milliseconds: expm's, bit for bit
        assert got.tobytes() == want.tobytes()
    for dt_ns in (1, 1_000, PERIOD_NS - 3_000, PERIOD_NS + 7, PERIOD_NS + 2_345_678,
                  3 * PERIOD_NS // 2, 5_000_000):
        got = sampler.sample(dt_ns)
        want = transition(model, dt_ns / 1e9, q)
        for name, g, w in zip(('Ad', 'Bd', 'Qd'), got, want):
            scale = np.abs(w).max()
            assert np.abs(g - w).max() <= 64 * np.finfo(float).eps * scale, (dt_ns, name)
    # Beyond one grid_ns: composed from a multiple of it, sampled exactly once.
    far = 3 * sampler.grid_ns + 12_345
    got, want = sampler.sample(far), transition(model, far / 1e9, q)
    for g, w in zip(got, want):
        assert np.abs(g - w).max() <= 64 * np.finfo(float).eps * np.abs(w).max()
    assert 3 * sampler.grid_ns in sampler.anchors()
    # The order the intervals come in changes nothing (a history re-run's numbers are
    # those of a run in stamp order).
    intervals = [PERIOD_NS + 7, 1_000, far, 5_000_000, 3 * sampler.grid_ns + 5]
    other = IntervalSampler(a, b, q)
    backwards = {dt_ns: other.sample(dt_ns) for dt_ns in intervals[::-1]}
    for dt_ns in intervals:
        for g, w in zip(sampler.sample(dt_ns), backwards[dt_ns]):
            assert g.tobytes() == w.tobytes(), dt_ns


def _textbook_update(p_prior, x_prior, c, r, y):
    s = c @ p_prior @ c.T + r
    gain = p_prior @ c.T @ np.linalg.inv(s)
    innovation = y - c @ x_prior
    joseph = np.eye(len(x_prior)) - gain @ c
    p = joseph @ p_prior @ joseph.T + gain @ r @ gain.T
    return x_prior + gain @ innovation, p, gain, innovation @ np.linalg.inv(s) @ innovation


def test_the_update_of_several_outputs_is_lapack_and_equals_the_textbook(monkeypatch):
    # numpy's linalg wrappers cost 16-22 us each on p x p where the LAPACK call costs 3-5 us
    # (issue 29): the update of several outputs calls none of them.
    rng = np.random.default_rng(3)
    a = rng.standard_normal((4, 4)) - 3.0 * np.eye(4)
    model = StateSpaceModel.from_matrices(a, rng.standard_normal((4, 1)),
                                          rng.standard_normal((3, 4)))
    r = np.diag([0.01, 0.02, 0.03])
    kf = TimeVaryingKalman(model, np.eye(4) * 0.1, r, np.eye(4) * 2.0)
    refuse_linalg(monkeypatch)
    for k in range(20):
        p_prior, x_prior = None, None
        if k:
            ad, bd, qd = kf.intervals.peek(PERIOD_NS)
            p_prior = ad @ kf.covariance @ ad.T + qd
            x_prior = ad @ kf.estimate + bd @ [0.5]
        y = rng.standard_normal(3)
        x = kf.update(k * PERIOD_NS, y, [0.5])
        if p_prior is None:
            continue
        monkeypatch.undo()
        want = _textbook_update(p_prior, x_prior, model.c, r, y)
        refuse_linalg(monkeypatch)
        np.testing.assert_allclose(x, want[0], rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(kf.covariance, want[1], rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(kf.gain, want[2], rtol=1e-12, atol=1e-15)
        assert kf.nis == pytest.approx(want[3], rel=1e-12)
    # A subset of the outputs: the same steps on its rows of C and R.
    ad, bd, qd = kf.intervals.peek(PERIOD_NS)
    p_prior = ad @ kf.covariance @ ad.T + qd
    x_prior = ad @ kf.estimate + bd @ [0.5]
    x = kf.advance_outputs(20 * PERIOD_NS, np.array([0.3, -0.1]), np.array([0.5]), (0, 2))
    monkeypatch.undo()
    want = _textbook_update(p_prior, x_prior, model.c[[0, 2]], r[np.ix_([0, 2], [0, 2])],
                            np.array([0.3, -0.1]))
    np.testing.assert_allclose(x, want[0], rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(kf.covariance, want[1], rtol=1e-12, atol=1e-15)


def refuse_linalg(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError('numpy.linalg called on the update path')
    for name in ('cholesky', 'solve', 'inv'):
        monkeypatch.setattr(np.linalg, name, refuse)


def test_an_innovation_covariance_that_is_not_positive_definite_is_an_error():
    model = StateSpaceModel.from_matrices(-np.eye(2), [[0.0], [1.0]], np.eye(2))
    kf = TimeVaryingKalman(model, np.eye(2), np.eye(2) * 0.01)
    kf._prior_p = -np.eye(2) * 5.0  # a broken prior: S = -5 I + R
    with pytest.raises(np.linalg.LinAlgError, match='innovation covariance S'):
        kf.update(0, [0.0, 0.0], [0.0])
