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
``threads`` through the real node: a world's islands on threads give the serial bits.

The README says a world's islands are stepped on ``threads`` cores. Two nodes run the same
world of two separated piles of boxes falling onto the floor (two groups of islands, so the
threaded step has parts to share out), one with ``threads: 1`` and one with ``threads: 2``;
their recordings, read with the ``mcap`` library (not rbd_ros's reader), hold the same bytes
on every output topic, and each replays MATCH. A ``threads`` of 0 is refused in one line.
"""

import collections
import math
import pathlib

from conftest import NodeProcess
from mcap.reader import make_reader
from rbd_ros.bag.replay import replay_bag

OUTPUTS = ('/poses', '/tf')


def _piles():
    """Two 3 x 4 piles of 0.1 m boxes, 3 m apart, dropped from a little above the floor."""
    params = {'gravity': [0.0, 0.0, -9.81], 'ground.enabled': True, 'timestep_s': 0.001,
              'publish_rate_hz': 100.0, 'duration_s': 0.4, 'real_time_factor': 0.0,
              'body_names': []}
    for pile, x0 in (('a', 0.0), ('b', 3.0)):
        for i in range(3):
            for k in range(4):
                name = f'{pile}{i}{k}'
                params['body_names'].append(name)
                params[f'bodies.{name}.shape'] = 'box'
                params[f'bodies.{name}.dimensions_m'] = [0.1, 0.1, 0.1]
                # a column of 4 per (pile, i), 1 mm gaps, each box turned a little
                params[f'bodies.{name}.initial_position'] = [x0 + 0.3 * i, 0.0,
                                                             0.06 + 0.101 * k]
                half = 0.01 * k  # a turn of 0.02 k rad about z
                params[f'bodies.{name}.initial_orientation'] = [0.0, 0.0, math.sin(half),
                                                                math.cos(half)]
    return params


def _outputs(bag_dir):
    """Return ``{topic: [(log time, bytes)]}`` of the recording, read with ``mcap``."""
    found = collections.defaultdict(list)
    (path,) = pathlib.Path(bag_dir).glob('*.mcap')
    with open(path, 'rb') as f:
        for _, channel, message in make_reader(f).iter_messages():
            if channel.topic in OUTPUTS:
                found[channel.topic].append((message.log_time, message.data))
    return found


def test_islands_on_two_threads_publish_the_serial_bits(tmp_path):
    recorded = {}
    for threads in (1, 2):
        bag = tmp_path / f'threads{threads}'
        params = {**_piles(), 'threads': threads, 'record_path': str(bag)}
        node = NodeProcess(tmp_path, params, namespace=False)
        try:
            assert node.wait(300) == 0, node.stderr
        finally:
            node.stop()
        recorded[threads] = _outputs(bag)
        result = replay_bag(bag)
        assert result.match, result.problems
    one, two = recorded[1], recorded[2]
    # 0.4 s at 100 Hz: the samples at 0, 10, ..., 400 ms on each topic
    assert [len(one[topic]) for topic in OUTPUTS] == [41, 41], {t: len(v) for t, v in one.items()}
    for topic in OUTPUTS:
        assert one[topic] == two[topic], topic
    # the boxes moved (the piles fell and settled): the samples are not all the first one
    assert len({data for _, data in one['/poses']}) > 10


def test_threads_of_zero_is_refused_in_one_line(tmp_path):
    node = NodeProcess(tmp_path, {**_piles(), 'threads': 0}, namespace=False)
    try:
        assert node.wait(120) == 2, node.stderr
    finally:
        node.stop()
    lines = [line for line in node.stderr.splitlines() if 'threads' in line]
    assert lines and 'parameter threads = 0: must be >= 1' in lines[0], node.stderr
