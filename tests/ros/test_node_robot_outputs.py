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
A robot's ``odom`` and ``joint_wrenches``, through real DDS and the node's own recordings.

Every expected value is computed here: the floating root's velocity by finite differences of
its published poses, its pose from its own ``/tf`` transform, a hanging chain's joint forces
from the link masses read out of the URDF file (statics: joint k from the bottom carries the k
links below it). Replay must match the recordings bit for bit, and must not match a copy with
one of these messages altered by one bit.
"""

import math
import pathlib
import struct
import xml.etree.ElementTree as ET

from conftest import wait_until
import numpy as np
from rbd_ros.bag.recording import BagWriter, open_bag
from rbd_ros.bag.replay import replay_bag
from rbd_ros.msgs.conversions import time_from_msg

REPO = pathlib.Path(__file__).resolve().parents[2]
URDF = REPO / 'msg_config' / 'urdf'
G = 9.81
H_NS = 1_000_000  # the physics step of these tests, ns

# A floating two-link robot: a base and an arm on a continuous joint about the base's z, hung
# from a bracket (a massless frame on a fixed joint, folded into the base's body). The base's
# COM is off its link frame's origin (and off the hinge's line), so the link frame's velocity
# differs from the COM's, and the arm's swing makes the base translate and rotate.
FLOATING_URDF = """<?xml version="1.0"?>
<robot name="floater">
  <link name="base">
    <inertial><origin xyz="0.1 0 0.05"/><mass value="2.0"/>
      <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial>
  </link>
  <joint name="bracket_joint" type="fixed">
    <parent link="base"/><child link="bracket"/>
    <origin xyz="0.2 0 0" rpy="0 0 0.4"/>
  </joint>
  <link name="bracket"/>
  <joint name="hinge" type="continuous">
    <parent link="bracket"/><child link="arm"/>
    <origin xyz="0.1 0 0" rpy="0 0 -0.4"/><axis xyz="0 0 1"/>
  </joint>
  <link name="arm">
    <inertial><origin xyz="0.25 0 0"/><mass value="1.0"/>
      <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial>
  </link>
