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

``observer_ros.config.nonlinear`` reads them and its parameters are the schema's: a
configuration with ``model.dynamics`` has for its model the equations linearized exactly at
``model.operating_point_*``, which carries them to the extended and unscented filters; each
source is measured by the model's expressions of its outputs, and a step that is not finite
is counted in the stream's (and so the node's) counters.
"""

import numpy as np
import pytest

from observer_ros.config import validate_parameters
from observer_ros.config.nonlinear import NONLINEAR_PARAMETERS, read_nonlinear_model
from observer_ros.config.schema import PARAMETER_SPECS
from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear import differential_drive, ExtendedKalman, UnscentedKalman

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
        'model.constant_values', 'model.operating_point_states', 'model.operating_point_inputs',
        'model.function']
    for name, value_type, default, _ in NONLINEAR_PARAMETERS:
        spec = PARAMETER_SPECS[name]
        assert (spec.value_type, spec.default, spec.dynamic) == (value_type, default, False)


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


#: ``BASE`` as a configuration of the extended Kalman filter with three sources.
SYSTEM = {**BASE, 'observer.type': 'extended_kalman',
          'observer.process_noise': [1e-4, 1e-4, 1e-4, 0.05, 0.05],
          'observer.initial_state': [0.0] * 5, 'observer.history': 0.3,
          'observer.sources': ['wheels', 'imu', 'camera'],
          'sources.wheels.fields': ['velocity.left', 'velocity.right'],
          'sources.wheels.outputs': ['wheel_left', 'wheel_right'],
          'sources.wheels.measurement_noise': [0.01, 0.01],
          'sources.imu.type': 'imu', 'sources.imu.fields': ['angular_velocity.z'],
          'sources.imu.outputs': ['gyro_z'], 'sources.imu.measurement_noise': [1e-4],
          'sources.camera.type': 'pose_with_covariance_stamped',
          'sources.camera.fields': ['pose.pose.position.x', 'pose.pose.position.y',
                                    'pose.pose.orientation.yaw'],
          'sources.camera.outputs': ['cam_y', 'cam_x', 'cam_yaw'],
          'sources.camera.measurement_noise': [1e-4, 1e-4, 1e-4]}


@pytest.mark.parametrize('kind, filter_class', [('extended_kalman', ExtendedKalman),
                                                ('unscented_kalman', UnscentedKalman)])
def test_the_equations_reach_the_filter_through_the_one_configuration(kind, filter_class):
    system = validate_parameters({**SYSTEM, 'observer.type': kind,
                                  'model.operating_point_states': [0, 0, 0.3, 1.0, 0.2]},
                                 strict=True)
    model = system.model
    x0, u0 = np.array([0.0, 0.0, 0.3, 1.0, 0.2]), np.zeros(2)
    # The configuration's linear model is the exact linearization at the operating point.
    assert model.a.tolist() == model.nonlinear.jacobian(x0, u0).tolist()
    assert model.c.tolist() == model.nonlinear.measurement()(x0, u0)[1].tolist()
    assert model.b.tolist() == [[0.0, 0.0]] * 3 + [[1.0, 0.0], [0.0, 1.0]]
    assert model.state_names == ('px', 'py', 'yaw', 'v', 'w')
    stream = system.observer.take_stream()
    assert type(stream.estimator) is filter_class
    assert stream.estimator.model is model.nonlinear  # converted once, handed on
    assert stream.estimator.angles.states == (2,) and stream.estimator.angles.outputs == (5,)


def test_each_source_is_measured_by_the_models_expressions_of_its_outputs():
    system = validate_parameters(SYSTEM)
    sources = {source.name: source for source in system.observer.sources.sources}
    names = system.model.output_names
    # sources.camera.outputs gives its fields' outputs in its own order: cam_y first.
    assert [names[k] for k in sources['camera'].outputs] == ['cam_y', 'cam_x', 'cam_yaw']
    assert [names[k] for k in sources['wheels'].outputs] == ['wheel_left', 'wheel_right']
    model = system.model.nonlinear
    x, u = np.array([1.0, 2.0, 0.3, 1.5, 0.2]), np.zeros(2)
    assert model.h(x, u, sources['camera'].outputs).tolist() == [2.0, 1.0, 0.3]
    assert model.h(x, u, sources['wheels'].outputs) == pytest.approx([29.4, 30.6], rel=1e-15)
    assert model.h(x, u, sources['imu'].outputs).tolist() == [0.2]
    # A camera sample of (y, x, yaw) corrects py with y, px with x.
    stream = system.observer.take_stream()
    stream.add_input(0, [0.0, 0.0])
    stream.add_measurement(0, [0.0, 0.0], source='wheels')
    estimate = stream.add_measurement(0, [2.0, 1.0, 0.0], source='camera')[-1].estimate
    assert estimate[1] > 1.9 and estimate[0] > 0.9 and abs(estimate[0] - 1.0) < 0.1


def test_a_step_that_is_not_finite_is_dropped_and_counted_by_the_stream():
    system = validate_parameters({
        'model.state_names': ['q'], 'model.dynamics': ['-1'], 'model.output_names': ['y'],
        'model.measurements': ['sqrt(q)'], 'observer.type': 'extended_kalman',
        'observer.process_noise': [1e-4], 'observer.measurement_noise': [1e-4],
        'observer.initial_state': [0.05], 'model.operating_point_states': [1.0]})
    stream = system.make_stream()
    first = stream.add_measurement(0, [0.2236])
    dropped = stream.add_measurement(100_000_000, [0.1])  # q = -0.05: sqrt is not real
    assert np.isfinite(first[-1].estimate).all()
    assert dropped[-1].estimate.tolist() == first[-1].estimate.tolist()  # kept, not NaN
    assert stream.counters['nonfinite'] == 1


@pytest.mark.parametrize('change, parameter, what', [
    ({'model.A': [0.0] * 25}, 'model.A', 'linearized at model.operating_point_states; '
     'expected it empty'),
    ({'model.operating_point_states': [0.0, 1.0]}, 'model.operating_point_states',
     "expected 5 values (one per name of ['px', 'py', 'yaw', 'v', 'w']), got 2"),
    ({'model.operating_point_inputs': [0.0, float('inf')]}, 'model.operating_point_inputs',
     'expected finite numbers'),
    ({'model.dynamics': [], 'model.A': [0.0], 'model.B': [], 'model.C': [1.0],
      'model.state_names': [], 'model.input_names': [], 'model.output_names': []},
     'model.measurements', 'given without model.dynamics'),
    ({'model.measurements': [], 'model.output_names': [], 'model.angle_outputs': []},
     'model.measurements',
     'expected at least one output'),
    ({'model.measurements': ['(v - w * b / 2) / r', '(v + w * b / 2) / r', 'w', 'px', 'py',
                             'log(yaw)']}, 'model.operating_point_states',
     'the Jacobians are not finite at the operating point'),
    ({'observer.type': 'kalman', 'observer.time_varying': True}, 'observer.time_varying',
     'the time-varying Kalman filter propagates its covariance with the linear model'),
    ({'model.disturbances': ['constant']}, 'model.disturbances', 'takes no disturbances'),
])
def test_a_bad_model_written_as_equations_is_refused_naming_the_parameter(change, parameter,
                                                                          what):
    with pytest.raises(ConfigError) as caught:
        validate_parameters({**SYSTEM, **change})
    assert caught.value.parameter == parameter, str(caught.value)
    assert what in caught.value.reason, caught.value.reason
