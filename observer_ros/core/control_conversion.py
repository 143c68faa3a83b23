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
Conversion between a StateSpaceModel and python-control's ``StateSpace``, names included.

:meth:`StateSpaceModel.from_statespace <observer_ros.core.model.StateSpaceModel.from_statespace>`
and :meth:`~observer_ros.core.model.StateSpaceModel.to_statespace` are these two functions:
python-control's labels become the model's names and back (the ones python-control makes
up, ``x[0]``, ``u[1]``..., are not names), its ``dt`` the model's period. python-control is
imported only when a model is converted to it (about a second).
"""

import re
from typing import Any, Optional, TYPE_CHECKING

from observer_ros.core.errors import ConfigError

if TYPE_CHECKING:
    from observer_ros.core.model import StateSpaceModel


#: Signal names python-control makes up when none are given (``x[0]``, ``u[1]``...).
_CONTROL_DEFAULT_NAME = re.compile(r'^[xuy]\[\d+\]$')


def from_statespace(cls, sys: Any) -> 'StateSpaceModel':
    """
    Build a model from a python-control ``StateSpace`` system.

    Parameters
    ----------
    sys : control.StateSpace
        Continuous (``sys.dt`` 0, or None for an unspecified time base, taken as
        continuous) or discrete with a period (``sys.dt > 0``). Its state, input and
        output labels become the model's names, unless they are the ones
        python-control makes up (``x[0]``, ``u[0]``, ``y[0]``...).

    Returns
    -------
    StateSpaceModel

    Raises
    ------
    ConfigError
        Naming ``sys`` when it is not a state-space system (convert a transfer function
        with ``control.ss`` first, choosing the realization) or is discrete with an
        unspecified period (``dt=True``); naming ``A`` ... ``D`` as :meth:`from_flat`
        does for empty or non-finite matrices.

    Examples
    --------
    >>> import control
    >>> from observer_ros.core import StateSpaceModel
    >>> cart = control.ss([[0, 1], [0, 0]], [[0], [1]], [[1, 0]], 0, 0.01,
    ...                   states=['position', 'velocity'], inputs=['force'])
    >>> model = StateSpaceModel.from_statespace(cart)
    >>> model.dt, model.state_names, model.input_names, model.output_names
    (0.01, ('position', 'velocity'), ('force',), ('y1',))

    """
    matrices = [getattr(sys, name, None) for name in ('A', 'B', 'C', 'D')]
    if any(matrix is None for matrix in matrices) or not hasattr(sys, 'dt'):
        raise ConfigError(
            'sys', f'expected a control.StateSpace system, got {type(sys).__name__}; '
            'convert a transfer function with control.ss(sys), which chooses the states')
    dt = sys.dt
    if dt is None:
        dt = 0.0
    elif dt is True:
        raise ConfigError(
            'sys', 'the system is discrete with an unspecified period (dt=True); set '
            'its period in seconds (control.ss(..., dt=0.01))')

    def labels(name: str) -> Optional[list]:
        values = list(getattr(sys, name, None) or [])
        if not values or all(_CONTROL_DEFAULT_NAME.match(str(v)) for v in values):
            return None
        return values

    return cls.from_matrices(*matrices, dt=dt, state_names=labels('state_labels'),
                             input_names=labels('input_labels'),
                             output_names=labels('output_labels'))


def to_statespace(model: 'StateSpaceModel') -> Any:
    """
    Return the model as a python-control ``StateSpace`` system, with its names.

    Returns
    -------
    control.StateSpace
        ``dt`` 0 (continuous) or the period; the state, input and output labels are the
        model's names.

    Raises
    ------
    ConfigError
        Naming ``B`` for a model without inputs (python-control cannot hold one).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[-1]], [[1]], [[2]], dt=0.0,
    ...                                          state_names=['speed'])
    >>> sys = model.to_statespace()
    >>> sys.dt, sys.state_labels, float(sys.dcgain())
    (0, ['speed'], 2.0)
    >>> back = oc.StateSpaceModel.from_statespace(sys)
    >>> back.state_names, back.input_names, bool((back.c == model.c).all())
    (('speed',), ('u1',), True)

    """
    if model.n_inputs == 0:
        raise ConfigError('B', 'python-control has no state-space systems without inputs '
                          '(m = 0)')
    import control  # about a second to import, so only when asked
    dt = model.dt if model.is_discrete else 0
    return control.ss(model.a, model.b, model.c, model.d, dt,
                      states=list(model.state_names), inputs=list(model.input_names),
                      outputs=list(model.output_names))


__all__ = ['from_statespace', 'to_statespace']
