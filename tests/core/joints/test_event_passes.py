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

"""A step whose limit events outnumber its passes still takes its whole time (no overshoot)."""

import math

import numpy as np
import pytest

from rbd_ros.core import BodyState
from rbd_ros.core.joints import ArticulatedSimulator, Joint
from rbd_ros.core.joints import kernels as jk
from tests.core.joints.closed_forms import G, pendulum_period
from tests.core.joints.test_articulated import rod_model, y_rotation

#: The issue's bounds after every step: joint error and overshoot beyond a bound (rad).
JOINT_TOL = 1e-12
LIMIT_TOL = 1e-12
UPPER = 0.5


def _rod(body, x_offset, theta0, upper=None):
    """Return body ``body``: a 1 m, 1 kg rod hinged at its top end at (x_offset, 0, 0) about y."""
    com = np.array([x_offset, 0.0, 0.0]) - 0.5 * np.array(
        [math.sin(theta0), 0.0, math.cos(theta0)])
    joint = Joint(f'pivot{body}', 'revolute', None, body,
                  origin_parent_b=(x_offset, 0.0, 0.0), origin_child_b=(0.0, 0.0, 0.5),
                  axis_b=(0.0, 1.0, 0.0), upper=upper)
    return rod_model(), BodyState(com, y_rotation(theta0)), joint


def chattering_pair(step_ns, theta_free):
    """
    Return a simulator of two separate rods: one driven into its stop, one swinging free.

    Rod 0 starts at rest at 0.45 rad under a position target that moves at 1 rad/s (its
    reference rate) past its upper limit 0.5 rad: from ~50 ms on the held limit pauses the
    motor, gravity pulls the rod off the stop, the released motor drives it back in, and a
    step holds more stops than its 2 n + 2 = 6 passes. Rod 1 (its own joint to the world)
    swings from ``theta_free`` with nothing to do with rod 0.
    """
    parts = [_rod(0, 0.0, 0.45, UPPER), _rod(1, 5.0, theta_free)]
    sim = ArticulatedSimulator([p[0] for p in parts], [p[1] for p in parts],
                               [p[2] for p in parts], timestep_ns=step_ns)
    sim.set_motor(0, position=0.45, time_constant_s=0.01, reference_rates=(1.0, 0.0))
    return sim


def swing_angle(sim, b):
    """Return rod ``b``'s angle about y from the downward vertical (its hinge angle)."""
    q = sim.states[b].orientation_wb
    return 2.0 * math.atan2(q[2], q[0])


@pytest.mark.parametrize('step_ns, swing_tol', [(1_000_000, 1e-12), (10_000_000, 1e-9)])
def test_steps_past_the_pass_cap_keep_the_clock_and_the_bound(step_ns, swing_tol):
    theta_free = math.radians(10.0)
    sim = chattering_pair(step_ns, theta_free)
    h = step_ns * 1e-9
    period = pendulum_period(2.0 / 3.0, theta_free, G)   # a thin rod: L_eq = 2 L / 3
    n = round(period / h)
    clamped = 0
    for _ in range(n):
        sim.step()
        clamped += sim.clamped_steps
        # the kernel's clock (the motors' time) ends every step where the simulator's does:
        # the sub-steps' times sum to h (to the ulps of adding up a step's 7 of them)
        _, work = sim.kernel_arrays()
        assert abs(work.stats[jk.S_TIME] - sim.time_ns * 1e-9) <= 1e-15, sim.time_ns
        assert max(sim.joint_error()) <= JOINT_TOL
        assert sim.joint_positions()[0][0] <= UPPER + LIMIT_TOL
    # the passes ran out in every step once the target had passed the bound (from ~50 ms)
    assert clamped >= n - round(0.06 / h), (clamped, n)
    # the rod under the motor ends on its stop, at rest (its speed into it taken out)
    assert abs(sim.joint_positions()[0][0] - UPPER) <= LIMIT_TOL
    assert abs(sim.joint_velocities()[0][0]) <= 1e-12
    # the free rod lost no time to its neighbour's stops: one period after its release it is
    # at theta_free less the turning point's curvature over the d = n h - T it is off the
    # period, (g / L_eq) sin(theta) d^2 / 2 (the next term, ~(g / L)^2 d^4 / 24, is < 1e-11
    # rad). What is left is RK4's amplitude error over one period, O(h^4): measured 1.3e-14
    # rad at 1 ms and 7.1e-10 rad at 10 ms. Losing the rest of each capped step put it
    # 3.2e-3 rad short.
    d = n * h - period
    expected = theta_free - 1.5 * G * math.sin(theta_free) * d * d / 2.0
    assert abs(swing_angle(sim, 1) - expected) <= swing_tol, swing_angle(sim, 1) - expected


def test_many_steps_in_one_call_keep_the_clock():
    # the same run in one call of 200 steps: the clock and the bound as step by step
    sim = chattering_pair(1_000_000, math.radians(10.0))
    sim.step(200)
    _, work = sim.kernel_arrays()
    assert sim.clamped_steps >= 140
    assert abs(work.stats[jk.S_TIME] - 0.2) <= 1e-14
    assert abs(sim.joint_positions()[0][0] - UPPER) <= LIMIT_TOL
    assert max(sim.joint_error()) <= JOINT_TOL
