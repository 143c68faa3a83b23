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
The one parameter schema of observer_ros and the one function that validates it.

Nodes declare their ROS parameters from :data:`PARAMETERS`; the design CLI and the bag
tools read the same YAML file (``/**: ros__parameters:``). :func:`validate_parameters`
turns a flat ``{'model.A': [...], ...}`` mapping into a checked :class:`System` holding the
model and every design, or raises :class:`ConfigError` naming the parameter. It has no side
effects, so nodes call it to vet run-time parameter changes before applying them.
"""

from dataclasses import dataclass, field
import json
import math
from typing import Any, Mapping, Optional
import warnings

import numpy as np
import yaml

from observer_ros.core.analysis import format_modes
from observer_ros.core.design.chen import design_chen
from observer_ros.core.design.common import ObserverDesign
from observer_ros.core.design.controller import (
    closed_loop_poles, controller_transfer_function, ControllerTransferFunction)
from observer_ros.core.design.feedback import design_feedback, FeedbackDesign
from observer_ros.core.design.full_order import design_full_order
from observer_ros.core.design.kalman import design_kalman
from observer_ros.core.design.reduced_order import COORDINATES, design_reduced_order
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.estimators import Estimator, make_estimator
from observer_ros.core.model import (
    covariance_from_flat, matrix_from_flat, StateSpaceModel, vector_from_flat)
from observer_ros.core.placement import METHODS
from observer_ros.core.poles import parse_poles, poles_meeting_error_spec, slowest_allowed_pole
from observer_ros.core.simulation import input_limits_from_flat
from observer_ros.core.streaming import StreamEstimator, ValueLimits

OBSERVER_TYPES = ('full_order', 'reduced_order', 'chen', 'kalman')

NANOSECONDS = 1_000_000_000

#: What numpy and scipy raise when a design's arithmetic breaks down (overflow, no
#: convergence); a design that raises one is refused like any other failed design.
NUMERIC_FAILURES = (np.linalg.LinAlgError, ValueError, ArithmeticError)

DOUBLE, DOUBLE_ARRAY, STRING, STRING_ARRAY, INTEGER, BOOL = (
    'double', 'double_array', 'string', 'string_array', 'integer', 'bool')


#: The nodes of the package, by the name each declares its parameters under.
PLANT, OBSERVER, FEEDBACK = 'plant_simulator', 'observer', 'state_feedback'
ALL_NODES = (PLANT, OBSERVER, FEEDBACK)

#: Largest magnitude of a model, gain or covariance entry: beyond it the exact
#: discretization and the designs overflow double precision.
ENTRY_LIMIT = 1e12

#: Default of ``topics.<topic>.limit``: the largest magnitude a vector value may have.
VALUE_LIMIT = 1e9

#: Largest magnitude of a continuous pole (rad/s): beyond it the sampled designs overflow.
POLE_LIMIT = 1e9

#: Largest seed ``numpy.random.default_rng`` takes from a ROS integer parameter.
SEED_MAX = 2 ** 63 - 1


@dataclass(frozen=True)
class ParameterSpec:
    """
    One parameter: name, type, default, description, range and the nodes that declare it.

    Attributes
    ----------
    dynamic : bool
        Whether it may change at run time.
    nodes : tuple of str
        The nodes that declare it (:data:`PLANT`, :data:`OBSERVER`, :data:`FEEDBACK`).
    low, high : float or None
        Inclusive bounds of a number (of every entry's magnitude for ``entry_limit``).
    low_open : bool
        The lower bound is exclusive (``> low``).
    unit : str
        What the number is, for error messages (``'seconds'``).
    entry_limit : float or None
        Double arrays: the largest magnitude of an entry.

    """

    name: str
    kind: str
    default: Any
    description: str
    dynamic: bool = False
    nodes: tuple = ALL_NODES
    low: Optional[float] = None
    high: Optional[float] = None
    low_open: bool = False
    unit: str = 'a value'
    entry_limit: Optional[float] = None

    def range_text(self) -> str:
        """Return the accepted range in words (empty when any value of the type is accepted)."""
        if self.low is None and self.high is None:
            return ''
        low = '-inf' if self.low is None else f'{self.low:g}'
        high = 'inf' if self.high is None else f'{self.high:g}'
        return f'{"(" if self.low_open else "["}{low}, {high}]'


def _matrix(text: str) -> str:
    return f'{text}, flat row-major (row after row).'


_OBS, _FB, _PL = (OBSERVER,), (FEEDBACK,), (PLANT,)


def _seconds(name: str, default: float, description: str, low: float, high: float,
             nodes: tuple, dynamic: bool = False, low_open: bool = False) -> ParameterSpec:
    return ParameterSpec(name, DOUBLE, default, description, dynamic, nodes, low, high,
                         low_open, 'seconds')


def _array(name: str, description: str, nodes: tuple, dynamic: bool = False,
           limit: float = ENTRY_LIMIT) -> ParameterSpec:
    return ParameterSpec(name, DOUBLE_ARRAY, [], description, dynamic, nodes,
                         entry_limit=limit)


PARAMETERS = (
    _array('model.A', _matrix('State matrix A, n x n (n*n values)'), ALL_NODES),
    _array('model.B', _matrix('Input matrix B, n x m'), ALL_NODES),
    _array('model.C', _matrix('Output matrix C, p x n'), ALL_NODES),
    _array('model.D', _matrix('Feedthrough D, p x m; empty means zero'), ALL_NODES),
    _seconds('model.dt', 0.0, 'Model period in seconds: 0 for continuous time, > 0 for '
             'discrete time.', 0.0, 3600.0, ALL_NODES),
    ParameterSpec('model.state_names', STRING_ARRAY, [], 'n state names (default x1..xn).'),
    ParameterSpec('model.input_names', STRING_ARRAY, [], 'm input names (default u1..um).'),
    ParameterSpec('model.output_names', STRING_ARRAY, [], 'p output names (default y1..yp).'),
    ParameterSpec('observer.type', STRING, 'full_order',
                  'full_order | reduced_order | chen | kalman.', nodes=_OBS),
    ParameterSpec('observer.poles', STRING_ARRAY, [],
                  'Observer error poles as strings ("-10", "-2+2j", "zeta=0.8, wn=10"); '
                  's-plane for a continuous model, z-plane for a discrete one. n poles '
                  '(full order) or n - p (reduced order, Chen).', dynamic=True, nodes=_OBS),
    _array('observer.gain', _matrix('Given observer gain L instead of poles: n x p (full '
                                    'order) or (n-p) x p (reduced order, Chen)'),
           _OBS, dynamic=True),
    _array('observer.process_noise', 'Kalman Q: n diagonal values or n x n row-major. '
           'Continuous model: intensity (discretized per interval); discrete model: '
           'covariance.', _OBS, dynamic=True),
    _array('observer.measurement_noise', 'Kalman R: p diagonal values or p x p row-major; '
           'covariance of each sampled measurement (continuous model: intensity for the CARE '
           'design).', _OBS, dynamic=True),
    ParameterSpec('observer.method', STRING, 'auto',
                  'Pole placement method: ' + ' | '.join(METHODS) + '.', dynamic=True,
                  nodes=_OBS),
    ParameterSpec('observer.coordinates', STRING, 'orthonormal',
                  'Reduced order: orthonormal (C completed by an orthonormal null-space '
                  'basis) | observability (the observability matrix, one output).',
                  nodes=_OBS),
    ParameterSpec('observer.chen_seed', INTEGER, 0,
                  'Chen, several outputs, observer.gain empty: seed of the candidate choices '
                  'of L (the best-conditioned [C; T] is kept); no effect with one output '
                  '(0 ... 2^63 - 1).',
                  dynamic=True, nodes=_OBS, low=0, high=SEED_MAX, unit='a seed'),
    ParameterSpec('observer.error_tolerance', DOUBLE, 0.0,
                  'With observer.error_time: require ||e(T)|| <= tolerance for ||e(0)|| = 1 '
                  '(slowest pole ln(tolerance)/T); 0 disables. Without poles, poles are '
                  'generated at that bound.', dynamic=True, nodes=_OBS, low=0.0, high=1.0),
    _seconds('observer.error_time', 0.0, 'Time T in seconds of the error specification.',
             0.0, 1e6, _OBS, dynamic=True),
    _array('observer.initial_state', 'Initial estimate, n values. Empty (the default): the '
           'first measurement initialises the estimate (least-norm x with C x = y).', _OBS,
           dynamic=True, limit=VALUE_LIMIT),
    _array('feedback.gain', _matrix('Given state-feedback gain K, m x n (u = -K x_hat + N r)'),
           _FB, dynamic=True),
    ParameterSpec('feedback.poles', STRING_ARRAY, [],
                  'Poles of A - B K as strings, n of them.', dynamic=True, nodes=_FB),
    ParameterSpec('feedback.method', STRING, 'auto', 'Pole placement method for K.',
                  dynamic=True, nodes=_FB),
    _array('feedback.reference_gain', _matrix('Reference gain N, m x p; empty: unit DC gain '
                                              'when the plant is square'), _FB, dynamic=True),
    _array('feedback.input_limits', 'Command saturation: [min, max] or [min_1, max_1, ..., '
           'min_m, max_m].', _FB, dynamic=True, limit=VALUE_LIMIT),
    _seconds('feedback.timeout', 0.5, 'Steady-clock seconds without an accepted x_hat after '
             'which the safe command is published, with use_sim_time too (0.001 ... 3600).',
             0.001, 3600.0, _FB, dynamic=True),
    _array('feedback.safe_command', 'Command published when x_hat is stale or a command is '
           'beyond topics.u_cmd.limit, m values (default zeros; inside feedback.input_limits).',
           _FB, dynamic=True, limit=VALUE_LIMIT),
    _seconds('feedback.safe_command_period', 0.1, 'Steady-clock seconds between repetitions '
             'of the safe command while x_hat is stale (0.001 ... 3600).', 0.001, 3600.0, _FB,
             dynamic=True),
    ParameterSpec('plant.rate_hz', DOUBLE, 100.0,
                  'Plant sample rate in Hz (0.01 ... 10000; a discrete model: 1 / model.dt).',
                  nodes=_PL, low=0.01, high=10000.0, unit='a rate in Hz'),
    _array('plant.initial_state', 'True initial state, n values.', _PL, limit=VALUE_LIMIT),
    _array('plant.process_noise', 'Plant process noise: intensity (continuous) or covariance '
           '(discrete), n or n*n values; empty for none.', _PL),
    _array('plant.measurement_noise', 'Measurement noise covariance, p or p*p values; empty '
           'for none.', _PL),
    ParameterSpec('plant.seed', INTEGER, 0, 'Seed of the plant noise (0 ... 2^63 - 1).',
                  nodes=_PL, low=0, high=SEED_MAX, unit='a seed'),
    _array('plant.input_limits', 'Input saturation: [min, max] or [min_1, max_1, ..., min_m, '
           'max_m].', _PL, limit=VALUE_LIMIT),
    ParameterSpec('plant.lockstep', BOOL, False,
                  'Lockstep: publish /clock and advance only when the command computed '
                  'from the current sample has arrived (deterministic, faster than real '
                  'time).', nodes=_PL),
    _seconds('plant.lockstep_timeout', 1.0, 'Lockstep: wall-clock seconds to wait for the '
             'command before advancing with the last one (with a warning).', 0.001, 3600.0,
             _PL),
    ParameterSpec('plant.lockstep_subscribers', INTEGER, 1,
                  'Subscribers on y (the observer plus any recorder) the plant waits for '
                  'before its first sample, in lockstep and real time (1 ... 100).', nodes=_PL,
                  low=1, high=100, unit='a count'),
    ParameterSpec('plant.wait_for_command', BOOL, True,
                  'Also wait for a publisher on u_cmd before the first sample (false for an '
                  'open-loop run without state_feedback).', nodes=_PL),
    _seconds('plant.start_timeout', 10.0, 'Wall-clock seconds to wait for those peers; then '
             'the plant starts anyway with a warning naming what is missing. 0 waits without '
             'limit (0 ... 3600).', 0.0, 3600.0, _PL),
    _seconds('plant.command_timeout', 0.5, 'Seconds without a new u_cmd after which the plant '
             'applies plant.safe_input until the next command (counted, warned once per '
             'outage); steady clock in real time, simulated time in lockstep. More than one '
             'sample period (0.001 ... 3600).', 0.001, 3600.0, _PL),
    _array('plant.safe_input', 'Input applied before the first command and after '
           'plant.command_timeout, m values (default zeros; inside plant.input_limits).', _PL,
           limit=VALUE_LIMIT),
    ParameterSpec('plant.samples', INTEGER, 0,
                  'Number of samples to simulate, then stop; 0 runs until shut down.',
                  nodes=_PL, low=0, high=10 ** 12, unit='a count'),
    _seconds('observer.input_wait', 0.05, 'Wall-clock seconds a measurement may wait for the '
             'stamped input of its interval before the latest earlier input is used '
             '(0 ... 10).', 0.0, 10.0, _OBS),
    _seconds('observer.interval_resolution', 0.0,
             'Seconds: sample intervals are rounded to a multiple of this before the '
             'observer is discretized and designed for them (0: every interval exact). '
             'With jittered stamps and a continuous model, e.g. 1e-5 bounds the designs '
             'to one per 10 us of interval instead of one per new interval.', 0.0, 1e6,
             _OBS, dynamic=True),
    _seconds('observer.max_gap', 1.0, 'Seconds between measurements beyond which (or a '
             'backward jump beyond which) the estimator restarts from the new sample '
             '(0.001 ... 1e6).', 0.001, 1e6, _OBS),
    _seconds('observer.clock_tolerance', 0.5, 'Seconds a measurement or input may be stamped '
             'ahead of the node clock; a later stamp is dropped and counted (future_stamp), '
             'so it cannot capture the timeline. 0 turns the check off (0 ... 1e6).', 0.0,
             1e6, _OBS, dynamic=True),
) + tuple(
    spec for topic, names, nodes in (
        ('y', 'output', (PLANT, OBSERVER)), ('u', 'input', (PLANT, OBSERVER)),
        ('u_cmd', 'input', (PLANT, FEEDBACK)), ('x_hat', 'state', (OBSERVER, FEEDBACK)),
        ('x_true', 'state', (PLANT,)), ('reference', 'output', (FEEDBACK,)),
        ('innovation', 'output', (OBSERVER,)))
    for spec in (
        ParameterSpec(f'topics.{topic}.type', STRING, 'joint_state',
                      f'Message type of {topic}: joint_state (sensor_msgs/JointState, the '
                      f'model {names} names as joint names) | float64_multi_array '
                      f'(std_msgs/Float64MultiArray, unstamped).', nodes=nodes),
        ParameterSpec(f'topics.{topic}.field', STRING, 'position',
                      f'JointState field holding {topic}: position | velocity | effort.',
                      nodes=nodes),
        ParameterSpec(f'topics.{topic}.limit', DOUBLE, VALUE_LIMIT,
                      f'Largest magnitude of a value on {topic}: a received message with a '
                      f'larger value is dropped and counted (out_of_range), and no larger '
                      f'value is published (1e-300 ... 1e300).', nodes=nodes, low=1e-300,
                      high=1e300),
    )
)

MESSAGE_TYPES = ('joint_state', 'float64_multi_array')
JOINT_STATE_FIELDS = ('position', 'velocity', 'effort')
TOPICS = ('y', 'u', 'u_cmd', 'x_hat', 'x_true', 'reference', 'innovation')

PARAMETER_SPECS = {spec.name: spec for spec in PARAMETERS}


def parameter_table() -> str:
    """Return the parameter schema as the Markdown table README shows."""
    rows = ['| parameter | type | default | range | run-time | nodes | meaning |',
            '|---|---|---|---|---|---|---|']
    short = {PLANT: 'plant', OBSERVER: 'observer', FEEDBACK: 'feedback'}
    for spec in PARAMETERS:
        default = json.dumps(spec.default) if not isinstance(spec.default, str) else spec.default
        limits = spec.range_text() or (f'abs <= {spec.entry_limit:g}' if spec.entry_limit
                                       else '')
        nodes = 'all' if spec.nodes == ALL_NODES else ', '.join(short[n] for n in spec.nodes)
        rows.append(f'| `{spec.name}` | {spec.kind} | `{default}` | {limits} | '
                    f'{"yes" if spec.dynamic else "no"} | {nodes} | {spec.description} |')
    return '\n'.join(rows) + '\n'


def node_parameters(node: str) -> tuple:
    """Return the specs a node declares (``node``: :data:`PLANT`, :data:`OBSERVER` ...)."""
    if node not in ALL_NODES:
        raise ValueError(f'node: expected one of {", ".join(ALL_NODES)}, got {node!r}')
    return tuple(spec for spec in PARAMETERS if node in spec.nodes)


#: Parameters every ROS node has, allowed in shared parameter files.
ROS_PARAMETERS = ('use_sim_time', 'start_type_description_service')


@dataclass(frozen=True)
class PlantSettings:
    """Validated ``plant.*`` parameters."""

    rate_hz: float
    initial_state: np.ndarray
    process_noise: list
    measurement_noise: list
    seed: int
    input_limits: Optional[np.ndarray]
    command_timeout: float
    safe_input: np.ndarray

    @property
    def period_ns(self) -> int:
        """Sample period in integer nanoseconds."""
        return int(round(1e9 / self.rate_hz))


@dataclass(frozen=True)
class FeedbackSettings:
    """Validated ``feedback.*`` parameters and the feedback design."""

    design: FeedbackDesign
    reference_gain: Optional[np.ndarray]
    input_limits: Optional[np.ndarray]
    timeout: float
    safe_command: np.ndarray
    safe_command_period: float


@dataclass(frozen=True)
class System:
    """
    Everything a validated parameter set defines.

    Attributes
    ----------
    parameters : dict
        The complete flat parameter mapping (defaults filled in).
    model : StateSpaceModel
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

    def make_estimator(self) -> Estimator:
        """Build the runtime estimator of the observer design."""
        if self.observer is None:
            raise ConfigError('observer.poles', 'no observer is configured: give '
                              'observer.poles, observer.gain or the Kalman noises')
        return make_estimator(self.observer, self.initial_estimate,
                              self.parameters['observer.method'],
                              self.interval_resolution_ns)

    def make_stream(self) -> StreamEstimator:
        """
        Build the :class:`StreamEstimator` the observer node and the bag replay both run.

        Its gap, clock tolerance and value limits come from ``observer.max_gap``,
        ``observer.clock_tolerance`` and ``topics.<topic>.limit``; inputs count as stamped
        when ``topics.u.type`` carries a header.
        """
        params = self.parameters
        limits = ValueLimits(measurement=params['topics.y.limit'],
                             input=params['topics.u.limit'],
                             estimate=params['topics.x_hat.limit'],
                             innovation=params['topics.innovation.limit'])
        return StreamEstimator(
            self.make_estimator(), round(params['observer.max_gap'] * NANOSECONDS),
            input_stamped=params['topics.u.type'] == 'joint_state',
            clock_tolerance_ns=round(params['observer.clock_tolerance'] * NANOSECONDS),
            limits=limits)

    @property
    def interval_resolution_ns(self) -> int:
        """``observer.interval_resolution`` in integer nanoseconds."""
        return round(self.parameters['observer.interval_resolution'] * NANOSECONDS)


def flatten_parameters(tree: Mapping, prefix: str = '') -> dict:
    """Flatten nested YAML mappings into dotted names: ``{'model': {'A': x}}`` -> ``model.A``."""
    flat = {}
    for key, value in tree.items():
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            flat.update(flatten_parameters(value, name + '.'))
        else:
            flat[name] = value
    return flat


def load_parameter_file(path: str, node_name: Optional[str] = None) -> dict:
    """
    Read a ROS 2 parameter YAML file into a flat mapping.

    Parameters under ``/**`` apply to every node; a section named after ``node_name``
    (with or without a leading slash) is merged on top.

    Raises
    ------
    ConfigError
        Unreadable file, invalid YAML or no ``ros__parameters`` section.

    """
    try:
        with open(path, encoding='utf-8') as stream:
            document = yaml.safe_load(stream)
    except OSError as e:
        raise ConfigError('', f'cannot read parameter file {path}: {e.strerror}') from e
    except yaml.YAMLError as e:
        raise ConfigError('', f'{path} is not valid YAML: {e}') from e
    if not isinstance(document, Mapping):
        raise ConfigError('', f'{path}: expected a mapping with /**: ros__parameters:')
    flat: dict = {}
    sections = ['/**', '**']
    if node_name:
        sections += [node_name, '/' + node_name.lstrip('/')]
    found = False
    for section in sections:
        body = document.get(section)
        if isinstance(body, Mapping) and isinstance(body.get('ros__parameters'), Mapping):
            flat.update(flatten_parameters(body['ros__parameters']))
            found = True
    if not found:
        raise ConfigError('', f'{path}: no "/**: ros__parameters:" section found')
    return flat


def _check_range(spec: ParameterSpec, value):
    low, high = spec.low, spec.high
    below = low is not None and (value <= low if spec.low_open else value < low)
    if below or (high is not None and value > high):
        raise ConfigError(spec.name, f'expected {spec.unit} in {spec.range_text()}, '
                          f'got {value:g}')
    return value


def _coerce(spec: ParameterSpec, value: Any) -> Any:
    """Check and convert one value to its declared type and range; integers count as doubles."""
    name, kind = spec.name, spec.kind
    if value is None:
        return spec.default
    if kind == DOUBLE:
        numeric = (int, float, np.integer, np.floating)
        if isinstance(value, bool) or not isinstance(value, numeric):
            raise ConfigError(name, f'expected a number, got {value!r}')
        value = float(value)
        if not math.isfinite(value):
            raise ConfigError(name, f'expected a finite number, got {value}')
        return _check_range(spec, value)
    if kind == INTEGER:
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
            raise ConfigError(name, f'expected an integer, got {value!r}')
        return _check_range(spec, int(value))
    if kind == BOOL:
        if not isinstance(value, bool):
            raise ConfigError(name, f'expected true or false, got {value!r}')
        return value
    if kind == STRING:
        if not isinstance(value, str):
            raise ConfigError(name, f'expected a string, got {value!r}')
        return value
    if isinstance(value, (str, bytes)) or not hasattr(value, '__iter__'):
        raise ConfigError(name, f'expected a list, got {value!r}')
    items = list(value)
    if kind == DOUBLE_ARRAY:
        for index, item in enumerate(items):
            if isinstance(item, bool) or not isinstance(item, (int, float, np.floating,
                                                               np.integer)):
                raise ConfigError(name, f'expected numbers, entry {index} is {item!r}')
        values = [float(item) for item in items]
        for index, item in enumerate(values):
            if not math.isfinite(item):
                raise ConfigError(name, f'expected finite numbers, entry {index} is {item}')
            if spec.entry_limit is not None and abs(item) > spec.entry_limit:
                raise ConfigError(name, f'expected entries of magnitude <= '
                                  f'{spec.entry_limit:g}, entry {index} is {item:g}')
        return values
    return [item if isinstance(item, str) else str(item) for item in items]


def complete_parameters(params: Mapping[str, Any], strict: bool = False) -> dict:
    """
    Fill defaults and coerce every known parameter to its type.

    Unknown names are kept untouched unless ``strict`` is set, in which case any name
    outside the schema (other than ROS's own ``use_sim_time`` and ``qos_overrides.*``) is
    an error, so that a typo is not silently ignored.
    """
    complete = {}
    for spec in PARAMETERS:
        complete[spec.name] = _coerce(spec, params.get(spec.name, spec.default))
    for name, value in params.items():
        if name in PARAMETER_SPECS:
            continue
        if strict and not (name in ROS_PARAMETERS or name.startswith('qos_overrides.')):
            raise ConfigError(name, 'unknown parameter; see the parameter schema in README')
        complete[name] = value
    return complete


def _named(parameter: str, error: Exception) -> ConfigError:
    text = str(error)
    if isinstance(error, ConfigError) and error.parameter:
        return error
    if text.startswith(('model.', 'observer.', 'feedback.', 'plant.')):
        return ConfigError('', text)
    return ConfigError(parameter, text)


def _parsed_poles(params: dict, parameter: str) -> Optional[np.ndarray]:
    """Parse a pole parameter (None when empty) and bound the magnitude of every pole."""
    if not params[parameter]:
        return None
    poles = parse_poles(params[parameter], parameter)
    huge = poles[np.abs(poles) > POLE_LIMIT]
    if huge.size:
        raise ConfigError(parameter, f'poles {format_modes(huge)} exceed {POLE_LIMIT:g} in '
                          f'magnitude; no sampled design can realise them')
    return poles


def _observer_poles(params: dict, model: StateSpaceModel, count: int) -> Optional[np.ndarray]:
    poles = _parsed_poles(params, 'observer.poles')
    tolerance, time = params['observer.error_tolerance'], params['observer.error_time']
    if tolerance == 0.0 and time == 0.0:
        return poles
    try:
        bound = slowest_allowed_pole(tolerance, time)
    except ConfigError as e:
        raise ConfigError('observer.error_tolerance',
                          f'{e} (observer.error_tolerance={tolerance}, '
                          f'observer.error_time={time})') from e
    if poles is None:
        generated = poles_meeting_error_spec(tolerance, time, count)
        return np.exp(generated * model.dt) if model.is_discrete else generated
    if model.is_discrete:
        slow = poles[np.abs(poles) > math.exp(bound * model.dt) * (1 + 1e-12)]
    else:
        slow = poles[poles.real > bound * (1 - 1e-12)]
    if slow.size:
        raise ConfigError(
            'observer.poles',
            f'poles {format_modes(slow)} are slower than the error specification allows '
            f'(||e({time})|| <= {tolerance} needs real parts <= {bound:.6g})')
    return poles


def _design_observer(params: dict, model: StateSpaceModel) -> Optional[ObserverDesign]:
    kind = params['observer.type']
    if kind not in OBSERVER_TYPES:
        raise ConfigError('observer.type',
                          f'expected one of {", ".join(OBSERVER_TYPES)}, got {kind!r}')
    method = params['observer.method']
    if method not in METHODS:
        raise ConfigError('observer.method', f'expected one of {", ".join(METHODS)}, '
                          f'got {method!r}')
    coordinates = params['observer.coordinates']
    if coordinates not in COORDINATES:
        raise ConfigError('observer.coordinates',
                          f'expected one of {", ".join(COORDINATES)}, got {coordinates!r}')
    gain = params['observer.gain'] or None
    if kind == 'kalman':
        q, r = params['observer.process_noise'], params['observer.measurement_noise']
        if gain is not None or params['observer.poles']:
            raise ConfigError('observer.gain', 'a Kalman filter takes its gain from '
                              'observer.process_noise and observer.measurement_noise; leave '
                              'observer.gain and observer.poles empty')
        if not q and not r:
            return None
        if not q or not r:
            missing = 'observer.process_noise' if not q else 'observer.measurement_noise'
            raise ConfigError(missing, 'a Kalman filter needs both noise covariances')
        return design_kalman(model, q, r)
    count = model.n_states if kind == 'full_order' else model.n_states - model.n_outputs
    poles = _observer_poles(params, model, count)
    if kind != 'chen' and gain is not None and poles is not None and params['observer.poles']:
        raise ConfigError('observer.gain', 'give either observer.gain or observer.poles, '
                          'not both')
    if kind == 'chen':
        if poles is None:
            if gain is not None:
                raise ConfigError('observer.poles', f'a Chen observer needs its {count} poles '
                                  '(the eigenvalues of F) besides the gain L')
            return None
        return design_chen(model, poles, gain, params['observer.chen_seed'])
    if gain is None and poles is None:
        return None
    if poles is not None and poles.size != count:
        raise ConfigError('observer.poles', f'expected {count} poles for a {kind} observer '
                          f'of this model, got {poles.size}')
    if kind == 'full_order':
        return design_full_order(model, None if gain is not None else poles, gain, method)
    return design_reduced_order(model, None if gain is not None else poles, gain, coordinates,
                                method)


def _feedback(params: dict, model: StateSpaceModel) -> Optional[FeedbackSettings]:
    gain, pole_text = params['feedback.gain'] or None, params['feedback.poles']
    if gain is None and not pole_text:
        return None
    if gain is not None and pole_text:
        raise ConfigError('feedback.gain', 'give either feedback.gain or feedback.poles, '
                          'not both')
    method = params['feedback.method']
    if method not in METHODS:
        raise ConfigError('feedback.method', f'expected one of {", ".join(METHODS)}, '
                          f'got {method!r}')
    poles = _parsed_poles(params, 'feedback.poles')
    if poles is not None and poles.size != model.n_states:
        raise ConfigError('feedback.poles',
                          f'expected {model.n_states} poles, got {poles.size}')
    source = 'feedback.gain' if gain is not None else 'feedback.poles'
    try:
        design = design_feedback(model, poles, gain, method)
    except (ConfigError, DesignError) as e:
        raise _named(source, e) from e
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
                            safe_command_period=params['feedback.safe_command_period'])


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
    try:
        return input_limits_from_flat(values, n_inputs)
    except ConfigError as e:
        raise ConfigError(parameter, str(e).split(': ', 1)[-1]) from e


def _plant(params: dict, model: StateSpaceModel) -> PlantSettings:
    rate = params['plant.rate_hz']
    if model.is_discrete and abs(rate * model.dt - 1.0) > 1e-9:
        raise ConfigError('plant.rate_hz', f'a discrete model with model.dt = {model.dt} s '
                          f'runs at {1.0 / model.dt:g} Hz, got {rate}')
    initial = params['plant.initial_state']
    initial_state = (vector_from_flat('plant.initial_state', initial, model.n_states)
                     if initial else np.zeros(model.n_states))
    _check_inside('plant.initial_state', initial_state, params['topics.x_true.limit'],
                  'topics.x_true.limit')
    if params['plant.process_noise']:
        covariance_from_flat('plant.process_noise', params['plant.process_noise'],
                             model.n_states)
    if params['plant.measurement_noise']:
        covariance_from_flat('plant.measurement_noise', params['plant.measurement_noise'],
                             model.n_outputs)
    limits = _limits('plant.input_limits', params['plant.input_limits'], model.n_inputs)
    safe = params['plant.safe_input']
    safe_input = (vector_from_flat('plant.safe_input', safe, model.n_inputs) if safe
                  else np.zeros(model.n_inputs))
    _check_inside('plant.safe_input', safe_input, limits, 'plant.input_limits')
    _check_inside('plant.safe_input', safe_input, params['topics.u.limit'], 'topics.u.limit')
    command_timeout = params['plant.command_timeout']
    if command_timeout * rate <= 1.0:
        raise ConfigError('plant.command_timeout', f'expected more than one sample period '
                          f'(1 / plant.rate_hz = {1.0 / rate:g} s), got {command_timeout:g}: '
                          f'every sample would find the command stale')
    return PlantSettings(rate_hz=rate, initial_state=initial_state,
                         process_noise=params['plant.process_noise'],
                         measurement_noise=params['plant.measurement_noise'],
                         seed=params['plant.seed'], input_limits=limits,
                         command_timeout=command_timeout, safe_input=safe_input)


def _check_topics(params: dict) -> None:
    for topic in TOPICS:
        kind = params[f'topics.{topic}.type']
        if kind not in MESSAGE_TYPES:
            raise ConfigError(f'topics.{topic}.type',
                              f'expected one of {", ".join(MESSAGE_TYPES)}, got {kind!r}')
        joint_field = params[f'topics.{topic}.field']
        if joint_field not in JOINT_STATE_FIELDS:
            raise ConfigError(f'topics.{topic}.field', f'expected one of '
                              f'{", ".join(JOINT_STATE_FIELDS)}, got {joint_field!r}')


def _check_interval_resolution(params: dict, model: StateSpaceModel) -> None:
    resolution = params['observer.interval_resolution']
    if resolution >= params['observer.max_gap']:
        raise ConfigError('observer.interval_resolution', f'expected seconds in [0, '
                          f'observer.max_gap = {params["observer.max_gap"]}), got {resolution}')
    if resolution and model.is_discrete:
        raise ConfigError('observer.interval_resolution', f'a discrete model (model.dt = '
                          f'{model.dt}) has one period; expected 0, got {resolution}')


def validate_parameters(params: Mapping[str, Any], strict: bool = False) -> System:
    """
    Validate a flat parameter mapping and build every design it defines.

    Parameters
    ----------
    params : mapping
        ``{'model.A': [...], 'observer.type': 'chen', ...}``; missing names take their
        defaults from :data:`PARAMETERS`.
    strict : bool
        Reject unknown ``model.*``, ``observer.*``, ``feedback.*`` and ``plant.*`` names.

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
    _check_topics(complete)
    if not complete['model.A']:
        raise ConfigError('model.A', 'missing: the model needs A, B and C')
    model = StateSpaceModel.from_flat(
        complete['model.A'], complete['model.B'], complete['model.C'], complete['model.D'],
        complete['model.dt'], complete['model.state_names'], complete['model.input_names'],
        complete['model.output_names'])
    parameter = 'observer.gain' if complete['observer.gain'] else 'observer.poles'
    if complete['observer.type'] == 'kalman':
        parameter = 'observer.process_noise'
    try:
        observer = _design_observer(complete, model)
    except (ConfigError, DesignError) as e:
        raise _named(parameter, e) from e
    except NUMERIC_FAILURES as e:
        raise ConfigError(parameter, f'the design failed numerically ({e})') from e
    _check_interval_resolution(complete, model)
    initial = complete['observer.initial_state']
    initial_estimate = (vector_from_flat('observer.initial_state', initial, model.n_states)
                        if initial else None)
    if initial_estimate is not None:
        _check_inside('observer.initial_state', initial_estimate,
                      complete['topics.x_hat.limit'], 'topics.x_hat.limit')
    feedback = _feedback(complete, model)
    plant = _plant(complete, model)
    controller_tf, cl_poles, notes = None, None, []
    if observer is not None and feedback is not None:
        cl_poles = closed_loop_poles(model, observer.realization, feedback.design.gain)
        if model.n_inputs == 1 and model.n_outputs == 1:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter('always')
                controller_tf = controller_transfer_function(
                    model, observer.realization, feedback.design.gain)
            notes.extend(str(w.message) for w in caught)
    return System(parameters=complete, model=model, observer=observer,
                  observer_type=complete['observer.type'], initial_estimate=initial_estimate,
                  feedback=feedback, plant=plant, controller_tf=controller_tf,
                  closed_loop_poles=cl_poles, notes=tuple(notes))
