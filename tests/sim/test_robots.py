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
Robots of a params file (``robot_names``, ``robots.<name>.*``): read, placed, refused.

The placement is checked against forward kinematics written here from the URDF's numbers (the
arm hangs straight down at zero, so each link's COM sits at the mount height minus the link
lengths above it); every refusal is one line naming the parameter.
"""

import math
import os

import numpy as np
import pytest

from rbd_ros.core import ConfigError, ModelError
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.params import recorded_parameters
from rbd_ros.sim.robots import (DEFAULT_POSITION_TIME_CONSTANT_S, MAX_ROBOTS, read_robots,
                                robot_parameter_specs)

HERE = os.path.dirname(os.path.abspath(__file__))
URDF = os.path.join(os.path.dirname(os.path.dirname(HERE)), 'msg_config', 'urdf')
ARM = os.path.join(URDF, 'arm3.urdf')
G = (0.0, 0.0, -9.81)


#: A wheel on a continuous joint to the world (no limits to hold its position).
WHEEL = ('<robot name="wheel"><link name="world"/><link name="wheel"><inertial><mass '
         'value="1"/><inertia ixx="0.1" iyy="0.1" izz="0.1" ixy="0" ixz="0" iyz="0"/>'
         '</inertial></link><joint name="axle" type="continuous"><parent link="world"/>'
         '<child link="wheel"/><axis xyz="0 0 1"/></joint></robot>')


def _arm(**extra):
    params = {'robot_names': ['arm'], 'robots.arm.urdf_path': ARM}
    params.update({f'robots.arm.{k}': v for k, v in extra.items()})
    return params


def test_an_arm_is_read_placed_and_given_its_joint_parameters():
    (arm,) = read_robots(_arm(**{'joints.elbow.position_time_constant_s': 0.2}), G)
    assert arm.name == 'arm' and arm.joint_names == ('shoulder', 'elbow', 'wrist')
    assert arm.time_constants_s == (DEFAULT_POSITION_TIME_CONSTANT_S, 0.2,
                                    DEFAULT_POSITION_TIME_CONSTANT_S)
    names = {spec.name for spec in arm.specs}
    assert 'robots.arm.joints.wrist.position_time_constant_s' in names
    assert 'robots.arm.urdf_path' in names and 'robot_names' not in names
    # Hanging straight down from the mount at z = 2 m: COMs at 1.75, 1.25, 0.75 m.
    z = [s.position_w[2] for s in arm.placement.states]
    np.testing.assert_allclose(z, (1.75, 1.25, 0.75), atol=1e-12)
    assert all(m.gravity_w.tolist() == list(G) for m in arm.placement.models)
    assert arm.units('shoulder') == ('rad', 'rad/s', 'N m')


def _dynamics(arm):
    """Return ``{joint: (damping, friction)}`` of the arm's core joints."""
    return {j.name: (j.damping, j.friction) for j in arm.placement.joints}


def test_joint_damping_and_friction_come_from_the_urdf_unless_the_parameters_say():
    (arm,) = read_robots(_arm(), G)
    # arm3.urdf: <dynamics damping="0.1" friction="0.05"/> on the shoulder and the elbow only
    dynamics = _dynamics(arm)
    assert dynamics['shoulder'] == dynamics['elbow'] == (0.1, 0.05)
    assert dynamics['wrist'] == (0.0, 0.0)
    specs = {spec.name: spec for spec in arm.specs}
    assert specs['robots.arm.joints.elbow.friction'].default == 0.05
    assert specs['robots.arm.joints.wrist.damping'].default == 0.0
    (arm,) = read_robots(_arm(**{'joints.elbow.damping': 0.3, 'joints.shoulder.friction': 0.0,
                                 'joints.wrist.friction': 0.2}), G)
    dynamics = _dynamics(arm)
    assert dynamics['shoulder'] == (0.1, 0.0) and dynamics['elbow'] == (0.3, 0.05)
    assert dynamics['wrist'] == (0.0, 0.2)


def test_a_recording_carries_the_dynamics_and_an_older_one_replays_without_them():
    params = {**_arm(), 'gravity': list(G)}
    recorded = NodeConfig.from_parameters(params).to_parameters()
    # the values used are recorded, so replay does not depend on the URDF's defaults
    assert recorded['robots.arm.joints.shoulder.damping'] == 0.1
    assert recorded['robots.arm.joints.wrist.friction'] == 0.0
    assert _dynamics(NodeConfig.from_parameters(recorded_parameters(recorded)).robots[0]) \
        == _dynamics(read_robots(_arm(), G)[0])
    # a recording made before they were simulated has no such keys: that run had none
    old = {name: value for name, value in recorded.items()
           if not name.endswith(('.damping', '.friction'))}
    replayed = NodeConfig.from_parameters(recorded_parameters(old)).robots[0]
    assert set(_dynamics(replayed).values()) == {(0.0, 0.0)}


