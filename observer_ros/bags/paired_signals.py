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
One bag's inputs and outputs, read and paired: a measurement with the input in effect.

:func:`bag_signals` reads one bag's input and output topics (the task of one worker,
through :func:`observer_ros.bags.signals.read_signals`) and pairs them with the event
engine's rule (each measurement with the latest input stamped at or before it,
:class:`~observer_ros.core.rules.InputHistory`); a gap splits a bag into records. Both
``identify`` (:mod:`observer_ros.bags.identification`) and ``tune_kalman`` read bags so.

Identification and tuning take one sample period. Measurements whose intervals jitter by
more than :data:`~observer_ros.bags.signals.PERIOD_TOLERANCE` (a simulator's
``/joint_states``) are refused, unless ``resample`` puts each record onto a uniform grid
(:func:`resample`): the inputs zero-order held (the latest input stamped at or before each
grid time, as a command is applied), the outputs linearly interpolated between the two
measurements around it. :class:`Resampling` says what that did: the raw intervals, and the
error of the grid interpolated back to the measured stamps.
"""

from dataclasses import dataclass, replace
from typing import Optional, Sequence, Union

import numpy as np

from observer_ros.bags.signals import PERIOD_TOLERANCE, read_signals, SignalSpec
from observer_ros.bags.storage import BagError
from observer_ros.bags.time_bases import check_time_bases, log_timed
from observer_ros.core.errors import ConfigError
from observer_ros.core.rules import InputHistory
from observer_ros.core.tuning.identified_model import Record
from observer_ros.core.units import NANOSECONDS, rate_to_period_ns


#: A step longer than this many sample periods splits a bag into records.
GAP_PERIODS = 1.5

#: ``resample='auto'``: the grid period is the median measurement interval.
AUTO = 'auto'

#: Resampling interpolates across measurement gaps up to this many grid periods (or median
#: measurement intervals, if longer); a longer gap starts a new record.
RESAMPLE_GAP_PERIODS = 3


def resample_period(rate: Union[None, str, float], median_ns: int) -> Optional[int]:
    """
    Return the grid period (ns) of a ``--resample`` value: a rate in Hz, or ``auto``.

    Raises
    ------
    ConfigError
        Naming ``--resample``: not ``auto`` nor a positive finite rate.

    """
    if rate is None:
        return None
    if rate == AUTO:
        return int(median_ns)
    try:
        hertz = float(rate)
    except (TypeError, ValueError):
        hertz = float('nan')
    if not np.isfinite(hertz) or hertz <= 0 or NANOSECONDS / hertz < 1:
        raise ConfigError('--resample', f'expected a rate in Hz (> 0) or {AUTO}, got {rate!r}')
    return rate_to_period_ns(hertz, '--resample')


@dataclass(frozen=True)
class Resampling:
    """
    What resampling onto a uniform grid did to one bag.

    Attributes
    ----------
    period_ns : int
        The grid period.
    raw_samples, samples : int
        Measurements paired with an input, and grid points made from them.
    raw_median_ns, raw_min_ns, raw_max_ns : int
        The measured intervals within the grid's records.
    uneven : int
        Measured intervals off the median by more than ``PERIOD_TOLERANCE``.
    interpolation_rms : numpy.ndarray, shape (p,)
        RMS of ``y - interp(grid, y_grid)(t)`` at the measured stamps ``t`` inside the grid:
        what the grid loses of each output (0 when it holds every measurement).
    output_rms : numpy.ndarray, shape (p,)
        RMS of each output about its mean, to judge the error against.
    records : int
        Stretches of grid: a measurement gap longer than :data:`RESAMPLE_GAP_PERIODS`
        periods starts a new one.

    """

    period_ns: int
    raw_samples: int
    samples: int
    raw_median_ns: int
    raw_min_ns: int
    raw_max_ns: int
    uneven: int
    interpolation_rms: np.ndarray
    output_rms: np.ndarray
    records: int = 1


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
    resampling: Optional[Resampling] = None
    raw: Optional['BagSignals'] = None  # the measured samples, when resampled

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


def _inside(steps: np.ndarray, starts: np.ndarray) -> np.ndarray:
    inside = np.ones(len(steps), dtype=bool)
    inside[starts[1:] - 1] = False
    return inside


def resample(signals: BagSignals, histories: Sequence[InputHistory],
             period_ns: int) -> BagSignals:
    """
    Put each record of ``signals`` onto a uniform grid of ``period_ns``.

    A record here ends at a measurement gap longer than :data:`RESAMPLE_GAP_PERIODS` grid
    periods (or median measurement intervals, whichever is longer): shorter gaps, the
    jitter of a simulator's or a recorder's clock, are interpolated across. Each record's
    grid starts at its first measurement and ends at or before its last. The inputs are
    zero-order held: at each grid time, the latest input stamped at or before it
    (``histories``, one per input topic, as the pairing rule holds them). The outputs are
    linearly interpolated between the measurements around it (no anti-alias filter: a grid
    coarser than the measurements drops what lies between its points).

    Raises
    ------
    BagError
        A record too short to hold two grid points.

    """
    stamps, outputs = signals.stamps_ns, signals.outputs
    steps = np.diff(stamps)
    median = int(np.median(steps))
    gap_ns = RESAMPLE_GAP_PERIODS * max(int(period_ns), median)
    starts = np.concatenate([[0], np.nonzero(steps > gap_ns)[0] + 1]).astype(np.int64)
    ends = list(starts[1:]) + [len(stamps)]
    grids, values, grid_starts, back, measured = [], [], [], [], []
    for a, b in zip(starts, ends):
        times, record = stamps[a:b], outputs[a:b]
        grid = times[0] + period_ns * np.arange((times[-1] - times[0]) // period_ns + 1,
                                                dtype=np.int64)
        if len(grid) < 2:
            continue
        grid_starts.append(sum(len(g) for g in grids))
        grids.append(grid)
        relative = (times - times[0]).astype(float)
        points = (grid - times[0]).astype(float)
        y = np.column_stack([np.interp(points, relative, column) for column in record.T])
        values.append(y)
        inner = relative <= points[-1]
        back.append(np.column_stack([np.interp(relative[inner], points, column)
                                     for column in y.T]))
        measured.append(record[inner])
    if not grids:
        raise BagError(f'{signals.bag}: no record spans two periods of the '
                       f'{period_ns / 1e6:g} ms grid; resample at a higher rate')
    grid = np.concatenate(grids)
    columns = [np.array(history.values)[history.indices_at(grid)] for history in histories]
    u = np.hstack(columns) if columns else np.zeros((len(grid), 0))
    inside = steps[_inside(steps, starts)]
    error = np.concatenate(measured) - np.concatenate(back)
    note = Resampling(int(period_ns), len(stamps), len(grid), median,
                      int(inside.min()) if len(inside) else median,
                      int(inside.max()) if len(inside) else median,
                      int((np.abs(inside - median) > PERIOD_TOLERANCE * median).sum()),
                      np.sqrt(np.mean(error ** 2, axis=0)), np.std(outputs, axis=0),
                      len(grids))
    return replace(signals, stamps_ns=grid, inputs=u, outputs=np.concatenate(values),
                   starts=np.array(grid_starts, dtype=np.int64), period_ns=int(period_ns),
                   resampling=note, raw=signals)


def _interpolated(bag, topic: str, data, stamps: np.ndarray) -> np.ndarray:
    """Return ``data`` linearly interpolated at ``stamps`` (ns), column by column."""
    order = np.argsort(data.stamps_ns, kind='stable')
    times = data.stamps_ns[order]
    if len(times) < 2 or (np.diff(times) <= 0).any():
        raise BagError(f'{bag}: topic {topic}: the stamps do not increase; it cannot be '
                       f'interpolated onto the grid')
    origin = times[0]
    return np.column_stack([np.interp((stamps - origin).astype(float),
                                      (times - origin).astype(float), column)
                            for column in data.values[order].T])


def bag_signals(bag: str, inputs: Sequence[SignalSpec], outputs: Sequence[SignalSpec],
                use_log_time: bool = False,
                resample_rate: Union[None, str, float] = None,
                tool: str = 'identify') -> BagSignals:
    """
    Read and pair one bag's inputs and outputs; the task of one worker.

    With ``use_log_time`` every topic is stamped with its log times (the recorder's clock)
    instead of its header stamps. With ``resample_rate`` (Hz, or ``'auto'`` for the median
    measurement interval) the records are put onto a uniform grid (:func:`resample`); output
    topics stamped unlike the first are then linearly interpolated at its stamps first.
    ``tool`` is the command the time-base advice names.

    Raises
    ------
    BagError
        Missing topics, NaN, inputs and outputs stamped in different time bases, no
        measurement after the first input, uneven sampling (without ``resample_rate``).

    """
    read = read_signals(bag, (*inputs, *outputs))
    requests = [request for request, _ in read]
    data = [item for _, item in read]
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
                         f'use log times for both ({tool} --use-log-time)')
    keep = np.ones(len(stamps), dtype=bool)
    values = [output_data[0].values]
    for request, item in zip(requests[len(inputs) + 1:], output_data[1:]):
        if np.array_equal(item.stamps_ns, stamps):
            values.append(item.values)
        elif resample_rate is None:
            raise BagError(f'{bag}: topic {request.topic} is not stamped like '
                           f'{requests[len(inputs)].topic}; outputs must be sampled together, '
                           f'or resampled onto one grid (--resample RATE or auto)')
        else:  # interpolated at the first output's stamps, inside its own span
            values.append(_interpolated(bag, request.topic, item, stamps))
            keep &= (stamps >= item.stamps_ns.min()) & (stamps <= item.stamps_ns.max())
    y = np.hstack(values)
    columns, histories = [], []
    for request, item in zip(requests, input_data):
        history = InputHistory()
        for stamp, value in zip(item.stamps_ns.tolist(), item.values):
            history.store(stamp, value)
        histories.append(history)
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
    input_names = tuple(name for request in requests[:len(inputs)] for name in request.names)
    output_names = tuple(name for request in requests[len(inputs):] for name in request.names)
    signals = BagSignals(str(bag), stamps, u, y, starts.astype(np.int64), period, input_names,
                         output_names, tuple(requests[:len(inputs)]),
                         tuple(requests[len(inputs):]))
    grid = resample_period(resample_rate, period)
    if grid is not None:
        return resample(signals, histories, grid)
    uneven = np.abs(steps[_inside(steps, starts)] - period) > PERIOD_TOLERANCE * period
    if uneven.any():
        raise BagError(f'{bag}: {int(uneven.sum())} sample intervals differ from the median '
                       f'{period / 1e6:g} ms by more than {PERIOD_TOLERANCE:.0%}; '
                       f'identification takes one sample period: resample onto a uniform '
                       f'grid (identify --resample {AUTO}, or --resample RATE in Hz)')
    return signals


__all__ = ['AUTO', 'BagSignals', 'GAP_PERIODS', 'RESAMPLE_GAP_PERIODS', 'Resampling',
           'bag_signals', 'resample', 'resample_period']
