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

"""The tuning maths without bags: ALS, innovation statistics and subspace identification."""

import numpy as np
import pytest

from observer_ros.core.discretize import zero_order_hold
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers.kalman.design import design_kalman
from observer_ros.core.tuning.als import autocovariance_least_squares
from observer_ros.core.tuning.identified_model import fit_percent, Record, to_continuous
from observer_ros.core.tuning.innovations import (
    decay_samples, InnovationStatistics, nis_summary, whiteness)
from observer_ros.core.tuning.noise_model import (
    innovation_autocovariances, NoiseStructure, SampledFilter)
from observer_ros.core.tuning.subspace import identify_subspace, order_advice

A2 = np.array([[0.9, 0.1], [-0.1, 0.8]])
C2 = np.array([[1.0, 0.5], [0.0, 1.0]])
Q2 = np.array([[0.02, -0.008], [-0.008, 0.03]])
R2 = np.array([[0.01, 0.006], [0.006, 0.02]])


def _filter(q=Q2, r=R2, a=A2, c=C2) -> SampledFilter:
    model = StateSpaceModel.from_matrices(a, np.zeros((len(a), 1)), c, dt=0.1)
    return SampledFilter(a, c, design_kalman(model, q * 10, r / 10).filter_gain, 0.1)


@pytest.mark.parametrize('weighting', ['whitened', 'identity'])
def test_exact_autocovariances_give_back_a_full_q_and_r(weighting):
    sampled = _filter()
    exact = innovation_autocovariances(sampled, Q2, R2, 6)
    result = autocovariance_least_squares(exact, sampled, NoiseStructure.build(2, 2, 'full',
                                                                               'full'),
                                          weighting=weighting)
    assert result.unidentifiable == () and result.rank == result.n_parameters == 6
    np.testing.assert_allclose(result.process_noise, Q2, rtol=1e-8, atol=1e-12)
    np.testing.assert_allclose(result.measurement_noise, R2, rtol=1e-8, atol=1e-12)
    assert result.method == 'least squares'


def test_a_continuous_intensity_is_estimated_as_an_intensity():
    a = np.array([[0.0, 1.0], [-4.0, -0.4]])
    ad, _ = zero_order_hold(a, np.zeros((2, 1)), 0.01)
    c = np.array([[1.0, 0.0]])
    model = StateSpaceModel.from_matrices(a, np.zeros((2, 1)), c)
    from observer_ros.core.observers.kalman.estimator import KalmanStep
    design = design_kalman(model, [0.0, 0.4], [1e-5])
    step = KalmanStep(design).step(10_000_000)
    sampled = SampledFilter(step.ad, c, step.g[:2, 3:], 0.01, a)
    q, r = np.diag([0.0, 0.04]), np.array([[1e-4]])
    exact = innovation_autocovariances(sampled, q, r, 20)
    structure = NoiseStructure.build(2, 1, 'diagonal', 'full', {('Q', 0, 0): 0.0})
    result = autocovariance_least_squares(exact, sampled, structure)
    np.testing.assert_allclose(result.process_noise, q, atol=1e-10)
    np.testing.assert_allclose(result.measurement_noise, r, rtol=1e-8)


def test_a_full_q_with_fewer_outputs_names_what_it_cannot_identify_and_keeps_the_filter():
    a = np.array([[0.9, 0.1, 0.0], [0.0, 0.8, 0.2], [0.0, 0.0, 0.7]])
    c = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    q = np.array([[0.02, 0.005, 0.0], [0.005, 0.01, 0.003], [0.0, 0.003, 0.03]])
    sampled = _filter(q, R2, a, c)
    exact = innovation_autocovariances(sampled, q, R2, 10)
    result = autocovariance_least_squares(exact, sampled, NoiseStructure.build(3, 2, 'full',
                                                                               'full'))
    assert result.rank < result.n_parameters
    assert set(result.unidentifiable) <= {f'Q[x{i},x{j}]' for i in (1, 2, 3) for j in (1, 2, 3)}
    assert result.unidentifiable
    np.testing.assert_allclose(result.measurement_noise, R2, rtol=1e-6)
    # The same output spectrum: the optimal filters of both agree.
    model = StateSpaceModel.from_matrices(a, np.zeros((3, 1)), c, dt=0.1)
    true_gain = design_kalman(model, q, R2).filter_gain
    found_gain = design_kalman(model, result.process_noise, result.measurement_noise)
    np.testing.assert_allclose(found_gain.filter_gain, true_gain, atol=1e-6)


