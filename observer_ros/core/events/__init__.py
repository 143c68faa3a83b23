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
Stamped events to rows: the value, clock, stamp and pairing rules, each written once.

An event is one sample of a source: a measurement source (today one, ``y``, carrying every
output of the model) or an input source (today one, ``u``). :class:`EventEngine` turns the
events into :class:`Row` s ``(stamp, y, u, interval)`` for whatever consumes them (the
:class:`~observer_ros.core.streaming.EventStream` runs an estimator on each), and counts
every event it drops:

* on arrival, :meth:`EventEngine.accept` applies the value rules (the source's size, finite,
  within the :class:`~observer_ros.core.rules.ValueLimits`) and the clock rule (see
  :mod:`observer_ros.core.rules`);
* inputs are kept in stamp order (:class:`~observer_ros.core.rules.InputHistory`);
  measurements wait in one queue (:meth:`EventEngine._enqueue`, the one ordering rule:
  arrival order);
* :meth:`EventEngine.process`, the one processing routine, takes the queue in order and
  applies the stamp rules (:meth:`EventEngine._admit`: a repeated stamp or a small step back
  is dropped, a gap or a backward jump longer than ``max_gap_ns`` starts again) and the
  pairing rule: the input of the interval ending at measurement ``k`` is the latest one
  stamped at or before measurement ``k-1`` (``InputHistory.index_at``), so a future
  input never leaks into the past; a measurement whose input may still be on its way waits
  until an input stamped at or after the previous measurement arrives, or a flush. With a
  feedthrough (:attr:`EventEngine.pairs_at_stamp`) the consumer also needs the input in
  effect at the measurement's own stamp (the same rule at that stamp), so the measurement
  waits for an input stamped at or after it.

Several measurement sources and late measurements (the history). Each
:class:`~observer_ros.core.sources.MeasurementSource` names the outputs it carries; its
samples are rows with those ``outputs`` (``None``: every output). With several sources, or a
``history_ns`` above 0, the engine keeps a history (robot_localization's
``smooth_lagged_data``): every measurement processed in the last ``history_ns`` with the
consumer's state before it (:class:`HistoryEntry`), and the inputs it needs. Then the queue
is in stamp order (:meth:`EventEngine._enqueue`), and a measurement older than the newest
processed one (the ``out_of_order`` branch of :meth:`EventEngine._admit`) is no longer
dropped: the history's re-run (``History._rerun``) inserts it in stamp order (or fuses it
with the measurement of another source at the same stamp: one update with the outputs of both),
returns the consumer to its state before it and runs the rows after it again with their
inputs. What a re-run returns is what the newest row gives: the corrected newest estimate,
at the newest stamp (a row with ``rerun`` set). A measurement older than the history is
dropped and counted (``too_old``; ``out_of_order`` with a history of 0), as is one from a
source whose sample at that stamp is already in the history (``duplicate``). A source's
fixed latency moves its stamps back by it and takes the same path. With one source and no
history no history is kept, a late measurement is dropped (``out_of_order``), and the queue
is in arrival order, with one exception, the history's rule kept for one row: a measurement
stamped more than :data:`JUMP_FACTOR` times the interval before it ahead of the previous one
(an early-stamped outlier, or a real gap) is taken with the consumer's state before it kept
(``NewestRollback.take``); a measurement stamped between the previous one and it is then
inserted before it (``NewestRollback._insert_before_newest``): the consumer returns to that
state, takes the late measurement, then the newest again, and what it returns is the
corrected newest estimate, at the newest stamp, as with a history. So one early outlier never
silences the genuine samples after it; once their stamps pass it they follow on again.

The two ways (a history, or the one row kept) are two parts with the same verbs,
:class:`~observer_ros.core.events.history.History` and
:class:`~observer_ros.core.events.rollback.NewestRollback`; the engine chooses one when it
is made (:attr:`EventEngine.timeline`) and asks it, never which way it runs, on each event.
The other jobs are modules of their own: the value, clock and stamp rules
(:mod:`~observer_ros.core.events.admission`), the pairing rule
(:mod:`~observer_ros.core.events.inputs`), recordings (:mod:`~observer_ros.core.events.replay`)
and the records (:mod:`~observer_ros.core.events.records`).
"""

from observer_ros.core.events.engine import EventEngine
from observer_ros.core.events.records import (
    Event, HistoryEntry, INPUT, MEASUREMENT, PREDICTION, Row, RowCollector, Source, SourceStatus,
    SteadyRows)
from observer_ros.core.rules import (
    ahead_of_clock, in_sequence, InputHistory, rows_within, ValueLimits, within_limit)
from observer_ros.core.sources import MeasurementSource

__all__ = ['Event', 'EventEngine', 'HistoryEntry', 'INPUT', 'InputHistory', 'MEASUREMENT',
           'MeasurementSource', 'PREDICTION', 'Row', 'RowCollector', 'Source', 'SourceStatus',
           'SteadyRows', 'ValueLimits', 'ahead_of_clock', 'in_sequence', 'rows_within',
           'within_limit']
