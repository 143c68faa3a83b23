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
Measurement noise from the messages' covariance (``sources.<name>.noise: message``).

The block of ``R`` a message gives reaches the update at its stamp (the time-varying Kalman
filter, the EKF, the UKF); the estimate equals the filter run with that ``R`` given by hand;
a covariance that is unknown (-1), not finite or not positive definite is counted and the
configured block serves; a late sample finds its own noise again through the history.
"""

import math

import numpy as np
import pytest
from rosbags.rosbag2 import Writer
from scipy.linalg import expm

from bag_support import STORAGES, TYPESTORE
from observer_ros.bags.replay import replay_bag
from observer_ros.config import validate_parameters
from observer_ros.config.message_noise import attach_message_noise
from observer_ros.core.errors import ConfigError
from observer_ros.core.message_noise import SampleNoise
from observer_ros.core.nonlinear import ExtendedKalman, NonlinearModel, UnscentedKalman
from observer_ros.core.sources import MeasurementSource
from observer_ros.core.streaming import EventStream
from observer_ros.wire import FieldReader, FieldWriter
from observer_ros.wire.covariance import CovarianceReader

PERIOD_NS = 20_000_000
START_NS = 1_700_000_000 * 10**9
POSE = 'geometry_msgs/msg/PoseWithCovarianceStamped'
TWIST = 'geometry_msgs/msg/TwistWithCovarianceStamped'

#: A cart: position and velocity; a pose source (x) and a twist source (v).
CART = {
    'model.A': [0.0, 1.0, 0.0, 0.0], 'model.B': [], 'model.C': [1.0, 0.0, 0.0, 1.0],
    'model.state_names': ['x', 'v'], 'model.output_names': ['px', 'vx'],
    'observer.type': 'kalman', 'observer.time_varying': True,
    'observer.process_noise': [1e-4, 1e-2], 'observer.sources': ['pose', 'twist'],
    'sources.pose.type': 'pose_with_covariance_stamped',
    'sources.pose.fields': ['pose.pose.position.x'], 'sources.pose.outputs': ['px'],
    'sources.pose.measurement_noise': [0.25], 'sources.pose.noise': 'message',
    'sources.twist.type': 'twist_with_covariance_stamped',
    'sources.twist.fields': ['twist.twist.linear.x'], 'sources.twist.outputs': ['vx'],
    'sources.twist.measurement_noise': [0.09], 'observer.history': 0.2,
}


def message(msgtype, field, value, variance, stamp_ns, element0=None):
    """Serialize a message with ``value`` in ``field`` and ``variance`` as its covariance."""
    reader = CovarianceReader(msgtype, [field])
    paths = [field] + [path for path in reader.paths if path != reader.paths[0]]
    values = [value] + [variance] * (len(paths) - 1)
    if len(reader.paths) == 1:  # the variance is element 0 itself
        paths, values = [field, reader.paths[0]], [value, variance]
    elif element0 is not None:
        paths.append(reader.paths[0])
        values.append(element0)
    return FieldWriter(msgtype, paths).write(stamp_ns, values)


def samples(count=60, seed=3):
    """Pose and twist samples of a cart at 2 m/s, with a pose variance changing per sample."""
    rng = np.random.default_rng(seed)
    out = []
    for k in range(count):
        stamp = START_NS + k * PERIOD_NS
        t = k * PERIOD_NS / 1e9
        variance = float(rng.uniform(0.001, 0.5))
        out.append(('pose', stamp, 2.0 * t + rng.normal(0, math.sqrt(variance)), variance))
        out.append(('twist', stamp + PERIOD_NS // 2, 2.0 + rng.normal(0, 0.3), 0.09))
    return out


def run_node_path(system, feed, give_noise=True):
    """Feed the messages as the node does: the noise first, then the measurement."""
    stream = system.observer.make_stream()
    noise = stream.estimator.message_noise
    readers = noise.readers if give_noise and noise is not None else {}
    estimates = []
    fields = {'pose': (POSE, 'pose.pose.position.x'), 'twist': (TWIST, 'twist.twist.linear.x')}
    for name, stamp, value, variance, *element0 in feed:
        raw = message(*fields[name], value, variance, stamp, *element0)
        stamp_read, values = FieldReader(fields[name][0], [fields[name][1]]).read(raw)
        if name in readers:
            readers[name].take(stamp_read, raw)
        for sample in stream.add_measurement(stamp_read, values, source=name):
            estimates.append((sample.stamp_ns, sample.estimate.copy(), sample.covariance.copy()))
    for sample in stream.flush():
        estimates.append((sample.stamp_ns, sample.estimate.copy(), sample.covariance.copy()))
    return stream, estimates


def reference(feed, configured_pose=0.25, twist_variance=0.09, use_message=True):
    """Run the same Kalman filter written here in plain numpy, R of each pose from its message."""
    a = np.array([[0.0, 1.0], [0.0, 0.0]])
    q = np.diag([1e-4, 1e-2])
    x, p, last = np.zeros(2), np.eye(2), None
    out = []
    for name, stamp, value, variance, *_ in sorted(feed, key=lambda item: item[1]):
        if last is not None:
            dt = (stamp - last) / 1e9
            block = expm(np.block([[-a, q], [np.zeros((2, 2)), a.T]]) * dt)
            ad = block[2:, 2:].T
            x, p = ad @ x, ad @ p @ ad.T + ad @ block[:2, 2:]
        last = stamp
        c = np.array([[1.0, 0.0]]) if name == 'pose' else np.array([[0.0, 1.0]])
        r = (variance if use_message else configured_pose) if name == 'pose' else twist_variance
        s = c @ p @ c.T + r
        k = p @ c.T / s
        x = x + (k * (value - c @ x)).ravel()
        p = (np.eye(2) - k @ c) @ p @ (np.eye(2) - k @ c).T + r * k @ k.T
        out.append((stamp, x.copy(), p.copy()))
    return out


def test_the_covariance_of_each_message_reaches_r_and_equals_the_filter_by_hand():
    feed = samples()
    system = validate_parameters(CART)
    stream, estimates = run_node_path(system, feed)
    expected = reference(feed)
    assert [stamp for stamp, *_ in estimates] == [stamp for stamp, *_ in expected]
    for (_, x, p), (_, x_ref, p_ref) in zip(estimates, expected):
        np.testing.assert_allclose(x, x_ref, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(p, p_ref, rtol=1e-9, atol=1e-12)
    assert stream.estimator.message_noise.readers['pose'].counters == {'used': 60}
    # The decoded variance is the R of the pose's update at its stamp (the twist's stays).
    noise = stream.estimator.message_noise
    for name, stamp, _, variance in feed[-10:]:
        configured = np.diag([0.25, 0.09])
        if name == 'pose':
            assert noise.block(stamp, (0,), configured[:1, :1]).tolist() == [[variance]]
        else:
            assert not noise.has(stamp)
    # Without the messages' noise the configured 0.25 serves, and the estimates differ.
    _, configured = run_node_path(system, feed, give_noise=False)
    for (_, x, _), (_, x_ref, _) in zip(configured, reference(feed, use_message=False)):
        np.testing.assert_allclose(x, x_ref, rtol=1e-9, atol=1e-12)
    assert not np.allclose(configured[-1][1], estimates[-1][1], rtol=1e-6)


def test_a_constant_message_covariance_equals_that_r_configured_bit_for_bit():
    feed = [(name, stamp, value, 0.04 if name == 'pose' else variance)
            for name, stamp, value, variance in samples(30)]
    _, from_messages = run_node_path(validate_parameters(CART), feed)
    by_hand = validate_parameters({**CART, 'sources.pose.noise': 'configured',
                                   'sources.pose.measurement_noise': [0.04]})
    _, configured = run_node_path(by_hand, feed)
    for (_, x, p), (_, x_ref, p_ref) in zip(from_messages, configured):
        assert x.tolist() == x_ref.tolist() and p.tolist() == p_ref.tolist()


@pytest.mark.parametrize('variance, element0, reason', [
    (-1.0, None, 'fallback_unknown'),
    (float('nan'), None, 'fallback_nonfinite'),
    (8.98846567431158e+307, None, 'fallback_out_of_range'),  # found by the fuzz campaign
    (0.0, None, 'fallback_not_positive_definite'),
    (-0.5, None, 'fallback_not_positive_definite'),
])
def test_an_unusable_covariance_is_counted_and_the_configured_r_serves(variance, element0,
                                                                       reason):
    good = samples(20)
    feed = [(name, stamp, value, variance if name == 'pose' and k % 4 == 0 else noise)
            for k, (name, stamp, value, noise) in enumerate(good)]
    stream, estimates = run_node_path(validate_parameters(CART), feed)
    # The reference: the bad ones with the configured 0.25, the others with their own.
    fixed = [(name, stamp, value, 0.25 if name == 'pose' and k % 4 == 0 else noise)
             for k, (name, stamp, value, noise) in enumerate(good)]
    for (_, x, p), (_, x_ref, p_ref) in zip(estimates, reference(fixed)):
        np.testing.assert_allclose(x, x_ref, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(p, p_ref, rtol=1e-9, atol=1e-12)
    assert stream.estimator.message_noise.readers['pose'].counters == {'used': 10, reason: 10}
    assert len(estimates) == 40  # no measurement is lost for its covariance


def test_an_imu_with_element_0_at_minus_one_is_unknown_and_an_asymmetric_block_refused():
    reader = CovarianceReader('imu', ['angular_velocity.z', 'angular_velocity.x'])
    assert reader.paths[0] == 'angular_velocity_covariance[0]'
    values = dict(zip(reader.paths, [0.01, 0.04, 0.0, 0.0]))
    assert reader.check(list(values.values()))[0].tolist() == [[0.04, 0.0], [0.0, 0.01]]
    values['angular_velocity_covariance[0]'] = -1.0
    assert reader.check(list(values.values())) == (None, 'unknown')
    asymmetric = CovarianceReader('odometry', ['pose.pose.position.x', 'pose.pose.position.y'])
    assert asymmetric.check([1.0, 0.5, 0.1, 1.0]) == (None, 'not_positive_definite')
    assert asymmetric.check([1.0, 0.1, 0.1, 1.0])[0].tolist() == [[1.0, 0.1], [0.1, 1.0]]


def test_the_six_by_six_rows_and_columns_the_fields_select_are_read_from_the_bytes():
    # Odometry: yaw (row 5 of the pose's) and the twist's angular z (row 5 of the twist's).
    fields = ['pose.pose.orientation.yaw', 'twist.twist.angular.z', 'pose.pose.position.x']
    pose_cov = np.arange(36.0).reshape(6, 6)
    pose_cov = pose_cov + pose_cov.T + 200.0 * np.eye(6)
    twist_cov = np.diag([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
    paths = [f'pose.covariance[{k}]' for k in range(36)] + [
        f'twist.covariance[{k}]' for k in range(36)] + ['pose.pose.orientation.w']
    raw = FieldWriter('nav_msgs/msg/Odometry', paths).write(
        5, pose_cov.ravel().tolist() + twist_cov.ravel().tolist() + [1.0])
    reader = CovarianceReader('odometry', fields)
    from observer_ros.config.message_noise import MessageNoise
    store = SampleNoise(10**9)
    noise = MessageNoise(MeasurementSource('odom', (2, 0, 1)), 'odometry', fields, store)
    assert noise.take(5, raw)
    assert reader.paths[:2] == ('pose.covariance[0]', 'twist.covariance[0]')
    expected = np.array([[pose_cov[5, 5], 0.0, pose_cov[5, 0]], [0.0, 6.0, 0.0],
                         [pose_cov[0, 5], 0.0, pose_cov[0, 0]]])
    # The store holds it in the order of the source's outputs (2, 0, 1) ...
    r = store.block(5, (0, 1, 2), np.eye(3))
    order = [1, 2, 0]  # ... and the update asks in ascending order
    np.testing.assert_array_equal(r, expected[np.ix_(order, order)])


@pytest.mark.parametrize('change, parameter, what', [
    ({'sources.twist.noise': 'message', 'sources.twist.type': 'twist_stamped',
      'sources.twist.fields': ['twist.linear.x']}, 'sources.twist.noise',
     'carries no covariance'),
    ({'sources.pose.fields': ['pose.pose.orientation.w']}, 'sources.pose.noise',
     "gives no covariance of 'pose.pose.orientation.w'"),
    ({'observer.time_varying': False}, 'sources.pose.noise', 'takes R per sample'),
    ({'sources.pose.noise': 'covariance'}, 'sources.pose.noise', 'configured'),
])
def test_a_source_that_cannot_take_its_noise_from_its_messages_is_refused(change, parameter,
                                                                          what):
    with pytest.raises(ConfigError, match=rf'^{parameter}: .*{what}'):
        validate_parameters({**CART, **change})


def test_a_late_pose_finds_its_own_noise_through_the_history():
    feed = samples(40)
    late = list(feed)
    moved = late.pop(20)  # a pose arriving after three newer samples
    late.insert(24, moved)
    system = validate_parameters(CART)
    _, in_order = run_node_path(system, feed)
    _, out_of_order = run_node_path(system, late)
    final = {stamp: (x, p) for stamp, x, p in out_of_order}
    for stamp, x, p in in_order[-5:]:
        assert final[stamp][0].tolist() == x.tolist() and final[stamp][1].tolist() == p.tolist()


# --- the EKF and the UKF --------------------------------------------------------------------

def cart_model():
    return NonlinearModel(['x', 'v'], {'x': 'v', 'v': '0'}, {'px': 'x', 'vx': 'v'})


@pytest.mark.parametrize('kind', [ExtendedKalman, UnscentedKalman])
def test_the_nonlinear_filters_take_the_messages_r_as_if_given_by_hand(kind):
    sources = (MeasurementSource('pose', (0,)), MeasurementSource('twist', (1,)))
    feed = samples(30)

    def run(variance_of, noise):
        filter_ = kind(cart_model(), [1e-4, 1e-2], [0.25, 0.09])
        if noise is not None:
            store = SampleNoise(10**9)
            filter_.message_noise = store
        stream = EventStream(filter_, 10**9, sources=sources, history_ns=0)
        out = []
        for name, stamp, value, variance in feed:
            if noise is not None and name == 'pose':
                store.put(stamp, (0,), np.array([[variance]]))
            out += [(s.estimate.copy(), s.covariance.copy())
                    for s in stream.add_measurement(stamp, [value], source=name)]
        return out

    from_messages = run(None, True)
    # By hand: one update at a time, the R of that sample given to a filter of it.
    by_hand = kind(cart_model(), [1e-4, 1e-2], [0.25, 0.09])
    for (name, stamp, value, variance), (x, p) in zip(feed, from_messages):
        outputs = (0,) if name == 'pose' else (1,)
        by_hand.measurement_noise = np.diag([variance if name == 'pose' else 0.25, 0.09])
        by_hand._blocks = {}
        expected = by_hand.advance_outputs(stamp, np.array([value]), np.zeros(0), outputs)
        np.testing.assert_allclose(x, expected, rtol=1e-12, atol=1e-14)
        np.testing.assert_allclose(p, by_hand.covariance, rtol=1e-12, atol=1e-14)
    assert not np.allclose(from_messages[-1][0], run(None, None)[-1][0], rtol=1e-6)


def test_a_constant_gain_type_is_refused_by_name():
    class Constant:
        """A type without R per sample."""

    with pytest.raises(ConfigError, match=r'^sources.pose.noise: noise: message needs'):
        system = validate_parameters({**CART, 'sources.pose.noise': 'configured'})
        sources = system.observer.sources
        settings = sources.settings[0].__class__(
            **{**sources.settings[0].__dict__, 'noise': 'message'})
        attach_message_noise(Constant(), sources.__class__(
            sources.sources, (settings,) + sources.settings[1:], sources.msgtypes), 0)


@pytest.mark.parametrize('storage', sorted(STORAGES))
def test_replay_takes_the_noise_of_each_recorded_message_as_the_node_does(tmp_path, storage):
    feed = samples(40)
    late = list(feed)
    late.insert(30, late.pop(24))  # a pose logged after three newer samples
    fields = {'pose': (POSE, 'pose.pose.position.x'), 'twist': (TWIST, 'twist.twist.linear.x')}
    with Writer(tmp_path / 'bag', version=9, storage_plugin=STORAGES[storage]) as writer:
        connections = {name: writer.add_connection(f'/{name}', msgtype, typestore=TYPESTORE)
                       for name, (msgtype, _) in fields.items()}
        for k, (name, stamp, value, variance) in enumerate(late):
            writer.write(connections[name], START_NS + k * PERIOD_NS // 2,
                         message(*fields[name], value, variance, stamp))
    system = validate_parameters(CART)
    result = replay_bag(tmp_path / 'bag', system)
    _, live = run_node_path(system, late)
    assert result.stamps_ns.tolist() == [stamp for stamp, _, _ in live]
    assert result.estimates.tolist() == [x.tolist() for _, x, _ in live]
    assert result.covariances.tolist() == [p.tolist() for _, _, p in live]


def test_the_blocks_are_kept_for_the_history_and_start_again_after_a_jump_back():
    noise = SampleNoise(keep_ns=100)
    for stamp in range(0, 1000, 10):
        noise.put(stamp, (0,), np.array([[stamp + 1.0]]))
    assert len(noise) == 11 and noise.has(890) and not noise.has(880)
    assert noise.block(900, (0,), np.eye(1)).tolist() == [[901.0]]
    noise.put(5, (0,), np.array([[0.5]]))  # a looping bag starts again
    assert len(noise) == 1 and noise.block(5, (0,), np.eye(1)).tolist() == [[0.5]]
    noise.put(950, (0,), np.array([[2.0]]))
    noise.put(905, (0,), np.array([[3.0]]))  # late, within the window
    noise.put(905, (0,), np.array([[4.0]]))  # repeated: the first kept, as the engine does
    assert noise.block(905, (0, 1), np.diag([7.0, 8.0])).tolist() == [[3.0, 0.0], [0.0, 8.0]]
