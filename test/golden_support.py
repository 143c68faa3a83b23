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
Golden outputs: what the package computed when they were recorded, to hold a refactor to.

Three kinds, each through the public entry point a user runs:

- ``design/<config>.json``: ``design_observer <config> --json`` for every shipped config.
- ``closed_loop/<config>.npz``: the lockstep ``closed_loop`` record (``y``, ``u``,
  ``u_cmd``, ``x_true``, ``x_hat``; ``x_hat_covariance`` and ``nis`` where the observer has
  them) of every shipped config with a state feedback.
- ``replay/<case>.npz``: ``replay_bag`` over a committed bag (``bags/<case>``) made once
  from an open-loop simulation with random inputs, for every shipped config and the
  models without inputs of :data:`EXTRA_CONFIGS` (one per observer type).

What a golden promises (doc/testing.md): stamps, counters, integers, flags, names and the
shapes are equal exactly; every floating-point value agrees within the tolerance recorded
for it in ``tolerances.json``. Another CPU, BLAS kernel or numpy/scipy release rounds the
same computation differently, so a golden made on one machine is not reproduced bit for
bit on another; the tolerance says how far the rounding can move each value, measured from
the computation's own conditioning (:func:`measure_tolerances`). Bit-for-bit equality is
kept where one machine computes a thing twice (the controller against the pair, offline
against live, a re-run history against the in-order filter): those tests compare the two
runs with each other, never with a golden.

