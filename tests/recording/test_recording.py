# Copyright 2026 The rbd_ros authors
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
Round trips of :class:`rbd_ros.bag.recording.BagWriter` through independent readers.

Messages are serialised with rclpy (as the node does) and read back with our reader, with the
``mcap`` reader plus ``mcap-ros2-support`` decoding, and with ``rosbags``.
"""

import errno
import os
from pathlib import Path
import re
import shutil
import time

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from nav_msgs.msg import Odometry
import pytest
from rbd_ros.bag import recording
from rbd_ros.bag.recording import BagWriter, open_bag
from rbd_ros.core.errors import RecordingError
from rbd_ros.msgs.schemas import SEPARATOR
from rclpy.serialization import serialize_message
from rosbag2_decode import decode_bag_metadata, read_rosbag2_records, Rosbag2DecodeError
from rosbags.highlevel import AnyReader
from rosbags.rosbag2 import Reader as RosbagsReader
from rosgraph_msgs.msg import Clock
import yaml

STEP_NS = 1_000_000
TOPICS = {
    '/wrench': ('geometry_msgs/msg/WrenchStamped', {'depth': 10}),
    '/pose': ('geometry_msgs/msg/PoseStamped', {'depth': 5, 'reliability': 'best_effort'}),
    '/twist': ('geometry_msgs/msg/TwistStamped', {}),
    '/odom': ('nav_msgs/msg/Odometry', {'durability': 'transient_local', 'depth': 1}),
    '/clock': ('rosgraph_msgs/msg/Clock', {'depth': 1, 'reliability': 'best_effort'}),
}
CONFIG = {
    'mass_kg': 1.0, 'inertia': [0.1 / 3, 1e-300, 0.2, 0.0, 0.0, 0.0], 'integrator': 'rk4',
    'timestep_s': 0.001, 'world_frame': 'world', 'record_path': '/x/{stamp}',
    'wrench_input_names': [], 'start_paused': False,
}


def _stamp(t_ns):
    return Time(sec=t_ns // 1_000_000_000, nanosec=t_ns % 1_000_000_000)


def _messages(duration_ns=3_000_000_000, period_ns=10_000_000):
    """Yield (topic, msg, t_ns) for a synthetic run with distinct values in every field."""
    for k, t in enumerate(range(0, duration_ns + 1, period_ns)):
        x = k * 0.1 + 1e-17 * k
        if k % 7 == 0:
            w = WrenchStamped()
            w.header.stamp = _stamp(t)
            w.header.frame_id = 'base_link' if k % 2 else 'world'
            w.wrench.force.x, w.wrench.force.y, w.wrench.force.z = x, -x, 1.0 / 3.0
            w.wrench.torque.z = -0.25 * k
            yield '/wrench', w, t
        p = PoseStamped()
        p.header.stamp = _stamp(t)
        p.header.frame_id = 'world'
        p.pose.position.x, p.pose.position.y = x, 2 * x
        p.pose.orientation.w = 1.0
        yield '/pose', p, t
        tw = TwistStamped()
        tw.header.stamp = _stamp(t)
        tw.twist.linear.x, tw.twist.angular.z = x, -x
        yield '/twist', tw, t
        o = Odometry()
        o.header.stamp = _stamp(t)
        o.header.frame_id, o.child_frame_id = 'world', 'base_link'
        o.pose.pose.position.z = x
        o.twist.twist.angular.y = 3 * x
        yield '/odom', o, t
        c = Clock()
        c.clock = _stamp(t)
        yield '/clock', c, t


def _record(path, **kwargs):
    writer = BagWriter(path, config=CONFIG, **kwargs)
    for topic, (type_name, qos) in TOPICS.items():
        writer.add_topic(topic, type_name, qos)
    writer.flush()  # as the node does at start: schemas and channels on disk now
    written = []
    for topic, msg, t in _messages():
        data = serialize_message(msg)
        writer.write(topic, data, t)
        written.append((topic, t, data))
    return writer, written


@pytest.fixture
def recorded(tmp_path):
    writer, written = _record(tmp_path / 'run')
    writer.close()
    return writer, written


def test_our_reader_round_trip(recorded):
    writer, written = recorded
    bag = open_bag(writer.path)
    assert bag.finalised, bag.notes
    assert bag.notes == []
    assert bag.profile == 'ros2'
    assert [(m.topic, m.log_time_ns, m.data) for m in bag.messages()] == written
    assert bag.config == CONFIG  # floats survive the YAML round trip bit for bit
    assert bag.rbd_metadata['integrator'] == 'rk4'
    assert bag.rbd_metadata['timestep_ns'] == '1000000'
    for topic, (type_name, qos) in TOPICS.items():
        info = bag.topics[topic]
        assert info.type_name == type_name
        assert info.qos == [recording.normalize_qos(qos)]
        assert info.message_count == sum(1 for w in written if w[0] == topic)
        assert info.type_hash.startswith('RIHS01_') and len(info.type_hash) == 7 + 64


def test_mcap_reader_and_ros2_decoding(recorded):
    writer, written = recorded
    with open(writer.mcap_path, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        assert header.profile == 'ros2'
        summary = reader.get_summary()
        decoded = [(channel.topic, message.log_time, msg)
                   for schema, channel, message, msg in reader.iter_decoded_messages()]
    assert [(topic, t) for topic, t, _ in decoded] == [(topic, t) for topic, t, _ in written]
    # Every message decodes with the stored schema and carries the values we wrote.
    originals = list(_messages())
    for (topic, t, msg), (_, orig, _) in zip(decoded, originals):
        if topic == '/pose':
            assert msg.pose.position.x == orig.pose.position.x
            assert msg.header.frame_id == orig.header.frame_id
        elif topic == '/wrench':
            assert msg.wrench.force.z == orig.wrench.force.z
            assert msg.wrench.torque.z == orig.wrench.torque.z
            assert msg.header.frame_id == orig.header.frame_id
        elif topic == '/odom':
            assert msg.child_frame_id == 'base_link'
            assert msg.twist.twist.angular.y == orig.twist.twist.angular.y
            assert len(msg.pose.covariance) == 36
        elif topic == '/clock':
            assert (msg.clock.sec, msg.clock.nanosec) == (orig.clock.sec, orig.clock.nanosec)
    # Schemas: ros2msg, pkg/msg/Type, dependencies once with the rosbag2 separator.
    for schema in summary.schemas.values():
        assert schema.encoding == 'ros2msg'
        assert schema.name in {t for t, _ in TOPICS.values()}
        text = schema.data.decode()
        deps = [line for line in text.splitlines() if line.startswith('MSG: ')]
        assert len(deps) == len(set(deps))
        assert all('/msg/' not in d for d in deps)
        assert text.count('\n' + SEPARATOR + '\nMSG: ') == len(deps)
    # Channels: cdr with exactly the two rosbag2 metadata keys.
    for channel in summary.channels.values():
        assert channel.message_encoding == 'cdr'
        assert set(channel.metadata) == {'offered_qos_profiles', 'topic_type_hash'}
        qos = yaml.safe_load(channel.metadata['offered_qos_profiles'])
        assert qos == [recording.normalize_qos(TOPICS[channel.topic][1])]
        assert '&id' not in channel.metadata['offered_qos_profiles']
    # Statistics, chunk indexes with message indexes, metadata index.
    stats = summary.statistics
    assert stats.message_count == len(written)
    assert stats.channel_count == len(TOPICS)
    assert stats.message_start_time == 0 and stats.message_end_time == written[-1][1]
    assert stats.chunk_count == len(summary.chunk_indexes) >= 3
    for index in summary.chunk_indexes:
        assert index.message_index_offsets, 'chunk without message indexes'
        # A chunk covers less than 1 s of sim time (ended before reaching it).
        assert index.message_end_time - index.message_start_time < 1_000_000_000
    names = [m.name for m in summary.metadata_indexes]
    assert names.count('rbd_ros') == 1 and names.count('rosbag2') == 2


def test_rosbags_reads_the_bag(recorded):
    writer, written = recorded
    with RosbagsReader(Path(writer.path)) as reader:
        conns = {c.topic: c for c in reader.connections}
        assert set(conns) == set(TOPICS)
        for topic, (type_name, qos) in TOPICS.items():
            assert conns[topic].msgtype == type_name
            assert conns[topic].msgcount == sum(1 for w in written if w[0] == topic)
            got = conns[topic].ext.offered_qos_profiles[0]
            want = recording.normalize_qos(qos)
            assert got.depth == want['depth']
            assert got.reliability.name.lower() == want['reliability']
            assert got.durability.name.lower() == want['durability']
            assert got.history.name.lower() == want['history']
    with AnyReader([Path(writer.path)]) as reader:
        seen = []
        for conn, t, raw in reader.messages():
            msg = reader.deserialize(raw, conn.msgtype)
            seen.append((conn.topic, t, bytes(raw)))
            if conn.topic == '/pose':
                assert msg.pose.orientation.w == 1.0
    assert sorted(seen) == sorted(written)


def test_metadata_yaml_agrees_with_mcap_summary(recorded):
    writer, written = recorded
    with open(os.path.join(writer.path, 'metadata.yaml')) as f:
        meta = yaml.safe_load(f)['rosbag2_bagfile_information']
    with open(writer.mcap_path, 'rb') as f:
        reader = make_reader(f)
        summary = reader.get_summary()
        records = [m for m in reader.iter_metadata() if m.name == 'rosbag2']
    stats = summary.statistics
    assert meta['version'] == 9
    assert meta['storage_identifier'] == 'mcap'
    assert meta['ros_distro'] == 'jazzy'
    assert meta['message_count'] == stats.message_count
    assert meta['starting_time']['nanoseconds_since_epoch'] == stats.message_start_time
    assert meta['duration']['nanoseconds'] == stats.message_end_time - stats.message_start_time
    assert meta['relative_file_paths'] == [os.path.basename(writer.mcap_path)]
    assert meta['files'][0]['path'] == os.path.basename(writer.mcap_path)
    assert meta['files'][0]['message_count'] == stats.message_count
    by_channel = {c.topic: stats.channel_message_counts[c.id]
                  for c in summary.channels.values()}
    for entry in meta['topics_with_message_count']:
        tm = entry['topic_metadata']
        assert entry['message_count'] == by_channel[tm['name']]
        channel = next(c for c in summary.channels.values() if c.topic == tm['name'])
        assert tm['type'] == summary.schemas[channel.schema_id].name
        assert tm['serialization_format'] == 'cdr'
        assert tm['type_description_hash'] == channel.metadata['topic_type_hash']
        assert tm['offered_qos_profiles'] == yaml.safe_load(
            channel.metadata['offered_qos_profiles'])
    # The last rosbag2 record (written at close) is the metadata.yaml body, bare: rosbag2's
    # MCAP reader decodes serialized_metadata from its root (no rosbag2_bagfile_information).
    assert yaml.safe_load(records[-1].metadata['serialized_metadata']) == meta


def test_rosbag2_records_decode_the_way_rosbag2_reads_them(recorded):
    """Each record passes convert<BagMetadata>::decode; the last (read_metadata's) is complete."""
    writer, written = recorded
    decoded = read_rosbag2_records(writer.mcap_path)
    assert len(decoded) == 2  # update_metadata at open and at close, as SequentialWriter does
    at_open, at_close = decoded
    # At open rosbag2 writes starting_time = int64 max ns and no messages yet.
    assert at_open['starting_time'] == 2 ** 63 - 1
    assert at_open['message_count'] == 0 and at_open['files'][0]['message_count'] == 0
    assert at_close['storage_identifier'] == 'mcap' and at_close['ros_distro'] == 'jazzy'
    assert at_close['starting_time'] == 0
    assert at_close['duration'] == written[-1][1]
    assert at_close['message_count'] == len(written)
    assert at_close['relative_file_paths'] == [os.path.basename(writer.mcap_path)]
    assert at_close['files'][0]['path'] == os.path.basename(writer.mcap_path)
    assert at_close['custom_data'] == {}
    topics = {t['name']: t for t in at_close['topics']}
    assert set(topics) == set(TOPICS)
    for topic, (type_name, qos) in TOPICS.items():
        assert topics[topic]['type'] == type_name
        assert topics[topic]['serialization_format'] == 'cdr'
        assert topics[topic]['message_count'] == sum(1 for w in written if w[0] == topic)
        profile = topics[topic]['offered_qos_profiles'][0]
        want = recording.normalize_qos(qos)
        assert profile['history'] == want['history'] and profile['depth'] == want['depth']
        assert profile['reliability'] == want['reliability']
        assert profile['durability'] == want['durability']
    # The helper is strict: the form the old writer used (wrapped as in metadata.yaml) is what
    # rosbag2 cannot decode.
    with open(os.path.join(writer.path, 'metadata.yaml')) as f:
        wrapped = f.read()
    with pytest.raises(Rosbag2DecodeError, match="no key 'version'"):
        decode_bag_metadata(wrapped)


def test_schema_dependency_order_matches_rosbag2():
    from rbd_ros.msgs.schemas import message_definition
    deps = [line[5:] for line in message_definition('nav_msgs/msg/Odometry').decode().splitlines()
            if line.startswith('MSG: ')]
    # Depth-first pre-order, children sorted: the order in the rosbag2 reference, section 2.2.
    assert deps == ['geometry_msgs/PoseWithCovariance', 'geometry_msgs/Pose',
                    'geometry_msgs/Point', 'geometry_msgs/Quaternion',
                    'geometry_msgs/TwistWithCovariance', 'geometry_msgs/Twist',
                    'geometry_msgs/Vector3', 'std_msgs/Header', 'builtin_interfaces/Time']
    text = message_definition('geometry_msgs/msg/WrenchStamped').decode()
    assert text.startswith('# A wrench with reference coordinate frame and timestamp\n')
    assert '\n\n' + SEPARATOR + '\nMSG: geometry_msgs/Wrench\n' in text


def test_unfinalised_file_keeps_completed_chunks(tmp_path):
    """What a SIGKILL leaves: no close(), no summary, no metadata.yaml."""
    writer, written = _record(tmp_path / 'killed')

    def killed(name):
        """Copy the file as the OS has it now, without closing the writer: a SIGKILL."""
        copy_dir = tmp_path / name
        copy_dir.mkdir()
        shutil.copy(writer.mcap_path, copy_dir / 'killed_0.mcap')
        bag = open_bag(str(copy_dir))
        assert not bag.finalised
        assert any('not finalised' in note for note in bag.notes)
        assert any('metadata.yaml' in note for note in bag.notes)
        assert bag.config == CONFIG
        got = [(m.topic, m.log_time_ns, m.data) for m in bag.messages()]
        assert got == written[:len(got)]
        return got
    # At once: the last completed chunk may still be on the chunk thread (at most one,
    # blocks.ChunkEnds.MAX_PENDING), so at most the open chunk and that one are missing (< 1 s
    # of sim time each).
    assert killed('at_once')[-1][1] >= written[-1][1] - 2_000_000_000
    # Once the thread has written it (milliseconds later): at most the open chunk is missing.
    writer._drain()
    assert killed('later')[-1][1] >= written[-1][1] - 1_000_000_000
    writer.close()


@pytest.mark.parametrize('cut_chunk', [1, 2])
def test_truncated_file_reads_a_prefix(recorded, tmp_path, cut_chunk):
    writer, written = recorded
    data = open(writer.mcap_path, 'rb').read()
    with open(writer.mcap_path, 'rb') as f:
        chunks = sorted(make_reader(f).get_summary().chunk_indexes,
                        key=lambda c: c.chunk_start_offset)
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[:chunks[cut_chunk].chunk_start_offset + 100])  # inside that chunk
    bag = open_bag(str(cut))
    got = [(m.topic, m.log_time_ns, m.data) for m in bag.messages()]
    assert not bag.finalised
    assert bag.truncated
    assert got == written[:len(got)]
    assert 0 < len(got) < len(written)


