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

"""Helpers for tests with real rclpy nodes: contexts, bounded spinning, subprocess nodes."""

from contextlib import contextmanager
import os
from pathlib import Path
import re
import signal
import subprocess
import time
from typing import Optional

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from sensor_msgs.msg import JointState

from conftest import CONFIG_DIR, console_script
from observer_ros.nodes.closed_loop import ClosedLoop
from observer_ros.ros.executors import make_executor


@contextmanager
def ros_context(*ros_args):
    """Create a private rclpy context, initialised with ``--ros-args *ros_args``."""
    context = rclpy.Context()
    rclpy.init(args=['test', '--ros-args', *ros_args] if ros_args else ['test'],
               context=context)
    try:
        yield context
    finally:
        rclpy.try_shutdown(context=context)


@contextmanager
def executor_with(context, *nodes, executor_name: str = 'single'):
    """Spin ``nodes`` on an executor (single-threaded by default); destroy them afterwards."""
    executor = (SingleThreadedExecutor(context=context) if executor_name == 'single'
                else make_executor(executor_name, context))
    for node in nodes:
        executor.add_node(node)
    try:
        yield executor
    finally:
        for node in nodes:
            executor.remove_node(node)
            node.destroy_node()
        executor.shutdown()


def spin_until(executor, predicate, timeout: float) -> bool:
    """Spin until ``predicate()`` holds or ``timeout`` seconds pass; return the predicate."""
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() > deadline:
            return False
        executor.spin_once(timeout_sec=0.02)
    return True


#: Seconds a console-script process may take to start and be discovered: its imports take
#: 2-5 s on a quiet machine of two cores, over 20 s at load 15.
PROCESS_START = 60.0

#: Lockstep runs are the same bit for bit only while every answer comes within the wall-clock
#: ``feedback.timeout`` (after it the watchdog's safe command becomes the sample's command)
#: and ``plant.lockstep_timeout`` (after it the plant advances without the command). A loaded
#: machine can take longer than the defaults (0.5 s, 1 s): runs that must be exact wait this
#: long, per node.
PATIENT_LOCKSTEP = {'state_feedback': {'feedback.timeout': 60.0},
                    'observer_controller': {'feedback.timeout': 60.0},
                    'plant_simulator': {'plant.lockstep_timeout': 10.0}}


def patient_lockstep(executable: Optional[str] = None):
    """
    Return :data:`PATIENT_LOCKSTEP` for one executable as ``-p`` arguments.

    Without an executable: for every node, as ``Parameter`` overrides (one process).
    """
    if executable is None:
        merged = {name: value for settings in PATIENT_LOCKSTEP.values()
                  for name, value in settings.items()}
        return [Parameter(name, value=value) for name, value in merged.items()]
    return [argument for name, value in PATIENT_LOCKSTEP.get(executable, {}).items()
            for argument in ('-p', f'{name}:={value}')]


def cpu_wait_ns(pid: Optional[int] = None) -> int:
    """
    Return how long the threads of a process have waited for a CPU while ready to run (ns).

    Linux's scheduler statistics (``/proc/<pid>/task/<tid>/schedstat``, second field),
    summed over the threads alive now (this process by default); 0 where there are none. On
    a machine that is not overloaded it barely moves; on a loaded one it is the time a
    node's timer callback came late through no fault of the node, which a timing promise
    ("at most this late") allows on top.
    """
    tasks = Path('/proc') / ('self' if pid is None else str(pid)) / 'task'
    try:
        threads = list(tasks.iterdir())
    except OSError:
        return 0
    total = 0
    for thread in threads:
        try:
            total += int((thread / 'schedstat').read_text().split()[1])
        except (OSError, IndexError, ValueError):
            continue  # the thread has ended
    return total


def logged_since(stderr: str, wall_time: float, pattern) -> list:
    """
    Return the groups of ``pattern`` in the log lines of ``stderr`` stamped after ``wall_time``.

    The lines are rcutils' default ``[LEVEL] [seconds] [node]: message`` (seconds of the
    system clock, as ``time.time()``); ``pattern`` is matched against the message.
    """
    found = []
    for stamp, message in re.findall(r'^\[[A-Z]+\] \[([0-9.]+)\] \[[^]]*\]: (.*)$', stderr,
                                     re.MULTILINE):
        match = re.search(pattern, message)
        if match and float(stamp) > wall_time:
            found.append(match.groups())
    return found


def overrides(**values):
    """``Parameter`` overrides from keyword arguments (``plant__samples`` -> plant.samples)."""
    return [Parameter(name.replace('__', '.'), value=value) for name, value in values.items()]


