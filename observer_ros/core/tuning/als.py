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
Noise covariances from innovations: autocovariance least squares (ALS).

Stacking the innovation autocovariances ``C_0 .. C_(N-1)`` that a constant-gain filter
leaves (:mod:`observer_ros.core.tuning.noise_model`: linear in ``Q`` and ``R``) gives one
linear system in the free entries of ``Q`` and ``R`` (Odelson, Rajamani and Rawlings, 2006),
solved here in the least-squares sense with ``Q`` positive semidefinite and ``R`` positive
definite: the plain solution when it is one, else a semidefinite program (cvxpy with
Clarabel). A continuous model's ``Q`` is an intensity, mapped to ``Qd`` by Van Loan's
integral, which is linear in it, so the unknowns stay the user's own parameters.

The columns of that system say what the data can tell: an entry whose direction lies in the
system's null space is not identifiable (a full ``Q`` with fewer outputs than states usually
is not: the innovations only fix the output spectrum). :func:`autocovariance_least_squares`
names such entries; they take the least-norm value, which changes nothing the data can see
(the same filter gain and innovation covariance).

References
----------
B. J. Odelson, M. R. Rajamani and J. B. Rawlings, "A new autocovariance least-squares method
for estimating noise covariances", Automatica 42(2), 303-308, 2006.
"""

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
import scipy.linalg

from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.tuning.noise_model import (
    _measurement_response, _process_response, _stacked_observability, NoiseStructure,
    SampledFilter)

#: Row weightings of the ALS system: ``whitened`` (each lag block by ``S^-1/2``, the default)
#: or ``identity`` (as in the 2006 paper).
WEIGHTINGS = ('whitened', 'identity')

#: Singular values of the (column-scaled) ALS matrix below this fraction of the largest
#: span its null space: the directions no autocovariance can see.
RANK_TOLERANCE = 1e-9

#: A parameter whose unit direction has a null-space component above this is not
#: identifiable.
NULL_COMPONENT = 1e-6

#: Weight of the null-space directions in the semidefinite program: small, so the fit to
#: the autocovariances comes first and the unseen directions take the least norm.
NULL_WEIGHT = 1e-8


def _basis(size: int, row: int, column: int) -> np.ndarray:
    matrix = np.zeros((size, size))
    matrix[row, column] = matrix[column, row] = 1.0
    return matrix


@dataclass(frozen=True)
class AlsResult:
    """
    What :func:`autocovariance_least_squares` found.

    Attributes
    ----------
    process_noise, measurement_noise : numpy.ndarray, shapes (n, n) and (p, p)
        The estimates (``Q`` an intensity for a continuous model), PSD and PD.
    unidentifiable : tuple of str
        Entries the autocovariances cannot fix, as ``Q[name,name]`` (least-norm values).
    rank, n_parameters : int
        Rank of the ALS system and its number of free entries.
    singular_values : numpy.ndarray
        Of the column-scaled ALS matrix.
    residual : float
        ``||A x - b|| / ||b||`` at the estimate.
    method : str
        ``'least squares'`` (already PSD) or ``'semidefinite least squares'``.
    lags : int

    Examples
    --------
    See :func:`autocovariance_least_squares`; ``result.unidentifiable`` is empty when every
    free entry is fixed by the data:

    >>> import numpy as np
    >>> from observer_ros.core.tuning.noise_model import (
    ...     innovation_autocovariances, NoiseStructure, SampledFilter)
    >>> sampled = SampledFilter(np.array([[0.9]]), np.array([[1.0]]), np.array([[0.5]]), 0.1)
    >>> exact = innovation_autocovariances(sampled, [[0.1]], [[0.2]], 4)
    >>> result = autocovariance_least_squares(exact, sampled, NoiseStructure.build(1, 1))
    >>> result.unidentifiable, round(float(result.measurement_noise[0, 0]), 9)
    ((), 0.2)

    """

    process_noise: np.ndarray
    measurement_noise: np.ndarray
    unidentifiable: tuple
    rank: int
    n_parameters: int
    singular_values: np.ndarray
    residual: float
    method: str
    lags: int


def _label(key: tuple, state_names: Sequence[str], output_names: Sequence[str]) -> str:
    symbol, row, column = key
    names = state_names if symbol == 'Q' else output_names
    return f'{symbol}[{names[row]},{names[column]}]'


def autocovariance_least_squares(autocovariances, sampled: SampledFilter,
                                 structure: NoiseStructure,
                                 state_names: Optional[Sequence[str]] = None,
                                 output_names: Optional[Sequence[str]] = None,
                                 weighting: str = 'whitened') -> AlsResult:
    """
    Estimate ``Q`` and ``R`` from the innovation autocovariances of a running filter.

    Parameters
    ----------
    autocovariances : array_like, shape (lags, p, p)
        ``C_j = E[e[k+j] e[k]^T]`` estimated from the innovations
        (:meth:`~observer_ros.core.tuning.innovations.InnovationStatistics.autocovariances`).
    sampled : SampledFilter
        The filter that produced them.
    structure : NoiseStructure
        Free and known entries.
    state_names, output_names : sequence of str, optional
        For the names of entries in messages (default ``x1..``, ``y1..``).

    Returns
    -------
    AlsResult

    Raises
    ------
    ConfigError
        ``structure``: nothing free, or a structure other than a full ``Q`` leaves an entry
        the data cannot identify (named); ``measurement_noise``: the estimate of ``R`` is
        singular; ``autocovariances``: wrong shape or not finite.
    DesignError
        ``gain``: the filter is not stable.

    Examples
    --------
    The exact autocovariances of a suboptimal filter give back ``Q`` and ``R``:

    >>> import numpy as np
    >>> from observer_ros.core.model import StateSpaceModel
    >>> from observer_ros.core.tuning.noise_model import (
    ...     innovation_autocovariances, NoiseStructure, SampledFilter)
    >>> model = StateSpaceModel.from_matrices([[1, 0.1], [0, 0.9]], [[0], [0.1]], [[1, 0]],
    ...                                       dt=0.1)
    >>> sampled = SampledFilter(model.a, model.c, np.array([[0.5], [0.5]]), 0.1)
    >>> covariances = innovation_autocovariances(sampled, np.diag([1e-3, 4e-2]), [[0.01]], 8)
    >>> structure = NoiseStructure.build(2, 1, 'diagonal', 'full')
    >>> result = autocovariance_least_squares(covariances, sampled, structure)
    >>> np.round(np.diag(result.process_noise), 9).tolist(), result.unidentifiable
    ([0.001, 0.04], ())

    """
    sampled.check_stable()
    n_states, n_outputs = sampled.c.shape[1], sampled.c.shape[0]
    state_names = list(state_names or (f'x{i + 1}' for i in range(n_states)))
    output_names = list(output_names or (f'y{i + 1}' for i in range(n_outputs)))
    measured = np.asarray(autocovariances, dtype=float)
    if measured.ndim != 3 or measured.shape[1:] != (n_outputs, n_outputs):
        raise ConfigError('autocovariances', f'expected shape (lags, {n_outputs}, '
                          f'{n_outputs}), got {measured.shape}')
    if not np.isfinite(measured).all():
        raise ConfigError('autocovariances', 'expected finite values')
    lags = len(measured)
    keys = structure.parameters()
    if not keys:
        raise ConfigError('structure', 'nothing to estimate: every entry of Q and R is known')
    observability = _stacked_observability(sampled, lags)
    columns = []
    for symbol, row, column in keys:
        if symbol == 'Q':
            response = _process_response(sampled, observability, _basis(n_states, row, column))
        else:
            response = _measurement_response(sampled, observability,
                                             _basis(n_outputs, row, column))
        columns.append(response.ravel())
    matrix = np.column_stack(columns)
    known = (_process_response(sampled, observability, structure.process_known)
             + _measurement_response(sampled, observability, structure.measurement_known))
    target = (measured - known).ravel()
    if weighting not in WEIGHTINGS:
        raise ConfigError('weighting', f'expected one of {", ".join(WEIGHTINGS)}, got '
                          f'{weighting!r}')
    if weighting == 'whitened':
        weights = _whitening(measured[0], lags)
        matrix, target = weights @ matrix, weights @ target
    scale = np.linalg.norm(matrix, axis=0)
    if (scale == 0).any():
        blind = [_label(keys[i], state_names, output_names) for i in np.nonzero(scale == 0)[0]]
        raise ConfigError('structure', f'{", ".join(blind)} leave no trace in the '
                          f'innovations (the model does not observe them)')
    scaled = matrix / scale
    left, values, right = np.linalg.svd(scaled, full_matrices=True)
    rank = int(np.sum(values > values[0] * RANK_TOLERANCE))
    null = right[rank:].T
    blind = [i for i in range(len(keys)) if np.linalg.norm(null[i]) > NULL_COMPONENT]
    names = tuple(_label(keys[i], state_names, output_names) for i in blind)
    allowed = {i for i in blind if keys[i][0] == 'Q' and structure.process == 'full'}
    refused = [names[k] for k, i in enumerate(blind) if i not in allowed]
    if refused:
        raise ConfigError('structure', f'the innovations cannot tell {", ".join(refused)} '
                          f'apart from the other free entries (the ALS system has rank '
                          f'{rank} for {len(keys)} entries); fix them with known values or '
                          f'choose another structure')
    norm = float(np.linalg.norm(target)) or 1.0
    coefficients = right[:rank].T @ ((left[:, :rank].T @ (target / norm)) / values[:rank])
    q, r = _assemble(coefficients * norm / scale, keys, structure)
    method = 'least squares'
    if not (_is_psd(q) and np.linalg.eigvalsh(r).min() > 0.0):
        coefficients = _semidefinite(scaled, target / norm, null, scale, norm, keys, structure)
        q, r = _assemble(coefficients * norm / scale, keys, structure)
        q, r = _nearest_psd(q), _nearest_psd(r)
        method = 'semidefinite least squares'
    smallest = float(np.linalg.eigvalsh(r).min())
    if smallest <= 1e-12 * max(1.0, float(np.abs(r).max())):
        raise ConfigError('measurement_noise', f'the estimate of R is singular (smallest '
                          f'eigenvalue {smallest:.3g}): an output looks noise-free, which a '
                          f'Kalman filter cannot take; fix its variance with a known value')
    estimate = np.array([q[i, j] if s == 'Q' else r[i, j] for s, i, j in keys])
    residual = float(np.linalg.norm(matrix @ estimate - target) / norm)
    return AlsResult(q, r, names, rank, len(keys), values, residual, method, lags)


def _whitening(covariance: np.ndarray, lags: int) -> np.ndarray:
    """
    Row weights that whiten each lag block by ``S^-1/2`` (``S = C_0``), lag 0 by ``1/sqrt 2``.

    For near-white innovations the sample autocovariances of different lags are nearly
    independent with covariance ``S (x) S / N`` (twice that at lag 0), so these weights are
    close to the optimal ones of the ALS paper at a fraction of the cost.
    """
    values, vectors = np.linalg.eigh(0.5 * (covariance + covariance.T))
    if values.min() <= 0.0:
        raise ConfigError('autocovariances', 'the lag-0 autocovariance (the innovation '
                          'covariance) is not positive definite: an output never varies')
    root = (vectors / np.sqrt(values)) @ vectors.T
    block = np.kron(root, root)
    blocks = [block / np.sqrt(2.0)] + [block] * (lags - 1)
    return scipy.linalg.block_diag(*blocks)


def _assemble(coefficients, keys, structure: NoiseStructure) -> tuple:
    q = structure.process_known.copy()
    r = structure.measurement_known.copy()
    for value, (symbol, row, column) in zip(coefficients, keys):
        target = q if symbol == 'Q' else r
        target[row, column] = target[column, row] = value
    return q, r


def _is_psd(matrix: np.ndarray) -> bool:
    return bool(np.linalg.eigvalsh(matrix).min() >= 0.0)


def _nearest_psd(matrix: np.ndarray) -> np.ndarray:
    """Clip the solver's round-off negative eigenvalues (a few 1e-9 of the scale) to zero."""
    values, vectors = np.linalg.eigh(0.5 * (matrix + matrix.T))
    if values.min() >= 0.0:
        return 0.5 * (matrix + matrix.T)
    clipped = (vectors * np.maximum(values, 0.0)) @ vectors.T
    return 0.5 * (clipped + clipped.T)


