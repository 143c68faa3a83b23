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
Pole specifications: strings, damping-ratio pairs and error-tolerance bounds.

Poles of a continuous-time model are s-plane values; poles of a discrete-time model are
z-plane values. A continuous design sampled every ``dt`` seconds uses ``exp(lambda dt)``.
"""

import math
import re
from typing import Iterable, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError

#: Relative tolerance under which two poles count as conjugates or as repeated.
POLE_MATCH_RTOL = 1e-9

_DAMPING_PATTERN = re.compile(
    r'^\s*zeta\s*[=:]\s*(?P<zeta>[^,;\s]+)\s*[,;]\s*(?:wn|omega_n)\s*[=:]\s*(?P<wn>[^,;\s]+)\s*$')


def parse_pole(text: str, parameter: str = 'poles') -> complex:
    """
    Parse one pole written as ``'-2'``, ``'-2+2j'``, ``'-2 - 2i'`` or ``'3j'``.

    The text is parsed, never evaluated.

    Parameters
    ----------
    text : str or number
        The pole; a number (real or complex) is taken as it is, never through a text.
    parameter : str
        Name used in error messages.

    Returns
    -------
    complex

    Raises
    ------
    ConfigError
        Naming ``parameter``, if the text is not a finite complex number.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.parse_pole('-2 - 2i'), oc.parse_pole(-3)
    ((-2-2j), (-3+0j))

    """
    if isinstance(text, (int, float, complex, np.number)) and not isinstance(text, bool):
        value = complex(text)
    else:
        cleaned = str(text).strip().replace(' ', '').replace('i', 'j')
        try:
            value = complex(cleaned)
        except ValueError as e:
            raise ConfigError(
                parameter,
                f'cannot read {text!r} as a pole; expected a number such as "-2" or "-2+2j"'
            ) from e
    if not (math.isfinite(value.real) and math.isfinite(value.imag)):
        raise ConfigError(parameter, f'pole {text!r} is not finite')
    return value


def damping_pair(damping_ratio: float, natural_frequency: float,
                 parameter: str = 'poles') -> np.ndarray:
    """
    Two poles with damping ratio ``zeta`` and natural frequency ``wn`` (s-plane).

    Roots of ``s^2 + 2 zeta wn s + wn^2``: a conjugate pair when ``zeta < 1``, two real
    poles otherwise.

    Parameters
    ----------
    damping_ratio : float
        ``zeta >= 0``.
    natural_frequency : float
        ``wn > 0``, in rad/s.
    parameter : str
        Name used in error messages.

    Returns
    -------
    numpy.ndarray of complex, shape (2,)

    Raises
    ------
    ConfigError
        Naming ``parameter``, for non-finite values, ``zeta < 0`` or ``wn <= 0``.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.damping_pair(0.6, 10).round(6).tolist()
    [(-6+8j), (-6-8j)]

    """
    if not (math.isfinite(damping_ratio) and math.isfinite(natural_frequency)):
        raise ConfigError(parameter, f'damping ratio and natural frequency must be finite, '
                          f'got zeta={damping_ratio}, wn={natural_frequency}')
    if natural_frequency <= 0.0 or damping_ratio < 0.0:
        raise ConfigError(
            parameter, f'expected zeta >= 0 and wn > 0, got zeta={damping_ratio}, '
            f'wn={natural_frequency}')
    real = -damping_ratio * natural_frequency
    if damping_ratio < 1.0:
        imag = natural_frequency * math.sqrt(1.0 - damping_ratio ** 2)
        return np.array([complex(real, imag), complex(real, -imag)])
    root = natural_frequency * math.sqrt(damping_ratio ** 2 - 1.0)
    return np.array([complex(real + root), complex(real - root)])


def check_conjugate_pairs(poles: np.ndarray, parameter: str = 'poles') -> None:
    """
    Raise ConfigError unless every complex pole has its conjugate, as often as itself.

    Parameters
    ----------
    poles : array_like of complex
    parameter : str
        Name used in error messages.

    Raises
    ------
    ConfigError
        Naming ``parameter``, for a complex pole without its conjugate.

    Examples
    --------
    >>> from observer_ros.core.poles import check_conjugate_pairs
    >>> check_conjugate_pairs([-1 + 2j, -3])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: poles: complex pole (-1+2j) has no conjugate (-1-2j); ...

    """
    remaining = [complex(p) for p in poles]
    while remaining:
        pole = remaining.pop(0)
        scale = max(1.0, abs(pole))
        if abs(pole.imag) <= POLE_MATCH_RTOL * scale:
            continue
        for index, other in enumerate(remaining):
            if abs(other - pole.conjugate()) <= POLE_MATCH_RTOL * scale:
                del remaining[index]
                break
        else:
            raise ConfigError(
                parameter,
                f'complex pole {pole} has no conjugate {pole.conjugate()}; a real gain needs '
                f'complex poles in conjugate pairs')


def parse_poles(entries: Iterable, parameter: str = 'poles') -> np.ndarray:
    """
    Parse a pole list: numbers, complex strings and ``'zeta=0.8, wn=10'`` pair entries.

    Parameters
    ----------
    entries : iterable of str or float
        One pole per entry, or a damping-ratio pair (two poles) per ``'zeta=..., wn=...'``.
    parameter : str
        Name used in error messages.

    Returns
    -------
    numpy.ndarray of complex
        Poles with conjugate pairs checked; real poles have an exactly zero imaginary part
        and pairs are exact conjugates.

    Raises
    ------
    ConfigError
        Naming ``parameter``: unreadable or non-finite entries, unpaired complex poles.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.parse_poles(['-5', 'zeta=0.6, wn=10']).round(6).tolist()
    [(-5+0j), (-6+8j), (-6-8j)]
    >>> oc.parse_poles(['-1+2j'])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: poles: complex pole (-1+2j) has no conjugate ...

    """
    poles = []
    for entry in entries:
        match = _DAMPING_PATTERN.match(entry) if isinstance(entry, str) else None
        if match:
            try:
                zeta, wn = float(match['zeta']), float(match['wn'])
            except ValueError as e:
                raise ConfigError(parameter, f'cannot read {entry!r} as zeta and wn') from e
            poles.extend(damping_pair(zeta, wn, parameter))
        else:
            poles.append(parse_pole(entry, parameter))
    result = np.array(poles, dtype=complex)
    check_conjugate_pairs(result, parameter)
    return clean_poles(result)


def clean_poles(poles: Sequence[complex]) -> np.ndarray:
    """
    Zero tiny imaginary parts and make conjugate partners exact conjugates.

    Parameters
    ----------
    poles : array_like of complex, shape (k,)

    Returns
    -------
    numpy.ndarray of complex, shape (k,)
        In the same order; imaginary parts below :data:`POLE_MATCH_RTOL` (relative) are
        zero.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.clean_poles([-2 + 1e-14j, -1 + 2j, -1 - (2 + 1e-12)*1j]).tolist()
    [(-2+0j), (-1+2j), (-1-2j)]

    """
    result = np.array(poles, dtype=complex)
    for index, pole in enumerate(result):
        if abs(pole.imag) <= POLE_MATCH_RTOL * max(1.0, abs(pole)):
            result[index] = complex(pole.real, 0.0)
    for index, pole in enumerate(result):
        if pole.imag > 0:
            partners = np.flatnonzero(
                np.abs(result - pole.conjugate()) <= POLE_MATCH_RTOL * max(1.0, abs(pole)))
            for partner in partners:
                if result[partner].imag < 0:
                    result[partner] = pole.conjugate()
    return result


def slowest_allowed_pole(tolerance: float, time: float) -> float:
    """
    Slowest s-plane pole real part meeting ``||e(T)|| <= tolerance`` for ``||e(0)|| = 1``.

    From ``exp(lambda_max T) <= tolerance``: ``lambda_max <= ln(tolerance) / T``. The bound
    takes the error to decay like its slowest mode, as the seed notes do; non-normal error
    dynamics can add a transient factor, so leave margin.

    Parameters
    ----------
    tolerance : float
        Error norm allowed at ``time``, relative to the initial one: ``0 < tolerance < 1``.
    time : float
        Seconds, finite and > 0.

    Returns
    -------
    float
        The largest real part an s-plane pole may have (negative).

    Raises
    ------
    ConfigError
        Naming ``tolerance`` or ``time`` when out of range.

    Examples
    --------
    >>> round(slowest_allowed_pole(1e-3, 5.0), 4)
    -1.3816

    """
    if not (0.0 < tolerance < 1.0):
        raise ConfigError('tolerance', f'expected 0 < tolerance < 1, got {tolerance}')
    if not (time > 0.0 and math.isfinite(time)):
        raise ConfigError('time', f'expected a finite time > 0 s, got {time}')
    return math.log(tolerance) / time


def poles_meeting_error_spec(tolerance: float, time: float, count: int,
                             spacing: float = 0.25) -> np.ndarray:
    """
    ``count`` distinct real poles, the slowest at the bound of :func:`slowest_allowed_pole`.

    The others are spread by ``spacing`` times the bound: ``bound * (1, 1.25, 1.5, ...)``.

    Parameters
    ----------
    tolerance, time : float
        As for :func:`slowest_allowed_pole`.
    count : int
        Number of poles, >= 1.
    spacing : float
        Relative spacing of the poles, > 0.

    Returns
    -------
    numpy.ndarray of complex, shape (count,)
        s-plane poles (map them with :func:`to_discrete` for a discrete model).

    Raises
    ------
    ConfigError
        Naming ``tolerance``, ``time``, ``count`` or ``spacing`` when out of range.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.poles_meeting_error_spec(1e-3, 5.0, 3).real.round(4).tolist()
    [-1.3816, -1.7269, -2.0723]

    """
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 1:
        raise ConfigError('count', f'expected an integer >= 1, got {count!r}')
    if not (math.isfinite(spacing) and spacing > 0.0):
        raise ConfigError('spacing', f'expected a finite spacing > 0, got {spacing}')
    bound = slowest_allowed_pole(tolerance, time)
    return np.array([complex(bound * (1.0 + spacing * k)) for k in range(count)])


def to_discrete(poles: np.ndarray, dt: float) -> np.ndarray:
    """
    Map s-plane poles to the z-plane for sample interval ``dt``: ``exp(lambda dt)``.

    Parameters
    ----------
    poles : array_like of complex, shape (k,)
    dt : float
        Sample interval in seconds.

    Returns
    -------
    numpy.ndarray of complex, shape (k,)

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.to_discrete([-10, -1 + 2j, -1 - 2j], 0.1).round(4).tolist()
    [(0.3679+0j), (0.8868+0.1798j), (0.8868-0.1798j)]

    """
    return clean_poles(np.exp(np.asarray(poles, dtype=complex) * dt))


def is_stable(poles: np.ndarray, discrete: bool) -> bool:
    """
    Hurwitz (continuous) or Schur (discrete) stability of a pole set.

    Parameters
    ----------
    poles : array_like of complex
    discrete : bool
        z-plane (every ``|z| < 1``) or s-plane (every real part < 0).

    Returns
    -------
    bool

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.is_stable([-1, -2 + 1j, -2 - 1j], discrete=False), oc.is_stable([0.5, 1.0], True)
    (True, False)

    """
    poles = np.asarray(poles, dtype=complex)
    if discrete:
        return bool(np.all(np.abs(poles) < 1.0))
    return bool(np.all(poles.real < 0.0))


def pole_pairs(poles: np.ndarray) -> list:
    """
    Poles as ``[re, im]`` pairs for JSON output.

    Examples
    --------
    >>> from observer_ros.core.poles import pole_pairs
    >>> pole_pairs([-1 + 2j, -3])
    [[-1.0, 2.0], [-3.0, 0.0]]

    """
    return [[float(p.real), float(p.imag)] for p in np.asarray(poles, dtype=complex)]
