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
name that the robot does not have or that is given twice, an array whose length is neither 0 nor
the number of names (a Float64MultiArray: not the group's size), an infinite value (or NaN in a
Float64MultiArray), a position beyond a limit (the core's rule,
:func:`rbd_ros.core.joints.model.check_position_target`). A velocity target beyond the URDF's
``<limit velocity>`` is clipped to it; an effort beyond ``effort`` is clipped by the motor.

A target takes effect at the start of the next step and is held until replaced, as a wrench is;
with ``wrench_timeout_s > 0`` it expires as a wrench does and leaves the joint free.
"""

from dataclasses import dataclass
import math
from typing import Optional, Sequence, Tuple

from rbd_ros.core import InputError, RbdError
from rbd_ros.core.joints.model import check_position_target

#: Rejection reasons, in the order they are checked.
REJECT_REASONS = ('unknown_joint', 'duplicate_joint', 'length', 'non_finite', 'limit')
#: The interfaces of a command group (ros2_control's command interface names).
INTERFACES = ('position', 'velocity', 'effort')


class CommandRejected(InputError):
    """A command was rejected whole; :attr:`reason` is one of :data:`REJECT_REASONS`."""

    def __init__(self, reason, message):
        super().__init__(message)
        self.reason = reason


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
    """What a command needs to know of a moving joint: its core joint and velocity limit."""

    name: str
    core: object  # rbd_ros.core.joints.Joint
    velocity_limit: Optional[float]


def _target(topic, where, spec, index, mode, value):
    if mode == 'position':
        try:
            check_position_target(spec.core, value)
        except RbdError as exc:
            raise CommandRejected('limit', f'{topic}: {where}: {exc}') from None
    elif mode == 'velocity' and spec.velocity_limit is not None:
        value = min(max(value, -spec.velocity_limit), spec.velocity_limit)
    return JointTarget(index, mode, float(value))


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
                        effort: Sequence[float] = ()) -> Tuple[JointTarget, ...]:
    """
    Return the targets of a ``JointState`` command, or raise :class:`CommandRejected`.

    :param joints: the robot's moving joints, ``joint_states`` order.
    """
    index = {spec.name: k for k, spec in enumerate(joints)}
    seen = {}
    for k, name in enumerate(names):
        if name not in index:
            raise CommandRejected('unknown_joint', f'{topic}: name[{k}]: {name!r} is not a '
                                  f'moving joint of this robot ({", ".join(index)})')
        if name in seen:
            raise CommandRejected('duplicate_joint', f'{topic}: name[{k}]: {name!r} is also '
                                  f'name[{seen[name]}]')
        seen[name] = k
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
