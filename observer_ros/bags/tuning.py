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
Noise covariances from recordings: the filter run over bags, its innovations pooled, ALS.

:func:`bag_innovations` replays one bag with the observer's own engine
(:func:`observer_ros.bags.replay.replay_bag`) and returns what tuning needs of it; it is the
task worker processes or a Dask cluster run, one per bag. :func:`tune_noises` runs it over
every bag through a ``mapper`` (:mod:`observer_ros.app.parallel`), pools the innovations of
all bags (:class:`~observer_ros.core.tuning.innovations.InnovationStatistics`: pairs never
span two segments), estimates ``Q`` and ``R`` by autocovariance least squares
(:mod:`observer_ros.core.tuning.als`), and runs the tuned filter again, ``iterations`` times,
to judge it: NIS and whiteness before and after.

A segment is one uninterrupted run of the filter: a bag, or the part of it between two
gaps longer than ``observer.max_gap`` (the filter restarts there). Its first ``burn_in``
innovations, the start-up transient, are left out; by default as many as the prediction
error takes to fall to :data:`BURN_IN_DECAY` of its start, so a restart leaves no trace in
the statistics.
"""

from dataclasses import dataclass, field
from typing import Callable, Optional, Sequence

import numpy as np

from observer_ros.bags.filter_config import KalmanSetup, system_of
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.storage import BagError
from observer_ros.core.errors import ConfigError
from observer_ros.core.rules import in_sequence
from observer_ros.core.tuning.als import (
    AlsResult, autocovariance_least_squares, NoiseStructure, SampledFilter)
from observer_ros.core.tuning.innovations import (
    decay_samples, InnovationStatistics, nis_summary, NisSummary, Whiteness, whiteness)
from observer_ros.core.units import NANOSECONDS

#: Default burn-in: samples until ``||(Ad - L C)^k||`` falls to this.
BURN_IN_DECAY = 1e-12

#: Default lag count: samples until ``||(Ad - L C)^k||`` falls to this, within
#: :data:`LAG_RANGE` (at least ``n + 2``).
LAG_DECAY = 0.05
LAG_RANGE = (4, 50)

#: Lags the whiteness is judged over at least (the ALS may use fewer).
WHITENESS_LAGS = 20

#: Pooled samples needed per lag (after burn-in): fewer is "too short for the lag count".
SAMPLES_PER_LAG = 50

#: Sample intervals may differ from the bag's median by this fraction (ALS takes one period).
PERIOD_TOLERANCE = 0.02

#: Default number of tuning passes (estimate, run the tuned filter, estimate again).
ITERATIONS = 2


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


def bag_innovations(bag: str, parameters: dict, y_topic: str = 'y', u_topic: str = 'u',
                    truth_topic: Optional[str] = None, use_log_time: bool = False) -> BagRun:
    """
    Replay one bag with the filter of ``parameters`` (flat); the task of one worker.

    Raises
    ------
    BagError
        The bag cannot give the topics, holds a sample that is not finite, its inputs are
        stamped in another time base than its measurements, or its sample intervals are not
        even within :data:`PERIOD_TOLERANCE`.

    """
    system = system_of(parameters)
    result = replay_bag(bag, system, y_topic, u_topic, use_log_time)
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
                       f'{PERIOD_TOLERANCE:.0%}; tuning takes one sample period (resample or '
                       f'cut the recording)')
    truth_stamps = truth = None
    if truth_topic:
        try:
            data = result.truth(truth_topic)
            truth_stamps, truth = data.stamps_ns, data.values
        except BagError:
            pass  # no reference in this bag
    return BagRun(str(bag), result.stamps_ns, result.innovations, result.estimates, starts,
                  period, truth_stamps, truth)


def normalized_squares(innovations: np.ndarray, covariance: np.ndarray) -> np.ndarray:
    """Return the NIS ``e^T S^-1 e`` of each innovation, shape (k,)."""
    return np.einsum('ki,ij,kj->k', innovations, np.linalg.inv(covariance), innovations)


def common_period(runs: Sequence[BagRun], setup: KalmanSetup) -> int:
    """
    Return the one sample period of all bags (ns).

    Raises
    ------
    BagError
        Bags recorded at different rates, or (discrete model) at another rate than
        ``model.dt``.

    """
    periods = np.array([run.period_ns for run in runs])
    period = int(np.median(periods))
    off = [run for run in runs if abs(run.period_ns - period) > PERIOD_TOLERANCE * period]
    if off:
        raise BagError(f'{off[0].bag}: sampled every {off[0].period_ns / 1e6:g} ms, the other '
                       f'bags every {period / 1e6:g} ms; tune from bags of one rate')
    dt = setup.model.dt
    if setup.model.is_discrete and abs(period - dt * NANOSECONDS) > PERIOD_TOLERANCE * dt * 1e9:
        raise BagError(f'{runs[0].bag}: sampled every {period / 1e6:g} ms but model.dt is '
                       f'{dt:g} s; a discrete model needs bags at its own rate')
    return period


def default_lags(sampled: SampledFilter) -> int:
    """Return the lags until the prediction error's transition falls to :data:`LAG_DECAY`."""
    low, high = LAG_RANGE
    low = max(low, sampled.c.shape[1] + 2)
    return int(min(max(decay_samples(sampled.error_dynamics, LAG_DECAY, 10 * high), low),
                   high)) if high >= low else low


