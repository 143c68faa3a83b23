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
The nodes of observer_ros, each described once: role, parts, topics, managed twin, executables.

One :class:`NodeSpec` per node in :data:`NODE_SPECS`; everything else asks this table: the
schema's roles, the nodes of each vector topic and the short names of the parameter table
(:mod:`observer_ros.config.schema`), the parts each node builds
(:data:`observer_ros.config.configuration.NODE_PARTS`), the console scripts (``setup.py``
reads this file by its path, so it imports nothing but the standard library), the generic
``main`` and the managed twins (:mod:`observer_ros.nodes.main`) and the index of
``doc/nodes/`` (checked by ``test_the_docs_index_lists_every_executable_of_the_specs``).
The command-line tools that are not nodes are the other rows of the executables,
:data:`TOOLS`.
"""

from dataclasses import dataclass

#: The suffix of a managed (lifecycle) twin's executable: ``observer_lifecycle``.
MANAGED_SUFFIX = '_lifecycle'

#: The module of the generic ``main`` every node executable points at.
NODE_MAIN = 'observer_ros.nodes.main'


@dataclass(frozen=True)
class NodeSpec:
    """
    One node of the package, described once.

    Attributes
    ----------
    name : str
        The node's default name, its role in the schema (the name it declares its
        parameters under) and its executable.
    short : str
        Its name in the "nodes" column of the parameter table.
    parts : tuple of str
        The configuration parts it builds (``'observer'``, ``'feedback'``, ``'plant'``).
    subscribes, publishes : tuple of str
        The vector topics of the schema it subscribes to and publishes (relative names).
    module, node_class, wiring : str
        Where the node lives: ``module`` holds ``node_class`` (the plain node, configured
        at construction) and ``wiring`` (what the managed twin is made from).
    managed : bool
        Whether the node has a managed (lifecycle) twin, ``<name>_lifecycle``.
    combines : tuple of str
        The roles whose parameters it declares besides its own (the observer-controller
        declares the observer's and the state feedback's); empty for a node of its own.
    summary, managed_summary : str
        The node's line (and its twin's) in the index of ``doc/nodes/``.
    done : str
        A function of ``module`` that returns the predicate ending the spin, or empty.

    """

    name: str
    short: str
    parts: tuple
    subscribes: tuple
    publishes: tuple
    module: str
    node_class: str
    wiring: str = ''
    managed: bool = False
    combines: tuple = ()
    summary: str = ''
    managed_summary: str = ''
    done: str = ''

    @property
    def managed_name(self) -> str:
        """Return the executable of the managed twin (``observer_lifecycle``), or empty."""
        return self.name + MANAGED_SUFFIX if self.managed else ''

    @property
    def executables(self) -> tuple:
        """Return the executables of the node: its own, then its managed twin's."""
        return (self.name,) + ((self.managed_name,) if self.managed else ())

    @property
    def topics(self) -> tuple:
        """Return the vector topics it subscribes to or publishes."""
        return self.subscribes + self.publishes


#: Every node, in the order the schema lists them.
NODE_SPECS = (
    NodeSpec(
        'plant_simulator', 'plant', ('plant',),
        subscribes=('u_cmd',), publishes=('y', 'u', 'x_true'),
        module='observer_ros.nodes.plant_simulator', node_class='PlantSimulatorNode',
        summary='the model simulated exactly: publishes `y`, `u`, `x_true` (and `/clock` '
        'in lockstep)', done='plant_done'),
    NodeSpec(
        'observer', 'observer', ('observer',),
        subscribes=('y', 'u'),
        publishes=('x_hat', 'innovation', 'x_hat_covariance', 'innovation_covariance', 'nis'),
        module='observer_ros.nodes.observer', node_class='ObserverNode',
        wiring='ObserverWiring', managed=True,
        summary='`y`, `u` in, the state estimate `x_hat` out',
        managed_summary='the observer as a managed (lifecycle) node'),
    NodeSpec(
        'state_feedback', 'feedback', ('feedback',),
        subscribes=('x_hat', 'reference'), publishes=('u_cmd',),
        module='observer_ros.nodes.state_feedback', node_class='StateFeedbackNode',
        wiring='StateFeedbackWiring', managed=True,
        summary='`x_hat`, `reference` in, the command `u_cmd` out, with a watchdog',
        managed_summary='the state feedback as a managed node'),
    NodeSpec(
        'observer_controller', 'controller', ('observer', 'feedback'),
        subscribes=('y', 'u', 'reference'),
        publishes=('u_cmd', 'x_hat', 'innovation', 'x_hat_covariance',
                   'innovation_covariance', 'nis'),
        module='observer_ros.nodes.observer_controller', node_class='ObserverControllerNode',
        wiring='ObserverControllerWiring', managed=True, combines=('observer', 'state_feedback'),
        summary='observer and state feedback in one node and one callback: `y` in, `u_cmd` '
        'out first',
        managed_summary='the observer-controller as a managed node'),
)

