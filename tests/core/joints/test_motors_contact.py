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
Joint motors in the contact step (``WorldSimulator.set_motor``), against closed forms.

The rod is a box ``L × 0.04 × 0.04`` m of mass ``m`` hinged at its end about +y (its
coordinate ``q`` the turn about +y from horizontal along +x: positive turns it down), so
``I_pivot = m (L²/3 + 0.04²/12)`` and gravity's torque on it about the hinge is
``m g (L/2) cos q`` along +q. Every case checks the joints after every step: error at most
``JOINT_TOL = 1e-12`` (m, rad), the issue's bound.
"""

import math

from closed_forms import G
import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState, ConfigError
from rbd_ros.core.contact import ground_plane, Material, primitive_shape, StaticWorld
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.core.joints import ArticulatedSimulator, Joint
from stepping import JOINT_TOL, momentum, run_checked as _run

L = 1.0
M = 1.0
SIDE = 0.04
I_PIVOT = M * (L * L / 3.0 + SIDE * SIDE / 12.0)


def _rod(name='rod', gravity=G, mass_kg=M, length=L):
    shape = primitive_shape('box', [length, SIDE, SIDE])
    model = BodyModel(mass_kg, shape.mass_properties(mass_kg).inertia_b,
                      gravity_w=(0.0, 0.0, -gravity))
    return WorldBody(name, model, shape, Material(0.5, 0.0))


def _hinge(pivot, **kwargs):
    return Joint('hinge', 'revolute', None, 0, origin_parent_b=pivot,
                 origin_child_b=(-0.5 * L, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0), **kwargs)


def _rod_state(pivot, q, rate=0.0):
    """Return the rod turned by ``q`` about +y from along +x, turning at ``rate`` about it."""
    c, s = math.cos(q), math.sin(q)
    position = np.asarray(pivot) + 0.5 * L * np.array([c, 0.0, -s])
    velocity = 0.5 * L * rate * np.array([-s, 0.0, -c])
    return BodyState(position_w=position, orientation_wb=(math.cos(0.5 * q), 0.0,
                                                          math.sin(0.5 * q), 0.0),
                     linear_velocity_w=velocity, angular_velocity_b=(0.0, rate, 0.0))


def _angle(sim):
    """Return the rod's hinge angle (rad): its turn about +y."""
    q = sim.body_state(0).orientation_wb
    return 2.0 * math.atan2(q[2], q[0])


def _world(pivot, q0=0.0, static=None, h_ns=1_000_000, integrator='midpoint_cayley',
           rate=0.0, gravity=G, **joint):
    return WorldSimulator([_rod(gravity=gravity)], [_rod_state(pivot, q0, rate)], static,
                          joints=[_hinge(pivot, **joint)], timestep_ns=h_ns,
                          integrator=integrator)


@pytest.mark.parametrize('integrator', ['midpoint_cayley', 'symplectic_euler_quat_exp'])
def test_position_motor_holds_a_rod_horizontal_near_the_floor(integrator):
    """
    A position motor holds the rod horizontal, 0.5 mm over the floor, for 0.5 s.

    The floor is within the contacts' margin (1 mm): the rod has speculative contacts that
    take no impulse. The exact response from ``e = ė = 0`` is ``e = 0``: the motor lands the
    hinge on its target at every step (the pre-stabilization's tolerance, 1e-13), so the
    angle stays within 1e-12 rad (bound; the issue asks 1e-9; measured 1e-18), and the motor
    takes up gravity's whole torque, ``m g L/2`` (its sign: holding the rod up, against +q),
    to round-off: measured 2.2e-16 relative, bound 1e-12 (a few ulps over the visits' sums).
    """
    pivot = (0.0, 0.0, 0.5 * SIDE + 5e-4)
    sim = _world(pivot, static=StaticWorld(ground_plane()), integrator=integrator)
    sim.set_motor(0, position=0.0, time_constant_s=0.05)
    worst = [0.0, 0.0]

    def check(k):
        worst[0] = max(worst[0], abs(_angle(sim)))
        effort = sim.joint_efforts()[0]
        worst[1] = max(worst[1], abs(effort / (-M * G * 0.5 * L) - 1.0))
    _run(sim, 500, check)
    assert worst[0] <= 1e-12, worst
    assert worst[1] <= 1e-12, worst
    assert not sim.motor_saturated()[0]
    assert sim.body_state(0).position_w[2] - 0.5 * SIDE > 4e-4   # never touched


