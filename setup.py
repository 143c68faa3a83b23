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

from glob import glob
from importlib.util import module_from_spec, spec_from_file_location
from pathlib import Path

from setuptools import find_packages, setup

PACKAGE_NAME = 'observer_ros'


def _node_specs():
    """Load the node specs by path: a plain-data module (no rclpy, no numpy to import)."""
    path = Path(__file__).resolve().parent / PACKAGE_NAME / 'config' / 'node_specs.py'
    spec = spec_from_file_location('observer_ros_node_specs', path)
    module = module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


setup(
    name=PACKAGE_NAME,
    version='0.1.0',
    packages=find_packages(exclude=['test', 'test.*', 'benchmarks', 'benchmarks.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + PACKAGE_NAME]),
        ('share/' + PACKAGE_NAME, ['package.xml']),
        ('share/' + PACKAGE_NAME + '/config', glob('config/*.yaml') + glob('config/*.xml')),
        ('share/' + PACKAGE_NAME + '/config/nonlinear', glob('config/nonlinear/*.yaml')),
        ('share/' + PACKAGE_NAME + '/launch', glob('launch/*.launch.py')),
    ],
    # ROS 2 itself (rclpy, message packages) is deliberately not listed here: on a ROS
    # install it comes from the distribution; without ROS, requirements.txt pulls the
    # Jazzy wheels. Listing it would pull a second rclpy into a colcon workspace.
    install_requires=['setuptools', 'numpy', 'scipy', 'control>=0.10', 'pyyaml'],
    python_requires='>=3.10',
    zip_safe=True,
    maintainer='observer_ros maintainers',
    maintainer_email='maintainers@observer-ros.dev',
    description='State observers and observer-based state feedback for ROS 2.',
    license='Apache-2.0',
    extras_require={'test': ['pytest']},
    entry_points={
        # Every node executable (and its managed twin's) from the node specs, then the tools.
        'console_scripts': _node_specs().console_scripts(),
        # The observer types, found by observer_ros.core.observers through this group; a
        # separate package adds one in its own setup.py. Each type's priority orders them
        # (full_order, reduced_order, chen, kalman, extended_kalman, unscented_kalman), not
        # this list.
        'observer_ros.observer_types': [
            'full_order = observer_ros.core.observers.full_order:TYPE',
            'reduced_order = observer_ros.core.observers.reduced_order:TYPE',
            'chen = observer_ros.core.observers.chen:TYPE',
            'kalman = observer_ros.core.observers.kalman:TYPE',
            'extended_kalman = observer_ros.core.observers.extended_kalman:TYPE',
            'unscented_kalman = observer_ros.core.observers.unscented_kalman:TYPE',
        ],
    },
)
