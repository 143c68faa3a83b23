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

    Raises
    ------
    ConfigError
        If the text is not a finite complex number.

    """
    if isinstance(text, (int, float)) and not isinstance(text, bool):
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
    poles otherwise. ``parameter`` names the source in error messages.
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
    """Raise ConfigError unless every complex pole has its conjugate, as often as itself."""
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

    Returns
    -------
    numpy.ndarray of complex
        Poles with conjugate pairs checked; real poles have an exactly zero imaginary part
        and pairs are exact conjugates.

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
    """Zero tiny imaginary parts and make conjugate partners exact conjugates."""
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
    """
    bound = slowest_allowed_pole(tolerance, time)
    return np.array([complex(bound * (1.0 + spacing * k)) for k in range(count)])


def to_discrete(poles: np.ndarray, dt: float) -> np.ndarray:
    """Map s-plane poles to the z-plane for sample interval ``dt``: ``exp(lambda dt)``."""
    return clean_poles(np.exp(np.asarray(poles, dtype=complex) * dt))


def is_stable(poles: np.ndarray, discrete: bool) -> bool:
    """Hurwitz (continuous) or Schur (discrete) stability of a pole set."""
    poles = np.asarray(poles, dtype=complex)
    if discrete:
        return bool(np.all(np.abs(poles) < 1.0))
    return bool(np.all(poles.real < 0.0))


def pole_pairs(poles: np.ndarray) -> list:
    """Poles as ``[re, im]`` pairs for JSON output."""
    return [[float(p.real), float(p.imag)] for p in np.asarray(poles, dtype=complex)]
