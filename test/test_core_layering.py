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
The layers: each room imports only the rooms below it, and only ``ros`` and ``nodes`` ROS.

``observer_ros.core`` is a library (models, designs, estimators, the event engine);
``observer_ros.config`` (the parameter schema) and ``observer_ros.app`` (health logic,
reports, plots) sit on it without ROS; ``ros``, ``nodes``, ``bags`` and ``tools`` on top.
The wire codec (``observer_ros.wire``) sits at the bottom beside the core: it imports no
rclpy and nothing else of ours, so the bag tools (``observer_ros.bags``: storage and replay,
no codec of their own) run without ROS, and the configuration checks the field paths of the
measurement sources against its catalog of message types without reaching up into
``ros``.
"""

import importlib
import inspect
import pathlib
import pkgutil
import re
import subprocess
import sys

import observer_ros.app
import observer_ros.bags
import observer_ros.config
from observer_ros.config.schema import ALL_NODES
import observer_ros.core
import observer_ros.wire

ROS = ('rclpy', 'std_msgs', 'sensor_msgs', 'rosgraph_msgs', 'diagnostic_msgs')


def submodules(package) -> list:
    """Return the names of every module of ``package`` (a module alone: its own name)."""
    if not hasattr(package, '__path__'):
        return [package.__name__]
    return [info.name for info in pkgutil.walk_packages(package.__path__,
                                                        package.__name__ + '.')]


#: The wire codec's modules, which import no ROS and nothing of ours.
WIRE_CODEC = tuple(submodules(observer_ros.wire)) + ('observer_ros.wire',)


def imported_by(package) -> tuple:
    """Import ``package`` whole in a new interpreter: its modules, ours and ROS's loaded."""
    modules = submodules(package)
    script = (
        'import importlib, sys\n'
        f'for name in {modules!r}:\n'
        '    importlib.import_module(name)\n'
        'print(sorted(m for m in sys.modules if m.startswith("observer_ros.")))\n'
        f'print(sorted(m for m in sys.modules if m.split(".")[0] in {ROS!r}))\n')
    result = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                            check=True)
    package_modules, ros = (eval(line) for line in result.stdout.splitlines())
    return modules, package_modules, ros


def test_the_core_imports_no_ros_and_nothing_outside_the_core():
    modules, loaded, ros = imported_by(observer_ros.core)
    assert 'observer_ros.core.streaming' in modules and len(modules) > 10
    assert ros == []
    assert [name for name in loaded if not name.startswith('observer_ros.core')] == []


def test_the_parameter_schema_imports_no_ros():
    modules, _, ros = imported_by(observer_ros.config)
    assert 'observer_ros.config.sections' in modules
    assert ros == []


def test_the_wire_codec_imports_no_ros():
    modules, loaded, ros = imported_by(observer_ros.wire)
    assert 'observer_ros.wire.catalog' in modules
    assert ros == []
    assert loaded == sorted(WIRE_CODEC)


def test_the_bag_tools_import_no_ros_and_hold_no_wire_codec():
    modules, loaded, ros = imported_by(observer_ros.bags)
    assert 'observer_ros.bags.storage' in modules
    assert ros == []
    assert [name for name in loaded if name.startswith('observer_ros.ros')] == []
    # Nothing of the codec is defined under bags/: what they use of it is the codec's own.
    codec = {name for name, value in vars(observer_ros.wire).items()
             if getattr(value, '__module__', '').startswith('observer_ros.wire.')}
    for name in modules:
        module = importlib.import_module(name)
        defined = {key for key, value in vars(module).items()
                   if (inspect.isclass(value) or inspect.isfunction(value))
                   and value.__module__ == name}
        assert not defined & codec, (name, sorted(defined & codec))
        for key in set(vars(module)) & codec:
            assert getattr(module, key) is getattr(observer_ros.wire, key), (name, key)


def test_the_application_layer_imports_no_ros_and_nothing_above_it():
    modules, loaded, ros = imported_by(observer_ros.app)
    assert {'observer_ros.app.health', 'observer_ros.app.report'} <= set(modules)
    assert ros == []
    above = ('observer_ros.ros', 'observer_ros.nodes', 'observer_ros.bags', 'observer_ros.tools')
    assert [name for name in loaded if name.startswith(above)
            and name not in WIRE_CODEC] == []


def test_the_schema_imports_nothing_of_the_application_layer_or_above():
    _, loaded, _ = imported_by(observer_ros.config)
    assert [name for name in loaded
            if not name.startswith(('observer_ros.config', 'observer_ros.core'))
            and name not in WIRE_CODEC] == []


#: What only a node talks about: the diagnostics message, the node names (the schema's).
NODE_WORDS = re.compile(r'DiagnosticStatus|diagnostic_msgs|\b(?:' + '|'.join(
    name for name in ALL_NODES if name != 'observer') + r")\b|'observer'")


def test_the_core_mentions_no_node_concepts():
    sources = sorted(pathlib.Path(observer_ros.core.__file__).parent.rglob('*.py'))
    assert len(sources) > 10
    found = [f'{path.name}:{number}: {line.strip()}' for path in sources
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if NODE_WORDS.search(line)]
    assert found == []


def test_the_core_arguments_know_no_nodes_and_no_run_time_parameters():
    from dataclasses import fields

    from observer_ros.core.arguments import Argument
    assert {field.name for field in fields(Argument)}.isdisjoint({'nodes', 'dynamic'})
