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

The estimates come from :meth:`observer_ros.core.streaming.StreamEstimator.replay`, the
observer node's pairing and stamp rules and :meth:`Estimator.advance` arithmetic, so they
equal what the node publishes for the same messages, bit for bit. Use :func:`replay_bag`
from your own tests::

    from observer_ros.bags.replay import replay_bag
    result = replay_bag('my_run', 'my_params.yaml')
    assert result.error_norms()[-1] < 1e-3  # against /x_true; or any check on the arrays
"""

from dataclasses import dataclass, field
import os
from pathlib import Path
import tempfile
from typing import Optional, Union

import numpy as np

from observer_ros.bags.storage import (
    read_topics, TopicData, TopicRequest, TopicToWrite, write_bag)
from observer_ros.core.config import load_parameter_file, System, validate_parameters
from observer_ros.core.evaluation import align
from observer_ros.core.streaming import StreamEstimator

NANOSECONDS = 1_000_000_000


def topic_request(system: System, key: str, topic: Optional[str] = None) -> TopicRequest:
    """Return what to read for the topic playing role ``key`` (``y``, ``u``, ``x_true`` ...)."""
    model = system.model
    names = {'y': model.output_names, 'u': model.input_names, 'u_cmd': model.input_names,
             'x_true': model.state_names, 'x_hat': model.state_names,
             'reference': model.output_names, 'innovation': model.output_names}[key]
    params = system.parameters
    return TopicRequest(topic or key, params[f'topics.{key}.type'],
                        params[f'topics.{key}.field'], names)


def topic_data(path, system: System, key: str, topic: Optional[str] = None) -> TopicData:
    """Read the bag topic playing role ``key`` of ``system``."""
    return read_topics(path, [topic_request(system, key, topic)])[0]


@dataclass
class ReplayResult:
    """Estimates of a replay, with what was read and the stream's counters."""

    system: System
    bag: str
    stamps_ns: np.ndarray
    estimates: np.ndarray
    innovations: np.ndarray
    outputs: TopicData
    inputs: TopicData
    counters: dict = field(default_factory=dict)

    def truth(self, topic: str = 'x_true') -> TopicData:
        """Read the true state (or another reference topic) from the bag."""
        return topic_data(self.bag, self.system, 'x_true', topic)

    def error_norms(self, topic: str = 'x_true') -> np.ndarray:
        """``||x_true - x_hat||`` at the stamps both have, in time order."""
        truth = self.truth(topic)
        _, reference, estimate = align(truth.stamps_ns, truth.values, self.stamps_ns,
                                       self.estimates)
        return np.linalg.norm(reference - estimate, axis=1)


def replay_bag(bag: Union[str, os.PathLike], parameters: Union[str, os.PathLike, System],
               y_topic: str = 'y', u_topic: str = 'u') -> ReplayResult:
    """
    Run the configured observer over a bag.

    Parameters
    ----------
    bag : path-like
        rosbag2 directory (MCAP or sqlite3).
    parameters : path-like or System
        Parameter file (``/**: ros__parameters:``) or an already validated system. Its
        ``topics.y.*`` and ``topics.u.*`` give the message types, fields and joint names.
    y_topic, u_topic : str
        Topic names in the bag (``y`` is ``/y``).

    Raises
    ------
    observer_ros.bags.storage.BagError
        The bag cannot give the topics (see :func:`observer_ros.bags.storage.read_topic`).
    observer_ros.core.errors.ConfigError
        A bad parameter file, naming the parameter.

    """
    system = parameters if isinstance(parameters, System) else validate_parameters(
        load_parameter_file(str(parameters)))
    if system.observer is None:
        from observer_ros.core.errors import ConfigError
        raise ConfigError('observer.poles', 'replay needs an observer: observer.poles, '
                          'observer.gain or the Kalman noise covariances')
    outputs, inputs = read_topics(bag, [topic_request(system, 'y', y_topic),
                                        topic_request(system, 'u', u_topic)])
    stream = StreamEstimator(system.make_estimator(),
                             int(system.parameters['observer.max_gap'] * NANOSECONDS),
                             input_stamped=system.parameters['topics.u.type'] == 'joint_state')
    result = stream.replay(inputs.stamps_ns, inputs.values, outputs.stamps_ns, outputs.values,
                           inputs.log_times_ns, outputs.log_times_ns)
    return ReplayResult(system, str(bag), result.stamps_ns, result.estimates,
                        result.innovations, outputs, inputs, dict(stream.counters))


def write_replay(result: ReplayResult, bag: Optional[str] = None, csv: Optional[str] = None,
                 storage: str = 'mcap', innovation: bool = True) -> None:
    """
    Write ``x_hat`` (and the innovation) to a new bag and/or a CSV file.

    The bag's log times are the measurement stamps; the CSV has ``stamp_ns`` and one column
    per state (then ``innovation_<output>``), written to a temporary file renamed into place.
    """
    system = result.system
    params = system.parameters
    if bag is not None:
        topics = [TopicToWrite('/x_hat', params['topics.x_hat.type'],
                               params['topics.x_hat.field'], system.model.state_names,
                               result.stamps_ns, result.stamps_ns, result.estimates)]
        if innovation:
            topics.append(TopicToWrite(
                '/innovation', params['topics.innovation.type'],
                params['topics.innovation.field'], system.model.output_names,
                result.stamps_ns, result.stamps_ns, result.innovations))
        write_bag(bag, topics, storage)
    if csv is not None:
        header = ['stamp_ns', *system.model.state_names,
                  *(f'innovation_{name}' for name in system.model.output_names)]
        target = Path(csv)
        handle, scratch = tempfile.mkstemp(prefix=f'.{target.name}.',
                                           dir=target.parent if str(target.parent) else '.')
        try:
            with os.fdopen(handle, 'w', encoding='utf-8') as stream:
                stream.write(','.join(header) + '\n')
                values = np.column_stack([result.estimates, result.innovations])
                for stamp, row in zip(result.stamps_ns.tolist(), values.tolist()):
                    stream.write(f'{stamp},' + ','.join(map(repr, row)) + '\n')
            os.replace(scratch, target)
        finally:
            if os.path.exists(scratch):
                os.unlink(scratch)
