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
Joints between the bodies of a world (``joint_names``, ``joints.<name>.*``): read, refused, run.

In process, through :meth:`NodeConfig.from_parameters` (what the node calls at start): every bad
value is one line naming the parameter, its value and unit; what the core refuses in a world
with contact surfaces under the parameter's name when the simulator is built (the node's
first-step check), whatever the core accepts later. The readout is the core's joint
coordinate (a continuous joint's counting whole turns, a wheel's), and ``joint_command`` is
checked as a robot's and drives the core's motors (a position hold against gravity, a velocity
target). The node's topics,
``/tf``, the closed forms and replay are in ``tests/ros/test_node_world_joints.py``.
"""

import math
from pathlib import Path

import numpy as np
import pytest
from rbd_ros.core import ConfigError, ModelError
from rbd_ros.core.contact.simulator import WorldSimulator
from rbd_ros.core.joints.model import joint_position
from rbd_ros.core.joints.readout import KINDS as MOVING_KINDS
from rbd_ros.msgs import outputs
from rbd_ros.sim.build import kernel_kind, make_simulator
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.joint_commands import CommandRejected
from rbd_ros.sim.session import SimSession
from rbd_ros.sim.world_joints import JointedWorldSimulator, KINDS
from tests.core.joints.closed_forms import pendulum_period
import yaml

REPO = Path(__file__).resolve().parents[2]
PENDULUM = REPO / 'msg_config' / 'pendulum_world.yaml'


def _pendulum(**changes):
    """Return the parameters of ``msg_config/pendulum_world.yaml`` with ``changes`` applied."""
    params = yaml.safe_load(PENDULUM.read_text())['/**']['ros__parameters']
    params.update(changes)
    return params


def test_a_world_with_joints_compiles_its_own_kind_and_says_so():
    # The contact step with joints is a specialisation of its own (minutes cold): a node on a
    # world with joint_names must not take the plain contact step's mark on disk for it, and
    # sit silent while it compiles.
    from rbd_ros.core import jitcache, warmup
    assert kernel_kind(NodeConfig.from_parameters(_pendulum())) == 'world_joints'
    plain = {k: v for k, v in _pendulum().items()
             if k != 'joint_names' and not k.startswith('joints.')}
    assert kernel_kind(NodeConfig.from_parameters(plain)) == 'contact'
    assert 'world_joints' in warmup.KINDS and 'world_joints' in jitcache.KIND_MODULES
    assert 'the contact step with joints' in jitcache.compile_notice('world_joints')


def test_the_pendulum_file_reads_its_hinge_in_the_bodies_frames():
    config = NodeConfig.from_parameters(_pendulum())
    (hinge,) = config.world_joints
    joint = hinge.joint
    assert (hinge.name, joint.kind, joint.parent, joint.child) == ('hinge', 'revolute', None, 0)
    pivot = np.array([0.0, 0.0, 1.2])
    bob = config.bodies[0].initial_state.position_w
    # identity orientation: the child's origin is the pivot minus its position, exactly
    assert joint.origin_child_b.tolist() == (pivot - bob).tolist()
    assert joint.origin_parent_b.tolist() == pivot.tolist()
    assert joint.axis_b.tolist() == [0.0, 1.0, 0.0]
    assert joint.q_rest.tolist() == [1.0, 0.0, 0.0, 0.0]
    assert (joint.lower, joint.upper, joint.effort_limit) == (None, None, None)
    names = {spec.name for spec in config.all_specs()}
    assert {'joint_names', 'joints.hinge.type', 'joints.hinge.position_time_constant_s'} <= names
    # the recording's parameters give the same joints back
    again = NodeConfig.from_parameters(config.to_parameters())
    assert repr(again.world_joints) == repr(config.world_joints)


def test_an_axis_whose_norm_overflows_is_still_its_direction():
    # (0, 1e300, 1e300) is finite; its squared norm overflowed: numpy warnings on stderr and
    # an unnamed 'could not be projected' at start
    (hinge,) = NodeConfig.from_parameters(
        _pendulum(**{'joints.hinge.axis': [0.0, 1e300, 1e300]})).world_joints
    np.testing.assert_allclose(hinge.joint.axis_b, [0.0, math.sqrt(0.5), math.sqrt(0.5)],
                               rtol=0, atol=3e-16)


def test_a_joint_between_two_bodies_is_in_the_parent_frame_and_zero_at_the_initial_poses():
    turned = [0.0, 0.0, math.sin(0.25), math.cos(0.25)]  # 0.5 rad about z, [x, y, z, w]
    params = {k: v for k, v in _pendulum().items() if not k.startswith('joints.hinge.')}
    config = NodeConfig.from_parameters({**params, **{
        'joint_names': ['slide'],
        'bodies.target.initial_orientation': turned,
        'joints.slide.type': 'prismatic', 'joints.slide.parent': 'target',
        'joints.slide.child': 'bob', 'joints.slide.position': [0.0, 0.0, 0.6],
        'joints.slide.axis': [2.0, 0.0, 0.0]}})
    (slide,) = config.world_joints
    bodies = config.bodies
    joint = slide.joint
    assert (joint.parent, joint.child) == (1, 0)
    # the world axis x seen from the box turned by 0.5 rad about z
    np.testing.assert_allclose(joint.axis_b, [math.cos(0.5), -math.sin(0.5), 0.0], atol=1e-15)
    poses = [v for b in (bodies[1], bodies[0])
             for v in (b.initial_state.position_w, b.initial_state.orientation_wb)]
    q = joint_position(joint, *poses)
    assert abs(q[0]) < 1e-15


def _refusal(changes, exc_type=(ConfigError, ModelError)):
    with pytest.raises(exc_type) as info:
        NodeConfig.from_parameters(_pendulum(**changes))
    line = str(info.value)
    assert '\n' not in line and len(line) < 400, line
    return line


#: id -> (parameter changes, the start of the one line).
REFUSED = {
    'unknown_parent': ({'joints.hinge.parent': 'door'},
                       "parameter joints.hinge.parent = 'door': must be one of body_names"),
    'unknown_child': ({'joints.hinge.child': 'door'},
                      "parameter joints.hinge.child = 'door': must be one of body_names"),
    'child_is_the_world': ({'joints.hinge.child': 'world'},
                           "parameter joints.hinge.child = 'world': the world does not move"),
    'jointed_to_itself': ({'joints.hinge.parent': 'bob'},
                          "parameter joints.hinge.parent = 'bob': is the child too"),
    'duplicate_names': ({'joint_names': ['hinge', 'hinge']},
                        "parameter joint_names = ['hinge', 'hinge']: 'hinge' is listed twice"),
    'bad_name': ({'joint_names': ['a-b']}, "parameter joint_names = ['a-b']: 'a-b'"),
    'zero_axis': ({'joints.hinge.axis': [0.0, 0.0, 0.0]},
                  'parameter joints.hinge.axis = [0.0, 0.0, 0.0]: has zero length'),
    'axis_of_two': ({'joints.hinge.axis': [0.0, 1.0]},
                    'parameter joints.hinge.axis = [0.0, 1.0]: must have 3 values'),
    'position_of_two': ({'joints.hinge.position': [0.0, 1.2]},
                        'parameter joints.hinge.position = [0.0, 1.2] m: must have 3 values'),
    # finite but 1e300 m away: the start's projection failed without naming the joint
    'position_far_away': ({'joints.hinge.position': [1e300, 0.0, 1.2]},
                          'parameter joints.hinge.position = [1e+300, 0.0, 1.2] m: every '
                          'component must be within ±1e+07 m'),
    'lower_above_upper': ({'joints.hinge.lower': 1.0, 'joints.hinge.upper': 0.5},
                          'parameter joints.hinge.lower = 1.0 rad or m: must be <= upper'),
    'unknown_type': ({'joints.hinge.type': 'hinge'},
                     "parameter joints.hinge.type = 'hinge': must be one of "
                     + ', '.join(KINDS)),
    'no_type': ({'joints.hinge.type': ''}, "parameter joints.hinge.type = '': must be one of"),
    'negative_damping': ({'joints.hinge.damping': -1.0},
                         'parameter joints.hinge.damping = -1.0 N·m·s/rad or N·s/m: must be'),
    'time_constant_0': ({'joints.hinge.position_time_constant_s': 0.0},
                        'parameter joints.hinge.position_time_constant_s = 0.0 s: must be > 0'),
    'time_constant_below_the_step': (
        {'joints.hinge.position_time_constant_s': 0.0005},
        'parameter joints.hinge.position_time_constant_s = 0.0005 s: must be >= the step, '
        'timestep_s = 0.001 s'),
    'not_a_number': ({'joints.hinge.upper': 'high'},
                     "parameter joints.hinge.upper = 'high' rad or m: must be a number"),
    'limits_on_a_continuous_joint': (
        {'joints.hinge.type': 'continuous', 'joints.hinge.lower': -1.0},
        'parameter joints.hinge.lower = -1.0 rad or m: a continuous joint has no limits'),
    'friction_on_a_fixed_joint': (
        {'joints.hinge.type': 'fixed', 'joints.hinge.friction': 0.5},
        'parameter joints.hinge.friction = 0.5 N·m or N: a fixed joint takes no friction'),
    'cone_on_a_revolute_joint': (
        {'joints.hinge.cone_rad': 0.5},
        'parameter joints.hinge.cone_rad = 0.5 rad: only a spherical joint has a cone limit'),
    'cone_beyond_pi': ({'joints.hinge.type': 'spherical', 'joints.hinge.cone_rad': 4.0},
                       'parameter joints.hinge.cone_rad = 4.0 rad: must be in [0, 3.14159]'),
    'negative_cone': ({'joints.hinge.type': 'spherical', 'joints.hinge.cone_rad': -0.1},
                      'parameter joints.hinge.cone_rad = -0.1 rad: must be 0 (none) or in '
                      '(0, π], spherical joints only'),
    'a_joint_not_listed': ({'joints.door.type': 'revolute'},
                           "parameter joints.door.type = 'revolute': unknown parameter name"),
    'without_body_names': (
        {'body_names': [], 'bodies.bob.shape': None},
        "parameter joint_names = ['hinge']: joints join the bodies of a world"),
}


@pytest.mark.parametrize('case', sorted(REFUSED))
def test_a_bad_joint_parameter_is_refused_in_one_line_naming_it(case):
    changes, start = REFUSED[case]
    if case == 'without_body_names':  # a single body: keep only the top-level parameters
        params = {k: v for k, v in _pendulum().items() if not k.startswith('bodies.')}
        params['body_names'] = []
        params['initial_position'] = [0.0, 0.0, 1.0]
        with pytest.raises((ConfigError, ModelError)) as info:
            NodeConfig.from_parameters(params)
        line = str(info.value)
    else:
        line = _refusal(changes)
    assert line.startswith(start), line


def _beside_arm(**changes):
    """Return the pendulum world with msg_config/urdf/arm3.urdf beside it (1 m along y)."""
    return _pendulum(**{'robot_names': ['arm'], 'robots.arm.initial_position': [0.0, 1.0, 0.0],
                        'robots.arm.urdf_path': str(REPO / 'msg_config' / 'urdf' / 'arm3.urdf'),
                        **changes})


def test_joints_beside_robots_are_the_contact_worlds_first_joints_read_out_apart():
    config = NodeConfig.from_parameters(_beside_arm())
    assert [j.name for j in config.world_joints] == ['hinge'] and len(config.robots) == 1
    session = SimSession(config)
    world = session.simulator
    # the world's hinge first, then the arm's joints by their core names
    assert [j.name for j in world.joints[:2]] == ['hinge', 'arm/shoulder']
    session.submit_command('joint_command', (['hinge'], [0.0], [], []))
    session.submit_command('arm/joint_command', (['elbow'], [], [], [0.5]))
    session.advance(10)
    # each group's readout and command are its own: the arm's index 0, the world's 1
    hinge_q, _, hinge_effort = world.joint_states(1)
    assert abs(hinge_q[0]) <= 1e-12 and hinge_effort[0] > 5.0
    assert world.joint_states(0)[2] == [0.0, 0.5, 0.0]
    assert len(world.joint_wrenches(1)) == 1 and len(world.joint_wrenches(0)) == 5  # URDF's
    assert world.link_poses(1) == []
    with pytest.raises(CommandRejected, match='shoulder'):
        session.submit_command('joint_command', (['shoulder'], [0.1], [], []))


@pytest.mark.parametrize('field, value', [('child', 'hand'), ('parent', 'arm/upper')])
def test_a_world_joint_naming_a_robots_link_is_refused_in_one_line(field, value):
    with pytest.raises(ConfigError) as info:
        NodeConfig.from_parameters(_beside_arm(**{f'joints.hinge.{field}': value}))
    link = value.rsplit('/', 1)[-1]
    world = " or 'world'" if field == 'parent' else ''
    assert str(info.value) == (
        f"parameter joints.hinge.{field} = {value!r}: is link '{link}' of robot 'arm', not a "
        f"body: a world joint joins the bodies of body_names (bob, target){world}; a robot's "
        'links are joined by its URDF')


@pytest.mark.parametrize('field, value, unit', [('lower', -1.0, 'rad or m'),
                                                ('damping', 0.5, 'N·m·s/rad or N·s/m'),
                                                ('friction', 0.25, 'N·m or N')])
def test_what_the_core_refuses_in_a_world_is_named_as_the_parameter(field, value, unit):
    changes = {f'joints.hinge.{field}': value}
    if field == 'lower':
        changes['joints.hinge.upper'] = 1.0
    config = NodeConfig.from_parameters(_pendulum(**changes))
    try:
        simulator = make_simulator(config)
    except (ConfigError, ModelError) as exc:  # the core takes no such row in a world yet
        line = str(exc)
        assert line.startswith(f'parameter joints.hinge.{field} = {value!r} {unit}: '), line
        assert '\n' not in line and "joint 'hinge'" not in line, line
    else:  # the core accepts it: the node needs no change
        assert getattr(simulator.joints[0], field) == value


def test_a_world_without_joints_is_todays_world():
    params = yaml.safe_load((REPO / 'msg_config' / 'stack.yaml').read_text())
    config = NodeConfig.from_parameters(params['/**']['ros__parameters'])
    assert config.world_joints == ()
    assert type(make_simulator(config)) is WorldSimulator
    kinds = outputs.sample_builder(config).kinds
    assert not [k for k in kinds if 'joint' in k], kinds


def test_the_readout_is_the_cores_joint_coordinate_and_bad_commands_are_rejected():
    config = NodeConfig.from_parameters(_pendulum())
    session = SimSession(config)
    session.paused = False
    world = session.simulator
    assert isinstance(world, JointedWorldSimulator)
    builder = outputs.sample_builder(config)
    assert builder.kinds[-4:] == ('joint_states', 'joint_wrenches', 'poses', 'tf')
    assert [j.kind in MOVING_KINDS for j in world.joints] == [True]
    while session.time_ns < 200_000_000:
        session.advance(1000)
    (q,), (qd,), (effort,) = world.joint_states()
    state = world.body_state(0)
    expected = joint_position(world.joints[0], None, None, state.position_w,
                              state.orientation_wb)
    assert abs(q - expected[0]) < 1e-14 and qd < 0.0 and effort == 0.0  # no motor
    message = builder.robot_message('joint_states', session.time_ns, world)
    assert list(message.name) == ['hinge'] and list(message.position) == [q]
    commands = session.commands
    assert list(commands.inputs) == ['joint_command']
    with pytest.raises(CommandRejected) as info:
        session.submit_command('joint_command', (['door'], [0.1], [], []))
    assert info.value.reason == 'unknown_joint'
    # A world's joints are its joint_names, not a robot's (the message said "of this robot").
    assert str(info.value) == ("joint_command: name[0]: 'door' is not a moving joint of the "
                               "world's joint_names (hinge)")
    with pytest.raises(CommandRejected) as info:
        session.submit_command('joint_command', (['hinge'], [math.inf], [], []))
    assert info.value.reason == 'non_finite'
    assert commands.received_total == 2 and commands.rejected == {'unknown_joint': 1,
                                                                  'non_finite': 1}


@pytest.mark.parametrize('integrator', ['midpoint_cayley', 'symplectic_euler_quat_exp'])
def test_a_position_command_holds_the_ball_where_it_was_released(integrator):
    # joint_command through the session (as the node submits it) on the core's motor: a
    # position target of 0 (the release pose, 45 deg up) from rest is the critically damped
    # response with e0 = 0, so the hinge stays at 0 and its motor carries gravity's torque
    # about the hinge, m g L sin(theta0) = 5.549 N m (positive: gravity turns it negative,
    # towards the bottom at -theta0). Bounds: the pre-stabilization lands the coordinate on
    # the response to PROJECTION_TOL (1e-13), and a static hold's effort is gravity's to
    # round-off (1e-9 relative is a wide margin for it).
    config = NodeConfig.from_parameters(_pendulum(integrator=integrator))
    session = SimSession(config)
    world = session.simulator
    session.submit_command('joint_command', (['hinge'], [0.0], [], []))
    session.paused = False
    while session.time_ns < 1_000_000_000:
        session.advance(1000)
    (q,), (qd,), (effort,) = world.joint_states()
    hold = 1.0 * 9.81 * 0.8 * math.sin(math.pi / 4.0)
    print(f'{integrator}: q {q:.3g} rad, rate {qd:.3g} rad/s, effort - m g L sin theta0 '
          f'{effort - hold:.3g} N m')
    assert abs(q) <= 1e-12 and abs(qd) <= 1e-9
    assert effort == pytest.approx(hold, rel=1e-9)
    assert session.commands.received_total == 1 and session.commands.rejected == {}
    # a velocity command then turns it at that rate: q grows by v t (the velocity row)
    session.submit_command('joint_command', (['hinge'], [], [0.5], []))
    start = session.time_ns
    while session.time_ns < start + 200_000_000:
        session.advance(1000)
    (q,), (qd,), _ = world.joint_states()
    assert qd == pytest.approx(0.5, abs=1e-9) and q == pytest.approx(0.1, abs=1e-9)


def test_a_damped_world_joint_decays_as_its_closed_form():
    # The pendulum file's ball alone, no gravity, spun about its hinge at w0 with
    # joints.hinge.damping = c: joint_states' rate is w0 exp(-c t / I_pivot), I_pivot =
    # m L^2 + 2/5 m r^2, at every sample. The contact step takes the damping's exact flow at
    # each half kick, so what is left is round-off, a few ulp a step: 1e-12 relative after
    # 1000 steps (the core's test measures below 1e-14).
    params = {k: v for k, v in _pendulum().items() if not k.startswith('bodies.target.')}
    w0, c, length, radius = 2.0, 0.3, 0.8, 0.1
    theta0 = math.pi / 4.0
    lever = (-length * math.sin(theta0), 0.0, -length * math.cos(theta0))  # pivot to ball
    params.update({'gravity': [0.0, 0.0, 0.0], 'body_names': ['bob'],
                   'bodies.bob.initial_angular_velocity': [0.0, w0, 0.0],
                   # v = w x lever
                   'bodies.bob.initial_linear_velocity': [w0 * lever[2], 0.0, -w0 * lever[0]],
                   'joints.hinge.damping': c})
    session = SimSession(NodeConfig.from_parameters(params))
    session.paused = False
    world = session.simulator
    inertia = length * length + 0.4 * radius * radius
    worst = 0.0
    while session.time_ns < 1_000_000_000:
        session.advance(100)
        (_,), (rate,), (effort,) = world.joint_states()
        expected = w0 * math.exp(-c * session.time_ns * 1e-9 / inertia)
        worst = max(worst, abs(rate / expected - 1.0))
        assert effort == 0.0   # no motor: the damping is not a motor's effort
    assert worst <= 1e-12, worst


def test_a_ball_joints_cone_stops_the_ball_dead_on_its_rim():
    # The pendulum file's ball alone on a ball joint (.type spherical) whose .axis points from
    # the pivot to the ball (45 deg out), with .cone_rad = 0.3: released from rest it swings
    # down in its plane and the cone stops it 0.3 rad on (the axis in the child is the same
    # line at the initial pose), pi/4 - 0.3 rad off the vertical, where gravity holds it.
    # The contact step's stop is inelastic and lands it on the rim to its 1e-13: after the
    # stop the ball's angle is the rim's to 1e-12 rad and its speed 1e-12 m/s, and the energy
    # left is the potential at the rim to 1e-12 J: the stop took all of
    # m g L (cos(pi/4 - 0.3) - cos(pi/4)). Measured: 1.1e-16 (angle and speed), 1.3e-15 J.
    theta0, cone, length, pivot = math.pi / 4.0, 0.3, 0.8, (0.0, 0.0, 1.2)
    lever = (-length * math.sin(theta0), 0.0, -length * math.cos(theta0))
    params = {k: v for k, v in _pendulum().items() if not k.startswith('bodies.target.')}
    params.update({'body_names': ['bob'], 'joints.hinge.type': 'spherical',
                   'joints.hinge.axis': list(lever), 'joints.hinge.cone_rad': cone})
    config = NodeConfig.from_parameters(params)
    assert config.world_joints[0].joint.cone_rad == cone
    session = SimSession(config)
    session.paused = False
    world = session.simulator
    mass = world.bodies[0].model.mass_kg
    g = 9.81

    def angle():   # the ball's angle off the downward vertical, towards -x
        d = world.body_state(0).position_w - np.asarray(pivot)
        return math.atan2(-d[0], -d[2])

    def energy():
        s = world.body_state(0)
        return s.kinetic_energy(world.bodies[0].model) + mass * g * s.position_w[2]
    e0 = energy()
    while world.held_limits != [1]:
        session.advance(1)
        assert angle() >= theta0 - cone - 1e-12
        assert session.time_ns < 1_000_000_000
    rim = theta0 - cone
    worst = 0.0
    for _ in range(300):
        session.advance(1)
        worst = max(worst, abs(angle() - rim),
                    np.abs(world.body_state(0).linear_velocity_w).max())
    assert worst <= 1e-12, worst
    lost = mass * g * length * (math.cos(rim) - math.cos(theta0))
    assert abs(e0 - energy() - lost) <= 1e-12, (e0 - energy(), lost)
    assert world.joint_error()[1] <= 1e-12


def test_joint_wrenches_are_what_holds_a_chain_at_rest_and_a_swinging_ball():
    # Two balls hanging in a chain: the top hinge carries both weights, the lower one the
    # bottom ball's (parent on child, in the child's frame, about the joint point).
    params = {k: v for k, v in _pendulum().items() if not k.startswith('joints.')}
    params.update({
        'body_names': ['bob', 'target'], 'bodies.bob.initial_position': [0.0, 0.0, 1.0],
        'bodies.target.shape': 'sphere', 'bodies.target.dimensions_m': [0.1],
        'bodies.target.initial_position': [0.0, 0.0, 0.6], 'bodies.target.mass_kg': 0.5,
        'joint_names': ['top', 'low'],
        'joints.top.type': 'revolute', 'joints.top.child': 'bob',
        'joints.top.position': [0.0, 0.0, 1.4], 'joints.top.axis': [0.0, 1.0, 0.0],
        'joints.low.type': 'continuous', 'joints.low.parent': 'bob',
        'joints.low.child': 'target', 'joints.low.position': [0.0, 0.0, 0.8],
        'joints.low.axis': [0.0, 1.0, 0.0]})
    world = make_simulator(NodeConfig.from_parameters(params))
    assert all(math.isnan(v) for row in world.joint_wrenches() for v in row)  # no step yet
    world.step(20)
    top, low = world.joint_wrenches()
    g = 9.81
    np.testing.assert_allclose(top, [0.0, 0.0, 1.5 * g, 0.0, 0.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(low, [0.0, 0.0, 0.5 * g, 0.0, 0.0, 0.0], atol=1e-12)
    world.reset()
    assert all(math.isnan(v) for row in world.joint_wrenches() for v in row)

    # The file's ball swinging: against the closed form averaged over the last step (the
    # message is the step's average), ball frame: m g cos θ + m L θ̇² towards the pivot,
    # m g sin θ (1 - m L² / I_pivot) across, no torque about the hinge point.
    config = NodeConfig.from_parameters(_pendulum())
    world = make_simulator(config)
    pivot = np.array([0.0, 0.0, 1.2])
    offset = pivot - config.bodies[0].initial_state.position_w
    u = offset / np.linalg.norm(offset)
    m, radius, length = 1.0, 0.1, 0.8
    i_pivot = m * length ** 2 + 0.4 * m * radius ** 2

    def closed_form():
        (q,), (rate,), _ = world.joint_states()
        theta = math.pi / 4 + q
        return (m * g * math.cos(theta) + m * length * rate * rate,
                m * g * math.sin(theta) * (1.0 - m * length ** 2 / i_pivot))
    world.step(299)
    before = closed_form()
    world.step(1)
    after = closed_form()
    (row,) = world.joint_wrenches()
    force, torque = np.array(row[:3]), np.array(row[3:])
    radial = force @ u
    across = np.linalg.norm(force - radial * u)
    # O(h²) of a step average against the two ends' mean: (h²/8) F'' ~ 1e-7 F (h = 1 ms);
    # the integrator's own O((ω h)²) ~ 1e-5 of the force besides. Measured: 1.1e-6 of the
    # radial force, 5.0e-6 N across, 4.0e-6 N m.
    assert abs(radial - 0.5 * (before[0] + after[0])) < 2e-5 * before[0], (radial, before, after)
    assert abs(across - 0.5 * (before[1] + after[1])) < 5e-5, (across, before, after)
    assert np.linalg.norm(torque) < 1e-5, torque


def _four_bar():
    """
    Return the parameters of a parallelogram four-bar: a closed loop of three 1 kg balls.

    Balls of r = 0.05 m under gravity. Cranks ``a`` and ``b`` hang from hinges to the world at
    x = 0 and 0.6 m (z = 1.3 m), their balls l = 0.3 m below; the coupler ball ``c`` is hinged
    to both cranks Lc = 0.4 m below their pivots, so it translates on a circle. The coupler is
    launched at 1 m/s along x.
    """
    params = {'gravity': [0.0, 0.0, -9.81], 'body_names': ['a', 'b', 'c'],
              'joint_names': ['ga', 'gb', 'ac', 'bc'],
              'bodies.c.initial_linear_velocity': [1.0, 0.0, 0.0]}
    for name, position in (('a', [0.0, 0.0, 1.0]), ('b', [0.6, 0.0, 1.0]),
                           ('c', [0.3, 0.0, 0.9])):
        params.update({f'bodies.{name}.shape': 'sphere', f'bodies.{name}.dimensions_m': [0.05],
                       f'bodies.{name}.initial_position': position})
    for name, parent, child, position in (
            ('ga', 'world', 'a', [0.0, 0.0, 1.3]), ('gb', 'world', 'b', [0.6, 0.0, 1.3]),
            ('ac', 'a', 'c', [0.0, 0.0, 0.9]), ('bc', 'b', 'c', [0.6, 0.0, 0.9])):
        params.update({f'joints.{name}.type': 'revolute', f'joints.{name}.parent': parent,
                       f'joints.{name}.child': child, f'joints.{name}.position': position,
                       f'joints.{name}.axis': [0.0, 1.0, 0.0]})
    return params


def test_a_closed_loop_swings_with_its_closed_form_period_and_reports_no_wrenches():
    world = make_simulator(NodeConfig.from_parameters(_four_bar()))
    g, m, r, l, lc = 9.81, 1.0, 0.05, 0.3, 0.4
    # One coordinate θ (both cranks): kinetic ½ I θ̇², I = 2 m (l² + 2/5 r²) + m Lc² (the
    # coupler translates at Lc θ̇); potential -(2 m l + m Lc) g cos θ: a pendulum of
    # L_eq = I / (2 m l + m Lc). The start's projection onto the joints keeps the generalized
    # momentum m Lc v: θ̇0 = m Lc v / I, and the amplitude follows from the energy.
    inertia = 2.0 * m * (l * l + 0.4 * r * r) + m * lc * lc
    moment = 2.0 * m * l + m * lc
    rate0 = m * lc * 1.0 / inertia
    amplitude = math.acos(1.0 - 0.5 * inertia * rate0 * rate0 / (moment * g))
    period = pendulum_period(inertia / moment, amplitude, g)
    world.reset()   # projects now: a world's projection onto its joints waits for a step
    q, rates, _ = world.joint_states()
    assert q == [0.0, 0.0, 0.0, 0.0]
    # about +y a swing towards +x is negative; the coupler turns back against the cranks
    assert abs(rates[0] + rate0) < 1e-12 and rates[1] == rates[0] and rates[2] == -rates[0]
    up, previous, worst, step = [], 0.0, 0.0, 0
    while len(up) < 2:  # the crank's upward zero crossings, one period apart
        world.step(1)
        step += 1
        (qa, qb, qac, qbc), _, _ = world.joint_states()
        worst = max(worst, abs(qa - qb), abs(qac + qa), *world.joint_error())
        if previous < 0.0 <= qa:
            up.append((step - 1 + previous / (previous - qa)) * 1e-3)
        previous = qa
    # midpoint_cayley keeps a pendulum's period to (ω h)²/7 ~ 4e-6 relative at ω = 5.4 rad/s,
    # h = 1 ms; the linear interpolation at θ = 0 (θ'' = 0) adds O(h³). Measured 1.5e-6 s.
    assert abs((up[1] - up[0]) - period) < 1e-5, (up, period)
    assert worst <= 1e-12, worst  # the cranks turn together: the loop holds
    assert all(math.isnan(v) for row in world.joint_wrenches() for v in row)  # a loop's split


def test_a_loop_beside_a_robot_leaves_the_robots_wrenches_alone():
    # The four-bar beside arm3 hanging at rest 1 m along y (fixed to the world): the loop's
    # wrenches have no unique split (NaN), the arm's joints are a tree of their own and keep
    # theirs: at rest each joint carries the weight below it, the shoulder 3 m g = 29.43 N up
    # (arm3's three 1 kg links), in its child link's frame (not turned at rest).
    params = {**_four_bar(), 'robot_names': ['arm'],
              'robots.arm.initial_position': [0.0, 1.0, 0.0],
              'robots.arm.urdf_path': str(REPO / 'msg_config' / 'urdf' / 'arm3.urdf')}
    world = make_simulator(NodeConfig.from_parameters(params))
    world.step(5)
    loop = world.joint_wrenches(1)
    assert len(loop) == 4 and all(math.isnan(v) for row in loop for v in row)
    arm = world.joint_wrenches(0)  # mount_joint, shoulder, elbow, wrist, tool joint
    assert all(math.isfinite(v) for row in arm for v in row), arm
    # The momentum over a step of a body at rest: round-off of m Δv/h (~1e-16 m/s / 1e-3 s
    # per kg) and of the joint impulses; 1e-9 N leaves margin.
    for joint, carried in ((1, 3), (2, 2), (3, 1)):
        np.testing.assert_allclose(arm[joint][:3], (0.0, 0.0, carried * 9.81), rtol=0,
                                   atol=1e-9)


def _wheel(integrator, omega):
    """Return a wheel on a continuous axle to the world, spun at ``omega`` rad/s, no gravity."""
    return {'gravity': [0.0, 0.0, 0.0], 'integrator': integrator, 'body_names': ['wheel'],
            'bodies.wheel.shape': 'cylinder', 'bodies.wheel.dimensions_m': [0.3, 0.05],
            'bodies.wheel.initial_position': [0.0, 0.0, 1.0],
            'bodies.wheel.initial_angular_velocity': [0.0, 0.0, omega],
            'joint_names': ['axle'], 'joints.axle.type': 'continuous',
            'joints.axle.child': 'wheel', 'joints.axle.position': [0.0, 0.0, 1.0],
            'joints.axle.axis': [0.0, 0.0, 1.0]}


@pytest.mark.parametrize('integrator, omega, chunk', [
    ('symplectic_euler_quat_exp', 20.0, 100), ('symplectic_euler_quat_exp', 3000.0, 7),
    ('midpoint_cayley', 20.0, 100), ('midpoint_cayley', 3000.0, 7)])
def test_a_continuous_joint_counts_its_turns(integrator, omega, chunk):
    # A wheel spun about its axle (a principal axis: ω stays constant, no gravity) turns by the
    # integrator's rotation of ω h every step: exactly ω h for the exponential map, the Cayley
    # map's 2 atan(ω h / 2) for midpoint_cayley. joint_states reads the sum, not wrapped: 20
    # rad (3.2 turns) after 1 s at 20 rad/s; at 3000 rad/s (3 rad a step, just below π) read
    # every 7 steps (21 rad, 3.3 turns, between two readouts), 478 turns (313 with Cayley):
    # the count is kept every step, not every readout. Bound: the running angle is the twist
    # read from the orientation plus whole turns, so it is off by the orientation's round-off
    # (a product a step, ~eps each: a random walk of √1000 eps ~ 1e-14 rad) and its own
    # rounding (eps |q|, 4 eps for margin). Measured: 3.6e-15 rad at 20 rad, 4.5e-13 rad (1
    # ulp) at 3003 rad. The reset starts the count again from 0.
    world = make_simulator(NodeConfig.from_parameters(_wheel(integrator, omega)))
    h, eps = 1e-3, np.finfo(float).eps
    per_step = omega * h if integrator.endswith('_exp') else 2.0 * math.atan(0.5 * omega * h)
    steps, worst = 0, 0.0
    while steps < 1000:
        world.step(chunk)
        steps += chunk
        (q,), (rate,), _ = world.joint_states()
        error = abs(q - steps * per_step)
        worst = max(worst, error)
        assert error <= 1e-14 + 4.0 * eps * abs(q), (steps, q, steps * per_step)
        assert rate == pytest.approx(omega, rel=1e-14)  # constant to round-off
    print(f'{integrator} at {omega} rad/s: {q!r} rad after {steps} steps, worst error '
          f'{worst:.2g} rad')
    assert abs(q) > 6.0 * math.pi  # over three turns
    world.reset()
    assert world.joint_states()[0] == [0.0]


def test_a_velocity_motor_turns_a_hinge_without_limits_through_pi_and_on():
    # pendulum_world's hinge has no limits: its angle is measured in (−π, π]. Driven at 3 rad/s
    # it passes π at ~1.06 s; the motor's goal for the step, q + v* h, was set before the angle
    # wrapped, so the drifted joint missed it by ~2π and the world paused ("pre-stabilization
    # ... error 3.17"). Now it turns on: at 3 rad/s exactly (the velocity row's coordinate grows
    # by v* h a step, to the projection's 1e-13), through a whole turn and more.
    params = yaml.safe_load((REPO / 'msg_config' / 'pendulum_world.yaml').read_text())[
        '/**']['ros__parameters']
    params = {**params, 'body_names': ['bob']}
    params = {k: v for k, v in params.items() if not k.startswith('bodies.target')}
    session = SimSession(NodeConfig.from_parameters(params))
    session.advance(10)
    session.submit_command('joint_command', (['hinge'], [], [3.0], []))
    session.advance(1)   # the command takes effect at this step's start
    start_ns, (q0,) = session.time_ns, session.simulator.joint_states()[0]
    turned, last = 0.0, q0
    while session.time_ns < 2_500_000_000:  # through π at ~1.06 s, and on past -π
        session.advance(100)
        assert session.error is None, session.error
        (q,), (rate,), _ = session.simulator.joint_states()
        step = q - last
        turned += step - 2.0 * math.pi * math.floor(step / (2.0 * math.pi) + 0.5)
        last = q
        assert abs(rate - 3.0) <= 1e-9, rate
    assert abs(turned - 3.0 * (session.time_ns - start_ns) * 1e-9) <= 1e-9, turned
    assert turned > 2.0 * math.pi   # a whole turn
