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
Several measurement sources and the history of late measurements, without ROS.

Random arrival orders (hypothesis) within the history give, bit for bit, what the same
samples give arriving in stamp order; the stamps of every source (future, past beyond the
history, repeated, equal across sources) are handled and counted; the early outlier no
longer silences the samples after it; the configurations the estimators cannot run are
refused at start-up, naming the source and the reason.
"""

from collections import Counter
import math
import pathlib
import re

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
import pytest

from observer_ros.core import (
    ConfigError, design_chen, design_full_order, design_kalman, design_reduced_order,
    make_estimator, StateSpaceModel)
from observer_ros.core.estimators import SubsetUpdates
from observer_ros.core.events import EventEngine
from observer_ros.core.observers import observer_type, observer_types
from observer_ros.core.rules import ValueLimits
from observer_ros.core.sources import check_sources, MeasurementSource
from observer_ros.core.streaming import EventStream, RecordedEvent

SECOND_NS = 1_000_000_000
MS = 1_000_000
SPRING = ([[0.0, 1.0], [-4.0, -0.4]], [[0.0], [1.0]], [[1.0, 0.0], [0.0, 1.0]])
INTEGRATOR = ([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [[1.0, 0.0], [0.0, 1.0]])
TWO = (MeasurementSource('pose', (0,)), MeasurementSource('twist', (1,)))


def estimator(kind: str, matrices=SPRING):
    model = StateSpaceModel.from_matrices(*matrices)
    if kind == 'full_order':
        return make_estimator(design_full_order(model, poles=[-20, -25]))
    return make_estimator(design_kalman(model, [0.0, 1.0], [0.01, 0.04]),
                          time_varying=kind == 'time_varying')


def fingerprint(samples) -> list:
    return [(s.stamp_ns, np.asarray(s.estimate, dtype=float).tobytes(),
             None if s.covariance is None else np.asarray(s.covariance).tobytes())
            for s in samples]


@st.composite
def recordings(draw):
    """Draw inputs and two sources' samples: ``(inputs, [(arrival, stamp, source, y)])``."""
    inputs = [(SECOND_NS + k * 10 * MS, [draw(st.floats(-1, 1))]) for k in range(30)]
    samples, stamp, taken = [], SECOND_NS, set()
    for _ in range(draw(st.integers(5, 40))):
        stamp += draw(st.sampled_from([0, 1, 2, 3, 7]) if samples else st.just(0)) * MS
        source = draw(st.sampled_from(['pose', 'twist']))
        if (stamp, source) in taken:  # a repeat of one source: the first to arrive wins
            continue
        taken.add((stamp, source))
        delay = draw(st.sampled_from([0, 0, 0, 5, 40, 90])) * MS
        samples.append((stamp + delay, stamp, source, [draw(st.floats(-2, 2))]))
    return inputs, samples


@pytest.mark.parametrize('kind', ['time_varying', 'kalman', 'full_order'])
@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(recording=recordings())
def test_any_arrival_order_within_the_history_equals_stamp_order_bit_for_bit(kind, recording):
    inputs, samples = recording
    results = []
    for order in (sorted(samples), sorted(samples, key=lambda s: (s[1], s[0]))):
        stream = EventStream(estimator(kind), SECOND_NS, sources=TWO, history_ns=100 * MS)
        for stamp, u in inputs:
            stream.add_input(stamp, u)
        for arrival, stamp, source, y in order:
            stream.add_measurement(stamp, y, source=source)
        counts = stream.counters
        assert not counts['too_old'] and not counts['duplicate']
        assert counts['estimates'] + counts['reruns'] == len(samples)
        results.append(fingerprint(stream.history()))
    assert results[0] == results[1]


def test_one_source_with_a_history_equals_no_history_when_nothing_is_late():
    rng = np.random.default_rng(4)
    stamps = SECOND_NS + np.cumsum(rng.integers(5, 15, 300)) * MS
    stamps[200:] += 3 * SECOND_NS  # a gap: a restart
    outputs = rng.standard_normal((300, 2))
    inputs = rng.standard_normal((300, 1))
    for kind in ('time_varying', 'kalman', 'full_order'):
        got = []
        for history in (0, 200 * MS):
            stream = EventStream(estimator(kind), SECOND_NS, history_ns=history,
                                 fast_paths=False)
            assert stream.engine.keeps_history is bool(history)
            samples = []
            for stamp, u, y in zip(stamps.tolist(), inputs, outputs):
                samples += stream.add_input(stamp, u) + stream.add_measurement(stamp, y)
            got.append((fingerprint(samples), Counter(stream.counters)['restart_gap']))
        assert got[0] == got[1]
        assert all(not sample.corrected for sample in samples)


