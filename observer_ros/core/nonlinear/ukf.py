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
The unscented Kalman filter of a nonlinear model, continuous-discrete.

Sigma points: the scaled set of Van der Merwe, ``2n + 1`` points ``x`` and
``x +- columns of sqrt((n + lambda) P)`` (lower Cholesky factor), ``lambda = alpha^2 (n +
kappa) - n``, mean weights ``lambda / (n + lambda)`` and ``1 / (2 (n + lambda))``, the
covariance weight of the centre plus ``1 - alpha^2 + beta``. Defaults ``alpha = 1``,
``beta = 2``, ``kappa = 0`` (all weights non-negative but the centre's mean weight 0).

Prediction over an interval ``T`` with ``u`` held: each sigma point integrated by ``x' = f(x,
u)`` with the classical RK4 in ``ceil(T / max_step)`` equal steps (global error of order
``h^4``; a discrete model: one application of ``f``); their weighted mean and spread, plus
the process noise of the interval ``Qd``, the Riccati equation ``P' = F P + P F^T + Q``
integrated from ``P = 0`` along the mean with the same RK4 (the exact ``Qd`` of a linear
model to the integrator's accuracy; a discrete model's ``Q`` as given).

Update with a source's outputs: sigma points drawn again from ``(x-, P-)``, mapped by the
source's ``h``; ``S = sum W (z - z_mean)(.)^T + R_s``, ``P_xz`` likewise, ``K = P_xz S^-1``,
``x = x- + K v``, ``P = P- - K S K^T``. Residuals of angle states and angle outputs are
wrapped to ``(-pi, pi]``, and their means taken as the centre point plus the weighted
wrapped residuals, so a heading near ``+-pi`` averages to ``+-pi``, not to 0.
"""

import math
from typing import Optional

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear.ekf import integrate
from observer_ros.core.nonlinear.filter import DEFAULT_MAX_STEP, NonlinearFilter, rk4

__all__ = ['UnscentedKalman']


class UnscentedKalman(NonlinearFilter):
    """
    Unscented Kalman filter (see the module for the sigma points and the steps).

    Parameters
    ----------
    model, process_noise, measurement_noise, initial_covariance, initial_state, max_step
        As :class:`~observer_ros.core.nonlinear.filter.NonlinearFilter`.
    alpha, beta, kappa : float
        The spread and weights of the sigma points (``alpha`` in ``(0, 1]``).

    Examples
    --------
    >>> from observer_ros.core.nonlinear import differential_drive
    >>> ukf = UnscentedKalman(differential_drive(), [0.0, 0.0, 0.0, 0.1, 0.1],
    ...                       [0.01, 0.01, 1e-4, 0.01, 0.01, 1e-3])
    >>> x = ukf.update(0, [20.0, 20.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0])
    >>> x = ukf.advance_outputs(10_000_000, np.array([20.0, 20.0]), np.zeros(2), (0, 1))
    >>> (ukf.estimate.round(3) + 0.0).tolist()
    [0.01, 0.0, 0.0, 1.0, 0.0]

    """

    def __init__(self, model, process_noise, measurement_noise, initial_covariance=None,
                 initial_state=None, max_step: float = DEFAULT_MAX_STEP, alpha: float = 1.0,
                 beta: float = 2.0, kappa: float = 0.0) -> None:
        for name, value in (('alpha', alpha), ('beta', beta), ('kappa', kappa)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (
                    math.isfinite(value)):
                raise ConfigError(name, f'expected a finite number, got {value!r}')
        if not 0.0 < alpha <= 1.0:
            raise ConfigError('alpha', f'expected 0 < alpha <= 1, got {alpha!r}')
        super().__init__(model, process_noise, measurement_noise, initial_covariance,
                         initial_state, max_step)
        n = self.n_states
        spread = alpha * alpha * (n + kappa)
        if spread <= 0.0:
            raise ConfigError('kappa', f'expected alpha^2 (n + kappa) > 0 (n = {n}), got '
                              f'{spread:g}')
        self.alpha, self.beta, self.kappa = float(alpha), float(beta), float(kappa)
        lam = spread - n
        self.scale = math.sqrt(spread)
        self.mean_weights = np.full(2 * n + 1, 0.5 / spread)
        self.mean_weights[0] = lam / spread
        self.covariance_weights = self.mean_weights.copy()
        self.covariance_weights[0] += 1.0 - alpha * alpha + beta
        self._zero = np.zeros((n, n))

    def sigma_points(self, x: np.ndarray, p: np.ndarray) -> Optional[np.ndarray]:
        """Return the ``(2n + 1, n)`` sigma points of ``(x, P)``, None when P is not PD."""
        try:
            factor = np.linalg.cholesky(p) * self.scale
        except np.linalg.LinAlgError:
            return None
        return np.vstack([x, x + factor.T, x - factor.T])

    def _mean(self, points: np.ndarray, wrap) -> tuple:
        """Return the weighted mean of ``points`` and their residuals (wrapped by ``wrap``)."""
        centre = points[0]
        residuals = wrap(points - centre)
        mean = centre + self.mean_weights @ residuals
        return mean, wrap(points - mean)

    def propagate(self, x: np.ndarray, p: np.ndarray, interval_ns: int,
                  u: np.ndarray) -> tuple:
        """Return ``(x, P)`` carried over ``interval_ns``: the sigma points moved by ``f``."""
        points = self.sigma_points(x, p)
        if points is None:
            return np.full_like(x, math.nan), p
        model = self.model
        if model.is_discrete:
            moved = model.f_many(points, u)
            noise = self.process_noise
        else:
            count, h = self.steps(interval_ns)
            moved = rk4(model.f_many, points, u, count, h)
            noise = integrate(model.f_and_jacobian, x, self._zero, self.process_noise, u,
                              count, h)[1]
        if not np.isfinite(moved).all():
            return np.full_like(x, math.nan), p
        mean, residuals = self._mean(moved, self.wrap_states)
        spread = (residuals.T * self.covariance_weights) @ residuals
        return mean, spread + noise

    def correct(self, x: np.ndarray, p: np.ndarray, y: np.ndarray, u: np.ndarray,
                outputs: tuple) -> Optional[tuple]:
        """Return ``(x, P, innovation, S, nis)`` after the update, None when not finite."""
        points = self.sigma_points(x, p)
        if points is None:
            return None
        measured = self.model.measurement(outputs).many(points, u)
        if not np.isfinite(measured).all():
            return None

        def wrap(residual):
            return self.wrap_outputs(residual, outputs)

        predicted, z_residuals = self._mean(measured, wrap)
        x_residuals = self.wrap_states(points - x)
        weighted = z_residuals.T * self.covariance_weights
        s = weighted @ z_residuals + self.noise_block(outputs)
        s = 0.5 * (s + s.T)
        cross = (x_residuals.T * self.covariance_weights) @ z_residuals
        try:
            factor = np.linalg.cholesky(s)
        except np.linalg.LinAlgError:
            return None
        k = np.linalg.solve(factor.T, np.linalg.solve(factor, cross.T)).T  # P_xz S^-1
        innovation = wrap(y - predicted)
        whitened = np.linalg.solve(factor, innovation)
        return (x + k @ innovation, p - k @ s @ k.T, innovation, s,
                float(whitened @ whitened))
