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

"""The spherical joint's cone limit (issue 27 items 1 and 4) against closed forms."""

import math

import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState, ConfigError
from rbd_ros.core.joints import ArticulatedSimulator, cone_angle, Joint
from rbd_ros.core.rotations import quat_from_axis_angle
from tests.core.joints.closed_forms import cone_rim_torque, cone_stop, G

STEPS_NS = (1_000_000, 10_000_000)
# The projection leaves every row within PROJECTION_TOL = 1e-13 (m, or the cosine of an angle
# off 90 deg), the held cone row too; the bound is 1e-12 m and rad.
JOINT_TOL = 1e-12
# The rod: 1 m, 1 kg, uniform (a 1e-3 polar moment keeps I positive definite); about its end
# I1 = m L^2 / 12 + m (L/2)^2 = 1/3 kg m^2 across it, and m g d = g / 2 N m.
I1 = 1.0 / 3.0
MGD = 0.5 * G


def rod_on_ball(theta0, phidot0, alpha, up, step_ns, linear_damping=0.0):
    """
    Return a rod on a ball joint at the world origin with a cone limit ``alpha`` about +-z.

    The rod (body z) leaves its end at the origin ``theta0`` off the cone's axis (+z when
    ``up``, -z hanging), in the x-z plane, turning about z at ``phidot0`` with no spin about
    its own axis (``omega = phidot0 (z - cos theta0 f)``, ``f`` the rod's unit vector).
    """
    s = 1.0 if up else -1.0
    model = BodyModel(1.0, np.diag([1.0 / 12.0, 1.0 / 12.0, 1e-3]), gravity_w=(0.0, 0.0, -G),
                      linear_damping_per_s=linear_damping)
    q = quat_from_axis_angle(np.array([0.0, 1.0, 0.0]), theta0)
    state = BodyState(orientation_wb=q)
    rot = state.rotation_wb()
    f = s * rot[:, 2]
    omega_w = phidot0 * (np.array([0.0, 0.0, 1.0]) - f[2] * f)
    com = 0.5 * f
    state = BodyState(com, q, np.cross(omega_w, com), rot.T @ omega_w)
    joint = Joint('ball', 'spherical', None, 0, origin_child_b=(0.0, 0.0, -0.5 * s),
                  axis_b=(0.0, 0.0, s), cone_rad=alpha)
    return ArticulatedSimulator([model], [state], [joint], timestep_ns=step_ns)


def angle(sim):
    """Return the rod's angle off the cone's axis, rad."""
    return cone_angle(sim.joints[0], None, sim.states[0].orientation_wb)


def azimuth_rate(sim):
    """Return the rod's rate about z from its centre's motion, rad/s."""
    s = sim.states[0]
    x, y = s.position_w[0], s.position_w[1]
    return (x * s.linear_velocity_w[1] - y * s.linear_velocity_w[0]) / (x * x + y * y)


def potential(alpha, up):
    """Return the rod's potential energy at ``alpha`` off the axis, J (zero at the pivot)."""
    return (1.0 if up else -1.0) * MGD * math.cos(alpha)


