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
A world of bodies in one node, through real DDS: ``msg_config/floor_world.yaml``.

Three bodies on a floor (μ 0.5, g 9.81 m/s²), each compared with its closed form from the
node's published (and recorded) values: a box launched at 2 m/s stops after ``v0²/(2 μ g)``;
a ball launched at 1 m/s without spin ends rolling at ``5/7 v0``; a box pushed on its own
``<body>/wrench`` with 10 N from t_on to t_off stops after ``a T²/2 + (a T)²/(2 μ g)``,
``a = F/m − μ g``. Per-body topics agree with ``poses`` and ``/tf``; the bag replays bit for
bit; bad world files exit 2 naming the parameter. And ``msg_config/stack.yaml`` at rest: each
box of the column reads its own weight on ``contact_wrench``; ``msg_config/cradle.yaml``'s
striker hands its motion through a row of four balls to the last.
"""

from conftest import FIRST_START_S, NodeProcess, REPO, wait_until
from geometry_msgs.msg import PoseArray, PoseStamped, TwistStamped
import numpy as np
import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import main as replay_main
from rbd_ros.msgs import conversions
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.serialization import deserialize_message
from std_srvs.srv import SetBool
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

G, MU = 9.81, 0.5
BODIES = ('pushed', 'slider', 'ball')
END_NS = 3_000_000_000


def _messages(bag, topic, msg_type):
    return {raw.log_time_ns: deserialize_message(raw.data, msg_type)
            for raw in bag.messages([topic])}


@pytest.fixture(scope='module')
def world_run(module_tmp):
    """Run floor_world.yaml for 3 s, pushing ``pushed`` 10 N from ~0.5 s to ~1 s; the bag."""
    node_proc = NodeProcess(module_tmp, {
        'start_paused': True, 'real_time_factor': 1.0, 'duration_s': 3.0,
        'record_path': str(module_tmp / 'world')},
        params_file=REPO / 'msg_config' / 'floor_world.yaml', namespace=True)
    context = rclpy.Context()
    context.init()
    node = rclpy.create_node('world_talker', context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    ns = node_proc.namespace
    spin = lambda: executor.spin_once(timeout_sec=0.02)  # noqa: E731
    poses = {}
    node.create_subscription(PoseStamped, f'{ns}/pushed/pose',
                             lambda m: poses.__setitem__(conversions.time_from_msg(
                                 m.header.stamp), m), 100)
    push = node.create_publisher(conversions.WrenchStamped, f'{ns}/pushed/wrench', 10)
    pause = node.create_client(SetBool, f'{ns}/rigid_body_node/pause')
    try:
        wait_until(lambda: push.get_subscription_count() > 0 and pause.service_is_ready(),
                   FIRST_START_S, spin=spin, what='the world node (a first start may compile)')
        future = pause.call_async(SetBool.Request(data=False))
        wait_until(future.done, 30.0, spin=spin, what='~/pause')
        for t_ns, force in ((500_000_000, 10.0), (1_000_000_000, 0.0)):
            wait_until(lambda: poses and max(poses) >= t_ns, 60.0, spin=spin,
                       what=f'sim time {t_ns} ns')
            push.publish(conversions.wrench_to_msg('world', (force, 0.0, 0.0), (0.0, 0.0, 0.0)))
        assert node_proc.wait(120.0) == 0, node_proc.stderr
    finally:
        node_proc.stop()
        executor.shutdown()
        node.destroy_node()
        context.try_shutdown()
    return ns, open_bag(str(module_tmp / 'world'))


def test_every_body_has_its_topics_and_the_world_its_own(world_run):
    ns, bag = world_run
    types = {topic: info.type_name for topic, info in bag.topics.items()}
    for body in BODIES:
        assert types[f'{ns}/{body}/pose'] == 'geometry_msgs/msg/PoseStamped'
        assert types[f'{ns}/{body}/odom'] == 'nav_msgs/msg/Odometry'
        assert types[f'{ns}/{body}/contact_wrench'] == 'geometry_msgs/msg/WrenchStamped'
        assert types[f'{ns}/{body}/wrench'] == 'geometry_msgs/msg/WrenchStamped'
    assert types[f'{ns}/poses'] == 'geometry_msgs/msg/PoseArray'
    assert types['/tf'] == 'tf2_msgs/msg/TFMessage'
    assert f'{ns}/pose' not in types  # no single-body topics in a world


def test_each_body_ends_where_its_closed_form_says(world_run):
    ns, bag = world_run
    final = {b: _messages(bag, f'{ns}/{b}/pose', PoseStamped)[END_NS].pose.position
             for b in BODIES}
    # The 0.05 % bound on a sliding stop (the core measures ~4e-7 relative at 1 ms).
    assert final['slider'].x == pytest.approx(2.0 ** 2 / (2 * MU * G), rel=5e-4)
    # The pushed box: from the recorded push times (the steps they took effect at).
    t_on, t_off = (raw.log_time_ns * 1e-9 for raw in bag.messages([f'{ns}/pushed/wrench']))
    a = 10.0 / 1.0 - MU * G
    v = a * (t_off - t_on)
    assert final['pushed'].x == pytest.approx(0.5 * a * (t_off - t_on) ** 2
                                              + v * v / (2 * MU * G), rel=5e-4)
    # The ball rolls on at 5/7 v0 (its spin-up ends at 2 v0 / (7 μ g) = 0.058 s); the rolling
    # speed is reached exactly by the impulse that stops the slip (core: ~1e-12 relative).
    twist = _messages(bag, f'{ns}/ball/twist', TwistStamped)[END_NS].twist
    assert twist.linear.x == pytest.approx(5.0 / 7.0, rel=1e-9)
    assert twist.angular.y == pytest.approx(5.0 / 7.0 / 0.1, rel=1e-9)  # ω = v / r, rolling


def test_pose_array_tf_and_per_body_poses_agree(world_run):
    ns, bag = world_run
    arrays = _messages(bag, f'{ns}/poses', PoseArray)
    tfs = _messages(bag, '/tf', TFMessage)
    assert arrays.keys() == tfs.keys() and len(arrays) == 301  # 3 s at 100 Hz, and t = 0
    for i, body in enumerate(BODIES):
        for t, msg in _messages(bag, f'{ns}/{body}/pose', PoseStamped).items():
            assert arrays[t].poses[i] == msg.pose  # bit for bit: one state, one sample
            transform = tfs[t].transforms[i]
            assert transform.header.frame_id == 'world' and transform.child_frame_id == body
            p, q = transform.transform.translation, transform.transform.rotation
            assert (p.x, p.y, p.z) == (msg.pose.position.x, msg.pose.position.y,
                                       msg.pose.position.z)
            o = msg.pose.orientation
            assert (q.x, q.y, q.z, q.w) == (o.x, o.y, o.z, o.w)


def test_a_box_at_rest_in_the_world_feels_minus_m_g(world_run):
    ns, bag = world_run
    wrench = _messages(bag, f'{ns}/slider/contact_wrench',
                       conversions.WrenchStamped)[END_NS].wrench
    force = np.array([wrench.force.x, wrench.force.y, wrench.force.z])
    np.testing.assert_allclose(force, [0.0, 0.0, G], rtol=0, atol=1e-9)  # round-off


def _run_unpushed(tmp_path, config):
    """Run ``msg_config/<config>.yaml`` for 1 s unpushed, 100× real time; its namespace, bag."""
    node_proc = NodeProcess(tmp_path, {
        'start_paused': False, 'real_time_factor': 100.0, 'duration_s': 1.0,
        'record_path': str(tmp_path / config)},
        params_file=REPO / 'msg_config' / f'{config}.yaml', namespace=True)
    try:
        assert node_proc.wait(FIRST_START_S) == 0, node_proc.stderr
    finally:
        node_proc.stop()
    return node_proc.namespace, open_bag(str(tmp_path / config))


def test_each_box_of_a_resting_column_feels_its_own_weight(tmp_path):
    # msg_config/stack.yaml unpushed: three 1 kg boxes stacked exactly, read back from the
    # node's own recording. Each box's net contact force is its weight, m g up (2 m g from
    # below, m g from the box above), and no torque about its COM (the stack is symmetric).
    # A solver that stops short of converging and leaves shock propagation to finish records
    # the lower boxes' reactions short (a 10-box column's bottom box read 3.5 N for 9.81 N).
    ns, bag = _run_unpushed(tmp_path, 'stack')
    for body in ('bottom', 'middle', 'top'):
        wrenches = _messages(bag, f'{ns}/{body}/contact_wrench', conversions.WrenchStamped)
        assert max(wrenches) == 1_000_000_000
        for t_ns in sorted(wrenches)[-10:]:  # the last 0.1 s
            w = wrenches[t_ns].wrench
            # Measured: within 1e-7 N over the last 0.1 s; before the sweeps were warm-started
            # the bottom box read 9.797 N (13 mN short). 1e-6 N is 10× the measured error.
            np.testing.assert_allclose([w.force.x, w.force.y, w.force.z], [0.0, 0.0, G],
                                       rtol=0, atol=1e-6, err_msg=f'{body} at {t_ns} ns')
            np.testing.assert_allclose([w.torque.x, w.torque.y, w.torque.z], [0.0] * 3,
                                       rtol=0, atol=1e-6, err_msg=f'{body} at {t_ns} ns')


def test_newtons_cradle_hands_the_motion_to_the_last_ball(tmp_path):
    # msg_config/cradle.yaml: the striker b0 at 1 m/s, 5 cm from four touching balls on a
    # frictionless floor, ε = 1. Equal balls exchange their velocities in each collision, so
    # from the hit (t = gap / v = 0.05 s) b4 moves on at 1 m/s and b0-b3 are at rest. Read back
    # from the node's own recording at 1 s.
    ns, bag = _run_unpushed(tmp_path, 'cradle')
    end = 1_000_000_000
    speed = {b: _messages(bag, f'{ns}/{b}/twist', TwistStamped)[end].twist.linear
             for b in ('b0', 'b1', 'b2', 'b3', 'b4')}
    x = {b: _messages(bag, f'{ns}/{b}/pose', PoseStamped)[end].pose.position.x
         for b in ('b0', 'b4')}
    # Velocities: each exchange is exact to round-off (measured: b4 1 m/s to the bit, 5.6e-17
    # m/s left to the others); 1e-12 m/s bounds round-off of 1 m/s over a few impulses.
    assert speed['b4'].x == pytest.approx(1.0, abs=1e-12)
    for b in ('b0', 'b1', 'b2', 'b3'):
        assert abs(speed[b].x) <= 1e-12 and abs(speed[b].y) <= 1e-12, (b, speed[b])
    # Positions: contact is speculative, so a collision is resolved in the step whose end
    # would reach it: up to one step early, v h = 1 mm (b0 stops up to 1 mm short of b1, b4
    # leaves up to 1 ms early).
    assert x['b4'] == pytest.approx(0.85 + 1.0 * (1.0 - 0.05), abs=1e-3)
    assert x['b0'] == pytest.approx(0.05, abs=1e-3)


def test_the_world_bag_replays_bit_for_bit(world_run):
    ns, bag = world_run
    assert replay_main([bag.path, '--no-progress']) == 0


@pytest.mark.parametrize('params, text', [
    ({'body_names': ['a', 'a']}, "parameter body_names = ['a', 'a']: names must be distinct"),
    ({'body_names': ['a'], 'bodies.b.mass_kg': 2.0}, 'parameter bodies.b.mass_kg = 2.0'),
    ({'body_names': ['a'], 'mass_kg': 2.0}, 'parameter mass_kg = 2.0 kg: with body_names'),
    ({'body_names': ['a', 'b'], 'bodies.b.initial_position': [0.0, 0.0, 0.01]},
     'parameter bodies.a.initial_position = [0.0, 0.0, 0.0] m puts the body'),
    ({'body_names': ['a'], 'bodies.a.mesh_path': 'nowhere.stl'}, 'parameter bodies.a.mesh_path'),
    ({'body_names': ['a'], 'ground.enabled': True},
     'parameter bodies.a.initial_position = [0.0, 0.0, 0.0] m puts the body'),
    ({'body_names': ['a'], 'bodies.a.wrench_input_names': ['x'],
      'bodies.a.wrench_inputs.x.topic': '/poses'}, '/poses'),
])
def test_bad_world_files_give_one_line_and_exit_2(start_node, params, text):
    node = start_node(params)
    assert node.wait(120) == 2, node.stderr
    assert text in node.stderr, node.stderr
    assert len(node.stderr.strip().splitlines()) == 1, node.stderr


def test_markers_show_every_body_at_its_recorded_pose(world_run):
    ns, bag = world_run
    arrays = _messages(bag, f'{ns}/markers', MarkerArray)
    assert len(arrays) == 301
    poses = {b: _messages(bag, f'{ns}/{b}/pose', PoseStamped) for b in BODIES}
    for t in (0, 1_500_000_000, END_NS):
        bodies = [m for m in arrays[t].markers if m.ns == 'bodies']
        assert [m.id for m in bodies] == [0, 1, 2] and [m.text for m in bodies] == list(BODIES)
        for marker, body in zip(bodies, BODIES):
            assert marker.pose == poses[body][t].pose  # the same sample, bit for bit
        contacts = [m for m in arrays[t].markers if m.ns == 'contacts']
        assert contacts[0].action == contacts[0].DELETEALL
    # At rest on the floor, each box touches it at its 4 corners, the ball at 1 point.
    points = [m for m in arrays[END_NS].markers
              if m.ns == 'contacts' and m.type == m.SPHERE_LIST][0].points
    assert len(points) == 9 and all(abs(p.z) < 1e-9 for p in points)
    static = _messages(bag, f'{ns}/static_markers', MarkerArray)
    assert list(static) == [0] and [m.ns for m in static[0].markers] == ['ground']
