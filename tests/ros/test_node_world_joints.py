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
A world's joints in the node (``msg_config/pendulum_world.yaml``), through real DDS.

One node on the file as shipped (started paused, recorded, run 1.5 s of sim time at the file's
real-time factor), one probe: the node's graph, ``joint_states``, ``joint_wrenches`` and ``/tf``
as received, a ``joint_command`` naming no joint rejected and counted in ``/diagnostics``, and
the recording replayed. A second node takes a position command on the hinge (the core's motor)
and holds the ball where it was released, against gravity, recorded and replayed. The expected
values are closed forms of the file's numbers (repeated here from its comments, so that a
change of the file is seen): the ball of radius r = 0.1 m, 1 kg, hangs L = 0.8 m below the
hinge at (0, 0, 1.2) m and is released from rest at 45 degrees. A third node on
``msg_config/door_world.yaml`` swings the door onto its hinge's limit, where it stops dead and
then holds a push, read back from the node's own recording.
"""

import math
import pathlib
import time

from conftest import NodeProcess, wait_until
import numpy as np
import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import replay_bag
from rbd_ros.msgs.conversions import time_from_msg
from tests.core.joints.closed_forms import pendulum_period

REPO = pathlib.Path(__file__).resolve().parents[2]
PENDULUM = REPO / 'msg_config' / 'pendulum_world.yaml'
G = 9.81
M, R, L = 1.0, 0.1, 0.8  # kg, m, m
PIVOT = np.array([0.0, 0.0, 1.2])
THETA0 = math.pi / 4.0
BOB0 = PIVOT + L * np.array([-math.sin(THETA0), 0.0, -math.cos(THETA0)])
I_PIVOT = M * L * L + 0.4 * M * R * R  # kg m², a solid ball about the hinge
DURATION_NS = 1_500_000_000
PERIOD_NS = 10_000_000  # the file's publish_rate_hz: 100


@pytest.fixture(scope='module')
def run(module_tmp):
    """Run the node on the file once; return what the probe received and the bag."""
    from rclpy.qos import DurabilityPolicy, QoSProfile
    from ros_probe import Probe
    from sensor_msgs.msg import JointState, MultiDOFJointState
    from tf2_msgs.msg import TFMessage
    bag = module_tmp / 'pendulum'
    # joint_states and joint_wrenches are transient local (keep last 1): a subscription matched
    # after the node's t = 0 sample (published once, while paused) still gets it.
    latched = QoSProfile(depth=1000, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    node = NodeProcess(module_tmp, {'start_paused': True, 'duration_s': DURATION_NS * 1e-9,
                                    'record_path': str(bag)},
                       params_file=PENDULUM, namespace=True)
    probe = Probe(node.namespace, inputs=(), outputs=('diagnostics',))
    got = {'joint_states': {}, 'joint_wrenches': {}, 'tf': {}}

    def keep(kind, stamp_of):
        return lambda msg: got[kind].__setitem__(time_from_msg(stamp_of(msg)), msg)
    subs = [probe.node.create_subscription(JointState, 'joint_states',
                                           keep('joint_states', lambda m: m.header.stamp),
                                           latched),
            probe.node.create_subscription(MultiDOFJointState, 'joint_wrenches',
                                           keep('joint_wrenches', lambda m: m.header.stamp),
                                           latched),
            probe.node.create_subscription(TFMessage, '/tf', keep(
                'tf', lambda m: m.transforms[0].header.stamp), 1000)]
    command = probe.node.create_publisher(JointState, 'joint_command', 10)
    try:
        probe.wait(lambda: all(s.get_publisher_count() >= 1 for s in subs)
                   and command.get_subscription_count() >= 1
                   and probe.clients['pause'].service_is_ready(), 120, 'the node on the graph')
        ns = node.namespace.rstrip('/')
        topics = dict(probe.node.get_topic_names_and_types())
        # While paused: a command naming no joint of the world, checked and rejected on receipt.
        command.publish(JointState(name=['door'], position=[0.1]))
        rejected = probe.diagnostic_values(
            lambda v: v.get('commands_rejected_unknown_joint') == '1', 30)
        probe.pause(False)
        probe.wait(lambda: DURATION_NS in got['joint_states'] and DURATION_NS in got['tf'],
                   120, 'the last sample')
        status = node.wait(60)
    finally:
        probe.close()
        node.stop()
    return {'got': got, 'topics': topics, 'ns': ns, 'rejected': rejected, 'status': status,
            'bag': bag, 'stderr': node.stderr}


def test_the_world_joints_topics_are_on_the_graph(run):
    assert run['status'] == 0, run['stderr']
    ns, topics = run['ns'], run['topics']
    assert topics[f'{ns}/joint_states'] == ['sensor_msgs/msg/JointState']
    assert topics[f'{ns}/joint_wrenches'] == ['sensor_msgs/msg/MultiDOFJointState']
    assert topics[f'{ns}/joint_command'] == ['sensor_msgs/msg/JointState']
    assert f'{ns}/bob/pose' in topics and f'{ns}/target/pose' in topics


def _series(run):
    """Return ``(t s, q rad, q̇ rad/s)`` of every joint_states sample received, in time order."""
    samples = run['got']['joint_states']
    times = sorted(samples)
    assert times == list(range(0, DURATION_NS + 1, PERIOD_NS))  # none lost, sim-time stamps
    for t in times:
        msg = samples[t]
        assert list(msg.name) == ['hinge'] and msg.header.frame_id == ''
        assert list(msg.effort) == [0.0]  # no motor: the command named no joint
    return (np.array(times) * 1e-9, np.array([samples[t].position[0] for t in times]),
            np.array([samples[t].velocity[0] for t in times]))


def _hermite(t0, t1, q0, q1, v0, v1, target):
    """Return ``(t, q̇)`` where the cubic Hermite of two samples crosses ``target`` (bisection)."""
    dt = t1 - t0

    def at(s):
        h00, h10, h01, h11 = (2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2,
                              s**3 - s**2)
        d00, d10, d01, d11 = (6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s,
                              3 * s**2 - 2 * s)
        return (h00 * q0 + h10 * dt * v0 + h01 * q1 + h11 * dt * v1,
                (d00 * q0 + d10 * dt * v0 + d01 * q1 + d11 * dt * v1) / dt)
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if (at(mid)[0] - target) * (q0 - target) > 0.0:
            lo = mid
        else:
            hi = mid
    return t0 + lo * dt, at(lo)[1]


def test_the_pendulum_reaches_the_bottom_at_the_closed_form_quarter_period(run):
    t, q, qd = _series(run)
    assert abs(q[0]) < 1e-15 and abs(qd[0]) == 0.0  # released from rest; 0 at the initial pose
    # The bottom is q = -theta0 (rotation about +y carries the ball from -x down).
    i = next(k for k in range(len(q) - 1) if q[k] > -THETA0 >= q[k + 1])
    t_bottom, rate = _hermite(t[i], t[i + 1], q[i], q[i + 1], qd[i], qd[i + 1], -THETA0)
    # T/4 = sqrt(L_eq / g) K(sin²(theta0 / 2)), L_eq = I_pivot / (m L) (compound pendulum).
    quarter = pendulum_period(I_PIVOT / (M * L), THETA0, G) / 4.0
    # |q̇| at the bottom from the energy: ½ I q̇² = m g L (1 - cos theta0).
    speed = math.sqrt(2.0 * M * G * L * (1.0 - math.cos(THETA0)) / I_PIVOT)
    # Bounds: midpoint_cayley is second order, its phase error after a quarter period at
    # ω h = 3.5e-3 is ~(ω h)² T/4 / 24 ~ 2.4e-7 s and its energy error relative ~(ω h)²/8
    # ~ 1.5e-6; the cubic Hermite of 10 ms samples is off by ~q'''' Δt⁴ / 384 ~ 3e-9 rad.
    # Measured: -4.3e-7 s and 3.7e-6 rad/s; 1e-5 s and 1e-5 rad/s bound both with margin.
    print(f'T/4: node {t_bottom!r} s, closed form {quarter!r} s, error '
          f'{t_bottom - quarter:.3g} s; |q\u0307| {-rate!r} vs {speed!r} rad/s, error '
          f'{-rate - speed:.3g} rad/s')
    assert abs(t_bottom - quarter) < 1e-5, (t_bottom, quarter)
    assert abs(-rate - speed) < 1e-5, (rate, speed)


def _transforms(run):
    """Return ``{t: {child frame: (p, q (w, x, y, z))}}`` of every /tf message received."""
    out = {}
    for t, msg in run['got']['tf'].items():
        frames = {}
        for tr in msg.transforms:
            assert tr.header.frame_id == 'world' and time_from_msg(tr.header.stamp) == t
            p, r = tr.transform.translation, tr.transform.rotation
            frames[tr.child_frame_id] = (np.array([p.x, p.y, p.z]),
                                         np.array([r.w, r.x, r.y, r.z]))
        out[t] = frames
    return out


def _rotate(q, v):
    w, x, y, z = q
    u = np.array([x, y, z])
    return v + 2.0 * w * np.cross(u, v) + 2.0 * np.cross(u, np.cross(u, v))


def test_the_balls_tf_keeps_its_hinge_point_and_the_box_is_knocked_over(run):
    frames = _transforms(run)
    # /tf is volatile (as tf's is): the paused node's t = 0 sample may come before the probe's
    # subscription matched; every sample after the unpause must be there.
    assert set(range(PERIOD_NS, DURATION_NS + 1, PERIOD_NS)) <= set(frames), sorted(frames)
    assert set(frames) <= set(range(0, DURATION_NS + 1, PERIOD_NS)), sorted(frames)
    # The hinge point in the ball's frame: the pivot seen from its initial pose (identity).
    anchor_b = PIVOT - BOB0
    worst = max(float(np.linalg.norm(p + _rotate(q, anchor_b) - PIVOT))
                for p, q in (f['bob'] for f in frames.values()))
    print(f'hinge point off its pivot on /tf: at most {worst:.3g} m')
    # The joints hold to PROJECTION_TOL 1e-13 per row; /tf carries the state's exact floats
    # (measured 1.2e-13 m, through the knock).
    assert worst <= 1e-9
    # The ball hits the box ~20 degrees past the bottom: the box ends turned about y.
    p_end, q_end = frames[DURATION_NS]['target']
    tilt = 2.0 * math.asin(min(1.0, float(np.linalg.norm(q_end[1:]))))
    assert p_end[0] > 0.475 + 0.05 and tilt > 0.5, (p_end, tilt)


def test_joint_wrenches_are_the_hinge_force_of_the_closed_form_before_the_knock(run):
    wrenches, states = run['got']['joint_wrenches'], run['got']['joint_states']
    assert sorted(wrenches) == list(range(0, DURATION_NS + 1, PERIOD_NS))
    for msg in wrenches.values():
        assert list(msg.joint_names) == ['hinge'] and len(msg.wrench) == 1
    w = wrenches[0].wrench[0]
    assert all(math.isnan(v) for v in (w.force.x, w.force.y, w.force.z, w.torque.x,
                                       w.torque.y, w.torque.z))  # before the first step
    # In the ball's frame, which turns with the rod: the pivot is along o = PIVOT - BOB0.
    # The hinge pulls the ball towards the pivot by m g cos θ + m L θ̇² and across the rod by
    # m g sin θ (1 - m L² / I_pivot) (the ball's own spin takes the rest of the weight's
    # moment), θ = theta0 + q from the vertical; no torque about the hinge point.
    u = (PIVOT - BOB0) / np.linalg.norm(PIVOT - BOB0)
    worst = [0.0, 0.0, 0.0]
    for t in range(PERIOD_NS, 450_000_000, PERIOD_NS):  # the ball meets the box after 0.5 s
        w = wrenches[t].wrench[0]
        force = np.array([w.force.x, w.force.y, w.force.z])
        torque = np.array([w.torque.x, w.torque.y, w.torque.z])
        theta, rate = THETA0 + states[t].position[0], states[t].velocity[0]
        radial = M * G * math.cos(theta) + M * L * rate * rate
        across = M * G * math.sin(theta) * (1.0 - M * L * L / I_PIVOT)
        worst = [max(worst[0], abs(force @ u - radial)),
                 max(worst[1], abs(np.linalg.norm(force - (force @ u) * u) - across)),
                 max(worst[2], float(np.linalg.norm(torque)))]
    print(f'joint_wrenches against the closed form: radial {worst[0]:.3g} N, across '
          f'{worst[1]:.3g} N, torque {worst[2]:.3g} N m')
    # The message is the step's average: the radial force (7-15 N) lags its value at the
    # sample by h/2 dF/dt <= 0.5 ms x 20 N/s = 0.01 N (measured 0.014 N at most: the O((ω h)²)
    # of the integrator besides); across the rod and the torque the average is taken in the
    # ball's mid-step frame, off by O((ω h)²) (measured 8e-5 N and 4e-6 N m).
    assert worst[0] < 0.03 and worst[1] < 1e-3 and worst[2] < 1e-4, worst


def test_a_joint_command_naming_no_joint_is_rejected_and_counted(run):
    values = run['rejected']
    assert values['commands_received'] == '1' and values['commands_rejected'] == '1'


def test_a_position_command_holds_the_ball_against_gravity_and_replays(tmp_path):
    # The hinge commanded to 0 (the release pose, 45 deg) before the first step: the critically
    # damped response from e0 = 0 keeps it there, and its motor carries gravity's torque about
    # the hinge, m g L sin(theta0) = 5.549 N m, every sample. Bounds: the coordinate lands on
    # the response to the projection's 1e-13 per step; a static hold's effort is gravity's to
    # round-off (in process: 0 and 8.9e-16 N m); 1e-9 leaves margin for neither.
    from ros_probe import Probe
    from sensor_msgs.msg import JointState
    bag = tmp_path / 'held'
    node = NodeProcess(tmp_path, {'start_paused': True, 'duration_s': 0.5,
                                  'real_time_factor': 0.0, 'record_path': str(bag)},
                       params_file=PENDULUM, namespace=True)
    probe = Probe(node.namespace, inputs=(), outputs=('diagnostics',))
    got = {}
    sub = probe.node.create_subscription(
        JointState, 'joint_states',
        lambda m: got.__setitem__(time_from_msg(m.header.stamp), m), 1000)
    command = probe.node.create_publisher(JointState, 'joint_command', 10)
    try:
        probe.wait(lambda: sub.get_publisher_count() >= 1
                   and command.get_subscription_count() >= 1
                   and probe.clients['pause'].service_is_ready(), 120, 'the node on the graph')
        command.publish(JointState(name=['hinge'], position=[0.0]))
        probe.diagnostic_values(lambda v: v.get('commands_received') == '1', 30)
        probe.pause(False)
        probe.wait(lambda: 500_000_000 in got, 120, 'the last sample')
        assert node.wait(60) == 0, node.stderr
    finally:
        probe.close()
        node.stop()
    hold = M * G * L * math.sin(THETA0)
    for t in range(PERIOD_NS, 500_000_001, PERIOD_NS):
        (q,), (effort,) = got[t].position, got[t].effort
        assert abs(q) <= 1e-12 and effort == pytest.approx(hold, rel=1e-9), (t, q, effort)
    result = replay_bag(bag)
    assert result.match, (result.problems, {k: r.first_mismatch
                                            for k, r in result.topics.items()})


def test_the_recording_replays_bit_for_bit(run):
    bag = open_bag(run['bag'])
    assert {'/' + run['ns'].strip('/') + '/joint_states'} <= set(bag.topics), bag.topics
    result = replay_bag(run['bag'])
    assert result.match, result.problems


def test_a_bad_joint_parameter_stops_the_node_with_one_line(tmp_path):
    node = NodeProcess(tmp_path, {'joints.hinge.axis': [0.0, 0.0, 0.0]},
                       params_file=PENDULUM)
    started = time.monotonic()
    try:
        assert node.wait(60) == 2, node.stderr
    finally:
        node.stop()
    lines = [line for line in node.stderr.splitlines() if line.strip()]
    assert lines == ['rigid_body_node: parameter joints.hinge.axis = [0.0, 0.0, 0.0]: has zero '
                     'length: a joint axis needs a direction'], lines
    assert time.monotonic() - started < 60
    wait_until(lambda: node.process.poll() is not None, 1)


#: ``msg_config/door_world.yaml``'s door (repeated from its comments): a 20 kg box 0.04 x 0.8 x
#: 2.0 m hung by its edge on a hinge about z, its COM r = 0.4 m off the axis, upper limit 0.35
#: rad from its start.
DOOR = REPO / 'msg_config' / 'door_world.yaml'
DOOR_M, DOOR_R, DOOR_UPPER = 20.0, 0.4, 0.35  # kg, m, rad
DOOR_I = DOOR_M * (0.04 ** 2 + 0.8 ** 2) / 12.0 + DOOR_M * DOOR_R ** 2  # kg m², about the hinge


def _samples(bag, topic):
    """Return ``{t ns: message}`` of a topic of the node's recording."""
    return {time_from_msg(msg.header.stamp): msg for _, msg in bag.decoded_messages([topic])}


