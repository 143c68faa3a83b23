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

"""What every observer design returns, and the state-space form they share."""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.core.errors import DesignError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement_checks import sort_poles
from observer_ros.core.poles import is_stable
from observer_ros.core.ranks import format_modes


@dataclass(frozen=True)
class ObserverRealization:
    """
    An observer as a linear system with inputs ``y`` and ``u`` and output ``x_hat``.

    ``xi' = A xi + B_y y + B_u u`` (or ``xi[k+1] = ...`` for a discrete model) and
    ``x_hat = C xi + D_y y + D_u u``. Every linear observer type maps to this form, which the
    controller transfer function and the closed-loop analysis use.

    Attributes
    ----------
    a : numpy.ndarray, shape (q, q)
        ``q`` is the observer's order (``n`` full order, ``n - p`` reduced order).
    b_y, b_u : numpy.ndarray, shapes (q, p) and (q, m)
    c : numpy.ndarray, shape (n, q)
    d_y, d_u : numpy.ndarray, shapes (n, p) and (n, m)

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> realization = oc.design_full_order(model, poles=[-8, -9]).realization
    >>> print(realization.a.round(6))
    [[-17.   1.]
     [-72.   0.]]

    """

    a: np.ndarray
    b_y: np.ndarray
    b_u: np.ndarray
    c: np.ndarray
    d_y: np.ndarray
    d_u: np.ndarray


@dataclass(frozen=True)
class ObserverDesign:
    """
    Result of an observer design.

    Attributes
    ----------
    kind : str
        The name of the observer type that made it (``observer.type``).
    model : StateSpaceModel
        The model designed for.
    gain : numpy.ndarray
        The observer gain: ``L`` ``(n, p)`` for full order and Kalman (predictor form
        ``x' = A x + B u + L (y - C x)``), ``L`` ``(n - p, p)`` for the reduced-order and
        Chen observers.
    requested_poles, achieved_poles : numpy.ndarray of complex
        Sorted error-dynamics poles.
    method : str
        Algorithm that produced the gain (``'given'`` when the gain was supplied).
    residual : float
        Relative error of the verification (poles, or the Sylvester / Riccati residual).
    realization : ObserverRealization or None
        The observer as a system from ``(y, u)`` to ``x_hat``, in the model's coordinates;
        None for a type without a linear realization (its capabilities say so), which the
        closed-loop analysis then skips.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> design = oc.design_full_order(model, poles=[-8, -9])
    >>> design.order, design.achieved_poles.round(6).tolist()
    (2, [(-9+0j), (-8+0j)])

    """

    kind: str
    model: StateSpaceModel
    gain: np.ndarray
    requested_poles: np.ndarray
    achieved_poles: np.ndarray
    method: str
    residual: float
    realization: Optional[ObserverRealization]

    @property
    def order(self) -> int:
        """Number of observer states (``n`` for a design without a realization)."""
        if self.realization is None:
            return self.model.n_states
        return self.realization.a.shape[0]


def predictor_realization(model: StateSpaceModel, gain: np.ndarray) -> ObserverRealization:
    """
    Observer ``x_hat' = A x_hat + B u + L (y - C x_hat - D u)``: ``A - L C``, ``L``, ``B - L D``.

    The realization of a full-order observer of gain ``L``, and of a steady-state Kalman
    filter in predictor form.

    Parameters
    ----------
    model : StateSpaceModel
    gain : numpy.ndarray, shape (n, p)
        ``L``.

    Returns
    -------
    ObserverRealization
        Of order ``n``, with ``x_hat = xi``.

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> realization = oc.predictor_realization(model, np.array([[17.0], [72.0]]))
    >>> print(realization.b_y.ravel(), realization.b_u.ravel())
    [17. 72.] [0. 1.]

    """
    n_states = model.n_states
    return ObserverRealization(
        a=model.a - gain @ model.c, b_y=gain, b_u=model.b - gain @ model.d,
        c=np.eye(n_states), d_y=np.zeros((n_states, model.n_outputs)),
        d_u=np.zeros((n_states, model.n_inputs)))


def check_given_gain_stable(error_matrix: np.ndarray, discrete: bool,
                            parameter: str = 'gain') -> np.ndarray:
    """
    Return the sorted eigenvalues of the error dynamics, or raise if they are unstable.

    Parameters
    ----------
    error_matrix : numpy.ndarray, shape (q, q)
        ``A - L C`` (or its reduced-order counterpart) for the given gain.
    discrete : bool
        Schur (True) or Hurwitz (False) stability.
    parameter : str
        The argument the gain came in, named by the error.

    Returns
    -------
    numpy.ndarray of complex, shape (q,)

    Raises
    ------
    DesignError
        With ``parameter`` set, when an eigenvalue is not stable.

    """
    achieved = sort_poles(np.linalg.eigvals(error_matrix))
    if not is_stable(achieved, discrete):
        where = 'outside the unit circle' if discrete else 'in the closed right half-plane'
        raise DesignError(
            f'the given gain makes the observer error unstable: poles '
            f'{format_modes(achieved)} (some {where}); the estimate would diverge',
            parameter=parameter)
    return achieved


def require_stable_poles(poles: np.ndarray, discrete: bool, parameter: str = 'poles') -> None:
    """
    Refuse requested observer poles that would not make the error converge.

    Parameters
    ----------
    poles : numpy.ndarray of complex
    discrete : bool
        z-plane (True) or s-plane (False) poles.
    parameter : str
        The argument the poles came in, named by the error.

    Raises
    ------
    DesignError
        With ``parameter`` set, when a pole is not stable.

    """
    if not is_stable(poles, discrete):
        plane = 'inside the unit circle (z-plane, discrete model)' if discrete else \
            'with negative real parts (s-plane, continuous model)'
        raise DesignError(
            f'requested poles {format_modes(poles)} are not stable; expected poles {plane}',
            parameter=parameter)
