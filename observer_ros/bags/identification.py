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
Models from recordings: inputs and outputs read from bags, subspace identification, fit.

:func:`bag_signals` reads one bag's input and output topics (the task of one worker) and
pairs them with the event engine's rule (each measurement with the latest input stamped at
or before it, :class:`~observer_ros.core.rules.InputHistory`); a gap splits a bag into
records. :func:`identify_bags` keeps the last ``holdout`` of every record for validation,
identifies from the rest (:func:`observer_ros.core.tuning.subspace.identify_subspace`) and
scores the model on the held-out part.
"""

from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np

from observer_ros.bags.replay import check_time_bases, log_timed
from observer_ros.bags.storage import (
    absolute_topic, BagError, Playback, read_topics, topic_layout, TopicData, TopicRequest)
from observer_ros.bags.tuning import PERIOD_TOLERANCE
from observer_ros.config.schema import FIELD_MESSAGE_TYPES
from observer_ros.core.errors import ConfigError
from observer_ros.core.rules import InputHistory
from observer_ros.core.tuning.subspace import (
    fit_percent, identify_subspace, Record, SubspaceModel, to_continuous, validate)
from observer_ros.ros.cdr import (
    DecodeError, field_names, FieldPathError, FieldReader, MESSAGE_TYPES)

#: A step longer than this many sample periods splits a bag into records.
GAP_PERIODS = 1.5

#: Default fraction of each record held out for validation.
HOLDOUT = 0.3


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
        if msgtype in MESSAGE_TYPES.values():
            field = self.field or 'position'
            found = topic_layout(bag, self.topic, field)
            return TopicRequest(found.topic, found.kind, field, self.joints or found.names)
        kinds = {full: kind for kind, full in FIELD_MESSAGE_TYPES.items()}
        kind = kinds.get(msgtype)
        if kind is None:
            raise BagError(f'{bag}: topic {self.topic} holds {msgtype}; expected one of '
                           f'{", ".join(sorted(kinds))}')
        if not self.field or self.joints:
            raise BagError(f'{bag}: topic {self.topic} holds {msgtype}: name its field paths, '
                           f'TOPIC:PATH[,PATH...]; it has {", ".join(field_names(msgtype))}')
        fields = tuple(self.field.split(','))
        try:
            FieldReader(msgtype, fields)
        except FieldPathError as e:
            raise BagError(f'{bag}: topic {self.topic}: {e}') from e
        return FieldRequest(absolute_topic(self.topic), kind, msgtype, fields)


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


@dataclass(frozen=True)
class BagSignals:
    """One bag's paired samples: stamps, inputs, outputs, record starts, period."""

    bag: str
    stamps_ns: np.ndarray
    inputs: np.ndarray
    outputs: np.ndarray
    starts: np.ndarray
    period_ns: int
    input_names: tuple
    output_names: tuple
    input_topics: tuple  # the TopicRequest of each input topic
    output_topics: tuple

    def records(self) -> list:
        """Return ``(stamps, Record)`` of each stretch between gaps."""
        ends = list(self.starts[1:]) + [len(self.stamps_ns)]
        return [(self.stamps_ns[a:b], Record(self.inputs[a:b], self.outputs[a:b]))
                for a, b in zip(self.starts, ends)]


def _finite(bag, what, values, stamps) -> None:
    bad = ~np.isfinite(values).all(axis=1)
    if bad.any():
        raise BagError(f'{bag}: {what}: {int(bad.sum())} of {len(values)} samples are not '
                       f'finite (NaN or inf; the first stamped {stamps[int(np.argmax(bad))]} '
                       f'ns); clean or cut the recording')


def bag_signals(bag: str, inputs: Sequence[SignalSpec], outputs: Sequence[SignalSpec],
                use_log_time: bool = False) -> BagSignals:
    """
    Read and pair one bag's inputs and outputs; the task of one worker.

    With ``use_log_time`` every topic is stamped with its log times (the recorder's clock)
    instead of its header stamps.

    Raises
    ------
    BagError
        Missing topics, NaN, inputs and outputs stamped in different time bases, no
        measurement after the first input, uneven sampling.

    """
    requests = [spec.request(bag) for spec in (*inputs, *outputs)]
    vectors = [request for request in requests if isinstance(request, TopicRequest)]
    read = dict(zip(map(id, vectors), read_topics(bag, vectors))) if vectors else {}
    data = [read[id(request)] if isinstance(request, TopicRequest) else read_fields(bag, request)
            for request in requests]
    if use_log_time:
        data = [log_timed(item) for item in data]
    input_data, output_data = data[:len(inputs)], data[len(inputs):]
    for request, item in zip(requests, data):
        _finite(bag, f'topic {request.topic}', item.values, item.stamps_ns)
    stamps = output_data[0].stamps_ns
    steps = np.diff(stamps)
    gap_ns = GAP_PERIODS * int(np.median(steps)) if len(steps) else 0
    for request, item in zip(requests, input_data):
        check_time_bases(output_data[0], item, gap_ns, str(bag), requests[len(inputs)].topic,
                         request.topic,
                         'use log times for both (identify --use-log-time)')
    for request, item in zip(requests[len(inputs) + 1:], output_data[1:]):
        if not np.array_equal(item.stamps_ns, stamps):
            raise BagError(f'{bag}: topic {request.topic} is not stamped like '
                           f'{requests[len(inputs)].topic}; outputs must be sampled together')
    y = np.hstack([item.values for item in output_data])
    columns = []
    keep = np.ones(len(stamps), dtype=bool)
    for request, item in zip(requests, input_data):
        history = InputHistory()
        for stamp, value in zip(item.stamps_ns.tolist(), item.values):
            history.store(stamp, value)
        index = history.indices_at(stamps)
        keep &= index >= 0
        columns.append(np.array(history.values)[np.maximum(index, 0)])
    if not keep.any():
        raise BagError(f'{bag}: no measurement after the first input')
    u = np.hstack(columns)[keep] if columns else np.zeros((int(keep.sum()), 0))
    stamps, y = stamps[keep], y[keep]
    steps = np.diff(stamps)
    if not len(steps) or (steps <= 0).any():
        raise BagError(f'{bag}: the measurement stamps do not increase')
    period = int(np.median(steps))
    starts = np.concatenate([[0], np.nonzero(steps > GAP_PERIODS * period)[0] + 1])
    inside = np.ones(len(steps), dtype=bool)
    inside[starts[1:] - 1] = False
    uneven = np.abs(steps[inside] - period) > PERIOD_TOLERANCE * period
    if uneven.any():
        raise BagError(f'{bag}: {int(uneven.sum())} sample intervals differ from the median '
                       f'{period / 1e6:g} ms by more than {PERIOD_TOLERANCE:.0%}; '
                       f'identification takes one sample period')
    input_names = tuple(name for request in requests[:len(inputs)] for name in request.names)
    output_names = tuple(name for request in requests[len(inputs):] for name in request.names)
    return BagSignals(str(bag), stamps, u, y, starts.astype(np.int64), period, input_names,
                      output_names, tuple(requests[:len(inputs)]),
                      tuple(requests[len(inputs):]))


