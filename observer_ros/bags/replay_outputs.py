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
Where a replay's results go: a new bag and a CSV file, checked first, all or nothing.

:func:`check_outputs` refuses, before anything is written, an output path that cannot be
written; :func:`write_replay` writes ``x_hat`` (and the innovation) of a
:class:`~observer_ros.bags.replay_results.ReplayResult`, each output under a temporary name renamed
into place, and removes what it wrote when a later one fails.
"""

from dataclasses import dataclass
import os
from pathlib import Path
import shutil
from typing import Optional

import numpy as np

from observer_ros.bags.replay_results import ReplayResult
from observer_ros.bags.storage import absolute_topic, BagError, STORAGES
from observer_ros.bags.writing import TopicToWrite, write_bag
from observer_ros.wire.odometry import ODOMETRY


def missing_parents(path: Path) -> list:
    """Return the ancestors of ``path`` that do not exist yet, nearest first."""
    missing = []
    for parent in path.absolute().parents:
        if parent.exists():
            break
        missing.append(parent)
    return missing


def check_outputs(bag: Optional[str] = None, csv: Optional[str] = None,
                  report: Optional[str] = None, in_order: Optional[str] = None) -> None:
    """
    Check that the outputs of a replay can be written, before anything is.

    The bag must not exist, the CSV files (``csv``, ``in_order``) must not be
    directories, the report must be a directory (or not exist), none may name another,
    and each must land in a directory that can be created and written.

    Raises
    ------
    observer_ros.bags.storage.BagError
        The first output that cannot be written, naming its option.

    """
    named = [(option, Path(value)) for option, value in
             (('--output', bag), ('--csv', csv), ('--report', report),
              ('--in-order', in_order)) if value is not None]
    for index, (option, path) in enumerate(named):
        if option == '--output' and os.path.lexists(path):
            raise BagError(f'--output: {path} exists already; choose a new output path')
        if option in ('--csv', '--in-order') and path.is_dir():
            raise BagError(f'--csv: {path} is a directory; give a file name')
        if option == '--report' and path.exists() and not path.is_dir():
            raise BagError(f'--report: {path} is a file; give a directory')
        for other, other_path in named[index + 1:]:
            first, second = path.absolute(), other_path.absolute()
            if first == second or first in second.parents or second in first.parents:
                raise BagError(f'{option} {path} and {other} {other_path} overlap; give '
                               f'separate paths')
        check_writable_parent(option, path)


def check_writable_parent(option: str, path: Path) -> None:
    """Refuse ``path`` when it lands in a directory that cannot be created or written."""
    missing = missing_parents(path)
    existing = (missing[-1] if missing else path.absolute()).parent
    if not existing.is_dir():
        raise BagError(f'{option}: {existing} is not a directory')
    if not os.access(existing, os.W_OK | os.X_OK):
        raise BagError(f'{option}: cannot write in {existing}')


#: What ``covariance`` may ask of the CSV files: nothing, the variances, every entry.
COVARIANCE_COLUMNS = ('none', 'diagonal', 'full')


def _covariance_columns(names, covariances, covariance: str) -> tuple:
    """Return the header and ``(k, c)`` values of the covariance columns asked for."""
    if covariances is None or covariance == 'none':
        return [], None
    if covariance == 'diagonal':
        return ([f'variance_{name}' for name in names],
                np.diagonal(covariances, axis1=1, axis2=2))
    return ([f'covariance_{row}_{column}' for row in names for column in names],
            covariances.reshape(len(covariances), -1))


def _write_table(target: Path, header: list, stamps, labels, values) -> None:
    """Write a CSV to a scratch file renamed into place, with a plain open()'s mode."""
    directory = target.parent if str(target.parent) else Path('.')
    while True:  # like tempfile.mkstemp, but created 0666 & ~umask, not 0600
        scratch = directory / f'.{target.name}.{os.urandom(6).hex()}'
        try:
            handle = os.open(scratch, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)
            break
        except FileExistsError:
            continue
    try:
        with os.fdopen(handle, 'w', encoding='utf-8') as stream:
            stream.write(','.join(header) + '\n')
            for stamp, label, row in zip(stamps.tolist(), labels.tolist(), values.tolist()):
                stream.write(f'{stamp},{label},' + ','.join(map(repr, row)) + '\n')
        os.replace(scratch, target)
    finally:
        if os.path.exists(scratch):
            os.unlink(scratch)


def _write_csv(result: ReplayResult, target: Path, covariance: str = 'diagonal') -> None:
    """Write the published estimates: stamp, event, x_hat, innovation, covariance."""
    model = result.system.model
    extra, columns = _covariance_columns(model.state_names, result.covariances, covariance)
    header = ['stamp_ns', 'event', *model.state_names,
              *(f'innovation_{name}' for name in model.output_names), *extra]
    values = np.column_stack([result.estimates, result.innovations,
                              *([] if columns is None else [columns])])
    labels = result.events if result.events is not None else np.full(
        len(result.stamps_ns), 'y')
    _write_table(target, header, result.stamps_ns, labels, values)


def _write_in_order(result: ReplayResult, target: Path, covariance: str = 'diagonal') -> None:
    """Write the in-order estimates: stamp, the sources of its update, x_hat, covariance."""
    model, in_order = result.system.model, result.in_order
    extra, columns = _covariance_columns(model.state_names, in_order.covariances, covariance)
    header = ['stamp_ns', 'sources', *model.state_names, *extra]
    values = np.column_stack([in_order.estimates, *([] if columns is None else [columns])])
    _write_table(target, header, in_order.stamps_ns, in_order.events, values)


