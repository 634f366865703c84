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
URDF robots in a world with contact (:mod:`rbd_ros.sim.robot_contact`), in process.

Through :meth:`NodeConfig.from_parameters` and :func:`make_simulator` (what the node calls at
start): a floating one-link box robot lands as a free box of the same mass and size does (the
same contact step, the same bits) and rests at its half height; a URDF pendulum in a world
with a ground far below swings as on the joints-only core and with the closed-form period; a
rod pendulum knocks a free box off its spot without ever gaining energy (ε = 0). What the
contact step cannot take yet is refused at start in one line naming the robot's parameter,
the URDF joint or the link. A link's ``<collision>`` elements collide where the URDF puts them
(one offset from the COM, several at once, a mesh beside a box), and a link fixed to the world
is an obstacle (a link jointed to it never touches it nor the links fixed with it).
"""

import math
from pathlib import Path

import numpy as np
import pytest
from rbd_ros.core import ConfigError, layout, ModelError
from rbd_ros.core.inertia import from_shape
from rbd_ros.sim.build import kernel_kind, make_simulator
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.robot_contact import RobotContactWorld
from rbd_ros.sim.robot_world import RobotWorld
from rbd_ros.sim.session import SimSession
from tests.core.joints.closed_forms import pendulum_period
import trimesh
import yaml

REPO = Path(__file__).resolve().parents[2]
PENDULUM_URDF = REPO / 'msg_config' / 'urdf' / 'pendulum.urdf'
G = 9.81
BOX_M, BOX_KG = (0.2, 0.3, 0.1), 2.0
#: Resting contact is speculative: each step's impulses drive a resting corner's φ to 0, so
#: the resting pose is exact but for the round-off of the position and rotation sums (~1e-16
#: per operation on sizes ~0.1 m, a few hundred operations a step, 3000 steps summed in the
#: worst case: ~1e-10 m); as tests/core/contact/test_nonconvex.py's REST_TOL.
REST_TOL = 1e-10


def _box_urdf(collision='<box size="0.2 0.3 0.1"/>', origin='0 0 0'):
    """Return a one-link floating box robot's URDF (the inertia of a uniform box, exactly)."""
    inertia = from_shape('box', BOX_M, BOX_KG).inertia_b
    return f"""<?xml version="1.0"?>
<robot name="crate">
  <link name="crate">
    <inertial>
      <mass value="{BOX_KG!r}"/>
      <inertia ixx="{float(inertia[0, 0])!r}" ixy="0" ixz="0"
               iyy="{float(inertia[1, 1])!r}" iyz="0" izz="{float(inertia[2, 2])!r}"/>
    </inertial>
    <collision><origin xyz="{origin}"/><geometry>{collision}</geometry></collision>
  </link>
</robot>"""


START = [0.0, 0.0, 0.3]
#: A tilt about x and y (x, y, z, w): it lands on a corner, then settles on its big face.
TILT = [math.sin(0.15) * 0.6, math.sin(0.15) * 0.8, 0.0, math.cos(0.15)]


def _ground(**more):
    return {'ground.enabled': True, 'gravity': [0.0, 0.0, -G], 'timestep_s': 0.001, **more}


def _box_robot(**more):
    return NodeConfig.from_parameters(_ground(
        robot_names=['crate'], **{'robots.crate.robot_description': _box_urdf(),
                                  'robots.crate.initial_position': START,
                                  'robots.crate.initial_orientation': TILT}, **more))


def _free_box():
    return NodeConfig.from_parameters(_ground(
        body_names=['crate'], **{'bodies.crate.shape': 'box',
                                 'bodies.crate.dimensions_m': list(BOX_M),
                                 'bodies.crate.mass_kg': BOX_KG,
                                 'bodies.crate.initial_position': START,
                                 'bodies.crate.initial_orientation': TILT}))


