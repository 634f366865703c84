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

"""Robots from URDF (issue 28 items 1 and 6): real files in, core bodies and joints out."""

import math
from pathlib import Path

import numpy as np
import pytest

from rbd_ros.core import ConfigError, ModelError
from rbd_ros.core.joints import ArticulatedSimulator
from rbd_ros.core.rotations import quat_from_axis_angle, quat_to_matrix
from rbd_ros.sim.meshes import resolve_mesh_path
from rbd_ros.sim.robot_placement import place_robot
from rbd_ros.sim.urdf import load_urdf
from tests.core.joints.closed_forms import (chain_joint_forces, compound_pendulum_l_eq,
                                            pendulum_period)
from tests.core.joints.test_articulated import run_angle, zero_crossings

URDF_DIR = Path(__file__).resolve().parents[2] / 'msg_config' / 'urdf'
PENDULUM, ARM3, FREE_BODY = [str(URDF_DIR / f'{name}.urdf')
                             for name in ('pendulum', 'arm3', 'free_body')]
L_BLOCK = 'package://rbd_ros/msg_config/meshes/l_block.stl'
# Every number below goes through a few float products and sums of O(1) values: 1e-12 is a
# thousand ulps of round-off, far below any convention error (which would be O(0.1)).
TOL = 1e-12
# The projection leaves every joint row within PROJECTION_TOL = 1e-13; the bound on the
# joint error is 1e-12 m and rad.
JOINT_TOL = 1e-12


def write(tmp_path, body, name='robot.urdf'):
    """Write ``<robot name="r">body</robot>`` to a file; return its path."""
    path = tmp_path / name
    path.write_text(f'<?xml version="1.0"?>\n<robot name="r">{body}</robot>\n')
    return str(path)


def inertial(mass='1.0', xyz='0 0 0', rpy='0 0 0', inertia='ixx="0.02" iyy="0.03" izz="0.04"'):
    return (f'<inertial><origin xyz="{xyz}" rpy="{rpy}"/><mass value="{mass}"/>'
            f'<inertia {inertia} ixy="0" ixz="0" iyz="0"/></inertial>')


def link(name, body=None):
    return f'<link name="{name}">{inertial() if body is None else body}</link>'


def joint(name, kind, parent, child, extra=''):
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="{child}"/>{extra}</joint>')


def test_pendulum_file_is_a_rod_fixed_to_the_world():
    robot = load_urdf(PENDULUM)
    assert robot.name == 'pendulum' and robot.source == PENDULUM and robot.fixed_to_world
    assert robot.urdf == Path(PENDULUM).read_text()  # what robot_description will publish
    assert robot.body_links == ('rod',) and robot.moving_joints == ('pivot',)
    world, rod = robot.links
    assert world.body is None and rod.body == 0
    assert rod.mass_kg == 1.0 and np.array_equal(rod.com_m, [0.0, 0.0, -0.75])
    assert np.array_equal(rod.inertia_b, np.diag([0.1875, 0.1875, 0.0002]))
    # the body frame is the COM with the link's axes: the link origin is 0.75 m up in it
    assert np.array_equal(rod.position_b, [0.0, 0.0, 0.75])
    (cylinder,) = rod.collisions
    assert cylinder.shape.shape == 'cylinder'
    assert np.array_equal(cylinder.shape.dimensions_m, [0.02, 1.5])
    assert np.allclose(cylinder.position_b, 0.0, atol=TOL)   # its origin is the COM
    pivot = robot.joint('pivot')
    assert (pivot.kind, pivot.lower, pivot.upper, pivot.effort, pivot.velocity) == \
        ('revolute', -3.1, 3.1, 10.0, 10.0)
    placed = place_robot(robot, joint_positions=[0.4])
    (core,) = placed.joints
    assert core.parent is None and core.child == 0 and core.effort_limit == 10.0
    assert np.array_equal(core.origin_parent_b, [0.0, 0.0, 2.0])
    assert np.array_equal(core.axis_b, [0.0, 1.0, 0.0])
    # COM at 0.75 m from the pivot, turned 0.4 rad about +y (which maps -z to (-sin, 0, -cos))
    (state,) = placed.states
    expected = np.array([0.0, 0.0, 2.0]) + 0.75 * np.array([-math.sin(0.4), 0.0,
                                                            -math.cos(0.4)])
    assert np.allclose(state.position_w, expected, atol=TOL, rtol=0)
    assert placed.models[0].gravity_w.tolist() == [0.0, 0.0, -9.81]


