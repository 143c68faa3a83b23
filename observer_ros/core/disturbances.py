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
Disturbance models: the plant augmented with constant, ramp and sinusoidal disturbances.

Each disturbance ``d_j`` is the first state of a small autonomous generator:

========== ====== ==================================== =====================
waveform   states continuous generator                 state names
========== ====== ==================================== =====================
constant   1      ``d' = 0``                           ``name``
ramp       2      ``d' = d_rate, d_rate' = 0``         ``name, name_rate``
sinusoid   2      ``d' = d_rate, d_rate' = -w^2 d``    ``name, name_rate``
========== ====== ==================================== =====================

A discrete model (``dt > 0``) gets the exact sampled generator (``[1]``,
``[[1, dt], [0, 1]]``, the rotation ``expm([[0, 1], [-w^2, 0]] dt)``), so the package's
discretization of a continuous augmented model (zero-order hold of ``u``, the disturbance
states evolving exactly) and a discrete model agree.

The disturbance enters at an input (``input:<name>``: ``x' = A x + B (u + d e_i)``, a matched
load), at an output (``output:<name>``: ``y = C x + d e_k``, a sensor bias) or through the
next column of a given matrix (``matrix``: ``x' = A x + B u + E[:, j] d``). The augmented
model stacks the plant states first, then every disturbance's states in the order given::

    x_aug = [x (n), d_1 states, d_2 states, ...]     A_aug = [[A, E Cd], [0, Ad]]
                                                      C_aug = [C, F Cd]

:func:`augment` checks that ``(A_aug, C_aug)`` is observable and names the disturbance that
is not, and refuses a sinusoid at the frequency of an undamped plant mode.
"""

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy.linalg import expm

from observer_ros.core.analysis import format_modes, observability_problem, pbh_lost_modes
from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import matrix_from_flat
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


def _generator(waveform: str, frequency: float, dt: float) -> np.ndarray:
    if waveform == 'constant':
        continuous = np.zeros((1, 1))
    elif waveform == 'ramp':
        continuous = np.array([[0.0, 1.0], [0.0, 0.0]])
    else:
        continuous = np.array([[0.0, 1.0], [-frequency ** 2, 0.0]])
    return expm(continuous * dt) if dt > 0.0 else continuous


def _continuous_modes(waveform: str, frequency: float) -> np.ndarray:
    if waveform == 'sinusoid':
        return np.array([1j * frequency, -1j * frequency])
    return np.zeros(WAVEFORM_STATES[waveform], dtype=complex)


def _entry(text: str, position: int, model: StateSpaceModel) -> tuple:
    """Return ``(entry, index)`` of one ``model.disturbance_entries`` entry."""
    side, _, target = str(text).partition(':')
    side, target = side.strip(), target.strip()
    if side not in ENTRY_SIDES:
        raise ConfigError('disturbance_entries', f'entry {position}: expected input:<input '
                          f'name>, output:<output name> or matrix, got {text!r}')
    if side == 'matrix':
        return side, -1
    names = model.input_names if side == 'input' else model.output_names
    if not target:
        if len(names) != 1:
            raise ConfigError('disturbance_entries', f'entry {position}: the model has '
                              f'{len(names)} {side}s; name one ({side}:{names[0]})')
        return side, 0
    if target in names:
        return side, names.index(target)
    raise ConfigError('disturbance_entries', f'entry {position}: no {side} named '
                      f'{target!r} (the {side}s are {list(names)})')


def augment(model: StateSpaceModel, waveforms: Sequence[str], entries: Sequence[str] = (),
            matrix: Sequence[float] = (), frequencies: Sequence[float] = (),
            names: Sequence[str] = ()) -> DisturbanceModel:
    """
    Augment ``model`` with disturbance generators and check the augmented pair.

    Parameters
    ----------
    model : StateSpaceModel
        The plant, continuous or discrete.
    waveforms : sequence of str
        One of ``constant``, ``ramp``, ``sinusoid`` per disturbance.
    entries : sequence of str
        Per disturbance: ``input:<input name>``, ``output:<output name>`` (the name may be
        left out when there is one input or output) or ``matrix``. Empty: every disturbance
        at the (single) input.
    matrix : sequence of float, shape (n * k,)
        ``E``, ``n x k`` row-major, one column per ``matrix`` entry, in order.
    frequencies : sequence of float
        rad/s, one (> 0) per sinusoid, in order.
    names : sequence of str
        One per disturbance (default ``d1``, ``d2``...), unique and not a state name.

    Returns
    -------
    DisturbanceModel

    Raises
    ------
    ConfigError
        Naming ``disturbances``, ``disturbance_entries``, ``disturbance_matrix``,
        ``disturbance_frequencies`` or ``disturbance_names``: a wrong count or value, a
        disturbance the measurements cannot see (named), or a sinusoid at the frequency of
        an undamped plant mode.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> from observer_ros.core.disturbances import augment
    >>> motor = oc.StateSpaceModel.from_matrices([[0, 1], [0, -2]], [[0], [4]], [[1, 0]],
    ...                                          state_names=['q', 'q_dot'])
    >>> augmented = augment(motor, ['constant'], names=['load']).augmented
    >>> augmented.state_names
    ('q', 'q_dot', 'load')
    >>> print(augmented.a)
    [[ 0.  1.  0.]
     [ 0. -2.  4.]
     [ 0.  0.  0.]]
    >>> augment(motor, ['constant'], ['output'], names=['bias'])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: disturbances: the constant 'bias' ... at s = 0 ...

    """
    waveforms = [str(waveform) for waveform in waveforms]
    count = len(waveforms)
    if count == 0:
        raise ConfigError('disturbances', 'expected at least one of constant, ramp, sinusoid')
    for position, waveform in enumerate(waveforms):
        if waveform not in WAVEFORM_STATES:
            raise ConfigError('disturbances', f'entry {position}: expected constant, ramp or '
                              f'sinusoid, got {waveform!r}')
    entries = list(entries) or ['input'] * count
    if len(entries) != count:
        raise ConfigError('disturbance_entries', f'expected {count} entries (one per '
                          f'disturbance in disturbances), got {len(entries)}')
    placed = [_entry(text, position, model) for position, text in enumerate(entries)]
    n_matrix = sum(1 for entry, _ in placed if entry == 'matrix')
    n = model.n_states
    if n_matrix:
        e_matrix = matrix_from_flat('disturbance_matrix', matrix, n, n_matrix)
    elif len(matrix):
        raise ConfigError('disturbance_matrix', 'no entry in disturbance_entries is matrix; '
                          'leave disturbance_matrix empty')
    else:
        e_matrix = np.zeros((n, 0))
    n_sinusoids = waveforms.count('sinusoid')
    frequencies = [float(f) for f in frequencies]
    if len(frequencies) != n_sinusoids:
        raise ConfigError('disturbance_frequencies', f'expected {n_sinusoids} frequencies in '
                          f'rad/s (one per sinusoid), got {len(frequencies)}')
    for frequency in frequencies:
        if not np.isfinite(frequency) or frequency <= 0.0:
            raise ConfigError('disturbance_frequencies', f'expected frequencies > 0 rad/s, got '
                              f'{frequency}')
    names = [str(name) for name in names] if names else [f'd{i + 1}' for i in range(count)]
    if len(names) != count:
        raise ConfigError('disturbance_names', f'expected {count} names (one per disturbance '
                          f'in disturbances), got {len(names)}')
    disturbances, column, sinusoid, first = [], 0, 0, n
    for waveform, (entry, index), name in zip(waveforms, placed, names):
        frequency = 0.0
        if waveform == 'sinusoid':
            frequency, sinusoid = frequencies[sinusoid], sinusoid + 1
        if entry == 'matrix':
            index, column = column, column + 1
        state_names = (name,) if WAVEFORM_STATES[waveform] == 1 else (name, f'{name}_rate')
        disturbances.append(Disturbance(name, waveform, entry, index, frequency, first,
                                        state_names))
        first += len(state_names)
    all_names = list(model.state_names) + [s for d in disturbances for s in d.state_names]
    if len(set(all_names)) != len(all_names):
        raise ConfigError('disturbance_names', f'state names must be unique: the augmented '
                          f'states would be {all_names}')
    disturbances = tuple(disturbances)
    _check_resonance(model, disturbances)
    augmented = _augmented_model(model, disturbances, e_matrix, all_names)
    _check_observable(model, disturbances, e_matrix)
    return DisturbanceModel(plant=model, disturbances=disturbances, augmented=augmented)


def _augmented_matrices(model: StateSpaceModel, disturbances: Sequence[Disturbance],
                        e_matrix: np.ndarray) -> tuple:
    n, p = model.n_states, model.n_outputs
    n_d = sum(d.n_states for d in disturbances)
    a = np.zeros((n + n_d, n + n_d))
    c = np.zeros((p, n + n_d))
    a[:n, :n], c[:, :n] = model.a, model.c
    for disturbance in disturbances:
        j = disturbance.first_state
        block = slice(j, j + disturbance.n_states)
        a[block, block] = _generator(disturbance.waveform, disturbance.frequency, model.dt)
        if disturbance.entry == 'input':
            a[:n, j] = model.b[:, disturbance.index]
            c[:, j] = model.d[:, disturbance.index]
        elif disturbance.entry == 'matrix':
            a[:n, j] = e_matrix[:, disturbance.index]
        else:
            c[disturbance.index, j] = 1.0
    return a, c


def _augmented_model(model, disturbances, e_matrix, state_names) -> StateSpaceModel:
    a, c = _augmented_matrices(model, disturbances, e_matrix)
    n_d = a.shape[0] - model.n_states
    b = np.vstack([model.b, np.zeros((n_d, model.n_inputs))])
    return StateSpaceModel(a=a, b=b, c=c, d=model.d, dt=model.dt,
                           state_names=tuple(state_names), input_names=model.input_names,
                           output_names=model.output_names)


def _plant_modes(model: StateSpaceModel) -> np.ndarray:
    """Return the plant poles in the s-plane sense of the disturbance modes."""
    return np.linalg.eigvals(model.a)


def _disturbance_modes(model: StateSpaceModel, disturbance: Disturbance) -> np.ndarray:
    modes = _continuous_modes(disturbance.waveform, disturbance.frequency)
    return np.exp(modes * model.dt) if model.is_discrete else modes


def _close(mode: complex, others) -> bool:
    return any(abs(mode - other) <= MODE_TOLERANCE * max(1.0, abs(mode)) for other in others)


def _check_resonance(model: StateSpaceModel, disturbances) -> None:
    """Refuse a sinusoid at the frequency of an undamped plant mode (a plant pole)."""
    plant_poles = _plant_modes(model)
    variable = 'z' if model.is_discrete else 's'
    for disturbance in disturbances:
        if disturbance.waveform != 'sinusoid':
            continue
        modes = _disturbance_modes(model, disturbance)
        if _close(modes[0], plant_poles):
            raise ConfigError(
                'disturbance_frequencies',
                f'{disturbance.frequency:g} rad/s of the sinusoid {disturbance.name!r} equals '
                f'the plant poles {variable} = {format_modes(modes)}: the disturbance '
                f'resonates with an undamped plant mode (its response grows without bound) '
                f'and cannot be told apart from that mode; choose another frequency or damp '
                f'the model')


def _check_observable(model: StateSpaceModel, disturbances, e_matrix) -> None:
    """Name the first disturbance that makes the augmented pair unobservable."""
    problem = observability_problem(model.a, model.c, discrete=model.is_discrete,
                                    state_names=model.state_names or None,
                                    consequence='; no disturbance can be estimated')
    if problem is not None:
        raise ConfigError('disturbances', f'the plant itself: {problem}')
    variable = 'z' if model.is_discrete else 's'
    for count in range(1, len(disturbances) + 1):
        chosen = disturbances[:count]
        a, c = _augmented_matrices(model, chosen, e_matrix)
        lost = pbh_lost_modes(a, c)
        if not lost:
            continue
        culprit = chosen[-1]
        if culprit.entry == 'output':
            reason = (f'it cannot be told apart from the plant mode at {variable} = '
                      f'{format_modes(lost)} seen at that output (a sensor bias on an '
                      f'integrating or matching mode)')
        else:
            where = (f'input {model.input_names[culprit.index]}' if culprit.entry == 'input'
                     else f'column {culprit.index} of disturbance_matrix')
            reason = (f'the plant has a transmission zero at {variable} = '
                      f'{format_modes(lost)} from {where} to the outputs, so the disturbance '
                      f'mode leaves no trace in y')
        if count > 1:
            others = ', '.join(repr(d.name) for d in chosen[:-1])
            reason += f' (together with {others})'
        raise ConfigError('disturbances', f'the {culprit.describe()} is not observable: '
                          f'{reason}; remove it or measure more')


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
    >>> from observer_ros.core.disturbances import augmented_noise
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
           'augment', 'augmented_noise']
