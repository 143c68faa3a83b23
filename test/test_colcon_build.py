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

"""``colcon build`` of the repository gives every executable and the ament index marker."""

import os
from pathlib import Path
import shutil
import subprocess
import sys

import pytest

from conftest import console_scripts, REPOSITORY

IGNORED = shutil.ignore_patterns('.venv', 'build', 'install', 'log', '.git', '__pycache__',
                                 '*.egg-info', '.pytest_cache', '.hypothesis', 'output')


@pytest.fixture(scope='module')
def colcon_install(tmp_path_factory):
    workspace = tmp_path_factory.mktemp('ws')
    shutil.copytree(REPOSITORY, workspace / 'src' / 'observer_ros', ignore=IGNORED)
    colcon = Path(sys.executable).with_name('colcon')
    assert colcon.exists(), 'colcon is not installed in this environment'
    result = subprocess.run(
        [str(colcon), 'build', '--event-handlers', 'console_direct-'],
        cwd=workspace, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stdout + result.stderr
    return workspace / 'install' / 'observer_ros'


def test_every_executable_is_installed_where_ros2_run_looks(colcon_install):
    scripts = console_scripts()
    assert 'design_observer' in scripts
    for name in scripts:
        assert (colcon_install / 'lib' / 'observer_ros' / name).is_file(), name


def test_ament_index_marker_package_xml_and_configs(colcon_install):
    share = colcon_install / 'share'
    assert (share / 'ament_index' / 'resource_index' / 'packages' / 'observer_ros').is_file()
    assert (share / 'observer_ros' / 'package.xml').is_file()
    shipped = {path.name for path in (REPOSITORY / 'config').glob('*.yaml')}
    installed = {path.name for path in (share / 'observer_ros' / 'config').glob('*.yaml')}
    assert shipped == installed
    launch = {path.name for path in (REPOSITORY / 'launch').glob('*.launch.py')}
    if launch:
        assert launch == {p.name for p in (share / 'observer_ros' / 'launch').glob('*.py')}


def test_installed_executable_runs_from_the_install_tree(colcon_install):
    site = next(colcon_install.glob('lib/python3*/site-packages'))
    env = dict(os.environ, PYTHONPATH=str(site))
    config = colcon_install / 'share' / 'observer_ros' / 'config' / 'seed000_reduced_order.yaml'
    result = subprocess.run(
        [str(colcon_install / 'lib' / 'observer_ros' / 'design_observer'), str(config)],
        capture_output=True, text=True, env=env, timeout=60)
    assert result.returncode == 0, result.stderr
    assert '0.5' in result.stdout
    where = subprocess.run(
        [sys.executable, '-c', 'import observer_ros; print(observer_ros.__file__)'],
        capture_output=True, text=True, env=env, cwd=str(colcon_install))
    assert str(site) in where.stdout


def test_every_module_is_installed(colcon_install):
    # A directory without __init__.py is skipped by find_packages: its modules would then
    # import from the source tree in development and be missing from a real install.
    site = next(colcon_install.glob('lib/python3*/site-packages'))
    source = {path.relative_to(REPOSITORY) for path in (REPOSITORY / 'observer_ros').rglob('*.py')
              if '__pycache__' not in path.parts}
    installed = {path.relative_to(site) for path in (site / 'observer_ros').rglob('*.py')}
    assert source - installed == set()


def test_the_install_tree_registers_the_observer_types(colcon_install):
    # The types are found through the entry points of the installed distribution.
    site = next(colcon_install.glob('lib/python3*/site-packages'))
    metadata = next(site.glob('observer_ros*.egg-info')) / 'entry_points.txt'
    text = metadata.read_text(encoding='utf-8')
    assert '[observer_ros.observer_types]' in text
    for name in ('full_order', 'reduced_order', 'chen', 'kalman'):
        assert f'{name} = observer_ros.core.observers.{name}:TYPE' in text
    code = ('from importlib.metadata import distribution\n'
            'from observer_ros.core.observers import observer_types\n'
            "print(distribution('observer_ros')._path, [t.name for t in observer_types()])")
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            env=dict(os.environ, PYTHONPATH=str(site)), cwd=str(colcon_install),
                            timeout=60)
    assert str(site) in result.stdout, result.stderr
    assert ("['full_order', 'reduced_order', 'chen', 'kalman', 'extended_kalman', "
            "'unscented_kalman']") in result.stdout
