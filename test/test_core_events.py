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
The event engine: one set of rules, its fast paths equal to its general path.

Random event orders (hypothesis): gaps, duplicates, stamps out of order and backward jumps,
NaN, infinite and huge values, inputs missing, late or doubled, flushes and resets. The
stream with the estimator's fast paths (the node's way: values as lists, ``prepare`` after
each estimate) and the stream on the general path alone must give the same estimates bit for
bit, the same counters and the same events; so must the batch replay of a recording on
either path. An estimator that offers nothing but the protocol runs in the stream too.
"""

from collections import Counter
import math

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
import pytest

from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators import (
    ConstantGainEstimator, Estimator, IntervalCache, SteadySteps)
from observer_ros.core.events import EventEngine, MEASUREMENT
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers import make_estimator
from observer_ros.core.observers.full_order.design import design_full_order
from observer_ros.core.observers.kalman.design import design_kalman
from observer_ros.core.observers.kalman.time_varying import (
    parse_initial_covariance, TimeVaryingKalman)
from observer_ros.core.rules import InputHistory, ValueLimits
from observer_ros.core.streaming import EventStream
from observer_ros.core.units import NANOSECONDS

PERIOD_NS = 10_000_000
SECOND_NS = NANOSECONDS
LIMIT = 1e6

#: Stamp steps, in periods: steady most of the time, then jitter, repeats, steps back,
#: gaps and backward jumps beyond the one-second gap limit.
STEPS = st.sampled_from([1.0] * 8 + [0.5, 1.5, 0.0, -0.5, -1.0, 150.0, -150.0])
VALUES = st.one_of(st.floats(-2.0, 2.0, allow_nan=False), st.sampled_from(
    [math.nan, math.inf, -math.inf, 1e12, LIMIT * 1.5]))


def model(inputs: bool = True) -> StateSpaceModel:
    if inputs:
        return StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    return StateSpaceModel.from_matrices([[0, 1], [-1, -0.1]], np.zeros((2, 0)), [[1, 0]])


def estimator(kind: str, inputs: bool = True) -> Estimator:
    plant = model(inputs)
    if kind == 'full_order':
        return make_estimator(design_full_order(plant, poles=[-4, -5]))
    design = design_kalman(plant, [0.0, 1.0], [0.01])
    return make_estimator(design, time_varying=kind == 'time_varying')


@st.composite
def event_lists(draw, inputs: bool = True):
    """Events ``(kind, stamp, values, now)``; kinds ``u``, ``y``, ``flush``, ``flush1``."""
    events, stamp = [], SECOND_NS
    for _ in range(draw(st.integers(1, 40))):
        stamp += int(PERIOD_NS * draw(STEPS))
        now = stamp + draw(st.sampled_from([0, 0, 0, SECOND_NS]))  # sometimes far ahead
        y = [draw(VALUES)] if draw(st.integers(0, 30)) else [0.1, 0.2]  # a wrong size
        arrangement = draw(st.sampled_from(['u first', 'y first', 'y only', 'u late']))
        if not inputs:
            arrangement = 'y only'
        u = [draw(VALUES)]
        if arrangement == 'u first':
            events += [('u', stamp, u, now), ('y', stamp, y, now)]
        elif arrangement == 'y first':
            events += [('y', stamp, y, now), ('u', stamp, u, now)]
        elif arrangement == 'u late':
            events += [('y', stamp, y, now), ('u', stamp - PERIOD_NS, u, now)]
        else:
            events.append(('y', stamp, y, now))
        action = draw(st.sampled_from([None] * 12 + ['flush', 'flush1', 'reset']))
        if action:
            events.append((action, 0, None, 0))
    return events


def fingerprint(samples) -> list:
    """Everything a published estimate carries, as bytes (bit for bit)."""
    return [(s.stamp_ns, np.asarray(s.estimate, dtype=float).tobytes(),
             np.asarray(s.innovation, dtype=float).tobytes(),
             None if s.covariance is None else np.asarray(s.covariance).tobytes(),
             None if s.nis is None else float(s.nis)) for s in samples]


def feed(stream: EventStream, events, node_like: bool) -> tuple:
    """Feed ``events``; ``node_like``: lists of floats and ``prepare`` after each estimate."""
    out = []
    for kind, stamp, values, now in events:
        if kind == 'u':
            out += fingerprint(stream.add_input(stamp, np.array(values), now))
        elif kind == 'y':
            samples = stream.add_measurement(
                stamp, list(values) if node_like else np.array(values), now, 7)
            out += fingerprint(samples)
            if node_like and samples:
                stream.prepare()
        elif kind == 'reset':
            stream.reset()
        else:
            out += fingerprint(stream.flush(first_only=kind == 'flush1'))
        out.append(('waiting', stream.pending, stream.waiting() is None))
    out += fingerprint(stream.flush())
    return out, +Counter(stream.counters), list(stream.events)


def make_stream(kind, fast=True, inputs=True, **kwargs) -> EventStream:
    return EventStream(estimator(kind, inputs), SECOND_NS, fast_paths=fast,
                       limits=ValueLimits(LIMIT, LIMIT, LIMIT, LIMIT), **kwargs)


SETTINGS = settings(max_examples=40, deadline=None,
                    suppress_health_check=[HealthCheck.too_slow])


@pytest.mark.parametrize('kind', ['full_order', 'kalman', 'time_varying'])
@pytest.mark.parametrize('form', ['current', 'delayed'])
@SETTINGS
@given(data=st.data())
def test_the_fast_paths_equal_the_general_path_event_by_event(kind, form, data):
    inputs = data.draw(st.booleans())
    events = data.draw(event_lists(inputs))
    stamped = data.draw(st.booleans())
    tolerance = data.draw(st.sampled_from([0, SECOND_NS // 2]))
    options = {'form': form, 'input_stamped': stamped, 'clock_tolerance_ns': tolerance}
    fast = make_stream(kind, True, inputs, **options)
    general = make_stream(kind, False, inputs, **options)
    assert feed(fast, events, node_like=True) == feed(general, events, node_like=False)


@pytest.mark.parametrize('kind', ['full_order', 'kalman'])
def test_the_steady_fast_path_does_the_work_at_a_steady_rate(kind):
    stream = make_stream(kind)
    taken = []
    step = stream._steady_step
    stream._steady_step = lambda *args: taken.append(step(*args)) or taken[-1]
    for k in range(100):
        stamp = SECOND_NS + k * PERIOD_NS
        if stream.add_measurement(stamp, [0.1 * math.sin(k)]):
            stream.prepare()
        stream.add_input(stamp, [0.0])
    assert sum(bool(result) for result in taken) >= 97
    assert stream.counters['estimates'] == 100


@pytest.mark.parametrize('kind', ['full_order', 'kalman', 'time_varying'])
@pytest.mark.parametrize('form', ['current', 'delayed'])
@SETTINGS
@given(data=st.data())
def test_the_batch_replay_equals_the_general_path(kind, form, data):
    inputs = data.draw(st.booleans())
    events = [e for e in data.draw(event_lists(inputs)) if e[0] in 'uy' and len(e[2]) == 1]
    clean = data.draw(st.booleans())
    if clean:  # a recording the batch path takes: stamps that follow on, finite values
        events = [(kind_, SECOND_NS + index * PERIOD_NS, [0.1 * index % 1.0], 0)
                  for index, (kind_, *_) in enumerate(events)]
    u_events = [e for e in events if e[0] == 'u']
    y_events = [e for e in events if e[0] == 'y']
    recording = ([e[1] for e in u_events],
                 np.array([e[2] for e in u_events], dtype=float).reshape(len(u_events),
                                                                         int(inputs)),
                 [e[1] for e in y_events],
                 np.array([e[2] for e in y_events], dtype=float).reshape(-1, 1),
                 [e[3] + 1 for e in u_events], [e[3] + 1 for e in y_events])
    results, kalman = [], []
    for fast in (True, False):
        stream = make_stream(kind, fast, inputs, form=form,
                             clock_tolerance_ns=SECOND_NS // 2)
        try:
            replayed = stream.replay(*recording)
        except ValueError as e:
            results.append(str(e))
            continue
        results.append((replayed.stamps_ns.tolist(), replayed.estimates.tobytes(),
                        replayed.innovations.tobytes(), +Counter(stream.counters)))
        kalman.append(replayed)
    assert results[0] == results[1]
    # The covariances and NIS where both paths give them. (Known and kept: the general path
    # gives none for a constant-gain Kalman filter, whose first sample has no covariance;
    # the batch path gives the steady one for every row.)
    fast, general = kalman if len(kalman) == 2 else (None, None)
    if fast is not None and general.covariances is not None:
        assert np.array_equal(fast.covariances, general.covariances)
        assert np.array_equal(fast.nis, general.nis)


def test_the_engine_alone_pairs_each_interval_with_the_input_at_the_previous_stamp():
    rng = np.random.default_rng(3)
    engine = EventEngine(n_outputs=1, n_inputs=1, max_gap_ns=SECOND_NS)
    stamps = SECOND_NS + np.cumsum(rng.integers(1, 3, 50)) * PERIOD_NS
    input_stamps = sorted(rng.choice(stamps, 20, replace=False).tolist())
    inputs = {stamp: [float(k)] for k, stamp in enumerate(input_stamps)}
    for stamp in input_stamps:
        assert engine.add_input(stamp, inputs[stamp]) == []
    rows = []
    for stamp in stamps.tolist():
        rows += engine.add_measurement(stamp, [0.0])
    rows += engine.flush()
    assert [row.stamp_ns for row in rows] == stamps.tolist()
    assert rows[0].interval_ns == 0
    for before, row in zip(rows, rows[1:]):
        assert row.interval_ns == row.stamp_ns - before.stamp_ns
        held = [s for s in input_stamps if s <= before.stamp_ns]
        expected = inputs[held[-1]] if held else [0.0]
        assert row.u.tolist() == expected
    assert {row.source for row in rows} == {MEASUREMENT}


def test_the_engine_drops_and_counts_by_the_stamp_rules():
    engine = EventEngine(n_outputs=1, n_inputs=0, max_gap_ns=SECOND_NS)
    stamps = [SECOND_NS, SECOND_NS + 10, SECOND_NS + 10, SECOND_NS + 5, 5 * SECOND_NS,
              SECOND_NS // 2]
    rows = [row for stamp in stamps for row in engine.add_measurement(stamp, [1.0])]
    assert [(row.stamp_ns, row.interval_ns) for row in rows] == [
        (SECOND_NS, 0), (SECOND_NS + 10, 10), (5 * SECOND_NS, 0), (SECOND_NS // 2, 0)]
    assert engine.counters == Counter(measurements=6, duplicate=1, out_of_order=1,
                                      restart_gap=1, restart_backward_jump=1)


def test_without_a_history_the_samples_before_a_jump_ahead_are_inserted_before_it():
    # The no-history rule: after a row stamped more than twice the interval before it ahead,
    # a measurement between the previous stamp and it is inserted (the newest row taken
    # again after it, with the input held at the late stamp); a plain reorder is dropped.
    engine = EventEngine(n_outputs=1, n_inputs=1, max_gap_ns=SECOND_NS)
    for stamp in (0, 10, 20):
        engine.add_input(stamp, [stamp])
        engine.add_measurement(stamp, [stamp])
    assert engine.add_measurement(100, [100.0])[0].interval_ns == 80  # the early outlier
    engine.add_input(30, [30])
    newest = engine.add_measurement(30, [30.0])
    assert [(row.stamp_ns, row.u.tolist(), row.interval_ns, row.rerun) for row in newest] == [
        (100, [30.0], 70, True)]
    assert engine.add_measurement(25, [25.0]) == []  # before the previous stamp (30)
    engine.add_measurement(50, [50.0])  # before its input: the newest holds the one of 30
    newest = engine.add_input(50, [50])  # the input held at 50 came: taken again
    assert [(row.stamp_ns, row.u.tolist(), row.interval_ns) for row in newest] == [
        (100, [50.0], 50)]
    engine.add_input(100, [100])
    assert [(row.stamp_ns, row.interval_ns) for row in engine.add_measurement(110, [1.0])] == [
        (110, 10)]
    assert engine.add_measurement(90, [90.0]) == []  # in order again: a step back is dropped
    rows = engine.consumer.rows
    assert [row.stamp_ns for row in rows if not row.rerun] == [0, 10, 20, 100, 110]
    assert [row.stamp_ns for row in rows if row.rerun] == [30, 100, 50, 100, 100]
    assert engine.counters['out_of_order'] == 2 and engine.counters['reruns'] == 2
    assert engine.counters['input_reruns'] == 1
    reorder = EventEngine(n_outputs=1, n_inputs=0, max_gap_ns=SECOND_NS)
    for stamp in (0, 10, 20, 30, 25):
        reorder.add_measurement(stamp, [1.0])
    assert reorder.counters['out_of_order'] == 1 and not reorder.counters['reruns']


def test_an_unknown_source_is_refused():
    engine = EventEngine(n_outputs=1, n_inputs=1, max_gap_ns=SECOND_NS)
    with pytest.raises(ValueError, match="measurement sources \\['y'\\], got 'imu0'"):
        engine.add_measurement(0, [1.0], source='imu0')
    with pytest.raises(ValueError, match='input sources'):
        engine.add_input(0, [1.0], source='y')


def test_input_history_keeps_stamp_order_and_the_later_of_equal_stamps():
    one, many = InputHistory(), InputHistory()
    stamps = np.array([30, 10, 20, 10, 40], dtype=np.int64)
    values = np.arange(5.0).reshape(-1, 1)
    for stamp, value in zip(stamps.tolist(), values):
        one.store(stamp, value)
    many.store_many(stamps, values)
    assert one.stamps == many.stamps == [10, 20, 30, 40]
    assert [v.tolist() for v in one.values] == [v.tolist() for v in many.values] == [
        [3.0], [2.0], [0.0], [4.0]]
    assert one.indices_at(np.array([5, 10, 25, 99])).tolist() == [
        one.index_at(5), one.index_at(10), one.index_at(25), one.index_at(99)] == [-1, 0, 1, 3]


class ProtocolOnly(Estimator):
    """An estimator that offers the protocol and nothing else (it delegates the maths)."""

    def __init__(self, inner: Estimator) -> None:
        self.inner = inner
        self.n_states, self.n_inputs, self.n_outputs = (
            inner.n_states, inner.n_inputs, inner.n_outputs)

    stamp_ns = property(lambda self: self.inner.stamp_ns)
    estimate = property(lambda self: self.inner.estimate)
    innovation = property(lambda self: self.inner.innovation)
    covariance = property(lambda self: self.inner.covariance)
    innovation_covariance = property(lambda self: self.inner.innovation_covariance)
    initial_state = property(lambda self: self.inner.initial_state)
    last_interval_ns = property(lambda self: self.inner.last_interval_ns)

    def advance(self, stamp_ns, y, u):
        return self.inner.advance(stamp_ns, y, u)

    def prediction(self, estimate, covariance, interval_ns, u):
        return self.inner.prediction(estimate, covariance, interval_ns, u)

    def reset(self, initial_state=None):
        self.inner.reset(initial_state)

    def restart(self):
        self.inner.restart()

    def snapshot(self):
        return self.inner.snapshot()

    def restore(self, state):
        self.inner.restore(state)

    def adopt(self, other):
        self.inner.adopt(other.inner)


@pytest.mark.parametrize('form', ['current', 'delayed'])
def test_an_estimator_without_fast_paths_runs_in_the_stream(form):
    events = [(kind, SECOND_NS + k * PERIOD_NS, [0.01 * k], 0)
              for k in range(40) for kind in ('u', 'y')]
    plain = EventStream(ProtocolOnly(estimator('kalman')), SECOND_NS, form=form)
    fast = EventStream(estimator('kalman'), SECOND_NS, form=form)
    assert not isinstance(plain.estimator, SteadySteps)
    assert isinstance(fast.estimator, SteadySteps)
    assert feed(plain, events, node_like=True) == feed(fast, events, node_like=True)


def test_the_fast_paths_are_a_capability_of_the_constant_gain_estimator_only():
    assert isinstance(estimator('full_order'), (ConstantGainEstimator, SteadySteps))
    assert isinstance(estimator('kalman'), SteadySteps)
    filter_ = estimator('time_varying')
    assert isinstance(filter_, TimeVaryingKalman) and not isinstance(filter_, SteadySteps)
    assert not hasattr(filter_, 'advance_many') and not hasattr(filter_, 'supports_batch')


def test_one_interval_cache_rounds_keeps_the_recent_and_drops_the_least_recently_used():
    made = []
    cache = IntervalCache(lambda dt: made.append(dt) or dt, size=2, resolution_ns=10)
    assert cache.get(14) == 10 and cache.get(6) == 10 and made == [10]  # one design
    cache.get(21)
    cache.get(14)  # 10 used again: 20 is the least recently used
    cache.get(33)
    assert made == [10, 20, 30]
    cache.get(19)  # 20 was dropped: made again
    assert made == [10, 20, 30, 20]
    assert cache.recent() == [20, 30, 10]
    cache.peek(50)  # a prediction: made, not recent
    assert cache.recent() == [20, 30, 10]
    with pytest.raises(ConfigError, match='^interval_resolution_ns: expected >= 0'):
        cache.resolution_ns = -1
    cache.resolution_ns = 0  # a new rounding forgets the old designs
    assert cache.recent() == [] and cache.get(14) == 14
    constant = IntervalCache(lambda dt: made.append(dt) or 'sampled', constant=True)
    assert constant.get(3) == constant.get(7) == 'sampled' and constant.recent() == [0]


@pytest.mark.parametrize('kind', ['full_order', 'time_varying'])
def test_both_engines_share_the_interval_cache(kind):
    engine = estimator(kind)
    engine.interval_resolution_ns = 1_000_000
    engine.update(0, [1.0], [0.0])
    for stamp in (10_200_000, 20_100_000, 31_000_000):
        engine.update(stamp, [1.0], [0.0])
    assert isinstance(engine.intervals, IntervalCache)
    assert engine.recent_intervals() == [11_000_000, 10_000_000]
    with pytest.raises(ConfigError, match='interval_resolution_ns'):
        engine.interval_resolution_ns = -5


@pytest.mark.parametrize('values,expected', [(None, np.eye(2)), ([], np.eye(2)),
                                             ([2.0, 3.0], np.diag([2.0, 3.0]))])
def test_initial_covariance_is_parsed_in_one_place(values, expected):
    np.testing.assert_array_equal(parse_initial_covariance(values, 2), expected)
    filter_ = TimeVaryingKalman(model(), np.diag([0.0, 1.0]), [[0.01]], values)
    np.testing.assert_array_equal(filter_.initial_covariance, expected)


def test_a_bad_initial_covariance_is_refused_the_same_way_by_the_design_and_the_filter():
    from observer_ros.core.observers import observer_type
    kind = observer_type('kalman')
    with pytest.raises(ConfigError, match='^initial_covariance: expected a positive definite'):
        parse_initial_covariance([1.0, 0.0], 2)
    values = kind.values({'process_noise': [0.0, 1.0], 'measurement_noise': [0.01],
                          'initial_covariance': [1.0, 0.0], 'time_varying': True})
    with pytest.raises(ConfigError, match='^initial_covariance: expected a positive definite'):
        kind.design(model(), values)


def test_an_infinite_measurement_without_limits_is_dropped_on_the_steady_path_too():
    # Before: with no limit set the steady path let y = inf through to the estimator, whose
    # non-finite estimate was then counted as estimate_reset and the estimator restarted,
    # where the general path drops the sample as malformed and keeps the estimate.
    fast = EventStream(estimator('full_order'), SECOND_NS)
    general = EventStream(estimator('full_order'), SECOND_NS, fast_paths=False)
    events = [(kind, SECOND_NS + k * PERIOD_NS, [0.01 * k], 0)
              for k in range(10) for kind in ('u', 'y')]
    events += [('y', SECOND_NS + 10 * PERIOD_NS, [math.inf], 0),
               ('y', SECOND_NS + 10 * PERIOD_NS, [-math.inf], 0)]
    got = feed(fast, events, node_like=True)
    assert got == feed(general, events, node_like=False)
    assert got[1]['malformed'] == 2 and 'estimate_reset' not in got[1]
    assert fast.estimator.stamp_ns == SECOND_NS + 9 * PERIOD_NS  # not restarted


# --- one event's path without repeated work (issue 29) -----------------------------------


def _loop(stream: EventStream, samples: int = 20) -> list:
    """Feed a node's loop: ``u`` stamped k before ``y`` of k, ``prepare`` after each estimate."""
    out = []
    for k in range(samples):
        stamp = SECOND_NS + k * PERIOD_NS
        out += stream.add_input(stamp, [0.1 * k])
        produced = stream.add_measurement(stamp, [math.sin(k)])
        if produced:
            stream.prepare()
        out += produced
    return out


