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
The ``main`` of every node executable, and the managed twins, made from the node specs.

Each node executable's console script points here with its name
(``observer_lifecycle = observer_ros.nodes.main:observer_lifecycle``): :func:`main` finds
its :class:`~observer_ros.config.node_specs.NodeSpec`, builds the node class (the plain
node of the spec's module, or its managed twin) and runs it with
:func:`~observer_ros.ros.run.run_node`. A managed twin is not a module of its own: it is
made by :func:`managed_class` from the spec's wiring and
:class:`~observer_ros.ros.lifecycle.ManagedNode`, the same for every node.

Importing it sets ``OPENBLAS_NUM_THREADS=1`` unless it is set already (before numpy loads):
see the guarantees page.
"""

from functools import lru_cache
from importlib import import_module
import os

# One BLAS thread unless the user says otherwise, set before numpy loads: a node's linear
# algebra is on small matrices, where OpenBLAS's threads only queue behind the node's own
# work on a busy machine (scipy's expm 3.7 ms against 0.12 ms at a load of 8 on two cores).
os.environ.setdefault('OPENBLAS_NUM_THREADS', '1')

from observer_ros.config.node_specs import node_spec, NodeSpec  # noqa: E402
from observer_ros.ros.lifecycle import ManagedNode  # noqa: E402
from observer_ros.ros.run import run_node  # noqa: E402


@lru_cache(maxsize=None)
def managed_class(spec: NodeSpec) -> type:
    """
    Return the managed (lifecycle) twin of the node ``spec``: its wiring on a ManagedNode.

    The twin declares the node's parameters (and ``autostart``) at construction and makes
    the same wiring as the plain node on ``configure`` (:mod:`observer_ros.ros.lifecycle`).
    Its class is named after the plain one (``ObserverNode``: ``ObserverLifecycleNode``).

    Raises
    ------
    ValueError
        The spec has no managed twin.

    """
    if not spec.managed:
        raise ValueError(f'node: {spec.name} has no managed twin (its spec says managed=False)')
    wiring = getattr(import_module(spec.module), spec.wiring)

    def __init__(self, node_name: str = spec.name, **kwargs) -> None:
        ManagedNode.__init__(self, node_name, spec.name, **kwargs)

    name = spec.node_class.removesuffix('Node') + 'LifecycleNode'
    return type(name, (wiring, ManagedNode), {
        '__init__': __init__, '__module__': __name__,
        '__doc__': f'The managed {spec.name} node (``ros2 lifecycle set /{spec.name} '
                   f'configure``), made from its spec.'})


def node_class(executable: str) -> type:
    """Return the class the executable ``executable`` runs: the plain node or its twin."""
    spec = node_spec(executable)
    if executable == spec.name:
        return getattr(import_module(spec.module), spec.node_class)
    return managed_class(spec)


def main(executable: str, args=None) -> int:
    """Run the node executable ``executable`` (``observer``, ``observer_lifecycle`` ...)."""
    spec = node_spec(executable)
    done = getattr(import_module(spec.module), spec.done) if spec.done else None
    return run_node(node_class(executable), executable, args, done=done)


def __getattr__(name: str):
    """Return the ``main`` of the node executable ``name`` (the console scripts' target)."""
    try:
        node_spec(name)
    except ValueError:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}') from None

    def executable_main(args=None) -> int:
        return main(name, args)

    executable_main.__name__ = executable_main.__qualname__ = name
    executable_main.__doc__ = f'Entry point of ``ros2 run observer_ros {name}``.'
    return executable_main


__all__ = ['main', 'managed_class', 'node_class']
