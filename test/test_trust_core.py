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
What no input may do to the core: bad values, bad stamps and bad parameters.

Every value a parameter can take is either refused with a reason naming it or runs; no
sample, however wrong, puts a non-finite or out-of-range value out or captures the timeline.
"""

import math
import re

import numpy as np
import pytest

from conftest import CONFIG_DIR
from observer_ros.config import (
    DOUBLE, INTEGER, load_parameter_file, PARAMETERS, validate_parameters)
from observer_ros.config.schema import node_parameters, OBSERVER, PLANT
from observer_ros.core import make_estimator
from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.observers.full_order.design import design_full_order
from observer_ros.core.simulation import PlantSimulator
from observer_ros.core.streaming import EventStream, ValueLimits
from observer_ros.core.units import NANOSECONDS

PERIOD_NS = 10_000_000
SEED003 = load_parameter_file(str(CONFIG_DIR / 'seed003_full_order.yaml'))
KALMAN = load_parameter_file(str(CONFIG_DIR / 'kalman_noisy.yaml'))


def double_integrator_stream(**kwargs):
    model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    design = design_full_order(model, poles=[-4, -5])
    return EventStream(make_estimator(design), NANOSECONDS, **kwargs), model


def samples(count, seed=0):
    """Stamps, inputs and outputs of the double integrator under random inputs."""
    model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    rng = np.random.default_rng(seed)
    plant = PlantSimulator(model, [1.0, -0.5])
    rows = []
    for k in range(count):
        u = rng.uniform(-1, 1, size=1)
        rows.append((NANOSECONDS + k * PERIOD_NS, u, plant.measure().copy()))
        plant.step(u, PERIOD_NS / 1e9)
    return rows


def clean_run(rows):
    stream, _ = double_integrator_stream()
    out = []
    for stamp, u, y in rows:
        stream.add_input(stamp, u)
        out += stream.add_measurement(stamp, y)
    return [(s.stamp_ns, s.estimate.copy()) for s in out]


def as_arrays(out):
    return [s.stamp_ns for s in out], np.array([s.estimate for s in out])


# --- parameters ---------------------------------------------------------------------------

RANGED = [spec for spec in PARAMETERS if spec.value_type in (DOUBLE, INTEGER)
          and (spec.low is not None or spec.high is not None)]


def outside(spec):
    """Values just outside the range of ``spec``, and far outside."""
    values = []
    if spec.low is not None:
        values += [spec.low if spec.low_open else spec.low - max(abs(spec.low) * 1e-3, 1),
                   -1e300 if spec.value_type == DOUBLE else -2 ** 63]
    if spec.high is not None:
        values += [spec.high + max(abs(spec.high) * 1e-3, 1),
                   1e300 if spec.value_type == DOUBLE else 2 ** 63 - 1]
    values = [int(v) if spec.value_type == INTEGER else v for v in values]
    low = -math.inf if spec.low is None else spec.low
    high = math.inf if spec.high is None else spec.high
    return [v for v in values if v < low or v > high or (spec.low_open and v == low)]


def test_every_number_parameter_has_a_range():
    for spec in PARAMETERS:
        if spec.value_type in (DOUBLE, INTEGER):
            assert spec in RANGED, spec.name


@pytest.mark.parametrize('spec', RANGED, ids=[spec.name for spec in RANGED])
def test_a_number_outside_its_range_is_refused_naming_the_parameter(spec):
    for value in outside(spec):
        params = dict(KALMAN if spec.name.startswith('observer.') else SEED003,
                      **{spec.name: value})
        with pytest.raises(ConfigError, match=f'^{spec.name}: expected'):
            validate_parameters(params)


@pytest.mark.parametrize('name,value,reason', [
    ('feedback.timeout', 3e10, r'^feedback\.timeout: expected seconds in \[0\.001, 3600\]'),
    ('feedback.timeout', 1e-9, r'^feedback\.timeout: expected seconds'),
    ('observer.chen_seed', -1, r'^observer\.chen_seed: expected a seed in \[0, '),
    ('plant.seed', -1, r'^plant\.seed: expected a seed'),
    ('plant.rate_hz', 1e-300, r'^plant\.rate_hz: expected 0 \(the model rate\) or a rate'),
    ('observer.poles', ['zeta=nan, wn=10'], r'^observer\.poles: damping ratio'),
    ('feedback.poles', ['zeta=0.5, wn=nan'], r'^feedback\.poles: damping ratio'),
    ('feedback.poles', ['zeta=-1, wn=3'], r'^feedback\.poles: expected zeta >= 0'),
    ('observer.poles', ['-1e300', '-2'], r'^observer\.poles: poles .* exceed 1e\+09'),
    ('feedback.poles', ['-1', '-1e12'], r'^feedback\.poles: poles .* exceed'),
    ('observer.initial_state', [1e10, 0.0], r'^observer\.initial_state: expected entries'),
    ('observer.gain', [1e300, 1.0], r'^observer\.gain: expected entries of magnitude'),
    ('feedback.safe_command', [5.0], r'^feedback\.safe_command: \[5\.0\] lies outside '
                                     r'feedback\.input_limits'),
    ('topics.y.limit', 0.0, r'^topics\.y\.limit: expected a value in'),
])
def test_values_that_break_the_loop_are_refused(name, value, reason):
    params = dict(SEED003, **{name: value})
    if name == 'feedback.safe_command':
        params['feedback.input_limits'] = [-1.0, 1.0]
    with pytest.raises(ConfigError, match=reason):
        validate_parameters(params)


#: ``(parameter, value, expected, a rate in Hz it works at)``: a time valid alone that
#: cannot work at 100 Hz.
AGAINST_THE_PERIOD = [
    # before: accepted, and every 10 ms interval was designed as 0.5 s (the loop diverged)
    ('observer.interval_resolution', 0.5, r'0 \(exact intervals\) or seconds below one '
                                          r'sample period', 1.0),
    # before: accepted, and the safe command won 198 of 200 samples
    ('feedback.timeout', 0.001, 'more than one sample period', 2000.0),
    ('observer.max_gap', 0.005, 'more than one sample period', 1000.0),  # restarts
    ('diagnostics.stale_timeout', 0.01, r'0 \(automatic\) or more than one sample period',
     1000.0),
    ('plant.command_timeout', 0.01, 'more than one sample period', None),
]


@pytest.mark.parametrize('name,value,expected,works_at', AGAINST_THE_PERIOD,
                         ids=[case[0] for case in AGAINST_THE_PERIOD])
def test_a_time_that_cannot_work_at_the_sample_period_is_refused(name, value, expected,
                                                                 works_at):
    with pytest.raises(ConfigError, match=rf'^{re.escape(name)}: expected {expected} \(0\.01 '
                                          rf's at 100 Hz, from plant\.rate_hz\), got '
                                          rf'{re.escape(str(value))}: '):
        validate_parameters(dict(SEED003, **{name: value}))
    if works_at is None:  # the plant's own timeout follows the plant's rate only
        return
    # The period is the inputs' expected rate when one is set ...
    validate_parameters(dict(SEED003, **{name: value, 'diagnostics.expected_rate': works_at}))
    # ... and without any rate a continuous model's 100 Hz is assumed, saying so.
    unknown = {key: item for key, item in SEED003.items() if key != 'plant.rate_hz'}
    with pytest.raises(ConfigError, match='from the 100 Hz assumed for a continuous '
                                          'model; set diagnostics.expected_rate'):
        validate_parameters(dict(unknown, **{name: value}))


def test_each_node_checks_its_own_times_against_the_period():
    # A discrete model at 1 Hz: the observer's own parameters are fine; the plant's
    # default command timeout (0.5 s) is below its period. Before, that default of a
    # parameter the observer does not declare refused the observer itself.
    model = {'model.A': [0.5], 'model.B': [1.0], 'model.C': [1.0], 'model.dt': 1.0,
             'observer.poles': ['0.1'], 'observer.max_gap': 5.0}
    observer = {spec.name: spec.default for spec in node_parameters(OBSERVER)}
    system = validate_parameters(dict(observer, **model))
    assert system.plant.rate_hz == 1.0
    plant = {spec.name: spec.default for spec in node_parameters(PLANT)}
    with pytest.raises(ConfigError, match=r'^plant\.command_timeout: expected more than one '
                                          r'sample period \(1 s at 1 Hz, from model\.dt\)'):
        validate_parameters(dict(plant, **model))
    # The observer's default gap (1 s) is one period at 1 Hz: every interval a restart.
    del model['observer.max_gap']
    with pytest.raises(ConfigError, match=r'^observer\.max_gap: expected more than one'):
        validate_parameters(dict(observer, **model))


def test_integral_outputs_that_can_have_no_effect_are_refused():
    without_inputs = {'model.A': [0.0, 1.0, -2.0, -3.0], 'model.B': [], 'model.C': [1.0, 0.0],
                      'observer.poles': ['-5', '-6'], 'feedback.integral_outputs': ['y1']}
    # before: accepted silently
    with pytest.raises(ConfigError, match=r'^feedback\.integral_outputs: the model has no '
                                          r'inputs \(model\.B is empty, m = 0\)'):
        validate_parameters(without_inputs)
    without_feedback = dict(without_inputs, **{'model.B': [0.0, 1.0]})
    with pytest.raises(ConfigError, match=r'^feedback\.integral_outputs: integral action '
                                          r'needs the state feedback'):
        validate_parameters(without_feedback)


@pytest.mark.parametrize('name,value,shown', [
    ('feedback.timeout', 3600.001, '3600.001'),  # before: "got 3600"
    ('feedback.timeout', 3600.0000000000005, '3600.0000000000005'),
    ('observer.max_gap', 1000000.1, '1000000.1'),  # before: "got 1e+06"
    ('plant.seed', 2 ** 63, '9223372036854775808'),  # before: "got 9.22337e+18"
    ('observer.gain', [1e12 + 1.0, 0.0], '1000000000001.0'),  # an entry beyond its limit
])
def test_a_refusal_shows_the_value_as_given(name, value, shown):
    with pytest.raises(ConfigError, match=re.escape(f'{shown}') + '$') as caught:
        validate_parameters(dict(SEED003, **{name: value}))
    assert caught.value.parameter == name
    if name == 'plant.seed':
        assert '[0, 9223372036854775807]' in str(caught.value)  # the range exact too


def test_a_numeric_breakdown_in_a_design_is_a_refusal_not_a_crash():
    # A tiny pole next to a huge one overflowed the placement (LinAlgError) before.
    for method in ('auto', 'place', 'acker'):
        params = dict(SEED003, **{'observer.poles': ['-1e-300', '-1e9'],
                                  'observer.method': method})
        try:
            system = validate_parameters(params)
        except ConfigError as e:
            assert str(e).startswith('observer.poles: ')
        else:
            assert system.observer is not None


def test_sampling_that_merges_fast_poles_still_runs_with_a_single_pole_method():
    # exp(lambda dt) is 0 for both poles at 10 ms: 'place' refuses repeated poles, so the
    # sampled design takes 'auto'; before, every sample raised inside the callback.
    system = validate_parameters(dict(SEED003, **{'observer.poles': ['-1e9', '-1e6'],
                                                  'observer.method': 'place'}))
    stream = system.make_stream()
    out = []
    for stamp, u, y in samples(20):
        stream.add_input(stamp, u)
        out += stream.add_measurement(stamp, y)
    assert len(out) == 20 and np.isfinite(as_arrays(out)[1]).all()


# --- values and stamps --------------------------------------------------------------------

def test_a_huge_measurement_is_dropped_and_leaves_no_trace():
    rows = samples(40)
    stream, _ = double_integrator_stream(limits=ValueLimits(measurement=1e9))
    out = []
    for k, (stamp, u, y) in enumerate(rows):
        stream.add_input(stamp, u)
        if k == 10:  # before: x_hat went to 2.8e307 and stayed near 1e300
            assert stream.add_measurement(stamp, [1e308]) == []
            assert stream.add_measurement(stamp, [math.nan]) == []
        out += stream.add_measurement(stamp, y)
    assert stream.counters['out_of_range'] == 1 and stream.counters['malformed'] == 1
    expected = clean_run(rows)
    assert [s for s, _ in expected] == as_arrays(out)[0]
    assert np.array_equal(np.array([e for _, e in expected]), as_arrays(out)[1])


def test_an_estimate_beyond_its_limit_is_never_returned():
    stream, _ = double_integrator_stream(limits=ValueLimits(estimate=0.9))
    out = []
    for stamp, u, y in samples(30):
        stream.add_input(stamp, u)
        out += stream.add_measurement(stamp, y)
    assert stream.counters['estimate_reset'] > 0
    assert all(np.abs(s.estimate).max() <= 0.9 for s in out)


def test_a_measurement_far_ahead_of_the_clock_cannot_capture_the_timeline():
    rows = samples(60)
    stream, _ = double_integrator_stream(clock_tolerance_ns=NANOSECONDS // 2)
    out = []
    for k, (stamp, u, y) in enumerate(rows):
        now = stamp + 1_000_000  # the receiver's clock, 1 ms after the sample
        stream.add_input(stamp, u, now)
        if k == 20:  # before: the next 0.9 s of samples were dropped as out of order
            assert stream.add_measurement(stamp + 900_000_000, y, now) == []
        out += stream.add_measurement(stamp, y, now)
    assert stream.counters['future_stamp'] == 1
    assert stream.counters['out_of_order'] == 0
    expected = clean_run(rows)
    assert as_arrays(out)[0] == [s for s, _ in expected]
    assert np.array_equal(as_arrays(out)[1], np.array([e for _, e in expected]))


def test_an_input_stamped_in_the_future_is_dropped_and_the_right_inputs_are_used():
    rows = samples(60)
    stream, _ = double_integrator_stream(clock_tolerance_ns=NANOSECONDS // 2)
    out = []
    for k, (stamp, u, y) in enumerate(rows):
        now = stamp + 1_000_000
        if k == 5:  # before: every later step used an earlier input, late_input stayed 0
            assert stream.add_input(stamp + 100 * NANOSECONDS, [3.0], now) == []
        out += stream.add_measurement(stamp, y, now)  # y before its u: waits for it
        out += stream.add_input(stamp, u, now)
    assert stream.counters['future_stamp'] == 1 and stream.counters['late_input'] == 0
    assert np.array_equal(as_arrays(out)[1], np.array([e for _, e in clean_run(rows)]))


def test_the_clock_check_is_off_without_a_clock_or_a_tolerance():
    stream, _ = double_integrator_stream(clock_tolerance_ns=NANOSECONDS // 2)
    assert len(stream.add_measurement(50 * NANOSECONDS, [1.0], 0)) == 1  # sim time not yet set
    stream, _ = double_integrator_stream()
    assert len(stream.add_measurement(50 * NANOSECONDS, [1.0], NANOSECONDS)) == 1


@pytest.mark.parametrize('steady', [True, False])
def test_batch_replay_applies_the_same_value_and_clock_rules_as_the_stream(steady):
    rows = samples(80)
    stamps = np.array([r[0] for r in rows], dtype=np.int64)
    inputs = np.array([r[1] for r in rows])
    outputs = np.array([r[2] for r in rows])
    if not steady:
        stamps[30:] += 2 * NANOSECONDS  # a gap: the sample-by-sample path
    arrivals = stamps + 1_000_000
    outputs[7] = 1e12                          # out of range
    outputs[9] = math.nan                      # malformed
    stamps[11] += 5 * NANOSECONDS                # far ahead of its arrival
    inputs[13] = 1e12
    kwargs = {'clock_tolerance_ns': NANOSECONDS // 2,
              'limits': ValueLimits(measurement=1e9, input=1e9)}
    live, _ = double_integrator_stream(**kwargs)
    out = []
    for k in range(len(rows)):
        out += live.add_input(int(stamps[k] - (stamps[11] - arrivals[11] + 1_000_000
                                               if k == 11 else 0)), inputs[k],
                              int(arrivals[k]))
        out += live.add_measurement(int(stamps[k]), outputs[k], int(arrivals[k]))
    out += live.flush()
    batch, _ = double_integrator_stream(**kwargs)
    input_stamps = stamps.copy()
    input_stamps[11] = arrivals[11] - 1_000_000
    result = batch.replay(input_stamps, inputs, stamps, outputs, arrivals, arrivals)
    assert result.stamps_ns.tolist() == as_arrays(out)[0]
    assert np.array_equal(result.estimates, as_arrays(out)[1])
    for key in ('out_of_range', 'malformed', 'future_stamp'):
        assert batch.counters[key] == live.counters[key] == (2 if key == 'out_of_range' else 1)


def test_the_first_measurement_initialises_an_unpinned_estimate():
    stream, model = double_integrator_stream()
    first = stream.add_measurement(NANOSECONDS, [5015.0])[0]
    assert first.estimate.tolist() == [5015.0, 0.0]
    assert first.innovation.tolist() == [5015.0]   # y0 - C x0, was reported as 0
    system = validate_parameters(dict(SEED003, **{'observer.initial_state': [1.0, 2.0]}))
    pinned = system.make_stream().add_measurement(NANOSECONDS, [5015.0])[0]
    assert pinned.estimate.tolist() == [1.0, 2.0]
    assert pinned.innovation.tolist() == [5014.0]


def test_only_the_first_waiting_measurement_stops_waiting_on_flush():
    stream, _ = double_integrator_stream()
    stream.add_input(NANOSECONDS, [0.0])
    stream.add_measurement(NANOSECONDS, [0.0], arrival_ns=1)
    stream.add_measurement(NANOSECONDS + PERIOD_NS, [0.0], arrival_ns=2)
    assert stream.add_measurement(NANOSECONDS + 2 * PERIOD_NS, [0.0], arrival_ns=3) == []
    assert stream.add_measurement(NANOSECONDS + 3 * PERIOD_NS, [0.0], arrival_ns=4) == []
    first = stream.waiting()
    assert first[1] == 3
    assert len(stream.flush(first_only=True)) == 1
    assert stream.waiting()[1] == 4 and stream.waiting()[0] != first[0]


def test_every_tool_refuses_an_unknown_parameter_the_same_way(tmp_path):
    from observer_ros.bags.replay import replay_bag
    from observer_ros.tools.design_observer import main as design_main
    path = tmp_path / 'typo.yaml'
    path.write_text((CONFIG_DIR / 'seed003_full_order.yaml').read_text().replace(
        'poles:', 'polse:', 1))
    # before: replay_bag ignored the misspelt key and replayed without an observer change
    with pytest.raises(ConfigError, match=r'^observer\.polse: unknown parameter; did you mean '
                       r"'observer\.poles'\? \(every parameter: doc/parameters\.md\)"):
        replay_bag(tmp_path / 'no_bag_needed', path)
    assert design_main([str(path)]) == 2


@pytest.mark.parametrize('vector,limit,inside', [
    ([2e300, 0.0], 1e300, False), ([math.inf, 0.0], 1e300, False),  # limit**2 overflows
    ([1e300, -1e300], 1e300, True), ([math.nan], 1e300, False), ([1e200], 1e160, False),
    ([3.0, 4.0], 4.0, True), ([3.0, 4.5], 4.0, False), ([], 1.0, True)])
def test_the_limit_check_is_exact_for_every_limit(vector, limit, inside):
    from observer_ros.core.rules import within_limit
    assert within_limit(np.array(vector, dtype=float), limit) is inside


def count_steady_steps(stream) -> list:
    """Count the estimates the stream's steady fast path makes (a list of one count)."""
    taken = [0]
    step = stream._steady_step

    def counting(*args):
        result = step(*args)
        taken[0] += bool(result)
        return result

    stream._steady_step = counting
    return taken


