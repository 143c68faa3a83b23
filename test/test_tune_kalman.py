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

import json
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

from bag_support import JOINT_STATE, joint_state, serialize, TYPES, TYPESTORE
from conftest import CONFIG_DIR
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.tuning import TunedFilterError
from observer_ros.bags.writing import TopicToWrite, write_bag
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.errors import DesignError
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
    _refused([str(tmp_path / 'nan'), params, '--resample', '-5'], capsys,
             "--resample: expected a rate in Hz (> 0) or auto, got '-5'")
    luenberger = yaml.safe_load(open(params))
    luenberger['/**']['ros__parameters']['observer'] = {'type': 'full_order',
                                                        'poles': [0.5, 0.6]}
    (tmp_path / 'luenberger.yaml').write_text(yaml.safe_dump(luenberger))
    _refused([str(tmp_path / 'nan'), str(tmp_path / 'luenberger.yaml')], capsys,
             'observer.type: tune_kalman tunes a Kalman filter')
    # A filter of measurement sources: its partial updates do not give one ALS model.
    _refused([str(tmp_path / 'nan'), str(CONFIG_DIR / 'wheeled_base_sources.yaml')], capsys,
             'observer.sources: tune_kalman tunes a filter updated with every output',
             'give the outputs with tune_kalman --outputs TOPIC:PATH[,PATH...]')
    assert not output.exists() and not output.parent.exists() and not report.exists()


