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
Sampled full-order observer in current-estimator form.

Per interval: ``x_prior = Ad x_hat + Bd u`` and ``x_hat = x_prior + M (y - C x_prior)``, so
the error obeys ``e_new = (I - M C) Ad e``; ``M`` places ``eig((I - M C) Ad)`` at
``exp(lambda dt)`` (the pair ``(Ad, C Ad)``).

With several measurement sources each subset of outputs gets its own ``M``, placed at the
same poles for the pair ``(Ad, C_s Ad)`` of its rows of ``C`` (``FullOrderStep.for_outputs``),
designed on first use and cached per interval; a subset that cannot see every mode of ``A``
is refused, naming the modes.
"""

from typing import Optional

import numpy as np

from observer_ros.core.analysis import require_seen
from observer_ros.core.design.common import ObserverDesign
from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators.constant_gain import place_sampled, StepDesign, StepMatrices
from observer_ros.core.observers.common import current_form


class FullOrderStep(StepDesign):
    """
    Step design of the full-order observer.

    Parameters
    ----------
    design : ObserverDesign
        From :func:`observer_ros.core.observers.full_order.design.design_full_order`. Its requested
        poles (those of ``A - L C`` for a given gain; s-plane for a continuous model) are
        placed as ``exp(lambda dt)`` for every interval; for a discrete model with a given
        gain ``L`` the filter gain is ``A^-1 L``.
    method : str
        Placement method for the per-interval designs.

    """

    kind = 'full_order'

    def __init__(self, design: ObserverDesign, method: str = 'auto') -> None:
        super().__init__(design.model)
        self.poles = design.requested_poles
        self.method = method
        self.filter_gain = None
        if self.model.is_discrete and design.method == 'given':
            try:
                self.filter_gain = np.linalg.solve(self.model.a, design.gain)
            except np.linalg.LinAlgError as e:
                raise ConfigError(
                    'gain', 'a discrete model with a singular A cannot run a given '
                    'predictor gain in current-estimator form; give poles') from e

    def design_step(self, ad, bd, dt) -> StepMatrices:
        """Place ``eig((I - M C) Ad)`` at the discrete poles and assemble the step."""
        c = self.model.c
        require_seen(self.model, a=ad)  # the one rule, for this interval's sampled A
        poles = self.discrete_poles(self.poles, dt)
        if self.filter_gain is not None:
            gain = self.filter_gain
        else:
            gain = place_sampled(ad, c @ ad, poles, self.method).gain
        return current_form(ad, bd, c, gain, poles)

    def several_sources_problem(self) -> Optional[str]:
        """None, unless a given gain of a discrete model is used as it is (every output)."""
        if self.filter_gain is not None:
            return ('a given gain L of a discrete model is used as it is, for every output; '
                    'give poles so that a gain is designed for each subset of outputs')
        return None

    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """Say why ``outputs`` alone cannot have a gain: the modes they cannot see."""
        problem = self.several_sources_problem()
        if problem is not None:
            return problem
        return self.observability_problem(
            outputs, detectable=False,
            consequence=', so no observer of them alone can place its poles')
