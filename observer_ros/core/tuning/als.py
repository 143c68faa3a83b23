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

A constant-gain filter running over recorded data, optimal or not, leaves innovations whose
autocovariances are linear in the noise covariances it was not told. With the sampled plant
``x[k+1] = Ad x[k] + Bd u[k] + w[k]``, ``y[k] = C x[k] + v[k]`` (``w`` of covariance ``Qd``,
``v`` of covariance ``R``) and the predictor gain ``L = Ad M`` of the filter (``M`` its
filter gain), the prediction error ``eps = x - x_hat[k|k-1]`` obeys
``eps[k+1] = Abar eps[k] + w[k] - L v[k]`` with ``Abar = Ad - L C``, and the innovation
``e = C eps + v`` has, in steady state,

* ``C_0 = C P C^T + R``,
* ``C_j = C Abar^j P C^T - C Abar^(j-1) L R`` for ``j >= 1``,

where ``P = Abar P Abar^T + Qd + L R L^T``. Stacking ``C_0 .. C_(N-1)`` gives one linear
system in the free entries of ``Q`` and ``R`` (Odelson, Rajamani and Rawlings, 2006), solved
here in the least-squares sense with ``Q`` positive semidefinite and ``R`` positive definite:
the plain solution when it is one, else a semidefinite program (cvxpy with Clarabel). A
continuous model's ``Q`` is an intensity, mapped to ``Qd`` by Van Loan's integral, which is
linear in it, so the unknowns stay the user's own parameters.

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
from typing import Mapping, Optional, Sequence, Tuple

import numpy as np
import scipy.linalg

from observer_ros.core.discretize import van_loan
from observer_ros.core.errors import ConfigError, DesignError

#: Structures a covariance can be given: every entry free, or the diagonal only.
STRUCTURES = ('diagonal', 'full')

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


@dataclass(frozen=True)
class SampledFilter:
    """
    A constant-gain filter over one sample period, as ALS models it.

    Parameters
    ----------
    ad : numpy.ndarray, shape (n, n)
        Sampled state matrix.
    c : numpy.ndarray, shape (p, n)
    filter_gain : numpy.ndarray, shape (n, p)
        ``M`` of ``x_hat[k|k] = x_hat[k|k-1] + M e[k]``; the predictor gain is ``Ad M``.
    dt : float
        Sample period in seconds.
    a : numpy.ndarray or None, shape (n, n)
        The continuous model's ``A`` when ``Q`` is an intensity (``Qd`` by Van Loan); None
        for a discrete model, whose ``Q`` is ``Qd`` itself.

    Examples
    --------
    >>> import numpy as np
    >>> sampled = SampledFilter(np.array([[0.9]]), np.array([[1.0]]), np.array([[0.5]]), 0.1)
    >>> sampled.predictor_gain.tolist(), sampled.error_dynamics.round(6).tolist()
    ([[0.45]], [[0.45]])

    """

    ad: np.ndarray
    c: np.ndarray
    filter_gain: np.ndarray
    dt: float
    a: Optional[np.ndarray] = None

    @property
    def predictor_gain(self) -> np.ndarray:
        """``L = Ad M``, shape (n, p)."""
        return self.ad @ self.filter_gain

    @property
    def error_dynamics(self) -> np.ndarray:
        """``Abar = Ad - L C`` of the prediction error, shape (n, n)."""
        return self.ad - self.predictor_gain @ self.c

    def sampled_process_noise(self, process_noise) -> np.ndarray:
        """Return ``Qd`` of one period for ``Q`` (an intensity for a continuous model)."""
        q = np.asarray(process_noise, dtype=float)
        return q if self.a is None else van_loan(self.a, q, self.dt)

    def check_stable(self) -> None:
        """Raise DesignError (``gain``) when the prediction error does not decay."""
        radius = float(np.max(np.abs(np.linalg.eigvals(self.error_dynamics))))
        if radius >= 1.0:
            raise DesignError(f'the filter is not stable (spectral radius of Ad - L C '
                              f'{radius:.6g}); innovations have no steady state', 'gain')


def innovation_autocovariances(sampled: SampledFilter, process_noise, measurement_noise,
                               lags: int) -> np.ndarray:
    """
    Return the steady-state ``C_0 .. C_(lags-1)`` of the innovations, shape ``(lags, p, p)``.

    Parameters
    ----------
    sampled : SampledFilter
    process_noise : array_like, shape (n, n)
        ``Q`` (intensity for a continuous model).
    measurement_noise : array_like, shape (p, p)
        ``R``.
    lags : int

    Returns
    -------
    numpy.ndarray, shape (lags, p, p)

    Examples
    --------
    An optimal filter leaves white innovations:

    >>> import numpy as np
    >>> from observer_ros.core.observers.kalman.design import design_kalman
    >>> from observer_ros.core.model import StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[1, 0.1], [0, 1]], [[0], [0.1]], [[1, 0]],
    ...                                       dt=0.1)
    >>> design = design_kalman(model, [1e-4, 1e-2], [0.01])
    >>> sampled = SampledFilter(model.a, model.c, design.filter_gain, 0.1)
    >>> c = innovation_autocovariances(sampled, np.diag([1e-4, 1e-2]), [[0.01]], 3)
    >>> bool(abs(c[1, 0, 0]) < 1e-12 and abs(c[2, 0, 0]) < 1e-12)
    True

    """
    q = np.asarray(process_noise, dtype=float)
    r = np.asarray(measurement_noise, dtype=float)
    observability = _stacked_observability(sampled, lags)
    return (_process_response(sampled, observability, q)
            + _measurement_response(sampled, observability, r))


