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
The linear observer types on a nonlinear plant: the gain at the operating point, f and h.

A linear type (the full-order observer, the Kalman filter...) is designed on the
linearization of the equations at the operating point
(:class:`~observer_ros.core.nonlinear.linearize.LinearizedModel`) with today's checks
(observability, placement, the Riccati equation), and its estimator gives, for each sample
interval and each set of outputs, the gain ``M`` of its current-form step.
:class:`NonlinearPrediction` runs that gain with the nonlinear prediction::

    x_prior = the solution of x' = f(x, u) over the interval (RK4, 1 ms steps at most)
    x_hat = x_prior + M (y - h(x_prior, u))

the sampled form of ``x_hat' = f(x_hat, u) + L (y - h(x_hat, u))``; a discrete model
applies ``f`` once per sample, as the linear estimator applies ``Ad`` once. With a linear
model it is the linear current-form estimator to the integrator's accuracy (1e-14 measured
for the four built-in types, jittered 10 ms stamps).

Only a step in innovation form can take it: ``error = (I - M C) Ad`` and
``input_gain = (I - M C) Bd``, checked on the step of a nominal interval. The four built-in
linear types in the current form are (the reduced-order and Chen observers too: their
``M`` sets the measured directions to ``y``); an observer in the delayed form (``form``) is
not, the time-varying Kalman filter propagates its own covariance with the linear model
(``time_varying``), and a type whose step is not in that form (``type``): each is refused
naming the argument. The first sample starts the estimate one Gauss-Newton step from the
prior with the linearization's ``C`` (a pinned initial state is kept), as the linear
estimator starts at the least-norm state that gives ``y``.
"""

import math
from typing import Optional

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators.constant_gain import ConstantGainEstimator
from observer_ros.core.estimators.intervals import IntervalCache
from observer_ros.core.estimators.protocol import Prediction
from observer_ros.core.nonlinear.filter import DEFAULT_MAX_STEP, NonlinearFilter, rk4
from observer_ros.core.nonlinear.model import NonlinearModel

__all__ = ['NonlinearPrediction', 'NOMINAL_INTERVAL_NS']

#: The interval whose step is checked for the innovation form (10 ms).
NOMINAL_INTERVAL_NS = 10_000_000

#: Relative tolerance of the innovation-form check.
FORM_TOLERANCE = 1e-9


def _gain(step, n: int) -> np.ndarray:
    """Return ``M`` of a step, ``(n, q)``."""
    return step.g_y[:n]


def innovation_form_problem(step, c: np.ndarray) -> Optional[str]:
    """Say why a step is not ``x_hat = x_prior + M (y - C x_prior)``; None when it is."""
    n = c.shape[1]
    gain = _gain(step, n)
    if step.ad is None or step.bd is None:
        return 'its step does not say its sampled plant'
    projector = np.eye(n) - gain @ c
    for name, given, expected in (('error', step.error, projector @ step.ad),
                                  ('input gain', step.g_known[:n, n:], projector @ step.bd)):
        scale = max(1.0, float(np.abs(expected).max(initial=0.0)))
        if given.shape != expected.shape or np.abs(given - expected).max(
                initial=0.0) > FORM_TOLERANCE * scale:
            return f'its step is not in innovation form (its {name} is not (I - M C) times ' \
                   f'the sampled plant)'
    return None


class NonlinearPrediction(NonlinearFilter):
    """
    A linear type's gain run with the nonlinear prediction (see the module notes).

    Parameters
    ----------
    linear : ConstantGainEstimator
        The type's estimator, designed on the linearization.
    model : NonlinearModel
        The equations.
    arguments : mapping
        The type's arguments (``form``, ``time_varying`` name what is refused).
    initial_state : array_like, optional
    max_step : float
        Longest RK4 step of a continuous model's prediction (seconds).

    Raises
    ------
    ConfigError
        ``form``, ``time_varying`` or ``type``: the estimator's step cannot take the
        nonlinear prediction.

    """

    def __init__(self, linear, model: NonlinearModel, arguments=None, initial_state=None,
                 max_step: float = DEFAULT_MAX_STEP) -> None:
        arguments = dict(arguments or {})
        if arguments.get('time_varying'):
            raise ConfigError('time_varying', 'the time-varying Kalman filter propagates its '
                              'covariance with the linear model; with equations '
                              '(model.dynamics) expected false, or a type that runs the '
                              'equations itself (capability equations: the extended Kalman '
                              'filter)')
        if arguments.get('form', 'current') != 'current':
            raise ConfigError('form', 'the nonlinear prediction corrects the prediction to '
                              "the measurement's stamp; with equations (model.dynamics) "
                              "expected 'current'")
        if not isinstance(linear, ConstantGainEstimator):
            raise ConfigError('type', f'its estimator ({type(linear).__name__}) gives no gain '
                              'per interval to correct the nonlinear prediction with')
        design = linear.design
        c = design.model.c
        problem = innovation_form_problem(design.step(NOMINAL_INTERVAL_NS), c)
        if problem is not None:
            raise ConfigError('type', f'{problem}: it cannot correct the nonlinear '
                              'prediction x_hat = x_prior + M (y - h(x_prior)); expected a '
                              'type whose step is, or one that runs the equations itself '
                              '(capability equations)')
        n, p = model.n_states, model.n_outputs
        super().__init__(model, np.zeros(n), np.eye(p), None, initial_state, max_step)
        self.linear, self.c = linear, c
        self._gains: dict = {}
        self._interval = 0
        self._last_step = None

    @property
    def covariance(self) -> Optional[np.ndarray]:
        """The covariance of the last step's design (a Kalman filter's ``P``), else None."""
        step = self._last_step
        return None if step is None else step.covariance

    @property
    def innovation_covariance(self) -> Optional[np.ndarray]:
        """``S`` of the last step's design (a Kalman filter's), else None."""
        step = self._last_step
        return None if step is None else step.innovation_covariance

    @property
    def nis(self) -> Optional[float]:
        """``v^T S^-1 v`` with the last step's ``S`` (a Kalman filter's), else None."""
        s = self.innovation_covariance
        if s is None or self._innovation.shape != (len(s),):
            return None
        return float(self._innovation @ np.linalg.solve(s, self._innovation))

    def several_sources_problem(self) -> Optional[str]:
        """Return the linear estimator's answer: its gains are the ones run."""
        return self.linear.several_sources_problem()

    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """Return the linear estimator's answer (a subset whose gain cannot be designed)."""
        return self.linear.subset_problem(outputs)

    def _step(self, outputs: tuple, interval_ns: int):
        """Return the step of ``outputs`` over ``interval_ns`` (cached per interval)."""
        cache = self._gains.get(outputs)
        if cache is None:
            design = self.linear.design
            if len(outputs) != self.n_outputs:
                design = design.for_outputs(outputs)
            cache = self._gains[outputs] = IntervalCache(
                design.step, self.linear.intervals.size, self.linear.intervals.resolution_ns)
        return cache.get(interval_ns)

    def propagate(self, x: np.ndarray, p: np.ndarray, interval_ns: int,
                  u: np.ndarray) -> tuple:
        """Return ``x`` carried by ``f`` over the interval with ``u`` held, and ``p``."""
        self._interval = interval_ns
        f = self.model.f
        u = np.asarray(u, dtype=float)
        if self.model.is_discrete:
            return f(x, u), p
        return rk4(f, x, u, *self.steps(interval_ns)), p

    def correct(self, x: np.ndarray, p: np.ndarray, y: np.ndarray, u: np.ndarray,
                outputs: tuple) -> Optional[tuple]:
        """Return ``x + M (y - h(x, u))`` (the first sample: see the module notes)."""
        innovation = self.wrap_outputs(y - self.model.h(x, u, outputs), outputs)
        if not np.isfinite(innovation).all():
            return None
        if self._stamp is None:  # the first sample
            rows = self.c[list(outputs)]
            if self._pinned is not None:  # as the type's design starts, on the innovation
                design = self.linear.design
                if len(outputs) != self.n_outputs:
                    design = design.for_outputs(outputs)
                start = design.initial_estimate(x, rows @ x + innovation)
                return np.array(start, dtype=float), p, innovation, None, math.nan
            step = np.linalg.lstsq(rows, innovation, rcond=None)[0]
            return x + step, p, innovation, None, math.nan
        step = self._last_step = self._step(outputs, self._interval)
        return x + _gain(step, self.n_states) @ innovation, p, innovation, None, math.nan

    def advance_outputs(self, stamp_ns: int, y: np.ndarray, u: np.ndarray,
                        outputs: tuple) -> np.ndarray:
        """Take the values ``y`` of ``outputs`` at ``stamp_ns`` (see the module notes)."""
        if self._stamp is None:
            self._interval = 0
        return super().advance_outputs(stamp_ns, y, u, outputs)

    def prediction(self, estimate: np.ndarray, covariance: Optional[np.ndarray],
                   interval_ns: int, u: np.ndarray) -> Prediction:
        """Return ``x`` carried by ``f`` over ``interval_ns`` with ``u``; ``covariance`` as is."""
        estimate = np.array(estimate, dtype=float)
        if interval_ns <= 0:
            return Prediction(0, estimate, covariance)
        x = self.propagate(estimate, None, int(interval_ns), np.asarray(u, dtype=float))[0]
        if not np.isfinite(x).all():
            self.counters['nonfinite'] += 1
            return Prediction(0, estimate, covariance)
        if self.angles is not None:
            self.angles.keep(x)
        return Prediction(0, x, covariance)

    def snapshot(self) -> tuple:
        """Return the running state, for :meth:`restore`."""
        return super().snapshot(), self._last_step

    def restore(self, state: tuple) -> None:
        """Return to a state taken by :meth:`snapshot`."""
        super().restore(state[0])
        self._last_step = state[1]
