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
The results of a replay: the estimates and what was read, in stamp order, and against references.

:class:`ReplayResult` is what :func:`observer_ros.bags.replay.replay_bag` returns (with its
:class:`InOrderEstimates`); :class:`StateReference` and :func:`reference_rmse` compare one
state with a recorded joint (``replay --reference``). Writing the results to a bag or a CSV
file is :mod:`observer_ros.bags.replay_outputs`.
"""

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from observer_ros.bags.reading import read_topics, TopicRequest
from observer_ros.bags.replay_reading import topic_data
from observer_ros.bags.storage import BagError, TopicData
from observer_ros.bags.time_bases import log_timed
from observer_ros.config import Configuration
from observer_ros.config.schema import JOINT_STATE_FIELDS
from observer_ros.core.evaluation import align
from observer_ros.core.units import seconds_to_ns


@dataclass(frozen=True)
class InOrderEstimates:
    """
    The estimate at each stamp once every late sample is in, in stamp order.

    What the node's history holds when no later sample can change it: the estimates the
    stream computed again after a late measurement but published only for the newest stamp
    (see ``doc/measurement_sources.md``).

    Attributes
    ----------
    stamps_ns : numpy.ndarray of int64, shape (k,)
    estimates : numpy.ndarray, shape (k, n)
    covariances : numpy.ndarray or None, shape (k, n, n)
    events : numpy.ndarray of str, shape (k,)
        The sources whose samples made each update, joined by ``+``.

    """

    stamps_ns: np.ndarray
    estimates: np.ndarray
    covariances: Optional[np.ndarray]
    events: np.ndarray


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
    warnings : tuple of str
        What the observer node would warn of
        (:func:`~observer_ros.bags.time_bases.stream_warnings`): inputs stamped in another
        time base than the measurements, with what to do.
    events : numpy.ndarray of str or None, shape (k,)
        What made each estimate: the name of the measurement source whose sample it is the
        estimate of (``y`` without sources), ``rerun`` (the newest estimate again, corrected
        after a late sample), ``input`` (released by the input it waited for), ``flush``
        (released at the end of the bag with the inputs at hand).
    in_order : InOrderEstimates or None
        The estimates in stamp order after every late sample.

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
    warnings: tuple = ()
    events: Optional[np.ndarray] = None
    in_order: Optional[InOrderEstimates] = None

    def truth(self, topic: str = 'x_true') -> TopicData:
        """Read the true state (or another reference topic) from the bag, in the replay's time."""
        data = topic_data(self.bag, self.system, 'x_true', topic)
        return log_timed(data) if self.use_log_time else data

    def error_norms(self, topic: str = 'x_true') -> np.ndarray:
        """``||x_true - x_hat||`` at the stamps both have, in time order."""
        truth = self.truth(topic)
        _, reference, estimate = align(truth.stamps_ns, truth.values, self.stamps_ns,
                                       self.estimates)
        estimate = self.system.observer.angles.states_near(estimate, reference)
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
        keep = stamps >= stamps[0] + seconds_to_ns(settle_s, 'settle_s')
        stamps, truth, estimate = stamps[keep], truth[keep], estimate[keep]
    if not len(stamps):
        raise BagError(f'{result.bag}: --reference: {reference.topic} and the estimates '
                       f'share no stamp (after {settle_s:g} s of settling)')
    return float(np.sqrt(np.mean((truth - estimate) ** 2))), len(stamps)
