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
Joint commands (JointState by name, Float64MultiArray by group) and command groups.

The arm of ``msg_config/urdf/arm3.urdf`` (three revolute joints, limits [-3, 3] rad, velocity
limit 3 rad/s, effort 60 N m) is commanded as topic_based_ros2_control and
forward_command_controller would; every refusal is one line naming the field.
"""

import math
import os

import pytest

from rbd_ros.core import ConfigError
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.joint_commands import (CommandRejected, group_targets, joint_state_targets,
                                        JointTarget, MAX_TRAJECTORY_POINTS)
from rbd_ros.sim.robots import read_command_groups, read_robots
from rbd_ros.sim.session import SimSession
from rbd_ros.sim.trajectory import TrajectoryPoint

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ARM = os.path.join(ROOT, 'msg_config', 'urdf', 'arm3.urdf')
NAN = math.nan
TOPIC = 'arm/joint_command'
S = 1_000_000_000  # ns


@pytest.fixture(scope='module')
def arm():
    (robot,) = read_robots({'robot_names': ['arm'], 'robots.arm.urdf_path': ARM})
    return robot


def test_each_joint_takes_its_first_finite_field(arm):
    targets = joint_state_targets(TOPIC, arm.joint_specs(), ['wrist', 'shoulder', 'elbow'],
                                  position=[NAN, 0.5, NAN], velocity=[1.0, 2.0, NAN],
                                  effort=[NAN, NAN, 4.0])
    assert targets == (JointTarget(2, 'velocity', 1.0), JointTarget(0, 'position', 0.5),
                       JointTarget(1, 'effort', 4.0))


def test_nan_and_absent_fields_leave_the_joint_alone(arm):
    assert joint_state_targets(TOPIC, arm.joint_specs(), ['elbow'], position=[NAN]) == ()
    assert joint_state_targets(TOPIC, arm.joint_specs(), ['elbow']) == ()


def test_a_velocity_beyond_the_urdf_limit_is_clipped_to_it(arm):
    (target,) = joint_state_targets(TOPIC, arm.joint_specs(), ['elbow'], velocity=[-10.0])
    assert target == JointTarget(1, 'velocity', -3.0)  # <limit velocity="3"/> in arm3.urdf


@pytest.mark.parametrize('names, fields, reason, words', [
    (['knee'], {'position': [0.0]}, 'unknown_joint', "name[0]: 'knee' is not a moving joint"),
    (['elbow', 'elbow'], {'position': [0.0, 0.0]}, 'duplicate_joint', 'name[1]'),
    (['elbow', 'wrist'], {'position': [0.0]}, 'length', 'position: 1 values for 2 names'),
    (['elbow'], {'effort': [math.inf]}, 'non_finite', 'effort[0]: inf is not finite'),
    (['elbow'], {'position': [3.5]}, 'limit', "joint 'elbow'.position: 3.5 rad is beyond upper"),
])
def test_bad_joint_state_commands_are_refused_whole(arm, names, fields, reason, words):
    with pytest.raises(CommandRejected) as caught:
        joint_state_targets(TOPIC, arm.joint_specs(), names, **fields)
    assert caught.value.reason == reason
    assert str(caught.value).startswith(TOPIC + ': ') and words in str(caught.value)


def test_a_group_command_maps_values_to_its_joints_in_order(arm):
    (group,) = read_command_groups({'command_group_names': ['g'], 'command_groups.g.robot': 'arm',
                                    'command_groups.g.joints': ['wrist', 'shoulder']}, [arm])
    assert group.joints == (2, 0) and group.interface == 'position'
    targets = group_targets('g/commands', arm.joint_specs(), group.joints, group.interface,
                            [0.1, -0.2])
    assert targets == (JointTarget(2, 'position', 0.1), JointTarget(0, 'position', -0.2))


def test_a_group_without_joints_takes_every_moving_joint(arm):
    (group,) = read_command_groups({'command_group_names': ['g'], 'command_groups.g.robot': 'arm',
                                    'command_groups.g.interface': 'effort'}, [arm])
    assert group.joints == (0, 1, 2) and group.interface == 'effort'


@pytest.mark.parametrize('data, reason, words', [
    ([0.1], 'length', 'data: 1 values for the 3 joints'),
    ([0.1, NAN, 0.0], 'non_finite', 'data[1] (elbow): nan is not a finite position'),
    ([0.1, 0.0, -4.0], 'limit', "data[2] (wrist): joint 'wrist'.position: -4.0 rad"),
])
def test_bad_group_commands_are_refused_whole(arm, data, reason, words):
    with pytest.raises(CommandRejected) as caught:
        group_targets('g/commands', arm.joint_specs(), (0, 1, 2), 'position', data)
    assert caught.value.reason == reason and words in str(caught.value)


@pytest.mark.parametrize('extra, words', [
    ({'command_groups.g.robot': 'leg'}, "command_groups.g.robot = 'leg': must be one of"),
    ({'command_groups.g.robot': 'arm', 'command_groups.g.joints': ['knee']},
     "'knee' is not a moving joint of robot 'arm'"),
    ({'command_groups.g.robot': 'arm', 'command_groups.g.joints': ['elbow', 'elbow']},
     "'elbow' is listed twice"),
    ({'command_groups.g.robot': 'arm', 'command_groups.g.interface': 'torque'},
     "command_groups.g.interface = 'torque': must be one of position, velocity, effort"),
])
def test_bad_groups_are_refused_at_start(arm, extra, words):
    with pytest.raises(ConfigError) as caught:
        read_command_groups({'command_group_names': ['g'], **extra}, [arm])
    assert words in str(caught.value) and '\n' not in str(caught.value)


GRIPPER = os.path.join(ROOT, 'msg_config', 'urdf', 'gripper.urdf')


@pytest.fixture(scope='module')
def gripper():
    (robot,) = read_robots({'robot_names': ['gripper'], 'robots.gripper.urdf_path': GRIPPER})
    return robot


def test_a_mimic_joint_takes_no_command_and_no_place_in_a_group(gripper):
    assert gripper.joint_names == ('finger_left', 'finger_right')
    with pytest.raises(CommandRejected) as caught:
        joint_state_targets('gripper/joint_command', gripper.joint_specs(),
                            ['finger_left', 'finger_right'], position=[0.01, 0.01])
    assert caught.value.reason == 'mimic_joint'
    assert str(caught.value) == (
        "gripper/joint_command: name[1]: 'finger_right' is a mimic joint (of 'finger_left') "
        "and takes no command; command 'finger_left'")
    (group,) = read_command_groups({'command_group_names': ['g'],
                                    'command_groups.g.robot': 'gripper'}, [gripper])
    assert group.joints == (0,)   # [] = every moving joint but the mimics
    with pytest.raises(ConfigError, match=r"command_groups.g.joints.*'finger_right' is a mimic "
                                          r"joint \(of 'finger_left'\) and takes no command"):
        read_command_groups({'command_group_names': ['g'], 'command_groups.g.robot': 'gripper',
                             'command_groups.g.joints': ['finger_right']}, [gripper])


def _arm_session(**extra):
    """Return a session of arm3 (joints only) with the group ``g`` of its three joints."""
    config = NodeConfig.from_parameters({
        'robot_names': ['arm'], 'robots.arm.urdf_path': ARM, 'gravity': [0.0, 0.0, -9.81],
        'command_group_names': ['g'], 'command_groups.g.robot': 'arm',
        'command_groups.g.joints': ['shoulder', 'elbow', 'wrist'], **extra})
    return SimSession(config)


def test_a_trajectory_whose_spline_passes_a_limit_is_followed_up_to_the_limit():
    # Both points are within [-3, 3] rad, but the cubic from 2.9 rad at 5 rad/s to 2.95 rad
    # at rest in 0.2 s peaks at 3.06 rad: the reference is held at the limit there, and the
    # session goes on (it used to stop on the core's ConfigError: the node exited).
    session = _arm_session()
    session.advance(10)
    session.submit_command('g/joint_trajectory', (
        ['shoulder', 'elbow', 'wrist'], 0,
        [TrajectoryPoint(S, [2.9, 0.0, 0.0], [5.0, 0.0, 0.0]),
         TrajectoryPoint(S + S // 5, [2.95, 0.0, 0.0], [0.0, 0.0, 0.0])]))
    while session.time_ns < 2 * S:
        session.advance(1000)
        assert session.error is None and session.simulator.joint_positions(0)[0] <= 3.0
    assert abs(session.simulator.joint_positions(0)[0] - 2.95) < 1e-6


def _continuous_pendulum():
    """Return a session of the URDF pendulum on a continuous joint (no limits at all)."""
    with open(os.path.join(ROOT, 'msg_config', 'urdf', 'pendulum.urdf')) as f:
        urdf = f.read().replace('type="revolute"', 'type="continuous"')
    urdf = urdf.replace('<limit lower="-3.1" upper="3.1" effort="10" velocity="10"/>', '')
    return SimSession(NodeConfig.from_parameters({
        'robot_names': ['p'], 'robots.p.robot_description': urdf,
        'gravity': [0.0, 0.0, -9.81]}))


@pytest.mark.parametrize('field, value, words', [
    ('position', 1e300, 'position[0] (pivot): 1e+300 rad is beyond the largest position a '
     'joint takes, 1e+06 rad'),
    ('velocity', 1e300, 'velocity[0] (pivot): 1e+300 rad/s is beyond the largest velocity'),
    ('velocity', -1e4, 'velocity[0] (pivot): -10000.0 rad/s is beyond'),
    ('effort', 1e12, 'effort[0] (pivot): 1000000000000.0 N m is beyond the largest effort'),
])
def test_a_target_beyond_what_a_step_can_take_is_refused_and_the_world_goes_on(
        field, value, words):
    # A joint without URDF limits took any finite target; the step could not follow it and
    # the world paused (ConvergenceError: the projection's error inf).
    session = _continuous_pendulum()
    session.advance(10)
    with pytest.raises(CommandRejected) as caught:
        session.submit_command('p/joint_command', (['pivot'], *[
            [value] if f == field else [] for f in ('position', 'velocity', 'effort')]))
    assert caught.value.reason == 'limit' and words in str(caught.value), str(caught.value)
    assert session.commands.rejected == {'limit': 1}
    session.advance(100)
    assert session.error is None and session.time_ns > 10_000_000


@pytest.mark.parametrize('field, words', [
    ('velocities', 'points[0].velocities (shoulder): 1e+300 rad/s is beyond'),
    ('accelerations', 'points[0].accelerations (shoulder): 1e+300 rad/s² is beyond'),
])
def test_a_trajectory_with_absurd_rates_is_refused_and_the_world_goes_on(field, words):
    session = _arm_session()
    session.advance(10)
    rates = {'velocities': [0.0] * 3, 'accelerations': [0.0] * 3}
    rates[field] = [1e300, 0.0, 0.0]
    with pytest.raises(CommandRejected) as caught:
        session.submit_command('g/joint_trajectory', (
            ['shoulder', 'elbow', 'wrist'], 0,
            [TrajectoryPoint(S, [0.1, 0.0, 0.0], rates['velocities'],
                             rates['accelerations'])]))
    assert caught.value.reason == 'limit' and words in str(caught.value), str(caught.value)
    session.advance(100)
    assert session.error is None


def test_a_followed_spline_faster_than_a_step_can_follow_gives_no_feed_forward():
    # A first point 1 ns after the trajectory starts: the segment to it from the joints'
    # state moves at ~1e8 rad/s, sampled at the step start as the feed-forward rate; the
    # step of a world with contact failed with its error inf and the world paused.
    session = _arm_session(**{'ground.enabled': True})
    session.advance(10)
    session.submit_command('g/joint_trajectory', (
        ['shoulder', 'elbow', 'wrist'], 0,
        [TrajectoryPoint(1, [0.1, 0.0, 0.0]), TrajectoryPoint(2, [2.0, 0.0, 0.0])]))
    while session.time_ns < S:
        session.advance(1000)
        assert session.error is None
    assert abs(session.simulator.joint_positions(0)[0] - 2.0) < 1e-3


class _CountedPoints(list):
    """Trajectory points that count how many were read (a real list of real points)."""

    read = 0

    def __getitem__(self, k):
        self.read += 1
        return super().__getitem__(k)

    def __iter__(self):
        for k in range(len(self)):
            yield self[k]


def test_a_trajectory_of_too_many_points_is_refused_from_its_count_and_counted():
    # 100 000 points blocked the node's executor ~4.8 s, every point read and checked before
    # anything could refuse the trajectory. Points 1 ms apart, on the arm's start pose: a
    # trajectory that would otherwise be followed.
    session = _arm_session()
    session.advance(10)

    def points(n):
        return _CountedPoints(TrajectoryPoint((k + 1) * 1_000_000, [0.0, 0.0, 0.0])
                              for k in range(n))

    too_many = points(MAX_TRAJECTORY_POINTS + 1)
    with pytest.raises(CommandRejected) as caught:
        session.submit_command('g/joint_trajectory', (['shoulder', 'elbow', 'wrist'], 0,
                                                      too_many))
    assert caught.value.reason == 'limit'
    assert str(caught.value) == (f'g/joint_trajectory: points: {MAX_TRAJECTORY_POINTS + 1} '
                                 'points is beyond the most a trajectory takes, '
                                 f'{MAX_TRAJECTORY_POINTS}')
    assert too_many.read == 0
    assert session.commands.rejected == {'limit': 1}
    most = points(MAX_TRAJECTORY_POINTS)  # the cap itself is taken and followed
    session.submit_command('g/joint_trajectory', (['shoulder', 'elbow', 'wrist'], 0, most))
    assert most.read >= MAX_TRAJECTORY_POINTS
    session.advance(100)
    assert session.commands.following and session.error is None
    assert session.commands.rejected == {'limit': 1}


def test_a_position_time_constant_below_the_step_is_refused_and_the_step_itself_converges(
        tmp_path):
    # The gripper's finger with an effort limit out of reach (1e6 N): at h = 1 ms a time
    # constant of h/3.5 drove it to its limit and held it there, h/3.3 stopped the world (the
    # projection did not converge); neither was refused.
    urdf = tmp_path / 'gripper.urdf'
    urdf.write_text(open(GRIPPER).read().replace('effort="20"', 'effort="1e6"'))
    name = 'robots.gripper.joints.finger_left.position_time_constant_s'

    def session(tau):
        return SimSession(NodeConfig.from_parameters({
            'robot_names': ['gripper'], 'robots.gripper.urdf_path': str(urdf), name: tau}))

    with pytest.raises(ConfigError) as caught:
        session(0.000999)
    assert str(caught.value) == (
        f'parameter {name} = 0.000999 s: must be >= the step, timestep_s = 0.001 s: a motor '
        'faster than a step overshoots, and below ~timestep_s / 3 drives the joint to its '
        'limit or stops the world')
    # At the bound the finger goes to its target as the critically damped closed form
    # e(t) = e0 (1 + t/τ) exp(-t/τ) does, from e0 = -0.1 m at rest: never past it, its error
    # over the first five steps (where the move is made) within 5 % of the closed form's
    # (measured: 4 %, the step's own dynamics at ω h = 1; later the step's decay per step,
    # ~0.8, outruns e^-1 by a little), and to 1e-9 m in 30 steps (measured 2e-13 m).
    s = session(0.001)
    s.paused = False
    s.submit_command('gripper/joint_command', (['finger_left'], [0.1], [], []))
    for k in range(1, 31):
        s.advance(1)
        q = s.simulator.joint_positions(0)[0]
        assert q <= 0.1, (k, q)
        if k <= 5:
            exact = -0.1 * (1 + k) * math.exp(-k)
            assert abs((q - 0.1) - exact) <= 0.05 * abs(exact), (k, q)
    assert abs(q - 0.1) < 1e-9 and s.error is None
