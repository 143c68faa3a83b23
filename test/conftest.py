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

"""Shared fixtures: an isolated ROS domain per test run and the shipped configs."""

import ast
import os
from pathlib import Path
import random

import numpy as np
import pytest
import scipy.optimize

REPOSITORY = Path(__file__).resolve().parents[1]
CONFIG_DIR = REPOSITORY / 'config'

# One private DDS domain per test run, traffic kept on this machine. Set before any test
# imports rclpy; subprocesses inherit it.
os.environ.setdefault('ROS_DOMAIN_ID', str(random.SystemRandom().randint(1, 100)))
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
    """Names of the console scripts declared in setup.py."""
    tree = ast.parse((REPOSITORY / 'setup.py').read_text(encoding='utf-8'))
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict):
            for key, value in zip(node.keys, node.values):
                if isinstance(key, ast.Constant) and key.value == 'console_scripts':
                    return [ast.literal_eval(item).split('=')[0].strip() for item in value.elts]
    raise AssertionError('no console_scripts in setup.py')
