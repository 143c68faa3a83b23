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

"""The tuning tests' simulated recordings (:mod:`observer_ros.bags.examples`) and expectations."""

import numpy as np

from observer_ros.bags.examples import (  # noqa: F401 - the tests' names for them
    COUPLED, NoisyPlant, SPRING, START_NS)


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