``python test/golden_support.py`` records them anew and prints what changed, leaf by leaf,
in units in the last place (paste it into the commit): do that only for a change of
behaviour that is meant, and say why in the commit. The committed bags are inputs and are
kept (``--new-bags`` writes them anew too).
"""

import argparse
import functools
import json
import os
from pathlib import Path
import subprocess
import sys
import tempfile

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
import yaml

from bag_support import (
    float64_array, FLOAT64_MULTI_ARRAY, JOINT_STATE, joint_state, serialize, TYPESTORE)

GOLDEN_DIR = Path(__file__).resolve().parent / 'golden'
CONFIG_DIR = Path(__file__).resolve().parents[1] / 'config'

#: Shipped configs, in the order they are recorded.
SHIPPED_CONFIGS = sorted(path.name for path in CONFIG_DIR.glob('*.yaml'))

#: Shipped configs with a state feedback (recorded in lockstep closed loop).
CLOSED_LOOP_CONFIGS = ['dc_motor_load.yaml', 'kalman_noisy.yaml', 'kalman_time_varying.yaml',
                       'robot_joint.yaml', 'seed001_fourth_order_chen.yaml',
                       'seed001_third_order.yaml', 'seed001_third_order_chen.yaml',
                       'seed003_full_order.yaml']

#: Samples of each closed-loop record and each replay bag.
CLOSED_LOOP_SAMPLES = 200
REPLAY_SAMPLES = 300

_WITHOUT_INPUTS = {'A': [0.0, 1.0, 0.0, 0.0], 'B': [], 'C': [1.0, 0.0],
                   'state_names': ['position', 'velocity']}

#: Configs of the golden set that are not shipped: models without inputs (m = 0).
EXTRA_CONFIGS = {
    'no_inputs_full_order.yaml': {'model': _WITHOUT_INPUTS,
                                  'observer': {'type': 'full_order', 'poles': [-8.0, -9.0]},
                                  'plant': {'rate_hz': 100.0, 'initial_state': [0.5, 1.0]}},
    'no_inputs_reduced_order.yaml': {'model': _WITHOUT_INPUTS,
                                     'observer': {'type': 'reduced_order', 'poles': [-8.0]},
                                     'plant': {'rate_hz': 100.0, 'initial_state': [0.5, 1.0]}},
    'no_inputs_kalman.yaml': {'model': _WITHOUT_INPUTS,
                              'observer': {'type': 'kalman', 'process_noise': [0.0, 0.5],
                                           'measurement_noise': [0.01]},
                              'plant': {'rate_hz': 100.0, 'initial_state': [0.5, 1.0]}},
}

_MESSAGE_TYPES = {'joint_state': JOINT_STATE, 'float64_multi_array': FLOAT64_MULTI_ARRAY}


def config_path(name: str) -> Path:
    """Path of a golden config: shipped, or written under ``golden/configs``."""
    if name in EXTRA_CONFIGS:
        return GOLDEN_DIR / 'configs' / name
    return CONFIG_DIR / name


#: Shipped configs of several measurement sources: their robot-style bags are written and
#: replayed by test/test_sources_nodes.py (each source on its own topic, no ``y``).
SOURCE_CONFIGS = ['wheeled_base_sources.yaml']


def replay_cases() -> list:
    """Names of the replay cases: every shipped config of one ``y`` and the extra ones."""
    return [name for name in SHIPPED_CONFIGS if name not in SOURCE_CONFIGS] + sorted(
        EXTRA_CONFIGS)


def design_json(name: str, script: str, path=None) -> dict:
    """
    Run ``design_observer <config> --json``; return the parsed object.

    ``path``: the parameter file to read instead of the config's own (a perturbed copy).
    """
    result = subprocess.run([script, str(path or config_path(name)), '--json'],
                            capture_output=True, text=True, timeout=120, env=dict(os.environ))
    if result.returncode != 0:
        raise AssertionError(f'design_observer {name}: {result.stderr}')
    return json.loads(result.stdout)


def closed_loop_record(name: str, controller: bool = False, extra=(), path=None) -> dict:
    """
    Run the lockstep closed loop of a config; return every recorded topic's arrays.

    ``controller``: the plant and one ``observer_controller`` instead of the pair;
    ``extra``: more parameter overrides; ``path``: the parameter file to read instead of the
    config's own (a perturbed copy).
    """
    from ros_support import overrides, patient_lockstep, ros_context
    from observer_ros.nodes.closed_loop import ClosedLoop
    from observer_ros.ros.executors import make_executor, spin_until
    from observer_ros.ros.recorder import TopicRecorder

    with ros_context('--params-file', str(path or config_path(name))) as context:
        settings = (overrides(plant__lockstep=True, plant__samples=CLOSED_LOOP_SAMPLES)
                    + patient_lockstep() + list(extra))
        loop = ClosedLoop(record=True, context=context,
                          executor=make_executor('single', context), overrides=settings,
                          controller=controller)
        extra = None
        try:
            system = loop.system
            if system.observer.design.kind == 'kalman':
                extra = TopicRecorder(system, ('x_hat_covariance', 'nis'),
                                      node_name='golden_recorder', context=context)
                loop.executor.add_node(extra)
                assert spin_until(loop.executor, lambda: all(
                    extra.count_publishers(topic) >= 1
                    for topic in ('x_hat_covariance', 'nis')), 10.0)
            assert loop.spin(timeout_sec=120.0), 'the lockstep run did not finish'
            recorders = [loop.recorder] + ([extra] if extra is not None else [])
            # A controller publishes the last u_cmd (which ends the run) before the last
            # estimate: let what it published after it arrive.
            spin_until(loop.executor, lambda: all(
                len(stamps) and stamps[-1] == CLOSED_LOOP_SAMPLES * system.plant.period_ns
                for stamps in [loop.recorder.arrays('x_hat')[0]] + (
                    [] if extra is None else [extra.arrays('nis')[0]])), 5.0, context)
            record = {}
            for recorder in recorders:
                for topic, codec in recorder.codecs.items():
                    stamps, values = recorder.arrays(topic)
                    # The command computed from the last sample may arrive after the run.
                    keep = CLOSED_LOOP_SAMPLES - 1 if topic == 'u_cmd' else len(stamps)
                    if codec.stamped:  # unstamped: the recorder's receive time, not kept
                        record[f'{topic}.stamps'] = stamps[:keep]
                    record[f'{topic}.values'] = values[:keep]
            return record
        finally:
            if extra is not None:
                loop.executor.remove_node(extra)
                extra.destroy_node()
            loop.destroy()


def assert_records_equal(found: dict, golden: dict) -> None:
    """Every array of ``golden`` is in ``found`` with the same dtype, shape and bytes."""
    assert sorted(found) == sorted(golden)
    for key, expected in golden.items():
        value = np.asarray(found[key])
        assert value.shape == expected.shape, key
        if expected.dtype.kind == 'U':
            assert str(value) == str(expected), key
            continue
        assert value.dtype == expected.dtype, key
        assert value.tobytes() == expected.tobytes(), (
            key, float(np.max(np.abs(value - expected))) if value.size else None)


#: Where the tolerance of every floating-point value of every golden is kept.
TOLERANCE_FILE = GOLDEN_DIR / 'tolerances.json'

#: Unit roundoff's spacing at 1 (one unit in the last place of 1.0).
EPS = float(np.finfo(float).eps)

#: Model matrices perturbed to measure a golden's conditioning (see measure_tolerances).
PERTURBED_MATRICES = ('A', 'B', 'C', 'D')

#: Perturbed runs per golden: the tolerance takes the largest move seen.
PERTURBATIONS = 4

#: The tolerance is MARGIN times the largest move caused by a relative perturbation of one
#: unit roundoff of the model matrices. A backward-stable computation on another machine
#: gives the exact result of inputs perturbed by c n u (u the unit roundoff, n the order,
#: c a small constant of the algorithm), so its output moves by about c n times the measured
#: move: n <= 6 in the goldens and c of a few units for LU, QR, Schur and matrix products
#: give c n <= 32. The per-step rounding of a simulated loop is a random walk of such
#: perturbations, smaller than the fixed perturbation measured over the whole run.
MARGIN = 32

#: A value whose perturbed runs did not move at all still may move by rounding alone: the
#: tolerance is at least FLOOR_ULPS units in the last place of the largest value of its
#: array (16: a sum or product of a few dozen rounded terms).
FLOOR_ULPS = 16


def _is_float_leaf(value) -> bool:
    """Whether a design-report leaf holds floating-point numbers (compared with tolerance)."""
    flat = np.ravel(np.asarray(value, dtype=object)) if isinstance(value, list) else [value]
    return (any(isinstance(item, float) for item in flat)
            and all(isinstance(item, (int, float)) and not isinstance(item, bool)
                    for item in flat))


def _leaves(summary: dict, prefix: str = '') -> dict:
    """Flatten a design report into ``{'a/b': value}`` (lists are leaves)."""
    leaves = {}
    for key, value in summary.items():
        if isinstance(value, dict):
            leaves.update(_leaves(value, f'{prefix}{key}/'))
        else:
            leaves[f'{prefix}{key}'] = value
    return leaves


def record_of(kind: str, output) -> dict:
    """
    Return ``{key: value}`` of one golden's output, the unit its tolerances are kept by.

    Design reports are flattened to their leaves (floating-point leaves as arrays, the rest
    as parsed JSON); closed-loop and replay records are already arrays.
    """
    if kind != 'design':
        return dict(output)
    return {key: (np.asarray(value, dtype=float) if _is_float_leaf(value) else value)
            for key, value in _leaves(output).items()}


def _floats(value) -> bool:
    return isinstance(value, np.ndarray) and value.dtype.kind == 'f'


def _is_series(kind: str) -> bool:
    """Closed-loop and replay arrays run along time (axis 0): one tolerance per column."""
    return kind != 'design'


def tolerances_of(kind: str, base: dict, perturbed: list) -> dict:
    """
    Return the tolerance of every floating-point value of ``base``.

    ``perturbed``: the same golden computed from model matrices perturbed by one unit
    roundoff. Per value: ``max(FLOOR_ULPS * EPS * max|array|, MARGIN * move)``, the move the
    largest over the perturbed runs (and, for a time series, over time: one tolerance per
    column).
    """
    out = {}
    for key, value in base.items():
        if not _floats(value):
            continue
        move = np.zeros(value.shape)
        for other in perturbed:
            if other[key].shape != value.shape:
                raise AssertionError(f'{key}: shape {other[key].shape} in a perturbed run, '
                                     f'{value.shape} unperturbed')
            with np.errstate(invalid='ignore'):  # non-finite values are compared exactly
                step = np.abs(np.asarray(other[key], dtype=float) - value)
            move = np.fmax(move, np.where(np.isfinite(value), step, 0.0))
        finite = value[np.isfinite(value)]
        scale = float(np.max(np.abs(finite))) if finite.size else 0.0
        if _is_series(kind) and value.ndim:
            move = np.max(move, axis=0) if value.shape[0] else move[0:0].sum(axis=0)
        out[key] = np.maximum(FLOOR_ULPS * EPS * scale, MARGIN * move).tolist()
    return out


def assert_records_close(found: dict, golden: dict, tolerances: dict, kind: str) -> None:
    """
    ``found`` agrees with ``golden`` as the golden promises (see the module's docstring).

    Non-float values (stamps, counters, integers, flags, names) are equal exactly; float
    arrays have the golden's shape, NaN where it has NaN, and differ by at most their
    recorded tolerance.
    """
    assert sorted(found) == sorted(golden), (sorted(set(found) ^ set(golden)))
    for key, expected in golden.items():
        value = found[key]
        if not _floats(expected):
            if isinstance(expected, np.ndarray):
                value = np.asarray(value)
                assert value.shape == expected.shape, key
                if expected.dtype.kind == 'U':
                    assert str(value) == str(expected), key
                else:
                    assert value.dtype == expected.dtype, key
                    assert value.tobytes() == expected.tobytes(), key
            else:
                assert value == expected, (key, value, expected)
            continue
        assert key in tolerances, (
            f'{key}: no tolerance recorded; run python test/golden_support.py')
        value = np.asarray(value, dtype=float)
        assert value.shape == expected.shape, (key, value.shape, expected.shape)
        finite = np.isfinite(expected)
        # NaN and infinities are where they were, and equal (an infinite condition number).
        assert np.array_equal(value[~finite], expected[~finite], equal_nan=True) and np.all(
            np.isfinite(value[finite])), f'{key}: a NaN or an infinity moved'
        allowed = np.asarray(tolerances[key], dtype=float)
        with np.errstate(invalid='ignore'):
            off = np.where(finite, np.abs(value - expected), 0.0)
        if np.all(off <= allowed):
            continue
        worst = np.unravel_index(np.argmax(off - np.broadcast_to(allowed, off.shape)),
                                 off.shape)
        raise AssertionError(
            f'{key}{[int(i) for i in worst]}: {float(value[worst])!r} against the golden '
            f'{float(expected[worst])!r}, '
            f'off by {off[worst]:.3g} where {np.broadcast_to(allowed, off.shape)[worst]:.3g} '
            f'is allowed')


@functools.lru_cache(maxsize=None)
def _tolerance_table() -> dict:
    return json.loads(TOLERANCE_FILE.read_text())


def golden_tolerances(kind: str, name: str) -> dict:
    """Return the recorded tolerances of one golden (``kind``: design, replay, closed_loop)."""
    return _tolerance_table().get(f'{kind}/{name}', {})


def golden_file(kind: str, name: str) -> Path:
    """Return the path of one golden's record."""
    suffix = '.json' if kind == 'design' else '.npz'
    return GOLDEN_DIR / kind / name.replace('.yaml', suffix)


def load_golden(kind: str, name: str) -> dict:
    """Load one golden's record (see :func:`record_of`)."""
    path = golden_file(kind, name)
    return record_of(kind, json.loads(path.read_text()) if kind == 'design'
                     else load_npz(path))


def assert_matches_golden(kind: str, name: str, output) -> None:
    """``output`` (a design report or a record) agrees with its golden as promised."""
    assert_records_close(record_of(kind, output), load_golden(kind, name),
                         golden_tolerances(kind, name), kind)


@functools.lru_cache(maxsize=None)
def pair_record(name: str) -> dict:
    """Return the lockstep closed loop of the observer and state_feedback pair, run once."""
    return closed_loop_record(name)


def replay_record(name: str, path=None) -> dict:
    """
    Replay a config's golden bag; return the estimates, innovations and counters.

    ``path``: the parameter file to read instead of the config's own (a perturbed copy).
    """
    from observer_ros.bags.replay import replay_bag

    result = replay_bag(GOLDEN_DIR / 'bags' / name.replace('.yaml', ''),
                        str(path or config_path(name)))
    record = {'stamps': result.stamps_ns, 'estimates': result.estimates,
              'innovations': result.innovations,
              'counters': np.array(json.dumps(result.counters, sort_keys=True))}
    for key in ('covariances', 'innovation_covariances', 'nis'):
        value = getattr(result, key)
        if value is not None:
            record[key] = value
    return record


def _write_config(name: str) -> None:
    path = config_path(name)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': EXTRA_CONFIGS[name]}}))


def _message(kind: str, field: str, names, stamp_ns: int, values):
    """Return a rosbags message of ``kind`` carrying ``values`` (in ``field`` of a JointState)."""
    if kind == 'joint_state':
        return joint_state(stamp_ns, names, **{'position': (), field: values})
    return float64_array(values)


def write_replay_bag(name: str, directory: Path = GOLDEN_DIR / 'bags') -> None:
    """Simulate a config's plant open loop with random inputs; write ``y`` and ``u``."""
    from observer_ros.config import load_parameter_file, validate_parameters
    from observer_ros.core.simulation import PlantSimulator

    system = validate_parameters(load_parameter_file(str(config_path(name))))
    plant = system.plant
    simulator = PlantSimulator(system.model, plant.initial_state, plant.process_noise,
                               plant.measurement_noise, plant.seed, plant.input_limits,
                               plant.disturbance, plant.disturbance_time,
                               input_offset=plant.input_offset)
    params = system.parameters
    model = system.model
    rng = np.random.default_rng(20261201)
    path = directory / name.replace('.yaml', '')
    if path.exists():
        raise FileExistsError(path)
    start_ns = 1_000_000_000
    period_ns = plant.period_ns
    with Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        y_kind, u_kind = params['topics.y.type'], params['topics.u.type']
        y_topic = writer.add_connection('/y', _MESSAGE_TYPES[y_kind], typestore=TYPESTORE)
        u_topic = None
        if model.n_inputs:
            u_topic = writer.add_connection('/u', _MESSAGE_TYPES[u_kind], typestore=TYPESTORE)
        for index in range(REPLAY_SAMPLES):
            stamp = start_ns + index * period_ns
            u = rng.uniform(-1.0, 1.0, size=model.n_inputs)
            if u_topic is not None:
                message = _message(u_kind, params['topics.u.field'], model.input_names,
                                   stamp, u)
                writer.write(u_topic, stamp - 1000, serialize(message))
            y = simulator.measure()
            message = _message(y_kind, params['topics.y.field'], model.output_names, stamp, y)
            writer.write(y_topic, stamp, serialize(message))
            simulator.step(u, period_ns / 1e9)


def save_npz(path: Path, record: dict) -> None:
    """Write a record (uncompressed: the bytes of every array are the golden)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez(path, **record)


def load_npz(path: Path) -> dict:
    """Read a record written by :func:`save_npz`."""
    with np.load(path) as data:
        return {key: data[key] for key in data.files}


def perturbed_config(name: str, seed: int, directory: Path) -> Path:
    """
    Write a copy of a config whose model matrices are perturbed by one unit roundoff.

    Every entry of ``A``, ``B``, ``C`` and ``D`` is multiplied by ``1 + EPS`` or ``1 - EPS``
    (random signs, seeded): zeros and the structure stay, each value moves by an ulp or two.
    """
    data = yaml.safe_load(config_path(name).read_text())
    rng = np.random.default_rng(seed)
    for node in data.values():
        model = node.get('ros__parameters', {}).get('model', {})
        for key in PERTURBED_MATRICES:
            values = model.get(key)
            if isinstance(values, list) and values:
                signs = rng.choice((-1.0, 1.0), size=len(values)).tolist()
                model[key] = [float(v) * (1.0 + EPS * sign) for v, sign in zip(values, signs)]
    path = directory / f'{seed}_{name}'
    path.write_text(yaml.safe_dump(data))
    return path


def golden_output(kind: str, name: str, script: str, path=None):
    """Compute one golden's output as the user's entry point gives it."""
    if kind == 'design':
        return design_json(name, script, path)
    if kind == 'replay':
        return replay_record(name, path)
    return closed_loop_record(name, path=path)


def measure_tolerances(kind: str, name: str, script: str, output) -> dict:
    """
    Measure the tolerances of one golden from its conditioning.

    The golden is computed again from :data:`PERTURBATIONS` copies of its config whose model
    matrices are perturbed by one unit roundoff (:func:`perturbed_config`); how far each value
    moves measures how far rounding can move it (:func:`tolerances_of`).
    """
    with tempfile.TemporaryDirectory() as directory:
        runs = [record_of(kind, golden_output(kind, name, script,
                                              perturbed_config(name, seed, Path(directory))))
                for seed in range(PERTURBATIONS)]
    return tolerances_of(kind, record_of(kind, output), runs)


def describe_change(kind: str, name: str, output) -> list:
    """Lines saying what a new record changes against the committed golden."""
    label = f'{kind}/{name}'
    path = golden_file(kind, name)
    if not path.exists():
        return [f'{label}: new']
    old, new = load_golden(kind, name), record_of(kind, output)
    lines = [f'{label} {key}: removed' for key in sorted(set(old) - set(new))]
    lines += [f'{label} {key}: added' for key in sorted(set(new) - set(old))]
    for key in sorted(set(old) & set(new)):
        before, after = old[key], new[key]
        if _floats(before) and _floats(after) and before.shape == after.shape:
            if before.tobytes() == after.tobytes():
                continue
            with np.errstate(invalid='ignore'):
                off = np.abs(after - before)
            moved = int(np.sum(~(off == 0) & ~(np.isnan(before) & np.isnan(after))))
            largest = float(np.nanmax(np.abs(before))) if before.size else 0.0
            worst = float(np.nanmax(off)) if moved else 0.0
            lines.append(f'{label} {key}: {moved} of {before.size} values moved, by up to '
                         f'{worst:.3g} ({worst / (EPS * largest) if largest else 0:.0f} ulp '
                         f'of the largest value)')
        elif isinstance(before, np.ndarray) or isinstance(after, np.ndarray):
            if (np.shape(before) != np.shape(after)
                    or np.asarray(before).tobytes() != np.asarray(after).tobytes()):
                lines.append(f'{label} {key}: changed')
        elif before != after:
            lines.append(f'{label} {key}: {str(before)[:60]} -> {str(after)[:60]}')
    return lines


def _save(kind: str, name: str, output) -> None:
    path = golden_file(kind, name)
    if kind == 'design':
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(output, indent=1, sort_keys=True) + '\n')
    else:
        save_npz(path, output)


def goldens() -> list:
    """``(kind, name)`` of every golden, in the order they are recorded."""
    return ([('design', name) for name in SHIPPED_CONFIGS]
            + [('replay', name) for name in replay_cases()]
            + [('closed_loop', name) for name in CLOSED_LOOP_CONFIGS])


def main(argv=None) -> int:
    """Record the golden outputs and their tolerances anew; print what changed."""
    parser = argparse.ArgumentParser(
        prog='python test/golden_support.py',
        description='Record the golden outputs and their tolerances anew and print, leaf by '
                    'leaf, what changed against the committed ones (for the commit message).')
    parser.add_argument('--only', choices=('design', 'replay', 'closed_loop'),
                        action='append', help='record only these kinds (repeatable)')
    parser.add_argument('--new-bags', action='store_true',
                        help='write the replay bags anew too (they are inputs: normally kept)')
    args = parser.parse_args(argv)
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from conftest import console_script

    script = console_script('design_observer')
    for name in EXTRA_CONFIGS:
        _write_config(name)
    table = json.loads(TOLERANCE_FILE.read_text()) if TOLERANCE_FILE.exists() else {}
    changes = []
    for kind, name in goldens():
        if args.only and kind not in args.only:
            continue
        if kind == 'replay':
            bag = GOLDEN_DIR / 'bags' / name.replace('.yaml', '')
            if args.new_bags and bag.exists():
                import shutil
                shutil.rmtree(bag)
            if not bag.exists():
                write_replay_bag(name)
        output = golden_output(kind, name, script)
        changes += describe_change(kind, name, output)
        _save(kind, name, output)
        table[f'{kind}/{name}'] = measure_tolerances(kind, name, script, output)
        print(f'recorded {kind}/{name}', file=sys.stderr)
    TOLERANCE_FILE.write_text(json.dumps(table, indent=1, sort_keys=True) + '\n')
    print('\n'.join(changes) if changes else 'no golden record changed')
    return 0


if __name__ == '__main__':
    sys.exit(main())
