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
The application layer without ROS: node health logic, design reports and run plots.

Built on the core and the configuration (:mod:`observer_ros.config`), used by the nodes,
the tools and the bag replays: :mod:`~observer_ros.app.health` judges a running node's
inputs and estimator (the levels of ``DiagnosticStatus``, its counters),
:mod:`~observer_ros.app.design_check` its validated design,
:mod:`~observer_ros.app.report` writes what ``design_observer`` prints, and
:mod:`~observer_ros.app.plots` draws the figures of an estimation run. Imports no ROS.
"""
