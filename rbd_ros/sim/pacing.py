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
Wall-clock pacing of the fixed physics step: which steps are due, and what was dropped.

The sim time due is ``sim_anchor + (wall_now - wall_anchor) * real_time_factor`` against an
absolute wall anchor (re-anchored on pause, reset and a change of the factor), so pacing error
does not accumulate. A tick steps for at most :data:`TICK_BUDGET_NS` of wall time; a backlog of
more than :data:`MAX_BACKLOG_STEPS` steps is dropped (the wall time dropped is counted). A
factor of 0 means as fast as possible. Wall time is ``time.monotonic_ns`` unless a clock is
given (tests pass their own).
"""

import time

MAX_BACKLOG_STEPS = 1000  # the catch-up cap: a longer backlog of due steps is dropped
TICK_BUDGET_NS = 10_000_000  # wall time a tick may step for (then serve callbacks)


class Pacer:
    """
    The pacing state of one run: the anchors, the factor, the drop and lag accounting.

    :param real_time_factor: sim seconds per wall second (0: as fast as possible).
    :param clock: wall time in integer ns (monotonic).
    """

    def __init__(self, real_time_factor, clock=time.monotonic_ns):
        """Pace at ``real_time_factor``; anchor with :meth:`anchor` before the first step."""
        self.real_time_factor = real_time_factor
        self.clock = clock
        self.dropped_ns = 0  # sim time dropped from a backlog, in total
        self.dropped_wall_ns = 0  # the wall time it stood for (sim time over the factor)
        self.lag_max_ns = 0  # largest lag of sim time behind its wall-clock target (sim ns)
        self.step_wall_ns = 1_000_000  # wall time per step of the last run (1 ms until measured)
        self.wall_anchor_ns = self.sim_anchor_ns = 0

    def anchor(self, sim_time_ns):
        """Make ``sim_time_ns`` due now (at start, pause, reset and a change of the factor)."""
        self.wall_anchor_ns = self.clock()
        self.sim_anchor_ns = sim_time_ns

    def set_factor(self, real_time_factor, sim_time_ns):
        """Pace at a new factor from ``sim_time_ns`` on."""
        self.real_time_factor = float(real_time_factor)
        self.anchor(sim_time_ns)

    def seconds_to_next_step(self, sim_time_ns, timestep_ns, longest_s=0.1, steps=1):
        """
        Wall seconds until the ``steps``-th step after ``sim_time_ns`` is due (0 at RTF 0).

        At most ``longest_s``. The node asks for the step that ends at the next output sample:
        the steps before it have nothing to show, so it wakes once a sample, not once a step.
        """
        rtf = self.real_time_factor
        if rtf == 0:
            return 0.0
        due_ns = self.wall_anchor_ns + (
            sim_time_ns + steps * timestep_ns - self.sim_anchor_ns) / rtf
        return min(longest_s, max(0.0, (due_ns - self.clock()) * 1e-9))

    def due_steps(self, sim_time_ns, timestep_ns, deferred_ns=0):
        """
        Return ``(steps due now, steps dropped)`` at ``sim_time_ns`` (RTF > 0).

        More than :data:`MAX_BACKLOG_STEPS` due: the cap is kept and the rest dropped (the
        anchor moves on by them and :attr:`dropped_ns` counts them; :attr:`dropped_wall_ns`
        the wall time they stood for). ``deferred_ns``: sim time the caller leaves to step by
        choice (the steps before its next sample), which is not lag.
        """
        elapsed_ns = self.clock() - self.wall_anchor_ns
        rtf = self.real_time_factor
        target_ns = self.sim_anchor_ns + (elapsed_ns if rtf == 1.0 else int(elapsed_ns * rtf))
        self.lag_max_ns = max(self.lag_max_ns, target_ns - sim_time_ns - deferred_ns)
        due = (target_ns - sim_time_ns) // timestep_ns
        if due <= MAX_BACKLOG_STEPS:
            return due, 0
        dropped = due - MAX_BACKLOG_STEPS
        self.dropped_ns += dropped * timestep_ns
        self.dropped_wall_ns += round(dropped * timestep_ns / rtf)
        self.sim_anchor_ns -= dropped * timestep_ns
        return MAX_BACKLOG_STEPS, dropped

    def steps_that_fit(self, n_steps, now_ns, deadline_ns):
        """Return how many of ``n_steps`` the last measured wall time per step fits (>= 1)."""
        return min(n_steps, max(1, (deadline_ns - now_ns) // self.step_wall_ns))

    def measured(self, start_ns, steps):
        """Note that ``steps`` (> 0) steps took the wall time since ``start_ns``."""
        self.step_wall_ns = max(1, (self.clock() - start_ns) // steps)

    def take_lag_max(self):
        """Return the largest lag (ns) seen since the last call, and start over."""
        lag, self.lag_max_ns = self.lag_max_ns, 0
        return lag