</robot>
"""


def _quat_mul(a, b):
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return np.array([aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
                     aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw])


def _rotate(q, v):
    """Return ``R(q) v`` (``q`` = w, x, y, z) through the quaternion product."""
    qc = np.array([q[0], -q[1], -q[2], -q[3]])
    return _quat_mul(_quat_mul(q, np.concatenate(([0.0], v))), qc)[1:]


def _flip_last_bit(data, offset):
    """Return CDR ``data`` with the float64 at byte ``offset`` changed in its last bit."""
    (value,) = struct.unpack_from('<d', data, offset)
    bits = struct.unpack('<q', struct.pack('<d', value))[0] ^ 1
    return data[:offset] + struct.pack('<q', bits) + data[offset + 8:]


def _tampered(bag, out, topic, offset_of):
    """Copy ``bag`` with the 10th message on ``topic`` changed in one bit (see offset_of)."""
    src = open_bag(bag)
    writer = BagWriter(out, config=dict(src.config))
    for name, info in src.topics.items():
        writer.add_topic(name, info.type_name, info.qos[0])
    seen = 0
    for raw in src.messages():
        data = raw.data
        if raw.topic == topic:
            seen += 1
            if seen == 10:
                data = _flip_last_bit(data, offset_of(data))
        writer.write(raw.topic, data, raw.log_time_ns, raw.publish_time_ns)
    writer.close(run_metadata=src.run_metadata)
    assert seen >= 10
    return out


def _step(probe):
    """Call ``~/step`` (again while the node compiles its kernels); return the sim time, ns."""
    def stepped():
        response = probe.call('step')
        if not response.success:
            assert response.message.startswith('compiling'), response.message
        return response.success and response
    return int(wait_until(stepped, 300, probe.spin, 'a step').message.split()[2])


def test_a_floating_robot_odom_is_its_root_links_tf_and_pose_rate(
        start_node, probe_for, tmp_path):
    from nav_msgs.msg import Odometry
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
    from sensor_msgs.msg import MultiDOFJointState
    from tf2_msgs.msg import TFMessage
    urdf = tmp_path / 'floater.urdf'
    urdf.write_text(FLOATING_URDF)
    bag = tmp_path / 'floater'
    node = start_node({
        'robot_names': ['floater'], 'robots.floater.urdf_path': str(urdf),
        'robots.floater.initial_position': [1.0, -2.0, 0.5],
        'robots.floater.initial_orientation': [0.1, 0.2, 0.3, math.sqrt(1 - 0.14)],
        'robots.floater.initial_joint_velocities': [4.0], 'gravity': [0.0, 0.0, -G],
        'publish_tf': True, 'publish_rate_hz': 1000.0, 'start_paused': True,
        'record_path': str(bag)}, namespace=True)
    probe = probe_for(node, inputs=(), outputs=())
    odom, tf = {}, {}
    latched = QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL,
                         reliability=ReliabilityPolicy.RELIABLE)
    probe.node.create_subscription(
        Odometry, 'floater/odom', lambda m: odom.__setitem__(time_from_msg(m.header.stamp), m),
        latched)
    probe.node.create_subscription(
        TFMessage, '/tf',
        lambda m: tf.__setitem__(time_from_msg(m.transforms[0].header.stamp), m), 1000)
    # odom is transient local: its t = 0 sample says the node is up (/tf is volatile: its
    # t = 0 message went out before this subscription, so the comparisons start at step 1).
    wrenches = {}
    probe.node.create_subscription(
        MultiDOFJointState, 'floater/joint_wrenches',
        lambda m: wrenches.__setitem__(time_from_msg(m.header.stamp), m), 1000)
    probe.wait(lambda: 0 in odom, 120, 'the t = 0 odom sample')
    times = []
    for _ in range(40):
        t = _step(probe)
        probe.wait(lambda: t in odom and t in tf and t in wrenches, 20,
                   f'the sample at {t} ns')
        times.append(t)
    assert times == [k * H_NS for k in range(1, 41)]
    assert node.stop() == 0

    # The odom pose is the root link's /tf transform, bit for bit (one pose, two messages).
    for t in times:
        msg = odom[t]
        assert (msg.header.frame_id, msg.child_frame_id) == ('world', 'base')
        (root,) = [tr for tr in tf[t].transforms if tr.child_frame_id == 'base']
        assert root.header.frame_id == 'world'
        p, o = msg.pose.pose.position, msg.pose.pose.orientation
        tr, rot = root.transform.translation, root.transform.rotation
        assert (p.x, p.y, p.z, o.x, o.y, o.z, o.w) == (tr.x, tr.y, tr.z, rot.x, rot.y, rot.z,
                                                       rot.w)
    # The twist, in the link frame (REP 105), against central differences of the pose over
    # 2 h: the error is h² x''' / 6. The root's jerk is of order ω³ r with the arm's ω = 4
    # rad/s and r ~ 0.3 m, 20 m/s³: h²/6 x 20 ~ 3e-6 m/s (3.5e-7 measured). Its angular
    # velocity (~0.4 rad/s) is driven at the arm's rate, ω''' ~ ω_arm³ |ω_root| ~ 26 rad/s⁴:
    # 4e-6 rad/s (7e-6 measured, with the quaternion's own curvature); 3e-5 bounds it. A twist
    # in the wrong frame (world, not link: rotated by 0.75 rad) or of the COM (0.11 m off) is
    # wrong by > 1e-2.
    pos = {t: np.array([odom[t].pose.pose.position.x, odom[t].pose.pose.position.y,
                        odom[t].pose.pose.position.z]) for t in times}
    quat = {t: np.array([odom[t].pose.pose.orientation.w, odom[t].pose.pose.orientation.x,
                         odom[t].pose.pose.orientation.y, odom[t].pose.pose.orientation.z])
            for t in times}
    h = H_NS * 1e-9
    worst_v = worst_w = 0.0
    speed = 0.0
    for t in times[1:-1]:
        twist = odom[t].twist.twist
        v_l = np.array([twist.linear.x, twist.linear.y, twist.linear.z])
        w_l = np.array([twist.angular.x, twist.angular.y, twist.angular.z])
        v_fd = (pos[t + H_NS] - pos[t - H_NS]) / (2 * h)
        worst_v = max(worst_v, float(np.linalg.norm(_rotate(quat[t], v_l) - v_fd)))
        # q̇ = ½ q ⊗ (0, ω_l): ω_l = 2 (q* ⊗ q̇), vector part
        q_dot = (quat[t + H_NS] - quat[t - H_NS]) / (2 * h)
        q_conj = quat[t] * np.array([1.0, -1.0, -1.0, -1.0])
        w_fd = 2.0 * _quat_mul(q_conj, q_dot)[1:]
        worst_w = max(worst_w, float(np.linalg.norm(w_l - w_fd)))
        speed = max(speed, float(np.linalg.norm(v_l)), float(np.linalg.norm(w_l)))
    assert speed > 0.1  # the root does move: the check is not of zeros
    assert worst_v <= 3e-6 and worst_w <= 3e-5, (worst_v, worst_w)
    _check_hinge_wrench(times, pos, quat, tf, wrenches)

    # The recording replays bit for bit, odom and joint_wrenches included; one bit changed in
    # either is a mismatch on that topic.
    ns = '/' + node.namespace.strip('/')
    result = replay_bag(bag)
    assert result.match, result.problems
    for kind in ('odom', 'joint_wrenches', 'joint_states'):
        assert result.topics[f'{ns}/floater/{kind}'].samples == 41
    # odom: the pose's x follows the header, the child frame id and its padding: its last
    # 8 + 36 x 8 + 6 x 8 + 36 x 8 bytes are pose and covariances, twist and covariance.
    cases = {'odom': lambda data: len(data) - 36 * 8 - 6 * 8 - 36 * 8 - 7 * 8,
             'joint_wrenches': lambda data: len(data) - 6 * 8}  # the last joint's force x
    for kind, offset_of in cases.items():
        topic = f'{ns}/floater/{kind}'
        tampered = replay_bag(_tampered(bag, tmp_path / f'tampered_{kind}', topic, offset_of))
        assert not tampered.match
        assert [t for t, r in tampered.topics.items() if r.mismatches] == [topic], \
            tampered.problems


def _check_hinge_wrench(times, pos, quat, tf, wrenches):
    """
    Check the floater's hinge wrench by Newton and Euler on the arm, from its /tf poses.

    The hinge is the only thing acting on the arm besides gravity: ``m a_com = F_w + m g`` and,
    about the COM, in the arm's axes, ``τ_com = I ω̇ + ω × I ω`` with ``τ_com = τ_A + (A − C) ×
    F`` for the reported torque ``τ_A`` about the joint (the arm link's origin A). The massless
    bracket passes that wrench on: its fixed joint carries the same force and, about its own
    origin B, ``τ_B = τ_A + (A − B) × F`` (statics), in the bracket's frame.
    """
    mass, inertia, com_l = 1.0, np.diag([0.001, 0.02, 0.02]), np.array([0.25, 0.0, 0.0])
    g_w = np.array([0.0, 0.0, -G])
    h = H_NS * 1e-9
    arm_p, arm_q, bracket_p, bracket_q = {}, {}, {}, {}

    def compose(p, q, transform):  # a frame given by its /tf transform from frame (p, q)
        tr, rot = transform.translation, transform.rotation
        return (p + _rotate(q, np.array([tr.x, tr.y, tr.z])),
                _quat_mul(q, np.array([rot.w, rot.x, rot.y, rot.z])))
    for t in times:
        rel = {tr.child_frame_id: tr for tr in tf[t].transforms}
        assert rel['bracket'].header.frame_id == 'base'
        assert rel['arm'].header.frame_id == 'bracket'
        bracket_p[t], bracket_q[t] = compose(pos[t], quat[t], rel['bracket'].transform)
        arm_p[t], arm_q[t] = compose(bracket_p[t], bracket_q[t], rel['arm'].transform)
    com_w = {t: arm_p[t] + _rotate(arm_q[t], com_l) for t in times}

    def omega(t):  # arm's ω in its own axes, central difference of its quaternion
        q_dot = (arm_q[t + H_NS] - arm_q[t - H_NS]) / (2 * h)
        return 2.0 * _quat_mul(arm_q[t] * np.array([1.0, -1.0, -1.0, -1.0]), q_dot)[1:]
    worst_f = worst_t = worst_b = 0.0
    size_f = size_t = 0.0
    for t in times[2:-2]:
        assert wrenches[t].joint_names == ['bracket_joint', 'hinge']
        assert wrenches[t].header.frame_id == ''
        bracket, w = wrenches[t].wrench
        force_l = np.array([w.force.x, w.force.y, w.force.z])
        torque_a = np.array([w.torque.x, w.torque.y, w.torque.z])
        accel = (com_w[t + H_NS] - 2 * com_w[t] + com_w[t - H_NS]) / h ** 2
        force_w = _rotate(arm_q[t], force_l)
        worst_f = max(worst_f, float(np.linalg.norm(mass * accel - (force_w + mass * g_w))))
        w_t = omega(t)
        w_dot = (omega(t + H_NS) - omega(t - H_NS)) / (2 * h)
        torque_c = torque_a + np.cross(-com_l, force_l)
        euler = inertia @ w_dot + np.cross(w_t, inertia @ w_t)
        worst_t = max(worst_t, float(np.linalg.norm(torque_c - euler)))
        size_f = max(size_f, float(np.linalg.norm(force_l)))
        size_t = max(size_t, float(np.linalg.norm(torque_a)))
        # The bracket's joint, from the hinge's wrench by statics (world frame, then its own).
        torque_b_w = _rotate(arm_q[t], torque_a) + np.cross(arm_p[t] - bracket_p[t], force_w)
        q_bw = bracket_q[t] * np.array([1.0, -1.0, -1.0, -1.0])
        got = [bracket.force.x, bracket.force.y, bracket.force.z, bracket.torque.x,
               bracket.torque.y, bracket.torque.z]
        want = np.concatenate((_rotate(q_bw, force_w), _rotate(q_bw, torque_b_w)))
        worst_b = max(worst_b, float(np.abs(np.array(got) - want).max()))
    # Second differences err by h² x'''' / 12: the COM circles at ω = 4 rad/s, r ~ 0.25 m,
    # so x'''' ~ ω⁴ r = 64 m/s⁴ and m h²/12 x 64 ~ 5e-6 N; the torque's ω̇ and ω come from
    # differences of the quaternion, each ~1e-5 rad/s off (above), times I ω ~ 0.1: ~1e-6 N m.
    # 1e-4 N and 1e-5 N m bound both; the force is ~3 N (mostly the centripetal m ω² r) and the
    # torque about the joint ~0.05 N m, so a wrong frame, sign or point is far outside.
    assert size_f > 1.0 and size_t > 1e-3, (size_f, size_t)
    assert worst_f <= 1e-4 and worst_t <= 1e-5, (worst_f, worst_t)
    # The same numbers through two frame changes (the test's and the node's): round-off of
    # values ~3 N and lever arms ~0.1 m, 1e-12 N or N m.
    assert worst_b <= 1e-12, worst_b


def _masses(path):
    """Return the URDF's link masses (kg) in link order, None for a link without one."""
    masses = []
    for link in ET.parse(path).getroot().iter('link'):
        mass = link.find('inertial/mass')
        masses.append(None if mass is None else float(mass.get('value')))
    return masses


def test_a_hanging_chain_reports_k_m_g_and_a_fixed_robot_no_odom(
        start_node, probe_for, tmp_path):
    from sensor_msgs.msg import MultiDOFJointState
    bag = tmp_path / 'arm'
    node = start_node({
        'robot_names': ['arm'], 'robots.arm.urdf_path': str(URDF / 'arm3.urdf'),
        'gravity': [0.0, 0.0, -G], 'publish_rate_hz': 100.0, 'record_path': str(bag)},
        namespace=True)
    probe = probe_for(node, inputs=(), outputs=())
    got = []
    probe.node.create_subscription(MultiDOFJointState, 'arm/joint_wrenches', got.append, 100)
    probe.wait(lambda: any(time_from_msg(m.header.stamp) > 0 for m in got), 120,
               'a joint_wrenches sample after the first step')
    ns = '/' + node.namespace.strip('/')
    # The graph: the node's topics under its namespace (the probe only subscribes).
    topics = probe.wait(lambda: (lambda names: f'{ns}/arm/joint_states' in names and names)(
        dict(probe.node.get_topic_names_and_types())), 30, 'the node on the graph')
    assert topics[f'{ns}/arm/joint_wrenches'] == ['sensor_msgs/msg/MultiDOFJointState']
    assert not [name for name in topics if name.endswith('odom')], topics
    assert node.stop() == 0

    # arm3.urdf: world -(fixed)- mount -(shoulder)- upper -(elbow)- fore -(wrist)- hand
    # -(fixed)- tool0; the three moving links' masses from the file, the weight below each
    # joint by statics (the links hang straight down, at rest).
    masses = _masses(URDF / 'arm3.urdf')
    below = {'shoulder': sum(masses[2:5]), 'elbow': sum(masses[3:5]), 'wrist': masses[4]}
    assert all(m is not None and m > 0 for m in masses[2:5]) and masses[5] is None
    msg = next(m for m in got if time_from_msg(m.header.stamp) > 0)
    assert msg.joint_names == ['mount_joint', 'shoulder', 'elbow', 'wrist', 'tool_joint']
    assert msg.header.frame_id == '' and not msg.transforms and not msg.twist
    wrench = dict(zip(msg.joint_names, msg.wrench))
    for name, mass in below.items():
        force, torque = wrench[name].force, wrench[name].torque
        # The parent holds the child up: + z of the child link frame (the world's z here),
        # m g of every link below. 1e-12 relative: the core's statics to round-off of its
        # solve (doc/joints.md: 1e-12 on its own chain), the frame change a few ulps more.
        expected = mass * G
        assert abs(force.z / expected - 1.0) <= 1e-12, (name, force, expected)
        assert math.hypot(force.x, force.y) <= 1e-12 * expected, (name, force)
        assert math.sqrt(torque.x ** 2 + torque.y ** 2 + torque.z ** 2) <= 1e-12 * expected
    # The fixed joint inside the world holds the massless mount, from which the whole arm
    # hangs: the three links' weight, up, with no torque (the shoulder is at the mount's
    # origin). The one to the frame tool0 (no <inertial>: folded into the hand's body) holds
    # nothing: exactly 0.
    mount, tool = wrench['mount_joint'], wrench['tool_joint']
    expected = below['shoulder'] * G  # the shoulder holds all three links
    assert abs(mount.force.z / expected - 1.0) <= 1e-12, (mount, expected)
    assert max(abs(mount.force.x), abs(mount.force.y), abs(mount.torque.x),
               abs(mount.torque.y), abs(mount.torque.z)) <= 1e-12 * expected, mount
    assert [tool.force.x, tool.force.y, tool.force.z, tool.torque.x, tool.torque.y,
            tool.torque.z] == [0.0] * 6

    b = open_bag(bag)
    assert not [topic for topic in b.topics if topic.endswith('odom')], sorted(b.topics)
    decode = b.decoder(f'{ns}/arm/joint_wrenches')
    first = decode(next(iter(b.messages([f'{ns}/arm/joint_wrenches']))).data)
    # At t = 0 no step has computed the multipliers yet: every value is NaN.
    assert time_from_msg(first.header.stamp) == 0
    assert all(math.isnan(v) for w in first.wrench for v in (w.force.x, w.torque.z))
    result = replay_bag(bag)
    assert result.match, result.problems
    assert result.topics[f'{ns}/arm/joint_wrenches'].samples >= 2


def _link_names(path):
    """Return the URDF file's link names in document order (read here, not by rbd_ros)."""
    return [link.get('name') for link in ET.parse(path).getroot().iter('link')]


def test_two_robots_of_one_urdf_publish_their_own_frames_with_frame_prefix(
        start_node, probe_for, tmp_path):
    """
    Name every link frame with its robot's ``frame_prefix``.

    Two arm3 robots (one URDF) and a floater, each with a prefix: ``/tf``, ``odom`` and the
    links' ``markers`` name every link frame with it (the URDF's ``world`` link stays the world
    frame), and the two arms' link transforms are the same.
    """
    from nav_msgs.msg import Odometry
    from tf2_msgs.msg import TFMessage
    from visualization_msgs.msg import MarkerArray
    urdf = tmp_path / 'floater.urdf'
    # In a world with contact every moving link needs a collision shape: a box at each COM.
    box = '<collision><origin xyz="{}"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision>'
    urdf.write_text(FLOATING_URDF.replace(
        '</inertial>\n  </link>\n  <joint name="bracket_joint"',
        '</inertial>' + box.format('0.1 0 0.05') + '\n  </link>\n  <joint name="bracket_joint"'
    ).replace('</inertial>\n  </link>\n</robot>',
              '</inertial>' + box.format('0.25 0 0') + '\n  </link>\n</robot>'))
    assert urdf.read_text().count('<collision>') == 2
    bag = tmp_path / 'two_arms'
    arm = str(URDF / 'arm3.urdf')
    bends = [0.3, -0.2, 0.1]
    node = start_node({
        'robot_names': ['left', 'right', 'floater'],
        'robots.left.urdf_path': arm, 'robots.left.frame_prefix': 'left/',
        'robots.left.initial_position': [0.0, 0.0, 2.0],
        'robots.left.initial_joint_positions': list(bends),  # no YAML alias (rcl refuses)
        'robots.right.urdf_path': arm, 'robots.right.frame_prefix': 'right/',
        'robots.right.initial_position': [0.0, 1.0, 2.0],
        'robots.right.initial_joint_positions': list(bends),
        'robots.floater.urdf_path': str(urdf), 'robots.floater.frame_prefix': 'f/',
        'robots.floater.initial_position': [3.0, 0.0, 3.0],
        'ground.enabled': True, 'gravity': [0.0, 0.0, -G], 'publish_tf': True,
        'publish_rate_hz': 1000.0, 'start_paused': True, 'record_path': str(bag)},
        namespace=True)
    probe = probe_for(node, inputs=(), outputs=())
    tf, odom, markers = {}, {}, {}
    probe.node.create_subscription(
        TFMessage, '/tf', lambda m: tf.__setitem__(time_from_msg(m.transforms[0].header.stamp),
                                                   m), 1000)
    probe.node.create_subscription(
        Odometry, 'floater/odom', lambda m: odom.__setitem__(time_from_msg(m.header.stamp), m),
        1000)
    probe.node.create_subscription(
        MarkerArray, 'markers',
        lambda m: markers.__setitem__(time_from_msg(m.markers[0].header.stamp), m), 1000)
    # A request sent before the service is matched is lost: wait for it (a start takes seconds).
    probe.wait(probe.clients['step'].service_is_ready, 120, 'the step service')
    t = 0
    for _ in range(3):
        t = _step(probe)
    probe.wait(lambda: t in tf and t in odom and t in markers, 30, f'the sample at {t} ns')
    assert node.stop() == 0

    arm_links = _link_names(URDF / 'arm3.urdf')
    assert arm_links[0] == 'world'
    frames = {tr.child_frame_id: tr for tr in tf[t].transforms}
    expected = ({f'{side}/{link}' for side in ('left', 'right') for link in arm_links[1:]}
                | {f'f/{link}' for link in _link_names(urdf)})
    assert set(frames) == expected, sorted(frames)
    # Parents: the world frame for each arm's mount (hung from the URDF's world link) and the
    # floater's root; a prefixed link of the same robot for every other frame.
    for child, tr in frames.items():
        side = child.split('/')[0]
        assert tr.header.frame_id == 'world' or tr.header.frame_id.startswith(side + '/'), tr
    assert {child for child, tr in frames.items() if tr.header.frame_id == 'world'} == {
        'left/mount', 'right/mount', 'f/base'}
    assert odom[t].child_frame_id == 'f/base' and odom[t].header.frame_id == 'world'
    # One URDF, the same joint positions, 1 m apart in y: the mount transforms differ by that
    # placement; each link in its parent link is the same motion (two identical chains under
    # the same gravity; the world coordinates differ, so a few ulps: 1e-12 m and rad).
    left, right = frames['left/mount'].transform, frames['right/mount'].transform
    assert abs(right.translation.y - left.translation.y - 1.0) <= 1e-12
    for link in arm_links[2:]:
        a, b = frames[f'left/{link}'].transform, frames[f'right/{link}'].transform
        for field in ('x', 'y', 'z'):
            assert abs(getattr(a.translation, field) - getattr(b.translation, field)) <= 1e-12
        assert abs(a.rotation.w - b.rotation.w) <= 1e-12, link
    # The moving links' markers are drawn in their prefixed frames; the mounts (fixed to the
    # world) are static markers in the world frame.
    link_frames = {m.header.frame_id for m in markers[t].markers if m.ns == 'links'}
    assert link_frames == {f'{side}/{link}' for side in ('left', 'right')
                           for link in ('upper', 'fore', 'hand')} | {'f/base', 'f/arm'}, \
        link_frames
    result = replay_bag(bag)
    assert result.match, result.problems
