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
The fuzz campaign over real DDS, for measurement sources of every message type.

One observer node with a source of each type read by field path (``sensor_msgs/JointState``,
``Imu``, ``nav_msgs/Odometry``, the stamped geometry messages, ``geometry_msgs/Twist``,
``std_msgs/Float64`` and ``Float64MultiArray``), each on its own topic. Hypothesis draws
bad messages (bytes, truncations, NaN, infinities, huge values, stamps that are no time,
ahead of the clock, older than the history, repeated by the same source) between good
samples of every source (the stamped ones sharing stamps, so equal stamps of two sources
make one update). The node must count exactly the bad messages of each source by reason,
publish only finite values, and publish exactly what a clean stream gives for the good
samples alone.
"""

import math

from hypothesis import given, HealthCheck, settings, strategies as st
import numpy as np
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from observer_ros.config import validate_parameters
from observer_ros.config.schema import FIELD_MESSAGE_TYPES
from observer_ros.nodes.observer import ObserverNode
from observer_ros.ros.messages import FieldCodec, MalformedMessage, message_class, stamp_to_ns
from observer_ros.wire import FieldWriter, ORIGIN, STAMP
from ros_support import executor_with, ros_context, spin_until

CAMPAIGN = settings(max_examples=8, deadline=None, derandomize=True, database=None,
                    suppress_health_check=list(HealthCheck))

#: One field of each message type the sources read.
FIELDS = {'joint_state': 'position.wheel', 'float64_multi_array': 'data[1]',
          'float64': 'data', 'imu': 'angular_velocity.z', 'odometry': 'twist.twist.linear.x',
          'pose_stamped': 'pose.position.x', 'twist_stamped': 'twist.angular.z',
          'wrench_stamped': 'wrench.force.z', 'point_stamped': 'point.x',
          'vector3_stamped': 'vector.y', 'twist': 'linear.x'}
SOURCES = sorted(FIELDS)
HISTORY_NS = 3_000_000_000

#: Bad kinds and the reason each is counted under; the last four for stamped types only.
VALUE_KINDS = {'bytes': 'malformed', 'truncated': 'malformed', 'nan': 'malformed',
               'inf': 'malformed', 'huge': 'out_of_range'}
STAMP_KINDS = {'nanosec': 'malformed', 'negative': 'malformed', 'future': 'future_stamp',
               'too_old': 'too_old', 'duplicate': 'duplicate'}


def parameters() -> dict:
    """Return a one-state model seen by one output per source, each on its own topic."""
    params = {'model.A': [0.0], 'model.B': [], 'model.C': [1.0] * len(SOURCES),
              'model.output_names': SOURCES, 'observer.type': 'kalman',
              'observer.time_varying': True, 'observer.process_noise': [1.0],
              'observer.initial_state': [0.0], 'observer.history': HISTORY_NS / 1e9,
              'observer.max_gap': 5.0, 'observer.clock_tolerance': 0.5,
              'observer.sources': SOURCES}
    for name in SOURCES:
        params.update({f'sources.{name}.type': name, f'sources.{name}.topic': f'fuzz/{name}',
                       f'sources.{name}.fields': [FIELDS[name]],
                       f'sources.{name}.outputs': [name],
                       f'sources.{name}.measurement_noise': [0.01]})
    return params


class Encoders:
    """Serialize a value of each source's field, stamped (where the type has a header)."""

    def __init__(self) -> None:
        self.writers = {name: FieldWriter(FIELD_MESSAGE_TYPES[name], [FIELDS[name]])
                        for name in SOURCES if name not in ('joint_state',
                                                            'float64_multi_array')}
        self.codecs = {name: FieldCodec(name, FIELD_MESSAGE_TYPES[name], [FIELDS[name]])
                       for name in SOURCES}

    def good(self, name: str, stamp_ns: int, value: float) -> bytes:
        if name == 'joint_state':
            message = JointState(name=['caster', 'wheel'], position=[0.0, value])
            message.header.stamp.sec, message.header.stamp.nanosec = divmod(stamp_ns, 10 ** 9)
            return serialize_message(message)
        if name == 'float64_multi_array':
            return serialize_message(Float64MultiArray(data=[0.0, value, 2.0]))
        return self.writers[name].write(stamp_ns, [value])

    def stamped(self, name: str) -> bool:
        return self.codecs[name].stamped

    def content_length(self, name: str, raw: bytes) -> int:
        """Length of the shortest prefix of ``raw`` that still decodes."""
        for length in range(len(raw) + 1):
            try:
                self.codecs[name].decode(raw[:length])
            except MalformedMessage:
                continue
            return length
        raise AssertionError('the message does not decode')

    def bad(self, kind: str, name: str, stamp_ns: int, data) -> bytes:
        if kind == 'bytes':
            return data.draw(st.binary(max_size=60))
        if kind == 'truncated':
            raw = self.good(name, stamp_ns, 0.5)
            return raw[:data.draw(st.integers(0, self.content_length(name, raw) - 1))]
        value = {'nan': math.nan, 'inf': -math.inf, 'huge': 1e300}.get(kind, 0.25)
        raw = bytearray(self.good(name, stamp_ns, value))
        if kind == 'nanosec':
            STAMP.pack_into(raw, ORIGIN, 1, data.draw(st.integers(10 ** 9, 2 ** 32 - 1)))
        elif kind == 'negative':
            STAMP.pack_into(raw, ORIGIN, data.draw(st.integers(-2 ** 31, -1)), 0)
        return bytes(raw)


