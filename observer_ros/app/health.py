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
Health checks of a running node, without ROS: input rates, stale inputs, NIS windows.

The nodes publish these as ``diagnostic_msgs/DiagnosticStatus`` entries; here each check is
a :class:`Check` (level, a message a person understands, and ``(key, value)`` pairs). The
levels are those of ``DiagnosticStatus``: :data:`OK`, :data:`WARN`, :data:`ERROR`.

- :class:`InputMonitor`: the rate of one input topic measured from its stamps (data time,
  so a lockstep or replayed run measures the simulated rate) against the expected rate, and
  the age of its latest message on the steady clock (a stale input).
- :func:`nis_findings`: the mean NIS over the last ``N`` samples
  (:class:`~observer_ros.core.consistency.NisWindow`) against its two-sided chi-square
  bounds, the consistency test of a Kalman filter.
- :class:`CounterWatch`: counters that grew since the last report (dropped or repaired
  data), by reason.

The configuration status (the validated design judged once) is
:mod:`observer_ros.app.design_check`.
"""

from collections import Counter
from dataclasses import dataclass, field
import math
from typing import Iterable, Mapping, Optional, Sequence

from observer_ros.core.consistency import NisWindow
from observer_ros.core.units import NANOSECONDS

#: Levels of ``diagnostic_msgs/DiagnosticStatus``.
OK, WARN, ERROR = 0, 1, 2
LEVEL_NAMES = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR'}

#: Counters of dropped or repaired input data: their growth warns in the inputs status.
INPUT_WARNING_COUNTERS = ('malformed', 'out_of_range', 'future_stamp', 'duplicate',
                          'out_of_order', 'too_old', 'late_input', 'invalid_clock',
                          'lockstep_timeouts',
                          'stale', 'unsafe_command', 'command_timeouts',
                          'started_without_peers')

#: Counters of estimator restarts and failed steps: their growth warns in the estimator status.
ESTIMATOR_WARNING_COUNTERS = ('restart_gap', 'restart_backward_jump', 'estimate_reset',
                              'step_failed')

#: Every counter whose growth means data was lost or repaired.
WARNING_COUNTERS = INPUT_WARNING_COUNTERS + ESTIMATOR_WARNING_COUNTERS

#: Stale after this many expected periods when no timeout is configured ...
STALE_PERIODS = 10
#: ... but never sooner than this (seconds): scheduling jitter is not an outage.
STALE_FLOOR = 0.5


@dataclass(frozen=True)
class Check:
    """
    One health report: what a ``DiagnosticStatus`` carries, without ROS.

    Attributes
    ----------
    section : str
        ``configuration``, ``inputs`` or ``estimator`` (the status is named
        ``'<node>: <section>'``).
    level : int
        :data:`OK`, :data:`WARN` or :data:`ERROR`.
    message : str
        What is wrong, in words (``'ok'`` when nothing is).
    values : tuple of (str, str)
        The measured values and counters.

    """

    section: str
    level: int
    message: str
    values: tuple = field(default_factory=tuple)


def combine(section: str, findings: Iterable[tuple], values: Sequence[tuple]) -> Check:
    """
    Return one :class:`Check` from ``(level, text)`` findings: the worst level, its texts.

    The message joins the texts of the findings at the worst level (``'; '``); ``'ok'``
    when there are none above :data:`OK`.
    """
    findings = list(findings)
    level = max((found for found, _ in findings), default=OK)
    texts = [text for found, text in findings if found == level and found > OK]
    return Check(section, level, '; '.join(texts) if texts else 'ok',
                 tuple((key, str(value)) for key, value in values))


def seconds_text(value: float) -> str:
    """Format seconds for a message: ``2.3 s``, ``0.01 s``."""
    return f'{value:.3g} s'


def rate_text(value: float) -> str:
    """Format a rate for a message: ``100 Hz``, ``9.5 Hz``."""
    return f'{value:.3g} Hz'


class InputMonitor:
    """
    Rate and age of one input topic.

    Parameters
    ----------
    topic : str
        The topic as the node names it (``'y'``), for the messages.
    expected_rate : float or None
        Hz the messages should come at (None: not judged, only measured).
    stale_after : float
        Steady-clock seconds without a message after which the input is stale.
    tolerance : float
        Relative rate error accepted: the measured rate may differ from the expected one by
        this fraction (``0.5``: 50 ... 150 Hz for 100 Hz) before the check warns.
    required : bool
        A required input that never came or went stale is an :data:`ERROR` (a missing one a
        :data:`WARN`); an optional one (``reference``) only reports its age.
    minimum_only : bool
        Judge only a rate below the expected one (``x_hat`` may come faster when the
        observer also publishes predictions).

    """

    def __init__(self, topic: str, expected_rate: Optional[float], stale_after: float,
                 tolerance: float = 0.5, required: bool = True,
                 minimum_only: bool = False) -> None:
        self.topic = topic
        self.expected_rate = expected_rate
        self.stale_after = float(stale_after)
        self.tolerance = float(tolerance)
        self.required = required
        self.minimum_only = minimum_only
        self.count = 0
        self.last_arrival_ns: Optional[int] = None
        self.started_ns: Optional[int] = None
        self._last_stamp: Optional[int] = None
        self._anchor: Optional[int] = None  # the last stamp of the previous report
        self._first: Optional[int] = None  # the first stamp since the previous report
        self._since = 0  # messages since the previous report
        self.rate: Optional[float] = None

    def start(self, now_ns: int) -> None:
        """Mark when the node began waiting (the age of a never-seen input counts from it)."""
        self.started_ns = now_ns

    def tick(self, stamp_ns: int, arrival_ns: int) -> None:
        """Count one message stamped ``stamp_ns`` that arrived at ``arrival_ns`` (steady)."""
        self.count += 1
        self._since += 1
        self.last_arrival_ns = arrival_ns
        if self._first is None:
            self._first = stamp_ns
        self._last_stamp = stamp_ns

    def measured_rate(self) -> Optional[float]:
        """
        Measure the rate of the stamps since the previous call (Hz; None: not measurable).

        Measured over the messages of the report alone, so a gap before them (an outage)
        does not lower the rate once the input is back.
        """
        since, first, last, anchor = self._since, self._first, self._last_stamp, self._anchor
        self._since, self._first, self._anchor = 0, None, last
        if since == 0 or last is None:
            return None
        if since >= 2 and last > first:  # k stamps T apart span (k - 1) T
            return (since - 1) * NANOSECONDS / (last - first)
        if since == 1 and anchor is not None and last > anchor:  # a slow input
            return NANOSECONDS / (last - anchor)
        return None  # stamps that went back (a restart)

    def age(self, now_ns: int) -> Optional[float]:
        """Return how long ago the latest message came, in seconds (None: none yet)."""
        if self.last_arrival_ns is None:
            return None
        return (now_ns - self.last_arrival_ns) / NANOSECONDS

    def findings(self, now_ns: int) -> tuple:
        """Return ``(findings, values)`` of this input at ``now_ns`` (steady clock)."""
        topic, expected = self.topic, self.expected_rate
        rate = self.measured_rate()
        if rate is not None:
            self.rate = rate
        age = self.age(now_ns)
        values = [(f'{topic}.count', self.count),
                  (f'{topic}.rate_hz', 'none' if self.rate is None else f'{self.rate:.4g}'),
                  (f'{topic}.expected_rate_hz', 'any' if expected is None else f'{expected:.4g}'),
                  (f'{topic}.age_s', 'never' if age is None else f'{age:.3g}')]
        expected_every = ('' if expected is None else
                          f' (expected every {seconds_text(1.0 / expected)})')
        bad = ERROR if self.required else OK
        if age is None:
            waited = (None if self.started_ns is None
                      else (now_ns - self.started_ns) / NANOSECONDS)
            if not self.required:
                return [], values
            since = '' if waited is None else f' in {seconds_text(waited)}'
            level = ERROR if waited is not None and waited > self.stale_after else WARN
            return [(level, f'no {topic} received yet{since}{expected_every}')], values
        if age > self.stale_after:
            return [(bad, f'{topic} stale for {seconds_text(age)}{expected_every}')], values
        if rate is not None and expected:
            low, high = expected * (1 - self.tolerance), expected * (1 + self.tolerance)
            if rate < low or (rate > high and not self.minimum_only):
                return [(WARN, f'{topic} at {rate_text(rate)}, expected {rate_text(expected)}'
                         f' (+-{self.tolerance:.0%})')], values
        return [], values


#: Per-source drop reasons reported by the ``sources`` check (zeros shown too).
SOURCE_DROPS = ('malformed', 'out_of_range', 'future_stamp', 'duplicate', 'too_old',
                'out_of_order')


def sources_check(report: Mapping[str, object], decode_drops: Mapping[str, Counter],
                  depth: tuple) -> Check:
    """
    Return the ``sources`` check: each measurement source's counts, age and history use.

    Parameters
    ----------
    report : mapping
        ``{source: SourceStatus}`` of
        :meth:`~observer_ros.core.streaming.EventStream.source_report`.
    decode_drops : mapping
        ``{source: Counter}`` of messages dropped before the stream (``malformed`` bytes).
    depth : tuple
        ``(entries, span_ns)`` of the history in use.

    A stale source (older than its ``timeout``) warns; the values hold, per source,
    ``received``, ``used``, ``reruns``, the drops by reason, ``age_s`` of its last sample
    and ``max_lag_s`` (how far back into the history its samples reached).
    """
    findings, values = [], []
    for name, status in report.items():
        counts = Counter(status.counts) + Counter(decode_drops.get(name, {}))
        values += [(f'{name}.{key}', counts.get(key, 0))
                   for key in ('received', 'used', 'reruns') + SOURCE_DROPS]
        age = status.age_ns
        values += [(f'{name}.age_s', 'never' if age is None else f'{age / NANOSECONDS:.3g}'),
                   (f'{name}.max_lag_s', f'{status.max_lag_ns / NANOSECONDS:.3g}'),
                   (f'{name}.stale', str(status.stale).lower())]
        if status.stale:
            findings.append((WARN, f'source {name} stale' + (
                '' if age is None else f' for {seconds_text(age / NANOSECONDS)}')))
    entries, span = depth
    values += [('history.entries', entries), ('history.span_s', f'{span / NANOSECONDS:.3g}')]
    return combine('sources', findings, values)


def stale_timeout(configured: float, expected_rate: Optional[float]) -> float:
    """
    Return the stale timeout in seconds: ``configured`` when above 0, else automatic.

    Automatic: :data:`STALE_PERIODS` expected periods, at least :data:`STALE_FLOOR` s.
    """
    if configured > 0:
        return configured
    if not expected_rate:
        return STALE_FLOOR
    return max(STALE_PERIODS / expected_rate, STALE_FLOOR)


def nis_findings(window: NisWindow) -> tuple:
    """
    Return ``(findings, values)`` of a NIS window: its mean against its bounds.

    Not judged until the window is full; a mean above the upper bound warns that R or Q is
    too small (or the model wrong), below the lower one that they are too large; a mean
    that is not finite is an :data:`ERROR`.
    """
    count = len(window.values)
    mean = window.mean
    bound = f'{window.confidence:.4g}'.rstrip('0')
    values = [('nis.mean', 'none' if not count else f'{mean:.4g}'),
              ('nis.samples', count), ('nis.window', window.window),
              ('nis.bound_low', f'{window.low:.4g}'), ('nis.bound_high', f'{window.high:.4g}'),
              ('nis.confidence', bound)]
    if not window.full:
        return [], values
    over = f'over {count} samples'
    percent = f'{window.confidence * 100:.4g}%'
    if not math.isfinite(mean):
        return [(ERROR, f'NIS mean is not finite {over}')], values
    if mean > window.high:
        return [(WARN, f'NIS mean {mean:.3g} above the {percent} bound {window.high:.3g} '
                 f'{over}: R or Q too small (or a model error)')], values
    if mean < window.low:
        return [(WARN, f'NIS mean {mean:.3g} below the {percent} bound {window.low:.3g} '
                 f'{over}: R or Q too large')], values
    return [], values


class CounterWatch:
    """
    Counters that grew since the previous report, by reason.

    Parameters
    ----------
    watched : sequence of str
        The counter names whose growth warns.
    what : str
        What grew, for the message (``'inputs dropped or repaired'``).

    """

    def __init__(self, watched: Sequence[str], what: str) -> None:
        self.watched = tuple(watched)
        self.what = what
        self._previous: Counter = Counter()

    def findings(self, counters: Mapping[str, int]) -> list:
        """Return the ``(WARN, text)`` finding when a watched counter grew (else none)."""
        grown = {key: counters.get(key, 0) - self._previous.get(key, 0) for key in self.watched}
        self._previous = Counter({key: counters.get(key, 0) for key in self.watched})
        grown = {key: value for key, value in grown.items() if value > 0}
        if not grown:
            return []
        reasons = ', '.join(f'{value} {key}' for key, value in sorted(grown.items()))
        return [(WARN, f'{self.what} since the last report: {reasons}')]


def innovation_values(innovations: Sequence[float]) -> tuple:
    """
    Return ``(findings, values)`` of the squared innovation norms of the last samples.

    Shows the latest ``|v|`` and the RMS over the samples; a non-finite one is an
    :data:`ERROR`.
    """
    if not innovations:
        return [], [('innovation.norm', 'none'), ('innovation.rms', 'none')]
    last = math.sqrt(innovations[-1]) if innovations[-1] >= 0 else math.nan
    rms = math.sqrt(math.fsum(innovations) / len(innovations))
    values = [('innovation.norm', f'{last:.4g}'), ('innovation.rms', f'{rms:.4g}'),
              ('innovation.samples', len(innovations))]
    if not (math.isfinite(last) and math.isfinite(rms)):
        return [(ERROR, 'the innovation is not finite')], values
    return [], values


def covariance_values(trace: Optional[float]) -> tuple:
    """Return ``(findings, values)`` of the trace of ``P`` (None: the filter has no P)."""
    if trace is None:
        return [], []
    values = [('covariance.trace', f'{trace:.4g}')]
    if not math.isfinite(trace) or trace < 0:
        return [(ERROR, f'the covariance trace is {trace:g}: the filter diverged')], values
    return [], values


__all__ = ['Check', 'CounterWatch', 'ERROR', 'ESTIMATOR_WARNING_COUNTERS',
           'INPUT_WARNING_COUNTERS', 'InputMonitor', 'LEVEL_NAMES', 'OK', 'WARN',
           'WARNING_COUNTERS', 'combine', 'covariance_values',
           'innovation_values', 'nis_findings', 'stale_timeout']
