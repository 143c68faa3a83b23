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
The extended and unscented Kalman filters in the event engine, against references.

- The EKF run by the event stream on the differential-drive base with three sources (wheel
  speeds at 100 Hz, the gyro's yaw rate at 50 Hz, a camera pose at 10 Hz arriving 150 ms
  late, two of its samples out of order) equals, to 1e-9 relative, an EKF written here in
  plain numpy (the Jacobians by hand, the same RK4) run on the samples in stamp order.
- A linear model written as expressions gives the linear time-varying Kalman filter's
  estimates and covariances to 1e-9.
- Predictions between samples, updates with no output, angles wrapped, steps that are not
  finite dropped and counted (never returned as NaN).
"""

import math

import numpy as np
import pytest

from observer_ros.core.angles import wrap_angles
from observer_ros.core.errors import ConfigError, StampError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.nonlinear import (
    differential_drive, ExtendedKalman, linear_as_expressions, NonlinearModel,
    UnscentedKalman)
from observer_ros.core.observers.kalman.time_varying import TimeVaryingKalman
from observer_ros.core.sources import MeasurementSource
from observer_ros.core.streaming import EventStream

MS = 1_000_000
SECOND_NS = 1_000_000_000
RADIUS, TRACK = 0.05, 0.3
Q = np.diag([0.0, 0.0, 0.0, 0.2, 0.3])  # intensities: accelerations the inputs miss
R = np.diag([0.2 ** 2, 0.2 ** 2, 0.01 ** 2, 0.05 ** 2, 0.05 ** 2, 0.02 ** 2])
P0 = np.diag([0.1 ** 2, 0.1 ** 2, 0.05 ** 2, 0.1 ** 2, 0.05 ** 2])
X0 = np.array([0.0, 0.0, 3.0, 1.0, 0.4])  # heading near pi: it crosses it
SOURCES = (MeasurementSource('wheels', (0, 1)), MeasurementSource('gyro', (2,)),
           MeasurementSource('camera', (3, 4, 5)))
STEP = 0.001


# --- the reference: plain numpy, the Jacobians by hand --------------------------------------

def f_ref(x, u):
    return np.array([x[3] * math.cos(x[2]), x[3] * math.sin(x[2]), x[4], u[0], u[1]])


def jacobian_ref(x):
    a = np.zeros((5, 5))
    a[0, 2], a[0, 3] = -x[3] * math.sin(x[2]), math.cos(x[2])
    a[1, 2], a[1, 3] = x[3] * math.cos(x[2]), math.sin(x[2])
    a[2, 4] = 1.0
    return a


def h_ref(x):
    return np.array([(x[3] - x[4] * TRACK / 2) / RADIUS, (x[3] + x[4] * TRACK / 2) / RADIUS,
                     x[4], x[0], x[1], x[2]])


H_REF = np.zeros((6, 5))
H_REF[0, 3:] = [1 / RADIUS, -TRACK / 2 / RADIUS]
H_REF[1, 3:] = [1 / RADIUS, TRACK / 2 / RADIUS]
H_REF[2, 4] = H_REF[3, 0] = H_REF[4, 1] = H_REF[5, 2] = 1.0


def predict_ref(x, p, seconds, u, q=Q, step=STEP):
    count = max(1, math.ceil(seconds / step - 1e-9))
    h = seconds / count

    def derivative(x, p):
        a = jacobian_ref(x)
        return f_ref(x, u), a @ p + p @ a.T + q

    for _ in range(count):
        k1 = derivative(x, p)
        k2 = derivative(x + h / 2 * k1[0], p + h / 2 * k1[1])
        k3 = derivative(x + h / 2 * k2[0], p + h / 2 * k2[1])
        k4 = derivative(x + h * k3[0], p + h * k3[1])
        x = x + h / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        p = p + h / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
    x = x.copy()
    x[2] = wrap_angles(x[2])
    return x, p


def update_ref(x, p, y, rows):
    h, r = H_REF[rows], R[np.ix_(rows, rows)]
    v = y - h_ref(x)[rows]
    if 5 in rows:
        v[rows.index(5)] = wrap_angles(v[rows.index(5)])
    s = h @ p @ h.T + r
    k = p @ h.T @ np.linalg.inv(s)
    i_kh = np.eye(5) - k @ h
    x = x + k @ v
    x[2] = wrap_angles(x[2])
    return x, i_kh @ p @ i_kh.T + k @ r @ k.T


# --- a recording -------------------------------------------------------------------------

def recording(seed=3, seconds=1.5):
    """Return inputs every 10 ms, wheels every 10 ms, gyro every 20 ms (+5), camera 100 ms (+3)."""
    rng = np.random.default_rng(seed)
    inputs = [(k * 10 * MS, rng.normal(0.0, [0.5, 0.5])) for k in range(int(seconds * 100))]
    truth, samples = X0.copy(), []
    events = sorted([(k * 10 * MS, 'wheels') for k in range(int(seconds * 100))]
                    + [(k * 20 * MS + 5 * MS, 'gyro') for k in range(int(seconds * 50))]
                    + [(k * 100 * MS + 3 * MS, 'camera') for k in range(int(seconds * 10))])
    previous = 0
    for stamp, source in events:
        u = [v for s, v in inputs if s <= previous][-1]
        truth, _ = predict_ref(truth, np.zeros((5, 5)), (stamp - previous) / SECOND_NS, u,
                               q=np.zeros((5, 5)))
        previous = stamp
        rows = list(SOURCES[['wheels', 'gyro', 'camera'].index(source)].outputs)
        y = h_ref(truth)[rows] + rng.normal(0.0, np.sqrt(np.diag(R)[rows]))
        if source == 'camera':
            y[2] = wrap_angles(y[2])
        samples.append((stamp, source, y))
    return inputs, samples


def reference(inputs, samples):
    """Run the reference EKF in stamp order; return ``{stamp: (x, P)}``."""
    x, p, previous, states = X0.copy(), P0.copy(), None, {}
    for stamp, source, y in sorted(samples, key=lambda s: s[0]):
        if previous is not None:
            u = [v for s, v in inputs if s <= previous][-1]
            x, p = predict_ref(x, p, (stamp - previous) / SECOND_NS, u)
        x, p = update_ref(x, p, y, list(SOURCES[['wheels', 'gyro', 'camera'].index(
            source)].outputs))
        states[stamp], previous = (x, p), stamp
    return states


def arrival_order(samples, late_ns=150 * MS):
    """Return the samples as they arrive: the camera late_ns late, 503 ms after 603 ms."""
    arrivals = [(stamp + (late_ns if source == 'camera' else 0), k, stamp, source, y)
                for k, (stamp, source, y) in enumerate(samples)]
    arrivals.sort(key=lambda a: (a[0], a[1]))
    order = [a[2:] for a in arrivals]
    first = next(k for k, a in enumerate(order) if a[:2] == (503 * MS, 'camera'))
    second = next(k for k, a in enumerate(order) if a[:2] == (603 * MS, 'camera'))
    order.insert(second, order.pop(first))  # 503 now arrives just after 603
    return order


def make_stream(estimator):
    return EventStream(estimator, SECOND_NS, sources=SOURCES, history_ns=500 * MS,
                       output_names=estimator.model.output_names)


def relative_error(a, b):
    """Return the largest difference relative to the largest entry of ``b``."""
    return float(np.max(np.abs(np.asarray(a) - b)) / np.max(np.abs(b)))


def test_the_ekf_in_the_event_stream_equals_a_numpy_reference_with_a_late_camera():
    inputs, samples = recording()
    order = arrival_order(samples)
    assert [a[0] for a in order] != sorted(a[0] for a in order)  # late and out of order
    stream = make_stream(ExtendedKalman(differential_drive(RADIUS, TRACK), Q, R, P0, X0,
                                        max_step=STEP))
    for stamp, u in inputs:
        stream.add_input(stamp, u)
    published = []
    for stamp, source, y in order:
        published += stream.add_measurement(stamp, list(y), source=source)
    stream.flush()
    assert stream.counters['reruns'] >= 15 and not stream.counters['too_old']
    expected = reference(inputs, samples)
    history = stream.history()
    assert len(history) >= 40
    for sample in history:
        x, p = expected[sample.stamp_ns]
        assert relative_error(sample.estimate, x) < 1e-9
        assert relative_error(sample.covariance, p) < 1e-9
    newest = max(expected)
    assert history[-1].stamp_ns == newest
    estimator = stream.estimator
    assert relative_error(estimator.estimate, expected[newest][0]) < 1e-9
    assert relative_error(estimator.covariance, expected[newest][1]) < 1e-9
    # the heading crossed pi and stayed in (-pi, pi]
    headings = [s.estimate[2] for s in published]
    assert max(headings) > 3.0 and min(headings) < -3.0
    assert all(-math.pi < value <= math.pi for value in headings)
    assert all(np.isfinite(s.estimate).all() for s in published)
    # a prediction between samples: the reference carried on from the newest state
    u = inputs[-1][1]
    prediction = stream.predict(newest + 7 * MS)
    x, p = predict_ref(*expected[newest], 0.007, u)
    assert relative_error(prediction.estimate, x) < 1e-9
    assert relative_error(prediction.covariance, p) < 1e-9


def test_an_update_with_no_output_is_the_prediction():
    ekf = ExtendedKalman(differential_drive(RADIUS, TRACK), Q, R, P0, X0)
    ekf.advance_outputs(0, np.zeros(0), np.zeros(2), ())
    u = np.array([0.3, -0.2])
    predicted = ekf.predict(20 * MS, u)
    ekf.advance_outputs(20 * MS, np.zeros(0), u, ())
    assert ekf.estimate.tolist() == predicted.estimate.tolist()
    assert ekf.covariance.tolist() == predicted.covariance.tolist()
    assert ekf.innovation.size == 0 and ekf.nis == 0.0
    with pytest.raises(StampError, match='is not after the previous sample'):
        ekf.advance_outputs(20 * MS, np.zeros(0), u, ())


@pytest.mark.parametrize('discrete', [False, True])
def test_a_linear_model_as_expressions_equals_the_time_varying_kalman_filter(discrete):
    a = [[0.0, 1.0, 0.0], [-4.0, -0.4, 1.0], [0.0, 0.0, -0.5]]
    b = [[0.0], [1.0], [0.3]]
    c = [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]]
    model = StateSpaceModel.from_matrices(a, b, c)
    if discrete:
        model = StateSpaceModel.from_matrices(np.eye(3) + 0.01 * np.array(a),
                                              0.01 * np.array(b), c, dt=0.01)
    q, r = np.diag([0.0, 0.5, 0.1]), np.diag([0.01, 0.04])
    p0, x0 = np.diag([1.0, 2.0, 0.5]), np.array([0.5, 0.0, -0.2])
    linear = TimeVaryingKalman(model, q, r, p0, x0)
    equations = linear_as_expressions(model)
    filters = [ExtendedKalman(equations, q, r, p0, x0),  # max_step 1 ms: 6e-11 apart
               UnscentedKalman(equations, q, r, p0, x0)]
    rng = np.random.default_rng(7)
    stamp = 0
    for k in range(300):
        stamp += (10 if discrete else int(rng.integers(1, 25))) * MS
        u, y = rng.normal(size=1), rng.normal(size=2)
        outputs = [(0, 1), (0,), (1,), ()][k % 4]
        expected = linear.advance_outputs(stamp, y[list(outputs)], u, outputs)
        for estimator in filters:
            got = estimator.advance_outputs(stamp, y[list(outputs)], u, outputs)
            assert relative_error(got, expected) < 1e-9, (type(estimator).__name__, k)
            assert relative_error(estimator.covariance, linear.covariance) < 1e-9
            if outputs:
                assert relative_error(estimator.innovation_covariance,
                                      linear.innovation_covariance) < 1e-9
                assert estimator.nis == pytest.approx(linear.nis, rel=1e-8)


def test_a_step_that_is_not_finite_is_dropped_and_counted_never_returned():
    # sqrt(x) leaves its domain when x crosses 0: the prediction is NaN there
    model = NonlinearModel(['x', 'v'], {'x': 'v', 'v': '0'}, {'y': 'sqrt(x)'})
    for kind in (ExtendedKalman, UnscentedKalman):
        estimator = kind(model, [0.0, 0.01], [0.01], [0.01, 0.01], [1.0, -1.0],
                         max_step=0.05)
        stream = EventStream(estimator, SECOND_NS)
        published = []
        for k in range(40):
            published += stream.add_input(k * 100 * MS, [])
            published += stream.add_measurement(k * 100 * MS, [max(0.0, 1 - 0.1 * k) ** 0.5])
        stream.flush()
        assert published and all(np.isfinite(s.estimate).all() for s in published)
        assert all(s.covariance is None or np.isfinite(s.covariance).all() for s in published)
        assert estimator.counters['nonfinite'] > 0, kind.__name__
        assert estimator.events[-1][0] == 'nonfinite'
        assert 'was not finite and was dropped' in estimator.events[-1][1]
        assert np.isfinite(estimator.estimate).all()
        assert np.isfinite(estimator.predict(10 * SECOND_NS, np.zeros(0)).estimate).all()


def test_the_filters_are_estimators_the_stream_can_restore():
    ekf = ExtendedKalman(differential_drive(RADIUS, TRACK), Q, R, P0, X0)
    ekf.update(0, h_ref(X0), [0.0, 0.0])
    state = ekf.snapshot()
    before = (ekf.estimate, ekf.covariance.copy())
    ekf.advance_outputs(10 * MS, np.array([0.4]), np.zeros(2), (2,))
    ekf.restore(state)
    assert ekf.estimate.tolist() == before[0].tolist()
    assert ekf.covariance.tolist() == before[1].tolist() and ekf.stamp_ns == 0
    ekf.restart()
    assert ekf.stamp_ns is None
    ekf.reset()
    assert ekf.estimate.tolist() == X0.tolist()


@pytest.mark.parametrize('arguments, parameter, what', [
    ({'process_noise': [1.0, 2.0]}, 'process_noise', ''),
    ({'measurement_noise': [1.0] * 5 + [0.0]}, 'measurement_noise', 'positive definite'),
    ({'initial_covariance': [1.0] * 4 + [-1.0]}, 'initial_covariance', ''),
    ({'initial_state': [0.0] * 4}, 'initial_state', 'expected 5 finite values'),
    ({'max_step': 0.0}, 'max_step', 'expected a step > 0 s'),
    ({'model': 'x'}, 'model', 'expected a NonlinearModel'),
    ({'alpha': 2.0}, 'alpha', 'expected 0 < alpha <= 1'),
    ({'kappa': -5.0}, 'kappa', 'expected alpha^2 (n + kappa) > 0'),
])
def test_bad_arguments_are_refused_naming_them(arguments, parameter, what):
    given = {'model': differential_drive(), 'process_noise': Q, 'measurement_noise': R}
    given.update(arguments)
    kinds = ((UnscentedKalman,) if parameter in ('alpha', 'kappa')
             else (ExtendedKalman, UnscentedKalman))
    for kind in kinds:
        with pytest.raises(ConfigError) as caught:
            kind(**given)
        assert caught.value.parameter == parameter and what in caught.value.reason


@pytest.mark.parametrize('kind', [ExtendedKalman, UnscentedKalman])
def test_late_and_out_of_order_samples_give_what_stamp_order_gives_bit_for_bit(kind):
    inputs, samples = recording(seconds=0.8)
    histories = []
    for order in (arrival_order(samples), sorted(samples, key=lambda s: s[0])):
        stream = make_stream(kind(differential_drive(RADIUS, TRACK), Q, R, P0, X0,
                                  max_step=0.005))
        for stamp, u in inputs:
            stream.add_input(stamp, u)
        for stamp, source, y in order:
            stream.add_measurement(stamp, list(y), source=source)
        histories.append([(s.stamp_ns, s.estimate.tobytes(), s.covariance.tobytes())
                          for s in stream.history()])
    assert len(histories[0]) >= 40 and histories[0] == histories[1]
