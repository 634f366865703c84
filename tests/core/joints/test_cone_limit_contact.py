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
A spherical joint's cone limit in the contact step (``WorldSimulator(joints=...)``).

The rod is a box ``SIDE × SIDE × L`` m of mass ``M`` (its axis body z) hanging by its upper
end from a ball joint to the world at ``PIVOT``, the cone about the downward vertical, so
across its axis about the pivot ``I1 = M (L² + SIDE²)/12 + M (L/2)²`` and ``m g d =
M g L/2``. Its cross-section is square, so every axis across the rod through the pivot is a
principal axis with ``I1``: the cone's swing axis ``n`` among them. Every case checks the
joints after every step: error at most ``JOINT_TOL = 1e-12`` (m, rad), the issue's bound.
"""

import math

from closed_forms import cone_rim_torque, cone_stop, G
import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState
from rbd_ros.core.contact import ground_plane, Material, primitive_shape, StaticWorld
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.core.joints import ArticulatedSimulator, cone_angle, Joint
from rbd_ros.core.rotations import quat_from_axis_angle
from stepping import run_checked as _run

L = 1.0
M = 1.0
SIDE = 0.04
I1 = M * (L * L + SIDE * SIDE) / 12.0 + M * (0.5 * L) ** 2
MGD = M * G * 0.5 * L
PIVOT = np.array([0.0, 0.0, 2.0])   # the rod's lower end 1 m above the floor when hanging
STEPS_NS = [1_000_000, 10_000_000]
STEP_IDS = ['h1ms', 'h10ms']
# The swing out onto the rim: 0.4 rad off the vertical, 2 rad/s outward, 11 rad/s about z;
# on the rim of the 0.6 rad cone the rod turns at phidot_a = 5.23 rad/s, above the free
# conical pendulum's 4.22 rad/s, so the rim holds it there (it pushes with 1.49 N m).
THETA0, THETADOT0, PHIDOT0, ALPHA = 0.4, 2.0, 11.0, 0.6


def _rod(mu=0.5):
    shape = primitive_shape('box', [SIDE, SIDE, L])
    model = BodyModel(M, shape.mass_properties(M).inertia_b, gravity_w=(0.0, 0.0, -G))
    return WorldBody('rod', model, shape, Material(mu, 0.0))


def _ball(alpha, pivot=PIVOT, tilt=0.0):
    """
    Return the ball joint at ``pivot``, its cone ``alpha`` about the downward vertical.

    ``tilt``: the cone's axis turned that far from it towards +x (``q_rest`` turns the child's
    axis, the rod's −z, onto it at rest).
    """
    axis = (math.sin(tilt), 0.0, -math.cos(tilt))
    return Joint('ball', 'spherical', None, 0, origin_parent_b=tuple(pivot),
                 origin_child_b=(0.0, 0.0, 0.5 * L), axis_b=axis,
                 q_rest=tuple(quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), -tilt)),
                 cone_rad=alpha)


def _rod_state(theta0, thetadot0, phidot0, pivot=PIVOT):
    """
    Return the rod ``theta0`` off the downward vertical towards −x, no spin about its axis.

    Turning at ``thetadot0`` away from the vertical (about +y) and ``phidot0`` about z:
    ``ω = phidot0 (z − cos θ f) + thetadot0 y``, ``f`` the unit vector from the pivot along it.
    """
    q = quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), theta0)
    rot = BodyState(orientation_wb=q).rotation_wb()
    f = -rot[:, 2]
    omega_w = (phidot0 * (np.array([0.0, 0.0, 1.0]) - f[2] * f)
               + thetadot0 * np.array([0.0, 1.0, 0.0]))
    com = 0.5 * L * f
    return BodyState(np.asarray(pivot) + com, q, np.cross(omega_w, com), rot.T @ omega_w)


def _angle(state):
    """Return the rod's angle off the cone's axis (the downward vertical), rad."""
    return cone_angle(_ball(ALPHA), None, state.orientation_wb)


def _normal_rate(state):
    """Return the rod's rate away from the cone's axis, ``θ̇ = ω · n``, rad/s."""
    f = -state.rotation_wb()[:, 2]
    n = np.cross((0.0, 0.0, -1.0), f)
    return float(state.angular_velocity_w() @ n) / np.linalg.norm(n)


def _azimuth_rate(state, pivot=PIVOT):
    """Return the rod's rate about z from its centre's motion, rad/s."""
    x, y = state.position_w[0] - pivot[0], state.position_w[1] - pivot[1]
    v = state.linear_velocity_w
    return (x * v[1] - y * v[0]) / (x * x + y * y)


def _energy(state, model):
    """Return the rod's energy, J (potential zero at the world origin)."""
    return state.kinetic_energy(model) + M * G * state.position_w[2]


