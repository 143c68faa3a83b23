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
Measurement sources in the nodes and the bag tools: a wheeled base's JointState, Imu, Pose.

A robot-style bag (``/joint_states``, ``/imu/data``, ``/mocap/pose`` 50 ms late, ``/cmd_vel``
as ``geometry_msgs/Twist``, laid out as ``ros2 bag record`` does) goes through ``replay``
and, with ``play_bag``, through the unchanged observer node: the same estimates, bit for
bit. Over DDS: one measurement stamped 0.9 s early does not silence the genuine ones.
"""

import math

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosbags.rosbag2 import Writer
from sensor_msgs.msg import JointState

from bag_support import serialize, STORAGES, TYPES, TYPESTORE
from conftest import CONFIG_DIR
from observer_ros.bags.replay import replay_bag
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.simulation import PlantSimulator
from observer_ros.nodes.observer import ObserverNode
from observer_ros.ros.messages import ns_to_stamp, stamp_to_ns
from ros_support import executor_with, ros_context, spin_until

CONFIG = CONFIG_DIR / 'wheeled_base_sources.yaml'
TOPICS = ('/joint_states', '/imu/data', '/mocap/pose', '/cmd_vel')
START_NS = 1_700_000_000 * 10**9
PERIOD_NS = 10_000_000
MOCAP_LATENCY_NS = 50_000_000


def _header(stamp_ns, frame_id):
    stamp = TYPES['builtin_interfaces/msg/Time'](sec=int(stamp_ns // 10**9),
                                                 nanosec=int(stamp_ns % 10**9))
    return TYPES['std_msgs/msg/Header'](stamp=stamp, frame_id=frame_id)


def _vector(x=0.0, y=0.0, z=0.0):
    return TYPES['geometry_msgs/msg/Vector3'](x=x, y=y, z=z)


def write_wheeled_bag(path, samples=120, storage='mcap'):
    """
    Record a simulated base as ``ros2 bag record`` of the four topics of :data:`TOPICS` does.

    Wheels at 100 Hz and the IMU at 50 Hz on the same stamps, the motion capture at 20 Hz
    stamped 50 ms after its sample was taken (and logged then, after the wheel samples of
    those 50 ms), the commands unstamped, logged just before the sample they act from.
    Returns the true states at each 10 ms sample.
    """
    system = validate_parameters(load_parameter_file(str(CONFIG)))
    plant = PlantSimulator(system.model, initial_state=[0.0, 0.0, 0.0, 0.0])
    rng = np.random.default_rng(17)
    truth, pending = [], []
    zeros9 = np.zeros(9)
    with Writer(path, version=9, storage_plugin=STORAGES[storage]) as writer:
        add = {topic: writer.add_connection(topic, msgtype, typestore=TYPESTORE)
               for topic, msgtype in zip(TOPICS, (
                   'sensor_msgs/msg/JointState', 'sensor_msgs/msg/Imu',
                   'geometry_msgs/msg/PoseStamped', 'geometry_msgs/msg/Twist'))}
        for index in range(samples):
            stamp = START_NS + index * PERIOD_NS
            u = np.array([0.5 + 0.3 * math.sin(index / 15), 0.4 * math.cos(index / 20)])
            command = TYPES['geometry_msgs/msg/Twist'](linear=_vector(x=u[0]),
                                                       angular=_vector(z=u[1]))
            writer.write(add['/cmd_vel'], stamp - 1000, serialize(command))
            y = plant.measure() + rng.normal(0.0, 1e-3, size=5)
            truth.append(plant.x.copy())
            joints = TYPES['sensor_msgs/msg/JointState'](
                header=_header(stamp, ''),
                name=['left_wheel_joint', 'right_wheel_joint', 'caster_joint'],
                position=np.array([0.1 * index, 0.2 * index, 0.0]),
                velocity=np.array([y[0], y[1], 0.0]), effort=np.zeros(0))
            writer.write(add['/joint_states'], stamp, serialize(joints))
            if index % 2 == 0:
                writer.write(add['/imu/data'], stamp, serialize(TYPES['sensor_msgs/msg/Imu'](
                    header=_header(stamp, 'imu_link'),
                    orientation=TYPES['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0,
                                                                      w=1.0),
                    orientation_covariance=zeros9, angular_velocity=_vector(z=y[2]),
                    angular_velocity_covariance=zeros9, linear_acceleration=_vector(),
                    linear_acceleration_covariance=zeros9)))
            if index % 5 == 0:
                pending.append((stamp + MOCAP_LATENCY_NS, y[3], y[4]))
            while pending and pending[0][0] <= stamp:
                taken, x, yaw = pending.pop(0)
                pose = TYPES['geometry_msgs/msg/Pose'](
                    position=TYPES['geometry_msgs/msg/Point'](x=x, y=0.0, z=0.0),
                    orientation=TYPES['geometry_msgs/msg/Quaternion'](
                        x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)))
                writer.write(add['/mocap/pose'], taken + 500_000, serialize(
                    TYPES['geometry_msgs/msg/PoseStamped'](header=_header(taken, 'world'),
                                                           pose=pose)))
            plant.step(u, PERIOD_NS / 1e9)
    return np.array(truth)


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_a_robot_bag_of_three_sensors_replays_with_late_poses(tmp_path, storage):
    bag = tmp_path / 'base'
    truth = write_wheeled_bag(bag, storage=storage)
    result = replay_bag(bag, CONFIG, u_topic='/cmd_vel')
    counters = result.counters
    # One estimate per wheel sample; the IMU sample of a wheel stamp joins its update, and
    # each pose, 50 ms late, is inserted in stamp order (the corrected newest returned).
    assert counters['reruns'] >= 60 + 20 and counters.get('too_old', 0) == 0
    assert counters.get('out_of_order', 0) == 0 and counters.get('malformed', 0) == 0
    assert np.all(np.isfinite(result.estimates))
    last = result.stamps_ns == result.stamps_ns[-1]
    error = np.abs(result.estimates[last][-1] - truth[-1])
    assert np.all(error < [0.01, 0.01, 0.05, 0.05]), error


def test_the_live_node_fed_by_play_bag_equals_the_replay(tmp_path):
    from observer_ros.ros.recorder import TopicRecorder
    from ros_support import NodeProcess
    bag = tmp_path / 'base'
    write_wheeled_bag(bag, samples=80)
    offline = replay_bag(bag, CONFIG, u_topic='/cmd_vel')
    calls = []  # what the node gave its stream, in order
    with ros_context('--params-file', str(CONFIG), '-p', 'use_sim_time:=true',
                     '-r', 'u:=/cmd_vel') as context:
        observer = ObserverNode(context=context)
        stream = observer.stream
        add_input, add_measurement = stream.add_input, stream.add_measurement

        def recorded_input(stamp_ns, u, *args):
            calls.append(('u', stamp_ns, np.array(u, dtype=float)))
            return add_input(stamp_ns, u, *args)

        def recorded_measurement(stamp_ns, y, now_ns=None, arrival_ns=0, source='y'):
            calls.append((source, stamp_ns, np.array(y, dtype=float)))
            return add_measurement(stamp_ns, y, now_ns, arrival_ns, source)
        stream.add_input, stream.add_measurement = recorded_input, recorded_measurement
        recorder = TopicRecorder(observer.system, ['x_hat'], context=context)
        with executor_with(context, observer, recorder) as executor:
            player = NodeProcess('play_bag', str(bag), '--paced-by', 'x_hat', '--trigger',
                                 *TOPICS[:3])
            finished = spin_until(executor, lambda: player.process.poll() is not None, 90.0)
            code, out, err = player.stop()
            assert finished and code == 0, err
            spin_until(executor, lambda: recorder.count('x_hat') >= len(offline.stamps_ns),
                       5.0)
            stamps, estimates = recorder.arrays('x_hat')
    # Each measurement waited for its answer: one x_hat per source message, at the replay's
    # stamps, the values exactly what the stream gives for what the node was given.
    assert f'{len(offline.stamps_ns)} answered, 0 unanswered' in out
    assert np.array_equal(stamps, offline.stamps_ns)
    clean = offline.system.make_stream()
    expected = []
    for source, stamp, values in calls:
        expected += (clean.add_input(stamp, values) if source == 'u'
                     else clean.add_measurement(stamp, values, source=source))
    assert np.array_equal(estimates, np.array([sample.estimate for sample in expected]))
    # The node stamps the unstamped Twist commands with /clock at their arrival: their log
    # times when it keeps up (on a loaded machine a command may be taken after a later
    # /clock), and then its estimates are the offline replay's bit for bit.
    given = [stamp for source, stamp, _ in calls if source == 'u']
    assert len(given) == len(offline.inputs.log_times_ns)
    assert np.all(np.array(given) >= offline.inputs.log_times_ns)
    if np.array_equal(given, offline.inputs.log_times_ns):
        assert np.array_equal(estimates, offline.estimates)


BASE = {'model.A': [0.0, 1.0, 0.0, 0.0], 'model.B': [0.0, 1.0], 'model.C': [1.0, 0.0, 0.0, 1.0],
        'model.output_names': ['camera_x', 'wheel_v'], 'observer.type': 'kalman',
        'observer.time_varying': True, 'observer.process_noise': [0.0, 1.0],
        'observer.history': 0.2, 'observer.sources': ['wheels', 'camera'],
        'sources.wheels.fields': ['velocity.wheel'], 'sources.wheels.outputs': ['wheel_v'],
        'sources.wheels.measurement_noise': [1e-2],
        'sources.camera.type': 'pose_stamped', 'sources.camera.fields': ['pose.position.x'],
        'sources.camera.outputs': ['camera_x'], 'sources.camera.measurement_noise': [1e-4],
        'sources.camera.latency': 0.05}
FULL_ORDER = {'observer.type': 'full_order', 'observer.poles': ['-3', '-4'],
              'observer.process_noise': [], 'sources.wheels.measurement_noise': [],
              'sources.camera.measurement_noise': []}


@pytest.mark.parametrize('change, message', [
    ({'sources.camera.fields': ['pose.position.w']}, "sources.camera.fields: 'pose.position.w' "
     'is no field of geometry_msgs/msg/PoseStamped; it has pose.position.x, pose.position.y'),
    ({'sources.imu.fields': ['angular_velocity.z']}, "sources.imu.fields: 'imu' is no "
     "measurement source: observer.sources names ['wheels', 'camera']"),
    ({'sources.camera.gain': [1.0]}, "sources.camera.gain: unknown setting 'gain'"),
    ({'sources.camera.outputs': ['wheel_v']}, 'sources.camera.outputs: output wheel_v is '
     "carried by sources 'wheels' and 'camera'"),
    ({'sources.camera.outputs': []}, 'sources.camera.outputs: expected 1 outputs'),
    ({'observer.sources': ['wheels']}, "sources.camera.type: 'camera' is no measurement "
     "source: observer.sources names ['wheels']"),
    ({'sources.camera.latency': 0.3}, "observer.history: source 'camera' has a latency "
     'of 0.3 s, longer than the history'),
    ({'sources.camera.timeout': 0.001}, 'sources.camera.timeout: expected 0 (never stale) or '
     'more than one sample period'),
    ({'sources.wheels.measurement_noise': []}, 'sources.wheels.measurement_noise: expected '
     'the block of R of every source'),
    ({'observer.history': 2.0}, 'observer.history: expected 0 ... 1 s (the gap limit'),
    ({**FULL_ORDER}, "observer.sources: source 'wheels' (outputs ['wheel_v']) alone: (A, C) "
     'of these outputs is not observable: the modes 0 cannot be seen'),
    ({'observer.type': 'reduced_order', 'observer.process_noise': [], 'observer.poles': ['-5'],
      'model.A': [0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0], 'model.B': [0.0, 0.0, 1.0],
      'model.C': [1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 'sources.wheels.measurement_noise': [],
      'sources.camera.measurement_noise': []},
     'observer.sources: this observer needs every output at each update'),
])
def test_a_bad_source_configuration_is_refused_naming_the_parameter(change, message):
    with pytest.raises(ConfigError) as raised:
        validate_parameters({**BASE, **change}, strict=True)
    assert str(raised.value).startswith(message), str(raised.value)


def test_a_predict_only_source_is_taken_and_the_sources_make_the_stream():
    system = validate_parameters({**BASE, **FULL_ORDER, 'sources.wheels.predict_only': True})
    stream = system.make_stream()
    assert [source.name for source in stream.engine.measurement_sources] == ['wheels', 'camera']
    assert stream.engine.history_ns == 200_000_000
    kalman = validate_parameters(BASE)
    assert np.array_equal(kalman.observer.design.measurement_noise, np.diag([1e-4, 1e-2]))


def test_the_node_declares_each_sources_parameters_and_refuses_an_unknown_source():
    parameters = [Parameter(name, value=value) for name, value in BASE.items()]
    with ros_context() as context:
        node = ObserverNode(context=context, parameter_overrides=parameters)
        try:
            assert node.get_parameter('sources.camera.latency').value == 0.05
            assert node.get_parameter('sources.wheels.topic').value == ''
            assert set(node.sources) == {'wheels', 'camera'}
        finally:
            node.destroy_node()
        with pytest.raises(ConfigError, match="sources.imu.topic: 'imu' is no measurement"):
            ObserverNode(context=context, parameter_overrides=parameters + [
                Parameter('sources.imu.topic', value='/imu')])


#: Seconds the early outlier is stamped ahead of the plant's samples (the issue's 0.9 s).
OUTLIER_AHEAD_NS = 900_000_000


@pytest.mark.parametrize('history', [1.0, 0.0])
def test_an_early_stamped_outlier_does_not_silence_the_genuine_samples(history):
    # One y, stamped 0.9 s ahead of the samples (inside the clock tolerance), then the
    # genuine samples: with observer.history 1 s each is inserted before it in stamp order
    # and answered with the corrected estimate at the outlier's stamp; once the stamps pass
    # it, estimates in order again. None is dropped, nothing non-finite is published.
    # Without a history (the default) the same: the state before the jump ahead is kept.
    config = CONFIG_DIR / 'seed003_full_order.yaml'
    with ros_context('--params-file', str(config)) as context:
        observer = ObserverNode(context=context, parameter_overrides=[
            Parameter('observer.history', value=history),
            Parameter('observer.max_gap', value=1.0),
            Parameter('observer.clock_tolerance', value=2.0)])
        driver = Node('outlier_driver', context=context)
        y = driver.create_publisher(JointState, 'y', 100)
        u = driver.create_publisher(JointState, 'u', 100)
        received = []
        driver.create_subscription(JointState, 'x_hat', lambda m: received.append(
            (stamp_to_ns(m.header.stamp), list(m.position))), 1000)
        names = observer.system.model
        with executor_with(context, observer, driver) as executor:
            assert spin_until(executor, lambda: y.get_subscription_count() > 0
                              and u.get_subscription_count() > 0
                              and driver.count_publishers('x_hat') > 0, 10.0)
            start = observer.get_clock().now().nanoseconds

            def send(stamp, value):
                command = JointState(name=list(names.input_names), position=[0.0])
                ns_to_stamp(command.header.stamp, stamp)
                u.publish(command)
                message = JointState(name=list(names.output_names), position=[value])
                ns_to_stamp(message.header.stamp, stamp)
                y.publish(message)

            period = 20_000_000
            count = 0
            for k in range(5):
                send(start + k * period, 0.1 * k)
                count += 1
            assert spin_until(executor, lambda: len(received) >= 5, 10.0)
            outlier = start + 4 * period + OUTLIER_AHEAD_NS
            message = JointState(name=list(names.output_names), position=[0.5])
            ns_to_stamp(message.header.stamp, outlier)
            y.publish(message)
            assert spin_until(executor, lambda: len(received) >= 6, 10.0)
            for k in range(5, 60):  # 1.1 s of genuine samples, past the outlier's stamp
                # (each answered at least once: an input stamped before the outlier's stamp
                # re-runs the outlier's row as well, and the corrected estimate goes out)
                send(start + k * period, 0.1 * k)
                assert spin_until(executor, lambda: len(received) >= k + 2, 10.0), k
            last = start + 59 * period
            assert spin_until(executor, lambda: received[-1][0] == last, 10.0)
            counters = observer.stream.counters
    # The genuine sample stamped as the outlier is the only one dropped (same source, same
    # stamp); the inputs stamped before the outlier re-run its row too.
    assert counters['out_of_order'] == 0 and counters['too_old'] == 0
    assert counters['duplicate'] == 1 and counters['reruns'] >= 40
    stamps = [stamp for stamp, _ in received]
    # While the genuine stamps are before the outlier's, each answer is stamped with it.
    meanwhile = [stamp for stamp in stamps[6:] if stamp == outlier]
    assert len(meanwhile) >= 40
    assert stamps[-10:] == [start + k * period for k in range(50, 60)] and all(
        math.isfinite(value) for _, values in received for value in values)


def test_the_sources_status_reports_each_source_and_a_stale_one_warns():
    from geometry_msgs.msg import PoseStamped
    from observer_ros.nodes.main import node_class
    ObserverLifecycleNode = node_class('observer_lifecycle')
    from ros_support import DiagnosticsListener
    settings = {**BASE, 'diagnostics.period': 0.1, 'sources.camera.timeout': 0.3,
                'sources.wheels.topic': 'joint_states', 'sources.camera.topic': 'pose',
                'autostart': True}
    parameters = [Parameter(name, value=value) for name, value in settings.items()]
    with ros_context() as context:
        # The managed twin: the same wiring, made on configure (autostart).
        observer = ObserverLifecycleNode(context=context, parameter_overrides=parameters)
        listener = DiagnosticsListener(context=context)
        driver = Node('sources_driver', context=context)
        wheels = driver.create_publisher(JointState, 'joint_states', 10)
        camera = driver.create_publisher(PoseStamped, 'pose', 10)
        estimates = []
        driver.create_subscription(JointState, 'x_hat', estimates.append, 100)
        name = '/observer: sources'
        with executor_with(context, observer, listener, driver) as executor:
            assert spin_until(executor, lambda: wheels.get_subscription_count() > 0
                              and camera.get_subscription_count() > 0
                              and driver.count_publishers('x_hat') > 0, 10.0)
            start = observer.get_clock().now().nanoseconds
            for k in range(10):
                stamp = start + k * 10_000_000
                message = JointState(name=['wheel'], velocity=[0.5], position=[0.0])
                ns_to_stamp(message.header.stamp, stamp)
                wheels.publish(message)
                assert spin_until(executor, lambda: len(estimates) > k, 5.0)
            pose = PoseStamped()
            ns_to_stamp(pose.header.stamp, start + 30_000_000)  # 50 ms latency: at -20 ms
            pose.pose.position.x = 0.01
            camera.publish(pose)
            assert spin_until(executor, lambda: len(estimates) > 10, 5.0)
            # Taken 20 ms before the first wheel sample: inserted before it, every wheel
            # sample taken again.
            assert spin_until(executor, lambda: (listener.latest(name) or (0, 0, {}))[2].get(
                'camera.reruns') == '1', 5.0)
            ns_to_stamp(pose.header.stamp, start - 250_000_000)  # 0.34 s before the newest
            camera.publish(pose)
            assert spin_until(executor, lambda: listener.latest(name)[2].get(
                'camera.too_old') == '1', 5.0)
            level, message, values = listener.latest(name)
            assert values['wheels.received'] == '10' and values['wheels.used'] == '10'
            assert values['camera.received'] == '2' and values['camera.max_lag_s'] == '0.11'
            assert int(values['history.entries']) >= 10
            # No camera sample for its timeout (0.3 s): the source is stale, the status warns.
            assert spin_until(executor, lambda: listener.level_is(
                name, 'WARN', text='source camera stale'), 5.0)
            # The corrected newest estimate was published with the newest stamp again.
            assert estimates[10].header.stamp == estimates[9].header.stamp


def test_the_replay_command_takes_a_configuration_of_sources(tmp_path, capsys):
    from observer_ros.tools.replay import main as replay_main
    bag = tmp_path / 'base'
    write_wheeled_bag(bag, samples=40)
    csv = tmp_path / 'estimates.csv'
    assert replay_main([str(bag), str(CONFIG), '--u-topic', '/cmd_vel', '--csv', str(csv)]) == 0
    out = capsys.readouterr().out
    # 40 wheel, 20 IMU and 7 pose samples; one estimate each (new, or corrected).
    assert 'replayed 67 measurements into 67 estimates' in out and 'too_old' not in out
    assert len(csv.read_text().splitlines()) == 68
