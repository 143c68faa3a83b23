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
Innovation statistics pooled over recordings: autocovariances, whiteness and NIS.

The innovations ``e_k = y_k - C x_hat[k|k-1]`` of a filter running over recorded data are
the raw material of noise tuning. :class:`InnovationStatistics` keeps, for lags
``j = 0 .. lags - 1``, the sums ``sum_k e[k+j] e[k]^T`` and their pair counts over any number
of segments (a segment is one uninterrupted run of the filter: pairs never span two), so
several recordings pool exactly: adding their segments one by one gives the same sums as
adding them all at once. :func:`whiteness` judges the normalized autocorrelation against its
bounds for white innovations, :func:`nis_summary` the mean NIS against its chi-square band
(:func:`observer_ros.core.consistency.nis_bounds`).
"""

from dataclasses import dataclass
import math
from typing import Iterable, Optional

import numpy as np

from observer_ros.core.consistency import nis_bounds
from observer_ros.core.errors import ConfigError

#: Two-sided 95 % point of the standard normal: whiteness bounds are +-1.96 / sqrt(N).
WHITENESS_Z = 1.959963984540054


class InnovationStatistics:
    """
    Sums of lagged innovation products over segments, pooled.

    Parameters
    ----------
    lags : int
        Lags ``0 .. lags - 1`` kept (at least 1).
    n_outputs : int
        Innovation dimension ``p``.

    Attributes
    ----------
    sums : numpy.ndarray, shape (lags, p, p)
        ``sums[j] = sum_k e[k+j] e[k]^T`` within segments.
    counts : numpy.ndarray of int, shape (lags,)
        Pairs summed at each lag.
    samples, segments : int
        Innovations and segments added.

    Examples
    --------
    >>> import numpy as np
    >>> e = np.random.default_rng(1).standard_normal((1000, 1))
    >>> whole = InnovationStatistics(3, 1)
    >>> whole.add(e)
    >>> halves = InnovationStatistics(3, 1)
    >>> halves.add(e[:500]); halves.add(e[500:])
    >>> int(whole.counts[1]), int(halves.counts[1])
    (999, 998)

    """

    def __init__(self, lags: int, n_outputs: int) -> None:
        if int(lags) < 1:
            raise ConfigError('lags', f'expected at least 1, got {lags}')
        self.lags = int(lags)
        self.n_outputs = int(n_outputs)
        self.sums = np.zeros((self.lags, self.n_outputs, self.n_outputs))
        self.counts = np.zeros(self.lags, dtype=np.int64)
        self.samples = 0
        self.segments = 0

    def add(self, innovations) -> None:
        """
        Add one segment of innovations, shape ``(k, p)``, in time order.

        Raises
        ------
        ConfigError
            Naming ``innovations``: wrong width or a value that is not finite.

        """
        e = np.ascontiguousarray(innovations, dtype=float)
        if e.ndim != 2 or e.shape[1] != self.n_outputs:
            raise ConfigError('innovations', f'expected shape (k, {self.n_outputs}), got '
                              f'{e.shape}')
        if not np.isfinite(e).all():
            raise ConfigError('innovations', 'expected finite values (NaN or inf found)')
        count = len(e)
        # einsum's own loops, not BLAS: exact sums in a fixed order, and no thread start-up.
        for lag in range(min(self.lags, count)):
            self.sums[lag] += np.einsum('ki,kj->ij', e[lag:], e[:count - lag])
            self.counts[lag] += count - lag
        self.samples += count
        self.segments += 1

    def merge(self, others: Iterable['InnovationStatistics']) -> 'InnovationStatistics':
        """Return the pooled statistics of ``self`` and ``others`` (same lags and width)."""
        pooled = InnovationStatistics(self.lags, self.n_outputs)
        for part in (self, *others):
            if (part.lags, part.n_outputs) != (self.lags, self.n_outputs):
                raise ConfigError('others', f'expected {self.lags} lags of {self.n_outputs} '
                                  f'outputs, got {part.lags} of {part.n_outputs}')
            pooled.sums += part.sums
            pooled.counts += part.counts
            pooled.samples += part.samples
            pooled.segments += part.segments
        return pooled

    def autocovariances(self) -> np.ndarray:
        """
        Return ``C_j = E[e[k+j] e[k]^T]`` estimated for every lag, shape ``(lags, p, p)``.

        Raises
        ------
        ConfigError
            Naming ``lags`` when a lag has no pair (the segments are shorter than it).

        """
        if (self.counts == 0).any():
            short = int(np.argmax(self.counts == 0))
            raise ConfigError('lags', f'{self.lags} lags need segments longer than {short} '
                              f'samples; the longest has fewer')
        return self.sums / self.counts[:, None, None]


@dataclass(frozen=True)
class Whiteness:
    """
    Normalized innovation autocorrelation and its bounds for white innovations.

    Attributes
    ----------
    correlation : numpy.ndarray, shape (lags, p, p)
        ``C_j[a, b] / sqrt(C_0[a, a] C_0[b, b])``; lag 0 holds the correlation matrix.
    bound : float
        ``1.96 / sqrt(N)``: 95 % of the lag >= 1 values of white innovations lie within.
    outside : float
        Fraction of the lag >= 1 values outside the bound (about 0.05 when white).
    portmanteau : numpy.ndarray, shape (p,)
        Ljung-Box statistic of each output over lags ``1 .. lags - 1``.
    p_values : numpy.ndarray, shape (p,)
        Chi-square tail probability of each statistic (small: not white).

    """

    correlation: np.ndarray
    bound: float
    outside: float
    portmanteau: np.ndarray
    p_values: np.ndarray

    @property
    def white(self) -> bool:
        """Whether no output's Ljung-Box test rejects whiteness at 1 %."""
        return bool((self.p_values > 0.01).all())


