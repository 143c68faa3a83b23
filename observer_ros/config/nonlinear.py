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
The parameters of a model written as equations, read into a NonlinearModel.

Flat ROS parameters, as every other section: the names of ``model.state_names``,
``model.input_names`` and ``model.output_names``, one expression per state in
``model.dynamics`` and one per output in ``model.measurements`` (in those orders), named
constants in ``model.constant_names`` / ``model.constant_values``, angles in
``model.angle_states`` / ``model.angle_outputs`` (names), ``model.dt``::

    model.state_names: [px, py, yaw, v, w]
    model.input_names: [a, alpha]
    model.dynamics: ['v * cos(yaw)', 'v * sin(yaw)', 'w', 'a', 'alpha']
    model.output_names: [wheel_left, wheel_right, gyro_z]
    model.measurements: ['(v - w * b / 2) / r', '(v + w * b / 2) / r', 'w']
    model.constant_names: [r, b]
    model.constant_values: [0.05, 0.3]
    model.angle_states: [yaw]

:data:`NONLINEAR_PARAMETERS` describes the parameters this module adds (name, type, default,
description) for the schema; :func:`read_nonlinear_model` builds the model, with every error
named by its parameter (``model.dynamics: entry 3 (yaw): ...``).
"""

from typing import Any, Mapping, Optional

from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear.functions import function_model
from observer_ros.core.nonlinear.linearize import linearize, LinearizedModel
from observer_ros.core.nonlinear.model import NonlinearModel

__all__ = ['NONLINEAR_PARAMETERS', 'read_linearized_model', 'read_nonlinear_model']

#: ``(name, value type, default, description)`` of the parameters of the equations; the
#: names, angles and ``model.dt`` are the linear model's own parameters.
NONLINEAR_PARAMETERS = (
    ('model.dynamics', 'string_array', [], 'A model written as equations: one expression '
     'per state of model.state_names, dx/dt = f(x, u) (x[k+1] with model.dt > 0), over the '
     'state, input and constant names; + - * / ** unary -, parentheses, sin cos tan asin '
     'acos atan atan2 sinh cosh tanh exp log sqrt abs min max, pi, e. Empty: the linear '
     'model of A, B, C.'),
    ('model.measurements', 'string_array', [], 'With model.dynamics: one expression h(x, u) '
     'per output of model.output_names.'),
    ('model.constant_names', 'string_array', [], 'With model.dynamics: names of constants '
     'the expressions use (a wheel radius, a mass).'),
    ('model.constant_values', 'double_array', [], 'With model.dynamics: the value of each of '
     'model.constant_names.'),
    ('model.operating_point_states', 'double_array', [], 'With model.dynamics: the state x0 '
     'where the equations are linearized exactly (the linear model the names, sources and '
     'designs read), one value per name of model.state_names. Empty: zero.'),
    ('model.operating_point_inputs', 'double_array', [], 'With model.dynamics: the input u0 '
     'of the operating point, one value per name of model.input_names. Empty: zero.'),
    ('model.function', 'string', '', 'Instead of model.dynamics and model.measurements: the '
     'name of a model of Python functions registered in the entry point group '
     'observer_ros.nonlinear_models (f, h and their Jacobians; made with the constants of '
     'model.constant_names). Empty: none.'),
)

#: The linear model's own parameters, which a model written as equations replaces.
LINEAR_PARAMETERS = ('model.A', 'model.B', 'model.C', 'model.D')

#: The arguments of :class:`NonlinearModel` and the parameters that give them.
PARAMETER_OF = {'states': 'model.state_names', 'inputs': 'model.input_names',
                'outputs': 'model.output_names', 'constants': 'model.constant_names',
                'dynamics': 'model.dynamics', 'angle_states': 'model.angle_states',
                'angle_outputs': 'model.angle_outputs', 'dt': 'model.dt'}


def _strings(params: Mapping[str, Any], name: str) -> list:
    values = params.get(name) or []
    if isinstance(values, str) or not all(isinstance(value, str) for value in values):
        raise ConfigError(name, f'expected a list of strings, got {values!r}')
    return list(values)


def read_nonlinear_model(params: Mapping[str, Any]) -> Optional[NonlinearModel]:
    """
    Return the model the equations of ``params`` define, or None without ``model.dynamics``.

    Parameters
    ----------
    params : mapping
        Flat parameters (``{'model.dynamics': [...], ...}``).

    Raises
    ------
    ConfigError
        Named by the parameter: a count that does not match its names, an expression that is
        not allowed (``model.dynamics: entry 3 (yaw): 'w.real' at column 1: ...``), a name
        reserved or given twice.

    Examples
    --------
    >>> model = read_nonlinear_model({
    ...     'model.state_names': ['q', 'dq'], 'model.dynamics': ['dq', '-g * sin(q)'],
    ...     'model.output_names': ['angle'], 'model.measurements': ['q'],
    ...     'model.constant_names': ['g'], 'model.constant_values': [9.81]})
    >>> model.f([0.5, 0.0], []).round(3).tolist()
    [0.0, -4.703]
    >>> read_nonlinear_model({'model.dynamics': ['1'], 'model.state_names': ['a', 'b']})
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: model.dynamics: expected one expression per state \
of model.state_names (2: ['a', 'b']), got 1

    """
    dynamics = _strings(params, 'model.dynamics')
    function = params.get('model.function') or ''
    if function:
        return _function_model(params, function, dynamics)
    if not dynamics:
        return None
    states = _strings(params, 'model.state_names')
    outputs = _strings(params, 'model.output_names')
    measurements = _strings(params, 'model.measurements')
    constant_names = _strings(params, 'model.constant_names')
    constant_values = list(params.get('model.constant_values') or [])
    for name, values, names, of in (
            ('model.dynamics', dynamics, states, 'state of model.state_names'),
            ('model.measurements', measurements, outputs, 'output of model.output_names'),
            ('model.constant_values', constant_values, constant_names,
             'name of model.constant_names')):
        if len(values) != len(names):
            what = 'expression' if name != 'model.constant_values' else 'value'
            raise ConfigError(name, f'expected one {what} per {of} ({len(names)}: '
                              f'{names}), got {len(values)}')
    try:
        return NonlinearModel(
            states, dict(zip(states, dynamics)), dict(zip(outputs, measurements)),
            _strings(params, 'model.input_names'), dict(zip(constant_names, constant_values)),
            params.get('model.dt', 0.0), _strings(params, 'model.angle_states'),
            _strings(params, 'model.angle_outputs'))
    except ConfigError as e:
        raise _renamed(e, states, outputs) from None


def _function_model(params: Mapping[str, Any], function: str, dynamics: list):
    """Return the model of Python functions ``model.function`` names."""
    for name in ('model.dynamics', 'model.measurements'):
        if params.get(name):
            raise ConfigError(name, f'model.function ({function!r}) gives the model; expected '
                              f'it empty')
    if not isinstance(function, str):
        raise ConfigError('model.function', f'expected a name, got {function!r}')
    constant_names = _strings(params, 'model.constant_names')
    constant_values = list(params.get('model.constant_values') or [])
    if len(constant_values) != len(constant_names):
        raise ConfigError('model.constant_values', f'expected one value per name of '
                          f'model.constant_names ({len(constant_names)}: {constant_names}), '
                          f'got {len(constant_values)}')
    try:
        return function_model(
            function, dict(zip(constant_names, constant_values)),
            _strings(params, 'model.state_names'), _strings(params, 'model.output_names'),
            _strings(params, 'model.input_names'), params.get('model.dt', 0.0),
            _strings(params, 'model.angle_states'), _strings(params, 'model.angle_outputs'))
    except ConfigError as e:
        raise ConfigError(PARAMETER_OF.get(e.parameter, 'model.function'), e.reason) from None


def _renamed(error: ConfigError, states: list, outputs: list) -> ConfigError:
    """Return ``error`` named by its parameter (``dynamics.yaw`` -> ``model.dynamics``)."""
    kind, _, which = error.parameter.partition('.')
    if kind in ('dynamics', 'outputs') and which:
        names = states if kind == 'dynamics' else outputs
        parameter = 'model.dynamics' if kind == 'dynamics' else 'model.measurements'
        return ConfigError(parameter, f'entry {names.index(which) + 1} ({which}): '
                           f'{error.reason}')
    if kind == 'constants' and which:
        return ConfigError('model.constant_values', f'{which}: {error.reason}')
    return ConfigError(PARAMETER_OF.get(kind, error.parameter), error.reason)


def read_linearized_model(section) -> Optional[LinearizedModel]:
    """
    Return the model of ``model.dynamics`` linearized at its operating point; None without.

    ``section``: the :class:`~observer_ros.config.sections.ModelSection` (its fields bound to
    the parameters of :data:`NONLINEAR_PARAMETERS` and the names).

    The one conversion of a model written as equations in a configuration: the
    :class:`~observer_ros.core.nonlinear.linearize.LinearizedModel` is the configuration's
    model (its ``A``, ``B``, ``C``, ``D`` the exact Jacobians at
    ``model.operating_point_states`` and ``model.operating_point_inputs``) and carries the
    equations to the filters that run them.

    Raises
    ------
    ConfigError
        As :func:`read_nonlinear_model`; ``model.A`` (or ``B``, ``C``, ``D``) given as well;
        an operating point of the wrong size, or where a Jacobian is not finite.

    """
    params = {parameter: getattr(section, field)
              for field, parameter in section.bindings().items()}
    model = read_nonlinear_model(params)
    if model is None:
        for name in ('model.measurements', 'model.constant_names', 'model.constant_values',
                     'model.operating_point_states', 'model.operating_point_inputs'):
            if params.get(name):
                raise ConfigError(name, 'given without model.dynamics (or model.function); '
                                  'write the dynamics there or leave it empty')
        return None
    for name in LINEAR_PARAMETERS:
        if params.get(name):
            raise ConfigError(name, 'a model written as equations (model.dynamics) is '
                              'linearized at model.operating_point_states; expected it empty')
    if not model.n_outputs:
        raise ConfigError('model.measurements', 'expected at least one output: names in '
                          'model.output_names and their expressions here')
    try:
        return linearize(model, params.get('model.operating_point_states'),
                         params.get('model.operating_point_inputs'))
    except ValueError as e:  # a model of functions that gave the wrong shapes
        if isinstance(e, ConfigError):
            raise _operating_point_error(e) from None
        raise ConfigError('model.function', f'{model.name!r}: {e}') from None


def _operating_point_error(e: ConfigError) -> ConfigError:
    """Return an error of :func:`linearize` named by its parameter."""
    parameter = {'operating_state': 'model.operating_point_states',
                 'operating_input': 'model.operating_point_inputs'}.get(e.parameter,
                                                                        'model.function')
    return ConfigError(parameter, e.reason)