def test_an_input_after_the_prepared_step_does_not_prepare_it_again(monkeypatch):
    # Before: the node's prepare after an estimate and add_input's prepare each asked the
    # engine for the input and the estimator for the step: twice per message.
    stream = EventStream(estimator('full_order'), max_gap_ns=SECOND_NS)
    calls = []
    prepare = stream.estimator.prepare
    monkeypatch.setattr(stream.estimator, 'prepare',
                        lambda *args: calls.append(args) or prepare(*args))
    samples = _loop(stream)
    assert len(calls) == len(samples)  # once per estimate, not again for each input
    reference = EventStream(estimator('full_order'), max_gap_ns=SECOND_NS, fast_paths=False)
    assert fingerprint(samples) == fingerprint(_loop(reference))


def test_a_late_input_still_prepares_the_step_again():
    stream = EventStream(estimator('full_order'), max_gap_ns=SECOND_NS)
    _loop(stream, 3)
    stream.prepare()
    key = stream._steady_key
    stream.add_input(SECOND_NS + 2 * PERIOD_NS, [5.0])  # replaces the input held at the step
    assert stream._steady_key is not key and stream._steady_key[1].tolist() == [5.0]


def test_the_nis_of_a_constant_gain_kalman_filter_is_computed_when_read(monkeypatch):
    # Before: the stream computed v^T S^-1 v (a solve) for every estimate, read or not.
    import observer_ros.core.estimators.protocol as protocol
    solved = []
    nis = protocol.normalized_innovation_squared
    monkeypatch.setattr(protocol, 'normalized_innovation_squared',
                        lambda *args: solved.append(1) or nis(*args))
    stream = EventStream(estimator('kalman'), max_gap_ns=SECOND_NS, fast_paths=False)
    samples = _loop(stream)
    assert not solved
    assert [s.nis for s in samples[1:]] == [nis(s.innovation, s.innovation_covariance)
                                            for s in samples[1:]]


