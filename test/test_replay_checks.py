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
The offline tools on a differential-drive set-up, and what they check before they work.

One ``y`` (the wheel speeds in ``/joint_states``) and a ``geometry_msgs/Twist`` input on
``/cmd_vel``, the most common robot set-up, recorded the way ``ros2 bag record`` does:
replayed and tuned without a crash, two sources on one topic both read, streams stamped in
different clocks warned of, a misspelt joint refused up front with what the bag holds.
"""

import math

import numpy as np
import pytest
from rosbags.rosbag2 import Writer
import yaml

from bag_support import float64_array, joint_state, serialize, STORAGES, TYPES, TYPESTORE
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.storage import BagError
from observer_ros.tools.replay import main as replay_main
from observer_ros.tools.tune_kalman import main as tune_main

#: Wall-clock start of the recordings (ns).
WALL_START_NS = 1_700_000_000 * 10**9
PERIOD_NS = 10_000_000
JOINTS = ['wheel_left_joint', 'wheel_right_joint']
#: Wheel speeds (rad/s) follow the commanded ones with a time constant of 0.1 s; wheels of
#: radius 0.033 m, 0.16 m apart: w_left = (v - 0.08 w) / 0.033.
A = [-10.0, 0.0, 0.0, -10.0]
B = [303.0, -24.2, 303.0, 24.2]


#: Each wheel a source of its own, both on ``/joint_states``.
WHEEL_SOURCES = {'left': {'topic': '/joint_states', 'type': 'joint_state',
                          'fields': ['velocity.wheel_left_joint'],
                          'outputs': ['wheel_left_joint'], 'measurement_noise': [0.01]},
                 'right': {'topic': '/joint_states', 'type': 'joint_state',
                           'fields': ['velocity.wheel_right_joint'],
                           'outputs': ['wheel_right_joint'], 'measurement_noise': [0.01]}}


def drive_parameters(path, u_type='twist', sources=None, **observer):
    """Write a differential drive's parameter file: wheel speeds, commanded (v, w)."""
    section = {
        'model': {'A': A, 'B': B, 'C': [1.0, 0.0, 0.0, 1.0], 'state_names': ['wl', 'wr'],
                  'input_names': ['v_cmd', 'w_cmd'], 'output_names': list(JOINTS)},
        'observer': {'type': 'kalman', 'process_noise': [1.0, 1.0],
                     'measurement_noise': [0.01, 0.01], 'initial_state': [0.0, 0.0],
                     **observer},
        'topics': {'y': {'type': 'joint_state', 'field': 'velocity'},
                   'u': ({'type': 'twist', 'fields': ['linear.x', 'angular.z']}
                         if u_type == 'twist' else {'type': 'float64_multi_array'})}}
    if sources:
        section['observer']['sources'] = list(sources)
        section['observer'].pop('measurement_noise')
        section['sources'] = sources
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': section}}))
    return path


