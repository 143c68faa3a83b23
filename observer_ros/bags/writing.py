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
Writing vector topics to a new rosbag2 bag (MCAP or sqlite3), complete or not at all.

:func:`write_bag` writes to a temporary directory renamed into place when complete, so a
failed write never leaves a bag that looks valid.
"""

from dataclasses import dataclass
import os
from pathlib import Path
import shutil
import tempfile
from typing import Sequence

import numpy as np

from observer_ros.bags.storage import absolute_topic, BagError, STORAGES
from observer_ros.wire import Encoder


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
