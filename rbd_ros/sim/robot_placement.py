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
A URDF robot placed in the world: :func:`place_robot` gives its bodies, states and core joints.

Forward kinematics from the root pose through every joint at its initial position and rate
(mimics following their leaders), each checked against its limits and the bounds of
:mod:`rbd_ros.sim.params`; the result, a :class:`Placement`, is what
:class:`rbd_ros.core.joints.ArticulatedSimulator` (or a world with contact) takes.

Neighbours: :mod:`rbd_ros.sim.urdf` reads the :class:`rbd_ros.sim.urdf.Robot` placed here (and
states the URDF conventions); :mod:`rbd_ros.sim.robots` places each configured robot.
"""

from dataclasses import dataclass
import math
from typing import Tuple

import numpy as np
from rbd_ros.core import BodyModel, BodyState
from rbd_ros.core.errors import ConfigError, finite_vector
from rbd_ros.core.joints import Joint
from rbd_ros.core.joints.model import coordinate_units, plane_x
from rbd_ros.core.rotations import matrix_to_quat, quat_to_matrix
from rbd_ros.sim.params import MAX_JOINT_POSITION, MAX_JOINT_RATE
from rbd_ros.sim.urdf import frozen_pose, MOVING_TYPES, refuse, Robot


@dataclass(frozen=True)
class Placement:
    """What :class:`rbd_ros.core.joints.ArticulatedSimulator` takes, and each link's pose."""

    models: Tuple[BodyModel, ...]
    states: Tuple[BodyState, ...]
    joints: Tuple[Joint, ...]
    link_poses_w: dict


def _mimic_values(source, robot, q_values, qd_values, given):
    """Set each mimic's initial coordinate and rate from its leader's; refuse a mismatch."""
    index = {name: k for k, name in enumerate(robot.moving_joints)}

    def follow(name):
        joint = robot.joint(name)
        k = index[name]
        if joint.mimic is not None:
            lead, mult, offset = joint.mimic
            q_l, qd_l = follow(lead)
            for values, value, field, unit, was_given in (
                    (q_values, mult * q_l + offset, 'initial_joint_positions', 'rad or m',
                     given[0]),
                    (qd_values, mult * qd_l, 'initial_joint_velocities', 'rad/s or m/s',
                     given[1])):
                if was_given and abs(values[k] - value) > 1e-9 * max(1.0, abs(value)):
                    refuse(ConfigError, source, f'{field}[{k}]', f'{float(values[k])!r} for '
                           f'joint {name!r}, a mimic of {lead!r}, must be {value!r} (multiplier '
                           f'{mult!r} times its value plus offset)', float(values[k]), unit)
                values[k] = value
        return float(q_values[k]), float(qd_values[k])

    for name, (_, coordinate) in zip(robot.moving_joints, robot.coordinates):
        if coordinate is None:   # a planar joint's entries have no mimic
            follow(name)


