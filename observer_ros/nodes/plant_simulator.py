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
``plant_simulator``: the model simulated exactly, publishing ``y``, ``u`` and ``x_true``.

At sample ``k`` (time ``t_k``) it publishes ``y`` and ``x_true`` of the current state and the
input ``u`` it applies from ``t_k`` to ``t_(k+1)``, all stamped ``t_k``, ``y`` first (then
``u``, then ``x_true`` while something subscribes it; with a feedthrough ``D``, ``u`` before
``y``); the applied input is
the latest command received on ``u_cmd``, saturated to ``plant.input_limits``. So in a closed
loop the command computed from sample ``k-1`` acts over the interval after sample ``k``.

Like an actuator driver it has a command timeout: before the first command, and at every
sample whose latest command arrived more than ``plant.command_timeout`` seconds before it, it
applies ``plant.safe_input`` instead (an outage is counted as ``command_timeouts`` and warned
about once); the next command ends the outage. Real time measures that age on the steady
clock, lockstep in simulated time. A ``u_cmd`` beyond ``topics.u_cmd.limit`` is dropped and
counted (``out_of_range``).

Start: no sample is published before ``plant.lockstep_subscribers`` subscriptions on ``y``
have matched and, with ``plant.wait_for_command``, a publisher on ``u_cmd`` has, and they
have stayed matched for ``plant.settle_time`` wall-clock seconds (the rest of discovery goes
on after the first match); after ``plant.start_timeout`` wall-clock seconds without them the
plant starts anyway with a warning naming what is missing. A steady timer polls for them;
nothing blocks.

Real time: then a timer on the node clock ticks at ``plant.rate_hz``, the first sample at
once. Each sample is stamped with the node clock's time to the period: the latest point
``start + k * period`` at or before the clock when the tick runs, ``k`` counting every period
since the start, those the timer skipped after a stall included; the plant simulates exactly
the interval since its previous sample (whole periods). So the stamps never fall behind the
clock by more than the tick's lateness within a period, however often the process stalls
(with ``start + index * period`` a 0.6 s stall left every later stamp 0.6 s behind). The
clock's exact time is not used: each new interval would cost the observer a design
(pole placement, Riccati or sampling) at every sample, 6 to 30 ms (see the plant page).

Lockstep (``plant.lockstep: true``): the plant publishes ``/clock`` itself and moves to the
next sample only once the command computed from the current sample (stamped ``t_k``) has
arrived, or after ``plant.lockstep_timeout`` wall-clock seconds with a warning; runs are
deterministic and as fast as the nodes answer.

A model without inputs (``model.B`` empty) is simulated autonomously: no ``u_cmd``
subscription, no ``u`` topic, no wait for a command (real time only).

With ``plant.hold_without_command`` (real time) the simulation holds its state over every
interval that starts without a command in effect (before the first command, and in a
command outage), as a brake holds a joint: ``plant.safe_input``, the disturbances and the
noise do not move it, the samples (``y``, the safe input on ``u``) are still published and
counted as ``held_samples``. A managed controller sends nothing until it is active: without
it the joint runs away under its load while the controller waits for ``configure`` and
``activate``.

``plant.input_offset`` adds a constant input disturbance to the applied input; the
published ``u`` is the applied command without it (what a controller knows).
"""

from observer_ros.config import PLANT
from observer_ros.nodes.plant_part import PlantPart
from observer_ros.ros.parameters import ConfiguredNode


class PlantSimulatorNode(ConfiguredNode):
    """
    The plant simulator node: its plant part, running from its construction.

    ``finished`` completes after ``plant.samples`` samples; the part's state is reachable
    from the node (``node.counters``, ``node.simulator``, ``node.index``...).
    """

    def __init__(self, node_name: str = 'plant_simulator', **kwargs) -> None:
        super().__init__(node_name, PLANT, **kwargs)
        self.plant_part = PlantPart(self)
        self.plant_part.build(self.system)
        self.health = self.plant_part.health
        self.diagnostics = self.health.publisher

    def missing_peers(self) -> list:
        """Return what the plant still waits for before its first sample (empty: nothing)."""
        return self.plant_part.missing_peers()


def _forward(name: str) -> property:
    """Return a property of the node reading the plant part's attribute ``name``."""
    return property(lambda node: getattr(node.plant_part, name),
                    doc=f"The plant part's ``{name}``.")


for _name in ('simulator', 'counters', 'command', 'command_stamp', 'command_subscription',
              'publishers_', 'codecs', 'finished', 'samples', 'index', 'stamp_ns', 'started',
              'start_ns', 'period_ns', 'lockstep', 'applied'):
    setattr(PlantSimulatorNode, _name, _forward(_name))


def plant_done(node: PlantSimulatorNode):
    """Predicate ending the spin when ``plant.samples`` are done (never when it is 0)."""
    return node.finished.done if node.samples else None
