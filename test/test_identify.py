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

"""``identify`` on a simulated third-order bag at 30 dB: poles, fit, order choice, bad input."""

import numpy as np
import pytest

from observer_ros.bags.examples import (
    THIRD_ORDER_A, THIRD_ORDER_B, THIRD_ORDER_PERIOD, THIRD_ORDER_SAMPLES, THIRD_ORDER_SNR_DB,
    write_third_order)
from observer_ros.bags.writing import TopicToWrite, write_bag
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.discretize import zero_order_hold
from observer_ros.tools.design_observer import main as design_observer
from observer_ros.tools.identify import main
from observer_ros.tools.replay import main as replay
from observer_ros.tools.tune_kalman import main as tune_kalman
from tuning_support import START_NS

#: The plant: poles -1.58 and -0.91 +- 2.34j, sampled at 20 Hz, position measured (the
#: tuning page's example, written by the package's examples module).
A, B = THIRD_ORDER_A, THIRD_ORDER_B
PERIOD, SAMPLES, SNR_DB = THIRD_ORDER_PERIOD, THIRD_ORDER_SAMPLES, THIRD_ORDER_SNR_DB


@pytest.fixture(scope='module')
def third_order_bag(tmp_path_factory):
    path = tmp_path_factory.mktemp('identify') / 'run'
    write_third_order(path)
    return path


def test_a_third_order_plant_at_30_db(third_order_bag, tmp_path, capsys):
    model = tmp_path / 'model.yaml'
    assert main([str(third_order_bag), '--order', '3', '--continuous', '-o', str(model)]) == 0
    out = capsys.readouterr().out
    flat = load_parameter_file(str(model))
    system = validate_parameters(flat, strict=True)  # ready for the observer
    assert system.observer.kind.name == 'kalman' and system.model.dt == 0.0
    found = np.sort_complex(np.linalg.eigvals(system.model.a))
    truth = np.sort_complex(np.linalg.eigvals(A))
    errors = np.abs(found - truth) / np.abs(truth)
    fit = float(out.split('fit on the held-out data: position ')[1].split('%')[0])
    print(f'poles {found.round(4).tolist()} (true {truth.round(4).tolist()}), largest error '
          f'{errors.max():.3%}; fit {fit:.2f}%')
    assert errors.max() < 0.01 and fit > 90.0
    assert 'suggested order 3' in out and 'too' not in out
    assert flat['topics.y.type'] == 'joint_state' and flat['model.output_names'] == ['position']


@pytest.mark.parametrize('order, verdict', [(2, 'too low'), (4, 'too high')])
def test_a_wrong_order_shows_in_the_singular_values(third_order_bag, order, verdict, capsys):
    assert main([str(third_order_bag), '--order', str(order)]) == 0
    out = capsys.readouterr().out
    line = next(text for text in out.splitlines() if text.startswith('largest gap'))
    print(line)
    assert 'suggested order 3' in line and verdict in line
    assert out.splitlines()[1].startswith('singular values (horizon 20): ')


def test_bad_input_is_a_clear_error_and_nothing_is_written(tmp_path, capsys):
    output, report = tmp_path / 'out' / 'model.yaml', tmp_path / 'report'
    written = ['--order', '3', '-o', str(output), '--report', str(report)]
    write_third_order(tmp_path / 'constant', 2000, inputs=np.full((2000, 1), 0.5))
    write_third_order(tmp_path / 'short', 40)
    write_third_order(tmp_path / 'nan', 2000, nan_at=500)
    cases = [('constant', 'inputs: no excitation: force is constant'),
             ('short', 'horizon: too short'),
             ('nan', 'topic /y: 1 of 2000 samples are not finite')]
    for bag, expected in cases:
        assert main([str(tmp_path / bag), *written]) == 2
        error = capsys.readouterr().err
        assert expected in error, error
    assert main([str(tmp_path / 'nan'), '--order', '3', '--inputs', '/u:effort']) == 2
    assert 'no effort per joint' in capsys.readouterr().err
    assert not output.parent.exists() and not report.exists()


