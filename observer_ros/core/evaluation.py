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

"""Estimation quality: errors against a reference trajectory, per state, as numbers and text."""

from dataclasses import dataclass
import math
from typing import Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError

#: The settling time is this many time constants of the slowest observer pole (2 %).
SETTLING_TIME_CONSTANTS = 4.0


def decay_rate(poles, discrete_dt: float = 0.0) -> float:
    """
    Slowest decay rate ``-max Re(lambda)`` (1/s) of the error dynamics.

    Discrete poles (``discrete_dt > 0``) are converted with ``ln|z| / dt``.

    Parameters
    ----------
    poles : array_like of complex
        s-plane poles, or z-plane poles when ``discrete_dt > 0``.
    discrete_dt : float
        The sample period of z-plane poles; 0 for s-plane poles.

    Returns
    -------
    float
        In 1/s; negative when a pole does not decay.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.decay_rate([-8, -2 + 1j, -2 - 1j])
    2.0
    >>> round(oc.decay_rate([0.5], discrete_dt=0.1), 6)
    6.931472

    """
    poles = np.asarray(poles, dtype=complex)
    if discrete_dt > 0.0:
        return float(-np.log(np.abs(poles)).max() / discrete_dt)
    return float(-poles.real.max())


def settling_time(poles, discrete_dt: float = 0.0) -> float:
    """
    Designed settling time ``4 / decay rate`` in seconds (inf if not decaying).

    Parameters
    ----------
    poles : array_like of complex
    discrete_dt : float
        As for :func:`decay_rate`.

    Returns
    -------
    float
        Seconds until the slowest mode has decayed to about 2 %.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.settling_time([-8, -2])
    2.0

    """
    rate = decay_rate(poles, discrete_dt)
    return SETTLING_TIME_CONSTANTS / rate if rate > 0 else math.inf


def align(reference_stamps, reference, stamps, values):
    """
    Rows of both series at the stamps they share, in time order.

    Examples
    --------
    >>> from observer_ros.core.evaluation import align
    >>> common, left, right = align([1, 2, 3], [[10], [20], [30]], [2, 3, 4], [[2], [3], [4]])
    >>> common.tolist(), left.tolist(), right.tolist()
    ([2, 3], [[20], [30]], [[2], [3]])

    """
    reference_stamps = np.asarray(reference_stamps, dtype=np.int64)
    stamps = np.asarray(stamps, dtype=np.int64)
    common, left, right = np.intersect1d(reference_stamps, stamps, return_indices=True)
    return common, np.asarray(reference)[left], np.asarray(values)[right]


@dataclass(frozen=True)
class ErrorReport:
    """
    Per-state estimation errors.

    Attributes
    ----------
    names : tuple of str
    times : numpy.ndarray, shape (k,)
        Seconds from the first common sample.
    error : numpy.ndarray, shape (k, n)
        ``x - x_hat``.
    settling_time : float
        Designed settling time (seconds).
    initial, after_settling, final : numpy.ndarray, shape (n,)
        Absolute error at the start, at the first sample after the settling time, at the end.
    rmse : numpy.ndarray, shape (n,)
        Over the whole run.
    max_after_settling : numpy.ndarray, shape (n,)
    convergence_time : float
        First time after which the error norm stays below ``tolerance`` (nan if never).
    tolerance : float

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> stamps = np.arange(0, 3_000_000_000, 500_000_000)
    >>> truth = np.ones((6, 2))
    >>> estimate = truth - np.exp(-2.0 * stamps / 1e9)[:, None] * [1.0, 0.5]
    >>> report = oc.error_report(stamps, truth, estimate, ('x1', 'x2'), settling=2.0)
    >>> report.initial.tolist(), report.after_settling.round(4).tolist()
    ([1.0, 0.5], [0.0183, 0.0092])

    """

    names: tuple
    times: np.ndarray
    error: np.ndarray
    settling_time: float
    initial: np.ndarray
    after_settling: np.ndarray
    final: np.ndarray
    rmse: np.ndarray
    max_after_settling: np.ndarray
    convergence_time: float
    tolerance: float


