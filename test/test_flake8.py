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

"""Lint like ament_flake8: 99 columns, single quotes, google import order, docstrings."""

import subprocess
import sys

from conftest import REPOSITORY

LINTED = ['observer_ros', 'test', 'launch', 'setup.py', 'benchmarks', 'doc']


def test_flake8():
    paths = [str(REPOSITORY / path) for path in LINTED if (REPOSITORY / path).exists()]
    result = subprocess.run(
        [sys.executable, '-m', 'flake8', '--config', str(REPOSITORY / 'setup.cfg'), *paths],
        capture_output=True, text=True, cwd=REPOSITORY)
    assert result.returncode == 0, f'flake8 found problems:\n{result.stdout}{result.stderr}'
