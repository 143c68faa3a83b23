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
SIGINT, repeated SIGINTs, SIGTERM and ``ros2 launch``'s Ctrl-C stop every executable cleanly.

Each case runs in a fresh process, started in a process group of its own. A process counts
as up once its stop handler is installed (SIGTERM caught, in ``/proc/<pid>/status``) and,
for the nodes that log at start-up, once that line is out: the node is spinning. The nodes
exit 0; the offline tools exit ``128 + signal`` (130 for SIGINT, 143 for SIGTERM) with one
line. Never a traceback, never an abort.
"""

import os
from pathlib import Path
import signal
import subprocess
import threading
import time

import pytest

from bag_support import write_robot_bag
from conftest import CONFIG_DIR, console_script
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.ros.recorder import TopicRecorder
from ros_support import executor_with, PROCESS_START, ros_context, spin_until

CONFIG = str(CONFIG_DIR / 'seed003_full_order.yaml')

#: What must never appear on stderr, whatever the signals.
CRASH_MARKS = ('Traceback', 'terminate called', 'KeyboardInterrupt', 'Exception ignored')

#: Seconds a process may take to come up, and to exit once signalled.
START_TIMEOUT = PROCESS_START
EXIT_TIMEOUT = 15.0

#: Seconds between two signals of a storm.
STORM_INTERVAL = 0.001

#: The node executables and the line each logs once it is built (None: no line).
NODES = {
    'plant_simulator': None,
    'observer': 'observer of order',
    'state_feedback': 'K = ',
    'observer_controller': 'closed loop: ',
    'closed_loop': 'K = ',
}


def handles_sigterm(pid: int) -> bool:
    """Whether process ``pid`` catches SIGTERM (``SigCgt`` in ``/proc/<pid>/status``)."""
    try:
        status = Path(f'/proc/{pid}/status').read_text(encoding='utf-8')
    except FileNotFoundError:
        return False
    for line in status.splitlines():
        if line.startswith('SigCgt:'):
            return bool(int(line.split()[1], 16) >> (signal.SIGTERM - 1) & 1)
    return False


class Executable:
    """A console script in a process group of its own, its stderr collected as it comes."""

    def __init__(self, name: str, *args: str, ready_line=None, process_group: int = 0) -> None:
        self.name = name
        # process_group=0: a new group led by this process, as launch's children get.
        # With the fault handler on, a process that does not exit in time shows on stderr
        # where each of its threads was when SIGABRT ended it (see finish()).
        self.process = subprocess.Popen(
            [console_script(name), *args], stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
            process_group=process_group, env={**os.environ, 'PYTHONFAULTHANDLER': '1'})
        self.ready_line = ready_line
        self.signalled = False
        self.lines = []
        self.logged = threading.Event()
        self.reader = threading.Thread(target=self._read, daemon=True)
        self.reader.start()

    def _read(self) -> None:
        for line in self.process.stderr:
            self.lines.append(line)
            if self.ready_line is not None and self.ready_line in line:
                self.logged.set()
        self.logged.set()

    def wait_until_up(self) -> None:
        """Wait (bounded) until the stop handler is installed and the ready line is out."""
        deadline = time.monotonic() + START_TIMEOUT
        while not handles_sigterm(self.process.pid):
            assert time.monotonic() < deadline, f'{self.name} did not come up'
            try:
                self.process.wait(timeout=0.01)
            except subprocess.TimeoutExpired:
                continue
            raise AssertionError(f'{self.name} exited {self.process.returncode} before it '
                                 f'was up: {self.stderr()}')
        if self.ready_line is not None:
            assert self.logged.wait(max(0.0, deadline - time.monotonic())), (
                f'{self.name} did not log {self.ready_line!r}: {self.stderr()}')
            assert self.process.poll() is None, self.stderr()

    def send(self, signum: int) -> None:
        self.signalled = True
        self.process.send_signal(signum)

    def storm(self) -> None:
        """SIGINT and SIGTERM by turns, every millisecond, until the process is gone."""
        self.signalled = True
        deadline = time.monotonic() + EXIT_TIMEOUT
        signals = (signal.SIGINT, signal.SIGTERM)
        count = 0
        while self.process.poll() is None and time.monotonic() < deadline:
            self.process.send_signal(signals[count % 2])
            count += 1
            try:
                self.process.wait(timeout=STORM_INTERVAL)
            except subprocess.TimeoutExpired:
                pass

    def launch_interrupt(self) -> None:
        """Ctrl-C under ``ros2 launch``: the terminal's SIGINT to the group, then launch's."""
        self.signalled = True
        os.killpg(os.getpgid(self.process.pid), signal.SIGINT)
        self.process.send_signal(signal.SIGINT)

    def finish(self) -> tuple:
        """Wait (bounded) for the exit; return ``(returncode, stderr)``."""
        if not self.signalled:
            self.process.kill()
        try:
            self.process.wait(timeout=EXIT_TIMEOUT)
        except subprocess.TimeoutExpired:
            self.process.send_signal(signal.SIGABRT)  # the fault handler dumps the stacks
            try:
                self.process.wait(timeout=5.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.reader.join(timeout=EXIT_TIMEOUT)
        return self.process.returncode, self.stderr()

    def stderr(self) -> str:
        return ''.join(self.lines)


#: Each case: how the signals are sent, the first signal (for the tools' exit status).
CASES = {
    'SIGINT': (lambda e: e.send(signal.SIGINT), signal.SIGINT),
    'storm': (Executable.storm, signal.SIGINT),
    'SIGTERM': (lambda e: e.send(signal.SIGTERM), signal.SIGTERM),
    'launch': (Executable.launch_interrupt, signal.SIGINT),
}


def run_cases(start) -> dict:
    """Start one fresh process per case (all at once), signal each when up; the outcomes."""
    processes = {}
    try:
        for case in CASES:
            processes[case] = start()
        for case, process in processes.items():
            process.wait_until_up()
            CASES[case][0](process)
    finally:
        outcomes = {case: process.finish() for case, process in processes.items()}
    return outcomes


def assert_clean(outcomes: dict, expected) -> None:
    for case, (code, err) in outcomes.items():
        want = expected(CASES[case][1])
        assert code == want, f'{case}: exit {code}, expected {want}:\n{err}'
        for mark in CRASH_MARKS:
            assert mark not in err, f'{case}: {mark!r} on stderr:\n{err}'


@pytest.mark.parametrize('executor', ['events', 'single'])
@pytest.mark.parametrize('name', sorted(NODES))
def test_node_exits_0_on_sigint_repeated_signals_sigterm_and_launch_ctrl_c(name, executor):
    outcomes = run_cases(lambda: Executable(
        name, '--executor', executor, '--ros-args', '--params-file', CONFIG,
        ready_line=NODES[name]))
    assert_clean(outcomes, lambda first: 0)


def test_play_bag_exits_0_on_every_stop_signal(tmp_path):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=50)
    # Waits for a subscriber nobody starts: spinning until a signal comes.
    outcomes = run_cases(lambda: Executable(
        'play_bag', str(bag), '--wait-for', '/joint_states', '--wait', '60'))
    assert_clean(outcomes, lambda first: 0)


@pytest.mark.parametrize('name', ['design_observer', 'replay'])
def test_offline_tool_exits_128_plus_signal_with_one_line(tmp_path, name):
    # The parameter file is a FIFO nobody writes: the tool waits in main() until signalled.
    fifo = tmp_path / 'params.yaml'
    os.mkfifo(fifo)
    args = [str(fifo)] if name == 'design_observer' else [str(tmp_path / 'bag'), str(fifo)]
    outcomes = run_cases(lambda: Executable(name, *args))
    assert_clean(outcomes, lambda first: 128 + first)
    for case, (_, err) in outcomes.items():
        first = signal.Signals(CASES[case][1]).name
        assert err == f'{name}: interrupted by {first}\n', (case, err)


@pytest.mark.parametrize('executor', ['events', 'single'])
def test_ctrl_c_on_the_launched_loop_stops_the_three_nodes_cleanly(executor):
    # As closed_loop.launch.py starts them: three processes in one group, talking over DDS.
    system = validate_parameters(load_parameter_file(CONFIG))
    common = ['--executor', executor, '--ros-args', '--params-file', CONFIG]
    with ros_context() as context:
        recorder = TopicRecorder(system, ('x_hat', 'u_cmd'), context=context)
        with executor_with(context, recorder) as spinner:
            nodes = [Executable('observer', *common, ready_line=NODES['observer'])]
            group = os.getpgid(nodes[0].process.pid)
            try:
                for name in ('state_feedback', 'plant_simulator'):
                    nodes.append(Executable(name, *common, ready_line=NODES[name],
                                            process_group=group))
                for node in nodes:
                    node.wait_until_up()
                # Traffic through all three: the plant's y made an x_hat, that a u_cmd.
                assert spin_until(spinner, lambda: recorder.count('x_hat') > 10 and
                                  recorder.count('u_cmd') > 10, START_TIMEOUT), (
                    [node.stderr() for node in nodes])
                os.killpg(group, signal.SIGINT)
                for node in nodes:
                    node.send(signal.SIGINT)
            finally:
                outcomes = {node.name: node.finish() for node in nodes}
    for name, (code, err) in outcomes.items():
        assert code == 0, f'{name}: exit {code}:\n{err}'
        for mark in CRASH_MARKS:
            assert mark not in err, f'{name}: {mark!r} on stderr:\n{err}'
