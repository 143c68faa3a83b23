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
Models given as Python functions, for what expressions cannot say (a table, a solver).

A package registers a model in the entry point group :data:`GROUP`
(``observer_ros.nonlinear_models``), as observer types are registered: its setup.py says
``'observer_ros.nonlinear_models': ['my_base = my_package.models:make_base']``, and a
parameter file names it with ``model.function: my_base`` instead of ``model.dynamics`` and
``model.measurements`` (the state, input and output names and ``model.constant_*`` stay
in the file). The entry point gives a :class:`ModelFunctions`, or a callable that takes the
constants (``{name: value}``) and returns one.

No finite differences: a :class:`ModelFunctions` gives the Jacobians with the functions
(``f_jacobians``: ``df/dx`` and ``df/du``; ``h_jacobians``: ``dh/dx`` and ``dh/du``). A
value outside a function's domain may be returned as NaN or raised as ``ValueError``,
``OverflowError`` or ``ZeroDivisionError``: the filters drop and count the step.
"""

from dataclasses import dataclass
from importlib.metadata import entry_points
import math
from typing import Callable, Mapping, Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear.model import DOMAIN_ERRORS, NonlinearModel

__all__ = ['FunctionModel', 'GROUP', 'ModelFunctions', 'function_model',
           'registered_functions']

#: The entry point group of models given as Python functions.
GROUP = 'observer_ros.nonlinear_models'


@dataclass(frozen=True)
class ModelFunctions:
    """
    A model's functions and their Jacobians, all of ``(x, u)`` (numpy arrays).

    Attributes
    ----------
    f : callable
        ``x' = f(x, u)`` (or ``x[k+1]``), shape ``(n,)``.
    h : callable
        ``y = h(x, u)`` of every output, shape ``(p,)``.
    f_jacobians : callable
        ``(df/dx, df/du)``, shapes ``(n, n)`` and ``(n, m)``.
    h_jacobians : callable
        ``(dh/dx, dh/du)``, shapes ``(p, n)`` and ``(p, m)``.

    """

    f: Callable
    h: Callable
    f_jacobians: Callable
    h_jacobians: Callable


def registered_functions() -> dict:
    """Return the entry points of :data:`GROUP` by name (not loaded)."""
    return {entry_point.name: entry_point for entry_point in entry_points(group=GROUP)}


def _call(function, x, u, shapes) -> tuple:
    """Call a user's function; its results as float arrays of ``shapes``, NaN if it failed."""
    try:
        result = function(x, u)
    except DOMAIN_ERRORS:
        return tuple(np.full(shape, math.nan) for shape in shapes)
    results = (result,) if len(shapes) == 1 else tuple(result)
    arrays = []
    for value, shape in zip(results, shapes):
        array = np.asarray(value, dtype=float)
        if array.size == 0 and 0 in shape:
            array = array.reshape(shape)
        arrays.append(array)
    if len(arrays) != len(shapes) or any(
            array.shape != shape for array, shape in zip(arrays, shapes)):
        raise ValueError(f'expected arrays of shapes {list(shapes)}, got '
                         f'{[array.shape for array in arrays]}')
    return tuple(arrays)


class _Measurement:
    """``(h, H)`` of some outputs, as :meth:`NonlinearModel.measurement` gives them."""

    def __init__(self, model: 'FunctionModel', outputs: tuple) -> None:
        self.model, self.rows = model, list(outputs)

    def __call__(self, x, u) -> tuple:
        values, (jacobian, _) = self.model.h_all(x, u), self.model.h_jacobians(x, u)
        return values[self.rows], jacobian[self.rows]

    def values(self, x, u) -> np.ndarray:
        return self.model.h_all(x, u)[self.rows]

    def many(self, points, u) -> np.ndarray:
        return np.array([self.values(point, u) for point in np.asarray(points, dtype=float)]
                        ).reshape(len(points), len(self.rows))