def error_report(stamps_ns, truth, estimate, names: Sequence[str], settling: float,
                 tolerance: Optional[float] = None) -> ErrorReport:
    """
    Compare an estimate with the truth sampled at the same stamps.

    Parameters
    ----------
    stamps_ns : array_like, shape (k,)
    truth, estimate : array_like, shape (k, n)
    names : sequence of str
    settling : float
        Designed settling time in seconds.
    tolerance : float, optional
        Error-norm tolerance for the convergence time; default 1 % of the initial error norm.

    Returns
    -------
    ErrorReport

    Raises
    ------
    ConfigError
        Naming ``stamps_ns`` when it is empty, ``truth`` or ``estimate`` when their shapes
        do not match ``(k, n)``.

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> stamps = np.arange(0, 3_000_000_000, 500_000_000)
    >>> truth = np.ones((6, 2))
    >>> estimate = truth - np.exp(-2.0 * stamps / 1e9)[:, None] * [1.0, 0.5]
    >>> report = oc.error_report(stamps, truth, estimate, ('x1', 'x2'), settling=2.0)
    >>> report.convergence_time, report.rmse.round(3).tolist()
    (2.5, [0.439, 0.22])

    """
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    if stamps.size == 0:
        raise ConfigError('stamps_ns', 'no common samples between the truth and the estimate')
    truth = np.atleast_2d(np.asarray(truth, dtype=float))
    estimate = np.atleast_2d(np.asarray(estimate, dtype=float))
    for name, values in (('truth', truth), ('estimate', estimate)):
        if values.ndim != 2 or values.shape[0] != stamps.size:
            raise ConfigError(name, f'expected {stamps.size} rows (one per stamp), got shape '
                              f'{values.shape}')
    if estimate.shape != truth.shape:
        raise ConfigError('estimate', f'expected the shape of truth {truth.shape}, got '
                          f'{estimate.shape}')
    times = (stamps - stamps[0]) / 1e9
    error = truth - estimate
    norms = np.linalg.norm(error, axis=1)
    if tolerance is None:
        tolerance = max(1e-2 * norms[0], 1e-12)
    settled = np.flatnonzero(times >= settling) if math.isfinite(settling) else np.array([])
    settle_index = int(settled[0]) if settled.size else len(times) - 1
    above = np.flatnonzero(norms > tolerance)
    if above.size == 0:
        convergence = 0.0
    elif above[-1] + 1 < len(times):
        convergence = float(times[above[-1] + 1])
    else:
        convergence = math.nan
    return ErrorReport(
        names=tuple(names), times=times, error=error, settling_time=settling,
        initial=np.abs(error[0]), after_settling=np.abs(error[settle_index]),
        final=np.abs(error[-1]), rmse=np.sqrt(np.mean(error ** 2, axis=0)),
        max_after_settling=np.abs(error[settle_index:]).max(axis=0),
        convergence_time=convergence, tolerance=tolerance)


def format_error_table(report: ErrorReport) -> str:
    """
    Table: per state initial error, error after the settling time, final error, RMSE.

    Parameters
    ----------
    report : ErrorReport

    Returns
    -------
    str
        One header line, a rule, one line per state and a convergence summary.

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> stamps = np.arange(0, 3_000_000_000, 500_000_000)
    >>> truth = np.ones((6, 2))
    >>> estimate = truth - np.exp(-2.0 * stamps / 1e9)[:, None] * [1.0, 0.5]
    >>> report = oc.error_report(stamps, truth, estimate, ('x1', 'x2'), settling=2.0)
    >>> print(oc.format_error_table(report).splitlines()[-1])
    error norm below 0.0112 from t = 2.500 s (designed settling time 2.000 s)

    """
    header = (f'{"state":<12}{"initial":>12}{f"at t={report.settling_time:.3g} s":>16}'
              f'{"final":>12}{"rmse":>12}{"max after":>12}')
    lines = [header, '-' * len(header)]
    for index, name in enumerate(report.names):
        lines.append(f'{name:<12}{report.initial[index]:>12.3e}'
                     f'{report.after_settling[index]:>16.3e}{report.final[index]:>12.3e}'
                     f'{report.rmse[index]:>12.3e}{report.max_after_settling[index]:>12.3e}')
    lines.append(f'error norm below {report.tolerance:.3g} from t = '
                 f'{report.convergence_time:.3f} s (designed settling time '
                 f'{report.settling_time:.3f} s)')
    return '\n'.join(lines)
