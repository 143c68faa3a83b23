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
Measurements and inputs arriving as streams: pairing by stamp and stamp hygiene.

:class:`StreamEstimator` feeds an :class:`~observer_ros.core.estimators.Estimator` from two
streams, as the observer node and the offline bag replay both do (one code path, so they
give identical estimates). For the interval ending at measurement ``k`` the input is the
latest one stamped at or before measurement ``k-1``: a future input never leaks into the
past. A measurement whose input may still be on its way waits (``pending``) until an input
stamped at or after the previous measurement arrives, or until :meth:`flush`.

Bad stamps never crash and never produce NaN: duplicates and small backward steps are
dropped and counted; a backward jump or a gap longer than ``max_gap_ns`` restarts the
estimator from the new sample.
"""

import bisect
from collections import Counter
from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.core.estimators import Estimator

#: Inputs kept at most (older ones are dropped once no interval can need them).
MAX_INPUTS = 10_000


@dataclass(frozen=True)
class EstimateSample:
    """One published estimate: stamp, ``x_hat``, innovation and (Kalman) covariance."""

    stamp_ns: int
    estimate: np.ndarray
    innovation: np.ndarray
    covariance: Optional[np.ndarray]


@dataclass(frozen=True)
class ReplayArrays:
    """Estimates of a batch replay: stamps ``(k,)``, ``x_hat`` ``(k, n)``, innovations."""

    stamps_ns: np.ndarray
    estimates: np.ndarray
    innovations: np.ndarray


class StreamEstimator:
    """
    Pair stamped inputs with stamped measurements and run the estimator.

    Parameters
    ----------
    estimator : Estimator
    max_gap_ns : int
        A forward gap or backward jump longer than this restarts the estimator.
    input_stamped : bool
        False when inputs are stamped on arrival (unstamped messages): then no measurement
        waits for a later input.

    Attributes
    ----------
    counters : collections.Counter
        ``measurements``, ``estimates``, ``duplicate``, ``out_of_order``,
        ``restart_gap``, ``restart_backward_jump``, ``no_input``, ``late_input``, ``inputs``.
    events : list of (str, str)
        ``(kind, text)`` of notable events since the caller last cleared it.

    """

    def __init__(self, estimator: Estimator, max_gap_ns: int, input_stamped: bool = True):
        self.estimator = estimator
        self.max_gap_ns = int(max_gap_ns)
        self.input_stamped = input_stamped
        self.counters: Counter = Counter()
        self.events: list = []
        self._input_stamps: list = []
        self._inputs: list = []
        self._pending: list = []
        self._zero_input = np.zeros(estimator.n_inputs)
        self._inputs_absent = False

    @property
    def pending(self) -> int:
        """Number of measurements waiting for their input."""
        return len(self._pending)

    def reset(self) -> None:
        """Restart the estimator from its initial state; inputs are kept."""
        self.estimator.reset()
        self._pending.clear()

    def add_input(self, stamp_ns: int, u) -> list:
        """Store an input; return the estimates of measurements it releases."""
        self.counters['inputs'] += 1
        self._inputs_absent = False
        stamp_ns = int(stamp_ns)
        index = bisect.bisect_left(self._input_stamps, stamp_ns)
        vector = np.array(u, dtype=float)
        if index < len(self._input_stamps) and self._input_stamps[index] == stamp_ns:
            self._inputs[index] = vector
        else:
            self._input_stamps.insert(index, stamp_ns)
            self._inputs.insert(index, vector)
        previous = self.estimator.stamp_ns
        if previous is None or stamp_ns >= previous - self.max_gap_ns:
            self._prune()  # not while a backward jump (a looping bag) is under way
        return self._release(force=False)

    def add_measurement(self, stamp_ns: int, y) -> list:
        """Take a measurement; return the estimates produced now (possibly none)."""
        self.counters['measurements'] += 1
        self._pending.append((int(stamp_ns), np.array(y, dtype=float)))
        return self._release(force=False)

    def flush(self) -> list:
        """Process every waiting measurement with the inputs at hand."""
        if self._pending and not self._input_stamps:
            self._inputs_absent = True
        return self._release(force=True)

    def _ready(self, previous: int) -> bool:
        if not self.input_stamped or self._inputs_absent:
            return True
        return bool(self._input_stamps) and self._input_stamps[-1] >= previous

    def _input_for(self, previous: int) -> np.ndarray:
        index = bisect.bisect_right(self._input_stamps, previous) - 1
        if index < 0:
            if self._input_stamps:
                self.counters['late_input'] += 1
            else:
                self.counters['no_input'] += 1
            return self._zero_input
        return self._inputs[index]

    def _release(self, force: bool) -> list:
        produced = []
        while self._pending:
            stamp, y = self._pending[0]
            previous = self.estimator.stamp_ns
            if previous is not None and 0 < stamp - previous <= self.max_gap_ns:
                if not (force or self._ready(previous)):
                    break
                if not self._ready(previous):
                    self.counters['late_input'] += 1
                u = self._input_for(previous)
            else:
                u = self._zero_input
            self._pending.pop(0)
            sample = self._process(stamp, y, u, previous)
            if sample is not None:
                produced.append(sample)
        return produced

    def _process(self, stamp: int, y: np.ndarray, u: np.ndarray,
                 previous: Optional[int]) -> Optional[EstimateSample]:
        if not self._admit(stamp, previous):
            return None
        estimate = self.estimator.update(stamp, y, u)
        self.counters['estimates'] += 1
        return EstimateSample(stamp, estimate, self.estimator.innovation,
                              self.estimator.covariance)

    def _admit(self, stamp: int, previous: Optional[int]) -> bool:
        """Apply the stamp rules to a measurement; False when it is dropped."""
        if previous is None:
            return True
        step = stamp - previous
        if step == 0:
            self.counters['duplicate'] += 1
            self.events.append(('duplicate', f'dropped a measurement with a repeated '
                                f'stamp ({stamp} ns)'))
            return False
        if -self.max_gap_ns <= step < 0:
            self.counters['out_of_order'] += 1
            self.events.append(('out_of_order', f'dropped a measurement older than the '
                                f'previous one ({stamp} < {previous} ns)'))
            return False
        if step < 0 or step > self.max_gap_ns:
            kind = 'restart_backward_jump' if step < 0 else 'restart_gap'
            self.counters[kind] += 1
            if step < 0:  # inputs of the abandoned timeline must not pair with the new one
                keep = bisect.bisect_right(self._input_stamps, stamp)
                del self._input_stamps[keep:]
                del self._inputs[keep:]
            self.events.append((kind, f'time jumped by {step / 1e9:.3f} s; the estimator '
                                f'restarts from this sample'))
            self.estimator.restart()
        return True

    def replay(self, input_stamps, inputs, stamps, outputs, input_arrivals=None,
               arrivals=None) -> 'ReplayArrays':
        """
        Run over whole recorded streams at once, as if every input had arrived in time.

        Gives what the node computes from the same messages when no input arrives later than
        the measurement after it (a recording played back): the same pairing and stamp
        rules, and :meth:`Estimator.advance` for the arithmetic, so the estimates are equal
        bit for bit. Rows with a non-finite value are dropped and counted as ``malformed``.

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

        Raises
        ------
        ValueError
            Lengths differ, or a backward jump without arrival times.

        """
        estimator = self.estimator
        n_outputs, n_inputs = estimator.n_outputs, estimator.n_inputs
        outputs = np.ascontiguousarray(outputs, dtype=float).reshape(-1, n_outputs)
        inputs = np.ascontiguousarray(inputs, dtype=float).reshape(-1, n_inputs)
        stamps = np.asarray(stamps, dtype=np.int64)
        input_stamps = np.asarray(input_stamps, dtype=np.int64)
        if len(stamps) != len(outputs) or len(input_stamps) != len(inputs):
            raise ValueError('replay: stamps and values differ in length')
        good_inputs = np.isfinite(inputs).all(axis=1)
        good = np.isfinite(outputs).all(axis=1)
        jump = -self.max_gap_ns
        looping = ((np.diff(stamps[good]) < jump).any()
                   or (np.diff(input_stamps[good_inputs]) < jump).any())
        if looping:
            if arrivals is None or input_arrivals is None:
                raise ValueError('replay: the stamps jump backwards (a looping recording); '
                                 'give the arrival times to replay it message by message')
            return self._replay_in_arrival_order(
                input_stamps, inputs, stamps, outputs, input_arrivals, arrivals)
        self.counters['malformed'] += int((~good_inputs).sum() + (~good).sum())
        order = np.argsort(input_stamps[good_inputs], kind='stable')
        input_stamps = input_stamps[good_inputs][order].tolist()
        inputs = inputs[good_inputs][order]
        self.counters['inputs'] += len(input_stamps)
        last_input = input_stamps[-1] if input_stamps else None
        zero = self._zero_input
        measured = stamps[good]
        steps = np.diff(measured)
        if (estimator.stamp_ns is None and len(measured) and (steps > 0).all()
                and (steps <= self.max_gap_ns).all()):
            return self._replay_steady(measured, outputs[good], np.array(input_stamps),
                                       inputs)
        kept, estimates, innovations = [], [], []
        find = bisect.bisect_right
        for index in np.flatnonzero(good).tolist():
            stamp = int(stamps[index])
            self.counters['measurements'] += 1
            previous = estimator.stamp_ns
            if previous is not None and 0 < stamp - previous <= self.max_gap_ns:
                position = find(input_stamps, previous) - 1
                if position < 0:
                    self.counters['late_input' if input_stamps else 'no_input'] += 1
                    u = zero
                else:
                    if self.input_stamped and last_input < previous:
                        self.counters['late_input'] += 1
                    u = inputs[position]
            elif not self._admit(stamp, previous):
                continue
            else:
                u = zero
            estimates.append(estimator.advance(stamp, outputs[index], u))
            innovations.append(estimator.innovation)
            kept.append(stamp)
        self.counters['estimates'] += len(kept)
        return ReplayArrays(np.array(kept, dtype=np.int64),
                            np.array(estimates).reshape(-1, estimator.n_states),
                            np.array(innovations).reshape(-1, n_outputs))

    def _replay_steady(self, stamps, outputs, input_stamps, inputs) -> 'ReplayArrays':
        # Every measurement is admitted, so each interval's input is known in advance: the
        # latest input stamped at or before the previous measurement (zero before the first).
        estimator = self.estimator
        count = len(stamps)
        pairing = np.searchsorted(input_stamps, stamps[:-1], side='right') - 1
        held = np.vstack([self._zero_input, inputs])[np.concatenate([[-1], pairing]) + 1]
        if len(input_stamps):
            self.counters['late_input'] += int((pairing < 0).sum()) if len(pairing) else 0
            if self.input_stamped:
                self.counters['late_input'] += int((stamps[:-1] > input_stamps[-1]).sum())
        else:
            self.counters['no_input'] += count - 1
        estimates, innovations = estimator.advance_many(stamps, outputs, held)
        self.counters['measurements'] += count
        self.counters['estimates'] += count
        return ReplayArrays(stamps.copy(), np.ascontiguousarray(estimates),
                            np.ascontiguousarray(innovations))

    def _replay_in_arrival_order(self, input_stamps, inputs, stamps, outputs, input_arrivals,
                                 arrivals) -> 'ReplayArrays':
        events = sorted(
            [(int(t), 0, k) for k, t in enumerate(np.asarray(input_arrivals).tolist())]
            + [(int(t), 1, k) for k, t in enumerate(np.asarray(arrivals).tolist())])
        samples = []
        for _, kind, index in events:
            values = inputs[index] if kind == 0 else outputs[index]
            if not np.isfinite(values).all():
                self.counters['malformed'] += 1
                continue
            add = self.add_input if kind == 0 else self.add_measurement
            samples += [(sample.stamp_ns, sample.estimate, sample.innovation)
                        for sample in add(int((input_stamps if kind == 0 else stamps)[index]),
                                          values)]
        samples += [(sample.stamp_ns, sample.estimate, sample.innovation)
                    for sample in self.flush()]
        n_states, n_outputs = self.estimator.n_states, self.estimator.n_outputs
        return ReplayArrays(np.array([s[0] for s in samples], dtype=np.int64),
                            np.array([s[1] for s in samples]).reshape(-1, n_states),
                            np.array([s[2] for s in samples]).reshape(-1, n_outputs))

    def _prune(self) -> None:
        previous = self.estimator.stamp_ns
        if previous is None:
            keep_from = max(0, len(self._input_stamps) - MAX_INPUTS)
        else:
            keep_from = max(0, bisect.bisect_right(self._input_stamps, previous) - 1)
            keep_from = max(keep_from, len(self._input_stamps) - MAX_INPUTS)
        if keep_from:
            del self._input_stamps[:keep_from]
            del self._inputs[:keep_from]
