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

:func:`tune_noises` replays every bag with the filter through a ``mapper``
(:func:`~observer_ros.bags.innovation_runs.bag_innovations` in
:mod:`observer_ros.bags.innovation_runs`, one task per bag), pools the innovations of
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
from typing import Callable, Optional, Sequence, Tuple

import numpy as np

from observer_ros.bags.filter_config import KalmanSetup
from observer_ros.bags.innovation_runs import BagRun, run_bags, SignalChoice
from observer_ros.bags.signals import PERIOD_TOLERANCE
from observer_ros.bags.storage import BagError
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.tuning.als import AlsResult, autocovariance_least_squares
from observer_ros.core.tuning.innovations import (
    decay_samples, InnovationStatistics, nis_summary, NisSummary, Whiteness, whiteness)
from observer_ros.core.tuning.noise_model import NoiseStructure, SampledFilter
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

#: Default number of tuning passes (estimate, run the tuned filter, estimate again).
ITERATIONS = 2

#: ``Q`` counts as zero when no entry exceeds this fraction of the largest entry of ``R``.
ZERO_PROCESS_NOISE = 1e-12

#: Exit status of ``tune_kalman`` when the tuning failed its own checks (innovations not
#: white after tuning, a zero ``Q``) and ``--accept-failed-checks`` was not given; errors
#: exit with 2.
FAILED_CHECKS_STATUS = 3


def zero_process_noise(estimate: AlsResult) -> bool:
    """Whether the estimated ``Q`` is zero (:data:`ZERO_PROCESS_NOISE` of ``R``)."""
    scale = float(np.max(np.abs(estimate.measurement_noise), initial=0.0))
    return float(np.max(np.abs(estimate.process_noise), initial=0.0)) <= \
        ZERO_PROCESS_NOISE * max(scale, np.finfo(float).tiny)


def zero_q_advice(state_names: Sequence[str]) -> str:
    """Say what to do when ``Q`` came out zero."""
    first = state_names[-1] if state_names else '0'
    return (f'give Q a floor where the plant is driven by noise (--known '
            f'"Q[{first},{first}]=VALUE", VALUE a variance you believe), estimate a full Q '
            f'(--process-structure full), check the model (identify another order), or '
            f'record longer with more excitation')


#: An estimated ``R`` whose smallest eigenvalue is at most this fraction of its largest is
#: singular: the filter would take some combination of the outputs as exact.
SINGULAR_MEASUREMENT_NOISE = 1e-6


def singular_measurement_noise(estimate: AlsResult) -> Optional[Tuple[float, float]]:
    """Return the smallest and largest eigenvalues of a singular estimated ``R``, else None."""
    values = np.linalg.eigvalsh(np.atleast_2d(np.asarray(estimate.measurement_noise, float)))
    if values.size < 2 or values[-1] <= 0.0:
        return None
    if values[0] > SINGULAR_MEASUREMENT_NOISE * values[-1]:
        return None
    return float(values[0]), float(values[-1])


