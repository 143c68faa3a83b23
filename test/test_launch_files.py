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
The launch files, read as source where ``launch`` is not installed.

Every argument is documented (doc/lifecycle_and_launch.md), every executable is a console
script of the
package, every remapped name is a topic of the node it remaps, the managed nodes get the
``autostart`` parameter; with ``launch`` installed (a Jazzy install),
``generate_launch_description()`` runs and declares the same arguments.
"""

import ast
import importlib.util

import pytest

from conftest import console_scripts, REPOSITORY
from observer_ros.config import COMBINED_NODES, PARAMETER_SPECS, TOPIC_ROLES
from observer_ros.config.node_specs import NODE_SPECS
from observer_ros.ros.executors import EXECUTORS

LAUNCH_FILES = sorted((REPOSITORY / 'launch').glob('*.launch.py'))
LAUNCH_PAGE = (REPOSITORY / 'doc' / 'lifecycle_and_launch.md').read_text(encoding='utf-8')

#: The role (parameter and topic set) of each node executable, from the node specs.
ROLES = {name: spec.name for spec in NODE_SPECS for name in spec.executables}


def calls(tree, *names) -> list:
    """Return the calls of the functions or classes called ``names``."""
    return [node for node in ast.walk(tree) if isinstance(node, ast.Call)
            and getattr(node.func, 'id', None) in names]


def keywords(call) -> dict:
    return {keyword.arg: keyword.value for keyword in call.keywords}


class LaunchSource:
    """One launch file's syntax tree, with its local names resolved."""

    def __init__(self, path) -> None:
        self.path = path
        self.tree = ast.parse(path.read_text(encoding='utf-8'))
        self.names = {target.id: node.value for node in ast.walk(self.tree)
                      if isinstance(node, ast.Assign) for target in node.targets
                      if isinstance(target, ast.Name)}
        self.arguments = {call.args[0].value: keywords(call)
                          for call in calls(self.tree, 'DeclareLaunchArgument')}
        self.nodes = [(call.func.id, keywords(call))
                      for call in calls(self.tree, 'Node', 'LifecycleNode')]

    def resolve(self, node):
        """Return the expression a local name stands for (other nodes as they are)."""
        while isinstance(node, ast.Name) and node.id in self.names:
            node = self.names[node.id]
        return node

    def configuration(self, node) -> str:
        """Return the argument name of ``LaunchConfiguration('name')``."""
        node = self.resolve(node)
        assert isinstance(node, ast.Call) and node.func.id == 'LaunchConfiguration', (
            ast.unparse(node))
        return node.args[0].value

    def parameter_names(self, node) -> set:
        """Names set by the dictionaries of a ``parameters=[...]`` list."""
        names = set()
        for item in self.resolve(node).elts:
            item = self.resolve(item)
            if isinstance(item, ast.Dict):
                names.update(key.value for key in item.keys)
        return names


SOURCES = [pytest.param(LaunchSource(path), id=path.name) for path in LAUNCH_FILES]


def test_the_launch_files_exist_and_setup_installs_them():
    assert {path.name for path in LAUNCH_FILES} == {'closed_loop.launch.py',
                                                    'observer.launch.py',
                                                    'observer_controller.launch.py'}
    setup = (REPOSITORY / 'setup.py').read_text(encoding='utf-8')
    assert "('share/' + PACKAGE_NAME + '/launch', glob('launch/*.launch.py'))" in setup


@pytest.mark.parametrize('source', SOURCES)
def test_every_launch_argument_is_documented(source):
    section = LAUNCH_PAGE[LAUNCH_PAGE.index('## Launch files'):]
    section = section[:section.index('\n## ')]
    assert source.path.name in section
    assert source.arguments
    for name, options in source.arguments.items():
        assert f'`{name}`' in section, f'{source.path.name}: {name} is not documented'
        assert 'description' in options and 'default_value' in options, name
    executor = source.arguments['executor']
    assert ast.literal_eval(executor['choices']) == list(EXECUTORS)
    assert executor['default_value'].value == EXECUTORS[0]


@pytest.mark.parametrize('source', SOURCES)
def test_every_executable_is_a_console_script_run_like_the_plain_one(source):
    scripts = console_scripts()
    for kind, options in source.nodes:
        executable = options['executable'].value
        assert executable in scripts and executable in ROLES, executable
        assert options['package'].value == 'observer_ros'
        assert ast.unparse(source.resolve(options['arguments'])) == (
            "['--executor', LaunchConfiguration('executor')]")
        assert source.configuration(options['namespace']) == 'namespace'
        assert (kind == 'LifecycleNode') == executable.endswith('_lifecycle'), executable
        names = source.parameter_names(options['parameters'])
        assert 'use_sim_time' in names
        # autostart is a schema parameter of the managed nodes only.
        assert ('autostart' in names) == (kind == 'LifecycleNode'), executable
        assert 'autostart' in PARAMETER_SPECS
        condition = options.get('condition')
        if executable == 'plant_simulator' and 'lifecycle' in source.arguments:
            # A managed controller sends nothing until active: the plant holds the joint.
            assert 'plant.hold_without_command' in names
        if executable != 'plant_simulator':
            wanted = 'IfCondition' if kind == 'LifecycleNode' else 'UnlessCondition'
            assert condition.func.id == wanted, executable
            assert source.configuration(condition.args[0]) == 'lifecycle'


@pytest.mark.parametrize('source', SOURCES)
def test_remapped_names_are_the_topics_of_the_node(source):
    remapped = {}
    for _, options in source.nodes:
        role = ROLES[options['executable'].value]
        combined = {role, *COMBINED_NODES.get(role, ())}
        topics = {topic for topic, _, roles in TOPIC_ROLES if combined.intersection(roles)}
        if 'remappings' not in options:
            continue
        for pair in source.resolve(options['remappings']).elts:
            name = pair.elts[0].value
            assert name in topics, f'{name} is no topic of {role}'
            remapped[name] = source.configuration(pair.elts[1])
    if source.path.name == 'observer.launch.py':
        assert remapped == {'y': 'measurement_topic', 'u': 'input_topic',
                            'x_hat': 'estimate_topic'}
    assert set(remapped.values()) <= set(source.arguments)


@pytest.mark.parametrize('source', SOURCES)
def test_generate_launch_description_declares_the_arguments(source):
    # The repository's launch/ folder imports as a namespace package: ask for real modules.
    pytest.importorskip('launch.actions')
    pytest.importorskip('launch_ros.actions')
    from launch.actions import DeclareLaunchArgument
    spec = importlib.util.spec_from_file_location(source.path.stem.replace('.', '_'),
                                                  source.path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    description = module.generate_launch_description()
    declared = [entity for entity in description.entities
                if isinstance(entity, DeclareLaunchArgument)]
    assert [entity.name for entity in declared] == list(source.arguments)
    for entity in declared:
        assert entity.description and entity.default_value is not None, entity.name
    executor = next(entity for entity in declared if entity.name == 'executor')
    assert list(executor.choices) == list(EXECUTORS)
