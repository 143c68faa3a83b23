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
The schema parameters as ROS sees them: statically typed, with the schema's own refusals.

Every parameter is declared with its schema type (``ros2 param describe`` shows it, and rclpy
keeps it); integers from a parameter file or ``-p`` are still taken as doubles, and a value
of another type is still refused by name with the validation's reason.
"""

import pytest
from rclpy.parameter import Parameter

from conftest import CONFIG_DIR
from observer_ros.core.errors import ConfigError
from observer_ros.nodes.main import node_class as executable_class
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.observer_controller import ObserverControllerNode
from observer_ros.nodes.plant_simulator import PlantSimulatorNode
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.parameters import PARAMETER_TYPES
from ros_support import ros_context

SEED003 = CONFIG_DIR / 'seed003_full_order.yaml'
ObserverLifecycleNode = executable_class('observer_lifecycle')
ObserverControllerLifecycleNode = executable_class('observer_controller_lifecycle')


@pytest.mark.parametrize('node_class', [ObserverNode, ObserverControllerNode])
def test_the_design_for_the_expected_interval_is_made_at_start_up(node_class):
    # Seed 003 is continuous: each new interval is designed (pole placement, about a
    # millisecond). The interval of diagnostics.expected_rate is designed when the node is
    # built, not in the callback of the second sample, where it held up the first commands.
    with ros_context('--params-file', str(SEED003), '-p',
                     'diagnostics.expected_rate:=1000.0') as context:
        node = node_class(context=context)
        try:
            intervals = node.stream.estimator.intervals
            assert 1_000_000 in intervals and 10_000_000 not in intervals
        finally:
            node.destroy_node()


@pytest.mark.parametrize('node_class', [ObserverNode, StateFeedbackNode, PlantSimulatorNode,
                                        ObserverLifecycleNode, ObserverControllerNode,
                                        ObserverControllerLifecycleNode])
def test_every_schema_parameter_is_declared_with_its_type(node_class):
    with ros_context('--params-file', str(SEED003)) as context:
        node = node_class(context=context)
        try:
            assert len(node.specs) > 20
            for name, spec in node.specs.items():
                descriptor = node.describe_parameter(name)
                expected = PARAMETER_TYPES[spec.value_type]
                assert (descriptor.type, descriptor.dynamic_typing) == (expected.value, False)
                assert node.get_parameter(name).type_ == expected, name
                assert descriptor.read_only == (not (spec.dynamic or node.managed)), name
                assert descriptor.additional_constraints.startswith(spec.value_type)
        finally:
            node.destroy_node()


def test_integers_from_the_command_line_are_taken_as_doubles():
    with ros_context('--params-file', str(SEED003), '-p', 'observer.max_gap:=2',
                     '-p', 'observer.clock_tolerance:=1',
                     '-p', 'observer.initial_state:=[1, 0]') as context:
        node = ObserverNode(context=context)
        try:
            for name, value in (('observer.max_gap', 2.0), ('observer.clock_tolerance', 1.0),
                                ('observer.initial_state', [1.0, 0.0])):
                parameter = node.get_parameter(name)
                assert parameter.value == value and all(
                    isinstance(item, float) for item in (
                        value if isinstance(value, list) else [parameter.value]))
                assert node.describe_parameter(name).dynamic_typing is False
            assert node.system.parameters['observer.max_gap'] == 2.0
            result = node.set_parameters([Parameter('observer.clock_tolerance', value=3)])[0]
            assert result.successful, result.reason
            assert node.get_parameter('observer.clock_tolerance').value == 3.0
        finally:
            node.destroy_node()


def test_a_value_of_another_type_in_a_file_is_refused_by_name():
    with ros_context('--params-file', str(SEED003), '-p', 'observer.max_gap:=soon') as context:
        with pytest.raises(ConfigError, match=r'^observer\.max_gap: expected a number, got '
                                              r"'soon'"):
            ObserverNode(context=context)
        managed = ObserverLifecycleNode(context=context)  # stays up, unconfigured
        try:
            assert managed.get_parameter('observer.max_gap').value == 'soon'
            result = managed.set_parameters([Parameter('observer.max_gap', value=2)])[0]
            assert result.successful, result.reason
            assert managed.get_parameter('observer.max_gap').value == 2.0
            assert managed.describe_parameter('observer.max_gap').type == (
                Parameter.Type.DOUBLE.value)
        finally:
            managed.destroy_node()


def test_a_request_of_another_type_is_refused_with_the_schema_reason_first():
    with ros_context('--params-file', str(SEED003)) as context:
        node = ObserverNode(context=context)
        try:
            for parameter, reason in (
                    (Parameter('observer.clock_tolerance', value='x'),
                     "observer.clock_tolerance: expected double, got string 'x'"),
                    (Parameter('observer.clock_tolerance', Parameter.Type.NOT_SET),
                     'observer.clock_tolerance: cannot be unset (NOT_SET)')):
                result = node.set_parameters_atomically([parameter])
                assert not result.successful and result.reason.startswith(reason), result.reason
            result = node.set_parameters_atomically([Parameter('observer.max_gap', value=2.0)])
            assert not result.successful and 'read-only' in result.reason  # rclpy's refusal
            assert node.get_parameter('observer.clock_tolerance').value == 0.5
        finally:
            node.destroy_node()
