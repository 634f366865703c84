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

r"""
Joint commands as the ROS tools send them: validated, pending, then held in sim time (no rclpy).

Three ways in, each read into :class:`JointTarget` values (one motor target per joint):

- ``<robot>/joint_command``, a ``sensor_msgs/JointState`` by joint name (what
  topic_based_ros2_control sends): per joint, a finite ``position`` gives a position target; else
  a finite ``velocity`` a velocity target; else a finite ``effort`` an effort. NaN, or an empty
  array, leaves that joint as it was (so one message may command some joints only). A joint
  with a position and a velocity given takes the position (the core's motor has one mode).
- ``<group>/commands``, a ``std_msgs/Float64MultiArray``, one value per joint of the group in
  the group's order, read as the group's ``interface`` (what forward_command_controller and its
  ``JointGroup{Position,Velocity,Effort}Controller``\\ s take).
- ``<group>/joint_trajectory`` (:mod:`rbd_ros.sim.trajectory`): position targets every step.

Rejected whole, counted by reason (:data:`REJECT_REASONS`), one line naming the field: a joint
name that the robot does not have or that is given twice, a mimic joint (it follows its
leader and takes no command), an array whose length is neither 0 nor
the number of names (a Float64MultiArray: not the group's size), an infinite value (or NaN in a
Float64MultiArray), a position beyond a limit (the core's rule,
:func:`rbd_ros.core.joints.model.check_position_target`), a trajectory of more than
:data:`MAX_TRAJECTORY_POINTS` points (from their count, before any is read). A velocity
target beyond the URDF's ``<limit velocity>`` is clipped to it; an effort beyond ``effort``
is clipped by the motor.

A target takes effect at the start of the next step and is held until replaced, as a wrench is;
with ``wrench_timeout_s > 0`` it expires as a wrench does and leaves the joint free.

**Joints of several coordinates.** A planar joint is three entries of ``joint_states`` and of
the commands, ``<joint>/x``, ``<joint>/y`` and ``<joint>/theta``, and a universal joint two,
``<joint>/theta1`` and ``<joint>/theta2`` (:func:`coordinate_entries`: MoveIt's names of a
planar joint's variables, ``<joint>/<variable>``), each commanded, limited and held as a
one-coordinate joint (the core's motor of that coordinate,
:meth:`rbd_ros.core.joints.ArticulatedSimulator.set_motor`'s ``coordinate``): x and y as a
prismatic joint's (m, m/s, N), theta and the universal angles as a revolute joint's (rad in
``(-π, π]``, rad/s, N m). The joint's one velocity limit and effort limit cap each.
"""

from dataclasses import dataclass
import math
from typing import Optional, Sequence, Tuple

from rbd_ros.core import RbdError
from rbd_ros.core.joints.model import check_position_target, coordinate_units, MOTOR_COORDINATES
from rbd_ros.sim.inputs import WrenchRejected
from rbd_ros.sim.trajectory import parse_trajectory

#: Rejection reasons, in the order they are checked.
REJECT_REASONS = ('unknown_joint', 'duplicate_joint', 'mimic_joint', 'length', 'non_finite',
                  'limit')
#: The interfaces of a command group (ros2_control's command interface names).
INTERFACES = ('position', 'velocity', 'effort')
#: The largest target a joint takes, by interface (rad, rad/s, N m; m, m/s, N for a prismatic
#: joint), and the largest acceleration a trajectory point gives (rad/s² or m/s²). Beyond, a
#: command is refused (``limit``): a continuous joint's angle past 1e6 rad keeps no 1e-10 rad
#: of precision; a velocity of 1e3 rad/s turns a joint 1 rad a 1 ms step, what the contact
#: step still follows; an effort of 1e6 is the default ``max_torque_nm`` / ``max_force_n`` of
#: a wrench. A joint without URDF limits took any finite value, and a step that could not
#: follow it paused the world (1e300 rad/s, 1e12 N m).
MAX_TARGET = {'position': 1e6, 'velocity': 1e3, 'effort': 1e6}
MAX_ACCELERATION = 1e5
#: The most points a trajectory takes (``limit`` beyond), refused from the count before any
#: point is read: 100 000 points blocked the node's executor for ~4.8 s (each point converted,
#: checked when received and again when it takes effect, ~50 µs a time); 1000 take 0.09 s
#: and 0.07 s, 10 000 took 0.5 s and 0.6 s (measured on a loaded 2-core machine). MoveIt's
#: and most planners' trajectories have tens to hundreds of points; 10 s at 100 Hz fit.
MAX_TRAJECTORY_POINTS = 1000


