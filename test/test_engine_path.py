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
One event's path through the engine (issue 29): its work per update, and the same results.

Benchmark section 9 times an update with sources against the bare filter; its figures
depend on the machine and its load. What the engine does per update does not: the Python
calls it makes beside the filter's own are counted here (53 before issue 29's engine work,
33 after). The common cases taken inline (the value rule of admission and publication, the
filter's snapshot without its prior) are checked against the general rules.
"""

import gc
import math
import sys

import numpy as np
import pytest

from observer_ros.core import design_kalman, make_estimator, StateSpaceModel
from observer_ros.core.events import EventEngine
from observer_ros.core.rules import ValueLimits, within_limit
from observer_ros.core.sources import MeasurementSource
from observer_ros.core.streaming import EventStream

MS = 1_000_000
SECOND = 1_000_000_000

#: Python calls of the engine per update with sources (an input, then a measurement),
#: beside the filter's own: 53 before issue 29's engine work, 34 after; a little room.
CALL_BUDGET = 35

#: Section 9's model: two mass-spring axes, positions and velocities measured.
AXIS = np.array([[0.0, 1.0], [-4.0, -0.4]])
MODEL = StateSpaceModel.from_matrices(
    np.kron(np.eye(2), AXIS), np.kron(np.eye(2), [[0.0], [1.0]]),
    [[1, 0, 0, 0], [0, 0, 1, 0], [0, 1, 0, 0], [0, 0, 0, 1]])
ENCODERS = MeasurementSource('encoders', (2, 3))
CAMERA = MeasurementSource('camera', (0, 1))


def kalman():
    """Return section 9's time-varying Kalman filter."""
    design = design_kalman(MODEL, [0.0, 1.0, 0.0, 1.0], [1e-4] * 4)
    return make_estimator(design, time_varying=True, interval_resolution_ns=10_000)


def samples(count: int) -> list:
    """``(stamp, u, y)`` of the encoders at 1 kHz, seeded."""
    rng = np.random.default_rng(29)
    return [(SECOND + k * MS, rng.standard_normal(2), rng.standard_normal(2))
            for k in range(count)]


def python_calls(run) -> int:
    """Return the number of Python-level calls ``run()`` makes."""
    calls = 0

    def profile(frame, event, arg):
        nonlocal calls
        calls += event == 'call'

    # No collection in between: a finalizer (__del__, a weakref callback) of another test's
    # objects would be counted too (36 calls in a whole run where this module alone made 34).
    enabled = gc.isenabled()
    gc.disable()
    sys.setprofile(profile)
    try:
        run()
    finally:
        sys.setprofile(None)
        if enabled:
            gc.enable()
    return calls


def test_an_update_with_sources_costs_the_engine_at_most_its_call_budget():
    stream = EventStream(kalman(), SECOND, sources=(ENCODERS, CAMERA), history_ns=500 * MS)
    bare = kalman()
    rows = samples(600)  # more than the history: the oldest entries are pruned
    for stamp, u, y in rows[:-1]:
        stream.add_input(stamp, u)
        stream.add_measurement(stamp, y, source='encoders')
        bare.advance_outputs(stamp, y, u, ENCODERS.outputs)
    stamp, u, y = rows[-1]

    def update():
        stream.add_input(stamp, u)
        assert len(stream.add_measurement(stamp, y, source='encoders')) == 1

    engine_and_filter = python_calls(update)
    filter_alone = python_calls(lambda: bare.advance_outputs(stamp, y, u, ENCODERS.outputs))
    assert engine_and_filter - filter_alone <= CALL_BUDGET


VALUES = [[0.5, -0.25], [3.0, -3.0], [3.0, 3.5], [math.nan, 0.0], [math.inf, 0.0],
          [-math.inf, 1.0], [1e308, 1e308], [-1e308, -1e308], [0.0, 0.0]]


@pytest.mark.parametrize('limit', [math.inf, 3.0, 1e308])
@pytest.mark.parametrize('values', VALUES)
def test_admission_inline_agrees_with_the_value_rule(values, limit):
    engine = EventEngine(n_outputs=2, n_inputs=2, max_gap_ns=SECOND,
                         limits=ValueLimits(measurement=limit, input=limit))
    with np.errstate(over='ignore'):
        expected = within_limit(np.array(values), limit)
        for source in ('y', 'u'):
            assert engine.accept(engine.sources[source], 0, np.array(values), None) is expected


@pytest.mark.parametrize('limit', [math.inf, 2.0, 1e300])
@pytest.mark.parametrize('value', [0.5, 1.5, 2.5, -3.0, 1e200, -1e300])
def test_publication_inline_agrees_with_the_value_rule(value, limit):
    """An estimate or innovation beyond its limit restarts the filter, as the rule says."""
    model = StateSpaceModel.from_matrices([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]],
                                          [[1.0, 0.0], [0.0, 1.0]])
    design = design_kalman(model, [0.0, 1.0], [1e-4, 1e-4])
    limits = ValueLimits(estimate=limit, innovation=limit)
    sources = (MeasurementSource('a', (0,)), MeasurementSource('b', (1,)))
    stream = EventStream(make_estimator(design, time_varying=True), SECOND, limits=limits,
                         sources=sources)
    twin = make_estimator(design, time_varying=True)
    with np.errstate(over='ignore', invalid='ignore'):
        twin.advance_outputs(0, np.array([value]), np.zeros(1), (0,))
        expected = (within_limit(twin.estimate, limit)
                    and within_limit(twin.innovation, limit))
        stream.add_input(0, [0.0])
        produced = stream.add_measurement(0, [value], source='a')
    assert bool(produced) is expected
    assert stream.counters['estimate_reset'] == (0 if expected else 1)


def test_a_snapshot_after_the_first_sample_restores_to_the_same_numbers():
    """The prior is not kept after a first sample: a reset or restart sets it again."""
    rows = samples(8)
    straight, restored = kalman(), kalman()
    for stamp, u, y in rows[:4]:
        straight.advance_outputs(stamp, y, u, ENCODERS.outputs)
        restored.advance_outputs(stamp, y, u, ENCODERS.outputs)
    state = restored.snapshot()
    for stamp, u, y in rows[4:6]:
        restored.advance_outputs(stamp, y, u, ENCODERS.outputs)
    restored.restore(state)
    for filter_ in (straight, restored):
        filter_.restart()  # from the estimate held, P0 added
        for stamp, u, y in rows[6:]:
            filter_.advance_outputs(stamp, y, u, ENCODERS.outputs)
    assert restored.estimate.tolist() == straight.estimate.tolist()
    assert restored.covariance.tolist() == straight.covariance.tolist()
    first = kalman()
    stamp, u, y = rows[0]
    first.advance_outputs(stamp, y, u, ENCODERS.outputs)
    first.reset()
    state = first.snapshot()  # before a first sample: the prior is kept
    first.advance_outputs(stamp, y, u, ENCODERS.outputs)
    expected = first.estimate.tolist()
    first.restore(state)
    first.advance_outputs(stamp, y, u, ENCODERS.outputs)
    assert first.estimate.tolist() == expected