def _signals_task(task: tuple) -> BagSignals:
    return bag_signals(*task)


@dataclass(frozen=True)
class Identification:
    """An identification run: the model, its fit on the held-out data and what it used."""

    model: SubspaceModel
    continuous: Optional[tuple]  # (A, B) when asked for
    fit: np.ndarray
    validation: list  # (stamps, measured, simulated) per held-out record
    signals: list
    period_ns: int
    residual_covariance: np.ndarray
    estimation_samples: int
    validation_samples: int


def identify_bags(bags: Sequence[str], inputs: Sequence[SignalSpec],
                  outputs: Sequence[SignalSpec], order: int, mapper: Callable,
                  holdout: float = HOLDOUT, horizon: Optional[int] = None,
                  continuous: bool = False, use_log_time: bool = False,
                  feedthrough: str = 'fit') -> Identification:
    """
    Identify a model of ``order`` from the bags and score it on their held-out parts.

    ``feedthrough`` (``fit`` or ``zero``): ``D`` fitted, or fixed at zero
    (:func:`~observer_ros.core.tuning.subspace.identify_subspace`).

    Raises
    ------
    BagError, ConfigError, DesignError
        Unusable bags (naming the cause), too little data for the order and horizon, no
        excitation, a model with no continuous counterpart.

    """
    if not 0 < holdout < 1:
        raise ConfigError('--holdout', f'expected a fraction in (0, 1), got {holdout}')
    signals = list(mapper(_signals_task, [(bag, tuple(inputs), tuple(outputs), use_log_time)
                                          for bag in bags], 'read'))
    first = signals[0]
    for item in signals[1:]:
        if (item.input_names, item.output_names) != (first.input_names, first.output_names):
            raise BagError(f'{item.bag}: holds inputs {list(item.input_names)} and outputs '
                           f'{list(item.output_names)}, {first.bag} holds '
                           f'{list(first.input_names)} and {list(first.output_names)}')
    periods = [item.period_ns for item in signals]
    period = int(np.median(periods))
    for item in signals:
        if abs(item.period_ns - period) > PERIOD_TOLERANCE * period:
            raise BagError(f'{item.bag}: sampled every {item.period_ns / 1e6:g} ms, the other '
                           f'bags every {period / 1e6:g} ms; identify from bags of one rate')
    estimation, held_out = [], []
    for item in signals:
        for stamps, record in item.records():
            split = int(round(len(stamps) * (1 - holdout)))
            estimation.append(Record(record.inputs[:split], record.outputs[:split]))
            held_out.append((stamps[split:], Record(record.inputs[split:],
                                                    record.outputs[split:])))
    dt = period / 1e9
    model = identify_subspace(estimation, order, dt, horizon, first.input_names, feedthrough)
    validation = []
    for stamps, record in held_out:
        if len(stamps) <= 2 * order:
            continue
        simulated, _ = validate(model, record)
        validation.append((stamps, record.outputs, simulated))
    if not validation:
        raise BagError('no held-out data long enough to validate on; record longer or raise '
                       '--holdout')
    measured = np.concatenate([v[1] for v in validation])
    simulated = np.concatenate([v[2] for v in validation])
    fit = fit_percent(measured, simulated)
    residuals = np.concatenate([
        record.outputs - model.simulate(record.inputs, x0)
        for record, x0 in zip(estimation, model.initial_states)])
    covariance = np.atleast_2d(np.cov(residuals.T))
    converted = to_continuous(model.a, model.b, dt) if continuous else None
    return Identification(model, converted, fit, validation, signals, period, covariance,
                          sum(len(r.inputs) for r in estimation), len(measured))


__all__ = ['BagSignals', 'GAP_PERIODS', 'HOLDOUT', 'Identification', 'SignalSpec',
           'bag_signals', 'identify_bags']
