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
Observer type ``alpha_beta``: an alpha-beta tracker whose innovation is clipped.

For a model with two states (a position, measured, and its rate) and one output: per
interval ``dt`` the estimate is predicted with the model (``x_prior = Ad x + Bd u``), and
corrected with the innovation clipped to ``innovation_limit``:
``x = x_prior + [alpha, beta / dt] clip(y - C x_prior - D u)``, so one outlier moves the
estimate by a bounded step. The clipping makes it non-linear: it has no linear realization,
and observer_ros skips the closed-loop analysis for it. Its error poles in the small-signal
(unclipped) range, ``z^2 - (2 - alpha - beta) z + (1 - alpha)``, do not depend on ``dt``.

Nothing in observer_ros names this type: it is found through the entry point in this
package's ``setup.py``.
"""

import numpy as np

from observer_ros.core import (
    Argument, Capabilities, ConfigError, Estimator, ObserverDesign, ObserverType, Prediction,
    StampError, transition)
from observer_ros.core.arguments import DOUBLE
from observer_ros.core.observers import ReportItem

NAME = 'alpha_beta'

#: How many distinct intervals :meth:`AlphaBetaEstimator.recent_intervals` keeps.
RECENT = 4

ALPHA = Argument('alpha', DOUBLE, 0.5, 'Alpha-beta: position gain alpha (0 ... 1].',
                 tunable=True, low=0.0, high=1.0, low_open=True)
BETA = Argument('beta', DOUBLE, 0.1, 'Alpha-beta: rate gain beta (0 ... 2].', tunable=True,
                low=0.0, high=2.0, low_open=True)
INNOVATION_LIMIT = Argument('innovation_limit', DOUBLE, 1e9, 'Alpha-beta: largest magnitude '
                            'of the innovation a sample corrects with (> 0).', tunable=True,
                            low=0.0, low_open=True)


def error_poles(alpha: float, beta: float) -> np.ndarray:
    """Return the small-signal error poles (z-plane) of the alpha-beta tracker."""
    return np.sort_complex(np.roots([1.0, -(2.0 - alpha - beta), 1.0 - alpha]).astype(complex))


def _design(model, values, disturbance=None):
    """Check the model and the gains; return the design (never None: the gains default)."""
    if model.n_states != 2 or model.n_outputs != 1:
        raise ConfigError('alpha', f'an alpha-beta tracker needs a model with 2 states and 1 '
                          f'output, got {model.n_states} states and {model.n_outputs} outputs')
    alpha, beta = values['alpha'], values['beta']
    poles = error_poles(alpha, beta)
    if np.abs(poles).max() >= 1.0:
        raise ConfigError('beta', f'alpha = {alpha:g} and beta = {beta:g} do not make the '
                          f'error converge (poles {poles.tolist()}); take beta < 4 - 2 alpha')
    return ObserverDesign(kind=NAME, model=model, gain=np.array([[alpha], [beta]]),
                          requested_poles=poles, achieved_poles=poles, method='alpha_beta',
                          residual=0.0, realization=None)


class AlphaBetaEstimator(Estimator):
    """The runtime alpha-beta tracker (an observer_ros ``Estimator`` of its own)."""

    def __init__(self, design: ObserverDesign, values, initial_state=None) -> None:
        model = design.model
        self.model = model
        self.n_states, self.n_inputs, self.n_outputs = (model.n_states, model.n_inputs,
                                                        model.n_outputs)
        self.alpha, self.beta = float(design.gain[0, 0]), float(design.gain[1, 0])
        self.limit = values['innovation_limit']
        self._initial = None
        if initial_state is not None:
            self.initial_state = initial_state
        self.reset()

    @property
    def initial_state(self):
        """The pinned first estimate, or None (the first measurement starts it)."""
        return None if self._initial is None else self._initial.copy()

    @initial_state.setter
    def initial_state(self, values) -> None:
        self._initial = None if values is None else np.asarray(values, dtype=float).copy()

    @property
    def stamp_ns(self):
        """Stamp of the last sample, None before the first."""
        return self._stamp

    @property
    def estimate(self) -> np.ndarray:
        """Return x_hat, zeros before the first sample."""
        return np.zeros(self.n_states) if self._x is None else self._x.copy()

    @property
    def innovation(self) -> np.ndarray:
        """The last innovation, unclipped."""
        return self._innovation.copy()

    @property
    def last_interval_ns(self) -> int:
        """The last step's interval (0 at a first sample)."""
        return self._last_interval

    def update(self, stamp_ns: int, y, u) -> np.ndarray:
        """Take a sample, checking its sizes first."""
        y = np.asarray(y, dtype=float).reshape(-1)
        u = np.asarray(u, dtype=float).reshape(-1)
        if y.size != self.n_outputs or u.size != self.n_inputs:
            raise ConfigError('y', f'expected {self.n_outputs} outputs and {self.n_inputs} '
                              f'inputs, got {y.size} and {u.size}')
        return self.advance(int(stamp_ns), y, u)

    def _output(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        return self.model.c @ x + self.model.d @ u

    def advance(self, stamp_ns: int, y: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Predict over the interval and correct with the clipped innovation."""
        if self._stamp is None:
            if self._x is None:  # the least-norm state whose output is y
                self._x = np.linalg.lstsq(self.model.c, y - self.model.d @ u, rcond=None)[0]
            self._innovation = y - self._output(self._x, u)
            self._stamp, self._last_interval = int(stamp_ns), 0
            return self._x.copy()
        interval = int(stamp_ns) - self._stamp
        if interval <= 0:
            raise StampError(f'stamp {stamp_ns} is not after the last one ({self._stamp})')
        ad, bd, _ = transition(self.model, interval / 1e9)
        prior = ad @ self._x + bd @ u
        self._innovation = y - self._output(prior, u)
        step = np.clip(self._innovation, -self.limit, self.limit)
        gain = np.array([[self.alpha], [self.beta * 1e9 / interval]])
        self._x = prior + gain @ step
        self._stamp, self._last_interval = int(stamp_ns), interval
        if interval not in self._recent:
            self._recent = (self._recent + [interval])[-RECENT:]
        return self._x.copy()

    def prediction(self, estimate, covariance, interval_ns: int, u) -> Prediction:
        """Carry ``estimate`` over ``interval_ns`` with ``u`` held (no covariance)."""
        estimate = np.asarray(estimate, dtype=float)
        if interval_ns <= 0:
            return Prediction(0, estimate.copy(), None)
        ad, bd, _ = transition(self.model, interval_ns / 1e9)
        return Prediction(0, ad @ estimate + bd @ np.asarray(u, dtype=float), None)

    def reset(self, initial_state=None) -> None:
        """Start again from ``initial_state`` (or the first measurement)."""
        if initial_state is not None:
            self.initial_state = initial_state
        self._x = self.initial_state
        self._stamp, self._last_interval, self._recent = None, 0, []
        self._innovation = np.zeros(self.n_outputs)

    def restart(self) -> None:
        """Forget the stamps; the next sample starts from the estimate held."""
        self._stamp, self._last_interval = None, 0

    def snapshot(self) -> tuple:
        """Return the running state."""
        return (None if self._x is None else self._x.copy(), self._stamp,
                self._innovation.copy(), self._last_interval)

    def restore(self, state: tuple) -> None:
        """Return to a snapshot."""
        x, self._stamp, innovation, self._last_interval = state
        self._x = None if x is None else x.copy()
        self._innovation = innovation.copy()

    def adopt(self, other: 'AlphaBetaEstimator') -> None:
        """Take the gains of ``other`` and keep the running state."""
        self.alpha, self.beta, self.limit = other.alpha, other.beta, other.limit

    def recent_intervals(self) -> list:
        """Return the last few distinct intervals stepped over (ns)."""
        return list(self._recent)


def _estimator(design, values, initial_state=None, interval_resolution_ns=0):
    return AlphaBetaEstimator(design, values, initial_state)


def _report(design):
    return (ReportItem('alpha', 'alpha', float(design.gain[0, 0])),
            ReportItem('beta', 'beta', float(design.gain[1, 0])))


TYPE = ObserverType(
    NAME, 'alpha-beta tracker with a clipped innovation (plug-in)',
    (ALPHA, BETA, INNOVATION_LIMIT), design=_design, estimator=_estimator, report=_report,
    capabilities=Capabilities(covariance=False, needs_every_output=True,
                              linear_realization=False, several_sources=False),
    charged=lambda given: 'alpha')
