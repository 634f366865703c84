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
Motors on a spherical (ball) joint's three coordinates, against closed forms (issue 27).

A rod (1 kg, 1 m, square 4 cm section) hangs from a ball joint at the world origin by its
upper end. The joint's coordinates ``rx, ry, rz`` are the rotation vector of its turn in the
parent's (here the world's) axes; their motors turn about those axes. A position target is
the orientation ``q* = exp(φ*)``: the error ``ψ = log(e q*⁻¹)`` (``e`` the joint's turn) follows
``ψ(t) = ψ0 (1 + ω t) e^(−ω t)`` exactly from rest, about the fixed axis of ``ψ0``, whatever
loads the rod (the three motor rows fix its relative angular acceleration).
"""

import math

import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState, ConfigError
from rbd_ros.core.joints import ArticulatedSimulator, cone_angle, Joint
from rbd_ros.core.rotations import quat_conjugate, quat_multiply, quat_to_matrix
from tests.core.joints.closed_forms import critically_damped, G
from tests.core.joints.stepping import JOINT_TOL

MASS, LENGTH, SIDE = 1.0, 1.0, 0.04
ROD_INERTIA = np.diag([MASS * (LENGTH ** 2 + SIDE ** 2) / 12.0] * 2
                      + [MASS * SIDE ** 2 / 6.0])


def quat_exp(phi):
    """Return ``exp(φ)``, the unit quaternion of rotation vector ``φ`` (w, x, y, z)."""
    phi = np.asarray(phi, dtype=float)
    angle = float(np.linalg.norm(phi))
    if angle == 0.0:
        return np.array([1.0, 0.0, 0.0, 0.0])
    return np.concatenate([[math.cos(0.5 * angle)], math.sin(0.5 * angle) * phi / angle])


def quat_log(q):
    """Return the rotation vector of unit quaternion ``q``, the shorter way (``|φ| <= π``)."""
    q = np.asarray(q, dtype=float)
    if q[0] < 0.0:
        q = -q
    s = float(np.linalg.norm(q[1:]))
    return q[1:] * (2.0 * math.atan2(s, q[0]) / s) if s > 0.0 else np.zeros(3)


def rod(step_ns=1_000_000, gravity=G, effort_limit=None, q0=(1.0, 0.0, 0.0, 0.0),
        inertia=None, anchor=0.5 * LENGTH):
    """Return the rod at rest on its ball joint at the origin, turned by ``q0`` from hanging."""
    model = BodyModel(MASS, ROD_INERTIA if inertia is None else inertia,
                      gravity_w=(0.0, 0.0, -gravity))
    joint = Joint('ball', 'spherical', None, 0, origin_child_b=(0.0, 0.0, anchor),
                  effort_limit=effort_limit)
    q0 = np.asarray(q0, dtype=float)
    state = BodyState(tuple(-quat_to_matrix(q0) @ np.array([0.0, 0.0, anchor])),
                      orientation_wb=tuple(q0))
    return ArticulatedSimulator([model], [state], [joint], timestep_ns=step_ns)


def set_orientation(sim, phi, omega):
    """Command the ball joint's orientation ``exp(φ)``: one position target a coordinate."""
    for k, name in enumerate(('rx', 'ry', 'rz')):
        sim.set_motor(0, position=float(phi[k]), time_constant_s=1.0 / omega, coordinate=name)


@pytest.mark.parametrize('step_ns, tol', [(1_000_000, 2e-10), (10_000_000, 2e-5)])
@pytest.mark.parametrize('q0', [(1.0, 0.0, 0.0, 0.0), tuple(quat_exp((-0.4, 0.6, 0.2)))],
                         ids=['from_rest_pose', 'from_elsewhere'])
def test_an_orientation_target_follows_the_critically_damped_closed_form(step_ns, tol, q0):
    # the error ψ = log(e q*⁻¹) follows ψ0 (1 + ω t) e^(−ω t) about its fixed axis; RK4's error
    # O(h⁴) as a revolute motor's (test_universal_motors: 2e-10 at 1 ms, 2e-5 at 10 ms),
    # gravity loading the rod all the way
    sim = rod(step_ns, q0=q0)
    target, omega = np.array([0.5, -0.3, 0.8]), 10.0
    q_star = quat_exp(target)
    psi0 = quat_log(quat_multiply(np.asarray(q0), quat_conjugate(q_star)))
    set_orientation(sim, target, omega)
    worst = worst_joint = 0.0
    for _ in range(3_000_000_000 // step_ns):
        sim.step()
        t = sim.time_ns * 1e-9
        psi = quat_log(quat_multiply(sim.states[0].orientation_wb, quat_conjugate(q_star)))
        exact = psi0 * critically_damped(1.0, omega, t)
        worst = max(worst, float(np.abs(psi - exact).max()))
        assert float(psi @ psi0) >= -1e-12   # no overshoot past the target
        worst_joint = max(worst_joint, *sim.joint_error())
    print(f'h {step_ns * 1e-6:g} ms, q0 {q0}: worst |ψ - closed form| {worst:.3g}')
    assert worst <= tol, worst
    assert worst_joint <= JOINT_TOL, worst_joint
    # held at q* (ψ ~ e0 31 e^-30 after 3 s): the reported coordinates are φ* itself
    assert np.abs(sim.joint_positions()[0] - target).max() <= 1e-9
    # the motors carry gravity's torque about the pivot, world axes: efforts -τ_g
    rot = quat_to_matrix(sim.states[0].orientation_wb)
    torque = np.cross(rot @ np.array([0.0, 0.0, -0.5 * LENGTH]), np.array([0.0, 0.0, -MASS * G]))
    assert np.abs(sim.coordinate_efforts(0) + torque).max() <= 1e-9
    assert sim.coordinate_saturated(0) == [False] * 3
    assert math.isnan(sim.joint_efforts()[0])


@pytest.mark.parametrize('step_ns', (1_000_000, 10_000_000))
def test_an_angular_velocity_target_is_held_exactly_under_gravity(step_ns):
    sim = rod(step_ns)
    rates = np.array([0.7, -0.4, 0.3])
    for k, rate in enumerate(rates):
        sim.set_motor(0, velocity=float(rate), coordinate=k)
    for _ in range(2_000_000_000 // step_ns):
        sim.step()
        # the relative angular velocity, world axes, held at the end of every step: round-off
        assert np.abs(sim.joint_velocities()[0] - rates).max() <= 1e-12
        assert max(sim.joint_error()) <= JOINT_TOL
    # reached by the first step's velocity projection, turning about the fixed axis since:
    # exp(ω* (t - h)), whose rotation vector is ω* (t - h) (|ω*| t < π)
    t = sim.time_ns * 1e-9 - step_ns * 1e-9
    assert np.abs(sim.joint_positions()[0] - rates * t).max() <= 1e-9


def test_efforts_turn_a_ball_about_their_axis_exactly_clipped_by_the_effort_limit():
    # no gravity, isotropic inertia 0.1 anchored at its centre: torques (2, -0.2, 0) N m clipped
    # to (0.3, -0.2, 0) by the effort limit 0.3 N m turn it about that fixed axis,
    # φ = τ t² / 2I (RK4 exact on a constant acceleration)
    sim = rod(gravity=0.0, effort_limit=0.3, inertia=0.1 * np.eye(3), anchor=0.0)
    sim.set_motor(0, effort=2.0, coordinate='rx')
    sim.set_motor(0, effort=-0.2, coordinate='ry')
    assert sim.coordinate_efforts(0).tolist() == [0.3, -0.2, 0.0]
    sim.step(1000)
    expected = np.array([0.3, -0.2, 0.0]) / (2.0 * 0.1)
    assert np.abs(sim.joint_positions()[0] - expected).max() <= 1e-12
    assert np.abs(sim.joint_velocities()[0] - 2.0 * expected).max() <= 1e-12


def test_a_motor_over_its_effort_limit_saturates_alone():
    # rx to 1 rad in 0.1 s needs ~33 N m at the start: with a 1 N m limit it saturates and
    # pushes +1 N m about x (gravity opposing it once the rod swings up), while ry and rz hold 0
    # with no effort (the swing is about x alone). The rod's energy about the pivot then obeys
    # I θ̇²/2 = τ θ − m g d (1 − cos θ), to RK4's error.
    sim = rod(effort_limit=1.0)
    set_orientation(sim, (1.0, 0.0, 0.0), 10.0)
    inertia_x = ROD_INERTIA[0, 0] + MASS * (0.5 * LENGTH) ** 2
    worst = 0.0
    for _ in range(300):
        sim.step()
        assert sim.coordinate_saturated(0) == [True, False, False]
        q, rate = sim.joint_positions()[0], sim.joint_velocities()[0]
        assert np.abs(q[1:]).max() <= 1e-13 and np.abs(rate[1:]).max() <= 1e-12
        work = 0.5 * inertia_x * rate[0] ** 2 - (q[0] - MASS * G * 0.5 * LENGTH
                                                 * (1.0 - math.cos(q[0])))
        worst = max(worst, abs(work))
    assert worst <= 1e-12, worst
    assert sim.coordinate_efforts(0)[0] == 1.0
    assert np.abs(sim.coordinate_efforts(0)[1:]).max() <= 1e-12
    assert sim.motor_saturated() == [True]


def test_motors_between_two_free_bodies_keep_momentum():
    # no gravity: a base and a rod on a ball joint, one motor of each mode; every row is
    # J^T λ, equal and opposite (a force pair at the joint, a torque pair about an axis): the
    # linear momentum stays to round-off (RK4 keeps linear invariants); the angular momentum,
    # not linear in the state (r × p, R I Rᵀ ω), to RK4's O(h⁴): measured 1.4e-11 kg m²/s
    # over 1 s (the universal joint's test case 6.9e-12), 16 times less at h/2 for each motor
    # alone, 4e-17 without motors
    model = BodyModel(MASS, np.diag([0.08, 0.06, 0.03]), gravity_w=(0.0, 0.0, 0.0))
    joint = Joint('ball', 'spherical', 0, 1, origin_parent_b=(0.0, 0.0, -0.5),
                  origin_child_b=(0.0, 0.0, 0.5))
    states = [BodyState((0.0, 0.0, 0.0), linear_velocity_w=(0.1, 0.0, 0.2),
                        angular_velocity_b=(0.0, 0.2, 0.0)),
              BodyState((0.0, 0.0, -1.0), angular_velocity_b=(0.0, 0.2, 0.4))]
    sim = ArticulatedSimulator([model, model], states, [joint])
    sim.set_motor(0, position=0.6, time_constant_s=0.1, coordinate='rx')
    sim.set_motor(0, velocity=-0.3, coordinate='ry')
    sim.set_motor(0, effort=0.2, coordinate='rz')
    lin0, ang0 = sim.momentum()
    for _ in range(1000):
        sim.step()
        lin, ang = sim.momentum()
        assert np.abs(lin - lin0).max() <= 1e-14
        assert np.abs(ang - ang0).max() <= 5e-11
    assert abs(sim.joint_velocities()[0][1] + 0.3) <= 1e-12


@pytest.mark.parametrize('kwargs, message', [
    ({'effort': 1.0, 'coordinate': 3},
     "joint 'ball'.coordinate: 3 is not a motor coordinate of a spherical joint (0 or 'rx', "
     "1 or 'ry', 2 or 'rz')"),
    ({'velocity': math.inf, 'coordinate': 'rz'},
     "joint 'ball'/rz.velocity: inf rad/s must be finite"),
    ({'position': 0.2, 'coordinate': 'ry'},
     "joint 'ball'/ry.time_constant_s: None; a position target needs a time constant"),
])
def test_bad_ball_motor_commands_name_the_coordinate(kwargs, message):
    sim = rod()
    with pytest.raises(ConfigError) as err:
        sim.set_motor(0, **kwargs)
    assert message in str(err.value)


def test_a_target_beyond_the_cone_stops_on_its_rim():
    # the cone 0.3 rad about the hanging rod, rx driven to 0.6: the cone stop holds the rod on
    # its rim (a held cone pauses the three motor rows until the next step boundary), never
    # past it by more than the crossing tolerance, and the rod ends on the rim (measured
    # 0.30000000000000004 rad)
    model = BodyModel(MASS, ROD_INERTIA, gravity_w=(0.0, 0.0, -G))
    joint = Joint('ball', 'spherical', None, 0, origin_child_b=(0.0, 0.0, 0.5 * LENGTH),
                  axis_b=(0.0, 0.0, -1.0), cone_rad=0.3)
    sim = ArticulatedSimulator([model], [BodyState((0.0, 0.0, -0.5 * LENGTH))], [joint])
    set_orientation(sim, (0.6, 0.0, 0.0), 10.0)
    for _ in range(1000):
        sim.step()
        assert cone_angle(joint, None, sim.states[0].orientation_wb) <= 0.3 + 1e-12
        assert max(sim.joint_error()) <= JOINT_TOL
    assert np.abs(sim.joint_positions()[0] - (0.3, 0.0, 0.0)).max() <= 1e-12
