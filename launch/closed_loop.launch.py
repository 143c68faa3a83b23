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
Launch plant simulator, observer and state feedback with one parameter file.

``lifecycle:=true`` runs the managed observer and state feedback (``observer_lifecycle``,
``state_feedback_lifecycle``); they wait for ``ros2 lifecycle set`` unless
``autostart:=true``. ``namespace:=robot1`` puts the whole loop, topics included, under
``/robot1``.
"""

from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition, UnlessCondition
from launch.substitutions import LaunchConfiguration, PathJoinSubstitution
from launch_ros.actions import LifecycleNode, Node
from launch_ros.parameter_descriptions import ParameterValue
from launch_ros.substitutions import FindPackageShare


def generate_launch_description() -> LaunchDescription:
    """Three nodes sharing ``params_file`` (``/**: ros__parameters:``)."""
    params_file = LaunchConfiguration('params_file')
    namespace = LaunchConfiguration('namespace')
    lifecycle = LaunchConfiguration('lifecycle')
    sim_time = {'use_sim_time': ParameterValue(LaunchConfiguration('use_sim_time'),
                                               value_type=bool)}
    autostart = {'autostart': ParameterValue(LaunchConfiguration('autostart'), value_type=bool)}
    common = [params_file, sim_time]
    # A managed controller sends nothing until it is active: the plant holds the joint.
    held = {'plant.hold_without_command': ParameterValue(lifecycle, value_type=bool)}
    plant = [params_file, sim_time, held]
    managed = [params_file, sim_time, autostart]
    executor = ['--executor', LaunchConfiguration('executor')]
    return LaunchDescription([
        DeclareLaunchArgument(
            'params_file', description='Parameter file shared by the three nodes.',
            default_value=PathJoinSubstitution([FindPackageShare('observer_ros'), 'config',
                                                'seed001_third_order.yaml'])),
        DeclareLaunchArgument('namespace', default_value='',
                              description='Namespace of the three nodes and their topics.'),
        DeclareLaunchArgument('use_sim_time', default_value='false', choices=['true', 'false'],
                              description='Run on /clock (lockstep plant or a bag).'),
        DeclareLaunchArgument('executor', default_value='events', choices=['events', 'single'],
                              description='rclpy executor of every node.'),
        DeclareLaunchArgument('lifecycle', default_value='false', choices=['true', 'false'],
                              description='Run the managed (lifecycle) observer and state '
                              'feedback.'),
        DeclareLaunchArgument('autostart', default_value='false', choices=['true', 'false'],
                              description='With lifecycle:=true, configure and activate them '
                              'at start.'),
        Node(package='observer_ros', executable='plant_simulator', name='plant_simulator',
             namespace=namespace, parameters=plant, arguments=executor, output='screen'),
        Node(package='observer_ros', executable='observer', name='observer',
             namespace=namespace, parameters=common, arguments=executor, output='screen',
             condition=UnlessCondition(lifecycle)),
        Node(package='observer_ros', executable='state_feedback', name='state_feedback',
             namespace=namespace, parameters=common, arguments=executor, output='screen',
             condition=UnlessCondition(lifecycle)),
        LifecycleNode(package='observer_ros', executable='observer_lifecycle',
                      name='observer', namespace=namespace, parameters=managed,
                      arguments=executor, output='screen', condition=IfCondition(lifecycle)),
        LifecycleNode(package='observer_ros', executable='state_feedback_lifecycle',
                      name='state_feedback', namespace=namespace, parameters=managed,
                      arguments=executor, output='screen', condition=IfCondition(lifecycle)),
    ])
