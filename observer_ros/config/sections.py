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
The parameters as typed sections, made from the one schema.

A parameter set is checked once, parameter by parameter, with the schema's
:class:`~observer_ros.config.schema.ParameterSpec` (:func:`complete_parameters`), and read
into frozen dataclasses, one per section: :class:`ModelSection`, :class:`ObserverSection`,
:class:`FeedbackSection`, :class:`PlantSection`, :class:`DiagnosticsSection`,
:class:`TopicsSection` (and :class:`ControllerSection`, :class:`LifecycleSection`), together
:class:`Sections`. Code reads these attributes (``sections.plant.samples``), never a
parameter name.

Each field is bound to its parameter once, with :func:`bound`: the field's name is the
argument the core knows the value by (``ModelSection.A``, ``IntegralSection.poles``), the
binding names the parameter a user sets (``model.A``, ``feedback.integral_poles``). An
observer type's arguments are bound in the schema
(:data:`~observer_ros.config.schema.OBSERVER_ARGUMENTS`) and read into
:attr:`ObserverSection.arguments` by their own names.

A section's :meth:`Section.binding` turns those bindings into a :class:`Binding`, through
which the errors of a core call are charged to the parameter their argument stands for
(``poles: expected 2 poles`` becomes ``observer.poles: expected 2 poles``): the error
carries its argument and its reason, the binding the parameter; no text is parsed.
"""

from contextlib import contextmanager
from dataclasses import dataclass, field, fields, replace
import difflib
from typing import Any, Iterable, Iterator, Mapping

import numpy as np

from observer_ros.config.schema import (
    OBSERVER_ARGUMENTS, PARAMETER_SPECS, PARAMETERS, ROS_PARAMETERS, source_parameter,
    SOURCE_SETTINGS, source_specs, topic_parameter, TOPIC_ROLES, TOPIC_SETTINGS)
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.wire import find

#: Field metadata: the parameter a field is bound to, or the section a field holds.
PARAMETER, SECTION = 'parameter', 'section'

#: What numpy and scipy raise when a design's arithmetic breaks down (overflow, no
#: convergence); a design that raises one is refused like any other failed design.
NUMERIC_FAILURES = (np.linalg.LinAlgError, ValueError, ArithmeticError)


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


class Binding(Mapping):
    """
    Which parameter each argument of a core call stands for: ``{argument: parameter}``.

    Made from the sections whose values a call takes (``ModelSection.binding() |
    ObserverSection.binding()``); a later section's argument of the same name wins.

    Examples
    --------
    >>> from observer_ros.core.errors import ConfigError
    >>> binding = ModelSection.binding()
    >>> binding['A']
    'model.A'
    >>> str(binding.error(ConfigError('B', 'expected 2x1'), 'model.A'))
    'model.B: expected 2x1'

    """

    def __init__(self, parameters: Mapping[str, str]) -> None:
        self._parameters = dict(parameters)

    def __getitem__(self, argument: str) -> str:
        return self._parameters[argument]

    def __iter__(self) -> Iterator[str]:
        return iter(self._parameters)

    def __len__(self) -> int:
        return len(self._parameters)

    def __or__(self, other: Mapping[str, str]) -> 'Binding':
        return Binding({**self._parameters, **other})

    def error(self, error: Exception, fallback: str) -> ConfigError:
        """
        Return a core error as a ConfigError naming the parameter its argument is bound to.

        An error about no bound argument (an unobservable pair names none) is charged to
        ``fallback``: the parameter whose value led to it. An error that names one of the
        bound parameters already keeps it.
        """
        argument = getattr(error, 'parameter', '')
        reason = getattr(error, 'reason', None) or str(error)
        if argument in self._parameters.values():
            return ConfigError(argument, reason)
        return ConfigError(self._parameters.get(argument) or fallback, reason)

    @contextmanager
    def charged(self, fallback: str, numeric: bool = False) -> Iterator[None]:
        """
        Re-raise the core's ConfigError and DesignError under their parameters.

        With ``numeric``, a numeric failure (:data:`NUMERIC_FAILURES`) of the call is
        refused too, charged to ``fallback``.
        """
        try:
            yield
        except (ConfigError, DesignError) as e:
            raise self.error(e, fallback) from e
        except NUMERIC_FAILURES as e:
            if not numeric:
                raise
            raise ConfigError(fallback, f'the design failed numerically ({e})') from e


def bound(parameter: str) -> Any:
    """
    Return a section field bound to ``parameter`` of the schema.

    Raises
    ------
    KeyError
        ``parameter`` is not in the schema (when the section is defined).

    """
    return field(metadata={PARAMETER: PARAMETER_SPECS[parameter].name})


def nested(section: type) -> Any:
    """Return a section field that holds another section (read from the same parameters)."""
    return field(metadata={SECTION: section})


@dataclass(frozen=True)
class Section:
    """
    Base of the typed sections: fields bound to parameters (:func:`bound`) or sections.

    A section whose values are not one parameter each (an observer type's arguments)
    overrides :meth:`values`, :meth:`bindings` and :meth:`parameter_names`; one that is no
    dataclass of fields (the topics, by topic) offers :meth:`read` and
    :meth:`parameter_names` itself (:class:`TopicsSection`).
    """

    @classmethod
    def bindings(cls) -> dict:
        """Return ``{field name: parameter}`` of the fields bound to parameters."""
        return {item.name: item.metadata[PARAMETER] for item in fields(cls)
                if PARAMETER in item.metadata}

    @classmethod
    def binding(cls) -> Binding:
        """Return the :class:`Binding` of the section's own fields."""
        return Binding(cls.bindings())

    @classmethod
    def parameter_names(cls) -> tuple:
        """Return every parameter the section (with its nested sections) reads."""
        names = []
        for item in fields(cls):
            if PARAMETER in item.metadata:
                names.append(item.metadata[PARAMETER])
            elif SECTION in item.metadata:
                names.extend(item.metadata[SECTION].parameter_names())
        return tuple(names)

    @classmethod
    def read(cls, checked: Mapping[str, Any]) -> 'Section':
        """Return the section of a checked parameter mapping (:func:`complete_parameters`)."""
        return cls(**cls.values(checked))

    @classmethod
    def values(cls, checked: Mapping[str, Any]) -> dict:
        """Return the section's field values from a checked parameter mapping."""
        values = {}
        for item in fields(cls):
            if PARAMETER in item.metadata:
                values[item.name] = checked[item.metadata[PARAMETER]]
            elif SECTION in item.metadata:
                values[item.name] = item.metadata[SECTION].read(checked)
        return values


@dataclass(frozen=True)
class ModelSection(Section):
    """``model.*``: the plant's matrices, names and disturbances (the arguments of the core)."""

    A: list = bound('model.A')
    B: list = bound('model.B')
    C: list = bound('model.C')
    D: list = bound('model.D')
    dt: float = bound('model.dt')
    state_names: list = bound('model.state_names')
    input_names: list = bound('model.input_names')
    output_names: list = bound('model.output_names')
    angle_states: list = bound('model.angle_states')
    angle_outputs: list = bound('model.angle_outputs')
    disturbances: list = bound('model.disturbances')
    disturbance_entries: list = bound('model.disturbance_entries')
    disturbance_matrix: list = bound('model.disturbance_matrix')
    disturbance_frequencies: list = bound('model.disturbance_frequencies')
    disturbance_names: list = bound('model.disturbance_names')
    dynamics: list = bound('model.dynamics')  # the equations: observer_ros.config.nonlinear
    measurements: list = bound('model.measurements')
    constant_names: list = bound('model.constant_names')
    constant_values: list = bound('model.constant_values')
    operating_point_states: list = bound('model.operating_point_states')
    operating_point_inputs: list = bound('model.operating_point_inputs')
    function: str = bound('model.function')


@dataclass(frozen=True)
class JointStatesSection(Section):
    """``observer.joint_*``: the joints of ``joint_states_hat`` and the states of each field."""

    names: list = bound('observer.joint_names')
    position: list = bound('observer.joint_position_states')
    velocity: list = bound('observer.joint_velocity_states')
    effort: list = bound('observer.joint_effort_states')


@dataclass(frozen=True)
class ObserverSection(Section):
    """
    ``observer.*``: the type, the stream's settings and every observer type's arguments.

    Attributes
    ----------
    arguments : dict
        The arguments of every registered observer type, checked, by their own names
        (``arguments['poles']`` is ``observer.poles``; bound in
        :data:`~observer_ros.config.schema.OBSERVER_ARGUMENTS`).

    """

    type: str = bound('observer.type')  # noqa: A003 (the parameter's name)
    initial_state: list = bound('observer.initial_state')
    input_wait: float = bound('observer.input_wait')
    unstamped_input: str = bound('observer.unstamped_input')
    interval_resolution: float = bound('observer.interval_resolution')
    max_gap: float = bound('observer.max_gap')
    clock_tolerance: float = bound('observer.clock_tolerance')
    publish_rate: float = bound('observer.publish_rate')
    history: float = bound('observer.history')
    sources: list = bound('observer.sources')
    joint_states: JointStatesSection = nested(JointStatesSection)
    arguments: dict = field(default_factory=dict)

    @classmethod
    def bindings(cls) -> dict:
        """Bound fields, the estimator's name of the resolution and the types' arguments."""
        own = super().bindings()
        return {**own, 'interval_resolution_ns': own['interval_resolution'],
                **OBSERVER_ARGUMENTS}

    @classmethod
    def parameter_names(cls) -> tuple:
        """Return the section's parameters, the types' arguments included."""
        return super().parameter_names() + tuple(OBSERVER_ARGUMENTS.values())

    @classmethod
    def values(cls, checked: Mapping[str, Any]) -> dict:
        """Read the bound fields, and the types' arguments by their own names."""
        return {**super().values(checked),
                'arguments': {argument: checked[parameter]
                              for argument, parameter in OBSERVER_ARGUMENTS.items()}}


@dataclass(frozen=True)
class IntegralSection(Section):
    """``feedback.integral_*``: integral action, by the names of the integral design."""

    poles: list = bound('feedback.integral_poles')
    integral_gain: list = bound('feedback.integral_gain')
    outputs: list = bound('feedback.integral_outputs')


@dataclass(frozen=True)
class FeedbackSection(Section):
    """``feedback.*``: the state feedback's gain or poles, limits and safe command."""

    gain: list = bound('feedback.gain')
    poles: list = bound('feedback.poles')
    method: str = bound('feedback.method')
    reference_gain: list = bound('feedback.reference_gain')
    input_limits: list = bound('feedback.input_limits')
    disturbance_rejection: bool = bound('feedback.disturbance_rejection')
    timeout: float = bound('feedback.timeout')
    safe_command: list = bound('feedback.safe_command')
    safe_command_period: float = bound('feedback.safe_command_period')
    integral: IntegralSection = nested(IntegralSection)


@dataclass(frozen=True)
class ControllerSection(Section):
    """``controller.*``: what only the one-process observer-controller has."""

    input_source: str = bound('controller.input')


@dataclass(frozen=True)
class LifecycleSection(Section):
    """The managed nodes' own parameters."""

    autostart: bool = bound('autostart')


@dataclass(frozen=True)
class PlantSection(Section):
    """``plant.*``: the simulated plant, its noise, disturbance, pacing and start."""

    rate_hz: float = bound('plant.rate_hz')
    initial_state: list = bound('plant.initial_state')
    process_noise: list = bound('plant.process_noise')
    measurement_noise: list = bound('plant.measurement_noise')
    seed: int = bound('plant.seed')
    input_limits: list = bound('plant.input_limits')
    lockstep: bool = bound('plant.lockstep')
    lockstep_timeout: float = bound('plant.lockstep_timeout')
    lockstep_subscribers: int = bound('plant.lockstep_subscribers')
    wait_for_command: bool = bound('plant.wait_for_command')
    hold_without_command: bool = bound('plant.hold_without_command')
    start_timeout: float = bound('plant.start_timeout')
    settle_time: float = bound('plant.settle_time')
    command_timeout: float = bound('plant.command_timeout')
    input_offset: list = bound('plant.input_offset')
    safe_input: list = bound('plant.safe_input')
    disturbance: list = bound('plant.disturbance')
    disturbance_time: float = bound('plant.disturbance_time')
    samples: int = bound('plant.samples')


@dataclass(frozen=True)
class DiagnosticsSection(Section):
    """``diagnostics.*``: the health reports and what they judge the inputs against."""

    period: float = bound('diagnostics.period')
    hardware_id: str = bound('diagnostics.hardware_id')
    expected_rate: float = bound('diagnostics.expected_rate')
    rate_tolerance: float = bound('diagnostics.rate_tolerance')
    stale_timeout: float = bound('diagnostics.stale_timeout')
    nis_window: int = bound('diagnostics.nis_window')
    nis_confidence: float = bound('diagnostics.nis_confidence')


@dataclass(frozen=True)
class TopicSettings:
    """
    ``topics.<topic>.*`` of one vector topic.

    Attributes
    ----------
    type : str
        ``joint_state`` or ``float64_multi_array``.
    field : str
        The JointState field holding the values.
    limit : float
        The largest magnitude a value may have.
    fields : tuple of str
        ``topics.u.fields``: the values read by field path (empty: the vector of ``type``
        and ``field``; other topics have none).

    """

    type: str  # noqa: A003 (the parameter's name)
    field: str
    limit: float
    fields: tuple = ()

    @property
    def stamped(self) -> bool:
        """Whether the messages carry a header stamp (a JointState does): the catalog says."""
        entry = find(self.type)
        return entry is not None and entry.stamped


class SettingsByName(Mapping):
    """A section kept by name (a topic, a source): a read-only mapping of its settings."""

    def __init__(self, settings: Mapping[str, Any]) -> None:
        self._settings = dict(settings)

    def __getitem__(self, name: str) -> Any:
        return self._settings[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._settings)

    def __len__(self) -> int:
        return len(self._settings)


class TopicsSection(SettingsByName):
    """
    ``topics.*``: :class:`TopicSettings` by topic (``topics['y'].limit``), every vector topic.

    Its parameters are :func:`~observer_ros.config.schema.topic_parameter` of each topic of
    :data:`~observer_ros.config.schema.TOPIC_ROLES` and each setting.
    """

    @classmethod
    def parameter_names(cls) -> tuple:
        """Return every ``topics.<topic>.<setting>`` parameter."""
        return tuple(topic_parameter(topic, setting) for topic, _, _ in TOPIC_ROLES
                     for setting in TOPIC_SETTINGS) + (INPUT_FIELDS,)

    @classmethod
    def read(cls, checked: Mapping[str, Any]) -> 'TopicsSection':
        """Return the settings of every vector topic."""
        return cls({topic: TopicSettings(**{
            setting: checked[topic_parameter(topic, setting)] for setting in TOPIC_SETTINGS},
            fields=tuple(checked[INPUT_FIELDS]) if topic == 'u' else ())
            for topic, _, _ in TOPIC_ROLES})


#: ``topics.u.fields``: the inputs read by field path.
INPUT_FIELDS = topic_parameter('u', 'fields')


@dataclass(frozen=True)
class SourceSettings:
    """
    ``sources.<name>.*`` of one measurement source, checked one by one.

    Attributes
    ----------
    name : str
    topic : str
        Its topic (the name when ``sources.<name>.topic`` is empty).
    type : str
        A short name of :data:`~observer_ros.config.schema.FIELD_MESSAGE_TYPES`.
    fields, outputs : tuple of str
        The field paths and the outputs they carry, in the same order.
    measurement_noise : tuple of float
    latency, timeout : float
        Seconds.
    predict_only : bool

    """

    name: str
    topic: str
    type: str  # noqa: A003 (the parameter's name)
    fields: tuple
    outputs: tuple
    measurement_noise: tuple
    latency: float
    timeout: float
    predict_only: bool

    def parameter(self, setting: str) -> str:
        """Return the parameter of one of its settings: ``sources.imu.fields``."""
        return source_parameter(self.name, setting)


class SourcesSection(SettingsByName):
    """
    ``sources.<name>.*``: :class:`SourceSettings` by name, in ``observer.sources`` order.

    Empty without ``observer.sources`` (one source, ``topics.y``). Its parameters are made
    for each name (:func:`~observer_ros.config.schema.source_specs`), so the section binds
    none of the schema's own.
    """

    @classmethod
    def parameter_names(cls) -> tuple:
        """None of the schema's: a source's parameters are made for its name."""
        return ()

    @classmethod
    def read(cls, checked: Mapping[str, Any]) -> 'SourcesSection':
        """Return the settings of every source named in ``observer.sources``."""
        sources = {}
        for name in checked['observer.sources']:
            values = {setting: checked[source_parameter(name, setting)]
                      for setting in SOURCE_SETTINGS}
            for setting in ('fields', 'outputs', 'measurement_noise'):
                values[setting] = tuple(values[setting])
            values['topic'] = values['topic'] or name
            sources[name] = SourceSettings(name, **values)
        return cls(sources)


@dataclass(frozen=True)
class Sections(Section):
    """
    Every section of a checked parameter set, in schema order.

    Attributes
    ----------
    parameters : dict
        The complete checked mapping (defaults filled in, unknown names kept unless
        strict): what a parameter file written back holds (``design_observer --write``).
        Code reads the sections instead.

    """

    model: ModelSection = nested(ModelSection)
    observer: ObserverSection = nested(ObserverSection)
    feedback: FeedbackSection = nested(FeedbackSection)
    controller: ControllerSection = nested(ControllerSection)
    lifecycle: LifecycleSection = nested(LifecycleSection)
    plant: PlantSection = nested(PlantSection)
    diagnostics: DiagnosticsSection = nested(DiagnosticsSection)
    topics: TopicsSection = nested(TopicsSection)
    sources: SourcesSection = nested(SourcesSection)
    parameters: dict = field(default_factory=dict, repr=False, compare=False)

    @classmethod
    def check(cls, params: Mapping[str, Any], strict: bool = False) -> 'Sections':
        """
        Check ``params`` once (:func:`complete_parameters`) and read every section.

        The observer types' arguments are converted once into the type their designs take
        (:func:`converted_arguments`: ``observer.poles`` a complex array, from the numbers
        or texts given).
        """
        checked = complete_parameters(params, strict)
        values = cls.values(checked)
        values['observer'] = replace(values['observer'],
                                     arguments=converted_arguments(params, checked))
        return cls(**values, parameters=checked)


def converted_arguments(params: Mapping[str, Any], checked: Mapping[str, Any]) -> dict:
    """
    Return the observer types' arguments by their own names, each in its final type.

    An argument with a ``parse`` (``poles``) is converted once from the value as given in
    ``params`` (:meth:`~observer_ros.core.arguments.Argument.convert`: numbers stay
    numbers on the way, texts are parsed), the others are the checked values. The checked
    mapping keeps the parameter's own form (texts), for a parameter file written back.

    Raises
    ------
    ConfigError
        Naming the parameter (``observer.poles: cannot read 'x' as a pole``).

    """
    converted = {}
    for argument, parameter in OBSERVER_ARGUMENTS.items():
        spec = PARAMETER_SPECS[parameter]
        converted[argument] = (checked[parameter] if spec.parse is None
                               else spec.convert(params.get(parameter, spec.default)))
    return converted
