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

import io
import re
import subprocess
import sys
import tokenize

import pytest

from conftest import REPOSITORY

LINTED = ['observer_ros', 'test', 'launch', 'setup.py', 'benchmarks', 'doc']


def test_flake8():
    paths = [str(REPOSITORY / path) for path in LINTED if (REPOSITORY / path).exists()]
    result = subprocess.run(
        [sys.executable, '-m', 'flake8', '--config', str(REPOSITORY / 'setup.cfg'), *paths],
        capture_output=True, text=True, cwd=REPOSITORY)
    assert result.returncode == 0, f'flake8 found problems:\n{result.stdout}{result.stderr}'


@pytest.mark.skipif(sys.version_info >= (3, 12), reason='flake8 checks inside f-strings there')
def test_no_f_string_field_opens_or_closes_with_a_space():
    # Python 3.12 (Jazzy's) tokenizes f-strings, so flake8 there flags f'{ {...}[x]}' (E201)
    # and f'{x }' (E202), which it cannot see on 3.11: benchmarks/run.py had two.
    found = []
    for path in python_files():
        text = path.read_text(encoding='utf-8')
        for token in tokenize.generate_tokens(io.StringIO(text).readline):
            prefix = re.match(r'[A-Za-z]*', token.string).group().lower()
            if token.type != tokenize.STRING or 'f' not in prefix:
                continue
            body = token.string.replace('{{', '').replace('}}', '')
            if re.search(r'\{\s|\s\}', body):
                found.append(f'{path.relative_to(REPOSITORY)}:{token.start[0]}')
    assert not found, found


def python_files() -> list:
    """Return the Python files flake8 lints here."""
    files = []
    for name in LINTED:
        path = REPOSITORY / name
        files += sorted(path.rglob('*.py')) if path.is_dir() else [path] * path.exists()
    return files
