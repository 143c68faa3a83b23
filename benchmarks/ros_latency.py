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
4. ROS latency: a ``y`` publish to its ``x_hat``, against a bare relay, per executor.

The observer node and a relay (subscribe ``y``, copy the JointState, publish it) run as
separate processes on the same executor type with the package's QoS. A probe in this
process pings them in turn, one message in flight at a time: ``y`` to the observer, then
``y`` to the relay (remapped), and takes the time until the answer with the same stamp
arrives. As in a closed loop, the probe sends the command ``u`` stamped like ``y`` after the
estimate arrived (the estimate for the next ``y`` needs it), outside the timed window.
"""

import os
import signal
import subprocess
import sys
import time

import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState

from benchmarks.common import CONFIG_DIR, pyplot, REPOSITORY, Section
from observer_ros.ros.messages import ns_to_stamp, stamp_to_ns
from observer_ros.ros.parameters import EXECUTORS, publisher_qos, subscription_qos

CONFIG = CONFIG_DIR / 'seed001_fourth_order.yaml'


def start(kind: str, executor: str, *ros_args: str) -> subprocess.Popen:
    """Start ``benchmarks.ros_runner`` for ``kind`` on ``executor``."""
    return subprocess.Popen(
        [sys.executable, '-m', 'benchmarks.ros_runner', kind, '--executor', executor, '--ros-args',
         '--params-file', str(CONFIG), *ros_args], cwd=REPOSITORY,
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=dict(os.environ))


def stop(process: subprocess.Popen) -> None:
    """Interrupt and reap."""
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
    try:
        process.wait(timeout=10)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


class Probe(Node):
    """Publish ``u``/``y`` and ``relay_in``; note when the stamped answers arrive."""

    def __init__(self, context) -> None:
        super().__init__('latency_probe', context=context)
        self.publishers_ = {topic: self.create_publisher(JointState, topic, publisher_qos())
                            for topic in ('u', 'y', 'relay_in')}
        self.arrivals = {}
        for topic in ('x_hat', 'relay'):
            self.create_subscription(JointState, topic,
                                     lambda m, t=topic: self._on_answer(t, m),
                                     subscription_qos())

    def _on_answer(self, topic: str, message: JointState) -> None:
        self.arrivals[(topic, stamp_to_ns(message.header.stamp))] = time.perf_counter_ns()

    def ready(self) -> bool:
        """Whether both peers are matched both ways."""
        return (all(p.get_subscription_count() > 0 for p in self.publishers_.values())
                and all(s.get_publisher_count() > 0 for s in self.subscriptions))

    def ping(self, executor, target: str, stamp: int) -> float:
        """Round trip to the observer (``x_hat``) or the relay, in microseconds (nan: lost)."""
        message = JointState(name=['y1'], position=[0.1 * (stamp % 7)])
        ns_to_stamp(message.header.stamp, stamp)
        key = (target, stamp)
        sent = time.perf_counter_ns()
        self.publishers_['y' if target == 'x_hat' else 'relay_in'].publish(message)
        deadline = time.monotonic() + 0.2
        while key not in self.arrivals and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.001)
        arrived = self.arrivals.pop(key, None)
        if target == 'x_hat':  # the command computed from this estimate, as in a loop
            command = JointState(name=['u1'], position=[0.0])
            ns_to_stamp(command.header.stamp, stamp)
            self.publishers_['u'].publish(command)
        return float('nan') if arrived is None else (arrived - sent) / 1e3


def measure(executor_name: str, rounds: int) -> dict:
    """Latencies (microseconds) of the observer and the relay on ``executor_name``."""
    processes = [start('observer', executor_name),
                 start('relay', executor_name, '-r', 'y:=relay_in')]
    context = rclpy.Context()
    rclpy.init(context=context)
    probe = Probe(context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)
    try:
        deadline = time.monotonic() + 20.0
        while not probe.ready():
            if time.monotonic() > deadline or any(p.poll() is not None for p in processes):
                raise RuntimeError(f'{executor_name}: the nodes did not come up: ' + ' '.join(
                    (p.stderr.read() or b'').decode()[-300:] for p in processes
                    if p.poll() is not None))
            executor.spin_once(timeout_sec=0.05)
        time.sleep(0.3)
        latencies = {'x_hat': [], 'relay': []}
        for k in range(rounds + 50):
            order = ('x_hat', 'relay') if k % 2 else ('relay', 'x_hat')
            for target in order:
                value = probe.ping(executor, target, (k + 1) * 10_000_000)
                if k >= 50:  # warm-up
                    latencies[target].append(value)
        return {target: np.array(values) for target, values in latencies.items()}
    finally:
        executor.remove_node(probe)
        probe.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown(context=context)
        for process in processes:
            stop(process)


def run(smoke: bool, figures) -> Section:
    """Measure and return the section."""
    rounds = 10 if smoke else 1000
    section = Section(4, 'ROS latency: y to x_hat against a bare relay',
                      "observer p50 within 1.2x the relay's, same executor and QoS")
    results = {name: measure(name, rounds) for name in EXECUTORS}
    rows = []
    for name, values in results.items():
        observer, relay = values['x_hat'], values['relay']
        rows.append([name, f'{np.nanpercentile(observer, 50):.0f}',
                     f'{np.nanpercentile(observer, 99):.0f}',
                     f'{np.nanpercentile(relay, 50):.0f}', f'{np.nanpercentile(relay, 99):.0f}',
                     f'{np.nanpercentile(observer, 50) / np.nanpercentile(relay, 50):.2f}',
                     int(np.isnan(observer).sum() + np.isnan(relay).sum())])
    fastest = min(results, key=lambda name: np.nanpercentile(results[name]['x_hat'], 50))
    section.add(f'{rounds} round trips per node and executor (after 50 warm-up rounds), one '
                'message in flight, fourth-order observer (seed 001), observer and relay in '
                'their own processes, probe in a third. Microseconds, probe publish to probe '
                'callback (both ways through DDS).', '')
    section.table(['executor', 'observer p50', 'observer p99', 'relay p50', 'relay p99',
                   'observer / relay p50', 'lost'], rows)
    section.add(f'Fastest executor for the observer: **{fastest}**; the nodes spin '
                f'**{EXECUTORS[0]}** unless given `--executor`. The observer reads and writes '
                'the CDR bytes (raw subscription, no message objects); the relay builds '
                'message objects as a plain rclpy node does, which is why the observer can '
                'be the faster of the two. The MultiThreadedExecutor is not offered (see '
                '`observer_ros.ros.parameters.EXECUTORS`).', '')
    ratio = {name: np.nanpercentile(v['x_hat'], 50) / np.nanpercentile(v['relay'], 50)
             for name, v in results.items()}
    section.met = bool(ratio[EXECUTORS[0]] <= 1.2)
    plt = pyplot()
    figure, axis = plt.subplots(figsize=(7, 3.5))
    data, labels = [], []
    for name, values in results.items():
        for target, label in (('x_hat', 'observer'), ('relay', 'relay')):
            data.append(values[target][np.isfinite(values[target])])
            labels.append(f'{label}\n{name}')
    axis.boxplot(data, showfliers=False)
    axis.set_xticks(range(1, len(labels) + 1), labels, fontsize=8)
    axis.set_ylabel('round trip (us)')
    section.figures.append(figures.save(figure, 'ros_latency'))
    return section
