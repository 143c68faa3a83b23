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
A parameter set checked name by name against the one schema, and converted once.

:func:`complete_parameters` fills the defaults and coerces each given value with its
:class:`~observer_ros.config.schema.ParameterSpec` (the one place a value is coerced),
refusing misspelt names with a did-you-mean (:func:`unknown_parameter`) and unknown
measurement-source settings (:func:`unknown_source`); :func:`converted_parameters` turns
each parameter whose spec has a ``parse`` into its final type, once.
"""

import difflib
from typing import Any, Iterable, Mapping

from observer_ros.config.schema import (
    PARAMETER_SPECS, PARAMETERS, ROS_PARAMETERS, SOURCE_SETTINGS, source_specs)
from observer_ros.core.errors import ConfigError


#: The prefix of the measurement sources' parameters (``sources.<name>.<setting>``).
SOURCES_PREFIX = 'sources.'


def source_names(names: list) -> tuple:
    """
    Check the names of ``observer.sources``: unique, each a ROS parameter name token.

    Raises
    ------
    ConfigError
        ``observer.sources``, saying which name and why.

    """
    for name in names:
        if not name or not name.replace('_', 'a').isalnum() or not name[0].isalpha():
            raise ConfigError('observer.sources', f'expected names of letters, digits and '
                              f'underscores, starting with a letter, got {name!r}')
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ConfigError('observer.sources', f'names {repeated} are given twice; expected '
                          f'each source once')
    return tuple(names)


def unknown_source(parameter: str, sources: tuple) -> str:
    """Say why ``parameter`` (``sources.<name>.<setting>``) is none of the sources'."""
    name, _, setting = parameter[len(SOURCES_PREFIX):].partition('.')
    if name in sources:
        return (f'unknown setting {setting!r} of the measurement source {name!r}; expected '
                f'one of {", ".join(SOURCE_SETTINGS)}')
    return (f'{name!r} is no measurement source: observer.sources names '
            f'{list(sources) or "none"}; add it there, or remove its parameters')


def complete_parameters(params: Mapping[str, Any], strict: bool = False) -> dict:
    """
    Fill defaults and check every parameter of the schema once: its type and range.

    The one place a given value is coerced (by its
    :class:`~observer_ros.config.schema.ParameterSpec`), in schema order. Unknown names are
    kept untouched unless ``strict`` is set, in which case any name outside the schema
    (other than ROS's own ``use_sim_time`` and ``qos_overrides.*``) is an error, so that a
    typo is not silently ignored.

    Raises
    ------
    ConfigError
        Naming the parameter.

    """
    complete = {}
    for spec in PARAMETERS:
        complete[spec.name] = spec.coerce(params.get(spec.name, spec.default))
    sources = source_names(complete['observer.sources'])
    for name in sources:
        for spec in source_specs(name):
            complete[spec.name] = spec.coerce(params.get(spec.name, spec.default))
    for name, value in params.items():
        if name in PARAMETER_SPECS or name in complete:
            continue
        if name.startswith(SOURCES_PREFIX):
            raise ConfigError(name, unknown_source(name, sources))
        if strict and not (name in ROS_PARAMETERS or name.startswith('qos_overrides.')):
            raise ConfigError(name, unknown_parameter(name, PARAMETER_SPECS))
        complete[name] = value
    return complete


#: The page that lists every parameter (generated from the schema).
PARAMETERS_PAGE = 'doc/parameters.md'

#: difflib similarity from which a parameter name is offered for a misspelt one, and how far
#: below the best match the others offered may be.
CLOSE_NAME, CLOSE_SPREAD = 0.75, 0.05


def unknown_parameter(name: str, known: Iterable[str]) -> str:
    """
    Say that ``name`` is no parameter: the nearest of the ``known`` names and the page.

    Examples
    --------
    >>> unknown_parameter('observer.polse', ['observer.poles', 'feedback.poles'])
    "unknown parameter; did you mean 'observer.poles'? (every parameter: doc/parameters.md)"

    """
    names = sorted(known)
    close = [match for match in names if match.lower() == name.lower()]
    if not close:
        scored = sorted(((difflib.SequenceMatcher(None, name, match).ratio(), match)
                         for match in names), reverse=True)
        best = scored[0][0] if scored else 0.0
        close = [match for ratio, match in scored[:3]
                 if ratio >= CLOSE_NAME and ratio >= best - CLOSE_SPREAD]
    guess = (f'; did you mean {" or ".join(repr(match) for match in close)}?' if close
             else '')
    return f'unknown parameter{guess} (every parameter: {PARAMETERS_PAGE})'


def converted_parameters(params: Mapping[str, Any]) -> dict:
    """
    Return each parameter of the schema that has a ``parse``, converted into its final type.

    Converted once from the value as given in ``params``
    (:meth:`~observer_ros.core.arguments.Argument.convert`: numbers stay numbers on the
    way, texts are parsed; a pole list becomes a complex array, empty when none is given).
    The checked mapping (:func:`complete_parameters`) keeps the parameter's own form
    (texts), for a parameter file written back.

    Raises
    ------
    ConfigError
        Naming the parameter (``feedback.poles: cannot read 'x' as a pole``).

    """
    return {spec.name: spec.convert(params.get(spec.name, spec.default))
            for spec in PARAMETERS if spec.parse is not None}