def write_drive_bag(path, samples=200, storage='mcap', stamp_start_ns=WALL_START_NS,
                    u_type='twist', seed=5, command_delay_ns=-1000):
    """
    Record ``/joint_states`` (wheel velocities, stamped) and ``/cmd_vel`` (unstamped).

    The joint states are stamped from ``stamp_start_ns`` (0: simulation time) and logged in
    wall time; each command is logged 1 us before the sample it acts from
    (``command_delay_ns`` after it).
    """
    rng = np.random.default_rng(seed)
    speeds = np.zeros(2)
    msgtype = ('geometry_msgs/msg/Twist' if u_type == 'twist'
               else 'std_msgs/msg/Float64MultiArray')
    with Writer(path, version=9, storage_plugin=STORAGES[storage]) as writer:
        joints = writer.add_connection('/joint_states', 'sensor_msgs/msg/JointState',
                                       typestore=TYPESTORE)
        commands = writer.add_connection('/cmd_vel', msgtype, typestore=TYPESTORE)
        for index in range(samples):
            logged = WALL_START_NS + index * PERIOD_NS
            u = np.array([0.2 + 0.1 * math.sin(index / 10), 0.5 * math.cos(index / 15)])
            if u_type == 'twist':
                vector = TYPES['geometry_msgs/msg/Vector3']
                command = TYPES['geometry_msgs/msg/Twist'](linear=vector(x=u[0], y=0.0, z=0.0),
                                                           angular=vector(x=0.0, y=0.0, z=u[1]))
            else:
                command = float64_array(u)
            writer.write(commands, logged + command_delay_ns, serialize(command))
            measured = speeds + rng.normal(0.0, 0.1, size=2)
            writer.write(joints, logged, serialize(joint_state(
                stamp_start_ns + index * PERIOD_NS, [*JOINTS, 'caster'], [0.0, 0.0, 0.0],
                [*measured, 0.0])))
            target = np.array([(u[0] - 0.08 * u[1]) / 0.033, (u[0] + 0.08 * u[1]) / 0.033])
            speeds = target + (speeds - target) * math.exp(-10.0 * PERIOD_NS / 1e9)


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_a_twist_input_without_sources_replays_as_its_vector_does(tmp_path, storage):
    write_drive_bag(tmp_path / 'twist', storage=storage)
    write_drive_bag(tmp_path / 'vector', storage=storage, u_type='float64_multi_array')
    twist = replay_bag(tmp_path / 'twist', drive_parameters(tmp_path / 'twist.yaml'),
                       '/joint_states', '/cmd_vel')
    vector = replay_bag(tmp_path / 'vector', drive_parameters(
        tmp_path / 'vector.yaml', 'float64_multi_array'), '/joint_states', '/cmd_vel')
    assert len(twist.stamps_ns) == 200 and twist.counters.get('late_input', 0) == 0
    assert not twist.warnings
    np.testing.assert_array_equal(twist.stamps_ns, vector.stamps_ns)
    np.testing.assert_allclose(twist.estimates, vector.estimates, rtol=0, atol=1e-9)
    # The first estimate of the steady-state filter has no covariance yet (NaN), the others
    # the batch replay's.
    assert np.isnan(twist.covariances[0]).all()
    np.testing.assert_allclose(twist.covariances[1:], vector.covariances[1:], rtol=1e-12)


def test_replay_and_tune_kalman_take_a_twist_input(tmp_path, capsys):
    write_drive_bag(tmp_path / 'bag', samples=1000)
    params = drive_parameters(tmp_path / 'drive.yaml')
    assert replay_main([str(tmp_path / 'bag'), str(params), '--y-topic', '/joint_states',
                        '--u-topic', '/cmd_vel']) == 0
    assert 'into 1000 estimates' in capsys.readouterr().out
    assert tune_main([str(tmp_path / 'bag'), str(params), '--y-topic', '/joint_states',
                      '--u-topic', '/cmd_vel', '--lags', '8', '--iterations', '1',
                      '-o', str(tmp_path / 'tuned.yaml')]) == 0
    assert (tmp_path / 'tuned.yaml').exists()