def test_urdf_pendulum_period_matches_the_closed_form():
    theta0 = math.radians(60.0)
    robot = load_urdf(PENDULUM)
    placed = place_robot(robot, joint_positions=[theta0])
    sim = ArticulatedSimulator(placed.models, placed.states, placed.joints,
                               timestep_ns=1_000_000)
    # the file's rod: 1.5 m, I_pivot = m L^2 / 3, so L_eq = 2 L / 3 = 1 m (closed_forms.py)
    expected = pendulum_period(compound_pendulum_l_eq(1.5), theta0)
    crossings = zero_crossings(*run_angle(sim, int(1.3 * expected / 1e-3) + 2))
    # the target at h = 1 ms is 5e-7; the core's own rod reaches 3e-12 there
    # (doc/joints.md), so the URDF path adds nothing above RK4's O(h^4)
    assert abs((crossings[2] - crossings[0]) / expected - 1.0) <= 5e-7
    assert max(sim.joint_error()) <= JOINT_TOL


def arm_positions(q):
    """Return each link's COM of arm3 (independent kinematics: a planar chain in x-z)."""
    origin, angle, out = np.array([0.0, 0.0, 2.0]), 0.0, []
    for value in q:
        angle += value
        down = np.array([-math.sin(angle), 0.0, -math.cos(angle)])
        out.append(origin + 0.25 * down)
        origin = origin + 0.5 * down
    return np.array(out), origin


def test_arm3_world_links_frames_and_forward_kinematics():
    robot = load_urdf(ARM3)
    assert robot.moving_joints == ('shoulder', 'elbow', 'wrist')
    assert robot.body_links == ('upper', 'fore', 'hand')
    assert robot.link('mount').body is None            # fixed to the world: no body
    assert np.array_equal(robot.link('mount').position_b, [0.0, 0.0, 2.0])
    tool = robot.link('tool0')                           # no inertial, fixed: a frame of hand
    assert tool.body == 2 and np.allclose(tool.position_b, [0.0, 0.0, -0.25], atol=TOL)
    shoulder = robot.joint('shoulder')
    assert (shoulder.damping, shoulder.friction, shoulder.velocity) == (0.1, 0.05, 3.0)
    assert robot.joint('mount_joint').core is None and robot.joint('tool_joint').core is None
    q, qd = np.array([0.3, -0.5, 0.9]), np.array([0.4, 1.1, -0.7])
    placed = place_robot(robot, joint_positions=q, joint_velocities=qd)
    positions, tip = arm_positions(q)
    for state, expected in zip(placed.states, positions):
        assert np.allclose(state.position_w, expected, atol=TOL, rtol=0)
    assert np.allclose(placed.link_poses_w['tool0'][0], tip, atol=TOL, rtol=0)
    # velocities against a central difference of the independent kinematics: its error is
    # O(dt^2 |d3x/dt3|) ~ 1e-12 plus round-off 1e-16 / dt ~ 1e-10 at dt = 1e-6 s
    dt = 1e-6
    numeric = (arm_positions(q + qd * dt)[0] - arm_positions(q - qd * dt)[0]) / (2 * dt)
    for state, expected in zip(placed.states, numeric):
        assert np.allclose(state.linear_velocity_w, expected, atol=1e-8, rtol=0)
    # the core reads back the same joint values from these poses and twists
    sim = ArticulatedSimulator(placed.models, placed.states, placed.joints)
    assert max(sim.joint_error()) <= JOINT_TOL
    assert np.allclose(np.concatenate(sim.joint_positions()), q, atol=TOL, rtol=0)
    assert np.allclose(np.concatenate(sim.joint_velocities()), qd, atol=TOL, rtol=0)


