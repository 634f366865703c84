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
A node that cannot keep up with the wall clock still takes its wrenches promptly.

A world of resting boxes costs about a millisecond of wall time per 1 ms step, so at
``real_time_factor`` 0 (as fast as possible) and at 10 (always behind) every tick has far more
steps due than it can take. The node must still serve its subscriptions every tick budget
(10 ms of wall time), not after a whole backlog of up to 1000 steps. Measured from outside:
the sim time of the newest sample the test has seen when it sends a wrench, against the sim
time at which the node's recording says that wrench took effect.
"""

import glob
import statistics
import time

from conftest import FIRST_START_S, NodeProcess, wait_until
from geometry_msgs.msg import PoseStamped
from mcap.reader import make_reader
import pytest
from rbd_ros.msgs import conversions
from ros_context import ros_fixture  # noqa: F401 - the fixture ros

BODIES = 150
TRIALS = 9
STEP_NS = 1_000_000
# A node that stepped its whole backlog (up to 1000 steps) before serving messages would take
# the wrenches here, sent 0.1 s apart, one per backlog: hundreds to thousands of
# steps late (the node before this test took 2 of 9 within 3000 steps). Serving every 10 ms at
# about 1 ms a step, the gap is the ~10 steps of the budget, rounded up to a sample (a tick
# ends at one), plus the steps taken while the messages cross DDS (a few ms each way) and the
# test process runs. 500 steps, half a backlog, leaves ~450 ms of wall time for that: a full CI
# run on two workers measured a median of 260 steps (the node and the test each waiting for a
# core), far from the thousands of steps of a node that steps its backlog first.
MEDIAN_GAP_STEPS = 500


def world_params(record_path, real_time_factor):
    """Return the params of resting boxes on a floor (a grid), recorded, at the given factor."""
    names = [f'b{i}' for i in range(BODIES)]
    params = {'gravity': [0.0, 0.0, -9.81], 'ground.enabled': True, 'body_names': names,
              'publish_rate_hz': 50.0, 'timestep_s': STEP_NS * 1e-9,
              'real_time_factor': real_time_factor, 'record_path': record_path}
    for i, name in enumerate(names):
        params[f'bodies.{name}.shape'] = 'box'
        params[f'bodies.{name}.dimensions_m'] = [0.1, 0.1, 0.1]
        params[f'bodies.{name}.initial_position'] = [0.2 * (i % 12), 0.2 * (i // 12), 0.05]
    return params


@pytest.mark.parametrize('real_time_factor', [0.0, 10.0])
def test_a_node_behind_the_wall_clock_takes_wrenches_within_its_tick_budget(
        tmp_path, ros, real_time_factor):
    node, executor = ros
    record = tmp_path / 'behind'
    node_proc = NodeProcess(tmp_path, world_params(str(record), real_time_factor),
                            namespace=True)
    ns = node_proc.namespace
    spin = lambda: executor.spin_once(timeout_sec=0.02)  # noqa: E731
    stamps = []
    # Keep-last 1: what the test has seen last is the newest sample delivered, not one queued.
    node.create_subscription(PoseStamped, f'{ns}/b0/pose', lambda m: stamps.append(
        conversions.time_from_msg(m.header.stamp)), 1)
    pushes = [node.create_publisher(conversions.WrenchStamped, f'{ns}/b{k + 1}/wrench', 10)
              for k in range(TRIALS)]
    sent_after = []
    try:
        wait_until(lambda: all(p.get_subscription_count() > 0 for p in pushes) and stamps,
                   FIRST_START_S, spin=spin, what='the world node (a first start may compile)')
        for push in pushes:
            # Each wrench alone in the node's queue: a wake-up serves one message and then ticks
            # for up to the tick budget, so wrenches sent closer together than that wait behind
            # each other. Sent one fresh sample apart (~10 ms of wall now that a step of this
            # world costs ~0.5 ms), they queued up: the gaps grew trial by trial (60, 80, ...,
            # 245 steps; 197 to 1428 in another run) and failed the bound under load. 0.1 s
            # (ten tick budgets) apart, the gaps stay ~40-140 steps at load 6.
            apart = time.monotonic() + 0.1
            wait_until(lambda: time.monotonic() > apart, 60.0, spin=spin, what='0.1 s')
            seen = len(stamps)
            wait_until(lambda: len(stamps) > seen, 60.0, spin=spin, what='a fresh sample')
            sent_after.append(stamps[-1])  # the newest sample seen: the node is past it
            # 1 N sideways on a 1 kg box, well inside its friction cone (0.5 * 9.81 N).
            push.publish(conversions.wrench_to_msg('world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
        # Run on well past the last wrench (3 backlogs): the recording then holds every one.
        wait_until(lambda: stamps[-1] > sent_after[-1] + 3000 * STEP_NS, 60.0, spin=spin,
                   what='3000 more steps after the last wrench')
    finally:
        assert node_proc.stop() == 0, node_proc.stderr
    (bag,) = glob.glob(str(record / '*.mcap'))
    topics = [f'{ns}/b{k + 1}/wrench' for k in range(TRIALS)]
    applied = {}  # the sim time at which each wrench took effect, as recorded
    with open(bag, 'rb') as f:
        for _, channel, message in make_reader(f).iter_messages(topics=topics):
            applied[channel.topic] = message.log_time
    # A wrench not in the recording took effect more than 3000 steps after it was sent.
    gaps = [(applied[t] - s) // STEP_NS if t in applied else float('inf')
            for t, s in zip(topics, sent_after)]
    assert min(gaps) >= 0, gaps  # a wrench never takes effect before a sample seen
    assert statistics.median(gaps) < MEDIAN_GAP_STEPS, gaps
    assert max(gaps) < float('inf'), gaps