def test_the_early_outlier_no_longer_silences_the_samples_after_it():
    # The closed loop of the issue: the plant publishes y every 10 ms stamped by its clock;
    # one y comes stamped about 0.9 s ahead, inside the 1 s clock tolerance.
    def run(history_ns):
        stream = EventStream(estimator('time_varying', INTEGRATOR), 2 * SECOND_NS,
                             clock_tolerance_ns=SECOND_NS, history_ns=history_ns)
        out = []
        for k in range(200):
            stamp = SECOND_NS + k * 10 * MS
            out.append(stream.add_input(stamp, [0.1], now_ns=stamp)
                       + stream.add_measurement(stamp, [0.01 * k, 0.1], now_ns=stamp))
            if k == 50:
                out.append(stream.add_measurement(stamp + 905 * MS, [0.5, 0.1],
                                                  now_ns=stamp))
        return stream, out

    stream, published = run(SECOND_NS)
    outlier = SECOND_NS + 50 * 10 * MS + 905 * MS
    assert not stream.counters['out_of_order'] and not stream.counters['too_old']
    assert all(len(samples) == 1 for samples in published)  # every y gives an estimate
    meanwhile = [samples[0] for samples in published[52:52 + 90]]
    assert all(s.corrected and s.stamp_ns == outlier for s in meanwhile)  # the newest one
    assert not published[52 + 90][0].corrected  # then in order again
    assert stream.counters['reruns'] == 90 and stream.counters['rerun_rows'] == 2 * 90
    assert all(np.isfinite(s.estimate).all() for samples in published for s in samples)
    # Afterwards: what the same samples give in stamp order.
    ordered = EventStream(estimator('time_varying', INTEGRATOR), 2 * SECOND_NS,
                          history_ns=SECOND_NS)
    events = [(SECOND_NS + k * 10 * MS, [0.01 * k, 0.1]) for k in range(200)]
    events.append((outlier, [0.5, 0.1]))
    for stamp, y in sorted(events):
        ordered.add_input(stamp, [0.1])
        ordered.add_measurement(stamp, y)
    assert fingerprint(stream.history()) == fingerprint(ordered.history())
    # Without a history (the default) the same: the state before the jump ahead is kept and
    # each genuine sample is inserted before it (it used to drop 90 as out_of_order: 0.9 s
    # without an estimate).
    default, alone = run(0)
    assert not default.engine.keeps_history
    assert not default.counters['out_of_order'] and default.counters['reruns'] == 90
    assert [fingerprint(samples) for samples in alone] == [
        fingerprint(samples) for samples in published]


def feed(stream, events) -> list:
    return stream.replay_events(RecordedEvent(*event) for event in events)


def test_every_source_s_stamps_are_handled_and_counted():
    stream = EventStream(estimator('time_varying'), SECOND_NS, clock_tolerance_ns=50 * MS,
                         sources=TWO, history_ns=100 * MS, input_stamped=False,
                         limits=ValueLimits(measurement=1e3))
    t = SECOND_NS
    samples = feed(stream, [
        ('u', t, [0.0], t), ('pose', t, [1.0], t), ('twist', t, [0.5], t),  # equal: fused
        ('twist', t + 10 * MS, [0.5], t + 10 * MS),
        ('twist', t + 10 * MS, [0.6], t + 11 * MS),  # duplicate in one source
        ('pose', t + 10 * MS, [1.0], t + 12 * MS),  # equal stamp, other source: fused
        ('pose', t + 400 * MS, [1.0], t + 20 * MS),  # future: beyond the clock tolerance
        ('twist', t + 20 * MS, [math.nan], t + 20 * MS),  # malformed
        ('twist', t + 20 * MS, [1e6], t + 20 * MS),  # out of range
        ('twist', t + 20 * MS, [0.1, 0.2], t + 20 * MS),  # wrong size: malformed
        ('twist', t + 200 * MS, [0.5], t + 200 * MS),
        ('pose', t + 50 * MS, [1.0], t + 201 * MS),  # older than the history
        ('pose', t + 150 * MS, [1.0], t + 202 * MS),  # late, inside it
    ])
    report = stream.source_report(t + 210 * MS)
    assert report['twist'].counts == Counter(received=7, used=3, reruns=1, duplicate=1,
                                             malformed=2, out_of_range=1)
    assert report['pose'].counts == Counter(received=5, used=3, reruns=2, future_stamp=1,
                                            too_old=1)
    assert stream.counters['too_old'] == 1 and stream.counters['reruns'] == 3
    assert report['pose'].max_lag_ns == 50 * MS
    assert report['twist'].age_ns == 10 * MS and not report['twist'].stale
    assert all(np.isfinite(s.estimate).all() and np.isfinite(s.covariance).all()
               for s in samples)
    kinds = {kind for kind, _ in stream.events}
    assert {'duplicate', 'future_stamp', 'malformed', 'out_of_range', 'too_old'} <= kinds
    assert stream.engine.history_depth() == (2, 50 * MS)  # 150 and 200 ms