def test_a_floating_box_robot_lands_as_a_free_box_and_rests_at_its_half_height():
    robot_config, free_config = _box_robot(), _free_box()
    robot, free = make_simulator(robot_config), make_simulator(free_config)
    assert isinstance(robot, RobotContactWorld)
    # No joint: the plain contact step, as the free box's.
    assert kernel_kind(robot_config) == kernel_kind(free_config) == 'contact'
    worst = 0.0
    for _ in range(300):  # 3 s in 10 ms chunks
        robot.step(10)
        free.step(10)
        worst = max(worst, float(np.abs(robot.world.arrays[0] - free.arrays[0]).max()))
        # its odom (root link frame = body frame here) is the body's state
        assert robot.root_state(0)[:7] == robot.world.arrays[0][:7, 0].tolist()
    print(f'\nfloating box robot vs free box over 3 s: largest state difference {worst:.3e}')
    # The same bodies (mass, the inertia to the bit, the shape, the material) in the same
    # contact step. Only the start differs, by round-off: the robot's orientation goes through
    # a rotation matrix (place_robot's forward kinematics) and back, ~1e-16 off the free
    # body's; landing on a corner and rocking onto a face amplify it (measured 5.2e-14 over
    # 3 s). 1e-12 is far below any physical difference (a mm, a mrad) and above that.
    assert worst < 1e-12
    assert robot.arrays[0].shape == (13, 0)  # no free body
    x = robot.world.arrays[0][:, 0]
    # At rest on its largest face (0.2 m x 0.3 m): its COM half its 0.1 m height above the
    # ground, level, still.
    assert abs(x[2] - BOX_M[2] / 2) <= REST_TOL
    assert abs(abs(x[3]) - 1.0) < 1e-12 or abs(np.hypot(x[4], x[5])) < 1e-9
    assert np.abs(x[7:13]).max() < 1e-9
    assert robot.link_poses(0)[0][0] == tuple(x[:3].tolist())


def test_a_floating_robot_without_joints_has_empty_joint_states():
    # Its joint_states (published and recorded at t = 0) asked the contact step, which has
    # no joints, for its motor efforts: ConfigError 'a world without joints has no motors',
    # so a recorded node (or one with a joint_states subscriber) stopped at start.
    robot = make_simulator(_box_robot())
    assert robot.joint_states(0) == ([], [], [])
    robot.step(10)
    assert robot.joint_states(0) == ([], [], []) and robot.joint_efforts(0).shape == (0,)


def _pendulum(**more):
    return {'robot_names': ['pendulum'],
            'robots.pendulum.urdf_path': str(PENDULUM_URDF),
            'robots.pendulum.initial_joint_positions': [0.5],
            'gravity': [0.0, 0.0, -G], 'timestep_s': 0.001, **more}


def _swing(world, seconds):
    """Return the joint angle every step (rad) over ``seconds``, plain floats."""
    out = []
    for _ in range(round(seconds * 1000)):
        world.step(1)
        out.append(world.joint_states(0)[0][0])
    return np.array(out)


def _period(theta, h=1e-3):
    """Return the mean period (s) between the downward zero crossings of ``theta``."""
    t = []
    for k in range(1, len(theta)):
        if theta[k - 1] > 0.0 >= theta[k]:
            t.append((k - 1 + theta[k - 1] / (theta[k - 1] - theta[k])) * h)
    return (t[-1] - t[0]) / (len(t) - 1)


def test_a_urdf_pendulum_over_a_far_ground_swings_as_on_the_joints_core():
    config = NodeConfig.from_parameters(_pendulum(**{'ground.enabled': True,
                                                     'ground.height_m': -10.0}))
    alone = NodeConfig.from_parameters(_pendulum())
    world, core = make_simulator(config), make_simulator(alone)
    assert isinstance(world, RobotContactWorld) and isinstance(core, RobotWorld)
    assert kernel_kind(config) == 'world_joints' and kernel_kind(alone) == 'joints'
    seconds = 6.5  # three periods and a little
    a, b = _swing(world, seconds), _swing(core, seconds)
    exact = pendulum_period(1.0, 0.5, G)  # L_eq = I_pivot / (m d) = 0.75 / 0.75 = 1 m
    t_world, t_core = _period(a), _period(b)
    diff = float(np.abs(a - b).max())
    print(f'\nURDF pendulum: contact world T = {t_world!r} s, joints core T = {t_core!r} s, '
          f'closed form {exact!r} s; largest angle difference over {seconds} s {diff:.3e} rad')
    # The contact step's kick-drift-kick is second order: a period off by ~ T (ω h)² / 16 ≈
    # 2.04 · (3.1e-3)² / 16 ≈ 1.2e-6 s (measured -1.0e-6 s at h = 1 ms, -2.5e-7 s at 0.5 ms);
    # the crossings are interpolated linearly between samples where θ'' = -ω² sin θ = 0, so
    # that adds nothing at this level. Bounded at 5e-6 s. The joints core (RK4, O(h⁴)) is
    # within 1e-10 s (measured 6.7e-11 s).
    assert abs(t_world - exact) < 5e-6
    assert abs(t_core - exact) < 1e-9
    # The two paths agree to the kick-drift-kick's phase error (the joints core's is far
    # smaller): measured 4.5e-6 rad at h = 1 ms and 1.1e-6 rad at 0.5 ms (second order);
    # bounded at 2e-5 rad, the estimate above with a factor 2 of margin.
    assert diff < 2e-5
    # The rod touched nothing (its one link; the ground is 10 m below).
    assert len(world.contacts) == 0