def test_cut_in_the_summary_keeps_every_message(recorded, tmp_path):
    writer, written = recorded
    with open(writer.mcap_path, 'rb') as f:
        summary_start = make_reader(f).get_summary() and _footer_summary_start(f)
    data = open(writer.mcap_path, 'rb').read()
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(data[:summary_start + 10])
    bag = open_bag(str(cut))
    assert not bag.finalised
    assert [(m.topic, m.log_time_ns, m.data) for m in bag.messages()] == written


def _footer_summary_start(f):
    import struct
    f.seek(-8 - 20, os.SEEK_END)  # footer body (3 fields: 8 + 8 + 4 bytes) before the magic
    return struct.unpack('<Q', f.read(8))[0]


def test_refuses_to_overwrite(recorded, tmp_path):
    writer, _ = recorded
    with pytest.raises(RecordingError, match='already exists'):
        BagWriter(writer.path, config=CONFIG)
    again = BagWriter(writer.path, config={'mass_kg': 2.0}, overwrite=True)
    again.close()
    assert open_bag(writer.path).config == {'mass_kg': 2.0}
    other = tmp_path / 'not_a_bag'
    other.mkdir()
    (other / 'notes.txt').write_text('keep me')
    with pytest.raises(RecordingError, match="holds 'notes.txt'"):
        BagWriter(str(other), overwrite=True)
    assert (other / 'notes.txt').read_text() == 'keep me'


