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

"""Online replay: ``play_bag`` publishes a bag to the unchanged observer node (sim time)."""

import importlib.util
import subprocess
import sys

import numpy as np
import pytest
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_types_from_msg, get_typestore, Stores
from sensor_msgs.msg import JointState

from bag_support import (JOINT_STATE, joint_state, robot_parameters, ROBOT_TOPICS, serialize,
                         TYPESTORE, write_robot_bag)
from conftest import CONFIG_DIR, console_script
from observer_ros.bags.reading import read_topic
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.storage import BagError, Playback
from observer_ros.bags.storage import playback_class
from observer_ros.nodes.bag_player import main as player_main
from observer_ros.nodes.observer import ObserverNode
from observer_ros.ros.recorder import TopicRecorder
from ros_support import executor_with, NodeProcess, ros_context, run_lockstep, spin_until


def play_through_observer(bag, params, expected: int, *player_args, remap=(), parameters=(),
                          inputs=None):
    """
    Run ``play_bag BAG *player_args`` against an in-process observer node with sim time.

    Return the observer's ``x_hat`` (stamps, values), the player's stdout and the observer's
    clock at the end (ns). ``inputs``, a list, receives ``(stamp ns, values)`` of each input
    as the node stamped it.
    """
    ros_args = ['--params-file', str(params), '-p', 'use_sim_time:=true']
    for rule in remap:
        ros_args += ['-r', rule]
    for assignment in parameters:
        ros_args += ['-p', assignment]
    with ros_context(*ros_args) as context:
        observer = ObserverNode(context=context)
        if inputs is not None:
            add_input = observer.stream.add_input

            def recorded_input(stamp_ns, u, *args, **kwargs):
                inputs.append((stamp_ns, np.array(u, dtype=float)))
                return add_input(stamp_ns, u, *args, **kwargs)
            observer.stream.add_input = recorded_input
        recorder = TopicRecorder(observer.system, ['x_hat'], context=context)
        with executor_with(context, observer, recorder) as executor:
            player = NodeProcess('play_bag', str(bag), *player_args)
            finished = spin_until(executor, lambda: player.process.poll() is not None, 90.0)
            code, out, err = player.stop()
            assert finished and code == 0, err
            spin_until(executor, lambda: recorder.count('x_hat') >= expected, 5.0)
            return recorder.arrays('x_hat'), out, observer.get_clock().now().nanoseconds


@pytest.mark.parametrize('storage', ['mcap', 'sqlite3'])
def test_online_play_equals_offline_replay_and_the_recorded_run(tmp_path, storage):
    bag = tmp_path / 'run'
    config = CONFIG_DIR / 'seed001_fourth_order_chen.yaml'
    _, _, online, _ = run_lockstep(config.name, samples=150, bag=bag, storage=storage)
    offline = replay_bag(bag, config)
    assert np.array_equal(offline.estimates, online['x_hat'][1])
    (stamps, estimates), out, clock = play_through_observer(
        bag, config, len(offline.stamps_ns), '--topics', '/y', '/u', '--paced-by', 'x_hat')
    # The unchanged node, fed by the player, publishes the offline replay's x_hat exactly.
    assert np.array_equal(stamps, offline.stamps_ns)
    assert np.array_equal(estimates, offline.estimates)
    assert 'played 300 messages (/u 150, /y 150)' in out and '150 answered, 0 unanswered' in out
    # /clock followed the bag's log time (at least to the last measurement's).
    assert clock >= offline.outputs.log_times_ns[-1]


