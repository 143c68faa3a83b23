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

#: The settling time is this many time constants of the slowest observer pole (2 %).
SETTLING_TIME_CONSTANTS = 4.0


def decay_rate(poles, discrete_dt: float = 0.0) -> float:
    """
    Slowest decay rate ``-max Re(lambda)`` (1/s) of the error dynamics.

    Discrete poles (``discrete_dt > 0``) are converted with ``ln|z| / dt``.
    """
    poles = np.asarray(poles, dtype=complex)
    if discrete_dt > 0.0:
        return float(-np.log(np.abs(poles)).max() / discrete_dt)
    return float(-poles.real.max())


def settling_time(poles, discrete_dt: float = 0.0) -> float:
    """Designed settling time ``4 / decay rate`` in seconds (inf if not decaying)."""
    rate = decay_rate(poles, discrete_dt)
    return SETTLING_TIME_CONSTANTS / rate if rate > 0 else math.inf


def align(reference_stamps, reference, stamps, values):
    """Rows of both series at the stamps they share, in time order."""
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

    """
    stamps = np.asarray(stamps_ns, dtype=np.int64)
    if stamps.size == 0:
        raise ValueError('no common samples between the truth and the estimate')
    times = (stamps - stamps[0]) / 1e9
    error = np.asarray(truth, dtype=float) - np.asarray(estimate, dtype=float)
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
    """Table: per state initial error, error after the settling time, final error, RMSE."""
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
