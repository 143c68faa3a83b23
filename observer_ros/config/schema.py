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
The one parameter schema of observer_ros.

Every parameter the nodes declare, the design CLI and the bag tools read is a
:class:`~observer_ros.core.arguments.Argument` here, under its parameter name: the model,
the observer (``observer.type``, the stream's own settings and the arguments of every
registered observer type, :mod:`observer_ros.core.observers`), the state feedback, the
plant simulator and the message settings of each topic (``topics.<topic>.*``).
"""

from dataclasses import dataclass, fields
import json

from observer_ros.config.node_specs import (
    combined_nodes, node_spec, own_nodes, short_names, topic_nodes)
from observer_ros.config.nonlinear import NONLINEAR_PARAMETERS
from observer_ros.core.arguments import (
    Argument, array as _array, BOOL, DOUBLE, ENTRY_LIMIT, INTEGER, matrix_text as _matrix,
    number_text, SEED_MAX, STRING, STRING_ARRAY)
from observer_ros.core.arguments import seconds as _core_seconds
from observer_ros.core.observers import observer_arguments, observer_type_names, observer_types
from observer_ros.core.observers.common import read_poles
from observer_ros.core.placement import METHODS
from observer_ros.wire import JOINT_STATE_FIELDS, message_types, TYPE_NAMES

#: The nodes of the package, by the name each declares its parameters under: the nodes of
#: their own, in the order of :data:`~observer_ros.config.node_specs.NODE_SPECS`.
ALL_NODES = own_nodes()

#: Nodes that declare the parameters of several others, besides their own: the one-process
#: observer and state feedback (``observer_controller``) declares both and its own
#: ``controller.*``.
COMBINED_NODES = combined_nodes()

#: The roles the schema's tables name (each checked against the node specs).
PLANT, OBSERVER, FEEDBACK, CONTROLLER = (
    node_spec(name).name
    for name in ('plant_simulator', 'observer', 'state_feedback', 'observer_controller'))

#: Where the controller takes the input of its next prediction from.
CONTROLLER_INPUTS = ('u', 'command')

#: How the observer stamps an unstamped input (``observer.unstamped_input``).
UNSTAMPED_INPUTS = ('arrival', 'next_measurement')


@dataclass(frozen=True)
class ParameterSpec(Argument):
    """
    A parameter of the schema: an argument under its parameter name, and its nodes.

    What a :class:`~observer_ros.core.arguments.Argument` says, plus what only the nodes
    know about the parameter.

    Attributes
    ----------
    nodes : tuple of str
        The nodes that declare the parameter (:data:`ALL_NODES` or some of them).
    dynamic : bool
        Whether a running node accepts a change (otherwise it is read-only, structural);
        an observer type's argument is dynamic when it is tunable.

    """

    nodes: tuple = ALL_NODES
    dynamic: bool = False


#: Default of ``topics.<topic>.limit``: the largest magnitude a vector value may have.
VALUE_LIMIT = 1e9

#: Default limit of the covariance topics (their entries are squares of the states').
COVARIANCE_LIMIT = 1e18

#: The vector types of ``topics.<topic>.type``: those the catalog reads as a whole vector.
MESSAGE_TYPES = tuple(entry.name for entry in message_types() if entry.vector)

#: The message types read by field path (measurement sources, ``topics.u.fields``), by the
#: short name a parameter gives: ``imu`` is ``sensor_msgs/msg/Imu``. The wire catalog's own
#: view (:data:`observer_ros.wire.TYPE_NAMES`): a type registered there is one here.
FIELD_MESSAGE_TYPES = TYPE_NAMES

#: Message types of the inputs ``u``: the vector types, and those the catalog says carry
#: commands (``geometry_msgs/Twist`` on ``/cmd_vel``) read by ``topics.u.fields``.
INPUT_MESSAGE_TYPES = tuple(entry.name for entry in message_types()
                            if entry.vector or entry.commands)

#: Vector topics: name and what the entries are named after, in the schema's order.
TOPIC_KINDS = (
    ('y', 'output'), ('u', 'input'), ('u_cmd', 'input'), ('x_hat', 'state'),
    ('x_true', 'state'), ('reference', 'output'), ('innovation', 'output'),
    ('x_hat_covariance', 'state pair'), ('innovation_covariance', 'output pair'),
    ('nis', 'nis'))

#: Vector topics: name, what the entries are named after, and the nodes that use it (those
#: whose spec subscribes to or publishes it).
TOPIC_ROLES = tuple((topic, kind, topic_nodes(topic)) for topic, kind in TOPIC_KINDS)
TOPICS = tuple(topic for topic, _, _ in TOPIC_ROLES)

_OBS, _FB, _PL, _CTL = (OBSERVER,), (FEEDBACK,), (PLANT,), (CONTROLLER,)


def topic_names(model, topic: str) -> tuple:
    """
    Return the entry names of a vector topic for ``model`` (the joint names of a JointState).

    ``y``, ``reference``, ``innovation``: the output names; ``u``, ``u_cmd``: the input
    names; ``x_hat``, ``x_true``: the state names; ``x_hat_covariance``: ``"x1,x2"`` for each
    pair of states, row-major; ``innovation_covariance`` the same for the outputs; ``nis``:
    ``"nis"``.

    Raises
    ------
    KeyError
        ``topic`` is no vector topic of the package.

    """
    role = {name: role for name, role, _ in TOPIC_ROLES}[topic]
    if role == 'nis':
        return ('nis',)
    base = {'output': model.output_names, 'input': model.input_names,
            'state': model.state_names}[role.split()[0]]
    if role.endswith('pair'):
        return tuple(f'{row},{column}' for row in base for column in base)
    return tuple(base)


def _on(nodes: tuple, argument: Argument, name: str = '',
        dynamic: bool = None) -> ParameterSpec:
    """
    Return ``argument`` as the parameter ``name`` (default: its own) declared by ``nodes``.

    ``dynamic`` defaults to whether the argument is tunable.
    """
    values = {field.name: getattr(argument, field.name) for field in fields(Argument)}
    values['name'] = name or argument.name
    return ParameterSpec(**values, nodes=nodes,
                         dynamic=argument.tunable if dynamic is None else dynamic)


def _seconds(name, default, description, low, high, nodes, dynamic=False):
    return _on(nodes, _core_seconds(name, default, description, low, high), dynamic=dynamic)


def _values(name, description, nodes, dynamic=False, limit=ENTRY_LIMIT):
    return _on(nodes, _array(name, description, limit=limit), dynamic=dynamic)


def _spec(name, value_type, default, description, nodes=ALL_NODES, **options):
    return ParameterSpec(name, value_type, default, description, nodes=nodes, **options)


MODEL = (
    _values('model.A', _matrix('State matrix A, n x n (n*n values)'), ALL_NODES),
    _values('model.B', _matrix('Input matrix B, n x m'), ALL_NODES),
    _values('model.C', _matrix('Output matrix C, p x n'), ALL_NODES),
    _values('model.D', _matrix('Feedthrough D, p x m: y = C x + D u, u the input in effect '
                               'at the stamp of the measurement; empty means zero'), ALL_NODES),
    _seconds('model.dt', 0.0, 'Model period in seconds: 0 for continuous time, > 0 for '
             'discrete time.', 0.0, 3600.0, ALL_NODES),
    _spec('model.state_names', STRING_ARRAY, [], 'n state names (default x1..xn).'),
    _spec('model.input_names', STRING_ARRAY, [], 'm input names (default u1..um).'),
    _spec('model.output_names', STRING_ARRAY, [], 'p output names (default y1..yp).'),
    _spec('model.angle_states', STRING_ARRAY, [], 'States that are angles (names, or 0-based '
          'indices), kept in (-pi, pi] after every update and prediction; each must only '
          'integrate (its column of A zero, the unit column for a discrete model) and reach '
          'only angle outputs, a whole number of times. Empty: none.'),
    _spec('model.angle_outputs', STRING_ARRAY, [], 'Outputs that are angles (names, or 0-based '
          'indices), a heading from a quaternion for instance: their innovations are '
          'wrapped to (-pi, pi], so a measurement crossing +-pi moves the estimate by the '
          'small step it made. Empty: none.'),
    _spec('model.disturbances', STRING_ARRAY, [], 'Disturbance waveforms, one per disturbance: '
          'constant (1 state) | ramp (2 states: value, rate) | sinusoid (2 states: value, '
          'rate); the observers estimate the plant augmented with their states (README, '
          'Disturbances). Empty: none.'),
    _spec('model.disturbance_entries', STRING_ARRAY, [], 'Where each disturbance enters: '
          'input:<input name> (added to that input, a matched load) | output:<output name> '
          '(added to that output, a sensor bias) | matrix (the next column of '
          'model.disturbance_matrix); the name may be left out with one input or output. '
          'Empty: every disturbance at the single input.'),
    _values('model.disturbance_matrix', _matrix('Disturbance input matrix E, n x k, one column '
                                                'per matrix entry of '
                                                'model.disturbance_entries'), ALL_NODES),
    _values('model.disturbance_frequencies', 'Frequencies in rad/s (> 0), one per sinusoid '
            'of model.disturbances, in order.', ALL_NODES),
    _spec('model.disturbance_names', STRING_ARRAY, [], 'One name per disturbance (default '
          'd1..dk); its states are <name> and, for ramps and sinusoids, <name>_rate.'),
) + tuple(_spec(*parameter) for parameter in NONLINEAR_PARAMETERS)

OBSERVER_STREAM = (
    _spec('observer.type', STRING, observer_types()[0].name,
          ' | '.join(kind.name for kind in observer_types()) + ' (the registered observer '
          'types).', _OBS, choices=observer_type_names()),
    _values('observer.initial_state', 'Initial estimate, n values (with model.disturbances: '
            'plant then disturbance states). Empty (the default): the '
            'first measurement initialises the estimate (least-norm x with C x = y; a '
            'time-varying Kalman filter updates the prior 0 with P0).', _OBS, dynamic=True,
            limit=VALUE_LIMIT),
    _seconds('observer.input_wait', 0.05, 'Wall-clock seconds a measurement may wait for the '
             'stamped input of its interval before the latest earlier input is used '
             '(0 ... 10).', 0.0, 10.0, _OBS),
    _spec('observer.unstamped_input', STRING, 'arrival', 'How an unstamped u '
          '(float64_multi_array, or a zero stamp) is stamped: arrival (the node clock when it '
          'arrives; every sample period of delay pairs it one interval later) | '
          'next_measurement (the stamp of the next measurement: applied from that sample '
          'on, as a driver applying the latest command at each sample does, however late '
          'it arrived).', _OBS, choices=UNSTAMPED_INPUTS),
    _seconds('observer.interval_resolution', 0.0,
             'Seconds: sample intervals are rounded to a multiple of this before the '
             'observer is discretized and designed for them (0: every interval exact). '
             'With jittered stamps and a continuous model, e.g. 1e-5 bounds the designs '
             'to one per 10 us of interval instead of one per new interval. Below one '
             'sample period (see diagnostics.expected_rate).', 0.0, 1e6,
             _OBS, dynamic=True),
    _seconds('observer.max_gap', 1.0, 'Seconds between measurements beyond which (or a '
             'backward jump beyond which) the estimator restarts from the new sample; more '
             'than one sample period (0.001 ... 1e6).', 0.001, 1e6, _OBS),
    _seconds('observer.clock_tolerance', 0.5, 'Seconds a measurement or input may be stamped '
             'ahead of the node clock; a later stamp is dropped and counted (future_stamp), '
             'so it cannot capture the timeline. 0 turns the check off (0 ... 1e6).', 0.0,
             1e6, _OBS, dynamic=True),
    _spec('observer.publish_rate', DOUBLE, 0.0, 'Hz: above 0 the observer also publishes, '
          'at this rate on its clock, the estimate predicted to that time with the latest '
          'input (and its covariance), stamped with that time; 0 publishes once per '
          'measurement (0 ... 1000).', _OBS, low=0.0, high=1000.0, unit='a rate in Hz'),
    _seconds('observer.history', 0.0, 'Seconds of measurements, inputs and estimates kept '
             'for late ones: a measurement older than the newest one but inside the '
             'history is inserted in stamp order and the estimates after it computed again '
             '(the corrected newest one is published); older: dropped (too_old). 0 (the '
             'default) keeps none with one source: an older measurement is dropped '
             '(out_of_order). At most observer.max_gap (0 ... 1e6).', 0.0, 1e6, _OBS),
    _spec('observer.sources', STRING_ARRAY, [], 'Names of the measurement sources, each '
          'configured by sources.<name>.* (its topic, message type, fields, the outputs '
          'it carries...); every output in exactly one source. Empty (the default): one '
          'source, topics.y, with every output.', _OBS),
    _spec('observer.joint_names', STRING_ARRAY, [], 'Joints of the estimated joint states: '
          'when given, every x_hat is also published as a sensor_msgs/JointState on '
          'joint_states_hat (same stamp) with these joint names; empty: not published.',
          _OBS),
) + tuple(
    _spec(f'observer.joint_{field}_states', STRING_ARRAY, [], f'States (names, or 0-based '
          f'indices) copied into the {field} field of joint_states_hat, one per entry of '
          f'observer.joint_names; empty: the field stays empty.', _OBS)
    for field in JOINT_STATE_FIELDS)

FEEDBACK_PARAMETERS = (
    _values('feedback.gain', _matrix('Given state-feedback gain K, m x n (u = -K x_hat + N r)'),
            _FB, dynamic=True),
    _spec('feedback.poles', STRING_ARRAY, [], 'Poles of A - B K as strings, n of them.', _FB,
          dynamic=True, parse=read_poles),
    _spec('feedback.method', STRING, 'auto', 'Pole placement method for K: '
          + ' | '.join(METHODS) + '.', _FB, dynamic=True, choices=METHODS),
    _values('feedback.reference_gain', _matrix(
        'Reference gain N, m x p; empty: without integral action, N for unit DC gain from r '
        'to y when the plant is square (m = p) and its DC gain invertible, else no N r term; '
        'with integral action (feedback.integral_poles or integral_gain) no N r term, the '
        'integrator brings the outputs to r'), _FB, dynamic=True),
    _values('feedback.input_limits', 'Command saturation: [min, max] or [min_1, max_1, ..., '
            'min_m, max_m]. With integral action the integrator stops while the command is '
            'saturated and its error pushes further out (conditional integration).', _FB,
            dynamic=True, limit=VALUE_LIMIT),
    _spec('feedback.disturbance_rejection', BOOL, False,
          'u = -K x_hat - d_hat + N r: subtract the estimated matched input disturbances '
          '(model.disturbance_entries input:<name>) from their inputs; K covers the plant '
          'states only.', _FB, dynamic=True),
    _spec('feedback.integral_outputs', STRING_ARRAY, [], 'Integral action: the outputs (names '
          'or 0-based indices) whose tracking error r - y is integrated, at most m of them; '
          'empty: every output when the plant is square (m = p), required otherwise.', _FB),
    _spec('feedback.integral_poles', STRING_ARRAY, [], 'Integral action: the q poles of the '
          'integrators, placed together with feedback.poles on the augmented model [A 0; '
          '-C_i 0] (discrete: [A 0; -T C_i I]) as strings. With feedback.poles this designs K '
          'and K_i; empty with an empty feedback.integral_gain: no integral action.', _FB,
          dynamic=True, parse=read_poles),
    _values('feedback.integral_gain', _matrix('Integral action: a given K_i, m x q, in u = -K '
                                              'x_hat + K_i z (with feedback.gain)'), _FB,
            dynamic=True),
    _seconds('feedback.timeout', 0.5, 'Steady-clock seconds without an accepted x_hat after '
             'which the safe command is published, with use_sim_time too; more than one '
             'sample period (0.001 ... 3600).',
             0.001, 3600.0, _FB, dynamic=True),
    _values('feedback.safe_command', 'Command published when x_hat is stale or a command is '
            'beyond topics.u_cmd.limit, m values (default zeros; inside '
            'feedback.input_limits).', _FB, dynamic=True, limit=VALUE_LIMIT),
    _seconds('feedback.safe_command_period', 0.1, 'Steady-clock seconds between repetitions '
             'of the safe command while x_hat is stale (0.001 ... 3600).', 0.001, 3600.0, _FB,
             dynamic=True),
)

CONTROLLER_PARAMETERS = (
    _spec('controller.input', STRING, 'u', 'observer_controller: where the input of the next '
          'prediction comes from: u (the applied input the plant reports on u, stamped with '
          'the sample it is applied from) | command (no u topic: the command it sent, taken as '
          'applied from the next sample on; an actuator that saturates below '
          'feedback.input_limits or a command that arrives late makes the prediction wrong).',
          _CTL, choices=CONTROLLER_INPUTS),
)

#: Parameters of the managed (lifecycle) variants only (``observer_lifecycle``,
#: ``state_feedback_lifecycle``); the plain nodes do not declare them.
LIFECYCLE_PARAMETERS = (
    _spec('autostart', BOOL, False, 'Managed (lifecycle) nodes only: configure and activate '
          'at start, without a lifecycle manager or ros2 lifecycle set; a configure that '
          'fails leaves the node unconfigured with the reason logged.', (OBSERVER, FEEDBACK)),
)

PLANT_PARAMETERS = (
    _spec('plant.rate_hz', DOUBLE, 0.0,
          'Plant sample rate in Hz: 0 (the default) follows the model (1 / model.dt for a '
          'discrete one, 100 Hz for a continuous one); else 0.01 ... 10000.', _PL, low=0.0,
          high=10000.0, unit='a rate in Hz'),
    _values('plant.initial_state', 'True initial state, n values.', _PL, limit=VALUE_LIMIT),
    _values('plant.process_noise', 'Plant process noise: intensity (continuous) or covariance '
            '(discrete), n or n*n values; empty for none.', _PL),
    _values('plant.measurement_noise', 'Measurement noise covariance, p or p*p values; empty '
            'for none.', _PL),
    _spec('plant.seed', INTEGER, 0, 'Seed of the plant noise (0 ... 2^63 - 1).', _PL, low=0,
          high=SEED_MAX, unit='a seed'),
    _values('plant.input_limits', 'Input saturation: [min, max] or [min_1, max_1, ..., min_m, '
            'max_m].', _PL, limit=VALUE_LIMIT),
    _spec('plant.lockstep', BOOL, False,
          'Lockstep: publish /clock and advance only when the command computed from the '
          'current sample has arrived (deterministic, faster than real time).', _PL),
    _seconds('plant.lockstep_timeout', 1.0, 'Lockstep: wall-clock seconds to wait for the '
             'command before advancing with the last one (with a warning).', 0.001, 3600.0,
             _PL),
    _spec('plant.lockstep_subscribers', INTEGER, 1,
          'Subscribers on y (the observer plus any recorder) the plant waits for before its '
          'first sample, in lockstep and real time (1 ... 100).', _PL, low=1, high=100,
          unit='a count'),
    _spec('plant.wait_for_command', BOOL, True,
          'Also wait for a publisher on u_cmd before the first sample (false for an open-loop '
          'run without state_feedback).', _PL),
    _spec('plant.hold_without_command', BOOL, False,
          'Real time: while no command is in effect (before the first one, and while the '
          'latest is older than plant.command_timeout) the simulation holds its state, as a '
          'brake holds a joint, instead of letting plant.safe_input and the disturbances '
          'move it; samples are still published. True for a managed (lifecycle) controller, '
          'which sends nothing until it is active.', _PL),
    _seconds('plant.start_timeout', 10.0, 'Wall-clock seconds to wait for those peers; then '
             'the plant starts anyway with a warning naming what is missing. 0 waits without '
             'limit (0 ... 3600).', 0.0, 3600.0, _PL),
    _seconds('plant.settle_time', 0.5, 'Wall-clock seconds the plant waits, once its peers are '
             'matched, before its first sample (lockstep and real time): the rest of '
             'discovery (the other topics, the other direction) goes on after the first '
             'match and would delay the first samples (0 ... 60).', 0.0, 60.0, _PL),
    _seconds('plant.command_timeout', 0.5, 'Seconds without a new u_cmd after which the plant '
             'applies plant.safe_input until the next command (counted, warned once per '
             'outage); steady clock in real time, simulated time in lockstep. More than one '
             'sample period (0.001 ... 3600).', 0.001, 3600.0, _PL),
    _values('plant.input_offset', 'Constant input disturbance d added to the applied input '
            "(x' = A x + B (u + d)), m values; empty for none. u is published without it.",
            _PL, limit=VALUE_LIMIT),
    _values('plant.safe_input', 'Input applied before the first command and after '
            'plant.command_timeout, m values (default zeros; inside plant.input_limits).', _PL,
            limit=VALUE_LIMIT),
    _values('plant.disturbance', 'Disturbance states applied from plant.disturbance_time on, '
            'one value per disturbance state (value, and rate for ramps and sinusoids, in '
            'the order of model.disturbances); empty: no disturbance.', _PL,
            limit=VALUE_LIMIT),
    _seconds('plant.disturbance_time', 0.0, 'Simulated seconds after the first sample at '
             'which plant.disturbance is applied (a step; 0 ... 1e6).', 0.0, 1e6, _PL),
    _spec('plant.samples', INTEGER, 0,
          'Number of samples to simulate, then stop; 0 runs until shut down.', _PL, low=0,
          high=10 ** 12, unit='a count'),
)


DIAGNOSTICS = (
    _seconds('diagnostics.period', 1.0, 'Steady-clock seconds between two health reports on '
             '/diagnostics (configuration, inputs and, for the observer, estimator status); '
             '0 publishes none (0 ... 3600).', 0.0, 3600.0, ALL_NODES),
    _spec('diagnostics.hardware_id', STRING, '', 'hardware_id of the diagnostic statuses of '
          'the node; empty (the default): the fully qualified node name '
          '(/robot1/observer).'),
    _spec('diagnostics.expected_rate', DOUBLE, 0.0, 'Hz the inputs (y and u; x_hat; u_cmd) '
          'are expected at: 0 (the default) follows the plant rate (plant.rate_hz for the '
          'plant, else 1 / model.dt for a discrete model, 100 Hz for a continuous one) '
          '(0 ... 100000). Its period is the sample period feedback.timeout, '
          'observer.max_gap, observer.interval_resolution and diagnostics.stale_timeout are '
          'checked against.', low=0.0, high=100000.0, unit='a rate in Hz'),
    _spec('diagnostics.rate_tolerance', DOUBLE, 0.5, 'Relative error of the measured rate of an '
          'input (from its stamps) beyond which the inputs status warns: 0.5 accepts 50 ... '
          '150 Hz for 100 Hz (0.01 ... 100).', low=0.01, high=100.0),
    _seconds('diagnostics.stale_timeout', 0.0, 'Steady-clock seconds without a message after '
             'which an input is stale (ERROR); 0 (the default): 10 expected periods, at least '
             '0.5 s, for y and u; feedback.timeout for x_hat; plant.command_timeout for u_cmd; '
             'else more than one sample period (0 ... 3600).', 0.0, 3600.0, ALL_NODES),
    _spec('diagnostics.nis_window', INTEGER, 50, 'Kalman filter: NIS samples whose mean is '
          'checked against its two-sided chi-square bounds (2 ... 100000).', _OBS, low=2,
          high=100000, unit='a count'),
    _spec('diagnostics.nis_confidence', DOUBLE, 0.99, 'Kalman filter: two-sided probability '
          'of the NIS bounds; a window mean outside them warns (0.5 ... 0.999999).', _OBS,
          low=0.5, high=0.999999),
)


#: The settings every vector topic has: ``topics.<topic>.<setting>``.
TOPIC_SETTINGS = ('type', 'field', 'limit')


def topic_parameter(topic: str, setting: str) -> str:
    """Return the parameter of one of a topic's :data:`TOPIC_SETTINGS`: ``topics.y.limit``."""
    return f'topics.{topic}.{setting}'