@pytest.mark.parametrize('integrator', ['midpoint_cayley', 'symplectic_euler_quat_exp'])
@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_rod_swung_out_onto_the_rim_stops_dead_and_runs_around_it(h_ns, integrator):
    """
    The rod swings out from inside the 0.6 rad cone onto its rim (the floor on, far below).

    - No overshoot: the angle never exceeds the cone by more than 1e-12 rad (the pre-
      stabilization lands a held row on its bound to ``PROJECTION_TOL`` = 1e-13). Measured
      1.2e-15 rad.
    - No rebound: from the stop on the angle stays on the rim to 1e-12 rad (the rim pushes:
      the rod turns faster than the free conical pendulum; ``held_limits`` reads +1), and the
      rate away from the axis, ``θ̇ = ω · n``, is round-off (bound 1e-12 rad/s, measured 1.6e-15)
      with kick–drift–kick, whose step ends on a post-stabilization at the end pose.
      Symplectic Euler's step ends on the secant rate that carried the pose (``x₁ = x₀ +
      h u₁``, every constraint's rate is the secant's): at the stop's step that is
      ``(α − θ₀)/h`` into the rim, never out of it, and from the next step on the secant's
      between two rim poses ``Δφ = φ̇ h`` apart, ``θ̇ = ½ h φ̇² sin α cos α`` (its O(h²) terms
      are (φ̇ h)² = 2.7e-5 and 2.7e-3 of it: bound 1e-2 relative; measured 0.00638 rad/s).
    - The energy lost is the kinetic energy of the swing into the rim alone, ``½ I1 ω_n²``
      (``cone_stop``: ``L_z`` and the energy conserved to the rim). The stop's impulse is a
      torque pair along the swing axis ``n``, a principal axis of the rod about the pivot with
      ``I1``, so it takes out ``ω_n`` and nothing else; gravity and the pivot's force have no
      moment about z through the pivot, so ``L_z = I1 φ̇ sin²θ`` is kept. On the rim with
      ``θ̇ = 0`` the energy is ``L_z²/(2 I1 sin²α) − m g d cos α + const``, whatever error
      the integrator made on the way: so ``E₀ − E`` after the stop is the closed form to the
      round-off of the state's energy (~1e-14 of 19 J) and the pre-stabilization's 1e-13 rad
      on the rim (times its 1.5 N m): bound 1e-12 J, measured 8.4e-14 J; and it
      stays so (the rim does no work). Symplectic Euler's secant adds ``½ I1 θ̇²`` and its
      change of the rate about z, O((h φ̇²)²) I1: bound ``I1 (h φ̇²)²/8`` (3.1e-5 J at 1 ms),
      measured 9.2e-6 J. The rate about z on the rim is ``L_z / (I1 sin²α)``: 1e-12 rad/s
      (the secant's O(h²) with symplectic Euler: (h φ̇)² of it).
    """
    world = WorldSimulator([_rod()], [_rod_state(THETA0, THETADOT0, PHIDOT0)],
                           StaticWorld(ground_plane()), joints=[_ball(ALPHA)], timestep_ns=h_ns,
                           integrator=integrator)
    model = world.bodies[0].model
    h = h_ns * 1e-9
    _, _, phidot_a, lost = cone_stop(I1, MGD, THETA0, PHIDOT0, ALPHA, up=False,
                                     thetadot0=THETADOT0)
    assert cone_rim_torque(I1, MGD, ALPHA, phidot_a, up=False) < 0.0   # the rim pushes
    kdk = integrator == 'midpoint_cayley'
    secant = 0.0 if kdk else 0.5 * h * phidot_a ** 2 * math.sin(ALPHA) * math.cos(ALPHA)
    e_tol = 1e-12 if kdk else I1 * (h * phidot_a ** 2) ** 2 / 8.0
    spin_tol = 1e-12 if kdk else 2.0 * (h * phidot_a) ** 2 * phidot_a
    e0 = _energy(world.body_state(0), model)
    seen = {'stop': None, 'over': 0.0, 'rate': 0.0, 'below': 0.0, 'lost': 0.0, 'spin': 0.0,
            'held': True, 'landing': None}

    def check(k):
        s = world.body_state(0)
        seen['over'] = max(seen['over'], _angle(s) - ALPHA)
        if seen['stop'] is None and world.held_limits == [1]:
            seen['stop'] = k
            seen['landing'] = _normal_rate(s)
            return
        if seen['stop'] is None:
            seen['gap'] = (ALPHA - _angle(s)) / h   # what would land it on the rim
            return
        seen['rate'] = max(seen['rate'], abs(_normal_rate(s) - secant))
        seen['below'] = max(seen['below'], ALPHA - _angle(s))
        seen['lost'] = max(seen['lost'], abs(e0 - _energy(s, model) - lost))
        seen['spin'] = max(seen['spin'], abs(_azimuth_rate(s) - phidot_a))
        seen['held'] = seen['held'] and world.held_limits == [1]
    _run(world, round(1e9 / h_ns), check)
    assert seen['stop'] is not None and seen['stop'] > 0, seen
    assert seen['over'] <= 1e-12, seen
    if kdk:
        assert abs(seen['landing']) <= 1e-12, seen
        assert seen['rate'] <= 1e-12, seen
    else:
        assert abs(seen['landing'] - seen['gap'] - secant) <= 1e-2 * secant, seen
        assert seen['rate'] <= 1e-2 * secant, seen
    assert seen['below'] <= 1e-12 and seen['held'], seen
    assert seen['lost'] <= e_tol and lost > 1.0, (seen, lost)
    assert seen['spin'] <= spin_tol, seen
    assert len(world.contacts) == 0   # the floor is far below


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_the_contact_step_follows_the_tree_step_onto_the_rim(h_ns):
    """
    The same swing in ``ArticulatedSimulator`` (no floor): the same trajectory, to the methods.

    The two steps are different methods, so not the same bits: the tree step integrates by
    RK4 (O(h⁴)) and stops the rod where it locates the crossing inside the step; the contact
    step by kick–drift–kick (O(h²)) and stops it speculatively, on the rim at the end of the
    step whose drift would cross it. Both stop in the same step or the next (the crossing's
    time differs by the integrators' O(h²)), and both land on the rim with ``θ̇ = 0`` and the
    same ``L_z``, so the same rate about z. The rod's direction differs by the
    kick–drift–kick's global error, ~(ω h)² ω t with ω ~ 5 rad/s over 1 s: 1e-4 at 1 ms and
    1e-2 at 10 ms as bounds; measured 1.4e-5 and 1.1e-3 (the O(h²) ratio, 100). The rate about
    z on the rim: the contact step keeps ``L_z`` to round-off, RK4 to O(h⁴): bounds 1e-10 and
    1e-6 rad/s (the h⁴ ratio, 1e4), measured 6.3e-12 and 8e-8.
    """
    state = _rod_state(THETA0, THETADOT0, PHIDOT0)
    world = WorldSimulator([_rod()], [state], StaticWorld(ground_plane()),
                           joints=[_ball(ALPHA)], timestep_ns=h_ns)
    tree = ArticulatedSimulator([world.bodies[0].model], [state], [_ball(ALPHA)],
                                timestep_ns=h_ns)
    stops = [None, None]
    worst = [0.0, 0.0]

    def check(k):
        tree.step()
        a, b = world.body_state(0), tree.states[0]
        for i, sim in enumerate((world, tree)):
            if stops[i] is None and sim.held_limits == [1]:
                stops[i] = k
        worst[0] = max(worst[0], np.abs(a.rotation_wb()[:, 2] - b.rotation_wb()[:, 2]).max())
        if None not in stops and k > max(stops):
            worst[1] = max(worst[1], abs(_azimuth_rate(a) - _azimuth_rate(b)))
    _run(world, round(1e9 / h_ns), check)
    assert None not in stops and abs(stops[0] - stops[1]) <= 1, stops
    assert worst[0] <= (1e-4 if h_ns == 1_000_000 else 1e-2), worst
    assert worst[1] <= (1e-10 if h_ns == 1_000_000 else 1e-6), worst
    assert tree.held_limits == world.held_limits == [1]


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_rod_sliding_on_the_floor_into_a_tilted_cone_stays_finite_and_inside_it(h_ns):
    """
    The pivot 0.85 m above the floor: the hanging rod (1 m) leans with its tip on the floor.

    The cone (0.7 rad) is tilted 0.3 rad towards +x, so the circle the tip can slide on (the
    rod 0.575 rad off the vertical) is inside it on the +x side and leaves it at an azimuth
    of ±1.80 rad. Started on the +x side turning about z at 3.5 rad/s (below the 4.2 rad/s
    at which its swing out would lift the tip), the rod slides around on its tip (μ = 0.02)
    into the cone's rim at 2.4 rad/s, which stops it there with its tip on the floor: the
    floor's contacts and the held cone in the same steps. It stays finite, inside the cone to
    1e-12 rad (measured 6e-14), on the joint to 1e-12 (m, rad), its tip on the floor from
    the first touch on, and its energy never rises (it falls by the friction's work and the
    stop's; bound: the integrator's error, O((ω h)²) m g L/2 ~ 6e-3 J at 10 ms; measured
    none). It comes to rest on the rim: the floor, the rim and the pivot hold it in a corner
    where the contact step's joint loop stalls (``rbd_ros/core/contact/joints.py``: the
    patch is solved as if the rod were free), so the floor's contact is left approaching
    (6.6e-5 m/s at 1 ms, 2.6e-4 m/s at 10 ms) and pushed out at the next step, which moves
    the rod off the rim; the rest then creeps (the stall's residual). Bounds: 1e-6 rad off
    the rim and 1e-5 rad/s after 3 s (measured 3.5e-9 rad and 1.4e-7 rad/s at 1 ms,
    8.8e-7 rad and 2.8e-6 rad/s at 10 ms; 3.8e-7, 2.4e-7, 1.0e-7 and 8.6e-7 before the
    contacts' targets were taken again about the joint loop's velocities).
    """
    pivot = np.array([0.0, 0.0, 0.85])
    alpha, tilt = 0.7, 0.3
    joint = _ball(alpha, pivot, tilt)
    # the tip's lower corner a millimetre above the floor
    theta0 = math.acos((0.85 - 0.5 * SIDE * math.sin(0.555) - 1e-3) / L)
    world = WorldSimulator([_rod(mu=0.02)], [_rod_state(-theta0, 0.0, 3.5, pivot)],
                           StaticWorld(ground_plane()), joints=[joint], timestep_ns=h_ns)
    model = world.bodies[0].model
    e0 = _energy(world.body_state(0), model)
    seen = {'over': 0.0, 'both': 0, 'rise': -math.inf, 'touch': None, 'lost': 0}

    def check(k):
        s = world.body_state(0)
        assert np.isfinite(s.position_w).all() and np.isfinite(s.angular_velocity_b).all()
        seen['over'] = max(seen['over'], cone_angle(joint, None, s.orientation_wb) - alpha)
        touching = len(world.contacts) > 0
        if seen['touch'] is None and touching:
            seen['touch'] = k
        seen['lost'] += seen['touch'] is not None and not touching
        seen['both'] += world.held_limits == [1] and touching
        seen['rise'] = max(seen['rise'], _energy(s, model) - e0)
    _run(world, round(3e9 / h_ns), check)
    s = world.body_state(0)
    assert seen['over'] <= 1e-12, seen
    assert seen['touch'] is not None and seen['lost'] == 0 and seen['both'] > 0, seen
    assert seen['rise'] <= 6e-3, seen
    assert _energy(s, model) < e0 - 0.5, seen   # 0.8 J of turning at the start
    assert abs(cone_angle(joint, None, s.orientation_wb) - alpha) <= 1e-6, seen
    assert np.abs(s.angular_velocity_b).max() <= 1e-5, (seen, s)
