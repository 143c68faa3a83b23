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
Many bags: wall time of ``tune_kalman`` and ``replay`` against the number of workers.

``python -m benchmarks.bag_workers [--bags 8] [--samples 50000] [--workers 1 2 4] [--dask]
[--smoke]`` writes ``--bags`` simulated recordings (a two-output plant with known noises) to
a temporary folder, then times ``tune_kalman FOLDER PARAMS`` and ``replay FOLDER PARAMS``
with each worker count (local processes), and with ``--dask`` on a local Dask cluster of two
worker processes bound to 127.0.0.1. It prints one table; the tuned ``Q`` and ``R`` of
every run are checked equal (the pooling does not depend on where the bags ran).
"""

import argparse
import contextlib
import io
from pathlib import Path
import tempfile
import time

import numpy as np
import yaml

from observer_ros.bags.writing import TopicToWrite, write_bag
from observer_ros.tools.replay import main as replay_main
from observer_ros.tools.tune_kalman import main as tune_main

A = np.array([[0.9, 0.1], [-0.1, 0.8]])
B = np.array([[0.0], [0.1]])
C = np.array([[1.0, 0.5], [0.0, 1.0]])
Q = np.array([[0.02, -0.008], [-0.008, 0.03]])
R = np.array([[0.01, 0.006], [0.006, 0.02]])
PERIOD_NS = 100_000_000


def write_bags(folder: Path, bags: int, samples: int) -> Path:
    """Write ``bags`` recordings of ``samples`` each; return the parameter file (10x off)."""
    for index in range(bags):
        rng = np.random.default_rng(index)
        u = rng.uniform(-1, 1, (samples, 1))
        w = rng.standard_normal((samples, 2)) @ np.linalg.cholesky(Q).T
        v = rng.standard_normal((samples, 2)) @ np.linalg.cholesky(R).T
        x, state = np.empty((samples, 2)), np.zeros(2)
        drive = u @ B.T + w
        for k in range(samples):
            x[k] = state
            state = A @ state + drive[k]
        stamps = 10**18 + PERIOD_NS * np.arange(samples, dtype=np.int64)
        write_bag(folder / f'run{index:02d}', [
            TopicToWrite('/u', 'joint_state', 'position', ['u1'], stamps, stamps - 1000, u),
            TopicToWrite('/y', 'joint_state', 'position', ['s1', 's2'], stamps, stamps,
                         x @ C.T + v)])
    params = folder.parent / 'params.yaml'
    section = {'model': {'A': A.ravel().tolist(), 'B': B.ravel().tolist(),
                         'C': C.ravel().tolist(), 'dt': PERIOD_NS / 1e9,
                         'output_names': ['s1', 's2'], 'input_names': ['u1']},
               'observer': {'type': 'kalman', 'process_noise': (10 * Q).ravel().tolist(),
                            'measurement_noise': (R / 10).ravel().tolist()}}
    params.write_text(yaml.safe_dump({'/**': {'ros__parameters': section}}))
    return params


def timed(main, args) -> tuple:
    """Run a tool quietly; return ``(seconds, printed text)``."""
    started = time.perf_counter()
    with contextlib.redirect_stdout(io.StringIO()) as out:
        code = main(args)
    if code != 0:
        raise RuntimeError(f'{args}: exit status {code}')
    return time.perf_counter() - started, out.getvalue()


def tuned(text: str) -> str:
    """Return the tuned Q and R as printed."""
    return text.split('tuned Q')[1].split('ALS system')[0]


def main(args=None) -> int:
    """Print the wall times."""
    parser = argparse.ArgumentParser(prog='benchmarks.bag_workers')
    parser.add_argument('--bags', type=int, default=8)
    parser.add_argument('--samples', type=int, default=50_000)
    parser.add_argument('--workers', type=int, nargs='+', default=[1, 2, 4])
    parser.add_argument('--dask', action='store_true', help='also on a local Dask cluster')
    parser.add_argument('--smoke', action='store_true', help='2 bags of 2000 samples')
    options = parser.parse_args(args)
    if options.smoke:
        options.bags, options.samples, options.workers = 2, 2000, [1, 2]
    with tempfile.TemporaryDirectory() as scratch:
        folder = Path(scratch) / 'bags'
        started = time.perf_counter()
        params = str(write_bags(folder, options.bags, options.samples))
        print(f'{options.bags} bags of {options.samples} samples (two outputs) written in '
              f'{time.perf_counter() - started:.1f} s')
        rows, estimates = [], set()
        for workers in options.workers:
            tune, text = timed(tune_main, [str(folder), params, '--process-structure', 'full',
                                           '--workers', str(workers)])
            estimates.add(tuned(text))
            replay, _ = timed(replay_main, [str(folder), params, '--workers', str(workers)])
            rows.append((f'{workers} local', tune, replay))
        if options.dask:
            from distributed import LocalCluster
            with LocalCluster(n_workers=2, threads_per_worker=1, host='127.0.0.1',
                              dashboard_address=None) as cluster:
                address = cluster.scheduler_address
                tune, text = timed(tune_main, [str(folder), params, '--process-structure',
                                               'full', '--dask', address])
                estimates.add(tuned(text))
                replay, _ = timed(replay_main, [str(folder), params, '--dask', address])
                rows.append(('Dask, 2 processes', tune, replay))
    base_tune, base_replay = rows[0][1], rows[0][2]
    print('| workers | tune_kalman (3 passes) s | speed-up | replay s | speed-up |')
    print('| --- | --- | --- | --- | --- |')
    for name, tune, replay in rows:
        print(f'| {name} | {tune:.2f} | {base_tune / tune:.2f} | {replay:.2f} | '
              f'{base_replay / replay:.2f} |')
    print(f'tuned Q and R equal across runs: {len(estimates) == 1}')
    return 0 if len(estimates) == 1 else 1


if __name__ == '__main__':
    raise SystemExit(main())
