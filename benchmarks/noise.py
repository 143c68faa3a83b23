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
6. Noise: estimation error against observer pole speed, and the Kalman filter's optimum.

The noisy mass-spring-damper of ``config/kalman_noisy.yaml`` is simulated exactly (process
noise discretized with Van Loan's method, as the filter assumes) and every observer runs on
the same samples: the steady-state Kalman filter of the configuration, and Luenberger
observers (full order, reduced order, Chen) with poles at increasing speed. Fast poles
trust the noisy measurement, slow poles the model: the trade-off the course notes describe.
"""

import numpy as np

from benchmarks.common import CONFIG_DIR, pyplot, Section
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core import make_estimator
from observer_ros.core.observers.chen.design import design_chen
from observer_ros.core.observers.full_order.design import design_full_order
from observer_ros.core.observers.reduced_order.design import design_reduced_order
from observer_ros.core.simulation import PlantSimulator

BURN_IN = 1000


def simulate(system, samples: int, seed: int):
    """Stamps, outputs, inputs (row k held over (k-1, k]) and true states."""
    model, plant = system.model, system.plant
    dt = plant.period_ns / 1e9
    simulator = PlantSimulator(model, np.zeros(model.n_states), plant.process_noise,
                               plant.measurement_noise, seed)
    stamps = np.arange(samples, dtype=np.int64) * plant.period_ns
    inputs = np.zeros((samples, model.n_inputs))
    inputs[1:, 0] = np.sin(0.7 * dt * np.arange(samples - 1))
    outputs = np.empty((samples, model.n_outputs))
    truth = np.empty((samples, model.n_states))
    for k in range(samples):
        if k:
            simulator.step(inputs[k], dt)
        truth[k] = simulator.x
        outputs[k] = simulator.measure()
    return stamps, outputs, inputs, truth


def mse(estimator, stamps, outputs, inputs, truth) -> float:
    """Mean over samples (after the burn-in) of ``||x - x_hat||^2``."""
    estimates = np.array([estimator.update(int(stamp), y, u).copy()
                          for stamp, y, u in zip(stamps, outputs, inputs)])
    errors = (truth - estimates)[BURN_IN:]
    return float(np.mean(np.sum(errors ** 2, axis=1)))


#: Jitter of the time-varying filter's row: intervals of 0.5 ... 1.5 periods, from this many
#: distinct values (each sampled once by the simulator and by the filter).
JITTER_LEVELS = 41


def jittered_run(system, samples: int, seed: int) -> tuple:
    """Measured MSE and mean trace(P) of the time-varying filter on jittered stamps."""
    model, plant = system.model, system.plant
    rng = np.random.default_rng(seed)
    levels = (plant.period_ns * np.linspace(0.5, 1.5, JITTER_LEVELS)).astype(np.int64)
    steps = rng.choice(levels, size=samples - 1)
    stamps = np.concatenate([[0], np.cumsum(steps)])
    simulator = PlantSimulator(model, np.zeros(model.n_states), plant.process_noise,
                               plant.measurement_noise, seed)
    filter_ = make_estimator(system.observer.design, time_varying=True)
    errors, traces = [], []
    u = np.zeros(model.n_inputs)
    for k, stamp in enumerate(stamps.tolist()):
        if k:
            u = np.array([np.sin(0.7 * stamp / 1e9)])
            simulator.step(u, steps[k - 1] / 1e9)
        x_hat = filter_.advance(stamp, simulator.measure(), u)
        if k >= BURN_IN:
            errors.append(float(np.sum((simulator.x - x_hat) ** 2)))
            traces.append(float(np.trace(filter_.covariance)))
    return float(np.mean(errors)), float(np.mean(traces))


def run(smoke: bool, figures) -> Section:
    """Measure and return the section."""
    samples = 5_000 if smoke else 100_000
    section = Section(6, 'Noise: mean squared error against pole speed',
                      'measured Kalman MSE / trace(P) within [0.97, 1.03] over 10^5 samples, '
                      'also for the time-varying filter with jitter, and no Luenberger gain '
                      'below the Kalman MSE')
    system = validate_parameters(load_parameter_file(str(CONFIG_DIR / 'kalman_noisy.yaml')))
    data = simulate(system, samples + BURN_IN, seed=11)
    kalman = system.observer.make_estimator()
    kalman_mse = mse(kalman, *data)
    trace = float(np.trace(kalman.covariance))
    speeds = np.geomspace(1.0, 300.0, 5 if smoke else 14)
    model = system.model
    curves = {'full_order': [], 'reduced_order': [], 'chen': []}
    for speed in speeds:
        pair = [complex(-speed, 0.5 * speed), complex(-speed, -0.5 * speed)]
        designs = {'full_order': design_full_order(model, pair),
                   'reduced_order': design_reduced_order(model, [-speed]),
                   'chen': design_chen(model, [-speed])}
        for kind, design in designs.items():
            curves[kind].append(mse(make_estimator(design), *data))
    best = {kind: min(values) for kind, values in curves.items()}
    section.add(f'{samples:,} samples at {system.plant.rate_hz:g} Hz after a burn-in of '
                f'{BURN_IN}; full-order poles -s(1 +- 0.5j), reduced-order and Chen pole -s, '
                f's from {speeds[0]:g} to {speeds[-1]:g} rad/s. MSE = mean of '
                '||x - x_hat||^2.', '')
    rows = [[f'{speed:.3g}', *(f'{curves[kind][i]:.4e}' for kind in curves)]
            for i, speed in enumerate(speeds)]
    section.table(['pole speed s (rad/s)', 'full order MSE', 'reduced order MSE', 'Chen MSE'],
                  rows)
    measured_ratio = kalman_mse / trace
    section.add(f'Steady-state Kalman filter: measured MSE {kalman_mse:.4e}, trace(P) '
                f'{trace:.4e}, ratio **{measured_ratio:.4f}**. Best Luenberger MSE: ' +
                ', '.join(f'{kind} {value:.4e} ({value / kalman_mse:.3f}x Kalman)'
                          for kind, value in best.items()) + '.', '')
    jitter_mse, jitter_trace = jittered_run(system, samples + BURN_IN, seed=13)
    jitter_ratio = jitter_mse / jitter_trace
    section.add(f'Time-varying Kalman filter on jittered stamps (intervals 0.5 ... 1.5 periods, '
                f'{JITTER_LEVELS} distinct values, the plant simulated exactly over each): '
                f'measured MSE {jitter_mse:.4e}, mean trace(P) {jitter_trace:.4e}, ratio '
                f'**{jitter_ratio:.4f}**.', '')
    section.met = (0.97 <= measured_ratio <= 1.03 and min(best.values()) >= kalman_mse
                   and 0.97 <= jitter_ratio <= 1.03 and not smoke)
    if smoke:
        section.add('(Smoke run: too few samples to judge the goal.)', '')
    plt = pyplot()
    figure, axis = plt.subplots(figsize=(7, 4))
    for kind, values in curves.items():
        axis.loglog(speeds, values, 'o-', label=f'{kind} observer')
    axis.axhline(kalman_mse, color='k', label='Kalman, measured MSE')
    axis.axhline(trace, color='k', linestyle='--', label='Kalman, trace(P)')
    axis.set_xlabel('observer pole speed s (rad/s)')
    axis.set_ylabel('mean squared error')
    axis.legend(fontsize=8)
    section.figures.append(figures.save(figure, 'noise_mse'))
    return section
