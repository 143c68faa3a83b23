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
A nonlinear model written as equations: ``x' = f(x, u)`` (or ``x+ = f(x, u)``), ``y = h(x, u)``.

The user names the states, inputs, outputs and constants and writes each state's dynamics
and each output's measurement as an expression over those names
(:mod:`observer_ros.core.nonlinear.expressions`: a whitelist, nothing evaluated). The model
then derives the exact Jacobians ``F = df/dx`` and ``H = dh/dx`` with SymPy and generates
plain Python functions of them (``lambdify`` with common subexpressions, ``cse``) that the
filters call at run time; no finite differences.

Why SymPy and not CasADi (measured on the differential-drive model, 5 states, 2 inputs;
``benchmarks/nonlinear.py`` and ``doc/nonlinear.md``): a generated SymPy function costs
2-3.5 us per call from Python where a ``casadi.Function`` costs 25 us (its call converts
every argument to a ``DM`` and back), the wheel is 6.5 MB plus mpmath against ~93 MB (277 MB
installed), and it is a rosdep key (``python3-sympy``). SymPy's import (~0.5 s) is paid when
a model is built, never per message.

Every number of the expressions and every constant is passed to the generated functions as
a parameter (a float vector), never printed into generated code: the functions compute with
the exact binary values given (SymPy prints floats with 15 digits).
"""

from dataclasses import dataclass
import math
from typing import Mapping, Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear.expressions import (
    Expression, parse_expression, reserved_name_problem)

__all__ = ['NonlinearModel', 'differential_drive', 'linear_as_expressions']

#: What a model's generated functions raise on a value outside a function's domain (the
#: ``math`` module's ``sqrt(-1)``, ``log(0)``, an overflow, a division by zero): a call that
#: raises one gives NaN, which the filters drop and count.
DOMAIN_ERRORS = (ValueError, OverflowError, ZeroDivisionError)


def _heaviside(value, at_zero=0.5):
    """Return the step of the derivative of ``min``/``max`` (SymPy's ``Heaviside``)."""
    return at_zero if value == 0 else (1.0 if value > 0 else 0.0)


def _sign(value):
    return 0.0 if value == 0 else math.copysign(1.0, value)


@dataclass(frozen=True)
class _Compiled:
    """A generated function of ``(x, u, parameters)`` and the shape of what it returns."""

    function: object
    rows: int

    def __call__(self, x, u, parameters):
        try:
            return self.function(x, u, parameters)
        except DOMAIN_ERRORS:
            return None


class NonlinearModel:
    """
    A nonlinear model from equations, with exact Jacobians.

    Parameters
    ----------
    states : sequence of str
        The state names, in the order of ``x``.
    dynamics : mapping of str to str
        Each state's expression: ``x' = f(x, u)`` (continuous) or ``x[k+1] = f(x[k], u[k])``
        (``dt > 0``).
    outputs : mapping of str to str
        Each output's measurement expression ``h(x, u)``, in the order of ``y``.
    inputs : sequence of str
        The input names, in the order of ``u``.
    constants : mapping of str to float
        Named constants (masses, a wheel radius) the expressions may use.
    dt : float
        0: continuous; the sample period of a discrete model.
    angle_states, angle_outputs : sequence of str
        States kept in ``(-pi, pi]`` and outputs whose innovations are wrapped.

    Raises
    ------
    ConfigError
        A name that is reserved or given twice (``states``, ``inputs``, ``outputs``,
        ``constants``), a state without dynamics or dynamics of an unknown state, a
        constant that is not a finite number, an angle that is not a state or output;
        :class:`~observer_ros.core.nonlinear.expressions.ExpressionError` for an expression
        (``dynamics.<state>``, ``outputs.<output>``).

    Examples
    --------
    >>> model = NonlinearModel(['q', 'dq'], {'q': 'dq', 'dq': '-g / l * sin(q)'},
    ...                        {'angle': 'q'}, constants={'g': 9.81, 'l': 1.0})
    >>> model.f([0.5, 0.0], []).round(4).tolist()
    [0.0, -4.7032]
    >>> model.jacobian([0.0, 0.0], []).tolist()
    [[0.0, 1.0], [-9.81, 0.0]]

    """

    def __init__(self, states: Sequence[str], dynamics: Mapping[str, str],
                 outputs: Mapping[str, str], inputs: Sequence[str] = (),
                 constants: Optional[Mapping[str, float]] = None, dt: float = 0.0,
                 angle_states: Sequence[str] = (), angle_outputs: Sequence[str] = ()) -> None:
        constants = dict(constants or {})
        self.state_names = self._names('states', states)
        self.input_names = self._names('inputs', inputs)
        self.output_names = self._names('outputs', list(outputs))
        self.constant_names = self._names('constants', list(constants))
        seen: dict = {}
        for kind, names in (('states', self.state_names), ('inputs', self.input_names),
                            ('constants', self.constant_names)):
            for name in names:
                if name in seen:
                    raise ConfigError(kind, f'{name!r} is one of the {seen[name]} already')
                seen[name] = kind
        if not self.state_names:
            raise ConfigError('states', 'expected at least one state name')
        for name, value in constants.items():
            if (isinstance(value, bool) or not isinstance(value, (int, float))
                    or not math.isfinite(value)):
                raise ConfigError(f'constants.{name}', f'expected a finite number, got '
                                  f'{value!r}')
        self.constants = {name: float(value) for name, value in constants.items()}
        if isinstance(dt, bool) or not isinstance(dt, (int, float)) or not (
                math.isfinite(dt) and dt >= 0.0):
            raise ConfigError('dt', f'expected 0 (continuous) or a sample period > 0, got '
                              f'{dt!r}')
        self.dt = float(dt)
        unknown = sorted(set(dynamics) - set(self.state_names))
        if unknown:
            raise ConfigError('dynamics', f'{unknown} are not states (states: '
                              f'{list(self.state_names)})')
        missing = [name for name in self.state_names if name not in dynamics]
        if missing:
            raise ConfigError('dynamics', f'expected an expression for each state; missing '
                              f'{missing}')
        usable = self.state_names + self.input_names + self.constant_names
        self.dynamics = tuple(parse_expression(dynamics[name], usable, f'dynamics.{name}')
                              for name in self.state_names)
        self.outputs = tuple(parse_expression(outputs[name], usable, f'outputs.{name}')
                             for name in self.output_names)
        self.angle_states = self._indices('angle_states', angle_states, self.state_names)
        self.angle_outputs = self._indices('angle_outputs', angle_outputs, self.output_names)
        self._build()

    @staticmethod
    def _names(kind: str, names) -> tuple:
        if isinstance(names, str):
            raise ConfigError(kind, f'expected a list of names, got the string {names!r}')
        names = tuple(names)
        for name in names:
            problem = reserved_name_problem(name)
            if problem is not None:
                raise ConfigError(kind, problem)
        if len(set(names)) != len(names):
            twice = sorted({name for name in names if names.count(name) > 1})
            raise ConfigError(kind, f'{twice} named twice')
        return names

    @staticmethod
    def _indices(kind: str, names, known: tuple) -> tuple:
        if isinstance(names, str):
            raise ConfigError(kind, f'expected a list of names, got the string {names!r}')
        indices = set()
        for name in names:
            if name not in known:
                raise ConfigError(kind, f'{name!r} is not one of {list(known)}')
            indices.add(known.index(name))
        return tuple(sorted(indices))

    # --- sizes -----------------------------------------------------------------------------

    @property
    def n_states(self) -> int:
        """Number of states."""
        return len(self.state_names)

    @property
    def n_inputs(self) -> int:
        """Number of inputs."""
        return len(self.input_names)

    @property
    def n_outputs(self) -> int:
        """Number of outputs."""
        return len(self.output_names)

    @property
    def is_discrete(self) -> bool:
        """Whether the model is discrete (``dt > 0``)."""
        return self.dt > 0.0

    # --- the symbolic side (SymPy, at build time only) -------------------------------------

    def _build(self) -> None:
        """Make the symbolic ``f``, ``h`` and their Jacobians, and generate ``f`` with ``F``."""
        import sympy as sp
        self._sp = sp
        x = sp.symbols(f'x0:{self.n_states}', real=True)
        u = sp.symbols(f'u0:{self.n_inputs}', real=True) if self.n_inputs else ()
        numbers: list = list(self.constants.values())
        symbols = dict(zip(self.state_names, x))
        symbols.update(zip(self.input_names, u))
        for k, name in enumerate(self.constant_names):
            symbols[name] = sp.Symbol(f'k{k}', real=True)
        literal: dict = {}

        def number(value):
            if isinstance(value, int):
                return sp.Integer(value)
            if value not in literal:  # each float a parameter: its exact binary value
                literal[value] = sp.Symbol(f'k{len(numbers)}', real=True)
                numbers.append(float(value))
            return literal[value]

        functions = {'sin': sp.sin, 'cos': sp.cos, 'tan': sp.tan, 'asin': sp.asin,
                     'acos': sp.acos, 'atan': sp.atan, 'atan2': sp.atan2, 'sinh': sp.sinh,
                     'cosh': sp.cosh, 'tanh': sp.tanh, 'exp': sp.exp, 'log': sp.log,
                     'sqrt': sp.sqrt, 'abs': sp.Abs, 'min': sp.Min, 'max': sp.Max}
        constants = {'pi': sp.pi, 'e': sp.E}

        def make(expression: Expression):
            return sp.sympify(expression.build(symbols, functions, constants, number))

        self._f = [make(e) for e in self.dynamics]
        self._h = [make(e) for e in self.outputs]
        self._x, self._u = x, u
        self._k = sp.symbols(f'k0:{len(numbers)}', real=True) if numbers else ()
        self.parameters = np.array(numbers, dtype=float)
        self._jacobian = [[sp.diff(fi, xj) for xj in x] for fi in self._f]
        self._f_only = self._lambdify(self._f)
        flat = [entry for row in self._jacobian for entry in row]
        self._f_jacobian = self._lambdify(self._f + flat)
        self._f_many = self._lambdify(self._f, many=True)
        self._measurements: dict = {}

    def _lambdify(self, expressions, many: bool = False):
        """Generate a function of ``(x, u, parameters)``: ``math`` on floats, or numpy on rows."""
        sp = self._sp
        modules = ('numpy' if many else
                   [{'Heaviside': _heaviside, 'sign': _sign}, 'math'])
        function = sp.lambdify([list(self._x), list(self._u), list(self._k)], expressions,
                               modules=modules, cse=True)
        return (_Many if many else _Compiled)(function, len(expressions))

    def symbolic(self) -> tuple:
        """Return SymPy's expressions and symbols: ``(f, h, x, u)``."""
        return list(self._f), list(self._h), self._x, self._u

    def jacobians_at(self, x, u) -> tuple:
        """
        Return ``(A, B, C, D)``: ``df/dx``, ``df/du``, ``dh/dx``, ``dh/du`` at ``(x, u)``.

        SymPy's exact derivatives, generated on first use and called with the model's exact
        binary parameters; NaN outside a function's domain.
        """
        n, m, p = self.n_states, self.n_inputs, self.n_outputs
        if getattr(self, '_at', None) is None:
            sp, variables = self._sp, tuple(self._x) + tuple(self._u)
            rows = [sp.diff(e, v) for e in self._f + self._h for v in variables]
            self._at = self._lambdify(rows) if rows else None
        with np.errstate(all='ignore'):
            values = self._at(x, u, self.parameters) if self._at is not None else []
        values = np.array([math.nan] * ((n + p) * (n + m)) if values is None else values,
                          dtype=float).reshape(n + p, n + m)
        return (values[:n, :n].copy(), values[:n, n:].copy(), values[n:, :n].copy(),
                values[n:, n:].copy())

    # --- numbers (what the filters call) ---------------------------------------------------

    def f(self, x, u) -> np.ndarray:
        """
        Return the dynamics at ``(x, u)``, shape ``(n,)``; NaN where a function left its domain.

        Examples
        --------
        >>> differential_drive().f([0, 0, 0, 1.0, 0.5], [0, 0]).tolist()
        [1.0, 0.0, 0.5, 0.0, 0.0]

        """
        values = self._f_only(x, u, self.parameters)
        if values is None:
            return np.full(self.n_states, math.nan)
        return np.array(values, dtype=float)

    def f_and_jacobian(self, x, u) -> tuple:
        """Return ``f(x, u)`` and ``F = df/dx``, shapes ``(n,)`` and ``(n, n)`` (NaN: domain)."""
        n = self.n_states
        values = self._f_jacobian(x, u, self.parameters)
        if values is None:
            return np.full(n, math.nan), np.full((n, n), math.nan)
        values = np.array(values, dtype=float)
        return values[:n], values[n:].reshape(n, n)

    def f_many(self, points, u) -> np.ndarray:
        """
        Return the dynamics at many states ``points`` ``(k, n)`` with ``u``: ``(k, n)``.

        One vectorized call (the unscented filter's sigma points); NaN where a function left
        its domain.
        """
        return self._f_many(points, u, self.parameters)

    def jacobian(self, x, u) -> np.ndarray:
        """Return ``F = df/dx`` at ``(x, u)``, shape ``(n, n)``."""
        return self.f_and_jacobian(x, u)[1]

    def measurement(self, outputs: Optional[tuple] = None):
        """
        Return the generated ``(h, H)`` of some outputs: a function of ``(x, u)``.

        ``outputs``: indices into ``y`` (a source's); None: every output. Generated on first
        use and kept.

        Examples
        --------
        >>> h = differential_drive().measurement((2,))
        >>> [value.tolist() for value in h([0, 0, 0, 1.0, 0.5], [0, 0])]
        [[0.5], [[0.0, 0.0, 0.0, 0.0, 1.0]]]

        """
        key = tuple(range(self.n_outputs)) if outputs is None else tuple(outputs)
        function = self._measurements.get(key)
        if function is None:
            for index in key:
                if not (isinstance(index, (int, np.integer)) and 0 <= index < self.n_outputs):
                    raise ConfigError('outputs', f'expected indices below {self.n_outputs}, '
                                      f'got {list(key)}')
            sp = self._sp
            rows = [self._h[i] for i in key]
            jacobian = [sp.diff(hi, xj) for hi in rows for xj in self._x]
            function = _MeasurementFunction(self._lambdify(rows + jacobian),
                                            self._lambdify(rows, many=True), len(key),
                                            self.n_states, self.parameters)
            self._measurements[key] = function
        return function

    def h(self, x, u, outputs: Optional[tuple] = None) -> np.ndarray:
        """Return the measurement of ``outputs`` (all: None) at ``(x, u)``, shape ``(q,)``."""
        return self.measurement(outputs).values(x, u)


@dataclass(frozen=True)
class _Many:
    """A generated numpy function of ``(X^T, u, parameters)`` for ``k`` points at once."""

    function: object
    rows: int

    def __call__(self, points, u, parameters) -> np.ndarray:
        points = np.asarray(points, dtype=float)
        result = np.empty((len(points), self.rows))
        with np.errstate(all='ignore'):  # outside a domain: NaN, dropped by the filters
            values = self.function(points.T, u, parameters)
        for row, value in enumerate(values):
            result[:, row] = value  # a constant entry is broadcast
        return result


class _MeasurementFunction:
    """``(h, H)`` of some outputs at ``(x, u)``: NaN where a function left its domain."""

    def __init__(self, compiled: _Compiled, values: _Compiled, rows: int, n_states: int,
                 parameters: np.ndarray) -> None:
        self.compiled, self.rows, self.n_states = compiled, rows, n_states
        self._values = values
        self.parameters = parameters

    def many(self, points, u) -> np.ndarray:
        """Return ``h`` at many states ``points`` ``(k, n)``: ``(k, q)`` (sigma points)."""
        return self._values(points, u, self.parameters)

    def values(self, x, u) -> np.ndarray:
        """Return ``h(x, u)`` alone, shape ``(q,)``."""
        return self._values(np.asarray(x, dtype=float)[None, :], u, self.parameters)[0]

    def __call__(self, x, u) -> tuple:
        values = self.compiled(x, u, self.parameters)
        rows = self.rows
        if values is None:
            return np.full(rows, math.nan), np.full((rows, self.n_states), math.nan)
        values = np.array(values, dtype=float)
        return values[:rows], values[rows:].reshape(rows, self.n_states)


def differential_drive(wheel_radius: float = 0.05, track_width: float = 0.3,
                       camera: bool = True) -> NonlinearModel:
    """
    Return the differential-drive example: pose, speed and turn rate from wheels, IMU, camera.

    States ``px, py, yaw, v, w`` (``yaw`` an angle), inputs ``a, alpha`` (accelerations),
    outputs ``wheel_left, wheel_right`` (rad/s), ``gyro_z`` (rad/s) and, with ``camera``,
    ``cam_x, cam_y, cam_yaw`` (``cam_yaw`` an angle).

    Examples
    --------
    >>> differential_drive().output_names
    ('wheel_left', 'wheel_right', 'gyro_z', 'cam_x', 'cam_y', 'cam_yaw')

    """
    outputs = {'wheel_left': '(v - w * b / 2) / r', 'wheel_right': '(v + w * b / 2) / r',
               'gyro_z': 'w'}
    if camera:
        outputs.update({'cam_x': 'px', 'cam_y': 'py', 'cam_yaw': 'yaw'})
    return NonlinearModel(
        ['px', 'py', 'yaw', 'v', 'w'],
        {'px': 'v * cos(yaw)', 'py': 'v * sin(yaw)', 'yaw': 'w', 'v': 'a', 'w': 'alpha'},
        outputs, inputs=['a', 'alpha'], constants={'r': wheel_radius, 'b': track_width},
        angle_states=['yaw'], angle_outputs=['cam_yaw'] if camera else [])


def linear_as_expressions(model) -> NonlinearModel:
    """
    Return a linear :class:`~observer_ros.core.model.StateSpaceModel` written as equations.

    ``x' = A x + B u`` (or ``x+``) and ``y = C x`` as expressions of its entries (exact:
    each number becomes a parameter); ``D`` must be zero.

    Raises
    ------
    ConfigError
        ``D`` is not zero.

    Examples
    --------
    >>> from observer_ros.core.model import StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> linear_as_expressions(model).dynamics[0].text
    '1.0 * x2'

    """
    if np.any(model.d != 0.0):
        raise ConfigError('D', 'a model written as equations measures h(x, u) of the state; '
                          'expected D = 0')
    states = [f'x{k + 1}' for k in range(model.n_states)]
    inputs = [f'u{k + 1}' for k in range(model.n_inputs)]
    outputs = [f'y{k + 1}' for k in range(model.n_outputs)]

    def row(coefficients, names) -> list:
        return [f'{float(value)!r} * {name}' for value, name in zip(coefficients, names)
                if value != 0.0]

    dynamics = {state: ' + '.join(row(model.a[i], states) + row(model.b[i], inputs)) or '0'
                for i, state in enumerate(states)}
    measured = {output: ' + '.join(row(model.c[i], states)) or '0'
                for i, output in enumerate(outputs)}
    return NonlinearModel(states, dynamics, measured, inputs, dt=model.dt)
