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

"""Pairing inputs with measurements by stamp, and bad stamps, without ROS."""

import numpy as np
import pytest

from observer_ros.core import make_estimator
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers.full_order.design import design_full_order
from observer_ros.core.simulation import PlantSimulator
from observer_ros.core.streaming import EventStream
from observer_ros.core.units import NANOSECONDS

PERIOD_NS = 10_000_000


def double_integrator():
    model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    return model, design_full_order(model, poles=[-4, -5])


def simulated(count, inputs):
    model, _ = double_integrator()
    plant = PlantSimulator(model, [1.0, -0.5])
    ys = []
    for k in range(count):
        ys.append(plant.measure())
        plant.step(inputs[k], PERIOD_NS / 1e9)
    return np.array(ys)


def stream(max_gap=NANOSECONDS, stamped=True):
    _, design = double_integrator()
    return EventStream(make_estimator(design), max_gap, stamped)


def reference_estimates(ys, inputs):
    _, design = double_integrator()
    estimator = make_estimator(design)
    out = []
    for k, y in enumerate(ys):
        u = inputs[k - 1] if k else np.zeros(1)
        out.append(estimator.update(NANOSECONDS + k * PERIOD_NS, y, u).copy())
    return np.array(out)


def test_input_of_the_interval_is_the_one_stamped_at_the_previous_sample():
    inputs = np.sin(np.arange(50))[:, None]
    ys = simulated(50, inputs)
    expected = reference_estimates(ys, inputs)
    s = stream()
    got = []
    for k in range(50):
        stamp = NANOSECONDS + k * PERIOD_NS
        got += s.add_input(stamp, inputs[k])  # the plant publishes u_k with y_k
        got += s.add_measurement(stamp, ys[k])
    assert np.array_equal(np.array([g.estimate for g in got]), expected)
    assert s.counters['estimates'] == 50 and s.pending == 0


def test_a_future_input_never_leaks_into_the_past_and_late_inputs_release_waiting_samples():
    inputs = np.linspace(-1, 1, 20)[:, None]
    ys = simulated(20, inputs)
    expected = reference_estimates(ys, inputs)
    s = stream()
    got = s.add_input(NANOSECONDS, inputs[0]) + s.add_measurement(NANOSECONDS, ys[0])
    for k in range(1, 20):
        stamp = NANOSECONDS + k * PERIOD_NS
        got += s.add_measurement(stamp, ys[k])   # y_k before u_k: its interval needs u_(k-1)
        got += s.add_input(stamp, inputs[k])
    assert np.array_equal(np.array([g.estimate for g in got]), expected)


def test_measurement_waits_for_its_input_then_flush_uses_the_latest_earlier_one():
    s = stream()
    t = [NANOSECONDS + k * PERIOD_NS for k in range(4)]
    assert len(s.add_input(t[0], [1.0]) + s.add_measurement(t[0], [1.0])) == 1
    assert len(s.add_measurement(t[1], [1.0])) == 1   # its input (stamped t0) is here
    assert s.add_measurement(t[2], [1.0]) == []       # needs the input stamped t1
    assert s.add_measurement(t[3], [1.0]) == []
    assert s.pending == 2
    released = s.add_input(t[1], [3.0])
    assert [r.stamp_ns for r in released] == [t[2]]    # t3 still needs the input of t2
    assert s.pending == 1
    flushed = s.flush()
    assert [r.stamp_ns for r in flushed] == [t[3]]
    assert s.counters['late_input'] == 1


def test_unstamped_inputs_never_make_measurements_wait():
    s = stream(stamped=False)
    s.add_measurement(NANOSECONDS, [0.0])
    assert len(s.add_measurement(NANOSECONDS + PERIOD_NS, [0.0])) == 1


@pytest.mark.parametrize('offset,counter', [(0, 'duplicate'), (-PERIOD_NS, 'out_of_order')])
def test_duplicate_and_out_of_order_measurements_are_dropped(offset, counter):
    s = stream(stamped=False)
    for k in range(3):
        s.add_measurement(NANOSECONDS + k * PERIOD_NS, [1.0])
    before = s.estimator.estimate
    assert s.add_measurement(NANOSECONDS + 2 * PERIOD_NS + offset, [50.0]) == []
    assert s.counters[counter] == 1
    assert np.array_equal(s.estimator.estimate, before)
    assert s.events and s.events[-1][0] == counter


@pytest.mark.parametrize('jump,counter', [(-5 * NANOSECONDS, 'restart_backward_jump'),
                                          (5 * NANOSECONDS, 'restart_gap')])
