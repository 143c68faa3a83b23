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
Simulated recordings with known noises: the worked examples of doc/tuning.md.

``python -m observer_ros.bags.examples DIR`` writes into ``DIR`` what that page's commands
use: ``spring_run`` (the mass-spring-damper of ``config/kalman_noisy.yaml``, 300 s at
100 Hz), ``fleet/run0`` to ``run3`` (a two-output discrete plant with correlated noises),
``third_order`` (a third-order plant at 30 dB) and the parameter files ``spring_guess.yaml``
and ``coupled_guess.yaml`` (the right models with noises ten times off). The test suite
makes its recordings with the same code.
"""

import argparse
from dataclasses import dataclass
from pathlib import Path
import sys
from typing import Optional

import numpy as np
import yaml

from observer_ros.bags.writing import TopicToWrite, write_bag
from observer_ros.core.discretize import van_loan, zero_order_hold
from observer_ros.core.observers.kalman import NAME as KALMAN
from observer_ros.core.units import NANOSECONDS, seconds_to_ns

#: Start of the simulated stamps (ns): a wall-clock-like time.
START_NS = 1_700_000_000 * NANOSECONDS


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
                   'observer': {'type': KALMAN, 'process_noise': _flat(q),
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
        period_ns = seconds_to_ns(self.period)
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


#: The third-order plant of ``identify``'s example: poles -1.58 and -0.91 +- 2.34j, sampled
#: at 20 Hz, position measured at 30 dB signal-to-noise ratio.
THIRD_ORDER_A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-10.0, -9.2, -3.4]])
THIRD_ORDER_B = np.array([[0.0], [0.0], [10.0]])
THIRD_ORDER_PERIOD, THIRD_ORDER_SAMPLES, THIRD_ORDER_SNR_DB = 0.05, 20_000, 30.0


def write_third_order(path, samples: int = THIRD_ORDER_SAMPLES, seed: int = 1, inputs=None,
                      nan_at=None, feedthrough=None) -> float:
    """
    Record ``u`` (white) and ``y`` (position plus noise at 30 dB) as JointStates.

    ``feedthrough``: ``D``, ``y[k] = x1[k] + D u[k]`` with ``u[k]`` stamped with ``y[k]`` (the
    input applied at that sample); ``nan_at``: samples whose ``y`` is NaN. Returns the
    standard deviation of the noise.
    """
    ad, bd = zero_order_hold(THIRD_ORDER_A, THIRD_ORDER_B, THIRD_ORDER_PERIOD)
    rng = np.random.default_rng(seed)
    u = rng.standard_normal((samples, 1)) if inputs is None else inputs
    x, y = np.zeros(3), np.empty((samples, 1))
    for k in range(samples):
        y[k] = x[0] if feedthrough is None else x[0] + feedthrough * u[k, 0]
        x = ad @ x + bd @ u[k]
    noise = y.std() * 10 ** (-THIRD_ORDER_SNR_DB / 20)
    y += rng.standard_normal(y.shape) * noise
    if nan_at is not None:
        y[nan_at] = np.nan
    stamps = START_NS + seconds_to_ns(THIRD_ORDER_PERIOD) * np.arange(samples, dtype=np.int64)
    write_bag(path, [TopicToWrite('/u', 'joint_state', 'position', ['force'], stamps,
                                  stamps - 1000, u),
                     TopicToWrite('/y', 'joint_state', 'position', ['position'], stamps,
                                  stamps, y)])
    return noise


def write_tuning_example(folder) -> None:
    """Write the recordings and parameter files of doc/tuning.md into ``folder``."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    SPRING.write_bag(folder / 'spring_run', 30_000, seed=21)
    SPRING.write_parameters(folder / 'spring_guess.yaml', process_noise=np.diag([0.0, 0.4]),
                            measurement_noise=[[1e-5]])
    for part in range(4):
        COUPLED.write_bag(folder / 'fleet' / f'run{part}', 5000, seed=30 + part)
    COUPLED.write_parameters(folder / 'coupled_guess.yaml',
                             process_noise=COUPLED.process_noise * 10,
                             measurement_noise=COUPLED.measurement_noise / 10)
    write_third_order(folder / 'third_order', 20_000, seed=5)


def main(argv: Optional[list] = None) -> int:
    """Write the example recordings; return the exit status (2 when the folder is taken)."""
    parser = argparse.ArgumentParser(
        prog='python -m observer_ros.bags.examples',
        description='Write the simulated recordings and parameter files of the tuning '
                    'page (doc/tuning.md) into a folder.')
    parser.add_argument('folder', help='where to write them (made if missing; must not hold '
                                       'them already)')
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    folder = Path(args.folder)
    taken = [name for name in ('spring_run', 'fleet', 'third_order') if (folder / name).exists()]
    if taken:
        print(f'examples: error: {folder} already holds {", ".join(taken)}: name an empty '
              f'folder', file=sys.stderr)
        return 2
    write_tuning_example(folder)
    print(f'wrote spring_run, fleet/run0-3, third_order, spring_guess.yaml and '
          f'coupled_guess.yaml to {folder}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
