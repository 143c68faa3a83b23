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

"""``replay``: checked before it writes, outputs with plain permissions, one time base."""

import os
import stat
import subprocess

import numpy as np
import pytest
import yaml

from bag_support import robot_parameters, ROBOT_TOPICS, WALL_START_NS, write_robot_bag
from conftest import console_script
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.replay_outputs import write_replay
from observer_ros.bags.storage import BagError

STORAGES = ['mcap', 'sqlite3']

#: Simulation time when the recording starts (header stamps near 0 s).
SIM_START_NS = 5 * 10**8


def run_replay(*args):
    """Run ``replay`` to completion; return the CompletedProcess."""
    return subprocess.run([console_script('replay'), *map(str, args)], capture_output=True,
                          text=True, timeout=60)


def one_error_line(result, *fragments):
    """Assert exit status 2 and one ``replay: error:`` line holding every fragment."""
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('replay: error: '), lines
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def test_every_error_comes_before_anything_is_written(tmp_path):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=30)
    params = robot_parameters(tmp_path)
    outputs = tmp_path / 'outputs'
    out, csv, report = outputs / 'x_hat', outputs / 'x_hat.csv', outputs / 'report'
    writes = ['--output', out, '--csv', csv]
    topics = ['--y-topic', ROBOT_TOPICS[0], '--u-topic', ROBOT_TOPICS[1]]
    # A truth topic named for --report that the bag does not have (without --truth, a bag
    # with no /x_true gets a report without errors: test_replay_checks).
    one_error_line(run_replay(bag, params, *topics, *writes, '--report', report, '--truth',
                              '/x_true'), '--report: ', 'no topic /x_true; the bag has')
    assert not outputs.exists()
    # A bad parameter file, a missing topic, a bag that cannot be read.
    broken = tmp_path / 'broken.yaml'
    document = yaml.safe_load(params.read_text())
    document['/**']['ros__parameters']['model']['C'] = [1.0, 0.0, 0.0]
    broken.write_text(yaml.safe_dump(document))
    one_error_line(run_replay(bag, broken, *topics, *writes), 'model.C')
    one_error_line(run_replay(bag, params, *writes), 'no topic /y')
    one_error_line(run_replay(tmp_path / 'nothing', params, *topics, *writes),
                   'not a readable rosbag2 bag')
    assert not outputs.exists()
    # Outputs that cannot be written: nothing else is written either.
    outputs.mkdir()
    out.mkdir()
    one_error_line(run_replay(bag, params, *topics, *writes), f'--output: {out} exists')
    out.rmdir()
    one_error_line(run_replay(bag, params, *topics, '--output', out, '--csv', out / 'a.csv'),
                   'overlap')
    one_error_line(run_replay(bag, params, *topics, *writes, '--report', csv.parent / 'f',
                              '--csv', csv.parent / 'f'), 'overlap')
    (outputs / 'file').write_text('')
    one_error_line(run_replay(bag, params, *topics, *writes, '--report', outputs / 'file'),
                   '--report: ', 'is a file')
    assert sorted(p.name for p in outputs.iterdir()) == ['file']
    # And when everything is right, everything is written (in new directories too).
    done = run_replay(bag, params, *topics, '--output', out, '--csv', outputs / 'new' / 'x.csv')
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in outputs.iterdir()) == ['file', 'new', 'x_hat']
    assert (outputs / 'new' / 'x.csv').read_text().count('\n') == 31


@pytest.mark.parametrize('storage', STORAGES)
def test_outputs_get_the_permissions_of_a_plain_open(tmp_path, storage):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=20, storage=storage)
    result = replay_bag(bag, robot_parameters(tmp_path), *ROBOT_TOPICS)
    previous = os.umask(0o027)
    try:
        write_replay(result, str(tmp_path / 'out'), str(tmp_path / 'x_hat.csv'), storage)
        with open(tmp_path / 'plain', 'w'):
            pass
        (tmp_path / 'plain_directory').mkdir()
    finally:
        os.umask(previous)

    def mode(path):
        return stat.S_IMODE(path.stat().st_mode)
    plain, directory = mode(tmp_path / 'plain'), mode(tmp_path / 'plain_directory')
    assert (plain, directory) == (0o640, 0o750)
    assert mode(tmp_path / 'x_hat.csv') == plain
    assert mode(tmp_path / 'out') == directory
    files = list((tmp_path / 'out').iterdir())
    assert files and all(mode(file) == plain for file in files)