def coordinate_entries(name: str, kind: str) -> Tuple[Tuple[str, Optional[int]], ...]:
    """
    Return the ``joint_states`` entries of joint ``name`` of ``kind``: ``(entry, coordinate)``.

    A one-coordinate joint (revolute, continuous, prismatic) is one entry, its name, coordinate
    None; a planar joint three, ``<name>/x``, ``<name>/y``, ``<name>/theta``, and a universal
    joint two, ``<name>/theta1``, ``<name>/theta2``, coordinates 0, 1, (2) (the core's motor
    coordinates, :data:`rbd_ros.core.joints.model.MOTOR_COORDINATES`); other kinds none.
    """
    names = MOTOR_COORDINATES.get(kind, ())
    if len(names) == 1:
        return ((name, None),)
    return tuple((f'{name}/{coordinate}', k) for k, coordinate in enumerate(names))


class CommandRejected(WrenchRejected):
    """A command was rejected whole; :attr:`reason` is one of :data:`REJECT_REASONS`."""


@dataclass(frozen=True)
class JointTarget:
    """
    One joint's motor target.

    :ivar joint: the joint's index among the robot's moving joints (``joint_states`` order).
    :ivar mode: one of :data:`INTERFACES`.
    :ivar value: rad, rad/s or N m (m, m/s or N for a prismatic joint); a velocity already
        clipped to the joint's velocity limit.
    """

    joint: int
    mode: str
    value: float


@dataclass(frozen=True)
class JointSpec:
    """
    What a command needs to know of a ``joint_states`` entry: its core joint and velocity limit.

    ``coordinate``: None for a one-coordinate joint; a planar or universal joint's coordinate
    (:func:`coordinate_entries`).
    """

    name: str
    core: object  # rbd_ros.core.joints.Joint
    velocity_limit: Optional[float]
    coordinate: Optional[int] = None

    @property
    def units(self) -> Tuple[str, str, str]:
        """Return its ``(position, velocity, effort)`` units."""
        return coordinate_units(self.core, self.coordinate or 0)


def _target(topic, where, spec, index, mode, value):
    if mode == 'position':
        try:
            check_position_target(spec.core, value, coordinate=spec.coordinate or 0)
        except RbdError as exc:
            raise CommandRejected('limit', f'{topic}: {where}: {exc}') from None
    elif mode == 'velocity' and spec.velocity_limit is not None:
        value = min(max(value, -spec.velocity_limit), spec.velocity_limit)
    _bounded(topic, where, spec, value, MAX_TARGET[mode], mode)
    return JointTarget(index, mode, float(value))


def _bounded(topic, where, spec, value, bound, mode):
    """Refuse ``value`` beyond ``±bound`` (``limit``), naming it with its unit."""
    if not abs(value) <= bound:
        position, velocity, effort = spec.units
        unit = {'position': position, 'velocity': velocity, 'effort': effort,
                'acceleration': f'{position}/s²'}[mode]
        raise CommandRejected('limit', f'{topic}: {where}: {value!r} {unit} is beyond the '
                              f'largest {mode} a joint takes, {bound:g} {unit}')


def in_range(joint, value, coordinate=None):
    """
    Return ``value`` moved into the position targets ``joint`` can hold.

    Those are its limits and a revolute joint's ``(-π, π]`` (a planar joint's theta and a
    universal joint's angles too, ``coordinate``): where a followed trajectory's spline
    overshoots a limit between points that are within it, its reference rests at the limit
    (the core refuses a target beyond).
    """
    lower, upper = joint.lower, joint.upper
    angle = joint.kind in ('planar', 'universal') and \
        coordinate_units(joint, coordinate or 0)[0] == 'rad'
    if joint.kind == 'revolute' or angle:
        least = math.nextafter(-math.pi, 0.0)
        lower = least if lower is None else max(lower, least)
        upper = math.pi if upper is None else min(upper, math.pi)
    if lower is not None and value < lower:
        return float(lower)
    if upper is not None and value > upper:
        return float(upper)
    return value


def _floats(topic, field, values, n):
    try:
        out = [float(v) for v in values]
    except (TypeError, ValueError):
        raise CommandRejected('non_finite', f'{topic}: {field}: not numbers') from None
    if len(out) not in (0, n):
        raise CommandRejected('length', f'{topic}: {field}: {len(out)} values for {n} names '
                              '(give one per name, or none)')
    for k, v in enumerate(out):
        if math.isinf(v):
            raise CommandRejected('non_finite', f'{topic}: {field}[{k}]: {v!r} is not finite '
                                  '(NaN leaves the joint as it was; inf is refused)')
    return out


