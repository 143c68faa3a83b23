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

"""Benchmark 4 holds every node against a raw relay that receives the same messages."""

import pytest
import rclpy

from benchmarks.ros_latency import CONFIG, FLOOR, MEASURED, MESSAGES, TARGETS
from benchmarks.ros_runner import NODES


@pytest.fixture
def context():
    context = rclpy.Context()
    rclpy.init(context=context)
    yield context
    rclpy.try_shutdown(context=context)


@pytest.mark.parametrize('target', list(TARGETS))
def test_each_node_receives_the_messages_its_round_is_divided_by(context, target):
    # The probe publishes a request per node and one u per round: a node subscribed to u
    # receives two messages per round, the others one (a controller's reference topic has
    # no publisher here).
    published = {'u', *(request for request, _, _ in TARGETS.values())}
    request, kind, remappings = TARGETS[target]
    node = NODES[kind](context=context, cli_args=['--ros-args', '--params-file', str(CONFIG),
                                                  *remappings])
    try:
        topics = sorted(topic for topic in (s.topic_name.rsplit('/', 1)[-1]
                                            for s in node.subscriptions) if topic in published)
    finally:
        node.destroy_node()
    assert topics == sorted([request] + (['u'] if MESSAGES[target] == 2 else []))


def test_the_floor_of_each_node_receives_the_same_messages():
    assert set(FLOOR) == set(MEASURED)
    for target, floor in FLOOR.items():
        assert MESSAGES[floor] == MESSAGES[target], target
    assert MESSAGES['x_hat'] == 2  # y, then the command u after its estimate
