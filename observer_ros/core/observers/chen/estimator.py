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
Sampled Chen observer.

Per interval: ``F_d = expm(F dt)`` (or ``F`` for a discrete model), ``L_d`` the zero-order
hold of ``L`` through ``F`` (tends to ``L dt``), ``T`` from ``T Ad - F_d T = L_d C``. From the
previous estimate, ``z = F_d T x_hat + T Bd u + L_d C x_hat`` and ``x_hat = [C; T]^-1 [y; z]``;
the error ``T e`` evolves by ``F_d``. Rebuilding ``z`` from ``x_hat`` each interval keeps
the full-state error unchanged when ``T`` changes with the interval.
"""

import numpy as np

from observer_ros.core.discretize import zero_order_hold
from observer_ros.core.estimators.constant_gain import (
    assemble_step, least_norm_consistent, StepDesign, StepMatrices)
from observer_ros.core.observers.chen.design import ChenDesign
from observer_ros.core.observers.chen.sylvester import solve_chen
from observer_ros.core.placement_checks import sort_poles
from observer_ros.core.poles import clean_poles


class ChenStep(StepDesign):
    """Step design of Chen's observer from a :class:`ChenDesign` (its ``F`` and ``L``)."""

    kind = 'chen'

    def __init__(self, design: ChenDesign) -> None:
        super().__init__(design.model)
        self.f = design.f
        self.gain = design.gain
        self.poles = design.requested_poles

    def design_step(self, ad, bd, dt) -> StepMatrices:
        """Solve the sampled Sylvester equation and assemble the step."""
        p = self.model.n_outputs
        c = self.model.c
        if self.model.is_discrete:
            f_d, l_d = self.f, self.gain
            poles = self.poles
        else:
            f_d, l_d = zero_order_hold(self.f, self.gain, dt)
            poles = sort_poles(clean_poles(np.exp(self.poles * dt)))
        t, inverse, _, _ = solve_chen(ad, c, f_d, l_d)
        cols_y, cols_z = inverse[:, :p], inverse[:, p:]
        error = cols_z @ (f_d @ t + l_d @ c)
        return assemble_step(error, cols_z @ t @ bd, cols_y, c, ad, bd, poles)

    def initial_estimate(self, initial_state, y) -> np.ndarray:
        """Nearest point to the initial guess that agrees with the first measurement."""
        return least_norm_consistent(self.model.c, initial_state, y)
