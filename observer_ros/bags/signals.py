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
Signals read from bags by topic and field: the one reader of ``identify`` and ``tune_kalman``.

A :class:`SignalSpec` names a topic and what to read of it, as the command lines write it:
``TOPIC[:FIELD[:JOINT,...]]`` for a JointState (or Float64MultiArray) vector, or
``TOPIC:PATH[,PATH...]`` for any type the observer reads by field path (its measurement
sources and ``topics.u.fields``: :data:`~observer_ros.wire.TYPE_NAMES`).
:func:`read_signals` reads several of them from one bag: header stamps where the type has
them, else log times.
"""

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from observer_ros.bags.reading import read_topics, topic_layout, TopicRequest
from observer_ros.bags.storage import absolute_topic, BagError, Playback, TopicData
from observer_ros.wire import (
    DecodeError, field_names, FieldPathError, FieldReader, find, TYPE_NAMES)

#: Sample intervals may differ from the median by this fraction (identification and ALS
#: take one sample period; more needs resampling).
PERIOD_TOLERANCE = 0.02


@dataclass(frozen=True)
class SignalSpec:
    """
    A topic to read: ``TOPIC[:FIELD[:JOINT,JOINT...]]`` or ``TOPIC:PATH[,PATH...]``.

    A JointState topic names a field and joints (all joints by default), a Float64MultiArray
    its whole vector; any other type the observer reads by field path (``/cmd_vel`` as
    ``geometry_msgs/Twist``: ``/cmd_vel:linear.x,angular.z``; an ``Imu``:
    ``/imu:angular_velocity.z``) names its field paths.
    """

    topic: str
    field: Optional[str] = None
    joints: tuple = ()

    @classmethod
    def parse(cls, text: str) -> 'SignalSpec':
        """Parse ``TOPIC[:FIELD[:JOINT,...]]``; ValueError saying what was expected."""
        parts = text.split(':')
        if not parts[0] or len(parts) > 3 or any(not part for part in parts):
            raise ValueError(f'expected TOPIC[:FIELD[:JOINT,...]] or TOPIC:PATH[,PATH...] (for '
                             f'example /joint_states:position:elbow or /cmd_vel:linear.x), '
                             f'got {text!r}')
        joints = tuple(parts[2].split(',')) if len(parts) == 3 else ()
        return cls(parts[0], parts[1] if len(parts) > 1 else None, joints)

    def request(self, bag: str):
        """Return what to read in ``bag``: a TopicRequest, or a FieldRequest by field paths."""
        playback = Playback(bag, [self.topic])
        try:
            msgtype = playback.topics[absolute_topic(self.topic)][0]
        finally:
            playback.close()
        entry = find(msgtype)
        if entry is not None and entry.vector:
            field = self.field or 'position'
            found = topic_layout(bag, self.topic, field)
            return TopicRequest(found.topic, found.kind, field, self.joints or found.names)
        if entry is None:
            raise BagError(f'{bag}: topic {self.topic} holds {msgtype}; expected one of '
                           f'{", ".join(sorted(TYPE_NAMES.values()))}')
        if not self.field or self.joints:
            raise BagError(f'{bag}: topic {self.topic} holds {msgtype}: name its field paths, '
                           f'TOPIC:PATH[,PATH...]; it has {", ".join(field_names(msgtype))}')
        fields = tuple(self.field.split(','))
        try:
            FieldReader(msgtype, fields)
        except FieldPathError as e:
            raise BagError(f'{bag}: topic {self.topic}: {e}') from e
        return FieldRequest(absolute_topic(self.topic), entry.name, msgtype, fields)


@dataclass(frozen=True)
class FieldRequest:
    """A topic read by field paths, as the observer reads a measurement source or ``u``."""

    topic: str
    kind: str
    msgtype: str
    fields: tuple

    @property
    def names(self) -> tuple:
        """The entries' names: the field paths."""
        return self.fields


def read_fields(bag, request: FieldRequest) -> TopicData:
    """
    Read a topic by field paths: header stamps where the type has them, else log times.

    Raises
    ------
    BagError
        A message that does not hold the fields (the first one named).

    """
    reader = FieldReader(request.msgtype, request.fields)
    playback = Playback(bag, [request.topic])
    stamps, log_times, values = [], [], []
    try:
        for index, (_, log_time, raw) in enumerate(playback.messages()):
            try:
                stamp, vector = reader.read(raw)
            except DecodeError as e:
                raise BagError(f'{bag}: topic {request.topic}: message {index} does not hold '
                               f'{", ".join(request.fields)} ({e})') from e
            stamps.append(stamp or log_time)
            log_times.append(log_time)
            values.append(vector)
    finally:
        playback.close()
    if not values:
        raise BagError(f'{bag}: topic {request.topic} has no messages')
    return TopicData(np.array(stamps, dtype=np.int64), np.array(log_times, dtype=np.int64),
                     np.array(values, dtype=float).reshape(len(values), len(request.fields)))


def read_signals(bag, specs: Sequence[SignalSpec]) -> list:
    """
    Read the topics ``specs`` name from one bag; return ``(request, TopicData)`` of each.

    Raises
    ------
    BagError
        A topic the bag lacks, of a type that cannot be read so, or a field it has not.

    """
    requests = [spec.request(bag) for spec in specs]
    vectors = [request for request in requests if isinstance(request, TopicRequest)]
    read = dict(zip(map(id, vectors), read_topics(bag, vectors))) if vectors else {}
    return [(request, read[id(request)] if isinstance(request, TopicRequest)
             else read_fields(bag, request)) for request in requests]


__all__ = ['FieldRequest', 'PERIOD_TOLERANCE', 'SignalSpec', 'read_fields', 'read_signals']
