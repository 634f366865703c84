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
A single body with contact, through real DDS: a ground, obstacles, meshes, ``contact_wrench``.

The node's published (and recorded) values are compared with closed forms: a box sliding to a
stop on the ground travels ``d = v0² / (2 μ g)``; a box resting on the ground feels the contact
force ``−m g`` (the ground holds its weight), no torque.
"""

import math

from conftest import FIRST_START_S, REPO, wait_until, write_params
from geometry_msgs.msg import PointStamped, PoseStamped, WrenchStamped
import numpy as np
import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import main as replay_main
from rbd_ros.core import rotations
from rbd_ros.msgs import conversions
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from ros_probe import point
from std_srvs.srv import SetBool
import trimesh
from visualization_msgs.msg import Marker, MarkerArray
import yaml

G = 9.81
SLIDE = {
    'mass_kg': 2.0, 'shape': 'box', 'dimensions_m': [0.2, 0.2, 0.1],
    'initial_position': [0.0, 0.0, 0.05], 'initial_linear_velocity': [2.0, 0.0, 0.0],
    'gravity': [0.0, 0.0, -G], 'friction': 0.5, 'ground.enabled': True,
    'ground.friction': 0.5, 'real_time_factor': 0.0, 'start_paused': True,
}


def _subscribe(probe, msg_type, topic, store):
    probe.node.create_subscription(
        msg_type, topic,
        lambda msg: store.__setitem__(conversions.time_from_msg(msg.header.stamp), msg), 1000)


def _connect_and_run(probe):
    """Wait for the paused node's endpoints (contact_wrench too), then un-pause it."""
    probe.wait_connected(FIRST_START_S)  # a first start may compile the contact step
    probe.wait(lambda: probe.node.count_publishers('contact_wrench') >= 1, 60.0,
               'the contact_wrench publisher')
    assert probe.call('pause', SetBool.Request(data=False), timeout_s=120.0).success


def test_a_box_slides_to_a_stop_where_the_formula_says(tmp_path, start_node, probe_for):
    node = start_node({**SLIDE, 'record_path': str(tmp_path / 'slide')}, namespace=True)
    probe = probe_for(node)
    poses, wrenches = {}, {}
    _subscribe(probe, PoseStamped, 'pose', poses)
    _subscribe(probe, WrenchStamped, 'contact_wrench', wrenches)
    _connect_and_run(probe)
    probe.wait(lambda: poses.get(1_000_000_000), 120.0, 'the pose at t = 1 s')
    assert node.stop() == 0, node.stderr
    # The pose at 1 s (the box stops at v0 / (μ g) = 0.41 s): the node's own published value.
    x = poses[1_000_000_000].pose.position
    exact = 2.0 ** 2 / (2 * 0.5 * G)  # 0.40775 m
    # Tolerance: the 0.05 % bound on the stopping distance (the core measures 4e-7
    # relative at h = 1 ms: kick-drift-kick with contact after each half kick is second order).
    assert x.x == pytest.approx(exact, rel=5e-4)
    assert abs(x.y) < 1e-12 and x.z == pytest.approx(0.05, abs=1e-9)  # no sideways drift, on
    # the ground to round-off (the box never lifts or sinks: contact holds u_n = 0).
    # While sliding, the ground pushes up m g and back μ m g (kinetic friction, world frame).
    sliding = wrenches[200_000_000].wrench.force
    assert sliding.z == pytest.approx(2.0 * G, rel=1e-9)  # round-off of one impulse / h
    assert sliding.x == pytest.approx(-0.5 * 2.0 * G, rel=1e-9)
    # The recording replays bit for bit, contact wrench included.
    bag = open_bag(str(tmp_path / 'slide'))
    assert any(t.endswith('/contact_wrench') for t in bag.topics)
    assert replay_main([str(tmp_path / 'slide'), '--no-progress']) == 0


def test_a_resting_box_feels_minus_m_g_and_no_torque(start_node, probe_for):
    params = {**SLIDE, 'initial_linear_velocity': [0.0, 0.0, 0.0], 'mass_kg': 3.0}
    node = start_node(params, namespace=True)
    probe = probe_for(node)
    wrenches = {}
    _subscribe(probe, WrenchStamped, 'contact_wrench', wrenches)
    _connect_and_run(probe)
    probe.wait(lambda: wrenches.get(500_000_000), 120.0, 'the contact wrench at t = 0.5 s')
    assert node.stop() == 0, node.stderr
    msg = wrenches[500_000_000]
    assert msg.header.frame_id == 'world'
    force = conversions.vector_from_msg(msg.wrench.force)
    torque = conversions.vector_from_msg(msg.wrench.torque)
    # −m·gravity = (0, 0, m g): the impulse that cancels one step of gravity, divided by h;
    # round-off of a few ulps of m g.
    np.testing.assert_allclose(force, [0.0, 0.0, 3.0 * G], rtol=0, atol=1e-9)
    np.testing.assert_allclose(torque, [0.0, 0.0, 0.0], rtol=0, atol=1e-9)