def test_a_measurement_that_follows_on_with_a_history_does_not_wait_in_the_queue(monkeypatch):
    # Before: with a history every measurement was queued in stamp order and taken off it.
    from observer_ros.core.sources import MeasurementSource
    stream = EventStream(estimator('time_varying'), max_gap_ns=SECOND_NS,
                         sources=(MeasurementSource('y', (0,)),), history_ns=SECOND_NS // 2)
    queued = []
    enqueue = stream.engine._enqueue
    monkeypatch.setattr(stream.engine, '_enqueue',
                        lambda *args: queued.append(args) or enqueue(*args))
    samples = _loop(stream)
    assert len(queued) == 1  # the first measurement only (nothing to follow on from)
    plain = EventStream(estimator('time_varying'), max_gap_ns=SECOND_NS)
    assert fingerprint(samples) == fingerprint(_loop(plain))


def test_the_engine_holds_one_part_for_its_history_chosen_once():
    # Before: EventEngine was both (mixins) and asked keeps_history on every event.
    import inspect

    from observer_ros.core.events import engine as engine_module
    from observer_ros.core.events.history import History
    from observer_ros.core.events.rollback import NewestRollback
    from observer_ros.core.sources import MeasurementSource
    plain = EventEngine(n_outputs=1, n_inputs=1, max_gap_ns=SECOND_NS)
    late = EventEngine(n_outputs=1, n_inputs=1, max_gap_ns=SECOND_NS,
                       sources=(MeasurementSource('y', (0,)),), history_ns=SECOND_NS // 2)
    assert isinstance(plain.timeline, NewestRollback) and isinstance(late.timeline, History)
    assert not {History, NewestRollback} & set(EventEngine.__mro__)
    source = inspect.getsource(engine_module.EventEngine)
    assert source.count('self.keeps_history') == 2  # set once, read once: the choice
