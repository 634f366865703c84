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
Joint damping and Coulomb friction in the contact step (``WorldSimulator(joints=...)``).

Against closed forms, through the core (:mod:`rbd_ros.core.contact.motors`: damping is its
exact flow over each velocity update, friction a velocity target 0 bounded by the friction).
The rod is :mod:`test_motors_contact`'s: a box ``L × 0.04 × 0.04`` m hinged at its end about
+y, its coordinate ``q`` the turn from horizontal along +x (positive turns it down), so
gravity's torque along +q is ``m g (L/2) cos q = m g (L/2) sin θ``, ``θ = π/2 − q`` the angle
from the downward vertical. Every case checks the joints after every step (``JOINT_TOL``).
"""

import math

from closed_forms import damped_oscillation, G
import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState
from rbd_ros.core.contact import ground_plane, Material, primitive_shape, StaticWorld
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.core.joints import ArticulatedSimulator, Joint
from stepping import run_checked as _run
from test_articulated import zero_crossings
from test_motors_contact import _angle, _world, I_PIVOT, L, M

STEPS_NS = [1_000_000, 10_000_000]
STEP_IDS = ['h1ms', 'h10ms']
PIVOT = (0.0, 0.0, 2.0)


def _rate(sim):
    """Return the rod's hinge rate (rad/s): its spin about +y, the hinge axis."""
    return float(sim.body_state(0).angular_velocity_b[1])


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_damped_hinge_decays_exactly(h_ns):
    """
    A rod spun at ω0 on a damped hinge, no gravity: ``ω(t) = ω0 exp(−c t / I_pivot)``.

    Each velocity update (two half kicks a step) multiplies the rate by ``exp(−c a dt)``
    exactly, ``a`` the hinge's inverse effective inertia from one solve (``1/I_pivot`` to
    round-off), and every joint impulse acts at the hinge line, so it keeps the spin about it.
    What is left is round-off: a few ulp a step (4e-15 relative after 1 s, both steps), and
    the hinge's own tolerance: the pre-stabilization lands it to ``PROJECTION_TOL`` = 1e-13
    (m, rad), and a Newton step taken to meet that moves the rate by that order relative
    (measured 2.0e-13 and 1.3e-13 at one step near t = 0.5 s, at 1 ms and 10 ms, fading
    after). Bound 1e-12 relative at every step, 1e-13 after 1 s.
    """
    rate0, c = 2.0, 0.4
    sim = _world(PIVOT, rate=rate0, gravity=0.0, h_ns=h_ns, damping=c)
    n = 1_000_000_000 // h_ns
    worst = [0.0]

    def check(k):
        t = (k + 1) * h_ns * 1e-9
        expected = rate0 * math.exp(-c * t / I_PIVOT)
        worst[0] = max(worst[0], abs(_rate(sim) / expected - 1.0))
    _run(sim, n, check)
    print(f'h = {h_ns} ns: worst relative error of the rate {worst[0]:.3g}')
    assert worst[0] <= 1e-12, worst
    assert abs(_rate(sim) / (rate0 * math.exp(-c / I_PIVOT)) - 1.0) <= 1e-13


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_damped_pendulum_oscillates_at_the_closed_form(h_ns):
    """
    The rod hanging on a damped hinge (ζ = 0.05) from 1e-3 rad: ``A e^(−σ t) cos(ω_d t − φ)``.

    Kick–drift–kick: half the damping's exact flow before the first half kick and half after
    the second, symmetric as the drift between the kicks, so the damped motion is second
    order like the undamped one. ``ω_d`` from the zeros of the angle (π/ω_d apart), ``σ``
    from the log of the speed at them (:mod:`test_joint_friction`'s
    ``test_damped_small_oscillations`` for the tree step). The undamped rod keeps its
    frequency to (ω h)²/27 and (ω h)²/24 (5.5e-7 and 6.1e-5 at 1 and 10 ms, with the
    amplitude's θ0²/16 = 6e-8), the damped one to (ω h)²/24 (6.0e-7 and 6.2e-5); bound
    (ω h)²/10 on ``ω_d``. Both halves of the flow after the kicks (kick, damp; kick, damp:
    not symmetric) shifted ``ω_d`` at first order, by about ``ζ ω h / 4``: 4.7e-5 at 1 ms and
    4.2e-4 at 10 ms, which fail it. ``σ``: the speeds at the zeros are interpolated linearly
    (an O((ω h)²) error nearly the same at every zero, which the slope mostly drops) and the
    decay's own splitting is O((ω h)²) too: measured (ω h)²/100 (1.5e-7 and 1.4e-5); bound
    (ω h)² relative.
    """
    theta0, h = 1e-3, h_ns * 1e-9
    omega0 = math.sqrt(M * G * 0.5 * L / I_PIVOT)
    c = 2.0 * I_PIVOT * 0.05 * omega0
    sigma, omega_d = damped_oscillation(omega0, c, I_PIVOT)
    sim = _world(PIVOT, q0=0.5 * math.pi - theta0, h_ns=h_ns, damping=c)
    times, angles, rates = [], [], []

    def sample(k):
        times.append((k + 1) * h)
        angles.append(0.5 * math.pi - _angle(sim))
        rates.append(-_rate(sim))
    _run(sim, round(8.0 / h), sample)
    crossings = zero_crossings(times, angles, rates)
    assert len(crossings) >= 8
    measured = math.pi * (len(crossings) - 1) / (crossings[-1] - crossings[0])
    slope = np.polyfit(crossings, np.log(np.interp(crossings, times, np.abs(rates))), 1)[0]
    print(f'h = {h_ns} ns: omega_d {measured / omega_d - 1.0:.3g}, sigma '
          f'{-slope / sigma - 1.0:.3g} relative, (omega h)^2 {(omega0 * h) ** 2:.3g}')
    assert abs(measured / omega_d - 1.0) <= 0.1 * (omega0 * h) ** 2, measured / omega_d - 1.0
    assert abs(-slope / sigma - 1.0) <= (omega0 * h) ** 2, -slope / sigma - 1.0