def test_a_rod_pendulum_knocks_a_box_off_its_spot_and_never_gains_energy():
    # The rod (1.5 m from a pivot 2 m up) sweeps through a 0.2 m box resting on a ground at
    # z = 0.4 m beside the rod's lowest point: the box's top 0.1 m is in the rod's way.
    params = _pendulum(**{
        'ground.enabled': True, 'ground.height_m': 0.4, 'ground.restitution': 0.0,
        'robots.pendulum.restitution': 0.0, 'body_names': ['box'],
        'bodies.box.shape': 'box', 'bodies.box.dimensions_m': [0.2, 0.2, 0.2],
        'bodies.box.mass_kg': 0.5, 'bodies.box.initial_position': [0.13, 0.0, 0.5]})
    config = NodeConfig.from_parameters(params)
    world = make_simulator(config)
    models = [b.model for b in world.world.bodies]
    assert [b.name for b in world.world.bodies][0] == 'box'

    def energy():
        x = world.world.arrays[0]
        total = 0.0
        for i, model in enumerate(models):
            v, w = x[layout.S_VEL:layout.S_VEL + 3, i], x[layout.S_OMEGA:layout.S_OMEGA + 3, i]
            total += 0.5 * model.mass_kg * float(v @ v) + 0.5 * float(w @ model.inertia_b @ w)
            total += model.mass_kg * G * float(x[layout.S_POS + 2, i])
        return total

    e0 = energy()
    energies, box_x, hit = [], [], None
    for k in range(1500):
        world.step(1)
        energies.append(energy())
        box_x.append(float(world.arrays[0][0, 0]))
        if hit is None and any(a != b and min(a, b) == 0 and max(a, b) >= 1
                               for a, b in zip(world.contacts.body_a, world.contacts.body_b)):
            hit = k
    energies = np.array(energies)
    rise = float((energies - e0).max())
    print(f'\nrod knocks box: first touch at step {hit}, box moved {box_x[-1] - 0.13:.4f} m, '
          f'energy {e0:.6f} J -> {energies[-1]:.6f} J, largest rise {rise:.3e} J')
    assert hit is not None
    # Before the touch the rod swings freely: kick-drift-kick keeps its energy to O((ω h)²)
    # ~ 1e-5 of its ~1 J swing energy, oscillating, never drifting. The touch (ε = 0) and the
    # friction only take energy: no rise beyond that oscillation's 1e-5 J.
    assert rise < 1e-5
    assert energies[-1] < e0 - 0.01  # the inelastic hit and the box's sliding took some
    assert box_x[-1] > 0.13 + 0.05   # knocked off its spot along +x


def test_a_box_collision_offset_from_the_com_rests_at_the_height_its_offset_gives():
    # The crate's box collision 0.03 m below its COM (and 0.04 m, 0.05 m aside, inside its
    # footprint): tilted, it lands on a corner and settles on its big face, the COM then
    # 0.05 m (half the box) + 0.03 m (the offset) above the ground.
    config = NodeConfig.from_parameters(_ground(robot_names=['crate'], **{
        'robots.crate.robot_description': _box_urdf(origin='0.04 0.05 -0.03'),
        'robots.crate.initial_position': START, 'robots.crate.initial_orientation': TILT}))
    world = make_simulator(config)
    assert world.world.bodies[0].shape.shape == 'compound'
    world.step(3000)
    x = world.world.arrays[0][:, 0]
    print(f'\noffset box collision at rest: COM z {x[2]!r} m (closed form 0.08 m)')
    assert abs(x[2] - (BOX_M[2] / 2 + 0.03)) <= REST_TOL  # REST_TOL: a box's corners, exact
    assert abs(abs(x[3]) - 1.0) < 1e-12 or abs(np.hypot(x[4], x[5])) < 1e-9  # level
    assert np.abs(x[7:13]).max() < 1e-9


def _bench_urdf(feet_x=0.2):
    """Return a 2 kg link's URDF: two 0.1 m cube feet 0.05 m below its COM, at x = ±feet_x."""
    foot = ('<collision><origin xyz="{x} 0 -0.05"/><geometry><box size="0.1 0.1 0.1"/>'
            '</geometry></collision>')
    return f"""<?xml version="1.0"?>
<robot name="bench"><link name="bench"><inertial><mass value="2.0"/>
<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.05" iyz="0" izz="0.05"/></inertial>
{foot.format(x=feet_x)}{foot.format(x=-feet_x)}</link></robot>"""


