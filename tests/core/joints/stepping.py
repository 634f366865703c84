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

"""Stepping a jointed contact world with the joints checked after every step."""

import numpy as np

from tests.core.joints.closed_forms import critically_damped

#: The joints' error allowed after every step (m, rad): the issue's bound (the step's own is
#: ``PROJECTION_TOL = 1e-13`` per row; a distance over three rows is up to √3 of it).
JOINT_TOL = 1e-12


def run_checked(sim, n, each=None):
    """Step ``n`` times, checking the joints after every step; return the worst error."""
    worst = 0.0
    for k in range(n):
        sim.step()
        worst = max(worst, *sim.joint_error())
        if each is not None:
            each(k)
    assert worst <= JOINT_TOL, worst
    return worst


def momentum(sim):
    """Return a world's ``(P, L)``: linear (kg m/s), angular about the origin (kg m²/s)."""
    lin, ang = np.zeros(3), np.zeros(3)
    for i, body in enumerate(sim.bodies):
        s = sim.body_state(i)
        p = s.linear_momentum_w(body.model)
        lin += p
        ang += np.cross(s.position_w, p) + s.angular_momentum_w(body.model)
    return lin, ang


def follow_position_targets(sim, joint, targets, omega, n_steps):
    """
    Drive each motor coordinate of ``joint`` from rest to ``targets``; check every step.

    Each coordinate's error must keep its sign (no overshoot, within 1e-12 of round-off), and
    end within 1e-12 of the closed form's own error then (held: after 30 time constants that
    is ``e0 31 e^-30``, 1.5e-12 at 0.5; what is left is RK4's and the projection's
    round-off). Return ``(worst |q - closed form|, worst joint error)`` over the ``n_steps``
    steps, the closed form :func:`~closed_forms.critically_damped` per coordinate.
    """
    for k, target in enumerate(targets):
        sim.set_motor(joint, position=target, time_constant_s=1.0 / omega, coordinate=k)
    worst_follow = worst_joint = 0.0
    for _ in range(n_steps):
        sim.step()
        t = sim.time_ns * 1e-9
        q = sim.joint_positions()[joint]
        for k, target in enumerate(targets):
            worst_follow = max(worst_follow, abs(q[k] - target
                                                 - critically_damped(-target, omega, t)))
            assert (q[k] - target) * -target >= -1e-12, (k, q[k])
        worst_joint = max(worst_joint, *sim.joint_error())
    for k, target in enumerate(targets):
        assert abs(q[k] - target) <= abs(critically_damped(target, omega, t)) + 1e-12, (k, q[k])
    return worst_follow, worst_joint


def motors_on_both_solvers(make, motors, n_steps=500):
    """
    Step ``make(solver=...)`` with joint 0's ``motors`` (``set_motor`` keywords) on both solvers.

    Return ``[(solver, joint positions of joint 0, its coordinate efforts)]``, tree then dense.
    """
    runs = []
    for solver in ('auto', 'dense'):
        sim = make(solver=solver)
        for motor in motors:
            sim.set_motor(0, **motor)
        sim.step(n_steps)
        runs.append((sim.solver, np.array(sim.joint_positions()[0]), sim.coordinate_efforts(0)))
    return runs