def _stacked_observability(sampled: SampledFilter, lags: int) -> np.ndarray:
    """Return ``C Abar^j`` for ``j = 0 .. lags - 1``, shape ``(lags, p, n)``."""
    abar = sampled.error_dynamics
    rows = np.empty((lags,) + sampled.c.shape)
    row = sampled.c
    for lag in range(lags):
        rows[lag] = row
        row = row @ abar
    return rows


def _lyapunov(abar: np.ndarray, forcing: np.ndarray) -> np.ndarray:
    p = scipy.linalg.solve_discrete_lyapunov(abar, forcing)
    return 0.5 * (p + p.T)


def _process_response(sampled: SampledFilter, observability: np.ndarray, q) -> np.ndarray:
    """Return the autocovariances ``Q`` alone gives (``R = 0``)."""
    if not np.any(q):
        return np.zeros(observability.shape[:2] + (observability.shape[1],))
    p = _lyapunov(sampled.error_dynamics, sampled.sampled_process_noise(q))
    return observability @ p @ sampled.c.T


def _measurement_response(sampled: SampledFilter, observability: np.ndarray, r) -> np.ndarray:
    """Return the autocovariances ``R`` alone gives (``Q = 0``)."""
    gain = sampled.predictor_gain
    p = _lyapunov(sampled.error_dynamics, gain @ r @ gain.T)
    response = observability @ p @ sampled.c.T
    response[0] += r
    response[1:] -= observability[:-1] @ gain @ r
    return response


@dataclass(frozen=True)
class NoiseStructure:
    """
    Which entries of ``Q`` and ``R`` are estimated, and the values of the others.

    Build one with :meth:`build`. Entries are symmetric: ``(i, j)`` and ``(j, i)`` are one
    parameter.

    Attributes
    ----------
    process_free, measurement_free : numpy.ndarray of bool, shapes (n, n) and (p, p)
    process_known, measurement_known : numpy.ndarray, shapes (n, n) and (p, p)
        The values of the entries that are not free (zero where free).
    process, measurement : str
        The structure asked for: ``'diagonal'`` or ``'full'``.

    Examples
    --------
    >>> structure = NoiseStructure.build(2, 1, 'diagonal', 'full', {('Q', 0, 0): 0.0})
    >>> structure.parameters()
    [('Q', 1, 1), ('R', 0, 0)]

    """

    process_free: np.ndarray
    process_known: np.ndarray
    measurement_free: np.ndarray
    measurement_known: np.ndarray
    process: str = 'diagonal'
    measurement: str = 'full'

    @classmethod
    def build(cls, n_states: int, n_outputs: int, process: str = 'diagonal',
              measurement: str = 'full',
              known: Optional[Mapping[Tuple[str, int, int], float]] = None) -> 'NoiseStructure':
        """
        Return the structure of ``Q`` (``process``) and ``R`` (``measurement``).

        Parameters
        ----------
        n_states, n_outputs : int
        process, measurement : {'diagonal', 'full'}
            ``diagonal``: off-diagonal entries are zero (known); ``full``: all free.
        known : mapping, optional
            ``{('Q' or 'R', i, j): value}``: entries fixed at a value (zero-based indices;
            ``(j, i)`` is fixed with ``(i, j)``).

        Raises
        ------
        ConfigError
            Naming ``process``, ``measurement`` or ``known``.

        """
        for name, value in (('process', process), ('measurement', measurement)):
            if value not in STRUCTURES:
                raise ConfigError(name, f'expected one of {", ".join(STRUCTURES)}, got '
                                  f'{value!r}')
        matrices = {}
        for symbol, size, kind in (('Q', n_states, process), ('R', n_outputs, measurement)):
            shape = (size, size)
            free = np.eye(size, dtype=bool) if kind == 'diagonal' else np.ones(shape, dtype=bool)
            matrices[symbol] = (free, np.zeros((size, size)))
        for key, value in (known or {}).items():
            symbol, row, column = key
            if symbol not in matrices:
                raise ConfigError('known', f'expected an entry of Q or R, got {symbol!r}')
            free, values = matrices[symbol]
            size = len(free)
            if not (0 <= row < size and 0 <= column < size):
                raise ConfigError('known', f'{symbol}[{row},{column}] is outside the '
                                  f'{size}x{size} matrix')
            if not np.isfinite(value):
                raise ConfigError('known', f'{symbol}[{row},{column}]: expected a finite '
                                  f'value, got {value}')
            free[row, column] = free[column, row] = False
            values[row, column] = values[column, row] = float(value)
        return cls(*matrices['Q'], *matrices['R'], process, measurement)

    def parameters(self) -> list:
        """Return the free entries as ``('Q' or 'R', i, j)`` with ``i <= j``, Q first."""
        found = []
        for symbol, free in (('Q', self.process_free), ('R', self.measurement_free)):
            rows, columns = np.nonzero(np.triu(free))
            found += [(symbol, int(i), int(j)) for i, j in zip(rows, columns)]
        return found


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


__all__ = ['AlsResult', 'NoiseStructure', 'STRUCTURES', 'SampledFilter',
           'autocovariance_least_squares', 'innovation_autocovariances']
