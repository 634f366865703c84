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
Jointed bodies in the contact step (``WorldSimulator(joints=...)``), against closed forms.

The pendulum is a sphere bob of radius ``R`` hung by a weightless rod of length ``L`` from a
revolute joint to the world (``origin_child_b = (0, 0, L)``: the bob's z axis points at the
pivot), so ``I_pivot = m L² + (2/5) m R²``. Every case checks the joints after every step:
their error at most ``JOINT_TOL = 1e-12`` (m, rad), the issue's bound (the step's own is
``PROJECTION_TOL = 1e-13`` per row; a distance over three rows is up to √3 of it).
"""

import math

from closed_forms import G, pendulum_period
import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState, ConfigError, ModelError
from rbd_ros.core.contact import ground_plane, Material, obstacle, primitive_shape, StaticWorld
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.core.joints import Joint
from stepping import momentum, run_checked as _run

STEPS_NS = [1_000_000, 10_000_000]
STEP_IDS = ['h1ms', 'h10ms']
R = 0.05
L = 1.0


def _body(name, kind, dims, mass_kg=1.0, material=(0.5, 0.0), gravity=G):
    shape = primitive_shape(kind, dims)
    model = BodyModel(mass_kg, shape.mass_properties(mass_kg).inertia_b,
                      gravity_w=(0.0, 0.0, -gravity))
    return WorldBody(name, model, shape, Material(*material))


def _bob_state(pivot, theta):
    """Return the bob at angle ``theta`` about +y from hanging straight down (z at the pivot)."""
    position = np.asarray(pivot) + L * np.array([-math.sin(theta), 0.0, -math.cos(theta)])
    # turned by θ about y, its z axis is (sin θ, 0, cos θ): from the bob to the pivot
    return BodyState(position_w=position,
                     orientation_wb=(math.cos(0.5 * theta), 0.0, math.sin(0.5 * theta), 0.0))


def _pendulum(pivot, theta0, h_ns, bob=None, others=(), static=None,
              integrator='midpoint_cayley'):
    bob = bob or _body('bob', 'sphere', [R])
    hinge = Joint('pivot', 'revolute', None, 0, origin_parent_b=pivot,
                  origin_child_b=(0.0, 0.0, L), axis_b=(0.0, 1.0, 0.0))
    bodies = [bob] + [b for b, _ in others]
    states = [_bob_state(pivot, theta0)] + [s for _, s in others]
    return WorldSimulator(bodies, states, static, joints=[hinge], timestep_ns=h_ns,
                          integrator=integrator)


def _angle(sim, pivot):
    """Return the pendulum's angle from the downward vertical, rad (positive towards −x)."""
    d = sim.body_state(0).position_w - np.asarray(pivot)
    return math.atan2(-d[0], -d[2])


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_swinging_pendulum_keeps_its_period_and_energy(h_ns):
    """
    Without contact the step is kick–drift–kick with the joints pre-/post-stabilized.

    From 90° the period is ``4 sqrt(L_eq/g) K(sin² 45°)``, ``L_eq = I_pivot/(m L)``. The
    step (RATTLE's structure) is second order, so the period's error is O((ω h)²),
    ω = sqrt(g/L_eq) = 3.13 rad/s: measured 1.398e-6 and 1.399e-4 relative at 1 ms and 10 ms
    (a ratio of 100.0 for 10× the step), (ω h)²/7; bound (ω h)²/6. The energy oscillates by
    O((ω h)²) of m g L and does not drift: bound (ω h)² m g L.
    """
    pivot = (0.0, 0.0, 2.0)
    sim = _pendulum(pivot, math.pi / 2, h_ns)
    h = h_ns * 1e-9
    l_eq = (L * L + 0.4 * R * R) / L
    period = pendulum_period(l_eq, math.pi / 2)
    times, energy = [], []
    last = [_angle(sim, pivot)]

    def crossing(k):
        a = _angle(sim, pivot)
        if last[0] > 0.0 >= a:   # swinging through the bottom towards +x
            times.append((k + 1 - a / (a - last[0])) * h)
        last[0] = a
        s = sim.body_state(0)
        energy.append(0.5 * s.linear_velocity_w @ s.linear_velocity_w
                      + 0.5 * 0.4 * R * R * s.angular_velocity_b @ s.angular_velocity_b
                      + G * s.position_w[2])
    _run(sim, round(4.5 * period / h), crossing)
    measured = (times[-1] - times[0]) / (len(times) - 1)
    assert len(times) >= 4
    omega_h = math.sqrt(G / l_eq) * h
    assert abs(measured / period - 1.0) <= omega_h ** 2 / 6, (measured, period)
    e0 = G * pivot[2]   # released at rest, the bob at the pivot's height
    assert max(abs(e - e0) for e in energy) <= omega_h ** 2 * G * L, max(energy) - e0


