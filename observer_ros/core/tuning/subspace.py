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
Linear models from recorded inputs and outputs: subspace identification (PO-MOESP).

:func:`identify_subspace` finds ``A``, ``B``, ``C``, ``D`` of a chosen order from one or more
records of ``u`` and ``y`` sampled every ``dt``:

1. the past-output MOESP step (Verhaegen and Verdult, 2007): an LQ factorization of the
   block Hankel matrices of future inputs, past inputs and outputs (the instruments) and
   future outputs; the singular values of the part of the future outputs the past explains
   give the order (a gap after the true order), and its leading left singular vectors the
   extended observability matrix, from which ``C`` (first block) and ``A`` (shift
   invariance) follow;
2. ``B``, ``D`` and each record's initial state by linear least squares on the simulated
   output (the output is linear in them once ``A`` and ``C`` are fixed).

The past-output instruments make the estimate consistent with process and measurement noise
alike. The records and the model (its simulation, its fit on held-out data, its continuous
form) are in :mod:`observer_ros.core.tuning.identified_model`.

References
----------
M. Verhaegen and V. Verdult, *Filtering and System Identification: A Least Squares
Approach*, Cambridge University Press, 2007, chapter 9.
"""

from typing import Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.tuning.identified_model import _free_responses, Record, SubspaceModel

#: Default block rows of the Hankel matrices (the past window of the instruments).
HORIZON = 20

#: Hankel columns needed per row of the stacked data matrix at least.
COLUMNS_PER_ROW = 2

#: An input whose spread is below this fraction of its magnitude (or zero) does not excite.
EXCITATION = 1e-9


def _hankel(data: np.ndarray, start: int, rows: int, columns: int) -> np.ndarray:
    """Block Hankel matrix: block row ``i`` holds samples ``start + i .. + columns - 1``."""
    width = data.shape[1]
    matrix = np.empty((rows * width, columns))
    for i in range(rows):
        matrix[i * width:(i + 1) * width] = data[start + i:start + i + columns].T
    return matrix


def _check_records(records: Sequence[Record]) -> tuple:
    if not records:
        raise ConfigError('records', 'expected at least one record')
    n_inputs = records[0].inputs.shape[1]
    n_outputs = records[0].outputs.shape[1]
    for index, record in enumerate(records):
        if record.inputs.shape[1] != n_inputs or record.outputs.shape[1] != n_outputs:
            raise ConfigError('records', f'record {index}: expected {n_inputs} inputs and '
                              f'{n_outputs} outputs')
        if len(record.inputs) != len(record.outputs):
            raise ConfigError('records', f'record {index}: {len(record.inputs)} inputs but '
                              f'{len(record.outputs)} outputs')
        for name, values in (('inputs', record.inputs), ('outputs', record.outputs)):
            if not np.isfinite(values).all():
                raise ConfigError(name, f'record {index}: NaN or inf in the data')
    return n_inputs, n_outputs


def check_excitation(records: Sequence[Record], input_names: Sequence[str]) -> None:
    """
    Refuse inputs that do not vary: nothing to identify the input path from.

    Raises
    ------
    ConfigError
        Naming ``inputs`` and the inputs that are constant.

    """
    values = np.concatenate([record.inputs for record in records])
    if not values.shape[1]:
        return
    spread = values.max(axis=0) - values.min(axis=0)
    level = np.maximum(np.abs(values).max(axis=0), 1.0)
    flat = [name for name, s, m in zip(input_names, spread, level) if s <= EXCITATION * m]
    if flat:
        raise ConfigError('inputs', f'no excitation: {", ".join(flat)} '
                          f'{"is" if len(flat) == 1 else "are"} constant over the data, so '
                          f'the input path cannot be identified; record with a varying '
                          f'input (steps, a chirp, noise)')


def subspace_singular_values(records: Sequence[Record], horizon: int) -> tuple:
    """
    Return ``(singular values, left singular vectors)`` of the PO-MOESP step.

    Raises
    ------
    ConfigError
        Naming ``horizon``: the records are too short for it.

    """
    n_inputs, n_outputs = _check_records(records)
    blocks = []
    for record in records:
        columns = len(record.inputs) - 2 * horizon + 1
        if columns < 1:
            continue
        u, y = record.inputs, record.outputs
        blocks.append(np.vstack([_hankel(u, horizon, horizon, columns),
                                 _hankel(u, 0, horizon, columns),
                                 _hankel(y, 0, horizon, columns),
                                 _hankel(y, horizon, horizon, columns)]))
    rows = 2 * horizon * (n_inputs + n_outputs)
    columns = sum(block.shape[1] for block in blocks)
    if columns < COLUMNS_PER_ROW * rows:
        longest = max(len(record.inputs) for record in records)
        raise ConfigError('horizon', f'too short: {columns} Hankel columns for {rows} rows '
                          f'(horizon {horizon}; the longest record has {longest} samples); '
                          f'record longer or choose a lower order or horizon')
    data = np.hstack(blocks) / np.sqrt(columns)
    lower = np.linalg.qr(data.T, mode='r').T
    future_u = horizon * n_inputs
    past = horizon * (n_inputs + n_outputs)
    l32 = lower[future_u + past:, future_u:future_u + past]
    left, values, _ = np.linalg.svd(l32, full_matrices=False)
    return values, left


#: What :func:`identify_subspace` does with ``D``: fit it, or fix it at zero.
FEEDTHROUGH_CHOICES = ('fit', 'zero')


def identify_subspace(records: Sequence[Record], order: int, dt: float,
                      horizon: Optional[int] = None,
                      input_names: Optional[Sequence[str]] = None,
                      feedthrough: str = 'fit') -> SubspaceModel:
    """
    Identify a discrete model of ``order`` from ``records`` (PO-MOESP, then least squares).

    Parameters
    ----------
    records : sequence of Record
        Estimation data; several records (bags) are used together.
    order : int
        ``n``, at least 1 and below ``horizon``.
    dt : float
        Sample period of the data, > 0.
    horizon : int, optional
        Block rows (default :data:`HORIZON` or ``2 order`` if more). A longer past
        window lowers the finite-sample bias: for a third-order plant at 30 dB, the
        continuous poles came within 0.3 % with 20 rows, 2 to 4 % with 10.
    input_names : sequence of str, optional
        For the no-excitation message.
    feedthrough : {'fit', 'zero'}
        ``fit``: ``D`` by least squares with ``B`` (``y[k] = C x[k] + D u[k]``, ``u[k]`` the
        input in effect at sample ``k``); ``zero``: ``D = 0``, ``B`` fitted alone (a
        strictly proper plant, the usual case behind a zero-order hold).

    Returns
    -------
    SubspaceModel

    Raises
    ------
    ConfigError
        Naming ``order``, ``horizon``, ``dt``, ``inputs`` (no excitation), ``outputs``
        (NaN) or ``feedthrough``.
    DesignError
        When the identified ``A`` is not finite.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> u = rng.standard_normal((2000, 1))
    >>> a, b, c = np.array([[0.9, 0.2], [0.0, 0.7]]), np.array([[0.0], [1.0]]), np.eye(2)[:1]
    >>> x = np.zeros(2); y = []
    >>> for k in range(2000):
    ...     y.append(c @ x); x = a @ x + b @ u[k]
    >>> model = identify_subspace([Record(u, np.array(y))], 2, 0.1)
    >>> np.round(np.sort(model.poles.real), 6).tolist()
    [0.7, 0.9]

    """
    n_inputs, n_outputs = _check_records(records)
    if feedthrough not in FEEDTHROUGH_CHOICES:
        raise ConfigError('feedthrough', f'expected one of {", ".join(FEEDTHROUGH_CHOICES)}, '
                          f'got {feedthrough!r}')
    if not (isinstance(order, (int, np.integer)) and order >= 1):
        raise ConfigError('order', f'expected an integer of at least 1, got {order!r}')
    if not dt > 0:
        raise ConfigError('dt', f'expected a sample period > 0, got {dt}')
    horizon = max(2 * order, HORIZON) if horizon is None else int(horizon)
    if horizon <= order:
        raise ConfigError('horizon', f'expected more block rows than the order {order}, got '
                          f'{horizon}')
    names = list(input_names or (f'u{i + 1}' for i in range(n_inputs)))
    check_excitation(records, names)
    values, left = subspace_singular_values(records, horizon)
    if order > len(values) or order * n_outputs > left.shape[0] - n_outputs:
        raise ConfigError('order', f'expected at most {len(values)} for horizon {horizon}, '
                          f'got {order}')
    basis = left[:, :order]
    c = basis[:n_outputs]
    a = np.linalg.lstsq(basis[:-n_outputs], basis[n_outputs:], rcond=None)[0]
    if not np.isfinite(a).all():
        raise DesignError('the identified A is not finite', 'order')
    radius = float(np.max(np.abs(np.linalg.eigvals(a))))
    if radius > 1.0:
        raise DesignError(
            f'the identified model of order {order} is unstable (a pole at |z| = {radius:.6g} '
            f'> 1): B and D are fitted on its simulated output, which an unstable model '
            f'cannot give. Identify from open-loop data that excite the plant (in a closed '
            f'loop the input follows the noise and biases the subspace estimate), try another '
            f'order, or stabilise the plant first', 'order')
    b, d, initial = _input_matrices(a, c, records, feedthrough == 'fit')
    return SubspaceModel(a, b, c, d, float(dt), values, tuple(initial), horizon)


def _input_responses(a, c, inputs) -> np.ndarray:
    """Output of a unit ``B[i, j]`` for every ``(i, j)``: shape (N, p, n * m), j major."""
    n_states, count = len(a), len(inputs)
    n_inputs = inputs.shape[1]
    # Column j * n + i of the drive is u_j e_i: the state of every unit B[i, j] at once.
    drive = (inputs[:, None, :, None] * np.eye(n_states)[None, :, None, :]).reshape(
        count, n_states, n_inputs * n_states)
    states = np.empty_like(drive)
    state = np.zeros((n_states, n_states * n_inputs))
    for k in range(count):
        states[k] = state
        state = a @ state + drive[k]
    return np.einsum('pi,kij->kpj', c, states)


def _input_matrices(a, c, records, fit_d: bool = True) -> tuple:
    """Least squares for ``B``, ``D`` (``fit_d``, else zero) and one initial state per record."""
    n_states, n_outputs = len(a), c.shape[0]
    n_inputs = records[0].inputs.shape[1]
    n_initial = n_states * len(records)
    n_d = n_outputs * n_inputs if fit_d else 0
    width = n_states * n_inputs + n_d + n_initial
    rows, targets = [], []
    for index, record in enumerate(records):
        count = len(record.inputs)
        block = np.zeros((count, n_outputs, width))
        block[:, :, :n_states * n_inputs] = _input_responses(a, c, record.inputs)
        for j in range(n_inputs if fit_d else 0):
            for i in range(n_outputs):
                block[:, i, n_states * n_inputs + i * n_inputs + j] = record.inputs[:, j]
        start = n_states * n_inputs + n_d + index * n_states
        block[:, :, start:start + n_states] = _free_responses(a, c, count)
        rows.append(block.reshape(-1, width))
        targets.append(record.outputs.reshape(-1))
    solution = np.linalg.lstsq(np.vstack(rows), np.concatenate(targets), rcond=None)[0]
    b = solution[:n_states * n_inputs].reshape(n_inputs, n_states).T
    d = (solution[n_states * n_inputs:n_states * n_inputs + n_d].reshape(n_outputs, n_inputs)
         if fit_d else np.zeros((n_outputs, n_inputs)))
    initial = [solution[width - n_initial + k * n_states:width - n_initial + (k + 1) * n_states]
               for k in range(len(records))]
    return b, d, initial


def order_advice(values, order: int, noise_floor_ratio: float = 10.0) -> str:
    """
    Say what the singular values suggest about ``order``.

    The suggested order is the largest gap (ratio of neighbours) among the leading values;
    an order that drops a value well above the floor (the median of the rest) is too low, one
    that keeps values at the floor too high.
    """
    values = np.asarray(values, dtype=float)
    usable = values[values > 0]
    limit = min(len(usable) - 1, max(order + 3, 8))
    ratios = usable[:limit] / usable[1:limit + 1]
    suggested = int(np.argmax(ratios)) + 1
    floor = float(np.median(usable[suggested:])) if len(usable) > suggested else 0.0
    text = (f'largest gap after {suggested} (s{suggested}/s{suggested + 1} = '
            f'{ratios[suggested - 1]:.3g}): suggested order {suggested}')
    if order < suggested:
        text += (f'; order {order} leaves out s{order + 1} = {usable[order]:.4g}, '
                 f'{usable[order] / floor:.3g} times the noise floor {floor:.3g}: too low')
    elif order > suggested:
        text += (f'; order {order} keeps s{order} = {usable[order - 1]:.4g}, at the noise floor '
                 f'{floor:.3g}: too high (those states fit noise)')
    return text


__all__ = ['FEEDTHROUGH_CHOICES', 'check_excitation', 'identify_subspace', 'order_advice',
           'subspace_singular_values']
