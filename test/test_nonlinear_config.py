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
A model written as equations from flat parameters: each error names its parameter.

``observer_ros.config.nonlinear`` is not yet part of the schema (the hook is one line there);
these tests hold its reading and its messages.
"""

import numpy as np
import pytest

from observer_ros.config.nonlinear import NONLINEAR_PARAMETERS, read_nonlinear_model
from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear import differential_drive

BASE = {
    'model.state_names': ['px', 'py', 'yaw', 'v', 'w'], 'model.input_names': ['a', 'alpha'],
    'model.dynamics': ['v * cos(yaw)', 'v * sin(yaw)', 'w', 'a', 'alpha'],
    'model.output_names': ['wheel_left', 'wheel_right', 'gyro_z', 'cam_x', 'cam_y',
                           'cam_yaw'],
    'model.measurements': ['(v - w * b / 2) / r', '(v + w * b / 2) / r', 'w', 'px', 'py',
                           'yaw'],
    'model.constant_names': ['r', 'b'], 'model.constant_values': [0.05, 0.3],
    'model.angle_states': ['yaw'], 'model.angle_outputs': ['cam_yaw'],
}


def test_the_parameters_give_the_differential_drive_model():
    model = read_nonlinear_model(BASE)
    reference = differential_drive(0.05, 0.3)
    x, u = np.array([1.0, 2.0, 0.3, 1.5, 0.2]), np.array([0.1, 0.05])
    assert model.f_and_jacobian(x, u)[1].tolist() == reference.f_and_jacobian(x, u)[1].tolist()
    assert model.h(x, u).tolist() == reference.h(x, u).tolist()
    assert (model.angle_states, model.angle_outputs) == ((2,), (5,))
    assert read_nonlinear_model({'model.A': [0.0]}) is None
    assert [entry[0] for entry in NONLINEAR_PARAMETERS] == [
        'model.dynamics', 'model.measurements', 'model.constant_names',
        'model.constant_values']


@pytest.mark.parametrize('change, parameter, what', [
    ({'model.dynamics': ['v * cos(yaw)', 'v * sin(yaw)', 'w.real', 'a', 'alpha']},
     'model.dynamics', "entry 3 (yaw): 'w.real' at column 1: Attribute is not allowed"),
    ({'model.measurements': ['1'] * 5}, 'model.measurements',
     'expected one expression per output of model.output_names (6:'),
    ({'model.measurements': ['q'] + ['1'] * 5}, 'model.measurements',
     "entry 1 (wheel_left): 'q' at column 1: unknown name 'q'"),
    ({'model.constant_values': [0.05]}, 'model.constant_values', 'expected one value per'),
    ({'model.constant_values': [0.05, float('nan')]}, 'model.constant_values',
     'b: expected a finite number'),
    ({'model.constant_names': ['r', 'cos']}, 'model.constant_names', "'cos' is a function"),
    ({'model.input_names': ['a', 'px']}, 'model.input_names', "'px' is one of the states"),
    ({'model.angle_states': ['heading']}, 'model.angle_states', "'heading' is not one of"),
    ({'model.dynamics': 'v'}, 'model.dynamics', 'expected a list of strings'),
    ({'model.dt': -1.0}, 'model.dt', 'expected 0 (continuous) or a sample period'),
])
def test_an_error_names_the_parameter(change, parameter, what):
    with pytest.raises(ConfigError) as caught:
        read_nonlinear_model(dict(BASE, **change))
    assert caught.value.parameter == parameter, str(caught.value)
    assert what in caught.value.reason, caught.value.reason