def test_single_body_files_without_contact_have_todays_topics(start_node, probe_for):
    node = start_node({'start_paused': True}, namespace=True)
    probe = probe_for(node)
    probe.wait_connected(FIRST_START_S)  # a first start may compile the contact step
    names = dict(probe.node.get_topic_names_and_types())
    ns = node.namespace
    assert f'{ns}/pose' in names and f'{ns}/contact_wrench' not in names
    assert node.stop() == 0, node.stderr


def test_a_relative_mesh_path_resolves_against_the_params_file(tmp_path, start_node,
                                                               probe_for):
    folder = tmp_path / 'world'
    folder.mkdir()
    trimesh.creation.box(extents=(0.2, 0.2, 0.2)).export(folder / 'cube.stl')
    params = write_params(folder / 'cube.yaml', {
        'mesh_path': 'cube.stl', 'mass_kg': 1.0, 'gravity': [0.0, 0.0, -G],
        'initial_position': [0.0, 0.0, 0.1], 'ground.enabled': True, 'start_paused': True,
        'real_time_factor': 0.0})
    node = start_node(params_file=params, namespace=True)  # its cwd is tmp_path
    probe = probe_for(node)
    probe.wait_connected(FIRST_START_S)  # a first start may compile the contact step
    assert probe.call('pause', SetBool.Request(data=False), timeout_s=120.0).success
    pose = probe.wait(lambda: probe.samples['pose'].get(300_000_000), 120.0, 'pose at 0.3 s')
    assert node.stop() == 0, node.stderr
    # The mesh cube rests on the ground: its COM stays at half its side. STL stores float32,
    # so the side is float32(0.2) and the exact height float32(0.1) = 0.1000000015 m; against
    # the plane φ is exact, so only round-off remains.
    assert pose.pose.position.z == pytest.approx(float(np.float32(0.1)), abs=1e-12)


@pytest.mark.parametrize('params, text', [
    ({'ground.enabled': True, 'shape': 'box', 'dimensions_m': [0.2, 0.2, 0.2]},
     'parameter initial_position = [0.0, 0.0, 0.0] m: puts the body 0.1 m deep inside ground'),
    ({'ground.enabled': True, 'inertia': [0.1, 0.1, 0.1, 0.0, 0.0, 0.0],
      'initial_position': [0.0, 0.0, 1.0]},
     'parameter inertia = [0.1, 0.1, 0.1, 0.0, 0.0, 0.0] kg·m²: a body given only by its '
     'inertia has no collision shape'),
    ({'mesh_path': 'missing.stl'}, "missing.stl' does not exist or is not a file"),
    ({'obstacle_names': ['ramp'], 'obstacles.ramp.dimensions_m': [1.0, 0.0, 1.0]},
     "parameter obstacles.ramp.dimensions_m: [1.0, 0.0, 1.0] m for shape 'box'"),
    ({'ground.enabled': True, 'ground.restitution': 1.5},
     'parameter ground.restitution = 1.5'),
    ({'ground.enabled': True, 'integrator': 'rk4', 'initial_position': [0.0, 0.0, 1.0]},
     "parameter integrator = 'rk4': cannot take contact"),
])
def test_bad_contact_parameters_give_one_line_and_exit_2(tmp_path, start_node, params, text):
    node = start_node(params)
    assert node.wait(120) == 2, node.stderr
    assert text in node.stderr, node.stderr
    assert len(node.stderr.strip().splitlines()) == 1, node.stderr
    if 'mesh_path' in params:  # made relative to the params file (in tmp_path), then named
        assert f"parameter mesh_path = '{tmp_path / 'missing.stl'}'" in node.stderr


def test_contact_wrench_is_refused_as_an_input_topic(start_node):
    node = start_node({'wrench_input_names': ['x'], 'wrench_inputs.x.topic': 'contact_wrench'})
    assert node.wait(120) == 2, node.stderr
    assert 'contact_wrench' in node.stderr


def test_sigint_during_a_contact_run_leaves_a_bag_that_replays(tmp_path, start_node):
    params = {**SLIDE, 'start_paused': False, 'real_time_factor': 1.0,
              'record_path': str(tmp_path / 'run')}
    node = start_node(params)
    wait_until(lambda: (tmp_path / 'run').is_dir() and 'recording to' in node.stderr, 120.0,
               what='the node to start recording')
    wait_until(lambda: _recorded_pose_count(tmp_path / 'run') >= 30, 60.0,
               what='0.3 s recorded')
    assert node.stop() == 0, node.stderr
    assert replay_main([str(tmp_path / 'run'), '--no-progress']) == 0


