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

"""The records of the event engine: its sources, events, rows, history entries and constants."""

from collections import Counter
from typing import Any, NamedTuple, Optional

import numpy as np

#: The one measurement source and the one input source of today's configurations.
MEASUREMENT, INPUT = 'y', 'u'

#: Source of a queued prediction: an estimate waiting for the input after it (delayed form).
PREDICTION = 'prediction'

#: What :meth:`EventEngine._admit` says of a measurement to insert through the history.
LATE = -1

#: Without a history, a row whose interval exceeds this many times the interval before it is
#: taken with the consumer's state before it kept, so that the measurements stamped before
#: it (it may be an early-stamped outlier) are inserted, not dropped (the module notes).
JUMP_FACTOR = 2


class Source(NamedTuple):
    """
    A source of events: its name, role, size and value limit.

    ``outputs`` (measurement sources): the model outputs it carries, in its order;
    ``sorted_outputs`` in ascending order, ``order`` the permutation that puts its values in
    that order (None: they are), ``latency_ns`` its fixed latency.
    """

    name: str
    role: str
    size: int
    limit: float
    what: str
    outputs: tuple = ()
    sorted_outputs: tuple = ()
    order: Optional[list] = None
    latency_ns: int = 0


class Event(NamedTuple):
    """A queued event: source, stamp, values, sequence number and arrival time."""

    source: str
    stamp_ns: int
    values: Any
    sequence: int
    arrival_ns: int


class Row(NamedTuple):
    """
    What a consumer runs: a measurement ``y`` at ``stamp_ns`` with the input ``u`` held.

    ``interval_ns`` is the step from the previous row, 0 where the estimate starts (the
    first row, or after a gap or a backward jump). A ``PREDICTION`` row carries, in ``y``,
    the estimate to predict over the next interval with ``u``. ``outputs``: the ascending
    output indices ``y`` holds (None: every output, in order); ``source`` names its
    source(s), joined by ``+`` when the samples of several sources at one stamp are fused.
    ``rerun``: the row is taken again after a late measurement (see ``History._rerun``).
    """

    source: str
    stamp_ns: int
    y: Any
    u: np.ndarray
    interval_ns: int
    arrival_ns: int
    outputs: Optional[tuple] = None
    rerun: bool = False


class HistoryEntry:
    """
    One processed stamp of the history: the samples taken there and what it gave.

    Attributes
    ----------
    stamp_ns : int
    parts : dict
        ``{source name: (values in ascending output order, arrival_ns)}``.
    state : object
        The consumer's state before the row (``consumer.save()``), to re-run from.
    result : object
        What the consumer's ``take`` gave last for the row (its last item, or None).
    """

    __slots__ = ('stamp_ns', 'parts', 'state', 'result')

    def __init__(self, stamp_ns: int, parts: dict) -> None:
        self.stamp_ns = stamp_ns
        self.parts = parts
        self.state = None
        self.result = None


class SourceStatus(NamedTuple):
    """
    What the engine knows of one measurement source (for its health).

    ``counts``: ``received``, ``used`` (taken in order or inserted), ``reruns`` (inserted
    late), and the drops by reason (``malformed``, ``out_of_range``, ``future_stamp``,
    ``duplicate``, ``too_old`` / ``out_of_order``); ``last_stamp_ns`` and
    ``last_arrival_ns`` of its last sample taken (None before one); ``age_ns`` the clock
    minus that stamp (None without a clock or a sample); ``stale`` when the age exceeds the
    source's timeout; ``max_lag_ns`` how far behind the newest stamp its latest insertion
    reached (the history depth it uses).
    """

    counts: Counter
    last_stamp_ns: Optional[int]
    last_arrival_ns: Optional[int]
    age_ns: Optional[int]
    stale: bool
    max_lag_ns: int


class RowCollector:
    """A consumer that keeps the rows (the engine alone: events in, rows out)."""

    def __init__(self) -> None:
        self.stamp_ns: Optional[int] = None
        self.rows: list = []

    def take(self, row: Row) -> list:
        """Keep ``row``; it is the last processed stamp now."""
        self.stamp_ns = row.stamp_ns
        self.rows.append(row)
        return [row]

    def save(self) -> Optional[int]:
        """Return the state to re-run from: the last processed stamp."""
        return self.stamp_ns

    def load(self, state: Optional[int]) -> None:
        """Return to a state of :meth:`save` (the rows taken are kept)."""
        self.stamp_ns = state


class SteadyRows(NamedTuple):
    """Rows of a recording whose stamps all follow on: the inputs of each interval."""

    held: np.ndarray
    following: np.ndarray
    counts: Counter
    following_counts: Counter
