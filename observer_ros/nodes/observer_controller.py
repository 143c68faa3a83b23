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
event stream (:class:`~observer_ros.nodes.observer.ObserverWiring`) and each estimate it
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
import time

import numpy as np

from observer_ros.config import CONTROLLER
from observer_ros.core.rules import within_limit
from observer_ros.nodes.observer import ObserverWiring
from observer_ros.nodes.state_feedback import FeedbackPart
from observer_ros.ros.diagnostics import monitor
from observer_ros.ros.parameters import ConfiguredNode


def _poles_text(poles) -> str:
    """``[-9, -8, -3+4j, -3-4j]``: real poles as numbers, 4 significant digits."""
    texts = [f'{p.real:.4g}' if p.imag == 0 else f'{p:.4g}'.strip('()')
             for p in (complex(pole) for pole in poles)]
    return '[' + ', '.join(texts) + ']'


class ObserverControllerWiring(ObserverWiring):
    """
    The controller's wiring: the observer's stream and a feedback part in one callback.

    :class:`ObserverControllerNode` builds it in its constructor, the managed variant
    (made from its spec by :func:`observer_ros.nodes.main.managed_class`) on ``configure``.
    """

    def build(self, system) -> None:
        """Make the feedback part (``u_cmd`` first), then the observer's stream and topics."""
        self.feedback_part = FeedbackPart(self, stale_input='estimate')
        self.feedback_part.vet(system)
        self.commands_as_input = system.sections.controller.input_source == 'command'
        self.feedback_part.build(system)
        ObserverWiring.build(self, system)
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
        return system.model.n_inputs > 0 and not self.commands_as_input

    def vet_system(self, system) -> None:
        """Refuse what either node would refuse."""
        FeedbackPart(self).vet(system)
        ObserverWiring.vet_system(self, system)

    def apply_system(self, previous, system) -> None:
        """Switch the observer's gains (the estimate kept) and the law's."""
        ObserverWiring.apply_system(self, previous, system)
        self.feedback_part.apply(previous, system)

    def counters(self) -> Counter:
        """Stream, observer and command counts together."""
        return self.stream.counters + self.node_counters + self.feedback_part.command_counters

    def _on_measurement(self, message) -> None:
        stamp, y = self._decode('y', message)
        if y is None:
            return
        feedback = self.feedback_part
        if feedback.law.integral is not None:
            values = np.asarray(y, dtype=float)
            if within_limit(values, feedback.feedback_limits['y']):
                feedback.integrate_measurement(stamp, values)
        if self.commands_as_input and self.stream.estimator.feedthrough is not None:
            # D u needs the input in effect at this stamp: the command sent before, which
            # the plant applies from this sample on; given before the measurement.
            self._run(self.stream.add_input, stamp, feedback.sent)
        self._run(self.stream.add_measurement, stamp, y, self._clock_for(stamp),
                  time.monotonic_ns())

    def _publish(self, samples) -> None:
        feedback = self.feedback_part
        applied = []  # (stamp, the command in effect from that sample on)
        for sample in samples:  # u_cmd first: the plant waits for it
            applied.append((sample.stamp_ns, feedback.sent))
            feedback.command_for(sample.stamp_ns, sample.estimate)  # the new feedback.sent
        ObserverWiring._publish(self, samples)
        if self.commands_as_input and self.stream.estimator.feedthrough is None:
            # The input of the interval after each estimate, for the next prediction: given
            # once the estimate is out, so the stream prepares the next step with it.
            for stamp, command in applied:
                released = self.stream.add_input(stamp, command)
                if released:
                    self._publish(released)

    def pause(self) -> None:
        """Deactivation: the estimator restarts; one safe command, then silence."""
        ObserverWiring.pause(self)
        self.feedback_part.pause()


class ObserverControllerNode(ObserverControllerWiring, ConfiguredNode):
    """The observer-controller node, configured and running from its construction."""

    def __init__(self, node_name: str = 'observer_controller', **kwargs) -> None:
        super().__init__(node_name, CONTROLLER, **kwargs)
        self.build(self.system)
