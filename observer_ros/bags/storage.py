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
from pathlib import Path, PurePath
import shutil
import tempfile
from typing import Iterator, Optional, Sequence, Tuple

import numpy as np

from observer_ros.bags.mcap import read_mcap_topics
from observer_ros.wire import (
    decode, DecodeError, Encoder, full_type_name, message_types, parse_layout, vector_layout)

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
    """
    Return ``topic`` taken from the root: ``y``, ``/y`` and a recorded ``y`` are one topic.

    The one rule for topic names: applied to what is asked (``--y-topic y``) and to the
    names a bag records (rosbag2's own test bags hold ``AAA``, ``a_empty``), so either
    spelling finds the topic.
    """
    return topic if topic.startswith('/') else '/' + topic


def message_type(msgtype: str) -> str:
    """Return ``pkg/msg/Name`` for a recorded message type (older bags write ``pkg/Name``)."""
    package, _, name = msgtype.rpartition('/')
    return f'{package}/msg/{name}' if package and '/' not in package else msgtype


def _listing(reader) -> str:
    """List the topics of an open bag as recorded, with their types, for error messages."""
    present = dict.fromkeys(f'{c.topic} ({c.msgtype})' for c in reader.connections)
    return ', '.join(present) or 'no topics (it is empty)'


#: Suffixes of the rosbag2 storage files ``rosbags`` opens on their own.
STORAGE_SUFFIXES = ('.mcap', '.db3')


def _metadata(directory: Path) -> Optional[dict]:
    """Return the ``rosbag2_bagfile_information`` of ``directory``, None when unparsable."""
    import yaml
    try:
        with open(directory / 'metadata.yaml', encoding='utf-8') as stream:
            info = yaml.safe_load(stream)['rosbag2_bagfile_information']
    except (OSError, yaml.YAMLError, TypeError, KeyError):
        return None  # rosbags says what is wrong with it
    return info if isinstance(info, dict) else None


def _storage_files(directory: Path) -> list:
    return sorted(p for p in directory.iterdir()
                  if p.suffix in STORAGE_SUFFIXES and p.is_file())


def _target(path: Path) -> Path:
    """
    Return what ``rosbags`` opens for ``path``: the bag directory or one storage file.

    Besides a bag directory, a storage file (``.mcap``, ``.db3``) and a directory holding
    one storage file without ``metadata.yaml`` are read on their own, and so is a bag whose
    metadata is version 1 (``topic_and_type``, which ``rosbags`` does not read) with one
    file. Anything else is a BagError saying what the layout is and what to do.
    """
    if not path.exists():
        raise BagError(f'{path}: not a readable rosbag2 bag (no such file or directory)')
    if path.is_file():
        if path.name == 'metadata.yaml':
            return _target(path.parent)
        if path.suffix in STORAGE_SUFFIXES:
            return path
        if path.suffix == '.zstd':
            raise BagError(f'{path}: a zstd-compressed storage file; give the bag directory '
                           f'that holds it with its metadata.yaml, or decompress it first')
        raise BagError(f'{path}: not a readable rosbag2 bag (expected a bag directory or an '
                       f'.mcap or .db3 storage file)')
    if not (path / 'metadata.yaml').exists():
        files = _storage_files(path)
        if len(files) == 1:
            return files[0]
        if not files:
            raise BagError(f'{path}: not a readable rosbag2 bag (no metadata.yaml and no '
                           f'.mcap or .db3 file in it)')
        raise BagError(f'{path}: no metadata.yaml and {len(files)} storage files '
                       f'({", ".join(f.name for f in files)}); rebuild the metadata with '
                       f'"ros2 bag reindex {path}", or give one of the files')
    info = _metadata(path)
    if info is None:
        return path
    files = [path / PurePath(str(name)).name for name in info.get('relative_file_paths') or ()]
    missing = [f.name for f in files if not f.exists()]
    if missing:
        raise BagError(f'{path}: its metadata.yaml lists {", ".join(missing)}, not found in '
                       f'the bag directory; copy the storage files next to metadata.yaml')
    if info.get('version') == 1:
        if len(files) == 1:
            return files[0]
        raise BagError(f'{path}: metadata version 1 with {len(files)} storage files, which '
                       f'rosbags cannot read; rebuild the metadata with '
                       f'"ros2 bag reindex {path}"')
    return path


def _reader(path):
    from rosbags.rosbag2 import Reader
    target = _target(Path(path))
    try:
        reader = Reader(target)
        reader.open()
    except Exception as e:  # rosbags raises several types for unreadable bags
        what = '' if target == Path(path) else f' ({target.name} alone)'
        raise BagError(f'{path}: not a readable rosbag2 bag{what} ({e})') from e
    return reader


