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
Chen's Sylvester equation ``T A - F T = L C``: its solution, checked, and the choice of F, L.

:func:`solve_chen` solves it for a given ``F`` and ``L`` and checks what the observer needs
(``F`` and ``A`` share no eigenvalue, ``(F, L)`` controllable, ``[C; T]`` well enough
conditioned to invert). The seed notes' recipe picks a block-diagonal ``F``
(:func:`real_block_matrix`) and a random ``L`` (:func:`default_chen_gain`);
:func:`orthonormal_chen` picks ``F``, ``L`` and ``T`` together so that ``T`` has orthonormal
rows. The design that uses them is :func:`~observer_ros.core.observers.chen.design.design_chen`.
"""

import numpy as np
import scipy.linalg

from observer_ros.core.errors import DesignError
from observer_ros.core.placement_checks import REPEATED_RTOL, sort_poles
from observer_ros.core.poles import clean_poles
from observer_ros.core.ranks import format_modes, pbh_lost_modes


#: Largest accepted condition number of ``[C; T]``.
MAX_CONDITION = 1e10

#: Smallest accepted distance (relative) between an eigenvalue of F and one of A.
MIN_SEPARATION = 1e-8

#: Seed of the random choices (``L`` of :func:`default_chen_gain`, the free part of the rows
#: of :func:`orthonormal_chen` with several outputs), so designs are reproducible.
DEFAULT_SEED = 0

#: Constructions tried by :func:`orthonormal_chen` with several outputs (the best is kept).
CANDIDATES = 4


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
    >>> from observer_ros.core.observers.chen.sylvester import real_block_matrix
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


def _require_separated(a: np.ndarray, f: np.ndarray) -> None:
    eig_a = np.linalg.eigvals(a)
    eig_f = np.linalg.eigvals(f)
    gaps = np.abs(eig_f[:, None] - eig_a[None, :]) / np.maximum(1.0, np.abs(eig_a))[None, :]
    if gaps.size and gaps.min() < MIN_SEPARATION:
        shared = eig_f[np.argwhere(gaps < MIN_SEPARATION)[:, 0]]
        raise DesignError(
            f'Chen observer poles {format_modes(shared)} coincide with eigenvalues of A; the '
            f'Sylvester equation T A - F T = L C has no unique solution', parameter='poles')


def _checked_inverse(a, c, f, gain, t):
    """``([C; T]^-1, condition, residual)``, refusing an ill-conditioned ``[C; T]``."""
    stacked = np.vstack([c, t])
    condition = float(np.linalg.cond(stacked))
    if not np.isfinite(condition) or condition > MAX_CONDITION:
        raise DesignError(
            f'[C; T] is ill-conditioned (condition number {condition:.3g} > '
            f'{MAX_CONDITION:.0g}): x_hat = [C; T]^-1 [y; z] would amplify errors; choose '
            f'another L or poles')
    residual = float(np.linalg.norm(t @ a - f @ t - gain @ c) / max(
        1.0, np.linalg.norm(t) * np.linalg.norm(a) + np.linalg.norm(f) * np.linalg.norm(t)
        + np.linalg.norm(gain @ c)))
    return np.linalg.inv(stacked), condition, residual


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
    _require_separated(a, f)
    if pbh_lost_modes(f.T, gain.T):
        raise DesignError(
            '(F, L) is not controllable, so [C; T] would be singular; choose another L',
            parameter='gain')
    try:
        t = scipy.linalg.solve_sylvester(-f, a, gain @ c)
    except (np.linalg.LinAlgError, ValueError) as e:
        raise DesignError(f'the Sylvester equation T A - F T = L C failed: {e}') from e
    inverse, condition, residual = _checked_inverse(a, c, f, gain, t)
    return t, inverse, condition, residual


def _pole_groups(poles: np.ndarray) -> list:
    """One entry per real pole and per conjugate pair (the member with positive imag)."""
    return [pole for pole in sort_poles(clean_poles(poles)) if pole.imag >= 0]


def orthonormal_chen(a: np.ndarray, c: np.ndarray, poles, seed: int = DEFAULT_SEED):
    """
    Solve ``T A - F T = L C`` for ``F``, ``L`` and a ``T`` with orthonormal rows.

    Chen's ``F`` and ``L`` are free up to ``F`` having the wanted eigenvalues and ``(F, L)``
    being controllable; with one output every choice is the same observer in another basis
    (``F -> S F S^-1``, ``L -> S L``, ``T -> S T``), so the observer-controller does not
    depend on it, but the numerics do: a diagonal ``F`` with a random ``L`` gives rows
    ``t_i ~ C (A - mu_i I)^-1`` that are nearly parallel for clustered poles, and
    ``cond([C; T])`` reaches 1e8 at ten states. Here the rows are built one pole at a time
    (in the spirit of the orthogonal Sylvester-observer algorithms): row ``i`` solves
    ``t_i (A - mu_i I) = l_i C + sum_{j<i} f_ij t_j`` with the coefficients chosen so that
    ``t_i`` is orthogonal to the rows before it, and is then normalised. ``F`` comes out
    lower (block) triangular with the poles on its diagonal (2 x 2 blocks for conjugate
    pairs), ``T`` with orthonormal rows, so ``[C; T]`` is as well conditioned as the angle
    between ``C`` and the observer's subspace allows.

    Parameters
    ----------
    a : numpy.ndarray, shape (n, n)
    c : numpy.ndarray, shape (p, n)
    poles : array_like of complex, shape (n - p,)
        Eigenvalues of ``F``, conjugate pairs complete; none an eigenvalue of ``a``.
    seed : int
        With several outputs each row leaves a ``p``-dimensional choice: ``CANDIDATES``
        constructions draw it from a generator seeded with ``seed`` and the one with the
        smallest ``cond([C; T])`` is kept. With one output there is no choice (the rows are
        unique up to sign) and the seed changes nothing.

    Returns
    -------
    f : numpy.ndarray, shape (n - p, n - p)
    gain : numpy.ndarray, shape (n - p, p)
        ``L``.
    t : numpy.ndarray, shape (n - p, n)

    References
    ----------
    Orthogonal algorithms for the Sylvester-observer equation: P. Van Dooren, Systems &
    Control Letters 4 (1984); B. N. Datta and Y. Saad (1991), an Arnoldi method.

    """
    rng = np.random.default_rng(seed)
    schur = scipy.linalg.schur(np.asarray(a, dtype=complex), output='complex')
    best, best_condition = None, np.inf
    for _ in range(1 if c.shape[0] == 1 else CANDIDATES):
        candidate = _orthonormal_rows(schur, c, poles, rng)
        condition = np.linalg.cond(np.vstack([c, candidate[2]]))
        if best is None or condition < best_condition:
            best, best_condition = candidate, condition
    return best


def _orthonormal_rows(schur_form, c, poles, rng):
    """
    One construction of :func:`orthonormal_chen` from ``A = U S U^H``.

    The rows are kept in Schur coordinates too (``t U``; ``U`` is unitary, so inner products
    are the same), which makes each pole one triangular solve.
    """
    schur, unitary = schur_form
    n_states, n_outputs = schur.shape[0], c.shape[0]
    n_reduced = n_states - n_outputs
    lower = np.ascontiguousarray(schur.T)
    identity = np.eye(n_states)
    f = np.zeros((n_reduced, n_reduced))
    gain = np.zeros((n_reduced, n_outputs))
    t = np.zeros((n_reduced, n_states))
    # [C; T] U, filled as the rows are built.
    basis = np.zeros((n_outputs + n_reduced, n_states), dtype=complex)
    basis[:n_outputs] = c @ unitary
    done = 0
    for pole in _pole_groups(poles):
        rows = n_outputs + done
        # w = [C; T] (A - pole I)^-1 U, from w (S - pole I) = [C; T] U.
        w = scipy.linalg.solve_triangular(lower - pole * identity, basis[:rows].T,
                                          lower=True, check_finite=False).T
        norms = np.maximum(np.linalg.norm(w, axis=1), 1e-300)
        w = w / norms[:, None]
        # Combinations v with (v w) orthogonal to the rows already built: the left null
        # space of M = w (T U)^H, of dimension p (v M = 0 for the conjugated trailing
        # columns of U_M in M = U_M S V^H). For a real pole M is real, and so is v.
        if done:
            product = w @ basis[n_outputs:rows].conj().T
            if pole.imag == 0:
                product = product.real
            null = np.linalg.svd(product)[0][:, done:].conj()
        else:
            null = np.eye(rows)
        mix = np.ones(1) if n_outputs == 1 else rng.standard_normal(n_outputs)
        v = null @ mix
        row = (v @ w) @ unitary.conj().T
        v = v / norms
        if pole.imag == 0:
            row = row.real
            size = np.linalg.norm(row)
            t[done] = row / size
            basis[rows] = t[done] @ unitary
            gain[done] = v[:n_outputs] / size
            f[done, :done] = v[n_outputs:] / size
            f[done, done] = pole.real
            done += 1
            continue
        # Conjugate pair sigma + j omega: the rows x = [Re; Im] of row satisfy
        # x A - [[sigma, -omega], [omega, sigma]] x = [Re; Im] of (v basis); with x = R^T Q
        # (Q orthonormal rows) the block and the coefficients change basis by R^-T.
        x = np.vstack([row.real, row.imag])
        coefficients = np.vstack([v.real, v.imag])
        block = np.array([[pole.real, -pole.imag], [pole.imag, pole.real]])
        q, r = np.linalg.qr(x.T)
        to_q = np.linalg.inv(r.T)
        coefficients = to_q @ coefficients
        t[done:done + 2] = q.T
        basis[rows:rows + 2] = q.T @ unitary
        gain[done:done + 2] = coefficients[:, :n_outputs]
        f[done:done + 2, :done] = coefficients[:, n_outputs:]
        f[done:done + 2, done:done + 2] = to_q @ block @ r.T
        done += 2
    return f, gain, t


__all__ = ['CANDIDATES', 'DEFAULT_SEED', 'MAX_CONDITION', 'MIN_SEPARATION',
           'default_chen_gain', 'orthonormal_chen', 'real_block_matrix', 'solve_chen']
