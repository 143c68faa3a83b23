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

from observer_ros.core.errors import ConfigError


class StateFeedbackLaw:
    """
    ``u = -K x_hat + N r``, clipped to the input limits.

    Parameters
    ----------
    gain : array_like, shape (m, n)
        ``K``.
    reference_gain : array_like or None, shape (m, p)
        ``N``; None: references are ignored.
    input_limits : array_like or None, shape (m, 2)
        ``[min, max]`` per input; None: no clipping.

    Raises
    ------
    ConfigError
        Naming ``gain``, ``reference_gain`` or ``input_limits`` when the shapes disagree.

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> law = oc.StateFeedbackLaw([[5.0, 4.5]], reference_gain=[[5.0]],
    ...                           input_limits=[[-10.0, 10.0]])
    >>> law.command(np.array([1.0, 0.0]), reference=np.array([2.0])).tolist()
    [5.0]
    >>> law.command(np.array([4.0, 0.0])).tolist()
    [-10.0]

    """

    def __init__(self, gain: np.ndarray, reference_gain: Optional[np.ndarray] = None,
                 input_limits: Optional[np.ndarray] = None) -> None:
        self.gain = np.atleast_2d(np.asarray(gain, dtype=float))
        if self.gain.ndim != 2:
            raise ConfigError('gain', f'expected an m x n matrix, got shape {self.gain.shape}')
        n_inputs = self.gain.shape[0]
        if reference_gain is not None:
            reference_gain = np.atleast_2d(np.asarray(reference_gain, dtype=float))
            if reference_gain.ndim != 2 or reference_gain.shape[0] != n_inputs:
                raise ConfigError('reference_gain', f'expected a {n_inputs} x p matrix, got '
                                  f'shape {reference_gain.shape}')
        if input_limits is not None:
            input_limits = np.atleast_2d(np.asarray(input_limits, dtype=float))
            if input_limits.shape != (n_inputs, 2):
                raise ConfigError('input_limits', f'expected a {n_inputs} x 2 matrix '
                                  f'([min, max] per input), got shape {input_limits.shape}')
        self.reference_gain = reference_gain
        self.input_limits = input_limits

    def command(self, estimate: np.ndarray, reference: Optional[np.ndarray] = None):
        """
        Return the command for an estimate and an optional reference.

        Parameters
        ----------
        estimate : numpy.ndarray, shape (n,)
            ``x_hat``.
        reference : numpy.ndarray, shape (p,), optional
            ``r``; ignored without a reference gain.

        Returns
        -------
        numpy.ndarray, shape (m,)

        Examples
        --------
        >>> import numpy as np
        >>> from observer_ros.core import StateFeedbackLaw
        >>> StateFeedbackLaw([[1.0, 2.0]]).command(np.array([1.0, 1.0])).tolist()
        [-3.0]

        """
        u = -self.gain @ estimate
        if reference is not None and self.reference_gain is not None:
            u = u + self.reference_gain @ reference
        if self.input_limits is not None:
            u = np.clip(u, self.input_limits[:, 0], self.input_limits[:, 1])
        return u
