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
ROS parameters to and from the core's one schema.

:class:`ConfiguredNode` declares every parameter of :data:`observer_ros.core.config.PARAMETERS`
(structural ones read-only), validates them with
:func:`observer_ros.core.config.validate_parameters` at start-up and vets every run-time
change with the same function: a rejected change returns the reason and leaves everything
as it was; an accepted one is applied after it is set.
"""

import sys
from typing import Callable, Optional

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.qos import (
    DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy)
from rclpy.qos_overriding_options import QoSOverridingOptions

from observer_ros.core.config import PARAMETERS, System, validate_parameters
from observer_ros.core.errors import ConfigError, DesignError


def volatile_qos(depth: int, reliable: bool) -> QoSProfile:
    """Keep-last ``depth``, volatile, reliable or best effort: the package's QoS shapes."""
    return QoSProfile(depth=depth, history=HistoryPolicy.KEEP_LAST,
                      reliability=(ReliabilityPolicy.RELIABLE if reliable
                                   else ReliabilityPolicy.BEST_EFFORT),
                      durability=DurabilityPolicy.VOLATILE)


#: Subscriptions are best effort, which matches reliable and best-effort publishers alike.
SUBSCRIPTION_QOS = volatile_qos(10, reliable=False)

#: Publishers are reliable: every subscriber QoS can match them.
PUBLISHER_QOS = volatile_qos(10, reliable=True)

#: Users may override history, depth and reliability per topic with the standard
#: ``qos_overrides./<topic>.<publisher|subscription>.<policy>`` parameters.
QOS_OVERRIDES = QoSOverridingOptions.with_default_policies()


class ConfiguredNode(Node):
    """
    A node configured from the shared schema.

    Subclasses read :attr:`system` after ``super().__init__`` and implement
    :meth:`apply_system` to switch to a new validated configuration at run time.

    Raises
    ------
    ConfigError
        From the constructor, naming the parameter, when the start-up configuration is bad.

    """

    def __init__(self, node_name: str, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        for spec in PARAMETERS:
            self.declare_parameter(spec.name, spec.default, ParameterDescriptor(
                description=spec.description, read_only=not spec.dynamic,
                dynamic_typing=True))
        self.system: System = validate_parameters(self.current_parameters())
        self._pending: Optional[System] = None
        self.add_on_set_parameters_callback(self._vet_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

    def current_parameters(self) -> dict:
        """All schema parameters as a flat ``{name: value}`` mapping."""
        return {spec.name: self.get_parameter(spec.name).value for spec in PARAMETERS}

    def _vet_parameters(self, parameters) -> SetParametersResult:
        merged = self.current_parameters()
        touched = False
        for parameter in parameters:
            if parameter.name in merged:
                merged[parameter.name] = parameter.value
                touched = True
        if not touched:
            return SetParametersResult(successful=True)
        try:
            self._pending = validate_parameters(merged)
            self.vet_system(self._pending)
        except (ConfigError, DesignError) as e:
            self._pending = None
            return SetParametersResult(successful=False, reason=str(e))
        return SetParametersResult(successful=True)

    def _apply_parameters(self, parameters) -> None:
        if self._pending is None:
            return
        previous, self.system, self._pending = self.system, self._pending, None
        self.apply_system(previous, self.system)
        self.get_logger().info(
            'parameters updated: ' + ', '.join(p.name for p in parameters))

    def vet_system(self, system: System) -> None:
        """Raise ConfigError if this node cannot run ``system`` (beyond schema checks)."""

    def apply_system(self, previous: System, system: System) -> None:
        """Switch to a newly accepted configuration (called after the parameters are set)."""

    def warn_once(self, key: str, text: str) -> None:
        """Log a warning the first time ``key`` occurs."""
        seen = self.__dict__.setdefault('_warned', set())
        if key not in seen:
            seen.add(key)
            self.get_logger().warning(text + ' (reported once)')


def run_node(factory: Callable[[], Node], program: str, args=None,
             spin: Optional[Callable[[Node], None]] = None) -> int:
    """
    Spin one node the Jazzy way and return the exit status.

    A bad configuration prints one line, ``<program>: error: <parameter>: <reason>``, on
    stderr and returns 2.
    """
    rclpy.init(args=args)
    try:
        node = factory()
    except (ConfigError, DesignError) as e:
        print(f'{program}: error: {e}', file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    try:
        (spin or rclpy.spin)(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
