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

"""Golden replay: every committed bag in ``bags/`` replays bit for bit (regression test)."""

import math
from pathlib import Path

from geometry_msgs.msg import WrenchStamped
import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import main, replay_bag
from rclpy.serialization import deserialize_message, serialize_message
from rosbag2_decode import read_rosbag2_records
from sim_recorder import rewrite_bag
import yaml

REPO = Path(__file__).resolve().parents[2]
BAGS = sorted(p for p in (REPO / 'bags').iterdir() if p.is_dir())


def test_at_least_three_small_bags_each_described():
    assert len(BAGS) >= 3
    readme = (REPO / 'bags' / 'README.md').read_text()
    for bag in BAGS:
        assert sum(f.stat().st_size for f in bag.iterdir()) < 1_000_000, bag
        assert f'`{bag.name}`' in readme, f'{bag.name} has no line in bags/README.md'


@pytest.mark.parametrize('bag', BAGS, ids=[b.name for b in BAGS])
def test_reference_bag_replays_bit_exact(bag, capsys):
    opened = open_bag(str(bag))
    assert opened.finalised, opened.notes
    assert opened.profile == 'ros2'
    assert opened.config is not None
    result = replay_bag(opened)
    assert result.match, (result.problems, {t: r.first_mismatch
                                            for t, r in result.topics.items()})
    assert result.compared > 0
    assert all(t.bit_exact for t in result.topics.values())
    assert result.wrench_digest_checked  # recorded by the node: it holds the rbd_ros.run record
    assert main([str(bag), '--no-progress']) == 0
    assert capsys.readouterr().out.strip().endswith('MATCH')


@pytest.mark.parametrize('bag', BAGS, ids=[b.name for b in BAGS])
def test_reference_bag_rosbag2_records_decode_as_rosbag2_reads_them(bag):
    """What ros2 bag play/info take from the .mcap: every record decodes, the last is right."""
    opened = open_bag(str(bag))
    records = read_rosbag2_records(opened.mcap_path)
    assert len(records) == 2
    assert records[0]['starting_time'] == 2 ** 63 - 1  # the record made at open
    last = records[-1]
    meta = yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']
    assert last['message_count'] == meta['message_count'] == opened.statistics.message_count
    assert last['relative_file_paths'] == meta['relative_file_paths'] == [
        Path(opened.mcap_path).name]
    assert last['starting_time'] == opened.statistics.message_start_time
    assert last['duration'] == (opened.statistics.message_end_time
                                - opened.statistics.message_start_time)
    assert {t['name']: t['message_count'] for t in last['topics']} == {
        name: info.message_count for name, info in opened.topics.items()}


def test_reference_bag_with_a_wrench_altered_by_one_ulp_is_a_mismatch(tmp_path):
    """The node's digest of what it applied catches a recorded wrench changed in its last bit."""
    def edit(index, raw):
        if raw.topic != '/wrench':
            return None
        msg = deserialize_message(raw.data, WrenchStamped)
        msg.wrench.torque.x = math.nextafter(msg.wrench.torque.x, math.inf)
        return serialize_message(msg)

    altered = rewrite_bag(str(REPO / 'bags' / 'box_pushed'), str(tmp_path / 'altered'),
                          edit=edit)
    result = replay_bag(altered)
    assert not result.match and result.wrench_mismatches == 1
    assert any('not bit for bit' in p for p in result.problems), result.problems


