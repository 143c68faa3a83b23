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
Units of the package: stamps are integer nanoseconds, durations in formulas seconds.

The one rule from seconds to nanoseconds is :func:`seconds_to_ns` (a period from a rate:
:func:`rate_to_period_ns`): the product ``seconds * NANOSECONDS`` in double precision,
rounded to the nearest integer nanosecond, ties to even (Python's ``round``). A duration
written in decimal seconds with at most nine decimals gets its exact nanoseconds
(``0.3`` s is ``300_000_000`` ns, ``7e-9`` s is ``7`` ns, where truncating with ``int``
would give ``6`` for some of them); a half nanosecond goes to the even neighbour
(``0.5e-9`` s is ``0``, ``1.5e-9`` s is ``2``); negative durations round the same way
(``-1e-9`` s is ``-1``). A value that is not finite, or that overflows to infinity
(``1e300`` s), raises ConfigError (a ValueError) naming it. Parameters are converted
once, where they are read (:mod:`observer_ros.config`), and handed on in nanoseconds.

Examples
--------
>>> from observer_ros.core.units import rate_to_period_ns, seconds_to_ns
>>> 10_000_000 / NANOSECONDS
0.01
>>> seconds_to_ns(0.3), seconds_to_ns(1.5e-9), rate_to_period_ns(30.0)
(300000000, 2, 33333333)

"""

import math

from observer_ros.core.errors import ConfigError

#: Nanoseconds per second: a stamp ``t_ns`` is ``t_ns / NANOSECONDS`` seconds.
NANOSECONDS = 1_000_000_000


def seconds_to_ns(seconds: float, name: str = 'seconds') -> int:
    """
    Return a duration in seconds as integer nanoseconds: nearest, ties to even.

    Parameters
    ----------
    seconds : float or int
        The duration; negative durations are converted alike.
    name : str
        What the value is, for the error message (a parameter or argument name).

    Returns
    -------
    int
        ``round(seconds * NANOSECONDS)`` (see the module notes).

    Raises
    ------
    ConfigError
        A ValueError naming ``name``: the value, or its product with
        :data:`NANOSECONDS`, is not finite.

    Examples
    --------
    >>> seconds_to_ns(0), seconds_to_ns(-1e-9), seconds_to_ns(0.5e-9), seconds_to_ns(2.0)
    (0, -1, 0, 2000000000)

    """
    product = seconds * NANOSECONDS
    if not math.isfinite(product):
        raise ConfigError(name, f'expected a finite number of seconds, got {seconds!r}')
    return round(product)


def rate_to_period_ns(rate_hz: float, name: str = 'rate') -> int:
    """
    Return the period of a rate in integer nanoseconds: ``round(NANOSECONDS / rate_hz)``.

    Raises
    ------
    ConfigError
        A ValueError naming ``name``: a rate that is not finite and above 0.

    Examples
    --------
    >>> rate_to_period_ns(100.0), rate_to_period_ns(3.0)
    (10000000, 333333333)

    """
    if not (math.isfinite(rate_hz) and rate_hz > 0):
        raise ConfigError(name, f'expected a finite rate above 0 Hz, got {rate_hz!r}')
    return round(NANOSECONDS / rate_hz)


__all__ = ['NANOSECONDS', 'rate_to_period_ns', 'seconds_to_ns']
