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
Tuning from recorded data: noise covariances and models, ROS-free.

:mod:`~observer_ros.core.tuning.innovations` pools innovation statistics (autocovariances,
whiteness, NIS); :mod:`~observer_ros.core.tuning.noise_model` says what autocovariances a
filter leaves for given ``Q`` and ``R``, and :mod:`~observer_ros.core.tuning.als` estimates
``Q`` and ``R`` from them by autocovariance least squares;
:mod:`~observer_ros.core.tuning.subspace` identifies ``A, B, C, D`` from inputs and outputs
(PO-MOESP) and :mod:`~observer_ros.core.tuning.identified_model` holds the records, the
model and its fit on held-out data. The bag tools ``tune_kalman`` and ``identify`` run them
over recordings.
"""
