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

"""The core is ROS-free: importing every core module loads no rclpy and no ROS messages."""

import pkgutil
import subprocess
import sys

import observer_ros.core


def test_core_imports_no_ros():
    modules = [info.name for info in pkgutil.walk_packages(observer_ros.core.__path__,
                                                           'observer_ros.core.')]
    assert 'observer_ros.core.config' in modules and len(modules) > 10
    script = (
        'import importlib, sys\n'
        f'for name in {modules!r}:\n'
        '    importlib.import_module(name)\n'
        "ros = sorted(m for m in sys.modules if m.split('.')[0] in "
        "('rclpy', 'std_msgs', 'sensor_msgs', 'rosgraph_msgs', 'diagnostic_msgs'))\n"
        'print(ros)\n')
    result = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                            check=True)
    assert result.stdout.strip() == '[]'