class NodeProcess:
    """A console-script node in a subprocess, stopped with SIGINT."""

    def __init__(self, executable: str, *args: str, env: Optional[dict] = None) -> None:
        self.process = subprocess.Popen(
            [console_script(executable), *args], stdout=subprocess.PIPE,
            stderr=subprocess.PIPE, text=True, env=dict(os.environ) if env is None else env)

    def stop(self, timeout: float = 10.0):
        """Interrupt (like Ctrl-C) and return ``(returncode, stdout, stderr)``."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGINT)
        try:
            out, err = self.process.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.process.kill()
            out, err = self.process.communicate()
        return self.process.returncode, out, err


#: ``DiagnosticStatus`` levels by name.
LEVELS = {DiagnosticStatus.OK: 'OK', DiagnosticStatus.WARN: 'WARN',
          DiagnosticStatus.ERROR: 'ERROR'}


class DiagnosticsListener(Node):
    """Keep every status received on ``/diagnostics``, by name."""

    def __init__(self, **kwargs) -> None:
        super().__init__('diagnostics_listener', **kwargs)
        self.statuses: dict = {}
        self.hardware_ids: dict = {}
        self.create_subscription(DiagnosticArray, '/diagnostics', self._on_message,
                                 QoSProfile(depth=100))

    def _on_message(self, message) -> None:
        for status in message.status:
            values = {item.key: item.value for item in status.values}
            self.statuses.setdefault(status.name, []).append(
                (LEVELS[status.level], status.message, values))
            self.hardware_ids[status.name] = status.hardware_id

    def latest(self, name: str):
        """Return the latest ``(level, message, values)`` of a status (None: none yet)."""
        reports = self.statuses.get(name)
        return reports[-1] if reports else None

    def count(self, name: str) -> int:
        """Return the number of reports of a status so far."""
        return len(self.statuses.get(name, ()))

    def level_is(self, name: str, level: str, since: int = 0, text: str = '') -> bool:
        """Whether a report after the first ``since`` has ``level`` and contains ``text``."""
        return any(found == level and text in message
                   for found, message, _ in self.statuses.get(name, [])[since:])


def offline_estimates(system, recorder):
    """Run the configured estimator over the recorded y and u, as the observer node does."""
    stream = system.make_stream()
    events = [(stamp, 1, vector) for stamp, vector in zip(*recorder.arrays('u'))]
    events += [(stamp, 2, vector) for stamp, vector in zip(*recorder.arrays('y'))]
    samples = []
    for stamp, kind, vector in sorted(events, key=lambda e: (e[0], e[1])):
        add = stream.add_input if kind == 1 else stream.add_measurement
        samples += add(int(stamp), vector)
    samples += stream.flush()
    return (np.array([s.stamp_ns for s in samples], dtype=np.int64),
            np.array([s.estimate for s in samples]))


def run_lockstep(config, samples, extra=(), reference=None, bag=None, storage='mcap',
                 executor='single', controller=False):
    """
    Run the closed loop in lockstep; return (system, recorder arrays, plant counters).

    ``controller``: the plant and one ``observer_controller`` instead of the pair.
    """
    with ros_context('--params-file', str(CONFIG_DIR / config)) as context:
        settings = (overrides(plant__lockstep=True, plant__samples=samples)
                    + patient_lockstep() + list(extra))
        loop = ClosedLoop(record=True, context=context,
                          executor=make_executor(executor, context), overrides=settings,
                          controller=controller)
        helper = None
        try:
            if reference is not None:
                helper = Node('reference_publisher', context=context)
                publisher = helper.create_publisher(JointState, 'reference', 10)
                names = list(loop.plant.system.model.output_names)
                helper.create_timer(0.01, lambda: publisher.publish(
                    JointState(name=names, position=list(reference))))
                loop.executor.add_node(helper)
                assert spin_until(loop.executor, lambda: loop.feedback.feedback_part.reference
                                  is not None, 10.0), 'the reference never reached state_feedback'
            assert loop.spin(timeout_sec=60.0), 'the lockstep run did not finish'
            recorder = loop.recorder
            if bag is not None:
                loop.record(str(bag), storage)
            result = {topic: recorder.arrays(topic) for topic in ('y', 'u', 'x_true', 'x_hat')}
            return loop.system, recorder, result, dict(loop.plant.counters)
        finally:
            if helper is not None:
                loop.executor.remove_node(helper)
                helper.destroy_node()
            loop.destroy()
