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
A world's outputs as the node scales (issue 29, item 1), through real DDS.

Two balls falling from 10 m and 8 m onto a floor (g = 9.81 m/s², h = 1 ms): before either
touches (t < 1.26 s), ``z(t) = z0 − g t²/2`` exactly up to round-off (the default integrator
integrates a constant force exactly). ``per_body_topics: false`` leaves no per-body output
topic on the graph while ``poses`` and ``/tf`` carry those poses; by default every per-body
topic is there, and a subscriber that comes late, while paused or running, gets its samples
(the node builds a kind only for its subscribers). A flood of bad inputs on a world is
counted and changes nothing.
"""

import math
import time

from conftest import FIRST_START_S, wait_until
from geometry_msgs.msg import PointStamped, PoseArray, PoseStamped, TwistStamped
import pytest
from rbd_ros.bag.replay import replay_bag
from rbd_ros.msgs import conversions
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_context import ros_fixture  # noqa: F401 (the ros fixture)
from std_srvs.srv import SetBool
from tf2_msgs.msg import TFMessage

G = 9.81
HEIGHTS_M = {'high': 10.0, 'low': 8.0}
BODY_KINDS = ('pose', 'twist', 'odom', 'contact_wrench')
# Round-off of ~1,000 kick-drift-kick steps on values of ~10 m: ~1e-12 m; the bound leaves room.
FALL_TOL_M = 1e-9
FLOOD_S = 1.0  # of wall time; the node runs at real time, so the fall lasts beyond it
FREE_FALL_NS = 1_200_000_000  # the low ball (r = 0.1 m) touches at sqrt(2 * 7.9 / g) = 1.27 s
LATE_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.TRANSIENT_LOCAL)


def _world(**extra):
    params = {'gravity': [0.0, 0.0, -G], 'ground.enabled': True, 'timestep_s': 0.001,
              'publish_rate_hz': 100.0, 'body_names': list(HEIGHTS_M)}
    for i, (name, z0) in enumerate(HEIGHTS_M.items()):
        params[f'bodies.{name}.shape'] = 'sphere'
        params[f'bodies.{name}.dimensions_m'] = [0.1]
        params[f'bodies.{name}.initial_position'] = [float(i), 0.0, z0]
    params.update(extra)
    return params


def _node_topics(ros, node_proc, timeout_s, want):
    """
    Return the node's (publisher topics, subscription topics) once ``want(pubs, subs)``.

    Fails at once if the node has exited (it would never come on the graph).
    """
    node, executor = ros
    ns = node_proc.namespace
    found = []

    def look():
        assert node_proc.process.poll() is None, node_proc.stderr
        try:
            pubs = {t for t, _ in node.get_publisher_names_and_types_by_node(
                'rigid_body_node', ns)}
            subs = {t for t, _ in node.get_subscriber_names_and_types_by_node(
                'rigid_body_node', ns)}
        except Exception:  # NodeNameNonExistentError until discovered
            return False
        found[:] = [pubs, subs]
        return want(pubs, subs)
    wait_until(look, timeout_s, spin=lambda: executor.spin_once(timeout_sec=0.05),
               what='the node on the graph')
    return found


def _unpause(ros, ns):
    """Call the node's ``~/pause`` with ``data: false`` and wait for the answer."""
    node, executor = ros
    spin = lambda: executor.spin_once(timeout_sec=0.02)  # noqa: E731
    pause = node.create_client(SetBool, f'{ns}/rigid_body_node/pause')
    wait_until(pause.service_is_ready, 30.0, spin=spin, what='~/pause')
    future = pause.call_async(SetBool.Request(data=False))
    wait_until(future.done, 30.0, spin=spin, what='~/pause')
    assert future.result().success, future.result().message


def _fall_z(name, t_ns):
    t = t_ns * 1e-9
    return HEIGHTS_M[name] - 0.5 * G * t * t


