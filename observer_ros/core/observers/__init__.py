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
The observer types: one package each, found through the entry-point group of the types.

A type is a package (``observer_ros/core/observers/<type>/`` for the built-in ones, or any
installed package) that declares an :class:`ObserverType`: its name, the arguments it reads
(by their own names: ``poles``, ``gain``; the parameter schema offers each as
``observer.<name>``), its design function, its runtime estimator, the fields its report
shows and its :class:`Capabilities`. It is found through the Python entry-point group
``observer_ros.observer_types`` (:data:`GROUP`), where the built-in types are registered
too (``setup.py``). The parameter schema, the validator, ``design_observer``, the report,
the nodes and the bag tools find types with :func:`observer_type` and
:func:`observer_types` and ask their capabilities, never their names; an unknown name is an
error, never a fallback.

Examples
--------
>>> from observer_ros.core.observers import observer_type, observer_types
>>> [t.name for t in observer_types()]
['full_order', 'reduced_order', 'chen', 'kalman', 'extended_kalman', 'unscented_kalman']
>>> observer_type('kalman').argument_names()[:2]
('process_noise', 'measurement_noise')
>>> observer_type('kalman').capabilities.covariance
True

"""

from dataclasses import dataclass
from typing import Any, Callable, Mapping, Optional

import numpy as np

from observer_ros.core.design.common import ObserverDesign
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers import registry
from observer_ros.core.observers.capabilities import Capabilities, ReportItem
from observer_ros.core.observers.registry import GROUP, PluginLoadWarning

#: Priority of a type that gives none (the built-in ones are above it, so come first).
DEFAULT_PRIORITY = 100


def _no_report(design: ObserverDesign) -> tuple:
    return ()


@dataclass(frozen=True)
class ObserverType:
    """
    What one observer type is.

    Attributes
    ----------
    name : str
        ``observer.type`` of the type (and the name of its entry point).
    summary : str
        One line for the schema's description.
    arguments : tuple of Argument
        The arguments its design and estimator read, by their own names.
    design : callable
        ``design(model, values, disturbance) -> ObserverDesign or None`` with ``values`` the
        checked arguments by name and ``disturbance`` the
        :class:`~observer_ros.core.disturbance_model.DisturbanceModel` that augmented ``model``
        (None without ``model.disturbances``); None when the values configure no observer
        (no poles, gain or noise given). Raises ConfigError or DesignError naming its
        arguments.
    estimator : callable
        ``estimator(design, values, initial_state, interval_resolution_ns)`` returns the
        runtime :class:`~observer_ros.core.estimators.Estimator`.
    report : callable
        ``report(design) -> sequence of ReportItem``: the type's own matrices.
    vet : callable, optional
        ``vet(model, given)`` raises for values the type cannot take together with others
        (run before ``design``; ``given`` holds the values as given, by argument name).
    capabilities : Capabilities
    priority : int
        Order of the registry: higher first, then by name (:data:`DEFAULT_PRIORITY`).
    charged : callable, optional
        ``charged(given) -> argument name``: the argument a failed design is charged to
        when its error names none (default: the first argument).
    pinned : callable, optional
        ``pinned(design, values) -> {argument: value or None}``: the arguments that pin the
        design as it is (``design_observer --write``); None removes one. Default: none.

    Examples
    --------
    >>> kind = observer_type('full_order')
    >>> kind.values({'poles': ['-4', '-5']})['method']
    'auto'
    >>> kind.charged_argument({'gain': [1.0, 2.0]})
    'gain'

    """

    name: str
    summary: str
    arguments: tuple
    design: Callable[..., Optional[ObserverDesign]]
    estimator: Callable
    report: Callable[[ObserverDesign], tuple] = _no_report
    vet: Optional[Callable[[StateSpaceModel, Mapping[str, Any]], None]] = None
    capabilities: Capabilities = Capabilities()
    priority: int = DEFAULT_PRIORITY
    charged: Optional[Callable[[Mapping[str, Any]], str]] = None
    pinned: Optional[Callable[[ObserverDesign, Mapping[str, Any]], dict]] = None

    def argument_names(self) -> tuple:
        """Return the names of the type's arguments, in declaration order."""
        return tuple(argument.name for argument in self.arguments)

    def values(self, given: Mapping[str, Any]) -> dict:
        """
        Return the type's arguments checked and converted once, from ``given``.

        Defaults fill the missing; each value is in the type its design takes
        (:meth:`~observer_ros.core.arguments.Argument.convert`: ``poles`` a complex array).

        Raises
        ------
        ConfigError
            Naming the argument.

        """
        return {argument.name: argument.convert(given.get(argument.name, argument.default))
                for argument in self.arguments}

    def charged_argument(self, given: Mapping[str, Any]) -> str:
        """Return the argument a failed design of ``given`` is charged to (see ``charged``)."""
        if self.charged is not None:
            return self.charged(given)
        return self.arguments[0].name if self.arguments else 'type'

    def pinned_arguments(self, design: ObserverDesign, values: Mapping[str, Any]) -> dict:
        """Return the arguments that pin ``design`` (see ``pinned``; empty by default)."""
        return {} if self.pinned is None else dict(self.pinned(design, values))


