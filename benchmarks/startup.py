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
How long a node takes from the start of its process until it is ready.

``python -m benchmarks.startup [--runs N] [--nodes NAME [NAME ...]]`` starts each node, as
``ros2 run`` does (its ``main`` in a fresh interpreter, a shipped parameter file), ``N``
times (default 5), and notes on one monotonic clock, in seconds after ``Popen``:

- *imported*: the node's module imported (``python -X importtime``'s total is not used:
  the child prints nothing; this is the same import timed in a child of its own),
- *ready*: the node's first subscription (``y``, ``x_hat`` or ``u_cmd``) seen in the ROS
  graph from this process, that is parameters validated, the design made, the
  subscriptions created and discovered.

Printed per node: the median and the worst of the runs, with the load average and the CPU
steal over the runs, since start-up is CPU-bound and slows with the load. The goal (issue
29) is ready within 1 s on a quiet machine.

``--discovery profile`` (the default) runs the probe and the nodes with the shipped Fast DDS
profile (``config/fastdds_discovery.xml``, as the test suite does); ``--discovery defaults``
with Fast DDS's own settings, where a newcomer that misses its peers' first answers is
found at their next periodic announcement, up to 3 s later (``benchmarks.discovery``): about
one start in seven measured so, which is DDS's delay and not the node's.
"""

import argparse
import os
import statistics
import subprocess
import sys
import time
import uuid

from benchmarks.common import CONFIG_DIR
from benchmarks.discovery import PROFILE

#: Node -> (module, parameter file, the topic it subscribes first).
NODES = {
    'observer': ('observer_ros.nodes.observer', 'seed003_full_order.yaml', 'y'),
    'observer (kalman)': ('observer_ros.nodes.observer', 'kalman_noisy.yaml', 'y'),
    'state_feedback': ('observer_ros.nodes.state_feedback', 'seed003_full_order.yaml',
                       'x_hat'),
    'observer_controller': ('observer_ros.nodes.observer_controller',
                            'seed003_full_order.yaml', 'y'),
    'plant_simulator': ('observer_ros.nodes.plant_simulator', 'seed003_full_order.yaml',
                        'u_cmd'),
}

#: A node that is not ready after this many seconds counts as failed.
TIMEOUT = 30.0

#: The goal: ready within this many seconds on a quiet machine.
GOAL = 1.0

#: A node started as its console script does: the one main, given the executable's name.
MAIN = 'import sys; from observer_ros.nodes.main import main; sys.exit(main({executable!r}))'
IMPORT = 'import time; t = time.perf_counter(); import {module}; print(time.perf_counter() - t)'


def cpu_times() -> tuple:
    """Return (total, steal) jiffies of all CPUs from /proc/stat, or (0, 0) elsewhere."""
    try:
        with open('/proc/stat', encoding='ascii') as stat:
            fields = [int(value) for value in stat.readline().split()[1:]]
    except OSError:
        return 0, 0
    return sum(fields), (fields[7] if len(fields) > 7 else 0)


def import_seconds(module: str) -> float:
    """Seconds to import ``module`` in a fresh interpreter (its own start not counted)."""
    result = subprocess.run([sys.executable, '-c', IMPORT.format(module=module)],
                            capture_output=True, text=True, check=True)
    return float(result.stdout.split()[-1])


def ready_seconds(probe, module: str, parameters: str, topic: str) -> float:
    """Start the node of ``module`` in a fresh process; seconds until ``topic`` is subscribed."""
    executable = module.rsplit('.', 1)[-1]
    namespace = f'/startup_{uuid.uuid4().hex[:8]}'
    name = f'{namespace}/{topic}'
    started = time.monotonic()
    process = subprocess.Popen(
        [sys.executable, '-c', MAIN.format(executable=executable), '--ros-args', '--params-file',
         str(CONFIG_DIR / parameters), '-r', f'__ns:={namespace}'],
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    try:
        while probe.count_subscribers(name) == 0:
            if process.poll() is not None:
                raise RuntimeError(f'{module} exited with {process.returncode}: '
                                   f'{process.stderr.read()[-2000:]}')
            if time.monotonic() - started > TIMEOUT:
                raise RuntimeError(f'{module}: no subscription on {name} after {TIMEOUT} s')
            time.sleep(0.002)
        return time.monotonic() - started
    finally:
        process.terminate()
        try:
            process.communicate(timeout=10)
        except subprocess.TimeoutExpired:
            process.kill()
            process.communicate()


def main(args=None) -> int:
    """Measure and print the time to ready of each node."""
    parser = argparse.ArgumentParser(prog='benchmarks.startup',
                                     description=__doc__.strip().splitlines()[0])
    parser.add_argument('--runs', type=int, default=5, metavar='N',
                        help='starts per node (default 5)')
    parser.add_argument('--nodes', nargs='+', choices=sorted(NODES), default=list(NODES),
                        metavar='NAME', help=f'which nodes (default all: {", ".join(NODES)})')
    parser.add_argument('--discovery', choices=('profile', 'defaults'), default='profile',
                        help=f'Fast DDS discovery: config/{PROFILE.name} (default) or Fast '
                             "DDS's defaults (a periodic announcement every 3 s)")
    options = parser.parse_args(args)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    if options.discovery == 'profile':  # read when the first participant is made
        os.environ['FASTRTPS_DEFAULT_PROFILES_FILE'] = str(PROFILE)
    else:
        os.environ.pop('FASTRTPS_DEFAULT_PROFILES_FILE', None)
    import rclpy
    rclpy.init(args=[])
    probe = rclpy.create_node('startup_probe')
    load_before, cpu_before = os.getloadavg()[0], cpu_times()
    rows = []
    try:
        for label in options.nodes:
            module, parameters, topic = NODES[label]
            imports = [import_seconds(module) for _ in range(options.runs)]
            ready = [ready_seconds(probe, module, parameters, topic)
                     for _ in range(options.runs)]
            rows.append((label, parameters, imports, ready))
    finally:
        probe.destroy_node()
        rclpy.try_shutdown()
    load_after, cpu_after = os.getloadavg()[0], cpu_times()
    total = cpu_after[0] - cpu_before[0]
    steal = 100.0 * (cpu_after[1] - cpu_before[1]) / total if total else 0.0
    print(f'load average (1 min) {load_before:.2f} before, {load_after:.2f} after; steal '
          f'{steal:.1f} %; {os.cpu_count()} CPUs; {options.runs} run(s) per node; discovery: '
          + (f'config/{PROFILE.name}' if options.discovery == 'profile' else
             'Fast DDS defaults') + f'; goal: ready within {GOAL:g} s on a quiet machine')
    print('| node | parameters | import p50 (s) | ready p50 (s) | ready worst (s) |')
    print('|---|---|---|---|---|')
    for label, parameters, imports, ready in rows:
        print(f'| {label} | {parameters} | {statistics.median(imports):.2f} | '
              f'{statistics.median(ready):.2f} | {max(ready):.2f} |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