def test_velocity_motor_overcomes_the_damping():
    """
    A velocity motor on a damped hinge holds its rate; its effort includes the damping.

    No gravity. The rate is the target to round-off; the motor's effort is the impulse that
    gives back what the damping's exact flow took at each half kick,
    ``2 I_pivot v* (1 − exp(−c h / (2 I_pivot))) / h``: ``c v*`` to ``c h / (2 I_pivot)``
    relative (3e-4). To that form within 1e-6: the motor also takes up the pre-stabilization's
    impulses that make the Cayley drift turn ``v* h`` (it turns ``2 atan(v* h/2)``), of
    relative order ``(v* h)²/12`` = 1.9e-7 (measured 1.2e-7).
    """
    rate, c, h = 1.5, 0.2, 1e-3
    sim = _world(PIVOT, rate=rate, gravity=0.0, damping=c)
    sim.set_motor(0, velocity=rate)
    _run(sim, 500)
    assert abs(_rate(sim) - rate) <= 1e-12, _rate(sim)
    # two half flows of exp(-c h / (2 I)), each given back at once
    expected = 2.0 * I_PIVOT * rate * -math.expm1(-0.5 * c * h / I_PIVOT) / h
    assert abs(sim.joint_efforts()[0] / expected - 1.0) <= 1e-6, sim.joint_efforts()
    assert abs(sim.joint_efforts()[0] / (c * rate) - 1.0) <= c * h / I_PIVOT


def test_velocity_motor_overcomes_the_friction():
    """
    A velocity motor on a hinge with friction ``f``: its effort is ``f``, the friction ``−f``.

    No gravity. The motor's row drives the joint, so its friction row is off and the friction
    pushes ``−f`` against the rate with each half kick; the motor gives it back. Its effort is
    ``f`` within what it also takes up from the Cayley drift, ``I v* (v* h)²/(12 h)`` =
    9e-8 N m (measured with the damping above): bound 1e-6 N m. The rate is the target.
    """
    rate, friction = 1.5, 0.5
    sim = _world(PIVOT, rate=rate, gravity=0.0, friction=friction)
    sim.set_motor(0, velocity=rate)
    _run(sim, 500)
    assert abs(_rate(sim) - rate) <= 1e-12, _rate(sim)
    assert abs(sim.joint_efforts()[0] - friction) <= 1e-6, sim.joint_efforts()
    assert sim.joint_friction_efforts()[0] == -friction


