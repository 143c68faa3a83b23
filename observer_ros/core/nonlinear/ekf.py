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
The extended Kalman filter of a nonlinear model, continuous-discrete.

Prediction over an interval ``T`` with the input ``u`` held (zero-order hold):

- continuous model: the mean and the covariance integrated together,
  ``x' = f(x, u)`` and ``P' = F(x, u) P + P F(x, u)^T + Q`` (``Q`` an intensity), by the
  classical Runge-Kutta method of order 4 in ``ceil(T / max_step)`` equal steps
  (``max_step`` 1 ms by default): a local error of order ``h^5``, a global one of order
  ``h^4``. On a linear model this is the exact discretization ``Ad P Ad^T + Qd`` of the
  linear time-varying filter to about ``(|A| h)^5 / 120`` per step (1e-13 relative at
  ``|A| h = 0.01``);
- continuous model, ``covariance_prediction='midpoint'``: the same RK4 of the mean (bit
  for bit), and per step the covariance by the discrete map ``P+ = Phi P Phi^T + Qd`` with
  the Jacobian ``F`` taken once, at the step's midpoint (the point of RK4's second stage),
  ``Phi = I + F h + (F h)^2 / 2`` and ``Qd = Q h + (F Q + Q F^T) h^2 / 2``: second order in
  ``h`` (a local error of order ``h^3``). On the differential-drive base turning at 1.5 rad/s
  at 2 m/s, after 1 s the covariance differs from the RK4 of 0.1 ms steps by 5.6e-7 relative
  at 1 ms steps (2.3e-6 at 2 ms, 5.6e-5 at 10 ms; the RK4 1.5e-13, 2.1e-12, 1.3e-9), for
  60 to 75 % of the RK4's cost per step (benchmark section 10, ``doc/nonlinear.md``);
- discrete model: ``x+ = f(x, u)`` and ``P+ = F P F^T + Q``.

