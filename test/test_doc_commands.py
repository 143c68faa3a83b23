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
Every command of README.md and of every documentation page runs as a user would run it.

Each page's code blocks run in order in a fresh directory that holds the checkout's
``config/``, ``scripts/`` and ``launch/`` (what a user's checkout has), so a page may use
what an earlier block of it made (a recorded bag). The rules:

- A shell block runs in bash, command after command; each must exit 0. A node executable
  in the foreground (``observer ...``) is started, let come up and stopped with Ctrl-C
  (SIGINT), and must exit 0; a command ending with ``&`` runs until the block's end, is
  then stopped the same way and must exit 0 too.
- A shell block whose first line is ``# On a ROS 2 Jazzy install`` holds commands for a
  ROS 2 install (``ros2``, ``colcon``, ``rosdep``): they are checked against the package
  (executables, launch files and their arguments, parameters, lifecycle transitions, files)
  but not run, as the pip set-up has no ``ros2`` command. A ``ros2`` command outside such a
  block fails the test.
- Commands of the pip set-up (``./scripts/demo.sh``, ``source scripts/setup_env.sh``) run
  only in that set-up (the suite's interpreter is the ``.venv`` those scripts made), not
  under ``colcon test``.
- :data:`COVERED_ELSEWHERE` lists the few commands another test runs instead, with why.
- A Python block runs with the suite's interpreter; the ``test_`` functions it defines are
  called. A YAML block must parse.
- A text block after the line ``<!-- output of the commands above -->`` is what the shell
  block before it prints: its lines must appear in that output, in order (``...`` skips
  lines; numbers agree within 5 %).
"""

import ast
import hashlib
import os
from pathlib import Path
import re
import shlex
import signal
import subprocess
import sys
import time

import pytest
import yaml

from conftest import console_script, console_scripts, REPOSITORY
from doc_support import code_blocks, commands, OUTPUT_MARK, pages, SHELL_LANGUAGES, shows
from observer_ros.config import PARAMETER_SPECS
from observer_ros.config.node_specs import NODE_SPECS

PAGES = pages()

#: Commands shown on a page that this test does not run, each with the test that does.
COVERED_ELSEWHERE = {
    './scripts/test.sh': 'the test suite itself (this test is part of it)',
    './scripts/benchmark.sh': 'minutes of timing: test_benchmarks_smoke.py runs the same '
                              'suite (benchmarks.run) on tiny sizes',
    './scripts/docs.sh': 'test_docs.py builds the same site with the same options',
}

#: Commands that need the pip set-up (``.venv`` made by scripts/setup_env.sh).
PIP_SETUP = ('./scripts/demo.sh', 'source scripts/setup_env.sh', 'source .venv/bin/activate')

#: Console scripts that run until they are stopped: started, let come up, stopped.
NODES = tuple(name for spec in NODE_SPECS for name in spec.executables)

#: What a checkout holds that the pages' commands use.
CHECKOUT = ('config', 'launch', 'scripts', 'benchmarks', 'requirements.txt', 'setup.py',
            'package.xml')

#: The ROS 2 command-line verbs the pages may use in a ROS-install block.
ROS2_VERBS = ('run', 'launch', 'lifecycle', 'topic', 'service', 'param', 'bag', 'pkg')
LIFECYCLE_TRANSITIONS = ('configure', 'activate', 'deactivate', 'cleanup', 'shutdown')

#: Seconds a page's shell block may take.
BLOCK_TIMEOUT = 300

#: Options with which a command writes files that later commands of its page may read.
OUTPUT_OPTIONS = ('--record', '--report', '--csv', '--output', '--write')


def page_id(path: Path) -> str:
    return str(path.relative_to(REPOSITORY))


def reads_only_the_checkout(command) -> bool:
    """
    Whether a command depends on nothing but the checkout and writes nothing a page reads.

    Such a command gives the same result on every page, so it runs on the first page that
    shows it (README first) and is not run again on the others.
    """
    if command.background or '<<' in command.text or '>' in command.text:
        return False
    for word in command.words:
        if word in OUTPUT_OPTIONS or word == 'source':
            return False
        if ':=' in word:
            continue
        if ('/' in word or word.endswith('.yaml')) and not word.startswith(
                ('config/', './scripts/', '/')):
            return False
    return True


def _runnable(page: Path):
    for block in code_blocks(page):
        if block.language in SHELL_LANGUAGES and not block.needs_ros_install:
            yield from commands(block)


#: The page that runs each command that reads only the checkout.
FIRST_PAGE = {}
for _page in PAGES:
    for _command in _runnable(_page):
        if reads_only_the_checkout(_command):
            FIRST_PAGE.setdefault(_command.text, _page)


def pip_setup() -> bool:
    """Whether this interpreter is the ``.venv`` of scripts/setup_env.sh, installed as now."""
    stamp = Path(sys.prefix) / '.observer_ros_installed'
    if not stamp.exists():
        return False
    wanted = hashlib.sha256(b''.join((REPOSITORY / name).read_bytes()
                                     for name in ('requirements.txt', 'setup.py')))
    return stamp.read_text(encoding='utf-8').strip() == wanted.hexdigest()


def launch_arguments(name: str) -> set:
    path = REPOSITORY / 'launch' / name
    assert path.is_file(), f'no launch file {name}'
    tree = ast.parse(path.read_text(encoding='utf-8'))
    return {node.args[0].value for node in ast.walk(tree) if isinstance(node, ast.Call)
            and getattr(node.func, 'id', None) == 'DeclareLaunchArgument'}


def check_ros_command(command, where: str) -> None:
    """Check a command of a ROS-install block against the package, without running it."""
    words = command.words
    for computed in re.findall(r'\$\([^)]*\)', command.text):
        assert computed == '$(ros2 pkg prefix observer_ros)', (
            f'{where}: only the package prefix may be computed: {computed}')
    for path in re.findall(r'(?:^|\s|/share/observer_ros/)(config/[\w.]+)', command.text):
        assert (REPOSITORY / path).is_file(), f'{where}: no {path} in the package'
    first = words[0]
    if re.match(r'^[A-Z_]+=', first) or first in ('source', 'export'):
        return
    if first in ('colcon', 'rosdep'):
        assert words[1] in ('build', 'test', 'test-result', 'install'), f'{where}: {words}'
        return
    assert first == 'ros2', f'{where}: a ROS-install block holds ros2, colcon, rosdep: {words}'
    verb = words[1]
    assert verb in ROS2_VERBS, f'{where}: ros2 {verb}?'
    if verb == 'run' and words[2] == 'observer_ros':
        assert words[3] in console_scripts(), f'{where}: no executable {words[3]}'
    if verb == 'launch':
        assert words[2] == 'observer_ros', where
        declared = launch_arguments(words[3])
        for word in words[4:]:
            name = word.split(':=')[0]
            assert ':=' in word and name in declared, f'{where}: {words[3]} has no {name}'
    if verb == 'lifecycle' and words[2] == 'set':
        assert words[4] in LIFECYCLE_TRANSITIONS, f'{where}: no transition {words[4]}'
    if verb == 'param' and words[2] == 'set':
        assert words[4] in PARAMETER_SPECS, f'{where}: no parameter {words[4]}'


def shell_script(block, run_pip_setup: bool, skipped: list, checked: bool = False) -> str:
    """
    Return the bash script that runs a block's commands and checks each one.

    ``checked``: the page shows the block's output, so every command of it runs here.
    """
    support = REPOSITORY / 'test' / 'doc_support.py'
    lines = [
        # exec: a background job's pid ($!) is then the runner's, which a signal reaches.
        f'doc_node() {{ {shlex.quote(sys.executable)} {shlex.quote(str(support))} '
        f'"$(command -v "$1")" "${{@:2}}"; }}',
        f'doc_background() {{ exec {shlex.quote(sys.executable)} {shlex.quote(str(support))} '
        f'--background "$(command -v "$1")" "${{@:2}}"; }}',
        *(f'{node}() {{ doc_node {node} "$@"; }}' for node in NODES),
        'doc_pids=()',
        'doc_fail() { echo "DOC COMMAND FAILED (exit status $1): $2" >&2; '
        'for pid in "${doc_pids[@]}"; do kill -TERM "$pid" 2>/dev/null; done; wait; exit 97; }',
    ]
    for command in commands(block):
        where = f'{page_id(block.path)}:{command.line}'
        words = command.words
        assert words[0] not in ('ros2', 'colcon', 'rosdep'), (
            f'{where}: {words[0]} needs a ROS 2 install: put it in a block whose first line '
            f'is "# On a ROS 2 Jazzy install"')
        key = next((name for name in COVERED_ELSEWHERE if command.text.startswith(name)), None)
        if key:
            skipped.append(f'{where}: {key} ({COVERED_ELSEWHERE[key]})')
            continue
        first = FIRST_PAGE.get(command.text, block.path)
        if first != block.path and not checked:
            skipped.append(f'{where}: {command.text} (runs on {page_id(first)})')
            continue
        if command.text.startswith(PIP_SETUP) and not run_pip_setup:
            skipped.append(f'{where}: {command.text} (pip set-up only)')
            continue
        lines.append(f'echo "+ {where}: {words[0]}" >&2')
        if command.background:
            lines.append('doc_background ' + command.text)
            lines.append('doc_pids+=($!)')
        else:
            lines.append(command.text)
            lines.append(f'doc_status=$?; [ $doc_status -eq 0 ] || doc_fail $doc_status '
                         f'{shlex.quote(where)}')
    lines += ['for pid in "${doc_pids[@]}"; do',
              '  for _ in $(seq 300); do [ -e .doc-ready-$pid ] && break; sleep 0.1; done',
              '  kill -TERM "$pid"',
              '  wait "$pid" || doc_fail $? "a background command of the block"',
              'done']
    return '\n'.join(lines) + '\n'


def prepare(directory: Path) -> None:
    """Make ``directory`` look like a checkout: config/, scripts/, ... and the .venv."""
    for name in CHECKOUT:
        (directory / name).symlink_to(REPOSITORY / name)
    if sys.prefix != sys.base_prefix:
        (directory / '.venv').symlink_to(sys.prefix)


def _wait_for_group_exit(group: int, seconds: float) -> None:
    """Wait up to ``seconds`` until no process of ``group`` is left."""
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            os.killpg(group, 0)
        except ProcessLookupError:
            return
        time.sleep(0.05)


def run(argv: list, directory: Path, environment: dict) -> tuple:
    """
    Run ``argv`` in a process group of its own; return its exit status and output.

    Whatever the commands left running when it ends (or times out) is stopped with the
    group, so no node outlives its page and no pipe is held open.
    """
    with open(directory / '.doc-stdout', 'w+', encoding='utf-8') as out, \
            open(directory / '.doc-stderr', 'w+', encoding='utf-8') as err:
        process = subprocess.Popen(argv, cwd=directory, env=environment, stdout=out,
                                   stderr=err, text=True, start_new_session=True)
        try:
            status = process.wait(timeout=BLOCK_TIMEOUT)
        except subprocess.TimeoutExpired:
            status = f'timeout after {BLOCK_TIMEOUT} s'
        finally:
            for stop in (signal.SIGINT, signal.SIGKILL):
                try:
                    os.killpg(process.pid, stop)
                except ProcessLookupError:
                    break
                _wait_for_group_exit(process.pid, 2.0)
            process.wait()
        out.seek(0)
        err.seek(0)
        return status, out.read(), err.read()


def run_block(block, directory: Path, environment: dict, skipped: list,
              output: list, checked: bool = False) -> None:
    """Run one block; ``output`` keeps what the last shell block printed."""
    if block.language == 'text' and block.preceded_by == OUTPUT_MARK:
        assert output, f'{block.where}: no commands ran before this output'
        assert shows(block.text, output[-1]), (
            f'{block.where}: the commands above do not print this; they printed:\n'
            f'{output[-1][-4000:]}')
        return
    if block.language in SHELL_LANGUAGES:
        if block.needs_ros_install:
            for command in commands(block):
                check_ros_command(command, f'{page_id(block.path)}:{command.line}')
            return
        argv = ['bash', '-c', shell_script(block, pip_setup(), skipped, checked)]
    elif block.language == 'python':
        argv = [sys.executable, '-c', block.text + (
            '\nfor _name, _value in list(globals().items()):\n'
            "    if _name.startswith('test_') and callable(_value):\n"
            '        _value()\n')]
    elif block.language == 'yaml':
        yaml.safe_load(block.text)
        return
    else:
        return
    status, stdout, stderr = run(argv, directory, environment)
    output.append(stdout + stderr)
    assert status == 0, (
        f'{block.where}: the block failed (exit status {status})\n'
        f'--- stdout\n{stdout[-3000:]}\n--- stderr\n{stderr[-4000:]}')


@pytest.mark.parametrize('page', PAGES, ids=page_id)
def test_every_command_of_the_page_runs(page, tmp_path):
    environment = dict(os.environ)
    scripts = str(Path(console_script('observer')).parent)
    environment['PATH'] = scripts + os.pathsep + environment.get('PATH', '')
    prepare(tmp_path)
    skipped, output = [], []
    blocks = code_blocks(page)
    for block, after in zip(blocks, blocks[1:] + [None]):
        checked = after is not None and after.preceded_by == OUTPUT_MARK
        run_block(block, tmp_path, environment, skipped, output, checked)
    for line in skipped:
        print('not run here:', line)


def test_every_command_covered_elsewhere_is_on_a_page_and_runs_what_it_says():
    shown = [command.text for page in PAGES for block in code_blocks(page)
             if block.language in SHELL_LANGUAGES for command in commands(block)]
    for name in COVERED_ELSEWHERE:
        assert any(text.startswith(name) for text in shown), f'{name} is on no page'
    docs = (REPOSITORY / 'scripts' / 'docs.sh').read_text(encoding='utf-8')
    assert 'python -m sphinx -W --keep-going -b html doc doc/_build/html' in docs
    benchmark = (REPOSITORY / 'scripts' / 'benchmark.sh').read_text(encoding='utf-8')
    assert 'exec python -m benchmarks.run "$@"' in benchmark


def test_readme_and_every_executable_page_show_commands():
    # README and the page of each executable show commands a user can type (and this test
    # runs them).
    for page in [REPOSITORY / 'README.md', *sorted((REPOSITORY / 'doc' / 'nodes').glob('*.md'))]:
        assert any(block.language in SHELL_LANGUAGES for block in code_blocks(page)), page
