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
Analysis of the loop an observer and a state feedback close: G_oc, Diophantine, poles.

Design-time checks, not run-time code (the run-time law is
:mod:`observer_ros.core.feedback_law`): :mod:`~.observer_controller` (the observer and
``u = -K x_hat`` as one controller, ``G_oc = -U / Y``), :mod:`~.diophantine` (the same
controller from ``A R + B S = A_cl``, its cross-check), :mod:`~.frequency` (the comparison
of two responses on a frequency grid), :mod:`~.transfer_function` (the SISO transfer
function value) and :mod:`~.closed_loop` (the closed loop's state matrix and poles).
Observability and controllability of the model itself are in
:mod:`observer_ros.core.ranks` (the rank tests) and :mod:`observer_ros.core.analysis` (the
observability rule).
"""
