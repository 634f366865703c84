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
A robot's output messages of one sample: joint_states, odom, joint_wrenches, its links on /tf.

A part of :class:`rbd_ros.msgs.outputs.SampleBuilder` (which publishes and records the same
bytes, and which replay rebuilds), written the same way: CDR packed by ``struct`` with zeroed
padding, the floats computed in plain Python arithmetic (no BLAS) so the bytes are the same on
every machine.

- ``sensor_msgs/JointState`` on ``<robot>/joint_states``: stamped with sim time, ``frame_id``
  empty (as joint_state_broadcaster), the moving joints in URDF order with position (rad or m),
  velocity and effort (the motor's, applied over the last step; 0 without a motor).
- ``nav_msgs/Odometry`` on ``<robot>/odom``, a floating robot's only (REP 105): the root link's
  frame in the world frame (``child_frame_id`` that frame's id), twist in that link frame.
  Packed by :class:`rbd_ros.msgs.outputs.BodyOutputs` (the free bodies' odom rule, its one
  home) from :meth:`rbd_ros.sim.robot_world.RobotWorld.root_state`; :class:`RobotOutputs`
  names the kind.
- ``sensor_msgs/MultiDOFJointState`` on ``<robot>/joint_wrenches``: stamped with sim time,
  ``frame_id`` empty (each wrench is in its own joint's child link frame), ``joint_names``
  every URDF joint in document order (fixed joints included), ``transforms`` and ``twist``
  empty (the message allows an empty array), ``wrench`` per joint the force and torque the
  parent exerts on the child (:meth:`rbd_ros.sim.robot_world.RobotWorld.joint_wrenches`;
  NaN at time 0, before the first step has solved them).
- ``/tf``: one transform per URDF joint, parent link → child link (fixed joints included), as
  robot_state_publisher gives them, plus world frame → root link for a floating robot. A link's
  frame id is :meth:`rbd_ros.sim.robots.RobotConfig.link_frame` (its robot's ``frame_prefix`` +
  its URDF name; the URDF's ``world`` link is the node's world frame). The
  transform is the parent's frame pose inverted times the child's, from the simulated link
  poses (:meth:`rbd_ros.sim.robot_world.RobotWorld.link_poses`), so it agrees with
  ``joint_states`` through the URDF's kinematics to the joints' projection tolerance; a link
  whose parent is the ``world`` link gets its pose in the world (the ``world`` link of a robot
  placed at ``initial_position`` is not at the origin of the world frame it names).

The joints of a world (``joint_names``, :mod:`rbd_ros.sim.world_joints`) are a group of
:class:`JointOutputs` without a prefix: ``joint_states`` (the one-coordinate joints in
``joint_names`` order) and ``joint_wrenches`` (every joint), from
:class:`rbd_ros.sim.world_joints.JointedWorldSimulator`; their bodies are on ``/tf`` as bodies.
"""

from rbd_ros.msgs.cdr import cdr_string, layout
from rbd_ros.sim.params import NS_PER_S
from rbd_ros.sim.robot_world import multiply, rotate

ENCAPSULATION = b'\x00\x01\x00\x00'


def relative_pose(parent, child):
    """Return the child frame in the parent frame: ``(translation, (w, x, y, z))``."""
    (pp, qp), (pc, qc) = parent, child
    qp_inv = (qp[0], -qp[1], -qp[2], -qp[3])
    d = (pc[0] - pp[0], pc[1] - pp[1], pc[2] - pp[2])
    return rotate(qp_inv, d), multiply(qp_inv, qc)


class JointOutputs:
    """
    A group of joints' ``joint_states`` and ``joint_wrenches``, as CDR bytes.

    The world's joints (``joint_names``) are one such group, with no prefix: ``joint_states``
    and ``joint_wrenches``; a robot's (:class:`RobotOutputs`) are under its name.

    :param prefix: the topics' prefix (``'<robot>/'``, or ``''``).
    :param index: the group's index for the readouts (``world.joint_states(index)``).
    :param joint_names: ``joint_states``' names, in order. :param wrench_joints:
        ``joint_wrenches``' names, in order.
    """

    #: No odom and no link frames of its own (a robot's: :class:`RobotOutputs`).
    odom_kind = None
    transforms = ()

    def __init__(self, prefix, index, joint_names, wrench_joints):
        self.index = index
        self.kind = f'{prefix}joint_states'
        self.wrench_kind = f'{prefix}joint_wrenches'
        #: The sample kinds, in publishing order.
        self.kinds = (self.kind, self.wrench_kind)
        self.wrench_joints = tuple(wrench_joints)
        wrench_names = [cdr_string(name) for name in self.wrench_joints]
        m = len(wrench_names)
        self._wrenches = layout('i', 'I', cdr_string(''), 'I', *wrench_names, 'I', 'I', 'I',
                                *'d' * (6 * m))
        self._wrench_names = [v for name in wrench_names for v in (len(name), name)]
        self.joint_names = tuple(joint_names)
        names = [cdr_string(name) for name in self.joint_names]
        n = len(names)
        self._joint_states = layout('i', 'I', cdr_string(''), 'I', *names, 'I', *'d' * n, 'I',
                                    *'d' * n, 'I', *'d' * n)
        self._names = [v for name in names for v in (len(name), name)]

    def tf_fields(self):
        """Return the ``layout`` fields of this group's transforms (appended to ``/tf``'s)."""
        fields = []
        for _, _, parent, child in self.transforms:
            fields += ['i', 'I', parent, child, *'d' * 7]
        return fields

    def tf_values(self, sec, nanosec, poses):
        """Return the values of :meth:`tf_fields` at ``poses`` (``link_poses`` of the group)."""
        out = []
        for parent, child, parent_frame, child_frame in self.transforms:
            if parent is None:
                (px, py, pz), (qw, qx, qy, qz) = poses[child]
            else:
                (px, py, pz), (qw, qx, qy, qz) = relative_pose(poses[parent], poses[child])
            out += (sec, nanosec, len(parent_frame), parent_frame, len(child_frame),
                    child_frame, px, py, pz, qx, qy, qz, qw)
        return out

    def joint_states(self, time_ns, world):
        """Return the CDR bytes of this group's ``JointState`` now."""
        sec, nanosec = divmod(time_ns, NS_PER_S)
        q, qd, effort = world.joint_states(self.index)
        n = len(q)
        return self._joint_states.pack(ENCAPSULATION, sec, nanosec, 1, b'\x00', n, *self._names,
                                       n, *q, n, *qd, n, *effort)

    def joint_wrenches(self, time_ns, world):
        """Return the CDR bytes of this group's ``MultiDOFJointState`` of joint wrenches."""
        sec, nanosec = divmod(time_ns, NS_PER_S)
        values = [v for row in world.joint_wrenches(self.index) for v in row]
        m = len(self.wrench_joints)
        return self._wrenches.pack(ENCAPSULATION, sec, nanosec, 1, b'\x00', m,
                                   *self._wrench_names, 0, 0, m, *values)


class RobotOutputs(JointOutputs):
    """
    One robot's joint_states, odom, joint_wrenches and link transforms, as CDR bytes.

    :param robot: its :class:`rbd_ros.sim.robots.RobotConfig`.
    :param index: its index in the node's robots (the :class:`RobotWorld`'s).
    :param world_frame: the node's world frame id.
    """

    def __init__(self, robot, index, world_frame):
        urdf = robot.robot
        super().__init__(f'{robot.name}/', index, urdf.moving_joints,
                         (joint.name for joint in urdf.joints))
        #: ``<robot>/odom`` of a floating robot, None for one fixed to the world.
        self.odom_kind = None if urdf.fixed_to_world else f'{robot.name}/odom'
        self.kinds = tuple(k for k in (self.kind, self.odom_kind, self.wrench_kind) if k)
        #: The root link's frame id (odom's ``child_frame_id``).
        self.root_frame = robot.link_frame(urdf.root, world_frame)
        frame = {link.name: robot.link_frame(link.name, world_frame) for link in urdf.links}
        link_index = {link.name: k for k, link in enumerate(urdf.links)}
        #: (parent link index or None for the world frame, child link index, frame bytes)
        self.transforms = []
        if not urdf.fixed_to_world:
            self.transforms.append((None, link_index[urdf.root], cdr_string(world_frame),
                                    cdr_string(frame[urdf.root])))
        for joint in urdf.joints:
            # The ``world`` link is the world frame: a link hanging from it is given by its
            # pose in the world (the world link sits at initial_position, not at the origin).
            parent = None if joint.parent == 'world' and urdf.fixed_to_world \
                else link_index[joint.parent]
            self.transforms.append((parent, link_index[joint.child],
                                    cdr_string(frame[joint.parent]),
                                    cdr_string(frame[joint.child])))
