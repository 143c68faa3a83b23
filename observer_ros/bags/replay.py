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
Offline replay: the configured observer over a bag's ``y`` and ``u``, with recorded stamps.

The estimates come from :meth:`observer_ros.core.streaming.EventStream.replay`: the
observer node's event engine (pairing, stamp and value rules) and estimator arithmetic, so
they equal what the node publishes for the same messages, bit for bit. Use :func:`replay_bag`
from your own tests::

    from observer_ros.bags.replay import replay_bag
    result = replay_bag('my_run', 'my_params.yaml')
    assert result.error_norms()[-1] < 1e-3  # against /x_true; or any check on the arrays

Writing the results to a bag or a CSV file is :mod:`observer_ros.bags.replay_outputs`.
"""

import dataclasses
from dataclasses import dataclass, field
import os
from typing import Optional, Union

import numpy as np

from observer_ros.bags.storage import (
    absolute_topic, BagError, Playback, read_topics, TopicData, TopicRequest)
from observer_ros.config import Configuration, load_parameter_file, validate_parameters
from observer_ros.config.schema import (
    FIELD_MESSAGE_TYPES, JOINT_STATE_FIELDS, source_parameter, topic_names)
from observer_ros.core.estimates import replay_arrays
from observer_ros.core.evaluation import align
from observer_ros.core.events import INPUT, MEASUREMENT
from observer_ros.core.streaming import next_measurement_stamps, RecordedEvent
from observer_ros.core.units import NANOSECONDS, seconds_to_ns
from observer_ros.wire import DecodeError, FieldReader, find, parse_layout, topic_reader


#: Inputs, evenly spread, whose stamps are compared with the measurements' time base.
TIME_BASE_SAMPLES = 4096

#: What to do about streams stamped in different time bases, offline.
LOG_TIME_ADVICE = ('replay with log times for both (replay --use-log-time, '
                   'replay_bag(..., use_log_time=True))')

#: What made each published estimate (``ReplayResult.events``): a measurement source's
#: name (``y`` without sources) for its own estimate, and these.
RERUN, INPUT_EVENT, FLUSHED = 'rerun', 'input', 'flush'

#: Event kinds of the stream that a replay reports as warnings (the node warns of them too).
WARNED_EVENTS = ('time_base',)

#: Messages of a topic read before a stream none of which holds its fields is refused.
PROBE_MESSAGES = 20

#: A replay reads every message's covariance before it runs: its blocks are all kept.
NO_PRUNING = 1 << 62


def topic_request(system: Configuration, key: str, topic: Optional[str] = None) -> TopicRequest:
    """Return what to read for the topic playing role ``key`` (``y``, ``u``, ``x_true`` ...)."""
    settings = system.topics[key]
    return TopicRequest(topic or key, settings.type, settings.field,
                        topic_names(system.model, key))


def topic_data(path, system: Configuration, key: str, topic: Optional[str] = None) -> TopicData:
    """Read the bag topic playing role ``key`` of ``system``."""
    return read_topics(path, [topic_request(system, key, topic)])[0]


def log_timed(data: TopicData) -> TopicData:
    """Return ``data`` stamped with its log times (the recorder's clock) instead."""
    return TopicData(data.log_times_ns, data.log_times_ns, data.values)


def _seconds(ns: float) -> str:
    return f'{ns / NANOSECONDS:.6g} s'


def _clock(data: TopicData) -> str:
    """Say how a stream's stamps relate to its log times, for the time-base message."""
    offsets = data.stamps_ns - data.log_times_ns
    if not offsets.any():
        return 'uses its log times (unstamped, or stamped on arrival)'
    return f'has header stamps {_seconds(float(np.median(offsets)))} from its log times'


def check_time_bases(outputs: TopicData, inputs: TopicData, max_gap_ns: int, bag: str = '',
                     y_topic: str = 'y', u_topic: str = 'u',
                     log_time_advice: str = LOG_TIME_ADVICE) -> None:
    """
    Refuse measurements and inputs stamped in different time bases.

    A ``y`` stamped in simulation time (header stamps near 0 s) with an unstamped ``u``
    that falls back to the recorder's wall-clock log times pairs every interval with the
    wrong input (or none), which the counters only show as ``late_input``. Two tests,
    each beyond ``max_gap_ns``:

    * both streams' stamps against the one clock of the recording, their log times:
      ``stamp - log time`` of each input against that of the measurement logged next
      (median over up to :data:`TIME_BASE_SAMPLES` inputs spread over the recording; a
      simulation that runs slower or faster than real time drifts both alike);
    * the stamp ranges themselves, for bags whose log times copy the stamps: apart by
      more than both spans together.

    Raises
    ------
    observer_ros.bags.storage.BagError
        What was found, and what to do: stamp the inputs in the measurements' clock, or
        replay with log times for both (``replay --use-log-time``,
        ``replay_bag(..., use_log_time=True)``).

    """
    if not len(outputs.stamps_ns) or not len(inputs.stamps_ns):
        return
    advice = f'stamp {u_topic} in the clock of {y_topic}, or {log_time_advice}'
    prefix = f'{bag}: ' if bag else ''
    # At most TIME_BASE_SAMPLES inputs, evenly spread, each against the measurement logged
    # at (or next after) it; float: offsets near the int64 limits, far below max_gap.
    step = max(1, len(inputs.stamps_ns) // TIME_BASE_SAMPLES)
    u_logged = inputs.log_times_ns[::step]
    u_offsets = inputs.stamps_ns[::step].astype(float) - u_logged
    at = np.minimum(np.searchsorted(outputs.log_times_ns, u_logged), len(outputs.stamps_ns) - 1)
    y_offsets = outputs.stamps_ns[at].astype(float) - outputs.log_times_ns[at]
    difference = float(np.median(u_offsets - y_offsets))
    if abs(difference) > max_gap_ns:
        raise BagError(f'{prefix}{y_topic} and {u_topic} are stamped in different time bases: '
                       f'{y_topic} {_clock(outputs)}, {u_topic} {_clock(inputs)} '
                       f'({_seconds(abs(difference))} apart, more than {_seconds(max_gap_ns)}); '
                       f'every interval would use the wrong input. {advice}')
    y_first, y_last = int(outputs.stamps_ns.min()), int(outputs.stamps_ns.max())
    u_first, u_last = int(inputs.stamps_ns.min()), int(inputs.stamps_ns.max())
    apart = max(u_first - y_last, y_first - u_last)
    if apart > max(max_gap_ns, (y_last - y_first) + (u_last - u_first)):
        raise BagError(f'{prefix}{y_topic} and {u_topic} are stamped in different time bases: '
                       f'{y_topic} spans {_seconds(y_first)} to {_seconds(y_last)}, '
                       f'{u_topic} {_seconds(u_first)} to {_seconds(u_last)} '
                       f'({_seconds(apart)} apart); every interval would use the wrong '
                       f'input. {advice}')


def stream_warnings(stream, bag: str = '', y_topic: str = 'y', u_topic: str = 'u') -> tuple:
    """
    Return the warnings of a replayed stream: the first of each kind the node warns of.

    The text is the stream's own (the observer node logs the same words), followed by the
    counters it explains and what to do offline.
    """
    first: dict = {}
    for kind, text in stream.events:
        if kind in WARNED_EVENTS:
            first.setdefault(kind, text)
    counters = stream.counters
    prefix = f'{bag}: ' if bag else ''
    warnings = []
    if 'time_base' in first:
        late = counters.get('late_input', 0) + counters.get('no_input', 0)
        warnings.append(f'{prefix}{first["time_base"]} {late} of '
                        f'{counters.get("measurements", 0)} measurements were paired with a '
                        f'late input or none; stamp {absolute_topic(u_topic)} in the clock of '
                        f'the measurements, or {LOG_TIME_ADVICE}')
    return tuple(warnings)


@dataclass(frozen=True)
class InOrderEstimates:
    """
    The estimate at each stamp once every late sample is in, in stamp order.

    What the node's history holds when no later sample can change it: the estimates the
    stream computed again after a late measurement but published only for the newest stamp
    (see ``doc/measurement_sources.md``).

    Attributes
    ----------
    stamps_ns : numpy.ndarray of int64, shape (k,)
    estimates : numpy.ndarray, shape (k, n)
    covariances : numpy.ndarray or None, shape (k, n, n)
    events : numpy.ndarray of str, shape (k,)
        The sources whose samples made each update, joined by ``+``.

    """

    stamps_ns: np.ndarray
    estimates: np.ndarray
    covariances: Optional[np.ndarray]
    events: np.ndarray


@dataclass
class ReplayResult:
    """
    Estimates of a replay, with what was read and the stream's counters.

    Attributes
    ----------
    stamps_ns : numpy.ndarray of int64, shape (k,)
        The stamp of each estimate (its measurement's).
    estimates, innovations : numpy.ndarray, shapes (k, n) and (k, p)
        ``x_hat`` and ``y - C x_prior``, as the observer node publishes them.
    covariances : numpy.ndarray or None, shape (k, n, n)
        Kalman filters: ``P`` of each estimate (``x_hat_covariance``).
    innovation_covariances : numpy.ndarray or None, shape (k, p, p)
        Kalman filters: ``S`` of each innovation (``innovation_covariance``).
    nis : numpy.ndarray or None, shape (k,)
        Kalman filters: ``v^T S^-1 v`` of each innovation (``nis``).
    outputs, inputs : TopicData
        What was read for ``y`` and ``u``.
    counters : dict
        The stream's counters (see :class:`observer_ros.core.streaming.EventStream`).
    warnings : tuple of str
        What the observer node would warn of (:func:`stream_warnings`): inputs stamped in
        another time base than the measurements, with what to do.
    events : numpy.ndarray of str or None, shape (k,)
        What made each estimate: the name of the measurement source whose sample it is the
        estimate of (``y`` without sources), ``rerun`` (the newest estimate again, corrected
        after a late sample), ``input`` (released by the input it waited for), ``flush``
        (released at the end of the bag with the inputs at hand).
    in_order : InOrderEstimates or None
        The estimates in stamp order after every late sample.

    """

    system: Configuration
    bag: str
    stamps_ns: np.ndarray
    estimates: np.ndarray
    innovations: np.ndarray
    outputs: TopicData
    inputs: TopicData
    counters: dict = field(default_factory=dict)
    use_log_time: bool = False
    covariances: Optional[np.ndarray] = None
    innovation_covariances: Optional[np.ndarray] = None
    nis: Optional[np.ndarray] = None
    warnings: tuple = ()
    events: Optional[np.ndarray] = None
    in_order: Optional[InOrderEstimates] = None

    def truth(self, topic: str = 'x_true') -> TopicData:
        """Read the true state (or another reference topic) from the bag, in the replay's time."""
        data = topic_data(self.bag, self.system, 'x_true', topic)
        return log_timed(data) if self.use_log_time else data

    def error_norms(self, topic: str = 'x_true') -> np.ndarray:
        """``||x_true - x_hat||`` at the stamps both have, in time order."""
        truth = self.truth(topic)
        _, reference, estimate = align(truth.stamps_ns, truth.values, self.stamps_ns,
                                       self.estimates)
        estimate = self.system.observer.angles.states_near(estimate, reference)
        return np.linalg.norm(reference - estimate, axis=1)


@dataclass(frozen=True)
class StateReference:
    """
    A recorded reference for one state: a field of one joint of a JointState topic.

    Parse one from ``STATE=TOPIC:FIELD:JOINT`` with :meth:`parse` (``replay --reference``),
    for example ``q_dot=/joint_states:velocity:shoulder``.
    """

    state: str
    topic: str
    field: str
    joint: str

    @classmethod
    def parse(cls, text: str) -> 'StateReference':
        """Parse ``STATE=TOPIC:FIELD:JOINT``; ValueError saying what was expected."""
        state, _, rest = text.partition('=')
        parts = rest.split(':')
        if not state or len(parts) != 3 or not all(parts):
            raise ValueError(f'--reference: expected STATE=TOPIC:FIELD:JOINT (for example '
                             f'q_dot=/joint_states:velocity:shoulder), got {text!r}')
        if parts[1] not in JOINT_STATE_FIELDS:
            raise ValueError(f'--reference: expected a field in {", ".join(JOINT_STATE_FIELDS)}'
                             f', got {parts[1]!r} in {text!r}')
        return cls(state, *parts)


def reference_rmse(result: 'ReplayResult', reference: StateReference,
                   settle_s: float = 0.0) -> tuple:
    """
    Return ``(rmse, count)`` of one state against its recorded reference.

    The estimates are compared at the stamps they share with the reference (log times with
    ``use_log_time``); with ``settle_s`` only those at least that long after the first
    estimate count.

    Raises
    ------
    observer_ros.bags.storage.BagError
        An unknown state, a topic the bag cannot give, or no shared stamp.

    """
    names = result.system.model.state_names
    if reference.state not in names:
        raise BagError(f'--reference: {reference.state!r} is no state of the model '
                       f'({", ".join(names)})')
    request = TopicRequest(reference.topic, 'joint_state', reference.field, [reference.joint])
    (data,) = read_topics(result.bag, [request])
    if result.use_log_time:
        data = log_timed(data)
    column = names.index(reference.state)
    stamps, truth, estimate = align(data.stamps_ns, data.values[:, 0], result.stamps_ns,
                                    result.estimates[:, column])
    if len(stamps):
        keep = stamps >= stamps[0] + seconds_to_ns(settle_s, 'settle_s')
        stamps, truth, estimate = stamps[keep], truth[keep], estimate[keep]
    if not len(stamps):
        raise BagError(f'{result.bag}: --reference: {reference.topic} and the estimates '
                       f'share no stamp (after {settle_s:g} s of settling)')
    return float(np.sqrt(np.mean((truth - estimate) ** 2))), len(stamps)


def replay_data(bag, system: Configuration, outputs: TopicData, inputs: TopicData,
                use_log_time: bool = False, y_topic: str = 'y', u_topic: str = 'u',
                log_time_advice: str = '') -> 'ReplayResult':
    """
    Run the observer of ``system`` over measurements and inputs already read from ``bag``.

    What :func:`replay_bag` does without measurement sources (its second half), and what
    readers of other topics run:
    ``tune_kalman --inputs/--outputs`` reads them by field path
    (:func:`observer_ros.bags.signals.read_signals`). The stamps are checked for one time
    base (:func:`check_time_bases`, its advice ``log_time_advice`` when given) unless
    ``use_log_time``, which stamps both with their log times.
    """
    setup = system.observer
    max_gap_ns, input_stamped = setup.max_gap_ns, setup.input_stamped
    if use_log_time:
        outputs, inputs, input_stamped = log_timed(outputs), log_timed(inputs), False
    else:
        check_time_bases(outputs, inputs, max_gap_ns, str(bag), absolute_topic(y_topic),
                         absolute_topic(u_topic), *([log_time_advice] if log_time_advice
                                                    else []))
    if setup.unstamped_input == 'next_measurement' and not input_stamped:
        # As the node holds each unstamped u for the next measurement (hold_input).
        kept, stamps = next_measurement_stamps(inputs.log_times_ns, outputs.log_times_ns,
                                               outputs.stamps_ns)
        inputs = TopicData(stamps, inputs.log_times_ns[kept], inputs.values[kept])
    stream = setup.make_stream()
    stream.input_stamped = input_stamped
    stream.engine.retired = []
    result = stream.replay(inputs.stamps_ns, inputs.values, outputs.stamps_ns, outputs.values,
                           inputs.log_times_ns, outputs.log_times_ns)
    labels = _stamp_events(result.stamps_ns)
    return ReplayResult(system, str(bag), result.stamps_ns, result.estimates,
                        result.innovations, outputs, inputs, dict(stream.counters),
                        use_log_time, result.covariances, result.innovation_covariances,
                        result.nis, stream_warnings(stream, str(bag), y_topic, u_topic),
                        labels, _in_order(stream, result, labels))


def load_system(parameters: Union[str, os.PathLike, Configuration]) -> Configuration:
    """
    Return the validated system of a parameter file (or ``parameters`` itself).

    Raises
    ------
    observer_ros.core.errors.ConfigError
        A bad parameter file, or one without an observer, naming the parameter; an
        unknown parameter is an error, as in ``design_observer``.

    """
    system = parameters if isinstance(parameters, Configuration) else validate_parameters(
        load_parameter_file(str(parameters)), strict=True)
    if system.observer is None:
        from observer_ros.core.errors import ConfigError
        raise ConfigError('observer.poles', 'replay needs an observer: observer.poles, '
                          'observer.gain or the Kalman noise covariances')
    return system


def _input_reader(system: Configuration):
    """Return the reader of ``u``: by ``topics.u.fields``, else its vector of type and field."""
    settings = system.topics['u']
    return topic_reader(settings.type, settings.fields, settings.field,
                        topic_names(system.model, 'u'))


def _vector_parameter(system: Configuration, key: str) -> str:
    """Name the parameters that say what a vector topic (``y``, ``u``) is read from."""
    settings = system.topics[key]
    if key == 'u' and settings.fields:
        return 'topics.u.fields'
    names = 'model.output_names' if key == 'y' else 'model.input_names'
    if find(settings.type).named:
        return f'topics.{key}.field {settings.field!r} of the joints {names}'
    return f'{names} (one entry of data each)'


@dataclass(frozen=True)
class _Reading:
    """One stream read from a bag topic: its event name, type, reader and parameter."""

    name: str
    msgtype: str
    reader: object
    parameter: str


def _readings(system: Configuration, y_topic: str, u_topic: str) -> dict:
    """Return ``{topic: [_Reading, ...]}``: every stream the observer reads, by bag topic."""
    sources = system.observer.sources
    readings: dict = {}
    if sources is None:  # one y topic, as topics.y says
        settings = system.topics['y']
        readings[absolute_topic(y_topic)] = [_Reading(
            MEASUREMENT, FIELD_MESSAGE_TYPES[settings.type],
            topic_reader(settings.type, (), settings.field, topic_names(system.model, 'y')),
            _vector_parameter(system, 'y'))]
    else:
        for settings, msgtype in zip(sources.settings, sources.msgtypes):
            readings.setdefault(absolute_topic(settings.topic), []).append(_Reading(
                settings.name, msgtype, FieldReader(msgtype, settings.fields),
                source_parameter(settings.name, 'fields')))
    if system.model.n_inputs:
        msgtype = FIELD_MESSAGE_TYPES[system.topics['u'].type]
        readings.setdefault(absolute_topic(u_topic), []).append(_Reading(
            INPUT, msgtype, _input_reader(system), _vector_parameter(system, 'u')))
    for topic, streams in readings.items():
        types = {reading.msgtype for reading in streams}
        if len(types) > 1:
            raise BagError(f'{topic} is read as {" and ".join(sorted(types))} ('
                           + ', '.join(f'{reading.parameter}' for reading in streams)
                           + '); one topic holds one message type')
    return readings


def describe_message(raw: bytes, msgtype: str) -> str:
    """Say what a serialized message holds, for the error of a field it does not have."""
    entry = find(msgtype)
    if entry is None or not entry.vector:
        return f'a {msgtype}'
    try:
        layout = parse_layout(raw, msgtype)
    except DecodeError as e:
        return f'a {msgtype} that cannot be parsed ({e})'
    if not entry.layout.named:
        return f'{entry.fields[0]} of {layout.arrays[entry.fields[0]][1]} values'
    counts = ', '.join(f'{field} {layout.arrays[field][1]}' for field in entry.fields)
    return f'the joints {list(layout.names)} (values: {counts})'


class _FieldCheck:
    """
    Refuse a stream none of whose first messages holds what its parameter asks for.

    A misspelt joint or field would otherwise make every message malformed and the replay
    an empty success; a stream that reads some of its first :data:`PROBE_MESSAGES`
    messages is taken (the rest that fail are counted as ``malformed``).
    """

    def __init__(self, bag) -> None:
        self.bag = bag
        self.tried: dict = {}
        self.first: dict = {}
        self.readings: dict = {}

    def failed(self, topic: str, reading: _Reading, raw: bytes, error: Exception) -> None:
        """Note a message the reading could not read; raise after the probe's worth."""
        key = (topic, reading.name)
        if key not in self.tried:
            return  # it has read a message: failures are malformed messages, counted
        self.tried[key] += 1
        self.first.setdefault(key, (raw, error))
        if self.tried[key] >= PROBE_MESSAGES:
            self.refuse(topic, reading)

    def read(self, topic: str, reading: _Reading) -> None:
        """Note a message the reading read: the stream is there."""
        self.tried.pop((topic, reading.name), None)

    def start(self, readings: dict) -> None:
        """Watch every reading until it reads a message."""
        self.tried = {(topic, reading.name): 0 for topic, streams in readings.items()
                      for reading in streams}
        self.readings = readings

    def finish(self) -> None:
        """Refuse a reading that tried messages and read none."""
        for (topic, name), tried in list(self.tried.items()):
            if tried:
                reading = next(r for r in self.readings[topic] if r.name == name)
                self.refuse(topic, reading)

    def refuse(self, topic: str, reading: _Reading) -> None:
        key = (topic, reading.name)
        raw, error = self.first[key]
        raise BagError(f'{self.bag}: {reading.parameter}: none of the first '
                       f'{self.tried[key]} messages of {topic} holds what it asks for '
                       f'({error}); the topic holds {describe_message(raw, reading.msgtype)}')


def recorded_events(bag, system: Configuration, u_topic: str = 'u',
                    use_log_time: bool = False, y_topic: str = 'y',
                    on_message=None) -> tuple:
    """
    Read the measurement sources' and the inputs' messages of a bag, in bag order.

    Each message is read as the observer node reads it: the fields of its source
    (:class:`~observer_ros.wire.FieldReader`; without sources, ``y_topic`` as
    ``topics.y`` says), its header stamp where the type has one and it is not zero, else
    its log time (the node, under ``play_bag``, stamps it with ``/clock``, which is that
    log time); the log time is its arrival. Sources that share a topic each read every
    message of it, in the order of ``observer.sources``. ``on_message(source, stamp_ns,
    raw)``, when given, sees each message read (``sources.<name>.noise: message``).

    Returns
    -------
    events : list of RecordedEvent
    counts : dict
        ``{source or 'u': Counter}`` of messages read and dropped (``malformed``).

    Raises
    ------
    observer_ros.bags.storage.BagError
        A source's topic (or ``u_topic``) is not in the bag or holds another type, or none
        of the first :data:`PROBE_MESSAGES` messages of a topic has the fields (joints,
        entries) its parameter names: the error names the parameter and what the topic
        holds.

    """
    from collections import Counter
    readings = _readings(system, y_topic, u_topic)
    playback = Playback(bag, list(readings))
    events = []
    counts = {reading.name: Counter() for streams in readings.values() for reading in streams}
    check = _FieldCheck(bag)
    check.start(readings)
    try:
        for topic, (recorded_type, _) in playback.topics.items():
            for reading in readings[topic]:
                if recorded_type != reading.msgtype:
                    raise BagError(f'{bag}: topic {playback.recorded[topic]} holds '
                                   f'{recorded_type}, expected {reading.msgtype} (the type '
                                   f'of {reading.parameter.split()[0]})')
        for topic, log_time, raw in playback.messages():
            for reading in readings[topic]:
                name = reading.name
                counts[name]['received'] += 1
                try:
                    stamp, values = reading.reader.read(raw)
                except DecodeError as e:
                    check.failed(topic, reading, raw, e)
                    counts[name]['malformed'] += 1
                    continue
                check.read(topic, reading)
                if not all(map(np.isfinite, values)):
                    counts[name]['malformed'] += 1
                    continue
                stamp = log_time if use_log_time or not stamp else stamp
                if on_message is not None:
                    on_message(name, stamp, raw)
                events.append(RecordedEvent(name, stamp, np.array(values, dtype=float),
                                            log_time))
        check.finish()
    finally:
        playback.close()
    return events, counts


def _replay_sources(bag, system: Configuration, y_topic: str, u_topic: str,
                    use_log_time: bool) -> 'ReplayResult':
    """:func:`replay_bag` message by message: measurement sources, or inputs by field."""
    stream = system.observer.make_stream()
    noise = getattr(stream.estimator, 'message_noise', None)  # noise: message, every block
    if noise is not None:
        noise.keep_ns = NO_PRUNING
    events, counts = recorded_events(bag, system, u_topic, use_log_time, y_topic,
                                     None if noise is None else noise.take)
    if use_log_time:
        stream.input_stamped = False
    if system.observer.unstamped_input == 'next_measurement' and not stream.input_stamped:
        events = _held_inputs(events)
    stream.engine.retired = []
    causes: list = []
    samples = stream.replay_events(events, causes)
    model = system.model
    arrays = replay_arrays([sample._replace(innovation=_full_innovation(sample, model),
                                            innovation_covariance=None, nis=None)
                            for sample in samples], model.n_states, model.n_outputs)
    labels = _cause_events(samples, causes, stream.engine.sources)
    arrays = dataclasses.replace(arrays, covariances=_covariances(samples, model.n_states))
    measured = [event for event in events if event.source != INPUT]
    inputs = [event for event in events if event.source == INPUT]
    counters = dict(stream.counters)
    counters['malformed'] = counters.get('malformed', 0) + sum(
        count['malformed'] for count in counts.values())
    return ReplayResult(system, str(bag), arrays.stamps_ns, arrays.estimates,
                        arrays.innovations, _topic_data(measured, 0), _topic_data(
                            inputs, model.n_inputs), counters, use_log_time,
                        arrays.covariances, None, None,
                        stream_warnings(stream, str(bag), y_topic, u_topic), labels,
                        _in_order(stream, arrays, labels))


def _held_inputs(events: list) -> list:
    """Stamp each unstamped input with the next measurement in bag order (hold_input's rule)."""
    order = np.arange(len(events))
    is_input = np.array([event.source == INPUT for event in events], dtype=bool)
    measured = order[~is_input]
    kept, stamps = next_measurement_stamps(order[is_input], measured,
                                           [events[i].stamp_ns for i in measured])
    held = dict(zip(order[is_input][kept].tolist(), stamps.tolist()))
    return [event._replace(stamp_ns=held[index]) if index in held else event
            for index, event in enumerate(events) if event.source != INPUT or index in held]


def _covariances(samples: list, n_states: int) -> Optional[np.ndarray]:
    """
    Return ``P`` of each sample, ``(k, n, n)``: NaN where a sample has none, None if none has.

    The first estimate of a steady-state filter has no covariance yet (the node publishes
    none for it); the rest still go to the CSV.
    """
    if not any(sample.covariance is not None for sample in samples):
        return None
    missing = np.full((n_states, n_states), np.nan)
    return np.array([missing if sample.covariance is None else sample.covariance
                     for sample in samples], dtype=float)


def _in_order(stream, published, events) -> 'InOrderEstimates':
    """
    Return the in-order estimates of a replayed stream, after every late sample.

    With a history: the entries that left it (final) and those still in it, oldest first,
    each named by the sources of its update (``wheels+imu``). Without one nothing is re-run
    and the published estimates are the in-order ones.
    """
    engine = stream.engine
    if not engine.keeps_history:
        return InOrderEstimates(published.stamps_ns, published.estimates,
                                published.covariances, np.asarray(events, dtype=str))
    entries = [entry for entry in (engine.retired or []) + list(engine.entries)
               if entry.result is not None]
    n_states = stream.estimator.n_states
    stamps = np.array([entry.stamp_ns for entry in entries], dtype=np.int64)
    estimates = np.array([entry.result.estimate for entry in entries],
                         dtype=float).reshape(-1, n_states)
    covariances = _covariances([entry.result for entry in entries], n_states)
    names = np.array(['+'.join(entry.parts) for entry in entries], dtype=str)
    return InOrderEstimates(stamps, estimates, covariances, names)


def _full_innovation(sample, model) -> np.ndarray:
    """Return the innovation as a p-vector: NaN where an output was not in the update."""
    outputs = getattr(sample, 'outputs', None)
    if outputs is None:
        return sample.innovation
    full = np.full(model.n_outputs, np.nan)
    full[list(outputs)] = sample.innovation
    return full


def _topic_data(events: list, width: int) -> TopicData:
    """Return the events read as TopicData (values only when they share one width)."""
    stamps = np.array([event.stamp_ns for event in events], dtype=np.int64)
    logged = np.array([event.arrival_ns for event in events], dtype=np.int64)
    values = (np.array([event.values for event in events]).reshape(len(events), width)
              if width else np.zeros((len(events), 0)))
    return TopicData(stamps, logged, values)


def replay_bag(bag: Union[str, os.PathLike],
               parameters: Union[str, os.PathLike, Configuration],
               y_topic: str = 'y', u_topic: str = 'u',
               use_log_time: bool = False) -> ReplayResult:
    """
    Run the configured observer over a bag.

    Parameters
    ----------
    bag : path-like
        rosbag2 directory (MCAP or sqlite3), or one storage file.
    parameters : path-like or Configuration
        Parameter file (``/**: ros__parameters:``) or an already validated system. Its
        ``topics.y.*`` and ``topics.u.*`` give the message types, fields and joint names;
        with ``observer.sources`` each source's topic is read by its fields and every
        message goes to the stream in bag order (:func:`recorded_events`,
        :meth:`~observer_ros.core.streaming.EventStream.replay_events`), as the node takes
        them from ``play_bag``. Its innovations are then NaN where an output was not in the
        update, and it has no innovation covariances or NIS.
    y_topic, u_topic : str
        Topic names in the bag (``y`` is ``/y``; a bag's ``y`` recorded without the slash
        is found either way). A model without inputs (m = 0) reads no ``u_topic``.
    use_log_time : bool
        Stamp ``y`` and ``u`` (and the truth) with their log times, the recorder's clock,
        instead of their header stamps: for bags whose streams are stamped in different
        time bases (see :func:`check_time_bases`).

    Raises
    ------
    observer_ros.bags.storage.BagError
        The bag cannot give the topics (see :func:`observer_ros.bags.storage.read_topic`),
        or they are stamped in different time bases.
    observer_ros.core.errors.ConfigError
        A bad parameter file, naming the parameter.

    """
    system = load_system(parameters)
    if system.observer.sources is not None or system.topics['u'].fields:
        return _replay_sources(bag, system, y_topic, u_topic, use_log_time)
    if system.model.n_inputs == 0:  # no inputs: the measurements alone
        (outputs,) = read_topics(bag, [topic_request(system, 'y', y_topic)])
        inputs = TopicData(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 0)))
    else:
        outputs, inputs = read_topics(bag, [topic_request(system, 'y', y_topic),
                                            topic_request(system, 'u', u_topic)])
    return replay_data(bag, system, outputs, inputs, use_log_time, y_topic, u_topic)


def _cause_events(samples: list, causes: list, sources: dict) -> np.ndarray:
    """
    Name what made each estimate of :meth:`EventStream.replay_events`.

    The source of the measurement it is the estimate of (at the measurement's stamp, less
    the source's latency), ``rerun`` for the newest estimate corrected after a late sample,
    ``input`` for estimates an input released, ``flush`` for those of the final flush.
    """
    labels = []
    for sample, event in zip(samples, causes):
        if event is None:
            labels.append(FLUSHED)
        elif event.source == INPUT:
            labels.append(INPUT_EVENT)
        elif sample.stamp_ns == event.stamp_ns - sources[event.source].latency_ns:
            labels.append(event.source)
        else:
            labels.append(RERUN)
    return np.array(labels, dtype=str)


def _stamp_events(stamps_ns: np.ndarray) -> np.ndarray:
    """Name the estimates of one ``y`` stream: ``y``, or ``rerun`` at a stamp given before."""
    _, first = np.unique(stamps_ns, return_index=True)
    labels = np.full(len(stamps_ns), RERUN, dtype=object)
    labels[first] = MEASUREMENT
    return labels.astype(str)
