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
Motors on a universal joint's two angles, against closed forms (issue 27).

A rod hangs from a universal joint at the world origin: the first angle θ1 turns about the
world's x (``axis_b``), the second θ2 about the rod's own cross axis (``axis2_b``, y at rest),
so the rod's direction is ``R_x(θ1) R_y(θ2) (0, 0, -1)`` and gravity loads both angles.
"""

import math

import numpy as np
import pytest

from rbd_ros.core import BodyModel, BodyState, ConfigError
from rbd_ros.core.joints import ArticulatedSimulator, Joint
from rbd_ros.core.rotations import quat_to_matrix
from tests.core.joints.closed_forms import G
from tests.core.joints.stepping import follow_position_targets, motors_on_both_solvers

MASS, LENGTH = 1.0, 1.0
# The projection leaves every row within PROJECTION_TOL = 1e-13; the bound is 1e-12.
JOINT_TOL = 1e-12


def rod(step_ns=1_000_000, gravity=G, effort_limit=None, solver='auto', inertia=None,
        anchor=0.5 * LENGTH):
    """Return the simulator of a hanging rod at rest on its universal joint, body z along it."""
    if inertia is None:
        inertia = np.diag([MASS * LENGTH ** 2 / 12.0, MASS * LENGTH ** 2 / 12.0, 1e-3])
    model = BodyModel(MASS, inertia, gravity_w=(0.0, 0.0, -gravity))
    joint = Joint('cardan', 'universal', None, 0, axis_b=(1.0, 0.0, 0.0),
                  axis2_b=(0.0, 1.0, 0.0), origin_child_b=(0.0, 0.0, anchor),
                  effort_limit=effort_limit)
    return ArticulatedSimulator([model], [BodyState((0.0, 0.0, -anchor))], [joint],
                                timestep_ns=step_ns, solver=solver)


@pytest.mark.parametrize('step_ns, tol', [(1_000_000, 2e-10), (10_000_000, 2e-5)])
def test_position_targets_follow_the_critically_damped_closed_form(step_ns, tol):
    sim = rod(step_ns)
    targets, omega = (0.5, -0.7), 10.0
    worst_follow, worst_joint = follow_position_targets(sim, 0, targets, omega,
                                                        3_000_000_000 // step_ns)
    # each angle follows its own closed form to RK4's error (O(h^4): 1e4 times at 10 ms)
    assert worst_follow <= tol, worst_follow
    assert worst_joint <= JOINT_TOL, worst_joint
    # the motors carry gravity's torque about the anchor on each axis (the axes are
    # perpendicular, the alignment row's torque across both): efforts -τ_g · e, -τ_g · f
    rot = quat_to_matrix(sim.states[0].orientation_wb)
    r = rot @ np.array([0.0, 0.0, -0.5 * LENGTH])
    torque = np.cross(r, np.array([0.0, 0.0, -MASS * G]))
    cross_axis = rot @ np.array([0.0, 1.0, 0.0])
    efforts = sim.coordinate_efforts(0)
    # at rest to the closed form's residual acceleration ω² e ~ 1e-11
    assert abs(efforts[0] + torque[0]) <= 1e-9
    assert abs(efforts[1] + torque @ cross_axis) <= 1e-9
    assert sim.coordinate_saturated(0) == [False, False]
    assert math.isnan(sim.joint_efforts()[0])


def test_tree_and_dense_solvers_agree_on_the_motors():
    runs = motors_on_both_solvers(rod, [
        {'position': 0.4, 'time_constant_s': 0.1, 'coordinate': 'theta1'},
        {'velocity': 0.5, 'coordinate': 'theta2'}])
    assert [r[0] for r in runs] == ['tree', 'dense']
    assert np.abs(runs[0][1] - runs[1][1]).max() <= 1e-13   # two direct solves: round-off
    assert np.abs(runs[0][2] - runs[1][2]).max() <= 1e-9


@pytest.mark.parametrize('step_ns', (1_000_000, 10_000_000))
def test_velocity_targets_are_held_exactly_under_gravity(step_ns):
    sim = rod(step_ns)
    rates = (1.0, -0.5)
    for k, rate in enumerate(rates):
        sim.set_motor(0, velocity=rate, coordinate=k)
    for _ in range(2_000_000_000 // step_ns):
        sim.step()
        # velocity rows held at the end of every step (joint_velocity's θ̇2 is on the
        # child's cross axis, exact): round-off
        assert np.abs(sim.joint_velocities()[0] - rates).max() <= 1e-12
        assert max(sim.joint_error()) <= JOINT_TOL
    # reached by the first step's velocity projection, held since: q = v (t - h)
    t = sim.time_ns * 1e-9 - step_ns * 1e-9
    assert np.abs(sim.joint_positions()[0] - np.array(rates) * t).max() <= 1e-9


@pytest.mark.parametrize('k', (0, 1))
def test_an_effort_on_one_angle_turns_the_rod_about_that_axis_exactly(k):
    # no gravity, a ball-like body (isotropic inertia 0.1) anchored at its centre: a torque
    # on one angle turns it about that axis alone, θ = τ t² / 2I (RK4 exact on it), the other
    # angle stays 0; the effort limit 0.3 N m clips 2 N m
    sim = rod(gravity=0.0, effort_limit=0.3, inertia=0.1 * np.eye(3), anchor=0.0)
    sim.set_motor(0, effort=2.0, coordinate=k)
    assert sim.coordinate_efforts(0)[k] == 0.3
    sim.step(1000)
    q = sim.joint_positions()[0]
    assert abs(q[k] - 0.3 / (2.0 * 0.1)) <= 1e-12
    assert abs(q[1 - k]) <= 1e-15


def test_motors_between_two_free_bodies_keep_momentum():
    model = BodyModel(MASS, np.diag([0.08, 0.08, 0.01]), gravity_w=(0.0, 0.0, 0.0))
    joint = Joint('cardan', 'universal', 0, 1, origin_parent_b=(0.0, 0.0, -0.5),
                  origin_child_b=(0.0, 0.0, 0.5), axis_b=(1.0, 0.0, 0.0),
                  axis2_b=(0.0, 1.0, 0.0))
    states = [BodyState((0.0, 0.0, 0.0), linear_velocity_w=(0.1, 0.0, 0.2)),
              BodyState((0.0, 0.0, -1.0), angular_velocity_b=(0.0, 0.0, 0.4))]
    sim = ArticulatedSimulator([model, model], states, [joint])
    sim.set_motor(0, position=0.6, time_constant_s=0.1, coordinate=0)
    sim.set_motor(0, effort=0.2, coordinate=1)
    lin0, _ = sim.momentum()
    for _ in range(1000):
        sim.step()
        assert np.abs(sim.momentum()[0] - lin0).max() <= 1e-14   # equal and opposite rows
    assert abs(sim.joint_positions()[0][0] - 0.6) <= 1e-3


@pytest.mark.parametrize('kwargs, message', [
    ({'effort': 1.0, 'coordinate': 2},
     "joint 'cardan'.coordinate: 2 is not a motor coordinate of a universal joint (0 or "
     "'theta1', 1 or 'theta2')"),
    ({'position': -4.0, 'time_constant_s': 1.0, 'coordinate': 'theta2'},
     "joint 'cardan'/theta2.position: -4.0 rad must be in (-pi, pi] for a universal joint's "
     'theta2'),
    ({'velocity': math.inf, 'coordinate': 0},
     "joint 'cardan'/theta1.velocity: inf rad/s must be finite"),
])
def test_bad_universal_motor_commands_name_the_coordinate(kwargs, message):
    sim = rod()
    with pytest.raises(ConfigError) as err:
        sim.set_motor(0, **kwargs)
    assert message in str(err.value)
