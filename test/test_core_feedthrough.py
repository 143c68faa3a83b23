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
A feedthrough ``D != 0`` in every observer type, the stream, the simulator and the designs.

Each observer type runs a ``D != 0`` model against an independent reference: the same model
with ``D = 0`` fed ``y - D u`` worked out here by hand (and, for the full-order observer, a
plain numpy loop), with ``u`` the input in effect at the measurement's stamp.
"""

from dataclasses import replace

import numpy as np
import pytest

import observer_ros.core as oc
from observer_ros.core.discretize import zero_order_hold
from observer_ros.core.errors import ConfigError
from observer_ros.core.sources import MeasurementSource
from observer_ros.core.streaming import EventStream

#: Third order, two outputs, a direct path from the input to both outputs.
A = [[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [-6.0, -11.0, -6.0]]
B = [[0.0], [0.0], [1.0]]
C = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
D = [[0.5], [-1.0]]
PERIOD_NS, SAMPLES, GAP_NS = 10_000_000, 400, 10**9
X0 = np.array([1.0, -0.5, 0.25])

MODEL = oc.StateSpaceModel.from_matrices(A, B, C, D)
WITHOUT_D = replace(MODEL, d=np.zeros((2, 1)))

DESIGNS = {
    'full_order': lambda model: oc.design_full_order(model, poles=[-4, -5, -6]),
    'reduced_order': lambda model: oc.design_reduced_order(model, poles=[-7]),
    'chen': lambda model: oc.design_chen(model, poles=[-7]),
    'kalman': lambda model: oc.design_kalman(model, [0.1, 0.1, 0.1], [0.01, 0.01]),
    'kalman_time_varying': lambda model: oc.design_kalman(model, [0.1, 0.1, 0.1],
                                                          [0.01, 0.01]),
}


def estimator_for(kind: str, model):
    return oc.make_estimator(DESIGNS[kind](model),
                             **({'time_varying': True} if kind == 'kalman_time_varying'
                                else {}))


def recording(model=MODEL, samples=SAMPLES, seed=0):
    """``(stamps, inputs, outputs, states)``: ``y[k] = C x[k] + D u[k]``, ``u[k]`` applied at k."""
    rng = np.random.default_rng(seed)
    plant = oc.PlantSimulator(model, initial_state=X0)
    stamps = PERIOD_NS * np.arange(samples, dtype=np.int64)
    inputs = rng.standard_normal((samples, 1))
    outputs, states = np.empty((samples, 2)), np.empty((samples, 3))
    for k in range(samples):
        states[k] = plant.x
        outputs[k] = plant.measure(inputs[k])
        plant.step(inputs[k], PERIOD_NS / 1e9)
    return stamps, inputs, outputs, states


@pytest.mark.parametrize('kind', sorted(DESIGNS))
def test_each_observer_type_equals_the_model_without_d_fed_y_minus_d_u(kind):
    stamps, inputs, outputs, states = recording()
    stream = EventStream(estimator_for(kind, MODEL), GAP_NS)
    estimates = stream.replay(stamps, inputs, stamps, outputs).estimates
    # The reference: D = 0, y - D u by hand, the input of the interval the one before.
    reference = estimator_for(kind, WITHOUT_D)
    held = np.vstack([np.zeros((1, 1)), inputs[:-1]])
    by_hand = np.array([reference.update(int(t), y - np.asarray(D) @ u_now, u)
                        for t, y, u, u_now in zip(stamps, outputs, held, inputs)])
    np.testing.assert_allclose(estimates, by_hand, rtol=0, atol=1e-12)
    error = np.abs(estimates[-50:] - states[-50:]).max()
    print(f'{kind}: largest |x - x_hat| over the last 50 samples {error:.2e}')
    assert error < 1e-6  # no noise: the estimate converges to the state


def test_the_full_order_observer_equals_a_plain_numpy_loop():
    # One output, so the gain placing exp(lambda dt) is unique.
    model = oc.StateSpaceModel.from_matrices(A, B, C[:1], D[:1])
    rng = np.random.default_rng(4)
    plant = oc.PlantSimulator(model, initial_state=X0)
    stamps = PERIOD_NS * np.arange(SAMPLES, dtype=np.int64)
    inputs = rng.standard_normal((SAMPLES, 1))
    outputs = np.empty((SAMPLES, 1))
    for k in range(SAMPLES):
        outputs[k] = plant.measure(inputs[k])
        plant.step(inputs[k], PERIOD_NS / 1e9)
    poles = np.array([-4.0, -5.0, -6.0])
    estimator = oc.make_estimator(oc.design_full_order(model, poles=poles),
                                  initial_state=np.zeros(3))
    estimates = EventStream(estimator, GAP_NS).replay(stamps, inputs, stamps, outputs).estimates
    ad, bd = zero_order_hold(model.a, model.b, PERIOD_NS / 1e9)
    gain = oc.place_observer(ad, model.c @ ad, np.exp(poles * PERIOD_NS / 1e9)).gain  # (Ad, C Ad)
    c, d = model.c, model.d
    x = np.zeros(3)  # pinned: the first sample keeps it
    loop = [x]
    for k in range(1, SAMPLES):
        prior = ad @ x + bd @ inputs[k - 1]
        x = prior + gain @ (outputs[k] - c @ prior - d @ inputs[k])
        loop.append(x)
    np.testing.assert_allclose(estimates, np.array(loop), rtol=0, atol=1e-9)


@pytest.mark.parametrize('kind', ['reduced_order', 'chen'])
def test_the_reduced_reconstruction_takes_d_u_off_y(kind):
    # The measured part of the estimate is y - D u exactly (C x_hat = y - D u_now).
    stamps, inputs, outputs, _ = recording(samples=50)
    estimates = EventStream(estimator_for(kind, MODEL), GAP_NS).replay(
        stamps, inputs, stamps, outputs).estimates
    reconstructed = estimates @ MODEL.c.T + inputs @ MODEL.d.T
    np.testing.assert_allclose(reconstructed, outputs, rtol=0, atol=1e-12)


@pytest.mark.parametrize('kind', sorted(DESIGNS))
def test_live_event_by_event_equals_the_replay(kind):
    stamps, inputs, outputs, _ = recording(samples=120)
    replayed = EventStream(estimator_for(kind, MODEL), GAP_NS).replay(
        stamps, inputs, stamps, outputs).estimates
    live = EventStream(estimator_for(kind, MODEL), GAP_NS)
    samples = []
    for k, (t, u, y) in enumerate(zip(stamps.tolist(), inputs, outputs)):
        if k % 2:  # the plant publishes u before y; over DDS y may come first: it waits
            samples += live.add_input(t, u)
            samples += live.add_measurement(t, y.tolist())
        else:
            assert live.add_measurement(t, y.tolist()) == []
            samples += live.add_input(t, u)
    samples += live.flush()
    np.testing.assert_array_equal(np.array([s.estimate for s in samples]), replayed)


def test_d_zero_keeps_the_fast_paths_and_d_turns_them_off():
    zero = EventStream(estimator_for('full_order', WITHOUT_D), GAP_NS)
    direct = EventStream(estimator_for('full_order', MODEL), GAP_NS)
    assert zero.estimator.feedthrough is None and zero._fast
    np.testing.assert_array_equal(direct.estimator.feedthrough, MODEL.d)
    assert not direct._fast and direct.engine.pairs_at_stamp


def test_each_source_takes_its_own_rows_of_d():
    # Two sources at their own rates (y1 every sample, y2 every other one).
    stamps, inputs, outputs, _ = recording(samples=200)
    sources = (MeasurementSource('first', (0,)), MeasurementSource('second', (1,)))
    stream = EventStream(estimator_for('kalman_time_varying', MODEL), GAP_NS, sources=sources)
    reference = estimator_for('kalman_time_varying', WITHOUT_D)
    got, expected = [], []
    previous = np.zeros(1)
    for k, (t, u, y) in enumerate(zip(stamps.tolist(), inputs, outputs)):
        stream.add_input(t, u)
        outputs_now = (0,) if k % 2 else (0, 1)
        produced = stream.add_measurement(t, [y[0]], source='first')
        if len(outputs_now) == 2:
            produced = stream.add_measurement(t, [y[1]], source='second')
        got.append(produced[-1].estimate)
        free = (y - MODEL.d @ u)[list(outputs_now)]
        expected.append(reference.advance_outputs(t, free, previous, outputs_now).copy())
        previous = u
    # The first sample of the second source fuses with the first's at stamp 0: compare after.
    np.testing.assert_allclose(np.array(got)[2:], np.array(expected)[2:], rtol=0, atol=1e-9)


def test_a_late_input_re_runs_the_row_at_its_stamp_with_a_history():
    stamps, inputs, outputs, _ = recording(samples=30)
    on_time = EventStream(estimator_for('full_order', MODEL), GAP_NS, history_ns=GAP_NS // 10)
    late = EventStream(estimator_for('full_order', MODEL), GAP_NS, history_ns=GAP_NS // 10)
    for t, u, y in zip(stamps.tolist(), inputs, outputs):
        expected = on_time.add_input(t, u) + on_time.add_measurement(t, y.tolist())
        # The input stamped with the measurement comes after it stopped waiting (a flush).
        late.add_measurement(t, y.tolist())
        late.flush()
        corrected = late.add_input(t, u)
    assert late.counters['input_reruns'] > 0
    np.testing.assert_allclose(corrected[-1].estimate, expected[-1].estimate, rtol=0,
                               atol=1e-12)


def test_update_needs_the_input_in_effect_at_the_stamp():
    estimator = estimator_for('full_order', MODEL)
    with pytest.raises(ConfigError, match=r'u_now: the model has a feedthrough D != 0'):
        estimator.update(0, [1.0, 0.0], [0.0])
    with pytest.raises(ConfigError, match=r'u_now: expected 1 finite values'):
        estimator.update(0, [1.0, 0.0], [0.0], [1.0, 2.0])


def test_the_simulator_measures_c_x_plus_d_u_with_the_applied_input():
    plant = oc.PlantSimulator(MODEL, initial_state=X0, input_limits=[-1.0, 1.0],
                              input_offset=[0.25])
    np.testing.assert_array_equal(plant.measure([3.0]), MODEL.c @ X0 + MODEL.d @ [1.25])
    with pytest.raises(ConfigError, match=r'u: the model has a feedthrough'):
        plant.measure()
    plain = oc.PlantSimulator(WITHOUT_D, initial_state=X0)
    np.testing.assert_array_equal(plain.measure([3.0]), WITHOUT_D.c @ X0)


def test_an_input_disturbance_enters_through_d_too():
    # Augmented: y = C x + D (u + d); the observer of the augmented model finds d.
    from observer_ros.core.disturbances import augment
    plant = oc.StateSpaceModel.from_matrices(A, B, C[:1], D[:1])
    augmented = augment(plant, ['constant'], ['input']).augmented
    np.testing.assert_array_equal(augmented.c, [[1.0, 0.0, 0.0, 0.5]])
    np.testing.assert_array_equal(augmented.d, plant.d)
    simulator = oc.PlantSimulator(augmented, initial_state=[*X0, 0.7])
    estimator = oc.make_estimator(oc.design_full_order(augmented, poles=[-4, -5, -6, -7]))
    stream = EventStream(estimator, GAP_NS)
    rng = np.random.default_rng(2)
    for k in range(SAMPLES):
        u = rng.standard_normal(1)
        stream.add_input(k * PERIOD_NS, u)
        sample = stream.add_measurement(k * PERIOD_NS, simulator.measure(u).tolist())[-1]
        simulator.step(u, PERIOD_NS / 1e9)
    assert abs(sample.estimate[3] - 0.7) < 1e-4  # poles -4 ... -7, 4 s


@pytest.mark.parametrize('dt', [0.0, 0.01])
def test_the_integral_design_places_the_poles_of_the_loop_with_d(dt):
    # The loop built by hand: u = -K x + K_i z, z' = r - (C x + D u).
    from observer_ros.core.design.integral import design_integral
    model = oc.StateSpaceModel.from_matrices(A, B, C[:1], D[:1])
    poles = [-1.0, -2.0, -3.0, -4.0]
    if dt:
        ad, bd = zero_order_hold(model.a, model.b, dt)
        model = oc.StateSpaceModel.from_matrices(ad, bd, C[:1], D[:1], dt=dt)
        poles = np.exp(np.array(poles) * dt).tolist()
    design = design_integral(model, [0], poles=poles)
    k, k_i, c, d = design.gain, design.integral_gain, model.c, model.d
    top = np.hstack([model.a - model.b @ k, model.b @ k_i])
    error = np.hstack([-(c - d @ k), -d @ k_i])  # r - y with u = -K x + K_i z
    if dt:
        loop = np.vstack([top, np.hstack([np.zeros((1, 3)), np.eye(1)]) + dt * error])
    else:
        loop = np.vstack([top, error])
    found = np.sort_complex(np.linalg.eigvals(loop))
    np.testing.assert_allclose(found, np.sort_complex(np.array(poles, dtype=complex)),
                               atol=1e-9)


def test_a_configured_model_with_d_and_a_disturbance_runs(tmp_path):
    # The parameter file's path: model.D with model.disturbances, validated, its stream.
    from observer_ros.config import load_parameter_file, validate_parameters
    path = tmp_path / 'direct.yaml'
    path.write_text(
        '/**:\n  ros__parameters:\n    model:\n'
        '      A: [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, -6.0, -11.0, -6.0]\n'
        '      B: [0.0, 0.0, 1.0]\n      C: [1.0, 0.0, 0.0]\n      D: [0.5]\n'
        "      disturbances: ['constant']\n"
        "      disturbance_entries: ['input']\n"
        "    observer:\n      poles: ['-4', '-5', '-6', '-7']\n")
    system = validate_parameters(load_parameter_file(str(path)), strict=True)
    np.testing.assert_array_equal(system.model.c, [[1.0, 0.0, 0.0, 0.5]])
    stream = system.observer.make_stream()
    np.testing.assert_array_equal(stream.estimator.feedthrough, [[0.5]])
    simulator = oc.PlantSimulator(system.model, initial_state=[*X0, -0.3])
    for k in range(SAMPLES):
        u = np.array([np.sin(0.05 * k)])
        stream.add_input(k * PERIOD_NS, u)
        sample = stream.add_measurement(k * PERIOD_NS, simulator.measure(u).tolist())[-1]
        simulator.step(u, PERIOD_NS / 1e9)
    assert abs(sample.estimate[3] + 0.3) < 1e-4
