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
Motors on a planar joint's three coordinates (x, y, theta), against closed forms (issue 27).

The puck moves in the vertical plane x-z of the world: the joint's normal ``axis_b`` is +y,
its x axis ``axis2_b`` is +x, so its y axis ``axis_b × axis2_b`` is -z and gravity pulls
along +y with ``m g``. The anchor is 0.2 m from the puck's centre of mass along the body's x,
so gravity also turns theta (``m g r cos θ`` about the anchor) and the three coordinates are
coupled through the dynamics; each motor row still fixes its own coordinate's acceleration.
"""

import math

import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState, ConfigError
from rbd_ros.core.joints import ArticulatedSimulator, Joint
from tests.core.joints.closed_forms import G
from tests.core.joints.stepping import follow_position_targets, motors_on_both_solvers

MASS = 2.0
INERTIA = np.diag([0.05, 0.08, 0.03])   # about the centre; 0.08 about the normal (y)
ARM = 0.2   # anchor to centre of mass, m
# The projection leaves every row within PROJECTION_TOL = 1e-13; the bound is 1e-12.
JOINT_TOL = 1e-12


def puck(step_ns=1_000_000, gravity=G, arm=ARM, effort_limit=None, solver='auto'):
    """Return the puck on its planar joint to the world, at rest at x = y = theta = 0."""
    model = BodyModel(MASS, INERTIA, gravity_w=(0.0, 0.0, -gravity))
    joint = Joint('slide', 'planar', None, 0, axis_b=(0.0, 1.0, 0.0), axis2_b=(1.0, 0.0, 0.0),
                  origin_child_b=(-arm, 0.0, 0.0), effort_limit=effort_limit)
    return ArticulatedSimulator([model], [BodyState((arm, 0.0, 0.0))], [joint],
                                timestep_ns=step_ns, solver=solver)


@pytest.mark.parametrize('step_ns, tol', [(1_000_000, 2e-10), (10_000_000, 2e-5)])
def test_position_targets_follow_the_critically_damped_closed_form(step_ns, tol):
    sim = puck(step_ns)
    targets, omega = (0.3, -0.4, 1.0), 10.0
    worst_follow, worst_joint = follow_position_targets(sim, 0, targets, omega,
                                                        3_000_000_000 // step_ns)
    # each coordinate follows its own closed form to RK4's error: 9.7e-11 measured at 1 ms
    # (1-DOF arm: 7e-11), O(h^4) so 1e4 times that at 10 ms
    assert worst_follow <= tol, worst_follow
    assert worst_joint <= JOINT_TOL, worst_joint
    # the motors carry gravity: y pushes -m g (gravity pulls +y), theta -m g r cos θ, x 0;
    # at rest the row multipliers are the static forces to round-off (the residual motion is
    # e^-30 small)
    efforts = sim.coordinate_efforts(0)
    assert abs(efforts[0]) <= 1e-9
    assert abs(efforts[1] + MASS * G) <= 1e-9 * MASS * G
    assert abs(efforts[2] + MASS * G * ARM * math.cos(targets[2])) <= 1e-9
    assert sim.coordinate_saturated(0) == [False, False, False]
    assert math.isnan(sim.joint_efforts()[0])   # a planar joint has no single effort


def test_tree_and_dense_solvers_agree_on_the_motors():
    runs = motors_on_both_solvers(puck, [
        {'position': 0.2, 'time_constant_s': 0.1, 'coordinate': 'x'},
        {'velocity': 0.5, 'coordinate': 'y'}, {'effort': 0.3, 'coordinate': 'theta'}])
    assert [r[0] for r in runs] == ['tree', 'dense']
    # two direct factorisations of the same system: round-off apart
    assert np.abs(runs[0][1] - runs[1][1]).max() <= 1e-13
    assert np.abs(runs[0][2] - runs[1][2]).max() <= 1e-9


@pytest.mark.parametrize('step_ns', (1_000_000, 10_000_000))
def test_velocity_targets_are_held_exactly_under_gravity(step_ns):
    sim = puck(step_ns)
    rates = (0.4, -0.3, 2.0)
    for k, rate in enumerate(rates):
        sim.set_motor(0, velocity=rate, coordinate=k)
    for _ in range(2_000_000_000 // step_ns):
        sim.step()
        # velocity rows, enforced with the other rows at the end of every step: round-off
        # (the rates of joint_velocity; 1-DOF joints' bound)
        assert np.abs(sim.joint_velocities()[0] - rates).max() <= 1e-12
        assert sim.joint_error()[0] <= JOINT_TOL
    # reached by the first step's velocity projection, held since: q = v (t - h) (theta
    # wrapped to (-pi, pi]), to RK4's error on that uniform motion
    t = sim.time_ns * 1e-9 - step_ns * 1e-9
    q = sim.joint_positions()[0]
    assert abs(q[0] - rates[0] * t) <= 1e-9 and abs(q[1] - rates[1] * t) <= 1e-9
    assert abs(math.remainder(q[2] - rates[2] * t, 2.0 * math.pi)) <= 1e-9
    # y holds gravity and the turning centre's pull (its rate is constant): the centre of
    # mass is arm sin θ along y from the anchor, so m ÿ_com = -m r θ̇² sin θ = F_y + m g;
    # the row's multiplier at the step's end state, to round-off
    expected = -MASS * ARM * rates[2] ** 2 * math.sin(q[2]) - MASS * G
    assert abs(sim.coordinate_efforts(0)[1] - expected) <= 1e-9 * MASS * G


def test_efforts_are_clipped_per_coordinate_and_exact():
    # no gravity, the anchor at the centre of mass: x = F t² / 2m, theta = τ t² / 2 I_yy;
    # RK4 is exact on quadratic motion. The one effort limit (0.5) caps each coordinate:
    # 3 N to 0.5 N on x, -0.2 N on y as given, 0.8 N m to 0.5 N m on theta
    sim = puck(gravity=0.0, arm=0.0, effort_limit=0.5)
    for k, effort in enumerate((3.0, -0.2, 0.8)):
        sim.set_motor(0, effort=effort, coordinate=k)
    assert sim.coordinate_efforts(0).tolist() == [0.5, -0.2, 0.5]
    sim.step(1000)
    q = sim.joint_positions()[0]
    assert abs(q[0] - 0.5 * 0.5 / MASS) <= 1e-12
    assert abs(q[1] + 0.5 * 0.2 / MASS) <= 1e-12
    assert abs(q[2] - 0.5 * 0.5 / INERTIA[1, 1]) <= 1e-12


def test_a_coordinate_saturates_alone_and_says_so():
    # y needs m g = 19.6 N to hold against gravity; the limit is 5 N: y saturates and the
    # puck falls along +y at (m g - 5) / m, x and theta (the anchor at the centre of mass:
    # nothing loads them) keep their targets. (With the anchor off the centre, theta would
    # carry the falling anchor's torque too, and the first solve of a step, all rows on,
    # asks theta for y's unsaturated acceleration: every motor over its limit in that one
    # solve saturates together, as on a 1-DOF arm.)
    sim = puck(effort_limit=5.0, arm=0.0)
    for k in range(3):
        sim.set_motor(0, position=0.0, time_constant_s=0.05, coordinate=k)
    sim.step(100)
    assert sim.coordinate_saturated(0) == [False, True, False]
    assert sim.motor_saturated() == [True]
    efforts = sim.coordinate_efforts(0)
    assert efforts[1] == -5.0
    q = sim.joint_positions()[0]
    t = sim.time_ns * 1e-9
    # y falls as (g - 5/m) t²/2 to RK4's error (exact on it: constant force, theta held)
    assert abs(q[1] - 0.5 * (G - 5.0 / MASS) * t * t) <= 1e-9
    assert abs(q[0]) <= 1e-12 and abs(q[2]) <= 1e-12


def test_motors_between_two_free_bodies_keep_momentum():
    # no gravity: a base and a puck on a planar joint, all three motors driving; the rows are
    # equal and opposite, so the linear momentum stays at its start to round-off
    base = BodyModel(3.0, np.diag([0.2, 0.3, 0.25]), gravity_w=(0.0, 0.0, 0.0))
    top = BodyModel(MASS, INERTIA, gravity_w=(0.0, 0.0, 0.0))
    joint = Joint('slide', 'planar', 0, 1, origin_parent_b=(0.0, 0.1, 0.0),
                  origin_child_b=(-ARM, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0),
                  axis2_b=(1.0, 0.0, 0.0))
    states = [BodyState((0.0, 0.0, 0.0), linear_velocity_w=(0.1, 0.0, 0.2),
                        angular_velocity_b=(0.0, 0.3, 0.0)),
              BodyState((ARM, 0.1, 0.0), angular_velocity_b=(0.0, 0.3, 0.0))]
    sim = ArticulatedSimulator([base, top], states, [joint])
    sim.set_motor(0, position=0.3, time_constant_s=0.1, coordinate=0)
    sim.set_motor(0, velocity=-0.2, coordinate=1)
    sim.set_motor(0, effort=0.4, coordinate=2)
    lin0, _ = sim.momentum()
    for _ in range(1000):
        sim.step()
        assert np.abs(sim.momentum()[0] - lin0).max() <= 1e-14
    assert abs(sim.joint_positions()[0][0] - 0.3) <= 1e-3   # x reached its target


@pytest.mark.parametrize('kwargs, message', [
    ({'effort': 1.0, 'coordinate': 3},
     "joint 'slide'.coordinate: 3 is not a motor coordinate of a planar joint (0 or 'x', "
     "1 or 'y', 2 or 'theta')"),
    ({'effort': 1.0, 'coordinate': 'z'}, "joint 'slide'.coordinate: 'z' is not"),
    ({'position': 4.0, 'time_constant_s': 1.0, 'coordinate': 'theta'},
     "joint 'slide'/theta.position: 4.0 rad must be in (-pi, pi] for a planar joint's theta"),
    ({'velocity': math.nan, 'coordinate': 1}, "joint 'slide'/y.velocity: nan m/s must be finite"),
    ({'effort': math.inf, 'coordinate': 2}, "joint 'slide'/theta.effort: inf N m must be"),
])
def test_bad_planar_motor_commands_name_the_coordinate(kwargs, message):
    sim = puck()
    with pytest.raises(ConfigError) as err:
        sim.set_motor(0, **kwargs)
    assert message in str(err.value)


def test_a_one_coordinate_joint_has_coordinate_zero_only():
    joint = Joint('a', 'revolute', None, 0, axis_b=(0.0, 1.0, 0.0))
    sim = ArticulatedSimulator([BodyModel(1.0, np.eye(3))], [BodyState()], [joint])
    with pytest.raises(ConfigError, match=r"joint 'a'.coordinate: 1 is not a motor "
                                          r'coordinate of a revolute joint \(0 only\)'):
        sim.set_motor(0, effort=1.0, coordinate=1)
