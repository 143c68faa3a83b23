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

"""``tune_kalman`` on simulated bags with known noises: accuracy, pooling, Dask, bad input."""

import numpy as np
import pytest
import yaml

from conftest import CONFIG_DIR
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.storage import TopicToWrite, write_bag
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.flat_matrices import covariance_from_flat
from observer_ros.tools.tune_kalman import main
from tuning_support import COUPLED, expected_mse, NoisyPlant, SPRING, START_NS

SAMPLES = 100_000
#: Estimates within this fraction of the truth; tuned filter's MSE within this of the true's.
ACCURACY, MSE_MARGIN = 0.10, 0.03


def _noises(path, plant: NoisyPlant) -> tuple:
    flat = load_parameter_file(str(path))
    return (covariance_from_flat('q', flat['observer.process_noise'], len(plant.a)),
            covariance_from_flat('r', flat['observer.measurement_noise'], len(plant.c)))


def _mse(bag, params, skip: int = 1000) -> float:
    errors = replay_bag(bag, params).error_norms()[skip:]
    return float(np.mean(errors ** 2))


@pytest.fixture(scope='module')
def spring_bag(tmp_path_factory):
    directory = tmp_path_factory.mktemp('spring')
    SPRING.write_bag(directory / 'run', SAMPLES, seed=11)
    return directory


@pytest.fixture(scope='module')
def coupled_bag(tmp_path_factory):
    directory = tmp_path_factory.mktemp('coupled')
    COUPLED.write_bag(directory / 'run', SAMPLES, seed=12)
    return directory


def _relative(found, true):
    mask = true != 0
    return np.abs(found[mask] - true[mask]) / np.abs(true[mask])


def test_a_tenfold_wrong_guess_is_recovered_on_the_spring(spring_bag, tmp_path, capsys):
    wrong = SPRING.write_parameters(tmp_path / 'wrong.yaml', process_noise=np.diag([0, 0.4]),
                                    measurement_noise=[[1e-5]])
    tuned = tmp_path / 'tuned.yaml'
    assert main([str(spring_bag / 'run'), wrong, '-o', str(tuned),
                 '--known', 'Q[position,position]=0']) == 0
    out = capsys.readouterr().out
    q, r = _noises(tuned, SPRING)
    errors = np.concatenate([_relative(q, SPRING.process_noise),
                             _relative(r, SPRING.measurement_noise)])
    print(f'spring: Q[velocity] {q[1, 1]:.6g} (true 0.04), R {r[0, 0]:.6g} (true 1e-4); '
          f'largest error {errors.max():.2%}')
    assert errors.max() < ACCURACY and q[0, 0] == 0.0
    truth = SPRING.write_parameters(tmp_path / 'true.yaml')
    ratio = _mse(spring_bag / 'run', str(tuned)) / _mse(spring_bag / 'run', truth)
    expected = (expected_mse(SPRING, q, r)
                / expected_mse(SPRING, SPRING.process_noise, SPRING.measurement_noise))
    print(f'spring: MSE tuned / true {ratio:.5f} on the bag, {expected:.5f} expected')
    assert ratio < 1 + MSE_MARGIN and expected < 1 + MSE_MARGIN
    assert 'before: NIS mean' in out and 'NOT consistent' in out.split('after:')[0]
    after = out.split('after:')[1]
    assert ', consistent)' in after and '(white)' in after
    text = tuned.read_text()
    assert text.startswith('# Tuned by tune_kalman') and '# after:' in text
    validate_parameters(load_parameter_file(str(tuned)), strict=True)


