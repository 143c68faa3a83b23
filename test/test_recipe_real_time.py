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
The robot recipe's loop in real time: how an unstamped ``u`` is stamped decides its pairing.

``config/robot_joint.yaml``'s ``u`` is a ``Float64MultiArray`` (no stamp). Stamped on its
arrival, the input the plant applies from sample ``k`` (published with ``y_k``) is stamped
``t_k + latency``: the interval after ``t_k`` takes the input of ``t_(k-1)``, and each further
sample period of latency one more. From two periods of latency (20 ms at 100 Hz: a loaded
machine, a stalled process) the observer attributes the input's changes to the load, and the
servo's loop oscillates with growing amplitude. ``observer.unstamped_input:
next_measurement`` stamps it with the next measurement's stamp (the recipe's setting), which
is exact however late both arrive. The loop is simulated here without ROS, with the nodes'
own stream and feedback law, so the timing is exact and the test deterministic; then over
DDS in real time, with a relay that hands the observer ``y`` and ``u`` 25 ms late.
"""

from collections import deque
import time

import numpy as np
import pytest
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from conftest import CONFIG_DIR
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.simulation import PlantSimulator
from observer_ros.nodes.closed_loop import ClosedLoop
from observer_ros.nodes.state_feedback import feedback_law
from observer_ros.ros.executors import make_executor
from ros_support import overrides, ros_context, spin_until

CONFIG = 'robot_joint.yaml'
PERIOD_NS = 10_000_000
#: Samples simulated (8 s at 100 Hz) and the last ones checked for convergence.
SAMPLES, SETTLED_SAMPLES = 800, 100
#: How long after its sample a command reaches the plant, on top of the latency.
COMMAND_HOP_NS = 100_000


def recipe(**overrides):
    """Return the recipe's validated configuration, with parameter overrides."""
    parameters = load_parameter_file(str(CONFIG_DIR / CONFIG))
    parameters.update(overrides)
    return validate_parameters(parameters)


def real_time_loop(step: float, latency_ns: int, unstamped_input: str) -> np.ndarray:
    """
    Run the recipe's plant, observer stream and servo law at 100 Hz; return ``y``.

    The plant publishes the input it applies from sample ``k`` and ``y_k`` together; both
    reach the observer ``latency_ns`` later (the input first, as the plant publishes them);
    the command computed from ``y_k`` reaches the plant :data:`COMMAND_HOP_NS` after that
    and is applied from the next sample on (the plant simulator's rule).
    """
    system = recipe(**{'observer.unstamped_input': unstamped_input})
    plant = system.plant
    simulator = PlantSimulator(system.model, plant.initial_state, plant.process_noise,
                               plant.measurement_noise, plant.seed, plant.input_limits,
                               plant.disturbance, plant.disturbance_time)
    stream, law = system.make_stream(), feedback_law(system)
    reference = np.array([step])
    command, applied, in_flight, outputs = np.zeros(1), None, [], []
    for k in range(SAMPLES):
        stamp = k * PERIOD_NS
        while in_flight and in_flight[0][0] <= stamp:
            command = in_flight.pop(0)[1]
        if k:
            simulator.step(applied, PERIOD_NS / 1e9)
        applied = simulator.saturate(command)
        y = simulator.measure(applied)
        outputs.append(y[0])
        arrival = stamp + latency_ns
        if unstamped_input == 'next_measurement':
            stream.hold_input(applied.copy(), arrival)
        else:  # stamped on arrival, as the observer node does by default
            stream.add_input(arrival, applied.copy(), arrival)
        law.integral.measure(stamp, y)
        for sample in stream.add_measurement(stamp, y.copy(), arrival):
            in_flight.append((arrival + COMMAND_HOP_NS,
                              law.command(sample.estimate, reference, sample.stamp_ns)))
    return np.array(outputs)


@pytest.mark.parametrize('step', [1.0, 10.0, 50.0])
@pytest.mark.parametrize('latency_ms', [0.2, 12.0, 25.0])
def test_next_measurement_stamping_converges_however_late_the_input_arrives(step, latency_ms):
    y = real_time_loop(step, round(latency_ms * 1e6), 'next_measurement')
    assert np.abs(y[-SETTLED_SAMPLES:] - step).max() < 1e-6


