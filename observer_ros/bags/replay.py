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

from dataclasses import dataclass, field
import os
from typing import Optional, Union

import numpy as np

from observer_ros.bags.storage import (
    absolute_topic, BagError, Playback, read_topics, TopicData, TopicRequest)
from observer_ros.config import Configuration, load_parameter_file, validate_parameters
from observer_ros.config.schema import FIELD_MESSAGE_TYPES, JOINT_STATE_FIELDS, topic_names
from observer_ros.core.estimates import replay_arrays
from observer_ros.core.evaluation import align
from observer_ros.core.events import INPUT
from observer_ros.core.streaming import RecordedEvent
from observer_ros.core.units import NANOSECONDS
from observer_ros.ros.cdr import DecodeError, FieldReader, MessageReader


#: Inputs, evenly spread, whose stamps are compared with the measurements' time base.
TIME_BASE_SAMPLES = 4096


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
                     log_time_advice: str = 'replay with log times for both (replay '
                     '--use-log-time, replay_bag(..., use_log_time=True))') -> None:
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

    def truth(self, topic: str = 'x_true') -> TopicData:
        """Read the true state (or another reference topic) from the bag, in the replay's time."""
        data = topic_data(self.bag, self.system, 'x_true', topic)
        return log_timed(data) if self.use_log_time else data

    def error_norms(self, topic: str = 'x_true') -> np.ndarray:
        """``||x_true - x_hat||`` at the stamps both have, in time order."""
        truth = self.truth(topic)
        _, reference, estimate = align(truth.stamps_ns, truth.values, self.stamps_ns,
                                       self.estimates)
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
        keep = stamps >= stamps[0] + int(settle_s * NANOSECONDS)
        stamps, truth, estimate = stamps[keep], truth[keep], estimate[keep]
    if not len(stamps):
        raise BagError(f'{result.bag}: --reference: {reference.topic} and the estimates '
                       f'share no stamp (after {settle_s:g} s of settling)')
    return float(np.sqrt(np.mean((truth - estimate) ** 2))), len(stamps)


def replay_data(bag, system: Configuration, outputs: TopicData, inputs: TopicData,
                use_log_time: bool = False, y_topic: str = 'y',
                u_topic: str = 'u') -> 'ReplayResult':
    """
    Run the observer of ``system`` over measurements and inputs already read from ``bag``.

    What :func:`replay_bag` does without measurement sources, for readers of other topics:
    ``tune_kalman --inputs/--outputs`` reads them by field path
    (:func:`observer_ros.bags.signals.read_signals`). The stamps are checked for one time
    base (:func:`check_time_bases`) unless ``use_log_time``, which stamps both with their
    log times.
    """
    setup = system.observer
    max_gap_ns, input_stamped = setup.max_gap_ns, setup.input_stamped
    if use_log_time:
        outputs, inputs, input_stamped = log_timed(outputs), log_timed(inputs), False
    else:
        check_time_bases(outputs, inputs, max_gap_ns, str(bag), absolute_topic(y_topic),
                         absolute_topic(u_topic))
    stream = setup.make_stream()
    stream.input_stamped = input_stamped
    result = stream.replay(inputs.stamps_ns, inputs.values, outputs.stamps_ns, outputs.values,
                           inputs.log_times_ns, outputs.log_times_ns)
    return ReplayResult(system, str(bag), result.stamps_ns, result.estimates,
                        result.innovations, outputs, inputs, dict(stream.counters),
                        use_log_time, result.covariances, result.innovation_covariances,
                        result.nis)


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
    if settings.fields:
        return FieldReader(FIELD_MESSAGE_TYPES[settings.type], settings.fields)
    names = topic_names(system.model, 'u')
    return MessageReader(settings.type, settings.field, names)