def test_two_correlated_outputs_full_q_and_r(coupled_bag, tmp_path, capsys):
    wrong = COUPLED.write_parameters(tmp_path / 'wrong.yaml',
                                     process_noise=COUPLED.process_noise * 10,
                                     measurement_noise=COUPLED.measurement_noise / 10)
    tuned = tmp_path / 'tuned.yaml'
    assert main([str(coupled_bag), wrong, '-o', str(tuned), '--process-structure', 'full']) == 0
    out = capsys.readouterr().out
    assert 'not identifiable' not in out
    q, r = _noises(tuned, COUPLED)
    errors = np.concatenate([_relative(q, COUPLED.process_noise),
                             _relative(r, COUPLED.measurement_noise)])
    print(f'coupled: Q {q.ravel().round(5).tolist()} R {r.ravel().round(5).tolist()}; '
          f'largest error {errors.max():.2%}')
    assert errors.max() < ACCURACY
    ratio = (expected_mse(COUPLED, q, r)
             / expected_mse(COUPLED, COUPLED.process_noise, COUPLED.measurement_noise))
    print(f'coupled: expected MSE tuned / true {ratio:.5f}')
    assert ratio < 1 + MSE_MARGIN


def test_a_full_q_of_the_spring_is_judged_by_r_and_the_filter(spring_bag, tmp_path, capsys):
    wrong = SPRING.write_parameters(tmp_path / 'wrong.yaml', process_noise=np.diag([0, 0.4]),
                                    measurement_noise=[[1e-5]])
    tuned = tmp_path / 'tuned.yaml'
    assert main([str(spring_bag / 'run'), wrong, '-o', str(tuned), '--process-structure',
                 'full']) == 0
    out = capsys.readouterr().out
    line = next(text for text in out.splitlines() if text.startswith('not identifiable'))
    print(line)
    assert 'Q[velocity,velocity]' in line or 'Q[position,velocity]' in line
    q, r = _noises(tuned, SPRING)
    assert abs(r[0, 0] / 1e-4 - 1) < ACCURACY
    ratio = (expected_mse(SPRING, q, r)
             / expected_mse(SPRING, SPRING.process_noise, SPRING.measurement_noise))
    print(f'spring, full Q: R {r[0, 0]:.6g}, expected MSE tuned / true {ratio:.5f}')
    assert ratio < 1 + MSE_MARGIN


PARTS, PART_SAMPLES = 8, 3000
GAP_NS = 5 * 10**9  # longer than observer.max_gap: the filter restarts between recordings


@pytest.fixture(scope='module')
def eight_bags(tmp_path_factory):
    """Eight recordings as eight bags, and the same eight one after another in one bag."""
    directory = tmp_path_factory.mktemp('pool')
    folder = directory / 'bags'
    period = round(COUPLED.period * 1e9)
    stamps, values = [], {'u': [], 'y': [], 'x': []}
    start = START_NS
    for part in range(PARTS):
        u, x, y = COUPLED.write_bag(folder / f'part{part}', PART_SAMPLES, seed=100 + part,
                                    start_ns=start)
        stamps.append(start + period * np.arange(PART_SAMPLES, dtype=np.int64))
        for key, value in (('u', u), ('y', y), ('x', x)):
            values[key].append(value)
        start += PART_SAMPLES * period + GAP_NS
    stamps = np.concatenate(stamps)
    u, y = np.concatenate(values['u']), np.concatenate(values['y'])
    write_bag(directory / 'joined', [
        TopicToWrite('/u', 'joint_state', 'position', COUPLED.input_names, stamps,
                     stamps - 1000, u),
        TopicToWrite('/y', 'joint_state', 'position', COUPLED.output_names, stamps, stamps, y)])
    params = COUPLED.write_parameters(directory / 'start.yaml',
                                      process_noise=COUPLED.process_noise * 10,
                                      measurement_noise=COUPLED.measurement_noise / 10)
    return directory, params


def _tuned(args, path) -> np.ndarray:
    assert main([*args, '-o', str(path), '--process-structure', 'full']) == 0
    q, r = _noises(path, COUPLED)
    return np.concatenate([q.ravel(), r.ravel()])


