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

from observer_ros.core.analysis import format_modes
from observer_ros.core.design.common import ObserverRealization
from observer_ros.core.errors import DesignError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement import sort_poles
from observer_ros.core.poles import clean_poles, is_stable

#: Leading numerator coefficients below this (relative to the largest) are dropped.
COEFFICIENT_RTOL = 1e-10

#: A Markov parameter below this (relative to ``|c| |a|^(k-1) |b|``) counts as zero.
MARKOV_RTOL = 1e-12


#: G_oc and the Diophantine controller of the same closed loop must agree this closely
#: (largest relative difference of their frequency responses, see
#: :func:`response_disagreement`); beyond it :func:`controller_transfer_function` warns.
AGREEMENT_RTOL = 1e-8

#: Beyond this disagreement :func:`controller_transfer_function` refuses the design.
REFUSAL_RTOL = 1e-5

#: Points of the frequency grid of :func:`response_disagreement`.
GRID_POINTS = 200

#: Responses below this fraction of the largest one on the grid count as that fraction.
RESPONSE_FLOOR = 1e-9

#: The Diophantine reference is taken to be accurate to this many times ``eps`` times the
#: condition number of its (scaled) Sylvester matrix; a disagreement within that is not
#: held against G_oc (it warns, but does not refuse).
REFERENCE_SLACK = 10.0


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


class ControllerMismatchWarning(UserWarning):
    """G_oc and the Diophantine solution disagree (or could not be compared)."""


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


def _balanced(a, b, c):
    """Diagonal similarity that balances ``a`` (LAPACK's ``gebal``), applied to ``b`` and ``c``."""
    if a.size == 0:
        return a, b, c
    _, (scale, _) = scipy.linalg.matrix_balance(a, permute=False, separate=True)
    return a * scale[None, :] / scale[:, None], b / scale[:, None], c * scale[None, :]


def siso_zpk(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray):
    """
    Zeros, poles and gain of ``c (sI - a)^-1 b + d`` (one input, one output).

    Each piece comes from a backward-stable eigenvalue problem on a balanced realization: the
    poles are ``eig(a)``, the zeros the finite generalized eigenvalues of the Rosenbrock pencil
    ``[[a, b], [c, d]] - s [[I, 0], [0, 0]]`` (QZ), and the gain the first Markov parameter
    (``d``, ``c b``, ``c a b``...) that is not negligible. Unlike coefficients read off
    samples of ``G(s) den(s)``, none of this loses accuracy when the poles and zeros spread
    over decades or the realization is badly scaled.

    Parameters
    ----------
    a : numpy.ndarray, shape (n, n)
    b : numpy.ndarray, shape (n, 1)
    c : numpy.ndarray, shape (1, n)
    d : numpy.ndarray, shape (1, 1)

    Returns
    -------
    zeros : numpy.ndarray of complex, shape (n - r,)
        ``r`` is the relative degree.
    poles : numpy.ndarray of complex, shape (n,)
    gain : float
        ``G(s) = gain * prod(s - zeros) / prod(s - poles)``; 0 for ``G = 0``.

    """
    a, b, c = _balanced(np.asarray(a, dtype=float), np.asarray(b, dtype=float),
                        np.asarray(c, dtype=float))
    d = float(np.ravel(d)[0])
    order = a.shape[0]
    poles = clean_poles(np.linalg.eigvals(a)) if order else np.array([], dtype=complex)
    # Relative degree and high-frequency gain from the Markov parameters d, c b, c a b, ...
    norm_a = max(np.linalg.norm(a, 2), 1e-300) if order else 1.0
    scale = max(abs(d), np.linalg.norm(c) * np.linalg.norm(b) if order else 0.0, 1e-300)
    markov, vector, degree = d, b, 0
    while abs(markov) <= MARKOV_RTOL * scale * (norm_a ** max(degree - 1, 0)
                                                if degree else 1.0):
        if degree == order:
            return np.array([], dtype=complex), poles, 0.0
        markov = float((c @ vector)[0, 0])
        vector = a @ vector
        degree += 1
        scale = max(scale, abs(markov))
    count = order - degree
    if count == 0:
        return np.array([], dtype=complex), poles, markov
    pencil = np.block([[a, b], [c, np.array([[d]])]])
    mass = np.zeros((order + 1, order + 1))
    mass[:order, :order] = np.eye(order)
    alpha, beta = scipy.linalg.eig(pencil, mass, right=False, homogeneous_eigvals=True)
    finiteness = np.abs(beta) / np.hypot(np.abs(alpha), np.abs(beta))
    chosen = np.argsort(-finiteness, kind='stable')[:count]
    zeros = clean_poles(alpha[chosen] / beta[chosen])
    return zeros, poles, markov


