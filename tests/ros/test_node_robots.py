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
Robots in the node, through real DDS and the node's own recordings.

The URDFs of ``msg_config/urdf/`` are read here only for their numbers (lengths, masses); every
expected value is a closed form computed in the test: the compound pendulum's period (an
elliptic integral, by the arithmetic-geometric mean), gravity torques of the arm held still,
the link transforms of a revolute joint about y.
"""

import math
import pathlib
import shutil

from conftest import write_params
import numpy as np
import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import replay_bag

REPO = pathlib.Path(__file__).resolve().parents[2]
URDF = REPO / 'msg_config' / 'urdf'
G = 9.81
S = 1_000_000_000


def _run_to_end(start_node, tmp_path, params, timeout_s=180):
    """Run a node to its duration as fast as possible; return the bag."""
    bag = tmp_path / 'bag'
    node = start_node({**params, 'real_time_factor': 0.0, 'record_path': str(bag)})
    assert node.wait(timeout_s) == 0, node.stderr
    return bag


def _joint_states(bag, topic):
    """Return ``[(stamp ns, names, position, velocity, effort)]`` recorded on ``topic``."""
    b = open_bag(bag)
    decode = b.decoder(topic)
    out = []
    for raw in b.messages([topic]):
        msg = decode(raw.data)
        stamp = msg.header.stamp.sec * S + msg.header.stamp.nanosec
        out.append((stamp, list(msg.name), np.array(msg.position), np.array(msg.velocity),
                    np.array(msg.effort)))
    return out


def _ellipk(k):
    """Complete elliptic integral of the first kind K(k), by the arithmetic-geometric mean."""
    a, b = 1.0, math.sqrt(1.0 - k * k)
    while abs(a - b) > 1e-16 * a:
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    return math.pi / (2.0 * a)


def test_a_urdf_pendulum_swings_with_the_closed_form_period_and_replays(start_node, tmp_path):
    theta0 = 0.5
    bag = _run_to_end(start_node, tmp_path, {
        'robot_names': ['pendulum'], 'robots.pendulum.urdf_path': str(URDF / 'pendulum.urdf'),
        'robots.pendulum.initial_joint_positions': [theta0], 'gravity': [0.0, 0.0, -G],
        'duration_s': 4.5, 'publish_rate_hz': 1000.0, 'publish_tf': True})
    samples = _joint_states(bag, '/pendulum/joint_states')
    assert samples[0][1] == ['pivot'] and samples[0][0] == 0
    assert abs(samples[0][2][0] - theta0) < 1e-15 and len(samples) == 4501
    # Downward zero crossings of the angle, by linear interpolation between 1 ms samples: at
    # theta = 0 the angular acceleration is 0, so the interpolation error is O(dt³ θ'''/θ')
    # ~ 1e-7 s; RK4 at ω h = 3e-3 adds ~(ωh)⁴ relative. 1e-5 s bounds both with margin.
    t = np.array([s[0] for s in samples]) * 1e-9
    q = np.array([s[2][0] for s in samples])
    down = [t[i] + (t[i + 1] - t[i]) * q[i] / (q[i] - q[i + 1])
            for i in range(len(q) - 1) if q[i] > 0.0 >= q[i + 1]]
    assert len(down) == 2
    # Rod of 1.5 m about its end: L_eq = I / (m d) = (m L²/3) / (m L/2) = 2 L / 3 = 1 m.
    period = 4.0 * math.sqrt((2.0 * 1.5 / 3.0) / G) * _ellipk(math.sin(theta0 / 2.0))
    assert abs((down[1] - down[0]) - period) < 1e-5, (down[1] - down[0], period)
    # No motor: the effort is 0 throughout (no hidden damping or motor).
    assert all(not s[4].any() for s in samples)
    result = replay_bag(bag)
    assert result.match, result.problems


def test_joint_friction_holds_a_pendulum_and_damping_decays_another(start_node, tmp_path):
    # pendulum.urdf's rod: m = 1 kg, COM l = 0.75 m below the pivot, I = m L² / 3 = 0.75 kg m².
    # One copy has <dynamics friction="4"/> (> m g l sin 0.5 = 3.53 N m), the other a damping
    # parameter; both in one node.
    held_urdf = tmp_path / 'held.urdf'
    held_urdf.write_text((URDF / 'pendulum.urdf').read_text().replace(
        '<axis xyz="0 1 0"/>', '<axis xyz="0 1 0"/><dynamics friction="4.0"/>'))
    theta_held, theta_damped, damping = 0.5, 0.01, 0.15
    bag = _run_to_end(start_node, tmp_path, {
        'robot_names': ['held', 'damped'], 'robots.held.urdf_path': str(held_urdf),
        'robots.held.initial_joint_positions': [theta_held],
        'robots.damped.urdf_path': str(URDF / 'pendulum.urdf'),
        'robots.damped.initial_joint_positions': [theta_damped],
        'robots.damped.joints.pivot.damping': damping, 'gravity': [0.0, 0.0, -G],
        # one URDF's links twice: each robot's TF frames its own
        'robots.damped.frame_prefix': 'damped/',
        'duration_s': 8.0, 'publish_rate_hz': 1000.0})
    held = _joint_states(bag, '/held/joint_states')
    assert len(held) == 8001
    # Stuck: a velocity row enforced by the projection after every step, so the rate is zero
    # to round-off and the angle does not move (the bound, 1e-12).
    for _, _, position, velocity, effort in held:
        assert abs(position[0] - theta_held) <= 1e-12 and abs(velocity[0]) <= 1e-12
        assert effort[0] == 0.0   # no motor: the friction holds it, not a hidden motor
    samples = _joint_states(bag, '/damped/joint_states')
    t = np.array([s[0] for s in samples]) * 1e-9
    q = np.array([s[2][0] for s in samples])
    rate = np.array([s[3][0] for s in samples])
    zeros = [i for i in range(len(q) - 1) if q[i] * q[i + 1] < 0.0]
    crossings = np.array([t[i] + (t[i + 1] - t[i]) * q[i] / (q[i] - q[i + 1]) for i in zeros])
    speeds = np.array([abs(rate[i] + (rate[i + 1] - rate[i]) * (c - t[i]) / (t[i + 1] - t[i]))
                       for i, c in zip(zeros, crossings)])
    assert len(crossings) == 8   # every half period, π / ω_d = 1.0 s
    # Linearised: I θ'' + d θ' + m g l θ = 0, so θ = A e^(-σt) cos(ω_d t - φ) with σ = d / (2 I)
    # and ω_d² = m g l / I - σ²; |θ'| at the zeros is A ω_d e^(-σt) exactly.
    sigma = damping / (2.0 * 0.75)
    omega_d = math.sqrt(G * 0.75 / 0.75 - sigma * sigma)
    measured_omega = math.pi * (len(crossings) - 1) / (crossings[-1] - crossings[0])
    measured_sigma = -np.polyfit(crossings, np.log(speeds), 1)[0]
    # At 0.01 rad the nonlinearity shifts ω by θ0² / 16 = 6e-6 and the decay by O(θ0²) = 1e-4;
    # linear interpolation between 1 ms samples errs by O(h³) in the crossing times (θ'' = 0
    # there) and by the same h² ω² / 8 = 1.2e-6 fraction of every speed, which the slope drops.
    # Measured: ω_d -3e-6 (the nonlinearity), σ -9.4e-7.
    assert abs(measured_omega / omega_d - 1.0) <= 1e-5, measured_omega / omega_d - 1.0
    assert abs(measured_sigma / sigma - 1.0) <= 1e-4, measured_sigma / sigma - 1.0
    result = replay_bag(bag)
    assert result.match, result.problems


def test_tf_carries_every_link_as_the_urdf_kinematics_give_it(start_node, tmp_path):
    bag = _run_to_end(start_node, tmp_path, {
        'robot_names': ['arm'], 'robots.arm.urdf_path': str(URDF / 'arm3.urdf'),
        'robots.arm.initial_joint_positions': [0.4, -0.7, 1.1], 'gravity': [0.0, 0.0, -G],
        'duration_s': 0.5, 'publish_tf': True})
    states = {s[0]: s[2] for s in _joint_states(bag, '/arm/joint_states')}
    b = open_bag(bag)
    decode = b.decoder('/tf')
    checked = 0
    for raw in b.messages(['/tf']):
        msg = decode(raw.data)
        stamp = msg.transforms[0].header.stamp.sec * S + msg.transforms[0].header.stamp.nanosec
        q = states[stamp]
        got = {(tf.header.frame_id, tf.child_frame_id): tf.transform for tf in msg.transforms}
        # arm3.urdf: world -> mount fixed at z = 2; shoulder, elbow, wrist revolute about y,
        # each child 0.5 m below its parent's origin (0 for the shoulder); hand -> tool0 fixed
        # at z = -0.5.
        expected = {('world', 'mount'): ((0, 0, 2), 0.0), ('mount', 'upper'): ((0, 0, 0), q[0]),
                    ('upper', 'fore'): ((0, 0, -0.5), q[1]),
                    ('fore', 'hand'): ((0, 0, -0.5), q[2]), ('hand', 'tool0'): ((0, 0, -0.5), 0)}
        assert set(got) == set(expected)
        for key, (origin, angle) in expected.items():
            tr = got[key]
            # 1e-12: the joints hold their anchors to PROJECTION_TOL = 1e-13 m per joint, and
            # the relative transform is a few dozen flops on values of order 1
            assert np.allclose([tr.translation.x, tr.translation.y, tr.translation.z], origin,
                               atol=1e-12, rtol=0), (key, tr.translation)
            rot = [tr.rotation.w, tr.rotation.x, tr.rotation.y, tr.rotation.z]
            want = [math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0]
            assert np.allclose(rot, want, atol=1e-12, rtol=0), (key, rot, want)
        checked += 1
    assert checked == 51


def _arm_params():
    return {'robot_names': ['arm'], 'robots.arm.urdf_path': str(URDF / 'arm3.urdf'),
            'command_group_names': ['arm_group'], 'command_groups.arm_group.robot': 'arm',
            'gravity': [0.0, 0.0, -G], 'publish_rate_hz': 100.0}


def _gravity_torques(q):
    """Torques holding the arm3 links (1 kg, 0.5 m, COM mid-link) still at joint angles q."""
    phi = np.cumsum(q)  # each link's absolute angle from the downward vertical
    # horizontal lever of each link's COM and of its end, from the world-fixed shoulder axis
    com = [0.25 * math.sin(phi[k]) for k in range(3)]
    ends = np.concatenate(([0.0], np.cumsum([0.5 * math.sin(p) for p in phi])))
    x_com = [ends[k] + com[k] for k in range(3)]
    # joint k carries the links k..2 about its own axis, at horizontal position ends[k]
    return np.array([G * sum(x_com[i] - ends[k] for i in range(k, 3)) for k in range(3)])


def _commanding(probe, robot, group_name):
    """Return ``(latest, group, direct)``: the last joint_states and the two command topics."""
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray
    latest = {}
    probe.node.create_subscription(JointState, f'{robot}/joint_states',
                                   lambda m: latest.__setitem__('js', m), 10)
    group = probe.node.create_publisher(Float64MultiArray, f'{group_name}/commands', 10)
    direct = probe.node.create_publisher(JointState, f'{robot}/joint_command', 10)
    probe.wait(lambda: group.get_subscription_count() and direct.get_subscription_count()
               and 'js' in latest, 60, f'the {robot} node')
    return latest, group, direct


def test_commands_reach_their_targets_and_hold_them_against_gravity(
        start_node, probe_for, tmp_path):
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray, String
    node = start_node({**_arm_params(), 'record_path': str(tmp_path / 'live')}, namespace=True)
    probe = probe_for(node, inputs=(), outputs=('diagnostics',))
    latest, group, direct = _commanding(probe, 'arm', 'arm_group')

    def settled(target):
        js = latest.get('js')
        return js is not None and np.allclose(js.position, target, atol=1e-12, rtol=0) \
            and np.allclose(js.velocity, 0.0, atol=1e-12, rtol=0)

    # Settled to 1e-12 rad and rad/s, a motor's effort is the gravity torque plus at most
    # I ω² |e| + 2 I ω |ė| ~ 3 kg m² x 400/s² x 1e-12 ~ 1e-9 N m (ω = 1/τ = 20/s): 1e-8 N m.
    effort_tol = 1e-8
    target = [0.5, 0.0, 0.0]
    group.publish(Float64MultiArray(data=target))
    # Critically damped with τ = 0.05 s: |e| <= (1 + t/τ) e^{-t/τ} 0.5 rad < 1e-12 in 1.7 s.
    probe.wait(lambda: settled(target), 30, 'the group target')
    effort = np.array(latest['js'].effort)
    assert np.allclose(effort, _gravity_torques(target), rtol=0, atol=effort_tol), effort
    # A JointState by name moves only the joints it names (NaN leaves the shoulder alone).
    direct.publish(JointState(name=['elbow', 'shoulder'], position=[0.3, math.nan]))
    target = [0.5, 0.3, 0.0]
    probe.wait(lambda: settled(target), 30, 'the elbow target')
    effort = np.array(latest['js'].effort)
    assert np.allclose(effort, _gravity_torques(target), rtol=0, atol=effort_tol), effort
    # Bad commands are rejected, counted, and change nothing.
    direct.publish(JointState(name=['knee'], position=[0.1]))
    direct.publish(JointState(name=['elbow'], position=[3.5]))  # beyond the 3.0 rad limit
    group.publish(Float64MultiArray(data=[0.1]))
    group.publish(Float64MultiArray(data=[0.1, math.nan, 0.0]))
    values = probe.diagnostic_values(lambda v: v.get('commands_rejected') == '4', 30)
    assert values['commands_rejected_unknown_joint'] == '1'
    assert values['commands_rejected_limit'] == '1'
    assert values['commands_rejected_length'] == '1'
    assert values['commands_rejected_non_finite'] == '1'
    assert float(values['joint_error_max_m']) <= 1e-12
    assert settled(target)
    # A late subscriber still gets the robot description (transient local), as loaded.
    qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                     reliability=ReliabilityPolicy.RELIABLE)
    got = []
    probe.node.create_subscription(String, 'arm/robot_description', got.append, qos)
    probe.wait(lambda: got, 30, 'the robot description')
    assert got[0].data == (URDF / 'arm3.urdf').read_text()
    assert node.stop() == 0
    result = replay_bag(tmp_path / 'live')
    assert result.match, result.problems
    assert result.wrenches == 2  # the two commands that took effect (rejected: not recorded)


def test_a_joint_trajectory_is_followed_at_its_waypoint_times(start_node, probe_for, tmp_path):
    from builtin_interfaces.msg import Duration
    from sensor_msgs.msg import JointState
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    bag = tmp_path / 'traj'
    node = start_node({**_arm_params(), 'publish_rate_hz': 1000.0, 'record_path': str(bag)},
                      namespace=True)
    probe = probe_for(node, inputs=(), outputs=())
    latest = {}
    probe.node.create_subscription(JointState, 'arm/joint_states',
                                   lambda m: latest.__setitem__('js', m), 10)
    pub = probe.node.create_publisher(JointTrajectory, 'arm_group/joint_trajectory', 10)
    probe.wait(lambda: pub.get_subscription_count() and 'js' in latest, 60, 'the arm node')
    waypoints = [(1, [1.0, 0.5, -0.5]), (2, [0.0, -0.4, 0.2])]
    pub.publish(JointTrajectory(
        joint_names=['wrist', 'shoulder', 'elbow'],  # any order: mapped by name
        points=[JointTrajectoryPoint(positions=[p[2], p[0], p[1]], velocities=[0.0] * 3,
                                     time_from_start=Duration(sec=sec))
                for sec, p in waypoints]))
    probe.wait(lambda: np.allclose(latest['js'].position, waypoints[-1][1], atol=1e-9)
               and np.allclose(latest['js'].velocity, 0.0, atol=1e-9), 60, 'the last waypoint')
    assert node.stop() == 0
    b = open_bag(bag)
    ns = '/' + node.namespace.strip('/')
    (command,) = list(b.messages([ns + '/arm_group/joint_trajectory']))
    effect = command.log_time_ns  # recorded at the step start it took effect at
    states = {s[0]: s[2] for s in _joint_states(bag, ns + '/arm/joint_states')}
    for sec, target in waypoints:
        # The arm starts at rest on the trajectory (its start state); the position target
        # moves with the reference's rate and mid-step acceleration, so the joints lag by
        # O(h²): 5e-8 rad measured. 1e-6 rad leaves a factor 20.
        assert np.allclose(states[effect + sec * S], target, atol=1e-6, rtol=0), \
            (sec, states[effect + sec * S])
    result = replay_bag(bag)
    assert result.match, result.problems


@pytest.mark.parametrize('extra, words', [
    ({'robots.arm.urdf_path': '/nonexistent/arm.urdf'},
     "robots.arm.urdf_path: '/nonexistent/arm.urdf' does not exist"),
    ({'robots.arm.initial_joint_positions': [0.1]}, 'robots.arm.initial_joint_positions'),
    ({'command_groups.arm_group.interface': 'torque'},
     "parameter command_groups.arm_group.interface = 'torque': must be one of"),
])
def test_bad_robot_files_stop_the_node_at_start_in_one_line(start_node, extra, words):
    node = start_node({**_arm_params(), **extra})
    assert node.wait(120) == 2, node.stderr
    assert any(words in line for line in node.stderr.splitlines()), node.stderr
    assert 'Traceback' not in node.stderr


def test_a_relative_urdf_path_is_relative_to_the_params_file(start_node, tmp_path):
    robots = tmp_path / 'robots'
    (robots / 'urdf').mkdir(parents=True)
    shutil.copy(URDF / 'pendulum.urdf', robots / 'urdf' / 'p.urdf')
    params = write_params(robots / 'p.yaml', {
        'robot_names': ['p'], 'robots.p.urdf_path': 'urdf/p.urdf', 'duration_s': 0.01,
        'real_time_factor': 0.0})
    node = start_node(params_file=params)  # the node runs in tmp_path, not beside the file
    assert node.wait(120) == 0, node.stderr


def test_a_mimic_gripper_is_an_atwood_machine_and_takes_commands_on_its_leader(
        start_node, probe_for, tmp_path):
    # gripper.urdf: finger_right mimics finger_left (multiplier 1), masses m_l = 0.1 kg and
    # m_r = 0.3 kg sliding along ±y. Under gravity -y: q'' = g (m_r - m_l) / (m_l + m_r) and
    # finger_right's effort, the mimic's constraint force, -2 m_l m_r g / (m_l + m_r).
    m_l, m_r = 0.1, 0.3
    bag = _run_to_end(start_node, tmp_path, {
        'robot_names': ['gripper'], 'robots.gripper.urdf_path': str(URDF / 'gripper.urdf'),
        'gravity': [0.0, -G, 0.0], 'duration_s': 0.2, 'publish_rate_hz': 100.0})
    samples = _joint_states(bag, '/gripper/joint_states')
    assert samples[0][1] == ['finger_left', 'finger_right'] and len(samples) == 21
    acc = G * (m_r - m_l) / (m_l + m_r)
    force = -2.0 * m_l * m_r * G / (m_l + m_r)
    for stamp, _, position, velocity, effort in samples[1:]:
        t = stamp * 1e-9
        # RK4 integrates the constant acceleration exactly; the projection holds the mimic
        # row to 1e-13 m: round-off of ~200 steps on 0.1 m values, 1e-12 m
        assert abs(position[0] - 0.5 * acc * t * t) <= 1e-12, (t, position)
        assert abs(position[1] - position[0]) <= 1e-12
        assert abs(velocity[0] - acc * t) <= 1e-12 and abs(velocity[1] - velocity[0]) <= 1e-12
        # the multiplier of a direct solve: round-off on O(1) N values
        assert effort[0] == 0.0 and abs(effort[1] - force) <= 1e-12, effort
    result = replay_bag(bag)
    assert result.match, result.problems

    from sensor_msgs.msg import JointState
    from std_msgs.msg import Float64MultiArray
    node = start_node({'robot_names': ['gripper'],
                       'robots.gripper.urdf_path': str(URDF / 'gripper.urdf'),
                       'command_group_names': ['fingers'], 'command_groups.fingers.robot':
                       'gripper'}, namespace=True)
    probe = probe_for(node, inputs=(), outputs=('diagnostics',))
    latest, group, direct = _commanding(probe, 'gripper', 'fingers')
    # the default group is every joint but the mimic: one value, finger_left's position
    group.publish(Float64MultiArray(data=[0.03]))
    probe.wait(lambda: np.allclose(latest['js'].position, [0.03, 0.03], atol=1e-12, rtol=0),
               30, 'both fingers at 0.03 m')
    direct.publish(JointState(name=['finger_right'], position=[0.01]))
    values = probe.diagnostic_values(lambda v: v.get('commands_rejected') == '1', 30)
    assert values['commands_rejected_mimic_joint'] == '1'
    assert np.allclose(latest['js'].position, [0.03, 0.03], atol=1e-12, rtol=0)
    assert node.stop() == 0
