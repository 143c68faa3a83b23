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
Integral action (servo form): ``u = -K x + K_i z`` with ``z`` the integral of ``r - C_i x``.

The chosen outputs ``y_i = C_i x`` (``q`` rows of ``C``) are integrated. Continuous model:
``z' = r - C_i x``, and the augmented pair is ``A_a = [A 0; -C_i 0]``, ``B_a = [B; 0]``.
Discrete model (period ``T``): ``z[k+1] = z[k] + T (r[k] - C_i x[k])``, so
``A_a = [A 0; -T C_i I]``, ``B_a = [B; 0]``. In both, ``u = -K_a [x; z]`` with
``K_a = [K, -K_i]``: placing the ``n + q`` poles of ``A_a - B_a K_a`` gives ``K`` and
``K_i`` together (the feedback poles and the integral poles are one set).
"""

from dataclasses import dataclass

import numpy as np

from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.flat_matrices import matrix_from_flat
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement import place
from observer_ros.core.placement_checks import sort_poles
from observer_ros.core.poles import is_stable
from observer_ros.core.ranks import format_modes, require_controllable


@dataclass(frozen=True)
class IntegralDesign:
    """
    A state feedback with integral action.

    Attributes
    ----------
    gain : numpy.ndarray, shape (m, n)
        ``K``.
    integral_gain : numpy.ndarray, shape (m, q)
        ``K_i``.
    outputs : tuple of int
        Indices of the integrated outputs (rows of ``C``).
    requested_poles, achieved_poles : numpy.ndarray of complex, shape (n + q,)
        Sorted poles of ``A_a - B_a [K, -K_i]``.
    method : str
        Placement method (``'given'`` for given gains).
    residual : float

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[-1]], [[1]], [[1]], dt=0.0)
    >>> design = oc.design_integral(model, [0], poles=[-2, -3])
    >>> design.outputs, design.achieved_poles.real.round(6).tolist()
    ((0,), [-3.0, -2.0])

    """

    gain: np.ndarray
    integral_gain: np.ndarray
    outputs: tuple
    requested_poles: np.ndarray
    achieved_poles: np.ndarray
    method: str
    residual: float


def augmented_pair(model: StateSpaceModel, outputs) -> tuple:
    """
    Return ``(A_a, B_a)`` of the model with the integrators of ``outputs`` appended.

    The integrators take ``r - y = r - C_i x - D_i u``: with a feedthrough the rows of
    ``B_a`` below ``B`` are ``-D_i`` (``-T D_i`` for a discrete model), else zero.

    Parameters
    ----------
    model : StateSpaceModel
    outputs : sequence of int, shape (q,)
        Rows of ``C`` whose tracking error is integrated.

    Returns
    -------
    tuple of numpy.ndarray, shapes (n + q, n + q) and (n + q, m)

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> from observer_ros.core.design.integral import augmented_pair
    >>> model = oc.StateSpaceModel.from_matrices([[-1]], [[1]], [[2]])
    >>> a, b = augmented_pair(model, [0])
    >>> a.tolist(), b.tolist()
    ([[-1.0, 0.0], [-2.0, 0.0]], [[1.0], [0.0]])

    """
    c_i = model.c[list(outputs)]
    n_states, count = model.n_states, c_i.shape[0]
    if model.is_discrete:
        bottom = np.hstack([-model.dt * c_i, np.eye(count)])
    else:
        bottom = np.hstack([-c_i, np.zeros((count, count))])
    a = np.vstack([np.hstack([model.a, np.zeros((n_states, count))]), bottom])
    d_i = model.d[list(outputs)]
    if np.any(d_i != 0.0):  # the integrated error r - C x - D u sees the input directly
        b = np.vstack([model.b, -model.dt * d_i if model.is_discrete else -d_i])
    else:
        b = np.vstack([model.b, np.zeros((count, model.n_inputs))])
    return a, b


def design_integral(model: StateSpaceModel, outputs, poles=None, gain=None,
                    integral_gain=None, method: str = 'auto') -> IntegralDesign:
    """
    Design (or check) ``K`` and ``K_i`` of the servo law on the augmented model.

    Parameters
    ----------
    model : StateSpaceModel
    outputs : sequence of int, shape (q,)
        Integrated outputs; ``q <= m``, else the integrators cannot all be steered.
    poles : array_like of complex, shape (n + q,), optional
        Poles of ``A_a - B_a [K, -K_i]`` (s-plane, or z-plane for a discrete model).
    gain, integral_gain : array_like, shapes (m, n) and (m, q), optional
        Given ``K`` and ``K_i`` (flat: row-major); together they must stabilize the
        augmented loop.
    method : str
        Placement method (see :mod:`observer_ros.core.placement`).

    Returns
    -------
    IntegralDesign

    Raises
    ------
    ConfigError
        ``outputs`` out of range or more than ``m``; ``gain`` / ``integral_gain`` of the
        wrong size or only one of them; ``poles`` unstable or of the wrong count.
    DesignError
        An uncontrollable augmented pair (a plant zero at ``s = 0`` / ``z = 1`` on an
        integrated output), placement failure, or given gains that leave the loop unstable.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> from observer_ros.core.design.integral import design_integral
    >>> model = oc.StateSpaceModel.from_matrices([[-1]], [[1]], [[1]])
    >>> design = design_integral(model, [0], poles=[-2, -3])
    >>> design.gain.round(6).tolist(), design.integral_gain.round(6).tolist()
    ([[4.0]], [[6.0]])

    """
    outputs = tuple(int(index) for index in outputs)
    if not outputs or any(not 0 <= index < model.n_outputs for index in outputs):
        raise ConfigError('outputs', f'expected output indices in 0 ... {model.n_outputs - 1}, '
                          f'got {list(outputs)}')
    if len(set(outputs)) != len(outputs):
        raise ConfigError('outputs', f'expected distinct outputs, got {list(outputs)}')
    count = len(outputs)
    if count > model.n_inputs:
        raise ConfigError('outputs', f'{count} integrated outputs need at least {count} '
                          f'inputs; the model has {model.n_inputs}')
    a, b = augmented_pair(model, outputs)
    if gain is not None or integral_gain is not None:
        if gain is None or integral_gain is None:
            raise ConfigError('integral_gain' if integral_gain is None else 'gain',
                              'give both gain and integral_gain, or the poles')
        gain = matrix_from_flat('gain', np.ravel(gain), model.n_inputs, model.n_states)
        integral_gain = matrix_from_flat('integral_gain', np.ravel(integral_gain),
                                         model.n_inputs, count)
        achieved = sort_poles(np.linalg.eigvals(a - b @ np.hstack([gain, -integral_gain])))
        if not is_stable(achieved, model.is_discrete):
            raise DesignError(f'the given K and K_i leave the augmented loop unstable: poles '
                              f'{format_modes(achieved)}', parameter='integral_gain')
        return IntegralDesign(gain, integral_gain, outputs, achieved, achieved, 'given', 0.0)
    if poles is None:
        raise ConfigError('poles', 'expected the poles or both gains, got neither')
    poles = np.asarray(poles, dtype=complex)
    if poles.size != model.n_states + count:
        raise ConfigError('poles', f'expected {model.n_states + count} poles (n + q), got '
                          f'{poles.size}')
    if not is_stable(poles, model.is_discrete):
        raise ConfigError('poles', f'requested poles {format_modes(poles)} are not stable')
    try:
        require_controllable(a, b, '(A_a, B_a) with the integrators')
    except DesignError as e:
        raise DesignError(f'{e.reason}: a zero of the plant at '
                          f'{"z = 1" if model.is_discrete else "s = 0"} on an integrated '
                          f'output, or outputs that cannot be steered independently',
                          parameter='poles') from e
    result = place(a, b, poles, method)
    n_states = model.n_states
    return IntegralDesign(result.gain[:, :n_states], -result.gain[:, n_states:], outputs,
                          result.requested_poles, result.achieved_poles, result.method,
                          result.residual)