def write_replay(result: ReplayResult, bag: Optional[str] = None, csv: Optional[str] = None,
                 storage: str = 'mcap', innovation: bool = True,
                 in_order: Optional[str] = None, covariance: str = 'diagonal') -> None:
    """
    Write ``x_hat`` (and the innovation) to a new bag and/or CSV files.

    The bag's log times are the measurement stamps; with ``outputs.odometry.topic`` the bag
    also holds the ``nav_msgs/Odometry`` of each estimate on that topic. The CSV has a row
    per published estimate: ``stamp_ns``, ``event`` (what made the row: a measurement
    source's name, or ``y`` without sources; ``rerun``, the newest estimate again after a
    late sample; ``input``, released by the input it waited for; ``flush``, at the end of
    the bag), one column per state, ``innovation_<output>`` (empty outputs of a partial update are
    ``nan``), and where the filter has a covariance ``variance_<state>``
    (``covariance='full'``: ``covariance_<row>_<column>``, row-major; ``'none'``: no
    columns). ``in_order`` writes the estimates in stamp order after every late sample
    (``stamp_ns``, ``sources``: those of its update joined by ``+``, the states and the
    covariance columns). Every path is checked first (:func:`check_outputs`), each is
    written to a temporary name renamed into place, and when a later one fails the earlier
    are removed: an error leaves nothing behind. Files get the permissions a plain
    ``open()`` gives (the umask applies).

    Raises
    ------
    observer_ros.bags.storage.BagError
        An output that cannot be written, an unknown storage or covariance choice, or
        ``in_order`` for a result without in-order estimates.

    """
    check_outputs(bag, csv, None, in_order)
    if storage not in STORAGES:
        raise BagError(f'storage: expected one of {", ".join(STORAGES)}, got {storage!r}')
    if covariance not in COVARIANCE_COLUMNS:
        raise BagError(f'covariance: expected one of {", ".join(COVARIANCE_COLUMNS)}, got '
                       f'{covariance!r}')
    if in_order is not None and result.in_order is None:
        raise BagError('--in-order: this result has no in-order estimates (replay it with '
                       'replay_bag)')
    system = result.system
    estimate, innovations = system.topics['x_hat'], system.topics['innovation']
    written, made = [], made_directories(bag, csv, in_order)
    try:
        if bag is not None:
            topics = [TopicToWrite('/x_hat', estimate.type, estimate.field,
                                   system.model.state_names, result.stamps_ns,
                                   result.stamps_ns, result.estimates)]
            if innovation:
                topics.append(TopicToWrite(
                    '/innovation', innovations.type, innovations.field,
                    system.model.output_names, result.stamps_ns, result.stamps_ns,
                    result.innovations))
            if system.observer is not None and system.observer.odometry is not None:
                topics.append(odometry_topic(result, system.observer.odometry))
            write_bag(bag, topics, storage)
            written.append(Path(bag))
        for path, write in ((csv, _write_csv), (in_order, _write_in_order)):
            if path is not None:
                Path(path).absolute().parent.mkdir(parents=True, exist_ok=True)
                write(result, Path(path), covariance)
                written.append(Path(path))
    except BaseException:
        remove_outputs(written, made)
        raise


class OdometryTopicEncoder:
    """The encoder :func:`~observer_ros.bags.storage.write_bag` asks of an Odometry topic."""

    msgtype = ODOMETRY

    def __init__(self, output, covariances) -> None:
        from rosbags.typesys import get_typestore, Stores
        self.output, self.covariances = output, covariances
        self.typestore = get_typestore(Stores.ROS2_JAZZY)

    def encode(self, stamps_ns, estimates) -> list:
        """Return the serialized Odometry of each estimate."""
        encoder, covariances = self.output.encoder(), self.covariances
        return [self.output.encode(encoder, stamp, estimate,
                                   None if covariances is None else covariances[k])
                for k, (stamp, estimate) in enumerate(zip(stamps_ns.tolist(), estimates))]


@dataclass(frozen=True)
class EncodedTopic:
    """A topic :func:`~observer_ros.bags.storage.write_bag` writes with its own encoder."""

    topic: str
    encoder: object
    stamps_ns: np.ndarray
    log_times_ns: np.ndarray
    values: np.ndarray


def odometry_topic(result: ReplayResult, output) -> EncodedTopic:
    """
    Return the ``nav_msgs/Odometry`` topic of a replay's estimates (``outputs.odometry``).

    Its name is ``outputs.odometry.topic`` taken from the root; the covariance is the
    replay's ``P`` where the filter has one. ``/tf`` is not written: a bag replayed with
    ``ros2 bag play`` next to the node would give two parents of the child frame.
    """
    return EncodedTopic(absolute_topic(output.topic),
                        OdometryTopicEncoder(output, result.covariances),
                        result.stamps_ns, result.stamps_ns, result.estimates)


def made_directories(*paths) -> list:
    """Return the directories that writing ``paths`` creates, deepest first."""
    missing = {parent for path in paths if path is not None
               for parent in missing_parents(Path(path))}
    return sorted(missing, key=lambda directory: len(directory.parts), reverse=True)


def remove_outputs(written, directories=()) -> None:
    """Remove written outputs (files or bag directories), then emptied ``directories``."""
    for path in written:
        if path.is_dir() and not path.is_symlink():
            shutil.rmtree(path, ignore_errors=True)
        elif os.path.lexists(path):
            path.unlink()
    for directory in directories:  # deepest first; only what is left empty
        try:
            directory.rmdir()
        except OSError:
            continue


__all__ = ['COVARIANCE_COLUMNS', 'EncodedTopic', 'OdometryTopicEncoder', 'check_outputs',
           'check_writable_parent', 'made_directories', 'missing_parents', 'odometry_topic',
           'remove_outputs', 'write_replay']