def test_the_root_pose_and_joint_positions_place_the_links():
    quarter = [0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4)]  # 90 deg about z
    (arm,) = read_robots(_arm(initial_position=[1.0, 0.0, 0.0], initial_orientation=quarter,
                              initial_joint_positions=[math.pi / 2, 0.0, 0.0]), G)
    # The shoulder (about the mount's y, which the root turned to world -x) at +90 deg swings
    # the hanging arm from -z to the horizontal: COMs in a line 0.25, 0.75, 1.25 m out.
    p = np.array([s.position_w for s in arm.placement.states])
    np.testing.assert_allclose(p[:, 2], 2.0, atol=1e-12)
    out = p[:, :2] - (1.0, 0.0)
    np.testing.assert_allclose(np.linalg.norm(out, axis=1), (0.25, 0.75, 1.25), atol=1e-12)


def test_robot_description_takes_the_xml_itself():
    with open(os.path.join(URDF, 'pendulum.urdf')) as f:
        xml = f.read()
    (pendulum,) = read_robots({'robot_names': ['p'], 'robots.p.robot_description': xml}, G)
    assert pendulum.robot.source == 'robot_description'
    assert len(pendulum.joint_names) == 1


@pytest.mark.parametrize('params, error, words', [
    ({'robot_names': ['arm']}, ConfigError,
     'robots.arm.urdf_path / robots.arm.robot_description: neither given'),
    (_arm(robot_description='<robot name="x"/>'), ConfigError, 'both given'),
    ({'robot_names': ['arm', 'arm'], 'robots.arm.urdf_path': ARM}, ConfigError,
     "'arm' is listed twice"),
    ({'robot_names': ['9arm']}, ConfigError, "'9arm': letters, digits"),
    ({'robot_names': [f'r{k}' for k in range(MAX_ROBOTS + 1)]}, ConfigError,
     f'names; at most {MAX_ROBOTS}'),
    (_arm(urdf_path='/nonexistent/arm.urdf'), ConfigError,
     "robots.arm.urdf_path: '/nonexistent/arm.urdf' does not exist"),
    (_arm(initial_position=[0.0, 0.0]), ConfigError,
     'parameter robots.arm.initial_position = [0.0, 0.0] m: must have 3 values'),
    # finite but beyond a body's bound: was taken (a root 1e300 m away)
    (_arm(initial_position=[1e300, 0.0, 0.0]), ConfigError,
     'parameter robots.arm.initial_position = [1e+300, 0.0, 0.0] m: every component must be '
     'within ±1e+07 m'),
    (_arm(initial_orientation=[0.0, 0.0, 0.0, 2.0]), ConfigError, 'must be within 1e-3 of 1'),
    (_arm(initial_joint_positions=[0.1]), ConfigError, 'robots.arm.initial_joint_positions'),
    (_arm(initial_joint_positions=[5.0, 0.0, 0.0]), ConfigError,
     'robots.arm.initial_joint_positions[0]: 5.0'),
    # refused up front, named: it was 'the first physics step is not finite', naming nothing
    (_arm(initial_joint_velocities=[0.0, 1e200, 0.0]), ConfigError,
     "robots.arm.initial_joint_velocities[1]: 1e+200 rad/s for joint 'elbow' is beyond "
     '±1e+07 rad/s'),
    ({'robot_names': ['wheel'], 'robots.wheel.robot_description': WHEEL,
      'robots.wheel.initial_joint_positions': [1e300]}, ConfigError,
     "robots.wheel.initial_joint_positions[0]: 1e+300 rad for joint 'axle' is beyond "
     '±1e+07 rad'),
    (_arm(**{'joints.elbow.position_time_constant_s': 0.0}), ConfigError,
     'parameter robots.arm.joints.elbow.position_time_constant_s = 0.0 s: must be > 0'),
    (_arm(initial_position='up'), ConfigError, 'must be a list of numbers'),
    (_arm(**{'joints.elbow.damping': -1.0}), ConfigError,
     'parameter robots.arm.joints.elbow.damping = -1.0 N·m·s/rad or N·s/m: must be >= 0'),
    (_arm(**{'joints.wrist.friction': math.inf}), ConfigError,
     'parameter robots.arm.joints.wrist.friction = inf N·m or N'),
    (_arm(frame_prefix='/arm'), ConfigError,
     "parameter robots.arm.frame_prefix = '/arm': must not start with '/'"),
    (_arm(frame_prefix='arm /'), ConfigError, "parameter robots.arm.frame_prefix = 'arm /'"),
])
def test_bad_robot_parameters_are_refused_in_one_line(params, error, words):
    with pytest.raises(error) as caught:
        read_robots(params, G)
    message = str(caught.value)
    assert words in message, message
    assert '\n' not in message