def test_pooling_eight_bags_equals_one_joined_bag_locally_and_on_dask(
        eight_bags, tmp_path, capsys):
    directory, params = eight_bags
    joined = _tuned([str(directory / 'joined'), params], tmp_path / 'joined.yaml')
    local = _tuned([str(directory / 'bags'), params, '--workers', '2'], tmp_path / 'local.yaml')
    from distributed import LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol='tcp://',
                      host='127.0.0.1',
                      dashboard_address=None) as cluster:
        on_dask = _tuned([str(directory / 'bags'), params, '--dask', cluster.scheduler_address],
                         tmp_path / 'dask.yaml')
    out = capsys.readouterr().out
    assert f'{PARTS} bags' in out
    difference = max(np.abs(local - joined).max(), np.abs(on_dask - joined).max())
    print(f'pooled 8 bags against one joined bag: largest difference {difference:.3g} '
          f'(entries near {np.abs(joined).max():.3g})')
    np.testing.assert_allclose(local, joined, rtol=0, atol=1e-9)
    np.testing.assert_allclose(on_dask, joined, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(on_dask, local)


def _refused(args, capsys, *expected) -> str:
    assert main(args) == 2
    error = capsys.readouterr().err
    for text in expected:
        assert text in error, error
    return error


def test_bad_input_is_a_clear_error_and_nothing_is_written(tmp_path, capsys):
    params = COUPLED.write_parameters(tmp_path / 'params.yaml')
    output, report = tmp_path / 'out' / 'tuned.yaml', tmp_path / 'report'
    written = ['-o', str(output), '--report', str(report)]
    COUPLED.write_bag(tmp_path / 'short', 200, seed=1)
    _refused([str(tmp_path / 'short'), params, *written, '--lags', '10'], capsys,
             'too short for the lag count', '10 lags need at least 500')
    u, x, y = COUPLED.simulate(2000, seed=2)
    y[700, 1] = np.nan
    COUPLED.write_bag(tmp_path / 'nan', 2000, seed=2, outputs=y)
    _refused([str(tmp_path / 'nan'), params, *written], capsys, 'topic y: 1 of 2000 samples '
             'are not finite')
    # A third state the output never sees: its noise leaves no trace in the innovations.
    hidden = NoisyPlant(np.diag([0.9, 0.8, 0.5]), np.array([[0.0], [0.1], [0.0]]),
                        np.array([[1.0, 1.0, 0.0]]), np.diag([0.01, 0.01, 0.01]),
                        np.array([[0.01]]), 0.1, False, ('x1', 'x2', 'x3'), ('s1',))
    hidden.write_bag(tmp_path / 'hidden', 3000, seed=3)
    _refused([str(tmp_path / 'hidden'), hidden.write_parameters(tmp_path / 'hidden.yaml'),
              *written], capsys, 'structure: ', 'Q[x3,x3]', 'leave no trace')
    _refused([str(tmp_path / 'nan'), params, *written, '--known', 'Q[x9,x1]=0'], capsys,
             "--known: 'x9'")
    _refused([str(tmp_path / 'missing'), params], capsys, 'not a readable rosbag2 bag')
    luenberger = yaml.safe_load(open(params))
    luenberger['/**']['ros__parameters']['observer'] = {'type': 'full_order',
                                                        'poles': [0.5, 0.6]}
    (tmp_path / 'luenberger.yaml').write_text(yaml.safe_dump(luenberger))
    _refused([str(tmp_path / 'nan'), str(tmp_path / 'luenberger.yaml')], capsys,
             'observer.type: tune_kalman tunes a Kalman filter')
    # A filter of measurement sources: its partial updates do not give one ALS model.
    _refused([str(tmp_path / 'nan'), str(CONFIG_DIR / 'wheeled_base_sources.yaml')], capsys,
             'observer.sources: tune_kalman tunes a filter updated with every output')
    assert not output.exists() and not output.parent.exists() and not report.exists()
