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
10. Nonlinear filters: cost per update against filterpy, and in real time with a late camera.

The differential-drive base of :func:`observer_ros.core.nonlinear.differential_drive`
(5 states, 2 inputs). First the cost of one predict-and-update with the two wheel speeds at
1 kHz, against filterpy's ``ExtendedKalmanFilter`` and ``UnscentedKalmanFilter`` given the
same model: the same RK4 step of the mean, the Jacobians written by hand in numpy for
filterpy's EKF (its covariance step ``F P F^T + Q dt`` with ``F = I + A dt``; ours integrates
the Riccati equation), the same sigma points (Van der Merwe, alpha 1, beta 2, kappa 0) for
its UKF. Then the event stream with the wheels at 1 kHz, the gyro at 1 kHz and a camera pose
at 30 Hz arriving 50 ms late, history 0.5 s: the real-time factor. Then the two libraries
that derive Jacobians, SymPy (the one used) and CasADi (when installed): cost per call of
``f``, ``F``, ``h``, ``H`` from Python and import time. The EKF is measured with both
covariance predictions: ``rk4`` (the default, four Jacobians a step) and ``midpoint`` (one
Jacobian a step, second order; :mod:`observer_ros.core.nonlinear.ekf`).
``python -m benchmarks.nonlinear`` prints the section alone.
"""

from functools import partial
import math
import os
import subprocess
import sys
import time

import numpy as np

from benchmarks.common import per_call, Section
from observer_ros.core.nonlinear import differential_drive, ExtendedKalman, UnscentedKalman
from observer_ros.core.sources import MeasurementSource
from observer_ros.core.streaming import EventStream

MS = 1_000_000
SECOND = 1_000_000_000
RADIUS, TRACK = 0.05, 0.3
Q = np.diag([1e-6, 1e-6, 1e-6, 0.2, 0.3])
R = np.diag([0.2 ** 2, 0.2 ** 2, 0.01 ** 2, 0.05 ** 2, 0.05 ** 2, 0.02 ** 2])
P0 = np.diag([0.1 ** 2, 0.1 ** 2, 0.05 ** 2, 0.1 ** 2, 0.05 ** 2])
X0 = np.array([0.0, 0.0, 0.3, 1.0, 0.4])
#: The EKF with one Jacobian a step (``covariance_prediction='midpoint'``).
MIDPOINT_EKF = partial(ExtendedKalman, covariance_prediction='midpoint')
#: The filterpy filter each of ours is compared with.
FILTERPY = {'EKF': 'filterpy EKF', 'EKF midpoint': 'filterpy EKF', 'UKF': 'filterpy UKF'}
SOURCES = (MeasurementSource('wheels', (0, 1)), MeasurementSource('gyro', (2,)),
           MeasurementSource('camera', (3, 4, 5)))


def f_numpy(x, u):
    """Return the dynamics of the base, written in numpy (filterpy's model)."""
    return np.array([x[3] * math.cos(x[2]), x[3] * math.sin(x[2]), x[4], u[0], u[1]])


def rk4_numpy(x, dt, u):
    """Return one RK4 step of :func:`f_numpy`."""
    k1 = f_numpy(x, u)
    k2 = f_numpy(x + dt / 2 * k1, u)
    k3 = f_numpy(x + dt / 2 * k2, u)
    k4 = f_numpy(x + dt * k3, u)
    return x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)


def wheels_numpy(x):
    """Return the two wheel speeds."""
    return np.array([(x[3] - x[4] * TRACK / 2) / RADIUS, (x[3] + x[4] * TRACK / 2) / RADIUS])


WHEELS_JACOBIAN = np.array([[0, 0, 0, 1 / RADIUS, -TRACK / 2 / RADIUS],
                            [0, 0, 0, 1 / RADIUS, TRACK / 2 / RADIUS]])