def test_a_link_with_two_collisions_stands_on_both():
    # Tilted 0.1 rad about y, the bench lands on one foot, then stands on both, level, its COM
    # 0.1 m up (0.05 m to the feet's centres, half a foot below them); each foot carries half
    # its weight (its COM midway between them).
    world = make_simulator(NodeConfig.from_parameters(_ground(robot_names=['bench'], **{
        'robots.bench.robot_description': _bench_urdf(),
        'robots.bench.initial_position': [0.0, 0.0, 0.2],
        'robots.bench.initial_orientation': [0.0, math.sin(0.05), 0.0, math.cos(0.05)]})))
    world.step(2000)
    x = world.world.arrays[0][:, 0]
    assert abs(x[2] - 0.1) <= REST_TOL and np.abs(x[7:13]).max() < 1e-9
    c = world.contacts
    staged = c.stage > 0  # the step's contact stages: the weight's impulse m g h over them
    feet = [float(c.impulse_w[staged & (side * (c.point_w[:, 0] - x[0]) > 0.1), 2].sum())
            for side in (1.0, -1.0)]
    print(f'\nbench on two feet: COM z {x[2]!r} m; feet impulses {feet} N s over a step')
    weight = 2.0 * G * 1e-3
    # Each foot half the weight's impulse: the stages' impulses balance gravity over the step
    # and the moments about the COM cancel, to the solver's round-off (1e-12 of the impulse).
    assert all(abs(f - weight / 2) < 1e-12 * weight for f in feet), feet


@pytest.mark.parametrize('first', ['mesh', 'box'])
def test_a_link_with_a_mesh_and_a_box_collision_stands_on_both(tmp_path, first):
    # The bench of test_a_link_with_two_collisions_stands_on_both with its +x foot a mesh: a
    # unit cube's STL (written here by trimesh) at scale 0.1, the other foot the box
    # primitive; tilted to land on one or the other first. The compound's mesh part against
    # the ground is its surface points (the cube's corners among them), the box part its
    # corners: it stands level on both, its COM 0.1 m up, each foot carrying half its weight.
    stl = tmp_path / 'cube.stl'
    trimesh.creation.box(extents=(1.0, 1.0, 1.0)).export(stl)
    mesh_foot = (f'<collision><origin xyz="0.2 0 -0.05"/><geometry><mesh filename="{stl}" '
                 'scale="0.1 0.1 0.1"/></geometry></collision>')
    urdf = _bench_urdf().replace('<collision><origin xyz="0.2 0 -0.05"/>'
                                 '<geometry><box size="0.1 0.1 0.1"/></geometry></collision>',
                                 mesh_foot)
    assert urdf.count('<mesh ') == 1 and urdf.count('<box ') == 1
    tilt = 0.05 if first == 'mesh' else -0.05  # about y: +x (the mesh foot) down first
    world = make_simulator(NodeConfig.from_parameters(_ground(robot_names=['bench'], **{
        'robots.bench.robot_description': urdf,
        'robots.bench.initial_position': [0.0, 0.0, 0.2],
        'robots.bench.initial_orientation': [0.0, math.sin(tilt), 0.0, math.cos(tilt)]})))
    assert world.world.bodies[0].shape.shape == 'compound'
    world.step(2000)
    x = world.world.arrays[0][:, 0]
    c = world.contacts
    staged = c.stage > 0
    feet = [float(c.impulse_w[staged & (side * (c.point_w[:, 0] - x[0]) > 0.1), 2].sum())
            for side in (1.0, -1.0)]
    print(f'\nbench on a mesh and a box foot ({first} first): COM z {x[2]!r} m; feet '
          f'impulses {feet} N s over a step')
    # The two-box bench's bounds (measured here: 2.8e-17 m, 7e-15 m/s, the impulses to
    # 3e-18 N s): the mesh's corners rest on the plane as exactly as the box's.
    assert abs(x[2] - 0.1) <= REST_TOL and np.abs(x[7:13]).max() < 1e-9
    assert abs(x[4]) < 1e-12  # level: no turn left about y
    weight = 2.0 * G * 1e-3
    assert all(abs(f - weight / 2) < 1e-12 * weight for f in feet), feet