def test_robot_bag_at_recorded_timing_with_unstamped_commands(tmp_path):
    bag = tmp_path / 'robot'
    truth = write_robot_bag(bag, samples=150)
    params = robot_parameters(tmp_path)
    offline = replay_bag(bag, params, *ROBOT_TOPICS)
    # Recorded timing, twice as fast. The node stamps the Float64MultiArray commands on
    # arrival with /clock; a node that lags behind reads a later /clock (rclpy keeps only the
    # newest), so the estimates are the offline replay's only where it kept up. On a loaded
    # machine it lags by many samples: the estimates are then exactly what the estimator
    # gives for the stamps the node gave the commands.
    # The player does not wait for the node here, so the node's queues hold the whole bag:
    # on a loaded machine the default depth of 10 loses messages before the node takes them.
    deep = [f'qos_overrides.{topic}.subscription.depth:=1000' for topic in ROBOT_TOPICS]
    inputs = []
    (stamps, estimates), out, clock = play_through_observer(
        bag, params, len(truth), '--rate', '2', '--wait-for', *ROBOT_TOPICS,
        remap=[f'y:={ROBOT_TOPICS[0]}', f'u:={ROBOT_TOPICS[1]}'], parameters=deep,
        inputs=inputs)
    assert 'played 300 messages' in out and 'covering 1.490 s of bag time' in out
    assert np.array_equal(stamps, offline.stamps_ns)
    assert clock == offline.outputs.log_times_ns[-1]
    assert np.array_equal(estimates[0], offline.estimates[0])
    # Every command, stamped with the /clock at its arrival: never before its log time.
    commands = offline.inputs
    assert len(inputs) == len(commands.log_times_ns)
    assert all(np.array_equal(u, values) for (_, u), values in zip(inputs, commands.values))
    given = np.array([stamp for stamp, _ in inputs])
    assert np.all(given >= commands.log_times_ns) and np.all(np.diff(given) >= 0)
    np.testing.assert_array_equal(estimates, estimates_for(offline, given))
    np.testing.assert_array_equal(estimates_for(offline, commands.log_times_ns),
                                  offline.estimates)
    if np.array_equal(given, commands.log_times_ns):  # it kept up with every command
        np.testing.assert_array_equal(estimates, offline.estimates)


def estimates_for(offline, input_stamps):
    """Return the estimates of ``offline``'s bag with its inputs stamped ``input_stamps``."""
    stream = offline.system.make_stream()
    events = [(stamp, 0, u) for stamp, u in zip(input_stamps, offline.inputs.values)]
    outputs = offline.outputs
    events += [(stamp, 1, y) for stamp, y in zip(outputs.stamps_ns, outputs.values)]
    samples = []
    for stamp, kind, values in sorted(events, key=lambda event: event[:2]):
        samples += (stream.add_measurement if kind else stream.add_input)(int(stamp), values)
    samples += stream.flush()
    return np.array([sample.estimate for sample in samples])


def test_robot_bag_paced_through_a_remapped_observer(tmp_path):
    # Paced, the node never lags: each command is stamped between its log time and the
    # next measurement's, which pairs it exactly as the offline replay does.
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=100, storage='sqlite3')
    params = robot_parameters(tmp_path)
    offline = replay_bag(bag, params, *ROBOT_TOPICS)
    (stamps, estimates), out, _ = play_through_observer(
        bag, params, 100, '--paced-by', '/x_hat', '--trigger', ROBOT_TOPICS[0],
        remap=[f'y:={ROBOT_TOPICS[0]}', f'u:={ROBOT_TOPICS[1]}'])
    assert '100 answered, 0 unanswered' in out
    assert np.array_equal(stamps, offline.stamps_ns)
    assert np.array_equal(estimates, offline.estimates)


def run_player(*args, timeout=60):
    """Run ``play_bag`` to completion; return the CompletedProcess."""
    return subprocess.run([console_script('play_bag'), *map(str, args)], capture_output=True,
                          text=True, timeout=timeout)


def player_in_process(capsys, *args):
    """
    Run ``play_bag``'s ``main`` in this process; return it as a CompletedProcess.

    What the player checks and says is the same as in a process of its own, without the
    seconds of imports each new process costs (:func:`run_player` keeps that path tested).
    """
    try:
        code = player_main(['play_bag', *map(str, args)])
    except SystemExit as e:  # argparse's errors
        code = e.code
    captured = capsys.readouterr()
    return subprocess.CompletedProcess(args, code, captured.out, captured.err)


def one_error_line(result, *fragments):
    """Assert exit status 2 and one ``play_bag: error:`` line holding every fragment."""
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('play_bag: error: '), lines
    for fragment in fragments:
        assert fragment in lines[0], lines[0]


