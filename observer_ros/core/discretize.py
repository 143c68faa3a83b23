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

"""Exact sampling of continuous-time models: zero-order hold and Van Loan's method."""

import math
from typing import Optional

import numpy as np
import scipy.linalg

from observer_ros.core.errors import ConfigError
from observer_ros.core.units import NANOSECONDS, seconds_to_ns


def _check_interval(dt: float) -> None:
    if not (math.isfinite(dt) and dt > 0.0):
        raise ConfigError('dt', f'expected a finite sample interval > 0 s, got {dt}')


def zero_order_hold(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """
    Exact zero-order-hold discretization of ``x' = A x + B u`` over ``dt`` seconds.

    Parameters
    ----------
    a : numpy.ndarray, shape (n, n)
    b : numpy.ndarray, shape (n, m)
    dt : float
        Sample interval, > 0.

    Returns
    -------
    ad : numpy.ndarray, shape (n, n)
        ``expm(A dt)``.
    bd : numpy.ndarray, shape (n, m)
        ``integral_0^dt expm(A s) ds B``.

    Raises
    ------
    ConfigError
        Naming ``dt`` when it is not a finite interval > 0.

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> a, b = np.array([[0.0, 1.0], [0.0, 0.0]]), np.array([[0.0], [1.0]])
    >>> ad, bd = oc.zero_order_hold(a, b, 0.1)
    >>> print(ad.round(6))
    [[1.  0.1]
     [0.  1. ]]
    >>> print(bd.round(6))
    [[0.005]
     [0.1  ]]

    """
    _check_interval(dt)
    n_states, n_inputs = b.shape
    block = np.zeros((n_states + n_inputs, n_states + n_inputs))
    block[:n_states, :n_states] = a * dt
    block[:n_states, n_states:] = b * dt
    exponential = scipy.linalg.expm(block)
    return exponential[:n_states, :n_states], exponential[:n_states, n_states:]


def van_loan(a: np.ndarray, process_noise: np.ndarray, dt: float) -> np.ndarray:
    """
    Covariance of the sampled process noise (Van Loan's method).

    For ``x' = A x + w`` with white noise of intensity ``Q`` (``process_noise``), the noise
    added over one interval ``dt`` of the exact discrete model has covariance
    ``Qd = integral_0^dt expm(A s) Q expm(A s)^T ds``.

    Parameters
    ----------
    a : numpy.ndarray, shape (n, n)
    process_noise : numpy.ndarray, shape (n, n)
        Continuous-time intensity ``Q``.
    dt : float
        Sample interval, > 0.

    Returns
    -------
    numpy.ndarray, shape (n, n)
        Symmetric ``Qd``.

    Raises
    ------
    ConfigError
        Naming ``dt`` when it is not a finite interval > 0.

    Examples
    --------
    A random walk ``x' = w`` gathers ``Q dt`` over ``dt``:

    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> oc.van_loan(np.zeros((1, 1)), np.array([[2.0]]), 0.1).round(12).tolist()
    [[0.2]]

    References
    ----------
    C. F. Van Loan, "Computing integrals involving the matrix exponential", IEEE Trans.
    Automatic Control 23(3), 1978.

    """
    _check_interval(dt)
    n_states = a.shape[0]
    block = np.zeros((2 * n_states, 2 * n_states))
    block[:n_states, :n_states] = -a * dt
    block[:n_states, n_states:] = process_noise * dt
    block[n_states:, n_states:] = a.T * dt
    exponential = scipy.linalg.expm(block)
    ad_transpose = exponential[n_states:, n_states:]
    qd = ad_transpose.T @ exponential[:n_states, n_states:]
    return 0.5 * (qd + qd.T)


def transition(model, dt: float, process_noise: Optional[np.ndarray] = None) -> tuple:
    """
    Return ``(Ad, Bd, Qd)``: the model over ``dt`` seconds with the input held.

    A continuous model is sampled exactly (zero-order hold; ``Qd`` by Van Loan's method from
    the intensity ``process_noise``). A discrete model takes ``round(dt / model.dt)`` of its
    periods (none for ``dt`` under half a period): ``Ad = A^k``, ``Bd = sum A^i B`` and
    ``Qd = sum A^i Q A^i^T`` with ``Q`` its per-period covariance.

    Parameters
    ----------
    model : StateSpaceModel
    dt : float
        Seconds, >= 0.
    process_noise : numpy.ndarray, shape (n, n), optional
        ``Q``; without it ``Qd`` is None.

    Returns
    -------
    tuple
        ``(Ad (n, n), Bd (n, m), Qd (n, n) or None)``.

    Examples
    --------
    >>> from observer_ros.core.model import StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> ad, bd, _ = transition(model, 0.5)
    >>> ad.tolist(), bd.ravel().tolist()
    ([[1.0, 0.5], [0.0, 1.0]], [0.125, 0.5])

    """
    a, b = model.a, model.b
    n_states = a.shape[0]
    if not model.is_discrete:
        if dt == 0.0:
            qd = None if process_noise is None else np.zeros((n_states, n_states))
            return np.eye(n_states), np.zeros_like(b), qd
        ad, bd = zero_order_hold(a, b, dt)
        qd = None if process_noise is None else van_loan(a, process_noise, dt)
        return ad, bd, qd
    periods = max(0, round(dt / model.dt))
    ad, bd = np.eye(n_states), np.zeros_like(b)
    qd = None if process_noise is None else np.zeros((n_states, n_states))
    for _ in range(periods):
        bd = a @ bd + b
        if qd is not None:
            qd = a @ qd @ a.T + process_noise
        ad = a @ ad
    return ad, bd, qd


#: Largest ``alpha |delta|`` (``alpha = max(||A||_1, ||A||_inf)``) summed as a series.
SERIES_REACH = 0.5

#: Intervals that are whole multiples of this (1 ms) are sampled with ``expm`` exactly; the
#: others are composed from the multiple below them (:class:`IntervalSampler`).
EXACT_GRID_NS = 1_000_000

#: Truncation of the series of a step, relative to its leading term (eps / 8).
SERIES_TOLERANCE = 2.0 ** -55

#: Multiples sampled with ``expm`` that are kept (the oldest made again when needed).
MAX_ANCHORS = 256


def series_terms(theta: float) -> int:
    """
    Return the terms ``K`` after which a series in ``theta`` is cut: ``theta^K / K!`` small.

    The smallest ``K`` >= 1 with ``theta^K / K! <= SERIES_TOLERANCE``; for ``theta <= 0.5``
    the terms left out then sum to at most twice that.
    """
    terms, bound = 1, theta
    while bound > SERIES_TOLERANCE:
        terms += 1
        bound *= theta / terms
    return terms


class IntervalSampler:
    """
    ``(Ad, Bd, Qd)`` of a continuous model over intervals that jitter, without an ``expm`` each.

    An interval that is a whole multiple of ``grid_ns`` (:data:`EXACT_GRID_NS`, 1 ms; for
    a model with ``alpha > 500 /s`` the largest power of ten nanoseconds up to
    ``SERIES_REACH / alpha``) is sampled exactly (:func:`zero_order_hold`,
    :func:`van_loan`: ``expm``), once. Another, ``t = t0 + delta`` with ``t0`` the multiple
    below it (none, ``t0 = 0``, under one ``grid_ns``), is composed from it and the step over
    ``delta``: ``Ad(t) = Ad(delta) Ad(t0)``, ``Bd(t) = Bd(delta) + Ad(delta) Bd(t0)``,
    ``Qd(t) = Qd(delta) + Ad(delta) Qd(t0) Ad(delta)^T`` (exact identities), the step's
    three from the Taylor series of the block exponential
    ``expm([[A, Q, B], [0, -A^T, 0], [0, 0, 0]] delta)`` (``Qd(delta) = G Ad(delta)^T``, with
    ``G`` its upper middle block), cut where the terms left out are below ``2^-54`` of the
    leading one (``theta = alpha delta <= 0.5``). A composed interval agrees with ``expm``'s
    within a few units in the last place, not bit for bit; a steady rate of whole
    milliseconds (1 kHz, 100 Hz) is ``expm``'s exactly, as :func:`transition` gives. The
    numbers of an interval depend on it alone, not on the order intervals come in (a
    history re-run gives those of a run in stamp order).

    Parameters
    ----------
    a : numpy.ndarray, shape (n, n)
    b : numpy.ndarray, shape (n, m)
    process_noise : numpy.ndarray, shape (n, n)
        Continuous-time intensity ``Q``.

    Examples
    --------
    >>> import numpy as np
    >>> sampler = IntervalSampler(np.array([[0.0, 1.0], [-4.0, -0.4]]), np.array([[0.0], [1.0]]),
    ...                           np.diag([0.0, 0.04]))
    >>> ad, bd, qd = sampler.sample(10_000_000)  # whole milliseconds: expm
    >>> ad, bd, qd = sampler.sample(10_100_000)  # composed from it
    >>> exact, _ = zero_order_hold(sampler.a, sampler.b, 0.0101)
    >>> bool(np.allclose(ad, exact, rtol=0.0, atol=1e-15)), sampler.anchors()
    (True, [10000000])

    """

    def __init__(self, a: np.ndarray, b: np.ndarray, process_noise: np.ndarray) -> None:
        self.a, self.b, self.process_noise = a, b, process_noise
        n_states, n_inputs = b.shape
        self.n_states = n_states
        size = 2 * n_states + n_inputs
        block = np.zeros((size, size))
        block[:n_states, :n_states] = a
        block[:n_states, n_states:2 * n_states] = process_noise
        block[n_states:2 * n_states, n_states:2 * n_states] = -a.T
        block[:n_states, 2 * n_states:] = b
        self._block = block
        self._first_row = np.ascontiguousarray(np.eye(n_states, size))
        self.alpha = float(max(np.abs(a).sum(axis=0).max(initial=0.0),
                               np.abs(a).sum(axis=1).max(initial=0.0)))
        # The reach to the nearest nanosecond (the one rule; half a nanosecond past it is far
        # inside the series' cut at 2**-54), capped at a second: any reach from the grid up
        # gives the grid, and a tiny alpha would overflow.
        reach_ns = (seconds_to_ns(min(SERIES_REACH / self.alpha, 1.0), 'series reach')
                    if self.alpha > 0.0 else EXACT_GRID_NS)
        #: Multiples of this (ns) are sampled with expm; 1 ms, or the largest power of ten
        #: nanoseconds within the series' reach for a fast model.
        self.grid_ns = (EXACT_GRID_NS if reach_ns >= EXACT_GRID_NS
                        else 10 ** (len(str(max(1, reach_ns))) - 1))
        self._anchors: dict = {}

    def anchors(self) -> list:
        """Return the intervals (ns) sampled with ``expm`` and kept, in increasing order."""
        return sorted(self._anchors)

    def clear(self) -> None:
        """Forget the intervals sampled."""
        self._anchors.clear()

    def sample(self, dt_ns: int) -> tuple:
        """Return ``(Ad, Bd, Qd)`` over ``dt_ns`` nanoseconds (> 0)."""
        grid = self.grid_ns
        base = dt_ns // grid * grid
        if base == dt_ns:
            return self._anchor(base)
        step = self.step((dt_ns - base) / NANOSECONDS)
        return step if not base else compose(self._anchor(base), step)

    def _anchor(self, base_ns: int) -> tuple:
        anchors = self._anchors
        value = anchors.get(base_ns)
        if value is None:
            if len(anchors) >= MAX_ANCHORS:
                del anchors[next(iter(anchors))]
            value = anchors[base_ns] = self._exact(base_ns)
        return value

    def _exact(self, dt_ns: int) -> tuple:
        dt = dt_ns / NANOSECONDS
        ad, bd = zero_order_hold(self.a, self.b, dt)
        return ad, bd, van_loan(self.a, self.process_noise, dt)

    def step(self, delta: float) -> tuple:
        """
        Return ``(Ad, Bd, Qd)`` over ``delta`` seconds by the series (``alpha delta <= 0.5``).

        Raises
        ------
        ConfigError
            Naming ``dt`` when ``delta`` is not in ``(0, SERIES_REACH / alpha]``.

        """
        theta = delta * self.alpha
        if not (delta > 0.0 and theta <= SERIES_REACH):
            raise ConfigError('dt', f'expected a step in (0, {SERIES_REACH} / alpha] s for '
                              f'the series, got {delta}')
        scaled = self._block * delta
        row = self._first_row
        total = row.copy()
        for k in range(1, series_terms(theta) + 1):
            row = row @ scaled
            row *= 1.0 / k
            total += row
        n_states = self.n_states
        ad = total[:, :n_states]
        qd = total[:, n_states:2 * n_states] @ ad.T
        return ad, total[:, 2 * n_states:], 0.5 * (qd + qd.T)


def compose(earlier: tuple, step: tuple) -> tuple:
    """
    Return ``(Ad, Bd, Qd)`` over ``t0 + delta`` from those over ``t0`` then ``delta``.

    ``Ad = Ad2 Ad1``, ``Bd = Bd2 + Ad2 Bd1``, ``Qd = Qd2 + Ad2 Qd1 Ad2^T`` (the model over
    ``t0`` and then over ``delta``, the input held).
    """
    ad1, bd1, qd1 = earlier
    ad2, bd2, qd2 = step
    qd = ad2 @ qd1 @ ad2.T
    qd += qd2
    return ad2 @ ad1, bd2 + ad2 @ bd1, 0.5 * (qd + qd.T)
