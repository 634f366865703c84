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
The per-sample robot readouts (issue 28 speed): plain-float joint coordinates and wrenches.

:meth:`ArticulatedSimulator.joint_coordinates` (what ``joint_states`` publishes) against the
joint definitions computed here independently, with rotation matrices from the body states,
for every joint kind a robot has, at rest pose offsets, tilted axes and a continuous joint
turned past π; :meth:`ArticulatedSimulator.constraint_wrenches_w` against
:meth:`ArticulatedSimulator.joint_wrenches`.
"""

import math

import numpy as np
import pytest

from rbd_ros.core.joints import ArticulatedSimulator
from rbd_ros.sim.robot_placement import place_robot
from rbd_ros.sim.urdf import load_urdf

#: Round-off of a few operations on values of order 1 to 10.
TOL = 1e-12


def _inertial():
    return ('<inertial><origin xyz="0 0 -0.1" rpy="0.1 0.2 0.3"/><mass value="1.0"/>'
            '<inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial>')


#: World → revolute → prismatic → fixed (two bodies: a core fixed joint) → continuous → fixed
#: to a massless tool frame (folded), with turned joint origins and tilted axes.
URDF = f"""<?xml version="1.0"?>
<robot name="kinds">
  <link name="world"/>
  <joint name="rev" type="revolute"><parent link="world"/><child link="a"/>
    <origin xyz="0.1 -0.2 2.0" rpy="0.3 -0.2 0.5"/><axis xyz="0 1 1"/>
    <limit lower="-3" upper="3" effort="100" velocity="10"/></joint>
  <link name="a">{_inertial()}</link>
  <joint name="pri" type="prismatic"><parent link="a"/><child link="b"/>
    <origin xyz="0 0.1 -0.3" rpy="-0.4 0.1 0.2"/><axis xyz="1 0 1"/>
    <limit lower="-1" upper="1" effort="100" velocity="10"/></joint>
  <link name="b">{_inertial()}</link>
  <joint name="fix" type="fixed"><parent link="b"/><child link="c"/>
    <origin xyz="0.2 0 -0.1" rpy="0.5 0.4 -0.3"/></joint>
  <link name="c">{_inertial()}</link>
  <joint name="con" type="continuous"><parent link="c"/><child link="d"/>
    <origin xyz="0 0 -0.3" rpy="0.2 0.3 0.1"/><axis xyz="0.2 -0.3 1"/></joint>
  <link name="d">{_inertial()}</link>
  <joint name="tool" type="fixed"><parent link="d"/><child link="tool0"/>
    <origin xyz="0 0 -0.2"/></joint>
  <link name="tool0"/>
</robot>
"""


def _matrix(q):
    """Return the rotation matrix of a unit quaternion ``(w, x, y, z)`` (the test's own)."""
    w, x, y, z = q
    return np.array([[w * w + x * x - y * y - z * z, 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), w * w - x * x + y * y - z * z, 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), w * w - x * x - y * y + z * z]])


def _frame(states, body):
    """Return a body's ``(p, R, v, ω_w)``, the world's for None."""
    if body is None:
        return np.zeros(3), np.eye(3), np.zeros(3), np.zeros(3)
    s = states[body]
    rot = _matrix(s.orientation_wb)
    return s.position_w, rot, s.linear_velocity_w, rot @ s.angular_velocity_b


def expected(joint, states):
    """
    Return a one-coordinate joint's ``(position, rate)`` by its definition, from the states.

    Revolute and continuous: the angle of ``R_pc R_restᵀ`` about the axis (from its
    antisymmetric part and trace), in (-π, π]; the rate is the relative angular velocity on
    the axis. Prismatic: the anchors' offset in the parent frame on the axis, and its time
    derivative ``R_wpᵀ (Ȧ_c − Ȧ_p − ω_p × (A_c − A_p))``.
    """
    pp, rp, vp, wp = _frame(states, joint.parent)
    pc, rc, vc, wc = _frame(states, joint.child)
    axis = np.asarray(joint.axis_b)
    if joint.kind in ('revolute', 'continuous'):
        rel = rp.T @ rc @ _matrix(joint.q_rest).T
        vee = 0.5 * np.array([rel[2, 1] - rel[1, 2], rel[0, 2] - rel[2, 0],
                              rel[1, 0] - rel[0, 1]])
        angle = math.atan2(vee @ axis, 0.5 * (np.trace(rel) - 1.0))
        return angle, (rp.T @ (wc - wp)) @ axis
    assert joint.kind == 'prismatic'
    a_c = pc + rc @ joint.origin_child_b
    a_p = pp + rp @ joint.origin_parent_b
    a_c_dot = vc + np.cross(wc, a_c - pc)
    a_p_dot = vp + np.cross(wp, a_p - pp)
    return ((rp.T @ (a_c - a_p)) @ axis,
            (rp.T @ (a_c_dot - a_p_dot - np.cross(wp, a_c - a_p))) @ axis)