def _tree(path):
    return sorted(str(p.relative_to(path)) for p in Path(path).rglob('*'))


@pytest.mark.parametrize('case', ['mcap_named_directory', 'subdirectory', 'symlinked_file',
                                  'foreign_mcap', 'hidden_file'])
def test_overwrite_deletes_only_our_regular_files(tmp_path, case):
    """record_overwrite: anything but our own regular files refuses it, nothing deleted."""
    bag = tmp_path / 'x'
    bag.mkdir()
    (bag / 'metadata.yaml').write_text('rosbag2_bagfile_information: {}\n')
    (bag / 'x_0.mcap').write_bytes(b'old')
    outside = tmp_path / 'outside.txt'
    outside.write_text('user data')
    if case == 'mcap_named_directory':  # the case: a *directory* named x.mcap
        (bag / 'x.mcap').mkdir()
        (bag / 'x.mcap' / 'user.txt').write_text('user data')
    elif case == 'subdirectory':
        (bag / 'x_1.mcap').mkdir()
    elif case == 'symlinked_file':
        os.symlink(outside, bag / 'x_1.mcap')
    elif case == 'foreign_mcap':
        (bag / 'other_0.mcap').write_bytes(b'not ours')
    else:
        (bag / '.x_0.mcap.swp').write_bytes(b'')
    before = _tree(bag)
    with pytest.raises(RecordingError, match='not a file of an rbd_ros bag') as info:
        BagWriter(str(bag), overwrite=True)
    assert '\n' not in str(info.value) and str(bag) in str(info.value)
    assert _tree(bag) == before
    assert (bag / 'x_0.mcap').read_bytes() == b'old'
    assert outside.read_text() == 'user data'


