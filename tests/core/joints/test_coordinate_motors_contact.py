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
Motors on planar, universal and ball joints in the contact step (``WorldSimulator.set_motor``).

The bodies of ``test_planar_motors.py`` and ``test_universal_motors.py``: a 2 kg puck on a
planar joint in the vertical plane x-z (its y axis ``axis_b × axis2_b`` is -z, so gravity
pulls +y with ``m g``, its anchor 0.2 m off its centre of mass, so gravity turns theta too),
and a 1 m rod hanging from a universal joint (``θ1`` about x, ``θ2`` about the rod's own cross
axis, y at rest). The contact step lands each motor coordinate on the exact critically damped
response at every step's end (:mod:`rbd_ros.core.contact.motors`), one motor slot a
coordinate, so the closed form ``q* + e0 (1 + ω t) e^(−ω t)`` holds to the landing tolerance
(1e-13 a step, carried on by the response), against RK4's 1e-10 in the articulated step.
A rod on a ball joint (``test_ball_motors.py``'s, in a world) lands its orientation error on
the same response, about the fixed axis of its first error.
"""

import math

import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState
from rbd_ros.core.contact import Material, primitive_shape
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.core.joints import Joint
from rbd_ros.core.joints.model import joint_position, joint_velocity
from rbd_ros.core.rotations import quat_conjugate, quat_multiply, quat_to_matrix
from tests.core.joints.closed_forms import critically_damped, G
from tests.core.joints.stepping import momentum, run_checked
from tests.core.joints.test_ball_motors import quat_exp, quat_log

MASS, ARM = 2.0, 0.2   # the puck: kg, anchor to centre of mass (m)
ROD_MASS, LENGTH = 1.0, 1.0


def _body(name, mass, size, gravity):
    shape = primitive_shape('box', list(size))
    model = BodyModel(mass, shape.mass_properties(mass).inertia_b,
                      gravity_w=(0.0, 0.0, -gravity))
    return WorldBody(name, model, shape, Material(0.5, 0.0))


def puck(h_ns=1_000_000, gravity=G, effort_limit=None, integrator='midpoint_cayley', arm=ARM):
    """Return the puck on its planar joint to the world, at rest at x = y = theta = 0."""
    joint = Joint('slide', 'planar', None, 0, origin_parent_b=(0.0, 0.0, 1.0),
                  axis_b=(0.0, 1.0, 0.0), axis2_b=(1.0, 0.0, 0.0),
                  origin_child_b=(-arm, 0.0, 0.0), effort_limit=effort_limit)
    return WorldSimulator([_body('puck', MASS, (0.5, 0.1, 0.1), gravity)],
                          [BodyState((arm, 0.0, 1.0))], None, joints=[joint],
                          timestep_ns=h_ns, integrator=integrator)


def rod(h_ns=1_000_000, gravity=G, integrator='midpoint_cayley'):
    """Return the rod hanging at rest from its universal joint at (0, 0, 2) m."""
    joint = Joint('cardan', 'universal', None, 0, origin_parent_b=(0.0, 0.0, 2.0),
                  axis_b=(1.0, 0.0, 0.0), axis2_b=(0.0, 1.0, 0.0),
                  origin_child_b=(0.0, 0.0, 0.5 * LENGTH))
    return WorldSimulator([_body('rod', ROD_MASS, (0.04, 0.04, LENGTH), gravity)],
                          [BodyState((0.0, 0.0, 2.0 - 0.5 * LENGTH))], None, joints=[joint],
                          timestep_ns=h_ns, integrator=integrator)


def coordinates(sim):
    """Return joint 0's coordinates and rates from its child's state (the model's readout)."""
    s = sim.body_state(0)
    joint = sim.joints[0]
    omega_w = quat_to_matrix(s.orientation_wb) @ s.angular_velocity_b
    return (joint_position(joint, None, None, s.position_w, s.orientation_wb),
            joint_velocity(joint, None, None, None, None, s.position_w, s.orientation_wb,
                           s.linear_velocity_w, omega_w))


@pytest.mark.parametrize('integrator', ['midpoint_cayley', 'symplectic_euler_quat_exp'])
@pytest.mark.parametrize('make, targets', [(puck, (0.3, -0.4, 1.0)), (rod, (0.5, -0.7))])
def test_position_targets_land_on_the_exact_response(make, targets, integrator):
    # Each coordinate lands on q* + e0 (1 + ω t) e^(−ω t) at every step's end, to the
    # pre-stabilization's 1e-13 a step that the response carries on: bound 1e-10 (the
    # 1-coordinate rod's 6e-12, test_motors_contact); no overshoot beyond round-off.
    sim = make(integrator=integrator)
    omega, h = 10.0, 1e-3
    for k, target in enumerate(targets):
        sim.set_motor(0, position=target, time_constant_s=1.0 / omega, coordinate=k)
    worst = [0.0]

    def check(n):
        q = coordinates(sim)[0]
        for k, target in enumerate(targets):
            exact = target + critically_damped(-target, omega, (n + 1) * h)
            worst[0] = max(worst[0], abs(q[k] - exact))
            assert (q[k] - target) * -target >= -1e-12, (n, k, q[k])
    run_checked(sim, 3000, check)
    print(f'{make.__name__}, {integrator}: worst |q - closed form| {worst[0]:.3g}')
    assert worst[0] <= 1e-10, worst
    assert math.isnan(sim.joint_efforts()[0])   # one effort a coordinate
    assert sim.coordinate_saturated(0) == [False] * len(targets)
    # held (e ~ e0 31 e^-30 after 3 s): the efforts are the statics, to 1e-9 (as in the
    # articulated step's tests; the contact step's efforts are the steps' averages)
    efforts = sim.coordinate_efforts(0)
    if make is puck:
        # gravity pulls +y: y pushes -m g; theta holds -m g r cos θ about the anchor; x 0
        expected = (0.0, -MASS * G, -MASS * G * ARM * math.cos(targets[2]))
    else:
        rot = quat_to_matrix(sim.body_state(0).orientation_wb)
        torque = np.cross(rot @ np.array([0.0, 0.0, -0.5 * LENGTH]),
                          np.array([0.0, 0.0, -ROD_MASS * G]))
        expected = (-torque[0], -torque @ (rot @ np.array([0.0, 1.0, 0.0])))
    assert np.abs(efforts - expected).max() <= 1e-9, (efforts, expected)


def test_velocity_targets_are_held_and_land_on_v_t():
    # velocity rows in every post-stabilization visit: the rates are the targets to
    # round-off, and the pre-stabilization lands each coordinate on q + v* h a step, so
    # q = v* t (theta wrapped) to the landing tolerance summed over the steps
    sim = puck()
    rates = (0.4, -0.3, 2.0)
    for k, rate in enumerate(rates):
        sim.set_motor(0, velocity=rate, coordinate=k)

    def check(n):
        assert np.abs(coordinates(sim)[1] - rates).max() <= 1e-12
    run_checked(sim, 2000, check)
    q = coordinates(sim)[0]
    t = sim.time_ns * 1e-9
    assert abs(q[0] - rates[0] * t) <= 1e-10 and abs(q[1] - rates[1] * t) <= 1e-10
    assert abs(math.remainder(q[2] - rates[2] * t, 2.0 * math.pi)) <= 1e-10


def test_a_motor_over_its_effort_limit_saturates_alone():
    # the anchor at the centre of mass: y must carry m g = 19.6 N; with an effort limit of
    # 10 it saturates and pushes -10 N (against gravity's +y), so the puck falls at
    # (g - 10/m) exactly, y = (g - 5) t²/2 (to round-off: a constant force, kick-drift-kick
    # exact on it); x and theta hold their targets at 0 with no effort. (With the anchor off
    # the centre, theta carries m (g - ÿ) r and saturates with y once y's row asks to stop
    # the fall: one solve decides both, doc/joints.md.)
    sim = puck(effort_limit=10.0, arm=0.0)
    for k in range(3):
        sim.set_motor(0, position=0.0, time_constant_s=0.05, coordinate=k)
    run_checked(sim, 200)
    assert sim.coordinate_saturated(0) == [False, True, False]
    assert sim.coordinate_efforts(0).tolist() == [0.0, -10.0, 0.0]
    assert sim.motor_saturated() == [True]
    t = sim.time_ns * 1e-9
    q = coordinates(sim)[0]
    assert abs(q[1] - 0.5 * (G - 10.0 / MASS) * t * t) <= 1e-12 and abs(q[0]) <= 1e-12
    assert abs(q[2]) <= 1e-12


def test_motors_between_two_free_bodies_keep_momentum():
    # no gravity: a base and a puck on a planar joint, all three motors driving; every
    # impulse is J^T μ, equal and opposite: the linear momentum stays to round-off
    base = _body('base', 3.0, (0.3, 0.3, 0.3), 0.0)
    top = _body('puck', MASS, (0.5, 0.1, 0.1), 0.0)
    joint = Joint('slide', 'planar', 0, 1, origin_parent_b=(0.0, 0.1, 0.0),
                  origin_child_b=(-ARM, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0),
                  axis2_b=(1.0, 0.0, 0.0))
    states = [BodyState((0.0, 0.0, 1.0), linear_velocity_w=(0.1, 0.0, 0.2),
                        angular_velocity_b=(0.0, 0.3, 0.0)),
              BodyState((ARM, 0.1, 1.0), angular_velocity_b=(0.0, 0.3, 0.0))]
    sim = WorldSimulator([base, top], states, None, joints=[joint],
                         no_collision=[(0, 1)])
    sim.set_motor(0, position=0.3, time_constant_s=0.1, coordinate='x')
    sim.set_motor(0, velocity=-0.2, coordinate='y')
    sim.set_motor(0, effort=0.4, coordinate='theta')
    lin0 = momentum(sim)[0]

    def check(n):
        assert np.abs(momentum(sim)[0] - lin0).max() <= 1e-14
    run_checked(sim, 1000, check)
    assert np.allclose(sim.coordinate_efforts(0)[2], 0.4)


def ball_rod(h_ns=1_000_000, gravity=G, integrator='midpoint_cayley', q0=(1.0, 0.0, 0.0, 0.0),
             effort_limit=None):
    """Return the rod on a ball joint at (0, 0, 2) m by its upper end, at rest, turned by q0."""
    joint = Joint('ball', 'spherical', None, 0, origin_parent_b=(0.0, 0.0, 2.0),
                  origin_child_b=(0.0, 0.0, 0.5 * LENGTH), effort_limit=effort_limit)
    q0 = np.asarray(q0, dtype=float)
    position = np.array([0.0, 0.0, 2.0]) - quat_to_matrix(q0) @ np.array([0.0, 0.0, 0.5])
    return WorldSimulator([_body('rod', ROD_MASS, (0.04, 0.04, LENGTH), gravity)],
                          [BodyState(tuple(position), orientation_wb=tuple(q0))], None,
                          joints=[joint], timestep_ns=h_ns, integrator=integrator)


@pytest.mark.parametrize('integrator', ['midpoint_cayley', 'symplectic_euler_quat_exp'])
@pytest.mark.parametrize('h_ns', [1_000_000, 10_000_000], ids=['h1ms', 'h10ms'])
@pytest.mark.parametrize('q0', [(1.0, 0.0, 0.0, 0.0), tuple(quat_exp((-0.4, 0.6, 0.2)))],
                         ids=['from_rest_pose', 'from_elsewhere'])
def test_a_ball_orientation_target_lands_on_the_exact_response(integrator, h_ns, q0):
    # The error ψ = log(e q*⁻¹) lands on ψ0 (1 + ω t) e^(−ω t) at every step's end (its
    # motor rows about the world axes; ψ stays on ψ0's axis from rest), whatever gravity does,
    # to the pre-stabilization's 1e-13 a step carried on by the response (the planar and
    # universal coordinates' 6.0e-12 above): bound 1e-11
    sim = ball_rod(h_ns, integrator=integrator, q0=q0)
    target, omega, h = np.array([0.5, -0.3, 0.8]), 10.0, h_ns * 1e-9
    q_star = quat_exp(target)
    psi0 = quat_log(quat_multiply(np.asarray(q0), quat_conjugate(q_star)))
    for k, name in enumerate(('rx', 'ry', 'rz')):
        sim.set_motor(0, position=float(target[k]), time_constant_s=1.0 / omega,
                      coordinate=name)
    worst = [0.0]

    def check(n):
        psi = quat_log(quat_multiply(sim.body_state(0).orientation_wb, quat_conjugate(q_star)))
        exact = psi0 * critically_damped(1.0, omega, (n + 1) * h)
        worst[0] = max(worst[0], float(np.abs(psi - exact).max()))
        assert float(psi @ psi0) >= -1e-12, n   # no overshoot
    run_checked(sim, 3_000_000_000 // h_ns, check)
    print(f'ball, {integrator}, h {h * 1e3:g} ms: worst |ψ - closed form| {worst[0]:.3g}')
    assert worst[0] <= 1e-11, worst
    assert np.abs(coordinates(sim)[0] - target).max() <= 1e-9
    # held: the efforts are the statics, −(gravity's torque about the pivot), world axes
    rot = quat_to_matrix(sim.body_state(0).orientation_wb)
    torque = np.cross(rot @ np.array([0.0, 0.0, -0.5 * LENGTH]),
                      np.array([0.0, 0.0, -ROD_MASS * G]))
    assert np.abs(sim.coordinate_efforts(0) + torque).max() <= 1e-9
    assert sim.coordinate_saturated(0) == [False] * 3


@pytest.mark.parametrize('integrator', ['midpoint_cayley', 'symplectic_euler_quat_exp'])
def test_a_ball_angular_velocity_target_is_held(integrator):
    # velocity rows in every post-stabilization visit: ω_rel is the target to round-off under
    # gravity; the pre-stabilization lands the turn on exp(ω* h) e0 a step (not on rx + ω*_x h:
    # a rotation vector's rate is not ω_rel off a fixed axis), so exp(ω* t) to the landing's
    # 1e-13 a step summed over 2000 (kick-drift-kick's Cayley map would turn
    # 2 atan(|ω*| h / 2), 1e-7 short): measured 6.3e-11 and 4.4e-15
    sim = ball_rod(integrator=integrator)
    rates = np.array([0.7, -0.4, 0.3])
    for k, rate in enumerate(rates):
        sim.set_motor(0, velocity=float(rate), coordinate=k)

    def check(n):
        assert np.abs(coordinates(sim)[1] - rates).max() <= 1e-12
    run_checked(sim, 2000, check)
    t = sim.time_ns * 1e-9
    error = np.abs(coordinates(sim)[0] - rates * t).max()
    print(f'ball velocity, {integrator}: |q - ω* t| {error:.3g}')
    assert error <= 2e-10, error


def test_a_ball_motor_over_its_effort_limit_saturates_alone():
    # rx to 1 rad in 0.1 s needs ~33 N m: with a 1 N m limit it saturates and pushes +1 N m
    # about x, while ry and rz hold 0 with no effort (the swing is about x alone)
    sim = ball_rod(effort_limit=1.0)
    for k in range(3):
        sim.set_motor(0, position=1.0 if k == 0 else 0.0, time_constant_s=0.1, coordinate=k)
    run_checked(sim, 300)
    assert sim.coordinate_saturated(0) == [True, False, False]
    assert sim.coordinate_efforts(0)[0] == 1.0
    assert np.abs(sim.coordinate_efforts(0)[1:]).max() <= 1e-9
    assert np.abs(coordinates(sim)[0][1:]).max() <= 1e-12
    assert coordinates(sim)[0][0] > 0.0


def test_ball_motors_between_two_free_bodies_keep_momentum():
    # no gravity: a base and a rod on a ball joint, one motor of each mode; every impulse is
    # J^T μ, equal and opposite: linear and angular momentum stay to round-off. It grows with
    # the rod's spin (the effort turns it up to ~5 rad/s over the second): measured after 1 s
    # 4.8e-14 kg m/s and 1.3e-13 kg m²/s of 0.6 and 0.34 (4e-15 and 1e-15 without motors,
    # 5e-15 and 5e-14 with the effort alone); bounds 1e-13 and 3e-13
    base = _body('base', 3.0, (0.3, 0.3, 0.3), 0.0)
    top = _body('rod', ROD_MASS, (0.04, 0.04, LENGTH), 0.0)
    joint = Joint('ball', 'spherical', 0, 1, origin_parent_b=(0.0, 0.0, -0.15),
                  origin_child_b=(0.0, 0.0, 0.5))
    states = [BodyState((0.0, 0.0, 1.0), linear_velocity_w=(0.1, 0.0, 0.2),
                        angular_velocity_b=(0.0, 0.3, 0.0)),
              BodyState((0.0, 0.0, 0.35), angular_velocity_b=(0.0, 0.3, 0.2))]
    sim = WorldSimulator([base, top], states, None, joints=[joint], no_collision=[(0, 1)])
    sim.set_motor(0, position=0.3, time_constant_s=0.1, coordinate='rx')
    sim.set_motor(0, velocity=-0.2, coordinate='ry')
    sim.set_motor(0, effort=0.4, coordinate='rz')
    lin0, ang0 = momentum(sim)

    def check(n):
        lin, ang = momentum(sim)
        assert np.abs(lin - lin0).max() <= 1e-13
        assert np.abs(ang - ang0).max() <= 3e-13
    run_checked(sim, 1000, check)
    assert np.allclose(sim.coordinate_efforts(0)[2], 0.4)
