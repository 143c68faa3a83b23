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
Transfer functions of a SISO controller: the value type, its zeros and poles, its text.

:class:`ControllerTransferFunction` holds ``num / den`` with its zero-pole-gain form;
:func:`siso_zpk` computes zeros, poles and gain of a state-space system by eigenvalue
problems on a balanced realization; :func:`from_zpk` and :func:`from_polynomials` build the
value from either form, :func:`evaluate_zpk` evaluates it and :func:`polynomial_text` prints
a polynomial.
"""

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from observer_ros.core.placement_checks import sort_poles
from observer_ros.core.poles import clean_poles, is_stable

#: Leading numerator coefficients below this (relative to the largest) are dropped.
COEFFICIENT_RTOL = 1e-10

#: A Markov parameter below this (relative to ``|c| |a|^(k-1) |b|``) counts as zero.
MARKOV_RTOL = 1e-12


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
    >>> from observer_ros.core.loop_analysis.transfer_function import polynomial_text
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


def from_zpk(zeros, poles, gain: float, discrete: bool) -> ControllerTransferFunction:
    """Return the transfer function ``gain * prod(s - zeros) / prod(s - poles)``."""
    zeros, poles = sort_poles(zeros), sort_poles(poles)
    num = gain * np.real(np.poly(zeros)) if zeros.size else np.array([gain])
    den = np.real(np.poly(poles)) if poles.size else np.ones(1)
    return ControllerTransferFunction(num=np.atleast_1d(num), den=np.atleast_1d(den),
                                      zeros=zeros if gain else np.array([], dtype=complex),
                                      poles=poles, gain=float(gain), discrete=discrete)


def from_polynomials(num, den, discrete: bool) -> ControllerTransferFunction:
    """
    Return the transfer function ``num / den`` (coefficients, highest power first).

    ``den`` is made monic; leading numerator coefficients below :data:`COEFFICIENT_RTOL` of
    the largest are dropped, smaller ones set to zero.
    """
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


def evaluate_zpk(tf: ControllerTransferFunction, points: np.ndarray) -> np.ndarray:
    """Evaluate ``tf`` at ``points`` in its zero-pole-gain form (shape of ``points``)."""
    value = np.full(points.shape, complex(tf.gain))
    for zero in tf.zeros:
        value = value * (points - zero)
    for pole in tf.poles:
        value = value / (points - pole)
    return value