Update with the outputs of a source: ``v = y - h(x-, u)`` (angle outputs wrapped),
``S = H P- H^T + R_s``, ``K = P- H^T S^-1``, ``x = x- + K v`` and the Joseph form
``P = (I - K H) P- (I - K H)^T + K R_s K^T``, with ``H = dh/dx`` of the source's rows at
``x-`` and ``R_s`` their block of ``R``. ``u`` in ``h(x, u)`` is the input held over the
interval that ends at the measurement.
"""

from typing import Optional

import numpy as np
from scipy.linalg.lapack import dpotrf, dpotrs, dtrtrs

from observer_ros.core.errors import ConfigError
from observer_ros.core.nonlinear.filter import NonlinearFilter

__all__ = ['ExtendedKalman', 'PREDICTIONS']

#: The continuous model's prediction of the covariance: the Riccati equation integrated by
#: RK4 (four Jacobians a step, accurate to ``h^4``), or the discrete map of the Jacobian at
#: the step's midpoint (one a step, accurate to ``h^2``).
PREDICTIONS = ('rk4', 'midpoint')


class ExtendedKalman(NonlinearFilter):
    """
    Extended Kalman filter (see the module for the integrator and the update).

    Parameters are those of :class:`~observer_ros.core.nonlinear.filter.NonlinearFilter`,
    and ``covariance_prediction``: ``'rk4'`` (default, the accurate one) or ``'midpoint'``
    (one Jacobian a step, see the module).

    Raises
    ------
    ConfigError
        Those of the filter; ``covariance_prediction`` not one of :data:`PREDICTIONS`.

    Examples
    --------
    >>> from observer_ros.core.nonlinear import differential_drive
    >>> ekf = ExtendedKalman(differential_drive(), [0.0, 0.0, 0.0, 0.1, 0.1],
    ...                      [0.01, 0.01, 1e-4, 0.01, 0.01, 1e-3])
    >>> x = ekf.update(0, [20.0, 20.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0])
    >>> x = ekf.advance_outputs(10_000_000, np.array([20.0, 20.0]), np.zeros(2), (0, 1))
    >>> ekf.estimate.round(3).tolist()
    [0.01, 0.0, 0.0, 1.0, 0.0]

    """

    def __init__(self, *args, covariance_prediction: str = 'rk4', **kwargs) -> None:
        if covariance_prediction not in PREDICTIONS:
            raise ConfigError('covariance_prediction', f'expected one of {list(PREDICTIONS)}, '
                              f'got {covariance_prediction!r}')
        self.covariance_prediction = covariance_prediction
        super().__init__(*args, **kwargs)

    def adopt(self, other) -> None:
        """Take the model, noises, ``P0``, step and prediction of ``other``; keep the state."""
        super().adopt(other)
        self.covariance_prediction = other.covariance_prediction

    def propagate(self, x: np.ndarray, p: np.ndarray, interval_ns: int,
                  u: np.ndarray) -> tuple:
        """Return ``(x, P)`` carried over ``interval_ns`` (RK4, or the discrete map)."""
        model = self.model
        if model.is_discrete:
            f, jacobian = model.f_and_jacobian(x, u)
            return f, jacobian @ p @ jacobian.T + self.process_noise
        if self.covariance_prediction == 'midpoint':
            return integrate_midpoint(model.f, model.f_and_jacobian, x, p, self.process_noise,
                                      u, *self.steps(interval_ns))
        return integrate(model.f_and_jacobian, x, p, self.process_noise, u,
                         *self.steps(interval_ns))

    def correct(self, x: np.ndarray, p: np.ndarray, y: np.ndarray, u: np.ndarray,
                outputs: tuple) -> Optional[tuple]:
        """Return ``(x, P, innovation, S, nis)`` after the update, None when not finite."""
        h, jacobian = self.model.measurement(outputs)(x, u)
        if not (np.isfinite(h).all() and np.isfinite(jacobian).all()):
            return None
        r = self.noise_block(outputs)
        innovation = self.wrap_outputs(y - h, outputs)
        ph = p @ jacobian.T
        s = jacobian @ ph + r
        s = 0.5 * (s + s.T)
        # LAPACK directly: numpy.linalg's wrappers cost several times the small solves
        factor, info = dpotrf(s, lower=1, clean=1)
        if info:
            return None  # S not positive definite
        k = dpotrs(factor, ph.T, lower=1)[0].T  # P- H^T S^-1
        whitened = dtrtrs(factor, innovation, lower=1)[0]
        left = p - k @ ph.T  # (I - K H) P-
        updated = left - (left @ jacobian.T) @ k.T + k @ r @ k.T
        return x + k @ innovation, updated, innovation, s, float(whitened @ whitened)


def integrate(f_and_jacobian, x: np.ndarray, p: np.ndarray, q: np.ndarray, u: np.ndarray,
              count: int, h: float) -> tuple:
    """
    Integrate ``x' = f(x, u)``, ``P' = F P + P F^T + Q`` by RK4 in ``count`` steps of ``h``.

    Parameters
    ----------
    f_and_jacobian : callable
        ``(x, u) -> (f, F)``.
    x : numpy.ndarray, shape (n,)
    p : numpy.ndarray, shape (n, n)
        Symmetric; it stays exactly symmetric (each stage adds ``M + M^T``).
    q : numpy.ndarray, shape (n, n)
    u : numpy.ndarray, shape (m,)
    count : int
    h : float

    Returns
    -------
    tuple of numpy.ndarray
        ``(x, P)`` at the end.

    """
    half, sixth = 0.5 * h, h / 6.0
    for _ in range(count):
        f1, a1 = f_and_jacobian(x, u)
        m1 = a1 @ p
        d1 = m1 + m1.T + q
        f2, a2 = f_and_jacobian(x + half * f1, u)
        p2 = p + half * d1
        m2 = a2 @ p2
        d2 = m2 + m2.T + q
        f3, a3 = f_and_jacobian(x + half * f2, u)
        p3 = p + half * d2
        m3 = a3 @ p3
        d3 = m3 + m3.T + q
        f4, a4 = f_and_jacobian(x + h * f3, u)
        p4 = p + h * d3
        m4 = a4 @ p4
        d4 = m4 + m4.T + q
        x = x + sixth * (f1 + 2.0 * f2 + 2.0 * f3 + f4)
        p = p + sixth * (d1 + 2.0 * d2 + 2.0 * d3 + d4)
    return x, p


def integrate_midpoint(f, f_and_jacobian, x: np.ndarray, p: np.ndarray, q: np.ndarray,
                       u: np.ndarray, count: int, h: float) -> tuple:
    """
    Integrate the mean by RK4 and carry ``P`` by ``Phi P Phi^T + Qd``, one Jacobian a step.

    ``F`` at the midpoint ``x + h/2 f(x, u)`` (RK4's second stage, so the mean is that of
    :func:`integrate` bit for bit), ``Phi = I + F h + (F h)^2 / 2``,
    ``Qd = Q h + (F Q + Q F^T) h^2 / 2``: second order in ``h``.

    Parameters
    ----------
    f : callable
        ``(x, u) -> f``.
    f_and_jacobian : callable
        ``(x, u) -> (f, F)``.
    x : numpy.ndarray, shape (n,)
    p : numpy.ndarray, shape (n, n)
    q : numpy.ndarray, shape (n, n)
    u : numpy.ndarray, shape (m,)
    count : int
    h : float

    Returns
    -------
    tuple of numpy.ndarray
        ``(x, P)`` at the end.

    """
    half, sixth, square = 0.5 * h, h / 6.0, 0.5 * h * h
    eye = np.eye(len(x))
    qh = q * h
    for _ in range(count):
        f1 = f(x, u)
        f2, a = f_and_jacobian(x + half * f1, u)
        g = a * h
        phi = eye + g @ (eye + 0.5 * g)
        m = (a @ q) * square
        p = phi @ p @ phi.T + (qh + m + m.T)
        f3 = f(x + half * f2, u)
        f4 = f(x + h * f3, u)
        x = x + sixth * (f1 + 2.0 * f2 + 2.0 * f3 + f4)
    return x, p
