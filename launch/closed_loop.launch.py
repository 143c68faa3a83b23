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

"""Launch plant simulator, observer and state feedback with one parameter file."""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def generate_launch_description():
    """Three nodes sharing ``params_file`` (``/**: ros__parameters:``)."""
    default_params = os.path.join(get_package_share_directory('observer_ros'), 'config',
                                  'seed001_third_order.yaml')
    params_file = LaunchConfiguration('params_file')
    use_sim_time = LaunchConfiguration('use_sim_time')
    common = [params_file, {'use_sim_time': use_sim_time}]
    executor = ['--executor', LaunchConfiguration('executor')]
    return LaunchDescription([
        DeclareLaunchArgument('params_file', default_value=default_params,
                              description='Parameter file shared by the three nodes.'),
        DeclareLaunchArgument('use_sim_time', default_value='false',
                              description='Run on /clock (lockstep plant or a bag).'),
        DeclareLaunchArgument('executor', default_value='events',
                              choices=['events', 'single'],
                              description='rclpy executor of every node.'),
        Node(package='observer_ros', executable='plant_simulator', name='plant_simulator',
             parameters=common, arguments=executor, output='screen'),
        Node(package='observer_ros', executable='observer', name='observer',
             parameters=common, arguments=executor, output='screen'),
        Node(package='observer_ros', executable='state_feedback', name='state_feedback',
             parameters=common, arguments=executor, output='screen'),
    ])
