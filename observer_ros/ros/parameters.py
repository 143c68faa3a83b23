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
ROS parameters to and from the core's one schema, declared with their schema types.

:class:`ConfiguredNode` declares the parameters of :data:`observer_ros.config.PARAMETERS`
its node uses (structural ones read-only), validates them with
:func:`observer_ros.config.validate_parameters` at start-up and vets every run-time
change with the same function: a rejected change returns the reason and leaves everything
as it was; an accepted one is applied after it is set.
"""

from types import SimpleNamespace
from typing import Callable, Optional

from rcl_interfaces.msg import ParameterDescriptor, SetParametersResult
from rclpy.event_handler import PublisherEventCallbacks, UnsupportedEventTypeError
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.publisher import Publisher
from rclpy.subscription import Subscription

from observer_ros.config import (
    Configuration, node_parameters, PARAMETER_SPECS, ParameterSpec, validate_parameters)
from observer_ros.config.parameter_check import source_names, SOURCES_PREFIX, unknown_parameter
from observer_ros.config.schema import source_specs
from observer_ros.core.arguments import (
    BOOL, DOUBLE, DOUBLE_ARRAY, INTEGER, STRING, STRING_ARRAY)
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.ros.clock import guard_clock
from observer_ros.ros.qos import publisher_qos, QOS_OVERRIDES, subscription_qos


#: The ROS parameter type of each schema value type.
PARAMETER_TYPES = {
    DOUBLE: Parameter.Type.DOUBLE, DOUBLE_ARRAY: Parameter.Type.DOUBLE_ARRAY,
    STRING: Parameter.Type.STRING, STRING_ARRAY: Parameter.Type.STRING_ARRAY,
    INTEGER: Parameter.Type.INTEGER, BOOL: Parameter.Type.BOOL}


def coerced(spec: ParameterSpec, parameter: Parameter) -> Parameter:
    """
    Return ``parameter`` converted to the schema type where no value changes meaning.

    Integers become doubles for double parameters (``ros2 param set ... "[1, 2]"``), numbers
    become strings for pole lists; anything else is returned as it is, for the validation
    to refuse with a reason.
    """
    value_type, value, given = spec.value_type, parameter.value, parameter.type_
    if value_type == DOUBLE and given == Parameter.Type.INTEGER:
        return Parameter(parameter.name, Parameter.Type.DOUBLE, float(value))
    if value_type == DOUBLE_ARRAY and given in (Parameter.Type.INTEGER_ARRAY,
                                                Parameter.Type.BYTE_ARRAY) and (
            given == Parameter.Type.INTEGER_ARRAY or len(value) == 0):
        return Parameter(parameter.name, Parameter.Type.DOUBLE_ARRAY,
                         [float(item) for item in value])
    if value_type == STRING_ARRAY and (given in (Parameter.Type.DOUBLE_ARRAY,
                                                 Parameter.Type.INTEGER_ARRAY) or (
            given == Parameter.Type.BYTE_ARRAY and len(value) == 0)):
        return Parameter(parameter.name, Parameter.Type.STRING_ARRAY,
                         [str(item) for item in value])
    return parameter


def type_problem(spec: ParameterSpec, parameter: Parameter) -> Optional[str]:
    """Say why ``parameter`` cannot be the schema parameter ``spec`` (None when it can)."""
    if parameter.type_ == Parameter.Type.NOT_SET:
        return (f'{spec.name}: cannot be unset (NOT_SET); set its default '
                f'{spec.default!r} instead')
    if parameter.type_ != PARAMETER_TYPES[spec.value_type]:
        given = parameter.type_.name.lower()
        return f'{spec.name}: expected {spec.value_type}, got {given} {parameter.value!r}'
    return None


class SchemaParameters:
    """
    The schema parameters of a node: a mixin for ``Node`` and ``LifecycleNode``.

    :meth:`declare_schema` declares the parameters of a ``role``
    (:func:`observer_ros.config.node_parameters`) statically typed with their schema types
    (:data:`PARAMETER_TYPES`) and installs the callbacks that vet every set-parameters
    request before anything changes: a parameter set to NOT_SET or to another type is
    refused with a reason naming it (integers are taken as doubles, in a parameter file as
    in a request), and, once :attr:`system` holds a configuration, the merged values must
    pass :func:`~observer_ros.config.validate_parameters` and :meth:`vet_system`; an
    accepted change goes to :meth:`apply_system` after it is set. While :attr:`system` is
    None (a managed node not configured yet) only the types are checked: configuring
    validates.

    A parameter file that gives a parameter a value of another type (a string for a
    double) is the one case declared with dynamic typing: the parameter holds that value,
    so that validation refuses it by name with the reason it always gave (a plain node stops
    with it, a managed node stays unconfigured and may be set right); a statically typed
    parameter cannot hold it.
    """

    def declare_schema(self, role: str, managed: bool = False) -> None:
        """
        Declare the parameters of ``role`` and install the parameter callbacks.

        A plain node's structural parameters are read-only; a ``managed`` node's may be
        set while it is unconfigured (see :meth:`change_problem`), and it also declares
        the lifecycle parameters.
        """
        self.invalid_clock = 0
        guard_clock(self, self._on_invalid_clock)
        self.role = role
        self.managed = managed
        self.specs = {spec.name: spec for spec in node_parameters(role, managed)}
        self.system: Optional[Configuration] = None
        self._pending: Optional[Configuration] = None
        for spec in list(self.specs.values()):
            self._declare(spec)
        self._declare_sources()
        self._warn_unknown_overrides()
        self.add_pre_set_parameters_callback(self._coerce_parameters)
        self.add_on_set_parameters_callback(self._vet_parameters)
        self.add_post_set_parameters_callback(self._apply_parameters)

    def _declare_sources(self) -> None:
        """
        Declare ``sources.<name>.*`` of each name ``observer.sources`` gives (when declared).

        The names are read once, at declaration: ``observer.sources`` is structural. Names
        that are not valid are left to the validation, which refuses them by name.
        """
        if 'observer.sources' not in self.specs:
            return
        try:
            names = source_names(list(self.get_parameter('observer.sources').value))
        except ConfigError:
            return
        for name in names:
            for spec in source_specs(name):
                self.specs[spec.name] = spec
                self._declare(spec)

    def _declare(self, spec: ParameterSpec) -> None:
        # rclpy refuses an integer from a parameter file for a double parameter: read the
        # file's value here (ignore_override) and convert it to the schema type first.
        given = self._overrides().get(spec.name)
        if given is None:
            given = Parameter(spec.name, value=spec.default)
        typed = coerced(spec, given)
        read_only = not (spec.dynamic or self.managed)
        declared_type = PARAMETER_TYPES[spec.value_type]
        if type_problem(spec, typed) is not None:  # see the class docstring
            self.declare_parameter(spec.name, given.value, self._descriptor(
                spec, read_only, dynamic=True), ignore_override=True)
        elif Parameter.Type.from_parameter_value(typed.value) == declared_type:
            self.declare_parameter(spec.name, typed.value, self._descriptor(spec, read_only),
                                   ignore_override=True)
        else:  # an empty list, which rclpy takes for a byte array: declare the type alone,
            # set the value, then make it read-only (a read-only parameter cannot be set)
            self.declare_parameter(spec.name, declared_type, self._descriptor(spec, False),
                                   ignore_override=True)
            super().set_parameters_atomically([typed])
            if read_only:
                self.set_descriptor(spec.name, self._descriptor(spec, True))

    def _descriptor(self, spec: ParameterSpec, read_only: bool,
                    dynamic: bool = False) -> ParameterDescriptor:
        return ParameterDescriptor(
            description=spec.description, read_only=read_only, dynamic_typing=dynamic,
            type=0 if dynamic else PARAMETER_TYPES[spec.value_type].value,
            additional_constraints=self._constraints(spec))

    def _overrides(self) -> dict:
        return getattr(self, '_parameter_overrides', {})  # rclpy keeps no public copy

    @staticmethod
    def _constraints(spec: ParameterSpec) -> str:
        limits = spec.range_text() or (f'entries of magnitude <= {spec.entry_limit:g}'
                                       if spec.entry_limit else '')
        return f'{spec.value_type}{" in " + limits if limits else ""}'

    def _warn_unknown_overrides(self) -> None:
        """Warn about names of this node's sections in the parameter file that none has."""
        sections = {name.split('.', 1)[0] + '.' for name in self.specs}
        given = self._overrides()
        unknown = sorted(name for name in given if name.startswith(tuple(sections))
                         and name not in PARAMETER_SPECS and name not in self.specs
                         and not name.startswith(SOURCES_PREFIX))
        for name in unknown:
            self.get_logger().warning(
                f'{name} in the parameter file is ignored: '
                f'{unknown_parameter(name, set(self.specs) | set(PARAMETER_SPECS))}')

    def _on_invalid_clock(self, problem: str) -> None:
        self.invalid_clock += 1
        self.warn_once('invalid clock', f'dropped a /clock message: {problem}')

    def current_parameters(self) -> dict:
        """
        Return this node's schema parameters as a flat ``{name: value}`` mapping.

        With ``observer.sources``, the parameter file's ``sources.*`` that no named source
        has are included, so that the validation refuses them by name.
        """
        current = {name: self.get_parameter(name).value for name in self.specs}
        if 'observer.sources' in self.specs:
            current.update({name: parameter.value
                            for name, parameter in self._overrides().items()
                            if name.startswith(SOURCES_PREFIX) and name not in self.specs})
        return current

    def _coerce_parameters(self, parameters) -> list:
        return [coerced(self.specs[p.name], p) if p.name in self.specs else p
                for p in parameters]

    def set_parameters(self, parameter_list: list) -> list:
        """Set each parameter on its own, as rclpy does, with :meth:`set_parameters_atomically`."""
        return [self.set_parameters_atomically([parameter]) for parameter in parameter_list]

    def set_parameters_atomically(self, parameter_list: list) -> SetParametersResult:
        """
        Set the parameters all together or none, the schema's refusals coming first.

        rclpy checks a statically typed parameter's type before any callback, with a reason
        that names no parameter: a schema parameter that is NOT_SET or of another type
        (after the integer-to-double conversion), or that cannot change now, is refused
        here first with :func:`type_problem`'s or :meth:`change_problem`'s reason, in the
        order given. Undeclared and read-only parameters are left to rclpy, which raises or
        refuses before anything else, as with dynamic typing.
        """
        refusal = self._refusal(parameter_list)
        if refusal is not None:
            return refusal
        return super().set_parameters_atomically(parameter_list)

    def _refusal(self, parameters: list) -> Optional[SetParametersResult]:
        if not all(self.has_parameter(parameter.name) for parameter in parameters):
            return None  # rclpy raises ParameterNotDeclaredException
        for parameter in parameters:
            if self.describe_parameter(parameter.name).read_only:
                return super().set_parameters_atomically([parameter])  # rclpy's refusal
        for parameter in parameters:
            spec = self.specs.get(parameter.name)
            if spec is None:
                continue
            problem = type_problem(spec, coerced(spec, parameter)) or self.change_problem(spec)
            if problem:
                return SetParametersResult(successful=False, reason=problem)
        return None

    def _vet_parameters(self, parameters) -> SetParametersResult:
        # Types and changes were vetted by set_parameters_atomically; here: the values.
        merged = self.current_parameters()
        touched = False
        for parameter in parameters:
            if parameter.name in self.specs:
                merged[parameter.name] = parameter.value
                touched = True
        if not touched or self.system is None:
            return SetParametersResult(successful=True)
        try:
            self._pending = validate_parameters(merged, node=self.role)
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

    def change_problem(self, spec: ParameterSpec) -> Optional[str]:
        """Say why ``spec`` cannot change now (None when it can; see the managed nodes)."""
        return None

    def vet_system(self, system: Configuration) -> None:
        """Raise ConfigError if this node cannot run ``system`` (beyond schema checks)."""

    def apply_system(self, previous: Configuration, system: Configuration) -> None:
        """Switch to a newly accepted configuration (called after the parameters are set)."""

    def topic_publisher(self, message_class: type, topic: str,
                        matched: Optional[Callable] = None) -> Publisher:
        """
        Create a publisher with :func:`publisher_qos` (``qos_overrides`` apply).

        ``matched(status)`` is called (by the executor, off the message path) whenever a
        subscription matches or goes, ``status.current_count`` the subscriptions matched
        now; where the middleware has no matched events it is called once with a count of 1
        (the topic is then always published).
        """
        if matched is None:
            return self.output_publisher(message_class, topic, publisher_qos(),
                                         qos_overriding_options=QOS_OVERRIDES)
        try:
            return self.output_publisher(
                message_class, topic, publisher_qos(), qos_overriding_options=QOS_OVERRIDES,
                event_callbacks=PublisherEventCallbacks(matched=matched))
        except UnsupportedEventTypeError:
            matched(SimpleNamespace(current_count=1))
            return self.output_publisher(message_class, topic, publisher_qos(),
                                         qos_overriding_options=QOS_OVERRIDES)

    def output_publisher(self, *args, **kwargs) -> Publisher:
        """Create a publisher of the node's output (a managed node's is a lifecycle one)."""
        return self.create_publisher(*args, **kwargs)

    def topic_subscription(self, message_class: type, topic: str,
                           callback: Callable[[bytes], None]) -> Subscription:
        """
        Create a subscription with :func:`subscription_qos` (``qos_overrides`` apply).

        ``callback`` receives the serialized bytes (see ``VectorCodec.decode``).
        """
        return self.create_subscription(message_class, topic, callback, subscription_qos(),
                                        qos_overriding_options=QOS_OVERRIDES, raw=True)

    def warn_once(self, key: str, text: str) -> None:
        """Log a warning the first time ``key`` occurs."""
        seen = self.__dict__.setdefault('_warned', set())
        if key not in seen:
            seen.add(key)
            self.get_logger().warning(text + ' (reported once)')


class ConfiguredNode(SchemaParameters, Node):
    """
    A node configured from the shared schema at construction.

    Declares the parameters of its ``role`` (:meth:`SchemaParameters.declare_schema`),
    structural ones read-only, and validates them: subclasses read :attr:`system` after
    ``super().__init__`` and implement :meth:`apply_system` to switch to a new validated
    configuration at run time.

    Raises
    ------
    ConfigError
        From the constructor, naming the parameter, when the start-up configuration is bad.

    """

    def __init__(self, node_name: str, role: str, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.declare_schema(role)
        self.system = validate_parameters(self.current_parameters(), node=role)


__all__ = ['ConfiguredNode', 'PARAMETER_TYPES', 'SchemaParameters', 'coerced',
           'type_problem']