def default_burn_in(sampled: SampledFilter) -> int:
    """Return the samples the start-up transient takes to fall to :data:`BURN_IN_DECAY`."""
    return decay_samples(sampled.error_dynamics, BURN_IN_DECAY)


@dataclass(frozen=True)
class Pooled:
    """The innovations of several bags, pooled, with what was left out."""

    statistics: InnovationStatistics
    burn_in: int
    dropped: tuple  # (bag, segment start index, length) of segments too short to use
    nis: NisSummary
    whiteness: Whiteness


def pool(runs: Sequence[BagRun], lags: int, burn_in: int, covariance: np.ndarray) -> Pooled:
    """
    Pool the innovations of every segment of every bag, after ``burn_in`` samples each.

    ``covariance`` is the filter's innovation covariance ``S`` (for the NIS).

    Raises
    ------
    BagError
        Too short for the lag count: fewer than ``SAMPLES_PER_LAG * lags`` samples left.

    """
    n_outputs = runs[0].innovations.shape[1]
    statistics = InnovationStatistics(lags, n_outputs)
    dropped, kept = [], []
    for run in runs:
        for part in run.segments():
            length = part.stop - part.start
            if length < burn_in + lags:
                dropped.append((run.bag, part.start, length))
                continue
            kept.append(run.innovations[part.start + burn_in:part.stop])
            statistics.add(kept[-1])
    needed = SAMPLES_PER_LAG * lags
    if statistics.samples < needed:
        total = sum(len(run.stamps_ns) for run in runs)
        raise BagError(f'too short for the lag count: {statistics.samples} of {total} samples '
                       f'left after a burn-in of {burn_in} per segment ({len(dropped)} '
                       f'segments shorter than burn-in + lags dropped); {lags} lags need at '
                       f'least {needed}: record longer, or give fewer --lags or a shorter '
                       f'--burn-in')
    values = np.concatenate([normalized_squares(part, covariance) for part in kept])
    judged = statistics
    longest = max(len(part) for part in kept)
    if lags < min(WHITENESS_LAGS, longest):
        judged = InnovationStatistics(min(WHITENESS_LAGS, longest), n_outputs)
        for part in kept:
            judged.add(part)
    return Pooled(statistics, burn_in, tuple(dropped), nis_summary(values, n_outputs),
                  whiteness(judged))


@dataclass
class TuningRun:
    """
    A whole tuning: the runs and statistics before and after, and each ALS estimate.

    ``setups[0]`` is the file's filter, ``setups[-1]`` the tuned one; ``runs`` and
    ``pooled`` hold one entry per filter run (``iterations + 1`` of them).
    """

    def innovation_covariance(self, index: int) -> np.ndarray:
        """``S`` of filter run ``index`` at the bags' period."""
        return self.setups[index].innovation_covariance(self.period_ns)

    period_ns: int
    lags: list = field(default_factory=list)
    setups: list = field(default_factory=list)
    runs: list = field(default_factory=list)
    pooled: list = field(default_factory=list)
    estimates: list = field(default_factory=list)

    @property
    def tuned(self) -> KalmanSetup:
        """Return the tuned filter's setup."""
        return self.setups[-1]

    @property
    def final(self) -> AlsResult:
        """Return the last ALS estimate."""
        return self.estimates[-1]