def joint_state_targets(topic: str, joints: Sequence[JointSpec], names: Sequence[str],
                        position: Sequence[float] = (), velocity: Sequence[float] = (),
                        effort: Sequence[float] = (),
                        owner: str = 'this robot') -> Tuple[JointTarget, ...]:
    """
    Return the targets of a ``JointState`` command, or raise :class:`CommandRejected`.

    :param joints: the robot's moving joints, ``joint_states`` order.
    :param owner: whose joints they are, as an unknown name's rejection says it.
    """
    index = {spec.name: k for k, spec in enumerate(joints)}
    seen = {}
    for k, name in enumerate(names):
        if name not in index:
            raise CommandRejected('unknown_joint', f'{topic}: name[{k}]: {name!r} is not a '
                                  f'moving joint of {owner} ({", ".join(index)})')
        if name in seen:
            raise CommandRejected('duplicate_joint', f'{topic}: name[{k}]: {name!r} is also '
                                  f'name[{seen[name]}]')
        seen[name] = k
        leader = joints[index[name]].core.mimic
        if leader is not None:
            raise CommandRejected('mimic_joint', f'{topic}: name[{k}]: {name!r} is a mimic joint '
                                  f'(of {leader!r}) and takes no command; command {leader!r}')
    n = len(names)
    fields = [(mode, _floats(topic, mode, values, n))
              for mode, values in zip(INTERFACES, (position, velocity, effort))]
    targets = []
    for k, name in enumerate(names):
        for mode, values in fields:
            if values and not math.isnan(values[k]):
                targets.append(_target(topic, f'{mode}[{k}] ({name})', joints[index[name]],
                                       index[name], mode, values[k]))
                break
    return tuple(targets)


def group_targets(topic: str, joints: Sequence[JointSpec], group: Sequence[int],
                  interface: str, data: Sequence[float]) -> Tuple[JointTarget, ...]:
    """
    Return the targets of a ``Float64MultiArray`` on a group, or raise :class:`CommandRejected`.

    :param group: the group's joints, as indices into ``joints``, in the group's order.
    :param interface: one of :data:`INTERFACES`.
    """
    try:
        values = [float(v) for v in data]
    except (TypeError, ValueError):
        raise CommandRejected('non_finite', f'{topic}: data: not numbers') from None
    names = [joints[j].name for j in group]
    if len(values) != len(group):
        raise CommandRejected('length', f'{topic}: data: {len(values)} values for the '
                              f'{len(group)} joints of the group ({", ".join(names)})')
    for k, v in enumerate(values):
        if not math.isfinite(v):
            raise CommandRejected('non_finite', f'{topic}: data[{k}] ({names[k]}): {v!r} is '
                                  f'not a finite {interface}')
    return tuple(_target(topic, f'data[{k}] ({names[k]})', joints[j], j, interface, v)
                 for k, (j, v) in enumerate(zip(group, values)))


@dataclass(frozen=True)
class CommandEvent:
    """
    A command that took effect: at the start of the step beginning at ``time_ns``.

    :ivar time_ns: sim time of that step's start, int ns.
    :ivar input_name: the topic it arrived on (``<robot>/joint_command``, ``<g>/commands``,
        ``<g>/joint_trajectory``), relative.
    :ivar robot: the robot's index.
    :ivar targets: the :class:`JointTarget` values (empty for a trajectory).
    :ivar trajectory: the :class:`rbd_ros.sim.trajectory.Trajectory`, or None.
    :ivar tag: whatever the caller passed to ``submit`` (the node passes the message).
    """

    time_ns: int
    input_name: str
    robot: int
    targets: Tuple[JointTarget, ...] = ()
    trajectory: object = None
    tag: object = None


@dataclass(frozen=True)
class CommandInput:
    """One command topic: its kind and robot, and whose joints they are (``owner``)."""

    name: str
    kind: str
    robot: int
    group: Tuple[int, ...] = ()
    interface: str = 'position'
    owner: str = 'this robot'  # whose joints, as a rejection names them


def command_inputs(robots, groups) -> Tuple[CommandInput, ...]:
    """Return every command topic of ``robots`` and ``groups``, in a fixed order."""
    inputs = [CommandInput(f'{robot.name}/joint_command', 'joint_command', r)
              for r, robot in enumerate(robots)]
    for group in groups:
        inputs.append(CommandInput(f'{group.name}/commands', 'commands', group.robot,
                                   group.joints, group.interface))
        inputs.append(CommandInput(f'{group.name}/joint_trajectory', 'joint_trajectory',
                                   group.robot, group.joints))
    return tuple(inputs)