def _topic_parameters(topic: str, names: str, nodes: tuple) -> tuple:
    limit = COVARIANCE_LIMIT if names.endswith('pair') else VALUE_LIMIT
    entries = {'state pair': 'entries named "<state>,<state>" (row-major)',
               'output pair': 'entries named "<output>,<output>" (row-major)',
               'nis': 'one entry named "nis"'}.get(names, f'the model {names} names as joint '
                                                          f'names')
    inputs = topic == 'u'
    specs = (
        _spec(topic_parameter(topic, 'type'), STRING, 'joint_state',
              f'Message type of {topic}: joint_state (sensor_msgs/JointState, {entries}) | '
              f'float64_multi_array (std_msgs/Float64MultiArray, unstamped'
              + (', layout n x n' if names.endswith('pair') else '') + ')'
              + (' | twist (geometry_msgs/Twist, unstamped, e.g. /cmd_vel; with '
                 'topics.u.fields)' if inputs else '') + '.', nodes,
              choices=INPUT_MESSAGE_TYPES if inputs else MESSAGE_TYPES),
        _spec(topic_parameter(topic, 'field'), STRING, 'position',
              f'JointState field holding {topic}: position | velocity | effort.', nodes,
              choices=JOINT_STATE_FIELDS),
        _spec(topic_parameter(topic, 'limit'), DOUBLE, limit,
              f'Largest magnitude of a value on {topic}: a received message with a larger '
              f'value is dropped and counted (out_of_range), and no larger value is published '
              f'(1e-300 ... 1e300).', nodes, low=1e-300, high=1e300),
    )
    if inputs:
        specs += (_spec(topic_parameter(topic, 'fields'), STRING_ARRAY, [],
                        'The inputs read by field path, one per input in model order: '
                        'linear.x, angular.z for twist; data[0], data[3] for '
                        'float64_multi_array; <field>.<joint name> for joint_state. Empty '
                        '(the default): required for twist; otherwise the vector as '
                        'topics.u.type and topics.u.field say.', nodes),)
    return specs


