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
Physics through real DDS: one paused ``rigid_body_node`` process, driven with ``~/step``.

The node runs the default integrator, ``midpoint_cayley``: a kick-drift-kick (Strang) splitting
whose translation is Störmer–Verlet, which integrates a constant force exactly (the position
is a quadratic in t, which the scheme reproduces exactly), so the only error against
``x = F T² / 2m`` is floating-point round-off: each step adds at most a few ulps of |x|, i.e.
below ``N · 4ε · |x| ≈ 2e-13 m`` for the N <= 200 steps and |x| < 1 m here. Tolerances of
1e-9 m (or 1e-9 relative) leave a wide margin for that and would still fail for any first-order
error (``h F T / 2m`` = 7.5e-3 m for the force below) or a one-step timing slip.
"""

import math

from conftest import NodeProcess
import numpy as np
import pytest
from rbd_ros.core import rotations
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.session import SimSession
from ros_probe import Probe, step_until_moving
from std_srvs.srv import SetBool

H_NS = 10_000_000
MASS_KG = 2.0
S45 = math.sqrt(0.5)
PARAMS = {
    'mass_kg': MASS_KG, 'shape': 'box', 'dimensions_m': [0.2, 0.1, 0.05],
    'initial_orientation': [0.0, 0.0, S45, S45],  # 90° about world z: body x = world y
    'timestep_s': 0.01, 'publish_rate_hz': 100.0, 'start_paused': True,
    'real_time_factor': 0.0, 'twist_frame': 'world',
    'wrench_input_names': ['thruster'], 'wrench_inputs.thruster.topic': 'thruster',
    'wrench_inputs.thruster.frame': 'body', 'wrench_inputs.thruster.point_b': [0.0, 0.1, 0.0],
}
I_ZZ = MASS_KG * (0.2 ** 2 + 0.1 ** 2) / 12.0  # box about its z axis, kg·m²
TOL_M = 1e-9  # see the module docstring


class Rig:
    """The node process and the probe of this module."""

    def __init__(self, tmp):
        self.node = NodeProcess(tmp, PARAMS, namespace=True)
        self.probe = Probe(self.node.namespace, inputs=('wrench', 'thruster'))
        self.probe.wait_connected()


@pytest.fixture(scope='module')
def rig(module_tmp):
    rig = Rig(module_tmp)
    yield rig
    rig.probe.close()
    assert rig.node.stop() == 0, rig.node.stderr


def xyz(v):
    return np.array([v.x, v.y, v.z])


def quat_wxyz(q):
    return np.array([q.w, q.x, q.y, q.z])


def test_constant_world_force_gives_f_t2_over_2m(rig):
    probe = rig.probe
    probe.reset()
    force_n = 3.0
    probe.publish('wrench', 'world', (0.0, 0.0, force_n))
    t0, _ = step_until_moving(probe)
    t_end = probe.step(100)
    checked = 0
    for stamp, pose in probe.samples['pose'].items():
        if stamp < t0:
            continue
        t_s = (stamp - t0) * 1e-9
        expected = force_n * t_s ** 2 / (2.0 * MASS_KG)
        assert abs(pose.pose.position.z - expected) <= TOL_M, (stamp, pose.pose.position.z)
        assert pose.pose.position.x == 0.0 and pose.pose.position.y == 0.0
        checked += 1
    assert checked >= 2 and t_end - t0 >= 100 * H_NS
    twist = probe.samples['twist'][t_end].twist
    assert twist.linear.z == pytest.approx(force_n * (t_end - t0) * 1e-9 / MASS_KG, abs=1e-9)
    # A force at the COM does not turn the body: the orientation is the initial one exactly.
    final = probe.samples['pose'][t_end].pose.orientation
    assert np.array_equal(quat_wxyz(final), [S45, 0.0, 0.0, S45])


def test_body_force_on_rotated_body_moves_along_rotated_axis(rig):
    probe = rig.probe
    probe.reset()
    force_n = 1.5
    probe.publish('wrench', 'base_link', (force_n, 0.0, 0.0))  # body x, = world +y
    t0, _ = step_until_moving(probe)
    t_end = probe.step(50)
    position = xyz(probe.samples['pose'][t_end].pose.position)
    expected = force_n * ((t_end - t0) * 1e-9) ** 2 / (2.0 * MASS_KG)
    assert position[1] == pytest.approx(expected, abs=TOL_M)
    # x: the rotation matrix of the normalised (√½, 0, 0, √½) has cos²−sin² ≈ ε, not 0.
    assert abs(position[0]) <= 4 * np.finfo(float).eps * abs(position[1])
    assert position[2] == 0.0


def test_force_at_offset_point_spins_with_right_sign_and_matches_offline_session(rig):
    probe = rig.probe
    probe.reset()
    # Force +x (body) at point_b = (0, 0.1, 0): torque r × f = (0, 0, -0.1) N·m, a clockwise
    # spin about body z seen from +z. frame_id '' is read in the input's .frame (body).
    probe.publish('thruster', '', (1.0, 0.0, 0.0))
    t0, _ = step_until_moving(probe)
    t_end = probe.step(40)
    odom = probe.samples['odom'][t_end]
    omega_z = odom.twist.twist.angular.z
    assert omega_z < 0.0
    # Π_z grows by τ_z h each kick and the rotation is about a principal axis, so
    # ω_z = τ_z T / I_zz up to round-off (relative 1e-9, see the module docstring).
    assert omega_z == pytest.approx(-0.1 * (t_end - t0) * 1e-9 / I_ZZ, rel=1e-9)
    # The same wrench at the same step in a ROS-free SimSession gives bit-identical states.
    session = SimSession(NodeConfig.from_parameters(PARAMS))
    session.paused = False
    while session.time_ns < t0:
        session.advance(1000, until_ns=t0)
    session.submit('thruster', '', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    while session.time_ns < t_end:
        session.advance(1000, until_ns=t_end)
    state = session.state
    pose = probe.samples['pose'][t_end].pose
    assert np.array_equal(xyz(pose.position), state.position_w)
    assert np.array_equal(quat_wxyz(pose.orientation), state.orientation_wb)
    assert np.array_equal(xyz(odom.twist.twist.angular), state.angular_velocity_b)


def test_odometry_twist_is_in_the_body_frame(rig):
    probe = rig.probe
    probe.reset()
    probe.publish('wrench', 'world', (2.0, 0.0, 0.0))  # world +x = body -y (body rotated 90°)
    probe.publish('thruster', 'base_link', (0.0, 0.0, 0.0), (0.0, 0.0, 0.05))  # and a spin
    t0, _ = step_until_moving(probe)
    t_end = probe.step(20)
    odom = probe.samples['odom'][t_end]
    twist = probe.samples['twist'][t_end]
    pose = probe.samples['pose'][t_end]
    assert odom.header.frame_id == 'world' and odom.child_frame_id == 'base_link'
    assert twist.header.frame_id == 'world'
    rot_wb = rotations.quat_to_matrix(quat_wxyz(pose.pose.orientation))
    v_w, w_w = xyz(twist.twist.linear), xyz(twist.twist.angular)
    v_b, w_b = xyz(odom.twist.twist.linear), xyz(odom.twist.twist.angular)
    # Same velocities, related by R (round-off of one rotation: 1e-12 m/s is ~1e4 ε·|v|).
    np.testing.assert_allclose(v_b, rot_wb.T @ v_w, rtol=0, atol=1e-12)
    np.testing.assert_allclose(w_b, rot_wb.T @ w_w, rtol=0, atol=1e-12)
    # And visibly different: the world +x velocity is along body -y (the body has turned by
    # less than a degree from its initial 90°).
    assert v_w[0] > 0 and v_b[1] < 0 and abs(v_b[1]) > 0.9 * abs(v_w[0])
    # Odometry pose is the world pose.
    assert np.array_equal(xyz(odom.pose.pose.position), xyz(pose.pose.position))


def test_pause_step_and_reset(rig):
    probe = rig.probe
    probe.reset()
    first = probe.step()
    assert first == H_NS  # one step of exactly h from t = 0
    probe.pause(False)
    response = probe.call('step')
    assert not response.success  # ~/step is refused while running
    probe.wait(lambda: max(probe.samples['pose']) >= 50 * H_NS, what='the node to run')
    paused = probe.call('pause', SetBool.Request(data=True))
    assert paused.success
    t_paused = int(paused.message.split()[4])  # "paused at t = N ns"
    # Paused: the next ~/step is exactly one step after the time the pause reported.
    assert probe.step() == t_paused + H_NS
    # Reset: back to the initial state at t = 0 (a pose sample at 0 with the initial pose).
    probe.publish('wrench', 'world', (1.0, 0.0, 0.0))
    step_until_moving(probe)
    probe.reset()
    pose = probe.samples['pose'][0].pose
    assert np.array_equal(xyz(pose.position), [0.0, 0.0, 0.0])
    assert np.array_equal(quat_wxyz(pose.orientation), [S45, 0.0, 0.0, S45])
    # and the held wrench is gone: stepping does not move the body.
    t = probe.step(3)
    assert np.array_equal(xyz(probe.samples['twist'][t].twist.linear), [0.0, 0.0, 0.0])
