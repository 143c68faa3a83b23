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
A nonlinear model linearized exactly at an operating point: the linear model it carries.

:func:`linearize` evaluates SymPy's exact Jacobians ``A = df/dx``, ``B = df/du``,
``C = dh/dx`` and ``D = dh/du`` at the operating point ``(x0, u0)`` (generated functions
called with the model's exact binary parameters; a model of Python functions gives its own
Jacobians: no finite differences). The result is a
:class:`LinearizedModel`: a :class:`~observer_ros.core.model.StateSpaceModel` that also
carries the equations, so everything that reads a linear model (the names, the sources'
outputs, the topics, the designs of the linear types) reads it, and an estimator that can
run the equations (the extended and unscented Kalman filters) asks for
:attr:`LinearizedModel.nonlinear`.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.nonlinear.model import NonlinearModel

__all__ = ['LinearizedModel', 'linearize', 'nonlinear_model_of']


@dataclass(frozen=True, eq=False)
class LinearizedModel(StateSpaceModel):
    """
    The linearization of :attr:`nonlinear` at ``(operating_state, operating_input)``.

    Attributes
    ----------
    nonlinear : NonlinearModel
        The equations the model was linearized from.
    operating_state : numpy.ndarray, shape (n,)
    operating_input : numpy.ndarray, shape (m,)

    """

    nonlinear: Optional[NonlinearModel] = None
    operating_state: Optional[np.ndarray] = None
    operating_input: Optional[np.ndarray] = None


def nonlinear_model_of(model) -> Optional[NonlinearModel]:
    """Return the equations a model carries (a :class:`LinearizedModel`'s), else None."""
    return getattr(model, 'nonlinear', None)


def _point(name: str, values, size: int, names: tuple) -> np.ndarray:
    values = [] if values is None else list(values)
    if not values:
        return np.zeros(size)
    if len(values) != size:
        raise ConfigError(name, f'expected {size} values (one per name of {list(names)}), '
                          f'got {len(values)}')
    point = np.array(values, dtype=float)
    if not np.isfinite(point).all():
        raise ConfigError(name, f'expected finite numbers, got {values}')
    return point


def linearize(model: NonlinearModel, operating_state=None,
              operating_input=None) -> LinearizedModel:
    """
    Return ``model`` linearized exactly at ``(operating_state, operating_input)``.

    Parameters
    ----------
    model : NonlinearModel
    operating_state : array_like, shape (n,), optional
        ``x0`` (default: zero).
    operating_input : array_like, shape (m,), optional
        ``u0`` (default: zero).

    Returns
    -------
    LinearizedModel
        ``A``, ``B``, ``C``, ``D`` at the point, the model's names and ``dt``.

    Raises
    ------
    ConfigError
        ``operating_state`` or ``operating_input``: a wrong count, a value not finite, or a
        point where a Jacobian is not finite (outside a function's domain).

    Examples
    --------
    >>> from observer_ros.core.nonlinear import NonlinearModel
    >>> pendulum = NonlinearModel(['q', 'dq'], {'q': 'dq', 'dq': '-9.81 * sin(q) + u'},
    ...                           {'angle': 'q'}, ['u'])
    >>> linearize(pendulum, [0.0, 0.0]).a.tolist()
    [[0.0, 1.0], [-9.81, -0.0]]

    """
    x0 = _point('operating_state', operating_state, model.n_states, model.state_names)
    u0 = _point('operating_input', operating_input, model.n_inputs, model.input_names)
    a, b, c, d = model.jacobians_at(x0, u0)
    if not all(np.isfinite(matrix).all() for matrix in (a, b, c, d)):
        raise ConfigError('operating_state', 'the Jacobians are not finite at the operating '
                          f'point (x0 = {x0.tolist()}, u0 = {u0.tolist()}); expected a point '
                          'inside the domain of every function of the model')
    return LinearizedModel(
        a, b, c, d, model.dt, tuple(model.state_names), tuple(model.input_names),
        tuple(model.output_names), nonlinear=model, operating_state=x0, operating_input=u0)