def test_a_box_dropped_on_a_fixed_base_link_rests_on_it():
    # arm3's mount (world -> fixed -> mount, its 0.2 x 0.2 x 0.1 m box 0.05 m above the mount
    # frame, 2 m up) with the robot placed 0.5 m along x: an obstacle whose top is at
    # z = 2.1 m. A 0.1 m cube dropped on it rests there, its centre at 2.15 m; the arm below
    # (its upper link jointed to the mount, touching it at the shoulder) hangs still.
    world = make_simulator(_arm(body_names=['cube'], **{
        'robots.arm.initial_position': [0.5, 0.0, 0.0],
        'bodies.cube.shape': 'box', 'bodies.cube.dimensions_m': [0.1, 0.1, 0.1],
        'bodies.cube.mass_kg': 0.3, 'bodies.cube.initial_position': [0.55, 0.03, 2.4]}))
    world.step(1500)
    x = world.arrays[0][:, 0]
    print(f'\ncube on the mount: centre {x[:3].tolist()} m (closed form z = 2.15 m)')
    assert abs(x[2] - 2.15) <= REST_TOL and np.abs(x[7:13]).max() < 1e-9
    assert abs(x[0] - 0.55) < 1e-12 and abs(x[1] - 0.03) < 1e-12  # it fell straight
    q, qd, _ = world.joint_states(0)
    assert max(map(abs, q)) < 1e-12 and max(map(abs, qd)) < 1e-12
    # Placed inside the mount: refused, naming the link and the robot.
    with pytest.raises(ModelError) as caught:
        make_simulator(_arm(body_names=['cube'], **{
            'bodies.cube.shape': 'box', 'bodies.cube.dimensions_m': [0.1, 0.1, 0.1],
            'bodies.cube.initial_position': [0.0, 0.0, 2.1]}))
    assert "0.05 m deep inside link 'mount' of robot 'arm'" in str(caught.value), caught.value


def _refused(error, urdf=None, **params):
    """Return the one-line refusal of a pendulum file over a ground, with ``params``."""
    if urdf is not None:
        params['robots.pendulum.robot_description'] = urdf
        params['robots.pendulum.urdf_path'] = ''
    with pytest.raises(error) as caught:
        make_simulator(NodeConfig.from_parameters(_pendulum(**{'ground.enabled': True},
                                                            **params)))
    line = str(caught.value)
    assert '\n' not in line
    return line


def _pendulum_urdf(joint_extra='', collision=None):
    text = PENDULUM_URDF.read_text()
    text = text.replace('<axis xyz="0 1 0"/>', '<axis xyz="0 1 0"/>' + joint_extra)
    if collision is not None:
        start, end = text.index('<collision>'), text.index('</collision>') + len('</collision>')
        text = text[:start] + collision + text[end:]
    return text


def test_what_the_contact_step_cannot_take_is_refused_naming_the_parameter_or_the_urdf():
    # (A mimic joint is taken: test_a_mimic_gripper_squeezes_a_box_with_half_the_effort_a_side.)
    # A moving link without a shape (several, or one away from the COM, are a compound now).
    line = _refused(ModelError, _pendulum_urdf(collision=''))
    assert line.startswith("robot_description: link 'rod'.collision: none: "), line
    # An integrator without a velocity update to put contact impulses after.
    line = _refused(ConfigError, integrator='rk4')
    assert line.startswith("parameter integrator = 'rk4': cannot take contact (robots in a "
                           'world with contact)'), line
    # A free body where the rod hangs: named by the link and the robot.
    line = _refused(ModelError, body_names=['box'], **{
        'bodies.box.shape': 'box', 'bodies.box.dimensions_m': [0.2, 0.2, 0.2],
        'bodies.box.initial_position': [-0.49, 0.0, 1.1]})
    assert line.startswith('parameter bodies.box.initial_position = [-0.49, 0.0, 1.1] m puts '
                           "the body 0.118919 m deep inside link 'rod' of robot 'pendulum'"), line
    # A link in the ground: its robot's placement puts it there.
    line = _refused(ModelError, **{'ground.height_m': 1.0})
    assert line.startswith('parameter robots.pendulum.initial_position (with '
                           ".initial_orientation and .initial_joint_positions) puts link 'rod' "
                           "of robot 'pendulum' 0.325962 m deep inside ground"), line