def test_hanging_urdf_chain_joint_wrenches_carry_k_m_g():
    placed = place_robot(load_urdf(ARM3))
    sim = ArticulatedSimulator(placed.models, placed.states, placed.joints)
    sim.step(500)
    expected = chain_joint_forces(3, 1.0)     # joint k from the bottom: k m g
    wrench = sim.joint_wrenches()
    for j, state in enumerate(sim.states):
        # the links hang straight down, so child joint frame and body axes are the world's up
        # to a rotation about z; the vertical force is the weight below (statics), to
        # round-off of the solve (the core's own chain gives 1e-12: doc/joints.md)
        force = np.linalg.norm(wrench[j, 0:3])
        assert abs(force / expected[j] - 1.0) <= 1e-12, (j, wrench[j], expected[j])
        assert np.linalg.norm(wrench[j, 3:6]) <= 1e-12 * expected[j]
        assert np.abs(state.linear_velocity_w).max() <= 1e-12   # at rest, to round-off


def test_free_body_floats_at_the_root_pose():
    robot = load_urdf(FREE_BODY)
    assert not robot.fixed_to_world and robot.moving_joints == () and robot.joints == ()
    q = quat_from_axis_angle(np.array([1.0, 2.0, 2.0]) / 3.0, 0.7)
    placed = place_robot(robot, position_w=(1.0, -2.0, 0.5), orientation_wb=q)
    (state,) = placed.states
    assert np.allclose(state.position_w, [1.0, -2.0, 0.5], atol=TOL, rtol=0)
    assert np.allclose(state.orientation_wb * np.sign(state.orientation_wb[0]), q, atol=TOL)
    assert placed.joints == () and placed.models[0].mass_kg == 2.0
    (box,) = robot.links[0].collisions
    assert box.shape.shape == 'box' and np.array_equal(box.shape.dimensions_m, [0.4, 0.3, 0.2])


KINDS_URDF = (
    link('base')
    + joint('slide', 'prismatic', 'base', 'carriage',
            '<origin xyz="0.1 0 0.2" rpy="0.3 0 0"/><axis xyz="1 0 0"/>'
            '<limit lower="-1" upper="1" effort="5" velocity="2"/>')
    + link('carriage', inertial(xyz='0.1 0.05 0', rpy='0 0 1.5707963267948966'))
    + joint('spin', 'continuous', 'carriage', 'wheel',
            '<origin xyz="0 0.3 0" rpy="1.5707963267948966 0 0.2"/><axis xyz="0 0 1"/>'
            '<limit effort="3" velocity="9"/><mimic joint="slide" multiplier="2" '
            'offset="0.1"/><dynamics damping="0.2"/>')
    + link('wheel')
    + joint('plane', 'planar', 'wheel', 'puck', '<origin xyz="0 0 0.4"/><axis xyz="0 0 1"/>')
    + link('puck')
    + joint('loose', 'floating', 'base', 'ball', '<origin xyz="0 0 -1"/>')
    + link('ball')
    + joint('weld', 'fixed', 'base', 'weight', '<origin xyz="0.5 0 0" rpy="0 0.4 0"/>')
    + link('weight'))