def _two_arms(**more):
    return {'robot_names': ['a', 'b'], 'robots.a.urdf_path': ARM, 'robots.b.urdf_path': ARM,
            'robots.b.initial_position': [0.0, 1.0, 0.0], **more}


@pytest.mark.parametrize('more, words', [
    # /tf would carry two poses for 'mount', 'upper', ... (one per robot)
    ({}, "parameter robots.b.frame_prefix = '': link 'mount' of robot 'b' would be TF frame "
         "'mount', already the frame of link 'mount' of robot 'a'"),
    ({'robots.a.frame_prefix': 'x/', 'robots.b.frame_prefix': 'x/'},
     "robots.b.frame_prefix = 'x/': link 'mount' of robot 'b' would be TF frame 'x/mount'"),
    ({'robots.b.frame_prefix': 'b/', 'world_frame': 'upper'},
     "robots.a.frame_prefix = '': link 'upper' of robot 'a' would be TF frame 'upper', "
     'already the frame of world_frame'),
])
def test_two_robots_of_one_urdf_need_their_own_frames(more, words):
    with pytest.raises(ConfigError) as caught:
        NodeConfig.from_parameters(_two_arms(**more))
    assert words in str(caught.value) and '\n' not in str(caught.value), str(caught.value)


def test_a_urdf_link_that_cannot_be_a_tf_frame_is_refused():
    # A link named 'base link' was broadcast on /tf as a frame id no one can name back (tf2
    # takes no whitespace); the same rule as world_frame's and every body's, naming the link.
    xml = ('<robot name="r"><link name="base link"><inertial><mass value="1"/><inertia '
           'ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link></robot>')
    with pytest.raises(ConfigError) as caught:
        NodeConfig.from_parameters({'robot_names': ['r'], 'robots.r.robot_description': xml})
    assert str(caught.value) == (
        "parameter robots.r.frame_prefix = '': link 'base link' of robot 'r' would be TF "
        "frame 'base link', which holds ' ' at index 4: a frame id has no whitespace or "
        'control characters'), str(caught.value)


def test_a_robot_named_like_a_body_is_refused():
    # A floating robot's <name>/odom would be the body's <name>/odom: one topic, two sources.
    with pytest.raises(ConfigError) as caught:
        NodeConfig.from_parameters({
            'robot_names': ['box'], 'robots.box.urdf_path': ARM,
            'robots.box.initial_position': [0.0, 0.0, 2.0], 'robots.box.frame_prefix': 'r/',
            'body_names': ['box'], 'bodies.box.shape': 'box',
            'bodies.box.dimensions_m': [0.1, 0.1, 0.1],
            'bodies.box.initial_position': [3.0, 0.0, 0.05], 'ground.enabled': True})
    assert str(caught.value) == (
        "parameter robot_names = ['box']: 'box' is also in body_names: a robot's topics and a "
        "body's are both '<name>/...'; name them apart"), str(caught.value)


def test_a_frame_prefix_names_every_link_frame_but_the_world_link():
    config = NodeConfig.from_parameters(_two_arms(**{'robots.b.frame_prefix': 'right/'}))
    a, b = config.robots
    links = [link.name for link in b.robot.links]
    assert links[0] == 'world' and b.link_frame('world', 'map') == 'map'
    assert [b.link_frame(name, 'map') for name in links[1:]] == [
        'right/' + name for name in links[1:]]
    assert [a.link_frame(name, 'map') for name in links[1:]] == links[1:]
    # A body whose frame is a robot's link frame is refused too.
    with pytest.raises(ConfigError) as caught:
        NodeConfig.from_parameters({
            **_two_arms(**{'robots.b.frame_prefix': 'right/'}), 'body_names': ['box'],
            'bodies.box.shape': 'box', 'bodies.box.dimensions_m': [0.1, 0.1, 0.1],
            'bodies.box.initial_position': [3.0, 0.0, 0.05], 'ground.enabled': True,
            'bodies.box.body_frame': 'right/hand'})
    assert ("link 'hand' of robot 'b' would be TF frame 'right/hand', already the frame of "
            'bodies.box.body_frame') in str(caught.value)


def test_a_moving_link_without_inertial_names_the_file_and_link(tmp_path):
    bad = tmp_path / 'bad.urdf'
    bad.write_text('<robot name="b"><link name="world"/><link name="l"/>'
                   '<joint name="j" type="revolute"><parent link="world"/><child link="l"/>'
                   '<axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/>'
                   '</joint></robot>')
    with pytest.raises(ModelError) as caught:
        read_robots({'robot_names': ['b'], 'robots.b.urdf_path': str(bad)}, G)
    assert str(bad) in str(caught.value) and "'l'" in str(caught.value)


def test_every_robot_parameter_has_a_unit_or_none_and_a_description():
    for spec in robot_parameter_specs('arm'):
        assert spec.name.startswith('robots.arm.') and spec.description
