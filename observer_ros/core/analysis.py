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
Observability and controllability: ranks, conditioning and the PBH test for lost modes.

The functions take the matrices themselves (``model.a, model.c``), so they work for any
pair; errors name them ``A``, ``B`` and ``C``.
"""

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from observer_ros.core.errors import ConfigError, DesignError, UnobservableError

#: Relative tolerance of the PBH test: a mode is lost when the smallest singular value of
#: ``[lambda I - A; C]`` is below this times ``max(1, ||[A; C]||)``. It sits near the square
#: root of machine precision because eigenvalues of defective matrices are only that accurate.
#: The same relative tolerance is the margin of the stability boundary in
#: :func:`boundary_margin`.
PBH_RTOL = 1e-7

#: Share of the largest entry above which a state counts as part of an unseen direction.
DOMINANT_SHARE = 0.5


@dataclass(frozen=True)
class RankReport:
    """
    Kalman rank test of an observability or controllability matrix, plus PBH modes.

    Attributes
    ----------
    rank : int
        Numerical rank of the observability (controllability) matrix.
    n_states : int
    condition_number : float
        Ratio of its largest to its ``n``-th singular value (inf when rank deficient).
    lost_modes : tuple of complex
        Eigenvalues of ``A`` the outputs cannot see (the inputs cannot move), from the PBH
        test; the pair is observable (controllable) when it is empty.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> report = oc.observability([[1, 0], [0, 2]], [[1, 0]])
    >>> report.rank, report.full_rank, report.lost_modes
    (1, False, ((2+0j),))

    """

    rank: int
    n_states: int
    condition_number: float
    lost_modes: tuple

    @property
    def full_rank(self) -> bool:
        """Whether no mode is lost (the pair is observable / controllable)."""
        return not self.lost_modes


def _as_matrix(name: str, values) -> np.ndarray:
    """Return ``values`` as a 2-D float (or complex) array, or raise naming ``name``."""
    matrix = np.asarray(values)
    if matrix.dtype.kind not in 'fc':
        try:
            matrix = matrix.astype(float)
        except (TypeError, ValueError) as e:
            raise ConfigError(name, f'expected a matrix of numbers, got {values!r}') from e
    return np.atleast_2d(matrix)


def _pair(a, other, name: str, columns: bool) -> tuple[np.ndarray, np.ndarray]:
    """Check ``A`` square and ``other`` (``C``: n columns, ``B``: n rows); return arrays."""
    a, other = _as_matrix('A', a), _as_matrix(name, other)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ConfigError('A', f'expected a square matrix, got shape {a.shape}')
    n_states = a.shape[0]
    size = other.shape[1] if columns else other.shape[0]
    if other.ndim != 2 or size != n_states:
        where = f'p x {n_states}' if columns else f'{n_states} x m'
        raise ConfigError(name, f'expected a {where} matrix, got shape {other.shape}')
    return a, other


def observability_matrix(a, c) -> np.ndarray:
    """
    Return ``[C; C A; ...; C A^(n-1)]``.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)

    Returns
    -------
    numpy.ndarray, shape (n p, n)

    Raises
    ------
    ConfigError
        Naming ``A`` or ``C`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> print(oc.observability_matrix([[0, 1], [-2, -3]], [[1, 0]]))
    [[1. 0.]
     [0. 1.]]

    """
    a, c = _pair(a, c, 'C', columns=True)
    blocks = [c]
    for _ in range(a.shape[0] - 1):
        blocks.append(blocks[-1] @ a)
    return np.vstack(blocks)


def controllability_matrix(a, b) -> np.ndarray:
    """
    Return ``[B, A B, ..., A^(n-1) B]``.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)

    Returns
    -------
    numpy.ndarray, shape (n, n m)

    Raises
    ------
    ConfigError
        Naming ``A`` or ``B`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> print(oc.controllability_matrix([[0, 1], [-2, -3]], [[0], [1]]))
    [[ 0.  1.]
     [ 1. -3.]]

    """
    a, b = _pair(a, b, 'B', columns=False)
    return observability_matrix(a.T, b.T).T


def pbh_lost_modes(a, c, rtol: float = PBH_RTOL) -> tuple:
    """
    Eigenvalues of ``A`` that ``C`` cannot see (Popov-Belevitch-Hautus test).

    A mode ``lambda`` is unobservable when ``[lambda I - A; C]`` loses rank. Duality
    gives the uncontrollable modes of ``(A, B)`` as ``pbh_lost_modes(A.T, B.T)``.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)
    rtol : float
        Relative tolerance on the smallest singular value (see :data:`PBH_RTOL`).

    Returns
    -------
    tuple of complex
        One entry per distinct lost eigenvalue (conjugates both listed).

    Raises
    ------
    ConfigError
        Naming ``A`` or ``C`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.pbh_lost_modes([[1, 0], [0, 2]], [[1, 0]])
    ((2+0j),)
    >>> oc.pbh_lost_modes([[1, 0], [0, 2]], [[1, 1]])
    ()

    """
    a, c = _pair(a, c, 'C', columns=True)
    n_states = a.shape[0]
    scale = max(1.0, np.linalg.norm(np.vstack([a, c]), 2))
    lost = []
    for eigenvalue in np.linalg.eigvals(a):
        pencil = np.vstack([eigenvalue * np.eye(n_states) - a, c.astype(complex)])
        smallest = np.linalg.svd(pencil, compute_uv=False)[-1]
        if smallest <= rtol * scale and not any(
                abs(eigenvalue - seen) <= 1e-6 * max(1.0, abs(seen)) for seen in lost):
            lost.append(complex(eigenvalue))
    return tuple(lost)


def _report(matrix: np.ndarray, n_states: int, lost: tuple) -> RankReport:
    singular = np.linalg.svd(matrix, compute_uv=False)
    tol = max(matrix.shape) * np.finfo(float).eps * (singular[0] if singular.size else 0.0)
    rank = int(np.sum(singular > tol))
    condition = float(singular[0] / singular[n_states - 1]) if (
        singular.size >= n_states and singular[n_states - 1] > 0) else float('inf')
    return RankReport(rank=rank, n_states=n_states, condition_number=condition,
                      lost_modes=lost)


def observability(a, c) -> RankReport:
    """
    Rank and condition number of the observability matrix and the unobservable modes.

    Parameters
    ----------
    a : array_like, shape (n, n)
    c : array_like, shape (p, n)

    Returns
    -------
    RankReport
        ``full_rank`` when ``(A, C)`` is observable.

    Raises
    ------
    ConfigError
        Naming ``A`` or ``C`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> report = oc.observability(model.a, model.c)
    >>> report.full_rank, report.rank, report.condition_number
    (True, 2, 1.0)

    """
    a, c = _pair(a, c, 'C', columns=True)
    return _report(observability_matrix(a, c), a.shape[0], pbh_lost_modes(a, c))


def controllability(a, b) -> RankReport:
    """
    Rank and condition number of the controllability matrix and the uncontrollable modes.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)

    Returns
    -------
    RankReport
        ``full_rank`` when ``(A, B)`` is controllable.

    Raises
    ------
    ConfigError
        Naming ``A`` or ``B`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> report = oc.controllability([[-1, 0], [0, -2]], [[1], [0]])
    >>> report.full_rank, report.lost_modes
    (False, ((-2+0j),))

    """
    a, b = _pair(a, b, 'B', columns=False)
    return _report(controllability_matrix(a, b), a.shape[0], pbh_lost_modes(a.T, b.T))


def format_modes(modes) -> str:
    """
    Format eigenvalues compactly: ``-2, 1+3j``.

    Examples
    --------
    >>> from observer_ros.core.analysis import format_modes
    >>> format_modes([-2, 1 + 3j, 1 - 3j])
    '-2, 1+3j, 1-3j'

    """
    def one(value: complex) -> str:
        value = complex(value)
        if abs(value.imag) <= 1e-12 * max(1.0, abs(value)):
            return f'{value.real:.6g}'
        return f'{value.real:.6g}{value.imag:+.6g}j'
    return ', '.join(one(mode) for mode in modes)


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
    scaled by the model (:data:`PBH_RTOL`); with ``detectable`` only those that do not decay
    by :func:`boundary_margin` count (a Kalman filter tolerates an unseen decaying mode, not
    an unseen integrator whose eigenvalue rounding put at ``-3.5e-16``).

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


def require_controllable(a, b, what: str = '(A, B)') -> RankReport:
    """
    Return the controllability report, or raise DesignError listing the lost modes.

    Parameters
    ----------
    a : array_like, shape (n, n)
    b : array_like, shape (n, m)
    what : str
        How the message names the pair.

    Returns
    -------
    RankReport

    Raises
    ------
    DesignError
        Without a ``parameter`` (the pair as a whole is at fault), when a mode is lost.
    ConfigError
        Naming ``A`` or ``B`` when the shapes do not fit.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> oc.require_controllable([[0, 1], [0, 0]], [[0], [1]]).full_rank
    True

    """
    report = controllability(a, b)
    if not report.full_rank:
        raise DesignError(
            f'{what} is not controllable: the modes {format_modes(report.lost_modes)} cannot '
            f'be moved by the inputs (PBH test; controllability matrix rank '
            f'{report.rank} of {report.n_states}); no state feedback can place their poles')
    return report