def test_every_joint_type_maps_to_the_core(tmp_path):
    robot = load_urdf(write(tmp_path, KINDS_URDF))
    # a planar joint: three entries (MoveIt's variable names); floating and fixed skipped
    assert robot.moving_joints == ('slide', 'spin', 'plane/x', 'plane/y', 'plane/theta')
    assert robot.body_links == ('base', 'carriage', 'wheel', 'puck', 'ball', 'weight')
    # <inertial> rpy about z by 90 deg swaps the x and y moments into link axes
    assert np.allclose(robot.link('carriage').inertia_b, np.diag([0.03, 0.02, 0.04]),
                       atol=1e-15, rtol=0)
    spin = robot.joint('spin')
    assert spin.mimic == ('slide', 2.0, 0.1) and spin.damping == 0.2 and spin.effort == 3.0
    assert robot.joint('loose').core is None
    # spin mimics slide: q_spin = 2 q_slide + 0.1, q̇_spin = 2 q̇_slide; the planar puck at
    # (x, y, theta) = (0.1, -0.2, 0.4) moving at (0.05, 0.1, -0.3)
    q, qd = np.array([0.3, 0.7, 0.1, -0.2, 0.4]), np.array([0.2, 0.4, 0.05, 0.1, -0.3])
    placed = place_robot(robot, position_w=(0.0, 0.0, 1.0), joint_positions=q,
                         joint_velocities=qd, gravity_w=(0.0, 0.0, 0.0))
    assert [j.kind for j in placed.joints] == ['prismatic', 'continuous', 'planar', 'fixed']
    mimic = placed.joints[1]
    assert (mimic.mimic, mimic.mimic_multiplier, mimic.mimic_offset) == ('slide', 2.0, 0.1)
    # a value for the mimic that disagrees with its leader is refused, naming both
    with pytest.raises(ConfigError, match=r'initial_joint_velocities\[1\]: -1.0 for joint '
                                          r"'spin', a mimic of 'slide', must be 0.4 "):
        place_robot(robot, joint_positions=q, joint_velocities=[0.2, -1.0, 0.0, 0.0, 0.0])
    # none given: the mimic follows its leader from zeros, q_spin = offset
    assert place_robot(robot).joints[1].mimic == 'slide'
    assert placed.joints[0].lower == -1.0 and placed.joints[1].effort_limit == 3.0
    # <dynamics damping="0.2"/> of the continuous joint is simulated; friction absent means 0
    assert (placed.joints[1].damping, placed.joints[1].friction) == (0.2, 0.0)
    assert (placed.joints[0].damping, placed.joints[0].friction) == (0.0, 0.0)
    # the floating child starts at the joint origin, 1 m below the base, a free body
    assert np.allclose(placed.states[4].position_w, [0.0, 0.0, 0.0], atol=TOL, rtol=0)
    sim = ArticulatedSimulator(placed.models, placed.states, placed.joints)
    assert max(sim.joint_error()) <= JOINT_TOL
    readback = sim.joint_positions()
    assert np.allclose([readback[0][0], readback[1][0]], q[:2], atol=TOL, rtol=0)
    # the planar joint's x along the joint frame's x (its <axis> is z), y along its y
    assert placed.joints[2].axis2_b.tolist() == [1.0, 0.0, 0.0]
    assert np.allclose(readback[2], q[2:], atol=TOL) and len(readback[3]) == 0
    rates = sim.joint_velocities()
    assert np.allclose([rates[0][0], rates[1][0]], qd[:2], atol=TOL, rtol=0)
    assert np.allclose(rates[2], qd[2:], atol=TOL)
    # the weld's child keeps the joint origin's rotation (0.4 rad about y) in the base
    weight = quat_to_matrix(placed.states[5].orientation_wb)
    assert np.allclose(weight @ [0.0, 1.0, 0.0], [0.0, 1.0, 0.0], atol=TOL)
    assert math.isclose(math.atan2(weight[0, 2], weight[0, 0]), 0.4, abs_tol=TOL)


def test_mesh_collisions_with_scale_package_uri_and_relative_path(tmp_path):
    mesh_dir = tmp_path / 'meshes'
    mesh_dir.mkdir()
    stl = Path(__file__).resolve().parents[2] / 'msg_config' / 'meshes' / 'l_block.stl'
    (mesh_dir / 'block.stl').write_bytes(stl.read_bytes())
    body = (inertial() + f'<collision><geometry><mesh filename="{L_BLOCK}" scale="2 2 2"/>'
            '</geometry></collision><collision><origin xyz="0 0 1"/><geometry>'
            '<mesh filename="meshes/block.stl"/></geometry></collision>'
            '<collision><geometry><sphere radius="0.1"/></geometry></collision>')
    robot = load_urdf(write(tmp_path, link('m', body)))
    scaled, plain, sphere = robot.links[0].collisions     # every element is kept, in order
    assert scaled.shape.shape == plain.shape.shape == 'mesh' and sphere.shape.shape == 'sphere'
    # not centred: the mesh keeps the file's coordinates (times the scale) in its frame
    assert np.allclose(scaled.shape.vertices_b.max(axis=0),
                       2.0 * plain.shape.vertices_b.max(axis=0), rtol=1e-15, atol=0)
    assert np.array_equal(plain.position_b, [0.0, 0.0, 1.0])
    # the file as the URDF names it and as loaded, with its scale (markers draw it from there)
    assert scaled.mesh_file == (L_BLOCK, resolve_mesh_path(L_BLOCK, 'f'), (2.0, 2.0, 2.0))
    assert plain.mesh_file == ('meshes/block.stl', str(mesh_dir / 'block.stl'),
                               (1.0, 1.0, 1.0))
    assert sphere.mesh_file is None