def _from_zpk(zeros, poles, gain, discrete) -> ControllerTransferFunction:
    zeros, poles = sort_poles(zeros), sort_poles(poles)
    num = gain * np.real(np.poly(zeros)) if zeros.size else np.array([gain])
    den = np.real(np.poly(poles)) if poles.size else np.ones(1)
    return ControllerTransferFunction(num=np.atleast_1d(num), den=np.atleast_1d(den),
                                      zeros=zeros if gain else np.array([], dtype=complex),
                                      poles=poles, gain=float(gain), discrete=discrete)


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


def _evaluate_zpk(tf: ControllerTransferFunction, points: np.ndarray) -> np.ndarray:
    value = np.full(points.shape, complex(tf.gain))
    for zero in tf.zeros:
        value = value * (points - zero)
    for pole in tf.poles:
        value = value / (points - pole)
    return value


def frequency_grid(first: ControllerTransferFunction,
                   second: ControllerTransferFunction) -> np.ndarray:
    """
    Points on ``s = j w`` (``z = exp(j theta)``) around both systems' dynamics.

    ``GRID_POINTS`` log-spaced frequencies from a tenth of the slowest to ten times the
    fastest pole or zero magnitude (for a discrete system the magnitude of ``log z``, up to
    ``theta = pi``), plus points 1 % and 3 % either side of each pole's and zero's magnitude,
    where a lightly damped root's peak or notch lies (not on it: a root on the axis would
    make the response infinite or zero there).
    """
    roots = np.concatenate([first.zeros, first.poles, second.zeros, second.poles])
    if first.discrete:
        roots = np.log(roots[np.abs(roots) > 0].astype(complex))
    magnitudes = np.abs(roots)
    magnitudes = magnitudes[magnitudes > 0]
    low = magnitudes.min() / 10.0 if magnitudes.size else 1e-2
    high = magnitudes.max() * 10.0 if magnitudes.size else 1e2
    if first.discrete:
        low, high = min(low, np.pi / 10.0), np.pi
    frequencies = np.concatenate([np.logspace(np.log10(low), np.log10(high), GRID_POINTS),
                                  np.outer(magnitudes, [0.97, 0.99, 1.01, 1.03]).ravel()])
    frequencies = np.unique(frequencies[(frequencies >= low) & (frequencies <= high)])
    return np.exp(1j * frequencies) if first.discrete else 1j * frequencies


def response_disagreement(first: ControllerTransferFunction,
                          second: ControllerTransferFunction) -> float:
    """
    Largest relative difference of two frequency responses on :func:`frequency_grid`.

    ``max |G1 - G2| / max(|G2|, RESPONSE_FLOOR max |G2|)`` over the grid; the floor keeps a
    zero close to the imaginary axis (unit circle) from turning rounding into a large
    relative error. ``first`` is evaluated in its zero-pole-gain form (how
    :func:`controller_transfer_function` computes it), ``second`` from its polynomials (how
    the Diophantine equation gives it): the roots of clustered polynomial coefficients are
    less accurate than the coefficients.
    """
    points = frequency_grid(first, second)
    with np.errstate(all='ignore'):
        return _relative_difference(
            _evaluate_zpk(first, points),
            np.polyval(second.num, points) / np.polyval(second.den, points))


def _relative_difference(one: np.ndarray, two: np.ndarray) -> float:
    finite = np.isfinite(one) & np.isfinite(two)
    if not np.any(finite):
        return np.inf
    one, two = one[finite], two[finite]
    with np.errstate(all='ignore'):
        reference = np.abs(two)
        floor = RESPONSE_FLOOR * np.max(reference)
        ratio = np.abs(one - two) / np.maximum(np.maximum(reference, floor), 1e-300)
    return float(np.max(ratio)) if np.all(np.isfinite(ratio)) else np.inf


