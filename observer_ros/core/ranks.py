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
Observability and controllability ranks: the Kalman rank test, its conditioning, PBH modes.

The functions take the matrices themselves (``model.a, model.c``), so they work for any
pair; errors name them ``A``, ``B`` and ``C``. The observability rule that every design
asks (which modes are unseen, whether they decay, the error that says so) is in
:mod:`observer_ros.core.analysis`.
"""

from dataclasses import dataclass

import numpy as np

from observer_ros.core.errors import ConfigError, DesignError


#: Relative tolerance of the PBH test: a mode is lost when the smallest singular value of
#: ``[lambda I - A; C]`` is below this times ``max(1, ||[A; C]||)``. It sits near the square
#: root of machine precision because eigenvalues of defective matrices are only that accurate.
#: The same relative tolerance is the margin of the stability boundary in
#: :func:`~observer_ros.core.analysis.boundary_margin`.
PBH_RTOL = 1e-7


@dataclass(frozen=True)
class RankReport:
    """
    Kalman rank test of an observability or controllability matrix, plus PBH modes.

    Attributes
    ----------
    rank : int
        Numerical rank of the observability (controllability) matrix.
    n_states : int
    condition_number : float
        Ratio of its largest to its ``n``-th singular value (inf when rank deficient).
    lost_modes : tuple of complex
        Eigenvalues of ``A`` the outputs cannot see (the inputs cannot move), from the PBH
        test; the pair is observable (controllable) when it is empty.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> report = oc.observability([[1, 0], [0, 2]], [[1, 0]])
    >>> report.rank, report.full_rank, report.lost_modes
    (1, False, ((2+0j),))

    """

    rank: int
    n_states: int
    condition_number: float
    lost_modes: tuple

    @property
    def full_rank(self) -> bool:
        """Whether no mode is lost (the pair is observable / controllable)."""
        return not self.lost_modes


def _as_matrix(name: str, values) -> np.ndarray:
    """Return ``values`` as a 2-D float (or complex) array, or raise naming ``name``."""
    matrix = np.asarray(values)
    if matrix.dtype.kind not in 'fc':
        try:
            matrix = matrix.astype(float)
        except (TypeError, ValueError) as e:
            raise ConfigError(name, f'expected a matrix of numbers, got {values!r}') from e
    return np.atleast_2d(matrix)


def _pair(a, other, name: str, columns: bool) -> tuple[np.ndarray, np.ndarray]:
    """Check ``A`` square and ``other`` (``C``: n columns, ``B``: n rows); return arrays."""
    a, other = _as_matrix('A', a), _as_matrix(name, other)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ConfigError('A', f'expected a square matrix, got shape {a.shape}')
    n_states = a.shape[0]
    size = other.shape[1] if columns else other.shape[0]
    if other.ndim != 2 or size != n_states:
        where = f'p x {n_states}' if columns else f'{n_states} x m'
        raise ConfigError(name, f'expected a {where} matrix, got shape {other.shape}')
    return a, other


def observability_matrix(a, c) -> np.ndarray:
    """
    Return ``[C; C A; ...; C A^(n-1)]``.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)

    Returns
    -------
    numpy.ndarray, shape (n p, n)

    Raises
    ------
    ConfigError
        Naming ``A`` or ``C`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> print(oc.observability_matrix([[0, 1], [-2, -3]], [[1, 0]]))
    [[1. 0.]
     [0. 1.]]

    """
    a, c = _pair(a, c, 'C', columns=True)
    blocks = [c]
    for _ in range(a.shape[0] - 1):
        blocks.append(blocks[-1] @ a)
    return np.vstack(blocks)


def controllability_matrix(a, b) -> np.ndarray:
    """
    Return ``[B, A B, ..., A^(n-1) B]``.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)

    Returns
    -------
    numpy.ndarray, shape (n, n m)

    Raises
    ------
    ConfigError
        Naming ``A`` or ``B`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> print(oc.controllability_matrix([[0, 1], [-2, -3]], [[0], [1]]))
    [[ 0.  1.]
     [ 1. -3.]]

    """
    a, b = _pair(a, b, 'B', columns=False)
    return observability_matrix(a.T, b.T).T


def pbh_lost_modes(a, c, rtol: float = PBH_RTOL) -> tuple:
    """
    Eigenvalues of ``A`` that ``C`` cannot see (Popov-Belevitch-Hautus test).

    A mode ``lambda`` is unobservable when ``[lambda I - A; C]`` loses rank. Duality
    gives the uncontrollable modes of ``(A, B)`` as ``pbh_lost_modes(A.T, B.T)``.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)
    rtol : float
        Relative tolerance on the smallest singular value (see :data:`PBH_RTOL`).

    Returns
    -------
    tuple of complex
        One entry per distinct lost eigenvalue (conjugates both listed).

    Raises
    ------
    ConfigError
        Naming ``A`` or ``C`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.pbh_lost_modes([[1, 0], [0, 2]], [[1, 0]])
    ((2+0j),)
    >>> oc.pbh_lost_modes([[1, 0], [0, 2]], [[1, 1]])
    ()

    """
    a, c = _pair(a, c, 'C', columns=True)
    n_states = a.shape[0]
    scale = max(1.0, np.linalg.norm(np.vstack([a, c]), 2))
    lost = []
    for eigenvalue in np.linalg.eigvals(a):
        pencil = np.vstack([eigenvalue * np.eye(n_states) - a, c.astype(complex)])
        smallest = np.linalg.svd(pencil, compute_uv=False)[-1]
        if smallest <= rtol * scale and not any(
                abs(eigenvalue - seen) <= 1e-6 * max(1.0, abs(seen)) for seen in lost):
            lost.append(complex(eigenvalue))
    return tuple(lost)


def _report(matrix: np.ndarray, n_states: int, lost: tuple) -> RankReport:
    singular = np.linalg.svd(matrix, compute_uv=False)
    tol = max(matrix.shape) * np.finfo(float).eps * (singular[0] if singular.size else 0.0)
    rank = int(np.sum(singular > tol))
    condition = float(singular[0] / singular[n_states - 1]) if (
        singular.size >= n_states and singular[n_states - 1] > 0) else float('inf')
    return RankReport(rank=rank, n_states=n_states, condition_number=condition,
                      lost_modes=lost)


def observability(a, c) -> RankReport:
    """
    Rank and condition number of the observability matrix and the unobservable modes.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)

    Returns
    -------
    RankReport
        ``full_rank`` when ``(A, C)`` is observable.

    Raises
    ------
    ConfigError
        Naming ``A`` or ``C`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> report = oc.observability(model.a, model.c)
    >>> report.full_rank, report.rank, report.condition_number
    (True, 2, 1.0)

    """
    a, c = _pair(a, c, 'C', columns=True)
    return _report(observability_matrix(a, c), a.shape[0], pbh_lost_modes(a, c))


def controllability(a, b) -> RankReport:
    """
    Rank and condition number of the controllability matrix and the uncontrollable modes.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)

    Returns
    -------
    RankReport
        ``full_rank`` when ``(A, B)`` is controllable.

    Raises
    ------
    ConfigError
        Naming ``A`` or ``B`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> report = oc.controllability([[-1, 0], [0, -2]], [[1], [0]])
    >>> report.full_rank, report.lost_modes
    (False, ((-2+0j),))

    """
    a, b = _pair(a, b, 'B', columns=False)
    return _report(controllability_matrix(a, b), a.shape[0], pbh_lost_modes(a.T, b.T))


def format_modes(modes) -> str:
    """
    Format eigenvalues compactly: ``-2, 1+3j``.

    Examples
    --------
    >>> from observer_ros.core.ranks import format_modes
    >>> format_modes([-2, 1 + 3j, 1 - 3j])
    '-2, 1+3j, 1-3j'

    """
    def one(value: complex) -> str:
        value = complex(value)
        if abs(value.imag) <= 1e-12 * max(1.0, abs(value)):
            return f'{value.real:.6g}'
        return f'{value.real:.6g}{value.imag:+.6g}j'
    return ', '.join(one(mode) for mode in modes)


def require_controllable(a, b, what: str = '(A, B)') -> RankReport:
    """
    Return the controllability report, or raise DesignError listing the lost modes.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)
    what : str
        How the message names the pair.

    Returns
    -------
    RankReport

    Raises
    ------
    DesignError
        Without a ``parameter`` (the pair as a whole is at fault), when a mode is lost.
    ConfigError
        Naming ``A`` or ``B`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.require_controllable([[0, 1], [0, 0]], [[0], [1]]).full_rank
    True

    """
    report = controllability(a, b)
    if not report.full_rank:
        raise DesignError(
            f'{what} is not controllable: the modes {format_modes(report.lost_modes)} cannot '
            f'be moved by the inputs (PBH test; controllability matrix rank '
            f'{report.rank} of {report.n_states}); no state feedback can place their poles')
    return report
