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

"""Bags laid out by other tools: names without a slash, old metadata, lone storage files."""

import shutil
import sqlite3

import numpy as np
import pytest
import yaml

from bag_support import robot_parameters, ROBOT_TOPICS, write_robot_bag
from observer_ros.bags.reading import read_topic
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.storage import BagError, Playback

#: The robot's topics as a tool that records names without the leading slash writes them.
RELATIVE_TOPICS = tuple(topic.lstrip('/') for topic in ROBOT_TOPICS)

STORAGES = ['mcap', 'sqlite3']


def joints(bag):
    """Read the measured joint of a robot bag."""
    return read_topic(bag, ROBOT_TOPICS[0], 'joint_state', 'position', ['elbow'])


def assert_same(data, expected):
    """Two reads of a topic are equal."""
    assert np.array_equal(data.stamps_ns, expected.stamps_ns)
    assert np.array_equal(data.log_times_ns, expected.log_times_ns)
    assert np.array_equal(data.values, expected.values)


def edit_metadata(bag, change):
    """Rewrite ``bag/metadata.yaml`` through ``change(information)``."""
    path = bag / 'metadata.yaml'
    document = yaml.safe_load(path.read_text())
    change(document['rosbag2_bagfile_information'])
    path.write_text(yaml.safe_dump(document))


def storage_file(bag):
    """Return the one storage file of a bag written by rosbags."""
    (file,) = [p for p in bag.iterdir() if p.suffix in ('.mcap', '.db3')]
    return file


@pytest.mark.parametrize('storage', STORAGES)
def test_topics_recorded_without_a_slash_are_the_slashed_topic(tmp_path, storage):
    bag, reference = tmp_path / 'relative', tmp_path / 'absolute'
    write_robot_bag(bag, samples=40, storage=storage, topics=RELATIVE_TOPICS)
    write_robot_bag(reference, samples=40, storage=storage)
    params = robot_parameters(tmp_path)
    expected = replay_bag(reference, params, *ROBOT_TOPICS)
    for y_topic, u_topic in ((RELATIVE_TOPICS[0], ROBOT_TOPICS[1]),
                             (ROBOT_TOPICS[0], RELATIVE_TOPICS[1])):
        result = replay_bag(bag, params, y_topic, u_topic)
        assert np.array_equal(result.stamps_ns, expected.stamps_ns)
        assert np.array_equal(result.estimates, expected.estimates)
    # A missing topic lists the names as the bag has them.
    with pytest.raises(BagError, match=r'no topic /y; the bag has joint_states \(sensor_msgs'):
        replay_bag(bag, params)
    with pytest.raises(BagError, match=r'topic effort_controller/commands holds std_msgs'):
        read_topic(bag, '/effort_controller/commands', 'joint_state', 'position', ['u1'])
    # Played, selected and excluded under either spelling.
    playback = Playback(bag, topics=[ROBOT_TOPICS[0], RELATIVE_TOPICS[1]],
                        exclude=[RELATIVE_TOPICS[1]])
    try:
        assert playback.topics == {'/joint_states': ('sensor_msgs/msg/JointState', 40)}
        assert playback.recorded == {'/joint_states': 'joint_states'}
        assert {topic for topic, _, _ in playback.messages()} == {'/joint_states'}
    finally:
        playback.close()
    playback = Playback(bag, exclude=[ROBOT_TOPICS[0]])
    try:
        assert list(playback.topics) == ['/effort_controller/commands']
    finally:
        playback.close()
    with pytest.raises(BagError, match=r'--exclude: .* has no topic /x_hatt; the bag has '
                                       r'joint_states \(sensor_msgs/msg/JointState\), '
                                       r'effort_controller/commands'):
        Playback(bag, exclude=['/x_hatt'])


@pytest.mark.parametrize('storage', STORAGES)
def test_file_paths_with_the_bag_directory_in_front_are_read(tmp_path, storage):
    # Older rosbag2 (and its reindexer) wrote relative_file_paths as 'bag_name/bag_name_0.db3'.
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=30, storage=storage)
    expected = joints(bag)
    edit_metadata(bag, lambda info: info.update(relative_file_paths=[
        f'old_name/{name}' for name in info['relative_file_paths']]))
    assert_same(joints(bag), expected)
    assert len(replay_bag(bag, robot_parameters(tmp_path), *ROBOT_TOPICS).estimates) == 30


@pytest.mark.parametrize('storage', STORAGES)
def test_a_storage_file_without_metadata_is_read(tmp_path, storage):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=30, storage=storage)
    expected = joints(bag)
    offline = replay_bag(bag, robot_parameters(tmp_path), *ROBOT_TOPICS)
    (bag / 'metadata.yaml').unlink()
    for path in (bag, storage_file(bag)):  # the directory holding it, or the file itself
        assert_same(joints(path), expected)
        result = replay_bag(path, robot_parameters(tmp_path), *ROBOT_TOPICS)
        assert np.array_equal(result.estimates, offline.estimates)
    playback = Playback(bag)
    try:
        assert sorted(playback.topics) == sorted(ROBOT_TOPICS)
        assert len(list(playback.messages())) == 60
    finally:
        playback.close()


