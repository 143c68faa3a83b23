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
:class:`~observer_ros.config.schema.ParameterSpec`
(:func:`~observer_ros.config.parameter_check.complete_parameters`), and read into frozen
dataclasses, one per section: :class:`ModelSection`, :class:`ObserverSection`,
:class:`FeedbackSection`, :class:`PlantSection`, :class:`DiagnosticsSection`,
:class:`~observer_ros.config.topic_sections.TopicsSection` (and :class:`ControllerSection`,
:class:`LifecycleSection`), together :class:`Sections`. Code reads these attributes
(``sections.plant.samples``), never a parameter name.

Each field is bound to its parameter once, with :func:`~observer_ros.config.binding.bound`:
the field's name is the argument the core knows the value by (``ModelSection.A``,
``IntegralSection.poles``), the binding names the parameter a user sets (``model.A``,
``feedback.integral_poles``). An observer type's arguments are bound in the schema
(:data:`~observer_ros.config.schema.OBSERVER_ARGUMENTS`) and read into
:attr:`ObserverSection.arguments` by their own names.

A section's :meth:`~observer_ros.config.binding.Section.binding` turns those bindings into a
:class:`~observer_ros.config.binding.Binding`, through which the errors of a core call are
charged to the parameter their argument stands for (``poles: expected 2 poles`` becomes
``observer.poles: expected 2 poles``): the error carries its argument and its reason, the
binding the parameter; no text is parsed.
"""

from dataclasses import dataclass, field
from typing import Any, Mapping

import numpy as np

from observer_ros.config.binding import bound, nested, Section
from observer_ros.config.parameter_check import complete_parameters, converted_parameters
from observer_ros.config.schema import OBSERVER_ARGUMENTS
from observer_ros.config.topic_sections import SourcesSection, TopicsSection


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
class OdometrySection(Section):
    """``outputs.odometry.*``: the Odometry of the estimate, its frames and its states."""

    topic: str = bound('outputs.odometry.topic')
    frame_id: str = bound('outputs.odometry.frame_id')
    child_frame_id: str = bound('outputs.odometry.child_frame_id')
    x: str = bound('outputs.odometry.x')
    y: str = bound('outputs.odometry.y')
    yaw: str = bound('outputs.odometry.yaw')
    vx: str = bound('outputs.odometry.vx')
    vy: str = bound('outputs.odometry.vy')
    wz: str = bound('outputs.odometry.wz')
    absent_variance: float = bound('outputs.odometry.absent_variance')
    publish_tf: bool = bound('outputs.odometry.publish_tf')


@dataclass(frozen=True)
class ObserverSection(Section):
    """
    ``observer.*``: the type, the stream's settings and every observer type's arguments.

    Attributes
    ----------
    arguments : dict
        The arguments of every registered observer type, checked and converted, by their
        own names (``arguments['poles']`` is ``observer.poles``, a complex array; bound in
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
    odometry: OdometrySection = nested(OdometrySection)
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
    """
    ``feedback.integral_*``: integral action, by the names of the integral design.

    ``poles`` is the complex array converted once from the numbers or texts given (empty
    without integral poles).
    """

    poles: np.ndarray = bound('feedback.integral_poles')
    integral_gain: list = bound('feedback.integral_gain')
    outputs: list = bound('feedback.integral_outputs')


@dataclass(frozen=True)
class FeedbackSection(Section):
    """
    ``feedback.*``: the state feedback's gain or poles, limits and safe command.

    ``poles`` is the complex array converted once from the numbers or texts given (empty
    without poles).
    """

    gain: list = bound('feedback.gain')
    poles: np.ndarray = bound('feedback.poles')
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
        Check ``params`` once and read every section.

        Checked by :func:`~observer_ros.config.parameter_check.complete_parameters`; every
        parameter whose spec has a ``parse`` is converted once into the type its user takes
        (:func:`~observer_ros.config.parameter_check.converted_parameters`:
        ``observer.poles``, ``feedback.poles`` and ``feedback.integral_poles`` complex
        arrays, from the numbers or texts given), and the sections hold that value;
        :attr:`parameters` keeps the checked form.
        """
        checked = complete_parameters(params, strict)
        values = cls.values({**checked, **converted_parameters(params)})
        return cls(**values, parameters=checked)
