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
A world's joints and a URDF robot in one node, through real DDS.

``msg_config/pendulum_world.yaml`` as shipped (a ball on a hinge to the world, a box it knocks
over) with a second params file adding ``msg_config/urdf/arm3.urdf`` as robot ``arm``, fixed
to the world at y = 1 m (its ``world`` link there, its mount 2 m above), released at a
shoulder angle of 0.3 rad. One node runs them free (started paused, recorded, 0.6 s of sim
time as fast as possible): the pendulum reaches its bottom at the closed-form quarter period
and keeps its hinge point on ``/tf``; the arm's ``arm/joint_states`` come out beside the
world's ``joint_states`` (each its own joints), its links on ``/tf`` as the URDF's kinematics
give them from its joint angles; the recording replays MATCH. A second node holds both with
position commands (``joint_command`` for the hinge, ``arm/joint_command`` for the arm), each
reaching its own joints only, with the closed-form gravity torques as efforts; the recording
replays MATCH.
"""

import math
import pathlib

from conftest import NodeProcess
import numpy as np
import pytest
from rbd_ros.bag.replay import replay_bag
from rbd_ros.msgs.conversions import time_from_msg
from test_node_robots import _gravity_torques
from test_node_world_joints import _hermite
from tests.core.joints.closed_forms import pendulum_period

REPO = pathlib.Path(__file__).resolve().parents[2]
PENDULUM = REPO / 'msg_config' / 'pendulum_world.yaml'
ARM_URDF = REPO / 'msg_config' / 'urdf' / 'arm3.urdf'
# pendulum_world.yaml's numbers (repeated from its comments): the 1 kg ball of radius 0.1 m
# hangs L = 0.8 m below the hinge at (0, 0, 1.2) m, released from rest at 45 degrees.
G, M, R, L = 9.81, 1.0, 0.1, 0.8
PIVOT = np.array([0.0, 0.0, 1.2])
THETA0 = math.pi / 4.0
BOB0 = PIVOT + L * np.array([-math.sin(THETA0), 0.0, -math.cos(THETA0)])
I_PIVOT = M * L * L + 0.4 * M * R * R  # kg m², a solid ball about the hinge
ARM_AT = (0.0, 1.0, 0.0)  # the arm's world link, m: clear of the pendulum and the box
ARM_Q0 = [0.3, 0.0, 0.0]  # rad
DURATION_NS = 600_000_000
PERIOD_NS = 10_000_000  # the file's publish_rate_hz: 100


def _arm(bag, duration_s):
    return {'robot_names': ['arm'], 'robots.arm.urdf_path': str(ARM_URDF),
            'robots.arm.initial_position': list(ARM_AT),
            'robots.arm.initial_joint_positions': ARM_Q0, 'start_paused': True,
            'duration_s': duration_s, 'real_time_factor': 0.0, 'record_path': str(bag)}


@pytest.fixture(scope='module')
def run(module_tmp):
    """Run the node on both files once; return what the probe received and the bag."""
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from ros_probe import Probe, run_paused_node
    from sensor_msgs.msg import JointState
    from tf2_msgs.msg import TFMessage
    bag = module_tmp / 'pendulum_arm'
    node = NodeProcess(module_tmp, _arm(bag, DURATION_NS * 1e-9), params_file=PENDULUM,
                       namespace=True)
    probe = Probe(node.namespace, inputs=(), outputs=('diagnostics',))
    got = {'joint_states': {}, 'arm/joint_states': {}, 'tf': {}}
    # joint_states are transient local (keep last 1): the paused node's t = 0 sample reaches a
    # subscription matched after it; /tf is volatile.
    latched = QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL)

    def keep(kind, stamp_of):
        return lambda msg: got[kind].__setitem__(time_from_msg(stamp_of(msg)), msg)
    subs = [probe.node.create_subscription(JointState, kind, keep(kind, lambda m: m.header.stamp),
                                           latched)
            for kind in ('joint_states', 'arm/joint_states')]
    subs.append(probe.node.create_subscription(
        TFMessage, '/tf', keep('tf', lambda m: m.transforms[0].header.stamp), 1000))
    topics, status = run_paused_node(probe, node, subs,
                                     lambda: all(DURATION_NS in got[k] for k in got))
    return {'got': got, 'topics': topics, 'ns': node.namespace.rstrip('/'), 'status': status,
            'bag': bag, 'stderr': node.stderr}


def test_the_world_joints_and_the_robots_topics_are_on_the_graph(run):
    assert run['status'] == 0, run['stderr']
    ns, topics = run['ns'], run['topics']
    expected = {'joint_states': 'sensor_msgs/msg/JointState',
                'joint_wrenches': 'sensor_msgs/msg/MultiDOFJointState',
                'joint_command': 'sensor_msgs/msg/JointState',
                'arm/joint_states': 'sensor_msgs/msg/JointState',
                'arm/joint_wrenches': 'sensor_msgs/msg/MultiDOFJointState',
                'arm/joint_command': 'sensor_msgs/msg/JointState',
                'arm/robot_description': 'std_msgs/msg/String',
                'bob/pose': 'geometry_msgs/msg/PoseStamped'}
    for topic, kind in expected.items():
        assert topics.get(f'{ns}/{topic}') == [kind], (topic, sorted(topics))


def test_the_pendulum_swings_with_the_closed_form_quarter_period_beside_the_arm(run):
    samples = run['got']['joint_states']
    times = sorted(samples)
    assert times == list(range(0, DURATION_NS + 1, PERIOD_NS))  # none lost, sim-time stamps
    assert all(list(samples[t].name) == ['hinge'] for t in times)  # the world's joints only
    t = np.array(times) * 1e-9
    q = np.array([samples[k].position[0] for k in times])
    qd = np.array([samples[k].velocity[0] for k in times])
    assert abs(q[0]) < 1e-15 and qd[0] == 0.0
    i = next(k for k in range(len(q) - 1) if q[k] > -THETA0 >= q[k + 1])
    t_bottom, rate = _hermite(t[i], t[i + 1], q[i], q[i + 1], qd[i], qd[i + 1], -THETA0)
    quarter = pendulum_period(I_PIVOT / (M * L), THETA0, G) / 4.0
    speed = math.sqrt(2.0 * M * G * L * (1.0 - math.cos(THETA0)) / I_PIVOT)
    # The bounds of test_node_world_joints.py (the same world, the same step; the arm is
    # another island of the contact step and leaves the pendulum's bits alone).
    print(f'T/4: {t_bottom - quarter:.3g} s off; |q\u0307|: {-rate - speed:.3g} rad/s off')
    assert abs(t_bottom - quarter) < 1e-5 and abs(-rate - speed) < 1e-5, (t_bottom, rate)


def _transforms(run):
    """Return ``{t: {(parent, child): (p, q (w, x, y, z))}}`` of every /tf message received."""
    out = {}
    for t, msg in run['got']['tf'].items():
        frames = {}
        for tr in msg.transforms:
            assert time_from_msg(tr.header.stamp) == t
            p, r = tr.transform.translation, tr.transform.rotation
            frames[(tr.header.frame_id, tr.child_frame_id)] = (
                np.array([p.x, p.y, p.z]), np.array([r.w, r.x, r.y, r.z]))
        out[t] = frames
    return out


def _rotate(q, v):
    w, u = q[0], np.asarray(q[1:])
    return v + 2.0 * w * np.cross(u, v) + 2.0 * np.cross(u, np.cross(u, v))


def test_tf_keeps_the_hinge_point_and_gives_the_arm_as_its_joint_states_say(run):
    frames, arm = _transforms(run), run['got']['arm/joint_states']
    assert set(range(PERIOD_NS, DURATION_NS + 1, PERIOD_NS)) <= set(frames), sorted(frames)
    anchor_b = PIVOT - BOB0  # the hinge point in the ball's frame (identity at its start)
    worst = max(float(np.linalg.norm(p + _rotate(q, anchor_b) - PIVOT))
                for p, q in (f[('world', 'bob')] for f in frames.values()))
    print(f'hinge point off its pivot on /tf: at most {worst:.3g} m')
    # The joints hold to PROJECTION_TOL 1e-13 per row; /tf carries the state's exact floats
    # (measured 1.2e-13 m in test_node_world_joints.py, through the knock).
    assert worst <= 1e-12
    assert list(arm[0].name) == ['shoulder', 'elbow', 'wrist']
    # read back from the placed links' poses: round-off of the placement (one ulp of 0.3)
    assert np.allclose(arm[0].position, ARM_Q0, atol=1e-15, rtol=0), arm[0].position
    assert list(arm[0].velocity) == [0.0] * 3
    moved = 0.0
    for t, got in frames.items():
        q = arm[t].position
        moved = max(moved, abs(q[0] - ARM_Q0[0]))
        # arm3.urdf: world -> mount fixed 2 m up (its world link at ARM_AT: the mount is at
        # ARM_AT + 2 z in the world frame); shoulder, elbow, wrist about y, each 0.5 m below
        # its parent's origin (0 for the shoulder); hand -> tool0 fixed 0.5 m below.
        expected = {('world', 'mount'): ((ARM_AT[0], ARM_AT[1], 2.0), 0.0),
                    ('mount', 'upper'): ((0, 0, 0), q[0]),
                    ('upper', 'fore'): ((0, 0, -0.5), q[1]),
                    ('fore', 'hand'): ((0, 0, -0.5), q[2]),
                    ('hand', 'tool0'): ((0, 0, -0.5), 0.0)}
        for key, (origin, angle) in expected.items():
            p, r = got[key]
            # 1e-12: the anchors hold to PROJECTION_TOL = 1e-13 m, a relative transform is a
            # few dozen flops on values of order 1 (as test_node_robots.py)
            assert np.allclose(p, origin, atol=1e-12, rtol=0), (t, key, p)
            want = [math.cos(angle / 2), 0.0, math.sin(angle / 2), 0.0]
            assert np.allclose(r, want, atol=1e-12, rtol=0), (t, key, r, want)
    assert moved > 0.1  # it swung: released at 0.3 rad under gravity


def test_the_recording_of_both_replays_bit_for_bit(run):
    result = replay_bag(run['bag'])
    assert result.match, (result.problems, {k: r.first_mismatch
                                            for k, r in result.topics.items()})
    ns = run['ns']  # both groups compared, each on its own topic
    assert {f'{ns}/joint_states', f'{ns}/arm/joint_states'} <= set(result.topics), \
        sorted(result.topics)


def test_each_joint_command_holds_its_own_joints_and_replays(tmp_path):
    # The hinge commanded to 0 (the release pose) and the arm to its initial angles before the
    # first step: each critically damped response from e0 = 0 keeps its joints there, each
    # motor carrying gravity's torque: m g L sin(theta0) = 5.549 N m on the hinge, the arm's
    # closed form on its joints. A command naming the arm's joint on the world's joint_command
    # is rejected (unknown_joint): the two inputs are separate.
    from ros_probe import Probe
    from sensor_msgs.msg import JointState
    bag = tmp_path / 'held'
    node = NodeProcess(tmp_path, _arm(bag, 0.3), params_file=PENDULUM, namespace=True)
    probe = Probe(node.namespace, inputs=(), outputs=('diagnostics',))
    got = {'joint_states': {}, 'arm/joint_states': {}}
    subs = [probe.node.create_subscription(
        JointState, kind, lambda m, kind=kind: got[kind].__setitem__(
            time_from_msg(m.header.stamp), m), 1000) for kind in got]
    world = probe.node.create_publisher(JointState, 'joint_command', 10)
    arm = probe.node.create_publisher(JointState, 'arm/joint_command', 10)
    try:
        probe.wait(lambda: all(s.get_publisher_count() >= 1 for s in subs)
                   and world.get_subscription_count() >= 1
                   and arm.get_subscription_count() >= 1
                   and probe.clients['pause'].service_is_ready(), 120, 'the node on the graph')
        world.publish(JointState(name=['shoulder'], position=[0.3]))
        world.publish(JointState(name=['hinge'], position=[0.0]))
        arm.publish(JointState(name=['shoulder', 'elbow', 'wrist'], position=ARM_Q0))
        values = probe.diagnostic_values(lambda v: v.get('commands_received') == '3', 30)
        probe.pause(False)
        probe.wait(lambda: all(300_000_000 in series for series in got.values()), 120,
                   'the last sample')
        assert node.wait(60) == 0, node.stderr
    finally:
        probe.close()
        node.stop()
    assert values['commands_rejected'] == '1', values
    assert values['commands_rejected_unknown_joint'] == '1', values
    hold = M * G * L * math.sin(THETA0)
    torques = _gravity_torques(ARM_Q0)
    for t in range(PERIOD_NS, 300_000_001, PERIOD_NS):
        (q,), (effort,) = got['joint_states'][t].position, got['joint_states'][t].effort
        # as test_node_world_joints.py: the response lands on e = 0 to the projection's 1e-13
        assert abs(q) <= 1e-12 and effort == pytest.approx(hold, rel=1e-9), (t, q, effort)
        js = got['arm/joint_states'][t]
        # as test_node_robots.py: held to 1e-12 rad. The efforts are the gravity torques to
        # 1e-3 N m: the contact step reports a chain's motors off the statics at rest (shoulder
        # -3.7e-4, elbow +4.7e-4 N m, wrist exact; an arm alone in a world with a ground the
        # same, in process, where the joints-only core gives them to 1e-15), but the wrong
        # robot's or no command would be off by the torques themselves (0.7 to 6.5 N m).
        assert np.allclose(js.position, ARM_Q0, atol=1e-12, rtol=0), (t, js.position)
        assert np.allclose(js.effort, torques, atol=1e-3, rtol=0), (t, js.effort, torques)
    result = replay_bag(bag)
    assert result.match, (result.problems, {k: r.first_mismatch
                                            for k, r in result.topics.items()})
