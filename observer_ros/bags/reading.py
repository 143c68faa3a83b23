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
Reading vector topics of a rosbag2 bag: each topic's stamps, log times and vectors, checked.

:func:`read_topics` reads several vector topics in one pass (MCAP files with
:mod:`observer_ros.bags.mcap`, sqlite3 with ``rosbags``) and checks what it finds against
what was asked (topic present, message type, vector length) and against the bag's own
metadata (message counts); :func:`topic_layout` finds what to read for a topic from its
first message. Opening the bag is :mod:`observer_ros.bags.storage`.
"""

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from observer_ros.bags.mcap import read_mcap_topics
from observer_ros.bags.storage import (
    _listing, _mcap_files, _reader, _stored_connections, absolute_topic, BagError,
    message_type, TopicData)
from observer_ros.wire import (
    decode, DecodeError, full_type_name, message_types, parse_layout, vector_layout)


@dataclass(frozen=True)
class TopicRequest:
    """A vector topic to read: name, message kind, JointState field and joint names."""

    topic: str
    kind: str
    field: str
    names: Sequence[str]


def read_topic(path, topic: str, kind: str, field: str, names: Sequence[str]) -> TopicData:
    """
    Read one vector topic.

    Parameters
    ----------
    path : path-like
        The bag directory (or its storage file).
    topic : str
        Topic name (relative names are taken from the root, as recorded).
    kind : str
        A vector type of the wire catalog (``joint_state``, ``float64_multi_array``).
    field : str
        JointState field with the values.
    names : sequence of str
        Joint names in vector order (their count for Float64MultiArray).

    Raises
    ------
    BagError
        Unreadable bag, missing topic (the topics present are listed), wrong type, no
        messages, fewer messages than the metadata counts, or messages without the vector.

    """
    return read_topics(path, [TopicRequest(topic, kind, field, names)])[0]


def read_topics(path, requests: Sequence[TopicRequest]) -> list:
    """
    Read several vector topics in one pass over the bag; see :func:`read_topic`.

    Returns
    -------
    list of TopicData
        In the order of ``requests``.

    """
    requests = [TopicRequest(absolute_topic(r.topic), r.kind, r.field, r.names) for r in requests]
    reader = _reader(path)
    try:
        by_topic = {}
        for request in requests:
            connections = [c for c in reader.connections
                           if absolute_topic(c.topic) == request.topic]
            if not connections:
                raise BagError(f'{path}: no topic {request.topic}; the bag has '
                               f'{_listing(reader)}')
            types = {message_type(c.msgtype) for c in connections}
            expected = full_type_name(request.kind)
            if types != {expected}:
                raise BagError(f'{path}: topic {connections[0].topic} holds '
                               f'{", ".join(sorted(types))}, expected {expected} (set '
                               f'topics.<topic>.type to match)')
            by_topic[request.topic] = connections
        files = _mcap_files(reader)
        if files is not None:
            collected = read_mcap_topics(files, list(by_topic), key=absolute_topic)
        else:
            wanted = [c for c in _stored_connections(reader)
                      if absolute_topic(c.topic) in by_topic]
            collected = {topic: ([], []) for topic in by_topic}
            messages = reader.messages(connections=wanted) if wanted else ()
            for connection, log_time, raw in messages:
                times, raws = collected[absolute_topic(connection.topic)]
                times.append(log_time)
                raws.append(raw)
    except BagError:
        raise
    except Exception as e:
        raise BagError(f'{path}: cannot read topics {", ".join(r.topic for r in requests)} '
                       f'({e})') from e
    finally:
        reader.close()
    return [_decoded(path, request, by_topic[request.topic], *collected[request.topic])
            for request in requests]


def topic_layout(path, topic: str, field: str = 'position') -> TopicRequest:
    """
    Return what to read for a vector topic, found from the bag: its kind and entry names.

    A JointState topic gives the joint names of its first message, a Float64MultiArray the
    count of its first vector (named ``<topic>1 ..``).

    Raises
    ------
    BagError
        Unreadable bag, no such topic (the topics present listed), another message type,
        or a first message that cannot be decoded.

    """
    wanted = absolute_topic(topic)
    kinds = {entry.msgtype: entry.name for entry in message_types() if entry.vector}
    reader = _reader(path)
    try:
        connections = [c for c in reader.connections if absolute_topic(c.topic) == wanted]
        if not connections:
            raise BagError(f'{path}: no topic {wanted}; the bag has {_listing(reader)}')
        types = {message_type(c.msgtype) for c in connections}
        if len(types) != 1 or next(iter(types)) not in kinds:
            raise BagError(f'{path}: topic {wanted} holds {", ".join(sorted(types))}; expected '
                           f'one of {", ".join(sorted(kinds))}')
        kind = kinds[next(iter(types))]
        stored = [c for c in _stored_connections(reader) if absolute_topic(c.topic) == wanted]
        first = next(iter(reader.messages(connections=stored)), None)
    except BagError:
        raise
    except Exception as e:
        raise BagError(f'{path}: cannot read topic {wanted} ({e})') from e
    finally:
        reader.close()
    if first is None:
        raise BagError(f'{path}: topic {wanted} has no messages')
    try:
        layout = parse_layout(first[2], kind)
    except DecodeError as e:
        raise BagError(f'{path}: topic {wanted}: first message: {e}') from e
    shape = vector_layout(kind)
    if shape.named:
        if field not in layout.arrays or layout.arrays[field][1] != len(layout.names):
            raise BagError(f'{path}: topic {wanted}: the first message has no {field} per '
                           f'joint ({list(layout.names)})')
        return TopicRequest(wanted, kind, field, tuple(layout.names))
    count = layout.arrays[shape.array(field)][1]
    base = wanted.strip('/').replace('/', '_')
    return TopicRequest(wanted, kind, field, tuple(f'{base}{i + 1}' for i in range(count)))


def _decoded(path, request: TopicRequest, connections, log_times: list,
             raws: list) -> TopicData:
    topic, names = connections[0].topic, request.names  # as the bag records it
    counted = sum(c.msgcount for c in connections)
    if not raws:
        raise BagError(f'{path}: topic {topic} has no messages' + (
            f' although the metadata counts {counted}' if counted else ''))
    if counted and len(raws) != counted:
        raise BagError(f'{path}: topic {topic}: read {len(raws)} messages but the metadata '
                       f'counts {counted}; the bag is damaged or its QoS records disagree')
    stamps, values, errors = decode(raws, request.kind, request.field, names)
    if errors:
        index, reason = next(iter(sorted(errors.items())))
        raise BagError(f'{path}: topic {topic}: {len(errors)} of {len(raws)} messages do not '
                       f'hold the {len(names)}-vector {list(names)} (first, message {index}: '
                       f'{reason})')
    log_times = np.array(log_times, dtype=np.int64)
    stamps = np.where(stamps == 0, log_times, stamps)
    return TopicData(stamps, log_times, values)