def test_two_sources_on_one_topic_are_both_read(tmp_path):
    write_drive_bag(tmp_path / 'bag', samples=100)
    params = drive_parameters(tmp_path / 'two.yaml', sources=WHEEL_SOURCES,
                              time_varying=True)
    result = replay_bag(tmp_path / 'bag', params, u_topic='/cmd_vel')
    # Each message is read by both: 200 measurements, one estimate per stamp at least.
    assert result.counters['measurements'] == 200
    assert len(result.outputs.stamps_ns) == 200
    both = drive_parameters(tmp_path / 'one.yaml', sources={'wheels': {
        'topic': '/joint_states', 'type': 'joint_state',
        'fields': ['velocity.wheel_left_joint', 'velocity.wheel_right_joint'],
        'outputs': list(JOINTS), 'measurement_noise': [0.01, 0.01]}}, time_varying=True)
    together = replay_bag(tmp_path / 'bag', both, u_topic='/cmd_vel')
    last = together.stamps_ns[-1]
    # Two scalar updates at one stamp equal one update with both (R diagonal).
    np.testing.assert_allclose(result.estimates[result.stamps_ns == last][-1],
                               together.estimates[-1], rtol=1e-9)


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_sensors_in_simulation_time_with_wall_clock_commands_are_warned_of(tmp_path, storage,
                                                                           capsys):
    write_drive_bag(tmp_path / 'bag', storage=storage, stamp_start_ns=5 * 10**8)
    params = drive_parameters(tmp_path / 'drive.yaml')
    result = replay_bag(tmp_path / 'bag', params, '/joint_states', '/cmd_vel')
    assert result.counters['late_input'] > 190
    (warning,) = result.warnings
    assert 'different time bases' in warning and '--use-log-time' in warning
    assert 'stamp /cmd_vel in the clock of the measurements' in warning
    assert replay_main([str(tmp_path / 'bag'), str(params), '--y-topic', '/joint_states',
                        '--u-topic', '/cmd_vel']) == 0
    assert 'replay: warning:' in capsys.readouterr().err
    fixed = replay_bag(tmp_path / 'bag', params, '/joint_states', '/cmd_vel',
                       use_log_time=True)
    assert not fixed.warnings and fixed.counters.get('late_input', 0) == 0


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_a_misspelt_joint_of_a_source_is_refused_naming_what_the_bag_holds(tmp_path, storage,
                                                                           capsys):
    write_drive_bag(tmp_path / 'bag', samples=50, storage=storage)
    sources = {'wheels': {'topic': '/joint_states', 'type': 'joint_state',
                          'fields': ['velocity.wheel_left', 'velocity.wheel_right_joint'],
                          'outputs': list(JOINTS), 'measurement_noise': [0.01, 0.01]}}
    params = drive_parameters(tmp_path / 'bad.yaml', sources=sources)
    with pytest.raises(BagError, match=r'sources\.wheels\.fields: .*/joint_states.*'
                       r"'wheel_left_joint', 'wheel_right_joint', 'caster'"):
        replay_bag(tmp_path / 'bag', params, u_topic='/cmd_vel')
    csv = tmp_path / 'out.csv'
    assert replay_main([str(tmp_path / 'bag'), str(params), '--u-topic', '/cmd_vel',
                        '--csv', str(csv)]) == 2
    assert 'sources.wheels.fields' in capsys.readouterr().err and not csv.exists()


def test_a_misspelt_joint_of_y_is_refused_naming_the_parameters(tmp_path):
    write_drive_bag(tmp_path / 'bag', samples=50)
    params = drive_parameters(tmp_path / 'drive.yaml')
    document = yaml.safe_load(params.read_text())
    document['/**']['ros__parameters']['model']['output_names'] = ['wheel_left', 'wheel_right']
    params.write_text(yaml.safe_dump(document))
    with pytest.raises(BagError, match=r'topics\.y\.field .velocity. of the joints '
                       r'model\.output_names: none of the first 20 messages of /joint_states'):
        replay_bag(tmp_path / 'bag', params, '/joint_states', '/cmd_vel')


def test_a_short_command_array_is_refused_naming_its_fields(tmp_path):
    write_drive_bag(tmp_path / 'bag', samples=50, u_type='float64_multi_array')
    params = drive_parameters(tmp_path / 'drive.yaml', 'float64_multi_array')
    document = yaml.safe_load(params.read_text())
    document['/**']['ros__parameters']['topics']['u'] = {
        'type': 'float64_multi_array', 'fields': ['data[0]', 'data[2]']}
    params.write_text(yaml.safe_dump(document))
    with pytest.raises(BagError, match=r'topics\.u\.fields: .*data of 2 values'):
        replay_bag(tmp_path / 'bag', params, '/joint_states', '/cmd_vel')


