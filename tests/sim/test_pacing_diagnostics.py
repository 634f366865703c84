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
The wall-clock pacing and the diagnostics values, without ROS: a clock the test turns by hand.

What used to be testable only through DDS (the node's pacing and ``/diagnostics`` arithmetic)
lives in :mod:`rbd_ros.sim.pacing` and :mod:`rbd_ros.sim.diagnostics`; these tests drive them
with a hand clock and a real :class:`rbd_ros.sim.session.SimSession`, and check each figure
against what the pacing rule says it must be, computed here by hand.
"""

import math

from rbd_ros.sim import pacing
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.diagnostics import Diagnostics, status
from rbd_ros.sim.session import SimSession

MS = 1_000_000


class HandClock:
    """A monotonic clock in ns that moves only when told."""

    def __init__(self):
        self.now_ns = 10 * MS

    def __call__(self):
        return self.now_ns


def test_steps_become_due_at_the_real_time_factor():
    clock = HandClock()
    pacer = pacing.Pacer(2.0, clock=clock)
    pacer.anchor(0)
    assert pacer.due_steps(0, MS) == (0, 0)
    clock.now_ns += 5 * MS  # 5 ms of wall time at factor 2: 10 ms of sim time, 10 steps of 1 ms
    assert pacer.due_steps(0, MS) == (10, 0)
    # 3 of them taken: 7 due; the lag is what was due minus where the sim is
    assert pacer.due_steps(3 * MS, MS) == (7, 0)
    assert pacer.take_lag_max() == 10 * MS
    assert pacer.take_lag_max() == 0  # taken: starts over
    # the next step (at 10 ms) is due at wall anchor + 10 ms / 2: now; the one after in 0.5 ms
    assert pacer.seconds_to_next_step(9 * MS, MS) == 0.0
    assert math.isclose(pacer.seconds_to_next_step(10 * MS, MS), 0.5e-3, rel_tol=1e-12)


def test_a_backlog_over_the_cap_is_dropped_and_counted():
    clock = HandClock()
    pacer = pacing.Pacer(1.0, clock=clock)
    pacer.anchor(0)
    behind = pacing.MAX_BACKLOG_STEPS + 250
    clock.now_ns += behind * MS
    assert pacer.due_steps(0, MS) == (pacing.MAX_BACKLOG_STEPS, 250)
    assert pacer.dropped_ns == 250 * MS
    # the anchor moved on by the drop: after the cap is stepped, nothing more is due
    assert pacer.due_steps(pacing.MAX_BACKLOG_STEPS * MS, MS) == (0, 0)


def test_a_change_of_factor_re_anchors_without_a_jump():
    clock = HandClock()
    pacer = pacing.Pacer(1.0, clock=clock)
    pacer.anchor(0)
    clock.now_ns += 4 * MS
    pacer.set_factor(0.5, 4 * MS)  # 4 steps taken, factor halved now
    clock.now_ns += 4 * MS  # 4 ms of wall at 0.5: 2 more steps
    assert pacer.due_steps(4 * MS, MS) == (2, 0)
    pacer.set_factor(0, 6 * MS)  # as fast as possible: the next step is due at once
    assert pacer.seconds_to_next_step(6 * MS, MS) == 0.0


def test_the_tick_fits_the_steps_the_measured_step_time_allows():
    clock = HandClock()
    pacer = pacing.Pacer(1.0, clock=clock)
    start = clock()
    clock.now_ns += 3 * MS
    pacer.measured(start, 6)  # 0.5 ms a step
    assert pacer.step_wall_ns == MS // 2
    now = clock()
    assert pacer.steps_that_fit(100, now, now + pacing.TICK_BUDGET_NS) == 20
    assert pacer.steps_that_fit(5, now, now + pacing.TICK_BUDGET_NS) == 5
    assert pacer.steps_that_fit(100, now, now) == 1  # always at least one


def test_diagnostics_measure_the_factor_between_reads_and_the_energy():
    clock = HandClock()
    config = NodeConfig.from_parameters({'mass_kg': 2.0, 'initial_linear_velocity': [3.0, 0, 4.0],
                                         'gravity': [0.0, 0.0, 0.0]})
    session = SimSession(config)
    session.paused = False
    pacer = pacing.Pacer(1.0, clock=clock)
    diagnostics = Diagnostics(session, pacer, clock=clock)
    while session.steps_total < 20:  # advance stops at each sample due
        session.advance(20 - session.steps_total)
    clock.now_ns += 40 * MS  # 20 steps of 1 ms in 40 ms of wall: factor 0.5
    values = diagnostics.values()
    assert values['steps_taken'] == 20
    assert math.isclose(values['real_time_factor'], 0.5, rel_tol=1e-12)
    # 1/2 m |v|^2 = 1/2 * 2 kg * 25 m^2/s^2, free flight with no gravity or damping: kept
    # to round-off (1e-12 relative: 20 steps of a few flops each)
    assert math.isclose(values['kinetic_energy_j'], 25.0, rel_tol=1e-12)
    assert values['angular_momentum_norm_nms'] == 0.0
    assert status(session, values) == ('ok', 'running')
    session.paused = True
    assert status(session, diagnostics.values()) == ('ok', 'paused')


def test_a_non_finite_value_is_a_warning_naming_it():
    config = NodeConfig.from_parameters({})
    session = SimSession(config)
    level, message = status(session, {'kinetic_energy_j': float('inf'), 'steps_taken': 3})
    assert level == 'warn'
    assert message.endswith('not finite: kinetic_energy_j'), message