def test_urdf_joint_damping_and_friction_act_in_a_world_with_contact():
    # Damping: the rod spun about its pivot with gravity off decays as ω0 exp(−c t / I_pivot),
    # I_pivot = m L² / 3 = 0.75 kg m² (the contact step's exact flow of the damping over each
    # velocity update, so only the integrator's own drift on a spinning hinge is left).
    c, omega0 = 0.25, 2.0
    world = make_simulator(NodeConfig.from_parameters(_pendulum(**{
        'ground.enabled': True, 'ground.height_m': -10.0, 'gravity': [0.0, 0.0, 0.0],
        'robots.pendulum.initial_joint_positions': [0.0],
        'robots.pendulum.initial_joint_velocities': [omega0],
        'robots.pendulum.joints.pivot.damping': c})))
    worst = 0.0
    for k in range(1, 1001):
        world.step(1)
        rate = world.joint_states(0)[1][0]
        exact = omega0 * math.exp(-c * k * 1e-3 / 0.75)
        worst = max(worst, abs(rate - exact) / exact)
    print(f'\nURDF damped pivot in a world with contact: rate within {worst:.2e} relative '
          'of ω0 exp(−c t/I) over 1 s')
    # The damping itself is exact over each step; what is left is the default integrator's
    # drift of a spinning hinge (~5e-7 over 1 s undamped, measured by the core's own tests),
    # bounded at 1e-6 relative.
    assert worst < 1e-6
    # Coulomb friction from the URDF's <dynamics>: the rod at 0.5 rad under gravity needs
    # m g d sin θ = 1 · 9.81 · 0.75 · sin 0.5 = 3.53 N m to hold; a friction of 5 N m holds it
    # exactly (the stuck joint keeps the coordinate its step began with).
    world = make_simulator(NodeConfig.from_parameters(_pendulum(**{
        'ground.enabled': True, 'ground.height_m': -10.0, 'robots.pendulum.urdf_path': '',
        'robots.pendulum.robot_description': _pendulum_urdf('<dynamics friction="5.0"/>')})))
    world.step(2000)
    q, qd, _ = world.joint_states(0)
    print(f'URDF pivot with 5 N m friction at 0.5 rad after 2 s: q - 0.5 = {q[0] - 0.5:.2e} rad, '
          f'rate {qd[0]:.2e} rad/s')
    # Stuck: round-off of the joint impulses only (~1e-16 a step over 2000 steps).
    assert abs(q[0] - 0.5) < 1e-12 and abs(qd[0]) < 1e-12


ARM3_URDF = REPO / 'msg_config' / 'urdf' / 'arm3.urdf'
#: arm3's URDF damps its shoulder and elbow; these tests read still and crossing links undamped.
UNDAMPED = {f'robots.arm.joints.{joint}.{field}': 0.0 for joint in ('shoulder', 'elbow')
            for field in ('damping', 'friction')}


def _arm(**more):
    return NodeConfig.from_parameters({
        'robot_names': ['arm'], 'robots.arm.urdf_path': str(ARM3_URDF), 'ground.enabled': True,
        'gravity': [0.0, 0.0, -G], 'timestep_s': 0.001, **UNDAMPED, **more})


def test_adjacent_links_never_touch_each_other():
    # arm3 hangs straight down: its cylinders meet end to end at the elbow and the wrist (and
    # the hand's box at the wrist), touching. They are parent and child of one joint: no
    # contact between them, so the arm hangs still as on the joints-only core.
    world = make_simulator(_arm())
    world.step(500)
    assert len(world.contacts) == 0
    q, qd, _ = world.joint_states(0)
    print(f'\narm3 hanging 0.5 s in a world with contact: |q| <= {max(map(abs, q)):.3g} rad, '
          f'|qd| <= {max(map(abs, qd)):.3g} rad/s')
    # At rest on its joints (no contact to push it): each coordinate stays 0 but for
    # round-off of the joint impulses (~1e-16 per step, 500 steps).
    assert max(map(abs, q)) < 1e-12 and max(map(abs, qd)) < 1e-12
    # Folded at the elbow by 2.5 rad the upper arm and the forearm cross near the elbow (their
    # 0.03 m cylinders overlap over ~0.03 m): allowed, as they never collide.
    make_simulator(_arm(**{'robots.arm.initial_joint_positions': [0.0, 2.5, 0.0]}))


def _bracketed_arm3(z_m):
    """Return arm3's URDF with a ``bracket`` fixed to its mount: a 0.2 m cube ``z_m`` below it."""
    bracket = ('<joint name="bracket_joint" type="fixed"><parent link="mount"/><child '
               f'link="bracket"/><origin xyz="0 0 {z_m}"/></joint><link name="bracket">'
               '<collision><geometry><box size="0.2 0.2 0.2"/></geometry></collision></link>')
    return ARM3_URDF.read_text().replace('</robot>', bracket + '</robot>')