def test_per_body_topics_false_leaves_poses_and_tf_right(ros, start_node, tmp_path):
    # Paused until the test has seen the graph: a 1.6 s run could end before discovery does.
    bag = tmp_path / 'no_per_body'
    node_proc = start_node(_world(per_body_topics=False, real_time_factor=0.5,
                                  duration_s=0.8, start_paused=True, record_path=str(bag)),
                           namespace=True)
    ns = node_proc.namespace
    node, executor = ros
    poses, tfs = {}, {}
    node.create_subscription(PoseArray, f'{ns}/poses', lambda m: poses.__setitem__(
        conversions.time_from_msg(m.header.stamp), m), 1000)
    node.create_subscription(TFMessage, '/tf', lambda m: tfs.__setitem__(
        conversions.time_from_msg(m.transforms[0].header.stamp), m), 1000)
    inputs = {f'{ns}/{b}/{i}' for b in HEIGHTS_M for i in ('wrench', 'drag')}
    pubs, subs = _node_topics(ros, node_proc, FIRST_START_S, lambda p, s: {
        f'{ns}/poses', '/tf', f'{ns}/markers'} <= p and inputs <= s)
    _unpause(ros, ns)
    wait_until(lambda: node_proc.process.poll() is not None, 60.0,
               spin=lambda: executor.spin_once(timeout_sec=0.02), what='the end of the run')
    assert node_proc.wait(5.0) == 0, node_proc.stderr
    for _ in range(20):  # what DDS still holds
        executor.spin_once(timeout_sec=0.02)
    # No per-body output topic; the world's outputs and every input are there.
    assert not {t for t in pubs if t.rsplit('/', 1)[-1] in BODY_KINDS}, pubs
    assert {f'{ns}/poses', '/tf', f'{ns}/markers'} <= pubs, pubs
    assert {f'{ns}/{b}/{i}' for b in HEIGHTS_M for i in ('wrench', 'drag')} <= subs, subs
    # poses and /tf: every body's free fall, and the same values at every stamp.
    stamps = sorted(set(poses) & set(tfs))
    assert len(stamps) >= 10, (len(poses), len(tfs))  # the run publishes 81 in 1.6 s
    for t_ns in stamps:
        assert t_ns < FREE_FALL_NS
        transforms = {tr.child_frame_id: tr.transform.translation
                      for tr in tfs[t_ns].transforms}
        for name, pose in zip(HEIGHTS_M, poses[t_ns].poses):
            assert pose.position.z == pytest.approx(_fall_z(name, t_ns), abs=FALL_TOL_M)
            assert (transforms[name].x, transforms[name].y, transforms[name].z) == (
                pose.position.x, pose.position.y, pose.position.z)
    # The recording replays bit for bit on `poses`, its only record of the bodies' poses
    # (81 samples: 0 to 0.8 s at 100 Hz)...
    result = replay_bag(bag)
    assert result.match, result.problems
    assert {name: topic.samples for name, topic in result.topics.items()} == {f'{ns}/poses': 81}
    assert result.topics[f'{ns}/poses'].bit_exact
    # ... and it compares values: replayed at a 4 ms step (kick-drift-kick still integrates
    # the free fall exactly), each sample at t is held against the state at the first step end
    # t' >= t, so the largest position error is the closed form's max of g (t'^2 - t^2) / 2
    # over the samples (0.0155 m at t = 0.79 s); 1e-9 m covers the round-off of both runs.
    study = replay_bag(bag, timestep_s=0.004, tolerance=1.0)
    samples_ns = range(0, 800_000_001, 10_000_000)
    gaps = [(t_ns, -(-t_ns // 4_000_000) * 4_000_000) for t_ns in samples_ns]
    expected = max(0.5 * G * ((t1 * 1e-9) ** 2 - (t0 * 1e-9) ** 2) for t0, t1 in gaps)
    error = study.topics[f'{ns}/poses'].max_position_error_m
    assert error == pytest.approx(expected, abs=1e-9), (error, expected)


def test_default_topics_and_late_subscribers_paused_and_running(ros, start_node):
    node_proc = start_node(_world(start_paused=True, real_time_factor=0.25), namespace=True)
    ns = node_proc.namespace
    node, executor = ros
    spin = lambda: executor.spin_once(timeout_sec=0.02)  # noqa: E731
    expected = {f'{ns}/{b}/{k}' for b in HEIGHTS_M for k in BODY_KINDS} | {
        f'{ns}/poses', '/tf', f'{ns}/markers', f'{ns}/static_markers', '/diagnostics'}
    inputs = {f'{ns}/{b}/{i}' for b in HEIGHTS_M for i in ('wrench', 'drag')} | {
        '/clicked_point'}
    pubs, subs = _node_topics(ros, node_proc, FIRST_START_S, lambda p, s: expected <= p
                              and inputs <= s)
    # Today's outputs exactly (plus rclpy's own), and every input.
    assert pubs - expected == {'/rosout', '/parameter_events'}, pubs - expected
    assert {f'{ns}/{b}/{i}' for b in HEIGHTS_M for i in ('wrench', 'drag')} | {
        '/clicked_point'} <= subs, subs
    # Paused at t = 0, nobody had subscribed to high/pose: a late subscriber still gets it.
    late = {}
    node.create_subscription(PoseStamped, f'{ns}/high/pose', lambda m: late.__setitem__(
        conversions.time_from_msg(m.header.stamp), m), LATE_QOS)
    wait_until(lambda: 0 in late, 30.0, spin=spin, what='the paused sample on high/pose')
    assert late[0].pose.position.z == HEIGHTS_M['high']  # the initial state, exactly
    _unpause(ros, ns)
    wait_until(lambda: len(late) >= 5, 30.0, spin=spin, what='high/pose while running')
    # Running: another topic nobody listened to answers from the next sample on.
    twists = {}
    node.create_subscription(TwistStamped, f'{ns}/low/twist', lambda m: twists.__setitem__(
        conversions.time_from_msg(m.header.stamp), m), 100)
    wait_until(lambda: len(twists) >= 5, 30.0, spin=spin, what='low/twist, subscribed late')
    # At a factor of 0.25 the fall lasts 4.8 s of wall time: these samples are of it.
    assert min(twists) < FREE_FALL_NS, sorted(twists)
    for t_ns, msg in twists.items():
        if t_ns < FREE_FALL_NS:  # falling freely: v_z = -g t (round-off: ~1e-12 m/s)
            assert msg.twist.linear.z == pytest.approx(-G * t_ns * 1e-9, abs=FALL_TOL_M)
    for t_ns, msg in late.items():
        if t_ns < FREE_FALL_NS:
            assert msg.pose.position.z == pytest.approx(_fall_z('high', t_ns), abs=FALL_TOL_M)
    assert node_proc.stop() == 0, node_proc.stderr


def _counters(msg):
    return {kv.key: float(kv.value) for kv in msg.status[0].values
            if kv.key.startswith(('wrenches_', 'drags_'))}


def test_a_flood_of_bad_inputs_on_a_world_is_counted_and_changes_nothing(ros, start_node):
    # Issue 30, item 3, briefly: /clicked_point, <body>/drag and <body>/wrench flooded with
    # NaN, out-of-frame and out-of-range values as fast as one publisher can; every one is bad.
    # Without gravity the balls rest where they start: any input that took effect moves one.
    node_proc = start_node(_world(real_time_factor=1.0, gravity=[0.0, 0.0, 0.0]),
                           namespace=True)
    ns = node_proc.namespace
    node, executor = ros
    spin = lambda: executor.spin_once(timeout_sec=0.01)  # noqa: E731
    poses, diagnostics = {}, []
    node.create_subscription(PoseArray, f'{ns}/poses', lambda m: poses.__setitem__(
        conversions.time_from_msg(m.header.stamp), m), 1000)
    node.create_subscription(
        conversions.DiagnosticArray, '/diagnostics', lambda m: diagnostics.append(m)
        if m.status and m.status[0].name.startswith(f'{ns}/rigid_body_node:') else None, 100)
    wrench = node.create_publisher(conversions.WrenchStamped, f'{ns}/high/wrench', 10)
    drag = node.create_publisher(PointStamped, f'{ns}/low/drag', 10)
    click = node.create_publisher(PointStamped, '/clicked_point', 10)
    wait_until(lambda: min(p.get_subscription_count() for p in (wrench, drag, click)) > 0
               and len(diagnostics) >= 2 and poses, FIRST_START_S, spin=spin,
               what='the world node')
    before = _counters(diagnostics[-1])
    before_ns = max(poses)
    nan = float('nan')
    bad_wrenches = [conversions.wrench_to_msg('not_a_frame', (1.0, 0.0, 0.0), (0.0,) * 3),
                    conversions.wrench_to_msg('world', (nan, 0.0, 0.0), (0.0,) * 3),
                    conversions.wrench_to_msg('world', (1e300, 0.0, 0.0), (0.0,) * 3)]
    bad_points = []
    for frame, point in (('not_a_frame', (0.0, 0.0, 8.0)), ('world', (nan, 0.0, 8.0)),
                         ('world', (1e12, 0.0, 0.0))):
        msg = PointStamped()
        msg.header.frame_id = frame
        msg.point.x, msg.point.y, msg.point.z = point
        bad_points.append(msg)
    sent, end = 0, time.monotonic() + FLOOD_S
    while time.monotonic() < end:
        for i in range(3):
            wrench.publish(bad_wrenches[i])
            drag.publish(bad_points[i])
            click.publish(bad_points[i])
        sent += 9
        if sent % 900 == 0:
            spin()
    # The counters settle once the node has worked off what DDS kept (keep last 10).
    wait_until(lambda: len(diagnostics) >= 2 and _counters(diagnostics[-1]) == _counters(
        diagnostics[-2]) != before, 30.0, spin=spin, what='the counters to settle')
    after = _counters(diagnostics[-1])
    assert node_proc.stop() == 0, node_proc.stderr
    delta = {key: after[key] - before[key] for key in after}
    # Every input taken was bad and counted as rejected (received <= sent: DDS drops the rest).
    assert 0 < delta['wrenches_received'] <= sent, delta
    assert delta['wrenches_rejected'] == delta['wrenches_received'], delta
    assert 0 < delta['drags_received'] <= sent, delta
    assert delta['drags_rejected'] == delta['drags_received'], delta
    # The state stayed finite and exactly at rest, through the flood (no bad input took effect).
    assert max(poses) > before_ns + FLOOD_S * 1e9 * 0.5, (before_ns, max(poses))
    for msg in poses.values():
        for i, (name, pose) in enumerate(zip(HEIGHTS_M, msg.poses)):
            position = (pose.position.x, pose.position.y, pose.position.z)
            assert all(map(math.isfinite, position)) and position == (
                float(i), 0.0, HEIGHTS_M[name]), (name, position)
