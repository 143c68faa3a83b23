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
Managed (lifecycle) nodes on the schema parameters, with the plain nodes' wiring.

A :class:`ManagedNode` declares its parameters at construction and does nothing else: the
node's wiring (the same ``build`` the plain node runs in its constructor) is made by
``configure`` and released by ``cleanup``:

- ``configure`` validates the parameters and designs exactly as the plain node's start-up
  does; a bad configuration fails the transition, logs the plain node's one-line reason
  (``configure failed: observer.poles: ...``) and leaves the node unconfigured.
- ``activate`` enables the output (lifecycle publishers) and the subscriptions' callbacks;
  before it, messages that arrive are dropped and nothing is published on the output topics
  (``/diagnostics`` is published from ``configure`` on).
- ``deactivate`` calls the wiring's ``pause`` while the output is still enabled (the
  feedback node publishes its safe command once there), then disables the output.
- ``cleanup`` destroys, by name, every publisher, subscription, timer, service and client
  that ``configure`` made (:attr:`ManagedNode.made`, recorded as they are created) and drops
  the parts the wiring made (its ``PARTS``: the observer part, the feedback part, the
  health), where all the node's running state lives, so a later ``configure`` starts from
  the parameters as they are then; ``shutdown`` does the same from any state.

While unconfigured every parameter may be set (types are checked, configure validates);
once configured, structural parameters are refused with a reason and the others are vetted
as in the plain node. ``autostart`` configures and activates the node at construction.
"""

from typing import Optional

from rclpy.impl.implementation_singleton import rclpy_implementation
from rclpy.lifecycle import (
    LifecycleNode, LifecyclePublisher, LifecycleState, TransitionCallbackReturn)
from rclpy.publisher import Publisher
from rclpy.subscription import Subscription

from observer_ros.config import Configuration, ParameterSpec, validate_parameters
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.ros.parameters import SchemaParameters

#: The node method that destroys each kind of entity a configure may create.
DESTROYERS = {'publisher': 'destroy_publisher', 'subscription': 'destroy_subscription',
              'timer': 'destroy_timer', 'service': 'destroy_service',
              'client': 'destroy_client'}


class ManagedNode(SchemaParameters, LifecycleNode):
    """
    A lifecycle node configured from the shared schema by its ``configure`` transition.

    Subclasses put the plain node's wiring before this class in their bases: ``build``
    (make the parts, which make the estimator or law, publishers, subscriptions and timers
    for a validated ``system``), ``vet_system``, ``apply_system`` and optionally ``pause``
    (stop timers and send what deactivation owes) and ``resume``; ``PARTS`` names the
    attributes ``build`` sets.
    """

    def __init__(self, node_name: str, role: str, **kwargs) -> None:
        super().__init__(node_name, **kwargs)
        self.declare_schema(role, managed=True)
        self.active = False
        self.finalized = False
        #: Messages that arrived on a subscription while the node was not active.
        self.dropped_while_inactive = 0
        self.configure_error: Optional[str] = None
        #: What the running configure made: ``{name: entity}`` (``publisher x_hat``,
        #: ``timer _on_watchdog``), None outside configure and once released.
        self.made: Optional[dict] = None
        #: The parts configure made (the wiring's ``PARTS`` it set), by attribute name.
        self.made_attributes: Optional[set] = None
        self._making = False
        self._refuse_unknown_transitions()
        if self.get_parameter('autostart').value:
            if self.trigger_configure() == TransitionCallbackReturn.SUCCESS:
                self.trigger_activate()

    def _refuse_unknown_transitions(self) -> None:
        """
        Answer a transition the current state does not have with ``success: false``.

        rclpy's ``change_state`` handler raises inside the executor for one (``ros2 service
        call .../change_state`` with ``activate`` on an unconfigured node), which would end
        the node's spin; rclpy exposes no hook, so its service callback is wrapped.
        """
        service = self._service_change_state
        handler = service.callback

        def refusing(request, response):
            try:
                return handler(request, response)
            except rclpy_implementation.RCLError:
                state = self._state_machine.current_state[1]
                transition = request.transition.label or request.transition.id
                self.get_logger().warning(
                    f'transition {transition} refused: the state {state} has no such '
                    f'transition (ros2 lifecycle list {self.get_fully_qualified_name()})')
                response.success = False
                return response

        service.callback = refusing

    #: The attributes the wiring's ``build`` sets: its parts (dropped on cleanup).
    PARTS: tuple = ()

    # --- the wiring's hooks (the plain nodes' mixins override build, pause and resume) --

    def build(self, system: Configuration) -> None:
        """Create the node's wiring for ``system`` (see the node modules)."""
        raise NotImplementedError

    def pause(self) -> None:
        """Stop work on deactivation, while the output is still enabled."""

    def resume(self) -> None:
        """Start work on activation."""

    # --- parameters ----------------------------------------------------------------------

    def change_problem(self, spec: ParameterSpec) -> Optional[str]:
        """Refuse changes of structural parameters while the node is configured."""
        if spec.dynamic or self.system is None:
            return None
        name = self.get_fully_qualified_name()
        return (f'{spec.name}: read-only while {name} is configured; clean it up '
                f'(ros2 lifecycle set {name} cleanup), set it, then configure again')

    def output_publisher(self, *args, **kwargs) -> Publisher:
        """Create a lifecycle publisher: it publishes only while the node is active."""
        return self.create_lifecycle_publisher(*args, **kwargs)

    def topic_subscription(self, message_class: type, topic: str, callback) -> Subscription:
        """Subscribe like the plain node; messages are dropped while the node is not active."""
        def when_active(message) -> None:
            if self.active:
                callback(message)
            else:
                self.dropped_while_inactive += 1
        return super().topic_subscription(message_class, topic, when_active)

    # --- transitions -----------------------------------------------------------------------

    def on_configure(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Validate the parameters, design and build the wiring; fail with the reason."""
        self.made, self.made_attributes = {}, set()
        self._making = True
        error = None
        try:
            self.system = validate_parameters(self.current_parameters(), node=self.role)
            self.build(self.system)  # vets the system first, as the plain node does
        except (ConfigError, DesignError) as e:
            error = e
        except Exception as e:  # rclpy turns it into on_error silently: say what it was
            self.get_logger().error(f'configure raised {type(e).__name__}: {e}')
            raise
        finally:
            self._making = False  # on_error releases what was made too
            self.made_attributes = {name for name in self.PARTS if name in vars(self)}
        if error is not None:
            self._release()
            self.configure_error = str(error)
            self.get_logger().error(f'configure failed: {error}')
            return TransitionCallbackReturn.FAILURE
        self.configure_error = None
        return super().on_configure(state)

    def on_activate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Enable the output and the subscriptions' callbacks."""
        self.resume()
        self.active = True
        return super().on_activate(state)

    def on_deactivate(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Pause (while the output is still enabled), then disable the output."""
        self.active = False
        self.pause()
        return super().on_deactivate(state)

    def on_cleanup(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Release everything configure made; the node is unconfigured again."""
        self._release()
        return super().on_cleanup(state)

    def on_shutdown(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Pause if active, then release everything (from any state)."""
        if self.active:
            self.on_deactivate(state)
        self._release()
        self.finalized = True
        return super().on_shutdown(state)

    def on_error(self, state: LifecycleState) -> TransitionCallbackReturn:
        """Release everything after a transition raised; the node is unconfigured again."""
        self.active = False
        self._release()
        return TransitionCallbackReturn.SUCCESS

    def destroy_node(self) -> None:
        """Shut down first (the feedback node's safe command if it was active), then destroy."""
        if not self.finalized:
            try:
                self.trigger_shutdown()
            except rclpy_implementation.RCLError as e:  # in a transition, or ROS is down
                self.get_logger().warning(f'no shutdown transition before destroy: {e}')
        super().destroy_node()

    # --- what configure made ---------------------------------------------------------------

    def _register(self, kind: str, name: str, entity):
        """Record an entity configure made under ``<kind> <name>`` and return it."""
        if self.__dict__.get('_making'):
            key, count = f'{kind} {name}', 1
            while key in self.made:
                count += 1
                key = f'{kind} {name} #{count}'
            self.made[key] = entity
        return entity

    def create_publisher(self, msg_type, topic: str, *args, **kwargs):
        """Create a publisher, recorded while configuring."""
        return self._register('publisher', topic,
                              super().create_publisher(msg_type, topic, *args, **kwargs))

    def create_lifecycle_publisher(self, msg_type, topic: str, *args, **kwargs):
        """Create a lifecycle publisher, recorded while configuring."""
        return self._register('publisher', topic, super().create_lifecycle_publisher(
            msg_type, topic, *args, **kwargs))

    def create_subscription(self, msg_type, topic: str, *args, **kwargs):
        """Create a subscription, recorded while configuring."""
        return self._register('subscription', topic,
                              super().create_subscription(msg_type, topic, *args, **kwargs))

    def create_timer(self, timer_period_sec: float, callback, *args, **kwargs):
        """Create a timer, recorded by its callback's name while configuring."""
        name = getattr(callback, '__name__', type(callback).__name__)
        return self._register('timer', name, super().create_timer(
            timer_period_sec, callback, *args, **kwargs))

    def create_service(self, srv_type, srv_name: str, *args, **kwargs):
        """Create a service, recorded while configuring."""
        return self._register('service', srv_name,
                              super().create_service(srv_type, srv_name, *args, **kwargs))

    def create_client(self, srv_type, srv_name: str, *args, **kwargs):
        """Create a client, recorded while configuring."""
        return self._register('client', srv_name,
                              super().create_client(srv_type, srv_name, *args, **kwargs))

    def _release(self) -> None:
        """Destroy, by name, the entities configure made and drop the parts it set."""
        made = self.made
        self.made = self.made_attributes = None
        self.system = self._pending = None
        self.active = False
        for name, entity in (made or {}).items():
            if isinstance(entity, LifecyclePublisher):
                self.destroy_lifecycle_publisher(entity)
            else:
                getattr(self, DESTROYERS[name.split()[0]])(entity)
        for name in self.PARTS:
            vars(self).pop(name, None)