def _pd_response(e0, ed0, omega, t):
    """``e(t)`` of ``ë = −2ω ė − ω² e`` from ``(e0, ė0)``: ``(e0 + (ė0 + ω e0) t) exp(−ω t)``."""
    return (e0 + (ed0 + omega * e0) * t) * math.exp(-omega * t)


@pytest.mark.parametrize('integrator', ['midpoint_cayley', 'symplectic_euler_quat_exp'])
def test_position_motor_follows_the_exact_response_as_the_tree_step_does(integrator):
    """
    Turn the rod from horizontal to q* = 1 rad (τ = 0.1 s) under gravity, nothing touching.

    The contact step lands the coordinate on the exact critically damped response at every
    step's end, ``q(t) = q* + e(t)``, each step to the pre-stabilization's tolerance 1e-13,
    which the response carries on (a landing error decays by ``(1 + ω h) e^(−ω h)`` a step):
    measured 6.0e-12 rad over 3 s, both integrators (the response does not depend on how the
    rest is integrated); bound 1e-10 rad. ArticulatedSimulator integrates
    ``ë = −2ω ė − ω² e`` by RK4 (error O((ω h)⁴)): measured 9.7e-11 rad off the same closed
    form; bound 1e-9 rad.

    Efforts: the motor's impulse over the run is ``I q̇ − ∫ τ_g dt`` in both; kick–drift–kick
    takes gravity's integral by the trapezoid rule, as the sum of the tree's end-of-step
    efforts does: measured 5.6e-5 N m s apart, bound 1e-4. Symplectic Euler takes it by the
    left sum, ``h/2 |τ_g(q*) − τ_g(0)|`` = 1.13e-3 N m s off: measured 1.18e-3, bound 2e-3.
    Kick–drift–kick's effort is the step's average and the tree's the value at its end: they
    differ by up to ~``I |d³q/dt³| h`` = ``2 I ω³ h`` ≈ 0.67 N m at the start: measured 0.33,
    bound 1 N m. Symplectic Euler's step ends on the secant rate, so its effort is shifted by
    half a step (half of ``I q̈`` moves to the next step, 16 N m at the start): no per-step
    comparison. After 3 s (``e ~ 1e-11`` rad) the motor holds the rod at q* with
    ``−m g (L/2) cos q*`` to 1e-9 relative.
    """
    pivot = (0.0, 0.0, 2.0)
    h_ns = 1_000_000
    h = h_ns * 1e-9
    tau, target = 0.1, 1.0
    sim = _world(pivot, integrator=integrator)
    sim.set_motor(0, position=target, time_constant_s=tau)
    tree = ArticulatedSimulator([_rod().model], [_rod_state(pivot, 0.0)], [_hinge(pivot)],
                                timestep_ns=h_ns)
    tree.set_motor(0, position=target, time_constant_s=tau)
    worst = [0.0, 0.0, 0.0]
    impulse = [0.0, 0.5 * h * tree.joint_efforts()[0]]

    def check(k):
        tree.step()
        exact = target + _pd_response(-target, 0.0, 1.0 / tau, (k + 1) * h)
        worst[0] = max(worst[0], abs(_angle(sim) - exact))
        worst[1] = max(worst[1], abs(tree.joint_positions()[0][0] - exact))
        worst[2] = max(worst[2], abs(sim.joint_efforts()[0] - tree.joint_efforts()[0]))
        impulse[0] += h * sim.joint_efforts()[0]
        impulse[1] += h * tree.joint_efforts()[0]
    _run(sim, 3000, check)
    impulse[1] -= 0.5 * h * tree.joint_efforts()[0]
    assert worst[0] <= 1e-10, worst
    assert worst[1] <= 1e-9, worst
    if integrator == 'midpoint_cayley':
        assert abs(impulse[0] - impulse[1]) <= 1e-4, impulse
        assert worst[2] <= 1.0, worst
    else:
        assert abs(impulse[0] - impulse[1]) <= 2e-3, impulse
    holding = -M * G * 0.5 * L * math.cos(target)
    assert abs(sim.joint_efforts()[0] / holding - 1.0) <= 1e-9, sim.joint_efforts()


