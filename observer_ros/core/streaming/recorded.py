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

"""Recordings through a stream: whole recorded streams at once, or message by message."""

from typing import NamedTuple, Optional

import numpy as np

from observer_ros.core.estimates import replay_arrays, ReplayArrays
from observer_ros.core.events import INPUT
from observer_ros.core.rules import in_sequence, rows_within


class RecordedEvent(NamedTuple):
    """
    One recorded message, for :meth:`EventStream.replay_events`.

    ``source`` is ``'u'`` for an input or a measurement source's name; ``arrival_ns`` its
    arrival (log) time, the receiver's clock of the clock rule (0: no clock check).
    """

    source: str
    stamp_ns: int
    values: object
    arrival_ns: int = 0


def next_measurement_stamps(input_arrivals, measurement_arrivals,
                            measurement_stamps) -> tuple:
    """
    Stamp unstamped inputs as :meth:`EventStream.hold_input` does, for a recording.

    Each input is applied from the first measurement that arrives at or after it and is
    stamped with that measurement's stamp; of several inputs held for one measurement the
    last replaces the others, and an input after the last measurement is never applied.
    (``hold_input``'s other case, an input arriving when the receiver's clock equals the
    latest measurement's stamp, needs that clock, which a recording does not keep.)

    Parameters
    ----------
    input_arrivals : array_like of int, shape (k,)
        Arrival (log) order of the inputs, nondecreasing.
    measurement_arrivals : array_like of int, shape (m,)
        Arrival order of the measurements, nondecreasing, comparable with the inputs'.
    measurement_stamps : array_like of int, shape (m,)

    Returns
    -------
    kept : numpy.ndarray of int
        Indices of the inputs that are applied, in order.
    stamps : numpy.ndarray of int
        Their stamps.

    Examples
    --------
    >>> from observer_ros.core.streaming import next_measurement_stamps
    >>> next_measurement_stamps([5, 12, 13, 40], [10, 20, 30], [100, 200, 300])
    (array([0, 2]), array([100, 200]))

    """
    at = np.searchsorted(np.asarray(measurement_arrivals), np.asarray(input_arrivals),
                         side='left')
    last = np.append(at[1:] != at[:-1], True) if len(at) else np.zeros(0, dtype=bool)
    kept = np.flatnonzero(last & (at < len(measurement_stamps)))
    return kept, np.asarray(measurement_stamps, dtype=np.int64)[at[kept]]


