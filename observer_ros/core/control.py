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

"""The state-feedback law ``u = sat(-K x_hat + N r)``."""

from typing import Optional

import numpy as np


class StateFeedbackLaw:
    """
    ``u = -K x_hat + N r``, clipped to the input limits.

    Parameters
    ----------
    gain : numpy.ndarray, shape (m, n)
    reference_gain : numpy.ndarray or None, shape (m, p)
        None: references are ignored.
    input_limits : numpy.ndarray or None, shape (m, 2)

    """

    def __init__(self, gain: np.ndarray, reference_gain: Optional[np.ndarray] = None,
                 input_limits: Optional[np.ndarray] = None) -> None:
        self.gain = np.asarray(gain, dtype=float)
        self.reference_gain = reference_gain
        self.input_limits = input_limits

    def command(self, estimate: np.ndarray, reference: Optional[np.ndarray] = None):
        """Return the command for an estimate and an optional reference."""
        u = -self.gain @ estimate
        if reference is not None and self.reference_gain is not None:
            u = u + self.reference_gain @ reference
        if self.input_limits is not None:
            u = np.clip(u, self.input_limits[:, 0], self.input_limits[:, 1])
        return u
