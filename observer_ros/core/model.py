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
State-space models built from flat, row-major lists, from 2-D arrays or from python-control.

Errors name the matrices ``A``, ``B``, ``C``, ``D`` and the other fields (``dt``,
``state_names``...) as :mod:`observer_ros.core.errors` describes; the flat lists are read
by :mod:`observer_ros.core.flat_matrices`, and the conversions from and to python-control
are :mod:`observer_ros.core.control_conversion`.
"""

from dataclasses import dataclass
import math
from typing import Any, Optional, Sequence

import numpy as np

from observer_ros.core import control_conversion
from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import (
    ArrayLike, as_finite_vector, matrix_from_flat, square_from_flat)


def _names(parameter: str, names: Optional[Sequence[str]], size: int, prefix: str):
    if not names:
        return tuple(f'{prefix}{i + 1}' for i in range(size))
    if isinstance(names, str):
        raise ConfigError(parameter, f'expected a list of {size} names, got the string {names!r}')
    names = tuple(str(name) for name in names)
    if len(names) != size:
        raise ConfigError(parameter, f'expected {size} names, got {len(names)}')
    if len(set(names)) != size:
        raise ConfigError(parameter, f'names must be unique, got {list(names)}')
    return names


def _matrix_2d(parameter: str, values: Any) -> np.ndarray:
    try:
        matrix = np.asarray(values, dtype=float)
    except (TypeError, ValueError) as e:
        raise ConfigError(parameter, f'expected a matrix of numbers, got {values!r}') from e
    return np.atleast_2d(matrix)


def model_feedthrough(model: 'StateSpaceModel') -> Optional[np.ndarray]:
    """
    Return ``model.d`` when it has a non-zero entry, else None (the ``D = 0`` path).

    Everything that handles a feedthrough asks this once, so a model with ``D = 0`` takes
    exactly the arithmetic of a model without one.
    """
    d = model.d
    return np.array(d, dtype=float) if d.size and np.any(d != 0.0) else None


@dataclass(frozen=True)
class StateSpaceModel:
    """
    Linear time-invariant model ``x' = A x + B u``, ``y = C x + D u``.

    ``dt == 0`` means continuous time; ``dt > 0`` a discrete-time model
    ``x[k+1] = A x[k] + B u[k]`` with that period, in seconds. Build one with
    :meth:`from_matrices` (2-D arrays), :meth:`from_flat` (row-major lists, as ROS
    parameters hold them) or :meth:`from_statespace` (a ``control.StateSpace``); the
    constructor itself checks nothing.

    Parameters
    ----------
    a : numpy.ndarray, shape (n, n)
    b : numpy.ndarray, shape (n, m)
    c : numpy.ndarray, shape (p, n)
    d : numpy.ndarray, shape (p, m)
    dt : float
        0 (continuous time) or the sample period in seconds.
    state_names, input_names, output_names : tuple of str
        ``n``, ``m`` and ``p`` names (``x1``, ``u1``, ``y1``... by default).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [-2, -3]], [[0], [1]], [[1, 0]])
    >>> model.n_states, model.n_inputs, model.n_outputs, model.is_discrete
    (2, 1, 1, False)
    >>> model.state_names
    ('x1', 'x2')

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
    ) -> 'StateSpaceModel':
        """
        Build a model from flat row-major lists, inferring and checking every dimension.

        Parameters
        ----------
        a : sequence of float, shape (n * n,)
            ``A`` row after row; ``n`` comes from its length.
        b : sequence of float, shape (n * m,)
            ``B``; ``m`` comes from its length (empty: a model without inputs, m = 0).
        c : sequence of float, shape (p * n,)
            ``C``; ``p`` comes from its length.
        d : sequence of float, shape (p * m,), optional
            ``D``; None or empty for zero.
        dt : float
            0 (continuous time, the default) or the sample period in seconds.
        state_names, input_names, output_names : sequence of str, optional
            ``n``, ``m`` and ``p`` unique names.

        Returns
        -------
        StateSpaceModel

        Raises
        ------
        ConfigError
            Naming ``A``, ``B``, ``C``, ``D``, ``dt``, ``state_names``, ``input_names`` or
            ``output_names``, the expected shape and what was given.

        Examples
        --------
        >>> from observer_ros.core import StateSpaceModel
        >>> model = StateSpaceModel.from_flat([0, 1, 0, 0], [0, 1], [1, 0], dt=0.1)
        >>> print(model.b)
        [[0.]
         [1.]]
        >>> StateSpaceModel.from_flat([0, 1, 0, 0], [0, 1, 2], [1, 0])  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        observer_ros.core.errors.ConfigError: B: expected 2xm (a multiple of 2 values, ...), got 3

        """
        a_matrix = square_from_flat('A', a)
        n_states = a_matrix.shape[0]
        b_vector = as_finite_vector('B', b)
        if b_vector.size % n_states:
            raise ConfigError(
                'B',
                f'expected {n_states}xm (a multiple of {n_states} values, row-major, '
                f'n = {n_states} from A; none for a model without inputs), '
                f'got {b_vector.size}')
        n_inputs = b_vector.size // n_states
        c_vector = as_finite_vector('C', c)
        if c_vector.size == 0 or c_vector.size % n_states:
            raise ConfigError(
                'C',
                f'expected px{n_states} (a multiple of {n_states} values, row-major, '
                f'n = {n_states} from A), got {c_vector.size}')
        n_outputs = c_vector.size // n_states
        if d is None or len(d) == 0:
            d_matrix = np.zeros((n_outputs, n_inputs))
        else:
            d_matrix = matrix_from_flat('D', d, n_outputs, n_inputs)
        try:
            dt = float(dt)
        except (TypeError, ValueError) as e:
            raise ConfigError('dt', f'expected a number of seconds, got {dt!r}') from e
        if not math.isfinite(dt) or dt < 0.0:
            raise ConfigError('dt', f'expected 0 (continuous time) or a period > 0 s, got {dt}')
        return cls(
            a=a_matrix,
            b=b_vector.reshape(n_states, n_inputs),
            c=c_vector.reshape(n_outputs, n_states),
            d=d_matrix,
            dt=dt,
            state_names=_names('state_names', state_names, n_states, 'x'),
            input_names=_names('input_names', input_names, n_inputs, 'u'),
            output_names=_names('output_names', output_names, n_outputs, 'y'),
        )

    @classmethod
    def from_matrices(
        cls,
        a: Any,
        b: Any,
        c: Any,
        d: Any = None,
        dt: float = 0.0,
        state_names: Optional[Sequence[str]] = None,
        input_names: Optional[Sequence[str]] = None,
        output_names: Optional[Sequence[str]] = None,
    ) -> 'StateSpaceModel':
        """
        Build a model from 2-D arrays, checking that their shapes agree.

        Parameters
        ----------
        a : array_like, shape (n, n)
        b : array_like, shape (n, m)
            A flat vector of ``n`` entries is one input column; an empty one (or shape
            ``(n, 0)``) a model without inputs.
        c : array_like, shape (p, n)
            A flat vector of ``n`` entries is one output row.
        d : array_like, shape (p, m), optional
            Zero when omitted.
        dt : float
            0 (continuous time, the default) or the sample period in seconds.
        state_names, input_names, output_names : sequence of str, optional
            As for :meth:`from_flat`.

        Returns
        -------
        StateSpaceModel

        Raises
        ------
        ConfigError
            Naming ``A``, ``B``, ``C``, ``D`` (or a field, as :meth:`from_flat` does) with
            the expected and the given shape.

        Examples
        --------
        >>> from observer_ros.core import StateSpaceModel
        >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [0, 1], [1, 0],
        ...                                       state_names=['position', 'velocity'])
        >>> model.b.shape, model.c.shape, model.d.shape
        ((2, 1), (1, 2), (1, 1))
        >>> StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0, 1]], [1, 0])
        Traceback (most recent call last):
        ...
        observer_ros.core.errors.ConfigError: B: expected a 2 x m matrix, got shape (1, 2)

        """
        a = _matrix_2d('A', a)
        if a.ndim != 2 or a.shape[0] != a.shape[1]:
            raise ConfigError('A', f'expected a square matrix, got shape {a.shape}')
        n_states = a.shape[0]
        try:
            b = np.asarray(b, dtype=float)
        except (TypeError, ValueError) as e:
            raise ConfigError('B', f'expected a matrix of numbers, got {b!r}') from e
        if b.ndim == 1 and b.size == n_states:
            b = b.reshape(n_states, 1)  # one input given as a flat vector
        elif b.size == 0:
            b = np.zeros((n_states, 0))  # no inputs (m = 0)
        if b.ndim != 2 or b.shape[0] != n_states:
            raise ConfigError('B', f'expected a {n_states} x m matrix, got shape {b.shape}')
        c = _matrix_2d('C', c)
        if c.ndim != 2 or c.shape[1] != n_states:
            raise ConfigError('C', f'expected a p x {n_states} matrix, got shape {c.shape}')
        d_flat = None
        if d is not None:
            d = _matrix_2d('D', d)
            expected = (c.shape[0], b.shape[1])
            if d.shape != expected:
                raise ConfigError('D', f'expected a {expected[0]} x {expected[1]} matrix, '
                                  f'got shape {d.shape}')
            d_flat = d.ravel()
        return cls.from_flat(a.ravel(), b.ravel(), c.ravel(), d_flat, dt,
                             state_names, input_names, output_names)

    # The conversions from and to python-control (its labels as the names), with their
    # docstrings, are those of observer_ros.core.control_conversion.
    from_statespace = classmethod(control_conversion.from_statespace)
    to_statespace = control_conversion.to_statespace

    def transformed(self, transform: ArrayLike) -> 'StateSpaceModel':
        """
        Return the model in coordinates ``w = T x`` (``A_w = T A T^-1`` and so on).

        Parameters
        ----------
        transform : array_like, shape (n, n)
            ``T``, invertible.

        Returns
        -------
        StateSpaceModel
            ``T A T^-1``, ``T B``, ``C T^-1`` and the same ``D``, ``dt`` and names.

        Raises
        ------
        ConfigError
            Naming ``transform`` when it is not ``n x n`` or is singular.

        Examples
        --------
        >>> import observer_ros.core as oc
        >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [-2, -3]], [[0], [1]], [[1, 0]])
        >>> swapped = model.transformed([[0, 1], [1, 0]])
        >>> print(swapped.a)
        [[-3. -2.]
         [ 1.  0.]]

        """
        transform = _matrix_2d('transform', transform)
        if transform.shape != (self.n_states, self.n_states):
            raise ConfigError('transform', f'expected a {self.n_states} x {self.n_states} '
                              f'matrix, got shape {transform.shape}')
        try:
            inverse = np.linalg.inv(transform)
        except np.linalg.LinAlgError as e:
            raise ConfigError('transform', 'expected an invertible matrix') from e
        return StateSpaceModel(
            a=transform @ self.a @ inverse, b=transform @ self.b, c=self.c @ inverse,
            d=self.d, dt=self.dt, state_names=self.state_names,
            input_names=self.input_names, output_names=self.output_names)