def test_overwrite_replaces_our_own_bag_files(tmp_path):
    bag = tmp_path / 'x'
    bag.mkdir()
    for name in ('metadata.yaml', 'x_0.mcap', 'x_1.mcap', '.metadata.yaml.tmp'):
        (bag / name).write_bytes(b'old')
    BagWriter(str(bag), config={'mass_kg': 3.0}, overwrite=True).close()
    assert _tree(bag) == ['metadata.yaml', 'x_0.mcap']
    assert open_bag(str(bag)).config == {'mass_kg': 3.0}


@pytest.mark.parametrize('overwrite', [False, True])
def test_symlinked_record_path_is_a_clear_error(tmp_path, overwrite):
    target = tmp_path / 'real'
    target.mkdir()
    (target / 'user.txt').write_text('keep')
    link = tmp_path / 'link'
    os.symlink(target, link)
    dangling = tmp_path / 'dangling'
    os.symlink(tmp_path / 'nowhere', dangling)
    for path in (link, dangling):
        with pytest.raises(RecordingError, match='is a symbolic link') as info:
            BagWriter(str(path), overwrite=overwrite)
        assert str(path) in str(info.value)
    assert _tree(target) == ['user.txt']
    assert not (tmp_path / 'nowhere').exists()


def test_stamp_placeholder(tmp_path):
    writer = BagWriter(str(tmp_path / 'run_{stamp}'))
    writer.close()
    name = os.path.basename(writer.path)
    assert name.startswith('run_') and '{' not in name
    time.strptime(name[4:], '%Y_%m_%d-%H_%M_%S')
    assert os.path.isfile(os.path.join(writer.path, f'{name}_0.mcap'))


