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
The observer-controller from the Diophantine equation ``A R + B S = A_cl`` (SISO).

For a single-output plant the controller of a given order that yields a closed-loop
polynomial is unique, whatever observer gain produced it: :func:`diophantine_controller`
is the independent reference G_oc is checked against.
"""

import numpy as np

from observer_ros.core.errors import DesignError
from observer_ros.core.loop_analysis.transfer_function import (
    ControllerTransferFunction, from_polynomials, siso_zpk)
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.poles import clean_poles


def solve_diophantine(a_poly, b_poly, closed_loop_poly):
    """
    Solve ``A R + B S = A_cl`` for the controller ``S / R`` (polynomials, highest power first).

    ``deg R = deg A_cl - deg A`` and ``deg S = deg A - 1``; the Sylvester matrix is square
    and the solution unique when ``A`` and ``B`` are coprime.

    Parameters
    ----------
    a_poly : array_like, shape (n + 1,)
        Plant denominator ``A``.
    b_poly : array_like, shape (n + 1,) or shorter
        Plant numerator ``B``.
    closed_loop_poly : array_like, shape (2 n,) or longer
        Desired closed-loop polynomial ``A_cl``.

    Returns
    -------
    r_poly : numpy.ndarray, shape (deg A_cl - n + 1,)
    s_poly : numpy.ndarray, shape (n,)

    Raises
    ------
    DesignError
        Naming ``closed_loop_poly`` when the degrees don't fit; unnamed when ``A`` and
        ``B`` share a root (the plant has a cancellation).

    Examples
    --------
    A double integrator ``1 / s^2`` with the closed loop ``(s + 2)(s + 2.5)(s + 8)(s + 9)``:

    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> r_poly, s_poly = oc.solve_diophantine([1, 0, 0], [1], np.poly([-2, -2.5, -8, -9]))
    >>> r_poly.round(6).tolist(), s_poly.round(6).tolist()
    ([1.0, 21.5, 153.5], [409.0, 360.0])

    """
    r_poly, s_poly, _ = _solve_diophantine(a_poly, b_poly, closed_loop_poly)
    return r_poly, s_poly


def _solve_diophantine(a_poly, b_poly, closed_loop_poly):
    """:func:`solve_diophantine` plus the condition number of its (scaled) Sylvester matrix."""
    a_poly = np.trim_zeros(np.asarray(a_poly, dtype=float), 'f')
    b_poly = np.trim_zeros(np.asarray(b_poly, dtype=float), 'f')
    acl = np.trim_zeros(np.asarray(closed_loop_poly, dtype=float), 'f')
    n = a_poly.size - 1
    deg_r = acl.size - 1 - n
    deg_s = n - 1
    if deg_r < deg_s or b_poly.size - 1 > n:
        raise DesignError(
            f'the closed-loop polynomial has degree {acl.size - 1}; a proper controller for a '
            f'plant of degree {n} needs at least {2 * n - 1}', parameter='closed_loop_poly')
    # Frequency scaling s = sigma s' (sigma: the geometric mean of the closed-loop root
    # magnitudes) balances the coefficients; the columns are then equilibrated, and one step
    # of iterative refinement recovers what the solve lost.
    sigma = 1.0
    if acl[-1] != 0.0 and acl.size > 1:
        sigma = float(abs(acl[-1] / acl[0]) ** (1.0 / (acl.size - 1)))
    a_scaled = a_poly / sigma ** np.arange(n + 1)
    b_scaled = np.concatenate([np.zeros(n + 1 - b_poly.size), b_poly]) / sigma ** np.arange(
        n + 1)
    acl_scaled = acl / sigma ** np.arange(acl.size)
    unknowns = deg_r + 1 + deg_s + 1
    matrix = np.zeros((acl.size, unknowns))
    for j in range(deg_r + 1):  # column j multiplies s^(deg_r - j) in R
        matrix[j:j + n + 1, j] = a_scaled
    for j in range(deg_s + 1):
        shift = acl.size - (deg_s - j) - (n + 1)
        matrix[shift:shift + n + 1, deg_r + 1 + j] = b_scaled
    columns = np.linalg.norm(matrix, axis=0)
    columns[columns == 0.0] = 1.0
    equilibrated = matrix / columns
    condition = np.linalg.cond(equilibrated)
    if not np.isfinite(condition) or condition > 1e13:
        raise DesignError(
            'the Diophantine equation is singular: the plant numerator and denominator share '
            'a root (a pole-zero cancellation), so the closed loop cannot be assigned')
    solution = np.linalg.solve(equilibrated, acl_scaled)
    solution = solution + np.linalg.solve(equilibrated, acl_scaled - equilibrated @ solution)
    solution = solution / columns
    r_poly = solution[:deg_r + 1] * sigma ** np.arange(deg_r + 1)
    s_poly = solution[deg_r + 1:] * sigma ** np.arange(deg_r - deg_s, deg_r + 1)
    return r_poly, s_poly, float(condition)


def diophantine_controller(model: StateSpaceModel, controller_poles,
                           observer_poles) -> ControllerTransferFunction:
    """
    ``G_oc = S / R`` from ``A R + B S = prod(s - controller poles) prod(s - observer poles)``.

    The cross-check of the state-space observer-controller: for a single-output plant the
    controller of a given order is unique, whatever observer gain produced it.

    Parameters
    ----------
    model : StateSpaceModel
        Single input, single output, of order ``n``.
    controller_poles : array_like of complex, shape (n,)
        Poles of ``A - B K``.
    observer_poles : array_like of complex, shape (q,)
        The observer's error poles (``q = n`` full order, ``n - 1`` reduced order).

    Returns
    -------
    ControllerTransferFunction

    Raises
    ------
    DesignError
        Naming ``model`` when it is not single-input single-output; as
        :func:`solve_diophantine` otherwise.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> oc.diophantine_controller(model, [-2, -2.5], [-8, -9]).format_polynomials()
    '(409 s + 360) / (s^2 + 21.5 s + 153.5)'

    """
    if model.n_inputs != 1 or model.n_outputs != 1:
        raise DesignError('the Diophantine design is for single-input single-output plants',
                          parameter='model')
    closed = np.concatenate([np.ravel(controller_poles), np.ravel(observer_poles)])
    closed = np.asarray(closed, dtype=complex)
    r_poly, s_poly, shift, sigma, _ = diophantine_scaled(model, closed)
    # Back from w = (s - shift) / sigma to s (z): R(s) = R_w((s - shift) / sigma).
    to_w = np.polynomial.Polynomial([-shift / sigma, 1.0 / sigma])
    r_poly = np.polynomial.Polynomial(r_poly[::-1])(to_w).coef[::-1]
    s_poly = np.polynomial.Polynomial(s_poly[::-1])(to_w).coef[::-1]
    return from_polynomials(s_poly, r_poly, model.is_discrete)


def diophantine_scaled(model: StateSpaceModel, closed_roots: np.ndarray):
    """
    Solve the Diophantine equation in ``w = (s - shift) / sigma``; ``(R_w, S_w, shift, sigma)``.

    Every polynomial is built from its roots in ``w``: ``shift`` is 1 for a discrete model
    (whose poles crowd around ``z = 1``, where coefficients in ``z`` lose their digits) and
    0 otherwise, ``sigma`` the geometric mean of the shifted closed-loop root magnitudes.
    ``G_oc = S_w(w) / R_w(w)``.
    """
    zeros, poles, gain = siso_zpk(model.a, model.b, model.c, model.d)
    shift = 1.0 if model.is_discrete else 0.0
    shifted = closed_roots - shift
    magnitudes = np.abs(shifted[np.abs(shifted) > 0])
    sigma = float(np.exp(np.mean(np.log(magnitudes)))) if magnitudes.size else 1.0
    den = np.real(np.poly(clean_poles((poles - shift) / sigma)))
    num = gain * sigma ** (zeros.size - poles.size) * (
        np.real(np.poly(clean_poles((zeros - shift) / sigma))) if zeros.size else np.ones(1))
    closed = np.real(np.poly(clean_poles(shifted / sigma)))
    r_poly, s_poly, condition = _solve_diophantine(den, num, closed)
    return r_poly, s_poly, shift, sigma, condition
