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
Disturbances and the augmented plant, as the designs and the nodes use them once built.

A :class:`Disturbance` says what one disturbance is (its waveform, where it enters, its
states in the augmented model); a :class:`DisturbanceModel` holds the plant, its
disturbances and the augmented model, and answers what follows from them (the rejection
gain, the augmented state and process noise, the closed-loop poles without the generators'
modes). :func:`~observer_ros.core.disturbances.augment` builds and checks one from the
parameters.
"""

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel


#: Disturbance waveforms and their number of states.
WAVEFORM_STATES = {'constant': 1, 'ramp': 2, 'sinusoid': 2}
WAVEFORMS = tuple(WAVEFORM_STATES)

#: Where a disturbance enters: ``input:<name>``, ``output:<name>`` or ``matrix``.
ENTRY_SIDES = ('input', 'output', 'matrix')

#: Relative distance under which a disturbance mode counts as equal to a plant pole.
MODE_TOLERANCE = 1e-6


@dataclass(frozen=True)
class Disturbance:
    """
    One disturbance: its waveform, where it enters and its states in the augmented model.

    Attributes
    ----------
    name : str
    waveform : {'constant', 'ramp', 'sinusoid'}
    entry : {'input', 'output', 'matrix'}
    index : int
        The input or output index (``entry`` input or output), or the column of the
        disturbance matrix (``matrix``).
    frequency : float
        rad/s (sinusoids; 0 otherwise).
    first_state : int
        Index of the disturbance value ``d`` in the augmented state.
    state_names : tuple of str
        ``(name,)`` or ``(name, name_rate)``.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> motor = oc.StateSpaceModel.from_flat([0, 1, 0, -2], [0, 4], [1, 0])
    >>> (drift,) = oc.augment(motor, ['ramp'], names=['drift']).disturbances
    >>> drift.state_names, drift.first_state, drift.describe()
    (('drift', 'drift_rate'), 2, "ramp 'drift'")

    """

    name: str
    waveform: str
    entry: str
    index: int
    frequency: float
    first_state: int
    state_names: tuple

    @property
    def n_states(self) -> int:
        """States of the generator (1 or 2)."""
        return len(self.state_names)

    def describe(self) -> str:
        """Return e.g. ``constant 'load'`` or ``sinusoid (5 rad/s) 'hum'``."""
        waveform = self.waveform
        if waveform == 'sinusoid':
            waveform = f'sinusoid ({self.frequency:g} rad/s)'
        return f'{waveform} {self.name!r}'


@dataclass(frozen=True)
class DisturbanceModel:
    """
    The plant, its disturbances and the augmented model the observers are designed for.

    Attributes
    ----------
    plant : StateSpaceModel
        ``n`` states.
    disturbances : tuple of Disturbance
    augmented : StateSpaceModel
        ``n + n_d`` states (plant first), the plant's inputs and outputs.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> motor = oc.StateSpaceModel.from_flat([0, 1, 0, -2], [0, 4], [1, 0])
    >>> model = oc.augment(motor, ['constant', 'sinusoid'], ['input', 'input'],
    ...                    frequencies=[5.0], names=['load', 'hum'])
    >>> model.n_disturbance_states, model.augmented.state_names[2:]
    (3, ('load', 'hum', 'hum_rate'))
    >>> model.rejection_gain().tolist()
    [[1.0, 1.0, 0.0]]

    """

    plant: StateSpaceModel
    disturbances: tuple
    augmented: StateSpaceModel

    @property
    def n_disturbance_states(self) -> int:
        """``n_d``: the states of every generator together."""
        return self.augmented.n_states - self.plant.n_states

    def rejection_gain(self) -> np.ndarray:
        """
        Return ``K_d``, ``(m, n_d)``: ``u = -K x_hat - K_d d_hat`` cancels matched loads.

        Row ``i`` has a 1 at the value state of every ``input`` disturbance at input ``i``;
        the other disturbances (outputs, matrix) get no feedback.
        """
        n = self.plant.n_states
        gain = np.zeros((self.plant.n_inputs, self.n_disturbance_states))
        for disturbance in self.disturbances:
            if disturbance.entry == 'input':
                gain[disturbance.index, disturbance.first_state - n] = 1.0
        return gain

    def matched(self) -> tuple:
        """Return the matched input disturbances."""
        return tuple(d for d in self.disturbances if d.entry == 'input')

    def augmented_state(self, plant_state) -> np.ndarray:
        """
        Return a state of the plant as one of the augmented model: disturbance states 0.

        Parameters
        ----------
        plant_state : array_like, shape (n,)

        Returns
        -------
        numpy.ndarray, shape (n + n_d,)

        """
        return np.concatenate([plant_state, np.zeros(self.n_disturbance_states)])

    def augmented_process_noise(self, plant_noise, disturbance_noise=None) -> np.ndarray:
        """
        Return the process noise of the augmented model, as :func:`augmented_noise` does.

        ``disturbance_noise`` None gives the disturbance states no noise (the generators
        run exactly, as the plant simulator runs them).
        """
        n_d = self.n_disturbance_states
        noise = np.zeros(n_d) if disturbance_noise is None else disturbance_noise
        return augmented_noise(plant_noise, noise, n_d)

    def without_generator_modes(self, poles) -> np.ndarray:
        """
        Return closed-loop poles of the augmented model without the generators' modes.

        The generators are exogenous (nothing feeds back into them), so their modes appear
        in the closed loop of the augmented model unchanged; the loop of the real plant and
        the observer-controller has the others. Each mode takes the pole nearest it.

        Parameters
        ----------
        poles : array_like of complex, shape (k,)

        Returns
        -------
        numpy.ndarray of complex, shape (k - n_d,)

        Examples
        --------
        >>> import observer_ros.core as oc
        >>> motor = oc.StateSpaceModel.from_flat([0, 1, 0, -2], [0, 4], [1, 0])
        >>> load = oc.augment(motor, ['constant'])
        >>> load.without_generator_modes([-3.0, 1e-12, -5.0]).real.tolist()
        [-3.0, -5.0]

        """
        n = self.plant.n_states
        remaining = list(np.asarray(poles, dtype=complex))
        for mode in np.linalg.eigvals(self.augmented.a[n:, n:]):
            if remaining:
                remaining.pop(int(np.argmin(np.abs(np.array(remaining) - mode))))
        return np.array(remaining)


def augmented_noise(plant_noise: np.ndarray, disturbance_noise: Sequence[float],
                    n_disturbance_states: int) -> np.ndarray:
    """
    Return the block-diagonal process noise of the augmented model.

    Parameters
    ----------
    plant_noise : numpy.ndarray, shape (n, n)
        ``Q`` of the plant states.
    disturbance_noise : sequence of float, shape (n_d,)
        Diagonal intensity (continuous) or covariance (discrete) of the disturbance states:
        how fast the disturbance may wander.
    n_disturbance_states : int

    Returns
    -------
    numpy.ndarray, shape (n + n_d, n + n_d)

    Raises
    ------
    ConfigError
        ``disturbance_noise``: a wrong count or a negative value.

    Examples
    --------
    >>> from observer_ros.core.disturbance_model import augmented_noise
    >>> augmented_noise([[1.0]], [4.0], 1).tolist()
    [[1.0, 0.0], [0.0, 4.0]]

    """
    values = np.asarray(disturbance_noise, dtype=float).ravel()
    if values.size != n_disturbance_states:
        raise ConfigError('disturbance_noise', f'expected {n_disturbance_states} values (one '
                          f'per disturbance state), got {values.size}')
    if (values < 0.0).any() or not np.isfinite(values).all():
        raise ConfigError('disturbance_noise', f'expected finite values >= 0, got '
                          f'{values.tolist()}')
    plant_noise = np.atleast_2d(np.asarray(plant_noise, dtype=float))
    n = plant_noise.shape[0]
    q = np.zeros((n + values.size, n + values.size))
    q[:n, :n] = plant_noise
    q[n:, n:] = np.diag(values)
    return q


__all__ = ['Disturbance', 'DisturbanceModel', 'ENTRY_SIDES', 'WAVEFORMS', 'WAVEFORM_STATES',
           'augmented_noise']