#: The settings of every measurement source: ``sources.<name>.<setting>``.
SOURCE_SETTINGS = ('topic', 'type', 'fields', 'outputs', 'measurement_noise', 'latency',
                   'timeout', 'predict_only', 'noise')

#: Placeholder of the source name in the parameter table.
SOURCE_NAME = '<name>'


def source_parameter(name: str, setting: str) -> str:
    """Return the parameter of a measurement source's setting: ``sources.imu.fields``."""
    return f'sources.{name}.{setting}'


def source_specs(name: str) -> tuple:
    """
    Return the parameters of the measurement source ``name`` (:data:`SOURCE_SETTINGS`).

    Declared by the observer for each name of ``observer.sources``; :data:`PARAMETERS`
    lists them once with the name :data:`SOURCE_NAME`.
    """
    def named(setting):
        return source_parameter(name, setting)
    return (
        _spec(named('topic'), STRING, '', 'Topic of the source (relative names are '
              'remapped as usual); empty: the source name.', _OBS),
        _spec(named('type'), STRING, 'joint_state', 'Message type of the source: '
              + ' | '.join(FIELD_MESSAGE_TYPES) + '; header stamps where the type has '
              'them, else stamped on arrival.', _OBS, choices=tuple(FIELD_MESSAGE_TYPES)),
        _spec(named('fields'), STRING_ARRAY, [], 'Field paths of the values, in the order '
              'of sources.<name>.outputs: angular_velocity.z, pose.pose.position.x, '
              'pose.orientation.yaw (the roll, pitch, yaw of a quaternion), <field>.<joint '
              'name> for joint_state (velocity.left_wheel), data[<index>] for '
              'float64_multi_array, data for float64.', _OBS),
        _spec(named('outputs'), STRING_ARRAY, [], 'The model outputs (names, or 0-based '
              'indices) the fields carry, one per field; every output in exactly one '
              'source.', _OBS),
        _values(named('measurement_noise'), 'Kalman: the block of R of the source, k diagonal '
                'values or k x k row-major for its k outputs; given for every source or '
                'none (then observer.measurement_noise).', _OBS),
        _seconds(named('latency'), 0.0, 'Fixed latency: each sample was taken this long '
                 'before its stamp (before its arrival when stamped on arrival); within '
                 'observer.history (0 ... 1e6).', 0.0, 1e6, _OBS),
        _seconds(named('timeout'), 0.0, 'Seconds after its last sample at which the source '
                 'is reported stale; 0 (the default): never; else more than one sample '
                 'period (0 ... 3600).', 0.0, 3600.0, _OBS),
        _spec(named('predict_only'), BOOL, False, 'When the outputs of the source alone cannot '
              'correct the estimate (an unobservable subset for a steady-state Kalman filter '
              'or a full-order observer), its samples alone only move the estimate forward '
              'instead of the configuration being refused.', _OBS),
        _spec(named('noise'), STRING, 'configured', 'configured: R as configured; message: '
              "the block of R of each sample from its message's covariance (imu, odometry, "
              'pose_with_covariance_stamped, twist_with_covariance_stamped; the time-varying '
              'and nonlinear Kalman filters); an unknown (-1), non-finite or not positive '
              'definite covariance: the configured block, counted.', _OBS,
              choices=('configured', 'message')),
    )