def _stored_connections(reader) -> list:
    """
    Return the connections as the storage files record them.

    ``rosbags`` yields a message only for a connection whose QoS profiles equal the
    storage file's; real bags (rosbag2's talker, its converted bags) record other QoS in
    ``metadata.yaml`` than in the file, and would give no messages. Asking with the
    files' own connections gives every message; types and counts still come from the
    metadata (:attr:`reader.connections`).
    """
    storages = getattr(getattr(reader, 'storage', None), 'storages', None)
    if storages is None:  # a storage file opened alone: its connections are the file's
        return list(reader.connections)
    return [connection for storage in storages for connection in storage.connections]


def _mcap_files(reader) -> Optional[list]:
    """Return the bag's MCAP files when :mod:`observer_ros.bags.mcap` reads them, else None."""
    path = Path(reader.path)
    if path.is_file():
        return [path] if path.suffix == '.mcap' else None
    if reader.compression_mode:  # whole-file or per-message compression: rosbags decompresses
        return None
    info = _metadata(path)
    names = info.get('relative_file_paths') if info else None
    if not names or info.get('storage_identifier') != 'mcap':
        return None
    # As rosbag2 and rosbags read them: older bags prefix the bag directory's name.
    return [path / PurePath(str(name)).name for name in names]


class Playback:
    """
    A bag's messages in log-time order, raw, for publishing them again.

    Topic names are taken from the root (:func:`absolute_topic`) on both sides: ``AAA``
    recorded without a slash is played, selected and excluded as ``/AAA`` or ``AAA``.

    Parameters
    ----------
    path : path-like
        The bag directory (or its storage file).
    topics : sequence of str, optional
        Topics to play (all when None); each must be in the bag.
    exclude : sequence of str
        Topics left out; each must be in the bag (a misspelt name is an error, not a
        silently played topic).

    Attributes
    ----------
    topics : dict
        ``{topic: (message type, message count in the metadata)}`` of the played topics,
        names from the root, types ``pkg/msg/Name``.
    recorded : dict
        ``{topic: name as the bag records it}`` of the played topics.

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
        try:
            self._select(topics, exclude)
        except BagError:
            self._reader.close()
            raise

    def _select(self, topics: Optional[Sequence[str]], exclude: Sequence[str]) -> None:
        path, reader = self.path, self._reader
        present: dict = {}
        for connection in reader.connections:
            present.setdefault(absolute_topic(connection.topic), connection.topic)
        missing = [t for t in topics or () if absolute_topic(t) not in present]
        if missing:
            raise BagError(f'{path}: no topic {", ".join(missing)}; the bag has '
                           f'{_listing(reader)}')
        unknown = [t for t in exclude if absolute_topic(t) not in present]
        if unknown:
            raise BagError(f'--exclude: {path} has no topic {", ".join(unknown)}; the bag has '
                           f'{_listing(reader)}')
        wanted = set(present) if topics is None else {absolute_topic(t) for t in topics}
        wanted -= {absolute_topic(t) for t in exclude}
        if not wanted:
            raise BagError(f'{path}: nothing to play; the bag has {_listing(reader)}')
        self.recorded = {topic: present[topic] for topic in sorted(wanted)}
        self.topics = {}
        for connection in reader.connections:
            topic = absolute_topic(connection.topic)
            if topic not in wanted:
                continue
            msgtype = message_type(connection.msgtype)
            known, count = self.topics.get(topic, (msgtype, 0))
            if known != msgtype:
                raise BagError(f'{path}: topic {connection.topic} holds both {known} and '
                               f'{msgtype}; play it with --exclude {connection.topic}')
            self.topics[topic] = (msgtype, count + connection.msgcount)
        self._connections = [c for c in _stored_connections(reader)
                             if absolute_topic(c.topic) in wanted]

    def listing(self) -> str:
        """Return the played topics as the bag records them, for messages."""
        return ', '.join(self.recorded.values())

    def messages(self) -> Iterator[Tuple[str, int, bytes]]:
        """Yield ``(topic, log_time_ns, cdr_bytes)`` in log-time order, topics from the root."""
        if not self._connections:
            return
        try:
            for connection, log_time, raw in self._reader.messages(
                    connections=self._connections):
                yield absolute_topic(connection.topic), log_time, bytes(raw)
        except Exception as e:
            raise BagError(f'{self.path}: cannot read the messages ({e})') from e

    def check_counts(self, played: dict) -> None:
        """Raise BagError when a topic gave fewer messages than the metadata counts."""
        short = [f'{self.recorded[topic]}: {played.get(topic, 0)} of {count}'
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
                encoder = getattr(item, 'encoder', None) or Encoder(item.kind, item.names,
                                                                    item.field)
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
