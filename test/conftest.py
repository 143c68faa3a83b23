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
# The shipped discovery profile (config/fastdds_discovery.xml, a participant announced every
# 0.5 s instead of every 3 s): a process that missed its peers' first answers found them
# 0.5 to 3 s late with Fast DDS's defaults, in about one start of seven measured, and the
# tests wait for matched endpoints. What the tests check is the package, not that delay.
os.environ.setdefault('FASTRTPS_DEFAULT_PROFILES_FILE', str(
    Path(__file__).resolve().parents[1] / 'config' / 'fastdds_discovery.xml'))


#: Where the last run's slowest tests are kept (pytest's cache, ``.pytest_cache``).
DURATIONS_KEY = 'observer_ros/slowest'

#: A test that took longer than this (s) in the last run starts first in the next one.
SLOW_TEST = 5.0

#: A run of fewer tests than this is not a whole run (the suite has about 1 500).
WHOLE_RUN = 1000

#: The slowest tests when no run has been recorded yet (node id -> seconds, quiet machine).
KNOWN_SLOW = {
    'test/test_benchmarks_smoke.py::test_smoke_run_writes_every_section_and_figure': 60.0,
    'test/test_docs.py::test_the_docs_build_with_warnings_as_errors': 25.0,
}


def pytest_collection_modifyitems(session, config, items):
    """
    Start the slowest tests first (those over :data:`SLOW_TEST` in the last run).

    Under ``-n 2`` the workers take the tests in this order: a long test that starts last
    keeps one worker busy while the other waits, which cost the suite a minute. The others
    keep their order (a module's tests together). Every worker reads the same cache, so
    they collect the same order, as pytest-xdist requires.
    """
    cache = getattr(config, 'cache', None)
    slow = (cache.get(DURATIONS_KEY, None) if cache is not None else None) or KNOWN_SLOW
    first = sorted((item for item in items if item.nodeid in slow),
                   key=lambda item: -slow[item.nodeid])
    if first:
        chosen = set(map(id, first))
        items[:] = first + [item for item in items if id(item) not in chosen]


_durations: dict = {}


def pytest_runtest_logreport(report):
    """Add up each test's set-up, call and teardown time (reported to the controller too)."""
    _durations[report.nodeid] = _durations.get(report.nodeid, 0.0) + report.duration


def pytest_sessionfinish(session):
    """Keep the slowest tests of a whole run for the next one (the controller writes)."""
    config = session.config
    cache = getattr(config, 'cache', None)
    if cache is None or hasattr(config, 'workerinput') or config.option.keyword \
            or config.option.markexpr or len(_durations) < WHOLE_RUN:
        return  # a partial run says nothing about the rest
    cache.set(DURATIONS_KEY, {nodeid: round(seconds, 1) for nodeid, seconds in
                              _durations.items() if seconds > SLOW_TEST})


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