def test_tune_kalman_refuses_commands_in_another_clock_or_takes_log_times(tmp_path, capsys):
    write_drive_bag(tmp_path / 'bag', samples=1000, stamp_start_ns=5 * 10**8)
    params = drive_parameters(tmp_path / 'drive.yaml')
    arguments = [str(tmp_path / 'bag'), str(params), '--y-topic', '/joint_states',
                 '--u-topic', '/cmd_vel', '--lags', '8', '--iterations', '1']
    assert tune_main(arguments) == 2
    error = capsys.readouterr().err
    assert 'different time bases' in error and 'tune_kalman --use-log-time' in error
    assert tune_main([*arguments, '--use-log-time']) == 0, capsys.readouterr().err


WHEELS = {'wheels': {'topic': '/joint_states', 'type': 'joint_state',
                     'fields': ['velocity.wheel_left_joint', 'velocity.wheel_right_joint'],
                     'outputs': list(JOINTS), 'measurement_noise': [0.01, 0.01]}}


@pytest.mark.parametrize('options, needed', [
    (['--y-topic', '/joint_states'], 'observer.sources'),
    (['--settle', '1.0'], '--reference'),
    (['--truth', '/ground_truth'], '--report'),
    (['--storage', 'sqlite3', '--csv', 'x.csv'], '--output')])
def test_options_the_configuration_makes_meaningless_are_refused(tmp_path, capsys, options,
                                                                 needed):
    write_drive_bag(tmp_path / 'bag', samples=20)
    params = drive_parameters(tmp_path / 'drive.yaml', sources=WHEELS)
    options = [str(tmp_path / value) if value == 'x.csv' else value for value in options]
    assert replay_main([str(tmp_path / 'bag'), str(params), '--u-topic', '/cmd_vel',
                        *options]) == 2
    error = capsys.readouterr().err
    assert f'{options[0]}: ' in error and needed in error, error
    assert not (tmp_path / 'x.csv').exists()


def test_tune_kalman_writes_into_folders_it_makes(tmp_path, capsys):
    write_drive_bag(tmp_path / 'bag', samples=1000)
    params = drive_parameters(tmp_path / 'drive.yaml')
    tuned, report = tmp_path / 'new' / 'deeper' / 'tuned.yaml', tmp_path / 'reports' / 'tk'
    assert tune_main([str(tmp_path / 'bag'), str(params), '--y-topic', '/joint_states',
                      '--u-topic', '/cmd_vel', '--lags', '8', '--iterations', '1',
                      '-o', str(tuned), '--report', str(report)]) == 0, capsys.readouterr().err
    assert tuned.exists() and (report / 'tune_kalman.html').exists()


def test_identify_writes_into_folders_it_makes(tmp_path, capsys):
    from observer_ros.tools.identify import main as identify_main
    write_drive_bag(tmp_path / 'bag', samples=600, u_type='float64_multi_array')
    model, report = tmp_path / 'new' / 'model.yaml', tmp_path / 'reports' / 'identify'
    assert identify_main([str(tmp_path / 'bag'), '--order', '2', '--inputs',
                          '/cmd_vel', '--outputs',
                          '/joint_states:velocity:wheel_left_joint,wheel_right_joint',
                          '-o', str(model),
                          '--report', str(report)]) == 0, capsys.readouterr().err
    assert model.exists() and (report / 'identify.html').exists()


@pytest.mark.parametrize('tool', ['tune_kalman', 'identify'])
def test_an_output_under_a_file_is_refused_before_the_bag_is_read(tmp_path, capsys, tool):
    from observer_ros.tools.identify import main as identify_main
    (tmp_path / 'file').write_text('')
    missing_bag = str(tmp_path / 'no_bag')  # never read: the output is refused first
    arguments = ([missing_bag, str(drive_parameters(tmp_path / 'drive.yaml'))]
                 if tool == 'tune_kalman' else [missing_bag, '--order', '2'])
    main = tune_main if tool == 'tune_kalman' else identify_main
    assert main([*arguments, '-o', str(tmp_path / 'file' / 'out.yaml')]) == 2
    error = capsys.readouterr().err
    assert '--output: ' in error and str(tmp_path / 'file') in error, error


