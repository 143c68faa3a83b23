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
``observer_controller``: the observer and the state feedback in one node and one callback.

Each ``y`` (with the applied ``u`` when the plant reports one) goes through the observer's
observer part (:class:`~observer_ros.nodes.observer.ObserverPart`) and each estimate it
gives through the node's feedback part (:class:`~observer_ros.nodes.state_feedback.
FeedbackPart`) in the same callback: ``u_cmd`` is published first, then ``x_hat``,
``joint_states_hat``, the innovation, the covariances and NIS, as the observer publishes
them. No DDS hop between estimate and command, and the same parameters, sections and checks
as the two nodes (every observer type; reference gain, disturbance rejection, integral
action with anti-windup, input limits, the watchdog and safe command).

``controller.input`` says where the input of the next prediction comes from:

- ``u`` (default): the applied input the plant reports on ``u``, as the observer node takes
  it; the commands equal those of ``observer`` + ``state_feedback`` bit for bit.
- ``command``: no ``u`` topic; the command the node sent is taken as the input applied from
  the next sample on (what ``plant_simulator`` and a driver that writes commands at its next
  cycle do), ``feedback.safe_command`` before the first one. It is the command after
  ``feedback.input_limits``: an actuator that saturates below them, adds an offset or applies
  a command late makes the prediction wrong (the disturbance states absorb a constant
  error). With a feedthrough ``D`` that command is given to the stream before the
  measurement of the sample it is applied at, since ``D u`` needs it there.

The watchdog: ``feedback.timeout`` steady-clock seconds without an estimate (no ``y``, or
every ``y`` dropped) and the node publishes ``feedback.safe_command``, repeated every
``feedback.safe_command_period`` until the next estimate. Estimates predicted by
``observer.publish_rate`` are published on ``x_hat`` but give no command. The closed loop's
poles (the observer's, ``A - B K``'s, the integrators') are logged at start-up and
published on ``/diagnostics`` with the configuration.
"""

from collections import Counter
from typing import Optional

import numpy as np

from observer_ros.config import CONTROLLER
from observer_ros.core.rules import within_limit
from observer_ros.nodes.observer import ObserverPart, ObserverWiring
from observer_ros.nodes.state_feedback import FeedbackPart
from observer_ros.ros.diagnostics import monitor
from observer_ros.ros.parameters import ConfiguredNode


def _poles_text(poles) -> str:
    """``[-9, -8, -3+4j, -3-4j]``: real poles as numbers, 4 significant digits."""
    texts = [f'{p.real:.4g}' if p.imag == 0 else f'{p:.4g}'.strip('()')
             for p in (complex(pole) for pole in poles)]
    return '[' + ', '.join(texts) + ']'


class CommandFirst:
    """
    The observer-controller's hooks in its observer part: each estimate's command first.

    ``measured`` keeps a measurement for the integral action and, with
    ``controller.input: command`` and a feedthrough, gives the stream the command in effect
    before the measurement; ``estimated`` publishes the command of each estimate before its
    ``x_hat`` (the plant waits for it); ``published`` gives the commands to the stream as the
    inputs of the next intervals (``controller.input: command`` without a feedthrough), once
    the estimates are out, so the stream prepares the next step with them.
    """

    def __init__(self, feedback_part: FeedbackPart, commands_as_input: bool) -> None:
        self.feedback = feedback_part
        self.commands_as_input = commands_as_input
        self.observer = None  # the observer part, set once it is made
        #: With commands as inputs, ``add_input`` prepares the step: not after publishing.
        self.prepares_after_publish = not commands_as_input
        self._no_feedthrough = True

    def attach(self, observer) -> None:
        """Work with the observer part ``observer`` (built): its stream says about D."""
        self.observer = observer
        self._no_feedthrough = observer.stream.estimator.feedthrough is None
        self.prepares_after_publish = not (self.commands_as_input and self._no_feedthrough)

    def measured(self, stamp: int, y) -> None:
        """Keep a measurement for the integrator and give the input ``D u`` needs, if any."""
        feedback = self.feedback
        if feedback.law.integral is not None:
            values = np.asarray(y, dtype=float)
            if within_limit(values, feedback.feedback_limits['y']):
                feedback.integrate_measurement(stamp, values)
        if self.commands_as_input and not self._no_feedthrough:
            # D u needs the input in effect at this stamp: the command sent before, which
            # the plant applies from this sample on; given before the measurement.
            self.observer.run(self.observer.stream.add_input, stamp, feedback.sent)

    def estimated(self, samples) -> Optional[list]:
        """Publish the command of each estimate (u_cmd first); return what was in effect."""
        feedback = self.feedback
        if not (self.commands_as_input and self._no_feedthrough):
            for sample in samples:
                feedback.command_for(sample.stamp_ns, sample.estimate)
            return None
        applied = []  # (stamp, the command in effect from that sample on)
        for sample in samples:
            applied.append((sample.stamp_ns, feedback.sent))
            feedback.command_for(sample.stamp_ns, sample.estimate)  # the new feedback.sent
        return applied

    def published(self, applied: Optional[list]) -> None:
        """Give the commands sent to the stream as the inputs of the next intervals."""
        if not applied:
            return
        observer = self.observer
        for stamp, command in applied:
            released = observer.stream.add_input(stamp, command)
            if released:
                observer.publish(released)


class ObserverControllerWiring:
    """
    The controller's wiring: an observer part and a feedback part side by side.

    The observer part's hooks (:class:`CommandFirst`) turn each estimate into ``u_cmd``
    before ``x_hat`` is published. :class:`ObserverControllerNode` builds it in its
    constructor, the managed variant (made from its spec by
    :func:`observer_ros.nodes.main.managed_class`) on ``configure``.
    """

    #: The attributes :meth:`build` sets (a managed node drops them on cleanup).
    PARTS = ('observer_part', 'feedback_part', 'health', 'diagnostics')

    def build(self, system) -> None:
        """Make the feedback part (``u_cmd`` first), then the observer part and the health."""
        self.vet_system(system)
        self.feedback_part = feedback = FeedbackPart(self, stale_input='estimate')
        commands_as_input = system.sections.controller.input_source == 'command'
        feedback.build(system)
        hooks = CommandFirst(feedback, commands_as_input)
        self.observer_part = part = ObserverPart(self, hooks, primary=())
        part.build(system, inputs=system.model.n_inputs > 0 and not commands_as_input)
        hooks.attach(part)
        self.health = part.health
        self.diagnostics = part.health.publisher
        self.health.watch('reference', monitor(system, 'reference', 0.0, required=False,
                                               rated=False))
        self._log_loop(system)

    def _log_loop(self, system) -> None:
        """Log the closed loop's poles (and the analysis notes) at start-up."""
        feedback, loop = system.feedback, system.loop
        integral = ' with the integrators' if feedback.integral is not None else ''
        text = (f'closed loop: A - B K{integral} poles '
                f'{_poles_text(feedback.design.achieved_poles)}, observer poles '
                f'{_poles_text(system.observer.design.achieved_poles)}')
        if loop.closed_loop_poles is not None:
            text += f'; together {_poles_text(loop.closed_loop_poles)}'
        self.get_logger().info(text)
        for note in loop.notes:
            self.get_logger().info(note)

    def subscribes_input(self, system) -> bool:
        """Whether ``u`` is subscribed: not with ``controller.input: command``."""
        return (system.model.n_inputs > 0
                and system.sections.controller.input_source != 'command')

    def vet_system(self, system) -> None:
        """Refuse what either node would refuse."""
        (self.__dict__.get('feedback_part') or FeedbackPart(self)).vet(system)
        (self.__dict__.get('observer_part') or ObserverPart(self)).vet(system)

    def apply_system(self, previous, system) -> None:
        """Switch the observer's gains (the estimate kept) and the law's."""
        self.observer_part.apply(previous, system)
        self.feedback_part.apply(previous, system)

    def counters(self) -> Counter:
        """Stream, observer and command counts together."""
        return self.observer_part.counters() + self.feedback_part.command_counters

    def pause(self) -> None:
        """Deactivation: the estimator restarts; one safe command, then silence."""
        self.observer_part.pause()
        self.feedback_part.pause()

    def resume(self) -> None:
        """Activation: predictions (``observer.publish_rate``) start again."""
        self.observer_part.resume()

    stream = ObserverWiring.stream
    codecs = ObserverWiring.codecs
    sources = ObserverWiring.sources
    source_drops = ObserverWiring.source_drops
    node_counters = ObserverWiring.node_counters
    publishers_ = ObserverWiring.publishers_


class ObserverControllerNode(ObserverControllerWiring, ConfiguredNode):
    """The observer-controller node, configured and running from its construction."""

    def __init__(self, node_name: str = 'observer_controller', **kwargs) -> None:
        super().__init__(node_name, CONTROLLER, **kwargs)
        self.build(self.system)
