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
4. ROS latency: a ``y`` publish to its ``x_hat`` (and to its ``u_cmd``), against relays.

The observer node, two raw relays (subscribe ``y`` serialized, publish the same bytes: the
floor of rclpy's transport; one of them also subscribes ``u`` serialized and ignores it) and
a plain relay (subscribe ``y``, copy the JointState, publish it, as an ordinary rclpy node
does; it also takes ``u``) run as separate processes on the same executor type with the
package's QoS. A probe in this process waits until every endpoint is matched
both ways and each node has answered once, then pings them in turn, one message in flight
at a time, and takes the time from its publish to the answer with the same stamp. As in a
closed loop, the probe sends the command ``u`` stamped like ``y`` after the estimate arrived
(the estimate for the next ``y`` needs it), outside the timed window; every ping starts
after the same idle gap, so the observer has taken that ``u`` before its next ``y``. The
observer-controller (the same observer and a state feedback, ``controller.input: command``,
its estimate topics remapped away) answers each ``y`` with ``u_cmd``; it takes no ``u``.

Each node is compared with the raw relay that receives the same traffic (:data:`FLOOR`): the
observer (a ``y`` and a ``u`` per round) with the raw relay that takes ``u`` too, the
controller (a ``y`` per round) with the one that takes ``y`` only. The ratios against the
``y``-only relay, the accounting before issue 29's second round, are reported beside them.

Beside the round trips, the CPU time each node's process spent per round (every thread,
``/proc/<pid>/task/*/schedstat``, over the timed rounds: in place, cold, as a loop meets
it) and, in this process, the thread CPU time of one ``y`` (and its ``u``) through the
node's subscription callbacks, back to back (a tight loop, hot caches) and with 1 ms of
other work between messages (cold, without DDS).
"""

import os
from pathlib import Path
import signal
import struct
import subprocess
import sys
import time

import numpy as np
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

from benchmarks.common import CONFIG_DIR, pyplot, REPOSITORY, RUN_LENGTH, Section
from observer_ros.core.units import NANOSECONDS
from observer_ros.ros.executors import EXECUTORS
from observer_ros.ros.messages import ns_to_stamp
from observer_ros.ros.qos import publisher_qos, subscription_qos

CONFIG = CONFIG_DIR / 'seed001_fourth_order.yaml'

#: Answer topic -> (request topic, node kind, remappings), in report order.
TARGETS = {
    'raw_relay': ('raw_relay_in', 'raw_relay', ('-r', 'y:=raw_relay_in', '-r',
                                                'relay:=raw_relay')),
    'raw_relay_u': ('raw_relay_u_in', 'raw_relay_u', ('-r', 'y:=raw_relay_u_in', '-r',
                                                      'relay:=raw_relay_u')),
    'relay': ('relay_in', 'relay', ('-r', 'y:=relay_in')),
    'x_hat': ('y', 'observer', ()),
    'u_cmd': ('controller_in', 'observer_controller', (
        '-r', 'y:=controller_in', '-r', 'x_hat:=controller_x_hat', '-r',
        'innovation:=controller_innovation', '-p', 'controller.input:=command', '-p',
        "feedback.poles:=['-2+1j', '-2-1j', '-3', '-4']")),
}
LABELS = {'raw_relay': 'raw relay', 'raw_relay_u': 'raw relay + u', 'relay': 'plain relay',
          'x_hat': 'observer', 'u_cmd': 'controller'}

#: Messages a node receives per round: its request, and the probe's ``u`` if it subscribes it
#: (the probe publishes one ``u`` per round, after the observer's answer).
MESSAGES = {'raw_relay': 1, 'raw_relay_u': 2, 'relay': 2, 'x_hat': 2, 'u_cmd': 1}

#: The package's nodes against the raw relay: answer topic -> label of the ratios.
MEASURED = {'x_hat': 'observer', 'u_cmd': 'controller'}

#: The raw relay each node of :data:`MEASURED` is held against: the one with the same traffic.
FLOOR = {'x_hat': 'raw_relay_u', 'u_cmd': 'raw_relay'}

#: The accounting before: every node against the ``y``-only raw relay (reported beside).
OLD_FLOOR = 'raw_relay'

#: Idle time before every ping (s), and how long a ping waits for its answer (s).
GAP = 0.001
PING_TIMEOUT = 0.2

#: Goals against the raw relay on the default executor: p50 and p99 ratios.
GOAL_P50, GOAL_P99 = 1.05, 1.2

#: Stamps step by this from ping to ping of one node (a steady 100 Hz for the observer).
STEP_NS = 10_000_000

#: Goals of the CPU time per message in place against the raw relay's (issue 29).
GOAL_CPU = {'x_hat': 2.0, 'u_cmd': 2.5}

#: In-process CPU per message: node kind -> the parameters added to the seed's.
IN_PROCESS = {'x_hat': ('observer', ()),
              'u_cmd': ('observer_controller', TARGETS['u_cmd'][2][-4:])}

STAMP = struct.Struct('<iI')


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
    """Publish ``u`` and the requests; note when the stamped answers arrive."""

    def __init__(self, context) -> None:
        super().__init__('latency_probe', context=context)
        topics = ['u', *(request for request, _, _ in TARGETS.values())]
        self.publishers_ = {topic: self.create_publisher(JointState, topic, publisher_qos())
                            for topic in topics}
        self.arrivals = {}
        for topic in TARGETS:
            self.create_subscription(JointState, topic,
                                     lambda raw, t=topic: self._on_answer(t, raw),
                                     subscription_qos(), raw=True)

    def _on_answer(self, topic: str, raw: bytes) -> None:
        arrived = time.perf_counter_ns()
        seconds, nanoseconds = STAMP.unpack_from(raw, 4)  # after the CDR header
        self.arrivals[(topic, seconds * NANOSECONDS + nanoseconds)] = arrived

    def matched(self) -> bool:
        """Whether every publisher and subscription of the probe is matched."""
        return (all(p.get_subscription_count() > 0 for p in self.publishers_.values())
                and all(s.get_publisher_count() > 0 for s in self.subscriptions))

    @staticmethod
    def request(name: str, stamp: int, value: float) -> bytes:
        """Return a serialized JointState (serialized before the clock starts)."""
        message = JointState(name=[name], position=[value])
        ns_to_stamp(message.header.stamp, stamp)
        return serialize_message(message)

    def ping(self, executor, target: str, stamp: int) -> float:
        """Round trip to ``target`` (an answer topic), in microseconds (nan: lost)."""
        # The controller takes its commands as inputs: a measurement that no plant answers
        # drives its estimate beyond the limit now and then (dropped, the estimator restarts:
        # a lost ping). A constant measurement costs the same and keeps it bounded.
        value = 0.0 if target == 'u_cmd' else 0.1 * (stamp // STEP_NS % 7)
        request = self.request('y1', stamp, value)
        publisher = self.publishers_[TARGETS[target][0]]
        idle_until = time.monotonic() + GAP
        while time.monotonic() < idle_until:
            executor.spin_once(timeout_sec=GAP / 4)
        self.arrivals.clear()
        key = (target, stamp)
        sent = time.perf_counter_ns()
        publisher.publish(request)
        deadline = time.monotonic() + PING_TIMEOUT
        while key not in self.arrivals and time.monotonic() < deadline:
            executor.spin_once(timeout_sec=0.001)
        arrived = self.arrivals.pop(key, None)
        if target == 'x_hat':  # the command computed from this estimate, as in a loop
            self.publishers_['u'].publish(self.request('u1', stamp, 0.0))
        return float('nan') if arrived is None else (arrived - sent) / 1e3


def process_cpu_ns(pid: int) -> int:
    """CPU time (ns) every thread of process ``pid`` ran so far; 0 without ``/proc``."""
    total = 0
    try:
        tasks = list(Path(f'/proc/{pid}/task').iterdir())
    except OSError:
        return 0
    for task in tasks:
        try:
            total += int((task / 'schedstat').read_text().split()[0])
        except (OSError, ValueError, IndexError):
            pass  # a thread that ended meanwhile
    return total


def wait_until_ready(probe: Probe, executor, processes, name: str) -> dict:
    """Spin until every endpoint is matched and every node answered; return the last stamps."""
    deadline = time.monotonic() + 30.0

    def check():
        if time.monotonic() > deadline or any(p.poll() is not None for p in processes):
            raise RuntimeError(f'{name}: the nodes did not come up: ' + ' '.join(
                (p.stderr.read() or b'').decode()[-300:] for p in processes
                if p.poll() is not None))

    while not probe.matched():
        check()
        executor.spin_once(timeout_sec=0.05)
    stamps = {}
    for target in TARGETS:  # matched on the probe's side; an answer proves both sides
        stamps[target] = STEP_NS
        while np.isnan(probe.ping(executor, target, stamps[target])):
            check()
            stamps[target] += STEP_NS
    return stamps


def measure(executor_name: str, rounds: int, warm_up: int) -> tuple:
    """
    Round trips (microseconds) and process CPU per round (microseconds) per answer topic.

    The nodes spin on ``executor_name``; the CPU time is each node's process over the timed
    rounds (its ``y``, its ``u`` for the observer, and what it does idle meanwhile).
    """
    processes = [start(kind, executor_name, *remap) for _, kind, remap in TARGETS.values()]
    context = rclpy.Context()
    rclpy.init(context=context)
    probe = Probe(context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)
    try:
        stamps = wait_until_ready(probe, executor, processes, executor_name)
        latencies = {target: [] for target in TARGETS}
        targets = list(TARGETS)
        cpu_before = {}
        for k in range(rounds + warm_up):
            if k == warm_up:
                cpu_before = {t: process_cpu_ns(p.pid) for t, p in zip(TARGETS, processes)}
            shift = k % len(targets)
            for target in targets[shift:] + targets[:shift]:
                stamps[target] += STEP_NS
                value = probe.ping(executor, target, stamps[target])
                if k >= warm_up:
                    latencies[target].append(value)
        cpu = {t: (process_cpu_ns(p.pid) - cpu_before.get(t, 0)) / rounds / 1e3
               for t, p in zip(TARGETS, processes)}
        return {target: np.array(values) for target, values in latencies.items()}, cpu
    finally:
        executor.remove_node(probe)
        probe.destroy_node()
        executor.shutdown()
        rclpy.try_shutdown(context=context)
        for process in processes:
            stop(process)


def callback_cpu(target: str, count: int, gap: float) -> float:
    """
    Thread CPU time (us) of one message through a node's callbacks, in this process.

    The node of ``target`` (:data:`IN_PROCESS`) is built with the seed's parameters and its
    ``y`` subscription's callback called with serialized bytes, the observer's ``u`` after
    it as the probe sends it; ``gap`` seconds of other work (touching 4 MB) between two
    messages make it cold, 0 is a tight loop. Nothing subscribes its topics.
    """
    from benchmarks.ros_runner import NODES
    kind, extra = IN_PROCESS[target]
    context = rclpy.Context()
    rclpy.init(context=context)
    node = NODES[kind](context=context, cli_args=['--ros-args', '--params-file', str(CONFIG),
                                                  *extra])
    try:
        by_topic = {s.topic_name.rsplit('/', 1)[-1]: s.callback for s in node.subscriptions}
        on_y, on_u = by_topic['y'], by_topic.get('u') if target == 'x_hat' else None
        other = np.zeros(1 << 19)
        spent = []
        for k in range(count):
            stamp = (k + 1) * STEP_NS
            value = 0.0 if target == 'u_cmd' else 0.1 * (k % 7)
            y, u = Probe.request('y1', stamp, value), Probe.request('u1', stamp, 0.0)
            if gap:
                until = time.perf_counter() + gap
                while time.perf_counter() < until:
                    other += 1.0
            started = time.thread_time_ns()
            on_y(y)
            if on_u is not None:
                on_u(u)
            spent.append(time.thread_time_ns() - started)
        return float(np.median(spent[count // 10:])) / 1e3
    finally:
        node.destroy_node()
        rclpy.try_shutdown(context=context)


def percentile(values: np.ndarray, q: float) -> float:
    """``q``-th percentile of the answered round trips."""
    return float(np.nanpercentile(values, q))


def run(smoke: bool, figures) -> Section:
    """Measure and return the section."""
    rounds, warm_up = (10, 5) if smoke else (3000, 50)
    rounds = RUN_LENGTH.get('rounds') or rounds
    section = Section(4, 'ROS latency: y to x_hat and to u_cmd against a raw relay',
                      f'observer (y to x_hat) and observer-controller (y to u_cmd) p50 within '
                      f'{GOAL_P50}x and p99 within {GOAL_P99}x those of the raw relay (the '
                      'floor of rclpy transport) that receives the same messages, same executor '
                      f'and QoS; CPU per round in place at most {GOAL_CPU["x_hat"]}x (observer) '
                      f'and {GOAL_CPU["u_cmd"]}x (controller) that relay\'s')
    measured = {name: measure(name, rounds, warm_up) for name in EXECUTORS}
    results = {name: latencies for name, (latencies, _) in measured.items()}
    cpu = {name: process for name, (_, process) in measured.items()}
    rows, ratios = [], {}

    def ratio(values: dict, target: str, floor: str) -> tuple:
        return tuple(percentile(values[target], q) / percentile(values[floor], q)
                     for q in (50, 99))

    for name, values in results.items():
        ratios[name] = {target: ratio(values, target, FLOOR[target]) for target in MEASURED}
        old = ratio(values, 'x_hat', OLD_FLOOR)
        rows.append([name, *(f'{percentile(values[t], q):.0f}' for t in TARGETS
                             for q in (50, 99)),
                     *(f'{ratios[name][t][i]:.2f}' for t in MEASURED for i in (0, 1)),
                     *(f'{value:.2f}' for value in old),
                     int(sum(np.isnan(v).sum() for v in values.values()))])
    fastest = min(results, key=lambda name: percentile(results[name]['x_hat'], 50))
    section.add(f'{rounds} round trips per node and executor (after {warm_up} warm-up rounds '
                f'and once every endpoint answered), one message in flight, the {len(TARGETS)} '
                f'nodes pinged in rotating order after {GAP * 1e3:g} ms idle each; '
                'fourth-order observer (seed 001; the controller with feedback poles -2+-1j, '
                '-3, -4); each node in its own process, the probe in another. Microseconds, '
                'probe publish to probe callback (both ways through DDS).', '')
    section.table(['executor', *(f'{LABELS[t]} {q}' for t in TARGETS for q in ('p50', 'p99')),
                   *(f'{label} / {LABELS[FLOOR[t]]} {q}' for t, label in MEASURED.items()
                     for q in ('p50', 'p99')),
                   *(f'observer / {LABELS[OLD_FLOOR]} {q} (old)' for q in ('p50', 'p99')),
                   'lost'], rows)
    section.add(f'Fastest executor for the observer: **{fastest}**; the nodes spin '
                f'**{EXECUTORS[0]}** unless given `--executor`. The raw relay republishes the '
                'bytes it receives (no message objects): what is left is rclpy and DDS. Each '
                "round the probe also publishes the command `u` once, after the observer's "
                'answer (outside every timed window), and every node subscribed to `u` receives '
                'it: the observer, the raw relay + u (which ignores it) and the plain relay. So '
                'each node is held against the raw relay that receives the same messages '
                'per round (observer: raw relay + u, two; controller, which takes no `u`: raw '
                'relay, one); the columns marked old hold the observer against the `y`-only '
                'raw relay, the accounting before, so that the goal is seen not to move. The '
                'observer also reads and writes CDR bytes, and on top decodes `y`, runs the '
                'estimator and publishes `x_hat` (`innovation` only while subscribed: not '
                'here). The observer-controller decodes `y`, runs the estimator and the '
                'feedback law and publishes `u_cmd` (its estimate topics only while '
                'subscribed): its row is the latency from a '
                'measurement to the command, which the two nodes pay twice through DDS. The '
                'plain relay builds message objects both ways as an ordinary rclpy node does. '
                'The MultiThreadedExecutor is not offered (see '
                '`observer_ros.ros.executors.EXECUTORS`).', '')
    count = 50 if smoke else 2000
    in_process = {target: (callback_cpu(target, count, 0.0), callback_cpu(target, count, GAP))
                  for target in MEASURED}
    cpu_rows = []
    for name, process in cpu.items():
        cpu_rows.append([name, *(f'{process[t]:.0f}' for t in TARGETS),
                         *(f'{process[t] / process[FLOOR[t]]:.2f}' for t in MEASURED),
                         f'{process["x_hat"] / process[OLD_FLOOR]:.2f}'])
    section.add(f"CPU time per round of each node's process, in place (cold: {GAP * 1e3:g} ms "
                'idle before every ping, the other nodes pinged in between): every thread of '
                'the process over the timed rounds, divided by the rounds. Messages received '
                'per round: ' + ', '.join(f'{LABELS[t]} {count}' for t, count in MESSAGES.items())
                + '. Goals against the raw relay with the same messages: observer at most '
                f'{GOAL_CPU["x_hat"]}x the raw relay + u\'s, controller at most '
                f'{GOAL_CPU["u_cmd"]}x the raw relay\'s; the last column is the old accounting '
                '(observer against the `y`-only raw relay). Microseconds.', '')
    section.table(['executor', *(LABELS[t] for t in TARGETS),
                   *(f'{LABELS[t]} / {LABELS[FLOOR[t]]}' for t in MEASURED),
                   f'observer / {LABELS[OLD_FLOOR]} (old)'], cpu_rows)
    section.add(f"In this process, the thread CPU time of one message through the node's "
                f'subscription callbacks (median of {count}; nothing subscribed to its topics): '
                + '; '.join(f'{LABELS[t]} {hot:.0f} us in a tight loop, {cold:.0f} us with '
                            f'{GAP * 1e3:g} ms of other work between messages'
                            for t, (hot, cold) in in_process.items()) + '.', '')
    process = cpu[EXECUTORS[0]]
    section.met = (all(p50 <= GOAL_P50 and p99 <= GOAL_P99
                       for p50, p99 in ratios[EXECUTORS[0]].values())
                   and all(process[t] <= GOAL_CPU[t] * process[FLOOR[t]] for t in MEASURED))
    plt = pyplot()
    figure, axis = plt.subplots(figsize=(8, 3.5))
    data, labels = [], []
    for name, values in results.items():
        for target in TARGETS:
            data.append(values[target][np.isfinite(values[target])])
            labels.append(f'{LABELS[target]}\n{name}')
    axis.boxplot(data, showfliers=False)
    axis.set_xticks(range(1, len(labels) + 1), labels, fontsize=8)
    axis.set_ylabel('round trip (us)')
    section.figures.append(figures.save(figure, 'ros_latency'))
    return section