def _gravity_torque(theta):
    """Return gravity's torque on the rod about the hinge at ``theta`` from the vertical."""
    return M * G * 0.5 * L * math.sin(theta)


@pytest.mark.parametrize('damping', [0.0, 0.5], ids=['undamped', 'damped'])
def test_friction_holds_the_rod_at_rest(damping):
    """
    ``m g (L/2) sin θ < friction``: the rod stays where it was put, exactly, for 2 s.

    The friction row holds the rate at 0 in every post-stabilization and the coordinate at
    the step's start in the pre-stabilization, so the rate is round-off (bound 1e-12 rad/s,
    the issue's) and the angle too (1e-12 rad). The friction's effort is what holds the rod,
    gravity's torque (the two half kicks at one pose), to 1e-12 relative. A damped hinge
    too: each kick is projected before the damping's flow, which then finds the joint at
    rest and does nothing (flowing the kicked rate instead took ``c (g-kick rate) h`` of the
    holding off the friction: 7.5e-4 relative at 1 ms with ``c`` = 0.5 N m s/rad).
    """
    theta = 0.5
    torque = _gravity_torque(theta)
    sim = _world(PIVOT, q0=0.5 * math.pi - theta, friction=1.2 * torque, damping=damping)
    q0 = _angle(sim)
    worst = [0.0, 0.0]

    def check(k):
        worst[0] = max(worst[0], np.abs(sim.body_state(0).angular_velocity_b).max(),
                       np.abs(sim.body_state(0).linear_velocity_w).max())
        worst[1] = max(worst[1], abs(_angle(sim) - q0))
    _run(sim, 2000, check)
    print(f'held: speed {worst[0]:.3g}, turn {worst[1]:.3g} rad, friction effort '
          f'{sim.joint_friction_efforts()[0]:.17g} N m against {torque:.17g}')
    assert worst[0] <= 1e-12 and worst[1] <= 1e-12, worst
    assert abs(sim.joint_friction_efforts()[0] / -torque - 1.0) <= 1e-12
    assert sim.joint_efforts()[0] == 0.0   # no motor


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_friction_lets_the_rod_slip_at_the_reduced_acceleration(h_ns):
    """
    ``m g (L/2) sin θ > friction``: the rod starts turning at ``(m g (L/2) sin θ − f)/I``.

    The first step tries to hold it, needs more than ``f h`` and is taken again with the
    friction pushing ``−f`` (against the slip): the rate after it is ``α h`` to the
    integrator's order. Kick–drift–kick's two half kicks take gravity at the step's two
    poses, which differ by ``Δq = α h²/2``: the rate is off by ``m g (L/2) cos θ Δq (h/2) / I``,
    ``−(m g (L/2) cos θ / I) h²/4`` relative to ``α h`` (−3.2e-6 at 1 ms, −3.2e-4 at 10 ms;
    measured the same to 1e-4 of it), the hinge's centripetal impulses O((α h²)²) more;
    bound 1.1 times it. The friction's effort is ``−f`` exactly.
    """
    theta, h = 0.5, h_ns * 1e-9
    torque = _gravity_torque(theta)
    friction = 0.5 * torque
    alpha = (torque - friction) / I_PIVOT
    sim = _world(PIVOT, q0=0.5 * math.pi - theta, h_ns=h_ns, friction=friction)
    _run(sim, 1)
    error = _rate(sim) / (alpha * h) - 1.0
    print(f'h = {h_ns} ns: rate after one step / (alpha h) - 1 = {error:.3g}')
    order = M * G * 0.5 * L * math.cos(theta) / I_PIVOT * h * h / 4.0
    assert abs(error) <= 1.1 * order, (error, order)
    assert sim.joint_friction_efforts()[0] == -friction


