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
The simulated plant of a configuration: ``plant.*`` checked, for the plant simulator.

The plant simulates the model the observer estimates: with ``model.disturbances`` its
initial state, noise and disturbance step come from the
:class:`~observer_ros.config.model.Augmentation`.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.config.model import Augmentation
from observer_ros.config.sections import Sections
from observer_ros.config.timing import plant_rate
from observer_ros.config.values import check_inside, input_limits
from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import covariance_from_flat, vector_from_flat
from observer_ros.core.units import rate_to_period_ns


@dataclass(frozen=True)
class PlantSettings:
    """
    Validated ``plant.*`` parameters (``rate_hz`` resolved from the model when 0).

    Attributes
    ----------
    rate_hz : float
    initial_state : numpy.ndarray, shape (n + n_d,)
        The simulated model's (disturbance states 0).
    process_noise : list
        Flat, of the simulated model (empty: none).
    measurement_noise : list
        Flat (empty: none).
    seed : int
    input_limits : numpy.ndarray or None, shape (m, 2)
    command_timeout : float
        Seconds.
    safe_input : numpy.ndarray, shape (m,)
    disturbance : numpy.ndarray or None
        ``plant.disturbance``: the disturbance states from ``disturbance_time`` on.
    disturbance_time : float
    input_offset : numpy.ndarray or None, shape (m,)
    samples : int
        Samples to simulate (0: until shut down).
    lockstep : bool
    lockstep_timeout, start_timeout, settle_time : float
        Wall-clock seconds.
    lockstep_subscribers : int
    wait_for_command : bool
    hold_without_command : bool
        Real time: the state is held while no command is in effect.

    """

    rate_hz: float
    initial_state: np.ndarray
    process_noise: list
    measurement_noise: list
    seed: int
    input_limits: Optional[np.ndarray]
    command_timeout: float
    safe_input: np.ndarray
    disturbance: Optional[np.ndarray] = None
    disturbance_time: float = 0.0
    input_offset: Optional[np.ndarray] = None
    samples: int = 0
    lockstep: bool = False
    lockstep_timeout: float = 1.0
    lockstep_subscribers: int = 1
    wait_for_command: bool = True
    start_timeout: float = 10.0
    settle_time: float = 0.5
    hold_without_command: bool = False

    @property
    def period_ns(self) -> int:
        """Sample period in integer nanoseconds."""
        return rate_to_period_ns(self.rate_hz, 'plant.rate_hz')


def plant_settings(sections: Sections, augmentation: Augmentation) -> PlantSettings:
    """
    Check ``plant.*`` for the model the plant simulates.

    Raises
    ------
    ConfigError
        Naming the parameter: a rate that does not fit the model, a vector of the wrong
        size or outside its limits, lockstep without inputs.

    """
    section, model, plant = sections.plant, augmentation.model, augmentation.plant
    binding = section.binding()
    rate = plant_rate(sections, model)
    initial_state = (vector_from_flat(binding['initial_state'], section.initial_state,
                                      plant.n_states) if section.initial_state
                     else np.zeros(plant.n_states))
    check_inside(binding['initial_state'], initial_state, sections.topics['x_true'].limit,
                 'topics.x_true.limit')
    process_noise = section.process_noise
    if process_noise:
        process_noise = augmentation.simulated_noise(covariance_from_flat(
            binding['process_noise'], process_noise, plant.n_states), process_noise)
    initial_state = augmentation.simulated_state(initial_state)
    disturbance = augmentation.disturbance_step(section.disturbance)
    if section.measurement_noise:
        covariance_from_flat(binding['measurement_noise'], section.measurement_noise,
                             model.n_outputs)
    limits = input_limits(binding['input_limits'], section.input_limits, model.n_inputs)
    safe_input = (vector_from_flat(binding['safe_input'], section.safe_input, model.n_inputs)
                  if section.safe_input else np.zeros(model.n_inputs))
    check_inside(binding['safe_input'], safe_input, limits, 'plant.input_limits')
    check_inside(binding['safe_input'], safe_input, sections.topics['u'].limit,
                 'topics.u.limit')
    input_offset = (vector_from_flat(binding['input_offset'], section.input_offset,
                                     model.n_inputs) if section.input_offset else None)
    if model.n_inputs == 0 and section.lockstep:
        raise ConfigError(binding['lockstep'], 'a model without inputs (model.B empty) has no '
                          'command to wait for: run the plant in real time')
    return PlantSettings(
        rate_hz=rate, initial_state=initial_state, process_noise=process_noise,
        measurement_noise=section.measurement_noise, seed=section.seed, input_limits=limits,
        command_timeout=section.command_timeout, safe_input=safe_input,
        disturbance=disturbance,
        disturbance_time=section.disturbance_time if disturbance is not None else 0.0,
        input_offset=input_offset, samples=section.samples, lockstep=section.lockstep,
        lockstep_timeout=section.lockstep_timeout,
        lockstep_subscribers=section.lockstep_subscribers,
        wait_for_command=section.wait_for_command, start_timeout=section.start_timeout,
        settle_time=section.settle_time, hold_without_command=section.hold_without_command)
