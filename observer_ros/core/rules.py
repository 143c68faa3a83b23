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
The rules every sample of a stream meets, each written once, and the input history.

The value rule (:func:`rows_within`, :func:`within_limit`: finite, within a
:class:`ValueLimits` limit), the clock rule (:func:`ahead_of_clock`), the stamp rule of a
sample that follows on (:func:`in_sequence`), and :class:`InputHistory`, whose
:meth:`~InputHistory.index_at` is the pairing rule's lookup (the latest input stamped at or
before a stamp). Each works on one sample as on arrays of them, so the live path and the
batch replay apply the same rule. :mod:`observer_ros.core.events` applies them.
"""

import bisect
from dataclasses import dataclass
import math
from typing import Optional

import numpy as np

#: Inputs kept at most (older ones are dropped once no interval can need them).
MAX_INPUTS = 10_000


@dataclass(frozen=True)
class ValueLimits:
    """
    Largest magnitudes a stream accepts (measurements, inputs) and returns (estimates).

    ``math.inf`` (the default) sets no limit; non-finite values are refused regardless.

    Attributes
    ----------
    measurement, input, estimate, innovation : float

    Examples
    --------
    >>> ValueLimits(measurement=1e9).input
    inf

    """

    measurement: float = math.inf
    input: float = math.inf  # noqa: A003 (the role's name)
    estimate: float = math.inf
    innovation: float = math.inf


def rows_within(rows: np.ndarray, limit: float) -> tuple:
    """
    Return ``(finite, inside)`` of each row (the last axis): the value rule.

    A row is ``finite`` when every entry is, and ``inside`` when it is finite and no entry
    exceeds ``limit`` in magnitude. Works on one vector (two booleans) as on many rows.
    """
    finite = np.isfinite(rows).all(axis=-1)
    inside = finite & (np.abs(np.where(finite[..., None], rows, 0.0)).max(
        axis=-1, initial=0.0) <= limit)
    return finite, inside


#: Vectors up to this length are checked as lists of floats where the value rule is inline
#: on a hot path (their sum, minimum and maximum: faster than a dot product on a few values).
SHORT = 16


def within_limit(values, limit: float) -> bool:
    """
    Whether every entry of ``values`` (a vector, or one float) is finite and within ``limit``.

    The rule of :func:`rows_within`; one dot product decides the common case
    (``ndarray.dot``: a third of the ``@`` operator's cost on a short vector).
    """
    if isinstance(values, float):
        return math.isfinite(values) and -limit <= values <= limit
    square = values.dot(values)
    if square < math.inf and square <= limit * limit:  # limit * limit may overflow to inf
        return True
    return bool(rows_within(values, limit)[1])


def ahead_of_clock(stamps, nows, tolerance_ns: int):
    """
    Whether samples are stamped more than ``tolerance_ns`` ahead of the receiver's clock.

    ``nows`` (one reading or an array): the clock at arrival; a reading of 0 or None, or a
    tolerance of 0, checks nothing. Works on one stamp as on arrays.
    """
    if not tolerance_ns or nows is None:
        return False
    return (nows > 0) & (stamps - nows > tolerance_ns)


def in_sequence(steps, max_gap_ns: int):
    """Whether a stamp step follows on (after the previous, within the gap): the stamp rule."""
    return (steps > 0) & (steps <= max_gap_ns)


class InputHistory:
    """
    Inputs of one input source in stamp order (a repeated stamp replaces the earlier one).

    Examples
    --------
    >>> history = InputHistory()
    >>> history.store(10, 'a'); history.store(30, 'b')
    >>> history.index_at(29), history.index_at(30), history.index_at(5)
    (0, 1, -1)

    """

    def __init__(self) -> None:
        self.stamps: list = []
        self.values: list = []

    def __len__(self) -> int:
        return len(self.stamps)

    def index_at(self, stamp_ns: int) -> int:
        """Return the index of the latest input stamped at or before ``stamp_ns`` (-1: none)."""
        return bisect.bisect_right(self.stamps, stamp_ns) - 1

    def indices_at(self, stamps_ns: np.ndarray) -> np.ndarray:
        """:meth:`index_at` of many stamps at once."""
        return np.searchsorted(np.array(self.stamps, dtype=np.int64), stamps_ns,
                               side='right') - 1

    def store(self, stamp_ns: int, vector) -> None:
        """Keep an input in stamp order; a repeated stamp replaces the earlier input."""
        stamps = self.stamps
        if not stamps or stamp_ns > stamps[-1]:  # the usual case: the newest input
            stamps.append(stamp_ns)
            self.values.append(vector)
            return
        index = bisect.bisect_left(self.stamps, stamp_ns)
        if index < len(self.stamps) and self.stamps[index] == stamp_ns:
            self.values[index] = vector
        else:
            self.stamps.insert(index, stamp_ns)
            self.values.insert(index, vector)

    def store_many(self, stamps: np.ndarray, vectors: np.ndarray) -> None:
        """Store many inputs at once, as :meth:`store` one by one would."""
        if self.stamps:
            for stamp, vector in zip(stamps.tolist(), vectors):
                self.store(stamp, vector)
            return
        if not len(stamps):
            return
        order = np.argsort(stamps, kind='stable')
        ordered = stamps[order]
        last = np.append(ordered[1:] != ordered[:-1], True)  # of equal stamps the later wins
        self.stamps = ordered[last].tolist()
        self.values = list(vectors[order][last])

    def prune(self, previous: Optional[int]) -> None:
        """Drop inputs no interval after ``previous`` can need (and beyond the most kept)."""
        keep_from = len(self.stamps) - MAX_INPUTS
        if previous is not None:
            keep_from = max(keep_from, bisect.bisect_right(self.stamps, previous) - 1)
        if keep_from > 0:
            del self.stamps[:keep_from]
            del self.values[:keep_from]

    def drop_after(self, stamp_ns: int) -> None:
        """Forget the inputs stamped after ``stamp_ns`` (an abandoned timeline)."""
        keep = bisect.bisect_right(self.stamps, stamp_ns)
        del self.stamps[keep:]
        del self.values[keep:]