def _recorded_pose_count(path):
    try:
        bag = open_bag(str(path))
    except Exception:  # noqa: B902 - the file may not have its header yet
        return 0
    return sum(info.message_count or 0 for topic, info in bag.topics.items()
               if topic.endswith('/pose'))


def _run_config(start_node, probe_for, name, until_ns):
    """Run ``msg_config/<name>.yaml`` as fast as possible; return the samples to ``until_ns``."""
    node = start_node({'start_paused': True, 'real_time_factor': 0.0},
                      params_file=REPO / 'msg_config' / f'{name}.yaml', namespace=True)
    probe = probe_for(node)
    probe.wait_connected(FIRST_START_S)  # a first start may compile the contact step
    assert probe.call('pause', SetBool.Request(data=False), timeout_s=120.0).success
    probe.wait(lambda: probe.samples['pose'].get(until_ns), 120.0, f'the pose at {until_ns} ns')
    probe.wait(lambda: probe.samples['twist'].get(until_ns), 120.0, f'the twist at {until_ns} ns')
    assert node.stop() == 0, node.stderr
    return probe.samples


def test_the_msg_config_slope_cube_slides_at_g_sin_minus_mu_cos(start_node, probe_for):
    samples = _run_config(start_node, probe_for, 'slope', 1_000_000_000)
    theta, mu = math.radians(30.0), 0.3  # the ramp and the pair's friction in slope.yaml
    downhill = np.array([math.cos(theta), 0.0, -math.sin(theta)])
    config = yaml.safe_load((REPO / 'msg_config' / 'slope.yaml').read_text())
    start = np.array(config['/**']['ros__parameters']['initial_position'])
    end = np.array(conversions.vector_from_msg(samples['pose'][1_000_000_000].pose.position))
    travelled = (end - start) @ downhill
    # x(1 s) = g (sin θ − μ cos θ) / 2 = 1.1781 m; the bound 0.05 % (a constant
    # acceleration is integrated exactly by kick-drift-kick: the core measures ~1e-15).
    assert travelled == pytest.approx(0.5 * G * (math.sin(theta) - mu * math.cos(theta)),
                                      rel=5e-4)
    # It stays on the ramp's surface: no motion along the normal (round-off).
    normal = np.array([math.sin(theta), 0.0, math.cos(theta)])
    assert abs((end - start) @ normal) < 1e-9


def test_the_msg_config_l_block_comes_to_rest_inside_the_bin(start_node, probe_for):
    samples = _run_config(start_node, probe_for, 'l_block_bin', 3_000_000_000)
    pose = samples['pose'][3_000_000_000].pose
    twist = samples['twist'][3_000_000_000].twist
    p = conversions.vector_from_msg(pose.position)
    # Inside the walls (their inner faces at ±0.2 m) and lying slab-down: its COM is as high
    # above the ground as the L's centroid is above its slab's bottom face (0.05 m, in the
    # float32 coordinates STL stores), taken here from trimesh's own mass properties; the
    # ground's φ is exact at the mesh's vertices, so only round-off remains.
    mesh = trimesh.load(REPO / 'msg_config' / 'meshes' / 'l_block.stl', force='mesh')
    height = mesh.center_mass[2] - mesh.vertices[:, 2].min()
    assert max(abs(p[0]), abs(p[1])) < 0.2
    assert p[2] == pytest.approx(height, abs=1e-9)
    up = rotations.quat_rotate(conversions.quaternion_from_msg(pose.orientation),
                               np.array([0.0, 0.0, 1.0]))
    assert up[2] == pytest.approx(1.0, abs=1e-9)  # the upright points up
    speed = np.linalg.norm(conversions.vector_from_msg(twist.linear))
    spin = np.linalg.norm(conversions.vector_from_msg(twist.angular))
    assert speed < 1e-9 and spin < 1e-9  # at rest (round-off)


