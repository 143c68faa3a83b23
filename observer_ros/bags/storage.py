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
Read and write vector topics of rosbag2 bags (MCAP or sqlite3) with ``rosbags``.

The messages of MCAP bags are read with :mod:`observer_ros.bags.mcap` (one pass, several
times faster); the bag's metadata and connections, and sqlite3 messages, come from
``rosbags``.

Reading checks what it finds against what was asked (topic present, message type, vector
length) and against the bag's own metadata (message counts), and says what is wrong with
the bag's path and topic in the message. Writing goes to a temporary directory renamed into
place when complete, so a failed write never leaves a bag that looks valid.
"""

from dataclasses import dataclass
import os
from pathlib import Path
import shutil
import tempfile
from typing import Iterator, Optional, Sequence, Tuple

import numpy as np

from observer_ros.bags.cdr import decode, Encoder, MESSAGE_TYPES
from observer_ros.bags.mcap import read_mcap_topics

STORAGES = ('mcap', 'sqlite3')


class BagError(ValueError):
    """A bag that cannot give what was asked, with the reason."""


@dataclass(frozen=True)
class TopicData:
    """One topic's vectors: header stamps (log time when unstamped), log times, values."""

    stamps_ns: np.ndarray
    log_times_ns: np.ndarray
    values: np.ndarray


@dataclass(frozen=True)
class TopicToWrite:
    """A vector topic to write: name, message kind, field, joint names and the data."""

    topic: str
    kind: str
    field: str
    names: Sequence[str]
    stamps_ns: np.ndarray
    log_times_ns: np.ndarray
    values: np.ndarray


def absolute_topic(topic: str) -> str:
    """Return ``topic`` taken from the root, as bags record names (``y`` is ``/y``)."""
    return topic if topic.startswith('/') else '/' + topic


def _listing(reader) -> str:
    """List the topics of an open bag with their types, for error messages."""
    present = ', '.join(f'{c.topic} ({c.msgtype})' for c in reader.connections)
    return present or 'no topics (it is empty)'


def _reader(path):
    from rosbags.rosbag2 import Reader
    try:
        reader = Reader(Path(path))
        reader.open()
    except Exception as e:  # rosbags raises several types for unreadable bags
        raise BagError(f'{path}: not a readable rosbag2 bag ({e})') from e
    return reader


def _mcap_files(reader, path) -> Optional[list]:
    """Return the bag's MCAP files when :mod:`observer_ros.bags.mcap` reads them, else None."""
    path = Path(path)
    if path.is_file():
        return [path] if path.suffix == '.mcap' else None
    if reader.compression_mode:  # whole-file compression: rosbags decompresses
        return None
    import yaml
    with open(path / 'metadata.yaml', encoding='utf-8') as stream:
        info = yaml.safe_load(stream)['rosbag2_bagfile_information']
    names = info.get('relative_file_paths')
    if info.get('storage_identifier') != 'mcap' or not names:
        return None
    return [path / name for name in names]


def bag_topics(path) -> dict:
    """Return ``{topic: (message type, message count)}`` of a bag."""
    reader = _reader(path)
    try:
        return {name: (info.msgtype, info.msgcount) for name, info in reader.topics.items()}
    finally:
        reader.close()


