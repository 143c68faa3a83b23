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

"""State-space models built from flat, row-major parameter lists."""

from dataclasses import dataclass
import math
from typing import Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError

ArrayLike = Sequence[float] | np.ndarray


def _as_finite_vector(parameter: str, values: ArrayLike) -> np.ndarray:
    """Return ``values`` as a 1-D float array; refuse strings and non-finite entries."""
    if isinstance(values, (str, bytes)):
        raise ConfigError(parameter, f'expected a list of numbers, got the string {values!r}')
    try:
        vector = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as e:
        raise ConfigError(parameter, f'expected a list of numbers, got {values!r}') from e
    if vector.ndim == 0:
        vector = vector.reshape(1)
    if vector.ndim != 1:
        vector = vector.reshape(-1)
    bad = np.flatnonzero(~np.isfinite(vector))
    if bad.size:
        raise ConfigError(
            parameter,
            f'expected finite numbers, entry {int(bad[0])} is {vector[bad[0]]}')
    return vector


def matrix_from_flat(parameter: str, values: ArrayLike, rows: int, cols: int) -> np.ndarray:
    """
    Build a ``rows x cols`` matrix from a flat row-major list, checking its length.

    Parameters
    ----------
    parameter : str
        Parameter name used in error messages.
    values : sequence of float
        The ``rows * cols`` entries, row after row.
    rows, cols : int
        Expected shape.

    Returns
    -------
    numpy.ndarray, shape (rows, cols)

    Raises
    ------
    ConfigError
        If the length differs from ``rows * cols`` or an entry is not finite.

    """
    vector = _as_finite_vector(parameter, values)
    if vector.size != rows * cols:
        raise ConfigError(
            parameter,
            f'expected {rows}x{cols} ({rows * cols} values, row-major), got {vector.size}')
    return vector.reshape(rows, cols)


def vector_from_flat(parameter: str, values: ArrayLike, size: int) -> np.ndarray:
    """Return a finite vector of exactly ``size`` entries, or raise ConfigError naming it."""
    vector = _as_finite_vector(parameter, values)
    if vector.size != size:
        raise ConfigError(parameter, f'expected {size} values, got {vector.size}')
    return vector


def square_from_flat(parameter: str, values: ArrayLike) -> np.ndarray:
    """Infer ``n`` from ``n * n`` row-major entries and return the ``n x n`` matrix."""
    vector = _as_finite_vector(parameter, values)
    n = math.isqrt(vector.size)
    if vector.size == 0 or n * n != vector.size:
        raise ConfigError(
            parameter,
            f'expected a square matrix as n*n values (row-major), got {vector.size} values')
    return vector.reshape(n, n)


def covariance_from_flat(parameter: str, values: ArrayLike, size: int) -> np.ndarray:
    """
    Build a symmetric positive semi-definite ``size x size`` covariance.

    ``values`` holds either the ``size`` diagonal entries or all ``size * size`` entries
    (row-major).
    """
    vector = _as_finite_vector(parameter, values)
    if vector.size == size:
        matrix = np.diag(vector)
    elif vector.size == size * size:
        matrix = vector.reshape(size, size)
    else:
        raise ConfigError(
            parameter,
            f'expected {size} diagonal values or a {size}x{size} matrix '
            f'({size * size} values, row-major), got {vector.size}')
    if not np.allclose(matrix, matrix.T, rtol=1e-12, atol=1e-12 * max(1.0, np.abs(matrix).max())):
        raise ConfigError(parameter, 'expected a symmetric matrix')
    eigenvalues = np.linalg.eigvalsh(matrix)
    if eigenvalues.min() < -1e-12 * max(1.0, abs(eigenvalues).max()):
        raise ConfigError(
            parameter,
            f'expected a positive semi-definite matrix, smallest eigenvalue '
            f'{eigenvalues.min():.3g}')
    return matrix


def _names(parameter: str, names: Optional[Sequence[str]], size: int, prefix: str):
    if not names:
        return tuple(f'{prefix}{i + 1}' for i in range(size))
    names = tuple(str(name) for name in names)
    if len(names) != size:
        raise ConfigError(parameter, f'expected {size} names, got {len(names)}')
    if len(set(names)) != size:
        raise ConfigError(parameter, f'names must be unique, got {list(names)}')
    return names


