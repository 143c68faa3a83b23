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
What an estimator makes for each sample interval, made once per (rounded) interval.

Both runtime engines work per interval: the constant-gain estimator designs a step matrix,
the time-varying Kalman filter samples the model. :class:`IntervalCache` keeps what was made,
keyed by the interval in integer nanoseconds (rounded to ``resolution_ns`` when set), and
remembers the last few distinct intervals stepped over; :class:`IntervalDesigns` gives an
estimator the members that follow from it (``interval_resolution_ns``,
:meth:`~IntervalDesigns.recent_intervals`, :meth:`~IntervalDesigns.try_intervals`).
"""

from collections import OrderedDict
from typing import Any, Callable, Optional

from observer_ros.core.errors import ConfigError

#: Number of distinct sample intervals whose designs are kept.
DEFAULT_CACHE_SIZE = 256

#: Distinct recent intervals remembered for :meth:`IntervalCache.recent`.
RECENT_INTERVALS = 4


def rounded_interval(dt_ns: int, resolution_ns: int) -> int:
    """Return ``dt_ns`` rounded to the nearest multiple of ``resolution_ns`` (> 0), >= one."""
    return max(1, (dt_ns + resolution_ns // 2) // resolution_ns) * resolution_ns


class IntervalCache:
    """
    Values made per sample interval by ``make(key_ns)``, least recently used dropped.

    Parameters
    ----------
    make : callable
        ``make(interval_ns)``: what the interval needs (step matrices, a sampled model).
    size : int
        Distinct intervals kept.
    resolution_ns : int
        Round intervals to multiples of this before making or looking up (0: exact).
    constant : bool
        Every interval is the same (a discrete model): one key, 0.

    Attributes
    ----------
    last_dt_ns, last : int or None, object
        The interval (as asked, before rounding) of the last :meth:`get` and its value: a
        caller on a hot path compares ``last_dt_ns`` itself before calling :meth:`get`.

    Examples
    --------
    >>> cache = IntervalCache(lambda dt: dt / 1e9, resolution_ns=1000)
    >>> cache.get(10_400), cache.get(9_600), cache.recent()
    (1e-05, 1e-05, [10000])

    """

    def __init__(self, make: Callable[[int], Any], size: int = DEFAULT_CACHE_SIZE,
                 resolution_ns: int = 0, constant: bool = False) -> None:
        self.make = make
        self.size = size
        self.constant = constant
        self._values: OrderedDict = OrderedDict()
        self._recent: OrderedDict = OrderedDict()
        self._resolution_ns = 0
        self.last_dt_ns: Optional[int] = None
        self.last: Any = None
        self.resolution_ns = resolution_ns

    @property
    def resolution_ns(self) -> int:
        """Intervals are rounded to multiples of this before they are made (0: exact)."""
        return self._resolution_ns

    @resolution_ns.setter
    def resolution_ns(self, value: int) -> None:
        value = int(value)
        if value < 0:
            raise ConfigError('interval_resolution_ns', f'expected >= 0, got {value}')
        if value != self._resolution_ns:
            self._resolution_ns = value
            self.clear()

    def key(self, dt_ns: int) -> int:
        """Return the key an interval is made for (rounded; 0 when every one is the same)."""
        if self.constant:
            return 0
        if self._resolution_ns:
            return rounded_interval(dt_ns, self._resolution_ns)
        return dt_ns

    def get(self, dt_ns: int) -> Any:
        """Return the value of an interval (made now if new); it counts as recent."""
        if dt_ns == self.last_dt_ns:
            return self.last
        key = self.key(dt_ns)
        value = self._lookup(key)
        recent = self._recent
        recent[key] = None
        recent.move_to_end(key)
        if len(recent) > RECENT_INTERVALS:
            recent.popitem(last=False)
        self.last_dt_ns, self.last = dt_ns, value
        return value

    def peek(self, dt_ns: int) -> Any:
        """Return the value of an interval (made now if new) without counting it as recent."""
        return self._lookup(self.key(dt_ns))

    def __contains__(self, dt_ns: int) -> bool:
        """Whether the value of an interval is made already (a lookup would not make it)."""
        return self.key(dt_ns) in self._values

    def _lookup(self, key: int) -> Any:
        values = self._values
        value = values.get(key)
        if value is None:
            value = self.make(key)
            values[key] = value
            if len(values) > self.size:
                values.popitem(last=False)
        else:
            values.move_to_end(key)
        return value

    def recent(self) -> list:
        """Return the last few distinct intervals (ns, as made) stepped over, newest first."""
        return list(self._recent)[::-1]

    def clear(self, recent: bool = True) -> None:
        """Forget every value made (a new design); ``recent``: the recent intervals too."""
        self._values.clear()
        if recent:
            self._recent.clear()
        self.last_dt_ns = self.last = None


class IntervalDesigns:
    """
    The members of an estimator that makes something per interval (a mixin).

    The estimator keeps its :class:`IntervalCache` in ``intervals`` and may override
    :meth:`_forget_intervals` to drop what it derived from the old values.
    """

    intervals: IntervalCache

    @property
    def interval_resolution_ns(self) -> int:
        """Intervals are rounded to multiples of this before they are designed (0: exact)."""
        return self.intervals.resolution_ns

    @interval_resolution_ns.setter
    def interval_resolution_ns(self, value: int) -> None:
        before = self.intervals.resolution_ns
        self.intervals.resolution_ns = value  # checked; a change clears the cache
        if self.intervals.resolution_ns != before:
            self._forget_intervals()

    def _forget_intervals(self) -> None:
        """Drop what was derived from the intervals' values (default: nothing)."""

    def recent_intervals(self) -> list:
        """
        Return the last few distinct intervals (ns, rounded as designed) stepped over.

        Kept across a new design, so a caller can check that the new design can be sampled
        at the intervals in use before switching to it.
        """
        return self.intervals.recent()

    def try_intervals(self, intervals_ns) -> None:
        """Make the design of each interval (ns) now; raise what a sample would raise."""
        for dt_ns in intervals_ns:
            self.intervals.get(int(dt_ns))