#: The observer types' arguments, each bound to its parameter here, once:
#: ``{argument: parameter}`` (``poles`` is ``observer.poles``).
OBSERVER_ARGUMENTS = {argument.name: f'observer.{argument.name}'
                      for argument in observer_arguments()}

#: ``outputs.odometry.*``: the nav_msgs/Odometry (and /tf) of the estimate (empty topic: none).
ODOMETRY_OUTPUT = (
    _spec('outputs.odometry.topic', STRING, '', 'Topic of a nav_msgs/Odometry of each '
          'estimate (pose and twist from the states named below, covariance from P); empty '
          '(the default): none.', _OBS),
    _spec('outputs.odometry.frame_id', STRING, 'odom', 'header.frame_id of the Odometry: '
          'the frame of the pose (and the parent of the /tf transform).', _OBS),
    _spec('outputs.odometry.child_frame_id', STRING, 'base_link', 'child_frame_id of the '
          'Odometry: the frame of the twist (and the child of the /tf transform).', _OBS),
    *(_spec(f'outputs.odometry.{quantity}', STRING, '', f'The state that gives the '
            f"Odometry's {what}; empty: none (zero, with outputs.odometry.absent_variance).",
            _OBS) for quantity, what in (
                ('x', 'position x'), ('y', 'position y'), ('yaw', 'yaw (as a quaternion)'),
                ('vx', 'forward speed twist.linear.x'), ('vy', 'lateral speed twist.linear.y'),
                ('wz', 'yaw rate twist.angular.z'))),
    _spec('outputs.odometry.absent_variance', DOUBLE, 0.0, "The variance on the covariances' "
          'diagonal where no state is named (and everywhere for an observer without P); >= 0.',
          _OBS, low=0.0, high=1e18),
    _spec('outputs.odometry.publish_tf', BOOL, True, 'Also publish frame_id -> child_frame_id '
          'on /tf where tf2_msgs is installed (a ROS 2 install); skipped otherwise.', _OBS),
)