def _stamp(stamp_ns):
    return TYPES['builtin_interfaces/msg/Time'](sec=int(stamp_ns // 10**9),
                                                nanosec=int(stamp_ns % 10**9))


def _odometry(stamp_ns, speed, turn):
    """Build a rosbags nav_msgs/Odometry with a twist of ``speed`` (linear.x) and ``turn``."""
    vector, covariance = TYPES['geometry_msgs/msg/Vector3'], np.zeros(36)
    pose = TYPES['geometry_msgs/msg/Pose'](
        position=TYPES['geometry_msgs/msg/Point'](x=0.0, y=0.0, z=0.0),
        orientation=TYPES['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0))
    twist = TYPES['geometry_msgs/msg/Twist'](linear=vector(x=float(speed), y=0.0, z=0.0),
                                             angular=vector(x=0.0, y=0.0, z=float(turn)))
    return TYPES['nav_msgs/msg/Odometry'](
        header=TYPES['std_msgs/msg/Header'](stamp=_stamp(stamp_ns), frame_id='odom'),
        child_frame_id='base_link',
        pose=TYPES['geometry_msgs/msg/PoseWithCovariance'](pose=pose, covariance=covariance),
        twist=TYPES['geometry_msgs/msg/TwistWithCovariance'](twist=twist,
                                                             covariance=covariance))


def _write_robot_like(path, u, y, stamps, jitter_ns=None, extra=None):
    """
    Record ``u`` as an unstamped /cmd_vel Twist and ``y`` as /odom's twist, like a robot.

    Each command is logged 1 us before its measurement (stamped with that log time, having
    no header); with ``jitter_ns`` the measurements are stamped and logged that far off.
    ``extra`` (topic, joint, stamps, values) adds a JointState topic.
    """
    from rosbags.rosbag2 import Writer
    vector = TYPES['geometry_msgs/msg/Vector3']
    measured = stamps if jitter_ns is None else stamps + jitter_ns
    with Writer(path, version=9) as writer:
        commands = writer.add_connection('/cmd_vel', 'geometry_msgs/msg/Twist',
                                         typestore=TYPESTORE)
        odometry = writer.add_connection('/odom', 'nav_msgs/msg/Odometry', typestore=TYPESTORE)
        for k in range(len(stamps)):
            twist = TYPES['geometry_msgs/msg/Twist'](linear=vector(x=float(u[k, 0]), y=0.0, z=0.0),
                                                     angular=vector(x=0.0, y=0.0, z=0.0))
            writer.write(commands, int(stamps[k]) - 1000, serialize(twist))
            writer.write(odometry, int(measured[k]),
                         serialize(_odometry(int(measured[k]), *y[k])))
        if extra is not None:
            topic, joint, times, values = extra
            joints = writer.add_connection(topic, JOINT_STATE, typestore=TYPESTORE)
            for stamp, value in zip(times.tolist(), values):
                writer.write(joints, stamp, serialize(joint_state(stamp, [joint], value)))


def test_odometry_and_twist_topics_are_read_by_field_path_like_joint_states(tmp_path, capsys):
    # The coupled plant's input on /cmd_vel (geometry_msgs/Twist) and its two outputs in
    # /odom's twist tune to the very noises of the same samples recorded as JointStates:
    # tune_kalman reads them through identify's reader, exactly as the observer does.
    samples = 20_000
    u, _, y = COUPLED.write_bag(tmp_path / 'joint', samples, seed=21)
    stamps = START_NS + round(COUPLED.period * 1e9) * np.arange(samples, dtype=np.int64)
    _write_robot_like(tmp_path / 'robot', u, y, stamps)
    guess = COUPLED.write_parameters(tmp_path / 'guess.yaml',
                                     process_noise=COUPLED.process_noise * 10)
    joint, robot = tmp_path / 'joint.yaml', tmp_path / 'robot.yaml'
    assert main([str(tmp_path / 'joint'), guess, '-o', str(joint),
                 '--process-structure', 'full']) == 0
    capsys.readouterr()
    fields = ['--inputs', '/cmd_vel:linear.x',
              '--outputs', '/odom:twist.twist.linear.x,twist.twist.angular.z']
    assert main([str(tmp_path / 'robot'), guess, '-o', str(robot), '--process-structure',
                 'full', *fields]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert 'checks passed' in out
    for found, expected in zip(_noises(robot, COUPLED), _noises(joint, COUPLED)):
        np.testing.assert_allclose(found, expected, rtol=1e-9, atol=1e-15)
    # A file whose u is a twist read by field path (as identify writes it) needs no --inputs.
    twist = COUPLED.parameters(process_noise=COUPLED.process_noise * 10)
    twist['/**']['ros__parameters']['topics'] = {'u': {'type': 'twist', 'fields': ['linear.x']}}
    (tmp_path / 'twist.yaml').write_text(yaml.safe_dump(twist))
    assert main([str(tmp_path / 'robot'), str(tmp_path / 'twist.yaml'), '-o', str(robot),
                 '--process-structure', 'full', '--u-topic', '/cmd_vel', *fields[2:]]) == 0
    capsys.readouterr()
    for found, expected in zip(_noises(robot, COUPLED), _noises(joint, COUPLED)):
        np.testing.assert_allclose(found, expected, rtol=1e-9, atol=1e-15)
    # What cannot work is refused, naming the option and what would.
    _refused([str(tmp_path / 'robot'), guess, *fields[:2], '--outputs',
              '/odom:twist.twist.linear.x'], capsys, '--outputs: /odom:twist.twist.linear.x '
             'gives 1 value (twist.twist.linear.x); the model has 2 (s1, s2)')
    _refused([str(tmp_path / 'robot'), guess, '--inputs', '/cmd_vel:linear.x',
              '/cmd_vel:angular.z'], capsys, '--inputs: 2 topics given',
             'name them all on it, TOPIC:PATH[,PATH...]')
    _refused([str(tmp_path / 'robot'), guess, *fields[:2], '--outputs',
              '/odom:twist.twist.linear.x', '/cmd_vel:angular.z'], capsys,
             '--outputs: /cmd_vel (20000 messages) is not stamped like /odom',
             'record the outputs on one topic, resample them onto one grid')
    _refused([str(tmp_path / 'robot'), guess, *fields[:2], '--outputs', '/odom'], capsys,
             'topic /odom holds nav_msgs/msg/Odometry: name its field paths')


def test_jittered_stamps_are_refused_with_the_way_out_and_resampled(tmp_path, capsys):
    # Measurements 3 ms early or late at random are refused with the way out; --resample
    # auto tunes from the grid (inputs held, outputs interpolated).
    samples = 20_000
    u, _, y = COUPLED.simulate(samples, seed=22)
    stamps = START_NS + round(COUPLED.period * 1e9) * np.arange(samples, dtype=np.int64)
    jitter = np.random.default_rng(5).integers(-1, 2, samples) * 3_000_000
    _write_robot_like(tmp_path / 'jitter', u, y, stamps, jitter)
    guess = COUPLED.write_parameters(tmp_path / 'guess.yaml',
                                     process_noise=COUPLED.process_noise * 10)
    fields = ['--inputs', '/cmd_vel:linear.x',
              '--outputs', '/odom:twist.twist.linear.x,twist.twist.angular.z']
    _refused([str(tmp_path / 'jitter'), guess, *fields], capsys,
             'differ from the median 100 ms by more than 2%',
             'tune_kalman --resample auto, or --resample RATE in Hz')
    tuned = tmp_path / 'tuned.yaml'
    assert main([str(tmp_path / 'jitter'), guess, *fields, '--resample', 'auto',
                 '--process-structure', 'full', '-o', str(tuned)]) == 0
    out = capsys.readouterr().out
    assert '19999 samples every 100 ms' in out and 'checks passed' in out
    q, r = _noises(tuned, COUPLED)
    # Q within 10 %; R lower (measured 15 %): a grid point between two measurements
    # averages their noise.
    assert np.all(_relative(np.diag(q), np.diag(COUPLED.process_noise)) < ACCURACY)
    assert np.all(_relative(np.diag(r), np.diag(COUPLED.measurement_noise)) < 0.25)


#: A level measured by a gauge: an integrator, continuous, no process noise in the data.
LEVEL = NoisyPlant(a=np.array([[0.0]]), b=np.array([[1.0]]), c=np.array([[1.0]]),
                   process_noise=np.array([[0.0]]), measurement_noise=np.array([[0.01]]),
                   period=0.05, continuous=True, state_names=('level',),
                   output_names=('gauge',))


def test_failed_checks_exit_3_and_write_nothing_unless_accepted(tmp_path, capsys):
    output, report = tmp_path / 'tuned.yaml', tmp_path / 'report'
    # A wrong model (the coupled plant's A off): the tuned innovations are not white.
    COUPLED.write_bag(tmp_path / 'run', 20_000, seed=23)
    wrong = NoisyPlant(np.array([[0.7, 0.1], [-0.1, 0.8]]), COUPLED.b, COUPLED.c,
                       COUPLED.process_noise, COUPLED.measurement_noise, COUPLED.period, False,
                       COUPLED.state_names, COUPLED.output_names, COUPLED.input_names)
    params = wrong.write_parameters(tmp_path / 'wrong.yaml')
    args = [str(tmp_path / 'run'), params, '-o', str(output), '--report', str(report)]
    assert main(args) == 3
    captured = capsys.readouterr()
    assert 'FAILED check: the innovations of the tuned filter are NOT white' in captured.out
    assert 'tuned parameters: not written (--accept-failed-checks writes it anyway)' in \
        captured.out
    assert 'tune_kalman: failed its checks (exit status 3)' in captured.err
    assert not output.exists()
    summary = json.loads((report / 'tune_kalman.json').read_text())
    assert summary['failed_checks'] and 'NOT white' in summary['failed_checks'][0]
    assert main(args + ['--accept-failed-checks']) == 0
    assert 'FAILED check: the innovations' in output.read_text()  # said in the file too


def test_a_zero_q_is_a_failed_check_that_says_so_and_what_to_do(tmp_path, capsys):
    output = tmp_path / 'tuned.yaml'
    COUPLED.write_bag(tmp_path / 'run', 20_000, seed=23)
    # Every entry of Q known zero on a stable plant: the filter runs, but Q is zero.
    known = ['--known', 'Q[x1,x1]=0', '--known', 'Q[x2,x2]=0']
    assert main([str(tmp_path / 'run'), COUPLED.write_parameters(tmp_path / 'right.yaml'),
                 '-o', str(output), *known]) == 3
    out = capsys.readouterr().out
    assert 'FAILED check: the estimated Q (observer.process_noise) came out zero' in out
    assert not output.exists()
    # A zero Q on an integrator: no stabilizing filter. Said, with what to do; exit 3.
    LEVEL.write_bag(tmp_path / 'level', 4000, seed=0)
    guess = LEVEL.write_parameters(tmp_path / 'level.yaml', process_noise=np.array([[1e-3]]))
    for extra in ([], ['--accept-failed-checks']):
        assert main([str(tmp_path / 'level'), guess, '-o', str(output), '--known',
                     'Q[level,level]=0', *extra]) == 3
        error = capsys.readouterr().err
        assert 'tuning failed its checks: the estimated Q (observer.process_noise) came out ' \
            'zero' in error and 'not stabilizing' in error, error
        assert '--known "Q[level,level]=VALUE"' in error and 'Nothing written' in error
    assert not output.exists()


def test_outputs_stamped_apart_are_refused_or_interpolated_onto_one_grid(tmp_path, capsys):
    # s1 in /odom's twist, s2 a JointState stamped 2 ms later: one update per sample needs
    # them together; --resample interpolates s2 at the stamps of s1, then onto the grid.
    samples = 20_000
    u, _, y = COUPLED.simulate(samples, seed=24)
    stamps = START_NS + round(COUPLED.period * 1e9) * np.arange(samples, dtype=np.int64)
    _write_robot_like(tmp_path / 'robot', u, np.column_stack([y[:, 0], np.zeros(samples)]),
                      stamps, extra=('/s2', 's2', stamps + 2_000_000, y[:, 1:]))
    guess = COUPLED.write_parameters(tmp_path / 'guess.yaml',
                                     process_noise=COUPLED.process_noise * 10)
    fields = ['--inputs', '/cmd_vel:linear.x', '--outputs', '/odom:twist.twist.linear.x',
              '/s2:position:s2']
    _refused([str(tmp_path / 'robot'), guess, *fields], capsys,
             '--outputs: /s2 (20000 messages) is not stamped like /odom (20000)',
             'resample them onto one grid (--resample)')
    tuned = tmp_path / 'tuned.yaml'
    assert main([str(tmp_path / 'robot'), guess, *fields, '--resample', 'auto', '-o',
                 str(tuned), '--process-structure', 'full']) == 0
    assert 'checks passed' in capsys.readouterr().out
    q, r = _noises(tuned, COUPLED)
    assert np.all(_relative(np.diag(q), np.diag(COUPLED.process_noise)) < ACCURACY), q


def test_a_tuned_filter_refused_for_a_singular_r_blames_r_not_q():
    # Two wheel velocities and an IMU resampled onto one grid gave an R with eigenvalues
    # from 2.4e-12 to 0.096 and Q = diag(3.7, 0.6); the Kalman design then failed (a pole at
    # -6e4) and the refusal said "A Q this small for the model is near zero".
    estimate = SimpleNamespace(process_noise=np.diag([3.7, 0.6]),
                               measurement_noise=np.array([[1.0e-3, -1.0e-3, 0.0],
                                                           [-1.0e-3, 1.0e-3, 0.0],
                                                           [0.0, 0.0, 0.1]]))
    error = TunedFilterError(estimate, ['x1', 'x2'], DesignError('not stabilizing'))
    assert 'the estimated R (observer.measurement_noise) is singular' in error.reason
    assert '--measurement-structure diagonal' in error.reason
    assert 'Q this small' not in error.reason
    regular = SimpleNamespace(process_noise=np.diag([1e-9, 1e-9]),
                              measurement_noise=np.diag([1e-3, 1e-3, 0.1]))
    error = TunedFilterError(regular, ['x1', 'x2'], DesignError('not stabilizing'))
    assert 'A Q this small for the model is near zero' in error.reason
