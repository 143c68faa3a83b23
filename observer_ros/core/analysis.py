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
The one observability rule: which modes no output sees, whether they decay, and the error.

Every observer design, every source subset and every discretization asks
:func:`observability_problem` (or :func:`require_seen`, :func:`require_observable`); the
rank tests and the PBH test it rests on are in :mod:`observer_ros.core.ranks`. The
functions take the matrices themselves (``model.a, model.c``); errors name them ``A`` and
``C``.
"""

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from observer_ros.core.errors import UnobservableError
from observer_ros.core.ranks import (
    _pair, _report, observability, observability_matrix, pbh_lost_modes, PBH_RTOL, RankReport)

#: Share of the largest entry above which a state counts as part of an unseen direction.
DOMINANT_SHARE = 0.5


def boundary_margin(a) -> float:
    """
    Return how far inside the stability boundary a mode must lie to count as decaying.

    ``PBH_RTOL * max(1, ||A||_2)``. A computed eigenvalue of ``A`` is off by about
    ``eps ||A||`` times its condition number, and by about ``sqrt(eps) ||A||`` for a
    defective one (two integrators in a Jordan block): an unseen integrator comes out at
    ``-3.5e-16`` or ``+1.5e-8`` as rounding decides. The margin, scaled like those errors and
    above ``sqrt(eps) = 1.5e-8`` relative, is one that rounding cannot cross, so a mode on
    the boundary is never taken for a decaying one (nor for a growing one, which changes
    nothing: both are refused when unseen). A mode that genuinely decays slower than the
    margin (time constants beyond ``1e7 / ||A||`` s) is refused as if it did not decay.

    Parameters
    ----------
    a : array_like, shape (n, n)

    Returns
    -------
    float

    Examples
    --------
    >>> from observer_ros.core.analysis import boundary_margin
    >>> boundary_margin([[0, 1], [0, -5]]) == 1e-7 * float(np.linalg.norm([[0, 1], [0, -5]], 2))
    True

    """
    return PBH_RTOL * max(1.0, float(np.linalg.norm(np.asarray(a, dtype=float), 2)))


def decays(mode: complex, discrete: bool, margin: float) -> bool:
    """
    Whether an eigenvalue decays by more than ``margin`` (see :func:`boundary_margin`).

    Inside the unit circle by ``margin`` (discrete), or left of the imaginary axis by
    ``margin`` (continuous).

    Examples
    --------
    >>> from observer_ros.core.analysis import decays
    >>> decays(-3.5e-16, False, 1e-7), decays(-0.5, False, 1e-7), decays(1 - 1e-12, True, 1e-7)
    (False, True, False)

    """
    mode = complex(mode)
    return abs(mode) < 1.0 - margin if discrete else mode.real < -margin


def mode_text(value: complex, tol: float = 0.0) -> str:
    """
    Write an eigenvalue as the docs do: ``0``, ``-1``, ``0.5±2j`` (a conjugate pair at once).

    Real and imaginary parts within ``tol`` of zero are written as zero (rounding noise such
    as ``1.7e-15`` is not a value), and each part keeps 6 significant digits.

    Examples
    --------
    >>> from observer_ros.core.analysis import mode_text
    >>> mode_text(1.72781e-15, 1e-7), mode_text(-1.0000000000002), mode_text(0.5 + 2j)
    ('0', '-1', '0.5±2j')

    """
    value = complex(value)
    real = 0.0 if abs(value.real) <= tol else value.real
    imag = 0.0 if abs(value.imag) <= max(tol, 1e-12 * max(1.0, abs(value))) else value.imag
    text = f'{real + 0.0:.6g}'
    return text if imag == 0.0 else f'{text}±{abs(imag):.6g}j'


@dataclass(frozen=True)
class UnseenMode:
    """
    A mode of ``A`` that no output sees: its value, how the messages write it, its states.

    Attributes
    ----------
    value : complex
        The eigenvalue as computed (for a conjugate pair, the one with ``imag >= 0``).
    text : str
        Rounded for people: ``0``, ``-1``, ``0.5±2j`` (:func:`mode_text`).
    states : tuple of str
        The states that dominate its unseen direction (the null space of
        ``[lambda I - A; C]``): those whose entry is at least :data:`DOMINANT_SHARE` of the
        largest.
    decays : bool
        Whether it decays by more than :func:`boundary_margin` (a detectable mode).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> mode, = oc.unseen_modes([[-1, 0], [0, 2]], [[1, 0]], state_names=['a', 'b'])
    >>> mode.text, mode.states, mode.decays
    ('2', ('b',), False)

    """

    value: complex
    text: str
    states: tuple
    decays: bool


def _dominant_states(a: np.ndarray, c: np.ndarray, mode: complex, tol: float,
                     names: Sequence[str]) -> tuple:
    """Return the names of the states that dominate the null space of the PBH pencil."""
    n_states = a.shape[0]
    pencil = np.vstack([mode * np.eye(n_states) - a, c.astype(complex)])
    _, singular, vh = np.linalg.svd(pencil)
    rank = min(int(np.sum(singular > tol)), n_states - 1)
    null = vh[rank:].conj().T
    weight = np.linalg.norm(null, axis=1)
    return tuple(names[k] for k in range(n_states)
                 if weight[k] >= DOMINANT_SHARE * weight.max())


def unseen_modes(a, c, discrete: bool = False, state_names: Optional[Sequence[str]] = None,
                 rtol: float = PBH_RTOL) -> tuple:
    """
    Return the modes of ``A`` that ``C`` cannot see, one :class:`UnseenMode` each.

    The PBH test of :func:`pbh_lost_modes` (a mode is unseen when ``[lambda I - A; C]``
    loses rank to ``rtol`` times the model's scale); a conjugate pair is one entry. Each says
    whether it decays, with the margin of :func:`boundary_margin`.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)
    discrete : bool
        Whether ``A`` is a discrete-time transition matrix (decay: inside the unit circle).
    state_names : sequence of str, optional
        Names of the states (``x1``... when not given).
    rtol : float
        Relative tolerance of the PBH test.

    Returns
    -------
    tuple of UnseenMode

    Raises
    ------
    ConfigError
        Naming ``A`` or ``C`` when the shapes do not fit.

    Examples
    --------
    >>> from observer_ros.core.analysis import unseen_modes
    >>> [(m.text, m.states, m.decays) for m in unseen_modes([[0, 0], [0, -1]], [[0, 1]],
    ...                                                       state_names=['x', 'v'])]
    [('0', ('x',), False)]

    """
    a, c = _pair(a, c, 'C', columns=True)
    lost = pbh_lost_modes(a, c, rtol)
    if not lost:  # the common case, asked for every sampled interval: nothing more to do
        return ()
    n_states = a.shape[0]
    names = list(state_names) if state_names else [f'x{k + 1}' for k in range(n_states)]
    tol = rtol * max(1.0, np.linalg.norm(np.vstack([a, c]), 2))
    margin = boundary_margin(a)
    found = []
    for mode in lost:
        if mode.imag < -tol and any(abs(mode.conjugate() - other.value) <= 1e-6 * max(
                1.0, abs(mode)) for other in found):
            continue
        if mode.imag < -tol:
            mode = mode.conjugate()
        found.append(UnseenMode(
            value=mode, text=mode_text(mode, margin), decays=decays(mode, discrete, margin),
            states=_dominant_states(a, c, mode, tol, names)))
    return tuple(found)


def observability_problem(a, c, detectable: bool = False, discrete: bool = False,
                          state_names: Optional[Sequence[str]] = None,
                          what: str = '(A, C)', seen_from: str = 'the outputs',
                          consequence: Optional[str] = None) -> Optional[str]:
    """
    Say which modes no output sees, and which states they live in; None when all are seen.

    The one observability rule of the package: every observer design, every source subset
    and every discretization asks it. Unseen modes come from the PBH test with a tolerance
    scaled by the model (:data:`~observer_ros.core.ranks.PBH_RTOL`); with ``detectable``
    only those that do not decay by :func:`boundary_margin` count (a Kalman filter tolerates
    an unseen decaying mode, not an unseen integrator whose eigenvalue rounding put at
    ``-3.5e-16``).

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)
    detectable : bool
        Ask for detectability (unseen modes that decay are fine) instead of observability.
    discrete : bool
        ``A`` is a discrete-time transition matrix.
    state_names : sequence of str, optional
    what : str
        How the message names the pair.
    seen_from : str
        How the message names the outputs (``the outputs ['v_left']``, ``them``).
    consequence : str, optional
        What follows from it (default: no observer can place their poles; no Kalman filter).

    Returns
    -------
    str or None

    Examples
    --------
    >>> from observer_ros.core.analysis import observability_problem
    >>> print(observability_problem([[0, 0], [0, -1]], [[0, 1]], detectable=True,
    ...                             state_names=['x', 'v']))  # doctest: +NORMALIZE_WHITESPACE
    (A, C) is not detectable: the modes 0 cannot be seen from the outputs and do not decay
    (mode 0: states x; PBH test, observability matrix rank 1 of 2); no Kalman filter,
    steady-state or time-varying, can estimate them
    (its covariance would grow without bound)
    >>> observability_problem([[0, 0], [0, -1]], [[1, 0]], detectable=True) is None
    True

    """
    modes = unseen_modes(a, c, discrete, state_names)
    if detectable:
        modes = tuple(mode for mode in modes if not mode.decays)
    if not modes:
        return None
    texts = ', '.join(mode.text for mode in modes)
    states = '; '.join(f'mode {mode.text}: states {", ".join(mode.states)}' for mode in modes)
    rank = _report(observability_matrix(a, c), np.shape(a)[0], ()).rank
    states += f'; PBH test, observability matrix rank {rank} of {np.shape(a)[0]}'
    if detectable:
        default = ('; no Kalman filter, steady-state or time-varying, can estimate them (its '
                   'covariance would grow without bound)')
        return (f'{what} is not detectable: the modes {texts} cannot be seen from {seen_from} '
                f'and do not decay ({states}){consequence or default}')
    default = '; no observer can place their poles'
    return (f'{what} is not observable: the modes {texts} cannot be seen from {seen_from} '
            f'({states}){consequence or default}')


def require_observable(a, c, what: str = '(A, C)', detectable: bool = False,
                       discrete: bool = False, state_names: Optional[Sequence[str]] = None,
                       output_names: Optional[Sequence[str]] = None) -> RankReport:
    """
    Return the observability report, or raise DesignError naming the unseen modes.

    :func:`observability_problem` decides (the one rule); the message names the outputs
    when ``output_names`` are given.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)
    what : str
        How the message names the pair.
    detectable, discrete, state_names
        As :func:`observability_problem`.
    output_names : sequence of str, optional
        Named in the message.

    Returns
    -------
    RankReport

    Raises
    ------
    UnobservableError
        A :class:`DesignError` without a ``parameter`` (the pair as a whole is at fault),
        when a mode is lost (that does not decay, with ``detectable``).
    ConfigError
        Naming ``A`` or ``C`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.require_observable([[1, 0], [0, 2]], [[1, 0]])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.UnobservableError: (A, C) is not observable: the modes 2 ...

    """
    seen_from = f'the outputs {list(output_names)}' if output_names else 'the outputs'
    problem = observability_problem(a, c, detectable, discrete, state_names, what, seen_from)
    if problem is not None:
        raise UnobservableError(problem)
    return observability(a, c)


def require_seen(model, detectable: bool = False, a=None) -> None:
    """
    Apply the one observability rule to a model, with its names; raise when a mode is unseen.

    Parameters
    ----------
    model : StateSpaceModel
        Its ``C``, state and output names, and whether it is discrete.
    detectable : bool
        Refuse only unseen modes that do not decay (a Kalman filter).
    a : array_like, shape (n, n), optional
        A transition matrix to use instead of ``model.a`` (one interval of a sampled model:
        then discrete).

    Raises
    ------
    UnobservableError
        As :func:`require_observable` (the rule of :func:`observability_problem`).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> from observer_ros.core.analysis import require_seen
    >>> model = oc.StateSpaceModel.from_matrices([[0, 0], [0, -1]], [[1], [1]], [[0, 1]],
    ...                                          state_names=['x', 'v'])
    >>> require_seen(model, detectable=True)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.UnobservableError: (A, C) is not detectable: the modes 0 ...

    """
    discrete = model.is_discrete or a is not None
    output_names = model.output_names
    problem = observability_problem(
        model.a if a is None else a, model.c, detectable, discrete, model.state_names or None,
        seen_from=f'the outputs {list(output_names)}' if output_names else 'the outputs')
    if problem is not None:
        raise UnobservableError(problem)
