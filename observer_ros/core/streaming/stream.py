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

"""The event stream: an estimator run on the rows of the event engine, event by event."""

from collections import Counter
from math import inf, isfinite
from typing import Optional, Sequence

import numpy as np
from numpy import ndarray

from observer_ros.core.estimates import EstimateSample, SourceSample
from observer_ros.core.estimators import (
    Estimator, Prediction, SteadySteps, without_feedthrough)
from observer_ros.core.events import EventEngine, INPUT, MEASUREMENT, PREDICTION
from observer_ros.core.rules import SHORT, ValueLimits, within_limit
from observer_ros.core.sources import MeasurementSource
from observer_ros.core.streaming.recorded import RecordedReplay
from observer_ros.core.streaming.sources import SourceUpdates
from observer_ros.core.streaming.steady import SteadyPath

__all__ = ['EventStream', 'NO_VALUES']

#: The values of an update with no output (a predict-only source).
NO_VALUES = np.zeros(0)


class EventStream(SourceUpdates, SteadyPath, RecordedReplay):
    """
    Run an estimator on stamped inputs and measurements, paired by the event engine.

    Parameters
    ----------
    estimator : Estimator
    max_gap_ns : int
        A forward gap or backward jump longer than this restarts the estimator.
    input_stamped : bool
        False when inputs are stamped on arrival (unstamped messages): then no measurement
        waits for a later input.
    clock_tolerance_ns : int
        A sample stamped more than this ahead of the ``now_ns`` given with it is dropped
        (``future_stamp``); 0 turns the check off.
    limits : ValueLimits, optional
        Magnitude limits of the values (none by default).
    form : {'current', 'delayed'}
        ``current``: each measurement gives ``x[k|k]``. ``delayed``: it gives the prediction
        ``x[k+1|k]`` over the last interval with the input of the next one, once that input
        is known (it waits for it like a measurement), stamped with the measurement.
    fast_paths : bool
        Take the estimator's :class:`~observer_ros.core.estimators.SteadySteps` where they
        apply (the same numbers and counts; False: the general path only).
    sources : sequence of MeasurementSource, optional
        The measurement sources (default: one, ``y``, with every output). Several need an
        estimator with :class:`~observer_ros.core.estimators.SubsetUpdates`; each source
        alone is checked at once (:func:`~observer_ros.core.sources.check_subsets`).
    history_ns : int
        How far back (ns) a late measurement is inserted in stamp order and the estimates
        after it computed again; older ones are dropped (``too_old``). With several
        sources or a history the form must be ``current``.
    output_names : sequence of str, optional
        Names of the outputs, for the messages about sources (``y1``... otherwise).

    Attributes
    ----------
    engine : EventEngine
        The events and their rules (its ``consumer`` is this stream).
    counters : collections.Counter
        The engine's (``measurements``, ``duplicate``, ``out_of_order``, ``restart_gap``,
        ``restart_backward_jump``, ``no_input``, ``late_input``, ``inputs``, ``malformed``,
        ``out_of_range``, ``future_stamp``) and ``estimates``; ``estimate_reset`` counts
        estimates beyond their limit (not returned; the estimator restarted); with a history
        the engine's ``reruns``, ``rerun_rows``, ``too_old`` and ``corrected`` (the
        corrected estimates returned, besides ``estimates``); ``nonfinite``: the
        estimator's steps dropped as not finite (a nonlinear filter's own count).
    events : list of (str, str)
        ``(kind, text)`` of notable events since the caller last cleared it.

    Examples
    --------
    >>> from observer_ros.core import design_full_order, make_estimator, StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> stream = EventStream(make_estimator(design_full_order(model, poles=[-4, -5])),
    ...                      max_gap_ns=10 ** 9)
    >>> [s.stamp_ns for s in stream.add_input(0, [0.0]) + stream.add_measurement(0, [1.0])]
    [0]
    >>> [s.stamp_ns for s in stream.add_measurement(10_000_000, [1.0])]  # input of 0 held
    [10000000]
    >>> stream.add_measurement(20_000_000, [1.0])  # waits: the input of 10 ms may come
    []
    >>> [s.stamp_ns for s in stream.add_input(10_000_000, [0.5])]
    [20000000]

    """

    def __init__(self, estimator: Estimator, max_gap_ns: int, input_stamped: bool = True,
                 clock_tolerance_ns: int = 0, limits: Optional[ValueLimits] = None,
                 form: str = 'current', fast_paths: bool = True,
                 sources: Optional[Sequence[MeasurementSource]] = None,
                 history_ns: int = 0, output_names: Optional[Sequence[str]] = None) -> None:
        if form not in ('current', 'delayed'):
            raise ValueError(f"form: expected 'current' or 'delayed', got {form!r}")
        self.estimator = estimator
        self.limits = limits or ValueLimits()
        self.form = form
        self.engine = EventEngine(estimator.n_outputs, estimator.n_inputs, max_gap_ns,
                                  input_stamped, clock_tolerance_ns, self.limits,
                                  consumer=self, sources=sources, history_ns=history_ns,
                                  output_names=output_names)
        self.engine.pairs_at_stamp = estimator.feedthrough is not None
        self._updates: dict = {}  # outputs of a row -> outputs to update with
        self._owners: dict = {}  # output index -> its source
        if self.engine.keeps_history:
            self._check_sources(self.engine.measurement_sources, output_names)
        self._fast = (fast_paths and isinstance(estimator, SteadySteps)
                      and not self.engine.keeps_history and estimator.feedthrough is None)
        self._result_limit = min(self.limits.estimate, self.limits.innovation)
        #: The estimator's NIS is the protocol's (from the innovation and S, as a sample
        #: computes it when read): left to the sample, off the path to the estimate.
        self._lazy_nis = type(estimator).nis is Estimator.nis
        self._steady = 0  # steady measurements not yet added to the counters
        self._steady_key: Optional[tuple] = None
        #: The estimator's stamp when :meth:`prepare` last prepared a step (None: it did not).
        self._prepared_at: Optional[int] = None
        self._held_input: Optional[tuple] = None  # (u, now_ns) of hold_input
        self._last_measurement_ns: Optional[int] = None  # stamp of the latest measurement

    # --- what the engine and the callers read --------------------------------------------

    @property
    def stamp_ns(self) -> Optional[int]:
        """Stamp of the last measurement the estimator took (the engine's previous one)."""
        return self.estimator.stamp_ns

    @property
    def counters(self) -> Counter:
        """Return the counts of the class description, up to date."""
        counters = self.engine.counters
        dropped = getattr(self.estimator, 'counters', {}).get('nonfinite')
        if dropped:  # the estimator's steps dropped as not finite (a nonlinear filter)
            counters['nonfinite'] = dropped
        if self._steady:
            counters['measurements'] += self._steady
            counters['estimates'] += self._steady
            self._steady = 0
        return counters

    @property
    def events(self) -> list:
        """``(kind, text)`` of notable events since the caller last cleared the list."""
        return self.engine.events

    @property
    def max_gap_ns(self) -> int:
        """A forward gap or backward jump longer than this restarts the estimator."""
        return self.engine.max_gap_ns

    @property
    def clock_tolerance_ns(self) -> int:
        """Samples stamped further ahead of the clock than this are dropped (0: no check)."""
        return self.engine.clock_tolerance_ns

    @clock_tolerance_ns.setter
    def clock_tolerance_ns(self, value: int) -> None:
        self.engine.clock_tolerance_ns = int(value)

    @property
    def input_stamped(self) -> bool:
        """False when inputs are stamped on arrival (no measurement waits for a later one)."""
        return self.engine.input_stamped

    @input_stamped.setter
    def input_stamped(self, value: bool) -> None:
        self.engine.input_stamped = bool(value)

    @property
    def pending(self) -> int:
        """Number of measurements (and delayed estimates) waiting for their input."""
        return len(self.engine.queue)

    def waiting(self) -> Optional[tuple]:
        """
        ``(sequence, arrival_ns)`` of the first sample waiting for its input, or None.

        The sequence number tells one waiting sample from the next; ``arrival_ns`` is what
        was given to :meth:`add_measurement`.
        """
        return self.engine.waiting()

    def reset(self, keep_inputs: bool = True) -> None:
        """
        Restart the estimator from its initial state; the history is forgotten.

        ``keep_inputs``: the inputs are kept (``~/reset`` in a running loop: the input of the
        next interval is already here). False forgets them too, and an input held for the
        next measurement (:meth:`hold_input`): a lifecycle deactivation, after which the
        old inputs, seconds older than the next measurement, would be paired with it.
        """
        self.estimator.reset()
        self.engine.queue.clear()
        self.engine.clear_history()
        self._prepared_at = None
        if not keep_inputs:
            self.engine.clear_inputs()
            self._held_input = self._last_measurement_ns = None
            self._steady_key = None

    def source_report(self, now_ns: Optional[int] = None) -> dict:
        """``{source name: SourceStatus}`` (see :meth:`EventEngine.source_report`)."""
        return self.engine.source_report(now_ns)

    def history(self) -> list:
        """
        Return the estimates of the history, oldest first, as computed with every sample so far.

        One per stamp of the history (the last one is the newest estimate); empty without a
        history. Rows whose estimate was not returned (beyond a limit) are left out.
        """
        return [entry.result for entry in self.engine.entries if entry.result is not None]

    def save(self) -> tuple:
        """Return the estimator's running state, to re-run from (the engine's history)."""
        return self.estimator.snapshot()

    def load(self, state: tuple) -> None:
        """Return the estimator to a state of :meth:`save`."""
        self.estimator.restore(state)

    # --- events ----------------------------------------------------------------------------

    def add_input(self, stamp_ns: int, u, now_ns: Optional[int] = None,
                  source: str = INPUT) -> list:
        """
        Store an input; return the estimates of measurements it releases.

        ``now_ns`` is the receiver's clock at arrival, for the clock tolerance (None: no
        check).
        """
        released = self.engine.add_input(stamp_ns, u, now_ns, source)
        if not self._fast:  # prepare() would find nothing to prepare (and nothing prepared)
            return released
        prepared = self._prepared_at
        if not released and (prepared is None or prepared != self.estimator.stamp_ns
                             or stamp_ns <= prepared or self.engine.queue):
            self.prepare()  # not again for an input after the step prepared: it changes none
        return released

    def hold_input(self, u, now_ns: Optional[int] = None) -> list:
        """
        Stamp an unstamped input with the measurement it is applied from; return the estimates.

        The input is taken as applied from the first measurement stamped at its arrival
        (``now_ns``, the receiver's clock, equal to the latest measurement's stamp: a
        simulated clock that has not moved since that sample) or arriving after it (it is
        held until then; a later input replaces one still held), as a driver that applies
        the latest command at each sample does (``observer.unstamped_input:
        next_measurement``). Its pairing then does not depend on how late it arrived, where
        an input stamped on arrival is paired one more interval late for every sample
        period of delay.
        """
        if now_ns is not None and now_ns == self._last_measurement_ns:
            self._held_input = None
            return self.add_input(now_ns, u, now_ns)
        self._held_input = (u, now_ns)
        return []

    def add_measurement(self, stamp_ns: int, y, now_ns: Optional[int] = None,
                        arrival_ns: int = 0, source: str = MEASUREMENT) -> list:
        """
        Take a measurement; return the estimates produced now (possibly none).

        ``now_ns`` is the receiver's clock at arrival (see :meth:`add_input`);
        ``arrival_ns`` any monotonic arrival time the caller wants back from :meth:`waiting`
        (the node's steady clock, to bound the wait for the input). An input of
        :meth:`hold_input` is stored first, stamped ``stamp_ns``.
        """
        self._last_measurement_ns = stamp_ns
        held = self._held_input
        if held is not None:
            self._held_input = None
            released = self.add_input(stamp_ns, held[0], held[1])
            return released + self.add_measurement(stamp_ns, y, now_ns, arrival_ns, source)
        key = self._steady_key
        if (key is not None and type(y) is list and len(y) == 1 and type(y[0]) is float
                and source == MEASUREMENT):
            produced = self._steady_step(int(stamp_ns), y[0], now_ns, key)
            if produced is not None:
                return produced
        return self.engine.add_measurement(stamp_ns, y, now_ns, arrival_ns, source)

    def flush(self, first_only: bool = False) -> list:
        """
        Process waiting measurements with the inputs at hand.

        ``first_only``: only the first waits no longer; the ones after it are processed when
        their input is there (as :meth:`add_input` would).
        """
        return self.engine.flush(first_only)

    def predict(self, stamp_ns: int) -> Prediction:
        """
        Return the estimate predicted to ``stamp_ns`` with the latest input stamped by then.

        The estimator is not changed (``observer.publish_rate`` publishes these).
        """
        return self.estimator.predict(int(stamp_ns), self.engine.held_input(int(stamp_ns)))

    # --- rows ------------------------------------------------------------------------------

    def take(self, row) -> list:
        """Run the estimator on one row of the engine; return the estimates it gives now."""
        source, stamp_ns, y, u, interval_ns, arrival_ns, outputs, rerun = row
        if source == PREDICTION:
            return [self._delayed(y, u)]
        estimator = self.estimator
        if interval_ns == 0 and estimator.stamp_ns is not None:
            estimator.restart()  # a gap or a backward jump: start from the estimate held
        d = estimator.feedthrough
        if outputs is None:
            if d is not None:  # D u with the input in effect at the measurement's stamp
                y = without_feedthrough(d, y, self.engine.held_input(stamp_ns))
            estimate = estimator.advance(stamp_ns, y, u)  # checked on arrival
        else:
            update = self._updates.get(outputs)
            if update is None:
                update = self._update_outputs(outputs)
            if d is not None and update:
                y = without_feedthrough(d, y, self.engine.held_input(stamp_ns), update)
            estimate = estimator.advance_outputs(stamp_ns, y if update else NO_VALUES, u,
                                                 update)
        innovation = estimator.innovation
        inside = False  # _publishable's common case in one test, within_limit's rule inline
        if (not self._fast and type(estimate) is ndarray and type(innovation) is ndarray
                and len(estimate) <= SHORT and len(innovation) <= SHORT):
            limits = self.limits  # finite sums, then the extremes (as the engine's admission)
            for vector, limit in ((estimate, limits.estimate), (innovation, limits.innovation)):
                values = vector.tolist()
                inside = isfinite(sum(values)) and (
                    limit == inf or -limit <= min(values, default=0.0)
                    and max(values, default=0.0) <= limit)
                if not inside:
                    break
        if not inside and not self._publishable(estimate, innovation,
                                                estimator.result if self._fast else None):
            return []
        covariance = estimator.innovation_covariance
        # The protocol's NIS is computed from the innovation and S when first read.
        nis = None if covariance is None or self._lazy_nis else estimator.nis
        if not rerun:
            self.engine.counters['estimates'] += 1
        if outputs is None and not rerun:
            sample = EstimateSample(stamp_ns, estimate, innovation, estimator.covariance,
                                    covariance, nis)
        else:
            sample = SourceSample(stamp_ns, estimate.copy(), innovation, estimator.covariance,
                                  covariance, nis, None if outputs is None else update, rerun)
        if self.form == 'current':
            return [sample]
        self.engine.await_input(stamp_ns, sample, arrival_ns)
        return []

    def _delayed(self, sample: EstimateSample, u: np.ndarray) -> EstimateSample:
        """Return the prediction ``x[k+1|k]`` of a current sample, with the next input ``u``."""
        estimator = self.estimator
        interval = estimator.last_interval_ns
        prediction = estimator.predict(sample.stamp_ns + interval, u)
        return sample._replace(estimate=prediction.estimate,
                               covariance=prediction.covariance)

    def _publishable(self, estimate: np.ndarray, innovation: np.ndarray,
                     result: Optional[np.ndarray] = None) -> bool:
        """
        Whether an estimate may be returned; else count it and restart the estimator.

        ``result``, both together, is checked at once against the smaller limit first.
        """
        limits = self.limits
        if result is not None and within_limit(result, self._result_limit):
            return True
        if within_limit(estimate, limits.estimate) and within_limit(innovation,
                                                                    limits.innovation):
            return True
        self.engine.counters['estimate_reset'] += 1
        self.engine.events.append(
            ('estimate_reset', f'an estimate beyond its limit ({limits.estimate:g}, '
             f'innovation {limits.innovation:g}) was not published; the estimator restarts '
             f'from its initial state'))
        self.estimator.reset()
        return False