def test_long_jumps_restart_from_the_current_estimate(jump, counter):
    s = stream(stamped=False)
    for k in range(5):
        s.add_measurement(10 * NANOSECONDS + k * PERIOD_NS, [1.0])
    before = s.estimator.estimate
    out = s.add_measurement(10 * NANOSECONDS + 4 * PERIOD_NS + jump, [1.0])
    assert len(out) == 1 and s.counters[counter] == 1
    assert np.all(np.isfinite(out[0].estimate))
    np.testing.assert_array_equal(out[0].estimate, before)  # full order: restart keeps x_hat
    nxt = s.add_measurement(10 * NANOSECONDS + 5 * PERIOD_NS + jump, [1.0])
    assert len(nxt) == 1


def test_reset_returns_to_the_initial_state():
    s = stream(stamped=False)
    for k in range(5):
        s.add_measurement(NANOSECONDS + k * PERIOD_NS, [2.0])
    s.reset()
    out = s.add_measurement(2 * NANOSECONDS, [2.0])
    # Unpinned: the first measurement initialises the measured state (C = [1, 0]).
    np.testing.assert_array_equal(out[0].estimate, [2.0, 0.0])
    np.testing.assert_array_equal(out[0].innovation, [2.0])
    _, design = double_integrator()
    pinned = EventStream(make_estimator(design, initial_state=[0.5, 1.0]), NANOSECONDS,
                         False)
    for k in range(5):
        pinned.add_measurement(NANOSECONDS + k * PERIOD_NS, [2.0])
    pinned.reset()
    out = pinned.add_measurement(2 * NANOSECONDS, [2.0])
    np.testing.assert_array_equal(out[0].estimate, [0.5, 1.0])
    np.testing.assert_array_equal(out[0].innovation, [1.5])  # y - C x0, not zero


@pytest.mark.parametrize('looping', [False, True])
@pytest.mark.parametrize('seed', range(4))
def test_batch_replay_equals_the_live_stream_bit_for_bit(seed, looping):
    # Messy recorded streams: jitter, duplicates, out-of-order samples, a long gap, a
    # backward jump, inputs at other stamps than the measurements, NaN rows.
    rng = np.random.default_rng(seed)
    count = 300
    stamps = NANOSECONDS + np.cumsum(rng.integers(5, 15, size=count) * 1_000_000)
    stamps[100] = stamps[99]                        # duplicate
    stamps[150] = stamps[148] - 1_000_000           # out of order
    stamps[200:] += 3 * NANOSECONDS                   # gap
    if looping:
        stamps[250:] -= 10 * NANOSECONDS              # backward jump (a looping bag)
    outputs = rng.standard_normal((count, 1))
    outputs[50] = np.nan
    # Arrival order is recording order: u_k, then y_k, then (every third sample) an extra
    # input stamped 2 ms later.
    events = []
    for k in range(count):
        events.append((int(stamps[k]), 0, rng.standard_normal(1)))
        events.append((int(stamps[k]), 1, outputs[k]))
        if k % 3 == 0:
            events.append((int(stamps[k]) + 2_000_000, 0, rng.standard_normal(1)))
    events[40] = (events[40][0], events[40][1], np.array([np.inf]))
    live = stream()
    samples = []
    for stamp, kind, vector in events:
        if not np.all(np.isfinite(vector)):
            continue  # the node drops malformed messages before the stream sees them
        samples += (live.add_input if kind == 0 else live.add_measurement)(stamp, vector)
    samples += live.flush()
    batch = stream()
    input_stamps = [stamp for stamp, kind, _ in events if kind == 0]
    inputs = np.array([vector for _, kind, vector in events if kind == 0])
    if looping:
        with pytest.raises(ValueError, match='arrival'):
            stream().replay(input_stamps, inputs, stamps, outputs)
        input_arrivals = [position for position, event in enumerate(events) if event[1] == 0]
        arrivals = [position for position, event in enumerate(events) if event[1] == 1]
        result = batch.replay(input_stamps, inputs, stamps, outputs, input_arrivals, arrivals)
    else:
        result = batch.replay(input_stamps, inputs, stamps, outputs)
    assert np.array_equal(result.stamps_ns, [s.stamp_ns for s in samples])

    assert np.array_equal(result.estimates, np.array([s.estimate for s in samples]))
    assert np.array_equal(result.innovations, np.array([s.innovation for s in samples]))
    assert np.all(np.isfinite(result.estimates))
    assert batch.counters['malformed'] == 2
    assert live.counters['out_of_order'] == 1 and live.counters['restart_gap'] == 1
    assert live.counters['restart_backward_jump'] == int(looping)
    for key in ('duplicate', 'out_of_order', 'restart_gap', 'restart_backward_jump',
                'estimates'):
        assert batch.counters[key] == live.counters[key], key
