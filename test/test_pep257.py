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

"""Docstring style as ament_pep257 checks it: the pep257 convention with D213 summaries."""

import subprocess
import sys

from conftest import REPOSITORY

AMENT_PEP257_IGNORE = 'D100,D101,D102,D103,D104,D105,D106,D107,D404'


def test_pep257():
    result = subprocess.run(
        [sys.executable, '-m', 'pydocstyle', '--convention=pep257', '--add-select=D213',
         f'--add-ignore={AMENT_PEP257_IGNORE}',
         'observer_ros', 'test', 'launch', 'doc'],
        capture_output=True, text=True, cwd=REPOSITORY)
    assert result.returncode == 0, f'pydocstyle found problems:\n{result.stdout}{result.stderr}'