def test_a_door_swung_onto_its_limit_stops_dead_and_holds_a_push(tmp_path):
    # The door of door_world.yaml launched open at w0 = 1.5 rad/s about its hinge (its COM at
    # v = w0 x r = (-0.6, 0, 0) m/s, so nothing is lost to the start's projection) swings onto
    # its upper limit at 0.35 / 1.5 = 0.233 s: the stop is inelastic, so it stays there with no
    # rebound. From 0.4 s of sim time a +10 N m torque pushes it further open, against the
    # stop, which holds it. Everything is read back from the node's own recording.
    from ros_probe import Probe
    from sensor_msgs.msg import JointState
    bag_path = tmp_path / 'door'
    w0 = 1.5
    node = NodeProcess(tmp_path, {
        'start_paused': True, 'duration_s': 1.0, 'real_time_factor': 1.0,
        'record_path': str(bag_path), 'bodies.door.initial_angular_velocity': [0.0, 0.0, w0],
        'bodies.door.initial_linear_velocity': [-w0 * DOOR_R, 0.0, 0.0]},
        params_file=DOOR, namespace=True)
    probe = Probe(node.namespace, inputs=('door/wrench',), outputs=('diagnostics',))
    newest = [-1]
    sub = probe.node.create_subscription(
        JointState, 'joint_states',
        lambda m: newest.__setitem__(0, max(newest[0], time_from_msg(m.header.stamp))), 1000)
    try:
        probe.wait(lambda: sub.get_publisher_count() >= 1
                   and probe.publishers['door/wrench'].get_subscription_count() >= 1
                   and probe.clients['pause'].service_is_ready(), 120, 'the node on the graph')
        probe.pause(False)
        probe.wait(lambda: newest[0] >= 400_000_000, 120, 'sim time 0.4 s')
        probe.publish('door/wrench', 'world', torque=(0.0, 0.0, 10.0))
        assert node.wait(120) == 0, node.stderr
    finally:
        probe.close()
        node.stop()
    bag = open_bag(str(bag_path))
    ns = '/' + node.namespace.strip('/')
    states = _samples(bag, f'{ns}/joint_states')
    wrenches = _samples(bag, f'{ns}/joint_wrenches')
    assert sorted(states) == sorted(wrenches) == list(range(0, 1_000_000_001, PERIOD_NS))
    g = G
    stop_ns = DOOR_UPPER / w0 * 1e9
    pushed, worst_free, worst_over, worst_rate = None, 0.0, -math.inf, 0.0
    for t, msg in sorted(states.items()):
        (q,), (rate,), (effort,) = msg.position, msg.velocity, msg.effort
        assert list(msg.name) == ['hinge'] and effort == 0.0  # no motor
        worst_over = max(worst_over, q - DOOR_UPPER)
        w = wrenches[t].wrench[0]
        force = [w.force.x, w.force.y, w.force.z]
        torque = [w.torque.x, w.torque.y, w.torque.z]
        if t == 0:
            assert q == 0.0 and rate == pytest.approx(w0, abs=1e-12)
            continue
        # The hinge carries the weight m g and its moment m g r about the door's own x (the
        # door frame turns with it: its width along y, the hinge at -r y); while it swings,
        # the centripetal force m w0² r towards the hinge (-y).
        if t < stop_ns:
            worst_free = max(worst_free, abs(q - w0 * t * 1e-9))
            assert rate == pytest.approx(w0, abs=1e-12), (t, rate)
            expected = [0.0, -DOOR_M * w0 * w0 * DOOR_R, DOOR_M * g, DOOR_M * g * DOOR_R, 0.0,
                        0.0]
        else:
            assert abs(q - DOOR_UPPER) <= 1e-12, (t, q)
            worst_rate = max(worst_rate, abs(rate))
            if pushed is None and abs(torque[2] + 10.0) < 1e-9:
                pushed = t
            # at rest on the stop, and from the push on the stop's -10 N m about z besides
            expected = [0.0, 0.0, DOOR_M * g, DOOR_M * g * DOOR_R, 0.0,
                        0.0 if pushed is None else -10.0]
        # Bounds: the weight and its moment to round-off (1e-9 N, N m: relative 5e-12); the
        # centripetal 18 N is the step's average through the integrator, O((w0 h)²) = 2e-6
        # of it (measured 2.5e-6 N); 1e-4 N leaves margin.
        np.testing.assert_allclose(force + torque, expected, rtol=0.0, atol=1e-4,
                                   err_msg=f't = {t} ns')
        np.testing.assert_allclose([force[2], torque[0]], expected[2:4], rtol=0.0, atol=1e-9,
                                   err_msg=f't = {t} ns')
    print(f'door: free swing off w0 t by {worst_free:.3g} rad, beyond the limit by at most '
          f'{worst_over:.3g} rad, |rate| on the stop at most {worst_rate:.3g} rad/s, pushed '
          f'from {pushed} ns')
    # Bounds: the swing is the closed form to O((w0 h)²) of the angle (2e-6 of 0.35 rad; 8e-8
    # rad measured in process); the stop lands the joint on its bound to the pre-stabilization's
    # PROJECTION_TOL (1e-13; measured 5.6e-17), and holds it at rest: a rate left on the stop
    # is let go above LEAVE_RATE = 1e-12 rad/s (measured 2.6e-16 rad/s); no rebound.
    assert worst_free < 1e-6 and worst_over <= 1e-12 and worst_rate <= 1e-12
    assert pushed is not None and 400_000_000 < pushed < 1_000_000_000, pushed
    result = replay_bag(bag_path)
    assert result.match, (result.problems, {k: r.first_mismatch
                                            for k, r in result.topics.items()})