def test_metadata_version_1_is_read(tmp_path):
    # ROS 2 Crystal's metadata: topic_and_type, no QoS; rosbags reads version 2 on.
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=30, storage='sqlite3')
    expected = joints(bag)
    version_1 = {'rosbag2_bagfile_information': {
        'version': 1, 'storage_identifier': 'sqlite3',
        'relative_file_paths': [storage_file(bag).name],
        'duration': {'nanoseconds': 290_001_000},
        'starting_time': {'nanoseconds_since_epoch': int(expected.log_times_ns[0]) - 1000},
        'message_count': 60,
        'topics_with_message_count': [
            {'topic_and_type': {'name': topic, 'type': msgtype, 'serialization_format': 'cdr'},
             'message_count': 30}
            for topic, msgtype in zip(ROBOT_TOPICS, ('sensor_msgs/msg/JointState',
                                                     'std_msgs/msg/Float64MultiArray'))]}}
    (bag / 'metadata.yaml').write_text(yaml.safe_dump(version_1))
    assert_same(joints(bag), expected)


@pytest.mark.parametrize('storage', STORAGES)
def test_metadata_qos_unlike_the_storage_files_still_gives_every_message(tmp_path, storage):
    # rosbag2's talker bags record other QoS in metadata.yaml than in the storage file;
    # rosbags then matches no message to the metadata's connections.
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=30, storage=storage)
    expected = joints(bag)
    qos = ('- history: 3\n  depth: 0\n  reliability: 1\n  durability: 2\n  deadline:\n'
           '    sec: 0\n    nsec: 0\n  lifespan:\n    sec: 0\n    nsec: 0\n  liveliness: 1\n'
           '  liveliness_lease_duration:\n    sec: 0\n    nsec: 0\n'
           '  avoid_ros_namespace_conventions: false')

    def disagree(info):
        for topic in info['topics_with_message_count']:
            topic['topic_metadata']['offered_qos_profiles'] = qos
    edit_metadata(bag, disagree)
    assert_same(joints(bag), expected)
    playback = Playback(bag)
    try:
        played = [topic for topic, _, _ in playback.messages()]
        playback.check_counts({topic: played.count(topic) for topic in set(played)})
    finally:
        playback.close()
    assert len(played) == 60


def test_message_types_without_msg_are_read(tmp_path):
    # Some bags (rosbag2's seek test bag) record 'pkg/Name' instead of 'pkg/msg/Name'.
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=20, storage='sqlite3')
    expected = joints(bag)
    with sqlite3.connect(storage_file(bag)) as database:
        database.execute("UPDATE topics SET type = replace(type, '/msg/', '/')")
    database.close()

    def short_types(info):
        for topic in info['topics_with_message_count']:
            metadata = topic['topic_metadata']
            metadata['type'] = metadata['type'].replace('/msg/', '/')
    edit_metadata(bag, short_types)
    assert_same(joints(bag), expected)
    playback = Playback(bag)
    try:
        assert playback.topics[ROBOT_TOPICS[0]] == ('sensor_msgs/msg/JointState', 20)
    finally:
        playback.close()


def test_layouts_that_cannot_be_read_say_what_to_do(tmp_path):
    first, second = tmp_path / 'first', tmp_path / 'second'
    write_robot_bag(first, samples=5)
    write_robot_bag(second, samples=5)
    # Two storage files without metadata: a split bag whose metadata.yaml was lost.
    split = tmp_path / 'split'
    split.mkdir()
    for bag in (first, second):
        shutil.copy(storage_file(bag), split)
    with pytest.raises(BagError, match=r'no metadata.yaml and 2 storage files \(first.mcap, '
                                       r'second.mcap\); rebuild the metadata with "ros2 bag '
                                       r'reindex'):
        joints(split)
    # Metadata whose storage file was never copied.
    storage_file(first).unlink()
    with pytest.raises(BagError, match=r'metadata.yaml lists first.mcap, not found in the bag '
                                       r'directory; copy the storage files'):
        joints(first)
    empty = tmp_path / 'empty'
    empty.mkdir()
    with pytest.raises(BagError, match='no metadata.yaml and no .mcap or .db3 file'):
        joints(empty)
    compressed = tmp_path / 'x_0.db3.zstd'
    compressed.write_bytes(b'\x28\xb5\x2f\xfd')
    with pytest.raises(BagError, match='a zstd-compressed storage file; give the bag '
                                       'directory'):
        joints(compressed)
    # Version 1 with several files (rosbags reads version 2 on).
    edit_metadata(second, lambda info: info.update(
        version=1, relative_file_paths=['second.mcap', 'second.mcap']))
    with pytest.raises(BagError, match='metadata version 1 with 2 storage files'):
        joints(second)
    # The metadata file given instead of its directory is its directory.
    write_robot_bag(tmp_path / 'third', samples=5)
    assert len(joints(tmp_path / 'third' / 'metadata.yaml').values) == 5