def test_velocity_motor_turns_the_rod_at_its_rate():
    """
    A velocity motor turns the rod at 2 rad/s for 1 s under gravity.

    The pre-stabilization lands the coordinate on ``q + v* h`` every step: within 1e-12 rad
    after 1 s (bound; measured 4.4e-15). The motor takes up gravity's torque; over a step its
    average is ``−(m g L/2) (sin q₁ − sin q₀) / (v* h)`` (the integral of the torque at the
    constant rate), which the integrator's half kicks at the step's two poses (the trapezoid
    rule) meet within ``(v* h)² m g L/2 / 12`` = 1.6e-6 N m: measured 1.6e-6; bound 1e-5.
    """
    pivot = (0.0, 0.0, 2.0)
    rate = 2.0
    h = 1e-3
    sim = _world(pivot, rate=rate)
    sim.set_motor(0, velocity=rate)
    worst = [0.0, 0.0]
    last = [0.0]

    def check(k):
        q1 = (k + 1) * rate * h
        turn = (_angle(sim) - q1 + math.pi) % (2.0 * math.pi) - math.pi
        worst[0] = max(worst[0], abs(turn))
        expected = -M * G * 0.5 * L * (math.sin(q1) - math.sin(last[0])) / (rate * h)
        worst[1] = max(worst[1], abs(sim.joint_efforts()[0] - expected))
        last[0] = q1
    _run(sim, 1000, check)
    assert worst[0] <= 1e-12, worst
    assert worst[1] <= 1e-5, worst


@pytest.mark.parametrize('effort, applied', [(0.3, 0.3), (5.0, 2.0)], ids=['free', 'clipped'])
def test_effort_motor_accelerates_the_rod(effort, applied):
    """
    Without gravity an effort (clipped at ``effort_limit`` = 2 N m) turns the rod as a free one.

    ``τ`` the clipped effort: ``q = ½ (τ/I_pivot) t²``.

    Kick–drift–kick gives a constant generalized force half a step at each end, exact for a
    free coordinate; the hinge's centripetal impulses are O(h²) a step, so after 0.5 s the
    angle is within O((q̇ h)²) relative: measured 1.1e-8 and 4.7e-7; bound 1e-5 relative. The
    effort read back is the clipped one, exactly.
    """
    pivot = (0.0, 0.0, 2.0)
    sim = _world(pivot, gravity=0.0, effort_limit=2.0)
    sim.set_motor(0, effort=effort)
    _run(sim, 500)
    exact = 0.5 * applied / I_PIVOT * 0.5 ** 2
    assert abs(_angle(sim) / exact - 1.0) <= 1e-5, (_angle(sim), exact)
    assert sim.joint_efforts()[0] == applied


def test_position_motor_saturates_at_its_effort_limit():
    """
    A motor with half the effort that holding the rod takes saturates and lets it sink.

    ``effort_limit`` = ``m g L/4``: the motor pushes with ``−effort_limit`` (read back
    exactly) and the rod turns down from rest at ``q̈ = (m g L/2 − m g L/4) / I_pivot`` at
    first: after 20 ms ``q = ½ q̈ t²`` within 1e-5 relative (the torque's ``cos q`` falls by
    ~q²/2 ~ 1e-6, and kick–drift–kick's O(h²)): measured 1.4e-7.
    """
    pivot = (0.0, 0.0, 2.0)
    limit = 0.25 * M * G * L
    sim = _world(pivot, effort_limit=limit)
    sim.set_motor(0, position=0.0, time_constant_s=0.05)
    _run(sim, 20)
    assert sim.motor_saturated() == [True]
    assert sim.joint_efforts()[0] == -limit
    exact = 0.5 * (0.5 * M * G * L - limit) / I_PIVOT * 0.02 ** 2
    assert abs(_angle(sim) / exact - 1.0) <= 1e-5, (_angle(sim), exact)


