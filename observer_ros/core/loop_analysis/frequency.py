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
Two transfer functions compared on a frequency grid around their dynamics.

:func:`frequency_grid` picks the points (log-spaced, and close to every pole and zero),
:func:`response_disagreement` the largest relative difference of the two responses there.
"""

import numpy as np

from observer_ros.core.loop_analysis.transfer_function import (
    ControllerTransferFunction, evaluate_zpk)

#: Points of the frequency grid of :func:`response_disagreement`.
GRID_POINTS = 200

#: Responses below this fraction of the largest one on the grid count as that fraction.
RESPONSE_FLOOR = 1e-9


def frequency_grid(first: ControllerTransferFunction,
                   second: ControllerTransferFunction) -> np.ndarray:
    """
    Points on ``s = j w`` (``z = exp(j theta)``) around both systems' dynamics.

    ``GRID_POINTS`` log-spaced frequencies from a tenth of the slowest to ten times the
    fastest pole or zero magnitude (for a discrete system the magnitude of ``log z``, up to
    ``theta = pi``), plus points 1 % and 3 % either side of each pole's and zero's magnitude,
    where a lightly damped root's peak or notch lies (not on it: a root on the axis would
    make the response infinite or zero there).
    """
    roots = np.concatenate([first.zeros, first.poles, second.zeros, second.poles])
    if first.discrete:
        roots = np.log(roots[np.abs(roots) > 0].astype(complex))
    magnitudes = np.abs(roots)
    magnitudes = magnitudes[magnitudes > 0]
    low = magnitudes.min() / 10.0 if magnitudes.size else 1e-2
    high = magnitudes.max() * 10.0 if magnitudes.size else 1e2
    if first.discrete:
        low, high = min(low, np.pi / 10.0), np.pi
    frequencies = np.concatenate([np.logspace(np.log10(low), np.log10(high), GRID_POINTS),
                                  np.outer(magnitudes, [0.97, 0.99, 1.01, 1.03]).ravel()])
    frequencies = np.unique(frequencies[(frequencies >= low) & (frequencies <= high)])
    return np.exp(1j * frequencies) if first.discrete else 1j * frequencies


def response_disagreement(first: ControllerTransferFunction,
                          second: ControllerTransferFunction) -> float:
    """
    Largest relative difference of two frequency responses on :func:`frequency_grid`.

    ``max |G1 - G2| / max(|G2|, RESPONSE_FLOOR max |G2|)`` over the grid; the floor keeps a
    zero close to the imaginary axis (unit circle) from turning rounding into a large
    relative error. ``first`` is evaluated in its zero-pole-gain form (how
    :func:`controller_transfer_function` computes it), ``second`` from its polynomials (how
    the Diophantine equation gives it): the roots of clustered polynomial coefficients are
    less accurate than the coefficients.
    """
    points = frequency_grid(first, second)
    with np.errstate(all='ignore'):
        return relative_difference(
            evaluate_zpk(first, points),
            np.polyval(second.num, points) / np.polyval(second.den, points))


def relative_difference(one: np.ndarray, two: np.ndarray) -> float:
    """
    Largest ``|one - two| / max(|two|, RESPONSE_FLOOR max |two|)`` over the finite points.

    Infinite when no point is finite in both or a ratio is not finite.
    """
    finite = np.isfinite(one) & np.isfinite(two)
    if not np.any(finite):
        return np.inf
    one, two = one[finite], two[finite]
    with np.errstate(all='ignore'):
        reference = np.abs(two)
        floor = RESPONSE_FLOOR * np.max(reference)
        ratio = np.abs(one - two) / np.maximum(np.maximum(reference, floor), 1e-300)
    return float(np.max(ratio)) if np.all(np.isfinite(ratio)) else np.inf
