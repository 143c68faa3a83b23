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
An observer type from a separate package: found through its entry point, run everywhere.

``test/plugins/observer_ros_alpha_beta`` is a package of its own (its ``setup.py`` registers
``alpha_beta`` in the group ``observer_ros.observer_types``) with its own estimator and no
linear realization; nothing in observer_ros names it. It is installed into a temporary
directory (setuptools, offline) and put on ``PYTHONPATH`` of subprocesses only, so this
process's registry never sees it.
"""

import csv
import json
import os
from pathlib import Path
import subprocess
import sys

import numpy as np
import pytest
import rclpy
from rosbags.rosbag2 import StoragePlugin, Writer
from sensor_msgs.msg import JointState

from bag_support import float64_array, FLOAT64_MULTI_ARRAY, JOINT_STATE, joint_state
from bag_support import serialize, TYPESTORE
from conftest import console_script
from observer_ros.core.observers import observer_type_names
from ros_support import executor_with, NodeProcess, ros_context, spin_until

PLUGIN = Path(__file__).resolve().parent / 'plugins' / 'observer_ros_alpha_beta'
CONFIG = PLUGIN / 'alpha_beta.yaml'
PERIOD_NS = 10_000_000
START_NS = 1_700_000_000 * 10**9
#: The cart's true motion: from 0.3 m at 1.0 m/s, no force.
POSITION, VELOCITY = 0.3, 1.0


@pytest.fixture(scope='module')
def plugin_path(tmp_path_factory):
    """Install the plug-in package (code and entry points) into a directory of its own."""
    target = tmp_path_factory.mktemp('plugin')
    result = subprocess.run(
        [sys.executable, 'setup.py', '--quiet', 'build', '--build-base', str(target / 'build'),
         '--build-lib', str(target / 'site'), 'egg_info', '--egg-base', str(target / 'site')],
        cwd=PLUGIN, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    return target / 'site'


def _environment(plugin_path) -> dict:
    paths = [str(plugin_path), os.environ.get('PYTHONPATH', '')]
    return dict(os.environ, PYTHONPATH=os.pathsep.join(filter(None, paths)))


def _run(plugin_path, executable, *args, timeout=60):
    return subprocess.run([console_script(executable), *args], capture_output=True, text=True,
                          env=_environment(plugin_path), timeout=timeout)


def test_this_process_does_not_know_the_plugin():
    assert 'alpha_beta' not in observer_type_names()


def test_the_plugin_is_found_after_the_built_in_types(plugin_path):
    code = ('from observer_ros.core.observers import observer_types, plugin_failures\n'
            'print([t.name for t in observer_types()], plugin_failures())')
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            env=_environment(plugin_path), timeout=60)
    assert result.stdout.strip() == ("['full_order', 'reduced_order', 'chen', 'kalman', "
                                     "'extended_kalman', 'unscented_kalman', 'alpha_beta'] {}"
                                     ), result.stderr


def test_design_observer_runs_it_and_skips_the_closed_loop_analysis(plugin_path):
    text = _run(plugin_path, 'design_observer', str(CONFIG))
    assert text.returncode == 0, text.stderr
    assert 'Observer: alpha_beta (order 2), method alpha_beta' in text.stdout
    assert ('warning: closed-loop analysis skipped: the alpha_beta observer has no linear '
            'realization') in text.stdout
    assert 'Closed-loop poles =' not in text.stdout
    assert 'Observer-controller G_oc' not in text.stdout
    summary = json.loads(
        _run(plugin_path, 'design_observer', '--json', str(CONFIG)).stdout)
    assert summary['observer.type'] == 'alpha_beta'
    assert summary['observer.alpha'] == 0.5 and summary['observer.beta'] == 0.2
    assert 'closed_loop_poles' not in summary and 'controller_tf' not in summary
    assert summary['notes'][0].startswith('closed-loop analysis skipped')
    # Its small-signal error poles z^2 - (2 - alpha - beta) z + (1 - alpha).
    poles = np.sort_complex([complex(*pair) for pair in summary['observer.poles']])
    assert np.allclose(poles, np.sort_complex(np.roots([1.0, -1.3, 0.5])))
    assert 'feedback.gain' in summary  # the state feedback is designed as for any type


def test_its_own_arguments_are_checked_by_the_schema(plugin_path, tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text(CONFIG.read_text().replace('alpha: 0.5', 'alpha: 1.5'))
    result = _run(plugin_path, 'design_observer', str(bad))
    assert result.returncode == 2
    assert 'observer.alpha: expected a value in (0, 1], got 1.5' in result.stderr
    unstable = tmp_path / 'unstable.yaml'
    unstable.write_text(CONFIG.read_text().replace('beta: 0.2', 'beta: 2.0')
                        .replace('alpha: 0.5', 'alpha: 1.0'))
    result = _run(plugin_path, 'design_observer', str(unstable))
    assert result.returncode == 2
    assert 'observer.beta: alpha = 1 and beta = 2 do not' in result.stderr


def test_a_type_without_the_angles_capability_refuses_angles(plugin_path, tmp_path):
    angles = tmp_path / 'angles.yaml'
    angles.write_text(CONFIG.read_text().replace(
        '      output_names: [position]\n',
        '      output_names: [position]\n      angle_outputs: [position]\n'))
    result = _run(plugin_path, 'design_observer', str(angles))
    assert result.returncode == 2
    assert ('model.angle_outputs: the alpha_beta observer cannot keep angles'
            in result.stderr), result.stderr


def _cart(index: int) -> float:
    return POSITION + VELOCITY * index * PERIOD_NS / 1e9


def test_replay_runs_it_on_a_recorded_bag(plugin_path, tmp_path):
    bag = tmp_path / 'cart'
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        measured = writer.add_connection('/y', JOINT_STATE, typestore=TYPESTORE)
        commands = writer.add_connection('/u', FLOAT64_MULTI_ARRAY, typestore=TYPESTORE)
        for index in range(300):
            stamp = START_NS + index * PERIOD_NS
            writer.write(commands, stamp - 1000, serialize(float64_array([0.0])))
            # One outlier: the clipped innovation moves the estimate by a bounded step.
            y = _cart(index) + (50.0 if index == 150 else 0.0)
            writer.write(measured, stamp, serialize(joint_state(stamp, ['position'], [y])))
    params = tmp_path / 'cart.yaml'
    params.write_text(CONFIG.read_text() + '    topics:\n      u:\n'
                      '        type: float64_multi_array\n')
    table = tmp_path / 'x_hat.csv'
    result = _run(plugin_path, 'replay', str(bag), str(params), '--csv', str(table))
    assert result.returncode == 0, result.stderr
    with open(table, encoding='utf-8') as stream:
        rows = list(csv.DictReader(stream))
    assert len(rows) == 300
    velocity = np.array([float(row['velocity']) for row in rows])
    position = np.array([float(row['position']) for row in rows])
    truth = np.array([_cart(index) for index in range(300)])
    assert abs(velocity[140] - VELOCITY) < 1e-6 and abs(position[140] - truth[140]) < 1e-6
    jump = abs(position[150] - truth[150])
    assert 0.1 < jump <= 0.5 * 0.5 + 1e-9  # alpha times the innovation limit, not 50
    assert abs(velocity[-1] - VELOCITY) < 1e-6 and abs(position[-1] - truth[-1]) < 1e-6


def test_the_observer_node_runs_it_over_dds(plugin_path, tmp_path):
    # Without inputs (B empty) each measurement is an estimate at once.
    params = tmp_path / 'tracker.yaml'
    params.write_text(CONFIG.read_text().replace('      B: [0.0, 1.0]\n', '')
                      .replace('      input_names: [force]\n', '')
                      .replace("    feedback:\n      poles: ['-2.0', '-2.5']\n", ''))
    with ros_context() as context:
        node = rclpy.create_node('cart', context=context)
        publisher = node.create_publisher(JointState, 'y', 10)
        estimates = []
        node.create_subscription(
            JointState, 'x_hat', lambda message: estimates.append(list(message.position)), 10)
        process = NodeProcess('observer', '--ros-args', '--params-file', str(params),
                              env=_environment(plugin_path))
        try:
            with executor_with(context, node) as executor:
                matched = spin_until(executor, lambda: publisher.get_subscription_count() > 0
                                     and node.count_publishers('x_hat') > 0, 30.0)
                assert matched, process.stop()

                def send(index):
                    message = JointState(name=['position'], position=[_cart(index)])
                    stamp = START_NS + index * PERIOD_NS
                    message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp, 10**9)
                    publisher.publish(message)

                # Until both directions have matched, a measurement or its estimate may be
                # lost (a repeated stamp would be dropped, so no estimate would ever come):
                # send earlier points of the same line, each with its own stamp, until one
                # gives an estimate, and only then the 200 that are counted.
                for warm_up in range(-60, 0):
                    send(warm_up)
                    if spin_until(executor, lambda: len(estimates) > 0, 0.5):
                        break
                assert estimates, process.stop()
                before = len(estimates)
                for index in range(200):
                    send(index)
                    assert spin_until(executor, lambda: len(estimates) > before + index, 5.0), (
                        index, process.stop())
        finally:
            code, _, err = process.stop()
    assert code == 0, err
    assert len(estimates) == before + 200
    assert abs(estimates[-1][1] - VELOCITY) < 1e-6, estimates[-1]
    assert abs(estimates[-1][0] - _cart(199)) < 1e-6


def test_a_plugin_that_fails_to_load_is_reported_and_the_others_still_run(tmp_path):
    # An installed distribution whose entry points name a missing module and a non-type.
    info = tmp_path / 'broken_types-0.1.dist-info'
    info.mkdir()
    (info / 'METADATA').write_text('Metadata-Version: 2.1\nName: broken-types\nVersion: 0.1\n')
    (info / 'entry_points.txt').write_text(
        '[observer_ros.observer_types]\nmissing = observer_ros_no_such_module:TYPE\n'
        'wrong = os:sep\n')
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        filter(None, [str(tmp_path), os.environ.get('PYTHONPATH', '')])))
    config = tmp_path / 'missing.yaml'
    config.write_text('/**:\n  ros__parameters:\n    model: {A: [0.0], B: [1.0], C: [1.0]}\n'
                      '    observer: {type: missing}\n')
    result = subprocess.run([console_script('design_observer'), str(config)],
                            capture_output=True, text=True, env=env, timeout=60)
    assert result.returncode == 2
    assert ("design_observer: error: observer.type: observer type 'missing' is not available: "
            "entry point 'missing' = observer_ros_no_such_module:TYPE (distribution "
            'broken-types) of observer_ros.observer_types failed to load: '
            'ModuleNotFoundError') in result.stderr, result.stderr
    built_in = subprocess.run(
        [console_script('design_observer'), '--json',
         str(Path(__file__).resolve().parents[1] / 'config' / 'seed003_full_order.yaml')],
        capture_output=True, text=True, env=env, timeout=60)
    assert built_in.returncode == 0, built_in.stderr
    assert json.loads(built_in.stdout)['observer.type'] == 'full_order'
    # Each failure is reported once, as a warning naming its entry point.
    assert ("entry point 'wrong' = os:sep (distribution broken-types) of "
            'observer_ros.observer_types failed to load: TypeError: expected an ObserverType (or '
            'a callable returning one), got str') in built_in.stderr
    assert "entry point 'missing' = observer_ros_no_such_module:TYPE" in built_in.stderr
