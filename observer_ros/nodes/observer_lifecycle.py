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
``observer_lifecycle``: the observer as a managed (lifecycle) node.

The same wiring as ``observer`` (:class:`~observer_ros.nodes.observer.ObserverWiring`),
made on ``configure`` instead of at construction; see :mod:`observer_ros.ros.lifecycle`
for the transitions. On deactivation the estimator restarts: the next activation starts
from ``observer.initial_state`` (or the first measurement) instead of an old estimate.
"""

from observer_ros.config import OBSERVER
from observer_ros.nodes.observer import ObserverWiring
from observer_ros.ros.lifecycle import ManagedNode
from observer_ros.ros.run import run_node


class ObserverLifecycleNode(ObserverWiring, ManagedNode):
    """The managed observer node (``ros2 lifecycle set /observer configure``)."""

    def __init__(self, node_name: str = 'observer', **kwargs) -> None:
        super().__init__(node_name, OBSERVER, **kwargs)


def main(args=None) -> int:
    """Entry point of ``ros2 run observer_ros observer_lifecycle``."""
    return run_node(ObserverLifecycleNode, 'observer_lifecycle', args)
