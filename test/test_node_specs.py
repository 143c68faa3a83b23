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
A node is described once (:mod:`observer_ros.config.node_specs`), and everything asks that.

The schema's roles, the nodes of each vector topic, the short names of the parameter table,
the parts each node builds, the console scripts, the managed twins and the index of
``doc/nodes/`` all come from the one table of node specs.
"""

from dataclasses import replace
import os
import subprocess
import sys

import pytest

from conftest import REPOSITORY
from observer_ros.config import node_specs, schema
from observer_ros.config.configuration import NODE_PARTS
from observer_ros.config.node_specs import NODE_SPECS, NodeSpec


def test_the_schema_roles_topics_and_parts_come_from_the_node_specs():
    assert schema.ALL_NODES == tuple(spec.name for spec in NODE_SPECS if not spec.combines)
    assert schema.COMBINED_NODES == {'observer_controller': ('observer', 'state_feedback')}
    assert NODE_PARTS == {spec.name: spec.parts for spec in NODE_SPECS}
    for topic, _, nodes in schema.TOPIC_ROLES:
        assert nodes == tuple(spec.name for spec in NODE_SPECS
                              if not spec.combines and topic in spec.topics), topic
    # Every vector topic of a spec is one of the schema's, and every one has a node.
    used = {topic for spec in NODE_SPECS for topic in spec.topics}
    assert used == set(schema.TOPICS)


def test_a_node_added_to_the_specs_is_known_everywhere_that_derives_from_them():
    # Before the specs a node missing from the short-name dict was a KeyError in
    # parameter_table, and one missing from NODE_PARTS a KeyError in validate_parameters.
    extra = NodeSpec('estimator_monitor', 'monitor', ('observer',), subscribes=('x_hat',),
                     publishes=(), module='example.monitor', node_class='MonitorNode',
                     wiring='MonitorWiring', managed=True)
    specs = NODE_SPECS + (extra,)
    assert node_specs.short_names(specs)['estimator_monitor'] == 'monitor'
    assert node_specs.node_parts(specs)['estimator_monitor'] == ('observer',)
    assert 'estimator_monitor' in node_specs.own_nodes(specs)
    assert node_specs.topic_nodes('x_hat', specs) == ('observer', 'state_feedback',
                                                      'estimator_monitor')
    scripts = node_specs.console_scripts(specs)
    assert 'estimator_monitor = observer_ros.nodes.main:estimator_monitor' in scripts
    assert ('estimator_monitor_lifecycle = observer_ros.nodes.main:'
            'estimator_monitor_lifecycle') in scripts
    rows = node_specs.index_rows(specs)
    assert '| [`estimator_monitor_lifecycle`](estimator_monitor_lifecycle.md) |  |' in rows
    assert node_specs.node_spec('estimator_monitor_lifecycle', specs) == extra


def test_an_unknown_node_is_an_error_naming_the_known_ones():
    with pytest.raises(ValueError, match=r'node: expected one of plant_simulator, .*'
                       r"observer_lifecycle, .*got 'observr'"):
        node_specs.node_spec('observr')
    with pytest.raises(ValueError, match='node: expected one of'):
        schema.node_parameters('observr')


def test_every_node_role_has_a_short_name_in_the_parameter_table():
    table = schema.parameter_table()
    for spec in NODE_SPECS:
        assert spec.short in table, spec.name
    renamed = tuple(replace(spec, short=spec.short.upper()) for spec in NODE_SPECS)
    assert set(node_specs.short_names(renamed).values()) == {'PLANT', 'OBSERVER', 'FEEDBACK',
                                                             'CONTROLLER'}


def test_the_managed_twins_are_made_from_the_specs_with_no_module_of_their_own():
    from observer_ros.nodes.main import managed_class, node_class
    from observer_ros.ros.lifecycle import ManagedNode
    nodes = REPOSITORY / 'observer_ros' / 'nodes'
    assert not sorted(nodes.glob('*_lifecycle.py'))
    for spec in NODE_SPECS:
        plain = node_class(spec.name)
        assert plain.__name__ == spec.node_class
        if not spec.managed:
            with pytest.raises(ValueError, match=f'node: {spec.name} has no managed twin'):
                managed_class(spec)
            continue
        twin = node_class(spec.managed_name)
        assert twin is managed_class(spec)  # one class per spec
        assert issubclass(twin, ManagedNode)
        assert twin.__name__ == spec.node_class.replace('Node', 'LifecycleNode')
        assert twin.__mro__[1].__name__ == spec.wiring


def test_setup_declares_every_executable_of_the_specs_with_the_generic_main():
    from importlib.metadata import entry_points
    import observer_ros.nodes.main as node_main
    installed = {point.name: point.value for point in entry_points(group='console_scripts')
                 if point.value.startswith('observer_ros.')}
    for spec in NODE_SPECS:
        for name in spec.executables:
            assert installed[name] == f'observer_ros.nodes.main:{name}', name
            assert getattr(node_main, name).__name__ == name
    for name, target, _ in node_specs.TOOLS:
        assert installed[name] == target
    with pytest.raises(AttributeError, match='no attribute'):
        node_main.observer_lifecycle_twin


def test_the_docs_index_lists_every_executable_of_the_specs():
    index = (REPOSITORY / 'doc' / 'nodes' / 'index.md').read_text(encoding='utf-8')
    table = [line for line in index.splitlines() if line.startswith('| [`')]
    assert table == node_specs.index_rows()


@pytest.mark.parametrize('given', [None, '3'])
def test_the_executables_main_sets_one_blas_thread_before_numpy_loads(given):
    # A node's algebra is on small matrices: OpenBLAS's threads only queue behind it on a
    # busy machine. The executables' one main sets the default before numpy loads; a value
    # the user set stays.
    environment = {key: value for key, value in os.environ.items()
                   if key != 'OPENBLAS_NUM_THREADS'}
    if given is not None:
        environment['OPENBLAS_NUM_THREADS'] = given
    script = ('import sys; import observer_ros.nodes.main; from threadpoolctl import '
              'threadpool_info; print([pool["num_threads"] for pool in threadpool_info() '
              'if pool["internal_api"] == "openblas"][:1] or [0])')
    result = subprocess.run([sys.executable, '-c', script], env=environment, check=True,
                            capture_output=True, text=True, timeout=120)
    expected = 1 if given is None else min(int(given), os.cpu_count())
    assert result.stdout.strip() in (f'[{expected}]', '[0]'), result.stdout