def test_xacro_file_is_expanded(tmp_path):
    path = tmp_path / 'robot.urdf.xacro'
    path.write_text('<?xml version="1.0"?>\n<robot name="x" '
                    'xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
                    '<xacro:property name="m" value="2.5"/>\n'
                    '<link name="b"><inertial><mass value="${m}"/><inertia ixx="0.1" '
                    'iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/></inertial></link>\n'
                    '</robot>\n')
    robot = load_urdf(str(path))
    assert robot.link('b').mass_kg == 2.5 and '${m}' not in robot.urdf


def test_xml_string_is_robot_description():
    robot = load_urdf(xml=Path(FREE_BODY).read_text())
    assert robot.source == 'robot_description' and robot.body_links == ('box',)


def refused(error, path_or_xml, *fragments, xml=False, **place):
    """Assert that loading (and placing) raises ``error`` on one line with ``fragments``."""
    with pytest.raises(error) as info:
        robot = load_urdf(xml=path_or_xml) if xml else load_urdf(path_or_xml)
        place_robot(robot, **place)
    message = str(info.value)
    assert '\n' not in message, message
    for fragment in fragments:
        assert fragment in message, message
    return info.value


def test_malformed_xml_names_the_file_and_line(tmp_path):
    path = tmp_path / 'bad.urdf'
    path.write_text('<robot name="r">\n<link name="a">\n</robot>\n')
    refused(ConfigError, str(path), str(path), 'malformed XML', 'line 3')
    refused(ConfigError, '<robot name="r"><link', 'robot_description', 'malformed XML',
            xml=True)
    refused(ConfigError, '<robt name="r"/>', 'robot_description', '<robt>', xml=True)


def test_moving_link_without_inertial(tmp_path):
    path = write(tmp_path, link('a') + joint('j', 'revolute', 'a', 'b', '<limit lower="-1" '
                 'upper="1" effort="1" velocity="1"/>') + link('b', ''))
    refused(ModelError, path, path, "link 'b'.inertial", 'revolute joint', "'j'")
    path = write(tmp_path, link('alone', ''), 'root.urdf')
    refused(ModelError, path, "link 'alone'.inertial", 'floating root')


@pytest.mark.parametrize('mass', ['0', '-1.5', '1e308'])
def test_zero_negative_or_huge_mass(tmp_path, mass):
    path = write(tmp_path, link('a', inertial(mass=mass)))
    error = refused(ModelError, path, path, "link 'a'.inertial.mass", 'kg')
    assert error.value == float(mass)


ORIGIN = '<origin xyz="{xyz}" rpy="{rpy}"/>'


@pytest.mark.parametrize('where, xyz, rpy, fragments', [
    # yourdfpy built a NaN pose; the line named a rotation matrix, no file, joint or field
    ('joint', 'nan 0 1', '0 0 0', ["joint 'j'.origin.xyz", '[nan, 0.0, 1.0] m must be finite']),
    ('joint', '0 0 1', '0 inf 0', ["joint 'j'.origin.rpy", '[0.0, inf, 0.0] rad must be finite']),
    # finite but 1e300 m away: the start's projection failed without naming it
    ('joint', '1e300 0 1', '0 0 0', ["joint 'j'.origin.xyz", '[1e+300, 0.0, 1.0] m',
                                     'within ±1e+07 m']),
    # two values: numpy's broadcast error
    ('joint', '0 1', '0 0 0', ["joint 'j'.origin.xyz", "'0 1' must be 3 numbers in m"]),
    ('joint', '0 0 1', 'a b c', ["joint 'j'.origin.rpy", "'a b c' must be 3 numbers in rad"]),
    ('inertial', '0 0 -1e8', '0 0 0', ["link 'b'.inertial.origin.xyz", 'within ±1e+07 m']),
    ('collision', '0 nan 0', '0 0 0', ["link 'b'.collision[1].origin.xyz", 'must be finite']),
])
def test_a_bad_origin_is_refused_naming_its_element(tmp_path, where, xyz, rpy, fragments):
    bad = ORIGIN.format(xyz=xyz, rpy=rpy)
    good = ORIGIN.format(xyz='0 0 0', rpy='0 0 0')
    box = '<geometry><box size="0.1 0.1 0.1"/></geometry>'
    second = bad if where == 'collision' else good
    collisions = f'<collision>{good}{box}</collision><collision>{second}{box}</collision>'
    body = inertial(xyz=xyz, rpy=rpy) if where == 'inertial' else inertial()
    path = write(tmp_path, link('a') + link('b', body + collisions) + joint(
        'j', 'continuous', 'a', 'b', bad if where == 'joint' else good))
    error = refused(ModelError, path, path, *fragments, '(line 2)')
    assert error.field == fragments[0]