def motor_settings(targets, core_joints, time_constants_s, coordinates=()):
    """
    Return ``[(core joint index, set_motor keywords)]`` for held ``targets``.

    ``targets``: ``(joint, mode, value, rates or None)``, ``joint`` indexing the ``joint_states``
    entries that ``core_joints`` maps to the core's joints and ``coordinates`` (when given) to
    their motor coordinates (None: a one-coordinate joint's); a position target takes that
    entry's ``time_constants_s`` (s) and, when given, ``rates`` (a followed trajectory's
    reference rate and acceleration). What a robot's and a world's ``set_targets`` hand to the
    core's ``set_motors``.
    """
    motors = []
    for joint, mode, value, rates in targets:
        kwargs = {mode: value}
        if coordinates and coordinates[joint] is not None:
            kwargs['coordinate'] = coordinates[joint]
        if mode == 'position':
            kwargs['time_constant_s'] = time_constants_s[joint]
            if rates is not None:
                kwargs['reference_rates'] = rates
        motors.append((core_joints[joint], kwargs))
    return motors


def release(sim, joint, coordinate=None):
    """Turn the core motor of ``joint`` (its ``coordinate``'s, when not None) off."""
    if coordinate is None:
        sim.set_motor(joint)
    else:
        sim.set_motor(joint, coordinate=coordinate)


