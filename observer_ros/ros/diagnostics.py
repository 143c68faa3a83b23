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

"""Counters to ``/diagnostics`` (``diagnostic_msgs/DiagnosticArray``)."""

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.node import Node

#: Counters whose growth means data was lost or repaired; they raise the level to WARN.
WARNING_COUNTERS = ('malformed', 'out_of_range', 'future_stamp', 'duplicate', 'out_of_order',
                    'restart_gap', 'restart_backward_jump', 'late_input', 'estimate_reset',
                    'step_failed', 'lockstep_timeouts', 'stale', 'unsafe_command',
                    'command_timeouts', 'started_without_peers', 'invalid_clock')


class DiagnosticsPublisher:
    """Publish a node's counters once a second on ``/diagnostics``."""

    def __init__(self, node: Node, counters_source, period: float = 1.0) -> None:
        self.node = node
        self.counters_source = counters_source
        self.publisher = node.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.timer = node.create_timer(period, self.publish)

    def publish(self) -> None:
        """Publish the current counters."""
        counters = dict(self.counters_source())
        if getattr(self.node, 'invalid_clock', 0):
            counters['invalid_clock'] = self.node.invalid_clock
        status = DiagnosticStatus(
            name=f'observer_ros: {self.node.get_fully_qualified_name()}',
            hardware_id='observer_ros',
            values=[KeyValue(key=key, value=str(value)) for key, value in
                    sorted(counters.items())])
        warn = any(counters.get(key, 0) for key in WARNING_COUNTERS)
        status.level = DiagnosticStatus.WARN if warn else DiagnosticStatus.OK
        status.message = 'data dropped or repaired, see values' if warn else 'ok'
        message = DiagnosticArray(status=[status])
        message.header.stamp = self.node.get_clock().now().to_msg()
        self.publisher.publish(message)
