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
State observers and observer-based state feedback for ROS 2, in one room per layer.

``core`` (models, designs, estimators, the event engine; no ROS), ``config`` (the parameter
schema and its validation), ``app`` (health logic, reports, plots), ``ros`` (wiring to
rclpy: messages, parameters, QoS, executors), ``nodes`` (the ROS 2 nodes), ``bags``
(rosbag2 storage and replay) and ``tools`` (the command-line tools).
"""