class RecordedReplay:
    """The stream's replay of recordings (bags), through the engine's rules."""

    def replay(self, input_stamps, inputs, stamps, outputs, input_arrivals=None,
               arrivals=None) -> ReplayArrays:
        """
        Run over whole recorded streams at once, as if every input had arrived in time.

        Gives what the node computes from the same messages when no input arrives later than
        the measurement after it (a recording played back): the engine's rules, so the
        estimates are equal bit for bit. Rows with a non-finite value are dropped and
        counted as ``malformed``, rows beyond the :class:`ValueLimits` as ``out_of_range``,
        and, with arrival times and a clock tolerance, rows stamped too far ahead of their
        arrival as ``future_stamp`` (the arrival time plays the receiver's clock).

        Parameters
        ----------
        input_stamps : array_like of int, shape (k,)
            Input stamps in arrival order (equal stamps: the later one wins, as live).
        inputs : array_like, shape (k, m)
        stamps : array_like of int, shape (samples,)
            Measurement stamps in arrival order.
        outputs : array_like, shape (samples, p)
        input_arrivals, arrivals : array_like of int, optional
            Arrival (log) times. A recording with a backward jump (a looping bag) is then
            fed message by message in arrival order, as live; without them it is refused.

        Returns
        -------
        ReplayArrays

        Raises
        ------
        ValueError
            Lengths differ, or a backward jump without arrival times.

        """
        estimator, engine = self.estimator, self.engine
        n_outputs, n_inputs = estimator.n_outputs, estimator.n_inputs
        if engine.keeps_history:
            return self._replay_history(input_stamps, inputs, stamps, outputs, input_arrivals,
                                        arrivals)
        outputs = np.ascontiguousarray(outputs, dtype=float).reshape(-1, n_outputs)
        stamps = np.asarray(stamps, dtype=np.int64)
        input_stamps = np.asarray(input_stamps, dtype=np.int64)
        inputs = (np.ascontiguousarray(inputs, dtype=float).reshape(-1, n_inputs) if n_inputs
                  else np.zeros((len(input_stamps), 0)))  # m = 0: rows of nothing
        if len(stamps) != len(outputs) or len(input_stamps) != len(inputs):
            raise ValueError('replay: stamps and values differ in length')
        good_inputs, input_drops = engine.recorded_rows(inputs, input_stamps, input_arrivals,
                                                        self.limits.input)
        good, drops = engine.recorded_rows(outputs, stamps, arrivals, self.limits.measurement)
        jump = -engine.max_gap_ns
        looping = ((np.diff(stamps[good]) < jump).any()
                   or (np.diff(input_stamps[good_inputs]) < jump).any())
        if looping:
            if arrivals is None or input_arrivals is None:
                raise ValueError('replay: the stamps jump backwards (a looping recording); '
                                 'give the arrival times to replay it message by message')
            samples = engine.feed_in_arrival_order(input_stamps, inputs, stamps, outputs,
                                                   input_arrivals, arrivals)
            return replay_arrays(samples, estimator.n_states, n_outputs)
        counters = self.counters
        for key in drops:  # every kind named, zero included: replay reports them all
            counters[key] += input_drops[key] + drops[key]
        counters['inputs'] += len(input_stamps)
        counters['measurements'] += int((~good).sum())  # the dropped ones, as live
        engine.store_recorded_inputs(input_stamps[good_inputs], inputs[good_inputs])
        measured = stamps[good]
        if (self._fast and estimator.stamp_ns is None and len(measured)
                and in_sequence(np.diff(measured), engine.max_gap_ns).all()):
            steady = self._replay_steady(measured, outputs[good])
            if steady is not None:
                return steady
        samples = engine.process_recorded(measured, outputs[good])
        return replay_arrays(samples, estimator.n_states, n_outputs)

    def replay_events(self, events, causes: Optional[list] = None) -> list:
        """
        Feed recorded messages in the order given (a bag's), as live, then flush.

        The way to replay several measurement sources: each :class:`RecordedEvent` goes to
        :meth:`add_input` or :meth:`add_measurement` with its arrival time as the
        receiver's clock, so the estimates equal those of the live stream fed the same
        messages in the same order, bit for bit.

        Parameters
        ----------
        events : iterable of RecordedEvent
        causes : list, optional
            Extended with the event that returned each estimate (None: the final flush).

        Returns
        -------
        list of EstimateSample
            What the stream returned, in order (corrected ones included).

        """
        samples: list = []
        for event in events:
            source, stamp, values, arrival = event
            now = int(arrival) or None
            if source == INPUT:
                produced = self.add_input(stamp, values, now)
            else:
                produced = self.add_measurement(stamp, values, now, int(arrival), source)
            samples += produced
            if causes is not None:
                causes += [event] * len(produced)
        produced = self.flush()
        if causes is not None:
            causes += [None] * len(produced)
        return samples + produced

    def _replay_history(self, input_stamps, inputs, stamps, outputs, input_arrivals,
                        arrivals) -> ReplayArrays:
        """:meth:`replay` with a history: message by message, in arrival order when given."""
        engine, estimator = self.engine, self.estimator
        if len(engine.measurement_sources) > 1:
            raise ValueError('replay: several measurement sources; give the recording to '
                             'replay_events, message by message')
        name = engine.measurement_sources[0].name
        n_inputs = estimator.n_inputs
        outputs = np.ascontiguousarray(outputs, dtype=float).reshape(-1, estimator.n_outputs)
        inputs = (np.ascontiguousarray(inputs, dtype=float).reshape(-1, n_inputs) if n_inputs
                  else np.zeros((len(input_stamps), 0)))
        input_stamps = np.asarray(input_stamps, dtype=np.int64)
        stamps = np.asarray(stamps, dtype=np.int64)
        if len(stamps) != len(outputs) or len(input_stamps) != len(inputs):
            raise ValueError('replay: stamps and values differ in length')
        if arrivals is not None and input_arrivals is not None:
            order = sorted(
                [(int(t), 0, k) for k, t in enumerate(np.asarray(input_arrivals).tolist())]
                + [(int(t), 1, k) for k, t in enumerate(np.asarray(arrivals).tolist())])
            events = [RecordedEvent(INPUT, int(input_stamps[k]), inputs[k], t) if kind == 0
                      else RecordedEvent(name, int(stamps[k]), outputs[k], t)
                      for t, kind, k in order]
            return replay_arrays(self.replay_events(events), estimator.n_states,
                                 estimator.n_outputs)
        good, drops = engine.recorded_rows(inputs, input_stamps, None, self.limits.input)
        counters = self.counters
        counters.update(drops)
        counters['inputs'] += len(input_stamps)
        engine.store_recorded_inputs(input_stamps[good], inputs[good])
        samples = self.replay_events(RecordedEvent(name, stamp, y)
                                     for stamp, y in zip(stamps.tolist(), outputs))
        return replay_arrays(samples, estimator.n_states, estimator.n_outputs)

    def _replay_steady(self, stamps, outputs) -> Optional[ReplayArrays]:
        """
        Run measurements that all follow each other within the gap through the batch path.

        Every measurement is admitted, so each interval's input is known in advance
        (:meth:`EventEngine.steady_rows`). None (estimator untouched) when an estimate
        leaves its limit: the caller then takes the general path, which restarts the
        estimator there. Kept as it was: a constant-gain Kalman filter's covariance rows are
        the steady ``P`` for every row, where the general path has none at the first sample
        (so its arrays have none at all).
        """
        estimator = self.estimator
        count = len(stamps)
        rows = self.engine.steady_rows(stamps)
        saved = estimator.snapshot()
        estimates, innovations = estimator.advance_many(stamps, outputs, rows.held)
        limits = self.limits
        if not (rows_within(estimates, limits.estimate)[1].all()
                and rows_within(innovations, limits.innovation)[1].all()):
            estimator.restore(saved)
            return None
        counters = self.counters
        counters.update(rows.counts)
        counters['measurements'] += count
        counters['estimates'] += count
        covariance = estimator.covariance
        s = estimator.innovation_covariance
        arrays = ReplayArrays(
            stamps.copy(), np.ascontiguousarray(estimates), np.ascontiguousarray(innovations),
            None if covariance is None else np.broadcast_to(covariance, (count,)
                                                            + covariance.shape),
            None if s is None else np.broadcast_to(s, (count,) + s.shape),
            None if s is None else np.einsum('ki,ij,kj->k', innovations, np.linalg.inv(s),
                                             innovations))
        if self.form == 'delayed':
            counters.update(rows.following_counts)
            arrays = self._delayed_rows(arrays, stamps, rows.following)
        return arrays

    def _delayed_rows(self, arrays: ReplayArrays, stamps, following) -> ReplayArrays:
        """Return batch rows in the delayed form, each predicted as :meth:`_delayed` does."""
        estimator = self.estimator
        intervals = np.concatenate([[0], np.diff(stamps)]).tolist()
        estimates = np.empty_like(arrays.estimates)
        covariances = None if arrays.covariances is None else np.empty(arrays.covariances.shape)
        for k, (x, interval) in enumerate(zip(arrays.estimates, intervals)):
            covariance = None if covariances is None else arrays.covariances[k]
            predicted = estimator.prediction(x, covariance, int(interval), following[k])
            estimates[k] = predicted.estimate
            if covariances is not None:
                covariances[k] = predicted.covariance
        return ReplayArrays(arrays.stamps_ns, estimates, arrays.innovations, covariances,
                            arrays.innovation_covariances, arrays.nis)
