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
Offline replay throughput: samples per second of ``replay_bag`` on a fourth-order model.

``python benchmarks/replay_throughput.py [SAMPLES] [--storage mcap|sqlite3]`` writes a bag
of the seed 001 fourth-order plant (``y`` and ``u`` as JointState at 100 Hz), replays it
through the observer node's code path, and prints the measured rates: end to end (reading,
decoding, estimating) and with the ``x_hat`` bag written too.
"""

import argparse
from pathlib import Path
import sys
import tempfile
import time

import numpy as np

from observer_ros.bags.replay import replay_bag, write_replay
from observer_ros.bags.storage import TopicToWrite, write_bag
from observer_ros.core.config import load_parameter_file, validate_parameters

CONFIG = Path(__file__).resolve().parents[1] / 'config' / 'seed001_fourth_order.yaml'


def main() -> int:
    """Measure and print the replay throughput."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('samples', type=int, nargs='?', default=1_000_000)
    parser.add_argument('--storage', default='mcap', choices=('mcap', 'sqlite3'))
    options = parser.parse_args()
    system = validate_parameters(load_parameter_file(str(CONFIG)))
    rng = np.random.default_rng(0)
    stamps = np.arange(1, options.samples + 1, dtype=np.int64) * 10_000_000
    with tempfile.TemporaryDirectory() as scratch:
        bag = Path(scratch) / 'input'
        write_bag(bag, [
            TopicToWrite('/y', 'joint_state', 'position', ['y1'], stamps, stamps,
                         rng.standard_normal((options.samples, 1))),
            TopicToWrite('/u', 'joint_state', 'position', ['u1'], stamps, stamps,
                         rng.standard_normal((options.samples, 1)))], options.storage)
        started = time.perf_counter()
        result = replay_bag(bag, system)
        replayed = time.perf_counter() - started
        write_replay(result, str(Path(scratch) / 'output'), storage=options.storage,
                     innovation=False)
        total = time.perf_counter() - started
    assert len(result.estimates) == options.samples
    print(f'{options.samples} samples, n = 4, {options.storage}: replay {replayed:.2f} s '
          f'({options.samples / replayed:,.0f} samples/s); with x_hat written '
          f'{total:.2f} s ({options.samples / total:,.0f} samples/s)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
