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
Sampled reduced-order observer.

In the measured-first coordinates ``w = Q x = [x_a; x_b]`` of the design, the sampled plant
``Phi = Q Ad Q^-1``, ``Gamma = Q Bd`` gives ``x_a[k] - Phi_aa x_a[k-1] - Gamma_a u =
Phi_ab x_b[k-1]``, a measurement of ``x_b``. The observer::

    x_b_hat[k] = Phi_bb x_b_hat + Phi_ba y[k-1] + Gamma_b u
                 + L (y[k] - Phi_aa y[k-1] - Gamma_a u - Phi_ab x_b_hat)

has error ``e_b[k] = (Phi_bb - L Phi_ab) e_b[k-1]``, with ``L`` placing ``exp(lambda dt)``.
"""

import numpy as np

from observer_ros.core.estimators.constant_gain import (
    assemble_step, least_norm_consistent, place_sampled, StepDesign, StepMatrices)
from observer_ros.core.observers.reduced_order.design import ReducedOrderDesign


class ReducedOrderStep(StepDesign):
    """
    Step design of the reduced-order observer, in the coordinates of ``design``.

    A continuous model's observer poles are re-placed as ``exp(lambda dt)`` each interval;
    a discrete model with a given gain uses it as is.
    """

    kind = 'reduced_order'

    def __init__(self, design: ReducedOrderDesign, method: str = 'auto') -> None:
        super().__init__(design.model)
        self.transform = design.transform
        self.inverse = np.linalg.inv(design.transform)
        self.poles = design.requested_poles
        self.method = method
        self.given_gain = design.gain if (
            self.model.is_discrete and design.method == 'given') else None

    def design_step(self, ad, bd, dt) -> StepMatrices:
        """Partition the sampled plant, place ``Phi_bb - L Phi_ab`` and assemble the step."""
        p = self.model.n_outputs
        phi = self.transform @ ad @ self.inverse
        gamma = self.transform @ bd
        phi_aa, phi_ab, phi_ba, phi_bb = phi[:p, :p], phi[:p, p:], phi[p:, :p], phi[p:, p:]
        poles = self.discrete_poles(self.poles, dt)
        if self.given_gain is not None:
            gain = self.given_gain
        else:
            gain = place_sampled(phi_bb, phi_ab, poles, self.method).gain
        rows_a, rows_b = self.transform[:p], self.transform[p:]
        cols_a, cols_b = self.inverse[:, :p], self.inverse[:, p:]
        error_b = phi_bb - gain @ phi_ab
        error = cols_b @ (error_b @ rows_b + (phi_ba - gain @ phi_aa) @ rows_a)
        input_gain = cols_b @ (gamma[p:] - gain @ gamma[:p])
        output_gain = cols_a + cols_b @ gain
        return assemble_step(error, input_gain, output_gain, self.model.c, ad, bd, poles)

    def initial_estimate(self, initial_state, y) -> np.ndarray:
        """Nearest point to the initial guess that agrees with the first measurement."""
        return least_norm_consistent(self.model.c, initial_state, y)
