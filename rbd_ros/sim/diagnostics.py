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
The values the node publishes on ``/diagnostics`` once a second, and their level and message.

ROS-free: :class:`Diagnostics` reads the session and the :class:`rbd_ros.sim.pacing.Pacer`;
:func:`rbd_ros.msgs.conversions.diagnostics_to_msg` makes the message of its values.
"""

import math
import time

import numpy as np
from rbd_ros.core import layout
from rbd_ros.core.contact.joints import JOINT_LOOPS
from rbd_ros.core.rotations import quat_rotate


def energy_and_momentum(session):
    """Return the kinetic energy (J) and angular momentum (N·m·s, world) of all bodies."""
    config = session.config
    if config.robots and not config.contact:  # every link (the articulated simulator's bodies)
        sim = session.simulator.articulated
        energy = sum(float(s.kinetic_energy(m)) for m, s in zip(sim.models, sim.states))
        return energy, [float(v) for v in sim.momentum()[1]]
    # Every body at once from the packed states (13, N): a BodyState per body took ~0.4 ms a
    # body, 0.4 s a second of a 1000-body node's time. With robots, their links too.
    x, bodies = session.columns, config.bodies
    if config.robots:  # the contact world's every body: the free bodies, then the links
        world = session.simulator.world
        x, bodies = world.arrays[0], world.bodies
    mass = np.array([b.model.mass_kg for b in bodies])
    inertia_b = np.array([b.model.inertia_b for b in bodies])
    v_w = x[layout.S_VEL:layout.S_VEL + 3].T
    omega_b = x[layout.S_OMEGA:layout.S_OMEGA + 3].T
    spin_b = np.einsum('nij,nj->ni', inertia_b, omega_b)  # I_b ω_b, each body's L in its frame
    energy = 0.5 * (float(mass @ np.einsum('ni,ni->n', v_w, v_w))
                    + float(np.einsum('ni,ni->', omega_b, spin_b)))
    momentum = quat_rotate(x[layout.S_QUAT:layout.S_QUAT + 4].T, spin_b).sum(axis=0)
    return energy, [float(v) for v in momentum]


def status(session, values):
    """Return ``(level, message)`` of ``values``: 'error', 'warn' or 'ok', and why."""
    non_finite = [key for key, value in values.items()
                  if isinstance(value, float) and not math.isfinite(value)]
    commands = session.commands.rejected_total if session.commands is not None else 0
    level = 'error' if session.error else (
        'warn' if (session.inputs.rejected_total or session.drags.rejected_total or commands
                   or non_finite) else 'ok')
    message = session.error or ('paused' if session.paused else 'running')
    if non_finite:
        message += '; not finite: ' + ', '.join(non_finite)
    if values.get('joint_contact_loops_max', 0) >= JOINT_LOOPS:
        level = 'error' if level == 'error' else 'warn'
        message += (f'; a joint-contact solve did not converge in {JOINT_LOOPS} joint visits '
                    '(slow steps; contacts left approaching at up to '
                    f"{values['joint_contact_left_max_m_s']:.3g} m/s)")
    return level, message


class Diagnostics:
    """The diagnostics of one session; the real-time factor is measured between two reads."""

    def __init__(self, session, pacer, clock=time.monotonic_ns):
        """Measure from now."""
        self.session, self.pacer, self.clock = session, pacer, clock
        self.start()

    def start(self):
        """Measure the real-time factor from now."""
        s = self.session
        self._last = (self.clock(), s.time_ns, s.steps_total)

    def values(self):
        """Return name -> value (numbers, bools) since the last call; reset the lag maximum."""
        s, now = self.session, self.clock()
        wall0, sim0, _ = self._last
        self._last = (now, s.time_ns, s.steps_total)
        energy, momentum = energy_and_momentum(s)
        commands = {}
        if s.commands is not None:
            commands = {'commands_received': s.commands.received_total,
                        'commands_rejected': s.commands.rejected_total,
                        **{f'commands_rejected_{k}': v for k, v in s.commands.rejected.items()}}
            joint_error = s.simulator.articulated.joint_error()  # None before the first step
            if joint_error is not None:
                commands['joint_error_max_m'], commands['joint_error_max_rad'] = joint_error
            split = getattr(s.simulator.articulated, 'split_steps_total', None)
            if split is not None:   # the robots' RK4 step: its steps taken in sub-steps
                commands['joint_steps_split'] = split
            loops = s.take_joint_loops()  # None: no joint-contact solve in this world
            if loops is not None:
                commands['joint_contact_loops_max'], commands['joint_contact_left_max_m_s'] = loops
        return {
            'sim_time_s': s.time_ns * 1e-9,
            'real_time_factor': (s.time_ns - sim0) / max(1, now - wall0),
            'real_time_factor_target': self.pacer.real_time_factor,
            'steps_taken': s.steps_total,
            'paused': s.paused, 'wrenches_received': s.inputs.received_total,
            'wrenches_rejected': s.inputs.rejected_total,
            'drags_received': s.drags.received, 'drags_rejected': s.drags.rejected_total,
            **{f'wrenches_rejected_{k}': v for k, v in s.inputs.rejected.items()},
            **{f'drags_rejected_{k}': v for k, v in s.drags.rejected.items()},
            'kinetic_energy_j': energy,
            'angular_momentum_norm_nms': math.hypot(*momentum),
            'wall_time_dropped_s': self.pacer.dropped_wall_ns * 1e-9, 'resets': s.resets,
            'pacing_lag_max_ms': self.pacer.take_lag_max() * 1e-6, **commands}
