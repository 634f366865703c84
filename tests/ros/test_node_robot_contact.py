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
A URDF robot and a free body in one contact world, in the node, through real DDS.

One node on a params file written here (``msg_config/urdf/pendulum.urdf`` given as
``robot_description`` with a ball at its pivot end and a ``ceiling`` link fixed to the world
above it; its 1.5 m rod released at 0.5 rad from a pivot 2 m up, over a ground at z = 0.4 m
with a 0.2 m box resting beside the rod's lowest point), started paused, recorded, run 1 s of
sim time; one probe. The robot's topics are a robot's (``pendulum/joint_states``,
``pendulum/joint_wrenches``, the rod on ``/tf`` as robot_state_publisher gives it: world →
rod at the pivot, turned by the joint angle about y), the box's a world body's
(``box/pose``, ``box/twist``, world → box on ``/tf``); the rod knocks the box along +x, every
moving link's collision elements are on ``markers`` in their link frames, the ceiling's (fixed
to the world) once on ``static_markers`` in the world frame, and the recording replays MATCH.
"""

import math
import pathlib

from conftest import NodeProcess
import pytest
from rbd_ros.bag.replay import replay_bag
from rbd_ros.msgs.conversions import time_from_msg

REPO = pathlib.Path(__file__).resolve().parents[2]
PENDULUM_URDF = REPO / 'msg_config' / 'urdf' / 'pendulum.urdf'
DURATION_NS = 1_000_000_000
PERIOD_NS = 10_000_000  # publish_rate_hz 100
PIVOT = (0.0, 0.0, 2.0)
BOX0 = (0.13, 0.0, 0.5)


#: The rod's second <collision> (a ball at its pivot end) and the ceiling link: its box 0.15 m
#: above the pivot (the ball's top is 0.12 m below it).
BALL = ('<collision><origin xyz="0 0 0"/><geometry><sphere radius="0.03"/></geometry>'
        '</collision>')
CEILING = ('<joint name="ceiling_joint" type="fixed"><parent link="world"/><child '
           'link="ceiling"/><origin xyz="0 0 2"/></joint><link name="ceiling"><collision>'
           '<origin xyz="0 0 0.2"/><geometry><box size="0.3 0.3 0.1"/></geometry></collision>'
           '</link>')


def _urdf():
    text = PENDULUM_URDF.read_text()
    text = text.replace('</collision>', '</collision>' + BALL, 1)
    return text.replace('</robot>', CEILING + '</robot>')


def _params(bag):
    return {'robot_names': ['pendulum'], 'robots.pendulum.robot_description': _urdf(),
            'robots.pendulum.initial_joint_positions': [0.5],
            'gravity': [0.0, 0.0, -9.81], 'ground.enabled': True, 'ground.height_m': 0.4,
            'body_names': ['box'], 'bodies.box.shape': 'box',
            'bodies.box.dimensions_m': [0.2, 0.2, 0.2], 'bodies.box.mass_kg': 0.5,
            'bodies.box.initial_position': list(BOX0), 'timestep_s': 0.001,
            'publish_rate_hz': 100.0, 'real_time_factor': 0.0, 'start_paused': True,
            'duration_s': DURATION_NS * 1e-9, 'record_path': str(bag)}


@pytest.fixture(scope='module')
def run(module_tmp):
    """Run the node once; return what the probe received and the bag."""
    from geometry_msgs.msg import PoseStamped, TwistStamped
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from ros_probe import Probe, run_paused_node
    from sensor_msgs.msg import JointState, MultiDOFJointState
    from tf2_msgs.msg import TFMessage
    from visualization_msgs.msg import MarkerArray
    bag = module_tmp / 'robot_box'
    node = NodeProcess(module_tmp, _params(bag), namespace=True)
    probe = Probe(node.namespace, inputs=(), outputs=('diagnostics',))
    got = {'joint_states': {}, 'joint_wrenches': {}, 'pose': {}, 'twist': {}, 'tf': {},
           'markers': {}, 'static_markers': {}}
    # Transient local (keep last 1): a subscription matched after the paused node's t = 0
    # sample still gets it; /tf is volatile (its t = 0 sample may precede the match).
    latched = QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL)

    def keep(kind, stamp_of):
        return lambda msg: got[kind].__setitem__(time_from_msg(stamp_of(msg)), msg)
    subs = [probe.node.create_subscription(kind_type, topic, keep(kind, stamp), qos)
            for kind, kind_type, topic, stamp, qos in (
                ('joint_states', JointState, 'pendulum/joint_states',
                 lambda m: m.header.stamp, latched),
                ('joint_wrenches', MultiDOFJointState, 'pendulum/joint_wrenches',
                 lambda m: m.header.stamp, latched),
                ('pose', PoseStamped, 'box/pose', lambda m: m.header.stamp, 1000),
                ('twist', TwistStamped, 'box/twist', lambda m: m.header.stamp, 1000),
                ('tf', TFMessage, '/tf', lambda m: m.transforms[0].header.stamp, 1000),
                ('markers', MarkerArray, 'markers', lambda m: m.markers[0].header.stamp,
                 1000),
                ('static_markers', MarkerArray, 'static_markers',
                 lambda m: m.markers[0].header.stamp, latched))]
    topics, status = run_paused_node(
        probe, node, subs, lambda: all(DURATION_NS in got[k] for k in got
                                       if k != 'static_markers') and got['static_markers'])
    return {'got': got, 'topics': topics, 'ns': node.namespace.rstrip('/'), 'status': status,
            'bag': bag, 'stderr': node.stderr}


def test_the_robots_and_the_boxs_topics_are_on_the_graph(run):
    assert run['status'] == 0, run['stderr']
    expected = {'pendulum/joint_states': 'sensor_msgs/msg/JointState',
                'pendulum/joint_wrenches': 'sensor_msgs/msg/MultiDOFJointState',
                'pendulum/joint_command': 'sensor_msgs/msg/JointState',
                'pendulum/robot_description': 'std_msgs/msg/String',
                'box/pose': 'geometry_msgs/msg/PoseStamped',
                'box/twist': 'geometry_msgs/msg/TwistStamped'}
    for topic, type_name in expected.items():
        assert run['topics'][f"{run['ns']}/{topic}"] == [type_name], topic


def test_every_sample_arrives_and_the_rods_tf_is_its_joint_angle(run):
    got = run['got']
    expected = list(range(0, DURATION_NS + 1, PERIOD_NS))
    for kind in ('joint_states', 'joint_wrenches'):  # transient local: t = 0 too
        assert sorted(got[kind]) == expected, kind  # none lost, sim-time stamps
    # The box's topics and /tf are volatile: the paused node's t = 0 sample may precede the
    # probe's match; every sample after the unpause must be there.
    for kind in ('pose', 'twist', 'tf'):
        assert min(got[kind]) <= PERIOD_NS, kind
        assert sorted(got[kind]) == [t for t in expected if t >= min(got[kind])], kind
    worst = 0.0
    for t, msg in got['tf'].items():
        frames = {tr.child_frame_id: tr for tr in msg.transforms}
        assert set(frames) == {'rod', 'box', 'ceiling'}, sorted(frames)
        rod = frames['rod'].transform
        theta = got['joint_states'][t].position[0]
        # world -> rod: the pivot, turned by theta about y: q = (cos θ/2, 0, sin θ/2, 0)
        want = (*PIVOT, 0.0, math.sin(theta / 2), 0.0, math.cos(theta / 2))
        have = (rod.translation.x, rod.translation.y, rod.translation.z, rod.rotation.x,
                rod.rotation.y, rod.rotation.z, rod.rotation.w)
        worst = max(worst, max(abs(a - b) for a, b in zip(have, want)))
        box = frames['box'].transform.translation
        pose = got['pose'][t].pose.position
        assert (box.x, box.y, box.z) == (pose.x, pose.y, pose.z)  # the same floats
    print(f'\nrod on /tf vs its joint angle: at most {worst:.3g}')
    # The contact step holds the pivot to its projection tolerance (1e-13 per row) and the
    # joint angle is read from the same state: measured 9.4e-14; 1e-12 leaves a factor 10.
    assert worst < 1e-12


def test_the_rod_knocks_the_box_along_x_and_the_recording_replays_match(run):
    got = run['got']
    first = got['pose'][min(got['pose'])].pose.position
    # At rest on the ground until the rod arrives (speculative contact holds it exactly, but
    # for round-off over at most 10 steps).
    assert max(abs(a - b) for a, b in zip((first.x, first.y, first.z), BOX0)) < 1e-12
    last = got['pose'][DURATION_NS].pose.position
    # The rod (released at 0.5 rad) reaches the bottom after a quarter period (~0.51 s) and
    # pushes the box along +x; the box stays on the ground (its centre 0.1 m above z = 0.4).
    assert last.x > BOX0[0] + 0.05, last
    assert abs(last.z - 0.5) < 1e-6, last
    speeds = [got['twist'][t].twist.linear.x for t in sorted(got['twist'])]
    assert max(speeds) > 0.1 and min(speeds) > -1e-9
    result = replay_bag(run['bag'])
    assert result.match, result.problems


def test_every_moving_links_collision_elements_are_on_markers_in_its_frame(run):
    # The rod's cylinder and ball (robots, links, elements in order), each in its link's frame
    # (the frames /tf carries) at its <origin>, as the URDF gives them: the same floats, so
    # compared exactly. The ceiling, fixed to the world, is not here (static_markers).
    from visualization_msgs.msg import Marker
    want = [('rod', Marker.CYLINDER, (0.04, 0.04, 1.5), (0.0, 0.0, -0.75)),
            ('rod', Marker.SPHERE, (0.06, 0.06, 0.06), (0.0, 0.0, 0.0))]
    assert run['got']['markers'], 'no markers'
    for t, msg in run['got']['markers'].items():
        links = [m for m in msg.markers if m.ns == 'links']
        have = [(m.header.frame_id, m.type, (m.scale.x, m.scale.y, m.scale.z),
                 (m.pose.position.x, m.pose.position.y, m.pose.position.z)) for m in links]
        assert have == want, have
        assert [m.id for m in links] == [0, 1]
        assert [m.text for m in links] == ['pendulum/rod', 'pendulum/rod']
        for m in links:
            q = m.pose.orientation
            assert (q.x, q.y, q.z, q.w) == (0.0, 0.0, 0.0, 1.0)
            assert m.frame_locked and time_from_msg(m.header.stamp) == t
        # the free box is drawn as before, at its pose
        box = next(m for m in msg.markers if m.ns == 'bodies')
        if t in run['got']['pose']:
            pose = run['got']['pose'][t].pose.position
            assert (box.pose.position.x, box.pose.position.z) == (pose.x, pose.z)


def test_a_mimic_gripper_squeezes_a_box_with_half_its_effort_a_side(
        start_node, probe_for, tmp_path):
    # gripper.urdf (finger_right mimics finger_left) around a 2 cm box, no gravity: an effort of
    # 2 N on finger_left's joint_command closes both fingers onto the box, each pushing it with
    # τ/2 = 1 N (virtual work over the one coordinate; tests/sim/test_robot_contact.py). Read
    # from the recording: the last joint_wrenches give each finger ∓1 N along y (round-off of
    # O(1) N sums, 1e-12), the fingers rest on the box within the touching gap (1e-5 m), the box
    # stays put to 1e-9 m, and the bag replays MATCH.
    import numpy as np
    from rbd_ros.bag.recording import open_bag
    from sensor_msgs.msg import JointState
    bag = tmp_path / 'squeeze'
    node = start_node({
        'robot_names': ['gripper'],
        'robots.gripper.urdf_path': str(REPO / 'msg_config' / 'urdf' / 'gripper.urdf'),
        'gravity': [0.0, 0.0, 0.0], 'body_names': ['box'], 'bodies.box.shape': 'box',
        'bodies.box.dimensions_m': [0.02, 0.02, 0.02], 'bodies.box.mass_kg': 0.05,
        'bodies.box.initial_position': [0.0, 0.0, 1.05], 'wrench_timeout_s': 0.0,
        'start_paused': True, 'real_time_factor': 0.0, 'duration_s': 1.0,
        'record_path': str(bag)}, namespace=True)
    probe = probe_for(node, inputs=(), outputs=('diagnostics',))
    command = probe.node.create_publisher(JointState, 'gripper/joint_command', 10)
    probe.wait(lambda: command.get_subscription_count(), 60, 'the joint_command subscription')
    command.publish(JointState(name=['finger_left'], effort=[-2.0]))
    probe.diagnostic_values(lambda v: v.get('commands_received') == '1', 30)
    probe.pause(False)
    assert node.wait(120) == 0, node.stderr
    recorded = open_bag(bag)
    last = {}
    for topic in ('gripper/joint_states', 'gripper/joint_wrenches', 'box/pose'):
        name = f'{node.namespace}/{topic}'
        decode = recorded.decoder(name)
        last[topic] = decode(list(recorded.messages([name]))[-1].data)
    assert time_from_msg(last['gripper/joint_states'].header.stamp) == DURATION_NS
    q = np.array(last['gripper/joint_states'].position)
    assert np.abs(q + 0.005).max() <= 1e-5 and abs(q[1] - q[0]) <= 1e-12, q
    assert list(last['gripper/joint_states'].effort) == [-2.0, 0.0]
    sent = last['gripper/joint_wrenches']
    wrenches = {name: w.force for name, w in zip(sent.joint_names, sent.wrench)}
    assert abs(wrenches['finger_left'].y + 1.0) <= 1e-12, wrenches
    assert abs(wrenches['finger_right'].y - 1.0) <= 1e-12, wrenches
    box = last['box/pose'].pose.position
    assert max(abs(box.x), abs(box.y), abs(box.z - 1.05)) <= 1e-9, box
    result = replay_bag(str(bag))
    assert result.match, result.problems


def test_a_link_fixed_to_the_world_is_on_static_markers_once_in_the_world_frame(run):
    # The ceiling (world -> fixed 2 m up -> ceiling, its box 0.2 m above its frame) is static:
    # published once at start on the transient-local static_markers beside the ground, in
    # the world frame at its placed pose (0, 0, 2.2) m, with the id it had among the links.
    from visualization_msgs.msg import Marker
    (stamp, msg), = run['got']['static_markers'].items()
    assert stamp == 0
    assert [m.ns for m in msg.markers] == ['ground', 'links']
    ceiling = msg.markers[1]
    assert (ceiling.id, ceiling.type, ceiling.text) == (2, Marker.CUBE, 'pendulum/ceiling')
    assert ceiling.header.frame_id == 'world' and not ceiling.frame_locked
    p, q = ceiling.pose.position, ceiling.pose.orientation
    # 2 + 0.2 in floats, as the placement composes them
    assert (p.x, p.y, p.z) == (0.0, 0.0, 2.0 + 0.2) and (q.x, q.y, q.z, q.w) == (0, 0, 0, 1)
    assert (ceiling.scale.x, ceiling.scale.y, ceiling.scale.z) == (0.3, 0.3, 0.1)


@pytest.mark.parametrize('urdf', ['arm3.urdf', 'free_body.urdf'])
def test_a_robot_over_a_ground_without_free_bodies_records_and_replays(
        start_node, tmp_path, urdf):
    # A robot and a ground, no body_names: a contact world of no free bodies. Recording its
    # first sample built the bodies' markers from an empty list (shape (0,), not (0, 3)):
    # 'positions_w: shape (0,) for 0 bodies', exit 2 at start (a markers subscriber's first
    # sample too). It now runs, and its recording replays MATCH.
    bag = tmp_path / 'bag'
    node = start_node({
        'robot_names': ['r'], 'robots.r.urdf_path': str(REPO / 'msg_config' / 'urdf' / urdf),
        'robots.r.initial_position': [0.0, 0.0, 0.5], 'ground.enabled': True,
        'gravity': [0.0, 0.0, -9.81], 'real_time_factor': 0.0, 'duration_s': 0.1,
        'record_path': str(bag)})
    assert node.wait(120) == 0, node.stderr
    result = replay_bag(str(bag))
    assert result.match, result.problems


def test_a_gripper_squeeze_that_does_not_converge_is_a_diagnostics_warning(
        start_node, probe_for):
    # README ("what it does not do") and doc/robots.md promise it: a gripper on a velocity
    # group whose trajectory closes it on a 2 cm box on its palm runs its joint-contact loops
    # to their cap every step of the squeeze (seconds a step). Through the node: /diagnostics
    # turns WARN naming the unconverged solve, with the loops at the cap and the contacts left
    # approaching (tests/sim/test_pacing_diagnostics.py has the session's figures: 0.12 m/s).
    from rbd_ros.core.contact.joints import JOINT_LOOPS
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    from builtin_interfaces.msg import Duration
    node = start_node({
        'robot_names': ['gripper'],
        'robots.gripper.urdf_path': str(REPO / 'msg_config' / 'urdf' / 'gripper.urdf'),
        'gravity': [0.0, 0.0, -9.81], 'body_names': ['box'], 'bodies.box.shape': 'box',
        'bodies.box.dimensions_m': [0.02, 0.02, 0.02], 'bodies.box.mass_kg': 0.05,
        'bodies.box.initial_position': [0.0, 0.0, 1.05], 'ground.enabled': True,
        'command_group_names': ['g'], 'command_groups.g.robot': 'gripper',
        'command_groups.g.interface': 'velocity', 'start_paused': True,
        'real_time_factor': 0.0}, namespace=True)
    probe = probe_for(node, inputs=(), outputs=('diagnostics',))
    trajectory = probe.node.create_publisher(JointTrajectory, 'g/joint_trajectory', 10)
    probe.wait(lambda: trajectory.get_subscription_count(), 60, 'the trajectory subscription')
    trajectory.publish(JointTrajectory(joint_names=['finger_left'], points=[
        JointTrajectoryPoint(positions=[-0.01], time_from_start=Duration(nanosec=100_000_000)),
        JointTrajectoryPoint(positions=[0.02], time_from_start=Duration(nanosec=200_000_000))]))
    probe.diagnostic_values(lambda v: v.get('commands_received') == '1', 30)
    probe.pause(False)

    def warned():
        for msg in reversed(probe.diagnostics):
            status = msg.status[0]
            values = {kv.key: kv.value for kv in status.values}
            if 'did not converge' in status.message:
                return status, values
        return None
    status, values = probe.wait(warned, 120, 'a /diagnostics warning of the squeeze')
    assert status.level == status.WARN, status
    assert float(values['joint_contact_loops_max']) == JOINT_LOOPS, values
    assert float(values['joint_contact_left_max_m_s']) > 1e-3, values  # far from 1e-12 m/s
    assert f'did not converge in {JOINT_LOOPS} joint visits' in status.message, status.message
    assert node.stop() == 0
