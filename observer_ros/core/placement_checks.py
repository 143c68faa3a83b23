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
Checking a pole placement: poles sorted, grouped into clusters, and matched with those achieved.

:func:`placement_residual` is the verification every placement passes
(:func:`observer_ros.core.placement.place`): the achieved eigenvalues matched one to one
with the requested poles, a cluster of (nearly) repeated poles compared through its
polynomial's coefficients. :func:`pole_clusters` and its counts also choose the method.
"""

import numpy as np

from observer_ros.core.scipy_parts import linear_sum_assignment


#: Relative distance under which poles are treated as one (nearly) repeated cluster, both
#: for choosing the method and for verifying the result.
CLUSTER_RTOL = 1e-3


#: Relative distance under which two poles are the same repeated pole (Jordan chains).
REPEATED_RTOL = 1e-6


def sort_poles(poles) -> np.ndarray:
    """
    Sort by real part, then imaginary part, for side-by-side comparison.

    Parameters
    ----------
    poles : array_like of complex, shape (k,)

    Returns
    -------
    numpy.ndarray of complex, shape (k,)

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.sort_poles([-1, -3 + 1j, -3 - 1j]).tolist()
    [(-3-1j), (-3+1j), (-1+0j)]

    """
    poles = np.asarray(poles, dtype=complex)
    return poles[np.lexsort((poles.imag, poles.real))]


def pole_clusters(poles: np.ndarray, rtol: float = CLUSTER_RTOL) -> list:
    """
    Group poles closer than ``rtol`` (relative, single linkage) into clusters.

    Returns
    -------
    list of numpy.ndarray of int
        Indices of each cluster.

    """
    poles = np.asarray(poles, dtype=complex)
    labels = list(range(poles.size))
    for i in range(poles.size):
        for j in range(i + 1, poles.size):
            scale = max(1.0, abs(poles[i]), abs(poles[j]))
            if abs(poles[i] - poles[j]) <= rtol * scale and labels[i] != labels[j]:
                old, new = labels[j], labels[i]
                labels = [new if label == old else label for label in labels]
    groups: dict = {}
    for index, label in enumerate(labels):
        groups.setdefault(label, []).append(index)
    return [np.array(group) for group in groups.values()]


def max_multiplicity(poles: np.ndarray, rtol: float = CLUSTER_RTOL) -> int:
    """Size of the largest cluster of (nearly) equal poles."""
    return max((group.size for group in pole_clusters(poles, rtol)), default=0)


def has_repeated(poles: np.ndarray, rtol: float = CLUSTER_RTOL) -> bool:
    """Whether two poles are equal, or nearly, to within ``rtol`` relative."""
    return max_multiplicity(poles, rtol) > 1


def placement_residual(closed_loop: np.ndarray, poles: np.ndarray) -> tuple[float, np.ndarray]:
    """
    Relative error between ``eig(closed_loop)`` and ``poles``.

    Eigenvalues are matched to the requested poles one to one. A pole standing alone is
    compared directly. A cluster of repeated or nearly repeated poles, whose computed
    eigenvalues scatter by ``eps^(1/k)`` even for an exact gain, is compared through the
    coefficients of its polynomial shifted to the cluster centre, each scaled by
    ``max(1, |centre|)^j``: the symmetric functions of a cluster are as accurate as the
    matrix, its individual eigenvalues are not.

    Parameters
    ----------
    closed_loop : array_like, shape (n, n)
        ``A - B K`` or ``A - L C``.
    poles : array_like of complex, shape (n,)
        The requested poles.

    Returns
    -------
    residual : float
    achieved : numpy.ndarray of complex, shape (n,)
        Eigenvalues, sorted.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> residual, achieved = oc.placement_residual([[-2, 1], [0, -2]], [-2, -2])
    >>> residual, achieved.tolist()
    (0.0, [(-2+0j), (-2+0j)])

    """
    achieved = sort_poles(np.linalg.eigvals(closed_loop))
    poles = np.asarray(poles, dtype=complex)
    if not np.all(np.isfinite(achieved)):
        return float('inf'), achieved
    cost = np.abs(achieved[:, None] - poles[None, :])
    rows, cols = linear_sum_assignment()(cost)  # SciPy's, loaded when first used
    matched = np.empty_like(poles)
    matched[cols] = achieved[rows]
    residual = 0.0
    for group in pole_clusters(poles):
        wanted, got = poles[group], matched[group]
        centre = wanted.mean()
        scale = max(1.0, abs(centre))
        if group.size == 1:
            residual = max(residual, abs(got[0] - wanted[0]) / scale)
            continue
        powers = scale ** -np.arange(group.size + 1)
        difference = (np.poly(got - centre) - np.poly(wanted - centre)) * powers
        residual = max(residual, float(np.abs(difference).max()))
    return residual, achieved
