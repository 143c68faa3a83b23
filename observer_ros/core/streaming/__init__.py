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
An estimator run on stamped measurement and input events: the stream of the node and replay.

:class:`EventStream` drives an :class:`~observer_ros.core.estimators.Estimator` with the
rows of an :class:`~observer_ros.core.events.EventEngine`, where the value, clock, stamp and
pairing rules are written once; the observer node (event by event) and the offline bag
replay (:meth:`EventStream.replay`, a whole recording) both run it, so they give identical
estimates. The stream adds what concerns the estimates: an estimate or innovation beyond
its :class:`ValueLimits` is never returned (the estimator restarts from its initial state
instead), and the ``delayed`` form.

Bad stamps never crash and never produce NaN: duplicates and small backward steps are
dropped and counted; a backward jump or a gap longer than ``max_gap_ns`` restarts the
estimator from the new sample; a sample stamped further ahead of the receiver's clock than
``clock_tolerance_ns`` is dropped. Values that are not finite or exceed the limits are
dropped and counted.

Several measurement sources at their own rates, and late measurements: given
``sources`` (:class:`~observer_ros.core.sources.MeasurementSource`) and a ``history_ns``, the
engine keeps a history and the stream updates the estimator with the outputs that arrived
(:class:`~observer_ros.core.estimators.SubsetUpdates`, asked by capability; an estimator
without it takes one source only). A measurement older than the newest one but inside the
history is inserted in stamp order and the estimates after it computed again; what it
returns is the corrected newest estimate, at the newest stamp, marked ``corrected``
(:class:`~observer_ros.core.estimates.SourceSample`). Samples of two sources with one stamp
make one update with the outputs of both. See :mod:`observer_ros.core.events`.

A model with a feedthrough ``D`` (:attr:`~observer_ros.core.estimators.Estimator.feedthrough`)
measures ``y = C x + D u``: the stream takes ``D u`` off each measurement with the input in
effect at the measurement's stamp, the engine's pairing rule applied at that stamp (the
latest input stamped at or before it: ``EventEngine.held_input``), while the prediction
over the interval keeps the input of the interval. A measurement waits for an input stamped
at or after its own stamp, as it waits for the input of its interval (a flush takes the
latest one at hand), so the live stream and a replay give the same estimates; with a
history a late input re-runs the rows it changes. The input is then the one applied at that
sample, stamped with it (what the plant simulator publishes on ``u``, before ``y``), not a
command computed from the estimate. The fast paths are off with a feedthrough.

When the estimator offers :class:`~observer_ros.core.estimators.SteadySteps`, the stream
takes those fast paths where they apply (a prepared steady one-output step, a batch over a
recording whose stamps all follow on): a private optimisation, equal bit for bit to the
general path (``fast_paths=False`` turns it off; the tests hold the two equal). They are
off while the stream keeps a history.
"""

from observer_ros.core.estimates import (
    EstimateSample, replay_arrays, ReplayArrays, SourceSample)
from observer_ros.core.rules import ValueLimits
from observer_ros.core.streaming.recorded import next_measurement_stamps, RecordedEvent
from observer_ros.core.streaming.stream import EventStream

__all__ = ['EstimateSample', 'EventStream', 'RecordedEvent', 'ReplayArrays', 'SourceSample',
           'ValueLimits', 'next_measurement_stamps', 'replay_arrays']
