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

"""State feedback ``u = -K x_hat + N r`` with a reference gain for unit DC gain."""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.flat_matrices import matrix_from_flat
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement import place
from observer_ros.core.placement_checks import sort_poles
from observer_ros.core.poles import is_stable
from observer_ros.core.ranks import format_modes, require_controllable


@dataclass(frozen=True)
class FeedbackDesign:
    """
    State-feedback design.

    Attributes
    ----------
    gain : numpy.ndarray, shape (m, n)
        ``K`` in ``u = -K x``.
    requested_poles, achieved_poles : numpy.ndarray of complex
        Sorted poles of ``A - B K``.
    method : str
        Placement algorithm (``'given'`` when the gain was supplied).
    residual : float
        Relative error of the achieved poles.
    reference_gain : numpy.ndarray or None, shape (m, p)
        ``N`` giving unit DC gain from ``r`` to ``y`` (square systems without a zero at
        ``s = 0`` / ``z = 1``), else None.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> design = oc.design_feedback(model, poles=[-2, -2.5])
    >>> design.gain.round(6).tolist(), design.reference_gain.round(6).tolist()
    ([[5.0, 4.5]], [[5.0]])

    """

    gain: np.ndarray
    requested_poles: np.ndarray
    achieved_poles: np.ndarray
    method: str
    residual: float
    reference_gain: Optional[np.ndarray]


def reference_gain(model: StateSpaceModel, gain: np.ndarray) -> Optional[np.ndarray]:
    """
    ``N`` with unit DC gain from ``r`` to ``y`` under ``u = -K x + N r``, or None.

    The closed-loop DC gain is ``G0 = (C - D K) (-(A - B K))^-1 B + D`` (continuous) or with
    ``(I - (A - B K))^-1`` (discrete); ``N = G0^-1`` when ``G0`` is square and invertible.

    Parameters
    ----------
    model : StateSpaceModel
    gain : numpy.ndarray, shape (m, n)
        ``K``.

    Returns
    -------
    numpy.ndarray, shape (m, p), or None
        None when ``m != p`` or ``G0`` is singular (a zero at ``s = 0`` / ``z = 1``).

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> oc.reference_gain(model, np.array([[5.0, 4.5]])).round(6).tolist()
    [[5.0]]

    """
    if model.n_inputs != model.n_outputs:
        return None
    closed = model.a - model.b @ gain
    resolvent = (np.eye(model.n_states) - closed) if model.is_discrete else -closed
    try:
        dc_gain = (model.c - model.d @ gain) @ np.linalg.solve(resolvent, model.b) + model.d
        if np.linalg.cond(dc_gain) > 1e12:
            return None
        return np.linalg.inv(dc_gain)
    except np.linalg.LinAlgError:
        return None


def design_feedback(model: StateSpaceModel, poles=None, gain=None,
                    method: str = 'auto') -> FeedbackDesign:
    """
    Design (or check) the state-feedback gain ``K``.

    Parameters
    ----------
    model : StateSpaceModel
    poles : array_like of complex, shape (n,), optional
        Poles of ``A - B K`` (s-plane, or z-plane for a discrete model).
    gain : array_like, shape (m, n) or flat (m * n,), optional
        A given ``K`` (row-major when flat); it must stabilize ``A - B K``.
    method : str
        Placement method (see :mod:`observer_ros.core.placement`).

    Returns
    -------
    FeedbackDesign

    Raises
    ------
    ConfigError
        ``gain`` of the wrong size; ``poles`` not stable, of the wrong count or unpaired;
        ``method`` unknown; ``poles`` when neither poles nor a gain are given.
    DesignError
        Uncontrollable pair, placement failure, or a given ``gain`` leaving the loop
        unstable.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> oc.design_feedback(model, poles=[-2, -2.5]).gain.round(6).tolist()
    [[5.0, 4.5]]
    >>> oc.design_feedback(model, gain=[-1, 1])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.DesignError: gain: the given K leaves A - B K unstable: poles ...

    """
    if gain is not None:
        gain = matrix_from_flat('gain', np.ravel(gain), model.n_inputs, model.n_states)
        achieved = sort_poles(np.linalg.eigvals(model.a - model.b @ gain))
        if not is_stable(achieved, model.is_discrete):
            raise DesignError(
                f'the given K leaves A - B K unstable: poles {format_modes(achieved)}',
                parameter='gain')
        return FeedbackDesign(gain=gain, requested_poles=achieved, achieved_poles=achieved,
                              method='given', residual=0.0,
                              reference_gain=reference_gain(model, gain))
    if poles is None:
        raise ConfigError('poles', 'expected the feedback poles or a gain, got neither')
    poles = np.asarray(poles, dtype=complex)
    if not is_stable(poles, model.is_discrete):
        raise ConfigError('poles', f'requested poles {format_modes(poles)} are not stable')
    require_controllable(model.a, model.b)
    result = place(model.a, model.b, poles, method)
    return FeedbackDesign(
        gain=result.gain, requested_poles=result.requested_poles,
        achieved_poles=result.achieved_poles, method=result.method, residual=result.residual,
        reference_gain=reference_gain(model, result.gain))
