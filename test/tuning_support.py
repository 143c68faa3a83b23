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

"""Simulated recordings with known noise covariances, written as bags, for the tuning tests."""

from dataclasses import dataclass
from typing import Optional

import numpy as np
import yaml

from observer_ros.bags.storage import TopicToWrite, write_bag
from observer_ros.core.discretize import van_loan, zero_order_hold

#: Start of the simulated stamps (ns): a wall-clock-like time.
START_NS = 1_700_000_000 * 10**9


@dataclass(frozen=True)
class NoisyPlant:
    """
    A linear plant with known noises, and the parameter file of a Kalman filter for it.

    ``process_noise`` is an intensity when ``dt_model`` is 0 (continuous model sampled at
    ``period``), else the discrete covariance.
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    process_noise: np.ndarray
    measurement_noise: np.ndarray
    period: float
    continuous: bool
    state_names: tuple
    output_names: tuple
    input_names: tuple = ('force',)

    @property
    def sampled(self) -> tuple:
        """``(Ad, Bd, Qd)`` of one period."""
        if self.continuous:
            ad, bd = zero_order_hold(self.a, self.b, self.period)
            return ad, bd, van_loan(self.a, self.process_noise, self.period)
        return self.a, self.b, self.process_noise

    def simulate(self, samples: int, seed: int, initial_state=None) -> tuple:
        """Return ``(u, x, y)`` of ``samples`` steps: ``x[k+1] = Ad x + Bd u + w``."""
        rng = np.random.default_rng(seed)
        ad, bd, qd = self.sampled
        n_states, n_outputs = ad.shape[0], self.c.shape[0]
        u = rng.uniform(-1.0, 1.0, size=(samples, bd.shape[1]))
        w = _gaussian(rng, qd, samples)
        v = _gaussian(rng, self.measurement_noise, samples)
        drive = u @ bd.T + w
        x = np.empty((samples, n_states))
        state = np.zeros(n_states) if initial_state is None else np.asarray(initial_state, float)
        for k in range(samples):
            x[k] = state
            state = ad @ state + drive[k]
        y = x @ self.c.T + v
        assert y.shape[1] == n_outputs
        return u, x, y

    def parameters(self, process_noise=None, measurement_noise=None, **observer) -> dict:
        """Return a parameter document (``/**: ros__parameters:``) of a Kalman filter."""
        q = self.process_noise if process_noise is None else np.asarray(process_noise)
        r = self.measurement_noise if measurement_noise is None else np.asarray(measurement_noise)
        model = {'A': _flat(self.a), 'B': _flat(self.b), 'C': _flat(self.c),
                 'state_names': list(self.state_names), 'input_names': list(self.input_names),
                 'output_names': list(self.output_names)}
        if not self.continuous:
            model['dt'] = float(self.period)
        section = {'model': model,
                   'observer': {'type': 'kalman', 'process_noise': _flat(q),
                                'measurement_noise': _flat(r), **observer}}
        if self.continuous:
            section['plant'] = {'rate_hz': 1.0 / self.period}
        return {'/**': {'ros__parameters': section}}

    def write_parameters(self, path, **kwargs) -> str:
        """Write :meth:`parameters` to ``path``; return the path as text."""
        with open(path, 'w', encoding='utf-8') as stream:
            yaml.safe_dump(self.parameters(**kwargs), stream, sort_keys=False)
        return str(path)

    def write_bag(self, path, samples: int, seed: int, storage: str = 'mcap',
                  start_ns: int = START_NS, inputs: Optional[np.ndarray] = None,
                  outputs: Optional[np.ndarray] = None) -> tuple:
        """
        Record a simulation as ``/y``, ``/u`` and ``/x_true`` JointStates; return ``(u, x, y)``.

        Each input is stamped with its sample and logged just before the measurement: it is
        held from that sample to the next, as the plant applied it.
        """
        u, x, y = self.simulate(samples, seed)
        u = u if inputs is None else inputs
        y = y if outputs is None else outputs
        period_ns = round(self.period * 1e9)
        stamps = start_ns + period_ns * np.arange(samples, dtype=np.int64)
        write_bag(path, [
            TopicToWrite('/u', 'joint_state', 'position', self.input_names, stamps,
                         stamps - 1000, u),
            TopicToWrite('/y', 'joint_state', 'position', self.output_names, stamps, stamps, y),
            TopicToWrite('/x_true', 'joint_state', 'position', self.state_names, stamps,
                         stamps + 1000, x)], storage)
        return u, x, y


def _gaussian(rng, covariance, samples: int) -> np.ndarray:
    covariance = np.atleast_2d(np.asarray(covariance, dtype=float))
    values, vectors = np.linalg.eigh(covariance)
    root = vectors * np.sqrt(np.maximum(values, 0.0))
    return rng.standard_normal((samples, len(covariance))) @ root.T


def _flat(matrix) -> list:
    return [float(value) for value in np.asarray(matrix, dtype=float).ravel()]


#: The mass-spring-damper of config/kalman_noisy.yaml (position measured) at 100 Hz: noise
#: on the velocity only (the position's process noise is known to be zero).
SPRING = NoisyPlant(
    a=np.array([[0.0, 1.0], [-4.0, -0.4]]), b=np.array([[0.0], [1.0]]),
    c=np.array([[1.0, 0.0]]), process_noise=np.diag([0.0, 0.04]),
    measurement_noise=np.array([[1e-4]]), period=0.01, continuous=True,
    state_names=('position', 'velocity'), output_names=('position',))

#: A discrete two-state plant measured by two coupled sensors, with correlated process and
#: measurement noise (full Q and R, both identifiable: as many outputs as states).
COUPLED = NoisyPlant(
    a=np.array([[0.9, 0.1], [-0.1, 0.8]]), b=np.array([[0.0], [0.1]]),
    c=np.array([[1.0, 0.5], [0.0, 1.0]]),
    process_noise=np.array([[0.02, -0.008], [-0.008, 0.03]]),
    measurement_noise=np.array([[0.01, 0.006], [0.006, 0.02]]), period=0.1, continuous=False,
    state_names=('x1', 'x2'), output_names=('s1', 's2'), input_names=('u1',))


def expected_mse(plant: NoisyPlant, process_noise, measurement_noise) -> float:
    """
    Steady-state ``E||x - x_hat[k|k]||^2`` of the Kalman filter of the given noises on ``plant``.

    The filter's gain comes from ``process_noise`` and ``measurement_noise``; the errors from
    the plant's true noises: ``P = Abar P Abar^T + Qd + L R L^T`` (prediction error,
    ``Abar = Ad - L C``), filtered ``(I - M C) P (I - M C)^T + M R M^T``.
    """
    import scipy.linalg

    from observer_ros.core.model import StateSpaceModel
    from observer_ros.core.observers.kalman.design import design_kalman
    from observer_ros.core.observers.kalman.estimator import KalmanStep
    model = StateSpaceModel.from_matrices(plant.a, plant.b, plant.c,
                                          dt=0.0 if plant.continuous else plant.period)
    design = design_kalman(model, np.asarray(process_noise).ravel().tolist(),
                           np.asarray(measurement_noise).ravel().tolist())
    step = KalmanStep(design).step(round(plant.period * 1e9))
    n_states, n_inputs = plant.b.shape
    gain = step.g[:n_states, n_states + n_inputs:]
    ad, _, qd = plant.sampled
    predictor = ad @ gain
    abar = ad - predictor @ plant.c
    r = plant.measurement_noise
    p = scipy.linalg.solve_discrete_lyapunov(abar, qd + predictor @ r @ predictor.T)
    correction = np.eye(n_states) - gain @ plant.c
    return float(np.trace(correction @ p @ correction.T + gain @ r @ gain.T))