def test_the_reference_set_covers_the_issue():
    """Box pushed in world and body frames; torque-free T-handle; thrusters under gravity."""
    box = open_bag(str(REPO / 'bags' / 'box_pushed'))
    frames = {msg.header.frame_id for _, msg in box.decoded_messages(['/wrench'])}
    assert {'world', 'base_link'} <= frames
    t_handle = open_bag(str(REPO / 'bags' / 't_handle_flip'))
    assert not any(info.type_name.endswith('WrenchStamped') and info.message_count
                   for info in t_handle.topics.values())
    # The flip: body-frame omega_y changes sign during the run.
    omega_y = [msg.twist.twist.angular.y for _, msg in t_handle.decoded_messages(['/odom'])]
    assert max(omega_y) > 5.0 and min(omega_y) < -5.0
    thrusters = open_bag(str(REPO / 'bags' / 'thrusters_gravity'))
    assert thrusters.config['gravity'] == [0.0, 0.0, -9.81]
    assert thrusters.topics['/wrench_left'].message_count > 0
    assert thrusters.topics['/wrench_right'].message_count > 0


def test_the_world_bags_cover_issue_10():
    """A world with a box pushed to a stop; a nonconvex mesh in a bin, its mesh attached."""
    world = open_bag(str(REPO / 'bags' / 'floor_world_push'))
    assert world.config['bodies'] == ['pushed', 'slider', 'ball']
    assert world.topics['/pushed/wrench'].message_count == 2
    for body in world.config['bodies']:
        assert world.topics[f'/{body}/pose'].message_count == 301
        assert world.topics[f'/{body}/contact_wrench'].message_count == 301
    assert world.topics['/poses'].type_name == 'geometry_msgs/msg/PoseArray'
    speeds = [msg.twist.linear.x for _, msg in world.decoded_messages(['/pushed/twist'])]
    assert max(speeds) > 2.0 and abs(speeds[-1]) < 1e-12  # pushed, then stopped by friction
    mesh = open_bag(str(REPO / 'bags' / 'l_block_bin'))
    assert mesh.config['mesh_path'].endswith('l_block.stl')
    attached = mesh.attachments()
    assert attached[mesh.config['mesh_path']] == (
        REPO / 'msg_config' / 'meshes' / 'l_block.stl').read_bytes()
    assert mesh.config['obstacles'] == ['wall_n', 'wall_s', 'wall_e', 'wall_w']
    stack = open_bag(str(REPO / 'bags' / 'stack_knocked'))
    assert stack.topics['/striker/wrench'].message_count == 2
    final = {body: list(stack.decoded_messages([f'/{body}/pose']))[-1][1].pose.position
             for body in ('bottom', 'middle', 'top')}
    assert final['bottom'].x > 0.5  # shoved out from under the column
    # The column fell: the middle box (started at 0.3 m) lies on the floor, its COM at half a
    # side, and the top one (0.5 m) on the floor or on the middle one (0.1 or 0.3 m).  Which
    # of the two is chaotic: a change at round-off in the solver has given either.
    assert abs(final['middle'].z - 0.1) < 1e-6
    assert min(abs(final['top'].z - 0.1), abs(final['top'].z - 0.3)) < 1e-6


@pytest.mark.parametrize('bag', BAGS, ids=[b.name for b in BAGS])
def test_every_message_decodes_with_the_stored_schemas(bag):
    """The ``mcap`` reader with ``mcap-ros2-support`` decodes every message, without rclpy."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory
    opened = open_bag(str(bag))
    counts = {}
    with open(opened.mcap_path, 'rb') as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for schema, channel, message, decoded in reader.iter_decoded_messages():
            assert decoded is not None
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    assert counts == {t: info.message_count for t, info in opened.topics.items()
                      if info.message_count}


def test_a_mesh_bag_replays_from_a_temporary_copy_when_the_cache_is_not_private(
        tmp_path, monkeypatch):
    """The mesh copies follow the cache-folder rule: a shared cache folder is not trusted."""
    shared = tmp_path / 'rbd_ros'
    shared.mkdir()
    shared.chmod(0o777)
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path))
    with pytest.warns(RuntimeWarning, match='writable by group or others.*temporary folder'):
        result = replay_bag(open_bag(str(REPO / 'bags' / 'l_block_bin')))
    assert result.match, result.problems
    assert not (shared / 'bag_meshes').exists()  # nothing written into the shared folder
