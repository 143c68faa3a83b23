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
Reading a replay's topics: each role's topic, and the sources' and inputs' messages as events.

:func:`topic_request` and :func:`topic_data` read the topic playing a role (``y``, ``u``,
``x_true``) as a vector stream; :func:`recorded_events` reads every message of the
measurement sources and the inputs, in bag order, as the observer node reads it, and
refuses a stream none of whose first messages holds what its parameter asks for.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.bags.reading import read_topics, TopicRequest
from observer_ros.bags.storage import absolute_topic, BagError, Playback, TopicData
from observer_ros.config import Configuration
from observer_ros.config.schema import FIELD_MESSAGE_TYPES, source_parameter, topic_names
from observer_ros.core.events import INPUT, MEASUREMENT
from observer_ros.core.streaming import RecordedEvent
from observer_ros.wire import DecodeError, FieldReader, find, parse_layout, topic_reader


#: Messages of a topic read before a stream none of which holds its fields is refused.
PROBE_MESSAGES = 20


def topic_request(system: Configuration, key: str, topic: Optional[str] = None) -> TopicRequest:
    """Return what to read for the topic playing role ``key`` (``y``, ``u``, ``x_true`` ...)."""
    settings = system.topics[key]
    return TopicRequest(topic or key, settings.type, settings.field,
                        topic_names(system.model, key))


def topic_data(path, system: Configuration, key: str, topic: Optional[str] = None) -> TopicData:
    """Read the bag topic playing role ``key`` of ``system``."""
    return read_topics(path, [topic_request(system, key, topic)])[0]


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
