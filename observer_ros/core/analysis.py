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

"""Observability and controllability: ranks, conditioning and the PBH test for lost modes."""

from dataclasses import dataclass

import numpy as np

from observer_ros.core.errors import DesignError

#: Relative tolerance of the PBH test: a mode is lost when the smallest singular value of
#: ``[lambda I - A; C]`` is below this times ``max(1, ||[A; C]||)``. It sits near the square
#: root of machine precision because eigenvalues of defective matrices are only that accurate.
PBH_RTOL = 1e-7


@dataclass(frozen=True)
class RankReport:
    """Kalman rank test of an observability or controllability matrix, plus PBH modes."""

    rank: int
    n_states: int
    condition_number: float
    lost_modes: tuple

    @property
    def full_rank(self) -> bool:
        """Whether no mode is lost (the pair is observable / controllable)."""
        return not self.lost_modes


def observability_matrix(a: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Return ``[C; C A; ...; C A^(n-1)]``, shape ``(n p, n)``."""
    blocks = [c]
    for _ in range(a.shape[0] - 1):
        blocks.append(blocks[-1] @ a)
    return np.vstack(blocks)


def controllability_matrix(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Return ``[B, A B, ..., A^(n-1) B]``, shape ``(n, n m)``."""
    return observability_matrix(a.T, b.T).T


def pbh_lost_modes(a: np.ndarray, c: np.ndarray, rtol: float = PBH_RTOL) -> tuple:
    """
    Eigenvalues of ``A`` that ``C`` cannot see (Popov-Belevitch-Hautus test).

    A mode ``lambda`` is unobservable when ``[lambda I - A; C]`` loses rank. Duality
    gives the uncontrollable modes of ``(A, B)`` as ``pbh_lost_modes(A.T, B.T)``.

    Returns
    -------
    tuple of complex
        One entry per distinct lost eigenvalue (conjugates both listed).

    """
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


def observability(a: np.ndarray, c: np.ndarray) -> RankReport:
    """Rank and condition number of the observability matrix and the unobservable modes."""
    return _report(observability_matrix(a, c), a.shape[0], pbh_lost_modes(a, c))


def controllability(a: np.ndarray, b: np.ndarray) -> RankReport:
    """Rank and condition number of the controllability matrix and the uncontrollable modes."""
    return _report(controllability_matrix(a, b), a.shape[0], pbh_lost_modes(a.T, b.T))


def format_modes(modes) -> str:
    """Format eigenvalues compactly: ``-2, 1+3j``."""
    def one(value: complex) -> str:
        value = complex(value)
        if abs(value.imag) <= 1e-12 * max(1.0, abs(value)):
            return f'{value.real:.6g}'
        return f'{value.real:.6g}{value.imag:+.6g}j'
    return ', '.join(one(mode) for mode in modes)


def require_observable(a: np.ndarray, c: np.ndarray, what: str = '(A, C)') -> RankReport:
    """Return the observability report, or raise DesignError listing the unobservable modes."""
    report = observability(a, c)
    if not report.full_rank:
        raise DesignError(
            f'{what} is not observable: the modes {format_modes(report.lost_modes)} cannot '
            f'be seen from the outputs (PBH test; observability matrix rank '
            f'{report.rank} of {report.n_states}); no observer can place their poles')
    return report


def require_controllable(a: np.ndarray, b: np.ndarray, what: str = '(A, B)') -> RankReport:
    """Return the controllability report, or raise DesignError listing the lost modes."""
    report = controllability(a, b)
    if not report.full_rank:
        raise DesignError(
            f'{what} is not controllable: the modes {format_modes(report.lost_modes)} cannot '
            f'be moved by the inputs (PBH test; controllability matrix rank '
            f'{report.rank} of {report.n_states}); no state feedback can place their poles')
    return report
