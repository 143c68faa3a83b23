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
Fuzzing the parameters and messages of issue 30: the noise of each message, the Odometry.

Hypothesis draws covariances of any doubles (NaN, infinities, -1, huge, asymmetric,
indefinite), bytes and truncations of the covariance messages, and any values of the new
parameters (``sources.<name>.noise``, ``outputs.odometry.*``). A covariance is used only as
a symmetric positive definite block and otherwise counted by its reason (the estimate stays
finite), a message never raises, and a parameter is taken or refused naming itself.
"""

import math

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
from test_message_noise import CART, message, POSE, samples

from observer_ros.config import validate_parameters
from observer_ros.config.message_noise import MessageNoise
from observer_ros.core.errors import ConfigError
from observer_ros.core.message_noise import SampleNoise
from observer_ros.core.sources import MeasurementSource
from observer_ros.wire import FieldWriter
from observer_ros.wire.covariance import CovarianceReader, COVARIANCES, REASONS
from observer_ros.wire.odometry import OdometryEncoder

CAMPAIGN = settings(max_examples=150, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))

#: Every field that has a covariance, per type.
COVARIANCE_FIELDS = {msgtype: [f'{prefix}.{leaf}' for prefix, (_, _, rows) in vectors.items()
                               for leaf in rows]
                     for msgtype, vectors in COVARIANCES.items()}

DOUBLES = st.one_of(st.floats(allow_nan=True, allow_infinity=True),
                    st.sampled_from([-1.0, 0.0, 1e-300, 1e300, -0.0]),
                    st.floats(-10.0, 10.0))


@CAMPAIGN
@given(data=st.data())
def test_any_covariance_is_a_positive_definite_block_or_a_counted_reason(data):
    msgtype = data.draw(st.sampled_from(sorted(COVARIANCE_FIELDS)))
    fields = data.draw(st.lists(st.sampled_from(COVARIANCE_FIELDS[msgtype]), min_size=1,
                                max_size=4, unique=True))
    reader = CovarianceReader(msgtype, fields)
    values = data.draw(st.lists(DOUBLES, min_size=len(reader.paths),
                                max_size=len(reader.paths)))
    block, reason = reader.check(values)
    if block is None:
        assert reason in REASONS
        return
    assert reason is None and block.shape == (len(fields), len(fields))
    assert np.isfinite(block).all() and (block == block.T).all()
    assert np.linalg.eigvalsh(block).min() > 0.0 or np.isfinite(np.linalg.cholesky(block)).all()
    # The message's bytes give the same block.
    raw = FieldWriter(msgtype, reader.paths).write(1, values)
    store = SampleNoise(10**9)
    noise = MessageNoise(MeasurementSource('s', tuple(range(len(fields)))), msgtype, fields,
                         store)
    assert noise.take(1, raw)
    assert store.block(1, tuple(range(len(fields))), np.eye(len(fields))).tolist() == (
        block.tolist())


@CAMPAIGN
@given(data=st.data())
def test_any_bytes_of_a_covariance_message_are_counted_never_raised(data):
    store = SampleNoise(10**9)
    noise = MessageNoise(MeasurementSource('pose', (0,)), POSE, ['pose.pose.position.x'],
                         store)
    good = message(POSE, 'pose.pose.position.x', 1.0, 0.5, 7)
    raw = data.draw(st.one_of(st.binary(max_size=400),
                              st.integers(0, len(good) - 1).map(lambda n: good[:n])))
    used = noise.take(7, raw)
    assert used == store.has(7)
    assert sum(noise.counters.values()) == 1


@CAMPAIGN
@given(variances=st.lists(DOUBLES, min_size=20, max_size=20))
def test_the_filter_stays_finite_whatever_the_messages_say(variances):
    from test_message_noise import run_node_path
    feed = [(name, stamp, value, variances[k // 2] if name == 'pose' else noise)
            for k, (name, stamp, value, noise) in enumerate(samples(20))]
    stream, estimates = run_node_path(validate_parameters(CART), feed)
    assert len(estimates) == 40
    assert all(np.isfinite(x).all() and np.isfinite(p).all() for _, x, p in estimates)
    counters = stream.estimator.message_noise.readers['pose'].counters
    assert sum(counters.values()) == 20


NAMES = st.one_of(st.sampled_from(['', 'x', 'v', 'px', 'yaw', 'x ', 'X']),
                  st.text(max_size=6))


@CAMPAIGN
@given(data=st.data())
def test_any_odometry_parameters_are_taken_or_refused_by_name(data):
    change = {'outputs.odometry.topic': data.draw(st.sampled_from(['odom', '']))}
    for quantity in ('x', 'y', 'yaw', 'vx', 'vy', 'wz'):
        if data.draw(st.booleans()):
            change[f'outputs.odometry.{quantity}'] = data.draw(NAMES)
    for frame in ('frame_id', 'child_frame_id'):
        if data.draw(st.booleans()):
            change[f'outputs.odometry.{frame}'] = data.draw(st.text(max_size=5))
    if data.draw(st.booleans()):
        change['outputs.odometry.absent_variance'] = data.draw(DOUBLES)
    if data.draw(st.booleans()):
        change['sources.pose.noise'] = data.draw(st.one_of(
            st.sampled_from(['configured', 'message']), st.text(max_size=8)))
    try:
        system = validate_parameters({**CART, **change})
    except ConfigError as e:
        assert e.parameter.startswith(('outputs.odometry.', 'sources.pose.noise')), e
        return
    output = system.observer.odometry
    if output is None:
        return
    raw = OdometryEncoder(output.frame_id, output.child_frame_id)
    values = output.mapping.values(np.array([1.5, -0.5]), np.array([[0.1, 0.01], [0.01, 0.2]]))
    assert len(raw.encode(3, values.pose, values.pose_covariance, values.twist,
                          values.twist_covariance)) > 8 * 85
    assert all(map(math.isfinite, values.pose + values.twist))