def test_unwritable_path_is_a_clear_error(tmp_path):
    blocker = tmp_path / 'file'
    blocker.write_text('')
    with pytest.raises(RecordingError, match='cannot create the bag directory') as info:
        BagWriter(str(blocker / 'bag'))
    assert str(blocker) in str(info.value)


class _FillingDisk:
    """The bag file as a disk that fills up: writes fail with ENOSPC once ``full`` is set."""

    def __init__(self, file):
        self._file = file
        self.full = False

    def write(self, data):
        if self.full:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), self._file.name)
        return self._file.write(data)

    def __getattr__(self, name):
        return getattr(self._file, name)


def test_disk_full_is_a_clear_error(tmp_path, monkeypatch):
    disks = []

    def open_on_filling_disk(path, mode='r', *args, **kwargs):
        file = open(path, mode, *args, **kwargs)
        if mode == 'xb':  # the MCAP file; metadata.yaml and reading stay on the real disk
            file = _FillingDisk(file)
            disks.append(file)
        return file

    monkeypatch.setattr(recording, 'open', open_on_filling_disk, raising=False)
    writer = BagWriter(str(tmp_path / 'full'), chunk_duration_ns=STEP_NS)
    writer.add_topic('/pose', 'geometry_msgs/msg/PoseStamped')
    writer.flush()
    disks[0].full = True  # every later write fails as on a full disk
    data = serialize_message(PoseStamped())
    with pytest.raises(RecordingError, match='No space left on device'):
        for k in range(10):
            writer.write('/pose', data, k * STEP_NS)
    with pytest.raises(RecordingError, match='No space left on device'):
        writer.write('/pose', data, 20 * STEP_NS)  # stays failed, says why again
    writer.close()  # releases the file, does not raise a second time
    writer.close()
    assert writer.failed is not None and '\n' not in str(writer.failed)


