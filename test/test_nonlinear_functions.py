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
A model of Python functions registered in the entry point group observer_ros.nonlinear_models.

The test installs a distribution of its own (a module and its ``entry_points.txt`` on the
path): ``model.function: test_base`` gives the differential-drive base as numpy functions
with their Jacobians, and the extended and unscented filters run it as they run the same
model written as equations, to 1e-9. Errors name ``model.function``: an unknown name (with
those registered), an entry point that fails or gives no ModelFunctions (no finite
differences: the Jacobians are required), Jacobians of the wrong shapes.
"""

import sys

import numpy as np
import pytest
from test_nonlinear_config import SYSTEM

from observer_ros.config import validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear.functions import FunctionModel, GROUP

MODULE = """
import numpy as np
from observer_ros.core.nonlinear.functions import ModelFunctions


def make_base(constants):
    r, b = constants['r'], constants['b']

    def f(x, u):
        return [x[3] * np.cos(x[2]), x[3] * np.sin(x[2]), x[4], u[0], u[1]]

    def f_jacobians(x, u):
        a = np.zeros((5, 5))
        a[0, 2], a[0, 3] = -x[3] * np.sin(x[2]), np.cos(x[2])
        a[1, 2], a[1, 3] = x[3] * np.cos(x[2]), np.sin(x[2])
        a[2, 4] = 1.0
        return a, np.vstack([np.zeros((3, 2)), np.eye(2)])

    def h(x, u):
        return [(x[3] - x[4] * b / 2) / r, (x[3] + x[4] * b / 2) / r, x[4], x[0], x[1], x[2]]

    def h_jacobians(x, u):
        c = np.zeros((6, 5))
        c[0, 3], c[0, 4], c[1, 3], c[1, 4] = 1 / r, -b / 2 / r, 1 / r, b / 2 / r
        c[2, 4] = c[3, 0] = c[4, 1] = c[5, 2] = 1.0
        return c, np.zeros((6, 2))

    return ModelFunctions(f, h, f_jacobians, h_jacobians)


def wrong_shapes(constants):
    functions = make_base(constants)
    return ModelFunctions(functions.f, functions.h, lambda x, u: (np.eye(4), np.eye(2)),
                          functions.h_jacobians)


NOT_FUNCTIONS = 'f and h'
"""


@pytest.fixture
def registered(tmp_path, monkeypatch):
    """Install ``test_models`` and its entry points of the group on the path."""
    (tmp_path / 'test_models.py').write_text(MODULE)
    info = tmp_path / 'test_models-0.1.dist-info'
    info.mkdir()
    (info / 'METADATA').write_text('Metadata-Version: 2.1\nName: test-models\nVersion: 0.1\n')
    (info / 'entry_points.txt').write_text(
        f'[{GROUP}]\ntest_base = test_models:make_base\n'
        'wrong_shapes = test_models:wrong_shapes\nnot_functions = test_models:NOT_FUNCTIONS\n'
        'missing = test_models_nowhere:make\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    yield
    sys.modules.pop('test_models', None)


FUNCTIONS = {**SYSTEM, 'model.dynamics': [], 'model.measurements': [],
             'model.function': 'test_base'}


@pytest.mark.parametrize('kind', ['extended_kalman', 'unscented_kalman'])
def test_a_registered_model_runs_as_the_same_equations_do(registered, kind):
    point = {'model.operating_point_states': [0.0, 0.0, 0.4, 1.0, 0.1], 'observer.type': kind}
    functions = validate_parameters({**FUNCTIONS, **point})
    equations = validate_parameters({**SYSTEM, **point})
    assert isinstance(functions.model.nonlinear, FunctionModel)
    for name in 'abcd':
        assert np.allclose(getattr(functions.model, name), getattr(equations.model, name),
                           rtol=0, atol=1e-15), name
    runs = []
    for system in (functions, equations):
        stream = system.make_stream()
        assert stream.estimator.model is system.model.nonlinear
        rng = np.random.default_rng(4)
        returned = stream.add_input(0, [0.2, 0.1])
        for k in range(60):
            stamp = k * 10_000_000
            returned += stream.add_input(stamp, [0.2, 0.1 * np.sin(k / 7)])
            returned += stream.add_measurement(stamp, rng.normal(5.0, 0.1, 2), source='wheels')
            if k % 2 == 0:
                returned += stream.add_measurement(stamp, [0.1], source='imu')
            if k % 10 == 5:  # late, out of order
                returned += stream.add_measurement(stamp - 30_000_000,
                                                   [0.01 * k, 0.0, 0.4], source='camera')
        assert stream.counters['reruns'] >= 6  # each late camera sample re-ran the history
        runs.append((np.array([s.estimate for s in returned]),
                     np.array([s.covariance for s in returned])))
    (x_f, p_f), (x_e, p_e) = runs
    assert x_f.shape == x_e.shape and len(x_f) > 60
    assert np.max(np.abs(x_f - x_e)) <= 1e-9 * np.max(np.abs(x_e))
    assert np.max(np.abs(p_f - p_e)) <= 1e-9 * np.max(np.abs(p_e))


@pytest.mark.parametrize('change, parameter, what', [
    ({'model.function': 'no_such_model'}, 'model.function',
     "no model 'no_such_model' is registered in observer_ros.nonlinear_models; registered: "
     "['missing', 'not_functions', 'test_base', 'wrong_shapes']"),
    ({'model.function': 'missing'}, 'model.function',
     "entry point 'missing' = test_models_nowhere:make of observer_ros.nonlinear_models "
     'failed to load: ModuleNotFoundError'),
    ({'model.function': 'not_functions'}, 'model.function', 'expected ModelFunctions (f, h '
     'and their Jacobians: no finite differences), got str'),
    ({'model.function': 'wrong_shapes'}, 'model.function',
     "'wrong_shapes': expected arrays of shapes [(5, 5), (5, 2)], got [(4, 4), (2, 2)]"),
    ({'model.dynamics': SYSTEM['model.dynamics']}, 'model.dynamics',
     "model.function ('test_base') gives the model; expected it empty"),
    ({'model.constant_values': [0.05]}, 'model.constant_values', 'expected one value per'),
    ({'observer.type': 'kalman', 'observer.time_varying': True}, 'observer.time_varying',
     'propagates its covariance with the linear model'),
])
def test_a_bad_registered_model_is_refused_naming_the_parameter(registered, change, parameter,
                                                                what):
    with pytest.raises(ConfigError) as caught:
        validate_parameters({**FUNCTIONS, **change})
    assert caught.value.parameter == parameter, str(caught.value)
    assert what in caught.value.reason, caught.value.reason
