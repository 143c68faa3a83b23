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
"""

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from observer_ros.core.analysis import format_modes, pbh_lost_modes, require_observable
from observer_ros.core.design.common import (
    ObserverDesign, ObserverRealization, require_stable_poles)
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.model import matrix_from_flat, StateSpaceModel
from observer_ros.core.placement import placement_residual, REPEATED_RTOL, sort_poles
from observer_ros.core.poles import clean_poles

#: Largest accepted condition number of ``[C; T]``.
MAX_CONDITION = 1e10

#: Smallest accepted distance (relative) between an eigenvalue of F and one of A.
MIN_SEPARATION = 1e-8

#: Seed of the random ``L`` when none is given, so designs are reproducible.
DEFAULT_SEED = 0


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

    The other attributes are those of :class:`ObserverDesign`.

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


def real_block_matrix(poles) -> np.ndarray:
    """
    Real matrix with the given eigenvalues, block diagonal.

    Real poles give ``[lambda]``, conjugate pairs ``sigma +- j omega`` give
    ``[[sigma, omega], [-omega, sigma]]``, and repeated poles are chained as (real) Jordan
    blocks, so that a single column ``L`` can still make ``(F, L)`` controllable.

    Parameters
    ----------
    poles : array_like of complex, shape (q,)
        Conjugate pairs complete.

    Returns
    -------
    numpy.ndarray, shape (q, q)

    Examples
    --------
    >>> from observer_ros.core.design.chen import real_block_matrix
    >>> print(real_block_matrix([-1 + 2j, -1 - 2j, -3]))
    [[-3.  0.  0.]
     [ 0. -1.  2.]
     [ 0. -2. -1.]]

    """
    poles = sort_poles(clean_poles(poles))
    blocks = []
    previous = None
    for pole in poles:
        if pole.imag < 0:
            continue
        size = 1 if pole.imag == 0 else 2
        if pole.imag == 0:
            block = np.array([[pole.real]])
        else:
            block = np.array([[pole.real, pole.imag], [-pole.imag, pole.real]])
        chained = previous is not None and abs(pole - previous) <= REPEATED_RTOL * max(
            1.0, abs(pole))
        blocks.append((block, size, chained))
        previous = pole
    total = sum(size for _, size, _ in blocks)
    matrix = np.zeros((total, total))
    offset = 0
    for block, size, chained in blocks:
        matrix[offset:offset + size, offset:offset + size] = block
        if chained:
            matrix[offset - size:offset, offset:offset + size] = np.eye(size)
        offset += size
    return matrix


def default_chen_gain(f: np.ndarray, n_outputs: int, seed: int = DEFAULT_SEED) -> np.ndarray:
    """
    Draw a reproducible random ``L`` ``(n-p, p)`` with ``(F, L)`` controllable.

    Controllability is checked mode by mode (PBH): the rank of the Krylov matrix
    ``[L, F L, ...]`` is numerically meaningless beyond a dozen states.
    """
    rng = np.random.default_rng(seed)
    for _ in range(20):
        gain = rng.uniform(0.1, 1.0, size=(f.shape[0], n_outputs))
        if not pbh_lost_modes(f.T, gain.T):
            return gain
    raise DesignError('could not draw an L making (F, L) controllable; give a gain or '
                      'another seed', parameter='seed')


def solve_chen(a: np.ndarray, c: np.ndarray, f: np.ndarray, gain: np.ndarray):
    """
    Solve ``T A - F T = L C`` and return ``(T, [C; T]^-1, condition, residual)``.

    Raises
    ------
    DesignError
        Naming ``poles`` (the eigenvalues of ``F``) when ``F`` and ``A`` share an eigenvalue,
        ``gain`` when ``(F, L)`` is uncontrollable; unnamed when ``[C; T]`` is singular or
        ill-conditioned.

    """
    eig_a = np.linalg.eigvals(a)
    eig_f = np.linalg.eigvals(f)
    gaps = np.abs(eig_f[:, None] - eig_a[None, :]) / np.maximum(1.0, np.abs(eig_a))[None, :]
    if gaps.size and gaps.min() < MIN_SEPARATION:
        shared = eig_f[np.argwhere(gaps < MIN_SEPARATION)[:, 0]]
        raise DesignError(
            f'Chen observer poles {format_modes(shared)} coincide with eigenvalues of A; '
            f'the Sylvester equation T A - F T = L C has no unique solution', parameter='poles')
    if pbh_lost_modes(f.T, gain.T):
        raise DesignError(
            '(F, L) is not controllable, so [C; T] would be singular; choose another L',
            parameter='gain')
    try:
        t = scipy.linalg.solve_sylvester(-f, a, gain @ c)
    except (np.linalg.LinAlgError, ValueError) as e:
        raise DesignError(f'the Sylvester equation T A - F T = L C failed: {e}') from e
    stacked = np.vstack([c, t])
    condition = float(np.linalg.cond(stacked))
    if not np.isfinite(condition) or condition > MAX_CONDITION:
        raise DesignError(
            f'[C; T] is ill-conditioned (condition number {condition:.3g} > '
            f'{MAX_CONDITION:.0g}): x_hat = [C; T]^-1 [y; z] would amplify errors; choose '
            f'another L or poles')
    residual = float(np.linalg.norm(t @ a - f @ t - gain @ c) / max(
        1.0, np.linalg.norm(t) * np.linalg.norm(a) + np.linalg.norm(gain @ c)))
    return t, np.linalg.inv(stacked), condition, residual


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
        ``L``; a reproducible random one (``seed``) when omitted.
    seed : int
        Seed of the random ``L``.

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
    C.-T. Chen, Linear System Theory and Design, 3rd ed., section 8.4.

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
    require_observable(model.a, model.c)
    f = real_block_matrix(poles)
    if gain is None:
        gain = default_chen_gain(f, n_outputs, seed)
        method = f'sylvester (random L, seed {seed})'
    else:
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