class Playback:
    """
    A bag's messages in log-time order, raw, for publishing them again.

    Parameters
    ----------
    path : path-like
        The bag directory.
    topics : sequence of str, optional
        Topics to play (all when None); each must be in the bag.
    exclude : sequence of str
        Topics left out.

    Attributes
    ----------
    topics : dict
        ``{topic: (message type, message count in the metadata)}`` of the played topics.

    Raises
    ------
    BagError
        Unreadable bag, a named topic it does not hold (the topics present are listed), or
        nothing left to play.

    """

    def __init__(self, path, topics: Optional[Sequence[str]] = None,
                 exclude: Sequence[str] = ()) -> None:
        self.path = path
        self._reader = _reader(path)
        present = {c.topic: c.msgtype for c in self._reader.connections}
        wanted = set(present) if topics is None else {absolute_topic(t) for t in topics}
        wanted -= {absolute_topic(t) for t in exclude}
        missing = sorted(wanted - set(present))
        if missing or not wanted:
            listing = _listing(self._reader)
            self._reader.close()
            raise BagError(f'{path}: ' + (f'no topic {", ".join(missing)}; ' if missing else
                                          'nothing to play; ') + f'the bag has {listing}')
        self._connections = [c for c in self._reader.connections if c.topic in wanted]
        self.topics = {}
        for connection in self._connections:
            msgtype, count = self.topics.get(connection.topic, (connection.msgtype, 0))
            if msgtype != connection.msgtype:
                self._reader.close()
                raise BagError(f'{path}: topic {connection.topic} holds both {msgtype} and '
                               f'{connection.msgtype}; play it with --exclude')
            self.topics[connection.topic] = (msgtype, count + connection.msgcount)

    def messages(self) -> Iterator[Tuple[str, int, bytes]]:
        """Yield ``(topic, log_time_ns, cdr_bytes)`` in log-time order."""
        try:
            for connection, log_time, raw in self._reader.messages(
                    connections=self._connections):
                yield connection.topic, log_time, bytes(raw)
        except Exception as e:
            raise BagError(f'{self.path}: cannot read the messages ({e})') from e

    def check_counts(self, played: dict) -> None:
        """Raise BagError when a topic gave fewer messages than the metadata counts."""
        short = [f'{topic}: {played.get(topic, 0)} of {count}'
                 for topic, (_, count) in sorted(self.topics.items())
                 if count and played.get(topic, 0) != count]
        if short:
            raise BagError(f'{self.path}: read fewer messages than the metadata counts '
                           f'({"; ".join(short)}); the bag is damaged or its QoS records '
                           f'disagree')

    def close(self) -> None:
        """Close the bag."""
        self._reader.close()


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
    kind : {'joint_state', 'float64_multi_array'}
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
            connections = [c for c in reader.connections if c.topic == request.topic]
            if not connections:
                raise BagError(f'{path}: no topic {request.topic}; the bag has '
                               f'{_listing(reader)}')
            types = {c.msgtype for c in connections}
            expected = MESSAGE_TYPES[request.kind]
            if types != {expected}:
                raise BagError(f'{path}: topic {request.topic} holds '
                               f'{", ".join(sorted(types))}, expected {expected} (set '
                               f'topics.<topic>.type to match)')
            by_topic[request.topic] = connections
        files = _mcap_files(reader, path)
        if files is not None:
            collected = read_mcap_topics(files, list(by_topic))
        else:
            wanted = [c for connections in by_topic.values() for c in connections]
            collected = {topic: ([], []) for topic in by_topic}
            for connection, log_time, raw in reader.messages(connections=wanted):
                times, raws = collected[connection.topic]
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


def _decoded(path, request: TopicRequest, connections, log_times: list,
             raws: list) -> TopicData:
    topic, names = request.topic, request.names
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


def _qos():
    from rosbags.interfaces import (
        Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime)
    zero = QosTime(0, 0)
    return [Qos(QosHistory.KEEP_LAST, 10, QosReliability.RELIABLE, QosDurability.VOLATILE,
                zero, zero, QosLiveliness.AUTOMATIC, zero, False)]


def write_bag(path, topics: Sequence[TopicToWrite], storage: str = 'mcap') -> Path:
    """
    Write vector topics to a new bag directory at ``path``.

    Messages are written in log-time order with the reliable QoS the nodes publish with,
    so ``ros2 bag play`` offers them as recorded.

    Raises
    ------
    BagError
        ``path`` exists, or an unknown storage.

    """
    from rosbags.rosbag2 import StoragePlugin, Writer
    if storage not in STORAGES:
        raise BagError(f'storage: expected one of {", ".join(STORAGES)}, got {storage!r}')
    path = Path(path)
    if path.exists():
        raise BagError(f'{path}: exists already; choose a new output path')
    path.parent.mkdir(parents=True, exist_ok=True)
    scratch = Path(tempfile.mkdtemp(prefix=f'.{path.name}.', dir=path.parent))
    partial = scratch / path.name
    plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
    try:
        with Writer(partial, version=9, storage_plugin=plugin) as writer:
            streams = []
            for item in topics:
                encoder = Encoder(item.kind, item.names, item.field)
                connection = writer.add_connection(
                    absolute_topic(item.topic), encoder.msgtype, typestore=encoder.typestore,
                    offered_qos_profiles=_qos())
                raws = encoder.encode(item.stamps_ns, item.values)
                streams.append((np.asarray(item.log_times_ns, dtype=np.int64), connection,
                                raws))
            times = np.concatenate([s[0] for s in streams]) if streams else np.zeros(0)
            which = np.concatenate([np.full(len(s[0]), k) for k, s in enumerate(streams)]
                                   ) if streams else np.zeros(0, dtype=int)
            position = np.concatenate([np.arange(len(s[0])) for s in streams]
                                      ) if streams else np.zeros(0, dtype=int)
            write = writer.write
            for k in np.lexsort((which, times)).tolist():
                stream = streams[which[k]]
                write(stream[1], int(times[k]), stream[2][position[k]])
        os.replace(partial, path)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)
    return path
