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

``python test/golden_support.py`` records them anew (bags included): do that only for a
change of behaviour that is meant, and say why in the commit.
"""

import json
import os
from pathlib import Path
import subprocess
import sys

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


def design_json(name: str, script: str) -> dict:
    """Run ``design_observer <config> --json``; return the parsed object."""
    result = subprocess.run([script, str(config_path(name)), '--json'], capture_output=True,
                            text=True, timeout=120, env=dict(os.environ))
    if result.returncode != 0:
        raise AssertionError(f'design_observer {name}: {result.stderr}')
    return json.loads(result.stdout)


def closed_loop_record(name: str, controller: bool = False, extra=()) -> dict:
    """
    Run the lockstep closed loop of a config; return every recorded topic's arrays.

    ``controller``: the plant and one ``observer_controller`` instead of the pair;
    ``extra``: more parameter overrides.
    """
    from ros_support import overrides, patient_lockstep, ros_context
    from observer_ros.nodes.closed_loop import ClosedLoop
    from observer_ros.ros.executors import make_executor, spin_until
    from observer_ros.ros.recorder import TopicRecorder

    with ros_context('--params-file', str(config_path(name))) as context:
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


def replay_record(name: str) -> dict:
    """Replay a config's golden bag; return the estimates, innovations and counters."""
    from observer_ros.bags.replay import replay_bag

    result = replay_bag(GOLDEN_DIR / 'bags' / name.replace('.yaml', ''), str(config_path(name)))
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


def main() -> int:
    """Record every golden output anew."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from conftest import console_script

    script = console_script('design_observer')
    for name in EXTRA_CONFIGS:
        _write_config(name)
    for name in SHIPPED_CONFIGS:
        target = GOLDEN_DIR / 'design' / name.replace('.yaml', '.json')
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_text(json.dumps(design_json(name, script), indent=1, sort_keys=True)
                          + '\n')
        print('design', name)
    for name in replay_cases():
        write_replay_bag(name)
        save_npz(GOLDEN_DIR / 'replay' / name.replace('.yaml', '.npz'), replay_record(name))
        print('replay', name)
    for name in CLOSED_LOOP_CONFIGS:
        save_npz(GOLDEN_DIR / 'closed_loop' / name.replace('.yaml', '.npz'),
                 closed_loop_record(name))
        print('closed_loop', name)
    return 0


if __name__ == '__main__':
    sys.exit(main())
