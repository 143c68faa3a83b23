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
Faults in a running three-process loop: a node killed (SIGKILL, as a crash) and restarted.

The console-script processes run in real time; the test listens over DDS. A killed observer
leaves state_feedback without estimates: its safe command must come within the promised
bound and the loop must come back when the observer does. A killed plant leaves a gap in the
stamps: the restarted plant's samples restart the estimator, which converges again.

What the listener receives on one topic comes in the order it was published; arrival times
across topics say nothing about the order on a loaded machine, so the timing is read from
stamps and from what state_feedback measured itself.
"""

import time

import numpy as np
from rclpy.node import Node
from sensor_msgs.msg import JointState

from conftest import CONFIG_DIR
from observer_ros.ros.executors import make_executor
from observer_ros.ros.messages import stamp_to_ns
from ros_support import cpu_wait_ns, logged_since, NodeProcess, ros_context, spin_until

SEED003 = str(CONFIG_DIR / 'seed003_full_order.yaml')
#: A stable plant: on the safe command alone it stays where the loop can take it back however
#: long the observer takes to restart (seed 003's plant grows as e^(3t) and leaves
#: topics.y.limit within about 7 s, as long as a restart can take on a loaded machine).
STABLE = str(CONFIG_DIR / 'seed001_fourth_order_chen.yaml')
SAFE = [0.125]
TIMEOUT = 0.3
#: The watchdog's promise (doc/guarantees.md): the first safe command at most timeout + 10 ms
#: after the last accepted estimate, plus the time the node's process waited for a CPU.
SLACK = 0.010
#: state_feedback's warning when the watchdog fires: how long it waited (steady clock).
WATCHDOG_WARNING = r'^no x_hat for ([0-9.]+) s \(feedback\.timeout = 0\.3 s, steady clock'
TOPICS = ('u_cmd', 'x_hat', 'x_true', 'y')


class Listener:
    """The test's node: records arrival time, stamp and values of the loop's topics."""

    def __init__(self, context) -> None:
        self.node = Node('fault_listener', context=context)
        self.samples = {topic: [] for topic in TOPICS}
        self.subscriptions = {topic: self.node.create_subscription(
            JointState, topic, lambda m, t=topic: self.samples[t].append(
                (time.monotonic(), stamp_to_ns(m.header.stamp), list(m.position))), 1000)
            for topic in TOPICS}
        self.executor = make_executor('single', context)
        self.executor.add_node(self.node)

    def wait(self, predicate, timeout: float) -> bool:
        return spin_until(self.executor, predicate, timeout)

    def since(self, topic: str, moment: float) -> list:
        return [sample for sample in self.samples[topic] if sample[0] > moment]

    def close(self) -> None:
        self.executor.remove_node(self.node)
        self.node.destroy_node()
        self.executor.shutdown()


def start(name: str, config: str = SEED003) -> NodeProcess:
    extra = {'state_feedback': ['-p', f'feedback.timeout:={TIMEOUT}',
                                '-p', f'feedback.safe_command:={SAFE}'],
             'plant_simulator': ['-p', 'plant.lockstep_subscribers:=2',
                                 '-p', 'plant.start_timeout:=0.0',
                                 '-p', 'plant.command_timeout:=5.0']}.get(name, [])
    return NodeProcess(name, '--ros-args', '--params-file', config, *extra)


def running_loop(listener, processes, config: str = SEED003) -> None:
    for name in ('observer', 'state_feedback', 'plant_simulator'):
        processes[name] = start(name, config)
    assert listener.wait(lambda: len(listener.samples['u_cmd']) > 50 and all(
        u != SAFE for _, _, u in listener.samples['u_cmd'][-10:]), 60.0), (
        [p.stop()[2][-500:] for p in processes.values()])


def converged(listener, moment: float, tolerance: float) -> bool:
    """Whether x_hat matches x_true (same stamps) to ``tolerance`` in the last samples."""
    truth = {stamp: values for _, stamp, values in listener.since('x_true', moment)}
    pairs = [(np.array(truth[stamp]), np.array(values))
             for _, stamp, values in listener.since('x_hat', moment) if stamp in truth]
    return len(pairs) > 20 and all(np.linalg.norm(t - e) < tolerance for t, e in pairs[-10:])


def stop_all(processes) -> dict:
    return {name: process.stop() for name, process in processes.items()}


def test_a_killed_observer_gives_the_safe_command_in_time_and_the_loop_recovers():
    with ros_context() as context:
        listener = Listener(context)
        outcomes, killed, cpu_wait = killed_observer(listener)
    for name, (code, _, err) in outcomes.items():
        if name != 'observer':
            assert code == 0, (name, err)
    # In time, as state_feedback measured it on its steady clock, allowing the time its
    # process waited for a CPU from the kill to the safe command.
    waits = [float(waited) for waited, in logged_since(outcomes['state_feedback'][2], killed,
                                                       WATCHDOG_WARNING)]
    assert waits and TIMEOUT <= waits[0] <= TIMEOUT + SLACK + cpu_wait, (waits, cpu_wait)
    # Never early: a safe command comes at least feedback.timeout after the stamp of the
    # estimate behind the command before it (that estimate arrived after its stamp).
    commands = listener.samples['u_cmd']
    outages = [(previous[1], command[1]) for previous, command in zip(commands, commands[1:])
               if command[2] == SAFE and previous[2] != SAFE]
    assert outages and all(safe - estimate >= TIMEOUT * 1e9 for estimate, safe in outages), (
        outages)


def killed_observer(listener) -> tuple:
    """Return the processes' outcomes, the kill's system time, the feedback's CPU wait (s)."""
    processes = {}
    try:
        running_loop(listener, processes, STABLE)
        feedback = processes['state_feedback'].process.pid
        cpu_wait, killed = cpu_wait_ns(feedback), time.time()
        processes['observer'].process.kill()  # a crash: no goodbye
        processes['observer'].stop()
        assert listener.wait(lambda: listener.samples['u_cmd'][-1][2] == SAFE, 10.0)
        cpu_wait = max(0, cpu_wait_ns(feedback) - cpu_wait) / 1e9
        restarted = time.monotonic()
        processes['observer'] = start('observer', STABLE)
        if not listener.wait(lambda: any(u != SAFE for _, _, u in listener.since(
                'u_cmd', restarted + 1.0)), 60.0):
            seen = {topic: len(listener.since(topic, restarted)) for topic in TOPICS}
            tails = {name: processes.pop(name).stop()[2][-1500:]
                     for name in ('observer', 'state_feedback')}
            raise AssertionError(f'no command from the restarted observer within 60 s; '
                                 f'received since the restart: {seen}; {tails}')
        assert listener.wait(lambda: converged(listener, restarted, 1e-3), 30.0)
    finally:
        outcomes = stop_all(processes)
        listener.close()
    return outcomes, killed, cpu_wait


