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

"""A node imports at start-up only what it needs before its first message (issue 29)."""

import json
import subprocess
import sys
import warnings

import numpy as np
import pytest

from conftest import CONFIG_DIR, REPOSITORY
from observer_ros.config.node_specs import NODE_SPECS
from observer_ros.core.consistency import nis_bounds

#: Every node module (each spec's, the one main of the executables and the managed twins,
#: and the two nodes that are tools).
NODE_MODULES = tuple(spec.module.rsplit('.', 1)[-1] for spec in NODE_SPECS) + (
    'main', 'closed_loop', 'bag_player')

#: Heavy modules no node needs to import before its design: scipy.signal alone took 1.7 s
#: of a 3.5 s start-up at load 4.6 (pulled in by core.placement), python-control 0.4 s more
#: with matplotlib; the others belong to tools (tuning, plots, bags), not to nodes.
HEAVY = ('scipy.signal', 'scipy.stats', 'scipy.optimize', 'control', 'matplotlib', 'cvxpy',
         'dask', 'rosbags', 'slycot', 'sympy', 'pandas')

IMPORTS = """
import importlib, json, sys
heavy = {heavy!r}
found = {{}}
for name in {modules!r}:
    importlib.import_module('observer_ros.nodes.' + name)
    found[name] = sorted(m for m in heavy if m in sys.modules and m not in sum(
        found.values(), []))
print(json.dumps(found))
"""


def run_python(code: str, *arguments: str) -> str:
    result = subprocess.run([sys.executable, '-c', code, *arguments], cwd=REPOSITORY,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout


def test_importing_a_node_imports_no_heavy_module():
    # before: importing observer_ros.nodes.observer imported scipy.signal, scipy.stats and
    # scipy.optimize (core.placement at the top of the import chain of config.schema)
    found = json.loads(run_python(IMPORTS.format(heavy=HEAVY, modules=NODE_MODULES)))
    assert found == {name: [] for name in NODE_MODULES}


BUILD = """
import json, sys
import rclpy
rclpy.init(args=sys.argv)
from observer_ros.nodes.{module} import {node}
{node}()
print(json.dumps(sorted(m for m in {heavy!r} if m in sys.modules)))
"""


def modules_after_building(module: str, node: str, parameters: str) -> list:
    code = BUILD.format(module=module, node=node, heavy=HEAVY)
    return json.loads(run_python(code, '--ros-args', '--params-file',
                                 str(CONFIG_DIR / parameters)).splitlines()[-1])


def test_a_node_that_places_no_poles_loads_no_placement_module():
    # before: every observer node called preload_methods, which imported python-control
    # (and matplotlib, scipy.signal, scipy.stats): 1 s of a Kalman observer's start-up
    assert modules_after_building('observer', 'ObserverNode', 'kalman_noisy.yaml') == []
    assert modules_after_building(
        'plant_simulator', 'PlantSimulatorNode', 'seed003_full_order.yaml') == []


def test_a_placing_node_loads_its_placement_methods_but_not_python_control():
    # Varga's method calls slycot directly: python-control brought matplotlib (0.4 s) along.
    # SciPy's place_poles and linear_sum_assignment come without scipy.signal (scipy.stats
    # with it) and scipy.optimize (test_scipy_parts). What the placement methods need is
    # loaded at start-up (test_trust_ros checks that a method changed at run time imports
    # nothing in the parameter callback).
    assert modules_after_building(
        'observer', 'ObserverNode', 'seed003_full_order.yaml') == ['slycot']


def test_the_start_up_benchmark_prints_a_time_to_ready_per_node():
    out = run_python('from benchmarks.startup import main; main()', '--runs', '1',
                     '--nodes', 'observer (kalman)')
    assert 'load average (1 min)' in out and 'steal' in out
    row = [line for line in out.splitlines() if line.startswith('| observer (kalman) |')]
    assert len(row) == 1, out
    import_p50, ready_p50, ready_worst = (float(cell) for cell in row[0].split('|')[3:6])
    # The import and the start to ready are timed in different processes: a cold import can
    # take longer than a warm start (1.21 s against 0.65 s seen in a whole run), so only
    # each figure's own sense is checked, not their order (a timing is no unit test).
    assert import_p50 > 0 and 0 < ready_p50 <= ready_worst


@pytest.mark.parametrize('window, outputs', [(1, 1), (20, 2), (50, 1), (300, 4), (2000, 6)])
def test_the_nis_bounds_are_scipy_stats_chi2_quantiles_bit_for_bit(window, outputs):
    # nis_bounds computes them from scipy.special, without importing scipy.stats
    from scipy.stats import chi2
    for confidence in (0.9, 0.95, 0.99, 0.999):
        tail = (1 - confidence) / 2
        wanted = (float(chi2.ppf(tail, window * outputs)) / window,
                  float(chi2.ppf(1 - tail, window * outputs)) / window)
        assert nis_bounds(window, outputs, confidence) == wanted


def test_vargas_method_gives_control_place_vargas_gain_bit_for_bit():
    # core.placement calls slycot's SB01BD as control.place_varga does, without importing
    # python-control; the gains are the same to the last bit (repeated poles included).
    control = pytest.importorskip('control')
    pytest.importorskip('slycot')
    from observer_ros.core.placement_methods import _varga
    rng = np.random.default_rng(1)
    for n_states, n_inputs in [(2, 1), (3, 1), (4, 2), (6, 3), (10, 1)]:
        for case in range(6):
            a = rng.normal(size=(n_states, n_states))
            b = rng.normal(size=(n_states, n_inputs))
            poles = -rng.uniform(0.5, 5.0, size=n_states).astype(complex)
            if case % 2:
                poles[:2] = [-1 - 1j, -1 + 1j]
            if case % 3 == 0:
                poles[:] = -2.0
            given = a.copy(), b.copy()
            with warnings.catch_warnings():
                warnings.simplefilter('ignore')  # SLICOT's stability-condition warnings
                wanted = np.asarray(control.place_varga(a, b, poles))
                got = _varga(a, b, poles)
            assert got.tobytes() == wanted.tobytes(), (n_states, n_inputs, case)
            assert np.array_equal(a, given[0]) and np.array_equal(b, given[1])
