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
What ALS inverts: a sampled constant-gain filter and the innovation autocovariances it leaves.

A constant-gain filter running over recorded data, optimal or not, leaves innovations whose
autocovariances are linear in the noise covariances it was not told. With the sampled plant
``x[k+1] = Ad x[k] + Bd u[k] + w[k]``, ``y[k] = C x[k] + v[k]`` (``w`` of covariance ``Qd``,
``v`` of covariance ``R``) and the predictor gain ``L = Ad M`` of the filter (``M`` its
filter gain), the prediction error ``eps = x - x_hat[k|k-1]`` obeys
``eps[k+1] = Abar eps[k] + w[k] - L v[k]`` with ``Abar = Ad - L C``, and the innovation
``e = C eps + v`` has, in steady state,

* ``C_0 = C P C^T + R``,
* ``C_j = C Abar^j P C^T - C Abar^(j-1) L R`` for ``j >= 1``,

where ``P = Abar P Abar^T + Qd + L R L^T``. :class:`SampledFilter` is the filter,
:func:`innovation_autocovariances` the map from ``Q`` and ``R`` to ``C_0 .. C_(N-1)``, and
:class:`NoiseStructure` says which entries of ``Q`` and ``R`` are unknown; the least
squares that inverts the map is :mod:`observer_ros.core.tuning.als`.
"""

from dataclasses import dataclass
from typing import Mapping, Optional, Tuple

import numpy as np
import scipy.linalg

from observer_ros.core.discretize import van_loan
from observer_ros.core.errors import ConfigError, DesignError

#: Structures a covariance can be given: every entry free, or the diagonal only.
STRUCTURES = ('diagonal', 'full')


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


__all__ = ['NoiseStructure', 'STRUCTURES', 'SampledFilter', 'innovation_autocovariances']