def register(kind: ObserverType) -> ObserverType:
    """
    Add an observer type to the registry and return it (for a type made at run time).

    Installed types are found through the entry-point group :data:`GROUP` instead. An
    argument name shared by several types (``poles``, ``gain``) must be the same
    :class:`Argument` everywhere, so that the schema has one parameter for it.

    Parameters
    ----------
    kind : ObserverType

    Returns
    -------
    ObserverType
        ``kind`` itself.

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
    registry.load()
    registry.add(kind)
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
        ``type``: no such type (the message lists the registered ones), or its plug-in
        failed to load (the message names the entry point and the error).

    Examples
    --------
    >>> try:
    ...     observer_type('luenberger')
    ... except ValueError as error:
    ...     print(error.parameter, '|', error.reason.split(',')[0])
    type | expected one of full_order

    """
    registry.load()
    return registry.find(name)


def observer_types() -> tuple:
    """
    Return the registered types, in registry order (priority, then name).

    Returns
    -------
    tuple of ObserverType

    Examples
    --------
    >>> observer_types()[0].name
    'full_order'

    """
    registry.load()
    return registry.types()


def observer_type_names() -> tuple:
    """Return the names ``observer.type`` accepts: the registered types and failed plug-ins."""
    registry.load()
    return registry.types_and_failures()


def observer_arguments() -> tuple:
    """Return every argument of every registered type, each once, in declaration order."""
    registry.load()
    return registry.arguments()


def disturbance_arguments() -> tuple:
    """
    Return the arguments that apply only with ``model.disturbances``, over every type.

    Examples
    --------
    >>> disturbance_arguments()
    ('disturbance_noise',)

    """
    names = (name for kind in observer_types()
             for name in kind.capabilities.disturbance_arguments)
    return tuple(dict.fromkeys(names))


def plugin_failures() -> dict:
    """Return ``{type name: why its entry point failed to load}`` (empty when all loaded)."""
    registry.load()
    return registry.failures()


def make_estimator(design: ObserverDesign, initial_state=None, interval_resolution_ns: int = 0,
                   *, values: Optional[Mapping[str, Any]] = None, **arguments):
    """
    Build the runtime estimator of an observer design, through its registered type.

    The one way an estimator is made: the parameter configuration
    (:class:`observer_ros.config.ObserverSetup`) calls it too. For a continuous model the
    estimator places the observer's poles again for each new sample interval, as
    ``exp(lambda dt)``, which keeps jittered stamps exact (cached per interval, rounded to
    ``interval_resolution_ns``).

    Parameters
    ----------
    design : ObserverDesign
        From any design function; its ``kind`` names the observer type.
    initial_state : array_like, shape (n,), optional
        Pins the first estimate (see :class:`~observer_ros.core.estimators.Estimator`).
    interval_resolution_ns : int
        Round intervals to multiples of this before designing them (0: exact).
    values : mapping, optional
        The type's arguments by name, checked already (what
        :meth:`ObserverType.values` returns, or what the parameter schema checked): taken as
        they are, not checked again.
    **arguments
        Or the type's arguments as given (``method='lsq'``; ``time_varying=True``,
        ``initial_covariance=...`` for ``kalman``), checked here; the missing ones take
        their defaults.

    Returns
    -------
    Estimator
        The type's runtime estimator: an :class:`~observer_ros.core.estimators.Estimator`,
        or a :class:`TimeVaryingKalman` for ``kalman`` with ``time_varying=True``. A design
        on a model written as equations by a type without the capability ``equations``:
        its gain run with the nonlinear prediction
        (:class:`~observer_ros.core.nonlinear.prediction.NonlinearPrediction`).

    Raises
    ------
    ConfigError
        ``type``: the design's kind is no registered observer type; or a bad argument.
    TypeError
        Both ``values`` and ``arguments`` given.

    Examples
    --------
    >>> from observer_ros.core import design_kalman, StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> design = design_kalman(model, [0.0, 1.0], [0.01])
    >>> type(make_estimator(design)).__name__
    'ConstantGainEstimator'
    >>> type(make_estimator(design, time_varying=True)).__name__
    'TimeVaryingKalman'

    """
    kind = observer_type(design.kind)
    if values is None:
        values = kind.values(arguments)
    elif arguments:
        raise TypeError('make_estimator: give the checked values or the arguments, not both')
    estimator = kind.estimator(design, values, initial_state, interval_resolution_ns)
    equations = getattr(design.model, 'nonlinear', None)  # a model written as equations
    if equations is None or kind.capabilities.equations:
        return estimator
    from observer_ros.core.nonlinear.prediction import NonlinearPrediction  # lazy: SymPy's
    return NonlinearPrediction(estimator, equations, values, initial_state)


def rows(matrix) -> list:
    """Return a matrix as nested lists of floats (the report's JSON form)."""
    return np.atleast_2d(np.asarray(matrix, dtype=float)).tolist()


__all__ = ['Capabilities', 'DEFAULT_PRIORITY', 'GROUP', 'ObserverType', 'PluginLoadWarning',
           'ReportItem', 'disturbance_arguments', 'make_estimator', 'observer_arguments',
           'observer_type', 'observer_type_names', 'observer_types', 'plugin_failures',
           'register', 'rows']
