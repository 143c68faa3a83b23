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
The observer-controller as one system.

``G_oc = -U / Y``, the Diophantine cross-check and the closed loop of the separation
principle.
"""

from dataclasses import dataclass
import warnings

import numpy as np
import scipy.linalg
import scipy.signal

from observer_ros.core.analysis import format_modes
from observer_ros.core.design.common import ObserverRealization
from observer_ros.core.errors import DesignError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement import sort_poles
from observer_ros.core.poles import is_stable

#: Leading numerator coefficients below this (relative to the largest) are dropped.
COEFFICIENT_RTOL = 1e-10


class UnstableControllerWarning(UserWarning):
    """
    The observer-controller is stable in closed loop but unstable on its own.

    Examples
    --------
    The seed plant's reduced-order observer-controller has a pole at ``s = 1.6``:

    >>> import warnings
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices(
    ...     [[0, 1, 0], [0, 0, 1], [0, -24, -10]], [[0], [10], [-80]], [[1, 0, 0]])
    >>> observer = oc.design_reduced_order(model, poles=[-10, -10])
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter('always')
    ...     tf = oc.controller_transfer_function(model, observer.realization,
    ...                                          np.array([[1.25, 1.25, 0.19375]]))
    >>> caught[0].category.__name__, tf.format_polynomials()
    ('UnstableControllerWarning', '(9.1 s^2 + 73.5 s + 125) / (s^2 + 17 s - 30)')

    """


@dataclass(frozen=True)
class ControllerTransferFunction:
    """
    SISO transfer function ``G_oc(s) = -U(s) / Y(s) = num / den``.

    ``num`` and ``den`` list coefficients from the highest power down; ``den`` is monic.
    ``zeros``, ``poles`` and ``gain`` give the zero-pole-gain form
    ``gain * prod(s - zeros) / prod(s - poles)``.

    Attributes
    ----------
    num, den : numpy.ndarray, shapes (k + 1,) and (q + 1,)
        Polynomial coefficients, highest power first; ``q`` is the controller's order.
    zeros, poles : numpy.ndarray of complex, shapes (k,) and (q,)
    gain : float
        Leading numerator coefficient.
    discrete : bool
        Whether ``s`` stands for ``z`` (a discrete model).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> observer = oc.design_full_order(model, poles=[-8, -9])
    >>> k = oc.design_feedback(model, poles=[-2, -2.5]).gain
    >>> tf = oc.controller_transfer_function(model, observer.realization, k)
    >>> tf.format_polynomials(), tf.format_zpk(), tf.unstable
    ('(409 s + 360) / (s^2 + 21.5 s + 153.5)', '409 (s+0.8802) / (s^2+21.5s+153.5)', False)

    """

    num: np.ndarray
    den: np.ndarray
    zeros: np.ndarray
    poles: np.ndarray
    gain: float
    discrete: bool

    @property
    def unstable(self) -> bool:
        """Whether the controller on its own has unstable poles."""
        return not is_stable(self.poles, self.discrete) if self.poles.size else False

    def format_zpk(self, variable: str = 's') -> str:
        """Zero-pole-gain text like the seeds: ``11.6 (s+5.593) (s+2.312) / ...``."""
        def factors(roots):
            parts = []
            for root in sort_poles(roots):
                if root.imag < -1e-12:
                    continue
                if abs(root.imag) <= 1e-12 * max(1.0, abs(root)):
                    parts.append(f'({variable}{-root.real:+.4g})')
                else:
                    parts.append(f'({variable}^2{-2 * root.real:+.4g}{variable}'
                                 f'{abs(root) ** 2:+.4g})')
            return ' '.join(parts) or '1'
        return f'{self.gain:.4g} {factors(self.zeros)} / {factors(self.poles)}'

    def format_polynomials(self, variable: str = 's') -> str:
        """``(9.1 s^2 + 73.5 s + 125) / (s^2 + 17 s - 30)``."""
        return f'({polynomial_text(self.num, variable)}) / ({polynomial_text(self.den, variable)})'


def polynomial_text(coefficients, variable: str = 's') -> str:
    """
    Format coefficients (highest power first) as ``9.1 s^2 + 73.5 s + 125``.

    Examples
    --------
    >>> from observer_ros.core.design.controller import polynomial_text
    >>> polynomial_text([1, 17, -30], 'z')
    'z^2 + 17 z - 30'

    """
    coefficients = np.asarray(coefficients, dtype=float)
    degree = coefficients.size - 1
    terms = []
    for index, value in enumerate(coefficients):
        power = degree - index
        if value == 0.0 and coefficients.size > 1:
            continue
        magnitude = abs(value)
        text = '' if (magnitude == 1.0 and power > 0) else f'{magnitude:.6g}'
        if power > 0:
            text += (' ' if text else '') + variable + (f'^{power}' if power > 1 else '')
        sign = '-' if value < 0 else '+'
        terms.append((sign, text))
    if not terms:
        return '0'
    first_sign, first = terms[0]
    return ('-' if first_sign == '-' else '') + first + ''.join(
        f' {sign} {text}' for sign, text in terms[1:])


def controller_state_space(realization: ObserverRealization, feedback_gain: np.ndarray):
    """
    Close the observer with ``u = -K x_hat``: a system from ``y`` to ``u``.

    Parameters
    ----------
    realization : ObserverRealization
        The observer, of order ``q``.
    feedback_gain : numpy.ndarray, shape (m, n)
        ``K``.

    Returns
    -------
    a_c, b_c, c_c, d_c : numpy.ndarray, shapes (q, q), (q, p), (m, q), (m, p)
        ``xi' = A_c xi + B_c y`` and ``u = C_c xi + D_c y``;
        ``G_oc = -(C_c (sI - A_c)^-1 B_c + D_c)``.

    Raises
    ------
    DesignError
        Naming ``feedback_gain`` when ``I + K D_u`` is singular (an algebraic loop).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> observer = oc.design_full_order(model, poles=[-8, -9])
    >>> k = oc.design_feedback(model, poles=[-2, -2.5]).gain
    >>> a_c, b_c, c_c, d_c = oc.controller_state_space(observer.realization, k)
    >>> a_c.round(6).tolist(), c_c.round(6).tolist()
    ([[-17.0, 1.0], [-77.0, -4.5]], [[-5.0, -4.5]])

    """
    k = feedback_gain
    n_inputs = k.shape[0]
    loop = np.eye(n_inputs) + k @ realization.d_u
    try:
        closing = -np.linalg.solve(loop, k)
    except np.linalg.LinAlgError as e:
        raise DesignError('the observer-controller has an algebraic loop with no solution',
                          parameter='feedback_gain') from e
    c_c = closing @ realization.c
    d_c = closing @ realization.d_y
    a_c = realization.a + realization.b_u @ c_c
    b_c = realization.b_y + realization.b_u @ d_c
    return a_c, b_c, c_c, d_c


def _numerator(a, b, c, d, den) -> np.ndarray:
    """
    Numerator of ``c (sI - a)^-1 b + d`` with denominator ``den``, by interpolation.

    ``N(s) = G(s) den(s)`` is sampled at ``order + 1`` points on a circle through the poles'
    magnitude and its coefficients read off with one FFT. Unlike ``ss2tf`` (the roots of
    ``a - b c``), this stays accurate for the ill-conditioned bases that Chen's and the
    reduced-order designs produce: each sample is a well-posed linear solve.
    """
    order = a.shape[0]
    if order == 0:
        return np.atleast_1d(d[0, 0])
    magnitudes = np.abs(np.linalg.eigvals(a))
    magnitudes = magnitudes[magnitudes > 0]
    radius = float(np.exp(np.log(magnitudes).mean())) if magnitudes.size else 1.0
    count = order + 1
    points = radius * np.exp(2j * np.pi * np.arange(count) / count)
    identity = np.eye(order)
    values = np.array([
        (c @ np.linalg.solve(point * identity - a, b) + d)[0, 0] * np.polyval(den, point)
        for point in points])
    ascending = (np.fft.fft(values) / count).real / radius ** np.arange(count)
    return ascending[::-1]


def _transfer_function(num, den, discrete) -> ControllerTransferFunction:
    num = np.atleast_1d(np.real(np.squeeze(num)))
    den = np.atleast_1d(np.real(np.squeeze(den)))
    leading = den[0]
    num, den = num / leading, den / leading
    scale = max(np.abs(num).max(), 1e-300)
    while num.size > 1 and abs(num[0]) <= COEFFICIENT_RTOL * scale:
        num = num[1:]
    num = np.where(np.abs(num) <= COEFFICIENT_RTOL * scale, 0.0, num)
    return ControllerTransferFunction(
        num=num, den=den, zeros=sort_poles(np.roots(num)) if num.size > 1 else np.array([]),
        poles=sort_poles(np.roots(den)), gain=float(num[0]), discrete=discrete)


def controller_transfer_function(model: StateSpaceModel, realization: ObserverRealization,
                                 feedback_gain: np.ndarray) -> ControllerTransferFunction:
    """
    Compute the observer-controller transfer function ``G_oc = -U / Y`` (SISO).

    Works for every observer type through its :class:`ObserverRealization`. Warns with
    :class:`UnstableControllerWarning` when the controller itself is unstable (legal, as in
    the seed example ``(9.1 s^2 + 73.5 s + 125) / (s^2 + 17 s - 30)``, but the loop must
    then never be opened).

    Parameters
    ----------
    model : StateSpaceModel
        Single input, single output.
    realization : ObserverRealization
        The observer (``design.realization`` of any observer design).
    feedback_gain : numpy.ndarray, shape (1, n)
        ``K``.

    Returns
    -------
    ControllerTransferFunction

    Raises
    ------
    DesignError
        Naming ``model`` when the plant is not single-input single-output.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> observer = oc.design_full_order(model, poles=[-8, -9])
    >>> k = oc.design_feedback(model, poles=[-2, -2.5]).gain
    >>> oc.controller_transfer_function(model, observer.realization, k).format_polynomials()
    '(409 s + 360) / (s^2 + 21.5 s + 153.5)'

    """
    if model.n_inputs != 1 or model.n_outputs != 1:
        raise DesignError(
            f'G_oc is computed for single-input single-output plants; this one has '
            f'{model.n_inputs} inputs and {model.n_outputs} outputs', parameter='model')
    a_c, b_c, c_c, d_c = controller_state_space(realization, feedback_gain)
    den = np.poly(a_c) if a_c.size else np.ones(1)
    num = _numerator(a_c, b_c, -c_c, -d_c, den)
    result = _transfer_function(num, den, model.is_discrete)
    if result.unstable:
        warnings.warn(
            f'the observer-controller is unstable on its own (poles '
            f'{format_modes(result.poles)}): the closed loop is stable, but opening it '
            f'(saturation, a lost measurement) lets the controller state diverge',
            UnstableControllerWarning, stacklevel=2)
    return result


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
    unknowns = deg_r + 1 + deg_s + 1
    matrix = np.zeros((acl.size, unknowns))
    for j in range(deg_r + 1):  # column j multiplies s^(deg_r - j) in R
        matrix[j:j + a_poly.size, j] = a_poly
    b_padded = np.concatenate([np.zeros(n + 1 - b_poly.size), b_poly])
    for j in range(deg_s + 1):
        shift = acl.size - (deg_s - j) - (n + 1)
        matrix[shift:shift + n + 1, deg_r + 1 + j] = b_padded
    condition = np.linalg.cond(matrix)
    if not np.isfinite(condition) or condition > 1e13:
        raise DesignError(
            'the Diophantine equation is singular: the plant numerator and denominator share '
            'a root (a pole-zero cancellation), so the closed loop cannot be assigned')
    solution = np.linalg.solve(matrix, acl)
    return solution[:deg_r + 1], solution[deg_r + 1:]


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
    num, den = scipy.signal.ss2tf(model.a, model.b, model.c, model.d)
    closed = np.real(np.poly(np.concatenate([np.ravel(controller_poles),
                                             np.ravel(observer_poles)])))
    r_poly, s_poly = solve_diophantine(den, np.ravel(num), closed)
    return _transfer_function(s_poly, r_poly, model.is_discrete)


def closed_loop_matrix(model: StateSpaceModel, realization: ObserverRealization,
                       feedback_gain: np.ndarray) -> np.ndarray:
    """
    State matrix of plant plus observer under ``u = -K x_hat``, states ``[x; xi]``.

    By the separation principle its eigenvalues are ``eig(A - B K)`` together with the
    observer's error poles.

    Parameters
    ----------
    model : StateSpaceModel
    realization : ObserverRealization
        The observer, of order ``q``.
    feedback_gain : numpy.ndarray, shape (m, n)
        ``K``.

    Returns
    -------
    numpy.ndarray, shape (n + q, n + q)

    Raises
    ------
    DesignError
        As :func:`controller_state_space`.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> observer = oc.design_full_order(model, poles=[-8, -9])
    >>> k = oc.design_feedback(model, poles=[-2, -2.5]).gain
    >>> oc.closed_loop_matrix(model, observer.realization, k).shape
    (4, 4)

    """
    a_c, b_c, c_c, d_c = controller_state_space(realization, feedback_gain)
    n_inputs = model.n_inputs
    # u = C_c xi + D_c y and y = C x + D u  ->  (I - D_c D) u = C_c xi + D_c C x
    loop = np.eye(n_inputs) - d_c @ model.d
    u_of_x = np.linalg.solve(loop, d_c @ model.c)
    u_of_xi = np.linalg.solve(loop, c_c)
    y_of_x = model.c + model.d @ u_of_x
    y_of_xi = model.d @ u_of_xi
    top = np.hstack([model.a + model.b @ u_of_x, model.b @ u_of_xi])
    bottom = np.hstack([b_c @ y_of_x, a_c + b_c @ y_of_xi])
    return np.vstack([top, bottom])


#: Relative imaginary part below which a computed pole pair is a split real double pole.
SPLIT_RTOL = 1e-7


def closed_loop_poles(model: StateSpaceModel, realization: ObserverRealization,
                      feedback_gain: np.ndarray) -> np.ndarray:
    """
    Sorted eigenvalues of :func:`closed_loop_matrix`.

    A repeated real pole comes out of ``eig`` as a pair split by about ``sqrt(eps)``, often
    into the complex plane; pairs whose imaginary part is below ``SPLIT_RTOL`` of their
    magnitude are reported as the real double pole they are.

    Parameters
    ----------
    model : StateSpaceModel
    realization : ObserverRealization
    feedback_gain : numpy.ndarray, shape (m, n)

    Returns
    -------
    numpy.ndarray of complex, shape (n + q,)
        Sorted: the controller poles and the observer poles (separation principle).

    Raises
    ------
    DesignError
        As :func:`controller_state_space`.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> observer = oc.design_full_order(model, poles=[-8, -9])
    >>> k = oc.design_feedback(model, poles=[-2, -2.5]).gain
    >>> oc.closed_loop_poles(model, observer.realization, k).real.round(6).tolist()
    [-9.0, -8.0, -2.5, -2.0]

    """
    poles = scipy.linalg.eigvals(closed_loop_matrix(model, realization, feedback_gain))
    split = np.abs(poles.imag) <= SPLIT_RTOL * np.maximum(1.0, np.abs(poles))
    poles = np.where(split, poles.real + 0j, poles)
    return sort_poles(poles)