@pytest.mark.parametrize('step_ns', STEPS_NS)
@pytest.mark.parametrize('phidot0', (0.0, 3.0))
def test_rod_falls_onto_the_rim_stops_dead_and_keeps_its_swing_around_it(phidot0, step_ns):
    # an inverted rod 0.5 rad off the upward axis falls out onto the rim of a 1 rad cone,
    # swinging around it at phidot0 (0: a planar fall); outward gravity and centrifugal
    # force then keep it on the rim, held by the stop
    theta0, alpha = 0.5, 1.0
    omega_n, omega_t, phidot_a, lost = cone_stop(I1, MGD, theta0, phidot0, alpha)
    sim = rod_on_ball(theta0, phidot0, alpha, True, step_ns)
    e0 = sim.energy()
    stops, angles, worst = [], [], 0.0
    for _ in range(1_000_000_000 // step_ns):
        sim.step()
        if sim.last_stop is not None:
            stops.append((sim.last_stop, len(angles)))
        angles.append(angle(sim))
        worst = max(worst, *sim.joint_error())
    assert len(stops) == 1, stops
    (joint, _, speed), k = stops[0]
    assert joint == 0
    # the speed into the rim is sqrt(2 E_n / I1) from energy and L_z conservation, within
    # RK4's error on the fall (kept to ~h^4) and the crossing located to 1e-14 rad: 3.5e-12
    # relative measured at 1 ms and 3.5e-8 at 10 ms
    speed_tol = 1e-10 if step_ns == 1_000_000 else 1e-6
    assert abs(speed / omega_n - 1.0) <= speed_tol
    # no overshoot beyond 1e-12 rad; no rebound: on the rim from the stop on, held
    assert max(angles) <= alpha + 1e-12
    assert min(angles[k:]) >= alpha - 1e-12
    assert sim.held_limits == [1]
    assert worst <= JOINT_TOL
    # the stop removes the normal kinetic energy 1/2 I1 omega_n^2 (all of it when planar), to
    # RK4's energy error over the 0.3 s fall, ~h^4 (1.3e-12 J measured at 1 ms, 4.5e-9 J at
    # 10 ms), and the held rim does no work after
    e_tol = 1e-11 if step_ns == 1_000_000 else 1e-7
    assert abs((e0 - sim.energy()) - lost) <= e_tol
    # the tangential swing is kept: the azimuth rate L_z / (I1 sin^2 alpha) (2.4e-12 and
    # 2e-8 rad/s measured), the kinetic energy 1/2 I1 omega_t^2
    rate_tol = 1e-11 if step_ns == 1_000_000 else 1e-7
    assert abs(azimuth_rate(sim) - phidot_a) <= rate_tol
    assert abs(sim.energy() - potential(alpha, True) - 0.5 * I1 * omega_t ** 2) <= e_tol
    # the stop holds the rod with the closed form's torque about the swing axis (the point
    # rows add no torque about the anchor): m g d sin a + I1 phidot^2 sin a cos a, off by the
    # rate's error times 2 I1 phidot sin a cos a (6.4e-13 and 5.8e-9 N m measured)
    torque = np.linalg.norm(sim.joint_wrenches()[0, 3:6])
    assert abs(torque + cone_rim_torque(I1, MGD, alpha, phidot_a)) <= 10 * rate_tol


@pytest.mark.parametrize('step_ns', STEPS_NS)
def test_conical_pendulum_runs_along_the_rim_of_the_cone(step_ns):
    # a hanging rod started on the rim of a 0.6 rad cone, turning 1.5 times as fast as the
    # free conical pendulum at that angle (phidot^2 = m g d / (I1 cos a)): it would swing out,
    # so the rim holds it at a constant angle and it runs around it at a constant rate
    alpha = 0.6
    free = math.sqrt(MGD / (I1 * math.cos(alpha)))
    rate = 1.5 * free
    sim = rod_on_ball(alpha, rate, alpha, False, step_ns)
    e0 = sim.energy()
    angles, rates, worst = [], [], 0.0
    for _ in range(3_000_000_000 // step_ns):
        sim.step()
        angles.append(angle(sim))
        rates.append(azimuth_rate(sim))
        worst = max(worst, *sim.joint_error())
    assert sim.held_limits == [1]
    assert max(abs(a - alpha) for a in angles) <= 1e-12
    assert worst <= JOINT_TOL
    # held at a constant angle, the rod keeps L_z = I1 phidot sin^2 a and so its rate (and
    # its tip's rim speed L phidot sin a), to RK4's error over 3 s: 3.7e-13 and 3.7e-8
    # relative measured, the energy 1.6e-12 J and 1.6e-7 J
    tol = 1e-11 if step_ns == 1_000_000 else 1e-6
    assert max(abs(r - rate) for r in rates) <= tol * rate
    assert abs(sim.energy() - e0) <= tol
    # the rim pushes with I1 phidot^2 sin a cos a - m g d sin a (3.46 N m), off by the rate's
    # error times 2 I1 phidot sin a cos a (4.6e-12 and 4.6e-7 N m measured)
    torque = np.linalg.norm(sim.joint_wrenches()[0, 3:6])
    assert abs(torque + cone_rim_torque(I1, MGD, alpha, rate, up=False)) <= 10 * tol


@pytest.mark.parametrize('step_ns', STEPS_NS)
def test_cone_lets_go_at_once_when_the_rod_slows_below_the_free_conical_rate(step_ns):
    # the conical pendulum on the rim with a linear damping c: the force -m c v at the centre
    # is along the rim (no torque along theta), so phidot = phidot0 exp(-k t),
    # k = m c d^2 / I1; the rim pushes while I1 phidot^2 cos a > m g d and lets go at the
    # first step boundary after t* = ln(phidot0 / free) / k, the rod swinging in at once
    alpha, c = 0.6, 0.5
    free = math.sqrt(MGD / (I1 * math.cos(alpha)))
    rate0 = 1.2 * free
    k_decay = c * 0.25 / I1
    t_release = math.log(rate0 / free) / k_decay
    sim = rod_on_ball(alpha, rate0, alpha, False, step_ns, linear_damping=c)
    h = step_ns * 1e-9
    held, angles, released = [], [], None
    for i in range(1_500_000_000 // step_ns):
        sim.step()
        held.append(sim.held_limits[0])
        angles.append(angle(sim))
        if released is None and held[-1] == 0 and max(held) == 1:
            released = i
    assert released is not None
    # released at the boundary after t*: the multiplier changes sign there (RK4's error in
    # exp(-k t) moves t* by far less than a step)
    assert t_release <= (released + 1) * h <= t_release + h
    assert max(angles) <= alpha + 1e-12
    # no sticking: from the release on the rod swings in, away from the rim. Its pull on the
    # rim grows from 0 at t* as d tau / dt = -2 I1 phidot phidot' sin a cos a (1.8 N m/s), so
    # it leaves as (1/6) (d tau / dt / I1) t^3: 1.1e-4 rad in 0.05 s; half that bounds it
    after = angles[released:released + int(0.05 / h) + 1]
    assert max(after) <= alpha + 1e-12
    assert after[-1] < alpha - 5e-5


def two_rods(cone, step_ns, solver='auto'):
    """Return two free rods (body x) joined end to end by a ball joint with a cone on x."""
    model = BodyModel(1.0, np.diag([1e-3, 1.0 / 12.0, 1.0 / 12.0]))
    model2 = BodyModel(0.6, np.diag([1e-3, 0.05, 0.05]))
    joint = Joint('ball', 'spherical', 0, 1, origin_parent_b=(0.5, 0.0, 0.0),
                  origin_child_b=(-0.5, 0.0, 0.0), axis_b=(1.0, 0.0, 0.0), cone_rad=cone)
    states = [BodyState((0.0, 0.0, 0.0), linear_velocity_w=(0.1, -0.2, 0.3),
                        angular_velocity_b=(0.4, 0.5, -1.0)),
              BodyState((1.0, 0.0, 0.0), linear_velocity_w=(-0.3, 0.2, 0.1),
                        angular_velocity_b=(1.0, -2.0, 1.5))]
    return ArticulatedSimulator([model, model2], states, [joint], timestep_ns=step_ns,
                                solver=solver)


@pytest.mark.parametrize('step_ns', STEPS_NS)
def test_cone_stops_between_two_free_bodies_keep_momentum(step_ns):
    # no gravity: the limit's impulses and torques are equal and opposite, so every stop
    # keeps linear and angular momentum, and takes energy out only
    sim = two_rods(0.4, step_ns)
    p0, l0 = sim.momentum()
    e_prev, stops, worst, angles = sim.energy(), 0, 0.0, []
    rise_tol = 1e-12 if step_ns == 1_000_000 else 1e-8
    for _ in range(3_000_000_000 // step_ns):
        sim.step()
        stops += sim.last_stop is not None
        worst = max(worst, *sim.joint_error())
        states = sim.states  # each readout once a step (a tuple of BodyState per call)
        angles.append(cone_angle(sim.joints[0], states[0].orientation_wb,
                                 states[1].orientation_wb))
        # stops only take energy out; between them RK4 keeps it to ~h^4
        energy = sim.energy()
        assert energy - e_prev <= rise_tol
        e_prev = energy
    p, ang = sim.momentum()
    assert stops >= 1
    assert max(angles) <= 0.4 + 1e-12
    assert worst <= JOINT_TOL
    # linear momentum to round-off (the impulses are equal and opposite row by row; 1.2e-15
    # measured); angular momentum to RK4's O(h^4) over 3 s as for the free chain without a
    # cone (1.7e-14 and 2e-10 measured)
    assert np.abs(p - p0).max() <= 1e-13
    assert np.abs(ang - l0).max() <= (1e-12 if step_ns == 1_000_000 else 1e-8)


def test_tree_and_dense_solvers_agree_on_a_cone():
    tree, dense = two_rods(0.4, 1_000_000), two_rods(0.4, 1_000_000, solver='dense')
    assert (tree.solver, dense.solver) == ('tree', 'dense')
    tree.step(1500)
    dense.step(1500)
    # the same rows solved two ways: round-off over the stop and 1.5 s (3.6e-16 m measured)
    for a, b in zip(tree.states, dense.states):
        assert np.abs(a.position_w - b.position_w).max() <= 1e-12


def test_start_outside_the_cone_is_refused():
    with pytest.raises(ConfigError, match=r"joint 'ball'.cone_rad: the initial angle off the "
                                          r'axis 0.7\d* rad is beyond cone_rad 0.6 rad'):
        rod_on_ball(0.7, 0.0, 0.6, False, 1_000_000)
