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

"""Checks of values that several settings share: vectors inside limits, names as indices."""

from typing import Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.simulation import input_limits_from_flat


def check_inside(parameter: str, vector: np.ndarray, limits, source: str) -> None:
    """
    Refuse a vector outside ``limits`` (an ``(m, 2)`` array, or a magnitude bound).

    Raises
    ------
    ConfigError
        ``parameter``: the vector, and the limits of ``source`` it lies outside.

    """
    if limits is None:
        return
    if np.ndim(limits) == 0:
        outside = np.abs(vector) > limits
    else:
        outside = (vector < limits[:, 0]) | (vector > limits[:, 1])
    if outside.any():
        raise ConfigError(parameter, f'{vector.tolist()} lies outside {source} '
                          f'({np.asarray(limits).tolist()})')


def input_limits(parameter: str, values: Sequence[float],
                 n_inputs: int) -> Optional[np.ndarray]:
    """
    Return ``[min, max]`` per input, ``(m, 2)``, of a limits parameter (None when empty).

    Raises
    ------
    ConfigError
        ``parameter``: limits for a model without inputs, or a wrong count or order.

    """
    if values and not n_inputs:
        raise ConfigError(parameter, 'the model has no inputs (model.B is empty, m = 0): '
                          'expected no limits')
    try:
        return input_limits_from_flat(values, n_inputs)
    except ConfigError as e:
        raise ConfigError(parameter, e.reason) from e


def indices(parameter: str, entries: Sequence[str], names: Sequence[str], what: str) -> tuple:
    """
    Return the indices of ``entries``: names in ``names``, or 0-based indices.

    Raises
    ------
    ConfigError
        ``parameter``: an entry that is no ``what`` of the model.

    """
    found = []
    for entry in entries:
        if entry in names:
            found.append(names.index(entry))
        elif entry.isdigit() and int(entry) < len(names):
            found.append(int(entry))
        else:
            raise ConfigError(parameter, f'{entry!r} is no {what} of the model (expected one '
                              f'of {list(names)} or an index 0 ... {len(names) - 1})')
    return tuple(found)