def test_motor_between_two_free_bodies_keeps_momentum():
    """
    A position motor bends a free hinged pair (no gravity): momentum is kept.

    The motor's impulses are ``Jᵀ μ`` of its row, a torque pair about the hinge axis, so the
    linear and angular momentum of the pair stay what they were, to round-off that walks over
    the run (momenta ~0.1 N s, 500 steps). The rods meet at the hinge, so they are listed in
    ``no_collision`` (as a robot's adjacent links are): else their ends' contact there, which
    the hinge holds against, put impulses through both at every step. Measured with the block
    LDLᵀ: 5.0e-16 and 4.5e-15; with the contact, over eight starts (vx ±, ω_y 0.2 or 0.5 rad/s,
    0.1 or 0.03 s), 4.6e-15 to 1.9e-14 with the block LDLᵀ and 4.9e-15 to 2.1e-14 in
    articulated form; bound 4e-14, twice the worst of those.
    """
    a, b = _rod('a', gravity=0.0), _rod('b', gravity=0.0, mass_kg=2.0)
    hinge = Joint('bend', 'revolute', 0, 1, origin_parent_b=(0.5 * L, 0.0, 0.0),
                  origin_child_b=(-0.5 * L, 0.0, 0.0), axis_b=(0.0, 0.0, 1.0))
    states = [BodyState(position_w=(0.0, 0.0, 0.0), linear_velocity_w=(0.3, 0.0, 0.1),
                        angular_velocity_b=(0.0, 0.2, 0.0)),
              BodyState(position_w=(L, 0.0, 0.0), angular_velocity_b=(0.0, 0.2, 0.0))]
    sim = WorldSimulator([a, b], states, None, joints=[hinge], no_collision=[(0, 1)])
    sim.set_motor(0, position=1.0, time_constant_s=0.1)

    lin0, ang0 = momentum(sim)

    def check(k):
        lin, ang = momentum(sim)
        assert np.abs(lin - lin0).max() <= 4e-14, lin - lin0
        assert np.abs(ang - ang0).max() <= 4e-14, ang - ang0
    _run(sim, 500, check)
    assert abs(sim.joint_efforts()[0]) > 0.0


def test_bad_motor_commands_are_refused_in_one_line():
    pivot = (0.0, 0.0, 2.0)
    sim = _world(pivot)
    with pytest.raises(ConfigError, match=r"^joint 'hinge'\.velocity: .*rad/s"):
        sim.set_motor(0, velocity=math.nan)
    with pytest.raises(ConfigError, match=r"^joint 'hinge'\.time_constant_s: -1\.0 s must be > 0"):
        sim.set_motor(0, position=0.1, time_constant_s=-1.0)
    with pytest.raises(ConfigError, match=r'^joint_index: 3 is not a joint index'):
        sim.set_motor(3, effort=1.0)
    free = WorldSimulator([_rod()], [_rod_state(pivot, 0.0)], None)
    with pytest.raises(ConfigError, match=r'^joint_index: a world without joints has no motors'):
        free.set_motor(0, effort=1.0)


def _energy(sim):
    """Return the rod's kinetic plus potential energy, J (zero at the pivot's height 2 m)."""
    s, body = sim.body_state(0), sim.bodies[0]
    return (0.5 * M * s.linear_velocity_w @ s.linear_velocity_w
            + 0.5 * s.angular_velocity_b @ body.model.inertia_b @ s.angular_velocity_b
            + M * G * (s.position_w[2] - 2.0))


