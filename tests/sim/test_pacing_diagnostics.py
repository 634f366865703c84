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


def test_the_node_wakes_at_its_samples_and_deferred_steps_are_not_lag():
    # 100 Hz samples at 1 ms steps: the spin loop sleeps until the step that ends at the next
    # sample is due (the nine before it publish nothing), or at duration_s if that comes first.
    session = SimSession(NodeConfig.from_parameters({'duration_s': 0.015}))
    assert session.steps_to_next_output() == 10  # t = 0 -> the sample at 10 ms
    session.advance(3)
    assert session.steps_to_next_output() == 7
    session.advance(7)
    assert session.time_ns == 10 * MS and session.steps_to_next_output() == 5  # the end, 15 ms
    clock = HandClock()
    pacer = pacing.Pacer(1.0, clock=clock)
    pacer.anchor(10 * MS)
    # the 5th step after 10 ms is due 5 ms of wall from the anchor
    assert math.isclose(pacer.seconds_to_next_step(10 * MS, MS, steps=5), 5e-3, rel_tol=1e-12)
    clock.now_ns += 5 * MS
    # woken on time: 5 due, 4 of them left by choice; the lag is the one step a wake-up
    # every step saw too, not 5
    assert pacer.due_steps(10 * MS, MS, deferred_ns=4 * MS) == (5, 0)
    assert pacer.take_lag_max() == 1 * MS
    clock.now_ns += 20 * MS  # 20 ms late: lag
    pacer.due_steps(10 * MS, MS, deferred_ns=4 * MS)
    assert pacer.take_lag_max() == 21 * MS


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


def test_the_wall_time_dropped_is_the_sim_time_dropped_over_the_factor():
    # At 4x, 1250 steps of 1 ms fall due in 312.5 ms of wall time; the 250 dropped stood for
    # 62.5 ms of it (the diagnostics' wall_time_dropped_s), not 250 ms (their sim time).
    clock = HandClock()
    pacer = pacing.Pacer(4.0, clock=clock)
    pacer.anchor(0)
    clock.now_ns += (pacing.MAX_BACKLOG_STEPS + 250) * MS // 4
    assert pacer.due_steps(0, MS) == (pacing.MAX_BACKLOG_STEPS, 250)
    assert (pacer.dropped_ns, pacer.dropped_wall_ns) == (250 * MS, 250 * MS // 4)


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


def test_a_joint_contact_solve_that_does_not_converge_is_a_warning_naming_it():
    # A gripper (velocity group, trajectory closing it to -0.01 m) squeezes a 2 cm box on its
    # palm: from t = 78 ms its finger's motor saturates against the box and the joint visits
    # alternating with the contact sweeps run to their cap (64 a stage) without converging,
    # each step ~2.4 s of wall time (1 s of sim time took > 10 min), silently. Before the squeeze
    # the loops converge in a few visits.
    import os
    from rbd_ros.core.contact.joints import JOINT_LOOPS
    from rbd_ros.sim.trajectory import TrajectoryPoint
    urdf = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
        os.path.abspath(__file__)))), 'msg_config', 'urdf', 'gripper.urdf')
    session = SimSession(NodeConfig.from_parameters({
        'robot_names': ['gripper'], 'robots.gripper.urdf_path': urdf,
        'gravity': [0.0, 0.0, -9.81], 'body_names': ['box'], 'bodies.box.shape': 'box',
        'bodies.box.dimensions_m': [0.02, 0.02, 0.02], 'bodies.box.mass_kg': 0.05,
        'bodies.box.initial_position': [0.0, 0.0, 1.05], 'ground.enabled': True,
        'command_group_names': ['g'], 'command_groups.g.robot': 'gripper',
        'command_groups.g.interface': 'velocity'}))
    session.paused = False
    diagnostics = Diagnostics(session, pacing.Pacer(1.0))
    session.advance(10)
    session.submit_command('g/joint_trajectory', (['finger_left'], 0, [
        TrajectoryPoint(100_000_000, [-0.01]), TrajectoryPoint(200_000_000, [0.02])]))
    while session.time_ns < 70_000_000:  # the box landed on the palm, between the fingers
        session.advance(10)
    values = diagnostics.values()
    assert 0 < values['joint_contact_loops_max'] < JOINT_LOOPS, values
    assert status(session, values) == ('ok', 'running')
    while session.time_ns < 79_000_000:  # the squeeze
        session.advance(10)
    values = diagnostics.values()
    assert values['joint_contact_loops_max'] == JOINT_LOOPS, values
    left = values['joint_contact_left_max_m_s']
    assert left > 1e-3, values  # measured 0.12 m/s: far from the sweeps' 1e-12 m/s
    assert status(session, values) == (
        'warn', f'running; a joint-contact solve did not converge in {JOINT_LOOPS} joint '
        f'visits (slow steps; contacts left approaching at up to {left:.3g} m/s)')
    assert diagnostics.values()['joint_contact_loops_max'] == 0  # taken: since the last read


def test_a_robots_steps_split_into_sub_steps_are_counted():
    # The URDF pendulum (1.5 m rod, I about the pivot 0.75 kg m^2) at 20 ms, started at 8 rad/s
    # from hanging: 0.16 rad a step, so its first steps are split (kernels.SUBSTEP_ROTATION
    # = 0.1 rad) until gravity has slowed it to 5 rad/s (w^2 = 64 - 19.62 (1 - cos q): at
    # q ~ 2.1 rad); at 1 ms from 0.5 rad at rest (3.7 rad/s at most) none is.
    import os
    urdf = os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
        os.path.abspath(__file__)))), 'msg_config', 'urdf', 'pendulum.urdf')
    for step_s, rate, split in ((0.02, 8.0, True), (0.001, 0.0, False)):
        session = SimSession(NodeConfig.from_parameters({
            'robot_names': ['pendulum'], 'robots.pendulum.urdf_path': urdf,
            'robots.pendulum.initial_joint_positions': [0.0 if split else 0.5],
            'robots.pendulum.initial_joint_velocities': [rate],
            'gravity': [0.0, 0.0, -9.81], 'timestep_s': step_s}))
        session.paused = False
        diagnostics = Diagnostics(session, pacing.Pacer(1.0))
        assert diagnostics.values()['joint_steps_split'] == 0
        while session.steps_total < 5:   # an advance returns at a sample
            session.advance(5 - session.steps_total)
        values = diagnostics.values()
        core = session.simulator.articulated
        assert values['joint_steps_split'] == core.split_steps_total
        # 5 steps at 20 ms turn it ~0.75 rad, still above 6 rad/s: every one split in 2
        assert values['joint_steps_split'] == (5 if split else 0), values
        assert core.split_steps[1] == (2 if split else 1)   # the last call's most sub-steps
        assert status(session, values) == ('ok', 'running')