def test_no_private_names_of_dependencies():
    """Our code and tests use only public APIs of mcap & co: no name-mangled attributes."""
    root = Path(__file__).resolve().parents[2]
    mangled = re.compile(r'\._[A-Z]\w*__\w')  # an attribute mangled by a class's __name
    found = [f'{path.relative_to(root)}:{number}: {line.strip()}'
             for folder in ('rbd_ros', 'tests') for path in sorted((root / folder).rglob('*.py'))
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if mangled.search(line)]
    assert found == []


def test_bad_arguments(tmp_path):
    writer = BagWriter(str(tmp_path / 'b'))
    with pytest.raises(RecordingError, match='absolute'):
        writer.add_topic('pose', 'geometry_msgs/msg/PoseStamped')
    with pytest.raises(RecordingError, match='no_such_msgs'):
        writer.add_topic('/x', 'no_such_msgs/msg/Nothing')
    with pytest.raises(RecordingError, match='not a rosbag2 v9 QoS policy'):
        writer.add_topic('/y', 'geometry_msgs/msg/PoseStamped', {'depht': 3})
    with pytest.raises(RecordingError, match='add_topic'):
        writer.write('/z', b'', 0)
    writer.close()
    with pytest.raises(RecordingError, match='closed'):
        writer.write('/z', b'', 0)


@pytest.mark.parametrize('type_name', ['no_such_msgs/msg/Nothing', 'not/a/msg/type'])
def test_schema_errors_are_recording_errors(type_name):
    """A type we cannot record is a RecordingError naming it, never a bare ValueError."""
    from rbd_ros.msgs.schemas import message_definition, SchemaError
    with pytest.raises(SchemaError, match=type_name) as info:
        message_definition(type_name)
    assert isinstance(info.value, RecordingError)
    assert not isinstance(info.value, ValueError)


def test_an_mcap_without_a_public_writer_flush_is_named(tmp_path, monkeypatch):
    """We end chunks with mcap's public Writer.flush(); an mcap without it is one clear line."""
    monkeypatch.setattr(recording, 'Writer', type('Writer', (), {}))
    with pytest.raises(RecordingError, match=r'mcap 1\.\d+\.\d+: .*no public flush\(\)') as info:
        BagWriter(str(tmp_path / 'b'))
    assert '\n' not in str(info.value) and not (tmp_path / 'b').exists()