@pytest.fixture(scope='module')
def sim():
    robot = load_urdf(xml=URDF)
    placed = place_robot(robot, joint_positions=[0.4, 0.1, 2.8],
                         joint_velocities=[1.0, -0.3, 6.0])
    kinds = sorted(joint.kind for joint in placed.joints)
    assert kinds == ['continuous', 'fixed', 'prismatic', 'revolute']
    return ArticulatedSimulator(placed.models, placed.states, placed.joints,
                                timestep_ns=1_000_000)


def test_joint_coordinates_follow_the_joint_definitions(sim):
    moving = [j for j, joint in enumerate(sim.joints) if joint.kind != 'fixed']
    continuous = next(j for j in moving if sim.joints[j].kind == 'continuous')
    turns = 0.0
    for _ in range(40):
        positions, rates = sim.joint_coordinates(moving)
        rows = sim.state_rows()
        # the rows given or taken: the same bits
        assert sim.joint_coordinates(moving, rows) == (positions, rates)
        states = sim.states
        for j, q, qd in zip(moving, positions, rates):
            assert isinstance(q, float) and isinstance(qd, float)
            q_ref, qd_ref = expected(sim.joints[j], states)
            if j == continuous:  # the running angle: the definition's mod 2π
                turns = max(turns, abs(q))
                q = math.remainder(q, 2 * math.pi)
            assert abs(q - q_ref) <= TOL, (sim.joints[j].name, q, q_ref)
            assert abs(qd - qd_ref) <= TOL * max(1.0, abs(qd_ref)), (sim.joints[j].name, qd)
        # the numpy readout of the core, the same to round-off
        for j, q in zip(moving, positions):
            assert abs(q - float(sim.joint_positions()[j][0])) <= TOL
        sim.step(25)
    assert turns > math.pi + 1.0  # the continuous joint went round past π


def test_a_fixed_joint_has_no_coordinate(sim):
    fixed = next(j for j, joint in enumerate(sim.joints) if joint.kind == 'fixed')
    assert sim.joint_positions()[fixed].size == 0
    with pytest.raises(ValueError, match='fixed joint has no single coordinate'):
        sim.joint_coordinates([fixed])


def test_constraint_wrenches_are_what_joint_wrenches_turn_into_joint_frames(sim):
    sim.step(3)
    raw = np.array(sim.constraint_wrenches_w())
    assert raw.shape == (len(sim.joints), 6)
    wrenches = sim.joint_wrenches()
    for j, joint in enumerate(sim.joints):
        rot = _matrix(sim.states[joint.child].orientation_wb)
        force, torque_com = raw[j, :3], raw[j, 3:]
        torque = torque_com - np.cross(rot @ joint.origin_child_b, force)
        # joint_wrenches' frame: the child's joint axes; lengths and the axis component agree
        assert abs(np.linalg.norm(wrenches[j, :3]) - np.linalg.norm(force)) <= 1e-9
        assert abs(np.linalg.norm(wrenches[j, 3:]) - np.linalg.norm(torque)) <= 1e-9
        axis_w = rot @ _matrix(joint.q_rest).T @ np.asarray(joint.axis_b)
        assert abs(wrenches[j, 2] - force @ axis_w) <= 1e-9
        assert abs(wrenches[j, 5] - torque @ axis_w) <= 1e-9
    assert np.abs(raw).max() > 1.0  # gravity and the spin load the joints