def _values(source, robot, values, name, unit):
    """Return ``values`` as one finite number per moving joint (zeros for None)."""
    n = len(robot.moving_joints)
    if values is None:
        return np.zeros(n)
    try:
        array = np.array(values, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        refuse(ConfigError, source, name, f'{values!r} is not a list of numbers in {unit}',
               values, unit)
    if array.size != n:
        refuse(ConfigError, source, name, f'{array.size} values for {n} moving joints '
               f'({", ".join(robot.moving_joints)}); one per joint in URDF order, fixed '
               'joints skipped', list(values), unit)
    if not np.all(np.isfinite(array)):
        refuse(ConfigError, source, name, f'{array.tolist()} {unit} must be finite',
               list(values), unit)
    return array


def place_robot(robot: Robot, position_w=(0.0, 0.0, 0.0), orientation_wb=(1.0, 0.0, 0.0, 0.0),
                joint_positions=None, joint_velocities=None, gravity_w=(0.0, 0.0, -9.81),
                time_ns: int = 0) -> Placement:
    """
    Return the bodies, states and joints of ``robot`` placed in the world.

    Forward kinematics from the root link's frame at ``position_w`` (m) and ``orientation_wb``
    (``w, x, y, z``; the ``world`` link when fixed to the world), at rest, through every joint
    at ``joint_positions`` (rad or m) and ``joint_velocities`` (rad/s or m/s), one value each
    per :attr:`Robot.moving_joints` (None: zeros). A link's velocity is its parent's rigid
    motion plus the joint rate: ``ω_c = ω_p + q̇ a_w`` (rotary), ``v_c = v_p + ω_p × r
    + q̇ a_w`` (prismatic) at the link origin; a planar joint's child link frame is the joint
    frame moved by ``x e_x + y e_y`` and turned by theta about the normal ``a``
    (:func:`rbd_ros.core.joints.model.plane_x` gives ``e_x``, ``e_y = a × e_x``),
    ``ω_c = ω_p + θ̇ a_w``, ``v_c = v_p + ω_p × r + ẋ e_x + ẏ e_y`` (world frame, ``r`` to
    the link origin).
    ``link_poses_w`` maps each link name to its frame's ``(position_w, q_wl)``.

    :raises ConfigError: a wrong number of values, a non-finite one, one beyond a limit, a
        position beyond ±:data:`~rbd_ros.sim.params.MAX_JOINT_POSITION` or a velocity beyond
        ±:data:`~rbd_ros.sim.params.MAX_JOINT_RATE`; a root pose that is not finite or a zero
        quaternion.
    """
    source = robot.source
    q_values = _values(source, robot, joint_positions, 'initial_joint_positions', 'rad or m')
    qd_values = _values(source, robot, joint_velocities, 'initial_joint_velocities',
                        'rad/s or m/s')
    position = finite_vector(position_w, 'initial_position', 'm', error=ConfigError)
    quat = finite_vector(orientation_wb, 'initial_orientation', 'quaternion (w, x, y, z)', 4,
                         error=ConfigError)
    norm = float(np.linalg.norm(quat))
    if not norm > 1e-9:
        refuse(ConfigError, source, 'initial_orientation', f'{quat.tolist()} has zero norm, '
               'not a rotation', quat.tolist())
    root_pose = np.eye(4)
    root_pose[:3, :3] = quat_to_matrix(quat / norm)
    root_pose[:3, 3] = position
    _mimic_values(source, robot, q_values, qd_values,
                  (joint_positions is not None, joint_velocities is not None))
    coordinate = {}   # joint name -> its entries' (q, q̇), coordinate order
    for (joint_name, _), q, qd in zip(robot.coordinates, q_values, qd_values):
        coordinate.setdefault(joint_name, []).append((float(q), float(qd)))
    for k, name in enumerate(robot.moving_joints):
        joint, entry = robot.entry(name)
        units = coordinate_units(joint, entry or 0)[:2]   # reads the kind only
        for field, values, unit, bound, bound_name in (
                ('initial_joint_positions', q_values, units[0], MAX_JOINT_POSITION,
                 'MAX_JOINT_POSITION'),
                ('initial_joint_velocities', qd_values, units[1], MAX_JOINT_RATE,
                 'MAX_JOINT_RATE')):
            value = float(values[k])
            if not abs(value) <= bound:
                refuse(ConfigError, source, f'{field}[{k}]', f'{value!r} {unit} for joint '
                       f'{name!r} is beyond ±{bound:g} {unit} (rbd_ros.sim.params.'
                       f'{bound_name})', value, unit)
        value = float(q_values[k])
        if joint.kind == 'planar' and entry == 2 and not -math.pi < value <= math.pi:
            refuse(ConfigError, source, f'initial_joint_positions[{k}]',
                   f"{value!r} rad for {name!r} must be in (-pi, pi] (a planar joint's theta)",
                   value, 'rad')
        if (joint.lower is not None and value < joint.lower) or \
                (joint.upper is not None and value > joint.upper):
            unit = 'rad' if joint.kind == 'revolute' else 'm'
            refuse(ConfigError, source, f'initial_joint_positions[{k}]',
                   f'{value!r} {unit} for joint {name!r} is outside its limits '
                   f'[{joint.lower!r}, {joint.upper!r}] {unit}', value, unit)
    # forward kinematics, parents first: pose (4x4), v at the link origin, omega (world)
    frames = {robot.root: (root_pose, np.zeros(3), np.zeros(3))}
    pending = list(robot.joints)
    while pending:
        joint = next(j for j in pending if j.parent in frames)
        pending.remove(joint)
        pose_p, vel_p, omega_p = frames[joint.parent]
        frame_j = pose_p @ joint.origin
        axis_w = frame_j[:3, :3] @ joint.axis
        q, qd = coordinate.get(joint.name, [(0.0, 0.0)])[0]
        motion = np.eye(4)
        omega, vel = omega_p.copy(), vel_p + np.cross(omega_p, frame_j[:3, 3] - pose_p[:3, 3])
        if joint.kind == 'planar':
            (x, xd), (y, yd), (theta, thetad) = coordinate[joint.name]
            e_x = plane_x(joint.axis)
            e_y = np.cross(joint.axis, e_x)
            motion[:3, :3] = quat_to_matrix(np.concatenate(
                ([math.cos(0.5 * theta)], math.sin(0.5 * theta) * joint.axis)))
            motion[:3, 3] = x * e_x + y * e_y
            offset_w = frame_j[:3, :3] @ motion[:3, 3]
            vel = vel + frame_j[:3, :3] @ (xd * e_x + yd * e_y) + np.cross(omega_p, offset_w)
            omega = omega + thetad * axis_w
        elif joint.kind in ('revolute', 'continuous'):
            motion[:3, :3] = quat_to_matrix(np.concatenate(
                ([math.cos(0.5 * q)], math.sin(0.5 * q) * joint.axis)))
            omega = omega + qd * axis_w
        elif joint.kind == 'prismatic':
            motion[:3, 3] = q * joint.axis
            vel = vel + qd * axis_w + np.cross(omega_p, q * axis_w)
        frames[joint.child] = (frame_j @ motion, vel, omega)
    models, states = [], []
    for name in robot.body_links:
        link = robot.link(name)
        pose, vel, omega = frames[name]
        rot = pose[:3, :3]
        offset_w = rot @ link.com_m
        models.append(BodyModel(link.mass_kg, link.inertia_b, gravity_w=gravity_w))
        states.append(BodyState(pose[:3, 3] + offset_w, matrix_to_quat(rot),
                                vel + np.cross(omega, offset_w), rot.T @ omega,
                                time_ns=time_ns))
    links = {link.name: link for link in robot.links}
    joints = []
    for joint in robot.joints:
        if joint.core is None:
            continue
        parent = links[joint.parent]
        if parent.body is None:
            carrier = frames[joint.parent][0]
            parent_frame = carrier
        else:
            parent_frame = np.eye(4)
            parent_frame[:3, :3] = quat_to_matrix(parent.orientation_b)
            parent_frame[:3, 3] = parent.position_b
        frame_j = parent_frame @ joint.origin
        rot = frame_j[:3, :3]
        child = links[joint.child]
        kind = joint.kind
        extra = {}
        if kind in ('revolute', 'prismatic'):
            extra = {'lower': joint.lower, 'upper': joint.upper}
        if kind in MOVING_TYPES:
            extra.update(effort_limit=joint.effort, damping=joint.damping,
                         friction=joint.friction)
            if joint.mimic is not None:
                extra.update(mimic=joint.mimic[0], mimic_multiplier=joint.mimic[1],
                             mimic_offset=joint.mimic[2])
        if kind == 'planar':
            extra.update(axis2_b=rot @ plane_x(joint.axis), effort_limit=joint.effort)
        joints.append(Joint(joint.name, kind, parent.body, child.body,
                            origin_parent_b=frame_j[:3, 3], origin_child_b=-child.com_m,
                            axis_b=rot @ joint.axis, q_rest=matrix_to_quat(rot), **extra))
    poses = {name: frozen_pose(frame[0]) for name, frame in frames.items()}
    return Placement(tuple(models), tuple(states), tuple(joints), poses)
