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
``state_feedback_lifecycle``: the state feedback as a managed (lifecycle) node.

The same wiring as ``state_feedback``
(:class:`~observer_ros.nodes.state_feedback.StateFeedbackWiring`), made on ``configure``
instead of at construction; see :mod:`observer_ros.ros.lifecycle` for the transitions. On
deactivation (and on shutdown from active) it publishes ``feedback.safe_command`` exactly
once, then nothing until the next activation, whose watchdog arms with the first estimate.
"""

from observer_ros.config import FEEDBACK
from observer_ros.nodes.state_feedback import StateFeedbackWiring
from observer_ros.ros.lifecycle import ManagedNode
from observer_ros.ros.run import run_node


class StateFeedbackLifecycleNode(StateFeedbackWiring, ManagedNode):
    """The managed state-feedback node (``ros2 lifecycle set /state_feedback configure``)."""

    def __init__(self, node_name: str = 'state_feedback', **kwargs) -> None:
        super().__init__(node_name, FEEDBACK, **kwargs)


def main(args=None) -> int:
    """Entry point of ``ros2 run observer_ros state_feedback_lifecycle``."""
    return run_node(StateFeedbackLifecycleNode, 'state_feedback_lifecycle', args)