def _csv(path):
    """Return the header and the rows of a CSV as lists of strings."""
    lines = path.read_text().splitlines()
    return lines[0].split(','), [line.split(',') for line in lines[1:]]


def test_the_csv_says_what_made_each_row_and_the_in_order_file_has_one_per_stamp(tmp_path):
    from test_sources_nodes import CONFIG, write_wheeled_bag
    write_wheeled_bag(tmp_path / 'base', samples=40)
    csv, in_order = tmp_path / 'rows.csv', tmp_path / 'out' / 'in_order.csv'
    assert replay_main([str(tmp_path / 'base'), str(CONFIG), '--u-topic', '/cmd_vel',
                        '--csv', str(csv), '--in-order', str(in_order)]) == 0
    header, rows = _csv(csv)
    assert header[:7] == ['stamp_ns', 'event', 'x', 'yaw', 'v', 'w', 'innovation_v_left']
    assert header[-4:] == ['variance_x', 'variance_yaw', 'variance_v', 'variance_w']
    events = [row[1] for row in rows]
    # 40 wheel samples, 20 IMU samples joining them, 7 late poses re-running the newest.
    assert events.count('wheels') == 40 and events.count('imu') == 20
    assert events.count('rerun') == 7 and len(rows) == 67
    stamps = [int(row[0]) for row in rows]
    assert all(stamps[i] > max(stamps[:i]) for i, event in enumerate(events)
               if event == 'wheels' and i)
    header, ordered = _csv(in_order)
    assert header[:3] == ['stamp_ns', 'sources', 'x'] and header[-1] == 'variance_w'
    ordered_stamps = [int(row[0]) for row in ordered]
    assert ordered_stamps == sorted(set(stamps)) and len(ordered) == 40
    assert ordered[0][1] == 'wheels+imu+mocap' and ordered[1][1] == 'wheels'
    # The newest published row and the last in-order one are the same estimate.
    assert ordered[-1][2:] == rows[-1][2:6] + rows[-1][-4:]


def test_the_full_covariance_and_a_meaningless_covariance_option(tmp_path, capsys):
    write_drive_bag(tmp_path / 'bag', samples=30, u_type='float64_multi_array')
    params = drive_parameters(tmp_path / 'drive.yaml', 'float64_multi_array')
    csv = tmp_path / 'rows.csv'
    base = [str(tmp_path / 'bag'), str(params), '--y-topic', '/joint_states', '--u-topic',
            '/cmd_vel']
    assert replay_main([*base, '--csv', str(csv), '--covariance', 'full']) == 0
    header, rows = _csv(csv)
    assert header[-4:] == ['covariance_wl_wl', 'covariance_wl_wr', 'covariance_wr_wl',
                           'covariance_wr_wr']
    result = replay_bag(tmp_path / 'bag', params, '/joint_states', '/cmd_vel')
    assert [float(v) for v in rows[-1][-4:]] == result.covariances[-1].ravel().tolist()
    assert {row[1] for row in rows} == {'y'}
    assert replay_main([*base, '--covariance', 'full']) == 2
    assert '--covariance: it applies to --csv and --in-order' in capsys.readouterr().err
    observer = drive_parameters(tmp_path / 'poles.yaml', 'float64_multi_array')
    document = yaml.safe_load(observer.read_text())
    document['/**']['ros__parameters']['observer'] = {'poles': [-20.0, -25.0]}
    observer.write_text(yaml.safe_dump(document))
    assert replay_main([str(tmp_path / 'bag'), str(observer), '--y-topic', '/joint_states',
                        '--u-topic', '/cmd_vel', '--csv', str(csv), '--covariance',
                        'diagonal']) == 2
    assert 'has no covariance to write' in capsys.readouterr().err


