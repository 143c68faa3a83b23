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
