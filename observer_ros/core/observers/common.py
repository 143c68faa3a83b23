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

"""What several observer types share: arguments, the poles they are designed for, a step form."""

import math
from typing import Mapping, Optional, Sequence

import numpy as np

from observer_ros.core.arguments import (
    Argument, array, DOUBLE, matrix_text, seconds, STRING, STRING_ARRAY)
from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators.constant_gain import assemble_step, StepMatrices
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement import METHODS
from observer_ros.core.poles import parse_poles, poles_meeting_error_spec, slowest_allowed_pole
from observer_ros.core.ranks import format_modes

#: Largest magnitude of a continuous pole (rad/s): beyond it the sampled designs overflow.
POLE_LIMIT = 1e9

#: Estimate forms: the filtered ``x[k|k]`` or the one-step prediction ``x[k+1|k]``.
FORMS = ('current', 'delayed')


def read_poles(entries: Sequence, argument: str = 'poles') -> np.ndarray:
    """
    Parse a pole list once into the complex array a design takes; bound every pole.

    The ``parse`` of :data:`POLES` (:meth:`~observer_ros.core.arguments.Argument.convert`):
    numbers are taken as they are, texts parsed (:func:`~observer_ros.core.poles.parse_poles`).

    Raises
    ------
    ConfigError
        ``argument``: unreadable, unpaired, or beyond :data:`POLE_LIMIT`.

    """
    poles = parse_poles(entries, argument)
    huge = poles[np.abs(poles) > POLE_LIMIT]
    if huge.size:
        raise ConfigError(argument, f'poles {format_modes(huge)} exceed {POLE_LIMIT:g} in '
                          f'magnitude; no sampled design can realise them')
    return poles


POLES = Argument(
    'poles', STRING_ARRAY, [],
    'Observer error poles as strings ("-10", "-2+2j", "zeta=0.8, wn=10"); s-plane for a '
    'continuous model, z-plane for a discrete one. n poles (full order) or n - p (reduced '
    'order, Chen); with model.disturbances n counts the disturbance states too.',
    tunable=True, parse=read_poles)
GAIN = array('gain', matrix_text('Given observer gain L instead of poles: n x p (full order) '
                                 'or (n-p) x p (reduced order, Chen)'), tunable=True)
METHOD = Argument('method', STRING, 'auto',
                  'Pole placement method: ' + ' | '.join(METHODS) + '.', tunable=True,
                  choices=METHODS)
ERROR_TOLERANCE = Argument(
    'error_tolerance', DOUBLE, 0.0,
    'With observer.error_time: require ||e(T)|| <= tolerance for ||e(0)|| = 1 (slowest pole '
    'ln(tolerance)/T); 0 disables. Without poles, poles are generated at that bound.',
    tunable=True, low=0.0, high=1.0)
ERROR_TIME = seconds('error_time', 0.0, 'Time T in seconds of the error specification.',
                     0.0, 1e6, tunable=True)
FORM = Argument(
    'form', STRING, 'current',
    'Full order and Kalman: current (the filtered x[k|k], published with the measurement) | '
    'delayed (the prediction x[k+1|k] over the last interval with the input of the next, '
    'published once that input is known, stamped with the measurement).',
    choices=FORMS)

#: The arguments of the types designed from poles or a given gain.
POLE_ARGUMENTS = (POLES, GAIN, METHOD, ERROR_TOLERANCE, ERROR_TIME)


def parsed_poles(values: Mapping, argument: str = 'poles') -> Optional[np.ndarray]:
    """
    Return the poles of ``values[argument]`` (None when empty), parsed and bounded once.

    The checked values of a type (:meth:`~observer_ros.core.observers.ObserverType.values`,
    the parameter schema) hold the complex array :func:`read_poles` made, which is returned
    as it is; a list given as numbers or texts (a direct call) is read here.

    Raises
    ------
    ConfigError
        ``argument``: unreadable, unpaired, or beyond :data:`POLE_LIMIT`.

    """
    given = values[argument]
    if len(given) == 0:
        return None
    if isinstance(given, np.ndarray) and given.dtype == complex:
        return given
    return read_poles(given, argument)


def requested_poles(model: StateSpaceModel, values: Mapping, count: int) -> Optional[np.ndarray]:
    """
    Return the poles to design for: ``poles``, checked against the error specification.

    Without ``poles`` and with ``error_tolerance`` and ``error_time``, ``count`` poles at the
    bound (seed 004); with both, poles slower than the bound are refused.

    Raises
    ------
    ConfigError
        ``poles`` or ``error_tolerance``, saying what is wrong.

    """
    poles = parsed_poles(values)
    tolerance, time = values['error_tolerance'], values['error_time']
    if tolerance == 0.0 and time == 0.0:
        return poles
    try:
        bound = slowest_allowed_pole(tolerance, time)
    except ConfigError as e:
        raise ConfigError('error_tolerance', f'{e} (error_tolerance={tolerance}, '
                          f'error_time={time})') from e
    if poles is None:
        generated = poles_meeting_error_spec(tolerance, time, count)
        return np.exp(generated * model.dt) if model.is_discrete else generated
    if model.is_discrete:
        slow = poles[np.abs(poles) > math.exp(bound * model.dt) * (1 + 1e-12)]
    else:
        slow = poles[poles.real > bound * (1 - 1e-12)]
    if slow.size:
        raise ConfigError(
            'poles', f'poles {format_modes(slow)} are slower than the error specification '
            f'allows (||e({time})|| <= {tolerance} needs real parts <= {bound:.6g})')
    return poles


def poles_or_gain(model: StateSpaceModel, values: Mapping, count: int, kind: str) -> tuple:
    """
    Return ``(poles, gain)`` for a pole-placed type: one of them, or both None.

    Raises
    ------
    ConfigError
        Both ``gain`` and ``poles`` given, or the wrong number of poles.

    """
    poles = requested_poles(model, values, count)
    gain = values['gain'] or None
    if gain is not None and len(values['poles']):
        raise ConfigError('gain', 'give either gain or poles, not both')
    if poles is not None and poles.size != count:
        raise ConfigError('poles', f'expected {count} poles for a {kind} observer of this '
                          f'model, got {poles.size}')
    return poles, gain


def charged_poles_or_gain(given: Mapping) -> str:
    """Return the argument a failed pole-placed design is charged to: ``gain`` or ``poles``."""
    return 'gain' if given.get('gain') else 'poles'


def pinned_gain(design, values: Mapping) -> dict:
    """
    Return the arguments that pin a pole-placed design: its gain, instead of the poles.

    The error specification (``error_tolerance``, ``error_time``) is dropped with them.
    """
    return {'gain': np.ravel(design.gain).tolist(), 'poles': None, 'error_tolerance': None,
            'error_time': None}


def current_form(ad: np.ndarray, bd: np.ndarray, c: np.ndarray, filter_gain: np.ndarray,
                 poles: np.ndarray, covariance=None, innovation_covariance=None) -> StepMatrices:
    """Step matrices of ``x_hat = (I - M C)(Ad x_hat + Bd u) + M y``."""
    correction = np.eye(ad.shape[0]) - filter_gain @ c
    return assemble_step(correction @ ad, correction @ bd, filter_gain, c, ad, bd, poles,
                         covariance, innovation_covariance)
