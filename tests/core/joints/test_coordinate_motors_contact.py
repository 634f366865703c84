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
Motors on planar and universal joints in the contact step (``WorldSimulator.set_motor``).

The bodies of ``test_planar_motors.py`` and ``test_universal_motors.py``: a 2 kg puck on a
planar joint in the vertical plane x-z (its y axis ``axis_b × axis2_b`` is -z, so gravity
pulls +y with ``m g``, its anchor 0.2 m off its centre of mass, so gravity turns theta too),
and a 1 m rod hanging from a universal joint (``θ1`` about x, ``θ2`` about the rod's own cross
axis, y at rest). The contact step lands each motor coordinate on the exact critically damped
response at every step's end (:mod:`rbd_ros.core.contact.motors`), one motor slot a
coordinate, so the closed form ``q* + e0 (1 + ω t) e^(−ω t)`` holds to the landing tolerance
(1e-13 a step, carried on by the response), against RK4's 1e-10 in the articulated step.
"""

import math

import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState
from rbd_ros.core.contact import Material, primitive_shape
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.core.joints import Joint
from rbd_ros.core.joints.model import joint_position, joint_velocity
from rbd_ros.core.rotations import quat_to_matrix
from tests.core.joints.closed_forms import critically_damped, G
from tests.core.joints.stepping import momentum, run_checked

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
