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
Steady-state Kalman filter gains from the algebraic Riccati equations.

Continuous model (``dt == 0``): ``x' = A x + B u + w``, ``y = C x + v`` with intensities
``Q`` and ``R``; the CARE gives ``P`` and ``L = P C^T R^-1``.

Discrete model (``dt > 0``), or a continuous one sampled with :func:`design_sampled_kalman`:
the DARE gives the a-priori covariance ``P``, the filter (current) gain
``M = P C^T (C P C^T + R)^-1`` used in ``x_hat[k|k] = x_hat[k|k-1] + M (y[k] - C x_hat[k|k-1])``,
and the predictor gain ``L = A M`` of ``x_hat[k+1|k] = A x_hat[k|k-1] + B u + L (y - C x_hat)``.
:func:`control.dlqe` returns the predictor gain ``L = A M`` (the tests check it); this module
returns both and names them.
"""

from dataclasses import dataclass
import math
from typing import Optional

import numpy as np
import scipy.linalg

from observer_ros.core.analysis import boundary_margin, decays, require_seen
from observer_ros.core.design.common import ObserverDesign, predictor_realization
from observer_ros.core.discretize import van_loan, zero_order_hold
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.flat_matrices import covariance_from_flat
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement_checks import sort_poles


@dataclass(frozen=True)
class KalmanDesign(ObserverDesign):
    """
    Kalman design: :class:`ObserverDesign` (``gain`` = predictor gain ``L``) plus covariances.

    Attributes
    ----------
    filter_gain : numpy.ndarray or None, shape (n, p)
        ``M`` (discrete only).
    covariance : numpy.ndarray, shape (n, n)
        Continuous: the CARE solution. Discrete: a-priori (predicted) covariance.
    filtered_covariance : numpy.ndarray or None, shape (n, n)
        Discrete only: ``(I - M C) P``, the covariance of ``x_hat[k|k]``.
    process_noise, measurement_noise : numpy.ndarray, shapes (n, n) and (p, p)
        ``Q`` and ``R`` used (``Q`` discretized when sampled).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[1, 0.1], [0, 1]], [[0.005], [0.1]],
    ...                                          [[1, 0]], dt=0.1)
    >>> design = oc.design_kalman(model, process_noise=[1e-4, 1e-2], measurement_noise=[0.01])
    >>> design.method, design.filter_gain.shape, design.covariance.shape
    ('dare', (2, 1), (2, 2))

    """

    filter_gain: Optional[np.ndarray]
    covariance: np.ndarray
    filtered_covariance: Optional[np.ndarray]
    process_noise: np.ndarray
    measurement_noise: np.ndarray


def noise_matrices(model: StateSpaceModel, process_noise, measurement_noise):
    """
    Validate ``Q`` (n or n*n values) and ``R`` (p or p*p values, positive definite).

    Parameters
    ----------
    model : StateSpaceModel
    process_noise : array_like, shape (n,) or (n * n,)
        ``Q``: diagonal entries or the whole matrix, row-major.
    measurement_noise : array_like, shape (p,) or (p * p,)
        ``R``: diagonal entries or the whole matrix, row-major.

    Returns
    -------
    q : numpy.ndarray, shape (n, n)
    r : numpy.ndarray, shape (p, p)

    Raises
    ------
    ConfigError
        Naming ``process_noise`` or ``measurement_noise``: wrong size, asymmetric,
        indefinite, or (``R``) singular.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> from observer_ros.core.observers.kalman.design import noise_matrices
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> q, r = noise_matrices(model, [1, 2], [0.5])
    >>> q.tolist(), r.tolist()
    ([[1.0, 0.0], [0.0, 2.0]], [[0.5]])
    >>> noise_matrices(model, [1, 2], [0.0])  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: measurement_noise: expected a positive definite ...

    """
    q = covariance_from_flat('process_noise', process_noise, model.n_states)
    r = covariance_from_flat('measurement_noise', measurement_noise, model.n_outputs)
    if np.linalg.eigvalsh(r).min() <= 0.0:
        raise ConfigError('measurement_noise',
                          'expected a positive definite matrix (every output noisy)')
    return q, r


def _riccati_failure(e: Exception) -> DesignError:
    return DesignError(
        f'the Riccati equation has no stabilizing solution ({e}); the filter needs (A, C) '
        f'detectable and (A, Q^1/2) free of undisturbed modes on the stability boundary')


def _dare(a, c, q, r):
    try:
        covariance = scipy.linalg.solve_discrete_are(a.T, c.T, q, r)
    except (np.linalg.LinAlgError, ValueError) as e:
        raise _riccati_failure(e) from e
    innovation = c @ covariance @ c.T + r
    filter_gain = np.linalg.solve(innovation, c @ covariance).T
    residual_matrix = (a @ covariance @ a.T - covariance + q
                       - a @ covariance @ c.T @ filter_gain.T @ a.T)
    residual = float(np.linalg.norm(residual_matrix) / max(1.0, np.linalg.norm(covariance)))
    return covariance, filter_gain, residual


def discrete_kalman(model: StateSpaceModel, q: np.ndarray, r: np.ndarray,
                    a: Optional[np.ndarray] = None) -> KalmanDesign:
    """
    Solve the DARE for ``(A, C, Q, R)``; ``a`` overrides ``model.a`` (sampled models).

    Parameters
    ----------
    model : StateSpaceModel
    q : numpy.ndarray, shape (n, n)
        Covariance of the process noise per sample (already validated).
    r : numpy.ndarray, shape (p, p)
        Covariance of the measurement noise (already validated, positive definite).
    a : numpy.ndarray, shape (n, n), optional
        The discrete ``A`` to use instead of ``model.a``.

    Returns
    -------
    KalmanDesign
        With ``method`` ``'dare'``.

    Raises
    ------
    DesignError
        No stabilizing DARE solution, or an inaccurate one.

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> from observer_ros.core.observers.kalman.design import discrete_kalman
    >>> model = oc.StateSpaceModel.from_matrices([[0.9]], [[1]], [[1]], dt=0.1)
    >>> design = discrete_kalman(model, np.array([[1.0]]), np.array([[1.0]]))
    >>> round(float(design.filter_gain[0, 0]), 6)  # P = 1.483925 solves P^2 - 0.81 P - 1 = 0
    0.597407

    """
    a = model.a if a is None else a
    require_seen(model, detectable=True, a=a)
    covariance, filter_gain, residual = _dare(a, model.c, q, r)
    gain = a @ filter_gain
    filtered = (np.eye(model.n_states) - filter_gain @ model.c) @ covariance
    poles = sort_poles(np.linalg.eigvals(a - gain @ model.c))
    # The modes no output sees were judged above, with the rule's margin. What is left to
    # check is that the solution is the stabilizing one: inside the unit circle, with no
    # margin, since a short interval of a sampled model puts every pole near 1 (a 50 us
    # interval: 1 - 5e-8 for a mode decaying at 1e-3 per second).
    if not all(decays(pole, True, 0.0) for pole in poles) or residual > 1e-8:
        raise DesignError(
            f'the discrete Kalman design is not stabilizing or not accurate (largest pole '
            f'modulus {np.abs(poles).max():.6g}, Riccati residual {residual:.2g})')
    return KalmanDesign(
        kind='kalman', model=model, gain=gain, requested_poles=poles, achieved_poles=poles,
        method='dare', residual=residual, realization=predictor_realization(model, gain),
        filter_gain=filter_gain, covariance=covariance,
        filtered_covariance=0.5 * (filtered + filtered.T), process_noise=q,
        measurement_noise=r)


def design_kalman(model: StateSpaceModel, process_noise, measurement_noise) -> KalmanDesign:
    """
    Steady-state Kalman gain for a continuous (CARE) or discrete (DARE) model.

    Parameters
    ----------
    model : StateSpaceModel
    process_noise : array_like
        ``Q``: ``n`` diagonal entries or ``n * n`` row-major entries.
    measurement_noise : array_like
        ``R``: ``p`` diagonal entries or ``p * p`` row-major entries, positive definite.

    Returns
    -------
    KalmanDesign
        ``gain`` is ``L`` ``(n, p)`` (the predictor gain ``A M`` for a discrete model).

    Raises
    ------
    ConfigError
        Naming ``process_noise`` or ``measurement_noise``: wrong sizes, asymmetric or
        indefinite covariances.
    DesignError
        An undetectable pair (:class:`~observer_ros.core.errors.UnobservableError`: a mode
        no output sees that does not decay, named with its states), or no stabilizing
        Riccati solution.

    Examples
    --------
    A continuous double integrator with a noisy position measurement (CARE):

    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> design = oc.design_kalman(model, process_noise=[0, 1], measurement_noise=[1])
    >>> print(np.round(design.gain, 6).ravel(), design.method)
    [1.414214 1.      ] care

    """
    q, r = noise_matrices(model, process_noise, measurement_noise)
    if model.is_discrete:
        return discrete_kalman(model, q, r)
    # The one rule first: the CARE may return an unseen integrator at -3.5e-16, which a
    # test against the boundary itself would take for a decaying pole.
    require_seen(model, detectable=True)
    try:
        covariance = scipy.linalg.solve_continuous_are(model.a.T, model.c.T, q, r)
    except (np.linalg.LinAlgError, ValueError) as e:
        raise _riccati_failure(e) from e
    gain = covariance @ model.c.T @ np.linalg.inv(r)
    residual_matrix = (model.a @ covariance + covariance @ model.a.T + q
                       - gain @ r @ gain.T)
    residual = float(np.linalg.norm(residual_matrix) / max(1.0, np.linalg.norm(covariance)))
    poles = sort_poles(np.linalg.eigvals(model.a - gain @ model.c))
    margin = boundary_margin(model.a)
    if not all(decays(pole, False, margin) for pole in poles) or residual > 1e-8:
        raise DesignError(
            f'the continuous Kalman design is not stabilizing or not accurate (rightmost pole '
            f'{poles.real.max():.6g}, Riccati residual {residual:.2g})')
    return KalmanDesign(
        kind='kalman', model=model, gain=gain, requested_poles=poles, achieved_poles=poles,
        method='care', residual=residual, realization=predictor_realization(model, gain),
        filter_gain=None, covariance=covariance, filtered_covariance=None,
        process_noise=q, measurement_noise=r)


def design_sampled_kalman(model: StateSpaceModel, process_noise, measurement_noise,
                          dt: float) -> KalmanDesign:
    """
    Kalman filter for a continuous model sampled every ``dt`` seconds.

    The plant is discretized exactly (zero-order hold), the process noise intensity ``Q``
    with Van Loan's method; ``R`` is the covariance of each sampled measurement. The
    result's ``model`` is the sampled model (``dt`` set).

    Parameters
    ----------
    model : StateSpaceModel
        Continuous (``model.dt == 0``).
    process_noise : array_like, shape (n,) or (n * n,)
        Continuous-time intensity ``Q``.
    measurement_noise : array_like, shape (p,) or (p * p,)
        Covariance ``R`` of each sample.
    dt : float
        Sample interval in seconds, > 0.

    Returns
    -------
    KalmanDesign
        ``filter_gain`` is ``M`` ``(n, p)``, ``gain`` the predictor gain ``Ad M``.

    Raises
    ------
    ConfigError
        Naming ``model`` when it is discrete, ``dt`` when it is not a finite period > 0,
        ``process_noise`` or ``measurement_noise`` as :func:`design_kalman`.
    DesignError
        No stabilizing Riccati solution.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> design = oc.design_sampled_kalman(model, [0, 1], [0.01], dt=0.1)
    >>> design.model.dt, design.filter_gain.round(4).ravel().tolist()
    (0.1, [0.5485, 2.1248])

    """
    if model.is_discrete:
        raise ConfigError('model', f'expected a continuous model (dt = 0) to sample, got '
                          f'a discrete one (dt = {model.dt})')
    try:
        dt = float(dt)
    except (TypeError, ValueError) as e:
        raise ConfigError('dt', f'expected a number of seconds, got {dt!r}') from e
    if not (math.isfinite(dt) and dt > 0.0):
        raise ConfigError('dt', f'expected a finite sample interval > 0 s, got {dt}')
    q, r = noise_matrices(model, process_noise, measurement_noise)
    ad, bd = zero_order_hold(model.a, model.b, dt)
    sampled = StateSpaceModel(a=ad, b=bd, c=model.c, d=model.d, dt=dt,
                              state_names=model.state_names, input_names=model.input_names,
                              output_names=model.output_names)
    return discrete_kalman(sampled, van_loan(model.a, q, dt), r)