#: The executables that are no node of their own: ``(name, entry point, index line)``.
TOOLS = (
    ('design_observer', 'observer_ros.tools.design_observer:main',
     'designs from a parameter file and prints the report (no ROS needed)'),
    ('closed_loop', 'observer_ros.nodes.closed_loop:main',
     'plant, observer and feedback in one process; reports and records'),
    ('replay', 'observer_ros.tools.replay:main',
     'runs the observer over a rosbag2 bag offline'),
    ('play_bag', 'observer_ros.nodes.bag_player:main',
     "publishes a bag's topics with `/clock` to a running node"),
    ('tune_kalman', 'observer_ros.tools.tune_kalman:main',
     'estimates the Kalman noises `Q` and `R` from recorded bags'),
    ('identify', 'observer_ros.tools.identify:main',
     'identifies a linear model from recorded inputs and outputs'),
)


def node_spec(name: str, specs: tuple = NODE_SPECS) -> NodeSpec:
    """
    Return the spec of the node (or managed twin) called ``name``.

    Raises
    ------
    ValueError
        ``name`` is no node's name or executable; the message lists them.

    """
    for spec in specs:
        if name in spec.executables:
            return spec
    known = ', '.join(name for spec in specs for name in spec.executables)
    raise ValueError(f'node: expected one of {known}, got {name!r}')


def own_nodes(specs: tuple = NODE_SPECS) -> tuple:
    """Return the roles of the nodes that declare only their own parameters, in table order."""
    return tuple(spec.name for spec in specs if not spec.combines)


def combined_nodes(specs: tuple = NODE_SPECS) -> dict:
    """Return ``{role: roles it combines}`` for the nodes that declare others' parameters too."""
    return {spec.name: spec.combines for spec in specs if spec.combines}


def short_names(specs: tuple = NODE_SPECS) -> dict:
    """Return ``{role: short name}`` of every node (the parameter table's "nodes" column)."""
    return {spec.name: spec.short for spec in specs}


def node_parts(specs: tuple = NODE_SPECS) -> dict:
    """Return ``{role: configuration parts}`` of every node."""
    return {spec.name: spec.parts for spec in specs}


def topic_nodes(topic: str, specs: tuple = NODE_SPECS) -> tuple:
    """Return the nodes of their own (:func:`own_nodes`) that use the vector topic ``topic``."""
    return tuple(spec.name for spec in specs if not spec.combines and topic in spec.topics)


def console_scripts(specs: tuple = NODE_SPECS, tools: tuple = TOOLS) -> list:
    """
    Return the ``console_scripts`` of ``setup.py``: every node executable, then the tools.

    A node's executables point at the generic ``main`` with their name
    (``observer_lifecycle = observer_ros.nodes.main:observer_lifecycle``).
    """
    nodes = [f'{name} = {NODE_MAIN}:{name}' for spec in specs for name in spec.executables]
    return nodes + [f'{name} = {target}' for name, target, _ in tools]


def index_rows(specs: tuple = NODE_SPECS, tools: tuple = TOOLS) -> list:
    """Return the rows of the executables table of ``doc/nodes/index.md``, one per executable."""
    rows = []
    for spec in specs:
        rows.append(f'| [`{spec.name}`]({spec.name}.md) | {spec.summary} |')
        if spec.managed:
            name = spec.managed_name
            rows.append(f'| [`{name}`]({name}.md) | {spec.managed_summary} |')
    return rows + [f'| [`{name}`]({name}.md) | {line} |' for name, _, line in tools]


__all__ = ['combined_nodes', 'console_scripts', 'index_rows', 'MANAGED_SUFFIX', 'NODE_MAIN',
           'node_parts', 'node_spec', 'NODE_SPECS', 'NodeSpec', 'own_nodes', 'short_names',
           'topic_nodes', 'TOOLS']