def _slider(h_ns, v0, friction, mass_kg=1.0):
    """Return a box on a prismatic joint along +x to the world, sliding at ``v0``."""
    shape = primitive_shape('box', [0.1, 0.1, 0.1])
    model = BodyModel(mass_kg, shape.mass_properties(mass_kg).inertia_b,
                      gravity_w=(0.0, 0.0, -G))
    body = WorldBody('slider', model, shape, Material(0.5, 0.0))
    joint = Joint('slide', 'prismatic', None, 0, origin_parent_b=(0.0, 0.0, 1.0),
                  axis_b=(1.0, 0.0, 0.0), friction=friction)
    state = BodyState(position_w=(0.0, 0.0, 1.0), linear_velocity_w=(v0, 0.0, 0.0))
    return WorldSimulator([body], [state], None, joints=[joint], timestep_ns=h_ns)


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_slider_with_friction_stops_at_the_closed_form_distance(h_ns):
    """
    A slider at ``v0`` against friction ``f`` stops after ``v0² / (2 f/m)`` and stays.

    While it slips, each step's half kicks of ``−f`` and the drift between them at the mid
    rate land it on ``v0 t − a t²/2`` (``a = f/m``) exactly at every step's end. The step
    in which its stop needs no more than ``f h`` holds it where that step began, so it stops
    short by the exact motion left then, ``v²/(2a)`` with ``v <= a h``: at most ``a h²/2``
    (1.5e-6 m at 1 ms, 1.5e-4 m at 10 ms; measured 1.7e-7 and 1.7e-5 m short), plus
    round-off. Then it stays: speed 0 and no motion (1e-12) for 1 s more, its friction
    holding nothing.
    """
    v0, friction, mass = 1.0, 3.0, 1.0
    a, h = friction / mass, h_ns * 1e-9
    sim = _slider(h_ns, v0, friction, mass)
    steps = 0
    while sim.body_state(0).linear_velocity_w[0] != 0.0 and steps < 10_000:
        _run(sim, 1)
        steps += 1
        assert sim.body_state(0).linear_velocity_w[0] >= 0.0   # it never turns back
    distance = sim.body_state(0).position_w[0]
    exact = v0 * v0 / (2.0 * a)
    print(f'h = {h_ns} ns: stopped after {steps} steps, {distance - exact:.3g} m from '
          f'v0^2/(2a)')
    assert -0.5 * a * h * h - 1e-12 <= distance - exact <= 1e-12, distance - exact
    worst = [0.0, 0.0]

    def check(k):
        s = sim.body_state(0)
        worst[0] = max(worst[0], np.abs(s.linear_velocity_w).max())
        worst[1] = max(worst[1], abs(s.position_w[0] - distance))
    _run(sim, 1_000_000_000 // h_ns, check)
    assert worst[0] <= 1e-12 and worst[1] <= 1e-12, worst
    assert abs(sim.joint_friction_efforts()[0]) <= 1e-12


R_BOB = 0.05


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_damped_rubbing_pendulum_comes_to_rest_on_the_floor(h_ns):
    """
    A ball on a damped hinge with friction lands on the floor and stays there, at rest.

    Released from horizontal with the pivot lower than its length, the ball lands where it
    touches the floor (``cos θ = (z_p − R)/L``), the friction (half gravity's torque there)
    and the floor hold it: it stays finite, at that point (1e-12 m, the joints' and the
    contacts' round-off; measured 1.8e-15 and 1.2e-14 m at 1 and 10 ms), at rest (the
    contacts' sweep tolerance ``SWEEP_TOL_M_S`` = 1e-12 m/s, the friction and the floor
    sharing the load; measured 2.7e-13 and 3.9e-13), no deeper in the floor than round-off,
    the joints within ``JOINT_TOL`` after every step.
    """
    pivot, length = (0.0, 0.0, 0.8), 1.0
    shape = primitive_shape('sphere', [R_BOB])
    model = BodyModel(1.0, shape.mass_properties(1.0).inertia_b, gravity_w=(0.0, 0.0, -G))
    bob = WorldBody('bob', model, shape, Material(0.5, 0.0))
    cos_rest = (pivot[2] - R_BOB) / length
    friction = 0.5 * G * length * math.sqrt(1.0 - cos_rest ** 2)
    hinge = Joint('pivot', 'revolute', None, 0, origin_parent_b=pivot,
                  origin_child_b=(0.0, 0.0, length), axis_b=(0.0, 1.0, 0.0), damping=0.5,
                  friction=friction)
    start = BodyState(position_w=np.asarray(pivot) + (-length, 0.0, 0.0),
                      orientation_wb=(math.cos(0.25 * math.pi), 0.0, math.sin(0.25 * math.pi),
                                      0.0))
    sim = WorldSimulator([bob], [start], StaticWorld(ground_plane(material=Material(0.5, 0.0))),
                         joints=[hinge], timestep_ns=h_ns)
    depth = [0.0]

    def sink(k):
        depth[0] = max(depth[0], R_BOB - sim.body_state(0).position_w[2])
    _run(sim, round(2e9 / h_ns), sink)
    s = sim.body_state(0)
    x_rest = -length * math.sqrt(1.0 - cos_rest ** 2)
    print(f'h = {h_ns} ns: x - x_rest {s.position_w[0] - x_rest:.3g} m, z - R '
          f'{s.position_w[2] - R_BOB:.3g} m, speed {np.abs(s.linear_velocity_w).max():.3g}, '
          f'friction {sim.joint_friction_efforts()[0]:.6g} N m, depth {depth[0]:.3g}')
    assert np.isfinite(s.position_w).all()
    assert abs(s.position_w[0] - x_rest) <= 1e-12, s.position_w[0] - x_rest
    assert abs(s.position_w[2] - R_BOB) <= 1e-12, s.position_w[2] - R_BOB
    assert np.abs(s.linear_velocity_w).max() <= 1e-12, s.linear_velocity_w
    assert depth[0] <= 1e-12, depth[0]


#: The damped arm: three boxes ``0.8 ARM_L × 0.04 × 0.04`` m (shorter than the joints'
#: spacing ``ARM_L``, so that bent links do not overlap at a joint), hinged end to end about
#: +y, the first to the world at ``ARM_PIVOT``; ``ARM_POSE`` the joints' coordinates (each a
#: turn about +y from the parent link: positive turns down), every joint damped.
ARM_L = 0.5
ARM_MASSES = (1.0, 0.7, 0.4)
ARM_POSE = (0.3, -0.7, 0.5)
ARM_PIVOT = (0.0, 0.0, 1.5)
ARM_DAMPING = 0.5


def _arm():
    """Return ``(bodies, states, joints)`` of the damped arm standing still at ``ARM_POSE``."""
    bodies, states, joints = [], [], []
    anchor, turn = np.asarray(ARM_PIVOT, dtype=float), 0.0
    for k, (mass, q) in enumerate(zip(ARM_MASSES, ARM_POSE)):
        shape = primitive_shape('box', [0.8 * ARM_L, 0.04, 0.04])
        model = BodyModel(mass, shape.mass_properties(mass).inertia_b, gravity_w=(0.0, 0.0, -G))
        bodies.append(WorldBody(f'link{k}', model, shape, Material(0.5, 0.0)))
        turn += q
        along = np.array([math.cos(turn), 0.0, -math.sin(turn)])
        states.append(BodyState(position_w=anchor + 0.5 * ARM_L * along,
                                orientation_wb=(math.cos(0.5 * turn), 0.0,
                                                math.sin(0.5 * turn), 0.0)))
        joints.append(Joint(f'joint{k}', 'revolute', None if k == 0 else k - 1, k,
                            origin_parent_b=ARM_PIVOT if k == 0 else (0.5 * ARM_L, 0.0, 0.0),
                            origin_child_b=(-0.5 * ARM_L, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0),
                            damping=ARM_DAMPING))
        anchor = anchor + ARM_L * along
    return bodies, states, joints


def _arm_statics():
    """
    Return the motor efforts (N m) holding the arm still at ``ARM_POSE``: the statics.

    Joint ``i`` carries gravity's torque on links ``i`` and beyond about its axis, along +q
    (down) ``g Σ_k m_k (x_k − x_i)``, ``x_k`` link ``k``'s centre and ``x_i`` the joint's
    horizontal position; its motor gives the opposite.
    """
    turns = np.cumsum(ARM_POSE)
    joint_x = np.concatenate(([0.0], np.cumsum(ARM_L * np.cos(turns))))
    centre_x = joint_x[:-1] + 0.5 * ARM_L * np.cos(turns)
    return np.array([-G * sum(ARM_MASSES[k] * (centre_x[k] - joint_x[i])
                              for k in range(i, len(ARM_MASSES)))
                     for i in range(len(ARM_MASSES))])


def _arm_coordinates(sim):
    """Return the arm's joint coordinates (rad) from its links' turns about +y."""
    turns = [2.0 * math.atan2(sim.body_state(k).orientation_wb[2],
                              sim.body_state(k).orientation_wb[0]) for k in range(3)]
    return np.diff(np.concatenate(([0.0], turns)))


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
@pytest.mark.parametrize('integrator', ['midpoint_cayley', 'symplectic_euler_quat_exp'])
def test_damped_arm_held_still_gives_the_statics(integrator, h_ns):
    """
    Position motors hold a damped 3-link arm still at a bent pose: efforts are the statics.

    The arm is at rest at its targets (``e = ė = 0``), high over a floor (ground on, nothing
    touching). Each velocity update's gravity kick gives the joints a rate that the
    post-stabilization's motor rows take back; the damping's exact flow comes after that
    projection, so it finds the joints at rest and acts on nothing: the motors' efforts are
    gravity's torques (:func:`_arm_statics`, each joint a sum over the links beyond it) to
    round-off. Measured 6.7e-16 relative (4.4e-16 at 10 ms); bound 1e-12 (a few ulps a visit
    over the visits' sums, as the undamped rod's in :mod:`test_motors_contact`). Flowing the
    kicked rate instead (the damping before the projection) was off by ``c`` times the
    gravity kick's rate, O(h): 4e-4 to 7e-3 relative at 1 ms, ten times that at 10 ms. The
    pose stays within 1e-12 rad (measured 0). ``ArticulatedSimulator`` (damping a force in
    RK4, zero at the rates of its stages, which are zero at rest) gives the statics to the
    same bound (measured 1.8e-15).
    """
    expected = _arm_statics()
    bodies, states, joints = _arm()
    sim = WorldSimulator(bodies, states, StaticWorld(ground_plane()), joints=joints,
                         timestep_ns=h_ns, integrator=integrator)
    tree = ArticulatedSimulator([b.model for b in bodies], states, joints, timestep_ns=h_ns)
    for k, q in enumerate(ARM_POSE):
        sim.set_motor(k, position=q, time_constant_s=0.05)
        tree.set_motor(k, position=q, time_constant_s=0.05)
    worst = [0.0, 0.0, 0.0]

    def check(k):
        tree.step()
        worst[0] = max(worst[0], np.abs(sim.joint_efforts() / expected - 1.0).max())
        worst[1] = max(worst[1], np.abs(tree.joint_efforts() / expected - 1.0).max())
        worst[2] = max(worst[2], np.abs(_arm_coordinates(sim) - ARM_POSE).max())
    _run(sim, round(0.5e9 / h_ns), check)
    print(f'{integrator}, h = {h_ns} ns: efforts {sim.joint_efforts()} N m against '
          f'{expected}: worst relative {worst[0]:.3g} (tree {worst[1]:.3g}), pose '
          f'{worst[2]:.3g} rad')
    assert worst[0] <= 1e-12, worst
    assert worst[1] <= 1e-12, worst
    assert worst[2] <= 1e-12, worst
    assert not any(sim.motor_saturated())
    assert not np.any(sim.contact_wrench_w)   # the floor never touched