def _semidefinite(scaled: np.ndarray, target: np.ndarray, null: np.ndarray,
                  scale: np.ndarray, norm: float, keys, structure: NoiseStructure) -> np.ndarray:
    """
    Least squares over ``Q >= 0``, ``R >= 0`` (cvxpy, Clarabel), in scaled coordinates.

    Entry ``i`` is ``x[i] * norm / scale[i]``: the matrices divided by ``norm`` are
    ``known / norm + sum_i x[i] E_i / scale[i]``, PSD exactly when the matrices are.
    """
    import cvxpy as cp
    x = cp.Variable(scaled.shape[1])
    constraints = []
    for symbol, known in (('Q', structure.process_known), ('R', structure.measurement_known)):
        size = len(known)
        expression = cp.Constant(known / norm)
        for i, (entry, row, column) in enumerate(keys):
            if entry == symbol:
                expression = expression + x[i] * (_basis(size, row, column) / scale[i])
        constraints.append(0.5 * (expression + expression.T) >> 0)
    objective = cp.sum_squares(scaled @ x - target)
    if null.shape[1]:
        objective = objective + NULL_WEIGHT * cp.sum_squares(null.T @ x)
    problem = cp.Problem(cp.Minimize(objective), constraints)
    try:
        problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError as e:
        raise DesignError(f'the semidefinite least squares failed ({e})', 'structure') from e
    if x.value is None or problem.status not in ('optimal', 'optimal_inaccurate'):
        raise DesignError(f'the semidefinite least squares ended {problem.status}', 'structure')
    return np.asarray(x.value, dtype=float)


__all__ = ['AlsResult', 'autocovariance_least_squares']