@dataclass(frozen=True)
class StateSpaceModel:
    """
    Linear time-invariant model ``x' = A x + B u``, ``y = C x + D u``.

    ``dt == 0`` means continuous time; ``dt > 0`` a discrete-time model with that period,
    in seconds.
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    dt: float = 0.0
    state_names: tuple = ()
    input_names: tuple = ()
    output_names: tuple = ()

    @property
    def n_states(self) -> int:
        """Number of states ``n``."""
        return self.a.shape[0]

    @property
    def n_inputs(self) -> int:
        """Number of inputs ``m``."""
        return self.b.shape[1]

    @property
    def n_outputs(self) -> int:
        """Number of outputs ``p``."""
        return self.c.shape[0]

    @property
    def is_discrete(self) -> bool:
        """Whether the model is a discrete-time model (``dt > 0``)."""
        return self.dt > 0.0

    @classmethod
    def from_flat(
        cls,
        a: ArrayLike,
        b: ArrayLike,
        c: ArrayLike,
        d: Optional[ArrayLike] = None,
        dt: float = 0.0,
        state_names: Optional[Sequence[str]] = None,
        input_names: Optional[Sequence[str]] = None,
        output_names: Optional[Sequence[str]] = None,
        prefix: str = 'model.',
    ) -> 'StateSpaceModel':
        """
        Build a model from flat row-major lists, inferring and checking every dimension.

        ``n`` comes from ``A`` (``n * n`` values), ``m`` from ``B`` (``n * m`` values) and
        ``p`` from ``C`` (``p * n`` values). ``D`` may be empty (zero).

        Raises
        ------
        ConfigError
            Naming the parameter, the expected shape and what was given.

        """
        a_matrix = square_from_flat(prefix + 'A', a)
        n_states = a_matrix.shape[0]
        b_vector = _as_finite_vector(prefix + 'B', b)
        if b_vector.size == 0 or b_vector.size % n_states:
            raise ConfigError(
                prefix + 'B',
                f'expected {n_states}xm (a multiple of {n_states} values, row-major, '
                f'n = {n_states} from {prefix}A), got {b_vector.size}')
        n_inputs = b_vector.size // n_states
        c_vector = _as_finite_vector(prefix + 'C', c)
        if c_vector.size == 0 or c_vector.size % n_states:
            raise ConfigError(
                prefix + 'C',
                f'expected px{n_states} (a multiple of {n_states} values, row-major, '
                f'n = {n_states} from {prefix}A), got {c_vector.size}')
        n_outputs = c_vector.size // n_states
        if d is None or len(d) == 0:
            d_matrix = np.zeros((n_outputs, n_inputs))
        else:
            d_matrix = matrix_from_flat(prefix + 'D', d, n_outputs, n_inputs)
        dt = float(dt)
        if not math.isfinite(dt) or dt < 0.0:
            raise ConfigError(
                prefix + 'dt', f'expected 0 (continuous time) or a period > 0 s, got {dt}')
        return cls(
            a=a_matrix,
            b=b_vector.reshape(n_states, n_inputs),
            c=c_vector.reshape(n_outputs, n_states),
            d=d_matrix,
            dt=dt,
            state_names=_names(prefix + 'state_names', state_names, n_states, 'x'),
            input_names=_names(prefix + 'input_names', input_names, n_inputs, 'u'),
            output_names=_names(prefix + 'output_names', output_names, n_outputs, 'y'),
        )

    @classmethod
    def from_matrices(
        cls, a, b, c, d=None, dt: float = 0.0, **names
    ) -> 'StateSpaceModel':
        """Build a model from 2-D arrays ``(n, n)``, ``(n, m)``, ``(p, n)``, ``(p, m)``."""
        a = np.atleast_2d(np.asarray(a, dtype=float))
        if a.ndim != 2 or a.shape[0] != a.shape[1]:
            raise ConfigError('model.A', f'expected a square matrix, got shape {a.shape}')
        n_states = a.shape[0]
        b = np.asarray(b, dtype=float)
        if b.ndim == 1 and b.size == n_states:
            b = b.reshape(n_states, 1)  # one input given as a flat vector
        if b.ndim != 2 or b.shape[0] != n_states:
            raise ConfigError('model.B', f'expected an {n_states} x m matrix, got shape {b.shape}')
        c = np.atleast_2d(np.asarray(c, dtype=float))
        if c.ndim != 2 or c.shape[1] != n_states:
            raise ConfigError('model.C', f'expected a p x {n_states} matrix, got shape {c.shape}')
        d_flat = None
        if d is not None:
            d = np.atleast_2d(np.asarray(d, dtype=float))
            expected = (c.shape[0], b.shape[1])
            if d.shape != expected:
                raise ConfigError('model.D', f'expected a {expected[0]} x {expected[1]} matrix, '
                                  f'got shape {d.shape}')
            d_flat = d.ravel()
        return cls.from_flat(a.ravel(), b.ravel(), c.ravel(), d_flat, dt, **names)

    def transformed(self, transform: np.ndarray) -> 'StateSpaceModel':
        """Return the model in coordinates ``w = T x`` (``A_w = T A T^-1`` and so on)."""
        inverse = np.linalg.inv(transform)
        return StateSpaceModel(
            a=transform @ self.a @ inverse, b=transform @ self.b, c=self.c @ inverse,
            d=self.d, dt=self.dt, state_names=self.state_names,
            input_names=self.input_names, output_names=self.output_names)