@pytest.mark.parametrize('storage', STORAGES)
def test_measurements_in_simulation_time_with_wall_clock_inputs_are_refused(tmp_path,
                                                                            storage):
    # y stamped in simulation time, the unstamped commands on the recorder's wall clock:
    # every interval would pair with no input (u = 0), and only late_input would say so.
    sim, reference = tmp_path / 'sim', tmp_path / 'reference'
    write_robot_bag(sim, samples=100, storage=storage, stamp_start_ns=SIM_START_NS)
    write_robot_bag(reference, samples=100, storage=storage)
    params = robot_parameters(tmp_path)
    with pytest.raises(BagError, match=(
            r'/joint_states and /effort_controller/commands are stamped in different time '
            r'bases: /joint_states has header stamps -1.7e\+09 s from its log times, '
            r'/effort_controller/commands uses its log times .*stamp '
            r'/effort_controller/commands in the clock of /joint_states, or replay with log '
            r'times for both \(replay --use-log-time')):
        replay_bag(sim, params, *ROBOT_TOPICS)
    # With log times for both, the replay is the consistently stamped recording's.
    result = replay_bag(sim, params, *ROBOT_TOPICS, use_log_time=True)
    expected = replay_bag(reference, params, *ROBOT_TOPICS)
    assert np.array_equal(result.stamps_ns, expected.stamps_ns)
    assert np.array_equal(result.estimates, expected.estimates)
    assert result.counters == expected.counters and result.use_log_time
    # The command line says the same, writes nothing, and takes --use-log-time.
    csv = tmp_path / 'x_hat.csv'
    one_error_line(run_replay(sim, params, '--y-topic', ROBOT_TOPICS[0], '--u-topic',
                              ROBOT_TOPICS[1], '--csv', csv),
                   'different time bases', '--use-log-time')
    assert not csv.exists()
    done = run_replay(sim, params, '--y-topic', ROBOT_TOPICS[0], '--u-topic', ROBOT_TOPICS[1],
                      '--csv', csv, '--use-log-time')
    assert done.returncode == 0, done.stderr
    table = np.loadtxt(csv, delimiter=',', skiprows=1, usecols=(2, 3))
    assert np.array_equal(table, expected.estimates)


def test_log_times_copied_from_other_clocks_are_refused(tmp_path):
    # A converter that logs each message at its own stamp: y at simulation time, the
    # unstamped commands at wall-clock time. The offsets agree; the ranges cannot.
    bag = tmp_path / 'converted'
    write_robot_bag(bag, samples=50, stamp_start_ns=SIM_START_NS, log_start_ns=SIM_START_NS,
                    command_log_start_ns=WALL_START_NS)
    with pytest.raises(BagError, match=r'stamped in different time bases: /joint_states spans '
                                       r'0.5 s to 0.99 s, /effort_controller/commands '
                                       r'1.7e\+09 s'):
        replay_bag(bag, robot_parameters(tmp_path), *ROBOT_TOPICS)


def test_one_time_base_with_latency_or_simulation_time_is_replayed(tmp_path):
    params = robot_parameters(tmp_path)
    # Header stamps 0.2 s older than their log times (transport latency), unstamped commands.
    late = tmp_path / 'late'
    write_robot_bag(late, samples=50, stamp_start_ns=WALL_START_NS - 2 * 10**8)
    assert len(replay_bag(late, params, *ROBOT_TOPICS).estimates) == 50
    # y and u both stamped in simulation time, logged on the wall clock: one time base.
    sim = tmp_path / 'sim'
    write_robot_bag(sim, samples=50, stamp_start_ns=SIM_START_NS)
    document = yaml.safe_load(params.read_text())
    section = document['/**']['ros__parameters']
    section['model']['input_names'] = ['elbow']
    section['topics'] = {'u': {'type': 'joint_state', 'field': 'velocity'}}
    stamped = tmp_path / 'stamped.yaml'
    stamped.write_text(yaml.safe_dump(document))
    result = replay_bag(sim, stamped, ROBOT_TOPICS[0], ROBOT_TOPICS[0])
    assert len(result.estimates) == 50 and result.counters['late_input'] == 0
    assert result.stamps_ns[0] == SIM_START_NS