def whiteness(statistics: InnovationStatistics) -> Whiteness:
    """
    Judge the innovations of ``statistics`` for whiteness.

    Parameters
    ----------
    statistics : InnovationStatistics
        At least two lags.

    Returns
    -------
    Whiteness

    Raises
    ------
    ConfigError
        Naming ``lags`` when fewer than two lags are kept, or ``innovations`` when an output
        never varies.

    Examples
    --------
    >>> import numpy as np
    >>> statistics = InnovationStatistics(10, 1)
    >>> statistics.add(np.random.default_rng(0).standard_normal((5000, 1)))
    >>> whiteness(statistics).white
    True

    """
    if statistics.lags < 2:
        raise ConfigError('lags', 'whiteness needs at least 2 lags')
    covariances = statistics.autocovariances()
    scale = np.sqrt(np.diag(covariances[0]))
    if (scale <= 0).any():
        raise ConfigError('innovations', 'an output has zero innovation variance')
    correlation = covariances / np.outer(scale, scale)[None]
    samples = statistics.samples
    bound = WHITENESS_Z / math.sqrt(samples)
    later = correlation[1:]
    outside = float(np.mean(np.abs(later) > bound))
    counts = statistics.counts[1:].astype(float)
    diagonal = np.einsum('jii->ji', later)
    portmanteau = samples * (samples + 2) * np.sum(diagonal ** 2 / counts[:, None], axis=0)
    from scipy.stats import chi2
    p_values = chi2.sf(portmanteau, statistics.lags - 1)
    return Whiteness(correlation, bound, outside, portmanteau, np.asarray(p_values))


@dataclass(frozen=True)
class NisSummary:
    """
    Mean NIS of a run against the band of a consistent filter.

    Attributes
    ----------
    mean : float
        Mean of ``v^T S^-1 v`` over the samples.
    low, high : float
        99 % two-sided bounds of that mean (:func:`~observer_ros.core.consistency.nis_bounds`).
    samples, n_outputs : int

    """

    mean: float
    low: float
    high: float
    samples: int
    n_outputs: int

    @property
    def consistent(self) -> bool:
        """Whether the mean lies in its band."""
        return self.low <= self.mean <= self.high


def nis_summary(nis, n_outputs: int, confidence: float = 0.99) -> NisSummary:
    """
    Summarize NIS values (any shape; flattened) against the chi-square band of their mean.

    Parameters
    ----------
    nis : array_like
        ``v^T S^-1 v`` values.
    n_outputs : int
        ``p``: each value is chi-square with ``p`` degrees of freedom when consistent.
    confidence : float
        Two-sided confidence of the band.

    Returns
    -------
    NisSummary

    Raises
    ------
    ConfigError
        Naming ``nis`` when there is none or one is not finite.

    Examples
    --------
    >>> summary = nis_summary([0.5, 1.5, 1.0, 1.0], 1)
    >>> summary.mean, summary.consistent
    (1.0, True)

    """
    values = np.asarray(nis, dtype=float).ravel()
    if not len(values):
        raise ConfigError('nis', 'expected at least one value')
    if not np.isfinite(values).all():
        raise ConfigError('nis', 'expected finite values')
    low, high = nis_bounds(len(values), n_outputs, confidence)
    return NisSummary(float(np.mean(values)), low, high, len(values), int(n_outputs))


def moving_mean(values, window: int) -> np.ndarray:
    """Return the trailing mean of ``window`` values (fewer at the start), same length."""
    values = np.asarray(values, dtype=float)
    sums = np.cumsum(np.concatenate([[0.0], values]))
    index = np.arange(1, len(values) + 1)
    start = np.maximum(index - int(window), 0)
    return (sums[index] - sums[start]) / (index - start)


def decay_samples(transition_matrix, fraction: float, limit: Optional[int] = None) -> int:
    """
    Return the first ``k`` with ``||M^k||_2 <= fraction``: how long a transient takes to fade.

    Raises
    ------
    ConfigError
        Naming ``transition_matrix`` when it is not stable (spectral radius >= 1), or when
        ``limit`` steps do not get there.

    """
    matrix = np.asarray(transition_matrix, dtype=float)
    radius = float(np.max(np.abs(np.linalg.eigvals(matrix)))) if matrix.size else 0.0
    if radius >= 1.0:
        raise ConfigError('transition_matrix', f'expected a stable matrix, spectral radius '
                          f'{radius:.6g}')
    limit = 100_000 if limit is None else int(limit)
    power = np.eye(len(matrix))
    for k in range(limit + 1):
        if np.linalg.norm(power, 2) <= fraction:
            return k
        power = matrix @ power
    raise ConfigError('transition_matrix', f'a transient takes more than {limit} samples to '
                      f'fall to {fraction:g} (spectral radius {radius:.6g})')


__all__ = ['InnovationStatistics', 'NisSummary', 'Whiteness', 'decay_samples', 'moving_mean',
           'nis_summary', 'whiteness']
