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
Opening rosbag2 bags (MCAP or sqlite3) with ``rosbags``: their layout, topics and messages.

What ``rosbags`` opens for a path (a bag directory, one storage file, version-1 metadata),
the connections as the storage files record them, and :class:`Playback`, a bag's raw
messages in log-time order; with the bag's errors (:class:`BagError`), the one rule for
topic names (:func:`absolute_topic`) and the vectors read (:class:`TopicData`). Reading
vector topics is :mod:`observer_ros.bags.reading`, writing them
:mod:`observer_ros.bags.writing`.
"""

from dataclasses import dataclass
from pathlib import Path, PurePath
from typing import Iterator, Optional, Sequence, Tuple

import numpy as np

from observer_ros.wire import message_class as installed_class, MessageClassError

STORAGES = ('mcap', 'sqlite3')


class BagError(ValueError):
    """A bag that cannot give what was asked, with the reason."""


@dataclass(frozen=True)
class TopicData:
    """One topic's vectors: header stamps (log time when unstamped), log times, values."""

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


def playback_class(msgtype: str, topic: str):
    """
    Return the Python class of ``pkg/msg/Name`` (or ``pkg/Name``, ``pkg/srv/Name_Event``).

    Raises
    ------
    BagError
        The type is not installed, naming the topic.

    """
    try:
        return installed_class(msgtype)  # the wire catalog's one lookup
    except MessageClassError as e:
        raise BagError(f'topic {topic}: message type {msgtype} is not installed here; '
                       f'leave it out with --exclude {topic}') from e


def playback_classes(playback: Playback) -> dict:
    """
    Return ``{topic: class}`` of the played topics.

    Raises
    ------
    BagError
        One line naming every topic whose type is not installed, and the ``--exclude``
        that leaves them out.

    """
    classes, absent = {}, []
    for topic, (msgtype, _) in playback.topics.items():
        try:
            classes[topic] = playback_class(msgtype, topic)
        except BagError:
            absent.append(topic)
    if absent:
        names = [playback.recorded[topic] for topic in absent]
        types = ', '.join(f'{name} ({playback.topics[topic][0]})'
                          for name, topic in zip(names, absent))
        raise BagError(f'{playback.path}: message types not installed here: {types}; leave '
                       f'them out with --exclude {" ".join(names)}')
    return classes
