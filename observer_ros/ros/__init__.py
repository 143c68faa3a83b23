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
ROS 2 wiring: messages, schema parameters, QoS, executors, node main, health, lifecycle.

One module per subject: :mod:`~.messages` (vectors to and from messages, with the wire codec
:mod:`observer_ros.wire` that the bag tools share),
:mod:`~.parameters` (the schema parameters declared with their types), :mod:`~.qos`,
:mod:`~.clock` (the ``/clock`` guard), :mod:`~.executors`, :mod:`~.run` (every node's
``main``), :mod:`~.diagnostics`, :mod:`~.lifecycle` (managed nodes) and :mod:`~.recorder`.
"""
