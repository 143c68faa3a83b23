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
Innovations from recordings: each bag replayed with the filter, the task of one worker.

:func:`bag_innovations` replays one bag with the observer's own engine
(:func:`observer_ros.bags.replay.replay_bag`) and returns what tuning needs of it
(:class:`BagRun`: the innovations, the estimates, the segments, the sample period); it is
the task worker processes or a Dask cluster run, one per bag, and :func:`run_bags` runs it
over every bag through a ``mapper`` (:mod:`observer_ros.app.parallel`). A
:class:`SignalChoice` reads other topics than the parameter file's, by field path, in log
times or resampled. What tuning does with the runs is :mod:`observer_ros.bags.tuning`.
"""

from dataclasses import dataclass
from typing import Callable, Optional, Sequence

import numpy as np

from observer_ros.bags.filter_config import KalmanSetup, system_of
from observer_ros.bags.paired_signals import bag_signals
from observer_ros.bags.replay import replay_bag, replay_data
from observer_ros.bags.signals import PERIOD_TOLERANCE, read_signals, SignalSpec
from observer_ros.bags.storage import BagError, TopicData
from observer_ros.config.schema import topic_names
from observer_ros.core.errors import ConfigError
from observer_ros.core.rules import in_sequence
from observer_ros.wire import lookup


#: What a refusal of two time bases tells to do.
LOG_TIME_ADVICE = 'use log times for both (tune_kalman --use-log-time)'


@dataclass(frozen=True)
class BagRun:
    """
    One bag replayed: the innovations and what the report shows of the run.

    Attributes
    ----------
    bag : str
    stamps_ns : numpy.ndarray of int64, shape (k,)
    innovations : numpy.ndarray, shape (k, p)
    estimates : numpy.ndarray, shape (k, n)
    starts : numpy.ndarray of int
        Index of the first sample of each segment.
    period_ns : int
        Median sample interval within segments.
    truth_stamps_ns, truth : numpy.ndarray or None
        The bag's ``x_true``, when it has one.

    """

    bag: str
    stamps_ns: np.ndarray
    innovations: np.ndarray
    estimates: np.ndarray
    starts: np.ndarray
    period_ns: int
    truth_stamps_ns: Optional[np.ndarray] = None
    truth: Optional[np.ndarray] = None

    def segments(self) -> list:
        """Return the ``slice`` of each segment."""
        ends = list(self.starts[1:]) + [len(self.stamps_ns)]
        return [slice(int(a), int(b)) for a, b in zip(self.starts, ends)]


def segment_starts(stamps_ns: np.ndarray, max_gap_ns: int) -> np.ndarray:
    """Return where the filter (re)starts: index 0 and every step out of sequence."""
    broken = ~in_sequence(np.diff(stamps_ns), max_gap_ns)
    return np.concatenate([[0], np.nonzero(broken)[0] + 1]).astype(np.int64)


def _finite(bag: str, role: str, values: np.ndarray, stamps: np.ndarray) -> None:
    bad = ~np.isfinite(values).all(axis=1)
    if bad.any():
        first = int(np.argmax(bad))
        raise BagError(f'{bag}: {role}: {int(bad.sum())} of {len(values)} samples are not '
                       f'finite (NaN or inf; the first stamped {stamps[first]} ns); clean or '
                       f'cut the recording: tuning needs every sample')


@dataclass(frozen=True)
class SignalChoice:
    """
    What to read of each bag instead of the parameter file's ``y`` and ``u`` topics.

    Attributes
    ----------
    inputs, outputs : tuple of SignalSpec
        Read as ``identify`` reads them (:func:`observer_ros.bags.signals.read_signals`);
        empty: the file's ``topics.u`` / ``topics.y`` on the ``u`` / ``y`` topic.
    use_log_time : bool
        Stamp every topic with its log times.
    resample : str or None
        A rate in Hz, or ``auto``: the measurements put onto a uniform grid as ``identify
        --resample`` puts them (inputs zero-order held, outputs linearly interpolated).

    """

    inputs: tuple = ()
    outputs: tuple = ()
    use_log_time: bool = False
    resample: Optional[str] = None

    @property
    def reads_specs(self) -> bool:
        """Whether the bag is read by signal specs (else as the observer's file says)."""
        return bool(self.inputs or self.outputs or self.resample)


def file_spec(system, key: str, topic: str) -> SignalSpec:
    """Return the SignalSpec of what the file's ``topics.<key>`` reads from ``topic``."""
    settings = system.topics[key]
    if key == 'u' and settings.fields:
        return SignalSpec(topic, ','.join(settings.fields))
    if lookup(settings.type).named:
        return SignalSpec(topic, settings.field, tuple(topic_names(system.model, key)))
    return SignalSpec(topic)


def _width(option: str, specs, requests, found: int, wanted: int, names) -> None:
    if found != wanted:
        read = ', '.join(name for request in requests for name in request.names)
        raise ConfigError(option, f'{", ".join(spec_text(spec) for spec in specs)} gives '
                          f'{found} value{"" if found == 1 else "s"} ({read}); the model has '
                          f'{wanted} ({", ".join(names)}): name one field per model entry, in '
                          f'model order')


def spec_text(spec: SignalSpec) -> str:
    """Return a SignalSpec as the command line writes it."""
    parts = [spec.topic] + ([spec.field] if spec.field else []) + (
        [','.join(spec.joints)] if spec.joints else [])
    return ':'.join(parts)


def chosen_data(bag: str, system, choice: SignalChoice, y_topic: str, u_topic: str) -> tuple:
    """
    Read ``(outputs, inputs, breaks)`` of one bag as ``choice`` says, for :func:`replay_data`.

    ``breaks`` are the stamps that start a stretch of the resampled grid (each one a
    segment of its own, as after a gap; empty without resampling).

    Raises
    ------
    ConfigError
        Naming ``--inputs`` or ``--outputs``: more than one input topic (the observer reads
        ``u`` from one), or a count of values other than the model's.
    BagError
        Topics the bag cannot give, outputs not stamped together, uneven sampling (with
        ``resample``: what :func:`observer_ros.bags.paired_signals.bag_signals` refuses).

    """
    model = system.model
    inputs = choice.inputs or ((file_spec(system, 'u', u_topic),) if model.n_inputs else ())
    outputs = choice.outputs or (file_spec(system, 'y', y_topic),)
    if len(inputs) > 1:
        raise ConfigError('--inputs', f'{len(inputs)} topics given '
                          f'({", ".join(spec_text(spec) for spec in inputs)}); the observer '
                          f'reads every input from one topic: name them all on it, '
                          f'TOPIC:PATH[,PATH...]')
    if inputs and not model.n_inputs:
        raise ConfigError('--inputs', f'the model has no inputs; got '
                          f'{spec_text(inputs[0])}')
    if choice.resample:
        paired = bag_signals(bag, inputs, outputs, choice.use_log_time, choice.resample,
                             'tune_kalman')
        _width('--inputs', inputs, paired.input_topics, paired.inputs.shape[1],
               model.n_inputs, model.input_names)
        _width('--outputs', outputs, paired.output_topics, paired.outputs.shape[1],
               model.n_outputs, model.output_names)
        stamps = paired.stamps_ns  # each held input stamped at its grid point
        return (TopicData(stamps, stamps, paired.outputs),
                TopicData(stamps, stamps, paired.inputs), stamps[paired.starts])
    read = read_signals(bag, (*inputs, *outputs))
    input_read, output_read = read[:len(inputs)], read[len(inputs):]
    first_request, first = output_read[0]
    for request, data in output_read[1:]:
        if not np.array_equal(data.stamps_ns, first.stamps_ns):
            raise BagError(f'{bag}: --outputs: {request.topic} ({len(data.stamps_ns)} messages) '
                           f'is not stamped like {first_request.topic} '
                           f'({len(first.stamps_ns)}); tune_kalman updates every output at '
                           f'each sample, so the output topics must be sampled together: '
                           f'record the outputs on one topic, resample them onto one grid '
                           f'(--resample), or tune a model of the outputs of one topic')
    values = np.hstack([data.values for _, data in output_read])
    _width('--outputs', outputs, [r for r, _ in output_read], values.shape[1],
           model.n_outputs, model.output_names)
    output_data = TopicData(first.stamps_ns, first.log_times_ns, values)
    none = np.zeros(0, np.int64)
    if not inputs:
        return output_data, TopicData(none, none, np.zeros((0, 0))), none
    request, input_data = input_read[0]
    _width('--inputs', inputs, [request], input_data.values.shape[1], model.n_inputs,
           model.input_names)
    return output_data, input_data, none


def bag_innovations(bag: str, parameters: dict, y_topic: str = 'y', u_topic: str = 'u',
                    truth_topic: Optional[str] = None,
                    choice: Optional[SignalChoice] = None) -> BagRun:
    """
    Replay one bag with the filter of ``parameters`` (flat); the task of one worker.

    ``choice`` reads other topics, by field path, in log times or resampled
    (:class:`SignalChoice`); by default the file's ``y`` and ``u``.

    Raises
    ------
    BagError
        The bag cannot give the topics, holds a sample that is not finite, its inputs are
        stamped in another time base than its measurements, or its sample intervals are not
        even within :data:`PERIOD_TOLERANCE`.

    """
    system = system_of(parameters)
    choice = choice or SignalChoice()
    if choice.reads_specs or system.topics['u'].fields:  # a twist u: by its field paths
        outputs, inputs, breaks = chosen_data(bag, system, choice, y_topic, u_topic)
        result = replay_data(bag, system, outputs, inputs, choice.use_log_time,
                             choice.outputs[0].topic if choice.outputs else y_topic,
                             choice.inputs[0].topic if choice.inputs else u_topic,
                             LOG_TIME_ADVICE)
    else:
        breaks = np.zeros(0, np.int64)
        result = replay_bag(bag, system, y_topic, u_topic, choice.use_log_time)
    if result.warnings:  # inputs in another clock: every interval with the wrong input
        raise BagError(f'{result.warnings[0]}; tuning needs the inputs in the clock of the '
                       f'measurements (tune_kalman --use-log-time)')
    _finite(bag, f'topic {y_topic}', result.outputs.values, result.outputs.stamps_ns)
    if len(result.inputs.values):
        _finite(bag, f'topic {u_topic}', result.inputs.values, result.inputs.stamps_ns)
    if len(result.stamps_ns) < 2:
        raise BagError(f'{bag}: {len(result.stamps_ns)} estimates; too short to tune from')
    max_gap_ns = system.observer.max_gap_ns
    starts = segment_starts(result.stamps_ns, max_gap_ns)
    if len(breaks):  # each stretch of a resampled grid is a segment of its own
        starts = np.union1d(starts, np.nonzero(np.isin(result.stamps_ns, breaks))[0])
    steps = np.diff(result.stamps_ns)
    inside = np.ones(len(steps), dtype=bool)
    inside[starts[1:] - 1] = False
    if not inside.any():
        raise BagError(f'{bag}: no two samples follow each other within observer.max_gap')
    period = int(np.median(steps[inside]))
    uneven = np.abs(steps[inside] - period) > PERIOD_TOLERANCE * period
    if uneven.any():
        raise BagError(f'{bag}: {int(uneven.sum())} of {int(inside.sum())} sample intervals '
                       f'differ from the median {period / 1e6:g} ms by more than '
                       f'{PERIOD_TOLERANCE:.0%}; tuning takes one sample period: resample '
                       f'onto a uniform grid (tune_kalman --resample auto, or --resample RATE '
                       f'in Hz) or cut the recording')
    truth_stamps = truth = None
    if truth_topic:
        try:
            data = result.truth(truth_topic)
            truth_stamps, truth = data.stamps_ns, data.values
        except BagError:
            pass  # no reference in this bag
    return BagRun(str(bag), result.stamps_ns, result.innovations, result.estimates, starts,
                  period, truth_stamps, truth)


def run_bags(mapper: Callable, bags: Sequence[str], setup: KalmanSetup, y_topic: str,
             u_topic: str, label: str, truth_topic: Optional[str] = None,
             choice: Optional[SignalChoice] = None) -> list:
    """Replay every bag with ``setup``'s filter through ``mapper``; results in bag order."""
    tasks = [(bag, setup.parameters, y_topic, u_topic, truth_topic, choice) for bag in bags]
    return list(mapper(_bag_task, tasks, label))


def _bag_task(task: tuple) -> BagRun:
    return bag_innovations(*task)


__all__ = ['BagRun', 'LOG_TIME_ADVICE', 'PERIOD_TOLERANCE', 'SignalChoice', 'bag_innovations',
           'chosen_data', 'file_spec', 'run_bags', 'segment_starts', 'spec_text']