def test_bad_messages_of_every_source_type_are_counted_and_never_reach_the_estimate():
    params = parameters()
    system = validate_parameters(params)
    encoders = Encoders()
    with ros_context() as context:
        observer = ObserverNode(context=context, parameter_overrides=[
            Parameter(name, value=value) for name, value in params.items()])
        driver = Node('fuzz_driver', context=context)
        publishers = {name: driver.create_publisher(
            message_class(FIELD_MESSAGE_TYPES[name]), f'fuzz/{name}', 10) for name in SOURCES}
        estimates = []
        driver.create_subscription(JointState, 'x_hat', estimates.append, 1000)
        taken = []  # what reached the stream: (source, stamp, values, good)
        add_measurement = observer.stream.add_measurement
        tag = {'good': True}

        def recorded(stamp_ns, y, now_ns=None, arrival_ns=0, source='y'):
            taken.append((source, stamp_ns, list(y), tag['good']))
            return add_measurement(stamp_ns, y, now_ns, arrival_ns, source)
        observer.stream.add_measurement = recorded
        with executor_with(context, observer, driver) as executor:
            assert spin_until(executor, lambda: all(
                publisher.get_subscription_count() > 0 for publisher in publishers.values())
                and driver.count_publishers('x_hat') > 0, 10.0)
            clock = observer.get_clock()
            campaign = {'examples': 0, 'bad': 0}

            @CAMPAIGN
            @given(st.data())
            def example(data):
                observer.stream.reset()
                estimates.clear()
                taken.clear()
                before = observer.stream.source_report()
                drops_before = {name: dict(observer.source_drops[name]) for name in SOURCES}
                expected = {}
                last = {}
                for index in range(3):
                    # The stamped sources share this stamp; the unstamped ones are stamped
                    # on arrival by the node, later: their stamps interleave in time.
                    stamp = clock.now().nanoseconds
                    for name in SOURCES:
                        for _ in range(data.draw(st.integers(0, 1))):
                            kinds = dict(VALUE_KINDS)
                            if encoders.stamped(name):
                                kinds.update(STAMP_KINDS)
                            kind = data.draw(st.sampled_from(sorted(kinds)))
                            if kind in ('too_old', 'duplicate') and name not in last:
                                continue
                            bad_stamp = {'future': clock.now().nanoseconds + 10 ** 9,
                                         'too_old': stamp - HISTORY_NS - 500_000_000,
                                         'duplicate': last.get(name)}.get(kind, stamp)
                            tag['good'] = False
                            publishers[name].publish(encoders.bad(kind, name, bad_stamp, data))
                            key = (name, kinds[kind])
                            expected[key] = expected.get(key, 0) + 1
                            campaign['bad'] += 1
                            assert spin_until(executor, lambda: counted(
                                observer, before, drops_before, expected), 5.0), expected
                        tag['good'] = True
                        answered = len(estimates)
                        value = data.draw(st.floats(-1.0, 1.0))
                        publishers[name].publish(encoders.good(name, stamp, value))
                        last[name] = stamp
                        assert spin_until(executor, lambda: len(estimates) > answered, 5.0), (
                            name, index, dict(observer.counters()), taken[-3:])
                assert counted(observer, before, drops_before, expected, exactly=True)
                clean = system.make_stream()
                reference = []
                for source, stamp_ns, y, good in taken:
                    if good:
                        reference += clean.add_measurement(stamp_ns, y, source=source)
                got = np.array([list(m.position) for m in estimates])
                assert np.isfinite(got).all()
                assert [stamp_to_ns(m.header.stamp) for m in estimates] == [
                    sample.stamp_ns for sample in reference]
                assert np.array_equal(got, np.array([s.estimate for s in reference]))
                campaign['examples'] += 1

            example()
            assert campaign['examples'] == CAMPAIGN.max_examples and campaign['bad'] > 60


def counted(observer, before, drops_before, expected, exactly=False) -> bool:
    """Whether each source counted its bad messages by reason (at least, or exactly)."""
    report = observer.stream.source_report()
    for (name, reason), count in expected.items():
        if reason == 'malformed':
            got = (observer.source_drops[name].get(reason, 0)
                   - drops_before[name].get(reason, 0))
        else:
            got = report[name].counts.get(reason, 0) - before[name].counts.get(reason, 0)
        if got < count or (exactly and got != count):
            return False
    return True
