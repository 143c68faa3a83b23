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
The one function that validates a parameter set, and the :class:`System` it defines.

:func:`validate_parameters` turns a flat ``{'model.A': [...], ...}`` mapping into a checked
:class:`System` holding the model and every design, or raises ConfigError naming the
parameter. It has no side effects, so the nodes vet run-time changes with it before they
apply them, and the design CLI and the bag tools read files with it.
"""

from dataclasses import dataclass, field
from typing import Any, Mapping, Optional
import warnings

import numpy as np

from observer_ros.config.names import named, parameter_for
from observer_ros.config.schema import PARAMETER_SPECS, PARAMETERS, ROS_PARAMETERS
from observer_ros.core.arguments import number_text
from observer_ros.core.design.common import ObserverDesign
from observer_ros.core.design.feedback import design_feedback, FeedbackDesign
from observer_ros.core.design.integral import design_integral, IntegralDesign
from observer_ros.core.disturbances import augment, augmented_noise, DisturbanceModel
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.estimators import Estimator
from observer_ros.core.flat_matrices import (
    covariance_from_flat, matrix_from_flat, vector_from_flat)
from observer_ros.core.loop_analysis.closed_loop import closed_loop_poles
from observer_ros.core.loop_analysis.observer_controller import controller_transfer_function
from observer_ros.core.loop_analysis.transfer_function import ControllerTransferFunction
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers import disturbance_arguments, observer_type, ObserverType
from observer_ros.core.observers.common import parsed_poles
from observer_ros.core.rules import ValueLimits
from observer_ros.core.simulation import input_limits_from_flat
from observer_ros.core.streaming import EventStream
from observer_ros.core.units import NANOSECONDS


#: The plant rate of a continuous model when ``plant.rate_hz`` is 0 (follow the model).
DEFAULT_RATE_HZ = 100.0

#: What numpy and scipy raise when a design's arithmetic breaks down (overflow, no
#: convergence); a design that raises one is refused like any other failed design.
NUMERIC_FAILURES = (np.linalg.LinAlgError, ValueError, ArithmeticError)


@dataclass(frozen=True)
class PlantSettings:
    """Validated ``plant.*`` parameters (``rate_hz`` resolved from the model when 0)."""

    rate_hz: float
    initial_state: np.ndarray
    process_noise: list
    measurement_noise: list
    seed: int
    input_limits: Optional[np.ndarray]
    command_timeout: float
    safe_input: np.ndarray
    disturbance: Optional[np.ndarray] = None
    disturbance_time: float = 0.0
    input_offset: Optional[np.ndarray] = None

    @property
    def period_ns(self) -> int:
        """Sample period in integer nanoseconds."""
        return int(round(NANOSECONDS / self.rate_hz))


@dataclass(frozen=True)
class FeedbackSettings:
    """Validated ``feedback.*`` parameters and the feedback design."""

    design: FeedbackDesign
    reference_gain: Optional[np.ndarray]
    input_limits: Optional[np.ndarray]
    timeout: float
    safe_command: np.ndarray
    safe_command_period: float
    disturbance_gain: Optional[np.ndarray] = None

    @property
    def estimate_gain(self) -> np.ndarray:
        """
        Return the gain on the whole estimate: ``[K, K_d]``, ``(m, n + n_d)``.

        ``K_d`` (:attr:`disturbance_gain`) cancels the matched input disturbances when
        ``feedback.disturbance_rejection`` is set and is zero otherwise; without
        disturbances the gain is ``K``.
        """
        if self.disturbance_gain is None:
            return self.design.gain
        return np.hstack([self.design.gain, self.disturbance_gain])
    integral: Optional[IntegralDesign] = None


@dataclass(frozen=True)
class JointStateSelection:
    """
    Validated ``observer.joint_*``: which states fill each field of ``joint_states_hat``.

    Attributes
    ----------
    names : tuple of str
        The joint names.
    position, velocity, effort : tuple of int
        State indices, one per joint, or empty (the field stays empty).

    """

    names: tuple
    position: tuple = ()
    velocity: tuple = ()
    effort: tuple = ()


@dataclass(frozen=True)
class System:
    """
    Everything a validated parameter set defines.

    Attributes
    ----------
    parameters : dict
        The complete flat parameter mapping (defaults filled in).
    model : StateSpaceModel
        The model the observer estimates and the plant simulates: the plant augmented with
        the disturbance states (plant states first) when ``model.disturbances`` is given,
        else the plant itself.
    observer : ObserverDesign or None
        None when the parameters define no observer (no poles, gain or noise).
    observer_type : str
    initial_estimate : numpy.ndarray or None
        ``observer.initial_state`` when given (it pins the first estimate); None when the
        first measurement initialises the estimate.
    feedback : FeedbackSettings or None
    plant : PlantSettings
    controller_tf : ControllerTransferFunction or None
        SISO plants with both an observer and a feedback gain.
    closed_loop_poles : numpy.ndarray or None
    notes : tuple of str
        Warnings worth showing (an unstable controller, for instance).
    disturbance : DisturbanceModel or None
        The plant, its disturbances and the augmented model (``model.disturbances``).
    joint_states : JointStateSelection or None
        ``observer.joint_names`` and the states of each field, when given.

    """

    parameters: dict
    model: StateSpaceModel
    observer: Optional[ObserverDesign]
    observer_type: str
    initial_estimate: Optional[np.ndarray]
    feedback: Optional[FeedbackSettings]
    plant: PlantSettings
    controller_tf: Optional[ControllerTransferFunction] = None
    closed_loop_poles: Optional[np.ndarray] = None
    notes: tuple = field(default_factory=tuple)
    disturbance: Optional[DisturbanceModel] = None

    @property
    def plant_model(self) -> StateSpaceModel:
        """The plant without its disturbance states (what ``feedback.*`` is designed for)."""
        return self.model if self.disturbance is None else self.disturbance.plant
    joint_states: Optional[JointStateSelection] = None

    @property
    def kind(self) -> ObserverType:
        """The registered type of ``observer.type``."""
        return observer_type(self.observer_type)

    def observer_values(self) -> dict:
        """Return the arguments of the observer type, by their own names."""
        params = self.parameters
        return {name: params[f'observer.{name}'] for name in self.kind.argument_names()}

    def make_estimator(self) -> Estimator:
        """Build the runtime estimator of the observer design (through its type)."""
        if self.observer is None:
            raise ConfigError('observer.poles', 'no observer is configured: give '
                              'observer.poles, observer.gain or the Kalman noises')
        try:
            return self.kind.estimator(self.observer, self.observer_values(),
                                       self.initial_estimate, self.interval_resolution_ns)
        except ConfigError as e:
            raise named(e, 'observer', self.design_source) from e

    @property
    def design_source(self) -> str:
        """The parameter a failed observer design is charged to when its error names none."""
        return _design_source(self.kind, self.parameters)

    @property
    def form(self) -> str:
        """``observer.form``: ``current``, or ``delayed`` (types that have the argument)."""
        return self.observer_values().get('form', 'current')

    def make_stream(self) -> EventStream:
        """
        Build the :class:`EventStream` the observer node and the bag replay both run.

        Its gap, clock tolerance, value limits and form come from ``observer.max_gap``,
        ``observer.clock_tolerance``, ``topics.<topic>.limit`` and ``observer.form``; inputs
        count as stamped when ``topics.u.type`` carries a header.
        """
        params = self.parameters
        limits = ValueLimits(measurement=params['topics.y.limit'],
                             input=params['topics.u.limit'],
                             estimate=params['topics.x_hat.limit'],
                             innovation=params['topics.innovation.limit'])
        return EventStream(
            self.make_estimator(), round(params['observer.max_gap'] * NANOSECONDS),
            input_stamped=params['topics.u.type'] == 'joint_state',
            clock_tolerance_ns=round(params['observer.clock_tolerance'] * NANOSECONDS),
            limits=limits, form=self.form)

    @property
    def interval_resolution_ns(self) -> int:
        """``observer.interval_resolution`` in integer nanoseconds."""
        return round(self.parameters['observer.interval_resolution'] * NANOSECONDS)


def complete_parameters(params: Mapping[str, Any], strict: bool = False) -> dict:
    """
    Fill defaults and coerce every known parameter to its type and range.

    Unknown names are kept untouched unless ``strict`` is set, in which case any name
    outside the schema (other than ROS's own ``use_sim_time`` and ``qos_overrides.*``) is
    an error, so that a typo is not silently ignored.
    """
    complete = {}
    for spec in PARAMETERS:
        complete[spec.name] = spec.coerce(params.get(spec.name, spec.default))
    for name, value in params.items():
        if name in PARAMETER_SPECS:
            continue
        if strict and not (name in ROS_PARAMETERS or name.startswith('qos_overrides.')):
            raise ConfigError(name, 'unknown parameter; see the parameter schema in README')
        complete[name] = value
    return complete


def _given_observer_values(params: dict) -> dict:
    """Return the ``observer.*`` values by the names of the type's arguments."""
    return {name[len('observer.'):]: value for name, value in params.items()
            if name.startswith('observer.')}


def _observer_kind(params: dict) -> ObserverType:
    try:
        return observer_type(params['observer.type'])
    except ConfigError as e:
        raise named(e, 'observer', 'observer.type') from e


def _design_source(kind: ObserverType, params: dict) -> str:
    """Return the parameter a failed observer design is charged to when it names none."""
    charged = parameter_for('observer', kind.charged_argument(_given_observer_values(params)))
    return charged or 'observer.type'  # a type that charges no argument of its own


def _design_observer(kind: ObserverType, params: dict, model: StateSpaceModel,
                     disturbance: Optional[DisturbanceModel] = None) -> Optional[ObserverDesign]:
    given = _given_observer_values(params)
    if disturbance is None:
        for argument in disturbance_arguments():
            if given.get(argument):
                raise ConfigError(argument, 'the model has no disturbances '
                                  '(model.disturbances); leave it empty')
    if kind.vet is not None:
        kind.vet(model, given)
    return kind.design(model, kind.values(given), disturbance)


def _check_inside(parameter: str, vector: np.ndarray, limits, source: str) -> None:
    """Refuse a vector outside ``limits`` (an ``(m, 2)`` array, or a magnitude bound)."""
    if limits is None:
        return
    if np.ndim(limits) == 0:
        outside = np.abs(vector) > limits
    else:
        outside = (vector < limits[:, 0]) | (vector > limits[:, 1])
    if outside.any():
        raise ConfigError(parameter, f'{vector.tolist()} lies outside {source} '
                          f'({np.asarray(limits).tolist()})')


def _limits(parameter: str, values, n_inputs: int):
    if values and not n_inputs:
        raise ConfigError(parameter, 'the model has no inputs (model.B is empty, m = 0): '
                          'expected no limits')
    try:
        return input_limits_from_flat(values, n_inputs)
    except ConfigError as e:
        raise ConfigError(parameter, e.reason) from e


def _disturbance(params: dict, model: StateSpaceModel) -> Optional[DisturbanceModel]:
    """Augment the plant with ``model.disturbances`` (None when there are none)."""
    if not params['model.disturbances']:
        for name in ('model.disturbance_entries', 'model.disturbance_matrix',
                     'model.disturbance_frequencies', 'model.disturbance_names'):
            if params[name]:
                raise ConfigError(name, 'given without model.disturbances; list the '
                                  'disturbance kinds there or leave it empty')
        return None
    try:
        return augment(model, params['model.disturbances'], params['model.disturbance_entries'],
                       params['model.disturbance_matrix'],
                       params['model.disturbance_frequencies'],
                       params['model.disturbance_names'])
    except ConfigError as e:
        raise named(e, 'model', 'model.disturbances') from e


def _disturbance_gain(params: dict, model: StateSpaceModel,
                      disturbance: Optional[DisturbanceModel]) -> Optional[np.ndarray]:
    """Return ``K_d`` of ``u = -K x_hat - K_d d_hat`` (None without disturbances)."""
    rejection = params['feedback.disturbance_rejection']
    if disturbance is None:
        if rejection:
            raise ConfigError('feedback.disturbance_rejection', 'expected a model with a '
                              'matched input disturbance (model.disturbances with '
                              'model.disturbance_entries input:<name>); the model has none')
        return None
    if not rejection:
        return np.zeros((model.n_inputs, disturbance.n_disturbance_states))
    if not disturbance.matched():
        raise ConfigError('feedback.disturbance_rejection', 'expected a matched input '
                          'disturbance (model.disturbance_entries input:<name>); the '
                          'disturbances enter at outputs or through disturbance_matrix only')
    return disturbance.rejection_gain()


def _indices(parameter: str, entries, names: tuple, what: str) -> tuple:
    """Return the indices of ``entries`` (names in ``names``, or 0-based indices)."""
    indices = []
    for entry in entries:
        if entry in names:
            indices.append(names.index(entry))
        elif entry.isdigit() and int(entry) < len(names):
            indices.append(int(entry))
        else:
            raise ConfigError(parameter, f'{entry!r} is no {what} of the model (expected one '
                              f'of {list(names)} or an index 0 ... {len(names) - 1})')
    return tuple(indices)


def _integral_outputs(params: dict, model: StateSpaceModel) -> tuple:
    given = params['feedback.integral_outputs']
    if given:
        outputs = _indices('feedback.integral_outputs', given, model.output_names, 'output')
        if len(set(outputs)) != len(outputs):
            raise ConfigError('feedback.integral_outputs', f'names an output twice: {given}')
        if len(outputs) > model.n_inputs:
            raise ConfigError('feedback.integral_outputs', f'{len(outputs)} integrated outputs '
                              f'need at least as many inputs; the model has m = '
                              f'{model.n_inputs}')
        return outputs
    if model.n_inputs != model.n_outputs:
        raise ConfigError('feedback.integral_outputs', f'integral action on a non-square plant '
                          f'(m = {model.n_inputs} inputs, p = {model.n_outputs} outputs) needs '
                          f'the outputs to integrate: name at most {model.n_inputs} of '
                          f'{list(model.output_names)}')
    return tuple(range(model.n_outputs))


def _integral(params: dict, model: StateSpaceModel, poles, gain) -> Optional[IntegralDesign]:
    """Design the servo gains when integral action is asked for (None otherwise)."""
    integral_text, integral_gain = (params['feedback.integral_poles'],
                                    params['feedback.integral_gain'] or None)
    if not integral_text and integral_gain is None:
        if params['feedback.integral_outputs']:
            raise ConfigError('feedback.integral_outputs', 'integral action needs '
                              'feedback.integral_poles (with feedback.poles) or '
                              'feedback.integral_gain (with feedback.gain)')
        return None
    if integral_text and integral_gain is not None:
        raise ConfigError('feedback.integral_gain', 'give either feedback.integral_gain or '
                          'feedback.integral_poles, not both')
    if integral_gain is not None and gain is None:
        raise ConfigError('feedback.integral_gain', 'a given K_i goes with a given '
                          'feedback.gain; with feedback.poles give feedback.integral_poles')
    if integral_text and gain is not None:
        raise ConfigError('feedback.integral_poles', 'the integral poles are placed with '
                          'feedback.poles; with a given feedback.gain give '
                          'feedback.integral_gain')
    outputs = _integral_outputs(params, model)
    all_poles = None
    if integral_text:
        try:
            integral_poles = parsed_poles({'poles': integral_text})
        except ConfigError as e:
            raise named(e, 'feedback', 'feedback.integral_poles') from e
        if integral_poles.size != len(outputs):
            raise ConfigError('feedback.integral_poles', f'expected {len(outputs)} poles (one '
                              f'per integrated output), got {integral_poles.size}')
        all_poles = np.concatenate([poles, integral_poles])
    source = 'feedback.integral_gain' if integral_gain is not None else 'feedback.integral_poles'
    try:
        return design_integral(model, outputs, all_poles, gain, integral_gain,
                               params['feedback.method'])
    except (ConfigError, DesignError) as e:
        raise named(e, 'integral', source) from e
    except NUMERIC_FAILURES as e:
        raise ConfigError(source, f'the design failed numerically ({e})') from e


def _feedback(params: dict, model: StateSpaceModel,
              disturbance: Optional[DisturbanceModel] = None) -> Optional[FeedbackSettings]:
    gain, pole_text = params['feedback.gain'] or None, params['feedback.poles']
    if params['feedback.integral_outputs'] and model.n_inputs == 0:
        raise ConfigError('feedback.integral_outputs', 'the model has no inputs (model.B is '
                          'empty, m = 0): integral action is not available; leave it empty')
    if gain is None and not pole_text:
        if params['feedback.disturbance_rejection']:
            raise ConfigError('feedback.disturbance_rejection', 'expected feedback.gain or '
                              'feedback.poles with it')
        if params['feedback.integral_poles'] or params['feedback.integral_gain']:
            raise ConfigError('feedback.poles', 'integral action needs the state feedback '
                              'too: feedback.poles or feedback.gain')
        if params['feedback.integral_outputs']:
            raise ConfigError('feedback.integral_outputs', 'integral action needs the state '
                              'feedback (feedback.poles or feedback.gain) and '
                              'feedback.integral_poles or feedback.integral_gain; without '
                              'them leave it empty')
        return None
    if model.n_inputs == 0:
        raise ConfigError('feedback.gain' if gain is not None else 'feedback.poles',
                          'the model has no inputs (model.B is empty, m = 0): state feedback '
                          'is not available')
    if gain is not None and pole_text:
        raise ConfigError('feedback.gain', 'give either feedback.gain or feedback.poles, '
                          'not both')
    try:
        poles = parsed_poles({'poles': pole_text})
    except ConfigError as e:
        raise named(e, 'feedback', 'feedback.poles') from e
    if poles is not None and poles.size != model.n_states:
        raise ConfigError('feedback.poles',
                          f'expected {model.n_states} poles, got {poles.size}')
    source = 'feedback.gain' if gain is not None else 'feedback.poles'
    integral = _integral(params, model, poles, gain)
    if integral is not None:  # K comes from the augmented design; no N by default
        design = FeedbackDesign(gain=integral.gain, requested_poles=integral.requested_poles,
                                achieved_poles=integral.achieved_poles,
                                method=integral.method, residual=integral.residual,
                                reference_gain=None)
    else:
        try:
            design = design_feedback(model, poles, gain, params['feedback.method'])
        except (ConfigError, DesignError) as e:
            raise named(e, 'feedback', source) from e
        except NUMERIC_FAILURES as e:
            raise ConfigError(source, f'the design failed numerically ({e})') from e
    reference = params['feedback.reference_gain']
    if reference:
        reference_gain = matrix_from_flat('feedback.reference_gain', reference,
                                          model.n_inputs, model.n_outputs)
    else:
        reference_gain = design.reference_gain
    limits = _limits('feedback.input_limits', params['feedback.input_limits'], model.n_inputs)
    safe = params['feedback.safe_command']
    safe_command = (vector_from_flat('feedback.safe_command', safe, model.n_inputs) if safe
                    else np.zeros(model.n_inputs))
    _check_inside('feedback.safe_command', safe_command, limits, 'feedback.input_limits')
    _check_inside('feedback.safe_command', safe_command,
                  params['topics.u_cmd.limit'], 'topics.u_cmd.limit')
    return FeedbackSettings(design=design, reference_gain=reference_gain, input_limits=limits,
                            timeout=params['feedback.timeout'], safe_command=safe_command,
                            safe_command_period=params['feedback.safe_command_period'],
                            disturbance_gain=_disturbance_gain(params, model, disturbance),
                            integral=integral)


def _joint_states(params: dict, model: StateSpaceModel) -> Optional[JointStateSelection]:
    names = tuple(params['observer.joint_names'])
    fields = {kind: params[f'observer.joint_{kind}_states']
              for kind in ('position', 'velocity', 'effort')}
    if not names:
        for kind, states in fields.items():
            if states:
                raise ConfigError(f'observer.joint_{kind}_states', 'needs '
                                  'observer.joint_names (the joints of joint_states_hat)')
        return None
    if len(set(names)) != len(names):
        raise ConfigError('observer.joint_names', f'names must be unique, got {list(names)}')
    if not any(fields.values()):
        raise ConfigError('observer.joint_names', 'expected states for at least one field: '
                          'observer.joint_position_states, observer.joint_velocity_states or '
                          'observer.joint_effort_states')
    chosen = {}
    for kind, states in fields.items():
        parameter = f'observer.joint_{kind}_states'
        if states and len(states) != len(names):
            raise ConfigError(parameter, f'expected {len(names)} states (one per joint of '
                              f'observer.joint_names), got {len(states)}')
        chosen[kind] = _indices(parameter, states, model.state_names, 'state')
    return JointStateSelection(names, **chosen)


def plant_rate(params: Mapping, model: StateSpaceModel) -> float:
    """
    Return the plant rate: ``plant.rate_hz``, or with 0 the model's own.

    Raises
    ------
    ConfigError
        ``plant.rate_hz`` between 0 and 0.01 Hz, or not ``1 / model.dt`` for a discrete
        model.

    """
    rate = params['plant.rate_hz']
    if rate == 0.0:
        return 1.0 / model.dt if model.is_discrete else DEFAULT_RATE_HZ
    if rate < 0.01:
        raise ConfigError('plant.rate_hz', f'expected 0 (the model rate) or a rate in '
                          f'[0.01, 10000] Hz, got {number_text(rate)}')
    if model.is_discrete and abs(rate * model.dt - 1.0) > 1e-9:
        raise ConfigError('plant.rate_hz', f'a discrete model with model.dt = {model.dt} s '
                          f'runs at {1.0 / model.dt:g} Hz, got {rate}')
    return rate


def _plant_disturbance(params: dict, disturbance: Optional[DisturbanceModel]) -> tuple:
    """Return ``(values, time)`` of ``plant.disturbance`` (None when not applied)."""
    values = params['plant.disturbance']
    if not values:
        return None, 0.0
    if disturbance is None:
        raise ConfigError('plant.disturbance', 'the model has no disturbances '
                          '(model.disturbances); leave it empty')
    names = disturbance.augmented.state_names[disturbance.plant.n_states:]
    try:
        vector = vector_from_flat('plant.disturbance', values, len(names))
    except ConfigError as e:
        raise ConfigError('plant.disturbance', f'{e.reason} (one per disturbance state: '
                          f'{", ".join(names)})') from e
    return vector, params['plant.disturbance_time']


def _plant(params: dict, model: StateSpaceModel,
           disturbance: Optional[DisturbanceModel] = None) -> PlantSettings:
    rate = plant_rate(params, model)
    plant_model = model if disturbance is None else disturbance.plant
    initial = params['plant.initial_state']
    initial_state = (vector_from_flat('plant.initial_state', initial, plant_model.n_states)
                     if initial else np.zeros(plant_model.n_states))
    _check_inside('plant.initial_state', initial_state, params['topics.x_true.limit'],
                  'topics.x_true.limit')
    process_noise = params['plant.process_noise']
    if process_noise:
        q = covariance_from_flat('plant.process_noise', process_noise, plant_model.n_states)
        if disturbance is not None:
            process_noise = augmented_noise(q, np.zeros(disturbance.n_disturbance_states),
                                            disturbance.n_disturbance_states).ravel().tolist()
    if disturbance is not None:
        initial_state = np.concatenate([initial_state,
                                        np.zeros(disturbance.n_disturbance_states)])
    plant_disturbance, disturbance_time = _plant_disturbance(params, disturbance)
    if params['plant.measurement_noise']:
        covariance_from_flat('plant.measurement_noise', params['plant.measurement_noise'],
                             model.n_outputs)
    limits = _limits('plant.input_limits', params['plant.input_limits'], model.n_inputs)
    safe = params['plant.safe_input']
    safe_input = (vector_from_flat('plant.safe_input', safe, model.n_inputs) if safe
                  else np.zeros(model.n_inputs))
    _check_inside('plant.safe_input', safe_input, limits, 'plant.input_limits')
    _check_inside('plant.safe_input', safe_input, params['topics.u.limit'], 'topics.u.limit')
    offset = params['plant.input_offset']
    input_offset = (vector_from_flat('plant.input_offset', offset, model.n_inputs) if offset
                    else None)
    if model.n_inputs == 0 and params['plant.lockstep']:
        raise ConfigError('plant.lockstep', 'a model without inputs (model.B empty) has no '
                          'command to wait for: run the plant in real time')
    command_timeout = params['plant.command_timeout']
    return PlantSettings(rate_hz=rate, initial_state=initial_state,
                         process_noise=process_noise,
                         measurement_noise=params['plant.measurement_noise'],
                         seed=params['plant.seed'], input_limits=limits,
                         command_timeout=command_timeout, safe_input=safe_input,
                         disturbance=plant_disturbance, disturbance_time=disturbance_time,
                         input_offset=input_offset)


def _check_interval_resolution(params: dict, model: StateSpaceModel) -> None:
    resolution = params['observer.interval_resolution']
    if resolution >= params['observer.max_gap']:
        raise ConfigError('observer.interval_resolution', f'expected seconds in [0, '
                          f'observer.max_gap = {params["observer.max_gap"]}), got {resolution}')
    if resolution and model.is_discrete:
        raise ConfigError('observer.interval_resolution', f'a discrete model (model.dt = '
                          f'{model.dt}) has one period; expected 0, got {resolution}')


def sample_rate(params: Mapping, model: StateSpaceModel, plant: bool = False) -> tuple:
    """
    Return ``(rate_hz, source)``: the rate the samples come at, and the parameter that sets it.

    ``diagnostics.expected_rate``, else (and with ``plant`` always) the plant rate
    (:func:`plant_rate`: ``plant.rate_hz``, ``1 / model.dt``, or 100 Hz for a continuous
    model). The nodes watch their inputs against it and the time-like parameters are
    checked against its period (:data:`PERIOD_RULES`).
    """
    expected = params['diagnostics.expected_rate']
    if expected > 0 and not plant:
        return expected, 'diagnostics.expected_rate'
    rate = plant_rate(params, model)
    if params['plant.rate_hz']:
        return rate, 'plant.rate_hz'
    if model.is_discrete:
        return rate, 'model.dt'
    return rate, (f'the {number_text(DEFAULT_RATE_HZ)} Hz assumed for a continuous model; set '
                  + ('plant.rate_hz' if plant else 'diagnostics.expected_rate'))


#: Time-like parameters checked against one sample period: ``(parameter, whether it
#: follows the plant's rate (else the sample rate), what 0 means (None: not allowed),
#: whether it must be below the period (else above), what would go wrong)``.
PERIOD_RULES = (
    ('plant.command_timeout', True, None, False, 'every sample would find the command '
     'stale'),
    ('feedback.timeout', False, None, False, 'the safe command would replace the commands '
     'computed from most estimates'),
    ('observer.max_gap', False, None, False, 'every sample interval would restart the '
     'estimator'),
    ('observer.interval_resolution', False, 'exact intervals', True, 'a sample interval '
     'would be designed as a whole multiple of it, half a sample period or more off the '
     'real one'),
    ('diagnostics.stale_timeout', False, 'automatic', False, 'every input would be stale '
     'between two samples'),
)


def _check_sample_period(params: dict, model: StateSpaceModel, given) -> None:
    """
    Refuse a time-like parameter that cannot work at the sample period (:data:`PERIOD_RULES`).

    Only the parameters in ``given`` are checked: a node gives every parameter it declares,
    so each node checks its own (not the defaults of another node's), a file what it sets.
    """
    for name, plant, zero, below, harm in PERIOD_RULES:
        value = params[name]
        if name not in given or (zero is not None and value == 0.0):
            continue
        rate, source = sample_rate(params, model, plant)
        if (value * rate >= 1.0) if below else (value * rate <= 1.0):
            expected = (f'0 ({zero}) or ' if zero else '') + (
                'seconds below' if below else 'more than') + ' one sample period'
            raise ConfigError(name, f'expected {expected} ({number_text(1.0 / rate)} s at '
                              f'{number_text(rate)} Hz, from {source}), got '
                              f'{number_text(value)}: {harm}')


def _without_generator_modes(poles: np.ndarray, model: StateSpaceModel,
                             disturbance: DisturbanceModel) -> np.ndarray:
    """
    Drop the disturbance generators' modes from the augmented closed-loop poles.

    The generators are exogenous (nothing feeds back into them), so their modes appear in
    the augmented closed loop unchanged; the loop of the real plant and the observer-controller
    has the others.
    """
    n = disturbance.plant.n_states
    remaining = list(np.asarray(poles, dtype=complex))
    for mode in np.linalg.eigvals(model.a[n:, n:]):
        if remaining:
            remaining.pop(int(np.argmin(np.abs(np.array(remaining) - mode))))
    return np.array(remaining)


def validate_parameters(params: Mapping[str, Any], strict: bool = False) -> System:
    """
    Validate a flat parameter mapping and build every design it defines.

    Parameters
    ----------
    params : mapping
        ``{'model.A': [...], 'observer.poles': ['-8', '-9'], ...}``; missing names take their
        defaults from the schema (:data:`observer_ros.config.schema.PARAMETERS`).
    strict : bool
        Reject names outside the schema (besides ROS's own).

    Returns
    -------
    System

    Raises
    ------
    ConfigError
        The message starts with the parameter name and says what was expected. Design
        failures (unobservable pair, unstable given gain...) are reported against the
        parameter that caused them.

    """
    complete = complete_parameters(params, strict)
    if not complete['model.A']:
        raise ConfigError('model.A', 'missing: the model needs A, B and C')
    try:
        model = StateSpaceModel.from_flat(
            complete['model.A'], complete['model.B'], complete['model.C'],
            complete['model.D'], complete['model.dt'], complete['model.state_names'],
            complete['model.input_names'], complete['model.output_names'])
    except ConfigError as e:
        raise named(e, 'model', 'model.A') from e
    plant_model = model
    disturbance = _disturbance(complete, plant_model)
    if disturbance is not None:
        model = disturbance.augmented
    kind = _observer_kind(complete)
    fallback = _design_source(kind, complete)
    try:
        observer = _design_observer(kind, complete, model, disturbance)
    except (ConfigError, DesignError) as e:
        raise named(e, 'observer', fallback) from e
    except NUMERIC_FAILURES as e:
        raise ConfigError(fallback, f'the design failed numerically ({e})') from e
    _check_interval_resolution(complete, model)
    initial = complete['observer.initial_state']
    initial_estimate = (vector_from_flat('observer.initial_state', initial, model.n_states)
                        if initial else None)
    if initial_estimate is not None:
        _check_inside('observer.initial_state', initial_estimate,
                      complete['topics.x_hat.limit'], 'topics.x_hat.limit')
    feedback = _feedback(complete, plant_model, disturbance)
    plant = _plant(complete, model, disturbance)
    _check_sample_period(complete, model, params)
    joint_states = _joint_states(complete, model)
    controller_tf, cl_poles, notes = None, None, []
    if (observer is not None and feedback is not None
            and not kind.capabilities.linear_realization):
        notes.append(f'closed-loop analysis skipped: the {kind.name} observer has no linear '
                     f'realization, so neither the closed-loop poles nor G_oc are defined')
    elif observer is not None and feedback is not None and feedback.integral is not None:
        # Separation: the servo loop's poles (on the augmented model) and the observer's.
        cl_poles = np.concatenate([feedback.integral.achieved_poles, observer.achieved_poles])
        notes.append('integral action: no single observer-controller transfer function is '
                     'given (the integrator takes the measured y)')
    elif observer is not None and feedback is not None:
        cl_poles = closed_loop_poles(model, observer.realization, feedback.estimate_gain)
        if disturbance is not None:
            cl_poles = _without_generator_modes(cl_poles, model, disturbance)
        if model.n_inputs == 1 and model.n_outputs == 1:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter('always')
                try:
                    controller_tf = controller_transfer_function(
                        model, observer.realization, feedback.estimate_gain)
                except DesignError as e:
                    # The realization comes from the poles and, when given, the gain.
                    culprit = ('observer.poles / observer.gain' if complete.get('observer.gain')
                               else 'observer.poles')
                    raise ConfigError(culprit, e.reason) from e
            messages = [str(w.message) for w in caught]
            if disturbance is not None:
                # The augmented plant's disturbance modes are uncontrollable by construction:
                # the Diophantine cross-check does not apply to it.
                messages = [m for m in messages if not m.startswith('G_oc could not be')]
            notes.extend(messages)
    return System(parameters=complete, model=model, observer=observer,
                  observer_type=complete['observer.type'], initial_estimate=initial_estimate,
                  feedback=feedback, plant=plant, controller_tf=controller_tf,
                  closed_loop_poles=cl_poles, notes=tuple(notes), disturbance=disturbance,
                  joint_states=joint_states)