def test_a_link_jointed_to_the_world_links_never_touches_their_fixed_neighbours():
    # A bracket fixed to arm3's mount (both fixed to the world: one rigid group) around the
    # shoulder, 0.15 m below it: the upper arm (jointed to the mount) runs through it. It is
    # adjacent to the group, so it never touches the bracket either, and the arm hangs still
    # (before, only the mount itself was skipped: refused at start, the upper arm inside the
    # bracket).
    world = make_simulator(_arm(**{'robots.arm.robot_description': _bracketed_arm3(-0.15),
                                   'robots.arm.urdf_path': ''}))
    world.step(300)
    assert len(world.contacts) == 0
    q, qd, _ = world.joint_states(0)
    # as test_adjacent_links_never_touch_each_other: round-off of the joint impulses
    assert max(map(abs, q)) < 1e-12 and max(map(abs, qd)) < 1e-12
    # The forearm is not adjacent to the world's links: a bracket around it (0.75 m below the
    # mount) is an obstacle it starts inside, refused naming both links.
    with pytest.raises(ModelError) as caught:
        make_simulator(_arm(**{'robots.arm.robot_description': _bracketed_arm3(-0.75),
                               'robots.arm.urdf_path': ''}))
    line = str(caught.value)
    assert "puts link 'fore' of robot 'arm' " in line and \
        "inside link 'bracket' of robot 'arm'" in line, line


#: arm3 folded so that the hand (elbow 2.5 rad, wrist 1.0 rad) points back at the upper arm.
FOLDED = {'robots.arm.initial_joint_positions': [0.0, 2.5, 1.0],
          'robots.arm.initial_joint_velocities': [0.0, 0.0, 3.0], 'gravity': [0.0, 0.0, 0.0]}


def _hand_self_contacts(world, steps):
    """
    Return how many steps had a contact of the hand (body 2) with another link of its robot.

    The upper arm (body 0) or the mount, fixed to the world (static object 1, after the
    ground: ``body_b`` -2).
    """
    count = 0
    for _ in range(steps):
        world.step(1)
        c = world.contacts
        count += any({int(a), int(b)} in ({0, 2}, {2, -2}) for a, b in zip(c.body_a, c.body_b))
    return count


def test_other_links_of_a_robot_collide_unless_self_collision_is_off():
    # No gravity; the wrist turns at 3 rad/s toward the upper arm: the hand's end, swinging up
    # past z = 2 m, strikes the mount (a link fixed to the world, 0.1 m from the upper arm's
    # line) within ~0.1 s, before it reaches the upper arm.
    colliding = make_simulator(_arm(**FOLDED))
    hits = _hand_self_contacts(colliding, 800)
    passing = make_simulator(_arm(**FOLDED, **{'robots.arm.self_collision': False}))
    through = _hand_self_contacts(passing, 800)
    wrist_a = colliding.joint_states(0)[0][2]
    wrist_b = passing.joint_states(0)[0][2]
    print(f'\nfolded arm3: hand-robot contact steps {hits} (self_collision on), {through} '
          f'(off); wrist {wrist_a:.4f} rad vs {wrist_b:.4f} rad')
    assert hits > 0 and through == 0
    assert wrist_b > wrist_a + 0.1  # the hand was stopped by its own robot only when on
    # Started inside each other: refused with self_collision on, in one line naming both links.
    inside = {'robots.arm.initial_joint_positions': [0.0, 2.5, 2.5]}
    with pytest.raises(ModelError) as caught:
        make_simulator(_arm(**inside))
    line = str(caught.value)
    assert line.startswith('parameter robots.arm.initial_position (with .initial_orientation '
                           "and .initial_joint_positions) puts link 'upper' of robot 'arm' "), line
    assert "deep inside link 'hand' of robot 'arm'" in line, line
    make_simulator(_arm(**inside, **{'robots.arm.self_collision': False}))


ARM_TABLE = REPO / 'msg_config' / 'arm_table.yaml'


def _arm_table():
    """Return msg_config/arm_table.yaml's config (its URDF path made absolute, as the node)."""
    params = yaml.safe_load(ARM_TABLE.read_text())['/**']['ros__parameters']
    params['robots.arm.urdf_path'] = str(ARM_TABLE.parent / params['robots.arm.urdf_path'])
    return NodeConfig.from_parameters(params)


