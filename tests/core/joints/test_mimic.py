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

"""Mimic joints (``q_m = k q_l + c``, URDF ``<mimic>``) against closed forms (issue 28)."""

import math

import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState, ConfigError
from rbd_ros.core.errors import ModelError
from rbd_ros.core.joints import ArticulatedSimulator, Joint
from tests.core.joints.closed_forms import G, mimic_pendulum_period
from tests.core.joints.test_articulated import rod_model, y_rotation, zero_crossings

# The projection leaves every row, the mimic row included, within PROJECTION_TOL = 1e-13 rad
# or m; the bound on q_m - k q_l - c after every step is 1e-12.
MIMIC_TOL = 1e-12
LENGTHS = (1.0, 0.6)
MASSES = (1.0, 0.5)


def pendulums(k, c=0.0, theta0=0.0, step_ns=1_000_000, kind='revolute'):
    """
    Return two rods hinged to the world about y (pivots 2 m apart), joint 'b' mimicking 'a'.

    Rod ``i`` (length ``LENGTHS[i]``, mass ``MASSES[i]``, body z) hangs from its top end; rod a
    starts at ``theta0``, rod b at ``k theta0 + c``, both at rest.
    """
    models, states, joints = [], [], []
    for i, (length, mass, angle) in enumerate(zip(LENGTHS, MASSES, (theta0, k * theta0 + c))):
        pivot = np.array([2.0 * i, 0.0, 0.0])
        com = pivot - 0.5 * length * np.array([math.sin(angle), 0.0, math.cos(angle)])
        models.append(rod_model(length, mass))
        states.append(BodyState(com, y_rotation(angle)))
        mimic = {'mimic': 'a', 'mimic_multiplier': k, 'mimic_offset': c} if i == 1 else {}
        joints.append(Joint('ab'[i], kind, None, i, origin_parent_b=tuple(pivot),
                            origin_child_b=(0.0, 0.0, 0.5 * length), axis_b=(0.0, 1.0, 0.0),
                            **mimic))
    return ArticulatedSimulator(models, states, joints, timestep_ns=step_ns)


def pivot_terms():
    """Return ``(I1, mgl1, I2, mgl2)``: each rod's inertia about its pivot and its ``m g l``."""
    out = []
    for length, mass in zip(LENGTHS, MASSES):
        out += [mass * length ** 2 / 3.0, mass * G * 0.5 * length]
    return out


def mimic_error(sim, k, c, lead=0, follow=1):
    q = sim.joint_positions()
    return abs(float(q[follow][0]) - k * float(q[lead][0]) - c)


@pytest.mark.parametrize('k', (1.5, -0.8))
@pytest.mark.parametrize('theta0', (0.05, 1.0))
def test_tied_pendulums_swing_with_the_reduced_period(k, theta0):
    sim = pendulums(k, theta0=theta0)
    assert sim.solver == 'dense'
    i1, mgl1, i2, mgl2 = pivot_terms()
    period = mimic_pendulum_period(i1, mgl1, i2, mgl2, k, theta0)
    times, angles, rates, worst, energies = [], [], [], 0.0, []
    n = int(0.85 * period / 1e-3)
    for _ in range(n):
        times.append(sim.time_ns * 1e-9)
        angles.append(float(sim.joint_positions()[0][0]))
        rates.append(float(sim.joint_velocities()[0][0]))
        worst = max(worst, mimic_error(sim, k, 0.0))
        energies.append(sim.energy())
        sim.step()
    crossings = zero_crossings(times, angles, rates)
    assert len(crossings) == 2
    measured = 2.0 * (crossings[1] - crossings[0])
    # RK4 at h = 1 ms on a 1-DOF pendulum (error O((ω h)⁴), ω ~ 4 rad/s) and the Hermite
    # crossings: measured 1.9e-12 to 2.6e-12 relative; 1e-10 leaves a factor 40
    assert measured == pytest.approx(period, rel=1e-10)
    assert worst <= MIMIC_TOL
    # Energy: no damping, the mimic row does no work (J u = 0); RK4's drift over < 1 period,
    # measured 8e-14 J (0.05 rad) to 3e-11 J (1 rad) of ~5 J swings: 1e-9 J leaves a factor 30
    assert max(abs(e - energies[0]) for e in energies) <= 1e-9
    if theta0 < 0.1:
        # the small-oscillation period with its first amplitude correction,
        # T = 2π sqrt(I_eff / K_eff) (1 + K4 θ0² / (16 K_eff)), K4 = mgl1 + k⁴ mgl2; the next
        # term is O(θ0⁴) ~ 6e-6 relative at θ0 = 0.05
        i_eff, k_eff = i1 + k * k * i2, mgl1 + k * k * mgl2
        small = 2.0 * math.pi * math.sqrt(i_eff / k_eff) * (
            1.0 + (mgl1 + k ** 4 * mgl2) * theta0 ** 2 / (16.0 * k_eff))
        assert measured == pytest.approx(small, rel=1e-5)


