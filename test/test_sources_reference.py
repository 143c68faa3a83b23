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
Two sources at their own rates, one of them late and out of order, against references.

An encoder-like source at 1 kHz (velocity) and a camera-like source at 30 Hz (position)
whose samples arrive 50 ms late, some of them out of order, one stamped before the first
encoder sample and some stamped equal to an encoder sample. The stream is fed in arrival
order, as a node receives them. Independent references written here in plain numpy/scipy
(the package's filters are not used) process every measurement in true stamp order, the
samples of one stamp in one update: the time-varying Kalman filter, the steady-state
Kalman filter with one Riccati solution per subset of outputs and interval, the
full-order observer with one gain per subset placed by Ackermann's formula. The estimates
(and covariances) must agree to 1e-9 relative, or to what the problem's conditioning allows
where that is more (:func:`allowed_error`): at every stamp of the history at the end, and
for the estimates the stream returned along the way, each against the reference run on the
measurements that had arrived when it was returned.
"""

import math

import numpy as np
import pytest
import scipy.linalg

from observer_ros.core import design_full_order, design_kalman, make_estimator, StateSpaceModel
from observer_ros.core.sources import MeasurementSource
from observer_ros.core.streaming import EventStream, RecordedEvent

RTOL = 1e-9
#: The reference's own move under a relative perturbation of one unit roundoff of ``A``
#: measures the problem's conditioning: the package and the reference, each backward
#: stable, may differ by a small multiple of it (golden_support.MARGIN, the same rule as
#: the goldens' tolerances). The steady-state filter's Riccati equations with a singular
#: process noise are ill conditioned: its estimates move by about 2e-8 for one ulp of A.
MARGIN = 32
PERTURBATIONS = 3
START_NS = 1_000_000_000
FAST_NS = 1_000_000  # 1 kHz
SLOW_NS = 33_300_000  # 30 Hz, off the encoder's grid by multiples of 0.1 ms
LATE_NS = 50_000_000
COUNT = 500  # encoder samples: half a second
HISTORY_NS = 2_000_000_000  # the whole run, so that every stamp can be compared at the end

A = [[0.0, 1.0], [-4.0, -0.4]]  # a mass on a spring: either output alone sees both states
B = [[0.0], [1.0]]
C = [[1.0, 0.0], [0.0, 1.0]]  # y1 position (camera), y2 velocity (encoder)
Q = [0.0, 2.0]
R = np.array([[4e-4, 1e-4], [1e-4, 1e-4]])  # correlated: a fused update differs
POLES = [-20.0, -25.0]
SOURCES = (MeasurementSource('encoder', (1,)), MeasurementSource('camera', (0,)))


def scenario(seed: int, equal_stamps: bool) -> tuple:
    """Return ``(events in arrival order, inputs {stamp: u})``."""
    rng = np.random.default_rng(seed)
    events, inputs = [], {}
    for k in range(COUNT):
        stamp = START_NS + k * FAST_NS
        u = [math.sin(2 * math.pi * 3 * k * FAST_NS / 1e9)]
        inputs[stamp] = u
        velocity = math.cos(k / 80) + 0.01 * rng.standard_normal()
        events.append(RecordedEvent('u', stamp, np.array(u), stamp + 20_000))
        events.append(RecordedEvent('encoder', stamp, np.array([velocity]), stamp + 50_000))
    slow_stamps = [START_NS - 9_950_000 + j * SLOW_NS
                   for j in range((COUNT * FAST_NS + 10_000_000) // SLOW_NS)]
    if equal_stamps:  # every third one on an encoder stamp: one fused update there
        slow_stamps = [s - (s - START_NS) % FAST_NS if j % 3 == 2 else s
                       for j, s in enumerate(slow_stamps)]
    arrivals = [s + LATE_NS + int(rng.integers(0, 5_000_000)) for s in slow_stamps]
    for j in (3, 7, 11):  # out of order: the later sample arrives first
        arrivals[j], arrivals[j + 1] = arrivals[j + 1], arrivals[j]
    for stamp, arrival in zip(slow_stamps, arrivals):
        position = math.sin(stamp / 8e10) + 0.02 * rng.standard_normal()
        events.append(RecordedEvent('camera', stamp, np.array([position]), arrival))
    events.sort(key=lambda event: event.arrival_ns)
    return events, inputs


# --- the references: plain numpy and scipy, every measurement in stamp order ----------------


def sampled(dt: float, a=None) -> tuple:
    """``(Ad, Bd, Qd)`` over ``dt`` s: zero-order hold and Van Loan's integral, by expm."""
    a, b = np.array(A if a is None else a), np.array(B)
    n, m = b.shape
    block = np.zeros((n + m, n + m))
    block[:n, :n], block[:n, n:] = a, b
    hold = scipy.linalg.expm(block * dt)
    loan = np.zeros((2 * n, 2 * n))
    loan[:n, :n], loan[:n, n:], loan[n:, n:] = -a, np.diag(Q), a.T
    van = scipy.linalg.expm(loan * dt)
    ad = van[n:, n:].T
    return hold[:n, :n], hold[:n, n:], ad @ van[:n, n:]


def grouped(measurements) -> list:
    """``[(stamp, outputs, y)]`` in stamp order, the samples of one stamp together."""
    by_stamp: dict = {}
    for stamp, output, value in measurements:
        by_stamp.setdefault(stamp, {})[output] = value
    rows = []
    for stamp in sorted(by_stamp):
        outputs = sorted(by_stamp[stamp])
        rows.append((stamp, outputs, np.array([by_stamp[stamp][k] for k in outputs])))
    return rows


def held(inputs: dict, stamp: int) -> np.ndarray:
    """Return the latest input stamped at or before ``stamp`` (zero before the first)."""
    earlier = [s for s in inputs if s <= stamp]
    return np.array(inputs[max(earlier)]) if earlier else np.zeros(1)


def reference(kind: str, measurements, inputs: dict, a=None) -> dict:
    """
    ``{stamp: (x, P or None)}`` of a filter run on ``measurements`` in stamp order.

    ``a``: the plant's ``A`` (default :data:`A`). The sampled model and the Riccati solution
    of each interval and set of outputs are computed once (the intervals repeat).
    """
    c_all = np.array(C)
    x, p = np.zeros(2), np.eye(2)
    previous, out = None, {}
    models, riccati = {}, {}
    for stamp, outputs, y in grouped(measurements):
        c, r = c_all[outputs], R[np.ix_(outputs, outputs)]
        if previous is None:
            if kind == 'time_varying':  # the first sample updates the prior (x0, P0)
                gain = p @ c.T @ np.linalg.inv(c @ p @ c.T + r)
                joseph = np.eye(2) - gain @ c
                x, p = x + gain @ (y - c @ x), joseph @ p @ joseph.T + gain @ r @ gain.T
            out[stamp] = (x.copy(), p.copy() if kind == 'time_varying' else None)
            previous = stamp
            continue
        dt = (stamp - previous) / 1e9
        if dt not in models:
            models[dt] = sampled(dt, a)
        ad, bd, qd = models[dt]
        prior = ad @ x + bd @ held(inputs, previous)
        if kind == 'time_varying':
            p_prior = ad @ p @ ad.T + qd
            gain = p_prior @ c.T @ np.linalg.inv(c @ p_prior @ c.T + r)
            joseph = np.eye(2) - gain @ c
            p = joseph @ p_prior @ joseph.T + gain @ r @ gain.T
        elif kind == 'steady_kalman':
            key = (dt, tuple(outputs))
            if key not in riccati:
                riccati[key] = scipy.linalg.solve_discrete_are(ad.T, c.T, qd, r)
            p_prior = riccati[key]
            gain = p_prior @ c.T @ np.linalg.inv(c @ p_prior @ c.T + r)
            p = (np.eye(2) - gain @ c) @ p_prior
        else:  # full order, one output: Ackermann's formula for the pair (Ad, c Ad)
            pair = c @ ad
            observability = np.vstack([pair, pair @ ad])
            wanted = np.real(np.poly(np.exp(np.array(POLES) * (stamp - previous) / 1e9)))
            polynomial = ad @ ad + wanted[1] * ad + wanted[2] * np.eye(2)
            gain = polynomial @ np.linalg.solve(observability, [[0.0], [1.0]])
            p = None
        x = prior + gain @ (y - c @ prior)
        out[stamp] = (x.copy(), None if p is None else p.copy())
        previous = stamp
    return out


# --- the stream ------------------------------------------------------------------------------


def estimator(kind: str):
    model = StateSpaceModel.from_matrices(A, B, C)
    if kind == 'full_order':
        return make_estimator(design_full_order(model, poles=POLES), initial_state=[0.0, 0.0])
    design = design_kalman(model, Q, R.ravel().tolist())
    return make_estimator(design, initial_state=[0.0, 0.0],
                          time_varying=kind == 'time_varying')


def relative_error(got, expected) -> float:
    got, expected = np.asarray(got, dtype=float), np.asarray(expected, dtype=float)
    return float(np.linalg.norm(got - expected) / max(np.linalg.norm(expected), 1e-300))


def allowed_error(kind: str, measurements, inputs: dict, final: dict) -> float:
    """
    Return the tolerance of one scenario: ``max(RTOL, MARGIN * move)``.

    ``move``: the largest relative change of the reference's estimates and covariances when
    every entry of ``A`` is multiplied by ``1 +- eps`` (random signs, :data:`PERTURBATIONS`
    draws): how far a rounding error in the data can move the exact answer.
    """
    rng = np.random.default_rng(0)
    move = 0.0
    for _ in range(PERTURBATIONS):
        signs = rng.choice((-1.0, 1.0), size=np.shape(A))
        other = reference(kind, measurements, inputs,
                          a=np.array(A) * (1.0 + np.finfo(float).eps * signs))
        for stamp, (x, p) in final.items():
            move = max(move, relative_error(other[stamp][0], x))
            if p is not None:
                move = max(move, relative_error(other[stamp][1], p))
    return max(RTOL, MARGIN * move)


def measurement_of(event: RecordedEvent) -> tuple:
    output = {'encoder': 1, 'camera': 0}[event.source]
    return event.stamp_ns, output, float(event.values[0])


@pytest.mark.parametrize('kind, equal_stamps', [
    ('time_varying', True), ('steady_kalman', True), ('full_order', False)])
def test_late_and_out_of_order_sources_equal_the_reference_in_stamp_order(kind, equal_stamps):
    events, inputs = scenario(7, equal_stamps)
    stream = EventStream(estimator(kind), max_gap_ns=5 * 10 ** 9, sources=SOURCES,
                         history_ns=HISTORY_NS)
    arrived, returned = [], []
    for event in events:
        if event.source != 'u':
            arrived.append(measurement_of(event))
        for sample in stream.replay_events([event]):
            returned.append((len(arrived), sample))
    measurements = [measurement_of(event) for event in events if event.source != 'u']
    final = reference(kind, measurements, inputs)
    worst = 0.0
    history = stream.history()
    assert [sample.stamp_ns for sample in history] == sorted(final)
    for sample in history:
        x, p = final[sample.stamp_ns]
        worst = max(worst, relative_error(sample.estimate, x))
        if p is not None:
            worst = max(worst, relative_error(sample.covariance, p))
    # What was returned along the way: the estimates of the measurements arrived by then.
    corrected = [item for item in returned if item[1].corrected]
    chosen = corrected + returned[::60]
    for count, sample in chosen:
        x, p = reference(kind, arrived[:count], inputs)[sample.stamp_ns]
        worst = max(worst, relative_error(sample.estimate, x))
        if p is not None:
            worst = max(worst, relative_error(sample.covariance, p))
    allowed = allowed_error(kind, measurements, inputs, final)
    print(f'\n{kind}: worst relative error {worst:.2e}, allowed {allowed:.2e}')
    assert worst <= allowed, (worst, allowed)
    slow = sum(event.source == 'camera' for event in events)
    counters = stream.counters
    assert counters['reruns'] == slow == len(corrected) == counters['corrected']
    assert counters['estimates'] == COUNT
    assert not counters['too_old'] and not counters['duplicate']
    report = stream.source_report()
    assert report['camera'].counts['reruns'] == slow
    assert LATE_NS < report['camera'].max_lag_ns < LATE_NS + SLOW_NS + 5_000_000
    # The corrected estimates are the newest ones, at the newest stamp reached then.
    for count, sample in corrected:
        newest = max(stamp for stamp, _, _ in arrived[:count])
        assert sample.stamp_ns == newest


def test_equal_stamps_of_two_sources_make_one_update_with_both():
    # With R correlated between the two outputs, one fused update (the reference's) and
    # two updates in a row at one stamp differ; the stream gives the fused one, whichever
    # source comes first.
    _, inputs = scenario(3, False)
    stamps = [START_NS + k * FAST_NS for k in range(5)]
    results = []
    for order in (('encoder', 'camera'), ('camera', 'encoder')):
        stream = EventStream(estimator('time_varying'), max_gap_ns=10 ** 9, sources=SOURCES)
        for stamp in stamps:
            stream.add_input(stamp, inputs[stamp])
            for source in order:
                stream.add_measurement(stamp, [0.3 if source == 'camera' else -0.2],
                                       source=source)
        results.append(stream.estimator.estimate)
        assert stream.counters['reruns'] == len(stamps)  # the second of each stamp joins
        assert stream.history()[-1].outputs is None  # every output, fused
    measurements = [(stamp, output, 0.3 if output == 0 else -0.2)
                    for stamp in stamps for output in (0, 1)]
    expected = reference('time_varying', measurements, inputs)[stamps[-1]][0]
    for result in results:
        assert relative_error(result, expected) <= RTOL
    sequential = EventStream(estimator('time_varying'), max_gap_ns=10 ** 9, sources=SOURCES)
    for stamp in stamps:  # the two one after the other, a nanosecond apart
        sequential.add_input(stamp, inputs[stamp])
        sequential.add_measurement(stamp, [-0.2], source='encoder')
        sequential.add_measurement(stamp + 1, [0.3], source='camera')
    assert relative_error(sequential.estimator.estimate, expected) > 1e-6