@pytest.mark.parametrize('step', [1.0, 10.0, 50.0])
def test_stamping_on_arrival_diverges_from_two_periods_of_latency(step):
    # The cause of the report (issue 27): the same loop with the input stamped on arrival.
    quick = real_time_loop(step, 200_000, 'arrival')
    assert np.abs(quick[-SETTLED_SAMPLES:] - step).max() < 1e-6  # one interval late: stable
    late = real_time_loop(step, 25_000_000, 'arrival')
    assert np.abs(late[-SETTLED_SAMPLES:] - step).max() > 1e3 * step


def test_the_recipe_stamps_its_unstamped_input_with_the_next_measurement():
    system = validate_parameters(load_parameter_file(str(CONFIG_DIR / CONFIG)), strict=True)
    assert system.parameters['topics.u.type'] == 'float64_multi_array'
    assert system.observer.unstamped_input == 'next_measurement'


def test_an_unknown_unstamped_input_rule_is_refused_naming_the_parameter():
    with pytest.raises(ConfigError, match=r'observer\.unstamped_input.*next_measurement'):
        recipe(**{'observer.unstamped_input': 'latest'})


def test_a_held_input_is_paired_from_the_next_measurement_on():
    system = recipe(**{'observer.unstamped_input': 'next_measurement'})
    stream = system.make_stream()
    stream.hold_input(np.array([1.0]))
    stream.hold_input(np.array([2.0]))  # the later one replaces it
    stream.add_measurement(0, np.array([0.0]))
    assert stream.engine.held_input(0).tolist() == [2.0]
    stream.hold_input(np.array([3.0]))
    stream.add_measurement(PERIOD_NS, np.array([0.0]))
    assert stream.engine.inputs.stamps == [0, PERIOD_NS]
    assert stream.engine.held_input(PERIOD_NS - 1).tolist() == [2.0]


@pytest.mark.parametrize('keep_inputs, warned', [(True, True), (False, False)])
def test_a_reset_without_its_inputs_pairs_no_old_input_with_new_samples(keep_inputs, warned):
    # A lifecycle deactivation (keep_inputs=False) forgets them: after 17.6 s the old inputs
    # would be "stamped -17.6 s from the measurements" (different time bases?).
    stream = recipe().make_stream()
    for k in range(3):
        stream.add_input(k * PERIOD_NS, np.array([1.0]))
        stream.add_measurement(k * PERIOD_NS, np.array([0.0]))
    stream.reset(keep_inputs=keep_inputs)
    stream.events.clear()
    later = 17_600_000_000
    for k in range(3):
        stream.add_measurement(later + k * PERIOD_NS, np.array([0.0]))
        stream.add_input(later + k * PERIOD_NS + 1_000_000, np.array([0.5]))  # on arrival
    assert any(kind == 'time_base' for kind, _ in stream.events) == warned
    assert stream.counters['estimates'] == 6


def test_an_input_arriving_at_the_clock_of_the_latest_measurement_takes_its_stamp():
    # Lockstep: the simulated clock stands at t_k until the plant advances, and an executor
    # may deliver y_k before the input applied from t_k: it is that sample's input.
    system = recipe(**{'observer.unstamped_input': 'next_measurement'})
    for order in ('input first', 'measurement first'):
        stream = system.make_stream()
        for k in range(3):
            stamp = k * PERIOD_NS
            if order == 'input first':
                stream.hold_input(np.array([float(k)]), stamp)
                stream.add_measurement(stamp, np.array([0.0]), stamp)
            else:
                stream.add_measurement(stamp, np.array([0.0]), stamp)
                stream.hold_input(np.array([float(k)]), stamp)
            assert stream.engine.held_input(stamp).tolist() == [float(k)], order


#: Real-time runs: samples (4 s at 100 Hz, the load at 2 s) and the relay's delay.
REAL_TIME_SAMPLES, RELAY_DELAY_NS = 400, 25_000_000
#: How late (ms, at p95) the relay may send and still be a 25 ms relay: 1 ms measured quiet.
RELAY_PUNCTUALITY_MS = 3.0


