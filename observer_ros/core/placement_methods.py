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
The pole-placement methods: each computes a gain, which ``place`` then verifies.

``'place'`` (SciPy's ``place_poles``), ``'varga'`` (SLICOT ``SB01BD``, as
:func:`control.place_varga` calls it), ``'acker'``, ``'direct'`` and ``'canonical'``
(single input); :func:`observer_ros.core.placement.place` chooses among them and checks
the poles achieved. What they need (two SciPy functions, slycot) is loaded when a placement
is made, or by :func:`preload_methods`: SciPy's ``place_poles`` without ``scipy.signal``
and its ``linear_sum_assignment`` without ``scipy.optimize``
(:mod:`observer_ros.core.scipy_parts`).
"""

import numpy as np

from observer_ros.core.ranks import controllability_matrix
from observer_ros.core.scipy_parts import linear_sum_assignment, place_poles


#: Above this many states ``'auto'`` tries Varga's method first and ``'place'`` iterates
#: only :data:`LARGE_MAXITER` times.
LARGE_STATES = 24
LARGE_MAXITER = 3


def _acker(a: np.ndarray, b: np.ndarray, poles: np.ndarray) -> np.ndarray:
    n_states = a.shape[0]
    ctrb = controllability_matrix(a, b)
    coefficients = np.real(np.poly(poles))
    phi = np.zeros_like(a)
    for coefficient in coefficients:
        phi = phi @ a + coefficient * np.eye(n_states)
    last_row = np.linalg.solve(ctrb.T, np.eye(n_states)[:, -1])
    return (last_row @ phi).reshape(1, n_states)


def _direct(a: np.ndarray, b: np.ndarray, poles: np.ndarray) -> np.ndarray:
    # det(sI - A + b k) is affine in k for one input: c(k) = c(0) + M k.
    n_states = a.shape[0]
    open_loop = np.real(np.poly(a))[1:]
    columns = [np.real(np.poly(a - np.outer(b[:, 0], unit)))[1:] - open_loop
               for unit in np.eye(n_states)]
    wanted = np.real(np.poly(poles))[1:]
    return np.linalg.solve(np.column_stack(columns), wanted - open_loop).reshape(1, n_states)


def _canonical(a: np.ndarray, b: np.ndarray, poles: np.ndarray) -> np.ndarray:
    # Bass-Gura: K = (alpha - a) W^-1 Ctrb^-1, W the Hankel matrix of the open-loop
    # coefficients (the transformation to controllable canonical form).
    n_states = a.shape[0]
    open_loop = np.real(np.poly(a))[1:]
    wanted = np.real(np.poly(poles))[1:]
    hankel = np.zeros((n_states, n_states))
    extended = np.concatenate([open_loop[::-1][1:], [1.0]])
    for row in range(n_states):
        hankel[row, :n_states - row] = extended[row:]
    ctrb = controllability_matrix(a, b)
    difference = (wanted - open_loop)[::-1]
    return np.linalg.solve((ctrb @ hankel).T, difference).reshape(1, n_states)


def _scipy_parts(a: np.ndarray, b: np.ndarray, poles: np.ndarray) -> np.ndarray:
    maxiter = 50 if a.shape[0] <= LARGE_STATES else LARGE_MAXITER
    result = place_poles()(a, b, poles, method='YT', maxiter=maxiter)
    return np.asarray(result.gain_matrix)


def preload_methods() -> None:
    """
    Load what the placement methods need (two SciPy functions, slycot), now.

    The core loads them only when a placement is first made (a node that designs nothing by
    placement, a Kalman filter or the plant, pays nothing at start-up); ``place_poles`` comes
    without ``scipy.signal``, ``linear_sum_assignment`` without ``scipy.optimize``
    (:mod:`observer_ros.core.scipy_parts`). Nodes that may place poles
    call this at start-up, so that no design on a callback path (a new ``observer.method``
    or poles set at run time, a design per sample interval) pays for an import. Varga's
    method calls SLICOT through slycot directly, not through python-control, whose import
    takes matplotlib with it (another 0.4 s).

    Examples
    --------
    >>> from observer_ros.core.placement_methods import preload_methods
    >>> preload_methods()

    """
    place_poles()
    linear_sum_assignment()
    try:
        import slycot  # noqa: F401
    except ImportError:  # Varga's method then fails as an attempt, naming the import
        pass


def _varga(a: np.ndarray, b: np.ndarray, poles: np.ndarray) -> np.ndarray:
    # control.place_varga's call of SLICOT SB01BD, without importing python-control (and
    # matplotlib with it): the same arguments, the same alpha rule, the same -F.
    from slycot import sb01bd  # imported lazily so the core imports without slycot
    a, b = np.array(a, dtype=float), np.array(b, dtype=float)  # copies, as control's
    placed = np.atleast_1d(np.squeeze(np.asarray(poles)))
    alpha = -2 * abs(min(np.linalg.eig(a)[0].real))
    _, _, _, _, _, feedback, _ = sb01bd(b.shape[0], b.shape[1], len(placed), alpha, a, b,
                                        placed, 'C')
    return -feedback


_ALGORITHMS = {
    'place': _scipy_parts,
    'varga': _varga,
    'acker': _acker,
    'direct': _direct,
    'canonical': _canonical,
}


_SINGLE_INPUT_ONLY = ('acker', 'direct', 'canonical')
