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
package.xml declares what the package imports, through rosdep keys that exist.

``rosdep install --from-paths src`` on a ROS 2 install stops at the first key it cannot
resolve, and a module the nodes import with no key is missing at start-up. The keys of the
third-party Python modules were checked against rosdistro's ``rosdep/python.yaml``
(``python-control-pip``, ``python-slycot-pip``, ``python3-rosbags-pip`` and
``python3-cvxpy-pip`` are pip keys: Debian packages none of them); there is no
``python3-dask`` key.
"""

import ast
from pathlib import Path
import sys
import xml.etree.ElementTree as ElementTree

REPOSITORY = Path(__file__).resolve().parents[1]

#: Third-party modules and their rosdep keys (checked in rosdistro's rosdep/python.yaml).
ROSDEP_KEYS = {
    'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'yaml': 'python3-yaml',
    'matplotlib': 'python3-matplotlib', 'control': 'python-control-pip',
    'slycot': 'python-slycot-pip', 'rosbags': 'python3-rosbags-pip',
    'cvxpy': 'python3-cvxpy-pip', 'sympy': 'python3-sympy',
}

#: Modules with no rosdep key: from PyPI (requirements.txt), imported only inside the
#: functions that need them, and named in package.xml's comment; or brought by rosbags.
PIP_ONLY = {'dask', 'distributed', 'threadpoolctl', 'clarabel', 'zstandard', 'lz4',
            'backports', 'compression'}

#: ROS packages: the rosdep key is the package's name.
ROS_PACKAGES = {'rclpy', 'std_msgs', 'std_srvs', 'sensor_msgs', 'geometry_msgs', 'nav_msgs',
                'diagnostic_msgs', 'rosgraph_msgs', 'rcl_interfaces', 'lifecycle_msgs',
                'builtin_interfaces', 'launch', 'launch_ros', 'tf2_msgs'}


def declared(kinds=('exec_depend', 'depend')) -> set:
    root = ElementTree.parse(REPOSITORY / 'package.xml').getroot()
    return {element.text.strip() for kind in kinds for element in root.iter(kind)}


def imports() -> dict:
    """Return ``{module: [(path, line, at module level)]}`` of every import in observer_ros."""
    found: dict = {}
    for path in sorted((REPOSITORY / 'observer_ros').rglob('*.py')):
        tree = ast.parse(path.read_text(encoding='utf-8'))
        top = {id(node) for node in tree.body}
        for node in ast.walk(tree):
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and not node.level:
                names = [node.module]
            else:
                continue
            for name in names:
                found.setdefault(name.split('.')[0], []).append(
                    (path.relative_to(REPOSITORY), node.lineno, id(node) in top))
    return found


def test_every_imported_module_has_a_rosdep_key_in_package_xml():
    keys = declared()
    for module, places in imports().items():
        if module in sys.stdlib_module_names or module == 'observer_ros':
            continue
        if module in ROS_PACKAGES:
            assert module in keys or module == 'tf2_msgs', (module, places[0])
        elif module in PIP_ONLY:
            assert not any(top for _, _, top in places), (
                f'{module} has no rosdep key: import it where it is used, not at '
                f'module level ({places})')
        else:
            assert module in ROSDEP_KEYS, f'{module} ({places[0]}): which rosdep key?'
            assert ROSDEP_KEYS[module] in keys, (
                f'{module} is imported ({places[0]}) but package.xml has no '
                f'{ROSDEP_KEYS[module]}')


def test_package_xml_names_only_keys_that_exist():
    known = ROS_PACKAGES | set(ROSDEP_KEYS.values()) | {
        'ament_copyright', 'ament_flake8', 'ament_pep257', 'python3-pytest',
        'python3-sphinx'}
    every = declared(('exec_depend', 'depend', 'build_depend', 'test_depend', 'doc_depend'))
    assert every <= known, sorted(every - known)
