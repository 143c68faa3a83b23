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

"""Bags: CDR codec, record and replay round trips, robot-style layouts and bad bags."""

import doctest
import importlib
import pkgutil
import re
import subprocess
import zlib

import numpy as np
import pytest
from rosbags.rosbag2 import CompressionFormat, CompressionMode, Reader, StoragePlugin, Writer

from bag_support import (float64_array, JOINT_STATE, joint_state, robot_parameters, serialize,
                         TYPESTORE, write_robot_bag)
from conftest import CONFIG_DIR, console_script
from observer_ros.bags.mcap import McapError, read_mcap_topics
from observer_ros.bags.reading import read_topic, read_topics, TopicRequest
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.replay_outputs import write_replay
from observer_ros.bags.storage import _mcap_files, BagError
from observer_ros.bags.writing import TopicToWrite, write_bag
from observer_ros.config import load_parameter_file, validate_parameters
import observer_ros.wire
from observer_ros.wire import decode, DecodeError, Encoder, MessageReader, MessageWriter
from ros_support import run_lockstep

STORAGES = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}


def test_decode_equals_rosbags_on_mixed_layouts():
    rng = np.random.default_rng(0)
    raws, expected = [], []
    for index in range(400):
        names = [['shoulder', 'y1', 'wrist'], ['y1'], ['a', 'b', 'c', 'y1']][index % 3]
        values = rng.standard_normal(len(names))
        message = joint_state(index * 10**7 + 3, names, rng.standard_normal(len(names)),
                              values if index % 2 else (), frame_id='base' * (index % 4))
        raws.append(serialize(message))
        parsed = TYPESTORE.deserialize_cdr(raws[-1], JOINT_STATE)
        expected.append((parsed.header.stamp.sec * 10**9 + parsed.header.stamp.nanosec,
                         parsed.position[list(parsed.name).index('y1')]))
    stamps, values, errors = decode(raws, 'joint_state', 'position', ['y1'])
    assert errors == {}
    assert np.array_equal(stamps, [e[0] for e in expected])
    assert np.array_equal(values[:, 0], [e[1] for e in expected])
    # Velocity is empty in half of them: those are reported, never read as garbage.
    _, values, errors = decode(raws, 'joint_state', 'velocity', ['y1'])
    assert sorted(errors) == list(range(0, 400, 2))
    assert np.isnan(values[0::2]).all() and np.isfinite(values[1::2]).all()