class FunctionModel(NonlinearModel):
    """
    A nonlinear model of Python functions (:class:`ModelFunctions`), run as the equations are.

    Parameters
    ----------
    functions : ModelFunctions
    states, inputs, outputs : sequence of str
        The names, in the order of ``x``, ``u`` and ``y``.
    dt : float
        0: continuous; the sample period of a discrete model.
    angle_states, angle_outputs : sequence of str
    name : str
        The registered name, for the messages.

    Raises
    ------
    ConfigError
        As :class:`NonlinearModel` for the names (``states``...).

    """

    def __init__(self, functions: ModelFunctions, states: Sequence[str],
                 outputs: Sequence[str], inputs: Sequence[str] = (), dt: float = 0.0,
                 angle_states: Sequence[str] = (), angle_outputs: Sequence[str] = (),
                 name: str = '') -> None:
        self.functions, self.name = functions, name
        self.state_names = self._names('states', states)
        self.input_names = self._names('inputs', inputs)
        self.output_names = self._names('outputs', outputs)
        if not self.state_names:
            raise ConfigError('states', 'expected at least one state name')
        self.constant_names, self.constants = (), {}
        self.dynamics = self.outputs = ()
        self.dt = float(dt)
        self.angle_states = self._indices('angle_states', angle_states, self.state_names)
        self.angle_outputs = self._indices('angle_outputs', angle_outputs, self.output_names)
        self.parameters = np.zeros(0)
        self._measurements: dict = {}

    def f(self, x, u) -> np.ndarray:
        """Return the dynamics at ``(x, u)``, shape ``(n,)`` (NaN: outside its domain)."""
        return _call(self.functions.f, x, u, ((self.n_states,),))[0]

    def f_and_jacobian(self, x, u) -> tuple:
        """Return ``f(x, u)`` and ``df/dx``."""
        return self.f(x, u), self.f_jacobians(x, u)[0]

    def f_jacobians(self, x, u) -> tuple:
        """Return ``(df/dx, df/du)``."""
        n, m = self.n_states, self.n_inputs
        return _call(self.functions.f_jacobians, x, u, ((n, n), (n, m)))

    def f_many(self, points, u) -> np.ndarray:
        """Return ``f`` at each of ``points`` ``(k, n)``: ``(k, n)``."""
        return np.array([self.f(point, u) for point in np.asarray(points, dtype=float)])

    def h_all(self, x, u) -> np.ndarray:
        """Return ``h(x, u)`` of every output, shape ``(p,)``."""
        return _call(self.functions.h, x, u, ((self.n_outputs,),))[0]

    def h_jacobians(self, x, u) -> tuple:
        """Return ``(dh/dx, dh/du)``."""
        n, m, p = self.n_states, self.n_inputs, self.n_outputs
        return _call(self.functions.h_jacobians, x, u, ((p, n), (p, m)))

    def measurement(self, outputs: Optional[tuple] = None):
        """Return ``(h, H)`` of ``outputs`` (None: every output) as a function of ``(x, u)``."""
        key = tuple(range(self.n_outputs)) if outputs is None else tuple(outputs)
        function = self._measurements.get(key)
        if function is None:
            function = self._measurements[key] = _Measurement(self, key)
        return function

    def symbolic(self) -> tuple:
        """Refuse: a model of Python functions has no symbolic expressions."""
        raise ConfigError('function', f'{self.name!r} is a model of Python functions; '
                          'it has no symbolic expressions')

    def jacobians_at(self, x, u) -> tuple:
        """Return ``(A, B, C, D)``: the Jacobians at ``(x, u)``."""
        return self.f_jacobians(x, u) + self.h_jacobians(x, u)


def function_model(name: str, constants: Mapping[str, float], states: Sequence[str],
                   outputs: Sequence[str], inputs: Sequence[str] = (), dt: float = 0.0,
                   angle_states: Sequence[str] = (),
                   angle_outputs: Sequence[str] = ()) -> FunctionModel:
    """
    Return the model registered as ``name`` in :data:`GROUP`, made with ``constants``.

    Raises
    ------
    ConfigError
        ``function``: no such entry point (naming those registered), one that fails to
        load, or that gives no :class:`ModelFunctions`.

    """
    found = registered_functions()
    if name not in found:
        known = sorted(found) or f'none: the entry point group {GROUP} is empty'
        raise ConfigError('function', f'no model {name!r} is registered in {GROUP}; '
                          f'registered: {known}')
    entry_point = found[name]
    try:
        made = entry_point.load()
        if not isinstance(made, ModelFunctions) and callable(made):
            made = made(dict(constants))
    except Exception as e:  # noqa: B902 (a plug-in may raise anything)
        raise ConfigError('function', f'entry point {name!r} = {entry_point.value} of {GROUP} '
                          f'failed to load: {type(e).__name__}: {e}') from e
    if not isinstance(made, ModelFunctions):
        raise ConfigError('function', f'entry point {name!r} = {entry_point.value} of {GROUP}: '
                          f'expected ModelFunctions (f, h and their Jacobians: no finite '
                          f'differences), got {type(made).__name__}')
    return FunctionModel(made, states, outputs, inputs, dt, angle_states, angle_outputs,
                         name=name)