def filterpy_ekf(dt):
    """Return a step of filterpy's EKF on the base: RK4 mean, ``F = I + A dt``."""
    from filterpy.kalman import ExtendedKalmanFilter
    ekf = ExtendedKalmanFilter(dim_x=5, dim_z=2)
    ekf.x, ekf.P, ekf.Q, ekf.R = X0.copy(), P0.copy(), Q * dt, R[:2, :2].copy()
    u = np.array([0.1, 0.05])

    def step(z):
        x = ekf.x
        a = np.zeros((5, 5))
        a[0, 2], a[0, 3] = -x[3] * math.sin(x[2]), math.cos(x[2])
        a[1, 2], a[1, 3] = x[3] * math.cos(x[2]), math.sin(x[2])
        a[2, 4] = 1.0
        ekf.F = np.eye(5) + a * dt
        ekf.predict_x = lambda u=0: setattr(ekf, 'x', rk4_numpy(ekf.x, dt, u))
        ekf.predict(u)
        ekf.update(z, lambda x: WHEELS_JACOBIAN, wheels_numpy)
    return step


def filterpy_ukf(dt):
    """Return a step of filterpy's UKF on the base: RK4 for each sigma point."""
    from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
    points = MerweScaledSigmaPoints(5, alpha=1.0, beta=2.0, kappa=0.0)
    u = np.array([0.1, 0.05])
    ukf = UnscentedKalmanFilter(dim_x=5, dim_z=2, dt=dt, hx=wheels_numpy,
                                fx=lambda x, dt: rk4_numpy(x, dt, u), points=points)
    ukf.x, ukf.P, ukf.Q, ukf.R = X0.copy(), P0.copy(), Q * dt, R[:2, :2].copy()

    def step(z):
        ukf.predict()
        ukf.update(z)
    return step


def ours(kind, dt):
    """Return a step of our filter: predict over ``dt`` and update with the wheels."""
    estimator = kind(differential_drive(RADIUS, TRACK), Q, R, P0, X0, max_step=dt)
    u = np.array([0.1, 0.05])
    stamp = [0]
    estimator.advance_outputs(0, np.array([20.0, 20.0]), u, (0, 1))

    def step(z):
        stamp[0] += int(dt * SECOND)
        estimator.advance_outputs(stamp[0], z, u, (0, 1))
    return step


def per_update(step, repeat) -> float:
    """Return the seconds of one step (best of 3 rounds of ``repeat``)."""
    z = np.array([20.0, 21.0])
    return per_call(lambda: step(z), repeat)


