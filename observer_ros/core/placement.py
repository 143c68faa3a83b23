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
Pole placement that checks its own answer.

``place`` picks among several algorithms by the problem (input count, repeated poles),
verifies the eigenvalues it achieved and raises :class:`DesignError` rather than return a
wrong gain. ``place_observer`` is its dual for ``A - L C``.

Methods
-------
``'place'``
    Robust eigenstructure assignment (Kautsky-Nichols-Van Dooren / Tits-Yang, through
    :func:`scipy.signal.place_poles`). Refuses poles repeated more than ``rank(B)`` times.
    Each robustness iteration costs O(n^3) in Python loops (seconds at n = 100), so above
    :data:`LARGE_STATES` states only :data:`LARGE_MAXITER` are made.
``'varga'``
    Varga's Schur method (SLICOT ``SB01BD``, called as :func:`control.place_varga` calls
    it), which handles repeated poles.
``'acker'``
    Ackermann's formula, single input only; ill-conditioned for large ``n``.
``'direct'``
    The direct method of the course notes, single input: match the coefficients of
    ``det(sI - A + B K)`` with the desired polynomial (a linear system in ``K``).
``'canonical'``
    Bass-Gura, through the controllable canonical form, single input.
``'auto'``
    Try the suitable methods in a sensible order and return the first verified gain
    (Varga's first above :data:`LARGE_STATES` states: a fraction of a second at n = 100).
"""

from dataclasses import dataclass, replace

import numpy as np

from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.placement_checks import (
    has_repeated, max_multiplicity, placement_residual, sort_poles)
from observer_ros.core.placement_methods import _ALGORITHMS, _SINGLE_INPUT_ONLY, LARGE_STATES
from observer_ros.core.poles import check_conjugate_pairs, clean_poles
from observer_ros.core.ranks import format_modes

METHODS = ('auto', 'place', 'varga', 'acker', 'direct', 'canonical')

#: Default relative accuracy every achieved pole set must meet.
DEFAULT_RTOL = 1e-6

#: Above this many states the single-input closed forms are not tried by ``'auto'``.
CLOSED_FORM_MAX_STATES = 12


@dataclass(frozen=True)
class PlacementResult:
    """
    Gain from a pole placement and the evidence that it is right.

    Attributes
    ----------
    gain : numpy.ndarray
        ``K`` with ``eig(A - B K)`` at the requested poles (state feedback), or ``L`` with
        ``eig(A - L C)`` there (observer, from :func:`place_observer`).
    requested_poles, achieved_poles : numpy.ndarray of complex
        Sorted the same way, so they can be compared entry by entry.
    method : str
        The algorithm that produced the gain.
    residual : float
        Relative error of the achieved poles (distinct poles) or of the characteristic
        polynomial coefficients (repeated poles).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> result = oc.place([[0, 1], [0, 0]], [[0], [1]], [-2, -2.5])
    >>> result.gain.round(6).tolist(), result.method, bool(result.residual < 1e-12)
    ([[5.0, 4.5]], 'place', True)

    """

    gain: np.ndarray
    requested_poles: np.ndarray
    achieved_poles: np.ndarray
    method: str
    residual: float


def _candidates(method: str, n_states: int, n_inputs: int, poles: np.ndarray) -> list:
    if method != 'auto':
        return [method]
    if n_inputs == 1:
        order = (['varga', 'place'] if has_repeated(poles) or n_states > LARGE_STATES
                 else ['place', 'varga'])
        if n_states <= CLOSED_FORM_MAX_STATES:
            order.append('acker')
        return order
    if max_multiplicity(poles) > n_inputs or n_states > LARGE_STATES:
        return ['varga', 'place']
    return ['place', 'varga']


def _validate_problem(a, b, poles, method):
    if method not in METHODS:
        raise ConfigError('method', f'expected one of {", ".join(METHODS)}, got {method!r}')
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ConfigError('A', f'expected a square matrix, got shape {a.shape}')
    if b.ndim != 2 or b.shape[0] != a.shape[0]:
        raise ConfigError('B', f'expected {a.shape[0]} rows, got shape {b.shape}')
    poles = np.atleast_1d(np.asarray(poles, dtype=complex))
    if not np.all(np.isfinite(poles)):
        raise ConfigError('poles', f'expected finite values, got {poles.tolist()}')
    poles = clean_poles(poles)
    if poles.size != a.shape[0]:
        raise ConfigError(
            'poles', f'expected {a.shape[0]} poles (one per state), got {poles.size}')
    check_conjugate_pairs(poles)
    for name, matrix in (('A', a), ('B', b)):
        if not np.all(np.isfinite(matrix)):
            raise ConfigError(name, 'expected finite entries')
    return a, b, poles


def place(a, b, poles, method: str = 'auto', rtol: float = DEFAULT_RTOL) -> PlacementResult:
    """
    State-feedback gain ``K`` with ``eig(A - B K)`` at ``poles``, verified.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)
    poles : array_like of complex, shape (n,)
        Complex poles in conjugate pairs.
    method : str
        One of :data:`METHODS`.
    rtol : float
        Accepted relative error of the achieved poles (characteristic polynomial
        coefficients when poles repeat).

    Returns
    -------
    PlacementResult

    Raises
    ------
    DesignError
        When no method reaches ``rtol`` (naming ``poles``): the message lists every
        attempt and why it failed. An uncontrollable pair is reported with its modes
        (unnamed).
    ConfigError
        Naming ``A`` or ``B`` (shapes, non-finite entries), ``poles`` (count, non-finite,
        unpaired), ``method`` (unknown, or single-input only) or ``rtol``.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> a, b = [[0, 1], [0, 0]], [[0], [1]]
    >>> oc.place(a, b, [-2, -2.5]).gain.round(6).tolist()
    [[5.0, 4.5]]
    >>> oc.place(a, b, [-2, -2], method='acker').gain.round(6).tolist()
    [[4.0, 4.0]]
    >>> oc.place(a, b, [-2, -2, -3])
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: poles: expected 2 poles (one per state), got 3

    """
    if not (np.isfinite(rtol) and rtol > 0.0):
        raise ConfigError('rtol', f'expected a relative tolerance > 0, got {rtol}')
    a, b, poles = _validate_problem(a, b, poles, method)
    n_states, n_inputs = b.shape
    if method in _SINGLE_INPUT_ONLY and n_inputs != 1:
        raise ConfigError(
            'method', f'{method!r} needs a single input (column), the problem has {n_inputs}')
    failures = []
    for candidate in _candidates(method, n_states, n_inputs, poles):
        try:
            gain = np.real_if_close(_ALGORITHMS[candidate](a, b, poles))
            if np.iscomplexobj(gain) or not np.all(np.isfinite(gain)):
                raise ValueError('the gain is complex or not finite')
            gain = np.asarray(gain, dtype=float).reshape(n_inputs, n_states)
        except (ValueError, ArithmeticError, np.linalg.LinAlgError, ImportError) as e:
            failures.append(f'{candidate}: {e}')
            continue
        except Exception as e:  # noqa: B902 - SLICOT wrappers raise their own types
            failures.append(f'{candidate}: {type(e).__name__}: {e}')
            continue
        residual, achieved = placement_residual(a - b @ gain, poles)
        if residual <= rtol:
            return PlacementResult(gain=gain, requested_poles=sort_poles(poles),
                                   achieved_poles=achieved, method=candidate,
                                   residual=residual)
        failures.append(
            f'{candidate}: achieved poles {format_modes(achieved)} are off by {residual:.2g} '
            f'relative (tolerance {rtol:.1g})')
    lost = _uncontrollable_modes(a, b)
    if lost:
        raise DesignError(
            f'the pair is not controllable: the modes {format_modes(lost)} cannot be moved '
            f'(PBH test), so the poles {format_modes(poles)} cannot be placed')
    raise DesignError(
        f'no placement method reached the poles {format_modes(poles)} to {rtol:.1g}: '
        + '; '.join(failures), parameter='poles')


def _uncontrollable_modes(a: np.ndarray, b: np.ndarray) -> tuple:
    from observer_ros.core.ranks import pbh_lost_modes
    return pbh_lost_modes(a.T, b.T)


def place_observer(a, c, poles, method: str = 'auto',
                   rtol: float = DEFAULT_RTOL) -> PlacementResult:
    """
    Observer gain ``L`` with ``eig(A - L C)`` at ``poles``, by duality, verified.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)
    poles : array_like of complex, shape (n,)
    method, rtol
        As for :func:`place`.

    Returns
    -------
    PlacementResult
        With ``gain`` of shape ``(n, p)``.

    Raises
    ------
    DesignError
        When the pair is unobservable (the message names the lost modes, unnamed) or no
        method reaches the poles (naming ``poles``).
    ConfigError
        Naming ``A``, ``C``, ``poles``, ``method`` or ``rtol``, as :func:`place` does.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> result = oc.place_observer([[0, 1], [0, 0]], [[1, 0]], [-8, -9])
    >>> result.gain.round(6).tolist()
    [[17.0], [72.0]]

    """
    a = np.asarray(a, dtype=float)
    c = np.atleast_2d(np.asarray(c, dtype=float))
    if a.ndim == 2 and (c.ndim != 2 or c.shape[1] != a.shape[0]):
        raise ConfigError('C', f'expected {a.shape[0]} columns, got shape {c.shape}')
    if not np.all(np.isfinite(c)):
        raise ConfigError('C', 'expected finite entries')
    try:
        dual = place(a.T, c.T, poles, method, rtol)
    except DesignError as e:
        raise DesignError(
            e.reason.replace('is not controllable', 'is not observable')
            .replace('cannot be moved', 'cannot be seen from the outputs'),
            parameter=e.parameter) from e
    return replace(dual, gain=dual.gain.T.copy())