PARAMETERS = (MODEL + OBSERVER_STREAM + ODOMETRY_OUTPUT
              + tuple(_on(_OBS, argument, OBSERVER_ARGUMENTS[argument.name])
                      for argument in observer_arguments())
              + FEEDBACK_PARAMETERS + CONTROLLER_PARAMETERS + LIFECYCLE_PARAMETERS
              + PLANT_PARAMETERS + DIAGNOSTICS
              + tuple(spec for role in TOPIC_ROLES for spec in _topic_parameters(*role)))

PARAMETER_SPECS = {spec.name: spec for spec in PARAMETERS}

#: Parameters every ROS node has, allowed in shared parameter files.
ROS_PARAMETERS = ('use_sim_time', 'start_type_description_service')


def parameter_table() -> str:
    """Return the parameter schema as the Markdown table README shows."""
    rows = ['| parameter | type | default | range | run-time | nodes | meaning |',
            '|---|---|---|---|---|---|---|']
    short = short_names()
    for spec in PARAMETERS + source_specs(SOURCE_NAME):
        default = json.dumps(spec.default) if not isinstance(spec.default, str) else spec.default
        limits = spec.range_text() or (f'abs <= {number_text(spec.entry_limit)}'
                                       if spec.entry_limit else '')
        nodes = 'all' if spec.nodes == ALL_NODES else ', '.join(short[n] for n in spec.nodes)
        rows.append(f'| `{spec.name}` | {spec.value_type} | `{default}` | {limits} | '
                    f'{"yes" if spec.dynamic else "no"} | {nodes} | {spec.description} |')
    return '\n'.join(rows) + '\n'


def node_parameters(node: str, managed: bool = False) -> tuple:
    """
    Return the specs a node declares (``node``: :data:`PLANT`, :data:`OBSERVER` ...).

    ``managed``: the node's lifecycle variant, which also declares
    :data:`LIFECYCLE_PARAMETERS`. A combined node (:data:`COMBINED_NODES`) declares those of
    each node it combines, once.
    """
    if node not in ALL_NODES + tuple(COMBINED_NODES):
        raise ValueError(f'node: expected one of {", ".join(ALL_NODES + tuple(COMBINED_NODES))}'
                         f', got {node!r}')
    managed_only = () if managed else tuple(spec.name for spec in LIFECYCLE_PARAMETERS)
    roles = {node, *COMBINED_NODES.get(node, ())}
    return tuple(spec for spec in PARAMETERS
                 if roles.intersection(spec.nodes) and spec.name not in managed_only)
