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
Typed, ranged arguments: what an observer type reads and what a parameter schema holds.

An :class:`Argument` names a value, its value type (``double``, ``double_array``,
``string``, ``string_array``, ``integer``, ``bool``), default, range and description, and
checks a given value with :meth:`Argument.coerce` (the parameter's own value, the form a
parameter file holds) and converts it into the type its user takes with
:meth:`Argument.convert`, once (a pole list becomes a complex array straight from the
numbers or texts given, through the argument's ``parse``). Observer types declare theirs by their
own names (``poles``, ``gain``); the parameter schema (:mod:`observer_ros.config`) offers
each under its parameter name (``observer.poles``), with what only a node knows: which nodes
declare it and whether it may change at run time.
"""

from dataclasses import dataclass, field
import math
from typing import Any, Callable, Optional

import numpy as np

from observer_ros.core.errors import ConfigError

DOUBLE, DOUBLE_ARRAY, STRING, STRING_ARRAY, INTEGER, BOOL = (
    'double', 'double_array', 'string', 'string_array', 'integer', 'bool')

#: Largest magnitude of a model, gain or covariance entry: beyond it the exact
#: discretization and the designs overflow double precision.
ENTRY_LIMIT = 1e12

#: Largest seed ``numpy.random.default_rng`` takes from a ROS integer parameter.
SEED_MAX = 2 ** 63 - 1

_NUMBERS = (int, float, np.integer, np.floating)


def number_text(value) -> str:
    """
    Return a number with every digit it has: ``3600.001`` reads ``3600.001``, never ``3600``.

    The short ``g`` form when it is exact (``0.5``, ``1e+09``), else the shortest text that
    reads back as the same float (``repr``); integers whole.

    Examples
    --------
    >>> number_text(3600.001), number_text(1e9), number_text(0.5), number_text(2 ** 63 - 1)
    ('3600.001', '1e+09', '0.5', '9223372036854775807')

    """
    if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
        return str(int(value))
    value = float(value)
    short = f'{value:g}'
    return short if float(short) == value else repr(value)


@dataclass(frozen=True)
class Argument:
    """
    A named value with a value type, a default, a range and a description.

    Attributes
    ----------
    name : str
        The argument's name (or, in a parameter schema, the parameter's).
    value_type : str
        One of ``double``, ``double_array``, ``string``, ``string_array``, ``integer``,
        ``bool``.
    default : object
    description : str
    tunable : bool
        Whether a running estimator takes a new value in place, its state kept (gains,
        poles, noises); otherwise the value shapes the estimator (its form), which a new
        value rebuilds.
    low, high : float or None
        Inclusive bounds of a number.
    low_open : bool
        The lower bound is exclusive (``> low``).
    unit : str
        What the number is, for error messages (``'seconds'``).
    entry_limit : float or None
        Double arrays: the largest magnitude of an entry.
    choices : tuple of str
        Strings: the accepted values (empty: any).
    parse : callable, optional
        ``parse(entries, name)``: the final value of a string list whose entries may also
        be written as numbers (a pole list, parsed into a complex array), raising
        ConfigError naming ``name``; see :meth:`convert`.

    Examples
    --------
    >>> timeout = Argument('timeout', DOUBLE, 0.5, 'Seconds.', low=0.001, high=3600.0,
    ...                    unit='seconds')
    >>> timeout.coerce(2)
    2.0
    >>> timeout.coerce(1e9)
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: timeout: expected seconds in [0.001, 3600], got 1e+09

    """

    name: str
    value_type: str
    default: Any
    description: str
    tunable: bool = False
    low: Optional[float] = None
    high: Optional[float] = None
    low_open: bool = False
    unit: str = 'a value'
    entry_limit: Optional[float] = None
    choices: tuple = ()
    parse: Optional[Callable[[list, str], Any]] = field(default=None, compare=False,
                                                        repr=False)

    def range_text(self) -> str:
        """Return the accepted range in words (empty when any value of the type is)."""
        if self.low is None and self.high is None:
            return ''
        low = '-inf' if self.low is None else number_text(self.low)
        high = 'inf' if self.high is None else number_text(self.high)
        return f'{"(" if self.low_open else "["}{low}, {high}]'

    def _ranged(self, value):
        low, high = self.low, self.high
        below = low is not None and (value <= low if self.low_open else value < low)
        if below or (high is not None and value > high):
            raise ConfigError(self.name, f'expected {self.unit} in {self.range_text()}, '
                              f'got {number_text(value)}')
        return value

    def coerce(self, value: Any) -> Any:
        """
        Return ``value`` checked and converted to the value type (None gives the default).

        Integers count as doubles; numbers in a string list become strings (pole lists
        written as numbers).

        Raises
        ------
        ConfigError
            Naming the argument: wrong type, not finite, outside the range or the choices.

        """
        name, value_type = self.name, self.value_type
        if value is None:
            return self.default
        if value_type == DOUBLE:
            if isinstance(value, bool) or not isinstance(value, _NUMBERS):
                raise ConfigError(name, f'expected a number, got {value!r}')
            value = float(value)
            if not math.isfinite(value):
                raise ConfigError(name, f'expected a finite number, got {value}')
            return self._ranged(value)
        if value_type == INTEGER:
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
                raise ConfigError(name, f'expected an integer, got {value!r}')
            return self._ranged(int(value))
        if value_type == BOOL:
            if not isinstance(value, bool):
                raise ConfigError(name, f'expected true or false, got {value!r}')
            return value
        if value_type == STRING:
            if not isinstance(value, str):
                raise ConfigError(name, f'expected a string, got {value!r}')
            if self.choices and value not in self.choices:
                raise ConfigError(name, f'expected one of {", ".join(self.choices)}, '
                                  f'got {value!r}')
            return value
        if isinstance(value, (str, bytes)) or not hasattr(value, '__iter__'):
            raise ConfigError(name, f'expected a list, got {value!r}')
        items = list(value)
        if value_type == DOUBLE_ARRAY:
            for index, item in enumerate(items):
                if isinstance(item, bool) or not isinstance(item, _NUMBERS):
                    raise ConfigError(name, f'expected numbers, entry {index} is {item!r}')
            values = [float(item) for item in items]
            for index, item in enumerate(values):
                if not math.isfinite(item):
                    raise ConfigError(name, f'expected finite numbers, entry {index} is '
                                      f'{item}')
                if self.entry_limit is not None and abs(item) > self.entry_limit:
                    raise ConfigError(name, f'expected entries of magnitude <= '
                                      f'{number_text(self.entry_limit)}, entry {index} is '
                                      f'{number_text(item)}')
            return values
        return [item if isinstance(item, str) else str(item) for item in items]

    def convert(self, value: Any) -> Any:
        """
        Return ``value`` checked and converted, once, into the type the argument's user takes.

        Without ``parse``, what :meth:`coerce` returns. With it (a string list whose entries
        may be numbers, such as poles), the entries as given, numbers as numbers and texts
        as texts, are handed to ``parse``: a number never becomes a text on the way.

        Raises
        ------
        ConfigError
            Naming the argument, as :meth:`coerce` and ``parse`` do.

        """
        if self.parse is None:
            return self.coerce(value)
        if value is None:
            value = self.default
        if isinstance(value, (str, bytes)) or not hasattr(value, '__iter__'):
            raise ConfigError(self.name, f'expected a list, got {value!r}')
        return self.parse(list(value), self.name)


def seconds(name: str, default: float, description: str, low: float, high: float,
            tunable: bool = False, low_open: bool = False) -> Argument:
    """Return a ``double`` argument in seconds, with its range."""
    return Argument(name, DOUBLE, default, description, tunable, low=low, high=high,
                    low_open=low_open, unit='seconds')


def array(name: str, description: str, tunable: bool = False,
          limit: float = ENTRY_LIMIT) -> Argument:
    """Return a ``double_array`` argument (empty by default) whose entries are bounded."""
    return Argument(name, DOUBLE_ARRAY, [], description, tunable, entry_limit=limit)


def matrix_text(text: str) -> str:
    """Append the row-major layout to a matrix argument's description."""
    return f'{text}, flat row-major (row after row).'


__all__ = ['Argument', 'BOOL', 'DOUBLE', 'DOUBLE_ARRAY', 'ENTRY_LIMIT', 'INTEGER', 'SEED_MAX',
           'STRING', 'STRING_ARRAY', 'array', 'matrix_text', 'number_text', 'seconds']