def test_a_killed_and_restarted_plant_restarts_the_estimator_which_converges_again():
    with ros_context() as context:
        outcomes = killed_plant(Listener(context))
    for name, (code, _, err) in outcomes.items():
        if name != 'plant_simulator':
            assert code == 0, (name, err)
    assert 'the estimator restarts from this sample' in outcomes['observer'][2]


def killed_plant(listener) -> dict:
    processes = {}
    try:
        running_loop(listener, processes)
        processes['plant_simulator'].process.kill()
        processes['plant_simulator'].stop()
        killed = time.monotonic()
        assert listener.wait(lambda: listener.samples['u_cmd'][-1][2] == SAFE, 10.0)
        last_stamp = listener.samples['y'][-1][1]
        listener.wait(lambda: False, 1.2)  # longer than observer.max_gap (1 s)
        restarted = time.monotonic()
        processes['plant_simulator'] = start('plant_simulator')
        assert listener.wait(lambda: len(listener.since('x_hat', restarted)) > 50, 60.0)
        assert listener.wait(lambda: converged(listener, restarted, 1e-3), 30.0)
        assert listener.wait(lambda: any(u != SAFE for _, _, u in listener.since(
            'u_cmd', killed + 2.0)), 30.0)
        new_stamps = [stamp for _, stamp, _ in listener.since('x_hat', restarted)]
        assert new_stamps[0] - last_stamp > 10 ** 9 and np.all(np.diff(new_stamps) > 0)
    finally:
        outcomes = stop_all(processes)
        listener.close()
    return outcomes
