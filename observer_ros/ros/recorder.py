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

"""A node that collects vector topics into arrays (and keeps the raw messages)."""

from collections import defaultdict
import time

import numpy as np
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from observer_ros.config import Configuration
from observer_ros.ros.messages import MalformedMessage, VectorCodec
from observer_ros.ros.qos import volatile_qos

#: Messages a recorder's subscription queues while its callback is behind.
RECORDER_DEPTH = 1000


def recording_qos(node: Node, topic: str) -> QoSProfile:
    """
    Subscription QoS that records every message the publishers of ``topic`` deliver.

    Reliable with a deep queue, unless a publisher already discovered offers best effort
    (a reliable subscription would not match it). Publishers not yet discovered are assumed
    reliable, as the package's publishers are unless overridden.
    """
    offered = node.get_publishers_info_by_topic(node.resolve_topic_name(topic))
    reliable = all(info.qos_profile.reliability == ReliabilityPolicy.RELIABLE
                   for info in offered)
    return volatile_qos(RECORDER_DEPTH, reliable=reliable)


class TopicRecorder(Node):
    """
    Subscribe to the given topics and keep ``(stamp_ns, vector)`` per message.

    Parameters
    ----------
    system : Configuration
        Gives each topic's message type and names.
    topics : sequence of str
        Topic keys (``'y'``, ``'u'``, ``'u_cmd'``, ``'x_true'``, ``'x_hat'`` ...).
    keep_messages : bool
        Also keep ``(receive_time_ns, message)`` pairs (for bag writing).

    Notes
    -----
    Each topic's QoS comes from :func:`recording_qos` when the recorder is created.

    """

    def __init__(self, system: Configuration, topics, node_name: str = 'recorder',
                 keep_messages: bool = False, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.codecs = {topic: VectorCodec.for_topic(system, topic) for topic in topics}
        self.stamps: dict = defaultdict(list)
        self.values: dict = defaultdict(list)
        self.received: dict = defaultdict(list)
        self.messages: dict = defaultdict(list)
        self.keep_messages = keep_messages
        #: The subscription QoS of each topic (see :func:`recording_qos`).
        self.qos = {topic: recording_qos(self, topic) for topic in topics}
        for topic, codec in self.codecs.items():
            self.create_subscription(codec.message_class, topic,
                                     lambda message, t=topic: self._on_message(t, message),
                                     self.qos[topic])

    def _on_message(self, topic: str, message) -> None:
        now = self.get_clock().now().nanoseconds
        if self.keep_messages:
            self.messages[topic].append((now, message))
        try:
            stamp, vector = self.codecs[topic].decode(message)
        except MalformedMessage:
            return
        self.stamps[topic].append(now if stamp is None else stamp)
        self.received[topic].append(time.time_ns())
        self.values[topic].append(vector)

    def receive_times(self, topic: str) -> np.ndarray:
        """Wall-clock receive times (ns) of a topic's messages, as a bag recorder logs them."""
        return np.array(self.received[topic], dtype=np.int64)

    def count(self, topic: str) -> int:
        """Return the number of messages recorded on a topic."""
        return len(self.stamps[topic])

    def arrays(self, topic: str):
        """``(stamps_ns, values)`` of a topic as arrays, shapes ``(k,)`` and ``(k, size)``."""
        size = self.codecs[topic].size
        values = np.array(self.values[topic], dtype=float).reshape(-1, size)
        return np.array(self.stamps[topic], dtype=np.int64), values
