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
The QoS shapes of the package's topics, and the standard per-topic QoS overrides.

Subscriptions are best effort (they match every publisher), publishers reliable (every
subscription matches them); both keep the last 10 messages, volatile. Users may override
history, depth and reliability per topic with the qos_overrides./<topic>.<publisher|
subscription>.<policy> parameters (:data:`QOS_OVERRIDES`).
"""

from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy)
from rclpy.qos_overriding_options import QoSOverridingOptions


def volatile_qos(depth: int, reliable: bool) -> QoSProfile:
    """Keep-last ``depth``, volatile, reliable or best effort: the package's QoS shapes."""
    return QoSProfile(depth=depth, history=HistoryPolicy.KEEP_LAST,
                      reliability=(ReliabilityPolicy.RELIABLE if reliable
                                   else ReliabilityPolicy.BEST_EFFORT),
                      durability=DurabilityPolicy.VOLATILE)


def subscription_qos() -> QoSProfile:
    """
    Return the QoS of the nodes' subscriptions: best effort, which matches every publisher.

    A new profile per call: rclpy writes ``qos_overrides`` into the profile it is given, so
    a shared one would carry one topic's override to every later topic.
    """
    return volatile_qos(10, reliable=False)


def publisher_qos() -> QoSProfile:
    """Return the QoS of the nodes' publishers: reliable, which every subscription matches."""
    return volatile_qos(10, reliable=True)


#: Users may override history, depth and reliability per topic with the standard
#: ``qos_overrides./<topic>.<publisher|subscription>.<policy>`` parameters.
QOS_OVERRIDES = QoSOverridingOptions.with_default_policies()

__all__ = ['QOS_OVERRIDES', 'publisher_qos', 'subscription_qos', 'volatile_qos']