def test_an_axis_whose_norm_overflows_is_still_its_direction(tmp_path):
    # (0, 1e300, 1e300): numpy's overflow warning on stderr, then 'is not a direction'
    path = write(tmp_path, link('a') + link('b') + joint(
        'j', 'continuous', 'a', 'b', '<axis xyz="0 1e300 1e300"/>'))
    np.testing.assert_allclose(load_urdf(path).joint('j').axis,
                               [0.0, math.sqrt(0.5), math.sqrt(0.5)], rtol=0, atol=3e-16)


def test_non_positive_definite_inertia(tmp_path):
    path = write(tmp_path, link('a', inertial(inertia='ixx="0.1" iyy="-0.1" izz="0.1"')))
    refused(ModelError, path, path, "link 'a'.inertial.inertia", 'positive definite')


def test_lower_above_upper(tmp_path):
    path = write(tmp_path, link('a') + link('b') + joint(
        'j', 'revolute', 'a', 'b', '<limit lower="1" upper="-1" effort="1" velocity="1"/>'))
    refused(ModelError, path, path, "joint 'j'.limit.lower", '1.0 rad', 'upper -1.0 rad')


@pytest.mark.parametrize('kind, field, unit', [('revolute', 'damping', 'N m s/rad'),
                                               ('prismatic', 'friction', 'N')])
def test_negative_joint_dynamics(tmp_path, kind, field, unit):
    path = write(tmp_path, link('a') + link('b') + joint(
        'j', kind, 'a', 'b', '<limit lower="-1" upper="1" effort="1" velocity="1"/>'
        f'<dynamics {field}="-0.5"/>'))
    refused(ModelError, path, path, f"joint 'j'.dynamics.{field}", f'-0.5 {unit} must be >= 0')


@pytest.mark.parametrize('kind', ['revolute', 'prismatic'])
def test_a_limited_joint_type_without_limit_is_refused(tmp_path, kind):
    # the URDF spec requires <limit> of a revolute and a prismatic joint (urdfdom, so
    # robot_state_publisher, refuses such a file); it was taken as a joint without limits
    path = write(tmp_path, link('a') + link('b') + joint('j', kind, 'a', 'b',
                                                         '<axis xyz="0 0 1"/>'))
    refused(ModelError, path, path, "joint 'j'.limit", 'missing (line 2)',
            f'a {kind} joint needs <limit')
    # a continuous joint needs none
    assert load_urdf(write(tmp_path, link('a') + link('b') + joint(
        'j', 'continuous', 'a', 'b', '<axis xyz="0 0 1"/>'))).moving_joints == ('j',)


@pytest.mark.parametrize('kind', ['revolute', 'prismatic'])
@pytest.mark.parametrize('given, lower, upper', [
    ('upper="0.5"', 0.0, 0.5), ('lower="-0.5"', -0.5, 0.0), ('', 0.0, 0.0)])
def test_a_limit_without_lower_or_upper_takes_the_spec_s_default_zero(tmp_path, kind, given,
                                                                      lower, upper):
    # The URDF spec and urdfdom (robot_state_publisher, ros2_control, MoveIt): lower and upper
    # default to 0. Taken as no limit, the joint moved where every ROS tool holds it.
    path = write(tmp_path, link('a') + link('b') + joint(
        'j', kind, 'a', 'b', f'<axis xyz="0 0 1"/><limit {given} effort="1" velocity="1"/>'))
    (j,) = load_urdf(path).joints
    assert (j.lower, j.upper) == (lower, upper)
    unit = 'rad' if kind == 'revolute' else 'm'
    refused(ConfigError, path, f"initial_joint_positions[0]: 0.75 {unit} for joint 'j' is "
            f'outside its limits [{lower!r}, {upper!r}]', joint_positions=[0.75])
    # a bound given below the other's default is lower > upper, refused as any other
    if given:
        flipped = given.replace('0.5"', '-0.5"') if 'upper' in given else \
            given.replace('-0.5"', '0.5"')
        refused(ModelError, write(tmp_path, link('a') + link('b') + joint(
            'j', kind, 'a', 'b', f'<axis xyz="0 0 1"/><limit {flipped} effort="1" '
            'velocity="1"/>')), "joint 'j'.limit.lower", 'is above upper')