class TunedFilterError(DesignError):
    """
    The tuned filter cannot be made or run; the tuning failed its checks.

    ``exit_status`` is :data:`FAILED_CHECKS_STATUS`: ``tune_kalman`` exits with it.
    """

    exit_status = FAILED_CHECKS_STATUS

    def __init__(self, estimate: AlsResult, state_names: Sequence[str], cause: Exception):
        q = np.array2string(np.asarray(estimate.process_noise), precision=4,
                            separator=', ').replace('\n', '')
        r = np.array2string(np.asarray(estimate.measurement_noise), precision=4,
                            separator=', ').replace('\n', '')
        if zero_process_noise(estimate):
            reason = (f'tuning failed its checks: the estimated Q (observer.process_noise) '
                      f'came out zero (R = {r}): the innovations show no process noise '
                      f'beyond R, so the tuned filter would trust the model alone, and the '
                      f'tuned filter fails: {cause}. Nothing written (--accept-failed-checks '
                      f'cannot help: the nodes refuse this filter). What to do: '
                      f'{zero_q_advice(state_names)}')
        elif singular_measurement_noise(estimate):
            # Not Q's fault: a singular R makes the Kalman gain (nearly) unbounded.
            low, high = singular_measurement_noise(estimate)
            reason = (f'tuning failed its checks: the estimated R (observer.measurement_noise) '
                      f'is singular (eigenvalues from {low:.3g} to {high:.3g}; Q = {q}, '
                      f'R = {r}): the filter would take a combination of the outputs as '
                      f'exact, and it fails: {cause}. The innovations cannot tell the noise '
                      f'of that combination, as with outputs interpolated onto one grid or '
                      f'outputs that repeat each other. Nothing written. What to do: estimate '
                      f'a diagonal R (--measurement-structure diagonal), fix the variances you '
                      f'know (--known "R[0,0]=VALUE", by output name or index), or leave out '
                      f'an output that repeats others')
        else:
            reason = (f'tuning failed its checks: the tuned filter (Q = {q}, R = {r}) fails: '
                      f'{cause}. Nothing written. A Q this small for the model is near zero: '
                      f'{zero_q_advice(state_names)}')
        super().__init__(reason)

    def __reduce__(self):
        """Pickle as a plain DesignError of the same text (worker processes)."""
        return DesignError, (self.reason, self.parameter)


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
    if setup.model.is_discrete and abs(period - dt * NANOSECONDS) > (
            PERIOD_TOLERANCE * dt * NANOSECONDS):
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

    @property
    def failed_checks(self) -> list:
        """
        Return what the tuning failed of its own checks, one sentence each (empty: none).

        The innovations of the tuned filter must be white (Ljung-Box), and the estimated
        ``Q`` must not be zero.
        """
        failed = []
        if zero_process_noise(self.final):
            failed.append(f'the estimated Q (observer.process_noise) came out zero: the '
                          f'tuned filter trusts the model alone and will not follow a plant '
                          f'that departs from it; {zero_q_advice(self.tuned.state_names)}')
        whiteness = self.pooled[-1].whiteness
        if not whiteness.white:
            p_values = ', '.join(f'{p:.3g}' for p in whiteness.p_values)
            failed.append(f'the innovations of the tuned filter are NOT white (Ljung-Box p '
                          f'{p_values}; {whiteness.outside:.1%} of the autocorrelations '
                          f'outside +-{whiteness.bound:.3g}): the model does not explain the '
                          f'data (another order, the right inputs, resampling) or the noise '
                          f'structure is too narrow')
        return failed


def tune_noises(bags: Sequence[str], setup: KalmanSetup, structure: NoiseStructure,
                mapper: Callable, lags: Optional[int] = None, burn_in: Optional[int] = None,
                iterations: int = ITERATIONS, y_topic: str = 'y', u_topic: str = 'u',
                weighting: str = 'whitened', truth_topic: Optional[str] = None,
                choice: Optional[SignalChoice] = None) -> TuningRun:
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
    choice : SignalChoice, optional
        Read other topics than the file's ``y`` and ``u`` (by field path), in log times, or
        resampled onto a uniform grid.

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
    runs = run_bags(mapper, bags, setup, y_topic, u_topic, 'replay', truth_topic, choice)
    period = common_period(runs, setup)
    outcome = TuningRun(period)
    current = setup
    for iteration in range(iterations + 1):
        try:
            if iteration:
                estimate = outcome.final
                current = setup.with_noises(estimate.process_noise, estimate.measurement_noise,
                                            structure.process == 'diagonal',
                                            structure.measurement == 'diagonal')
                runs = run_bags(mapper, bags, current, y_topic, u_topic,
                                f'tuned filter {iteration}',
                                truth_topic if iteration == iterations else None, choice)
            sampled = current.sampled_filter(period)
            sampled.check_stable()
            count = lags if lags is not None else default_lags(sampled)
            skip = burn_in if burn_in is not None else default_burn_in(sampled)
            pooled = pool(runs, count, skip, current.innovation_covariance(period))
        except (BagError, ConfigError, DesignError) as e:
            if not iteration:
                raise
            raise TunedFilterError(outcome.final, current.state_names, e) from e
        outcome.lags.append(count)
        outcome.setups.append(current)
        outcome.runs.append(runs)
        outcome.pooled.append(pooled)
        if iteration == iterations:
            break
        outcome.estimates.append(autocovariance_least_squares(
            pooled.statistics.autocovariances(), sampled, structure, current.state_names,
            current.output_names, weighting))
    return outcome


__all__ = ['BURN_IN_DECAY', 'FAILED_CHECKS_STATUS', 'ITERATIONS', 'Pooled',
           'TunedFilterError', 'TuningRun', 'ZERO_PROCESS_NOISE', 'common_period',
           'default_burn_in', 'default_lags', 'normalized_squares', 'pool', 'tune_noises',
           'zero_process_noise', 'zero_q_advice']