@pytest.mark.parametrize('integrator', ['midpoint_cayley', 'symplectic_euler_quat_exp'])
@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_pendulum_bob_comes_to_rest_on_the_floor(h_ns, integrator):
    """
    Land the bob of a pivot lower than ``L + R`` on the floor, where it stays.

    Released from horizontal, the bob lands at the one angle where it touches the floor,
    ``cos θ = (z_p − R)/L``. ε = 0: the landing takes all its speed (along the arc, into the
    floor); the joint and the floor then hold it. At rest its centre is at
    ``x = −sqrt(L² − (z_p − R)²)``, ``z = R``: to 1e-12 m (the joints' and the contacts'
    round-off). No point goes below the floor by more than round-off: the contacts are
    speculative (``MARGIN_M``), so a bob arriving lands on the floor, not in it.
    """
    pivot = (0.0, 0.0, 0.8)
    sim = _pendulum(pivot, math.pi / 2, h_ns,
                    static=StaticWorld(ground_plane(material=Material(0.5, 0.0))),
                    integrator=integrator)
    depth = [0.0]

    def sink(k):
        depth[0] = max(depth[0], R - sim.body_state(0).position_w[2])
    _run(sim, round(2e9 / h_ns), sink)
    s = sim.body_state(0)
    x_rest = -math.sqrt(L * L - (pivot[2] - R) ** 2)
    assert abs(s.position_w[0] - x_rest) <= 1e-12, s.position_w[0] - x_rest
    assert abs(s.position_w[2] - R) <= 1e-12, s.position_w[2] - R
    assert np.abs(s.linear_velocity_w).max() <= 1e-12, s.linear_velocity_w
    assert depth[0] <= 1e-12, depth[0]


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_door_swung_against_a_post_stops_at_the_post(h_ns):
    """
    Swing a hinged door against a static post: it stops there, flush.

    The door is a box 0.8 × 0.04 × 1 m on a vertical hinge at its edge, swung at 2 rad/s; the
    post's face is where the door's face is at ψ_s = 60°.

    The hinge carries the door's weight; ε = 0, so the stop is inelastic: no rebound. The
    face lands on the post's face (speculative contacts); the joint loop ends with the contact
    satisfied (``joint_stats[3]`` 0: its targets are taken again about the loop's velocities,
    where the narrow phase's linear prediction about the door's turn had the patch and the
    hinge disagree by O((ω h)²) and the loop stall, leaving it approaching by 1.1e-8 m/s at
    1 ms, 2.5e-7 m/s at 10 ms; see ``rbd_ros/core/contact/joints.py``). Measured after 1 s:
    ψ − ψ_s = −2.0e-11 and −2.0e-10 rad, spin 4.3e-11 and 4.8e-10 rad/s (−5.8e-10 and
    −1.8e-9 rad, 1.2e-9 and 4.5e-9 rad/s before). Bounds: twice the 10 ms figures, 4e-10 rad
    of ψ_s (3e-10 m at the post, far under the contacts' touching gap ``TOUCH_M`` = 1e-5 m)
    and 1e-9 rad/s.
    """
    width, thick, height = 0.8, 0.04, 1.0
    door = _body('door', 'box', [width, thick, height], mass_kg=10.0)
    hinge = Joint('hinge', 'revolute', None, 0, origin_parent_b=(0.0, 0.0, 1.0),
                  origin_child_b=(-0.5 * width, 0.0, 0.0), axis_b=(0.0, 0.0, 1.0))
    psi_s = math.radians(60.0)
    along = np.array([math.cos(psi_s), math.sin(psi_s), 0.0])
    normal = np.array([-math.sin(psi_s), math.cos(psi_s), 0.0])
    post_w = 0.05
    centre = 0.6 * along + (0.5 * thick + 0.5 * post_w) * normal + np.array([0.0, 0.0, 1.0])
    post = obstacle('post', 'box', [post_w, post_w, 2.0], position_w=centre,
                    orientation_wb=(math.cos(0.5 * psi_s), 0.0, 0.0, math.sin(0.5 * psi_s)))
    sim = WorldSimulator([door], [BodyState(position_w=(0.5 * width, 0.0, 1.0),
                                            linear_velocity_w=(0.0, width, 0.0),
                                            angular_velocity_b=(0.0, 0.0, 2.0))],
                         StaticWorld(obstacles=(post,)), joints=[hinge], timestep_ns=h_ns)
    _run(sim, round(1.0e9 / h_ns))
    s = sim.body_state(0)
    psi = 2.0 * math.atan2(s.orientation_wb[3], s.orientation_wb[0])
    assert abs(psi - psi_s) <= 4e-10, psi - psi_s
    assert np.abs(s.angular_velocity_b).max() <= 1e-9, s.angular_velocity_b


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_pendulum_knocks_a_box_which_slides_to_a_stop(h_ns):
    """
    Knock a box with the bob: it leaves at ``V`` and stops ``V²/(2 μ g)`` further.

    The bob (ε = 1, μ = 0) swings from 60° into a box (2 kg, 0.2 m cube, μ = 0.3 on the
    floor) at the bottom of its arc.

    - Momentum: the joint acts at the pivot, so the angular momentum about the pivot axis of
      bob and box is kept through the impact, but for the floor's friction and the weights'
      moments over the impact step; bound: ``(μ M g L + (M + m) g a) h`` with ``a`` = 0.25 m,
      a lever larger than the box's reach from the pivot's vertical.
    - ``V`` (the box's speed after the impact step, plus the ``μ g h`` its friction took in
      that step) against the elastic closed form with the bob's effective mass
      ``m_eff = I_pivot / L²``: ``2 m_eff v / (m_eff + M)``, ``v`` the bob's speed at the
      step's start: within 3e-3 relative. The collision stage answers with the bob's free mass
      m, not m_eff = 1.001 m (the paper's order: collisions, then post-stabilization), which
      is −6.7e-4 of V; at 10 ms the bob still speeds up inside the impact step. Measured
      −6.7e-4 (1 ms) and −1.0e-3 (10 ms).
    - Energy: the impact step gains none; it loses the floor's friction work on the box,
      ``μ M g V h``, and what the collision stage's free mass and the step's own error take:
      measured 1.7 (1 ms) and 1.1 (10 ms) times ``μ M g V h``; bound 2.5 times.
    - The bob still swings: it leaves the box at ``v' = (M − m_eff)/(m_eff + M) v`` back,
      measured −0.27 % (1 ms) and −0.88 % (10 ms) off (the collision stage's free mass; at
      10 ms gravity and the box's friction within the impact step), bound 1.5 %; and rises
      to the angle that speed gives about the pivot, ``1 − cos θ = I_pivot (v'/L)²/(2 m g L)``:
      measured −0.27 % and −0.22 % off, bound 1 %.
    - The slide: kick–drift–kick lands within O(h²) of the exact distance: measured −4.1e-8
      (1 ms) and −4.3e-6 (10 ms) relative, a ratio of 100 for 10× the step; bound 25× that.
    """
    mu, m_box, side = 0.3, 2.0, 0.2
    pivot = (0.0, 0.0, 0.5 * side + L)
    box = _body('box', 'box', [side] * 3, mass_kg=m_box, material=(mu, 0.0))
    bob = _body('bob', 'sphere', [R], material=(0.0, 1.0))
    box_state = BodyState(position_w=(R + 0.5 * side, 0.0, 0.5 * side))
    sim = _pendulum(pivot, math.radians(60.0), h_ns, bob=bob, others=[(box, box_state)],
                    static=StaticWorld(ground_plane(material=Material(mu, 0.0))))
    h = h_ns * 1e-9
    i_pivot = L * L + 0.4 * R * R
    lever = np.array([0.0, 1.0, 0.0])

    def spin_y():
        """Angular momentum about the pivot's axis (y through the pivot) of bob and box."""
        total = 0.0
        for i, mass, inertia in ((0, 1.0, 0.4 * R * R), (1, m_box, m_box * side * side / 6)):
            s = sim.body_state(i)
            r = s.position_w - np.asarray(pivot)
            total += lever @ np.cross(r, mass * s.linear_velocity_w)
            total += inertia * s.angular_velocity_b[1]   # both spin about y only
        return total

    def energy():
        total = 0.0
        for i, mass, inertia in ((0, 1.0, 0.4 * R * R), (1, m_box, m_box * side * side / 6)):
            s = sim.body_state(i)
            total += (0.5 * mass * s.linear_velocity_w @ s.linear_velocity_w
                      + 0.5 * inertia * s.angular_velocity_b @ s.angular_velocity_b
                      + mass * G * s.position_w[2])
        return total

    before = None
    while sim.body_state(1).linear_velocity_w[0] <= 1e-6:   # resting: round-off, ~1e-18 m/s
        v_bob = np.linalg.norm(sim.body_state(0).linear_velocity_w)
        before = spin_y()
        e_before = energy()
        sim.step()
    after = spin_y()
    lost = e_before - energy()
    rebound = abs(sim.body_state(0).linear_velocity_w[0])
    assert abs(after - before) <= (mu * m_box * G * L + (m_box + 1.0) * G * 0.25) * h, \
        (after, before)
    v_box = sim.body_state(1).linear_velocity_w[0]
    m_eff = i_pivot / (L * L)
    expected = 2.0 * m_eff * v_bob / (m_eff + m_box)
    assert abs((v_box + mu * G * h) / expected - 1.0) <= 3e-3, (v_box, expected)
    assert 0.0 <= lost <= 2.5 * mu * m_box * G * v_box * h, (lost, mu * m_box * G * v_box * h)
    back = (m_box - m_eff) / (m_eff + m_box) * v_bob
    assert abs(rebound / back - 1.0) <= 1.5e-2, (rebound, back)
    x0 = sim.body_state(1).position_w[0]
    top = [0.0]

    def swing(k):
        top[0] = max(top[0], _angle(sim, pivot))
    _run(sim, round(2.0 / h), swing)
    rise = math.acos(1.0 - 0.5 * i_pivot * (back / L) ** 2 / (G * L))
    assert abs(top[0] / rise - 1.0) <= 1e-2, (top[0], rise)
    s = sim.body_state(1)
    assert abs(s.linear_velocity_w[0]) <= 1e-12
    slid = s.position_w[0] - x0
    exact = v_box ** 2 / (2.0 * mu * G)
    assert abs(slid / exact - 1.0) <= (1e-6 if h_ns == STEPS_NS[0] else 1e-4), (slid, exact)


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_hinged_pair_striking_a_box_keeps_momentum(h_ns):
    """
    Strike a free box with a hinged pair, without gravity: momentum is kept.

    Every impulse (joint and contact) is equal and opposite, so the linear momentum of the
    three (2 kg m/s) is kept to round-off, and the angular momentum about the origin too (the
    joints' impulses ``Jᵀ μ`` act at the pose the bodies are at; the free drift keeps each
    body's): measured 2.2e-15 kg m/s and 4.7e-16 kg m²/s at most over 1 s at 1 ms, bound
    1e-14 for both (a few ulps of 2 a step, not growing).
    """
    a = _body('a', 'box', [0.4, 0.1, 0.1], gravity=0.0, material=(0.3, 0.2))
    b = _body('b', 'box', [0.4, 0.1, 0.1], gravity=0.0, material=(0.3, 0.2))
    c = _body('c', 'box', [0.2, 0.2, 0.2], mass_kg=2.0, gravity=0.0, material=(0.3, 0.2))
    hinge = Joint('hinge', 'revolute', 0, 1, origin_parent_b=(0.2, 0.0, 0.0),
                  origin_child_b=(-0.3, 0.0, 0.0), axis_b=(0.0, 0.0, 1.0))
    # the pair turning as one at 0.5 rad/s about the hinge, moving at 1 m/s along x
    states = [BodyState(position_w=(0.0, 0.0, 0.0), linear_velocity_w=(1.0, -0.1, 0.0),
                        angular_velocity_b=(0.0, 0.0, 0.5)),
              BodyState(position_w=(0.5, 0.0, 0.0), linear_velocity_w=(1.0, 0.15, 0.0),
                        angular_velocity_b=(0.0, 0.0, 0.5)),
              BodyState(position_w=(1.3, 0.05, 0.0))]
    sim = WorldSimulator([a, b, c], states, None, joints=[hinge], timestep_ns=h_ns)

    lin0, ang0 = momentum(sim)
    touched = [False]

    def check(k):
        touched[0] = touched[0] or len(sim.contacts) > 0
        lin, ang = momentum(sim)
        assert np.abs(lin - lin0).max() <= 1e-14, lin - lin0
        assert np.abs(ang - ang0).max() <= 1e-14, ang - ang0
    _run(sim, round(1e9 / h_ns), check)
    assert touched[0]
    assert sim.body_state(2).linear_velocity_w[0] > 0.1   # the box was struck


