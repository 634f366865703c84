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
Drag and click limits through real DDS (issue 31 item 3).

A drag spring obeys the wrench limits (``max_force_n``, ``max_torque_nm``) when a point takes
effect; a point farther than ``max_drag_point_m`` from the origin is rejected; a paused node
keeps only the latest point per input.
"""

import time

from conftest import FIRST_START_S, REPO
from geometry_msgs.msg import PointStamped
import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.msgs import conversions
from ros_probe import point


def _start(start_node, probe_for, params):
    # publish_rate_hz = 1 / timestep_s: every ~/step publishes a pose (probe.step waits for it)
    node = start_node({'start_paused': True, 'publish_rate_hz': 1000.0, **params},
                      params_file=REPO / 'msg_config' / 'default.yaml', namespace=True)
    probe = probe_for(node, inputs=())
    drag = probe.node.create_publisher(PointStamped, 'drag', 1000)
    click = probe.node.create_publisher(PointStamped, '/clicked_point', 1000)
    probe.wait_connected(FIRST_START_S)
    probe.wait(lambda: drag.get_subscription_count() and click.get_subscription_count(), 60.0,
               'the drag subscriptions')
    return node, probe, drag, click


def _counters(probe, received):
    """Return the drag counters once the node has counted ``received`` points (~1 Hz)."""
    values = probe.diagnostic_values(lambda v: int(v['drags_received']) >= received, 60.0)
    return int(values['drags_received']), int(values['drags_rejected'])


def _settled(probe):
    """Return ``drags_received`` once two consecutive diagnostics (~1 s apart) agree."""
    probe.diagnostics.clear()

    def same():
        last = [int({kv.key: kv.value for kv in m.status[0].values}['drags_received'])
                for m in probe.diagnostics[-2:]]
        return len(last) == 2 and last[0] == last[1] and last[0]
    return probe.wait(same, 60.0, 'the drag counters to settle')


def test_far_points_and_over_limit_springs_are_rejected_and_counted(start_node, probe_for):
    # The default box rests on the floor, COM at z = 0.025 m; k = 50 N/m, c = 5 N·s/m.
    node, probe, drag, click = _start(start_node, probe_for, {'max_force_n': 10.0})
    drag.publish(point(1e9, 0.0, 0.1))  # |point| 1e9 m > max_drag_point_m = 1e3 m
    # The node warns of rejections at most once a second, and two publishers' messages may
    # arrive in either order: the click goes out once the drag's warning has been let through.
    assert _counters(probe, 1) == (1, 1)
    time.sleep(1.1)
    click.publish(point(1e300, 0.0, 0.3))  # the click that stopped a world for good
    # k |d| = 50 N/m × |(0.5, 0, 0.275)| m = 28.5 N > max_force_n = 10 N (the box is at rest,
    # so c ẋ = 0): rejected when it takes effect, at the next step start.
    drag.publish(point(0.5, 0.0, 0.3))
    assert _counters(probe, 3) == (3, 2)
    time.sleep(1.1)  # let the force-limit warning through the throttle too
    probe.step()
    assert probe.diagnostic_values(lambda v: int(v['drags_rejected']) == 3, 60.0)
    t = probe.step(10)
    z = conversions.vector_from_msg(probe.samples['pose'][t].pose.position)
    assert z[0] == 0.0 and z[2] == pytest.approx(0.025, abs=1e-9)  # not dragged (round-off)
    # Within the limit: k |d| = 50 × 0.1 = 5 N <= 10 N is accepted and pulls the box along x.
    drag.publish(point(0.1, 0.0, 0.025))
    assert _counters(probe, 4) == (4, 3)
    t = probe.step(20)
    assert conversions.vector_from_msg(probe.samples['pose'][t].pose.position)[0] > 0.0
    assert node.stop() == 0, node.stderr
    assert 'drag point rejected (distance): drag: |point| = 1e+09 m exceeds max_drag_point_m' \
        in node.stderr
    assert 'drag point rejected (force_limit): drag: |force| = 28.5' in node.stderr


def test_a_click_whose_spring_torque_exceeds_max_torque_nm_is_rejected(start_node, probe_for):
    node, probe, drag, click = _start(start_node, probe_for, {'max_torque_nm': 0.01})
    click.publish(point(0.0, 0.0, 0.05))  # on the top face: grabbed there, at r = 0.025 m z
    assert _counters(probe, 1) == (1, 0)
    probe.step()  # a zero-length spring on a body at rest: f = 0, accepted
    # The move: f = k (0.5, 0, 0) m = (25, 0, 0) N at r = (0, 0, 0.025) m, |r × f| = 0.625 N·m
    # > max_torque_nm = 0.01 N·m (|f| = 25 N is within max_force_n = 1e6 N).
    click.publish(point(0.5, 0.0, 0.05))
    assert _counters(probe, 2) == (2, 0)
    probe.step()
    assert probe.diagnostic_values(lambda v: int(v['drags_rejected']) == 1, 60.0)
    assert node.stop() == 0, node.stderr
    assert 'drag point rejected (torque_limit): clicked_point: |torque| = 0.625 N·m' \
        in node.stderr


def test_a_paused_node_keeps_only_the_latest_point_per_input(tmp_path, start_node, probe_for):
    node, probe, drag, click = _start(start_node, probe_for,
                                      {'record_path': str(tmp_path / 'flood')})
    n = 200
    for i in range(n):
        drag.publish(point(0.0, 0.0, 0.1 + 1e-3 * i))
        click.publish(point(5.0, 5.0, 0.1 + 1e-3 * i))  # far from the box: does nothing
        time.sleep(0.002)  # a flood, paced so the node's depth-10 queues rarely drop one
    received = _settled(probe)
    assert received >= 20  # a flood (a loaded machine may drop some; most arrive)
    probe.step()
    assert node.stop() == 0, node.stderr
    # Every applied point is recorded: one per input took effect at the step start.
    bag = open_bag(str(tmp_path / 'flood'))
    counts = {t: info.message_count for t, info in bag.topics.items()}
    assert counts[f'{node.namespace}/drag'] == 1 and counts['/clicked_point'] == 1
