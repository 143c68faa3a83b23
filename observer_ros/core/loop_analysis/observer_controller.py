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
The observer-controller as one system: ``G_oc = -U / Y``, checked against the Diophantine one.

:func:`controller_state_space` closes the observer with ``u = -K x_hat``;
:func:`controller_transfer_function` computes its transfer function and cross-checks it
with :func:`~observer_ros.core.loop_analysis.diophantine.diophantine_controller` on a
frequency grid (:mod:`~observer_ros.core.loop_analysis.frequency`).
"""

import warnings

import numpy as np

from observer_ros.core.design.common import ObserverRealization
from observer_ros.core.errors import DesignError
from observer_ros.core.loop_analysis.diophantine import diophantine_scaled
from observer_ros.core.loop_analysis.frequency import frequency_grid, relative_difference
from observer_ros.core.loop_analysis.transfer_function import (
    ControllerTransferFunction, evaluate_zpk, from_zpk, siso_zpk)
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.ranks import format_modes


#: G_oc and the Diophantine controller of the same closed loop must agree this closely
#: (largest relative difference of their frequency responses, see
#: :func:`response_disagreement`); beyond it :func:`controller_transfer_function` warns.
AGREEMENT_RTOL = 1e-8

#: Beyond this disagreement :func:`controller_transfer_function` refuses the design.
REFUSAL_RTOL = 1e-5

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


def _cross_check(model, realization, feedback_gain, result) -> None:
    """Compare ``result`` with the Diophantine controller of the same closed loop."""
    order, n_states = realization.a.shape[0], model.n_states
    strictly_proper = not np.any(realization.d_y)
    if not (order == n_states - 1 or (order == n_states and strictly_proper)):
        return
    closed = np.concatenate([np.linalg.eigvals(model.a - model.b @ feedback_gain),
                             np.linalg.eigvals(realization.a) if order else np.array([])])
    try:
        r_poly, s_poly, shift, sigma, condition = diophantine_scaled(model, closed)
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
            relative_difference(evaluate_zpk(result, points), reference),
            relative_difference(np.polyval(result.num, points) / np.polyval(result.den, points),
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
                                 feedback_gain: np.ndarray,
                                 cross_check: bool = True) -> ControllerTransferFunction:
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
    cross_check : bool
        Compare with the Diophantine solution (above). False for a model whose modes are
        not all controllable by construction (a plant augmented with disturbance
        generators), where the Diophantine equation does not apply.

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
    result = from_zpk(*siso_zpk(a_c, b_c, -c_c, -d_c), model.is_discrete)
    if cross_check:
        _cross_check(model, realization, feedback_gain, result)
    if result.unstable:
        warnings.warn(
            f'the observer-controller is unstable on its own (poles '
            f'{format_modes(result.poles)}): the closed loop is stable, but opening it '
            f'(saturation, a lost measurement) lets the controller state diverge',
            UnstableControllerWarning, stacklevel=2)
    return result