def test_unsupported_joint_fields_are_refused_in_one_line():
    bob = _body('bob', 'sphere', [R])
    # a cone limit is taken (tests/core/joints/test_cone_limit_contact.py); a start beyond it
    # is the articulated system's refusal, as for the other limits
    coned = Joint('pivot', 'spherical', None, 0, origin_child_b=(0.0, 0.0, L),
                  axis_b=(0.0, 0.0, 1.0), cone_rad=0.5)
    tilted = BodyState(position_w=(-L * math.sin(0.6), 0.0, -L * math.cos(0.6)),
                       orientation_wb=(math.cos(0.3), 0.0, math.sin(0.3), 0.0))
    with pytest.raises(ConfigError, match=r"^joint 'pivot'\.cone_rad: the initial angle off the "
                                          r'axis 0\.(6|59+)\d* rad is beyond cone_rad 0\.5 rad$'):
        WorldSimulator([bob], [tilted], None, joints=[coned])
    # damping and friction are taken (tests/core/joints/test_joint_friction_contact.py), and
    # mimics (below); a mimic of a joint that is not there is the articulated system's refusal
    tied = Joint('pivot', 'revolute', None, 0, origin_child_b=(0.0, 0.0, L),
                 axis_b=(0.0, 1.0, 0.0), mimic='other')
    with pytest.raises(ConfigError, match=r"joint 'pivot'\.mimic: 'other' is not"):
        WorldSimulator([bob], [BodyState(position_w=(0.0, 0.0, -L))], None, joints=[tied])