def recorded_events(bag, system: Configuration, u_topic: str = 'u',
                    use_log_time: bool = False) -> tuple:
    """
    Read the measurement sources' and the inputs' messages of a bag, in bag order.

    Each message is read as the observer node reads it: the fields of its source
    (:class:`~observer_ros.ros.cdr.FieldReader`), its header stamp where the type has one
    and it is not zero, else its log time (the node, under ``play_bag``, stamps it with
    ``/clock``, which is that log time); the log time is its arrival.

    Returns
    -------
    events : list of RecordedEvent
    counts : dict
        ``{source or 'u': Counter}`` of messages read and dropped (``malformed``).

    Raises
    ------
    observer_ros.bags.storage.BagError
        A source's topic (or ``u_topic``) is not in the bag or holds another type.

    """
    from collections import Counter
    sources = system.observer.sources
    readers = {absolute_topic(settings.topic): (
        settings.name, msgtype, FieldReader(msgtype, settings.fields))
               for settings, msgtype in zip(sources.settings, sources.msgtypes)}
    if system.model.n_inputs:
        settings = system.topics['u']
        msgtype = FIELD_MESSAGE_TYPES[settings.type]
        readers[absolute_topic(u_topic)] = (INPUT, msgtype, _input_reader(system))
    playback = Playback(bag, list(readers))
    events, counts = [], {name: Counter() for name, _, _ in readers.values()}
    try:
        for topic, (expected, _) in playback.topics.items():
            if expected != readers[topic][1]:
                raise BagError(f'{bag}: topic {playback.recorded[topic]} holds {expected}, '
                               f'expected {readers[topic][1]} (the type of its source)')
        for topic, log_time, raw in playback.messages():
            name, _, reader = readers[topic]
            counts[name]['received'] += 1
            try:
                stamp, values = reader.read(raw)
            except DecodeError:
                counts[name]['malformed'] += 1
                continue
            if not all(map(np.isfinite, values)):
                counts[name]['malformed'] += 1
                continue
            stamp = log_time if use_log_time or not stamp else stamp
            events.append(RecordedEvent(name, stamp, np.array(values, dtype=float), log_time))
    finally:
        playback.close()
    return events, counts


def _replay_sources(bag, system: Configuration, u_topic: str,
                    use_log_time: bool) -> 'ReplayResult':
    """:func:`replay_bag` of a configuration with measurement sources: message by message."""
    events, counts = recorded_events(bag, system, u_topic, use_log_time)
    stream = system.observer.make_stream()
    if use_log_time:
        stream.input_stamped = False
    samples = stream.replay_events(events)
    model = system.model
    arrays = replay_arrays([sample._replace(innovation=_full_innovation(sample, model),
                                            innovation_covariance=None, nis=None)
                            for sample in samples], model.n_states, model.n_outputs)
    measured = [event for event in events if event.source != INPUT]
    inputs = [event for event in events if event.source == INPUT]
    counters = dict(stream.counters)
    counters['malformed'] = counters.get('malformed', 0) + sum(
        count['malformed'] for count in counts.values())
    return ReplayResult(system, str(bag), arrays.stamps_ns, arrays.estimates,
                        arrays.innovations, _topic_data(measured, 0), _topic_data(
                            inputs, model.n_inputs), counters, use_log_time,
                        arrays.covariances, None, None)


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
        return _replay_sources(bag, system, u_topic, use_log_time)
    if system.model.n_inputs == 0:  # no inputs: the measurements alone
        (outputs,) = read_topics(bag, [topic_request(system, 'y', y_topic)])
        inputs = TopicData(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 0)))
    else:
        outputs, inputs = read_topics(bag, [topic_request(system, 'y', y_topic),
                                            topic_request(system, 'u', u_topic)])
    setup = system.observer
    max_gap_ns, input_stamped = setup.max_gap_ns, setup.input_stamped
    if use_log_time:
        outputs, inputs, input_stamped = log_timed(outputs), log_timed(inputs), False
    else:
        check_time_bases(outputs, inputs, max_gap_ns, str(bag), absolute_topic(y_topic),
                         absolute_topic(u_topic))
    stream = setup.make_stream()
    stream.input_stamped = input_stamped
    result = stream.replay(inputs.stamps_ns, inputs.values, outputs.stamps_ns, outputs.values,
                           inputs.log_times_ns, outputs.log_times_ns)
    return ReplayResult(system, str(bag), result.stamps_ns, result.estimates,
                        result.innovations, outputs, inputs, dict(stream.counters),
                        use_log_time, result.covariances, result.innovation_covariances,
                        result.nis)