def test_an_unstamped_twist_input_is_read_by_field_path_like_a_joint_state(tmp_path, capsys):
    # /cmd_vel as geometry_msgs/Twist (no header: stamped with its log time, 1 us before its
    # measurement) gives the model of the same input recorded as a stamped JointState.
    from rosbags.rosbag2 import Writer
    from bag_support import joint_state, serialize, TYPES, TYPESTORE
    samples = 4000
    write_third_order(tmp_path / 'joint', samples)
    ad, bd = zero_order_hold(A, B, PERIOD)
    rng = np.random.default_rng(1)
    u = rng.standard_normal((samples, 1))
    x, y = np.zeros(3), np.empty((samples, 1))
    for k in range(samples):
        y[k] = x[0]
        x = ad @ x + bd @ u[k]
    y += rng.standard_normal(y.shape) * y.std() * 10 ** (-SNR_DB / 20)
    stamps = START_NS + round(PERIOD * 1e9) * np.arange(samples, dtype=np.int64)
    vector = TYPES['geometry_msgs/msg/Vector3']
    with Writer(tmp_path / 'twist', version=9) as writer:
        commands = writer.add_connection('/cmd_vel', 'geometry_msgs/msg/Twist',
                                         typestore=TYPESTORE)
        measured = writer.add_connection('/y', 'sensor_msgs/msg/JointState', typestore=TYPESTORE)
        for k in range(samples):
            twist = TYPES['geometry_msgs/msg/Twist'](linear=vector(x=float(u[k, 0]), y=0.0, z=0.0),
                                                     angular=vector(x=0.0, y=0.0, z=0.0))
            writer.write(commands, int(stamps[k]) - 1000, serialize(twist))
            writer.write(measured, int(stamps[k]),
                         serialize(joint_state(int(stamps[k]), ['position'], y[k])))
    model = tmp_path / 'model.yaml'
    assert main([str(tmp_path / 'twist'), '--order', '3', '--inputs', '/cmd_vel:linear.x',
                 '-o', str(model)]) == 0
    twist_out = capsys.readouterr().out
    assert main([str(tmp_path / 'joint'), '--order', '3']) == 0
    joint_out = capsys.readouterr().out
    poles = [line for line in twist_out.splitlines() if 'poles' in line]
    assert poles and poles == [line for line in joint_out.splitlines() if 'poles' in line]
    section = load_parameter_file(str(model))
    assert section['topics.u.type'] == 'twist' and section['topics.u.fields'] == ['linear.x']
    validate_parameters(section, strict=True)
    # A Twist named without its fields, or with a wrong one, says what it has.
    assert main([str(tmp_path / 'twist'), '--order', '3', '--inputs', '/cmd_vel']) == 2
    assert 'name its field paths, TOPIC:PATH[,PATH...]; it has linear.x' in \
        capsys.readouterr().err
    assert main([str(tmp_path / 'twist'), '--order', '3', '--inputs', '/cmd_vel:linear.q']) == 2
    assert "'linear.q' is no field of geometry_msgs/msg/Twist" in capsys.readouterr().err