@pytest.mark.parametrize('k', (1.5, -0.8))
def test_tied_pendulums_in_a_world_swing_with_the_reduced_period(k):
    """
    A mimic (``q_b = k q_a``) is one more row of the contact step's joint visits.

    test_mimic.py's two rods hinged 2 m apart, b tied to a, over a floor: released from
    1 rad (the floor 1.5 m below the pivots) they swing with the period of the reduced system
    (``mimic_pendulum_period``), the tie held within ``MIMIC_TOL`` after every step. The step
    is second order: the period's error is O((ω h)²), ω = sqrt(K_eff / I_eff) the
    small-oscillation rate (~4 rad/s): measured 1.4e-6 (k = 1.5) and 1.1e-6 (k = -0.8)
    relative, (ω h)²/13 and /14; bound (ω h)²/5. A mimic gripper squeezing a box:
    tests/sim/test_robot_contact.py.
    """
    from test_mimic import MIMIC_TOL, pendulums, pivot_terms
    from closed_forms import mimic_pendulum_period
    theta0, h = 1.0, 1e-3
    system = pendulums(k, theta0=theta0)   # its joints, models and start (not stepped)
    rods = [WorldBody(name, model, primitive_shape('box', [0.02, 0.02, length]), Material(0.5))
            for name, model, length in zip('ab', system.models, (1.0, 0.6))]
    sim = WorldSimulator(rods, system.states, StaticWorld(ground_plane(offset_m=-1.5)),
                         joints=system.joints, timestep_ns=round(h * 1e9))
    i1, mgl1, i2, mgl2 = pivot_terms()
    period = mimic_pendulum_period(i1, mgl1, i2, mgl2, k, theta0)

    def angles():
        return [2.0 * math.atan2(sim.body_state(i).orientation_wb[2],
                                 sim.body_state(i).orientation_wb[0]) for i in range(2)]
    crossings, last, worst = [], angles()[0], 0.0
    for step in range(round(1.3 * period / h)):
        sim.step()
        a, b = angles()
        worst = max(worst, abs(b - k * a), *sim.joint_error())
        if (last < 0.0) != (a < 0.0):   # rod a through the bottom (θ'' = 0 there)
            crossings.append((step + last / (last - a)) * h)
        last = a
    assert worst <= MIMIC_TOL, worst
    assert len(crossings) == 3   # T/4, 3T/4, 5T/4
    omega_h = math.sqrt((mgl1 + k * k * mgl2) / (i1 + k * k * i2)) * h
    measured = crossings[2] - crossings[0]
    assert abs(measured / period - 1.0) <= omega_h ** 2 / 5, (measured, period)