def test_one_message_reader_equals_the_batch_decoder_as_layouts_change():
    rng = np.random.default_rng(2)
    raws = []
    for index in range(300):
        names = [['shoulder', 'y1', 'wrist'], ['y1'], ['a', 'b', 'c', 'y1']][index % 3]
        raws.append(serialize(joint_state(
            index * 10**7 + 5, names, rng.standard_normal(len(names)),
            rng.standard_normal(len(names)), frame_id='base' * (index // 11 % 3))))
    for field in ('position', 'velocity'):
        stamps, values, errors = decode(raws, 'joint_state', field, ['y1'])
        assert errors == {}
        reader = MessageReader('joint_state', field, ['y1'])
        read = [reader.read(raw) for raw in raws]
        assert [stamp for stamp, _ in read] == stamps.tolist()
        assert [vector for _, vector in read] == values.tolist()


def test_one_message_reader_refuses_what_it_cannot_read():
    reader = MessageReader('joint_state', 'position', ['y1', 'y2'])
    good = serialize(joint_state(7, ['y2', 'y1'], [2.0, 1.0]))
    assert reader.read(good) == (7, [1.0, 2.0])
    for raw, reason in ((good[:-3], 'truncated'),
                        (serialize(joint_state(7, ['y1'], [1.0])), r"joints \['y2'\] missing"),
                        (serialize(joint_state(7, ['y1', 'y2'], [1.0])), '2 names but 1'),
                        (b'\x00\x00\x00\x00' + good[4:], 'little-endian')):
        with pytest.raises(DecodeError, match=reason):
            reader.read(raw)
    assert reader.read(good) == (7, [1.0, 2.0])  # and reads the good layout again


REPEATED = r"joints \['y1'\] named more than once"


def test_a_repeated_joint_name_is_refused_by_both_decoders():
    # before: ['y1', 'y1'] with [0.2, 999] was read as 999 (the last one won)
    repeated = serialize(joint_state(7, ['y1', 'y1'], [0.2, 999.0]))
    with pytest.raises(DecodeError, match=REPEATED):
        MessageReader('joint_state', 'position', ['y1']).read(repeated)
    good = serialize(joint_state(5, ['y1'], [0.1]))
    _, values, errors = decode([good, repeated, good], 'joint_state', 'position', ['y1'])
    assert list(errors) == [1] and re.search(REPEATED, errors[1]), errors
    assert np.isnan(values[1]).all() and values[[0, 2], 0].tolist() == [0.1, 0.1]
    # A repeated joint the model does not name is one of the ignored extra joints.
    extra = serialize(joint_state(7, ['wrist', 'y1', 'wrist'], [1.0, 0.5, 2.0]))
    assert MessageReader('joint_state', 'position', ['y1']).read(extra) == (7, [0.5])
    assert decode([extra], 'joint_state', 'position', ['y1'])[1].tolist() == [[0.5]]


def test_the_codec_examples_run():
    attempted = 0
    modules = pkgutil.walk_packages(observer_ros.wire.__path__, 'observer_ros.wire.')
    for module in [info.name for info in modules]:
        result = doctest.testmod(importlib.import_module(module))
        assert result.failed == 0, module
        attempted += result.attempted
    assert attempted > 0


@pytest.mark.parametrize('storage', sorted(STORAGES))
@pytest.mark.parametrize('topic', ['y', 'u'])
def test_a_bag_with_a_repeated_joint_name_is_refused_saying_where(tmp_path, storage, topic):
    bag = tmp_path / 'run'
    with Writer(bag, version=9, storage_plugin=STORAGES[storage]) as writer:
        connections = {key: writer.add_connection(f'/{key}', JOINT_STATE, typestore=TYPESTORE)
                       for key in ('u', 'y')}
        for index in range(10):
            stamp = 10**9 + index * 10**7
            for key in ('u', 'y'):
                name = f'{key}1'
                names, values = ([name, name], [0.2, 999.0]) if (
                    key == topic and index == 5) else ([name], [0.2])
                writer.write(connections[key], stamp + (key == 'y'),
                             serialize(joint_state(stamp, names, values)))
    with pytest.raises(BagError, match=rf'topic /{topic}: 1 of 10 messages do not hold the '
                                       rf"1-vector \['{topic}1'\] \(first, message 5: "
                                       rf"joints \['{topic}1'\] named more than once"):
        replay_bag(bag, CONFIG_DIR / 'seed003_full_order.yaml')


def test_one_message_reader_checks_every_fixed_byte_of_a_repeated_layout():
    reader = MessageReader('joint_state', 'position', ['y1'])
    first = serialize(joint_state(5, ['y1'], [1.0]))
    assert reader.read(first) == (5, [1.0])
    # The same size as the last message: only the bytes tell the layouts apart.
    renamed = serialize(joint_state(6, ['y2'], [2.0]))
    assert len(renamed) == len(first)
    with pytest.raises(DecodeError, match=r"joints \['y1'\] missing"):
        reader.read(renamed)
    # Serializers leave padding uninitialised: other padding is still the same layout.
    padded = bytearray(serialize(joint_state(7, ['y1'], [3.0])))
    padded[17:20] = b'\xff\xff\xff'  # after the empty frame_id, before the name count
    assert reader.read(bytes(padded)) == (7, [3.0])
    assert reader.read(bytes(padded)) == (7, [3.0])
    assert reader.read(first) == (5, [1.0])
    reader = MessageReader('float64_multi_array', 'data', ['u1', 'u2'])
    wide = bytes(MessageWriter(bytes(Encoder('float64_multi_array', ['a', 'b', 'c']).template),
                               'float64_multi_array', 'data').write(0, [1.0, 2.0, 3.0]))
    narrow = MessageWriter(bytes(Encoder('float64_multi_array', ['a', 'b']).template),
                           'float64_multi_array', 'data')
    assert reader.read(narrow.write(0, [4.0, 5.0])) == (0, [4.0, 5.0])
    with pytest.raises(DecodeError, match='expected 2 values in data, got 3'):
        reader.read(wide)
    assert reader.read(narrow.write(0, [6.0, 7.0])) == (0, [6.0, 7.0])


@pytest.mark.parametrize('kind', ['joint_state', 'float64_multi_array'])
def test_one_message_writer_equals_the_batch_encoder(kind):
    rng = np.random.default_rng(3)
    stamps = rng.integers(0, 10**12, size=20)
    values = rng.standard_normal((20, 3))
    encoder = Encoder(kind, ['x1', 'x2', 'x3'])
    writer = MessageWriter(bytes(encoder.template), kind, 'position')
    assert [writer.write(s, v) for s, v in zip(stamps, values)] == encoder.encode(stamps, values)


@pytest.mark.parametrize('kind', ['joint_state', 'float64_multi_array'])
def test_encode_equals_rosbags(kind):
    rng = np.random.default_rng(1)
    stamps = rng.integers(0, 10**12, size=50)
    values = rng.standard_normal((50, 3))
    raws = Encoder(kind, ['x1', 'x2', 'x3']).encode(stamps, values)
    for stamp, row, raw in zip(stamps, values, raws):
        if kind == 'joint_state':
            expected = joint_state(stamp, ['x1', 'x2', 'x3'], row)
        else:
            expected = float64_array(row)
        assert raw == serialize(expected)
    decoded = decode(raws, kind, 'position', ['x1', 'x2', 'x3'])
    assert np.array_equal(decoded[1], values)


def write_shuffled_bag(path, compression):
    """Three topics, log times out of order and tied, many chunks; return what was written."""
    rng = np.random.default_rng(4)
    written = {'/a': [], '/b': []}
    writer = Writer(path, version=9, storage_plugin=StoragePlugin.MCAP)
    if compression:
        writer.set_compression(compression, CompressionFormat.ZSTD)
    with writer:
        connections = {topic: writer.add_connection(topic, JOINT_STATE, typestore=TYPESTORE)
                       for topic in ('/a', '/other', '/b')}
        for index in range(3000):
            topic = ('/a', '/other', '/b')[index % 3]
            log_time = int(rng.integers(0, 500)) * 10**6  # ties and backward steps
            raw = serialize(joint_state(log_time + 1, ['y1'], rng.standard_normal(1),
                                        frame_id='f' * int(rng.integers(0, 200))))
            writer.write(connections[topic], log_time, raw)
            if topic in written:
                written[topic].append((log_time, raw))
    return written


@pytest.mark.parametrize('compression', [None, CompressionMode.STORAGE, CompressionMode.FILE,
                                         CompressionMode.MESSAGE])
def test_mcap_reading_equals_rosbags(tmp_path, compression):
    path = tmp_path / 'bag'
    write_shuffled_bag(path, compression)
    with Reader(path) as reader:
        expected = {topic: [(t, bytes(raw)) for c, t, raw in reader.messages(
            [c for c in reader.connections if c.topic == topic])] for topic in ('/a', '/b')}
    requests = [TopicRequest(topic, 'joint_state', 'position', ['y1']) for topic in ('b', '/a')]
    topics = read_topics(path, requests)
    for request, data in zip(requests, topics):
        topic = '/' + request.topic.lstrip('/')
        assert data.log_times_ns.tolist() == [t for t, _ in expected[topic]]
        stamps, values, _ = decode([raw for _, raw in expected[topic]], 'joint_state',
                                   'position', ['y1'])
        assert np.array_equal(data.stamps_ns, stamps) and np.array_equal(data.values, values)
    with Reader(path) as reader:  # which reader read_topics took
        files = _mcap_files(reader)
    if compression in (None, CompressionMode.STORAGE):  # the MCAP files are read directly
        assert files == sorted(path.glob('*.mcap'))
        found = read_mcap_topics(files, ['/a', '/b'])
        for topic in ('/a', '/b'):
            assert found[topic][0].tolist() == [t for t, _ in expected[topic]]
            assert found[topic][1] == [raw for _, raw in expected[topic]]
    else:  # compressed files or messages: rosbags decompresses
        assert files is None


def first_chunk(data):
    """Offsets of the first chunk's CRC field and of its records, in an MCAP file."""
    offset = 8
    while data[offset] != 0x06:
        offset += 9 + int.from_bytes(data[offset + 1:offset + 9], 'little')
    body = offset + 9
    name = int.from_bytes(data[body + 28:body + 32], 'little')
    records = body + 32 + name + 8
    size = int.from_bytes(data[body + 16:body + 24], 'little')
    return body + 24, records, size


def test_damaged_mcap_files_are_refused(tmp_path):
    path = tmp_path / 'bag'
    write_shuffled_bag(path, None)
    (file,) = path.glob('*.mcap')
    data = bytearray(file.read_bytes())
    with pytest.raises(McapError, match='not an MCAP file'):
        read_mcap_topics([path / 'metadata.yaml'], ['/a'])
    # rosbags writes no chunk checksum (0: unchecked); give the first chunk its CRC.
    crc_at, records, size = first_chunk(data)
    data[crc_at:crc_at + 4] = zlib.crc32(data[records:records + size]).to_bytes(4, 'little')
    file.write_bytes(bytes(data))
    good = read_topic(path, '/a', 'joint_state', 'position', ['y1'])
    data[records + size - 3] ^= 0xFF  # the last message's data: the checksum no longer matches
    file.write_bytes(bytes(data))
    with pytest.raises(BagError, match='checksum mismatch'):
        read_topic(path, '/a', 'joint_state', 'position', ['y1'])
    file.write_bytes(bytes(data[:len(data) // 3]))
    with pytest.raises(BagError):
        read_topic(path, '/a', 'joint_state', 'position', ['y1'])
    with pytest.raises(McapError, match='truncated'):
        read_mcap_topics([file], ['/a'])
    assert good.values.shape == (1000, 1)


@pytest.mark.parametrize('storage', sorted(STORAGES))
def test_record_replay_round_trip(tmp_path, storage):
    bag = tmp_path / 'run'
    config = 'seed001_fourth_order_chen.yaml'
    system, _, online, _ = run_lockstep(config, samples=200, bag=bag, storage=storage)
    result = replay_bag(bag, CONFIG_DIR / config)
    # Offline equals what the observer node published during the run, bit for bit ...
    assert np.array_equal(result.stamps_ns, online['x_hat'][0])
    assert np.array_equal(result.estimates, online['x_hat'][1])
    # ... and what the bag holds on /x_hat.
    recorded = read_topic(bag, 'x_hat', 'joint_state', 'position', system.model.state_names)
    assert np.array_equal(recorded.stamps_ns, result.stamps_ns)
    assert np.array_equal(recorded.values, result.estimates)
    assert result.counters['estimates'] == 200 and result.counters['malformed'] == 0
    assert result.error_norms()[-1] < 1e-2 * result.error_norms()[0]
    # Written results read back unchanged, from the bag and the CSV.
    write_replay(result, str(tmp_path / 'out'), str(tmp_path / 'out.csv'), storage)
    again = read_topic(tmp_path / 'out', 'x_hat', 'joint_state', 'position',
                       system.model.state_names)
    assert np.array_equal(again.values, result.estimates)
    table = np.loadtxt(tmp_path / 'out.csv', delimiter=',', skiprows=1, usecols=range(2, 6))
    stamps = np.loadtxt(tmp_path / 'out.csv', delimiter=',', skiprows=1, usecols=0,
                        dtype=np.int64)
    assert np.array_equal(stamps, result.stamps_ns)
    assert np.array_equal(table, result.estimates)


def test_robot_style_bag_reconstructs_the_unmeasured_state(tmp_path):
    bag = tmp_path / 'robot'
    truth = write_robot_bag(bag)
    result = replay_bag(bag, robot_parameters(tmp_path), y_topic='/joint_states',
                        u_topic='/effort_controller/commands')
    assert len(result.estimates) == len(truth)
    error = np.linalg.norm(result.estimates - truth, axis=1)
    assert error[-1] < 1e-9 * error.max()
    # The unmeasured velocity comes out right.
    np.testing.assert_allclose(result.estimates[-50:, 1], truth[-50:, 1], atol=1e-9)


def test_bad_bags_get_clear_errors(tmp_path):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=20)
    params = validate_parameters(load_parameter_file(str(robot_parameters(tmp_path))))
    with pytest.raises(BagError, match=r'no topic /y; the bag has /joint_states \(sensor_msgs'):
        replay_bag(bag, params)
    with pytest.raises(BagError, match='holds std_msgs/msg/Float64MultiArray, expected '
                                       'sensor_msgs/msg/JointState'):
        read_topic(bag, '/effort_controller/commands', 'joint_state', 'position', ['u1'])
    with pytest.raises(BagError, match=r'20 of 20 messages do not hold the 2-vector'):
        read_topic(bag, '/effort_controller/commands', 'float64_multi_array', 'position',
                   ['a', 'b'])
    with pytest.raises(BagError, match=r"joints \['knee'\] missing"):
        read_topic(bag, '/joint_states', 'joint_state', 'position', ['knee'])
    garbage = tmp_path / 'garbage'
    garbage.mkdir()
    (garbage / 'metadata.yaml').write_text('not: a bag\n')
    with pytest.raises(BagError, match='not a readable rosbag2 bag'):
        read_topic(garbage, '/y', 'joint_state', 'position', ['y1'])
    with pytest.raises(BagError, match='not a readable rosbag2 bag'):
        read_topic(tmp_path / 'missing', '/y', 'joint_state', 'position', ['y1'])
    empty = tmp_path / 'empty'
    with Writer(empty, version=9, storage_plugin=StoragePlugin.MCAP):
        pass
    with pytest.raises(BagError, match='no topics'):
        read_topic(empty, '/y', 'joint_state', 'position', ['y1'])


def test_metadata_count_disagreeing_with_the_messages_is_an_error(tmp_path):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=20, storage='sqlite3')
    metadata = bag / 'metadata.yaml'
    text = metadata.read_text()
    assert 'message_count: 20' in text
    metadata.write_text(text.replace('message_count: 20', 'message_count: 35', 1))
    with pytest.raises(BagError, match='read 20 messages but the metadata counts 35'):
        read_topic(bag, '/joint_states', 'joint_state', 'position', ['elbow'])


def test_writing_never_leaves_a_partial_bag(tmp_path):
    target = tmp_path / 'out'
    good = TopicToWrite('/x', 'joint_state', 'position', ['a'], np.array([1, 2]),
                        np.array([1, 2]), np.array([[1.0], [2.0]]))
    bad = TopicToWrite('/z', 'joint_state', 'position', ['a', 'b'], np.array([1]),
                       np.array([1]), np.array([[1.0, 2.0, 3.0]]))
    with pytest.raises(ValueError):
        write_bag(target, [good, bad])
    assert list(tmp_path.iterdir()) == []
    write_bag(target, [good])
    with pytest.raises(BagError, match='exists already'):
        write_bag(target, [good])


def test_replay_cli(tmp_path):
    bag = tmp_path / 'robot'
    write_robot_bag(bag, samples=50)
    params = str(robot_parameters(tmp_path))
    result = subprocess.run([console_script('replay'), str(bag), params,
                             '--y-topic', '/joint_states',
                             '--u-topic', '/effort_controller/commands', '--csv',
                             str(tmp_path / 'x_hat.csv'), '--output', str(tmp_path / 'out')],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert 'replayed 50 measurements into 50 estimates' in result.stdout
    assert (tmp_path / 'x_hat.csv').read_text().count('\n') == 51
    failed = subprocess.run([console_script('replay'), str(bag), params], capture_output=True,
                            text=True, timeout=60)
    assert failed.returncode == 2
    lines = failed.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith('replay: error: ') and '/joint_states' in (
        lines[0])
