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
Matrices, vectors and covariances from flat row-major lists, as ROS parameters hold them.

Every reader takes the name to report as its first argument and checks the length, the
numbers and (covariances) symmetry and definiteness: ``gain: expected 2x1 (2 values,
row-major), got 3`` (:mod:`observer_ros.core.errors`).
"""

import math
from typing import Sequence

import numpy as np

from observer_ros.core.errors import ConfigError

ArrayLike = Sequence[float] | np.ndarray


def as_finite_vector(parameter: str, values: ArrayLike) -> np.ndarray:
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
        Name used in error messages (the caller's argument, such as ``'gain'``).
    values : sequence of float, shape (rows * cols,)
        The entries, row after row.
    rows, cols : int
        Expected shape.

    Returns
    -------
    numpy.ndarray, shape (rows, cols)

    Raises
    ------
    ConfigError
        Naming ``parameter``, if the length differs from ``rows * cols`` or an entry is
        not a finite number.

    Examples
    --------
    >>> from observer_ros.core.flat_matrices import matrix_from_flat
    >>> print(matrix_from_flat('gain', [1, 2, 3, 4, 5, 6], 2, 3))
    [[1. 2. 3.]
     [4. 5. 6.]]
    >>> matrix_from_flat('gain', [1, 2, 3], 2, 1)
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: gain: expected 2x1 (2 values, row-major), got 3

    """
    vector = as_finite_vector(parameter, values)
    if vector.size != rows * cols:
        raise ConfigError(
            parameter,
            f'expected {rows}x{cols} ({rows * cols} values, row-major), got {vector.size}')
    return vector.reshape(rows, cols)


def vector_from_flat(parameter: str, values: ArrayLike, size: int) -> np.ndarray:
    """
    Return a finite vector of exactly ``size`` entries.

    Parameters
    ----------
    parameter : str
        Name used in error messages.
    values : sequence of float, shape (size,)
    size : int

    Returns
    -------
    numpy.ndarray, shape (size,)

    Raises
    ------
    ConfigError
        Naming ``parameter``, for a wrong length or a non-finite entry.

    Examples
    --------
    >>> from observer_ros.core.flat_matrices import vector_from_flat
    >>> vector_from_flat('initial_state', [1, 0], 2).tolist()
    [1.0, 0.0]
    >>> vector_from_flat('initial_state', [1], 2)
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: initial_state: expected 2 values, got 1

    """
    vector = as_finite_vector(parameter, values)
    if vector.size != size:
        raise ConfigError(parameter, f'expected {size} values, got {vector.size}')
    return vector


def square_from_flat(parameter: str, values: ArrayLike) -> np.ndarray:
    """
    Infer ``n`` from ``n * n`` row-major entries and return the ``n x n`` matrix.

    Parameters
    ----------
    parameter : str
        Name used in error messages.
    values : sequence of float, shape (n * n,)

    Returns
    -------
    numpy.ndarray, shape (n, n)

    Raises
    ------
    ConfigError
        Naming ``parameter``, when the length is not a positive square or an entry is not
        finite.

    Examples
    --------
    >>> from observer_ros.core.flat_matrices import square_from_flat
    >>> square_from_flat('A', [0, 1, 0, 0]).shape
    (2, 2)

    """
    vector = as_finite_vector(parameter, values)
    n = math.isqrt(vector.size)
    if vector.size == 0 or n * n != vector.size:
        raise ConfigError(
            parameter,
            f'expected a square matrix as n*n values (row-major), got {vector.size} values')
    return vector.reshape(n, n)


def covariance_from_flat(parameter: str, values: ArrayLike, size: int) -> np.ndarray:
    """
    Build a symmetric positive semi-definite ``size x size`` covariance.

    Parameters
    ----------
    parameter : str
        Name used in error messages (``'process_noise'``, ``'measurement_noise'``...).
    values : sequence of float, shape (size,) or (size * size,)
        Either the ``size`` diagonal entries or all ``size * size`` entries (row-major).
    size : int

    Returns
    -------
    numpy.ndarray, shape (size, size)

    Raises
    ------
    ConfigError
        Naming ``parameter``: wrong length, non-finite entry, asymmetric or indefinite.

    Examples
    --------
    >>> from observer_ros.core.flat_matrices import covariance_from_flat
    >>> print(covariance_from_flat('process_noise', [1, 2], 2))
    [[1. 0.]
     [0. 2.]]
    >>> covariance_from_flat('process_noise', [1, 2, 0, 1], 2)
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: process_noise: expected a symmetric matrix

    """
    vector = as_finite_vector(parameter, values)
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


__all__ = ['ArrayLike', 'as_finite_vector', 'covariance_from_flat', 'matrix_from_flat',
           'square_from_flat', 'vector_from_flat']