def _cross_check(model, realization, feedback_gain, result) -> None:
    """Compare ``result`` with the Diophantine controller of the same closed loop."""
    order, n_states = realization.a.shape[0], model.n_states
    strictly_proper = not np.any(realization.d_y)
    if not (order == n_states - 1 or (order == n_states and strictly_proper)):
        return
    closed = np.concatenate([np.linalg.eigvals(model.a - model.b @ feedback_gain),
                             np.linalg.eigvals(realization.a) if order else np.array([])])
    try:
        r_poly, s_poly, shift, sigma, condition = _diophantine_scaled(model, closed)
    except DesignError as e:
        warnings.warn(f'G_oc could not be cross-checked with the Diophantine equation ({e})',
                      ControllerMismatchWarning, stacklevel=3)
        return
    points = frequency_grid(result, result)
    scaled = (points - shift) / sigma
    with np.errstate(all='ignore'):
        reference = np.polyval(s_poly, scaled) / np.polyval(r_poly, scaled)
        # Both forms of the result: zero-pole-gain and the printed polynomials.
        disagreement = max(
            _relative_difference(_evaluate_zpk(result, points), reference),
            _relative_difference(np.polyval(result.num, points) / np.polyval(result.den, points),
                                 reference))
    if disagreement <= AGREEMENT_RTOL:
        return
    reference_error = REFERENCE_SLACK * np.finfo(float).eps * condition
    text = (f'G_oc from the observer realization and the Diophantine solution of '
            f'A R + B S = A_cl for the same closed-loop poles disagree by {disagreement:.2g} '
            f'relative (frequency response), more than {AGREEMENT_RTOL:.0e}')
    if disagreement > max(REFUSAL_RTOL, reference_error):
        raise DesignError(
            f'{text} and more than {REFUSAL_RTOL:.0e}, while the Diophantine solution is good '
            f'to about {reference_error:.1g}: the observer realization is numerically '
            f'unreliable (G_oc would print wrong digits); choose observer poles farther from '
            f'each other and from the eigenvalues of A, or another observer gain',
            parameter='realization')
    if disagreement > reference_error:
        blame = 'G_oc and the closed loop are that inaccurate'
    else:
        blame = (f'the Diophantine equation is ill-conditioned (good to about '
                 f'{reference_error:.1g}), so either may be that inaccurate')
    warnings.warn(f'{text}: {blame}', ControllerMismatchWarning, stacklevel=3)


def controller_transfer_function(model: StateSpaceModel, realization: ObserverRealization,
                                 feedback_gain: np.ndarray) -> ControllerTransferFunction:
    """
    Compute the observer-controller transfer function ``G_oc = -U / Y`` (SISO).

    Works for every observer type through its :class:`ObserverRealization`. Warns with
    :class:`UnstableControllerWarning` when the controller itself is unstable (legal, as in
    the seed example ``(9.1 s^2 + 73.5 s + 125) / (s^2 + 17 s - 30)``, but the loop must
    then never be opened).

    ``num``, ``den``, zeros, poles and gain come from eigenvalue problems on the balanced
    observer-controller (:func:`siso_zpk`). The result is then checked against the
    Diophantine solution of the same closed loop, ``A R + B S = det(sI - A + B K)
    det(sI - A_o)`` with ``A_o`` the observer's state matrix (its achieved poles, so that a
    placement error within tolerance is not counted): for one output the controller of
    order ``n - 1`` (reduced-order, Chen) or strictly proper of order ``n`` (full order,
    Kalman) is unique, so the two must agree. A disagreement beyond ``AGREEMENT_RTOL`` warns
    with :class:`ControllerMismatchWarning` (as does a closed loop the Diophantine equation
    cannot solve); beyond ``REFUSAL_RTOL`` the design is refused.

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
        Naming ``model`` when the plant is not single-input single-output; when ``G_oc``
        and the Diophantine solution disagree by more than ``REFUSAL_RTOL``.

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
    result = _from_zpk(*siso_zpk(a_c, b_c, -c_c, -d_c), model.is_discrete)
    _cross_check(model, realization, feedback_gain, result)
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


def plant_polynomials(model: StateSpaceModel):
    """
    Numerator and monic denominator of a SISO plant, highest power first.

    From :func:`siso_zpk` (zeros by QZ, poles by ``eig``): ``ss2tf`` takes the numerator as
    ``det(sI - A + B C) - det(sI - A)``, which cancels digits when ``B C`` is small next to
    ``A``.
    """
    zeros, poles, gain = siso_zpk(model.a, model.b, model.c, model.d)
    num = gain * np.real(np.poly(zeros)) if zeros.size else np.array([gain])
    return np.atleast_1d(num), np.real(np.poly(poles))


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
    r_poly, s_poly, shift, sigma, _ = _diophantine_scaled(model, closed)
    # Back from w = (s - shift) / sigma to s (z): R(s) = R_w((s - shift) / sigma).
    to_w = np.polynomial.Polynomial([-shift / sigma, 1.0 / sigma])
    r_poly = np.polynomial.Polynomial(r_poly[::-1])(to_w).coef[::-1]
    s_poly = np.polynomial.Polynomial(s_poly[::-1])(to_w).coef[::-1]
    return _transfer_function(s_poly, r_poly, model.is_discrete)


def _diophantine_scaled(model: StateSpaceModel, closed_roots: np.ndarray):
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
