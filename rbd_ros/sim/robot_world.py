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
:class:`RobotWorld`: the robots of a params file, stepped together, read out per robot (no rclpy).

Every robot's bodies and joints go into one :class:`rbd_ros.core.joints.ArticulatedSimulator`
(no contact: a robot file without free bodies, ground or obstacles; with them the robots are
in a contact world, :class:`rbd_ros.sim.robot_contact.RobotContactWorld`, which reads them out
through this class on the contact step). Core joint names are ``<robot>/<joint>``, so two
robots may use the same joint names. It answers what :class:`rbd_ros.sim.session.SimSession`
asks of a simulator (``time_ns``, ``arrays`` of the free bodies: none, ``step``, ``reset``, no
contact) and, per robot, the joint readouts, every link frame's pose, a floating root's state
and every joint's constraint wrench.

**Link frames.** A moving link's frame is its body's pose composed with the link's fixed
offset in that body (:class:`rbd_ros.sim.urdf.RobotLink`); a link that is part of the world
keeps its pose at time 0. The URDF's ``world`` link is the node's world frame.

**Joint wrenches.** Per URDF joint, the force (N) and torque (N m) the parent exerts on the
child, in the child link's frame (a URDF joint's frame: its origin is the joint), the torque
about that origin: ``f_l = R_wlᵀ f_w`` and ``τ_l = R_wlᵀ (τ_com − d × f_w)`` with ``f_w``,
``τ_com`` the core's multiplier wrench on the child body (world frame, about its COM) and ``d``
the COM → link origin offset (world). A fixed joint the core has no constraint for (inside the
world part, ``world`` → ``mount``, or to a massless frame folded into a body, ``tool0``) holds
the massless links below it: by their statics it carries the sum of what the core joints
hanging from them carry, ``f = Σ f_k`` and ``τ_O = Σ (τ_k + (A_k − O) × f_k)`` about its own
origin ``O`` (``A_k`` the joint ``k``'s origin), 0 when nothing hangs there. A ``floating``
joint carries nothing (0). Computed here in plain Python from the multipliers' world-frame
wrench (:meth:`~rbd_ros.core.joints.ArticulatedSimulator.constraint_wrenches_w`; the core's
:meth:`~rbd_ros.core.joints.ArticulatedSimulator.joint_wrenches` gives them in its own row
basis, through numpy), so the bytes are the same on every machine.

**Per sample** every readout takes the bodies' packed states as plain floats
(:meth:`~rbd_ros.core.joints.ArticulatedSimulator.state_rows`), never a ``BodyState`` per body,
and the joint coordinates from the core's plain-float
:meth:`~rbd_ros.core.joints.ArticulatedSimulator.joint_coordinates`.
"""

import dataclasses
import math

import numpy as np

from rbd_ros.core import layout
from rbd_ros.core.joints import ArticulatedSimulator
from rbd_ros.core.joints.readout import multiply, rotate as _rotate
from rbd_ros.sim.joint_commands import motor_settings, release


def rotate(q, v):
    """Return ``R(q) v`` for a unit quaternion ``q = (w, x, y, z)`` and ``v``, plain floats."""
    return _rotate(*q, *v)


_NAN6 = (math.nan,) * 6


def _conjugate(q):
    """Return the inverse ``(w, -x, -y, -z)`` of a unit quaternion."""
    return (q[0], -q[1], -q[2], -q[3])


def _held_joints(joints, joint):
    """
    Return the URDF indices of the core joints a folded fixed ``joint`` holds, URDF order.

    The links below it through folded fixed joints are massless (a world link, or a frame
    without ``<inertial>``): every core joint whose parent link is one of them hangs from it.
    A ``floating`` joint holds nothing (its child is a free body).
    """
    if joint.kind != 'fixed':
        return ()
    below, grew = {joint.child}, True
    while grew:
        grew = False
        for other in joints:
            if other.core is None and other.kind == 'fixed' and other.parent in below \
                    and other.child not in below:
                below.add(other.child)
                grew = True
    return tuple(k for k, other in enumerate(joints)
                 if other.core is not None and other.parent in below)


def _frame_pose(row, p, q):
    """
    Return a frame fixed in a body: ``(position_w, q_wl, d_w, q_wb)``, plain floats.

    ``row``: the body's packed state (13 floats, ``ArticulatedSimulator.state_rows``); ``p``,
    ``q``: the frame in the body frame; ``d_w = R_wb p`` (the COM → frame origin offset).
    """
    qb = (row[3], row[4], row[5], row[6])
    d = rotate(qb, p)
    return (row[0] + d[0], row[1] + d[1], row[2] + d[2]), multiply(qb, q), d, qb


class RobotWorld:
    """
    The robots of ``config`` in one articulated simulator.

    :param robots: the :class:`rbd_ros.sim.robots.RobotConfig` tuple.
    :param timestep_ns: the fixed step, int ns.
    """

    def __init__(self, robots, timestep_ns):
        self._assemble(robots, timestep_ns, 0)
        # The initial projection waits for the first step: building the world compiles nothing, so
        # a cold node publishes the placement at t = 0 while its kernels compile.
        self._sim = ArticulatedSimulator(*self._args, timestep_ns=timestep_ns,
                                         defer_projection=True)

    def _assemble(self, robots, timestep_ns, first_body, first_joint=0):
        """
        Gather every robot's bodies, states and joints and each link's carrier (no simulator).

        ``first_body``: the index of the first robot body in the simulator's bodies (a world
        with contact puts its free bodies first); the joints' body indices count from there.
        ``first_joint``: the index of the first robot joint in the simulator's joints (a world
        with contact puts its own joints, ``joint_names``, first).
        """
        self.robots = tuple(robots)
        self._timestep_ns = timestep_ns
        # Per joint group (each robot, then a contact world's own joints): the position time
        # constant of each moving joint, joint_states order.
        self._time_constants_s = [robot.entry_time_constants_s for robot in self.robots]
        models, states, joints = [], [], []
        self._moving = []   # per robot: the core joint index of each joint_states entry
        self._coordinates = []   # per robot: each entry's coordinate (None: a 1-coordinate joint)
        self._bodies = []   # per robot: (first body index, number of bodies)
        self._joint_offsets = []  # per robot: its first core joint index
        for robot in self.robots:
            placement = robot.placement
            b0, j0 = first_body + len(models), first_joint + len(joints)
            self._joint_offsets.append(j0)
            models += placement.models
            states += placement.states
            for joint in placement.joints:
                joints.append(dataclasses.replace(
                    joint, name=f'{robot.name}/{joint.name}', child=joint.child + b0,
                    parent=None if joint.parent is None else joint.parent + b0,
                    mimic=None if joint.mimic is None else f'{robot.name}/{joint.mimic}'))
            self._moving.append(tuple(j0 + robot.robot.joint(name).core
                                      for name, _ in robot.robot.coordinates))
            self._coordinates.append(tuple(k for _, k in robot.robot.coordinates))
            self._bodies.append((b0, len(placement.models)))
        self._args = (models, states, joints)
        self._no_bodies = (np.zeros((layout.N_STATE, 0)), np.zeros(0, dtype=np.int64))
        # Each link's carrier: (body index or None, position_b, q_bl), or its fixed world pose.
        self._links = []
        for robot, (b0, _) in zip(self.robots, self._bodies):
            links = []
            for link in robot.robot.links:
                if link.body is None:
                    p, q = robot.placement.link_poses_w[link.name]
                    links.append((link.name, None, tuple(np.asarray(p).tolist()),
                                  tuple(np.asarray(q).tolist())))
                else:
                    links.append((link.name, b0 + link.body,
                                  tuple(np.asarray(link.position_b).tolist()),
                                  tuple(np.asarray(link.orientation_b).tolist())))
            self._links.append(tuple(links))
        # Per robot: its root link's (body index, position_b, q_bl), None when fixed to the
        # world; and per URDF joint its child link's frame (body index or None for a world
        # link, position, q) with, for a core joint, ('core', core joint index) and for a
        # folded fixed joint ('held', the URDF indices of the core joints it holds).
        self._roots, self._joint_frames = [], []
        for robot, links in zip(self.robots, self._links):
            by_name = {name: (body, p, q) for name, body, p, q in links}
            urdf = robot.robot
            self._roots.append(None if urdf.fixed_to_world else by_name[urdf.root])
            j0 = self._joint_offsets[len(self._joint_frames)]
            frames = []
            for joint in urdf.joints:
                if joint.core is not None:
                    how = ('core', j0 + joint.core)
                else:
                    how = ('held', _held_joints(urdf.joints, joint))
                frames.append((how, *by_name[joint.child]))
            self._joint_frames.append(tuple(frames))

    # --- what SimSession asks of a simulator -----------------------------------------------

    @property
    def time_ns(self) -> int:
        """Return the sim time, int ns."""
        return self._sim.time_ns

    @property
    def arrays(self):
        """Return the free bodies' packed states and times: none in a robot file."""
        return self._no_bodies

    contact_wrench_w = None
    contacts = None

    def step(self, n: int = 1) -> None:
        """Advance ``n`` steps (see :meth:`ArticulatedSimulator.step`)."""
        self._sim.step(n)

    def reset(self) -> None:
        """Back to every robot's placement at time 0, every motor off."""
        self._sim = ArticulatedSimulator(*self._args, timestep_ns=self._timestep_ns,
                                         defer_projection=True)

    # --- per robot ---------------------------------------------------------------------------

    def joint_states(self, r: int):
        """
        Return robot ``r``'s ``(positions, velocities, efforts)``, ``joint_states`` order.

        Three lists of plain floats (rad or m, rad/s or m/s, N m or N: the motor efforts
        applied over the last step), the positions and velocities from
        :meth:`ArticulatedSimulator.joint_coordinates` (plain scalar arithmetic: the same
        bits on every machine).
        """
        q, qd = self._coordinates_of(r)
        return q, qd, self.joint_efforts(r).tolist()

    def _coordinates_of(self, r):
        """Return robot ``r``'s entries' ``(positions, rates)``, plain floats."""
        coordinates = self._coordinates[r]
        if coordinates.count(None) == len(coordinates):   # one-coordinate joints only
            return self._sim.joint_coordinates(self._moving[r])
        return self._sim.joint_coordinates(self._moving[r], coordinates=coordinates)

    def joint_positions(self, r: int) -> np.ndarray:
        """Return robot ``r``'s ``joint_states`` positions (rad or m), in order."""
        return np.array(self._coordinates_of(r)[0])

    def joint_velocities(self, r: int) -> np.ndarray:
        """Return robot ``r``'s ``joint_states`` velocities (rad/s or m/s)."""
        return np.array(self._coordinates_of(r)[1])

    def joint_efforts(self, r: int) -> np.ndarray:
        """
        Return robot ``r``'s motor efforts applied over the last step (N m or N).

        One per ``joint_states`` entry: a planar or universal joint's per coordinate (the
        core's ``coordinate_efforts``).
        """
        if not self._moving[r]:  # a floating robot without joints: the step may have none
            return np.zeros(0)
        efforts = self._sim.joint_efforts()
        return np.array([float(efforts[j]) if k is None
                         else float(self._sim.coordinate_efforts(j)[k])
                         for j, k in zip(self._moving[r], self._coordinates[r])])

    def set_target(self, r: int, joint: int, mode: str, value: float,
                   reference_rates=None) -> None:
        """Hold a motor target on moving joint ``joint`` of robot ``r`` (see set_motor)."""
        self.set_targets(r, [(joint, mode, value, reference_rates)])

    def set_targets(self, r: int, targets) -> None:
        """
        Hold several targets of robot ``r`` at once: ``(joint, mode, value, rates or None)``.

        A position target takes the joint's ``position_time_constant_s``; ``rates`` are a
        position target's reference rate and acceleration (a followed trajectory).
        """
        self._sim.set_motors(motor_settings(targets, self._moving[r],
                                            self._time_constants_s[r], self._coordinates[r]))

    def release(self, r: int, joint: int) -> None:
        """Turn the motor of ``joint_states`` entry ``joint`` of robot ``r`` off (free)."""
        release(self._sim, self._moving[r][joint], self._coordinates[r][joint])

    def link_poses(self, r: int):
        """
        Return ``[(position_w, q_wl)]`` of every link of robot ``r``, URDF link order.

        Plain float tuples computed in plain Python (no BLAS), so a recording's ``/tf`` bytes
        are the same on every machine.
        """
        rows = self._sim.state_rows()
        out = []
        for _, body, p, q in self._links[r]:
            if body is None:
                out.append((p, q))
                continue
            out.append(_frame_pose(rows[body], p, q)[:2])
        return out

    def root_state(self, r: int):
        """
        Return robot ``r``'s root link frame as 13 plain floats, or None when fixed to the world.

        ``(position_w, q_wl, v_w, ω_l)``: the frame's pose in the world (the same bits as its
        :meth:`link_poses` entry, so ``odom`` and ``/tf`` agree exactly), the velocity of its
        origin ``v_w = v_com + ω_w × d`` (world frame; ``d`` the COM → origin offset) and the
        angular velocity in the link frame ``ω_l = R_blᵀ ω_b``: the packed-state layout
        :meth:`rbd_ros.msgs.outputs.BodyOutputs.list_values` reads.
        """
        root = self._roots[r]
        if root is None:
            return None
        body, p, q = root
        row = self._sim.state_rows()[body]
        position, q_wl, (dx, dy, dz), qb = _frame_pose(row, p, q)
        v = row[7:10]
        omega_b = row[10:13]
        wx, wy, wz = rotate(qb, omega_b)
        velocity = (v[0] + (wy * dz - wz * dy), v[1] + (wz * dx - wx * dz),
                    v[2] + (wx * dy - wy * dx))
        omega_l = rotate(_conjugate(q), omega_b)
        return [*position, *q_wl, *velocity, *omega_l]

    def joint_wrenches(self, r: int):
        """
        Return every URDF joint's wrench of robot ``r``, URDF joint order: 6 floats each.

        ``(fx, fy, fz, τx, τy, τz)``: force (N) and torque (N m) the parent exerts on the
        child, child link frame, torque about its origin (the module docstring gives the
        formulas, a folded fixed joint's too). NaN for every joint at time 0, before the first
        step has computed the multipliers.
        """
        frames = self._joint_frames[r]
        if self._sim.time_ns == 0:
            return [_NAN6] * len(frames)
        # The multipliers' wrench on each child body, world frame, torque about its COM.
        raw = self._sim.constraint_wrenches_w()
        rows = self._sim.state_rows()
        # Each joint's child link frame (origin O_w, q_wl), and a core joint's force and its
        # torque about O_w, world frame.
        poses, world = [], {}
        for i, ((how, index), body, p, q) in enumerate(frames):
            if body is None:
                poses.append((p, q))
                continue
            origin, q_wl, (dx, dy, dz), _ = _frame_pose(rows[body], p, q)
            poses.append((origin, q_wl))
            if how == 'core':
                fx, fy, fz, tx, ty, tz = raw[index]
                world[i] = ((fx, fy, fz), (tx - (dy * fz - dz * fy), ty - (dz * fx - dx * fz),
                                           tz - (dx * fy - dy * fx)))
        out = []
        for i, ((how, index), _, _, _) in enumerate(frames):
            origin, q_wl = poses[i]
            if how == 'core':
                force, torque = world[i]
            else:  # a folded fixed joint: the statics of the massless links it holds
                force, torque = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
                for k in index:
                    (fx, fy, fz), (tx, ty, tz) = world[k]
                    ax, ay, az = (poses[k][0][0] - origin[0], poses[k][0][1] - origin[1],
                                  poses[k][0][2] - origin[2])
                    force = (force[0] + fx, force[1] + fy, force[2] + fz)
                    torque = (torque[0] + (tx + (ay * fz - az * fy)),
                              torque[1] + (ty + (az * fx - ax * fz)),
                              torque[2] + (tz + (ax * fy - ay * fx)))
            q_lw = _conjugate(q_wl)
            out.append((*rotate(q_lw, force), *rotate(q_lw, torque)))
        return out

    @property
    def articulated(self) -> ArticulatedSimulator:
        """Return the core simulator (joint errors, energy, momentum, wrenches)."""
        return self._sim
