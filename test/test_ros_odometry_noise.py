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
The observer node's two hooks of issue 30: the noise of each message, the Odometry back.

A live ObserverNode over DDS takes PoseWithCovarianceStamped and TwistWithCovarianceStamped
sources with ``noise: message`` and publishes ``nav_msgs/Odometry``: every pose's block of
``R`` is taken from its message, and the last Odometry holds the estimate the stream gives
by hand (``test_message_noise.run_node_path``) with ``P`` in the Odometry layout.
"""

import math

from geometry_msgs.msg import PoseWithCovarianceStamped, TwistWithCovarianceStamped
from nav_msgs.msg import Odometry
from rclpy.node import Node
from rclpy.parameter import Parameter
from test_message_noise import CART, run_node_path, samples

from observer_ros.config import validate_parameters
from observer_ros.nodes.observer import ObserverNode
from observer_ros.ros.messages import ns_to_stamp, stamp_to_ns
from ros_support import executor_with, ros_context, spin_until

ODOMETRY = {'outputs.odometry.topic': 'odom', 'outputs.odometry.x': 'x',
            'outputs.odometry.vx': 'v', 'outputs.odometry.child_frame_id': 'base_footprint'}


def test_the_node_takes_each_messages_noise_and_publishes_the_odometry():
    parameters = {**CART, **ODOMETRY, 'observer.clock_tolerance': 0.0}
    feed = samples(30)
    with ros_context() as context:
        observer = ObserverNode(context=context, parameter_overrides=[
            Parameter(name, value=value) for name, value in parameters.items()])
        driver = Node('noise_driver', context=context)
        pose = driver.create_publisher(PoseWithCovarianceStamped, 'pose', 100)
        twist = driver.create_publisher(TwistWithCovarianceStamped, 'twist', 100)
        received = []
        driver.create_subscription(Odometry, 'odom', received.append, 1000)
        with executor_with(context, observer, driver) as executor:
            assert spin_until(executor, lambda: pose.get_subscription_count() > 0
                              and twist.get_subscription_count() > 0
                              and driver.count_publishers('odom') > 0, 10.0)
            for name, stamp, value, variance in feed:
                if name == 'pose':
                    message = PoseWithCovarianceStamped()
                    message.pose.pose.position.x = value
                    message.pose.covariance[0] = variance
                else:
                    message = TwistWithCovarianceStamped()
                    message.twist.twist.linear.x = value
                    message.twist.covariance[0] = variance
                ns_to_stamp(message.header.stamp, stamp)
                (pose if name == 'pose' else twist).publish(message)
                # one at a time, in stamp order, as run_node_path takes them
                assert spin_until(executor, lambda: len(received) >= 1 and stamp_to_ns(
                    received[-1].header.stamp) == stamp, 10.0), stamp
            counters = observer.stream.estimator.message_noise.readers['pose'].counters
    _, expected = run_node_path(validate_parameters(CART), feed)
    last = received[-1]
    stamp, x, p = expected[-1]
    assert stamp_to_ns(last.header.stamp) == stamp
    assert (last.header.frame_id, last.child_frame_id) == ('odom', 'base_footprint')
    assert last.pose.pose.position.x == x[0] and last.twist.twist.linear.x == x[1]
    assert last.pose.covariance[0] == p[0, 0] and last.twist.covariance[0] == p[1, 1]
    assert last.pose.pose.orientation.w == 1.0 and math.isfinite(last.pose.covariance[0])
    assert counters['used'] == 30
