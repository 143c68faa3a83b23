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

"""Conversion between :class:`StateSpaceModel` and python-control's ``StateSpace``."""

import control
import numpy as np
import pytest
import scipy.signal

import observer_ros.core as oc
from observer_ros.core.errors import ConfigError


def random_model(seed: int, n: int, m: int, p: int, dt: float = 0.0, named: bool = True):
    rng = np.random.default_rng(seed)
    names = {}
    if named:
        names = {'state_names': [f'q{i}' for i in range(n)],
                 'input_names': [f'force{i}' for i in range(m)],
                 'output_names': [f'angle{i}' for i in range(p)]}
    return oc.StateSpaceModel.from_matrices(
        rng.standard_normal((n, n)), rng.standard_normal((n, m)), rng.standard_normal((p, n)),
        rng.standard_normal((p, m)), dt=dt, **names)


def assert_same_model(got, expected):
    for name in ('a', 'b', 'c', 'd'):
        np.testing.assert_array_equal(getattr(got, name), getattr(expected, name))
    assert got.dt == expected.dt
    assert (got.state_names, got.input_names, got.output_names) == (
        expected.state_names, expected.input_names, expected.output_names)


@pytest.mark.parametrize('dt', [0.0, 0.05])
@pytest.mark.parametrize('shape', [(1, 1, 1), (4, 2, 3)])
def test_round_trip_keeps_matrices_period_and_names(dt, shape):
    model = random_model(1, *shape, dt=dt)
    sys = model.to_statespace()
    assert isinstance(sys, control.StateSpace)
    assert sys.dt == dt and control.isdtime(sys, strict=True) == (dt > 0)
    for ours, theirs in zip((model.a, model.b, model.c, model.d), (sys.A, sys.B, sys.C, sys.D)):
        np.testing.assert_array_equal(theirs, ours)
    assert sys.state_labels == list(model.state_names)
    assert sys.input_labels == list(model.input_names)
    assert sys.output_labels == list(model.output_names)
    assert_same_model(oc.StateSpaceModel.from_statespace(sys), model)


def test_default_names_survive_a_round_trip():
    model = random_model(2, 3, 1, 2, named=False)
    assert model.state_names == ('x1', 'x2', 'x3')
    assert_same_model(oc.StateSpaceModel.from_statespace(model.to_statespace()), model)


def test_python_control_default_labels_become_ours():
    sys = control.ss(np.diag([-1.0, -2.0]), [[1.0], [1.0]], [[1.0, 0.0]], 0)
    assert sys.state_labels == ['x[0]', 'x[1]']
    model = oc.StateSpaceModel.from_statespace(sys)
    assert (model.state_names, model.input_names, model.output_names) == (
        ('x1', 'x2'), ('u1',), ('y1',))
    partly = control.ss(sys.A, sys.B, sys.C, sys.D, states=['p', 'v'])
    assert oc.StateSpaceModel.from_statespace(partly).state_names == ('p', 'v')


def test_the_same_system_either_way():
    # Matrices are not transposed or reordered: the DC gain and the transfer function agree.
    model = random_model(3, 3, 2, 2)
    model = oc.StateSpaceModel.from_matrices(model.a - 4 * np.eye(3), model.b, model.c,
                                             model.d)
    expected = -model.c @ np.linalg.solve(model.a, model.b) + model.d
    np.testing.assert_allclose(model.to_statespace().dcgain(), expected, rtol=1e-12)
    realized = oc.StateSpaceModel.from_statespace(control.ss(control.tf([2.0], [1, 3, 2])))
    num, den = scipy.signal.ss2tf(realized.a, realized.b, realized.c, realized.d)
    np.testing.assert_allclose(np.trim_zeros(num[0], 'f'), [2.0], rtol=1e-12)
    np.testing.assert_allclose(den, [1, 3, 2], rtol=1e-12)


def test_a_converted_model_designs_like_the_original():
    sys = control.ss([[0, 1], [0, 0]], [[0], [1]], [[1, 0]], 0)
    design = oc.design_full_order(oc.StateSpaceModel.from_statespace(sys), poles=[-8, -9])
    np.testing.assert_allclose(design.gain.ravel(), [17.0, 72.0], rtol=1e-12)
    np.testing.assert_allclose(np.ravel(control.place(sys.A.T, sys.C.T, [-8, -9])),
                               design.gain.ravel(), rtol=1e-9)


def test_unspecified_time_base_is_continuous():
    sys = control.StateSpace([[-1.0]], [[1.0]], [[1.0]], [[0.0]], None)
    assert sys.dt is None
    assert not oc.StateSpaceModel.from_statespace(sys).is_discrete


def test_discrete_without_a_period_is_refused():
    sys = control.ss([[0.5]], [[1.0]], [[1.0]], 0, True)
    with pytest.raises(ConfigError, match=r'^sys: .*unspecified period \(dt=True\)'):
        oc.StateSpaceModel.from_statespace(sys)


def test_transfer_function_is_refused_with_the_conversion_to_use():
    with pytest.raises(ConfigError, match=r'^sys: expected a control.StateSpace system, got '
                                          r'TransferFunction; .*control.ss\(sys\)'):
        oc.StateSpaceModel.from_statespace(control.tf([1.0], [1.0, 1.0]))


def test_non_finite_matrices_are_refused_naming_the_matrix():
    sys = control.ss([[-1.0]], [[1.0]], [[1.0]], 0)
    sys.A[0, 0] = np.nan
    with pytest.raises(ConfigError, match='^A: expected finite numbers'):
        oc.StateSpaceModel.from_statespace(sys)