def test_player_errors_name_the_bag_and_topic(tmp_path, capsys):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=20)
    one_error_line(run_player(bag, '--topics', '/y'), 'no topic /y', '/joint_states (sensor')

    def player(*args):
        return player_in_process(capsys, *args)
    one_error_line(player(bag, '--exclude', *ROBOT_TOPICS), 'nothing to play')
    one_error_line(player(tmp_path / 'missing'), 'not a readable rosbag2 bag')
    one_error_line(player(bag, '--paced-by', 'x_hat'),
                   '--trigger: /y is not among the played topics')
    one_error_line(player(bag, '--paced-by', '/joint_states', '--trigger',
                          '/effort_controller/commands'), 'also played from the bag')
    one_error_line(player(bag, '--rate', '0'), '--rate: expected a positive factor')
    # Paced, with no node under test: a clear error after --wait, not a hang.
    one_error_line(player(bag, '--paced-by', 'x_hat', '--trigger', '/joint_states',
                          '--wait', '1'), 'nobody subscribed to /joint_states')
    one_error_line(player(bag, '--wait-for', '/y'), '--wait-for: /y not among the played')
    with pytest.raises(BagError, match='foo_msgs/msg/Bar is not installed here'):
        playback_class('foo_msgs/msg/Bar', '/t')


def test_player_refuses_a_bag_shorter_than_its_metadata(tmp_path):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=20, storage='sqlite3')
    metadata = bag / 'metadata.yaml'
    metadata.write_text(metadata.read_text().replace('message_count: 20', 'message_count: 35',
                                                     1))
    one_error_line(run_player(bag, '--rate', '100', '--wait', '0'),
                   'fewer messages than the metadata counts', ': 20 of 35')


def test_playback_lists_topics_and_counts(tmp_path):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=20)
    playback = Playback(bag, exclude=[ROBOT_TOPICS[1]])
    try:
        assert playback.topics == {'/joint_states': ('sensor_msgs/msg/JointState', 20)}
        messages = list(playback.messages())
    finally:
        playback.close()
    assert [m[0] for m in messages] == ['/joint_states'] * 20
    assert [m[1] for m in messages] == sorted(m[1] for m in messages)
    recorded = read_topic(bag, '/joint_states', 'joint_state', 'position', ['elbow'])
    assert np.array_equal([m[1] for m in messages], recorded.log_times_ns)


#: The robot's topics as recorded without the leading slash.
RELATIVE_TOPICS = tuple(topic.lstrip('/') for topic in ROBOT_TOPICS)


def test_topics_recorded_without_a_slash_are_selected_paced_and_awaited(tmp_path):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=60, topics=RELATIVE_TOPICS)
    params = robot_parameters(tmp_path)
    offline = replay_bag(bag, params, *RELATIVE_TOPICS)
    (stamps, estimates), out, _ = play_through_observer(
        bag, params, 60, '--topics', *RELATIVE_TOPICS, '--wait-for', ROBOT_TOPICS[1],
        '--paced-by', 'x_hat', '--trigger', RELATIVE_TOPICS[0],
        remap=[f'y:={ROBOT_TOPICS[0]}', f'u:={ROBOT_TOPICS[1]}'])
    assert '60 answered, 0 unanswered' in out
    assert 'played 120 messages (/effort_controller/commands 60, /joint_states 60)' in out
    assert np.array_equal(stamps, offline.stamps_ns)
    assert np.array_equal(estimates, offline.estimates)


def test_exclude_refuses_a_topic_the_bag_does_not_have(tmp_path, capsys):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=10, topics=RELATIVE_TOPICS)

    def player(*args):
        return player_in_process(capsys, *args)
    one_error_line(player(bag, '--exclude', 'x_hatt', '--wait', '0'),
                   '--exclude: ', 'has no topic x_hatt', 'the bag has joint_states (sensor_msgs'
                   '/msg/JointState), effort_controller/commands (std_msgs')
    one_error_line(player(bag, '--exclude', *RELATIVE_TOPICS), 'nothing to play')
    # Excluded by either spelling: only the commands are played.
    played = run_player(bag, '--exclude', ROBOT_TOPICS[0], '--rate', '100', '--wait', '0')
    assert played.returncode == 0, played.stderr
    assert 'played 10 messages (/effort_controller/commands 10)' in played.stdout
    one_error_line(player(bag, '--paced-by', 'x_hat', '--trigger', 'y'),
                   '--trigger: /y is not among the played topics (effort_controller/commands, '
                   'joint_states)')


