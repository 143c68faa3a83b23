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
The closed loop of plant, observer and state feedback: its state matrix and its poles.

By the separation principle the poles are those of ``A - B K`` together with the
observer's error poles; :func:`closed_loop_poles` computes them from the loop itself.
"""

import numpy as np
import scipy.linalg

from observer_ros.core.design.common import ObserverRealization
from observer_ros.core.loop_analysis.observer_controller import controller_state_space
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement_checks import sort_poles


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
