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

"""Full-order (Luenberger) observer ``x_hat' = A x_hat + B u + L (y - C x_hat - D u)``."""


import numpy as np

from observer_ros.core.analysis import require_seen
from observer_ros.core.design.common import (
    check_given_gain_stable, ObserverDesign, predictor_realization, require_stable_poles)
from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import matrix_from_flat
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement import place_observer


#: The full-order observer is the predictor-form realization of its gain.
full_order_realization = predictor_realization


def design_full_order(model: StateSpaceModel, poles=None, gain=None,
                      method: str = 'auto') -> ObserverDesign:
    """
    Design (or check) a full-order Luenberger observer.

    Parameters
    ----------
    model : StateSpaceModel
    poles : array_like of complex, shape (n,), optional
        Error-dynamics poles: s-plane for a continuous model, z-plane for a discrete one.
    gain : array_like, shape (n, p) or flat (n * p,), optional
        A given ``L`` (row-major when flat); it is checked for stability instead of designed.
    method : str
        Placement method (see :mod:`observer_ros.core.placement`).

    Returns
    -------
    ObserverDesign
        ``gain`` is ``L``, shape ``(n, p)``.

    Raises
    ------
    ConfigError
        ``gain`` of the wrong size; ``poles`` of the wrong count or unpaired; ``method``
        unknown; ``poles`` when neither poles nor a gain are given.
    DesignError
        Unobservable pair (with the lost modes), placement failure, unstable ``poles``
        or a ``gain`` leaving the error unstable.

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> design = oc.design_full_order(model, poles=[-8, -9])
    >>> print(np.round(design.gain, 6).ravel(), design.method)
    [17. 72.] place

    A given gain is checked rather than designed:

    >>> oc.design_full_order(model, gain=[17, 72]).achieved_poles.round(6).tolist()
    [(-9+0j), (-8+0j)]
    >>> oc.design_full_order(model, gain=[17, 72, 1])
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: gain: expected 2x1 (2 values, row-major), got 3

    """
    if gain is not None:
        gain = matrix_from_flat('gain', np.ravel(gain), model.n_states, model.n_outputs)
        achieved = check_given_gain_stable(model.a - gain @ model.c, model.is_discrete, 'gain')
        return ObserverDesign(
            kind='full_order', model=model, gain=gain, requested_poles=achieved,
            achieved_poles=achieved, method='given', residual=0.0,
            realization=predictor_realization(model, gain))
    if poles is None:
        raise ConfigError('poles', 'expected the observer poles or a gain, got neither')
    poles = np.asarray(poles, dtype=complex)
    require_stable_poles(poles, model.is_discrete, 'poles')
    require_seen(model)
    result = place_observer(model.a, model.c, poles, method)
    return ObserverDesign(
        kind='full_order', model=model, gain=result.gain,
        requested_poles=result.requested_poles, achieved_poles=result.achieved_poles,
        method=result.method, residual=result.residual,
        realization=predictor_realization(model, result.gain))


__all__ = ['design_full_order', 'full_order_realization']
