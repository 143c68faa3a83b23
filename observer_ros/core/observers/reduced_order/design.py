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
Reduced-order (Luenberger / Ogata) observer in the partitioned form of the course notes.

In coordinates ``w = Q x = [x_a; x_b]`` where the measured part comes first
(``x_a = y - D u``), the observer estimates only ``x_b``::

    eta' = (Abb - L Aab) eta + [(Abb - L Aab) L + Aba - L Aaa] y + (Bb - L Ba) u
    x_b_hat = eta + L y

and ``x_hat = Q^-1 [y; x_b_hat]``. ``Q`` is, by default, ``[C; N^T]`` with ``N`` an
orthonormal basis of the null space of ``C`` (the natural permutation of the states when
``C`` selects states), or the observability matrix for a single output (``'observability'``,
the transformation the worked examples use).
"""

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from observer_ros.core.analysis import require_seen
from observer_ros.core.design.common import (
    check_given_gain_stable, ObserverDesign, ObserverRealization, require_stable_poles)
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.flat_matrices import matrix_from_flat
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement import place_observer
from observer_ros.core.ranks import observability_matrix

COORDINATES = ('orthonormal', 'observability')

#: Largest accepted condition number of the coordinate transformation ``Q``.
MAX_TRANSFORM_CONDITION = 1e10


@dataclass(frozen=True)
class Partition:
    """Blocks of ``Q A Q^-1`` and ``Q B`` with the ``p`` measured coordinates first."""

    aaa: np.ndarray
    aab: np.ndarray
    aba: np.ndarray
    abb: np.ndarray
    ba: np.ndarray
    bb: np.ndarray


@dataclass(frozen=True)
class ReducedOrderDesign(ObserverDesign):
    """
    Reduced-order observer design: :class:`ObserverDesign` plus the partitioned matrices.

    Attributes
    ----------
    transform : numpy.ndarray, shape (n, n)
        ``Q`` with ``w = Q x``; its first ``p`` rows are ``C``.
    partition : Partition
        The blocks in ``w`` coordinates.
    a_hat, b_hat, f_hat : numpy.ndarray
        ``Abb - L Aab`` ``(n-p, n-p)``, ``a_hat L + Aba - L Aaa`` ``(n-p, p)`` and
        ``Bb - L Ba`` ``(n-p, m)``: ``eta' = a_hat eta + b_hat y + f_hat u``.
    c_hat, d_hat : numpy.ndarray
        ``w_hat = c_hat eta + d_hat y``: ``[0; I]`` ``(n, n-p)`` and ``[I; L]`` ``(n, p)``.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> design = oc.design_reduced_order(model, poles=[-10])
    >>> design.order, design.gain.tolist(), design.a_hat.tolist()
    (1, [[10.0]], [[-10.0]])

    """

    transform: np.ndarray
    partition: Partition
    a_hat: np.ndarray
    b_hat: np.ndarray
    f_hat: np.ndarray
    c_hat: np.ndarray
    d_hat: np.ndarray


def _selected_states(c: np.ndarray):
    """Column index per row when every row of ``C`` is a multiple of a distinct unit row."""
    columns = []
    for row in c:
        nonzero = np.flatnonzero(row)
        if nonzero.size != 1:
            return None
        columns.append(int(nonzero[0]))
    return columns if len(set(columns)) == len(columns) else None


def measured_first_transform(model: StateSpaceModel,
                             coordinates: str = 'orthonormal') -> np.ndarray:
    """
    Coordinate change ``Q`` (``w = Q x``) whose first ``p`` rows are ``C``.

    Parameters
    ----------
    model : StateSpaceModel
        ``C`` must have full row rank ``p < n``.
    coordinates : {'orthonormal', 'observability'}
        ``'orthonormal'``: ``[C; N^T]``, ``N`` an orthonormal basis of ``null(C)``, taken
        as the unselected unit vectors when ``C`` selects states (keeping their order).
        ``'observability'``: the observability matrix (single output only).

    Returns
    -------
    numpy.ndarray, shape (n, n)

    Raises
    ------
    DesignError
        Naming ``C`` when it is rank deficient or leaves nothing to estimate; naming
        ``coordinates`` (``C`` for ``'orthonormal'``) when ``Q`` is ill-conditioned.
    ConfigError
        Naming ``coordinates``: unknown, or ``'observability'`` with several outputs.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices(
    ...     [[0, 1, 0], [0, 0, 1], [-1, -2, -3]], [[0], [0], [1]], [[0, 1, 0]])
    >>> print(oc.measured_first_transform(model))
    [[0. 1. 0.]
     [1. 0. 0.]
     [0. 0. 1.]]

    """
    c = model.c
    n_states, n_outputs = model.n_states, model.n_outputs
    if coordinates not in COORDINATES:
        raise ConfigError(
            'coordinates', f'expected one of {", ".join(COORDINATES)}, got {coordinates!r}')
    rank = np.linalg.matrix_rank(c)
    if rank < n_outputs:
        raise DesignError(
            f'a reduced-order observer needs C of full row rank p = {n_outputs}, '
            f'got rank {rank}; remove the redundant outputs', parameter='C')
    if n_outputs >= n_states:
        raise DesignError(
            f'{n_outputs} outputs measure all {n_states} states; a reduced-order '
            f'observer has nothing to estimate', parameter='C')
    if coordinates == 'observability':
        if n_outputs != 1:
            raise ConfigError(
                'coordinates',
                f"'observability' coordinates need a single output, the model has {n_outputs}")
        transform = observability_matrix(model.a, c)
    else:
        selected = _selected_states(c)
        if selected is not None:
            rest = [j for j in range(n_states) if j not in selected]
            complement = np.eye(n_states)[rest]
        else:
            complement = scipy.linalg.null_space(c).T
        transform = np.vstack([c, complement])
    condition = np.linalg.cond(transform)
    if not np.isfinite(condition) or condition > MAX_TRANSFORM_CONDITION:
        hint = "; try coordinates='orthonormal'" if coordinates == 'observability' else ''
        raise DesignError(
            f'the coordinate change to measured-first form is ill-conditioned '
            f'(condition number {condition:.3g} > {MAX_TRANSFORM_CONDITION:.0g}){hint}',
            parameter='coordinates' if coordinates == 'observability' else 'C')
    return transform


def partition_model(model: StateSpaceModel, transform: np.ndarray) -> Partition:
    """
    Split ``Q A Q^-1`` and ``Q B`` into measured (``a``) and unmeasured (``b``) blocks.

    Parameters
    ----------
    model : StateSpaceModel
    transform : numpy.ndarray, shape (n, n)
        ``Q`` from :func:`measured_first_transform`.

    Returns
    -------
    Partition
        ``aaa`` ``(p, p)``, ``aab`` ``(p, n-p)``, ``aba`` ``(n-p, p)``, ``abb``
        ``(n-p, n-p)``, ``ba`` ``(p, m)``, ``bb`` ``(n-p, m)``.

    """
    p = model.n_outputs
    a_w = transform @ model.a @ np.linalg.inv(transform)
    b_w = transform @ model.b
    return Partition(aaa=a_w[:p, :p], aab=a_w[:p, p:], aba=a_w[p:, :p], abb=a_w[p:, p:],
                     ba=b_w[:p], bb=b_w[p:])


def design_reduced_order(model: StateSpaceModel, poles=None, gain=None,
                         coordinates: str = 'orthonormal',
                         method: str = 'auto') -> ReducedOrderDesign:
    """
    Design (or check) a reduced-order observer of order ``n - p``.

    Parameters
    ----------
    model : StateSpaceModel
    poles : array_like of complex, shape (n - p,), optional
        Poles of ``Abb - L Aab`` (s-plane, or z-plane for a discrete model).
    gain : array_like, shape (n - p, p) or flat, optional
        A given ``L`` (row-major when flat), checked for stability instead of designed.
    coordinates : {'orthonormal', 'observability'}
        See :func:`measured_first_transform`.
    method : str
        Placement method.

    Returns
    -------
    ReducedOrderDesign
        ``gain`` is ``L``, shape ``(n - p, p)``.

    Raises
    ------
    ConfigError
        ``gain`` of the wrong size, ``poles`` of the wrong count (or neither given),
        ``coordinates`` or ``method`` unknown.
    DesignError
        ``C`` unsuitable (see :func:`measured_first_transform`), unobservable pair,
        unstable ``poles`` or a ``gain`` leaving the error unstable.

    Examples
    --------
    Ogata's minimum-order observer of a third-order plant measured in its first state:

    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices(
    ...     [[0, 1, 0], [0, 0, 1], [-6, -11, -6]], [[0], [0], [1]], [[1, 0, 0]])
    >>> design = oc.design_reduced_order(model, poles=[-2 + 3.4641j, -2 - 3.4641j])
    >>> print(np.round(design.gain, 3))
    [[-2.]
     [17.]]

    References
    ----------
    K. Ogata, Modern Control Engineering, section on minimum-order observers;
    D. G. Luenberger, "Observers for multivariable systems", IEEE TAC 11(2), 1966.

    """
    transform = measured_first_transform(model, coordinates)
    blocks = partition_model(model, transform)
    n_reduced, n_outputs = model.n_states - model.n_outputs, model.n_outputs
    if gain is not None:
        gain = matrix_from_flat('gain', np.ravel(gain), n_reduced, n_outputs)
        achieved = check_given_gain_stable(blocks.abb - gain @ blocks.aab,
                                           model.is_discrete, 'gain')
        requested, method_used, residual = achieved, 'given', 0.0
    else:
        if poles is None:
            raise ConfigError('poles', 'expected the observer poles or a gain, got neither')
        poles = np.asarray(poles, dtype=complex)
        if poles.size != n_reduced:
            raise ConfigError(
                'poles',
                f'a reduced-order observer of this model has order n - p = {n_reduced}: '
                f'expected {n_reduced} poles, got {poles.size}')
        require_stable_poles(poles, model.is_discrete, 'poles')
        require_seen(model)
        result = place_observer(blocks.abb, blocks.aab, poles, method)
        gain, achieved = result.gain, result.achieved_poles
        requested, method_used, residual = result.requested_poles, result.method, result.residual
    a_hat = blocks.abb - gain @ blocks.aab
    b_hat = a_hat @ gain + blocks.aba - gain @ blocks.aaa
    f_hat = blocks.bb - gain @ blocks.ba
    c_hat = np.vstack([np.zeros((n_outputs, n_reduced)), np.eye(n_reduced)])
    d_hat = np.vstack([np.eye(n_outputs), gain])
    inverse = np.linalg.inv(transform)
    # The measured part is y - D u, so u also reaches x_hat and eta through D.
    realization = ObserverRealization(
        a=a_hat, b_y=b_hat, b_u=f_hat - b_hat @ model.d, c=inverse @ c_hat,
        d_y=inverse @ d_hat, d_u=-inverse @ d_hat @ model.d)
    return ReducedOrderDesign(
        kind='reduced_order', model=model, gain=gain, requested_poles=requested,
        achieved_poles=achieved, method=method_used, residual=residual,
        realization=realization, transform=transform, partition=blocks, a_hat=a_hat,
        b_hat=b_hat, f_hat=f_hat, c_hat=c_hat, d_hat=d_hat)
