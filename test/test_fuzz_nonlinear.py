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
Fuzz of every parameter of a model written as equations, and of its run time.

Hypothesis draws values for each of ``model.dynamics``, ``model.measurements``,
``model.constant_names``, ``model.constant_values``, ``model.operating_point_states``,
``model.operating_point_inputs`` and ``model.function`` (texts of any characters, code a
user should not run, numbers that are not finite, lists of the wrong length, names of the
wrong kind): the
configuration is either valid or refused with a :class:`ConfigError` naming a ``model.*``
parameter, never another exception, and nothing is evaluated. At run time, measurements
that drive the equations out of their domain (``sqrt``, ``log`` of a negative state) are
dropped and counted as ``nonfinite``; every estimate returned is finite.
"""

import math

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
from test_nonlinear_config import SYSTEM

from observer_ros.config import validate_parameters
from observer_ros.core.errors import ConfigError

CAMPAIGN = settings(max_examples=60, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))

NUMBERS = st.one_of(st.floats(allow_nan=True, allow_infinity=True), st.integers(-10, 10),
                    st.sampled_from([0.0, -0.0, 1e308, -1e308, 5e-324]))
TEXTS = st.one_of(
    st.text(max_size=30),
    st.sampled_from(['__import__("os").system("true")', 'x.__class__', 'lambda: 1', '[v]',
                     'v if w else px', 'open("f")', 'v ** 1e308', '1 / 0', 'sqrt(-1)',
                     'atan2(py)', 'sin(px, py)', 'v' * 400, 'cos(yaw) * ' * 50 + '1',
                     'px +', ')(', 'exp(exp(exp(v)))', 'min(px, py, v)', "'text'", '1e999',
                     'b', 'r', 'yaw', 'v_cmd']))
VALUES = {
    'model.dynamics': st.lists(TEXTS, max_size=7),
    'model.measurements': st.lists(TEXTS, max_size=8),
    'model.constant_names': st.lists(st.one_of(TEXTS, st.sampled_from(
        ['r', 'b', 'px', 'sin', 'pi', 'e', 'x0', '_k', 'k0'])), max_size=4),
    'model.constant_values': st.lists(NUMBERS, max_size=4),
    'model.operating_point_states': st.lists(NUMBERS, max_size=7),
    'model.operating_point_inputs': st.lists(NUMBERS, max_size=4),
    'model.function': TEXTS,
}


@CAMPAIGN
@given(st.fixed_dictionaries({}, optional=VALUES))
def test_every_parameter_of_the_equations_is_valid_or_refused_by_name(change):
    params = {**SYSTEM, **change}
    try:
        system = validate_parameters(params)
    except ConfigError as e:
        assert e.parameter.startswith(('model.', 'observer.', 'sources.')), str(e)
        return
    model = system.model
    assert np.isfinite(model.a).all() and np.isfinite(model.c).all()
    assert model.nonlinear.n_states == model.n_states == 5


@CAMPAIGN
@given(st.lists(st.tuples(st.integers(1, 200_000_000), st.sampled_from(['root', 'log']),
                          NUMBERS), min_size=1, max_size=30))
def test_values_that_leave_the_domain_are_dropped_and_counted_never_returned(samples):
    system = validate_parameters({
        'model.state_names': ['q', 'dq'], 'model.input_names': ['u'],
        'model.dynamics': ['dq', 'u - q'], 'model.output_names': ['root', 'logarithm'],
        'model.measurements': ['sqrt(q)', 'log(q)'], 'model.operating_point_states': [1, 0],
        'observer.type': 'extended_kalman', 'observer.process_noise': [1e-3, 1e-1],
        'observer.history': 0.0, 'observer.initial_state': [1.0, 0.0],
        'observer.sources': ['root', 'log'], 'sources.root.fields': ['position.a'],
        'sources.root.outputs': ['root'], 'sources.root.measurement_noise': [1e-2],
        'sources.log.fields': ['position.b'], 'sources.log.outputs': ['logarithm'],
        'sources.log.measurement_noise': [1e-2]})
    stream = system.make_stream()
    stamp, returned = 0, []
    returned += stream.add_input(0, [0.0])
    for interval, source, value in samples:
        stamp += interval
        returned += stream.add_input(stamp, [float(np.clip(np.nan_to_num(value), -1e3, 1e3))])
        returned += stream.add_measurement(stamp, [value], source=source)
    for sample in returned:
        assert np.isfinite(sample.estimate).all()
        assert sample.covariance is None or np.isfinite(sample.covariance).all()
    assert math.isfinite(stream.estimator.estimate.sum())