def test_rod_falls_onto_a_limit_stop_and_stays():
    """
    Release the rod from horizontal onto a stop at the vertical (``upper`` = π/2).

    - Before the stop the energy is kept to kick–drift–kick's O((ω h)²), ω = sqrt(m g L /
      I_pivot) = 5.42 rad/s: bound (ω h)² m g L/2 = 1.4e-4 J; the speed at the step before
      the stop, ``ω(q) = sqrt(m g L sin q / I_pivot)``, is within ``1e-4`` relative of the
      closed form at the stop ``sqrt(m g L / I_pivot)`` (≈ sqrt(3 g / L) = 5.4249 rad/s for a
      thin rod): the angle left to the stop is under ω h, where ``sin`` is flat to (ω h)²/2.
      Measured 3.7e-6.
    - The stop: the drift lands the joint on the bound (the pre-stabilization's tolerance),
      so it never goes beyond it by more than 1e-12 rad (the issue's bound), and the impulse
      takes out the approach: at rest after it (rate ≤ 1e-12 rad/s) and for 1 s more (no
      rebound). The energy lost is all the kinetic energy at the stop, ½ I ω² = m g L/2: the
      energy after is −m g L/2 to 1e-12 J. Measured: no overshoot at all (0), rate after the
      stop 3.7e-15 rad/s, the energy after exact to the bit.
    """
    pivot = (0.0, 0.0, 2.0)
    bound = 0.5 * math.pi
    sim = _world(pivot, upper=bound)
    i_pivot = I_PIVOT
    omega_stop = math.sqrt(M * G * L / i_pivot)
    h = 1e-3
    last_rate = 0.0
    while sim.held_limits == [0]:
        last_rate = sim.body_state(0).angular_velocity_b[1]
        assert abs(_energy(sim)) <= (omega_stop * h) ** 2 * M * G * 0.5 * L
        _run(sim, 1)
        assert _angle(sim) <= bound + 1e-12
    assert abs(last_rate / omega_stop - 1.0) <= 1e-4, (last_rate, omega_stop)
    worst = [0.0, 0.0]

    def check(k):
        worst[0] = max(worst[0], _angle(sim) - bound)
        worst[1] = max(worst[1], abs(sim.body_state(0).angular_velocity_b[1]))
    _run(sim, 1000, check)
    assert worst[0] <= 1e-12 and worst[1] <= 1e-12, worst
    assert abs(_energy(sim) + M * G * 0.5 * L) <= 1e-12, _energy(sim)
    assert abs(_angle(sim) - bound) <= 1e-12


def test_rod_leaves_its_stop_when_pulled_away():
    """
    Resting on its stop at the vertical, the rod leaves it as soon as a motor pulls it off.

    No sticking: with an effort of −0.5 N m the rod turns off the stop from rest at
    ``q̈ = −0.5 / I_pivot`` (gravity's torque ``m g (L/2) cos q`` is zero at the vertical and
    grows as ``(L/2) m g δ``, δ = π/2 − q): after 50 ms δ = ½ (0.5 / I_pivot) t², less
    gravity's share, ~(ω t)²/12 = 6e-3 of it: measured −3.1e-3, bound 1e-2.
    """
    pivot = (0.0, 0.0, 2.0)
    bound = 0.5 * math.pi
    sim = _world(pivot, q0=bound, upper=bound)
    _run(sim, 10)
    assert abs(_angle(sim) - bound) <= 1e-12
    sim.set_motor(0, effort=-0.5)
    _run(sim, 50)
    assert sim.held_limits == [0]
    exact = 0.5 * 0.5 / I_PIVOT * 0.05 ** 2
    assert abs((bound - _angle(sim)) / exact - 1.0) <= 1e-2, (bound - _angle(sim), exact)