def test_a_wheel_on_a_continuous_axle_counts_its_turns_in_the_recording(tmp_path):
    # A wheel (a cylinder, no gravity) on a continuous axle to the world, spun at 20 rad/s
    # about it (a principal axis: the rate stays), recorded for 1 s: joint_states reads the
    # angle not wrapped, 3.2 turns at the end. midpoint_cayley turns it by the Cayley map's
    # 2 atan(ω h / 2) a step, so after n steps q = n 2 atan(ω h / 2) (to round-off: 1e-12 rad
    # bounds the sum's ~1e-14, tests/sim/test_world_joints.py); wrapped, it would read
    # 20 - 6 π = 1.15 rad at the end. The recording replays MATCH.
    omega, h_ns = 20.0, 1_000_000
    bag_path = tmp_path / 'wheel'
    node = NodeProcess(tmp_path, {
        'gravity': [0.0, 0.0, 0.0], 'integrator': 'midpoint_cayley', 'body_names': ['wheel'],
        'bodies.wheel.shape': 'cylinder', 'bodies.wheel.dimensions_m': [0.3, 0.05],
        'bodies.wheel.initial_position': [0.0, 0.0, 1.0],
        'bodies.wheel.initial_angular_velocity': [0.0, 0.0, omega],
        'joint_names': ['axle'], 'joints.axle.type': 'continuous',
        'joints.axle.child': 'wheel', 'joints.axle.position': [0.0, 0.0, 1.0],
        'timestep_s': h_ns * 1e-9, 'publish_rate_hz': 100.0, 'duration_s': 1.0,
        'real_time_factor': 0.0, 'record_path': str(bag_path)}, namespace=True)
    try:
        assert node.wait(120) == 0, node.stderr
    finally:
        node.stop()
    states = _samples(open_bag(str(bag_path)), '/' + node.namespace.strip('/') + '/joint_states')
    assert sorted(states) == list(range(0, 1_000_000_001, PERIOD_NS))
    per_step = 2.0 * math.atan(0.5 * omega * h_ns * 1e-9)
    worst = max(abs(msg.position[0] - t // h_ns * per_step) for t, msg in states.items())
    print(f'wheel: {states[1_000_000_000].position[0]!r} rad at 1 s, off the closed form by '
          f'at most {worst:.3g} rad')
    assert worst <= 1e-12 and states[1_000_000_000].position[0] > 6.0 * math.pi
    result = replay_bag(bag_path)
    assert result.match, result.problems
