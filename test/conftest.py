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

"""Shared fixtures: an isolated ROS domain per test run, the shipped configs, the scripts."""

import os
from pathlib import Path
import random
import shutil
import sys

import numpy as np
import pytest
import scipy.optimize

import observer_ros

REPOSITORY = Path(__file__).resolve().parents[1]
CONFIG_DIR = REPOSITORY / 'config'


def _domain_id() -> int:
    """
    Return this test process's DDS domain: one per test run, and one per worker under -n.

    ``ROS_DOMAIN_ID``, when set, is the run's first domain; otherwise a random one (or, with
    pytest-xdist, one derived from the run's id, which every worker shares). Worker ``gwK``
    takes the K-th domain after it, so parallel workers never hear each other.
    """
    given = os.environ.get('ROS_DOMAIN_ID')
    run = os.environ.get('PYTEST_XDIST_TESTRUNUID')
    if given:
        base = int(given)
    elif run:
        base = int(run, 16) % 100 + 1
    else:
        base = random.SystemRandom().randint(1, 100)
    worker = os.environ.get('PYTEST_XDIST_WORKER', 'gw0')
    return (base - 1 + int(worker[2:])) % 100 + 1


# One private DDS domain per test run, traffic kept on this machine. Set before any test
# imports rclpy; subprocesses inherit it.
os.environ['ROS_DOMAIN_ID'] = str(_domain_id())
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.setdefault('MPLBACKEND', 'Agg')


@pytest.fixture
def config_dir() -> Path:
    """Directory of the shipped parameter files."""
    return CONFIG_DIR


def match(achieved, wanted):
    """Reorder ``achieved`` so that entry ``i`` is the one paired with ``wanted[i]``."""
    achieved = np.asarray(achieved, dtype=complex)
    wanted = np.asarray(wanted, dtype=complex)
    rows, cols = scipy.optimize.linear_sum_assignment(
        np.abs(achieved[:, None] - wanted[None, :]))
    result = np.empty_like(wanted)
    result[cols] = achieved[rows]
    return result


def console_scripts() -> list:
    """Names of the console scripts setup.py declares (from the node specs and tools)."""
    from observer_ros.config.node_specs import console_scripts as declared
    return [item.split('=')[0].strip() for item in declared()]


#: Where ``ros2 run`` finds the console scripts: ``<prefix>/lib/<package>`` (setup.cfg).
PACKAGE = 'observer_ros'


def _script_directories() -> list:
    directories = []
    for variable in ('AMENT_PREFIX_PATH', 'COLCON_PREFIX_PATH'):
        for prefix in filter(None, os.environ.get(variable, '').split(os.pathsep)):
            # COLCON_PREFIX_PATH names install roots; an isolated install nests the package.
            directories += [Path(prefix) / 'lib' / PACKAGE,
                            Path(prefix) / PACKAGE / 'lib' / PACKAGE]
    package = Path(observer_ros.__file__).resolve().parent
    if package.parent.name in ('site-packages', 'dist-packages'):
        # <prefix>/lib/pythonX.Y/site-packages/observer_ros
        prefix = package.parents[3]
        directories += [prefix / 'lib' / PACKAGE, prefix / 'bin']
    directories.append(Path(sys.executable).parent)
    return directories


def console_script(name: str) -> str:
    """
    Return the path of the installed console script ``name``.

    A pip or venv set-up puts it on PATH (or next to the interpreter); an ament_python
    install (``colcon build``, then ``colcon test``) puts it in ``<prefix>/lib/observer_ros``
    of a prefix listed in AMENT_PREFIX_PATH or COLCON_PREFIX_PATH, or of the prefix that
    holds the imported package. Fails the test with what was searched when it is nowhere.
    """
    found = shutil.which(name)
    if found:
        return found
    directories = _script_directories()
    for directory in directories:
        path = directory / name
        if path.is_file() and os.access(path, os.X_OK):
            return str(path)
    pytest.fail(f'console script {name!r} not found: not on PATH and not in '
                f'{", ".join(map(str, dict.fromkeys(directories)))}; install the package '
                f'(pip install -e . or colcon build, then source install/setup.bash)',
                pytrace=False)