@pytest.mark.parametrize('field, values, words', [
    ('joint_positions', [1e300], "initial_joint_positions[0]: 1e+300 rad for joint 'j' is "
     'beyond ±1e+07 rad (rbd_ros.sim.params.MAX_JOINT_POSITION)'),
    ('joint_positions', [-1.0000001e7], 'beyond ±1e+07 rad'),
    ('joint_velocities', [1e200], "initial_joint_velocities[0]: 1e+200 rad/s for joint 'j' "
     'is beyond ±1e+07 rad/s (rbd_ros.sim.params.MAX_JOINT_RATE)'),
])
def test_initial_joint_values_beyond_their_bounds_are_refused(tmp_path, field, values, words):
    # a continuous joint has no limits to hold its position: 1e300 rad was taken, and a rate
    # of 1e200 rad/s made the first step non-finite (refused then, naming no parameter)
    path = write(tmp_path, link('a') + link('b') + joint('j', 'continuous', 'a', 'b',
                                                         '<axis xyz="0 0 1"/>'))
    refused(ConfigError, path, words, **{field: values})
    # the bounds themselves are taken
    place_robot(load_urdf(path), **{field: [math.copysign(1e7, values[0])]})


def test_a_prismatic_joint_rate_is_bounded_in_m_per_s(tmp_path):
    path = write(tmp_path, link('a') + link('b') + joint(
        'j', 'prismatic', 'a', 'b', '<limit lower="-1" upper="1" effort="1" velocity="1"/>'))
    refused(ConfigError, path, "initial_joint_velocities[0]: -3e+20 m/s for joint 'j' is "
            'beyond ±1e+07 m/s', joint_velocities=[-3e20])


def test_unknown_joint_type(tmp_path):
    path = write(tmp_path, link('a') + link('b') + joint('j', 'ball', 'a', 'b'))
    refused(ModelError, path, path, "joint 'j'.type", "'ball'", 'revolute')


def test_joint_naming_an_unknown_link(tmp_path):
    path = write(tmp_path, link('a') + joint('j', 'fixed', 'a', 'nowhere'))
    refused(ModelError, path, path, "joint 'j'.child", "'nowhere'", 'not a link')


def test_loops_are_refused(tmp_path):
    two_parents = write(tmp_path, link('a') + link('b') + link('c')
                        + joint('j1', 'fixed', 'a', 'c') + joint('j2', 'fixed', 'b', 'c'))
    refused(ModelError, two_parents, two_parents, "joint 'j2'.child", "'j1'", 'loop')
    cycle = write(tmp_path, link('a') + link('b') + link('c') + joint('j1', 'fixed', 'a', 'b')
                  + joint('j2', 'fixed', 'b', 'c') + joint('j3', 'fixed', 'c', 'b'),
                  'cycle.urdf')
    refused(ModelError, cycle, cycle, "joint 'j3'.child", 'loop')
    ring = write(tmp_path, link('a') + link('b') + joint('j1', 'fixed', 'a', 'b')
                 + joint('j2', 'fixed', 'b', 'a'), 'ring.urdf')
    refused(ModelError, ring, ring, 'loop')


def test_missing_mesh_file(tmp_path):
    body = inertial() + '<collision><geometry><mesh filename="gone.stl"/></geometry></collision>'
    path = write(tmp_path, link('a', body))
    refused(ModelError, path, path, "link 'a'.collision[0].mesh.filename", "'gone.stl'",
            'does not exist')