class RobotInputs:
    """
    The robots' command inputs: checked when received, applied at a step start, held.

    A received command is *pending* until :meth:`apply_pending`; its targets are then set on
    the :class:`~rbd_ros.sim.robot_world.RobotWorld` and held. A trajectory is followed: at
    every step start (:meth:`follow`) each of its joints is given the reference then, its
    rate and acceleration as feed-forward (the target moves with them inside the step). A
    later command on a joint of a followed trajectory ends that trajectory. With
    ``timeout_ns > 0`` a target expires like a wrench (at the first step start at or after
    ``t_effect + timeout``) and leaves the joint free; a trajectory expires ``timeout_ns``
    after its last point.

    :param robots: the :class:`rbd_ros.sim.robots.RobotConfig` tuple.
    :param groups: the :class:`rbd_ros.sim.robots.CommandGroup` tuple.
    """

    def __init__(self, robots, groups, timeout_ns=0):
        self.robots = tuple(robots)
        self.inputs = {spec.name: spec for spec in command_inputs(robots, groups)}
        self._specs = [robot.joint_specs() for robot in self.robots]
        self._timeout_ns = int(timeout_ns)
        self.received = dict.fromkeys(self.inputs, 0)
        self.rejected = {}  # reason -> count
        self._pending = []  # (input, payload, tag)
        self._expiry = {}  # (robot, joint) -> sim time its target expires
        self._following = []  # [CommandEvent of a trajectory, ...]

    @property
    def received_total(self) -> int:
        """Return how many commands arrived (accepted or not)."""
        return sum(self.received.values())

    @property
    def rejected_total(self) -> int:
        """Return how many were rejected."""
        return sum(self.rejected.values())

    @property
    def following(self) -> bool:
        """Return True while a trajectory is being followed (it needs a target every step)."""
        return bool(self._following)

    def _reject(self, exc):
        self.rejected[exc.reason] = self.rejected.get(exc.reason, 0) + 1
        raise exc

    def submit(self, input_name, payload, tag=None, state=None):
        """
        Check a received command; queue it for the start of the next step.

        :param payload: ``joint_command``: ``(names, position, velocity, effort)``;
            ``commands``: the data values; ``joint_trajectory``: ``(joint_names, stamp_ns,
            points)`` with :class:`rbd_ros.sim.trajectory.TrajectoryPoint` points.
        :param state: ``(q, q̇)`` of the robot now (to check a trajectory); None for others.
        :raises CommandRejected: counted; nothing queued.
        """
        spec = self.inputs.get(input_name)
        if spec is None:
            raise CommandRejected('unknown_joint', f'{input_name}: not a command input '
                                  f'({", ".join(self.inputs)})')
        self.received[input_name] += 1
        try:
            value = self._check(spec, payload, state)
        except WrenchRejected as exc:  # a CommandRejected or TrajectoryRejected
            self._reject(exc)
        self._pending.append((spec, payload, value, tag))

    def _check(self, spec, payload, state, effect_ns=0):
        specs = self._specs[spec.robot]
        if spec.kind == 'joint_command':
            return joint_state_targets(spec.name, specs, *payload, owner=spec.owner)
        if spec.kind == 'commands':
            return group_targets(spec.name, specs, spec.group, spec.interface, payload)
        names, stamp_ns, points = payload
        if len(points) > MAX_TRAJECTORY_POINTS:
            raise CommandRejected('limit', f'{spec.name}: points: {len(points)} points is beyond '
                                  f'the most a trajectory takes, {MAX_TRAJECTORY_POINTS}')
        q, qd = state
        group_names = [specs[j].name for j in spec.group]
        traj = parse_trajectory(spec.name, group_names, names, stamp_ns, points, effect_ns,
                                [q[j] for j in spec.group], [qd[j] for j in spec.group])
        knots = traj.knots
        for p in range(len(traj.times_ns)):  # every point must be a target its joints can hold
            _, v, a = knots[p + 1]
            for k, j in enumerate(spec.group):
                where = f'points[{p}].%s ({specs[j].name})'
                _target(spec.name, where % 'positions', specs[j], j, 'position',
                        float(traj.point_positions(p)[k]))
                _bounded(spec.name, where % 'velocities', specs[j], float(v[k]),
                         MAX_TARGET['velocity'], 'velocity')
                _bounded(spec.name, where % 'accelerations', specs[j], float(a[k]),
                         MAX_ACCELERATION, 'acceleration')
        return traj

    def apply_pending(self, time_ns, world):
        """Set the pending commands on ``world`` at the step starting at ``time_ns``."""
        events = []
        for spec, payload, value, tag in self._pending:
            r = spec.robot
            if spec.kind == 'joint_trajectory':
                traj = self._check(spec, payload, (world.joint_positions(r),
                                                   world.joint_velocities(r)), time_ns)
                self._end_following(r, spec.group)
                event = CommandEvent(time_ns, spec.name, r, (), traj, tag)
                self._following.append((event, spec.group))
                for j in spec.group:
                    self._expiry.pop((r, j), None)
            else:
                joints = [t.joint for t in value]
                self._end_following(r, joints)
                world.set_targets(r, [(t.joint, t.mode, t.value, None) for t in value])
                if self._timeout_ns:
                    for target in value:
                        self._expiry[(r, target.joint)] = time_ns + self._timeout_ns
                event = CommandEvent(time_ns, spec.name, r, value, None, tag)
            events.append(event)
        self._pending.clear()
        return events

    def _end_following(self, robot, joints):
        joints = set(joints)
        self._following = [(event, group) for event, group in self._following
                           if event.robot != robot or not joints & set(group)]

    def follow(self, time_ns, timestep_ns, world):
        """
        Give each followed trajectory's joints its reference now, rates as feed-forward.

        The position and rate are the reference's at the step start, the acceleration its value
        at mid-step: the step's mean acceleration for a cubic (whose acceleration is linear in
        time), so the target's rate at the step end is the reference's, and what the joint
        lags behind is of order h² (measured: 7.6e-6 rad at the waypoints of a 3-link arm's
        cubic with the start-of-step acceleration, 5e-8 with this one). Where the reference is
        beyond a limit (held at it, :func:`in_range`) or faster than :data:`MAX_TARGET`'s
        velocity or :data:`MAX_ACCELERATION`, it is given without feed-forward.
        """
        for event, group in self._following:
            q, qd, _ = event.trajectory.sample(time_ns)
            qdd = event.trajectory.sample(time_ns + timestep_ns // 2)[2]
            specs = self._specs[event.robot]
            targets = []
            for k, j in enumerate(group):
                held = in_range(specs[j].core, float(q[k]), specs[j].coordinate)
                rates = (float(qd[k]), float(qdd[k]))
                if held != q[k] or not (abs(rates[0]) <= MAX_TARGET['velocity']
                                        and abs(rates[1]) <= MAX_ACCELERATION):
                    rates = (0.0, 0.0)  # beyond a limit, or faster than a step can follow
                targets.append((j, 'position', held, rates))
            world.set_targets(event.robot, targets)
        if self._timeout_ns:
            ended = [(event, group) for event, group in self._following
                     if time_ns >= event.trajectory.end_ns + self._timeout_ns]
            for event, group in ended:
                self._following.remove((event, group))
                for j in group:
                    world.release(event.robot, j)

    def expire(self, time_ns, world):
        """Release the targets whose timeout has come (the joints are free again)."""
        for key in [key for key, t in self._expiry.items() if t <= time_ns]:
            del self._expiry[key]
            world.release(*key)

    def next_expiry_ns(self):
        """Return the earliest expiry time, or None."""
        return min(self._expiry.values()) if self._expiry else None

    def clear(self):
        """Drop pending, held and followed commands (a reset)."""
        self._pending.clear()
        self._expiry.clear()
        self._following.clear()