@pytest.mark.parametrize('h_ns', [1_000_000, 10_000_000], ids=['h1ms', 'h10ms'])
def test_door_on_the_floor_swung_against_its_limit(h_ns):
    """
    Swing a door standing on the floor against its hinge's limit: it stops there.

    The door is a box 0.8 × 0.04 × 1 m, 10 kg, on a vertical hinge, its lower edge on a
    frictionless floor, swung at 2 rad/s against its limit ψ = 60°.

    The hinge and the floor share its weight; the limit stops it: never beyond the bound by
    more than 1e-12 rad, at rest there after (spin ≤ 1e-12 rad/s) for 1 s, no rebound, and
    its lower edge stays on the floor (centre height 0.5 m to 1e-9 m: the floor's contact
    and the hinge hold the same height, to what the joint loop leaves, see
    ``rbd_ros/core/contact/joints.py``). Measured at 1 ms and 10 ms: overshoot 0 and 2.2e-16
    rad, spin after the stop 0, height error 0. ``held_limits`` reads +1 at the end of the
    stop's step, as without the floor (it read 0 here when the contact step's joints were
    new, though the stop held the door).
    """
    width, thick, height = 0.8, 0.04, 1.0
    shape = primitive_shape('box', [width, thick, height])
    door = WorldBody('door', BodyModel(10.0, shape.mass_properties(10.0).inertia_b,
                                       gravity_w=(0.0, 0.0, -G)), shape, Material(0.0, 0.0))
    bound = math.radians(60.0)
    hinge = Joint('hinge', 'revolute', None, 0, origin_parent_b=(0.0, 0.0, 0.5 * height),
                  origin_child_b=(-0.5 * width, 0.0, 0.0), axis_b=(0.0, 0.0, 1.0),
                  upper=bound)
    sim = WorldSimulator([door], [BodyState(position_w=(0.5 * width, 0.0, 0.5 * height),
                                            linear_velocity_w=(0.0, width, 0.0),
                                            angular_velocity_b=(0.0, 0.0, 2.0))],
                         StaticWorld(ground_plane(material=Material(0.0, 0.0))),
                         joints=[hinge], timestep_ns=h_ns)
    worst = [0.0, 0.0, 0.0]
    stopped = [None]
    held = [None]

    def check(k):
        s = sim.body_state(0)
        psi = 2.0 * math.atan2(s.orientation_wb[3], s.orientation_wb[0])
        worst[0] = max(worst[0], psi - bound)
        worst[1] = max(worst[1], abs(s.position_w[2] - 0.5 * height))
        if stopped[0] is None and psi >= bound - 1e-12:   # the step that lands it on the stop
            stopped[0] = k
            held[0] = (sim.held_limits, len(sim.contacts))
        if stopped[0] is not None and k > stopped[0]:
            worst[2] = max(worst[2], abs(s.angular_velocity_b[2]))
    _run(sim, round(1.5e9 / h_ns), check)
    assert stopped[0] is not None, worst
    # the stop's step held the limit, with the floor's contacts in it
    assert held[0][0] == [1] and held[0][1] > 0, held[0]
    assert worst[0] <= 1e-12, worst
    assert worst[1] <= 1e-9, worst
    assert worst[2] <= 1e-12, worst
    s = sim.body_state(0)
    assert abs(2.0 * math.atan2(s.orientation_wb[3], s.orientation_wb[0]) - bound) <= 1e-12
    assert len(sim.contacts) > 0


def test_reset_to_new_states_projects_them_and_repeats_a_fresh_world():
    """
    Reset a jointed world to new states: the run after it repeats a fresh world's, bit for bit.

    ``reset(states)`` projects the states onto the joints, as building a world does, and
    restarts the motors' responses: the run after it is the run of a world reset to those
    states with the same command set after (warm starts dropped, limits free, the motor's
    response from the new state).
    """
    pivot = (0.0, 0.0, 2.0)
    sim = _world(pivot, upper=1.2)
    sim.set_motor(0, position=0.5, time_constant_s=0.1)
    _run(sim, 100)
    moved = _rod_state(pivot, 0.3, rate=1.0)
    off = BodyState(position_w=moved.position_w + 1e-4, orientation_wb=moved.orientation_wb,
                    linear_velocity_w=moved.linear_velocity_w,
                    angular_velocity_b=moved.angular_velocity_b)
    sim.reset([off])
    assert max(sim.joint_error()) <= JOINT_TOL
    fresh = _world(pivot, upper=1.2)
    fresh.reset([off])
    fresh.set_motor(0, position=0.5, time_constant_s=0.1)
    _run(sim, 200)
    _run(fresh, 200)
    a, b = sim.body_state(0), fresh.body_state(0)
    assert np.array_equal(a.position_w, b.position_w)
    assert np.array_equal(a.orientation_wb, b.orientation_wb)
    assert np.array_equal(a.angular_velocity_b, b.angular_velocity_b)
    assert sim.joint_efforts()[0] == fresh.joint_efforts()[0]
    beyond = _rod_state(pivot, 1.3)
    with pytest.raises(ConfigError, match=r"^joint 'hinge'\.upper: the initial position "):
        sim.reset([beyond])