def test_a_source_s_latency_moves_its_stamps_back_through_the_history():
    late = (MeasurementSource('pose', (0,), latency_ns=30 * MS), TWO[1])
    shifted = EventStream(estimator('kalman'), SECOND_NS, sources=late, history_ns=50 * MS)
    direct = EventStream(estimator('kalman'), SECOND_NS, sources=TWO, history_ns=50 * MS)
    for k in range(100):
        stamp = SECOND_NS + k * MS
        for stream in (shifted, direct):
            stream.add_input(stamp, [0.0])
            stream.add_measurement(stamp, [0.2], source='twist')
        if k % 20 == 10:  # stamped on arrival: taken 30 ms earlier
            shifted.add_measurement(stamp, [0.3], source='pose')
            direct.add_measurement(stamp - 30 * MS, [0.3], source='pose')
    assert fingerprint(shifted.history()) == fingerprint(direct.history())
    assert shifted.counters['reruns'] == 5


def test_a_restart_ends_the_history():
    stream = EventStream(estimator('kalman'), 100 * MS, sources=TWO, history_ns=100 * MS,
                         input_stamped=False)
    t = SECOND_NS
    feed(stream, [('twist', t, [0.1], 0), ('twist', t + 10 * MS, [0.1], 0),
                  ('twist', t + 500 * MS, [0.1], 0),  # a gap: restart
                  ('pose', t + 450 * MS, [0.1], 0),  # inside the history, before the restart
                  ('pose', t + 500 * MS, [0.1], 0)])  # at the restart: fused
    assert stream.counters['restart_gap'] == 1
    assert stream.counters['too_old'] == 1 and stream.counters['reruns'] == 1


def test_a_predict_only_source_moves_the_estimate_forward():
    # Velocity alone cannot see the position of a double integrator: the full-order
    # observer refuses it, unless declared predict-only.
    with pytest.raises(ConfigError, match=r"^sources: source 'twist' \(outputs \['y2'\]\) "
                                          r'alone: \(A, C\) of these outputs is not observable: '
                                          r'the modes 0 cannot be seen'):
        EventStream(estimator('full_order', INTEGRATOR), SECOND_NS, sources=TWO)
    sources = (TWO[0], MeasurementSource('twist', (1,), predict_only=True))
    stream = EventStream(estimator('full_order', INTEGRATOR), SECOND_NS, sources=sources)
    t = SECOND_NS
    first = feed(stream, [('u', t, [1.0], 0), ('pose', t, [2.0], 0)])
    predicted = feed(stream, [('u', t + 10 * MS, [1.0], 0), ('twist', t + 10 * MS, [7.0], 0)])
    x = first[-1].estimate
    expected = [x[0] + 0.01 * x[1] + 0.5e-4, x[1] + 0.01]
    np.testing.assert_allclose(predicted[-1].estimate, expected, rtol=1e-12)
    assert predicted[-1].outputs == () and len(predicted[-1].innovation) == 0
    fused = feed(stream, [('pose', t + 20 * MS, [2.0], 0), ('twist', t + 20 * MS, [1.0], 0)])
    assert fused[-1].outputs is None and fused[-1].corrected
    # The steady-state Kalman filter: undetectable (an integrator unseen) is refused too;
    # the time-varying filter updates with any rows.
    with pytest.raises(ConfigError, match='not detectable: the modes 0'):
        EventStream(estimator('kalman', INTEGRATOR), SECOND_NS, sources=TWO)
    EventStream(estimator('time_varying', INTEGRATOR), SECOND_NS, sources=TWO)


def test_types_that_need_every_output_refuse_several_sources_through_their_capability():
    model = StateSpaceModel.from_matrices([[0, 1, 0], [0, 0, 1], [-1, -2, -3]],
                                          [[0], [0], [1]], [[1, 0, 0], [0, 1, 0]])
    sources = (MeasurementSource('a', (0,)), MeasurementSource('b', (1,), predict_only=True))
    for design in (design_reduced_order(model, poles=[-5]), design_chen(model, poles=[-5])):
        kind = observer_type(design.kind)
        assert kind.capabilities.needs_every_output and not kind.capabilities.several_sources
        with pytest.raises(ConfigError, match='^sources: this observer needs every output '
                                              'at each update'):
            EventStream(make_estimator(design), SECOND_NS, sources=sources)
    for kind in observer_types():
        if kind.capabilities.several_sources:
            assert not kind.capabilities.needs_every_output
    assert isinstance(estimator('time_varying'), SubsetUpdates)


