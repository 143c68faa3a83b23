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
The observer types, one module each, found through one registry.

A module declares an :class:`ObserverType`: its name, the arguments it reads (by their own
names: ``poles``, ``gain``; the parameter schema offers each as ``observer.<name>``), its
design function, its runtime estimator and the fields its report shows, and passes it to
:func:`register`. The parameter schema, the validator, ``design_observer``, the report, the
nodes and the bag tools find types with :func:`observer_type` and :func:`observer_types`; an
unknown name is an error, never a fallback. The built-in types are registered when this
package is imported: ``full_order``, ``reduced_order``, ``chen`` and ``kalman``.

Examples
--------
>>> from observer_ros.core.observers import observer_type, observer_types
>>> [t.name for t in observer_types()]
['full_order', 'reduced_order', 'chen', 'kalman']
>>> observer_type('kalman').argument_names()[:2]
('process_noise', 'measurement_noise')

"""

from dataclasses import dataclass
import importlib
from typing import Any, Callable, Mapping, Optional

import numpy as np

from observer_ros.core.design.common import ObserverDesign
from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel


@dataclass(frozen=True)
class ReportItem:
    """One field of a design report: JSON key, text label and the value (a matrix or number)."""

    key: str
    label: str
    value: Any


@dataclass(frozen=True)
class ObserverType:
    """
    What one observer type is.

    Attributes
    ----------
    name : str
        ``observer.type`` of the type.
    summary : str
        One line for the schema's description.
    arguments : tuple of Argument
        The arguments its design and estimator read, by their own names.
    design : callable
        ``design(model, values) -> ObserverDesign or None`` with ``values`` the checked
        arguments by name; None when the values configure no observer (no poles, gain or
        noise given). Raises ConfigError or DesignError naming its arguments.
    estimator : callable
        ``estimator(design, values, initial_state, interval_resolution_ns)`` returns the
        runtime :class:`~observer_ros.core.estimators.Estimator`.
    report : callable
        ``report(design) -> sequence of ReportItem``: the type's own matrices.
    vet : callable, optional
        ``vet(model, values)`` raises for values the type cannot take together with others
        (run before ``design``).

    Examples
    --------
    >>> kind = observer_type('full_order')
    >>> kind.values({'poles': ['-4', '-5']})['method']
    'auto'

    """

    name: str
    summary: str
    arguments: tuple
    design: Callable[[StateSpaceModel, Mapping[str, Any]], Optional[ObserverDesign]]
    estimator: Callable
    report: Callable[[ObserverDesign], tuple] = lambda design: ()
    vet: Optional[Callable[[StateSpaceModel, Mapping[str, Any]], None]] = None

    def argument_names(self) -> tuple:
        """Return the names of the type's arguments, in declaration order."""
        return tuple(argument.name for argument in self.arguments)

    def values(self, given: Mapping[str, Any]) -> dict:
        """
        Return the type's arguments checked, from ``given`` (defaults for the missing).

        Raises
        ------
        ConfigError
            Naming the argument.

        """
        return {argument.name: argument.coerce(given.get(argument.name, argument.default))
                for argument in self.arguments}


_TYPES: dict = {}
_ARGUMENTS: dict = {}


def register(kind: ObserverType) -> ObserverType:
    """
    Add an observer type to the registry and return it.

    An argument name shared by several types (``poles``, ``gain``) must be the same
    :class:`Argument` everywhere, so that the schema has one parameter for it.

    Parameters
    ----------
    kind : ObserverType

    Returns
    -------
    ObserverType
        ``kind`` itself, so that a module can write ``TYPE = register(ObserverType(...))``.

    Raises
    ------
    ValueError
        A type of that name is registered already, or an argument clashes.

    Examples
    --------
    >>> register(observer_type('chen'))
    Traceback (most recent call last):
    ...
    ValueError: observer type 'chen' is registered already

    """
    if kind.name in _TYPES:
        raise ValueError(f'observer type {kind.name!r} is registered already')
    for argument in kind.arguments:
        known = _ARGUMENTS.get(argument.name)
        if known is not None and known != argument:
            raise ValueError(f'observer type {kind.name!r}: argument {argument.name!r} '
                             f'differs from the one another type declares')
    for argument in kind.arguments:
        _ARGUMENTS[argument.name] = argument
    _TYPES[kind.name] = kind
    return kind


def observer_type(name: str) -> ObserverType:
    """
    Return the registered type called ``name``.

    Parameters
    ----------
    name : str

    Returns
    -------
    ObserverType

    Raises
    ------
    ConfigError
        ``type``: no such type (the message lists the registered ones).

    Examples
    --------
    >>> try:
    ...     observer_type('luenberger')
    ... except ValueError as error:
    ...     print(error.parameter, '|', error.reason.split(',')[0])
    type | expected one of full_order

    """
    kind = _TYPES.get(name)
    if kind is None:
        raise ConfigError('type', f'expected one of {", ".join(_TYPES)}, got {name!r}')
    return kind


def observer_types() -> tuple:
    """
    Return the registered types, in registration order.

    Returns
    -------
    tuple of ObserverType

    Examples
    --------
    >>> observer_types()[0].name
    'full_order'

    """
    return tuple(_TYPES.values())


def observer_arguments() -> tuple:
    """Return every argument of every registered type, each once, in declaration order."""
    return tuple(_ARGUMENTS.values())


def rows(matrix) -> list:
    """Return a matrix as nested lists of floats (the report's JSON form)."""
    return np.atleast_2d(np.asarray(matrix, dtype=float)).tolist()


# The built-in types register themselves, in this order (imported last: they use the names
# above).
for _module in ('full_order', 'reduced_order', 'chen', 'kalman'):
    importlib.import_module(f'{__name__}.{_module}')

__all__ = ['ObserverType', 'ReportItem', 'observer_arguments', 'observer_type',
           'observer_types', 'register', 'rows']
