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
doc/tuning.md runs: every command it shows, on the recordings it names, with its numbers.

The page's worked example uses simulated recordings made here (:mod:`tuning_support`):
``spring_run`` (the mass-spring-damper of ``config/kalman_noisy.yaml``, 300 s at 100 Hz),
``fleet/`` (four recordings of a two-output plant), ``third_order`` (a third-order plant at
30 dB). Each ``$ command`` of the page's ``console`` blocks runs in that folder, and every
output line the page shows (``...`` skips) must be among the lines the command printed.
"""

import os
from pathlib import Path
import re
import shlex

import pytest

from conftest import REPOSITORY
from observer_ros.bags.examples import main as examples_main
from observer_ros.config.node_specs import console_scripts
from observer_ros.tools.identify import main as identify_main
from observer_ros.tools.replay import main as replay_main
from observer_ros.tools.tune_kalman import main as tune_main
from test_run_reports import check_page

PAGE = REPOSITORY / 'doc' / 'tuning.md'
TOOLS = {'tune_kalman': tune_main, 'identify': identify_main, 'replay': replay_main}
#: The page's Dask address, replaced by the local test cluster's.
DASK_ADDRESS = 'tcp://127.0.0.1:8786'


def make_example(folder: Path) -> None:
    """Write the recordings and parameter files the page's commands use (as users do)."""
    assert examples_main([str(folder)]) == 0


def examples(text: str) -> list:
    """Return ``(command, shown output lines)`` of every ``$`` line in ``console`` blocks."""
    found = []
    for block in re.findall(r'```console\n(.*?)```', text, flags=re.DOTALL):
        for chunk in re.split(r'^(?=\$ )', block, flags=re.MULTILINE):
            if not chunk.startswith('$ '):
                continue
            lines = chunk.rstrip('\n').split('\n')
            command = lines[0][2:]
            while command.endswith('\\'):
                command = command[:-1] + lines.pop(1).strip()
            found.append((command, [line for line in lines[1:] if line.strip() != '...']))
    return found


def test_the_page_shows_commands():
    commands = [command.split()[0] for command, _ in examples(PAGE.read_text())]
    assert {'tune_kalman', 'identify', 'replay'} <= set(commands)


def test_every_command_of_the_page_runs_and_prints_what_it_shows(
        tmp_path, capsys, monkeypatch):
    make_example(tmp_path)
    monkeypatch.chdir(tmp_path)
    from distributed import LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False, protocol='tcp://',
                      host='127.0.0.1', dashboard_address=None) as cluster:
        for command, shown in examples(PAGE.read_text()):
            arguments = shlex.split(command.replace(DASK_ADDRESS, cluster.scheduler_address))
            assert arguments[0] in TOOLS, command
            code = TOOLS[arguments[0]](arguments[1:])
            printed = capsys.readouterr()
            assert code == (2 if 'error' in ''.join(shown) else 0), (command, printed.err)
            lines = [line.rstrip() for line in (printed.out + printed.err).splitlines()]
            for line in shown:
                assert line.rstrip() in lines, (command, line, printed.out + printed.err)
    assert Path('spring_tuned.yaml').exists()
    # The three reports the page's commands wrote, rendered in headless Chromium.
    check_page(tmp_path / 'report' / 'tune_kalman.html', tmp_path, 8,
               ['before: the filter of the parameter file', 'after: the tuned filter'])
    check_page(tmp_path / 'report' / 'replay.html', tmp_path, 16,
               [f'fleet/run{part}' for part in range(4)])
    check_page(tmp_path / 'report' / 'identify.html', tmp_path, 2,
               ['singular values', 'measured against simulated output'])


@pytest.mark.parametrize('name', ['tune_kalman', 'identify', 'replay'])
def test_the_tools_are_console_scripts(name):
    assert f'{name} = observer_ros.tools.{name}:main' in console_scripts()  # setup.py's
    assert os.path.exists(REPOSITORY / 'observer_ros' / 'tools' / f'{name}.py')