def test_mimic_effort_is_the_constraint_force():
    # at release from rest at θ0: q̈1 = -(mgl1 sin θ0 + k mgl2 sin kθ0) / I_eff, and rod b
    # alone, I2 q̈2 = -mgl2 sin q2 + λ with q̈2 = k q̈1, gives the mimic's generalized force λ
    k, theta0 = 1.5, 0.4
    sim = pendulums(k, theta0=theta0)
    i1, mgl1, i2, mgl2 = pivot_terms()
    acc = -(mgl1 * math.sin(theta0) + k * mgl2 * math.sin(k * theta0)) / (i1 + k * k * i2)
    force = i2 * k * acc + mgl2 * math.sin(k * theta0)
    sim.step(0)
    efforts = sim.joint_efforts()
    # the multipliers of a direct solve: round-off of a few dozen operations on O(1) values
    assert efforts[1] == pytest.approx(force, rel=1e-12, abs=1e-12)
    assert efforts[0] == 0.0   # the leader has no motor; its share -k λ is not an effort


def test_offset_is_held_and_motor_on_the_leader_drives_both():
    k, c = -1.0, 0.2
    sim = pendulums(k, c=c)
    sim.set_motor(0, position=0.3, time_constant_s=0.05)
    worst = 0.0
    for _ in range(500):
        sim.step()
        worst = max(worst, mimic_error(sim, k, c))
    assert worst <= MIMIC_TOL
    # the exact critically damped response from rest, e(t) = e0 (1 + ω t) exp(-ω t), e0 = 0.3
    # rad, ω t = 10 at 0.5 s; RK4 at ω h = 0.02 measured 1.1e-12 rad off; 1e-10 rad bound
    e = -0.3 * 11.0 * math.exp(-10.0)
    assert float(sim.joint_positions()[0][0]) == pytest.approx(0.3 + e, abs=1e-10)
    assert float(sim.joint_positions()[1][0]) == pytest.approx(-0.3 - e + c, abs=1e-10)


def test_prismatic_mimic_falls_with_the_reduced_acceleration():
    # two sliders along z under gravity, b = k a: generalized force -(m1 + k m2) g on q_a,
    # effective mass m1 + k² m2, so q_a(t) = -½ g (m1 + k m2) / (m1 + k² m2) t²
    k, c = 0.5, 0.1
    models = [BodyModel(1.0, np.eye(3) * 0.1, gravity_w=(0.0, 0.0, -G)),
              BodyModel(3.0, np.eye(3) * 0.2, gravity_w=(0.0, 0.0, -G))]
    states = [BodyState(), BodyState((1.0, 0.0, c))]
    joints = [Joint('a', 'prismatic', None, 0),
              Joint('b', 'prismatic', None, 1, origin_parent_b=(1.0, 0.0, 0.0), mimic='a',
                    mimic_multiplier=k, mimic_offset=c)]
    sim = ArticulatedSimulator(models, states, joints)
    worst = 0.0
    for _ in range(200):
        sim.step()
        worst = max(worst, mimic_error(sim, k, c))
    t = sim.time_ns * 1e-9
    acc = -G * (1.0 + k * 3.0) / (1.0 + k * k * 3.0)
    # RK4 integrates a constant acceleration exactly: round-off over 200 steps
    assert float(sim.joint_positions()[0][0]) == pytest.approx(0.5 * acc * t * t, rel=1e-11)
    assert worst <= MIMIC_TOL


def test_continuous_mimic_follows_past_half_a_turn_and_keeps_momentum():
    # two rotors on a free base (no gravity), b = 2 a, an effort motor on a: the mimic row and
    # the motor are internal, so momentum stays zero; q_a(t) = ½ τ / I_eff t² relative to the
    # base is not closed-form (the base turns), so check the tie and the momentum
    k = 2.0
    models = [BodyModel(5.0, np.diag([1.0, 1.0, 1.0])),
              BodyModel(1.0, np.diag([0.03, 0.03, 0.05])),
              BodyModel(1.0, np.diag([0.05, 0.05, 0.08]))]
    states = [BodyState(), BodyState((0.5, 0.0, 0.0)), BodyState((-0.5, 0.0, 0.0))]
    joints = [Joint('a', 'continuous', 0, 1, origin_parent_b=(0.5, 0.0, 0.0)),
              Joint('b', 'continuous', 0, 2, origin_parent_b=(-0.5, 0.0, 0.0), mimic='a',
                    mimic_multiplier=k)]
    sim = ArticulatedSimulator(models, states, joints)
    sim.set_motor(0, effort=5.0)
    worst = 0.0
    for _ in range(1000):
        sim.step()
        worst = max(worst, mimic_error(sim, k, 0.0))
    assert float(sim.joint_positions()[1][0]) > 2.0 * math.pi   # past a whole turn
    assert worst <= MIMIC_TOL
    lin, ang = sim.momentum()
    # internal impulses only: momentum stays zero to the round-off of 1000 steps of O(1) terms
    assert np.abs(lin).max() <= 1e-12 and np.abs(ang).max() <= 1e-12


