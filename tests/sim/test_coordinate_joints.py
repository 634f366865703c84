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
Planar and universal joints in the node's robots and worlds, in process: names, order, commands.

A URDF ``planar`` joint is three ``joint_states`` entries, ``<joint>/x``, ``<joint>/y``,
``<joint>/theta`` (MoveIt's names of its variables), and a world's ``universal`` joint two,
``<joint>/theta1``, ``<joint>/theta2``; each is commanded by that name as a one-coordinate
joint is. Through :meth:`NodeConfig.from_parameters` and :class:`SimSession` (what the node
runs); the closed forms through DDS are in ``tests/ros/test_node_coordinate_joints.py``.
"""

import math

import numpy as np
import pytest
from rbd_ros.core import ConfigError
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.joint_commands import CommandRejected, coordinate_entries
from rbd_ros.sim.session import SimSession

#: A 2 kg puck on a planar joint to the world in the vertical plane x-z: ``<axis>`` -y, so its
#: x is the world's x and its y the world's z (up); its COM 0.2 m along its x from the anchor.
PUCK_URDF = (
    '<robot name="puck"><link name="world"/><link name="puck"><inertial>'
    '<origin xyz="0.2 0 0"/><mass value="2.0"/><inertia ixx="0.01" iyy="0.02" izz="0.015" '
    'ixy="0" ixz="0" iyz="0"/></inertial><collision><origin xyz="0.2 0 0"/><geometry>'
    '<box size="0.1 0.1 0.1"/></geometry></collision></link>'
    '<joint name="plane" type="planar"><parent link="world"/><child link="puck"/>'
    '<origin xyz="0 0 1.5"/><axis xyz="0 -1 0"/><limit effort="1000" velocity="5"/></joint>'
    '</robot>')


def puck_params(**more):
    """Return the parameters of a robot file with the puck."""
    params = {'robot_names': ['puck'], 'robots.puck.robot_description': PUCK_URDF,
              'gravity': [0.0, 0.0, -9.81],
              'publish_rate_hz': 100.0}
    params.update(more)
    return params


def rod_params(**more):
    """Return a world with a 1 m rod hanging from a universal joint at (0, 0, 2) m."""
    params = {'body_names': ['rod'], 'bodies.rod.shape': 'box', 'bodies.rod.mass_kg': 1.0,
              'bodies.rod.dimensions_m': [0.04, 0.04, 1.0],
              'bodies.rod.initial_position': [0.0, 0.0, 1.5], 'gravity': [0.0, 0.0, -9.81],
              'joint_names': ['cardan'], 'joints.cardan.type': 'universal',
              'joints.cardan.child': 'rod', 'joints.cardan.position': [0.0, 0.0, 2.0],
              'joints.cardan.axis': [1.0, 0.0, 0.0], 'joints.cardan.axis2': [0.0, 1.0, 0.0]}
    params.update(more)
    return params


def ball_params(**more):
    """Return :func:`rod_params`' rod on a ball (``spherical``) joint at (0, 0, 2) m instead."""
    params = rod_params(**{'joints.cardan.type': 'spherical'})
    params = {k.replace('cardan', 'ball'): v for k, v in params.items()
              if k not in ('joints.cardan.axis', 'joints.cardan.axis2')}
    params['joint_names'] = ['ball']
    params.update(more)
    return params


def test_a_ball_joint_is_three_rotation_vector_coordinates():
    # a rotation vector (UR's rx, ry, rz of a pose): three coordinates whose rates and efforts
    # are the angular velocity and torque on the same axes (a quaternion's four are not)
    assert coordinate_entries('ball', 'spherical') == (('ball/rx', 0), ('ball/ry', 1),
                                                       ('ball/rz', 2))
    config = NodeConfig.from_parameters(ball_params())
    assert [entry for entry, _ in config.world_joints[0].entries] == ['ball/rx', 'ball/ry',
                                                                      'ball/rz']


def test_entries_are_moveits_variable_names():
    assert coordinate_entries('plane', 'planar') == (('plane/x', 0), ('plane/y', 1),
                                                     ('plane/theta', 2))
    assert coordinate_entries('cardan', 'universal') == (('cardan/theta1', 0),
                                                         ('cardan/theta2', 1))
    assert coordinate_entries('elbow', 'revolute') == (('elbow', None),)
    assert coordinate_entries('weld', 'fixed') == ()


def test_a_planar_robot_lists_and_places_its_three_coordinates():
    config = NodeConfig.from_parameters(puck_params(**{
        'robots.puck.initial_joint_positions': [0.3, -0.2, 0.5],
        'robots.puck.joints.plane.position_time_constant_s': 0.1}))
    (robot,) = config.robots
    assert robot.joint_names == ('plane/x', 'plane/y', 'plane/theta')
    assert robot.units('plane/x') == ('m', 'm/s', 'N')
    assert robot.units('plane/theta') == ('rad', 'rad/s', 'N m')
    assert robot.entry_time_constants_s == (0.1, 0.1, 0.1)
    names = {spec.name for spec in robot.specs}
    assert 'robots.puck.joints.plane.position_time_constant_s' in names
    assert 'robots.puck.joints.plane.damping' in names   # 0 only: the core takes none
    # the joint frame's x is the world's, its y the world's z: the anchor at (0.3, 0, 1.3)
    (joint,) = robot.placement.joints
    assert joint.axis2_b.tolist() == [1.0, 0.0, 0.0] and joint.effort_limit == 1000.0
    session = SimSession(config)
    q, qd, effort = session.simulator.joint_states(0)
    assert np.allclose(q, [0.3, -0.2, 0.5], atol=1e-15, rtol=0) and qd == [0.0] * 3
    pose = dict(zip([link.name for link in robot.robot.links],
                    session.simulator.link_poses(0)))['puck']
    assert np.allclose(pose[0], [0.3, 0.0, 1.3], atol=1e-15)


@pytest.mark.parametrize('params, words', [
    ({'robots.puck.initial_joint_positions': [0.1, 0.2]},
     'initial_joint_positions: 2 values for 3 moving joints (plane/x, plane/y, plane/theta)'),
    ({'robots.puck.initial_joint_positions': [0.0, 0.0, 4.0]},
     "initial_joint_positions[2]: 4.0 rad for 'plane/theta' must be in (-pi, pi]"),
    ({'robots.puck.joints.plane.damping': 0.5},
     'parameter robots.puck.joints.plane.damping = 0.5 N·m·s/rad or N·s/m: a planar joint '
     'takes no damping'),
])
def test_bad_planar_parameters_are_refused_in_one_line(params, words):
    with pytest.raises(ConfigError) as err:
        NodeConfig.from_parameters(puck_params(**params))
    assert words in str(err.value) and '\n' not in str(err.value)


def test_commands_by_entry_name_drive_each_coordinate_and_bad_ones_are_counted():
    config = NodeConfig.from_parameters(puck_params(**{
        'command_group_names': ['xy'], 'command_groups.xy.robot': 'puck',
        'command_groups.xy.joints': ['plane/x', 'plane/y']}))
    session = SimSession(config)
    inputs = session.commands
    bad = [('puck/joint_command', (['plane/z'], [0.1], [], []), 'unknown_joint'),
           ('puck/joint_command', (['plane'], [0.1], [], []), 'unknown_joint'),
           ('puck/joint_command', (['plane/theta'], [4.0], [], []), 'limit'),
           ('puck/joint_command', (['plane/x'], [math.inf], [], []), 'non_finite'),
           ('xy/commands', [0.1, math.nan], 'non_finite'),
           ('xy/commands', [0.1], 'length')]
    for topic, payload, reason in bad:
        with pytest.raises(CommandRejected) as err:
            inputs.submit(topic, payload)
        assert err.value.reason == reason, (topic, payload, str(err.value))
    assert inputs.rejected_total == len(bad)
    with pytest.raises(CommandRejected) as err:
        inputs.submit('puck/joint_command', (['plane/z'], [0.1], [], []))
    assert "'plane/z' is not a moving joint of this robot (plane/x, plane/y, plane/theta)" in \
        str(err.value)
    # x and y by the group, theta by name: each follows e0 (1 + ω t) e^(−ω t) (τ = 0.05 s)
    # from rest, to the articulated step's RK4 error: O((ω h)⁴), 9.7e-11 at ω = 10 in the
    # core's tests, so 16 times that at ω = 20 (measured 1.6e-9 over the run): 5e-9
    session.submit_command('xy/commands', [0.3, -0.4])
    session.submit_command('puck/joint_command', (['plane/theta'], [1.0], [], []))
    session.paused = False
    while session.time_ns < 1_000_000_000:
        session.advance(1000)
    t = session.time_ns * 1e-9
    q, _, effort = session.simulator.joint_states(0)
    for k, target in enumerate((0.3, -0.4, 1.0)):
        exact = target - target * (1.0 + 20.0 * t) * math.exp(-20.0 * t)
        assert abs(q[k] - exact) <= 5e-9, (k, q[k], exact)
    # the motors carry gravity: y (up) m g, theta m g r cos θ against its turn, x none; at
    # 1 s the response's acceleration is ω² e ~ 4e-6 of the move: 1e-3 relative
    assert effort[0] == pytest.approx(0.0, abs=1e-3)
    assert effort[1] == pytest.approx(2.0 * 9.81, rel=1e-3)
    assert effort[2] == pytest.approx(2.0 * 9.81 * 0.2 * math.cos(1.0), rel=1e-3)


def test_a_universal_world_joint_reads_and_refuses_its_second_axis():
    config = NodeConfig.from_parameters(rod_params())
    (cardan,) = config.world_joints
    assert [e for e, _ in cardan.entries] == ['cardan/theta1', 'cardan/theta2']
    assert cardan.joint.axis2_b.tolist() == [0.0, 1.0, 0.0]
    # the planar default: the world x in the plane across the axis (y when near x)
    planar = NodeConfig.from_parameters(rod_params(**{
        'joints.cardan.type': 'planar', 'joints.cardan.axis': [0.0, 0.0, 1.0],
        'joints.cardan.axis2': [0.0, 0.0, 0.0]})).world_joints[0]
    assert planar.joint.axis2_b.tolist() == [1.0, 0.0, 0.0]
    for more, words in (
            ({'joints.cardan.axis2': [0.1, 1.0, 0.0]},
             'parameter joints.cardan.axis2 = ['),
            ({'joints.cardan.axis2': [1e-13, 0.0, 0.0]}, 'has zero length'),
            ({'joints.cardan.type': 'revolute'},
             'parameter joints.cardan.axis2 = [0.0, 1.0, 0.0]: a revolute joint has no '
             'second axis')):
        with pytest.raises(ConfigError) as err:
            NodeConfig.from_parameters(rod_params(**more))
        assert words in str(err.value) and '\n' not in str(err.value), str(err.value)


def test_a_universal_world_joint_is_commanded_by_its_angles_in_the_contact_step():
    # the contact step lands each angle on its exact response at every step's end: the
    # closed form to 1e-10 (tests/core/joints/test_coordinate_motors_contact.py)
    session = SimSession(NodeConfig.from_parameters(rod_params(**{
        'joints.cardan.position_time_constant_s': 0.1})))
    session.submit_command('joint_command', (['cardan/theta2', 'cardan/theta1'],
                                             [-0.7, 0.5], [], []))
    session.paused = False
    while session.time_ns < 500_000_000:
        session.advance(1000)
    t = session.time_ns * 1e-9
    q, _, _ = session.simulator.joint_states(0)
    for k, target in enumerate((0.5, -0.7)):
        exact = target - target * (1.0 + 10.0 * t) * math.exp(-10.0 * t)
        assert abs(q[k] - exact) <= 1e-10, (k, q[k], exact)


def test_a_trajectory_over_a_planar_joints_coordinates_passes_its_waypoints():
    # x and theta of the puck follow a JointTrajectory with two points (cubic through rest):
    # the waypoints are reached to the follower's O(h²) lag (5e-8 rad on a 3-link arm's
    # gentler cubic, doc/robots.md; here measured 1.6e-7 m and 6.4e-7 rad, the lag growing with
    # the cubic's jerk: bound 1e-6), y held at 0 by its own position target meanwhile.
    from rbd_ros.sim.trajectory import TrajectoryPoint
    session = SimSession(NodeConfig.from_parameters(puck_params(**{
        'command_group_names': ['xt'], 'command_groups.xt.robot': 'puck',
        'command_groups.xt.joints': ['plane/x', 'plane/theta']})))
    session.submit_command('puck/joint_command', (['plane/y'], [0.0], [], []))
    session.submit_command('xt/joint_trajectory', (
        ['plane/theta', 'plane/x'], 0,
        [TrajectoryPoint(500_000_000, [0.5, 0.2], [0.0, 0.0]),
         TrajectoryPoint(1_000_000_000, [-0.3, 0.1], [0.0, 0.0])]))
    session.paused = False
    for t_ns, (x, theta) in ((500_000_000, (0.2, 0.5)), (1_000_000_000, (0.1, -0.3))):
        while session.time_ns < t_ns:
            session.advance(t_ns - session.time_ns)
        q = session.simulator.joint_states(0)[0]
        assert abs(q[0] - x) <= 1e-6 and abs(q[2] - theta) <= 1e-6, (t_ns, q)
        assert abs(q[1]) <= 1e-9, q