def write_jittered(path, samples=6000, jitter=0.2, seed=3):
    """
    Record the plant measured every 50 ms, +- ``jitter / 2`` of that, commanded at 10 Hz.

    The plant is simulated exactly between events (zero-order hold over each interval
    between a command and a measurement); the commands are stamped when they are applied.
    """
    rng = np.random.default_rng(seed)
    period_ns = round(PERIOD * 1e9)
    measured = START_NS + period_ns * np.arange(samples, dtype=np.int64) + np.round(
        rng.uniform(-jitter / 2, jitter / 2, samples) * period_ns).astype(np.int64)
    commanded = START_NS - period_ns + 2 * period_ns * np.arange(samples // 2 + 1,
                                                                 dtype=np.int64)
    u = rng.standard_normal((len(commanded), 1))
    events = sorted([(int(t), 0, k) for k, t in enumerate(commanded)]
                    + [(int(t), 1, k) for k, t in enumerate(measured)])
    x, now, held = np.zeros(3), events[0][0], np.zeros(1)
    y = np.empty((samples, 1))
    for stamp, kind, k in events:
        if stamp > now:
            ad, bd = zero_order_hold(A, B, (stamp - now) / 1e9)
            x, now = ad @ x + bd @ held, stamp
        if kind == 0:
            held = u[k]
        else:
            y[k] = x[0]
    y += rng.standard_normal(y.shape) * y.std() * 10 ** (-SNR_DB / 20)
    write_bag(path, [TopicToWrite('/u', 'joint_state', 'position', ['force'], commanded,
                                  commanded, u),
                     TopicToWrite('/y', 'joint_state', 'position', ['position'], measured,
                                  measured, y)])


def test_jittered_sampling_is_resampled_onto_a_uniform_grid(tmp_path, capsys):
    # Measurement intervals of 45..55 ms (a simulator's /joint_states) are refused with the
    # way out; --resample auto holds the inputs, interpolates the outputs and says so, with
    # the interpolation error and the fit of the raw samples beside the resampled fit.
    write_jittered(tmp_path / 'jitter')
    bag = str(tmp_path / 'jitter')
    assert main([bag, '--order', '3']) == 2
    error = capsys.readouterr().err
    assert 'sample intervals differ from the median' in error
    assert 'identify --resample auto, or --resample RATE in Hz' in error
    model = tmp_path / 'model.yaml'
    assert main([bag, '--order', '3', '--continuous', '--resample', 'auto', '-o',
                 str(model)]) == 0
    out = capsys.readouterr().out
    found = np.sort_complex(np.linalg.eigvals(
        validate_parameters(load_parameter_file(str(model)), strict=True).model.a))
    truth = np.sort_complex(np.linalg.eigvals(A))
    errors = np.abs(found - truth) / np.abs(truth)
    fit = float(out.split('fit on the held-out data: position ')[1].split('%')[0])
    raw = float(out.split('(not resampled): position ')[1].split('%')[0])
    line = next(text for text in out.splitlines() if text.startswith('resampled '))
    print(f'poles {found.round(3).tolist()}, largest error {errors.max():.2%}; fit {fit:.2f}% '
          f'(raw stamps {raw:.2f}%)\n{line}')
    assert 'every 50.0' in out and 'onto' in line and 'ms, median 50.0' in line
    assert 'inputs zero-order held, outputs linearly interpolated' in line
    assert errors.max() < 0.05 and fit > 90.0 and raw < fit - 10.0
    assert main([bag, '--order', '3', '--resample', '40']) == 0
    assert 'every 25 ms' in capsys.readouterr().out
    assert main([bag, '--order', '3', '--resample', '0']) == 2
    assert "--resample: expected a rate in Hz (> 0) or auto, got '0'" in capsys.readouterr().err
    assert main([bag, '--order', '3', '--resample', 'fast']) == 2
    assert "--resample: expected a rate in Hz (> 0) or auto, got 'fast'" in \
        capsys.readouterr().err


def innovation_rms(csv_path, skip: int) -> float:
    """RMS of the innovation column of a replay CSV after ``skip`` rows."""
    with open(csv_path, encoding='utf-8') as stream:
        header = stream.readline().strip().split(',')
    column = next(i for i, name in enumerate(header) if name.startswith('innovation'))
    innovation = np.loadtxt(csv_path, delimiter=',', skiprows=1, usecols=column)
    return float(np.sqrt(np.mean(innovation[skip:] ** 2)))


