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
Dead code: every function and method of the engine is used outside the tests.

A definition whose name no module of the package, benchmark or script uses (a name, an
attribute or a string naming it) is dead, or used by the tests alone. The audit covers the
event engine, the stream and the runtime estimators; the names of issue 28 found never
called elsewhere are checked gone.
"""

import ast
import collections
import importlib
from pathlib import Path
import re

import pytest

ROOT = Path(__file__).resolve().parents[1]
#: The modules audited: the engine's.
AUDITED = ('observer_ros/core/events', 'observer_ros/core/streaming',
           'observer_ros/core/estimators', 'observer_ros/core/rules.py')
#: Where a use counts: everything but the tests.
USERS = ('observer_ros', 'benchmarks', 'scripts', 'launch', 'examples', 'setup.py')
#: Called by something else than a name in this tree (Python's protocols).
CALLED_BY_PYTHON = re.compile(r'__\w+__')


def _files(*roots: str) -> list:
    files = []
    for root in roots:
        path = ROOT / root
        files += [path] if path.is_file() else sorted(path.rglob('*.py')) if path.exists() else []
    return files


def _definitions(path: Path):
    tree = ast.parse(path.read_text())
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            yield node.name, node.lineno
        if isinstance(node, ast.ClassDef):
            for item in node.body:
                if isinstance(item, ast.FunctionDef):
                    yield f'{node.name}.{item.name}', item.lineno


def _uses() -> collections.Counter:
    used = collections.Counter()
    for path in _files(*USERS):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Name):
                used[node.id] += 1
            elif isinstance(node, ast.Attribute):
                used[node.attr] += 1
            elif isinstance(node, ast.Constant) and isinstance(node.value, str):
                used.update(re.findall(r'\w+', node.value))  # getattr, entry points
    return used


def test_every_definition_of_the_engine_is_used_outside_the_tests():
    used = _uses()
    dead = [f'{path.relative_to(ROOT)}:{line} {name}'
            for path in _files(*AUDITED) for name, line in _definitions(path)
            if not CALLED_BY_PYTHON.fullmatch(name.rsplit('.', 1)[-1])
            and not used[name.rsplit('.', 1)[-1]]]
    assert not dead, dead


@pytest.mark.parametrize('module, name', [
    ('observer_ros.bags.filter_config', 'flat_parameters'),
    ('observer_ros.core.sources', 'subset_of'),
    ('observer_ros.core.observers.full_order.design', 'full_order_gain'),
    ('observer_ros.core', 'full_order_gain'),
])
def test_the_names_never_called_are_gone(module, name):
    assert not hasattr(importlib.import_module(module), name)


def test_a_disturbance_has_no_matched_input():
    from observer_ros.core.disturbances import Disturbance
    assert not hasattr(Disturbance, 'matched_input')