class Relay(Node):
    """Republish ``y`` and ``u`` on ``y_late`` and ``u_late`` ``delay_ns`` later (a stall)."""

    def __init__(self, delay_ns: int, **kwargs) -> None:
        super().__init__('relay', **kwargs)
        self.delay_ns = delay_ns
        self.queue: deque = deque()
        #: How much later than due each message went out, in nanoseconds.
        self.lateness: list = []
        self.late = {'u': self.create_publisher(Float64MultiArray, 'u_late', 100),
                     'y': self.create_publisher(JointState, 'y_late', 100)}
        for topic, kind in (('u', Float64MultiArray), ('y', JointState)):
            self.create_subscription(kind, topic, lambda m, t=topic: self.queue.append(
                (time.monotonic_ns() + delay_ns, t, m)), 100)
        self.create_timer(0.001, self._release)

    def _release(self) -> None:
        now = time.monotonic_ns()
        while self.queue and self.queue[0][0] <= now:
            due, topic, message = self.queue.popleft()
            self.late[topic].publish(message)
            self.lateness.append(now - due)


def late_real_time_loop(step: float, unstamped_input: str) -> tuple:
    """
    Run the recipe in real time, the observer's ``y`` and ``u`` relayed late.

    Return ``y`` and how much later than due (ns) the relay sent each message.
    """
    remaps = ('-r', 'observer:y:=y_late', '-r', 'observer:u:=u_late')
    with ros_context('--params-file', str(CONFIG_DIR / CONFIG), *remaps) as context:
        loop = ClosedLoop(record=True, context=context,
                          executor=make_executor('single', context),
                          overrides=overrides(plant__samples=REAL_TIME_SAMPLES,
                                              plant__lockstep_subscribers=2,
                                              observer__unstamped_input=unstamped_input))
        helper, relay = Node('reference_publisher', context=context), None
        try:
            relay = Relay(RELAY_DELAY_NS, context=context)
            reference = helper.create_publisher(JointState, 'reference', 10)
            helper.create_timer(0.01, lambda: reference.publish(
                JointState(name=['shoulder'], position=[step])))
            loop.executor.add_node(helper)
            loop.executor.add_node(relay)
            assert spin_until(loop.executor, lambda: loop.feedback.feedback_part.reference
                              is not None
                              and relay.late['y'].get_subscription_count() >= 1
                              and relay.late['u'].get_subscription_count() >= 1, 30.0)
            assert loop.spin(timeout_sec=120.0), 'the real-time run did not finish'
            return loop.recorder.arrays('y')[1][:, 0], np.array(relay.lateness)
        finally:
            for node in (helper, relay):
                if node is not None:
                    loop.executor.remove_node(node)
                    node.destroy_node()
            loop.destroy()


@pytest.mark.parametrize('step', [1.0, 10.0, 50.0])
def test_the_recipe_converges_in_real_time_with_its_inputs_25_ms_late(step):
    y, lateness = late_real_time_loop(step, 'next_measurement')
    assert len(y) == REAL_TIME_SAMPLES
    # 25 ms late, the servo's commands reach the plant 3 samples late too: the loop is
    # slower than the design's, but settles (measured: 2e-3, 2e-3, 7e-2 rad).
    error = np.abs(y[-SETTLED_SAMPLES:] - step).max()
    # The claim is about a relay 25 ms late. On a machine loaded beyond its cores (the suite's
    # two workers and two busy loops on two cores) the relay's timer itself runs late: 9 ms
    # at p95 measured so, 1 ms quiet. The commands then reach the plant a fourth sample late
    # and the servo's loop oscillates, at the base commit of this test too (3 of 4 runs). That
    # run did not test 25 ms: it is reported as skipped with its figures, never as a pass.
    late_ms = np.percentile(lateness, 95) / 1e6
    if error >= 0.01 * step and late_ms > RELAY_PUNCTUALITY_MS:
        pytest.skip(f'the relay sent its messages {late_ms:.1f} ms later than due at p95 (more '
                    f'than {RELAY_PUNCTUALITY_MS} ms: the machine is loaded beyond its cores); '
                    f'the loop ended {error:.3g} rad off')
    assert error < 0.01 * step, f'{error} rad off, the relay {late_ms:.1f} ms late at p95'


def test_the_recipe_diverges_in_real_time_with_inputs_stamped_on_arrival_25_ms_late():
    y, _ = late_real_time_loop(1.0, 'arrival')  # the report's loop (measured: 3e6 rad)
    assert np.abs(y[-SETTLED_SAMPLES:] - 1.0).max() > 1e3