def test_a_deferred_projection_gives_the_same_bits_and_the_same_refusals():
    # defer_projection (a node's jointed world: building it compiles nothing, issue 25 item 2)
    # moves the projection onto the joints to the first step, motor target or reset; every
    # step then gives the same bits as an eager world's. The bob starts 1 cm off its rod's
    # length, so the projection visibly moves it: until then the world holds it as given.
    pivot = (0.0, 0.0, 2.0)
    given = _bob_state(pivot, 0.6)
    given = BodyState(given.position_w + (0.0, 0.0, 0.01), given.orientation_wb)
    box = _body('box', 'box', [0.2, 0.2, 0.2])
    others = ((box, BodyState(position_w=(0.8, 0.0, 0.1))),)

    def world(defer, bob_state=given, at=pivot, box_state=others[0][1]):
        bob = _body('bob', 'sphere', [R])
        hinge = Joint('pivot', 'revolute', None, 0, origin_parent_b=at,
                      origin_child_b=(0.0, 0.0, L), axis_b=(0.0, 1.0, 0.0))
        return WorldSimulator([bob, box], [bob_state, box_state],
                              StaticWorld(ground_plane(material=Material(0.5, 0.0))),
                              joints=[hinge], timestep_ns=1_000_000, defer_projection=defer)

    eager, lazy = world(False), world(True)
    assert lazy.joint_error() is None and eager.joint_error() is not None
    assert np.array_equal(lazy.body_state(0).position_w, given.position_w)
    assert not np.array_equal(eager.body_state(0).position_w, given.position_w)
    assert lazy.running_angles() == [0.0]   # a revolute joint has no running angle
    eager.step(400)   # the bob swings down into the box
    lazy.step(400)
    for i in range(2):
        assert lazy.body_state(i) == eager.body_state(i), i
    assert lazy.joint_error() == eager.joint_error()
    assert len(lazy.contacts.point_w) > 0   # the box was struck: contact went through it too
    # a reset before the first step goes back to the projected placement, as an eager one
    eager, lazy = world(False), world(True)
    lazy.reset()
    assert lazy.body_state(0) == eager.body_state(0)
    # a motor target projects first, as an eager world had before it was set
    eager, lazy = world(False), world(True)
    for sim in (eager, lazy):
        sim.set_motor(0, position=0.1, time_constant_s=0.05)
        sim.step(200)
    assert lazy.body_state(0) == eager.body_state(0)
    # a placement that the projection puts inside the box (the bob given 0.6 m below a pivot
    # 1.1 m up, the box under the pivot) is refused at the first step, as an eager world
    # refuses it at its construction
    args = (BodyState((0.0, 0.0, 0.5)), (0.0, 0.0, 1.1), BodyState((0.0, 0.0, 0.1)))
    with pytest.raises(ModelError, match='bodies.bob'):
        world(False, *args)
    lazy = world(True, *args)
    with pytest.raises(ModelError, match='bodies.bob'):
        lazy.step()