def test_a_diagonal_structure_that_cannot_be_identified_is_refused_by_name():
    a = np.array([[0.9, 0.0], [0.0, 0.5]])
    c = np.array([[1.0, 0.0]])  # x2 never reaches the output
    model = StateSpaceModel.from_matrices(a, np.zeros((2, 1)), c, dt=0.1)
    sampled = SampledFilter(a, c, design_kalman(model, [0.1, 0.1], [0.1]).filter_gain, 0.1)
    exact = innovation_autocovariances(sampled, np.diag([0.1, 0.1]), [[0.1]], 6)
    with pytest.raises(ConfigError, match=r'structure: Q\[x2,x2\] leave no trace'):
        autocovariance_least_squares(exact, sampled, NoiseStructure.build(2, 1))


def test_estimates_that_would_be_indefinite_are_held_semidefinite():
    sampled = _filter()
    exact = innovation_autocovariances(sampled, np.diag([1e-6, 0.03]), R2, 6)
    exact[0] -= 0.002 * np.eye(2)  # sampling error pushes the plain solution negative
    result = autocovariance_least_squares(exact, sampled, NoiseStructure.build(2, 2))
    assert result.method == 'semidefinite least squares'
    assert np.linalg.eigvalsh(result.process_noise).min() >= 0.0
    assert np.linalg.eigvalsh(result.measurement_noise).min() > 0.0


def test_an_unstable_filter_and_bad_structures_are_errors():
    sampled = SampledFilter(np.array([[1.2]]), np.array([[1.0]]), np.array([[0.0]]), 0.1)
    with pytest.raises(DesignError, match='gain: the filter is not stable'):
        autocovariance_least_squares(np.ones((3, 1, 1)), sampled, NoiseStructure.build(1, 1))
    with pytest.raises(ConfigError, match="process: expected one of diagonal, full, got 'x'"):
        NoiseStructure.build(2, 1, 'x')
    with pytest.raises(ConfigError, match=r'known: Q\[2,0\] is outside the 2x2 matrix'):
        NoiseStructure.build(2, 1, known={('Q', 2, 0): 0.0})
    known = {('Q', 0, 0): 1.0, ('Q', 1, 1): 1.0, ('R', 0, 0): 1.0}
    with pytest.raises(ConfigError, match='nothing to estimate'):
        autocovariance_least_squares(np.ones((3, 1, 1)), _filter(np.eye(2), np.eye(1), A2,
                                                                 C2[:1]),
                                     NoiseStructure.build(2, 1, known=known))


def test_pooled_statistics_do_not_depend_on_how_segments_are_grouped():
    rng = np.random.default_rng(4)
    parts = [rng.standard_normal((n, 2)) for n in (500, 800, 300)]
    one = InnovationStatistics(5, 2)
    for part in parts:
        one.add(part)
    separate = []
    for part in parts:
        stats = InnovationStatistics(5, 2)
        stats.add(part)
        separate.append(stats)
    pooled = separate[0].merge(separate[1:])
    np.testing.assert_allclose(pooled.sums, one.sums, rtol=1e-14)
    assert pooled.counts.tolist() == one.counts.tolist() == [1600, 1597, 1594, 1591, 1588]
    white = whiteness(one)
    assert white.white and 0.0 <= white.outside < 0.2
    with pytest.raises(ConfigError, match='innovations: expected finite values'):
        one.add(np.array([[np.nan, 0.0]]))