@pytest.mark.parametrize('sources, history, match', [
    ((MeasurementSource('a', (0,)),), 0, r"^sources: outputs \['y2'\] belong to no source"),
    ((MeasurementSource('a', (0,)), MeasurementSource('a', (1,))), 0, 'named twice'),
    ((MeasurementSource('a', (0, 1)), MeasurementSource('b', (1,))), 0,
     "output y2 is carried by sources 'a' and 'b'"),
    ((MeasurementSource('a', (0, 2)),), 0, r'output 2 is no output of the model'),
    ((MeasurementSource('u', (0, 1)),), 0, "the name 'u' is taken"),
    ((MeasurementSource('a', (0, 1), latency_ns=20 * MS),), 10 * MS,
     "^history: source 'a' has a latency of 0.02 s, longer than the history"),
    ((MeasurementSource('a', (0, 1)),), 2 * SECOND_NS, r'^history: expected 0 ... 1 s'),
])
def test_bad_sources_are_refused_naming_what_is_wrong(sources, history, match):
    with pytest.raises(ConfigError, match=match):
        EventEngine(2, 1, SECOND_NS, sources=sources, history_ns=history)


def test_several_sources_take_the_current_form_only():
    with pytest.raises(ConfigError, match='^form: the delayed form takes one'):
        EventStream(estimator('kalman'), SECOND_NS, form='delayed', sources=TWO)
    check_sources(TWO, 2)  # fine as they are


def test_a_source_goes_stale_after_its_timeout():
    sources = (MeasurementSource('pose', (0,), timeout_ns=100 * MS), TWO[1])
    stream = EventStream(estimator('kalman'), SECOND_NS, sources=sources)
    assert stream.source_report(SECOND_NS)['pose'].stale  # nothing yet
    stream.add_measurement(SECOND_NS, [1.0], source='pose')
    assert not stream.source_report(SECOND_NS + 100 * MS)['pose'].stale
    assert stream.source_report(SECOND_NS + 101 * MS)['pose'].stale
    assert not stream.source_report(SECOND_NS + 101 * MS)['twist'].stale  # no timeout


def test_replay_with_a_history_equals_the_live_stream():
    rng = np.random.default_rng(8)
    stamps = SECOND_NS + np.arange(200) * 10 * MS
    arrivals = stamps + rng.integers(0, 40, 200) * MS  # some out of order
    outputs = rng.standard_normal((200, 2))
    live = EventStream(estimator('time_varying'), SECOND_NS, history_ns=50 * MS)
    batch = EventStream(estimator('time_varying'), SECOND_NS, history_ns=50 * MS)
    samples = []
    for stamp in stamps.tolist():
        samples += live.add_input(stamp, [0.5])
    for index in np.argsort(arrivals, kind='stable').tolist():
        samples += live.add_measurement(int(stamps[index]), outputs[index])
    result = batch.replay(stamps, np.full((200, 1), 0.5), stamps[np.argsort(
        arrivals, kind='stable')], outputs[np.argsort(arrivals, kind='stable')])
    assert result.estimates.tobytes() == np.array([s.estimate for s in samples]).tobytes()
    assert live.counters['reruns'] == batch.counters['reruns'] > 0
    with pytest.raises(ValueError, match='replay_events'):
        EventStream(estimator('kalman'), SECOND_NS, sources=TWO).replay([], [], [], [])


def test_an_input_that_comes_after_its_rows_were_taken_runs_them_again():
    # The node's input wait ran out (a flush): the rows took the latest earlier input. When
    # the input comes, the rows it belongs to are taken again: as if it had been in time.
    late = EventStream(estimator('time_varying'), SECOND_NS, sources=TWO, history_ns=SECOND_NS)
    timely = EventStream(estimator('time_varying'), SECOND_NS, sources=TWO,
                         history_ns=SECOND_NS)
    for k in range(30):
        stamp = SECOND_NS + k * 10 * MS
        u = [math.sin(k)]
        timely.add_input(stamp, u)
        timely.add_measurement(stamp, [0.1 * k], source='twist')
        if k in (10, 11, 12):  # their inputs come 30 ms late
            late.add_measurement(stamp, [0.1 * k], source='twist')
            late.flush()
            continue
        late.add_input(stamp, u)
        if k in (13, 14, 15):
            late.add_input(stamp - 30 * MS, [math.sin(k - 3)])
        late.add_measurement(stamp, [0.1 * k], source='twist')
    assert late.counters['late_input'] and late.counters['input_reruns'] == 3
    assert fingerprint(late.history()) == fingerprint(timely.history())


def test_the_python_example_of_the_doc_page_runs():
    page = pathlib.Path(__file__).resolve().parents[1] / 'doc' / 'measurement_sources.md'
    blocks = re.findall(r'```python\n(.*?)```', page.read_text(encoding='utf-8'), re.S)
    assert blocks
    for block in blocks:
        exec(compile(block, str(page), 'exec'), {})  # noqa: S102 - the page's own example
