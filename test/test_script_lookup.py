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

"""The suite starts the package's executables through ``console_script``, never by name."""

import ast
from pathlib import Path

from conftest import console_scripts

TESTS = Path(__file__).resolve().parent


#: The subprocess functions that take the command as their first argument.
LAUNCHERS = {'run', 'Popen', 'call', 'check_call', 'check_output'}


def _bare_script_calls(tree: ast.AST, scripts: set) -> list:
    """Return the lines where a subprocess call's command starts with a script's bare name."""
    found = []
    for node in ast.walk(tree):
        if not (isinstance(node, ast.Call) and node.args
                and getattr(node.func, 'attr', getattr(node.func, 'id', None)) in LAUNCHERS):
            continue
        command = node.args[0]
        if isinstance(command, ast.List) and command.elts:
            first = command.elts[0]
            if isinstance(first, ast.Constant) and first.value in scripts:
                found.append(node.lineno)
    return found


def test_no_test_runs_a_console_script_by_its_bare_name():
    # Under colcon test the scripts live in <prefix>/lib/observer_ros, not on PATH: a bare
    # name there is a FileNotFoundError (three replay tests failed that way).
    scripts = set(console_scripts())
    offenders = {path.name: lines for path in sorted(TESTS.glob('*.py'))
                 if (lines := _bare_script_calls(ast.parse(path.read_text()), scripts))}
    assert offenders == {}


def test_the_check_sees_a_bare_name():
    tree = ast.parse("subprocess.run(['replay', 'bag', 'params.yaml'])\n"
                     "subprocess.Popen([console_script('observer')])\n"
                     "names = ['replay', 'observer']\n")
    assert _bare_script_calls(tree, set(console_scripts())) == [1]
