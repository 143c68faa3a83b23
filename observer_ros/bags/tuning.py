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
from typing import Callable, Optional, Sequence, Tuple

import numpy as np

from observer_ros.bags.filter_config import KalmanSetup, system_of
from observer_ros.bags.identification import bag_signals
from observer_ros.bags.replay import replay_bag, replay_data
from observer_ros.bags.signals import PERIOD_TOLERANCE, read_signals, SignalSpec
from observer_ros.bags.storage import BagError, TopicData
from observer_ros.config.schema import topic_names
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.rules import in_sequence
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

#: What a refusal of two time bases tells to do.
LOG_TIME_ADVICE = 'use log times for both (tune_kalman --use-log-time)'

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
    if settings.type == 'joint_state':
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
        ``resample``: what :func:`observer_ros.bags.identification.bag_signals` refuses).

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


def run_bags(mapper: Callable, bags: Sequence[str], setup: KalmanSetup, y_topic: str,
             u_topic: str, label: str, truth_topic: Optional[str] = None,
             choice: Optional[SignalChoice] = None) -> list:
    """Replay every bag with ``setup``'s filter through ``mapper``; results in bag order."""
    tasks = [(bag, setup.parameters, y_topic, u_topic, truth_topic, choice) for bag in bags]
    return list(mapper(_bag_task, tasks, label))


def _bag_task(task: tuple) -> BagRun:
    return bag_innovations(*task)


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


__all__ = ['BURN_IN_DECAY', 'BagRun', 'FAILED_CHECKS_STATUS', 'ITERATIONS',
           'PERIOD_TOLERANCE', 'Pooled', 'SignalChoice', 'TunedFilterError', 'TuningRun',
           'ZERO_PROCESS_NOISE', 'bag_innovations', 'chosen_data', 'common_period',
           'default_burn_in', 'default_lags', 'file_spec', 'normalized_squares', 'pool',
           'run_bags', 'segment_starts', 'spec_text', 'tune_noises', 'zero_process_noise',
           'zero_q_advice']
