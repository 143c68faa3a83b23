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

"""The step designs: one matrix per sample interval, and the helpers that build them."""

import copy
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from observer_ros.core.analysis import observability_problem
from observer_ros.core.discretize import transition, zero_order_hold
from observer_ros.core.errors import DesignError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.placement import place_observer
from observer_ros.core.poles import to_discrete
from observer_ros.core.units import NANOSECONDS


@dataclass(frozen=True)
class StepMatrices:
    """
    One sample interval of an estimator.

    Attributes
    ----------
    g : numpy.ndarray, shape (n + p, n + m + p)
        ``[x_hat_new; innovation] = g @ [x_hat_prev; u; y]``; the innovation is
        ``y - C x_hat_prior`` with the prediction ``x_hat_prior = Ad x_hat_prev + Bd u``.
        The estimators evaluate it as ``g_known @ [x_hat_prev; u] + g_y @ y`` (see
        :func:`output_term`), so that the first product can be made before ``y`` arrives.
    g_known, g_y : numpy.ndarray, shapes (n + p, n + m) and (n + p, p)
        The columns of ``g`` for ``[x_hat_prev; u]`` and for ``y`` (made from ``g``).
    error : numpy.ndarray, shape (n, n)
        Designed error dynamics ``e_new = error @ e_prev`` (``e = x - x_hat``).
    poles : numpy.ndarray of complex
        Designed discrete poles of the interval.
    covariance : numpy.ndarray or None, shape (n, n)
        Kalman only: covariance of ``x_hat`` after the update.
    ad, bd : numpy.ndarray or None, shapes (n, n) and (n, m)
        The sampled plant of the interval.
    innovation_covariance : numpy.ndarray or None, shape (p, p)
        Kalman only: ``S = C P_prior C^T + R``.

    """

    g: np.ndarray
    error: np.ndarray
    poles: np.ndarray
    covariance: Optional[np.ndarray] = None
    ad: Optional[np.ndarray] = None
    bd: Optional[np.ndarray] = None
    innovation_covariance: Optional[np.ndarray] = None
    g_known: np.ndarray = field(init=False, repr=False)
    g_y: np.ndarray = field(init=False, repr=False)
    g_y_column: Optional[np.ndarray] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        split = self.g.shape[1] - (self.g.shape[0] - self.error.shape[0])
        g_y = np.ascontiguousarray(self.g[:, split:])
        object.__setattr__(self, 'g_known', np.ascontiguousarray(self.g[:, :split]))
        object.__setattr__(self, 'g_y', g_y)
        object.__setattr__(self, 'g_y_column',
                           np.ascontiguousarray(g_y[:, 0]) if g_y.shape[1] == 1 else None)


def output_term(step: StepMatrices, y: np.ndarray) -> np.ndarray:
    """
    Return ``g_y @ y``, the measurement's part of a step, the same way on every path.

    With one output it is an elementwise product (no sum, so exact whatever computes it);
    the batch replay forms it for many samples at once and stays equal bit for bit.
    """
    column = step.g_y_column
    if column is not None:
        return column * y[0]
    return step.g_y @ y


def assemble_step(error: np.ndarray, input_gain: np.ndarray, output_gain: np.ndarray,
                  c: np.ndarray, ad: np.ndarray, bd: np.ndarray, poles: np.ndarray,
                  covariance: Optional[np.ndarray] = None,
                  innovation_covariance: Optional[np.ndarray] = None) -> StepMatrices:
    """Stack ``x_hat_new = error x + input_gain u + output_gain y`` with the innovation rows."""
    n_outputs = c.shape[0]
    top = np.hstack([error, input_gain, output_gain])
    bottom = np.hstack([-c @ ad, -c @ bd, np.eye(n_outputs)])
    return StepMatrices(g=np.ascontiguousarray(np.vstack([top, bottom])), error=error,
                        poles=poles, covariance=covariance, ad=ad, bd=bd,
                        innovation_covariance=innovation_covariance)