def test_coloured_innovations_are_not_white_and_the_nis_band_judges_the_mean():
    rng = np.random.default_rng(5)
    e = np.convolve(rng.standard_normal(20000), [1.0, 0.8], 'same')[:, None]
    stats = InnovationStatistics(10, 1)
    stats.add(e)
    judged = whiteness(stats)
    assert not judged.white and judged.outside > 0.05
    good = nis_summary(rng.chisquare(2, 5000), 2)
    bad = nis_summary(2.0 * rng.chisquare(2, 5000), 2)
    assert good.consistent and not bad.consistent
    assert decay_samples(np.array([[0.5]]), 1e-3) == 10


def _third_order(samples: int, seed: int, snr_db: float = 30.0):
    a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-10.0, -9.2, -3.4]])
    b = np.array([[0.0], [0.0], [10.0]])
    ad, bd = zero_order_hold(a, b, 0.05)
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((samples, 1))
    x, y = np.zeros(3), np.empty((samples, 1))
    for k in range(samples):
        y[k] = x[0]
        x = ad @ x + bd @ u[k]
    noisy = y + rng.standard_normal(y.shape) * y.std() * 10 ** (-snr_db / 20)
    return a, ad, u, noisy


def test_subspace_identification_is_exact_without_noise_and_close_at_30_db():
    a, ad, u, _ = _third_order(3000, 1, snr_db=300.0)
    clean = identify_subspace([Record(u, _third_order(3000, 1, 300.0)[3])], 3, 0.05)
    np.testing.assert_allclose(np.sort_complex(clean.poles),
                               np.sort_complex(np.linalg.eigvals(ad)), rtol=1e-6)
    a, ad, u, y = _third_order(8000, 2)
    model = identify_subspace([Record(u[:6000], y[:6000])], 3, 0.05)
    continuous, _ = to_continuous(model.a, model.b, 0.05)
    truth = np.sort_complex(np.linalg.eigvals(a))
    found = np.sort_complex(np.linalg.eigvals(continuous))
    assert (np.abs(found - truth) / np.abs(truth)).max() < 0.01
    from observer_ros.core.tuning.identified_model import validate
    _, fit = validate(model, Record(u[6000:], y[6000:]))
    assert fit[0] > 90.0
    assert 'too low' in order_advice(model.singular_values, 2)
    assert 'too high' in order_advice(model.singular_values, 4)
    assert 'suggested order 3' in order_advice(model.singular_values, 3)


def test_identification_refuses_constant_inputs_short_data_and_nan():
    _, _, u, y = _third_order(2000, 3)
    with pytest.raises(ConfigError, match='inputs: no excitation: force is constant'):
        identify_subspace([Record(np.ones_like(u), y)], 3, 0.05, input_names=['force'])
    with pytest.raises(ConfigError, match='horizon: too short'):
        identify_subspace([Record(u[:60], y[:60])], 3, 0.05)
    y[10] = np.nan
    with pytest.raises(ConfigError, match='outputs: record 0: NaN or inf'):
        identify_subspace([Record(u, y)], 3, 0.05)
    with pytest.raises(DesignError, match='A: discrete poles -0.5'):
        to_continuous([[-0.5]], [[1.0]], 0.1)
    assert fit_percent([[0.0], [2.0]], [[1.0], [1.0]]).tolist() == [0.0]


def test_an_unstable_identified_model_is_refused_with_the_reason_not_an_svd_failure():
    # A plant whose state doubles every 70 samples: its model was returned with B and D fitted
    # on a simulation growing as 1.01^k; at |z| = 1.7 (closed-loop data) the fit overflowed
    # and numpy's SVD failed ('SVD did not converge').
    rng = np.random.default_rng(5)
    u = rng.standard_normal((3000, 1))
    x, y = 0.0, []
    for k in range(3000):
        y.append([x + 0.01 * rng.standard_normal()])
        x = 1.01 * x + u[k, 0]
    with pytest.raises(DesignError, match=r'order: the identified model of order 1 is unstable '
                                          r'\(a pole at \|z\| = 1\.01'):
        identify_subspace([Record(u, np.array(y))], 1, 0.1)
