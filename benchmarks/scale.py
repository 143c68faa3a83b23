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
7. Scale: n = 100 states, p = 10 outputs.

Design time (full-order placement to the poles of the Kalman filter of the same model, and
the Kalman design), update time, and the memory of an ``observer`` node process for that
model against one for the second-order seed 003 model (same executable, parameters from a
generated file).
"""

from pathlib import Path
import signal
import subprocess
import sys
import tempfile
import time

import numpy as np
import yaml

from benchmarks.common import CONFIG_DIR, per_call, random_stable_system, Section, timed
from observer_ros.core import make_estimator
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers.full_order.design import design_full_order
from observer_ros.core.observers.kalman.design import design_kalman


def resident_kib(parameter_file: str) -> int:
    """Return the VmRSS (KiB) of an ``observer`` process once it has logged its poles."""
    process = subprocess.Popen([sys.executable, '-m', 'benchmarks.ros_runner', 'observer',
                                '--ros-args', '--params-file', parameter_file],
                               stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        line = process.stderr.readline()
        if 'observer of order' not in line:
            raise RuntimeError(f'observer did not start: {line}{process.stderr.read()[-300:]}')
        time.sleep(1.0)
        with open(f'/proc/{process.pid}/status', encoding='utf-8') as status:
            for entry in status:
                if entry.startswith('VmRSS:'):
                    return int(entry.split()[1])
        raise RuntimeError('no VmRSS in /proc')
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()


def run(smoke: bool, figures) -> Section:
    """Measure and return the section."""
    n, p = (20, 2) if smoke else (100, 10)
    section = Section(7, f'Scale: n = {n}, p = {p}', 'design, update and memory measured '
                      '(no numeric goal)')
    rng = np.random.default_rng(100)
    a, b, c = random_stable_system(rng, n, 1, p)
    model = StateSpaceModel(a=a, b=b, c=c, d=np.zeros((p, 1)))
    kalman, kalman_s = timed(lambda: design_kalman(model, np.ones(n), np.full(p, 0.01)))
    full, full_s = timed(lambda: design_full_order(model, kalman.achieved_poles))
    rows = [['Kalman design (CARE, verified)', f'{kalman_s * 1e3:.0f} ms'],
            [f'full-order design, {n} poles (placement `{full.method}`, verified to '
             f'{full.residual:.1e})', f'{full_s * 1e3:.0f} ms']]
    for name, design in (('full order', full), ('Kalman', kalman)):
        estimator = make_estimator(design)
        ys, us = rng.standard_normal((1000, p)), rng.standard_normal((1000, 1))
        state = {'k': 0}

        def step():
            k = state['k'] = state['k'] + 1
            estimator.update(k * 10_000_000, ys[k % 1000], us[k % 1000])

        step()
        rows.append([f'{name} update, steady 100 Hz',
                     f'{per_call(step, 200 if smoke else 2000) * 1e6:.1f} us'])
    with tempfile.TemporaryDirectory() as scratch:
        parameters = {'/**': {'ros__parameters': {
            'model': {'A': a.ravel().tolist(), 'B': b.ravel().tolist(),
                      'C': c.ravel().tolist()},
            'observer': {'type': 'kalman', 'process_noise': [1.0] * n,
                         'measurement_noise': [0.01] * p}}}}
        big = Path(scratch) / 'big.yaml'
        big.write_text(yaml.safe_dump(parameters))
        large = resident_kib(str(big))
        small = resident_kib(str(CONFIG_DIR / 'seed003_full_order.yaml'))
    rows.append([f'observer node process, n = {n} Kalman (resident memory)',
                 f'{large / 1024:.1f} MiB'])
    rows.append(['observer node process, n = 2 (seed 003)', f'{small / 1024:.1f} MiB'])
    rows.append(['difference (the model, its designs and step matrices)',
                 f'{(large - small) / 1024:.1f} MiB'])
    section.add(f'A random stable model, n = {n}, p = {p}, one input.', '')
    section.table(['what', 'measured'], rows)
    section.met = None
    return section