def late_camera(kind, seconds: float) -> tuple:
    """Feed 1 kHz wheels and gyro and a 30 Hz camera 50 ms late; return (factor, counters)."""
    rng = np.random.default_rng(10)
    events = []
    for k in range(int(seconds * 1000)):
        stamp = SECOND + k * MS
        events.append((stamp, 0, stamp, rng.normal(0.0, 0.1, 2), 'u'))
        events.append((stamp + 1, 1, stamp, 20.0 + rng.normal(0.0, 0.2, 2), 'wheels'))
        events.append((stamp + 2, 1, stamp + MS // 2, rng.normal(0.4, 0.01, 1), 'gyro'))
    for j in range(int(seconds * 30)):
        stamp = SECOND + j * 33_333_333
        events.append((stamp + 50 * MS, 1, stamp, np.array([j / 30, 0.0, 0.3]), 'camera'))
    events.sort(key=lambda event: event[0])
    estimator = kind(differential_drive(RADIUS, TRACK), Q, R, P0, X0)
    stream = EventStream(estimator, SECOND, sources=SOURCES, history_ns=500 * MS,
                         output_names=estimator.model.output_names)
    started = time.perf_counter()
    for _, role, stamp, values, source in events:
        if role == 0:
            stream.add_input(stamp, values)
        else:
            stream.add_measurement(stamp, values, source=source)
    return (time.perf_counter() - started) / seconds, stream.counters


def library_costs(repeat: int) -> list:
    """Return rows ``[library, f, F, h, H, import]`` for SymPy and (installed) CasADi."""
    x, u = np.array([1.0, 2.0, 0.3, 1.5, 0.2]), np.array([0.1, 0.05])
    model = differential_drive(RADIUS, TRACK, camera=False)
    wheels = model.measurement((0, 1))
    rows = [['SymPy (lambdify, cse)',
             *(f'{per_call(call, repeat) * 1e6:.1f} us' for call in (
                 lambda: model.f(x, u), lambda: model.jacobian(x, u),
                 lambda: wheels.values(x, u), lambda: wheels(x, u)))]]
    try:
        import casadi as ca
    except ImportError:
        rows[0].append(import_time('sympy'))
        return rows
    xs, us = ca.SX.sym('x', 5), ca.SX.sym('u', 2)
    f = ca.vertcat(xs[3] * ca.cos(xs[2]), xs[3] * ca.sin(xs[2]), xs[4], us[0], us[1])
    h = ca.vertcat((xs[3] - xs[4] * TRACK / 2) / RADIUS, (xs[3] + xs[4] * TRACK / 2) / RADIUS)
    functions = [ca.Function(name, [xs, us], [e]) for name, e in (
        ('f', f), ('F', ca.jacobian(f, xs)), ('h', h), ('H', ca.jacobian(h, xs)))]
    rows[0].append(import_time('sympy'))
    rows.append(['CasADi (Function, jacobian; DM to numpy)',
                 *(f'{per_call(lambda g=g: np.asarray(g(x, u)), repeat) * 1e6:.1f} us'
                   for g in functions), import_time('casadi')])
    return rows


def import_time(module: str) -> str:
    """Return the import time of ``module`` in a fresh interpreter (best of 3)."""
    code = (f'import time; t = time.perf_counter(); import {module}; '
            f'print(time.perf_counter() - t)')
    best = min(float(subprocess.run([sys.executable, '-c', code], capture_output=True,
                                    text=True, check=True).stdout) for _ in range(3))
    return f'{best * 1e3:.0f} ms'


def run(smoke: bool, figures=None) -> Section:
    """Measure and return the section."""
    repeat = 20 if smoke else 1000
    seconds = 0.1 if smoke else 2.0
    load = os.getloadavg()[0]
    section = Section(10, 'Nonlinear filters (EKF, UKF)',
                      'the EKF costs no more per update than the EKF of filterpy, and a 30 Hz '
                      'camera '
                      '50 ms late with 1 kHz wheels and gyro keeps up in real time on one core')
    dt = 0.001
    costs = {name: per_update(make(dt), repeat) for name, make in (
        ('EKF', lambda dt: ours(ExtendedKalman, dt)), ('filterpy EKF', filterpy_ekf),
        ('EKF midpoint', lambda dt: ours(MIDPOINT_EKF, dt)),
        ('UKF', lambda dt: ours(UnscentedKalman, dt)), ('filterpy UKF', filterpy_ukf))}
    section.add(f'Differential-drive base (n = 5), predict over 1 ms (one RK4 step) and '
                f'update with the two wheel speeds; best of 3 rounds of {repeat}. Load '
                f'average at the start: {load:.2f} on {os.cpu_count()} CPUs.', '')
    section.table(['filter', 'observer_ros', 'filterpy', 'ratio (ours / filterpy)'], [
        [kind, f'{costs[kind] * 1e6:.0f} us', f'{costs[FILTERPY[kind]] * 1e6:.0f} us',
         f'**{costs[kind] / costs[FILTERPY[kind]]:.2f}**'] for kind in FILTERPY])
    rows, factors = [], {}
    for name, kind in (('ExtendedKalman', ExtendedKalman),
                       ('ExtendedKalman (midpoint)', MIDPOINT_EKF),
                       ('UnscentedKalman', UnscentedKalman)):
        factor, counters = late_camera(kind, seconds)
        factors[name] = factor
        rows.append([name, f'{counters["reruns"]}',
                     f'{counters["rerun_rows"] / max(1, counters["reruns"]):.0f}',
                     f'**{factor:.2f}**'])
    section.add('', f'The event stream, {seconds:g} s of messages: wheels and gyro at 1 kHz, a '
                f'camera pose at 30 Hz arriving 50 ms late, history 0.5 s, max_step 1 ms. '
                f'Real-time factor: seconds of computation per second of messages (below 1 '
                f'keeps up on one core).', '')
    section.table(['filter', 're-runs', 'rows per re-run', 'real-time factor'], rows)
    section.add('', 'Deriving the Jacobians: the cost per call from Python of the generated '
                'functions of the base (f, F = df/dx, h and H of the wheels) and the import '
                'time (paid once, when a model is built).', '')
    section.table(['library', 'f', 'F', 'h', 'H', 'import'], library_costs(repeat))
    section.met = (costs['EKF'] <= costs['filterpy EKF']
                   and factors['ExtendedKalman'] < 1.0)
    return section


if __name__ == '__main__':
    print(run('--smoke' in sys.argv).markdown())