def test_a_report_of_a_bag_without_the_true_state_shows_the_filter_alone(tmp_path, capsys):
    # A robot's bag has no /x_true: --report wrote nothing and exited 2 ("--report needs the
    # true state"); it now writes the estimates, innovations and NIS, and says why no errors.
    write_drive_bag(tmp_path / 'bag')
    params = drive_parameters(tmp_path / 'drive.yaml')
    assert replay_main([str(tmp_path / 'bag'), str(params), '--y-topic', '/joint_states',
                        '--u-topic', '/cmd_vel', '--report', str(tmp_path / 'report')]) == 0
    captured = capsys.readouterr()
    assert 'no x_true in the bag (no true state)' in captured.err
    page = (tmp_path / 'report' / 'replay.html').read_text(encoding='utf-8')
    assert ': estimates' in page and ': innovation' in page
    assert not (tmp_path / 'report' / 'replay.png').exists()
    # A truth named by --truth must be there.
    assert replay_main([str(tmp_path / 'bag'), str(params), '--y-topic', '/joint_states',
                        '--u-topic', '/cmd_vel', '--report', str(tmp_path / 'again'),
                        '--truth', '/ground_truth']) == 2
    assert 'no topic /ground_truth' in capsys.readouterr().err
    assert not (tmp_path / 'again').exists()


def test_a_report_of_measurement_sources_takes_their_partial_innovations(tmp_path, capsys):
    # Each source updates the outputs it measured: the other outputs' innovations are NaN
    # in that row, and the report's autocorrelation refused them after all the work
    # ("innovations: expected finite values", exit 2; seen on a TurtleBot3 bag).
    write_drive_bag(tmp_path / 'bag', samples=200)
    params = drive_parameters(tmp_path / 'two.yaml', sources=WHEEL_SOURCES,
                              time_varying=True)
    assert replay_main([str(tmp_path / 'bag'), str(params), '--u-topic', '/cmd_vel',
                        '--report', str(tmp_path / 'report')]) == 0, capsys.readouterr().err
    assert (tmp_path / 'report' / 'replay.html').exists()


@pytest.mark.parametrize('u_type', ['twist', 'float64_multi_array'])
def test_replay_holds_unstamped_inputs_for_the_next_measurement_as_the_node_does(
        tmp_path, u_type):
    # observer.unstamped_input: next_measurement: the node holds each unstamped u for the
    # next measurement (EventStream.hold_input); replay stamped it with its log time, so
    # offline and online differed. Both paths (message by message for a Twist, arrays for
    # a Float64MultiArray) against the stream fed in bag order as the node feeds it.
    from observer_ros.bags.replay import load_system
    from observer_ros.bags.replay_reading import recorded_events
    from observer_ros.core.events import INPUT
    # Measurements that reach the recorder 2.5 periods after their stamps, each command
    # just after the measurement of the sample it acts from: stamped on arrival, it would
    # be paired 2 intervals late.
    write_drive_bag(tmp_path / 'bag', samples=150, u_type=u_type,
                    stamp_start_ns=WALL_START_NS - 5 * PERIOD_NS // 2, command_delay_ns=1000)
    params = drive_parameters(tmp_path / 'drive.yaml', u_type,
                              unstamped_input='next_measurement')
    offline = replay_bag(tmp_path / 'bag', params, '/joint_states', '/cmd_vel')
    system = load_system(params)
    events, _ = recorded_events(tmp_path / 'bag', system, '/cmd_vel', False, '/joint_states')
    stream = system.observer.make_stream()
    online = []
    for event in events:
        if event.source == INPUT:
            online += stream.hold_input(event.values, event.arrival_ns)
        else:
            online += stream.add_measurement(event.stamp_ns, event.values, event.arrival_ns,
                                             event.arrival_ns, event.source)
    online += stream.flush()
    assert len(online) == len(offline.stamps_ns) == 150
    np.testing.assert_array_equal([sample.stamp_ns for sample in online], offline.stamps_ns)
    assert np.array_equal(np.array([sample.estimate for sample in online]),
                          offline.estimates)
    logged = replay_bag(tmp_path / 'bag', drive_parameters(tmp_path / 'logged.yaml', u_type),
                        '/joint_states', '/cmd_vel')
    assert not np.array_equal(logged.estimates, offline.estimates)