def test_wrong_number_of_initial_joint_values():
    refused(ConfigError, ARM3, ARM3, 'initial_joint_positions', '2 values for 3 moving joints',
            'shoulder, elbow, wrist', joint_positions=[0.1, 0.2])
    refused(ConfigError, ARM3, 'initial_joint_velocities', '4 values',
            joint_velocities=[0.0] * 4)
    refused(ConfigError, PENDULUM, 'initial_joint_positions[0]', '3.5', 'limits',
            joint_positions=[3.5])
    refused(ConfigError, FREE_BODY, 'initial_orientation', 'zero norm',
            orientation_wb=(0.0, 0.0, 0.0, 0.0))
    refused(ConfigError, FREE_BODY, 'initial_position', 'finite',
            position_w=(0.0, math.nan, 0.0))


def test_missing_file_and_bad_xacro(tmp_path):
    refused(ConfigError, str(tmp_path / 'none.urdf'), 'urdf_path', 'does not exist')
    path = tmp_path / 'bad.xacro'
    path.write_text('<robot xmlns:xacro="http://www.ros.org/wiki/xacro" name="r">'
                    '<link name="${undefined}"/></robot>')
    refused(ConfigError, str(path), str(path), 'xacro failed')


MIMIC_BASE = (link('base') + joint('a', 'revolute', 'base', 'one',
                                   '<axis xyz="0 0 1"/><limit lower="-1" upper="1"/>')
              + link('one'))


@pytest.mark.parametrize('extra, words', [
    ('<mimic joint="b"/>', "joint 'b'.mimic.joint: 'b' is the joint itself"),
    ('<mimic joint="zz"/>', "joint 'b'.mimic.joint: 'zz' is not a joint of this robot"),
    ('<mimic joint="weld"/>', "joint 'b'.mimic.joint: 'weld' is a fixed joint; a mimic "
                              'follows a revolute, continuous, prismatic joint'),
    ('<mimic joint="a" multiplier="nan"/>',
     "joint 'b'.mimic.multiplier: nan per leader unit must be finite"),
    ('<mimic joint="a" offset="inf"/>', "joint 'b'.mimic.offset: inf rad must be finite"),
])
def test_bad_mimics_are_refused_in_one_line(tmp_path, extra, words):
    body = (MIMIC_BASE + joint('b', 'continuous', 'base', 'two', extra) + link('two')
            + joint('weld', 'fixed', 'base', 'three') + link('three'))
    with pytest.raises(ModelError) as info:
        load_urdf(write(tmp_path, body))
    assert words in str(info.value) and '\n' not in str(info.value)


def test_a_cycle_of_mimics_and_a_planar_mimic_are_refused(tmp_path):
    body = (link('base') + joint('a', 'continuous', 'base', 'one', '<mimic joint="b"/>')
            + link('one') + joint('b', 'continuous', 'base', 'two', '<mimic joint="a"/>')
            + link('two'))
    with pytest.raises(ModelError, match=r"joint 'a'.mimic.joint: 'b' leads back to 'a'"):
        load_urdf(write(tmp_path, body))
    body = MIMIC_BASE + joint('p', 'planar', 'base', 'two', '<mimic joint="a"/>') + link('two')
    with pytest.raises(ModelError, match=r"joint 'p'.mimic.joint: 'a'; a planar joint cannot "
                                         'mimic'):
        load_urdf(write(tmp_path, body))


def test_a_urdf_mesh_past_the_mesh_file_limit_is_refused_before_it_is_read(tmp_path):
    # The limit of every mesh file (a body's or an obstacle's: sim/meshes.py) holds for a URDF
    # link's too: a 4 GB sparse STL was read whole (8.6 GB resident, 83 s) before "holds no
    # triangles". A file one byte over the limit is refused from its size alone.
    from rbd_ros.sim.params import MAX_MESH_FILE_BYTES
    huge = tmp_path / 'huge.stl'
    with open(huge, 'wb') as f:
        f.truncate(MAX_MESH_FILE_BYTES + 1)  # sparse: no disk
    xml = (URDF_DIR / 'arm3.urdf').read_text()
    xml = xml.replace('<cylinder radius="0.03" length="0.5"/>', f'<mesh filename="{huge}"/>', 1)
    with pytest.raises(ModelError, match=rf'\.mesh\.filename: .* is {MAX_MESH_FILE_BYTES + 1} '
                       rf'bytes, more than the limit of {MAX_MESH_FILE_BYTES} bytes'):
        load_urdf(xml=xml)