def test_a_feedthrough_identified_runs_in_design_observer_and_replay(tmp_path, capsys):
    # D = 0.8 from the input to the position: identify --feedthrough fit finds it, and the
    # file it writes runs in design_observer and replay as written (both exited 2 before:
    # "D: the runtime estimators need D = 0").
    bag, samples = tmp_path / 'direct', 8000
    noise = write_third_order(bag, samples, feedthrough=0.8)
    fitted, zero = tmp_path / 'fit.yaml', tmp_path / 'zero.yaml'
    assert main([str(bag), '--order', '3', '--feedthrough', 'fit', '-o', str(fitted)]) == 0
    fit = float(capsys.readouterr().out.split('held-out data: position ')[1].split('%')[0])
    d = load_parameter_file(str(fitted))['model.D']
    assert main([str(bag), '--order', '3', '--feedthrough', 'zero', '-o', str(zero)]) == 0
    fit_zero = float(capsys.readouterr().out.split('held-out data: position ')[1].split('%')[0])
    assert load_parameter_file(str(zero))['model.D'] == [0.0]
    assert design_observer([str(fitted)]) == 0
    assert 'Observer: kalman' in capsys.readouterr().out
    rms = {}
    for name, params in (('fit', fitted), ('zero', zero)):
        csv = tmp_path / f'{name}.csv'
        assert replay([str(bag), str(params), '--csv', str(csv)]) == 0
        assert f'replayed {samples} measurements into {samples} estimates' in (
            capsys.readouterr().out)
        rms[name] = innovation_rms(csv, samples // 2)
    print(f'D fitted {d[0]:.4f} (true 0.8), fit {fit:.2f}% (D fixed at zero: {fit_zero:.2f}%); '
          f'innovation RMS over the second half {rms["fit"]:.4g} (noise {noise:.4g}), '
          f'{rms["zero"]:.4g} with D = 0')
    assert abs(d[0] - 0.8) < 0.01 and fit > 95.0 and fit_zero < 50.0
    # The estimates converge: what is left of the innovation is the measurement noise.
    assert rms['fit'] < 1.2 * noise and rms['zero'] > 3 * rms['fit']
    # tune_kalman takes the file too (it exited 2 before), and finds R = the noise variance.
    tuned = tmp_path / 'tuned.yaml'
    assert tune_kalman([str(bag), str(fitted), '-o', str(tuned)]) == 0
    capsys.readouterr()
    r = load_parameter_file(str(tuned))['observer.measurement_noise'][0]
    print(f'tune_kalman: R {r:.4g}, noise variance {noise ** 2:.4g}')
    assert abs(r / noise ** 2 - 1.0) < 0.05


def test_feedthrough_zero_is_the_default_and_fit_finds_noise_on_a_plant_without_one(
        third_order_bag, tmp_path, capsys):
    default, fitted = tmp_path / 'default.yaml', tmp_path / 'fit.yaml'
    assert main([str(third_order_bag), '--order', '3', '-o', str(default)]) == 0
    fit_zero = float(capsys.readouterr().out.split('held-out data: position ')[1].split('%')[0])
    assert main([str(third_order_bag), '--order', '3', '--feedthrough', 'fit',
                 '-o', str(fitted)]) == 0
    fit = float(capsys.readouterr().out.split('held-out data: position ')[1].split('%')[0])
    d = load_parameter_file(str(fitted))['model.D'][0]
    print(f'no feedthrough in the plant: D fitted {d:.3g}, fit {fit:.2f}% (fixed at zero '
          f'{fit_zero:.2f}%)')
    assert load_parameter_file(str(default))['model.D'] == [0.0]
    assert abs(d) < 0.01 and abs(fit - fit_zero) < 0.1
    with pytest.raises(SystemExit) as exit_:
        main([str(third_order_bag), '--order', '3', '--feedthrough', 'some'])
    assert exit_.value.code == 2
    assert "--feedthrough: invalid choice: 'some'" in capsys.readouterr().err
