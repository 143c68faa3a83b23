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
Angles: outputs and states that live on a circle, wrapped to ``(-pi, pi]``.

A heading measured as ``3.1`` then ``-3.1`` rad has moved by ``0.08`` rad, not ``-6.2``. An
estimator given :class:`Angles` takes each angle output's innovation wrapped to
``(-pi, pi]`` (it moves the measurement by a whole turn to the branch of the prediction,
then updates as usual) and keeps each angle state in ``(-pi, pi]`` after every update and
prediction, the way robot_localization normalizes its angles after each update.

Keeping a state in range is only right when a whole turn of it changes nothing else:
:func:`check_angles` requires that the column of ``A`` of an angle state be zero
(continuous; the identity column for a discrete model: the state only integrates), and that
its column of ``C`` be zero on every output that is not an angle and a whole number on every
angle output. A heading ``yaw`` with ``yaw' = w`` and outputs ``yaw`` or ``2 yaw`` qualifies;
a pendulum angle with ``theta'' = -g/l theta`` does not (a linear model of it is only right
near 0, so it never needs wrapping).
"""

from dataclasses import dataclass
import math
from typing import Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError

__all__ = ['Angles', 'check_angles', 'wrap_angles']

#: A whole turn, in radians.
TURN = 2.0 * math.pi

#: How far from a whole number a column of ``C`` may be, relative (rounding of given values).
WHOLE_TOLERANCE = 1e-9


def wrap_angles(values) -> np.ndarray:
    """
    Return ``values`` wrapped to ``(-pi, pi]``.

    Parameters
    ----------
    values : array_like
        Angles in radians, any shape.

    Returns
    -------
    numpy.ndarray
        The same shape, each value moved by whole turns into ``(-pi, pi]``.

    Examples
    --------
    >>> from observer_ros.core.angles import wrap_angles
    >>> wrap_angles([3.3, -3.3, 3.141592653589793, -3.141592653589793]).round(4).tolist()
    [-2.9832, 2.9832, 3.1416, 3.1416]

    """
    values = np.asarray(values, dtype=float)
    wrapped = values - TURN * np.floor((values + math.pi) / TURN)
    # floor maps -pi to -pi; the interval is (-pi, pi]: take +pi there.
    return np.where(wrapped <= -math.pi, wrapped + TURN, wrapped)


@dataclass(frozen=True)
class Angles:
    """
    Which states and outputs are angles (0-based indices, ascending).

    Attributes
    ----------
    states : tuple of int
        Kept in ``(-pi, pi]`` after each update and prediction.
    outputs : tuple of int
        Their innovations are wrapped to ``(-pi, pi]``.

    Examples
    --------
    >>> import numpy as np
    >>> angles = Angles(states=(0,), outputs=(0,))
    >>> angles.near([-3.1], np.array([3.1])).round(4).tolist()  # the branch of 3.1
    [3.1832]
    >>> angles.keep(np.array([3.1832, 0.5])).round(4).tolist()
    [-3.1, 0.5]

    """

    states: tuple = ()
    outputs: tuple = ()

    def __bool__(self) -> bool:
        """Whether any state or output is an angle."""
        return bool(self.states or self.outputs)

    def near(self, y: np.ndarray, predicted: np.ndarray,
             outputs: Optional[Sequence[int]] = None) -> np.ndarray:
        """
        Return ``y`` with each angle output moved by whole turns to within pi of ``predicted``.

        ``predicted + wrap(y - predicted)`` for the angle outputs, the others as given; an
        update with it has the wrapped innovation. ``outputs``: the model outputs ``y``
        holds (a source's subset, ascending); all of them when None.
        """
        positions = self.positions(outputs)
        if not positions:
            return y
        y = np.array(y, dtype=float)
        index = list(positions)
        y[index] = predicted[index] + wrap_angles(y[index] - predicted[index])
        return y

    def positions(self, outputs: Optional[Sequence[int]] = None) -> tuple:
        """Return the positions of the angle outputs in a vector of ``outputs`` (all: None)."""
        if outputs is None:
            return self.outputs
        return tuple(k for k, index in enumerate(outputs) if index in self.outputs)

    def states_near(self, values, reference) -> np.ndarray:
        """
        Return states with each angle state moved by whole turns to within pi of ``reference``.

        ``values`` and ``reference`` are ``(n,)`` or ``(k, n)``: an estimate compared with the
        truth differs by its error, not by a turn.

        Examples
        --------
        >>> Angles(states=(0,)).states_near([[3.1, 1.0]], [[-3.1, 1.0]]).round(4).tolist()
        [[-3.1832, 1.0]]

        """
        values = np.array(values, dtype=float)
        if self.states:
            reference = np.asarray(reference, dtype=float)
            index = list(self.states)
            near = reference[..., index]
            values[..., index] = near + wrap_angles(values[..., index] - near)
        return values

    def keep(self, x: np.ndarray) -> np.ndarray:
        """Wrap the angle states of ``x`` to ``(-pi, pi]`` in place; return ``x``."""
        if self.states:
            index = list(self.states)
            x[index] = wrap_angles(x[index])
        return x


def _positions(name: str, entries, size: int, names: Sequence[str]) -> tuple:
    found = set()
    for entry in entries:
        if isinstance(entry, bool) or not isinstance(entry, (int, np.integer)) or not (
                0 <= entry < size):
            raise ConfigError(name, f'expected 0-based indices below {size} ({list(names)}), '
                              f'got {entry!r}')
        if entry in found:
            raise ConfigError(name, f'{names[entry]} is named twice')
        found.add(int(entry))
    return tuple(sorted(found))


def check_angles(model, angle_states=(), angle_outputs=()) -> Angles:
    """
    Return the :class:`Angles` of ``model``, checked: a whole turn of each changes nothing.

    Parameters
    ----------
    model : StateSpaceModel
    angle_states : sequence of int
        The states kept in ``(-pi, pi]`` (0-based).
    angle_outputs : sequence of int
        The outputs whose innovations are wrapped (0-based).

    Returns
    -------
    Angles

    Raises
    ------
    ConfigError
        ``angle_states``: an index out of range or twice; a state whose column of ``A`` is
        not zero (continuous) or the unit column (discrete), or that reaches an output that
        is not an angle, or an angle output through a coefficient that is not a whole
        number. ``angle_outputs``: an index out of range or twice.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> from observer_ros.core.angles import check_angles
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, -2]], [[0], [1]], [[1, 0]],
    ...                                          state_names=['yaw', 'w'])
    >>> check_angles(model, [0], [0])
    Angles(states=(0,), outputs=(0,))
    >>> check_angles(model, [1], [0])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: angle_states: state w cannot be kept in (-pi, pi]: ...

    """
    n_states, n_outputs = model.n_states, model.n_outputs
    state_names = model.state_names or tuple(f'x{k + 1}' for k in range(n_states))
    output_names = model.output_names or tuple(f'y{k + 1}' for k in range(n_outputs))
    states = _positions('angle_states', angle_states, n_states, state_names)
    outputs = _positions('angle_outputs', angle_outputs, n_outputs, output_names)
    identity = np.eye(n_states)
    scale = max(1.0, float(np.abs(model.a).max()))
    for j in states:
        column = model.a[:, j] - (identity[:, j] if model.is_discrete else 0.0)
        if np.abs(column).max() > WHOLE_TOLERANCE * scale:
            expected = 'the unit column (x[k+1] = x[k] + ...)' if model.is_discrete else 'zero'
            raise ConfigError('angle_states', f'state {state_names[j]} cannot be kept in (-pi, '
                              f'pi]: its column of A must be {expected}, so that a whole turn '
                              f'of it changes no other state; got {model.a[:, j].tolist()}')
        for i in range(n_outputs):
            value = float(model.c[i, j])
            if i not in outputs and value != 0.0:
                raise ConfigError('angle_states', f'state {state_names[j]} cannot be kept in '
                                  f'(-pi, pi]: output {output_names[i]} (not in angle_outputs) '
                                  f'sees it ({value:g} {state_names[j]}), and a whole turn '
                                  f'would move it')
            if abs(value - round(value)) > WHOLE_TOLERANCE * max(1.0, abs(value)):
                raise ConfigError('angle_states', f'state {state_names[j]} cannot be kept in '
                                  f'(-pi, pi]: the angle output {output_names[i]} sees '
                                  f'{value:g} times it, not a whole number of turns')
    return Angles(states, outputs)
