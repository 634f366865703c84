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
:class:`SimSession`: the simulated bodies with their inputs, stepped in sim time (no rclpy).

The node and the replay tool drive exactly this class, so a replay of recorded wrench events
reproduces the live run bit for bit. A single-body params file is a world of one body; which
core simulator steps it is :func:`rbd_ros.sim.build.make_simulator`'s choice. Usage::

    session = SimSession(NodeConfig.from_parameters(params))
    session.submit('wrench', 'world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # next step start
    while not session.finished:
        report = session.advance(100)        # <= 100 steps; stops early at a sample time
        for event in report.events:          # wrenches that took effect, with their step time
            record(event.time_ns, event)
        if report.sample_due:                # an output sample is due at session.time_ns
            publish(session.columns)         # (13, N): every body's packed state

Rules (all in sim time, integer ns):

- A wrench passed to :meth:`submit` takes effect at the START of the next physics step, i.e.
  at the step beginning at the current :attr:`time_ns`; the :class:`AppliedEvent` reports that
  time. Expiries (``wrench_timeout_s``) are applied at the first step start at or after
  ``t_effect + timeout``.
- Output samples are due after the step ending at ``t`` when a multiple of the publish period
  ``P`` lies in ``(t - h, t]``, and at ``t = 0``: :meth:`sample_due` is a pure function of sim
  time, so replay finds the same sample times whatever the wall clock did.
- :meth:`advance` honours :attr:`paused` (it does nothing while paused); :meth:`step` takes one
  step regardless (the ``~/step`` service). Replay sets ``paused = False``.
- :meth:`advance` stops at ``duration_s`` (:attr:`finished`).
- A step that would turn the state non-finite is not taken. If wrenches or drags act in it,
  every one of them is released (a bad input: counted as rejected, reason
  ``'non_finite_step'``, and described in :meth:`pop_releases`) and the step is tried again
  from the last finite state without them: one message never stops the world. If nothing
  acts, the step cannot be taken at all: :class:`rbd_ros.core.NonFiniteError` is raised, its
  ``events`` attribute listing the wrenches applied in that call, so a caller records every
  wrench that took effect, also on a failing run, and the session pauses. Replay runs this
  same rule, so a released input is released again at the same step.
- The simulator is stepped at most :func:`rbd_ros.sim.limits.step_chunk` steps per compiled call,
  so Python signal handlers run between calls (about every 0.1 s).
- Determinism: the simulator is stepped in chunks between events; the core guarantees that the
  chunking does not change the result, so the same config and the same wrenches submitted at
  the same sim times give bit-identical states.

Not thread-safe: call it from one thread (the node uses a single-threaded executor).
"""

from dataclasses import dataclass, field
import hashlib
import struct

from rbd_ros.core import layout, NonFiniteError
from rbd_ros.sim.build import make_simulator
from rbd_ros.sim.drag import DragInputs
from rbd_ros.sim.inputs import WorldInputs
from rbd_ros.sim.joint_commands import CommandEvent, RobotInputs
from rbd_ros.sim.limits import step_chunk
from rbd_ros.sim.world_joints import WorldJointInputs


@dataclass(frozen=True)
class StepReport:
    """
    What one :meth:`SimSession.advance` call did.

    :ivar steps: physics steps taken.
    :ivar events: :class:`rbd_ros.sim.inputs.AppliedEvent` list, wrenches that took effect (each
        with the sim time of the start of its step), in time order.
    :ivar sample_due: True when an output sample is due at the session's current time (the
        call stopped there).
    """

    steps: int = 0
    events: list = field(default_factory=list)
    sample_due: bool = False


class AppliedDigest:
    """
    A running SHA-256 over the wrenches that took effect, bit for bit, in order.

    The node digests what it applied and stores the count and the digest in the recording;
    replay digests what it applied and compares, so a wrench altered in the bag below the
    precision of the outputs is still found.  Per event, in this order: the effect time (int64
    ns, little endian), the input name and the received ``frame_id`` (each a uint32 byte length
    then its UTF-8 bytes), then force and torque as six float64 (little endian).
    """

    def __init__(self):
        self._sha = hashlib.sha256()
        self.count = 0

    def update(self, event):
        """Add one :class:`rbd_ros.sim.inputs.AppliedEvent` (or robot command event)."""
        if isinstance(event, CommandEvent):
            self._command(event)
            return
        name = event.input_name.encode('utf-8')
        frame = event.frame_id.encode('utf-8')
        self._sha.update(struct.pack('<qI', event.time_ns, len(name)) + name
                         + struct.pack('<I', len(frame)) + frame
                         + struct.pack('<6d', *event.force, *event.torque))
        self.count += 1

    def _command(self, event):
        """
        Add a :class:`rbd_ros.sim.joint_commands.CommandEvent`.

        The effect time (int64), the input name (uint32 length, UTF-8), then per target its
        joint index (int32), mode (its first letter) and value (float64); for a trajectory its
        start and point times (int64) and every knot's positions, rates and accelerations
        (float64), all little endian.
        """
        name = event.input_name.encode('utf-8')
        data = struct.pack('<qI', event.time_ns, len(name)) + name
        for target in event.targets:
            data += struct.pack('<ic d', target.joint, target.mode[0].encode(), target.value)
        if event.trajectory is not None:
            traj = event.trajectory
            data += struct.pack(f'<{1 + len(traj.times_ns)}q', traj.start_ns, *traj.times_ns)
            for knot in traj.knots:
                for values in knot:
                    data += struct.pack(f'<{len(values)}d', *values)
        self._sha.update(data)
        self.count += 1

    def hexdigest(self):
        """Return the digest so far, 64 hex digits."""
        return self._sha.hexdigest()


def _drag_inputs(config):
    """Build the :class:`DragInputs` of ``config``: ``<prefix>drag`` per body (``drag``)."""
    p = config.parameters
    return DragInputs([(f'{b.prefix}drag', b.drag_point_b, b.collision_shape)
                       for b in config.bodies], world_frame=config.world_frame,
                      stiffness_n_per_m=p['drag_stiffness_n_per_m'],
                      damping_n_s_per_m=p['drag_damping_n_s_per_m'],
                      click_radius_m=p['drag_click_radius_m'],
                      max_point_m=p['max_drag_point_m'], max_force_n=config.max_force_n,
                      max_torque_nm=config.max_torque_nm)


def _ceil_div(a, b):
    return -(-a // b)


class SimSession:
    """
    The simulator, the wrench inputs and the publish schedule of one node.

    :param config: a :class:`rbd_ros.sim.config.NodeConfig`.
    """

    def __init__(self, config):
        self.config = config
        # Every body of the world (one for a single-body file), with contact or free.
        self.simulator = make_simulator(config)
        self.inputs = WorldInputs(
            config.bodies, world_frame=config.world_frame, timeout_ns=config.wrench_timeout_ns,
            max_force_n=config.max_force_n, max_torque_nm=config.max_torque_nm)
        self.drags = _drag_inputs(config)
        #: The command inputs of the robots (:mod:`rbd_ros.sim.joint_commands`) and of the
        #: world's joints (:class:`rbd_ros.sim.world_joints.WorldJointInputs`); None without.
        self.commands = (WorldJointInputs(config.world_joints, config.wrench_timeout_ns,
                                          config.robots, config.command_groups)
                         if config.world_joints
                         else RobotInputs(config.robots, config.command_groups,
                                          config.wrench_timeout_ns) if config.robots
                         else None)
        self.paused = config.start_paused
        # Steps per compiled call: a signal is seen between calls (rbd_ros.sim.limits.step_chunk).
        self._chunk_max = step_chunk(len(config.bodies))
        self.steps_total = 0  # physics steps taken since start, over resets
        self.resets = 0
        self.error = None  # message of the last NonFiniteError, if any
        # The joint-contact loops' figures since take_joint_loops() (a jointed world with
        # contact): the most joint visits of one stage, the largest contact violation left.
        self._joint_loops = (0, 0.0)
        self._releases = []  # one line per release of the inputs of a non-finite step
        #: Called with the events of a step start (a list, non-empty) before that step runs:
        #: the node records every input that took effect before the step that uses it, so a
        #: step that never returns (a crash, a signal) cannot lose it.
        self.on_applied = None

    @property
    def time_ns(self):
        """Return the sim time, int ns."""
        return self.simulator.time_ns

    @property
    def state(self):
        """Return the current :class:`rbd_ros.core.BodyState` of body 0 (of a file's only one)."""
        return self.simulator.body_state(0)

    def body_state(self, index):
        """Return the current :class:`rbd_ros.core.BodyState` of body ``index``."""
        return self.simulator.body_state(index)

    @property
    def contact_wrenches_w(self):
        """
        Return every body's net contact force and torque over the last step, (N, 6), or None.

        Force in N and torque in N·m about the COM, world frame (the contact impulses of the
        step divided by its length); None when the configuration has no contact.
        """
        return self.simulator.contact_wrench_w

    @property
    def columns(self):
        """Return a read-only view of every body's packed state, (13, N) (see state_column)."""
        return self.simulator.arrays[0]

    @property
    def state_column(self):
        """
        Return a read-only view of body 0's packed state ``(p, q, v, ω_b)`` (13 floats).

        The view follows the simulator (steps and resets write in place): take it once.
        :meth:`rbd_ros.msgs.outputs.BodyOutputs.column_values` reads it without building a
        :class:`rbd_ros.core.BodyState` per sample.
        """
        return self.simulator.arrays[0][:, 0]

    @property
    def timestep_ns(self):
        """Return the physics step, int ns."""
        return self.config.timestep_ns

    @property
    def finished(self):
        """Return True once sim time has reached ``duration_s`` (never when it is 0)."""
        return 0 < self.config.duration_ns <= self.time_ns

    def sample_due(self, time_ns):
        """Return True if an output sample is due at sim time ``time_ns`` (a step end)."""
        if time_ns == 0:
            return True
        period = self.config.publish_period_ns
        return time_ns // period != (time_ns - self.config.timestep_ns) // period

    def submit(self, input_name, frame_id, force, torque, tag=None):
        """
        Queue a received wrench for the start of the next step (see WrenchInputs.submit).

        :param input_name: ``'wrench'`` or an extra input's name.
        :param frame_id: the received ``header.frame_id``.
        :param force: 3 numbers, N. :param torque: 3 numbers, N·m.
        :param tag: returned in the :class:`AppliedEvent` (the node passes the message).
        :raises rbd_ros.sim.inputs.WrenchRejected: counted; nothing queued.
        """
        return self.inputs.submit(input_name, frame_id, force, torque, tag)

    def submit_point(self, input_name, frame_id, point, tag=None):
        """
        Queue a received drag point for the start of the next step (see DragInputs.submit).

        :param input_name: ``'drag'`` (``'<body>/drag'`` in a world) or ``'clicked_point'``.
        :param point: 3 numbers, m, world frame (all NaN releases a drag).
        :raises rbd_ros.sim.inputs.WrenchRejected: counted; nothing queued.
        """
        return self.drags.submit(input_name, frame_id, point, tag)

    def submit_command(self, input_name, payload, tag=None):
        """
        Queue a received robot command for the start of the next step.

        :param input_name: its topic (``<robot>/joint_command``, ``<group>/commands``,
            ``<group>/joint_trajectory``).
        :param payload: see :meth:`rbd_ros.sim.joint_commands.RobotInputs.submit`.
        :raises rbd_ros.sim.joint_commands.CommandRejected: counted; nothing queued.
        """
        spec = self.commands.inputs.get(input_name) if self.commands else None
        state = None
        if spec is not None and spec.kind == 'joint_trajectory':
            world = self.simulator
            state = (world.joint_positions(spec.robot), world.joint_velocities(spec.robot))
        return self.commands.submit(input_name, payload, tag, state)

    def advance(self, max_steps, until_ns=None, through_samples=False):
        """
        Take up to ``max_steps`` steps; stop early when a sample is due or at the duration.

        Also stops when sim time reaches ``until_ns`` (replay: advance to a recorded event).
        Does nothing while :attr:`paused`. ``through_samples``: do not stop at the sample
        times before the last step (the caller builds none of them: nobody listens), so the
        steps between go in fewer, longer compiled calls (the same bits); the report says
        whether a sample is due at the end.

        :raises NonFiniteError: the state stays at its last finite value and the session
            pauses itself (:attr:`error` holds the message); the exception's ``events`` lists
            the wrenches applied in this call (they took effect before the failing step).
        """
        if self.paused:
            return StepReport()
        return self._run(max_steps, until_ns, through_samples=through_samples)

    def step(self):
        """Take exactly one step, paused or not (the ``~/step`` service)."""
        return self._run(1, None, ignore_duration=True)

    def reset(self):
        """Back to the initial state at time 0; pending and held wrenches are dropped."""
        self.simulator.reset()
        self.inputs.clear()
        self.drags.clear()
        if self.commands is not None:
            self.commands.clear()
        self._set_loads()
        self.resets += 1
        self.error = None

    def _joint_stats(self):
        """Return the contact step's joint figures of its last call, None without any."""
        return getattr(getattr(self.simulator, 'articulated', None), 'joint_stats', None)

    def _note_joint_loops(self):
        stats = self._joint_stats()
        if stats is not None:   # a jointed world with contact (its last call's figures)
            loops, left = self._joint_loops
            self._joint_loops = (max(loops, stats[2]), max(left, stats[3]))

    def take_joint_loops(self):
        """
        Return ``(most joint visits of one contact stage, largest contact violation m/s)``.

        Since the last call, over the steps taken, and start over; None but in a jointed
        world with contact. Visits at the cap
        (:data:`rbd_ros.core.contact.joints.JOINT_LOOPS`) are a joint-contact solve that did
        not converge: its steps cost the cap (a squeezed gripper's took ~2.4 s each) and
        leave contacts approaching at the violation.
        """
        figures, self._joint_loops = self._joint_loops, (0, 0.0)
        return None if self._joint_stats() is None else figures

    def pop_releases(self):
        """Return (and forget) one line per release of the inputs of a non-finite step."""
        releases, self._releases = self._releases, []
        return releases

    def _release_inputs(self, exc):
        """
        Release every wrench and drag acting in the step ``exc`` reports; True if any did.

        Each is counted as rejected (``'non_finite_step'``) on its input; robot commands are
        not released (a step of a robot that would be non-finite pauses the session).
        """
        names = self.inputs.release_held() + self.drags.release_held()
        if not names:
            return False
        self._set_loads()
        them = 'it' if len(names) == 1 else 'them'
        self._releases.append(
            f'{", ".join(names)}: released at t = {self.time_ns} ns and counted as rejected '
            f'(non_finite_step): the step would not be finite with {them} acting, so the world '
            f'goes on from its last finite state without {them} [{exc}]')
        return True

    def _set_loads(self):
        for i in range(len(self.config.bodies)):
            self.simulator.set_body_loads(i, self.inputs.body_loads(i), self.drags.springs(i))

    def _state_of(self, index):
        """Return body ``index``'s position, orientation, velocity and ω_b (views, no copy)."""
        x = self.simulator.arrays[0]
        return (x[layout.POS, index], x[layout.QUAT, index], x[layout.VEL, index],
                x[layout.OMEGA, index])

    def _commands_at(self, t):
        """Expire, apply and follow the robot commands at step start ``t``."""
        if self.commands is None:
            return (), False
        world = self.simulator
        self.commands.expire(t, world)
        applied = self.commands.apply_pending(t, world)
        self.commands.follow(t, self.config.timestep_ns, world)
        return applied, self.commands.following

    def steps_to_next_sample(self, time_ns):
        """Return how many steps from ``time_ns`` end at the next output sample (>= 1)."""
        period = self.config.publish_period_ns
        next_multiple = (time_ns // period + 1) * period
        return _ceil_div(next_multiple - time_ns, self.config.timestep_ns)

    def steps_to_next_output(self):
        """
        Return how many steps from now end at the next sample or at ``duration_s`` (>= 1).

        What the node's spin loop waits for: the steps before it have nothing to show.
        """
        steps = self.steps_to_next_sample(self.time_ns)
        if self.config.duration_ns > self.time_ns:
            steps = min(steps, _ceil_div(self.config.duration_ns - self.time_ns,
                                         self.config.timestep_ns))
        return steps

    def _run(self, max_steps, until_ns, ignore_duration=False, through_samples=False):
        h = self.config.timestep_ns
        duration = self.config.duration_ns
        events = []
        done = 0
        while done < max_steps:
            t = self.time_ns
            if duration and t >= duration and not ignore_duration:
                break
            if until_ns is not None and t >= until_ns:
                break
            expired = self.inputs.expire(t)
            applied = self.inputs.apply_pending(t)
            dragged, _ = self.drags.apply_pending(t, self._state_of)
            commands, following = self._commands_at(t)
            if commands:
                events.extend(commands)
                if self.on_applied is not None:
                    self.on_applied(list(commands))
            if applied or expired or dragged:
                self._set_loads()
                events.extend(applied)
                events.extend(dragged)
                if self.on_applied is not None and (applied or dragged):
                    self.on_applied(list(applied) + list(dragged))
            chunk = min(max_steps - done, self._chunk_max)
            if not through_samples:
                chunk = min(chunk, self.steps_to_next_sample(t))
            if following:
                chunk = 1  # a trajectory's reference is set at every step start
            for expiry in (self.inputs.next_expiry_ns(),
                           self.commands.next_expiry_ns() if self.commands else None):
                if expiry is not None:
                    chunk = min(chunk, max(1, _ceil_div(expiry - t, h)))
            if duration and not ignore_duration:
                chunk = min(chunk, max(1, _ceil_div(duration - t, h)))
            if until_ns is not None:
                chunk = min(chunk, max(1, _ceil_div(until_ns - t, h)))
            try:
                self.simulator.step(chunk)
            except NonFiniteError as exc:
                taken = (self.time_ns - t) // h
                self.steps_total += taken
                done += taken
                if self._release_inputs(exc):
                    continue  # the same step again, from the last finite state, without them
                self.paused = True
                self.error = str(exc)
                exc.events = events
                raise
            self.steps_total += chunk
            done += chunk
            self._note_joint_loops()
            if self.sample_due(self.time_ns) and not through_samples:
                return StepReport(done, events, True)
        return StepReport(done, events,
                          through_samples and done > 0 and self.sample_due(self.time_ns))