def run_bags(mapper: Callable, bags: Sequence[str], setup: KalmanSetup, y_topic: str,
             u_topic: str, label: str, truth_topic: Optional[str] = None,
             use_log_time: bool = False) -> list:
    """Replay every bag with ``setup``'s filter through ``mapper``; results in bag order."""
    tasks = [(bag, setup.parameters, y_topic, u_topic, truth_topic, use_log_time)
             for bag in bags]
    return list(mapper(_bag_task, tasks, label))


def _bag_task(task: tuple) -> BagRun:
    return bag_innovations(*task)


def tune_noises(bags: Sequence[str], setup: KalmanSetup, structure: NoiseStructure,
                mapper: Callable, lags: Optional[int] = None, burn_in: Optional[int] = None,
                iterations: int = ITERATIONS, y_topic: str = 'y', u_topic: str = 'u',
                weighting: str = 'whitened', truth_topic: Optional[str] = None,
                use_log_time: bool = False) -> TuningRun:
    """
    Estimate ``Q`` and ``R`` from the bags; see the module notes.

    Parameters
    ----------
    bags : sequence of str
    setup : KalmanSetup
        The filter that runs first (its noises are the initial guess).
    structure : NoiseStructure
    mapper : callable
        ``mapper(function, tasks, label)`` returns ``function(task)`` of each task in order
        (:func:`observer_ros.app.parallel.task_mapper`).
    lags, burn_in : int, optional
        Default: from the running filter (:func:`default_lags`, :func:`default_burn_in`).
    iterations : int
        ALS passes, each followed by a run of the filter it gives (at least 1).
    truth_topic : str, optional
        Read this reference (``x_true``) with the first and the last run, for the report.
    use_log_time : bool
        Stamp every topic with its log times (see
        :func:`observer_ros.bags.replay.replay_bag`).

    Raises
    ------
    BagError, ConfigError, DesignError
        A bag that cannot be used, a bad structure or lag count, an estimate the nodes
        would refuse; each names its cause.

    """
    if iterations < 1:
        raise ConfigError('iterations', f'expected at least 1, got {iterations}')
    if lags is not None and lags < 2:
        raise ConfigError('lags', f'expected at least 2, got {lags}')
    if burn_in is not None and burn_in < 0:
        raise ConfigError('burn_in', f'expected 0 or more, got {burn_in}')
    runs = run_bags(mapper, bags, setup, y_topic, u_topic, 'replay', truth_topic,
                    use_log_time)
    period = common_period(runs, setup)
    outcome = TuningRun(period)
    current = setup
    for iteration in range(iterations + 1):
        sampled = current.sampled_filter(period)
        sampled.check_stable()
        count = lags if lags is not None else default_lags(sampled)
        skip = burn_in if burn_in is not None else default_burn_in(sampled)
        pooled = pool(runs, count, skip, current.innovation_covariance(period))
        outcome.lags.append(count)
        outcome.setups.append(current)
        outcome.runs.append(runs)
        outcome.pooled.append(pooled)
        if iteration == iterations:
            break
        estimate = autocovariance_least_squares(
            pooled.statistics.autocovariances(), sampled, structure, current.state_names,
            current.output_names, weighting)
        outcome.estimates.append(estimate)
        current = setup.with_noises(estimate.process_noise, estimate.measurement_noise,
                                    structure.process == 'diagonal',
                                    structure.measurement == 'diagonal')
        runs = run_bags(mapper, bags, current, y_topic, u_topic, f'tuned filter {iteration + 1}',
                        truth_topic if iteration == iterations - 1 else None, use_log_time)
    return outcome


__all__ = ['BURN_IN_DECAY', 'BagRun', 'ITERATIONS', 'Pooled', 'TuningRun', 'bag_innovations',
           'common_period', 'default_burn_in', 'default_lags', 'normalized_squares', 'pool',
           'run_bags',
           'segment_starts', 'tune_noises']
