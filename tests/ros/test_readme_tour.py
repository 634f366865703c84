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
The README's 30-second tour as printed: its messages, sent to a node on stack.yaml, do as it says.

The tour's ``ros2 topic pub`` lines are read from the README (topic, type, YAML) and published
by rclpy, as ``ros2 topic pub --once`` would (ros2cli is not among the PyPI wheels): the striker
pushed at 40 N slides into the column, the dragged top box is pulled towards its point, every
body is in ``poses``, and the recording replays and plots with ``--animate``.
"""

import importlib
import re
import subprocess
import sys

from conftest import FIRST_START_S, REPO
from geometry_msgs.msg import PoseArray
from rbd_ros.bag.recording import open_bag
from ros_probe import call
from std_srvs.srv import SetBool
import yaml

PUB = re.compile(r'^ros2 topic pub --once (\S+) (\S+) "(.*)"$')


def tour_messages():
    """Return ``[(topic, message)]`` of the tour's ``ros2 topic pub`` lines, in order."""
    text = (REPO / 'README.md').read_text(encoding='utf-8')
    tour = text[text.index('## A 30-second tour'):]
    block = re.search(r'```bash\n(.*?)```', tour, re.S).group(1)
    found = []
    for line in block.splitlines():
        match = PUB.match(line.strip())
        if match:
            topic, kind, fields = match.groups()
            package, _, name = kind.split('/')
            msg = getattr(importlib.import_module(f'{package}.msg'), name)()
            _set_fields(msg, yaml.safe_load(fields))
            found.append((topic, msg))
    return found


def _set_fields(msg, values):
    for key, value in values.items():
        if isinstance(value, dict):
            _set_fields(getattr(msg, key), value)
        else:
            setattr(msg, key, float(value) if isinstance(value, (int, float)) else value)


def test_the_tour_pushes_the_striker_drags_the_top_box_and_the_bag_replays(
        tmp_path, start_node, probe_for):
    messages = tour_messages()
    assert [topic for topic, _ in messages] == ['striker/wrench', 'striker/wrench', 'top/drag']
    bag = tmp_path / 'stack'
    node = start_node({'start_paused': True, 'record_path': str(bag), 'real_time_factor': 2.0},
                      params_file=REPO / 'msg_config' / 'stack.yaml', namespace=True)
    probe = probe_for(node, inputs=(), outputs=('diagnostics',))
    poses = []
    probe.node.create_subscription(PoseArray, 'poses', poses.append, 100)
    pubs = {topic: probe.node.create_publisher(type(msg), topic, 10) for topic, msg in messages}
    probe.wait(lambda: all(p.get_subscription_count() for p in pubs.values()), FIRST_START_S,
               'the tour topics')
    assert call(probe, SetBool, 'pause', SetBool.Request(data=False)).success
    probe.wait(lambda: poses, 60.0, 'poses')
    start = [p.position.x for p in poses[-1].poses]  # bottom, middle, top, striker
    for (topic, msg), hold_s in zip(messages, (0.4, 0.0, 2.0)):
        pubs[topic].publish(msg)
        sent = len(poses)
        probe.wait(lambda: len(poses) >= sent + max(1, int(hold_s * 100)), 60.0,
                   f'{hold_s} s of poses after {topic}')
    end = [p.position.x for p in poses[-1].poses]
    assert len(end) == 4  # every body of stack.yaml, in body_names order
    # 40 N for ~0.4 s on the 2 kg striker: 8 m/s² against μ g = 4.9 m/s² of friction, so it
    # moves by several cm towards the column (at x = -0.8 + 0.2 it meets the bottom box).
    assert end[3] - start[3] > 0.05, (start, end)
    # The top box, dragged towards x = 0.5 m by a 50 N/m spring, moves in +x.
    assert end[2] - start[2] > 0.05, (start, end)
    assert node.stop() == 0, node.stderr
    assert open_bag(bag).finalised
    replay = subprocess.run([sys.executable, '-m', 'rbd_ros.bag.replay', str(bag),
                             '--no-progress'],
                            capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert replay.returncode == 0 and replay.stdout.strip().splitlines()[-1].startswith('MATCH'), \
        replay.stdout + replay.stderr
    gif = tmp_path / 'stack.gif'
    plot = subprocess.run([sys.executable, '-m', 'rbd_ros.bag.plot', str(bag), '-o',
                           str(tmp_path / 'stack.png'), '--animate', str(gif)],
                          capture_output=True, text=True, timeout=600, cwd=tmp_path)
    assert plot.returncode == 0, plot.stdout + plot.stderr
    assert gif.stat().st_size > 10_000  # frames of the world, not an empty file
