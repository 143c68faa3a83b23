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
The model section made a model: the plant, and the one transform ``model.disturbances`` makes.

:class:`Augmentation` reads :class:`~observer_ros.config.sections.ModelSection` into the
plant and the model the observer estimates and the plant simulates: the plant itself, or
with ``model.disturbances`` the plant augmented with the disturbance generators' states
(:func:`observer_ros.core.disturbances.augment`). Everything that follows from the
transform is decided by it, and nowhere else:

- the observer: its disturbance arguments (a Kalman filter's ``disturbance_noise``) only
  apply with disturbances (:meth:`Augmentation.refuse_without`); the type consumes them from
  the :class:`~observer_ros.core.disturbance_model.DisturbanceModel` it is designed with;
- the state feedback: ``K`` is designed for the plant (:attr:`Augmentation.plant`), and
  ``feedback.disturbance_rejection`` gives the gain ``K_d`` on the disturbance estimates
  (:meth:`Augmentation.disturbance_gain`);
- the plant simulator: ``plant.initial_state`` and ``plant.process_noise`` are the
  plant's, padded with zeros for the disturbance states
  (:meth:`Augmentation.simulated_state`, :meth:`Augmentation.simulated_noise`), and
  ``plant.disturbance`` steps the disturbance states (:meth:`Augmentation.disturbance_step`);
- the closed-loop analysis: the generators' modes are dropped from the closed-loop poles
  (:meth:`Augmentation.loop_poles`) and ``G_oc`` is not cross-checked with the Diophantine
  equation, which does not apply to generators no input reaches
  (:attr:`Augmentation.cross_check`).

Without ``model.disturbances`` the transform is the identity: the model is the plant.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.config.nonlinear import read_linearized_model
from observer_ros.config.sections import ModelSection
from observer_ros.config.values import indices
from observer_ros.core.angles import Angles, check_angles
from observer_ros.core.disturbance_model import DisturbanceModel
from observer_ros.core.disturbances import augment
from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import vector_from_flat
from observer_ros.core.model import StateSpaceModel

#: The reason a disturbance setting is refused for a model without disturbances.
NO_DISTURBANCES = 'the model has no disturbances (model.disturbances); leave it empty'


def _angles(section: ModelSection, model: StateSpaceModel) -> Angles:
    """Return ``model.angle_states`` and ``model.angle_outputs`` checked against ``model``."""
    binding = section.binding()
    states = indices(binding['angle_states'], section.angle_states, model.state_names, 'state')
    outputs = indices(binding['angle_outputs'], section.angle_outputs, model.output_names,
                      'output')
    with binding.charged(binding['angle_states']):
        return check_angles(model, states, outputs)


@dataclass(frozen=True)
class Augmentation:
    """
    The plant and the model made from it by ``model.disturbances`` (see the module notes).

    Attributes
    ----------
    plant : StateSpaceModel
        The plant of ``model.A`` ... ``model.D`` (what ``feedback.*`` is designed for).
    disturbance : DisturbanceModel or None
        The disturbances and the augmented model; None without ``model.disturbances``.
    angles : Angles
        ``model.angle_states`` and ``model.angle_outputs`` of the model (plant states keep
        their indices in the augmented model), checked by
        :func:`~observer_ros.core.angles.check_angles`.

    """

    plant: StateSpaceModel
    disturbance: Optional[DisturbanceModel] = None
    angles: Angles = Angles()

    @classmethod
    def read(cls, section: ModelSection) -> 'Augmentation':
        """
        Build the plant of ``section`` and augment it with its disturbances.

        With ``model.dynamics`` the plant is the model of the equations linearized at its
        operating point (:func:`~observer_ros.config.nonlinear.read_linearized_model`).

        Raises
        ------
        ConfigError
            Naming the ``model.*`` parameter: a wrong shape or name, a disturbance setting
            without ``model.disturbances``, or a disturbance the outputs cannot see.

        """
        binding = section.binding()
        equations = read_linearized_model(section)
        if equations is not None:
            if section.disturbances:
                raise ConfigError(binding['disturbances'], 'a model written as equations '
                                  '(model.dynamics) takes no disturbances; write their states '
                                  'into the equations')
            nonlinear = equations.nonlinear
            return cls(equations, angles=Angles(nonlinear.angle_states, nonlinear.angle_outputs))
        if not section.A:
            raise ConfigError(binding['A'], 'missing: the model needs A, B and C')
        with binding.charged(binding['A']):
            plant = StateSpaceModel.from_flat(
                section.A, section.B, section.C, section.D, section.dt, section.state_names,
                section.input_names, section.output_names)
        if not section.disturbances:
            for argument in ('disturbance_entries', 'disturbance_matrix',
                             'disturbance_frequencies', 'disturbance_names'):
                if getattr(section, argument):
                    raise ConfigError(binding[argument], 'given without model.disturbances; '
                                      'list the disturbance kinds there or leave it empty')
            return cls(plant, angles=_angles(section, plant))
        with binding.charged(binding['disturbances']):
            disturbance = augment(plant, section.disturbances, section.disturbance_entries,
                                  section.disturbance_matrix, section.disturbance_frequencies,
                                  section.disturbance_names)
        return cls(plant, disturbance, _angles(section, disturbance.augmented))

    @property
    def model(self) -> StateSpaceModel:
        """The model the observer estimates and the plant simulates (plant states first)."""
        return self.plant if self.disturbance is None else self.disturbance.augmented

    @property
    def n_disturbance_states(self) -> int:
        """The disturbance states after the plant's (0 without disturbances)."""
        return 0 if self.disturbance is None else self.disturbance.n_disturbance_states

    def output_bias(self, outputs) -> Optional[np.ndarray]:
        """
        Return ``E``, ``(q, n + n_d)``: the sensor bias of ``outputs`` in the estimate.

        ``E x_hat`` is what the ``output:`` disturbances add to those outputs (the columns of
        the augmented ``C`` on the disturbance states); None when they add nothing (no
        disturbances, or none at those outputs).
        """
        if self.disturbance is None:
            return None
        n_plant = self.plant.n_states
        bias = np.zeros((len(outputs), self.model.n_states))
        bias[:, n_plant:] = self.model.c[list(outputs), n_plant:]
        return bias if bias.any() else None

    def refuse_without(self, parameter: str, given) -> None:
        """Refuse a disturbance setting ``given`` (non-empty) for a model without any."""
        if given and self.disturbance is None:
            raise ConfigError(parameter, NO_DISTURBANCES)

    def disturbance_gain(self, rejection: bool) -> Optional[np.ndarray]:
        """
        Return ``K_d`` of ``u = -K x_hat - K_d d_hat``, ``(m, n_d)``; None without disturbances.

        ``rejection`` (``feedback.disturbance_rejection``): cancel every matched input
        disturbance; otherwise ``K_d`` is zero.

        Raises
        ------
        ConfigError
            ``feedback.disturbance_rejection`` without a matched input disturbance.

        """
        if self.disturbance is None:
            if rejection:
                raise ConfigError('feedback.disturbance_rejection', 'expected a model with a '
                                  'matched input disturbance (model.disturbances with '
                                  'model.disturbance_entries input:<name>); the model has none')
            return None
        if not rejection:
            return np.zeros((self.model.n_inputs, self.n_disturbance_states))
        if not self.disturbance.matched():
            raise ConfigError('feedback.disturbance_rejection', 'expected a matched input '
                              'disturbance (model.disturbance_entries input:<name>); the '
                              'disturbances enter at outputs or through disturbance_matrix '
                              'only')
        return self.disturbance.rejection_gain()

    def simulated_state(self, plant_state: np.ndarray) -> np.ndarray:
        """Return the simulated initial state: the plant's, disturbance states 0."""
        if self.disturbance is None:
            return plant_state
        return self.disturbance.augmented_state(plant_state)

    def simulated_noise(self, plant_noise: np.ndarray, given: list) -> list:
        """
        Return ``plant.process_noise`` for the simulated model (flat, as the simulator takes it).

        ``plant_noise`` is the checked ``(n, n)`` covariance of the plant states and ``given``
        the parameter's value: the disturbance states get no noise.
        """
        if self.disturbance is None:
            return given
        return self.disturbance.augmented_process_noise(plant_noise).ravel().tolist()

    def disturbance_step(self, values: list) -> Optional[np.ndarray]:
        """
        Return ``plant.disturbance`` checked: one value per disturbance state (None: empty).

        Raises
        ------
        ConfigError
            ``plant.disturbance``: given without disturbances, or a wrong count.

        """
        if not values:
            return None
        self.refuse_without('plant.disturbance', values)
        names = self.model.state_names[self.plant.n_states:]
        try:
            return vector_from_flat('plant.disturbance', values, len(names))
        except ConfigError as e:
            raise ConfigError('plant.disturbance', f'{e.reason} (one per disturbance state: '
                              f'{", ".join(names)})') from e

    def loop_poles(self, poles: np.ndarray) -> np.ndarray:
        """Return the closed-loop poles of the real loop: the generators' modes dropped."""
        if self.disturbance is None:
            return poles
        return self.disturbance.without_generator_modes(poles)

    @property
    def cross_check(self) -> bool:
        """Whether ``G_oc`` is cross-checked with the Diophantine equation (no generators)."""
        return self.disturbance is None
