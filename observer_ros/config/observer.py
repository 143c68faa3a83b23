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
The observer of a configuration: its design, and the estimator and stream made from it.

The path of an observer parameter (``observer.poles``) to the estimate:

1. :func:`~observer_ros.config.parameter_check.complete_parameters` checks the value once, and
   :class:`~observer_ros.config.sections.ObserverSection` holds it by its argument name
   (``arguments['poles']``);
2. :func:`observer_design` hands the type's arguments to its design function
   (``observer_ros.core.observers.<type>``), which parses the poles and places them;
3. :meth:`ObserverSetup.make_estimator` builds the type's estimator from the design through
   :func:`observer_ros.core.observers.make_estimator`, and :meth:`ObserverSetup.make_stream`
   runs it in an :class:`~observer_ros.core.streaming.EventStream`.

For a continuous model the estimator designs the observer again for each new sample
interval, at run time (:attr:`ObserverSetup.designs_per_interval`): it samples the plant
exactly over the interval and places the poles there as ``exp(lambda dt)`` (a Kalman
filter solves its Riccati equation there), so jittered stamps stay exact. Each interval is
designed once and cached, rounded to ``observer.interval_resolution``
(:class:`~observer_ros.core.estimators.StepDesign`).
"""

from contextlib import contextmanager
from dataclasses import dataclass, field as dataclass_field
from typing import Iterator, Optional

import numpy as np

from observer_ros.config.binding import Binding
from observer_ros.config.joint_states import joint_state_selection, JointStateSelection
from observer_ros.config.message_noise import attach_message_noise
from observer_ros.config.model import Augmentation
from observer_ros.config.odometry import odometry_output, OdometryOutput
from observer_ros.config.sections import ModelSection, ObserverSection, Sections
from observer_ros.config.sources import measurement_sources, SOURCE_ARGUMENTS, SourcesSetup
from observer_ros.config.values import check_inside
from observer_ros.core.angles import Angles
from observer_ros.core.design.common import ObserverDesign
from observer_ros.core.errors import ConfigError, UnobservableError
from observer_ros.core.estimators import Estimator
from observer_ros.core.flat_matrices import vector_from_flat
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.nonlinear.linearize import nonlinear_model_of
from observer_ros.core.observers import (
    disturbance_arguments, make_estimator, observer_type, ObserverType)
from observer_ros.core.rules import ValueLimits
from observer_ros.core.streaming import EventStream
from observer_ros.core.units import seconds_to_ns


def observer_design(sections: Sections, augmentation: Augmentation) -> Optional['ObserverSetup']:
    """
    Design the observer of ``observer.*`` for the model; return its one setup object.

    Every stream setting is converted here, once, into the unit the stream takes (seconds
    to integer nanoseconds with :func:`~observer_ros.core.units.seconds_to_ns`), and the
    type's arguments are those the schema converted (``poles`` a complex array). The
    :class:`ObserverSetup` made here is handed on whole; None when the arguments configure
    no observer (no poles, gain or noise).

    Raises
    ------
    ConfigError
        Naming the parameter: an unknown type, a failed design (charged to the argument the
        error names, else to :attr:`ObserverSetup.design_source`), a resolution that
        does not fit, an initial state of the wrong size or beyond ``topics.x_hat.limit``,
        joint states that are no states of the model.

    """
    section, model, topics = sections.observer, augmentation.model, sections.topics
    binding = ModelSection.binding() | section.binding()
    with binding.charged(binding['type']):
        kind = observer_type(section.type)
    history_ns = seconds_to_ns(section.history, binding['history'])
    sources = measurement_sources(sections, model)
    given = _with_source_noise(section.arguments, sources, kind, binding)
    design_source = binding.get(kind.charged_argument(given)) or binding['type']
    for argument in disturbance_arguments():
        augmentation.refuse_without(binding[argument], given.get(argument))
    with binding.charged(design_source, numeric=True):
        if kind.vet is not None:
            kind.vet(model, given)
        arguments = {name: given[name] for name in kind.argument_names()}
        with _naming_sources(sources, model):
            design = kind.design(model, arguments, augmentation.disturbance)
    _check_interval_resolution(section, model)
    initial_state = None
    if section.initial_state:
        initial_state = vector_from_flat(binding['initial_state'], section.initial_state,
                                         model.n_states)
        check_inside(binding['initial_state'], initial_state, topics['x_hat'].limit,
                     'topics.x_hat.limit')
    angles = augmentation.angles
    if angles and not kind.capabilities.angles:
        parameter = binding['angle_outputs' if angles.outputs else 'angle_states']
        raise ConfigError(parameter, f'the {kind.name} observer cannot keep angles (its type '
                          f'has no capability angles); expected none, or another observer.type')
    joint_states = joint_state_selection(section.joint_states, model)
    odometry = odometry_output(section.odometry, model.state_names)  # outputs.odometry.*
    if design is None:
        return None
    limits = ValueLimits(measurement=topics['y'].limit, input=topics['u'].limit,
                         estimate=topics['x_hat'].limit, innovation=topics['innovation'].limit)
    return ObserverSetup(
        kind=kind, arguments=arguments, design=design, initial_state=initial_state,
        interval_resolution_ns=seconds_to_ns(section.interval_resolution,
                                             binding['interval_resolution']),
        max_gap_ns=seconds_to_ns(section.max_gap, binding['max_gap']),
        clock_tolerance_ns=seconds_to_ns(section.clock_tolerance, binding['clock_tolerance']),
        input_wait_ns=seconds_to_ns(section.input_wait, binding['input_wait']),
        publish_rate=section.publish_rate, limits=limits, input_stamped=topics['u'].stamped,
        joint_states=joint_states, binding=binding, design_source=design_source,
        sources=sources, history_ns=history_ns, angles=angles,
        unstamped_input=section.unstamped_input, odometry=odometry)


@contextmanager
def _naming_sources(sources: Optional[SourcesSetup], model: StateSpaceModel) -> Iterator[None]:
    """Say which measurement sources carry the outputs that leave a mode unseen."""
    try:
        yield
    except UnobservableError as e:
        if sources is None:
            raise
        carried = ', '.join(
            f'{source.name!r} (outputs {[model.output_names[k] for k in source.outputs]})'
            for source in sources.sources)
        which = (f'source {carried}' if len(sources.sources) == 1
                 else f'sources {carried} together')
        raise UnobservableError(f'{which}: {e.reason}') from e


def _with_source_noise(given: dict, sources: Optional[SourcesSetup], kind: ObserverType,
                       binding: Binding) -> dict:
    """Return the type's arguments with ``R`` made of the sources' blocks, when they give them."""
    if sources is None or sources.measurement_noise is None:
        return given
    block = sources.settings[0].parameter('measurement_noise')
    if 'measurement_noise' not in kind.argument_names():
        raise ConfigError(block, f'a {kind.name} observer takes no measurement noise; '
                          f'expected none')
    if given['measurement_noise']:
        raise ConfigError(binding['measurement_noise'], 'the sources give their blocks of R '
                          '(sources.<name>.measurement_noise); expected it empty')
    return {**given, 'measurement_noise': sources.measurement_noise.ravel().tolist()}


def _check_interval_resolution(section: ObserverSection, model: StateSpaceModel) -> None:
    parameter = section.binding()['interval_resolution']
    resolution, max_gap = section.interval_resolution, section.max_gap
    if resolution >= max_gap:
        raise ConfigError(parameter, f'expected seconds in [0, observer.max_gap = {max_gap}), '
                          f'got {resolution}')
    if resolution and model.is_discrete:
        raise ConfigError(parameter, f'a discrete model (model.dt = {model.dt}) has one '
                          f'period; expected 0, got {resolution}')


@dataclass(frozen=True)
class ObserverSetup:
    """
    The observer of a configuration: its design, and how its estimator and stream run.

    The one configuration object of the observer part, made once by
    :func:`observer_design` (through :func:`observer_ros.config.validate_parameters`) when
    the parameters configure an observer, every value in its final type and unit, and
    handed on whole: the observer node, the bag replay and the tools run it.

    Attributes
    ----------
    kind : ObserverType
        The registered type of ``observer.type``: ask its ``capabilities``.
    arguments : dict
        The type's arguments by their own names, checked once.
    design : ObserverDesign
    initial_state : numpy.ndarray or None
        ``observer.initial_state``, which pins the first estimate; None: the first
        measurement initialises it.
    interval_resolution_ns, max_gap_ns, clock_tolerance_ns, input_wait_ns : int
        ``observer.interval_resolution``, ``observer.max_gap``, ``observer.clock_tolerance``
        and ``observer.input_wait`` in integer nanoseconds.
    publish_rate : float
        ``observer.publish_rate`` (Hz; 0: once per measurement).
    limits : ValueLimits
        ``topics.<topic>.limit`` of ``y``, ``u``, ``x_hat`` and ``innovation``.
    input_stamped : bool
        Whether ``u`` carries header stamps (``topics.u.type``).
    unstamped_input : str
        ``observer.unstamped_input``: ``arrival`` or ``next_measurement`` (how the node
        stamps an unstamped ``u``; see
        :meth:`~observer_ros.core.streaming.EventStream.hold_input`).
    joint_states : JointStateSelection or None
        ``observer.joint_*`` when given.
    binding : Binding
        The type's arguments (and the model's) bound to their parameters.
    design_source : str
        The parameter a failed design is charged to when its error names none.
    sources : SourcesSetup or None
        The measurement sources (None: one, ``topics.y``, with every output).
    history_ns : int
        ``observer.history`` in nanoseconds.
    angles : Angles
        ``model.angle_states`` and ``model.angle_outputs``, given to the estimator.

    """

    kind: ObserverType
    arguments: dict
    design: ObserverDesign
    initial_state: Optional[np.ndarray]
    interval_resolution_ns: int
    max_gap_ns: int
    clock_tolerance_ns: int
    input_wait_ns: int
    publish_rate: float
    limits: ValueLimits
    input_stamped: bool
    joint_states: Optional[JointStateSelection]
    binding: Binding
    design_source: str
    sources: Optional[SourcesSetup] = None
    history_ns: int = 0
    angles: Angles = Angles()
    unstamped_input: str = 'arrival'
    odometry: Optional[OdometryOutput] = None
    _built: list = dataclass_field(default_factory=list, compare=False, repr=False)

    @property
    def form(self) -> str:
        """``observer.form``: ``current``, or ``delayed`` (types that have the argument)."""
        return self.arguments.get('form', 'current')

    @property
    def designs_per_interval(self) -> bool:
        """
        Whether the estimator designs the observer again for each new sample interval.

        True for a continuous model: the built-in types' estimators sample it exactly over
        each new interval (rounded to :attr:`interval_resolution_ns`) and place the poles
        there again (or solve the Riccati equation there), at run time (see the module
        notes); a plug-in type's estimator works over each interval in its own way. A
        discrete model has one period.
        """
        return not self.design.model.is_discrete

    def pinned_parameters(self) -> dict:
        """
        Return the parameters that pin the design as it is (``design_observer --write``).

        ``{parameter: value}``, a value None removing the parameter; the type says which of
        its arguments pin it.
        """
        pinned = self.kind.pinned_arguments(self.design, self.arguments)
        return {self.binding[argument]: value for argument, value in pinned.items()}

    def make_estimator(self) -> Estimator:
        """
        Build the runtime estimator through :func:`observer_ros.core.observers.make_estimator`.

        Raises
        ------
        ConfigError
            Naming the parameter (a type's estimator that cannot take the design).

        """
        try:
            estimator = make_estimator(self.design, self.initial_state,
                                       self.interval_resolution_ns, values=self.arguments)
            estimator.keep_angles(self.angles)
            return estimator
        except ConfigError as e:
            raise self.binding.error(e, self.design_source) from e

    def make_stream(self) -> EventStream:
        """
        Build the :class:`EventStream` the observer node and the bag replay both run.

        Its gap, clock tolerance, value limits, stamped inputs, form, measurement sources
        and history are this setup's.

        Raises
        ------
        ConfigError
            Naming the parameter: the type cannot update with several sources, or with one
            source alone that is not ``predict_only`` (naming the source and the modes it
            cannot see).

        """
        estimator = self.make_estimator()
        attach_message_noise(estimator, self.sources, self.history_ns)  # noise: message
        binding = self.binding | SOURCE_ARGUMENTS
        with binding.charged('observer.sources'):
            return EventStream(estimator, self.max_gap_ns, input_stamped=self.input_stamped,
                               clock_tolerance_ns=self.clock_tolerance_ns, limits=self.limits,
                               form=self.form,
                               sources=None if self.sources is None else self.sources.sources,
                               history_ns=self.history_ns,
                               output_names=self.design.model.output_names)

    @property
    def checks_sources(self) -> bool:
        """Whether the stream checks rules of the sources (latency within the history...)."""
        return (self.sources is not None or self.keeps_history
                or nonlinear_model_of(self.design.model) is not None)  # the type may refuse

    def check_stream(self) -> None:
        """
        Build the stream now, which checks the sources' rules and asks the type about each.

        :func:`observer_ros.config.validate_parameters` calls it once when
        :attr:`checks_sources`; the stream it builds is the one :meth:`take_stream` hands
        on first, not built again.

        Raises
        ------
        ConfigError
            As :meth:`make_stream`.

        """
        self._built[:] = [self.make_stream()]

    def take_stream(self) -> EventStream:
        """
        Return the stream :meth:`check_stream` built, once; else build one (:meth:`make_stream`).

        What a node runs: the stream checked at validation, handed on, not built twice.
        """
        return self._built.pop() if self._built else self.make_stream()

    @property
    def keeps_history(self) -> bool:
        """Whether the stream keeps a history (several sources, or ``observer.history``)."""
        return self.history_ns > 0 or self.sources is not None and len(
            self.sources.sources) > 1