def test_drag_and_clicks_move_the_box_and_the_bag_replays(tmp_path, start_node, probe_for):
    # The default box on the floor (1 kg, 0.2 x 0.1 x 0.05 m), drag spring k = 50 N/m,
    # c = 5 N·s/m (ζ = c / (2 sqrt(k m)) = 0.35: settled to e^(-ζ ω t) < 1e-4 within 3.5 s).
    node = start_node({'start_paused': True, 'real_time_factor': 4.0,
                       'record_path': str(tmp_path / 'drag')},
                      params_file=REPO / 'msg_config' / 'default.yaml', namespace=True)
    probe = probe_for(node)
    drag = probe.node.create_publisher(PointStamped, 'drag', 10)
    click = probe.node.create_publisher(PointStamped, '/clicked_point', 10)
    probe.wait_connected(FIRST_START_S)
    probe.wait(lambda: drag.get_subscription_count() and click.get_subscription_count(), 60.0,
               'the drag subscriptions')
    k, g = 50.0, 9.81
    assert probe.call('pause', SetBool.Request(data=False), timeout_s=120.0).success
    probe.wait(lambda: probe.samples['pose'], 60.0, 'the first pose')

    sent = [0]

    def send_then_wait(publisher, msg, seconds):
        """Publish ``msg``; once the node has it, return the pose ``seconds`` of sim time later."""
        publisher.publish(msg)
        sent[0] += 1
        # The node counts what it received (/diagnostics, ~1 Hz): wait for it under any load.
        values = probe.diagnostic_values(lambda v: int(v['drags_received']) >= sent[0], 60.0)
        # The point acts from the diagnostics' sim time on (it is applied at the next step
        # start). Not the newest pose we hold: under load our pose backlog can lag the node
        # by more than `seconds`, and a pose from before the point arrived would be read.
        start = round(float(values['sim_time_s']) * 1e9)
        end = probe.wait(lambda: max(probe.samples['pose']) >= start + seconds * 1e9 and
                         max(probe.samples['pose']), 60.0, f'{seconds} s of sim time')
        return np.array(conversions.vector_from_msg(probe.samples['pose'][end].pose.position))

    # Drag the COM (drag_point_b = [0, 0, 0]) to (0.5, 0, 0.3): it hangs m g / k below.
    p = send_then_wait(drag, point(0.5, 0.0, 0.3), 4.0)
    np.testing.assert_allclose(p, [0.5, 0.0, 0.3 - g / k], atol=1e-3)  # settled (see above)
    # Release (NaN): it falls back to the floor.
    p = send_then_wait(drag, point(math.nan, math.nan, math.nan), 2.0)
    assert p[2] == pytest.approx(0.025, abs=1e-6)
    # Click on the top face centre: grabbed there; the next click lifts that point to 0.5 m.
    send_then_wait(click, point(p[0], p[1], 0.05), 0.05)
    q = send_then_wait(click, point(p[0], p[1], 0.5), 4.0)
    # Held 0.025 m above its COM: the COM hangs at 0.5 − 0.025 − m g / k, straight below.
    np.testing.assert_allclose(q, [p[0], p[1], 0.5 - 0.025 - g / k], atol=1e-3)
    r = send_then_wait(click, point(5.0, 5.0, 0.0), 2.0)  # far from the box: released
    assert r[2] == pytest.approx(0.025, abs=1e-6)
    assert node.stop() == 0, node.stderr
    bag = open_bag(str(tmp_path / 'drag'))
    counts = {t: info.message_count for t, info in bag.topics.items()}
    assert counts['/clicked_point'] == 3 and counts[f'{node.namespace}/drag'] == 2
    assert replay_main([str(tmp_path / 'drag'), '--no-progress']) == 0


def test_a_late_subscriber_gets_the_static_markers(start_node, probe_for):
    node = start_node({'start_paused': True},
                      params_file=REPO / 'msg_config' / 'l_block_bin.yaml', namespace=True)
    probe = probe_for(node)
    probe.wait_connected(FIRST_START_S)
    probe.wait(lambda: probe.node.count_publishers('static_markers') >= 1, 60.0,
               'the static_markers publisher')
    # Subscribed after the node published them once: transient local delivers them anyway.
    got = []
    qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)
    probe.node.create_subscription(MarkerArray, 'static_markers', got.append, qos)
    probe.wait(lambda: got, 60.0, 'the static markers')
    config = yaml.safe_load((REPO / 'msg_config' / 'l_block_bin.yaml').read_text())
    params = config['/**']['ros__parameters']
    by_ns = {}
    for marker in got[0].markers:
        by_ns.setdefault(marker.ns, []).append(marker)
    assert [m.id for m in by_ns['ground']] == [0]
    walls = by_ns['obstacles']
    assert [m.id for m in walls] == [0, 1, 2, 3]
    for marker, name in zip(walls, params['obstacle_names']):
        assert marker.type == Marker.CUBE and marker.header.frame_id == 'world'
        assert (marker.scale.x, marker.scale.y, marker.scale.z) == tuple(
            params[f'obstacles.{name}.dimensions_m'])
        p = marker.pose.position
        assert (p.x, p.y, p.z) == tuple(params[f'obstacles.{name}.position'])
    assert node.stop() == 0, node.stderr
