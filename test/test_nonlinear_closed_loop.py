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
The arm joint's closed loop through the nodes, at its operating point.

``config/nonlinear/arm_joint.yaml`` in ``closed_loop --controller`` (the plant simulator
and one observer-controller on one executor, in lockstep): the plant starts 30 degrees
from the operating point (45 degrees) and the loop holds it there, as the ROS-free loop of
``doc/arm_joint.md`` does. Before, the plant node simulated the linearization as if it were
the plant and the law ignored the operating point.
"""

import math

import numpy as np
import pytest

from conftest import REPOSITORY
from observer_ros.config import validate_parameters
from observer_ros.config.loader import load_parameter_file
from observer_ros.core.nonlinear.simulation import NonlinearPlantSimulator
from observer_ros.core.simulation import simulator_of
from observer_ros.nodes.closed_loop import ClosedLoop
from observer_ros.nodes.state_feedback import feedback_law
from observer_ros.ros.executors import make_executor
from ros_support import overrides, patient_lockstep, ros_context

ARM = REPOSITORY / 'config' / 'nonlinear' / 'arm_joint.yaml'


@pytest.fixture(scope='module')
def arm():
    parameters = load_parameter_file(str(ARM))
    return parameters, validate_parameters(parameters)


def test_a_plant_of_equations_is_simulated_by_its_equations(arm):
    _, system = arm
    plant = system.plant
    simulator = simulator_of(system.model, plant.initial_state, plant.process_noise,
                             plant.measurement_noise, plant.seed, plant.input_limits)
    assert isinstance(simulator, NonlinearPlantSimulator)
    assert simulator.model is system.model.nonlinear


def test_the_law_acts_on_the_deviation_from_the_operating_point(arm):
    parameters, system = arm
    law = feedback_law(system)
    x0 = np.array(parameters['model.operating_point_states'])
    u0 = np.array(parameters['model.operating_point_inputs'])
    assert law.command(x0.copy()).tolist() == u0.tolist()
    deviation = np.array([math.radians(30.0), 0.0])
    expected = u0 - system.feedback.estimate_gain @ deviation
    assert np.allclose(law.command(x0 + deviation), expected, rtol=1e-15, atol=1e-15)
    # an angle state's deviation is wrapped: a turn more is the same place
    assert np.allclose(law.command(x0 + deviation + [2 * math.pi, 0.0]), expected,
                       rtol=1e-12, atol=1e-12)


def test_the_arm_joint_converges_from_30_degrees_through_the_nodes(arm):
    parameters, _ = arm
    q0 = parameters['model.operating_point_states'][0]
    with ros_context('--params-file', str(ARM)) as context:
        loop = ClosedLoop(record=True, context=context, controller=True,
                          executor=make_executor('events', context),
                          overrides=overrides(plant__lockstep=True) + patient_lockstep())
        try:
            assert loop.spin(timeout_sec=240.0)
            stamps, x_true = loop.recorder.arrays('x_true')
        finally:
            loop.destroy()
    error = np.degrees(x_true[:, 0] - q0)
    assert abs(error[0] - 30.0) < 1.0  # the first sample, one period after the start
    seconds = (stamps - stamps[0]) / 1e9
    assert np.abs(error[seconds >= 2.0]).max() < 0.5
