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
The observer's Kalman outputs over DDS: P, S and NIS stamped like x_hat, and predictions.

A test node drives the unchanged observer node with stamped measurements in real time, so the
observer's clock and the stamps agree (predictions are made for the node clock).
"""

import math
import time

import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from conftest import CONFIG_DIR
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.nodes.observer import ObserverNode
from observer_ros.ros.messages import ns_to_stamp, stamp_to_ns
from ros_support import executor_with, ros_context, spin_until

CONFIG = CONFIG_DIR / 'kalman_time_varying.yaml'


class Listener:
    """Collect every topic the observer publishes, with arrival times."""

    def __init__(self, node, kinds) -> None:
        self.messages = {topic: [] for topic in kinds}
        for topic, message_class in kinds.items():
            node.create_subscription(message_class, topic,
                                     lambda m, t=topic: self.messages[t].append(
                                         (time.monotonic(), m)), 1000)


def measurement(stamp_ns, value):
    message = JointState(name=['position'], position=[value])
    ns_to_stamp(message.header.stamp, stamp_ns)
    return message


def publishers(driver) -> tuple:
    return (driver.create_publisher(JointState, 'y', 10),
            driver.create_publisher(JointState, 'u', 10))


def drive(observer, driver, executor, seconds, period=0.01):
    """Publish y (and u) stamped with the observer's clock, in real time; return the stamps."""
    y, u = driver.publishers_
    deadline = time.monotonic() + seconds
    next_time = time.monotonic()
    stamps = []
    while time.monotonic() < deadline:
        if time.monotonic() >= next_time:
            stamp = observer.get_clock().now().nanoseconds
            command = JointState(name=['force'], position=[0.0])
            ns_to_stamp(command.header.stamp, stamp)
            u.publish(command)
            y.publish(measurement(stamp, math.sin(len(stamps) / 20)))
            stamps.append(stamp)
            next_time += period
        executor.spin_once(timeout_sec=0.001)
    return stamps


def test_covariance_innovation_covariance_and_nis_come_stamped_like_x_hat():
    with ros_context('--params-file', str(CONFIG)) as context:
        observer = ObserverNode(context=context, parameter_overrides=[
            Parameter('observer.publish_rate', value=0.0)])
        driver = Node('driver', context=context)
        driver.publishers_ = publishers(driver)
        listener = Listener(driver, {'x_hat': JointState, 'x_hat_covariance': JointState,
                                     'innovation_covariance': JointState, 'nis': JointState})
        with executor_with(context, observer, driver) as executor:
            # Every output matched before the first y: each list then starts at the same one.
            topics = list(listener.messages)
            assert spin_until(executor, lambda: observer.count_publishers('y') >= 1 and all(
                observer.count_subscribers(topic) >= 1 for topic in topics), 10.0)
            sent = len(drive(observer, driver, executor, 0.5))
            # On a loaded machine some y are lost before the observer takes them (best-effort
            # queue of 10); what matters is that every x_hat comes with its P, S and NIS.

            def counts() -> set:
                return {len(listener.messages[topic]) for topic in topics}

            assert spin_until(executor, lambda: len(counts()) == 1 and
                              min(counts()) >= min(10, sent - 2), 5.0), counts()
            spin_until(executor, lambda: False, 0.2)  # nothing else was on its way
    stamps = {topic: [stamp_to_ns(m.header.stamp) for _, m in messages]
              for topic, messages in listener.messages.items()}
    assert stamps['x_hat'] == stamps['x_hat_covariance'] == stamps['nis'] == (
        stamps['innovation_covariance'])
    covariance = listener.messages['x_hat_covariance'][-1][1]
    assert list(covariance.name) == ['position,position', 'position,velocity',
                                     'velocity,position', 'velocity,velocity']
    p = np.array(covariance.position).reshape(2, 2)
    assert np.allclose(p, p.T) and np.all(np.linalg.eigvalsh(p) > 0)
    assert list(listener.messages['nis'][-1][1].name) == ['nis']
    assert listener.messages['nis'][-1][1].position[0] >= 0.0


def test_predictions_between_measurements_show_a_gap():
    # The gap starts when the observer has taken the last measurement, not when the test
    # stops sending: on a loaded machine the measurements still queued are taken between the
    # first predictions (each lowering P again). One publisher's messages arrive in the order
    # it published them, and each x_hat is followed by its covariance, so the outputs after
    # the last measurement's x_hat (stamped like it) are the gap's.
    system = validate_parameters(load_parameter_file(str(CONFIG)))
    assert system.parameters['observer.publish_rate'] == 50.0
    with ros_context('--params-file', str(CONFIG)) as context:
        overrides = [Parameter('topics.x_hat_covariance.type', value='float64_multi_array')]
        observer = ObserverNode(context=context, parameter_overrides=overrides)
        driver = Node('driver', context=context)
        driver.publishers_ = publishers(driver)
        listener = Listener(driver, {'x_hat': JointState,
                                     'x_hat_covariance': Float64MultiArray})
        estimates, covariances = (listener.messages[topic]
                                  for topic in ('x_hat', 'x_hat_covariance'))
        with executor_with(context, observer, driver) as executor:
            assert spin_until(executor, lambda: observer.count_publishers('y') >= 1 and
                              driver.count_subscribers('x_hat_covariance') >= 1, 10.0)
            measured = set(drive(observer, driver, executor, 0.5))

            def gap_start() -> int:
                return 1 + max(i for i, (_, m) in enumerate(estimates)
                               if stamp_to_ns(m.header.stamp) in measured)

            # 50 Hz for half a second: predictions, no silence.
            assert spin_until(executor, lambda: len(estimates) - gap_start() >= 25 and
                              len(covariances) >= len(estimates), 5.0), (
                len(estimates) - gap_start())
            start = gap_start()
    gap_stamps = [stamp_to_ns(m.header.stamp) for _, m in estimates[start:]]
    assert np.all(np.diff(gap_stamps) > 0)
    traces = [np.trace(np.array(m.data).reshape(2, 2)) for _, m in covariances[start:]]
    assert np.all(np.diff(traces) > 0), traces  # the uncertainty grows while nothing comes
    layout = covariances[-1][1].layout
    assert [(d.label, d.size, d.stride) for d in layout.dim] == [('rows', 2, 4),
                                                                 ('columns', 2, 2)]
    assert observer.counters()['predictions'] >= 25
