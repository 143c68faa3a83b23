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
The real-time plant's stamps follow its clock, stalls and all.

The plant runs on simulated time (``use_sim_time``) driven by the test's ``/clock``: a jump
of the clock is a stall of the process, deterministic and without a wait.
"""

import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState

from conftest import CONFIG_DIR
from observer_ros.nodes.plant_simulator import PlantSimulatorNode
from observer_ros.ros.messages import ns_to_stamp, stamp_to_ns
from ros_support import executor_with, ros_context, spin_until

MS = 1_000_000
SECOND = 1000 * MS


def test_a_stall_leaves_the_real_time_plant_s_stamps_on_its_clock():
    # Clock 1.00 s at the start, then 1.01, 1.02; a 0.6 s stall (1.62), then 1.63. The
    # samples are stamped 1.00, 1.01, 1.02, 1.62, 1.63 and the plant simulated the 0.63 s
    # (it stamped start + index x period: 1.03 and 1.04 after the stall, 0.59 s behind, and
    # simulated 0.04 s).
    config = CONFIG_DIR / 'seed003_full_order.yaml'
    with ros_context('--params-file', str(config)) as context:
        plant = PlantSimulatorNode(context=context, parameter_overrides=[
            Parameter('use_sim_time', value=True),
            Parameter('plant.wait_for_command', value=False),
            Parameter('plant.settle_time', value=0.0)])
        driver = Node('clock_driver', context=context)
        clock = driver.create_publisher(Clock, '/clock', 10)
        samples = []

        def tick(seconds_ns):
            message = Clock()
            ns_to_stamp(message.clock, seconds_ns)
            clock.publish(message)

        with executor_with(context, plant, driver) as executor:
            assert spin_until(executor, lambda: plant.count_subscribers('/clock') > 0, 10.0)
            assert spin_until(executor, lambda: tick(SECOND) or plant.get_clock().now(
                ).nanoseconds == SECOND, 10.0)
            driver.create_subscription(JointState, 'y', lambda m: samples.append(
                stamp_to_ns(m.header.stamp)), 100)
            assert spin_until(executor, lambda: len(samples) == 1, 10.0)
            for count, now in enumerate((1010, 1020, 1620, 1630), start=2):
                tick(now * MS)
                assert spin_until(executor, lambda: len(samples) == count, 10.0), samples
            elapsed = plant.simulator.elapsed
    assert samples == [1000 * MS, 1010 * MS, 1020 * MS, 1620 * MS, 1630 * MS]
    assert elapsed == pytest.approx(0.63, abs=1e-9)
    assert plant.counters['skipped_periods'] == 59


@pytest.mark.parametrize('feedthrough, order', [
    (None, ['y', 'u', 'x_true']),  # y first: the observer waits for it
    ([0.5], ['u', 'y', 'x_true'])])  # D u: the input in effect arrives before y
def test_a_sample_publishes_y_first_and_u_before_y_only_with_a_feedthrough(feedthrough, order):
    # Before, a sample published x_true, u, then y: about 60 us of the loop's critical path
    # ahead of the measurement the observer answers.
    config = CONFIG_DIR / 'seed003_full_order.yaml'
    extra = [] if feedthrough is None else [Parameter('model.D', value=feedthrough)]
    with ros_context('--params-file', str(config)) as context:
        plant = PlantSimulatorNode(context=context, parameter_overrides=[
            Parameter('plant.wait_for_command', value=False), *extra])
        try:
            part = plant.plant_part
            part.start_timer.cancel()
            published = []
            for topic, publisher in part.publishers_.items():
                publisher.publish = lambda data, topic=topic: published.append(topic)
            part.x_true_listened = True  # as when something subscribes x_true
            part.publish_sample()
            assert published == order
            part.x_true_listened = False  # nobody subscribes x_true: not published
            published.clear()
            part.publish_sample()
            assert published == order[:2]
        finally:
            plant.destroy_node()