@pytest.mark.parametrize('internals', [True, False])
@pytest.mark.parametrize('chunk_bytes, compression', [
    (300, 'zstd'), (1 << 20, 'zstd'), (300, 'lz4'), (300, 'none')])
def test_write_many_writes_the_bytes_of_write_one_by_one(
        tmp_path, monkeypatch, internals, chunk_bytes, compression):
    """
    A sample written at once (write_many) makes the same file as its messages one by one.

    Chunks end on bytes inside a sample (chunk_bytes 300: a few messages a chunk) or not
    (1 MiB), and on sim time between samples (chunk_duration 25 ms: every third sample), so
    the split of a sample across chunks is compared too; samples of two sets of topics (a
    topic twice in one), with messages written one by one between them, on their topics and
    another, so each channel's message index and count mixes both. The reference is mcap's
    own writer (``add_message`` of each, ``Writer.flush`` at each chunk's end: without the
    internals write_many and the chunk ends on a thread use, which it falls back to), with
    each compression.
    """
    with_internals = recording._mcap_internals
    topics = [('/a/pose', 'geometry_msgs/msg/PoseStamped'),
              ('/poses', 'geometry_msgs/msg/PoseArray'), ('/clock', 'rosgraph_msgs/msg/Clock'),
              ('/markers', 'visualization_msgs/msg/MarkerArray')]
    samples = [(t * 10_000_000, [(topic, bytes([t, i]) * (7 + 13 * i + t))
                                 for i, (topic, _) in enumerate(
                                     topics[:3] * 2 if t % 4 else topics[1:3])])
               for t in range(12)]
    singles = {t * 10_000_000: [('/markers', bytes([t]) * (5 + t))]
               + ([('/poses', b'p' * t)] if t % 3 else []) for t in range(12)}
    files = []
    for name, many, plain in (('mcap', False, True), ('one', False, not internals),
                              ('many', True, not internals)):
        monkeypatch.setattr(recording, '_mcap_internals',
                            (lambda writer: None) if plain else with_internals)
        writer = BagWriter(str(tmp_path / name / 'bag'), config=CONFIG, chunk_bytes=chunk_bytes,
                           chunk_duration_ns=25_000_000, compression=compression)
        for topic, type_name in topics:
            writer.add_topic(topic, type_name)
        for time_ns, messages in samples:
            if time_ns % 20_000_000:  # one by one before the sample at odd times
                for topic, data in singles[time_ns]:
                    writer.write(topic, data, time_ns)
            if many:
                writer.write_many(messages, time_ns)
            else:
                for topic, data in messages:
                    writer.write(topic, data, time_ns)
            if not time_ns % 20_000_000:
                for topic, data in singles[time_ns]:
                    writer.write(topic, data, time_ns)
        assert (writer._chunk_ends is None) == plain
        writer.close()
        files.append([(tmp_path / name / 'bag' / 'bag_0.mcap').read_bytes(),
                      (tmp_path / name / 'bag' / 'metadata.yaml').read_text()])
    assert files[0] == files[1] == files[2]
    got = [(m.topic, m.log_time_ns, m.data) for m in open_bag(str(tmp_path / 'many' / 'bag'))
           .messages()]
    assert got == [(topic, time_ns, data) for time_ns, messages in samples
                   for topic, data in [
                       *(singles[time_ns] if time_ns % 20_000_000 else []), *messages,
                       *([] if time_ns % 20_000_000 else singles[time_ns])]]


def test_write_many_refuses_an_unknown_topic_before_writing(tmp_path):
    writer = BagWriter(str(tmp_path / 'b'))
    writer.add_topic('/a', 'rosgraph_msgs/msg/Clock')
    with pytest.raises(RecordingError, match="'/z' was not added"):
        writer.write_many([('/a', b'\x00' * 12), ('/z', b'')], 0)
    writer.close()
    assert open_bag(str(tmp_path / 'b')).message_count == 0
