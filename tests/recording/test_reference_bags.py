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

from pathlib import Path

import pytest
from rbd_ros.recording import open_bag
from rbd_ros.replay import main, replay_bag

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
    assert main([str(bag), '--no-progress']) == 0
    assert capsys.readouterr().out.strip().endswith('MATCH')


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
