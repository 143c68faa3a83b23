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
``observer_controller_lifecycle``: the observer-controller as a managed (lifecycle) node.

The same wiring as ``observer_controller``
(:class:`~observer_ros.nodes.observer_controller.ObserverControllerWiring`), made on
``configure`` instead of at construction; see :mod:`observer_ros.ros.lifecycle` for the
transitions. On deactivation (and on shutdown from active) the estimator restarts and the
node publishes ``feedback.safe_command`` exactly once, then nothing until the next
activation.
"""

from observer_ros.config import CONTROLLER
from observer_ros.nodes.observer_controller import ObserverControllerWiring
from observer_ros.ros.lifecycle import ManagedNode
from observer_ros.ros.run import run_node


class ObserverControllerLifecycleNode(ObserverControllerWiring, ManagedNode):
    """The managed observer-controller (``ros2 lifecycle set /observer_controller ...``)."""

    def __init__(self, node_name: str = 'observer_controller', **kwargs) -> None:
        super().__init__(node_name, CONTROLLER, **kwargs)


def main(args=None) -> int:
    """Entry point of ``ros2 run observer_ros observer_controller_lifecycle``."""
    return run_node(ObserverControllerLifecycleNode, 'observer_controller_lifecycle', args)