def _hinged_plank(under, h_ns, top_z):
    """
    Return a world of a 1 m plank (2 kg, 5 cm thick) hinged at one end (axis y), and its start.

    The plank lies flat, hinged to the world.

    ``under``: ``(name, side_m, mass_kg, x_m)`` of the boxes of one column under it, from the
    floor up (the plank's other end on the top one); ``top_z`` the plank's centre height.
    """
    length, thick = 1.0, 0.05
    bodies = [_body('plank', 'box', [length, 0.2, thick], mass_kg=2.0)]
    states = [BodyState((0.5 * length, 0.0, top_z))]
    z = 0.0
    for name, side, mass, x in under:
        bodies.append(_body(name, 'box', [side] * 3, mass_kg=mass))
        states.append(BodyState((x, 0.0, z + 0.5 * side)))
        z += side
    assert abs(z - (top_z - 0.5 * thick)) < 1e-15
    hinge = Joint('hinge', 'revolute', None, 0, origin_parent_b=(0.0, 0.0, top_z),
                  origin_child_b=(-0.5 * length, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0))
    return WorldSimulator(bodies, states, StaticWorld(ground_plane()), joints=[hinge],
                          timestep_ns=h_ns), states


def _at_rest(sim, states):
    """
    Check that every body is still where it started: speed and move to 1e-12 (m/s, m).

    Spin to 1e-11 rad/s: 1e-12 m/s at 0.1 m, the smallest half-size of these bodies. The
    joint loop stops once a visit changes no velocity by more than ``SWEEP_TOL_M_S``
    (1e-12 m/s or rad/s), so a world at rest is still to about that.
    """
    speed = spin = moved = 0.0
    for i, start in enumerate(states):
        s = sim.body_state(i)
        speed = max(speed, np.abs(s.linear_velocity_w).max())
        spin = max(spin, np.abs(s.angular_velocity_b).max())
        moved = max(moved, np.abs(s.position_w - start.position_w).max())
    assert speed <= 1e-12 and moved <= 1e-12 and spin <= 1e-11, (speed, spin, moved)


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_a_hinged_plank_resting_on_a_box_is_at_rest(h_ns):
    """
    A plank hinged to the world at one end and lying on a box stays where it lies.

    The same plank on two such boxes without the hinge is at rest to round-off; hinged, its
    contact's target is taken again about the joint loop's velocities
    (``rbd_ros/core/contact/joints.py``: ``retarget``), where the narrow phase's linear
    prediction about the candidate pose (the plank turning about its hinge at the rate the
    joints' projection of gravity's kick gives it) allowed a sinking of ``|r_⊥| (h ω0)²/2``
    that the hinge could not give both of the patch's levers: the plank crept at 1.1e-7 m/s
    and sank 5.5e-9 m after 2 s at 10 ms (1.1e-10 m/s, 5.5e-13 m at 1 ms). Measured after
    2 s: 8.5e-14 m/s, 3.4e-13 rad/s, 3.5e-14 m from where it started at 1 ms; 1.4e-13 m/s,
    3.1e-13 rad/s, 4.9e-14 m at 10 ms. Bounds: :func:`_at_rest`; the joints within
    ``JOINT_TOL`` after every step.
    """
    side = 0.4
    sim, states = _hinged_plank([('box', side, 10.0, 0.8)], h_ns, side + 0.025)
    _run(sim, round(2e9 / h_ns))
    _at_rest(sim, states)
    free = WorldSimulator([_body('plank', 'box', [1.0, 0.2, 0.05], mass_kg=2.0),
                           _body('box', 'box', [side] * 3, mass_kg=10.0),
                           _body('box2', 'box', [side] * 3, mass_kg=10.0)],
                          [states[0], states[1], BodyState((0.2, 0.0, 0.5 * side))],
                          StaticWorld(ground_plane()), timestep_ns=h_ns)
    free.step(round(2e9 / h_ns))
    _at_rest(free, states[:1])


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
@pytest.mark.parametrize('case', ['plank', 'chain'])
def test_a_hinged_plank_or_chain_resting_on_a_stack_is_at_rest(case, h_ns):
    """
    A jointed body on a column of two boxes stays where it lies, and so does the column.

    ``plank``: the hinged plank of the test above, on two 0.2 m boxes (5 kg). ``chain``: two
    0.5 m links (1 kg each), the first hinged to the world, the second hinged to the first,
    lying across two 0.6 m boxes, the knee over them. The joint loop's shock pass puts the
    boxes a level below what lies on them (``joint_levels``; a joint to the world grounds a
    body only where nothing below does), so each box is held under the one above while that
    one is solved and the loop's alternation of patch and joints moves the jointed bodies
    alone (before: the plank crept at 9.3e-8 m/s and the chain at 2.7e-7 m/s after 2 s at
    10 ms, sinking 5e-9 and 1.4e-8 m). Bounds as for one box (:func:`_at_rest`); the joints
    within ``JOINT_TOL`` after every step.
    """
    if case == 'plank':
        side = 0.2
        sim, states = _hinged_plank([('box1', side, 5.0, 0.85), ('box2', side, 5.0, 0.85)],
                                    h_ns, 2 * side + 0.025)
    else:
        side, thick = 0.6, 0.05
        top = 2 * side + 0.5 * thick
        links = [_body(name, 'box', [0.5, 0.2, thick]) for name in ('a', 'b')]
        boxes = [_body(name, 'box', [side] * 3, mass_kg=5.0) for name in ('box1', 'box2')]
        states = [BodyState((0.25, 0.0, top)), BodyState((0.75, 0.0, top)),
                  BodyState((0.6, 0.0, 0.5 * side)), BodyState((0.6, 0.0, 1.5 * side))]
        joints = [Joint('hinge', 'revolute', None, 0, origin_parent_b=(0.0, 0.0, top),
                        origin_child_b=(-0.25, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0)),
                  Joint('knee', 'revolute', 0, 1, origin_parent_b=(0.25, 0.0, 0.0),
                        origin_child_b=(-0.25, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0))]
        sim = WorldSimulator(links + boxes, states, StaticWorld(ground_plane()), joints=joints,
                             timestep_ns=h_ns, no_collision=[(0, 1)])
    _run(sim, round(2e9 / h_ns))
    _at_rest(sim, states)
