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
A nonlinear model from equations: exact Jacobians, exact numbers, errors naming the part.

The Jacobians SymPy derives are compared with the ones written by hand for the
differential-drive base; every number of the expressions reaches the generated functions
with its exact binary value; a value outside a function's domain gives NaN (which the
filters drop and count), never an exception.
"""

import math

import numpy as np
import pytest

from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.nonlinear import (
    differential_drive, ExpressionError, linear_as_expressions, NonlinearModel)

R, B = 0.05, 0.3


def test_the_differential_drive_jacobians_equal_the_ones_written_by_hand():
    model = differential_drive(R, B)
    rng = np.random.default_rng(1)
    for _ in range(20):
        x, u = rng.normal(size=5), rng.normal(size=2)
        px, py, yaw, v, w = x
        f, jacobian = model.f_and_jacobian(x, u)
        np.testing.assert_allclose(f, [v * math.cos(yaw), v * math.sin(yaw), w, u[0], u[1]],
                                   rtol=1e-15, atol=0)
        expected = np.zeros((5, 5))
        expected[0, 2], expected[0, 3] = -v * math.sin(yaw), math.cos(yaw)
        expected[1, 2], expected[1, 3] = v * math.cos(yaw), math.sin(yaw)
        expected[2, 4] = 1.0
        np.testing.assert_allclose(jacobian, expected, rtol=1e-15, atol=0)
        h, h_jacobian = model.measurement()(x, u)
        np.testing.assert_allclose(h, [(v - w * B / 2) / R, (v + w * B / 2) / R, w, px, py,
                                       yaw], rtol=1e-14)
        expected = np.zeros((6, 5))
        expected[0, 3:] = [1 / R, -B / 2 / R]
        expected[1, 3:] = [1 / R, B / 2 / R]
        expected[2, 4] = expected[3, 0] = expected[4, 1] = expected[5, 2] = 1.0
        np.testing.assert_allclose(h_jacobian, expected, rtol=1e-15)


def test_a_source_measures_its_own_rows():
    model = differential_drive(R, B)
    x = np.array([1.0, 2.0, 0.3, 1.5, 0.2])
    h, h_jacobian = model.measurement((2, 5))(x, np.zeros(2))
    assert h.tolist() == [0.2, 0.3]
    assert h_jacobian.tolist() == [[0, 0, 0, 0, 1], [0, 0, 1, 0, 0]]
    with pytest.raises(ConfigError, match='outputs: expected indices below 6, got'):
        model.measurement((6,))


def test_numbers_reach_the_generated_functions_exactly():
    third = 1.0 / 3.0
    model = NonlinearModel(['x'], {'x': f'{third!r} * x + c'}, {'y': '0.1 * x'},
                           constants={'c': 0.7})
    assert model.f([1.0], [])[0] == third + 0.7  # SymPy would print 0.333333333333333
    assert model.h([1.0], [])[0] == 0.1


def test_a_linear_model_as_expressions_has_its_matrices_as_jacobians():
    model = StateSpaceModel.from_matrices([[0, 1], [-2, -0.3]], [[0], [1 / 3]], [[1, 0]])
    equations = linear_as_expressions(model)
    x, u = np.array([0.4, -1.1]), np.array([0.9])
    f, jacobian = equations.f_and_jacobian(x, u)
    assert f.tolist() == (model.a @ x + model.b @ u).tolist()
    assert jacobian.tolist() == model.a.tolist()
    assert equations.measurement()(x, u)[1].tolist() == model.c.tolist()


def test_values_outside_a_functions_domain_are_not_finite_and_raise_nothing():
    model = NonlinearModel(['a', 'b'], {'a': 'sqrt(a)', 'b': 'log(b) + exp(b)'},
                           {'y': '1 / a'})
    assert np.isnan(model.f([-1.0, 1.0], [])).all()
    assert np.isnan(model.f_and_jacobian([1.0, 1e6], [])[1]).all()
    assert not np.isfinite(model.measurement()([0.0, 1.0], [])[0]).any()
    assert not np.isfinite(model.h([0.0, 1.0], [])).any()  # numpy on rows: inf
    many = model.f_many([[-1.0, 1.0], [4.0, 1.0]], [])
    assert np.isnan(many[0, 0]) and many[1].tolist() == [2.0, math.e]


def test_min_max_and_abs_have_their_jacobians():
    model = NonlinearModel(['a', 'b'], {'a': 'max(a, b) + abs(b)', 'b': 'min(a, 2 * b)'},
                           {'y': 'a'})
    assert model.jacobian([1.0, 2.0], []).tolist() == [[0.0, 2.0], [1.0, 0.0]]
    assert model.jacobian([3.0, -2.0], []).tolist() == [[1.0, -1.0], [0.0, 2.0]]


@pytest.mark.parametrize('arguments, parameter, what', [
    ({'states': ['x', 'cos']}, 'states', "'cos' is a function"),
    ({'states': ['x', 'x']}, 'states', "['x'] named twice"),
    ({'states': 'x'}, 'states', 'expected a list of names'),
    ({'states': []}, 'states', 'expected at least one state'),
    ({'inputs': ['x']}, 'inputs', "'x' is one of the states already"),
    ({'constants': {'x': 1.0}}, 'constants', "'x' is one of the states already"),
    ({'constants': {'k': math.nan}}, 'constants.k', 'expected a finite number'),
    ({'constants': {'k': '1'}}, 'constants.k', 'expected a finite number'),
    ({'dynamics': {}}, 'dynamics', "missing ['x']"),
    ({'dynamics': {'x': '0', 'z': '1'}}, 'dynamics', "['z'] are not states"),
    ({'dynamics': {'x': 'x + q'}}, 'dynamics.x', "unknown name 'q'"),
    ({'outputs': {'y': 'x.real'}}, 'outputs.y', "'x.real' at column 1: Attribute"),
    ({'angle_states': ['y']}, 'angle_states', "'y' is not one of ['x']"),
    ({'angle_outputs': ['x']}, 'angle_outputs', "'x' is not one of ['y']"),
    ({'dt': -0.1}, 'dt', 'expected 0 (continuous) or a sample period > 0'),
])
def test_a_bad_model_is_refused_naming_the_part(arguments, parameter, what):
    given = {'states': ['x'], 'dynamics': {'x': '-x'}, 'outputs': {'y': 'x'}}
    given.update(arguments)
    with pytest.raises(ConfigError) as caught:
        NonlinearModel(**given)
    assert caught.value.parameter == parameter
    assert what in caught.value.reason
    if parameter.startswith(('dynamics.', 'outputs.')):
        assert isinstance(caught.value, ExpressionError)