def _two():
    models = [rod_model(), rod_model()]
    states = [BodyState(), BodyState((2.0, 0.0, 0.0))]
    return models, states


@pytest.mark.parametrize('b_kwargs, error, message', [
    ({'mimic': 'b'}, ModelError, r"^joint 'b'\.mimic: 'b' is the joint itself"),
    ({'mimic': 'z'}, ConfigError, r"^joint 'b'\.mimic: 'z' is not a joint of this system$"),
    ({'mimic': 'a', 'mimic_multiplier': math.nan}, ModelError,
     r"^joint 'b'\.mimic_multiplier: nan .* must be finite"),
    ({'mimic': 'a', 'mimic_offset': math.inf}, ModelError,
     r"^joint 'b'\.mimic_offset: inf rad must be finite"),
])
def test_bad_mimics_are_refused_with_one_line(b_kwargs, error, message):
    models, states = _two()
    with pytest.raises(error, match=message):
        joints = [Joint('a', 'revolute', None, 0),
                  Joint('b', 'revolute', None, 1, origin_parent_b=(2.0, 0.0, 0.0), **b_kwargs)]
        ArticulatedSimulator(models, states, joints)


def test_mimic_of_a_fixed_joint_a_cycle_and_a_spherical_mimic_are_refused():
    models, states = _two()
    b = {'origin_parent_b': (2.0, 0.0, 0.0)}
    with pytest.raises(ConfigError, match=r"^joint 'b'\.mimic: 'a' is a fixed joint; a mimic "):
        ArticulatedSimulator(models, states, [Joint('a', 'fixed', None, 0),
                                              Joint('b', 'revolute', None, 1, mimic='a', **b)])
    with pytest.raises(ConfigError, match=r"^joint 'a'\.mimic: 'b' leads back to 'a'"):
        ArticulatedSimulator(models, states,
                             [Joint('a', 'revolute', None, 0, mimic='b'),
                              Joint('b', 'revolute', None, 1, mimic='a', **b)])
    with pytest.raises(ModelError, match=r"^joint 'b'\.mimic: 'a'; a spherical joint cannot"):
        Joint('b', 'spherical', None, 1, mimic='a')


def test_a_mimic_joint_takes_no_motor():
    sim = pendulums(1.0)
    with pytest.raises(ConfigError, match=r"^joint 'b': a mimic joint \(of 'a'\) takes no "
                                          r"motor; command 'a'$"):
        sim.set_motor(1, effort=1.0)


def test_joint_error_reports_a_broken_mimic_tie():
    # /diagnostics' joint_error covers the mimic row: turn the mimic rod about its own pivot by
    # delta, which leaves its hinge's rows satisfied and breaks only q_b = k q_a + c by delta.
    from rbd_ros.core.joints.simulator import joint_error
    from rbd_ros.core.rotations import quat_multiply
    k, c, delta = -0.8, 0.1, 1e-6
    sim = pendulums(k, theta0=0.3, c=c)
    dist, ang = sim.joint_error()
    assert dist <= 1e-13 and ang <= 1e-13  # the projection's tolerance (PROJECTION_TOL)
    x = sim._x.copy()
    pivot = np.array([2.0, 0.0, 0.0])
    turn = y_rotation(delta)
    rot = np.array([[math.cos(delta), 0.0, math.sin(delta)], [0.0, 1.0, 0.0],
                    [-math.sin(delta), 0.0, math.cos(delta)]])   # R_y(delta)
    x[1, 0:3] = pivot + rot @ (x[1, 0:3] - pivot)
    x[1, 3:7] = quat_multiply(turn, x[1, 3:7])
    dist, ang = joint_error(sim._model, sim._work, x)
    # the hinge point moved by round-off only; the tie is off by delta (to the hinge's own
    # sub-1e-13 error and the rotation's round-off)
    assert dist <= 1e-13
    assert ang == pytest.approx(delta, abs=1e-12)