class StepDesign:
    """
    Base of the per-type step designs: turns a sample interval into :class:`StepMatrices`.

    Subclasses implement :meth:`design_step` for ``(Ad, Bd, discrete poles)``; this base
    discretizes continuous models exactly (zero-order hold) and maps the continuous poles
    to ``exp(lambda dt)``.
    """

    kind = 'base'

    def __init__(self, model: StateSpaceModel) -> None:
        self.model = model

    def step(self, dt_ns: int) -> StepMatrices:
        """Step matrices for an interval of ``dt_ns`` nanoseconds (ignored if discrete)."""
        model = self.model
        if model.is_discrete:
            return self.design_step(model.a, model.b, 0.0)
        dt = dt_ns / NANOSECONDS
        ad, bd = zero_order_hold(model.a, model.b, dt)
        return self.design_step(ad, bd, dt)

    def design_step(self, ad: np.ndarray, bd: np.ndarray, dt: float) -> StepMatrices:
        """
        Step matrices for the sampled plant ``(Ad, Bd)``.

        ``dt`` is the interval in seconds for a sampled continuous model, 0 for a discrete
        model (whose poles are already z-plane).
        """
        raise NotImplementedError

    #: Process noise for predicting a covariance (Kalman designs set it).
    process_noise: Optional[np.ndarray] = None

    def transition(self, dt_ns: int) -> tuple:
        """Return ``(Ad, Bd, Qd or None)`` over ``dt_ns`` (see :func:`~.discretize.transition`)."""
        return transition(self.model, dt_ns / NANOSECONDS, self.process_noise)

    def discrete_poles(self, continuous_or_discrete: np.ndarray, dt: float) -> np.ndarray:
        """``exp(lambda dt)`` for a sampled continuous model, the poles as given otherwise."""
        if self.model.is_discrete:
            return continuous_or_discrete
        return to_discrete(continuous_or_discrete, dt)

    def initial_estimate(self, initial_state: np.ndarray, y: np.ndarray) -> np.ndarray:
        """Estimate at the first sample; reduced observers make it agree with ``y``."""
        return initial_state.copy()

    def several_sources_problem(self) -> Optional[str]:
        """
        Say why this design takes no several sources (None: it does).

        The base answer: the observer is built on every output (the reduced-order types
        are), so each update needs them all. A type that designs per subset of outputs
        overrides this, :meth:`subset_problem` and :meth:`for_outputs`.
        """
        return ('this observer needs every output at each update (it is built on all of '
                'them); it takes one measurement source with every output')

    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """Say why a step from ``outputs`` alone cannot be designed (None: it can)."""
        return self.several_sources_problem()

    def for_outputs(self, outputs: tuple) -> 'StepDesign':
        """
        Return the step design of an update with ``outputs`` alone (ascending indices).

        A copy of this design for the model with those rows of ``C`` (a type with more
        per-output data, a noise block, extends it).

        Raises
        ------
        DesignError
            What :meth:`subset_problem` says.

        """
        problem = self.subset_problem(outputs)
        if problem is not None:
            raise DesignError(problem)
        subset = copy.copy(self)
        subset.model = outputs_model(self.model, outputs)
        return subset

    def observability_problem(self, outputs: tuple, detectable: bool,
                              consequence: str) -> Optional[str]:
        """
        Say which modes ``outputs`` alone cannot see (None: none), by the one rule.

        :func:`observer_ros.core.analysis.observability_problem` for these rows of ``C``;
        ``detectable``: only the modes that do not decay count (a Kalman filter).
        """
        model = self.model
        return observability_problem(
            model.a, model.c[list(outputs)], detectable=detectable,
            discrete=model.is_discrete, state_names=model.state_names or None,
            what='(A, C) of these outputs', seen_from='them', consequence=consequence)


def outputs_model(model: StateSpaceModel, outputs: tuple) -> StateSpaceModel:
    """Return ``model`` with the rows of ``C`` and ``D`` (and names) of ``outputs`` only."""
    index = list(outputs)
    rows = len(index)
    return replace(model, c=np.ascontiguousarray(model.c[index]).reshape(rows, model.n_states),
                   d=np.ascontiguousarray(model.d[index]).reshape(rows, model.n_inputs),
                   output_names=tuple(model.output_names[k] for k in index)
                   if model.output_names else ())


class PredictOnlyStep(StepDesign):
    """
    The step of an update with no output: ``x_hat = Ad x_hat + Bd u`` (a predict-only source).

    For a Kalman design the step reports the nominal covariance ``Ad P Ad^T + Qd`` carried
    from the steady filtered ``P`` of the design with every output.
    """

    kind = 'predict_only'

    def __init__(self, base: StepDesign) -> None:
        super().__init__(outputs_model(base.model, ()))
        self.base = base
        self.process_noise = base.process_noise

    def design_step(self, ad, bd, dt) -> StepMatrices:
        """Assemble the prediction (no gain; the error dynamics are the plant's)."""
        n = ad.shape[0]
        covariance = None
        if self.process_noise is not None:
            full = self.base.design_step(ad, bd, dt)
            if full.covariance is not None:
                model = self.base.model
                qd = transition(model, dt if dt else model.dt, self.process_noise)[2]
                covariance = ad @ full.covariance @ ad.T + qd
                covariance = 0.5 * (covariance + covariance.T)
        return assemble_step(ad, bd, np.zeros((n, 0)), self.model.c, ad, bd,
                             np.linalg.eigvals(ad), covariance, np.zeros((0, 0)))


def place_sampled(a: np.ndarray, c: np.ndarray, poles: np.ndarray, method: str):
    """
    Return a verified observer gain for one sampled interval (:func:`place_observer`).

    Sampling can make distinct continuous poles coincide (fast poles all map to
    ``exp(lambda dt) = 0``), which a method such as ``'place'`` refuses; the interval is
    then placed with ``'auto'``, which picks a method that takes repeated poles. The
    result is verified either way.
    """
    try:
        return place_observer(a, c, poles, method)
    except DesignError:
        if method == 'auto':
            raise
        return place_observer(a, c, poles, 'auto')


def least_norm_consistent(c: np.ndarray, initial_state: np.ndarray, y: np.ndarray):
    """``x0 + C^+ (y - C x0)``: the point nearest ``x0`` whose output is ``y``."""
    correction = np.linalg.lstsq(c, y - c @ initial_state, rcond=None)[0]
    return initial_state + correction