def test_a_saturated_motor_pushing_a_box_steps_the_same_in_any_chunks():
    # The node steps in chunks that end at samples and inputs; replay in others: the result
    # must not depend on them. The arm's shoulder motor saturates (60 N m) while the hand
    # pushes the box: a step taken again from its start with the motor saturated. That retry
    # reused the pose arrays of its failed attempt when the step was not the first of a call
    # (a recording of arm_table.yaml replayed with 0.06 m errors); bit for bit now.
    ends = []
    for chunk in (1, 7, 50):
        world = make_simulator(_arm_table())
        world.step(300)
        world.set_targets(0, [(0, 'position', -0.6, None), (1, 'position', 0.0, None),
                              (2, 'position', 0.0, None)])
        saturated = False
        for _ in range(350 // chunk):
            world.step(chunk)
            saturated = saturated or any(world.motor_saturated())
        world.step(650 - 300 - 350 // chunk * chunk)
        assert world.time_ns == 650_000_000 and saturated
        ends.append(world.world.arrays[0].copy())
    assert np.array_equal(ends[0], ends[1]) and np.array_equal(ends[0], ends[2])


def test_the_arm_table_file_sweeps_the_box_off_the_table():
    # msg_config/arm_table.yaml as shipped (its URDF path made absolute, as the node does), in
    # a session: the arm hangs still beside the table, then the file's joint_command swings
    # the shoulder to -0.6 rad and the hand sweeps the box off the table onto the floor.
    config = _arm_table()
    assert kernel_kind(config) == 'world_joints'
    session = SimSession(config)
    session.paused = False
    while session.time_ns < 200_000_000:  # 0.2 s at rest: nothing touches the arm
        session.advance(1000)
    box0 = session.body_state(0).position_w.copy()
    assert np.abs(box0 - (0.25, 0.0, 0.475)).max() < 1e-9  # resting on the table
    assert max(map(abs, session.simulator.joint_states(0)[0])) < 1e-12
    session.submit_command('arm/joint_command', (['shoulder', 'elbow', 'wrist'],
                                                 [-0.6, 0.0, 0.0], [], []))
    while session.time_ns < 2_200_000_000:
        session.advance(1000)
    box = session.body_state(0).position_w
    print(f'\narm_table: box from {box0.tolist()} to {box.tolist()} m after 2 s; shoulder '
          f'{session.simulator.joint_states(0)[0][0]:.4f} rad')
    # Off the table (its far edge x = 0.7 m, the box's half width 0.125 m) and down at the
    # floor: its centre below the table's top (0.35 m) means it left the table.
    assert box[2] < 0.35 and (box[0] > 0.7 or box[2] < 0.2)
    # The shoulder reached its target (the position motor's critically damped response).
    assert abs(session.simulator.joint_states(0)[0][0] + 0.6) < 1e-3


def test_a_mimic_gripper_squeezes_a_box_with_half_the_effort_a_side():
    # gripper.urdf (finger_right mimics finger_left, multiplier 1) around a 2 cm box held in
    # no gravity between its fingers, 5 mm from each; an effort τ = 2 N closes finger_left and,
    # through the tie, finger_right. Both reach the box together and squeeze it: by virtual
    # work (one coordinate q moves both fingers by δq) τ = F_left + F_right, and the box at
    # rest makes the two equal, F = τ/2 a side: each finger's joint wrench (the parent's force
    # on it, child frame = world axes here) is τ/2 along ∓y, to round-off of O(1) N sums. The
    # fingers rest on the box faces within the contacts' touching gap (TOUCH_M, 1e-5 m;
    # measured 3e-14 m), the box where it started to 1e-9 m (measured 4e-14 m: the tie keeps
    # the squeeze symmetric), the tie holds to MIMIC_TOL. The mimic has no motor: effort 0.
    from rbd_ros.core.contact.rows import TOUCH_M
    from tests.core.joints.test_mimic import MIMIC_TOL
    tau = 2.0
    world = make_simulator(NodeConfig.from_parameters({
        'robot_names': ['gripper'],
        'robots.gripper.urdf_path': str(REPO / 'msg_config' / 'urdf' / 'gripper.urdf'),
        'gravity': [0.0, 0.0, 0.0], 'body_names': ['box'], 'bodies.box.shape': 'box',
        'bodies.box.dimensions_m': [0.02, 0.02, 0.02], 'bodies.box.mass_kg': 0.05,
        'bodies.box.initial_position': [0.0, 0.0, 1.05]}))
    assert type(world) is RobotContactWorld
    world.set_target(0, 0, 'effort', -tau)
    worst = 0.0
    for _ in range(1000):
        world.step()
        q, _, _ = world.joint_states(0)
        worst = max(worst, abs(q[1] - q[0]))
    assert worst <= MIMIC_TOL, worst
    (q_left, q_right), _, efforts = world.joint_states(0)
    assert abs(q_left + 0.005) <= TOUCH_M and abs(q_right + 0.005) <= TOUCH_M, (q_left, q_right)
    assert np.abs(world.body_state(0).position_w - (0.0, 0.0, 1.05)).max() <= 1e-9
    assert efforts == [-tau, 0.0]
    _, left, right = world.joint_wrenches(0)   # mount (fixed), finger_left, finger_right
    assert abs(left[1] + 0.5 * tau) <= 1e-12 and abs(right[1] - 0.5 * tau) <= 1e-12, (left, right)