def node_like(stream, events):
    """Feed ``events`` as the observer node does: values as lists, prepared after estimates."""
    out = []
    for kind, stamp, value, now in events:
        if kind == 'u':
            out += [(s.stamp_ns, s.estimate) for s in stream.add_input(stamp, value, now)]
            continue
        samples = stream.add_measurement(stamp, [float(v) for v in value], now)
        out += [(s.stamp_ns, np.array(s.estimate)) for s in samples]
        stream.prepare()
    out += [(s.stamp_ns, s.estimate) for s in stream.flush()]
    return out


def general(stream, events):
    out = []
    for kind, stamp, value, now in events:
        add = stream.add_input if kind == 'u' else stream.add_measurement
        out += [(s.stamp_ns, s.estimate) for s in add(stamp, value, now)]
    out += [(s.stamp_ns, s.estimate) for s in stream.flush()]
    return out


@pytest.mark.parametrize('messy', [False, True])
@pytest.mark.parametrize('seed', [0, 1, 2])
def test_the_steady_path_the_general_path_and_the_batch_replay_agree(messy, seed):
    rng = np.random.default_rng(seed)
    rows = samples(300, seed)
    events = []
    stamp = NANOSECONDS
    for k, (_, u, y) in enumerate(rows):
        if messy and rng.random() < 0.2:
            stamp += int(PERIOD_NS * rng.uniform(0.5, 1.5))  # jitter
        else:
            stamp += PERIOD_NS
        if messy and rng.random() < 0.02:
            stamp += 2 * NANOSECONDS  # a gap beyond observer.max_gap
        value = y.copy()
        if messy and rng.random() < 0.03:
            value = np.array([rng.choice([1e12, math.nan])])
        events.append(('u', stamp, u, stamp + 1))
        events.append(('y', stamp, value, stamp + 1))
        if messy and rng.random() < 0.03:
            events.append(('y', stamp - PERIOD_NS // 2, y, stamp + 1))  # out of order
    kwargs = {'clock_tolerance_ns': NANOSECONDS // 2, 'limits': ValueLimits(1e9, 1e9, 1e9, 1e9)}
    fast, _ = double_integrator_stream(**kwargs)
    slow, _ = double_integrator_stream(fast_paths=False, **kwargs)
    taken = count_steady_steps(fast)
    got, expected = node_like(fast, events), general(slow, events)
    assert taken[0] > (100 if messy else 280)  # the fast path did the work
    assert [s for s, _ in got] == [s for s, _ in expected]
    assert np.array_equal(np.array([e for _, e in got]), np.array([e for _, e in expected]))
    assert fast.counters == slow.counters
    batch, _ = double_integrator_stream(**kwargs)
    inputs = [e for e in events if e[0] == 'u']
    outputs = [e for e in events if e[0] == 'y']
    result = batch.replay([e[1] for e in inputs], [e[2] for e in inputs],
                          [e[1] for e in outputs], [e[2] for e in outputs],
                          [e[3] for e in inputs], [e[3] for e in outputs])
    assert result.stamps_ns.tolist() == [s for s, _ in expected]
    assert np.array_equal(result.estimates, np.array([e for _, e in expected]))


@pytest.mark.parametrize('largest_y', [0.0, 1.0, 1e3, 1e300, math.inf, math.nan])
@pytest.mark.parametrize('limit', [1e-3, 10.0, 1e9, math.inf])
def test_the_prepared_step_s_bound_is_the_array_rule_s(largest_y, limit):
    # prepare says whether every y within largest_y keeps the result within limit, as
    # isfinite(|known| + |g_y| largest_y).all() and its max <= limit on arrays (numpy's
    # operations); it computes that on Python floats, which must give the same answer.
    stream, _ = double_integrator_stream()
    estimator = stream.estimator
    for stamp, u, y in samples(5):
        stream.add_input(stamp, u)
        stream.add_measurement(stamp, y)
    seen = set()
    for scale in (1.0, 1e200, -1e308):
        u = np.array([scale])
        estimator._prepared = None
        estimator.prepare(u, (largest_y, limit))
        known, step = estimator._prepared[3], estimator._prepared[2]
        reach = np.abs(known) + np.abs(step.g_y_column) * largest_y
        expected = bool(np.isfinite(reach).all() and reach.max() <= limit)
        assert estimator._prepared[6] is expected, (scale, reach)
        seen.add(expected)
    if largest_y == 1.0 and limit == 1e9:
        assert seen == {True, False}  # both answers are reached
