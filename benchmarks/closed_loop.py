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
5. Closed loop: the highest real-time rate, and the lockstep simulation speed.

At each rate the plant counts the samples that apply the command computed from the
previous sample (``commands_on_time``), from the first command on. Set-ups: one process
(``closed_loop``: the three nodes on one executor, or the plant and the observer-controller
with ``--controller``), two processes (the plant and the ``observer_controller``) and three
processes (the plant, ``observer`` and ``state_feedback``), the processes through
``benchmarks.ros_runner`` (the plant's first sample waits until its peers are matched).
Each set-up runs several times per rate and executor; the table shows the worst run.
Lockstep: the plant waits for each command, on simulated time.
"""

import re
import signal
import statistics
import subprocess
import sys
import time

import rclpy
from rclpy.parameter import Parameter

from benchmarks.common import (CONFIG_DIR, pyplot, REPOSITORY, RUN_LENGTH, Section,
                               stolen_seconds)
from observer_ros.config.plant import PlantSettings
from observer_ros.nodes.closed_loop import ClosedLoop
from observer_ros.ros.executors import make_executor

CONFIG = CONFIG_DIR / 'seed003_full_order.yaml'
LOG = re.compile(r'simulated (\d+) samples; (\d+) applied .*first command at sample (\w+)')


def on_time_fraction(samples: int, on_time: int, first: int) -> float:
    """Share of the samples after the first command that applied the previous one's."""
    return on_time / max(1, samples - first)


#: Goals at 1 kHz, worst of the runs: two processes (plant and controller), three processes.
GOAL_TWO, GOAL_THREE = 0.995, 0.99
GOAL_RATE = 1000.0
#: The rate of a run, given to every node: the plant's, and the one the others expect.
RATE_PARAMETERS = ('plant.rate_hz', 'diagnostics.expected_rate')


def one_process(rate: float, seconds: float, lockstep: bool = False,
                executor: str = 'single', controller: bool = False):
    """Run ``ClosedLoop`` on ``executor``; return ``(fraction on time, samples, wall s)``."""
    samples = int(rate * seconds)
    context = rclpy.Context()
    rclpy.init(args=['bench', '--ros-args', '--params-file', str(CONFIG)], context=context)
    overrides = [*(Parameter(name, value=float(rate)) for name in RATE_PARAMETERS),
                 Parameter('plant.samples', value=samples),
                 Parameter('plant.lockstep', value=lockstep)]
    loop = ClosedLoop(context=context, overrides=overrides,
                      executor=make_executor(executor, context), controller=controller)
    try:
        started = time.perf_counter()
        assert loop.spin(timeout_sec=seconds * 20 + 30), 'the closed loop did not finish'
        wall = time.perf_counter() - started
        counters = loop.plant.counters
        return (on_time_fraction(counters['samples'], counters['commands_on_time'],
                                 counters.get('first_command_sample', samples)),
                counters['samples'], wall)
    finally:
        loop.destroy()
        rclpy.try_shutdown(context=context)


def processes(rate: float, seconds: float, executor: str = 'events',
              nodes=('observer', 'state_feedback')) -> float:
    """Run the plant and ``nodes`` as processes; return the on-time fraction."""
    samples = int(rate * seconds)
    # Every node is told the rate, as one YAML file would: the observer designs for it.
    common = ['--executor', executor, '--ros-args', '--params-file', str(CONFIG),
              *(item for name in RATE_PARAMETERS for item in ('-p', f'{name}:={float(rate)}'))]
    runner = [sys.executable, '-m', 'benchmarks.ros_runner']

    def start(command, *extra):
        return subprocess.Popen([*command, *common, *extra], stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, text=True, cwd=REPOSITORY)

    helpers = [start([*runner, name]) for name in nodes]
    try:
        # The plant's first sample waits until y has a subscriber and u_cmd a publisher.
        plant = start([*runner, 'plant_simulator'], '-p', f'plant.samples:={samples}')
        _, err = plant.communicate(timeout=seconds * 5 + 60)
    finally:
        for helper in helpers:
            helper.send_signal(signal.SIGINT)
        for helper in helpers:
            try:
                helper.communicate(timeout=10)
            except subprocess.TimeoutExpired:
                helper.kill()
    found = LOG.search(err)
    if not found:
        raise RuntimeError(f'the plant did not report its counts: {err[-300:]}')
    done, on_time, first = found.groups()
    return 0.0 if first == 'none' else on_time_fraction(int(done), int(on_time), int(first))


#: The set-ups of the table: label -> function of (rate, seconds, executor) -> fraction.
SETUPS = {
    'one process': lambda rate, seconds, executor: one_process(
        rate, seconds, executor=executor)[0],
    'one process, controller': lambda rate, seconds, executor: one_process(
        rate, seconds, executor=executor, controller=True)[0],
    'two processes': lambda rate, seconds, executor: processes(
        rate, seconds, executor, ('observer_controller',)),
    'three processes': lambda rate, seconds, executor: processes(rate, seconds, executor),
}


def run(smoke: bool, figures) -> Section:
    """Measure and return the section."""
    section = Section(5, 'Closed loop: real-time rate and lockstep speed',
                      f'plant and controller as two processes at {GOAL_RATE:g} Hz with at least '
                      f'{100 * GOAL_TWO:g} % of samples applying the command computed from the '
                      f'previous sample, three processes at least {100 * GOAL_THREE:g} %, in '
                      'every run (events executor)')
    rates = RUN_LENGTH.get('rates') or ([100.0] if smoke else
                                        [100.0, 250.0, 500.0, 1000.0, 2000.0])
    seconds = RUN_LENGTH.get('seconds') or (0.5 if smoke else 2.0)
    runs = RUN_LENGTH.get('runs') or (1 if smoke else 5)
    fractions = {(setup, executor): [] for setup in SETUPS for executor in ('single', 'events')}
    stolen = {key: [] for key in fractions}  # per rate: host steal (s) in each run
    for rate in rates:
        for key, values in fractions.items():
            runs_here, steals = [], []
            for _ in range(runs):
                before = stolen_seconds()
                runs_here.append(SETUPS[key[0]](rate, seconds, key[1]))
                after = stolen_seconds()
                steals.append(None if before is None or after is None else after - before)
            values.append(runs_here)
            stolen[key].append(steals)

    def cell(key, i) -> str:
        values, steals = fractions[key][i], stolen[key][i]
        worst = min(range(len(values)), key=values.__getitem__)
        steal = steals[worst]
        return f'{100 * values[worst]:.1f} %' + ('' if steal is None else
                                                 f' ({1000 * steal:.0f})')

    header = ['rate (Hz)', *(f'{setup}, {executor}' for setup, executor in fractions)]
    rows = [[f'{rate:g}', *(cell(key, i) for key in fractions)] for i, rate in enumerate(rates)]
    every_steal = [s for per_key in stolen.values() for per_rate in per_key for s in per_rate
                   if s is not None]
    section.add(f'seed 003 (full-order observer and state feedback), {seconds:g} s per run, '
                f'{runs} run{"s" if runs > 1 else ""} per rate, set-up and executor; the worst '
                "run's share of the samples (after the first command) that applied the "
                'command computed from the previous sample. One process: `closed_loop` (the '
                'three nodes on one executor; "controller": the plant and the '
                'observer-controller). Two processes: the plant and `observer_controller`. '
                'Three processes: the plant, `observer` and `state_feedback`. Every node gets '
                'the rate (`plant.rate_hz`, `diagnostics.expected_rate`). The first sample of '
                'the plant waits until its endpoints are matched and'
                f' `plant.settle_time` ({PlantSettings.settle_time:g} s) more. In '
                'brackets: milliseconds of CPU time the host took from this virtual machine '
                "during that run (Linux's steal time, both CPUs together; blank where the "
                'system does not report it).', '')
    section.table(header, rows)
    if every_steal:
        section.add(f'Steal time per run: median {1000 * statistics.median(every_steal):.0f} '
                    f'ms, largest {1000 * max(every_steal):.0f} ms, over {len(every_steal)} '
                    f'runs of {seconds:g} s.', '')
    highest = {key: max((rate for rate, f in zip(rates, values) if min(f) >= 0.99),
                        default=0.0) for key, values in fractions.items()}
    section.add('Highest rate with at least 99 % on time in every run: ' + ', '.join(
        f'{setup}, {executor} {rate:g} Hz' for (setup, executor), rate in highest.items())
        + '.', '')
    lockstep_samples = 300 if smoke else 3000
    for executor in ('single', 'events'):
        _, done, wall = one_process(100.0, lockstep_samples / 100.0, lockstep=True,
                                    executor=executor)
        section.add(f'Lockstep, one process, {executor} executor (100 Hz model): {done} '
                    f'samples in {wall:.2f} s, {done / wall:,.0f} samples/s, real-time factor '
                    f'{done / wall / 100.0:.1f}.', '')
    if GOAL_RATE in rates:
        at = rates.index(GOAL_RATE)
        section.met = bool(min(fractions[('two processes', 'events')][at]) >= GOAL_TWO
                           and min(fractions[('three processes', 'events')][at]) >= GOAL_THREE)
    plt = pyplot()
    figure, axis = plt.subplots(figsize=(7, 3.5))
    for (setup, executor), values in fractions.items():
        axis.semilogx(rates, [100 * min(f) for f in values], 'o-', label=f'{setup}, {executor}')
    axis.axhline(99.0, color='k', linestyle='--', label='99 %')
    axis.set_xlabel('plant rate (Hz)')
    axis.set_ylabel('samples on time, worst run (%)')
    axis.legend(fontsize=6)
    section.figures.append(figures.save(figure, 'closed_loop_rate'))
    return section