def test_every_missing_message_type_is_named_at_once(tmp_path, capsys):
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg('float64 x', 'foo_msgs/msg/Bar'))
    store.register(get_types_from_msg('float64 y', 'baz_msgs/msg/Qux'))
    bag = tmp_path / 'foreign'
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        bars = writer.add_connection('/a', 'foo_msgs/msg/Bar', typestore=store)
        quxes = writer.add_connection('b', 'baz_msgs/msg/Qux', typestore=store)
        joints = writer.add_connection('/joint_states', JOINT_STATE, typestore=TYPESTORE)
        for index in range(5):
            writer.write(bars, index, bytes(store.serialize_cdr(
                store.types['foo_msgs/msg/Bar'](x=1.0), 'foo_msgs/msg/Bar')))
            writer.write(quxes, index, bytes(store.serialize_cdr(
                store.types['baz_msgs/msg/Qux'](y=1.0), 'baz_msgs/msg/Qux')))
            writer.write(joints, index, serialize(joint_state(index + 1, ['a'], [1.0])))
    one_error_line(player_in_process(capsys, bag, '--wait', '0'),
                   'message types not installed here: /a (foo_msgs/msg/Bar), b '
                   '(baz_msgs/msg/Qux); leave them out with --exclude /a b')
    played = run_player(bag, '--exclude', '/a', 'b', '--rate', '100', '--wait', '0')
    assert played.returncode == 0, played.stderr
    assert 'played 5 messages (/joint_states 5)' in played.stdout


@pytest.fixture(params=['as installed', 'test_msgs installed'])
def installed_types(request, tmp_path, monkeypatch):
    """Run as installed here, and once more with a ``test_msgs`` (a stand-in if absent)."""
    stand_in = (request.param == 'test_msgs installed'
                and importlib.util.find_spec('test_msgs') is None)
    if stand_in:
        package = tmp_path / 'test_msgs' / 'msg'
        package.mkdir(parents=True)
        (package.parent / '__init__.py').write_text('')
        (package / '__init__.py').write_text('class BasicTypes:\n    """Stand-in."""\n')
        monkeypatch.syspath_prepend(str(tmp_path))
    yield
    if stand_in:
        for name in ('test_msgs.msg', 'test_msgs'):
            sys.modules.pop(name, None)


def test_message_types_without_msg_resolve(installed_types):
    assert playback_class('sensor_msgs/JointState', '/t') is JointState
    assert playback_class('sensor_msgs/msg/JointState', '/t') is JointState
    assert playback_class('std_srvs/srv/Trigger_Event', '/t/_service_event').__name__ == (
        'Trigger_Event')
    # A type whose package is surely not installed, in the older pkg/Name spelling too:
    # refused, saying which and how to play without it.
    absent = 'observer_ros_absent_msgs'
    assert importlib.util.find_spec(absent) is None
    for msgtype in (f'{absent}/BasicTypes', f'{absent}/msg/BasicTypes'):
        with pytest.raises(BagError, match=f'topic topic1: message type {msgtype} is not '
                                           f'installed here; leave it out with --exclude '
                                           f'topic1'):
            playback_class(msgtype, 'topic1')
    # rosbag2's own test bags hold test_msgs/BasicTypes (before, this test assumed that
    # package absent and failed where it is installed): it resolves where it is, like any
    # type, and is refused where it is not.
    if importlib.util.find_spec('test_msgs') is not None:
        assert playback_class('test_msgs/BasicTypes', 'topic1') is (
            importlib.import_module('test_msgs.msg').BasicTypes)
    else:
        with pytest.raises(BagError, match='test_msgs/BasicTypes is not installed here'):
            playback_class('test_msgs/BasicTypes', 'topic1')
