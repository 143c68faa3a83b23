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
Launch the observer alone, to add to a robot's bringup.

``ros2 launch observer_ros observer.launch.py params_file:=robot.yaml namespace:=arm
measurement_topic:=/joint_states input_topic:=/forward_position_controller/commands``;
``lifecycle:=true`` runs the managed variant (``observer_lifecycle``), which waits for
``ros2 lifecycle set`` (or a lifecycle manager) unless ``autostart:=true``.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode, Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare


def generate_launch_description() -> LaunchDescription:
    """One observer node (plain or managed) with the given parameters and topic names."""
    params_file = LaunchConfiguration('params_file')
    namespace = LaunchConfiguration('namespace')
    lifecycle = LaunchConfiguration('lifecycle')
    sim_time = {'use_sim_time': ParameterValue(LaunchConfiguration('use_sim_time'),
                                               value_type=bool)}
    autostart = {'autostart': ParameterValue(LaunchConfiguration('autostart'), value_type=bool)}
    executor = ['--executor', LaunchConfiguration('executor')]
    remappings = [('y', LaunchConfiguration('measurement_topic')),
                  ('u', LaunchConfiguration('input_topic')),
                  ('x_hat', LaunchConfiguration('estimate_topic'))]
    return LaunchDescription([
        DeclareLaunchArgument(
            'params_file', description='Parameter file (/**: ros__parameters:).',
            default_value=PathJoinSubstitution([FindPackageShare('observer_ros'), 'config',
                                                'seed003_full_order.yaml'])),
        DeclareLaunchArgument('namespace', default_value='',
                              description='Namespace of the node and its relative topics.'),
        DeclareLaunchArgument('measurement_topic', default_value='y',
                              description='Topic of the measurements y (remaps y).'),
        DeclareLaunchArgument('input_topic', default_value='u',
                              description='Topic of the applied input u (remaps u).'),
        DeclareLaunchArgument('estimate_topic', default_value='x_hat',
                              description='Topic of the estimate x_hat (remaps x_hat).'),
        DeclareLaunchArgument('use_sim_time', default_value='false', choices=['true', 'false'],
                              description='Run on /clock (a bag or the lockstep plant).'),
        DeclareLaunchArgument('executor', default_value='events', choices=['events', 'single'],
                              description='rclpy executor of the node.'),
        DeclareLaunchArgument('lifecycle', default_value='false', choices=['true', 'false'],
                              description='Run the managed (lifecycle) observer_lifecycle.'),
        DeclareLaunchArgument('autostart', default_value='false', choices=['true', 'false'],
                              description='With lifecycle:=true, configure and activate at '
                              'start.'),
        Node(package='observer_ros', executable='observer', name='observer',
             namespace=namespace, parameters=[params_file, sim_time], remappings=remappings,
             arguments=executor, output='screen', condition=UnlessCondition(lifecycle)),
        LifecycleNode(package='observer_ros', executable='observer_lifecycle', name='observer',
                      namespace=namespace, parameters=[params_file, sim_time, autostart],
                      remappings=remappings, arguments=executor, output='screen',
                      condition=IfCondition(lifecycle)),
    ])
