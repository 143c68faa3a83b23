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
The data and the model of subspace identification: records, the model, its fit, its ``A, B``.

A :class:`Record` is one stretch of sampled inputs and outputs; a :class:`SubspaceModel` the
discrete model :func:`~observer_ros.core.tuning.subspace.identify_subspace` finds, which
simulates itself. :func:`fit_percent` scores a model on held-out data as MATLAB's
``compare`` does, ``100 (1 - ||y - y_sim|| / ||y - mean(y)||)``, the initial state estimated
from that data (:func:`validate`); :func:`to_continuous` gives the continuous model whose
zero-order-hold sampling it is.
"""

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from observer_ros.core.errors import DesignError


@dataclass(frozen=True)
class Record:
    """
    One stretch of sampled data.

    Attributes
    ----------
    inputs : numpy.ndarray, shape (N, m)
    outputs : numpy.ndarray, shape (N, p)

    Examples
    --------
    >>> import numpy as np
    >>> record = Record(np.zeros((5, 1)), np.ones((5, 2)))
    >>> record.outputs.shape
    (5, 2)

    """

    inputs: np.ndarray
    outputs: np.ndarray


@dataclass(frozen=True)
class SubspaceModel:
    """
    An identified discrete model and how it was found.

    Attributes
    ----------
    a, b, c, d : numpy.ndarray
        Shapes (n, n), (n, m), (p, n), (p, m).
    dt : float
    singular_values : numpy.ndarray
        Of the subspace step, largest first: the order is where they drop.
    initial_states : tuple of numpy.ndarray
        One per estimation record.
    horizon : int
        Block rows of the Hankel matrices.

    Examples
    --------
    See :func:`~observer_ros.core.tuning.subspace.identify_subspace`, which returns one;
    :meth:`simulate` runs it:

    >>> import numpy as np
    >>> model = SubspaceModel(np.array([[0.5]]), np.array([[1.0]]), np.array([[1.0]]),
    ...                       np.zeros((1, 1)), 0.1, np.ones(1), (), 10)
    >>> model.simulate(np.ones((3, 1))).ravel().tolist()
    [0.0, 1.0, 1.5]

    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray
    dt: float
    singular_values: np.ndarray
    initial_states: tuple
    horizon: int

    @property
    def poles(self) -> np.ndarray:
        """Eigenvalues of ``A`` (z-plane)."""
        return np.linalg.eigvals(self.a)

    def simulate(self, inputs, initial_state=None) -> np.ndarray:
        """Return the output ``(N, p)`` for ``inputs`` ``(N, m)`` from ``initial_state``."""
        states = _state_trajectory(self.a, self.b, np.asarray(inputs, dtype=float),
                                   initial_state)
        return states @ self.c.T + np.asarray(inputs, dtype=float) @ self.d.T


def _state_trajectory(a, b, inputs, initial_state=None) -> np.ndarray:
    count = len(inputs)
    state = np.zeros(len(a)) if initial_state is None else np.asarray(initial_state, float)
    drive = inputs @ b.T
    states = np.empty((count, len(a)))
    for k in range(count):
        states[k] = state
        state = a @ state + drive[k]
    return states


def _free_responses(a, c, count: int) -> np.ndarray:
    """``C A^k`` for ``k < count``, shape (count, p, n)."""
    rows = np.empty((count,) + c.shape)
    row = c
    for k in range(count):
        rows[k] = row
        row = row @ a
    return rows


def estimate_initial_state(model: SubspaceModel, record: Record) -> np.ndarray:
    """Return the initial state that best explains ``record`` (least squares)."""
    forced = model.simulate(record.inputs)
    free = _free_responses(model.a, model.c, len(record.inputs))
    matrix = free.reshape(-1, len(model.a))
    return np.linalg.lstsq(matrix, (record.outputs - forced).reshape(-1), rcond=None)[0]


def fit_percent(measured, simulated) -> np.ndarray:
    """
    Return ``100 (1 - ||y - y_sim|| / ||y - mean(y)||)`` per output, as MATLAB's ``compare``.

    Parameters
    ----------
    measured, simulated : array_like, shape (N, p)

    Returns
    -------
    numpy.ndarray, shape (p,)
        Percent; 100 is a perfect fit, 0 no better than the mean, -inf for a constant output.

    Examples
    --------
    >>> fit_percent([[1.0], [2.0], [3.0]], [[1.0], [2.0], [3.0]]).tolist()
    [100.0]

    """
    measured = np.asarray(measured, dtype=float)
    simulated = np.asarray(simulated, dtype=float)
    spread = np.linalg.norm(measured - measured.mean(axis=0), axis=0)
    error = np.linalg.norm(measured - simulated, axis=0)
    with np.errstate(divide='ignore', invalid='ignore'):
        return 100.0 * (1.0 - np.where(spread > 0, error / spread, np.inf))


def validate(model: SubspaceModel, record: Record) -> tuple:
    """Return ``(simulated output, fit % per output)`` on held-out ``record``."""
    initial = estimate_initial_state(model, record)
    simulated = model.simulate(record.inputs, initial)
    return simulated, fit_percent(record.outputs, simulated)


def to_continuous(a, b, dt: float) -> tuple:
    """
    Return ``(A, B)`` of the continuous model whose zero-order-hold sampling is ``(a, b)``.

    Parameters
    ----------
    a, b : array_like, shapes (n, n) and (n, m)
        The discrete model.
    dt : float
        Its sample period.

    Returns
    -------
    tuple of numpy.ndarray
        ``(A, B)`` continuous.

    Raises
    ------
    DesignError
        Naming ``A`` when ``a`` has an eigenvalue on the closed negative real axis (no real
        continuous model samples to it).

    Examples
    --------
    >>> import numpy as np
    >>> a, b = to_continuous([[np.exp(-0.2)]], [[1 - np.exp(-0.2)]], 0.1)
    >>> round(float(a[0, 0]), 9), round(float(b[0, 0]), 9)
    (-2.0, 2.0)

    """
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    poles = np.linalg.eigvals(a)
    bad = [p for p in poles if abs(p.imag) <= 1e-9 * max(1.0, abs(p)) and p.real <= 0]
    if bad:
        raise DesignError(f'discrete poles {", ".join(f"{p.real:.4g}" for p in bad)} on the '
                          f'negative real axis (or at 0) have no continuous counterpart; '
                          f'keep the discrete model', 'A')
    n_states, n_inputs = b.shape
    block = np.zeros((n_states + n_inputs, n_states + n_inputs))
    block[:n_states, :n_states] = a
    block[:n_states, n_states:] = b
    block[n_states:, n_states:] = np.eye(n_inputs)
    logarithm = scipy.linalg.logm(block) / dt
    if np.abs(np.imag(logarithm)).max() > 1e-8 * max(1.0, np.abs(logarithm).max()):
        raise DesignError('the matrix logarithm is not real; keep the discrete model', 'A')
    logarithm = np.real(logarithm)
    return logarithm[:n_states, :n_states], logarithm[:n_states, n_states:]


__all__ = ['Record', 'SubspaceModel', 'estimate_initial_state', 'fit_percent',
           'to_continuous', 'validate']
