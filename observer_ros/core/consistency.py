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
Consistency statistics of a Kalman filter: the NIS and its chi-square bounds.

The normalized innovation squared ``NIS = v' S^-1 v`` of a consistent filter with ``p``
outputs is chi-square with ``p`` degrees of freedom: :func:`nis_bounds` gives the two-sided
bounds of the mean of ``N`` of them and :class:`NisWindow` keeps the last ``N`` values and
their mean. What a node makes of a mean outside the bounds is its health logic
(:mod:`observer_ros.app.health`).
"""

from collections import deque
from functools import lru_cache
import math
from typing import Optional


@lru_cache(maxsize=64)
def nis_bounds(window: int, outputs: int, confidence: float = 0.99) -> tuple:
    """
    Two-sided bounds of the mean of ``window`` NIS values of a consistent filter.

    Each NIS of a consistent Kalman filter with ``outputs`` measurements is chi-square with
    ``outputs`` degrees of freedom; their sum over ``window`` independent samples is
    chi-square with ``window * outputs``, so the mean lies between the returned bounds
    with probability ``confidence``.

    Parameters
    ----------
    window : int
        Number of NIS samples averaged (``N >= 1``).
    outputs : int
        Measurement dimension ``p >= 1``.
    confidence : float
        Two-sided probability in (0, 1).

    Returns
    -------
    tuple of float
        ``(low, high)`` bounds of the mean NIS.

    Raises
    ------
    ValueError
        Naming the argument out of range.

    Examples
    --------
    >>> low, high = nis_bounds(50, 1, 0.99)
    >>> round(low, 3), round(high, 3)
    (0.56, 1.59)

    """
    if window < 1:
        raise ValueError(f'window: expected at least 1 sample, got {window}')
    if outputs < 1:
        raise ValueError(f'outputs: expected at least 1, got {outputs}')
    if not 0 < confidence < 1:
        raise ValueError(f'confidence: expected a probability in (0, 1), got {confidence}')
    # The chi-square quantile as scipy.stats.chi2.ppf computes it (2 gammaincinv(dof/2, q),
    # the same bits), from scipy.special: scipy.stats takes 0.3-1.8 s to import, and a node
    # with a covariance computes these bounds at start-up.
    from scipy.special import gammaincinv
    dof = window * outputs
    tail = (1 - confidence) / 2
    return (float(2 * gammaincinv(dof / 2, tail)) / window,
            float(2 * gammaincinv(dof / 2, 1 - tail)) / window)


class NisWindow:
    """
    The last ``window`` NIS values, their mean and its two-sided chi-square bounds.

    Parameters
    ----------
    window : int
        Samples averaged.
    outputs : int
        Measurement dimension ``p``.
    confidence : float
        Two-sided confidence of the bounds (:func:`nis_bounds`).

    Examples
    --------
    >>> window = NisWindow(2, 1)
    >>> window.add(0.5)
    >>> window.full, window.mean
    (False, 0.5)
    >>> window.add(1.5)
    >>> window.full, window.mean, window.low < window.mean < window.high
    (True, 1.0, True)

    """

    def __init__(self, window: int, outputs: int, confidence: float = 0.99) -> None:
        self.window = int(window)
        self.outputs = int(outputs)
        self.confidence = float(confidence)
        self.low, self.high = nis_bounds(self.window, self.outputs, self.confidence)
        self.values: deque = deque(maxlen=self.window)

    def add(self, nis: float) -> None:
        """Add one NIS value."""
        self.values.append(nis)

    def clear(self) -> None:
        """Forget the values (after an estimator restart)."""
        self.values.clear()

    @property
    def full(self) -> bool:
        """Whether the window holds ``window`` values (before that it is not judged)."""
        return len(self.values) >= self.window

    @property
    def mean(self) -> Optional[float]:
        """The mean of the values held (NaN when there are none)."""
        count = len(self.values)
        return math.fsum(self.values) / count if count else math.nan


__all__ = ['NisWindow', 'nis_bounds']
