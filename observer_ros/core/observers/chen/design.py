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
Chen's reduced-order observer through a Sylvester equation.

Choose ``F`` ``(n-p, n-p)`` Hurwitz with the desired poles and no eigenvalue shared with
``A``, and ``L`` ``(n-p, p)`` with ``(F, L)`` controllable; solve ``T A - F T = L C``.
Then ``z' = F z + T B u + L y`` tracks ``T x`` with error dynamics ``F`` and
``x_hat = [C; T]^-1 [y; z]``.

Without a given ``L`` the design picks ``F``, ``L`` and ``T`` together so that ``T`` has
orthonormal rows (:func:`orthonormal_chen`); the seed notes' recipe, a diagonal ``F`` and a
random ``L`` (:func:`real_block_matrix`,
:func:`~observer_ros.core.observers.chen.sylvester.default_chen_gain`), is what a given
``L`` is used with. With one output both give the same observer in another basis, and the same
observer-controller ``G_oc``, but the recipe's ``[C; T]`` is far worse conditioned. Those
constructions and the checked solution of the Sylvester equation are
:mod:`observer_ros.core.observers.chen.sylvester`; this module is the design that uses them.
"""

from dataclasses import dataclass

import numpy as np

from observer_ros.core.analysis import require_seen
from observer_ros.core.design.common import (
    ObserverDesign, ObserverRealization, require_stable_poles)
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.flat_matrices import matrix_from_flat
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers.chen.sylvester import (
    _checked_inverse, _require_separated, DEFAULT_SEED, orthonormal_chen, real_block_matrix,
    solve_chen)
from observer_ros.core.placement_checks import placement_residual, sort_poles
from observer_ros.core.poles import clean_poles


@dataclass(frozen=True)
class ChenDesign(ObserverDesign):
    """
    Chen observer design: :class:`ObserverDesign` plus ``F``, ``T`` and ``[C; T]^-1``.

    Attributes
    ----------
    gain : numpy.ndarray, shape (n - p, p)
        ``L``.
    f : numpy.ndarray, shape (n - p, n - p)
        ``F``, real, with the requested poles as eigenvalues.
    t : numpy.ndarray, shape (n - p, n)
        ``T``, the solution of ``T A - F T = L C``.
    inverse : numpy.ndarray, shape (n, n)
        ``[C; T]^-1``.
    condition : float
        Condition number of ``[C; T]``.

    Notes
    -----
    The other attributes are those of :class:`ObserverDesign`. With a given ``L``, ``f`` is
    block diagonal (:func:`real_block_matrix`); otherwise ``f`` is lower block triangular and
    ``t`` has orthonormal rows (:func:`orthonormal_chen`).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices(
    ...     [[0, 1, 0], [0, 0, 1], [-6, -11, -6]], [[0], [0], [1]], [[1, 0, 0]])
    >>> design = oc.design_chen(model, poles=[-4, -5])
    >>> design.f.shape, design.t.shape, design.inverse.shape, bool(design.condition < 1e10)
    ((2, 2), (2, 3), (3, 3), True)

    """

    f: np.ndarray
    t: np.ndarray
    inverse: np.ndarray
    condition: float


def design_chen(model: StateSpaceModel, poles, gain=None,
                seed: int = DEFAULT_SEED) -> ChenDesign:
    """
    Design Chen's reduced-order observer of order ``n - p``.

    Parameters
    ----------
    model : StateSpaceModel
    poles : array_like of complex, shape (n - p,)
        Eigenvalues of ``F``.
    gain : array_like, shape (n - p, p) or flat, optional
        ``L``, used with the block-diagonal ``F`` of :func:`real_block_matrix`. When
        omitted, ``F``, ``L`` and ``T`` come from :func:`orthonormal_chen` (``T`` with
        orthonormal rows), chosen for the conditioning of ``[C; T]``.
    seed : int
        With several outputs, seeds the candidate choices of :func:`orthonormal_chen`; with
        one output (or a given ``L``) it changes nothing.

    Returns
    -------
    ChenDesign

    Raises
    ------
    ConfigError
        ``poles`` of the wrong count, ``gain`` of the wrong size.
    DesignError
        Naming ``C`` (not of full row rank ``p < n``), ``poles`` (unstable, or shared with
        ``A``), ``gain`` (``(F, L)`` uncontrollable) or ``seed`` (no controllable random
        ``L``); unnamed for an unobservable pair or an ill-conditioned ``[C; T]``.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices(
    ...     [[0, 1, 0], [0, 0, 1], [-6, -11, -6]], [[0], [0], [1]], [[1, 0, 0]])
    >>> design = oc.design_chen(model, poles=[-4, -5])
    >>> design.order, design.gain.shape, design.achieved_poles.round(6).tolist()
    (2, (2, 1), [(-5+0j), (-4+0j)])
    >>> oc.design_chen(model, poles=[-4])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: poles: a Chen observer ... expected 2 poles, got 1

    References
    ----------
    C.-T. Chen, Linear System Theory and Design, 3rd ed., section 8.4; :func:`orthonormal_chen`.

    """
    n_states, n_outputs = model.n_states, model.n_outputs
    n_reduced = n_states - n_outputs
    if np.linalg.matrix_rank(model.c) < n_outputs or n_reduced < 1:
        raise DesignError(
            f'a Chen observer needs C of full row rank p < n (p = {n_outputs}, '
            f'n = {n_states}, rank {np.linalg.matrix_rank(model.c)})', parameter='C')
    poles = clean_poles(np.atleast_1d(np.asarray(poles, dtype=complex)))
    if poles.size != n_reduced:
        raise ConfigError(
            'poles', f'a Chen observer of this model has order n - p = {n_reduced}: '
            f'expected {n_reduced} poles, got {poles.size}')
    require_stable_poles(poles, model.is_discrete, 'poles')
    require_seen(model)
    if gain is None:
        _require_separated(model.a, np.diag(poles))
        # (F, L) is controllable by construction: a left eigenvector w of F with w L = 0
        # would make w T a left eigenvector of A for an eigenvalue of F, and T has full rank.
        f, gain, t = orthonormal_chen(model.a, model.c, poles, seed)
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(f)) and np.all(np.isfinite(gain))):
            raise DesignError('the Sylvester equation T A - F T = L C has no solution with '
                              'orthonormal rows for these poles; give the gain L',
                              parameter='poles')
        inverse, condition, residual = _checked_inverse(model.a, model.c, f, gain, t)
        method = ('sylvester (orthonormal T)' if n_outputs == 1 else
                  f'sylvester (orthonormal T, seed {seed})')
    else:
        f = real_block_matrix(poles)
        gain = matrix_from_flat('gain', np.ravel(gain), n_reduced, n_outputs)
        method = 'sylvester (given L)'
        t, inverse, condition, residual = solve_chen(model.a, model.c, f, gain)
    pole_residual, achieved = placement_residual(f, poles)
    residual = max(residual, pole_residual)
    realization = ObserverRealization(
        a=f, b_y=gain, b_u=t @ model.b - gain @ model.d, c=inverse[:, n_outputs:],
        d_y=inverse[:, :n_outputs], d_u=-inverse[:, :n_outputs] @ model.d)
    return ChenDesign(
        kind='chen', model=model, gain=gain, requested_poles=sort_poles(poles),
        achieved_poles=achieved, method=method, residual=residual, realization=realization,
        f=f, t=t, inverse=inverse, condition=condition)
