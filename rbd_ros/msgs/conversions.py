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
Plain values <-> ROS messages, by field name (no rclpy; the message classes are plain rosidl).

Inside rbd_ros a quaternion is ``(w, x, y, z)`` with ``v_w = R(q) v_b``; geometry_msgs writes
``x, y, z, w`` fields. Every conversion here goes by field name, never by position. The
output samples (pose, twist, odometry, clock, tf) are built in :mod:`rbd_ros.msgs.outputs`; this
module has the time stamps, the wrench input and the diagnostics.
"""

from collections.abc import Sequence

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Quaternion, WrenchStamped
from rbd_ros.sim.params import NS_PER_S
from rbd_ros.sim.trajectory import TrajectoryPoint


def time_to_msg(time_ns):
    """Integer ns (>= 0) → ``builtin_interfaces/Time`` (``sec``, ``nanosec`` in [0, 1e9))."""
    sec, nanosec = divmod(int(time_ns), NS_PER_S)
    return Time(sec=sec, nanosec=nanosec)


def time_from_msg(msg):
    """``builtin_interfaces/Time`` → integer ns."""
    return int(msg.sec) * NS_PER_S + int(msg.nanosec)


def quaternion_from_msg(msg):
    """``geometry_msgs/Quaternion`` → ``(w, x, y, z)`` tuple, by field name."""
    return (msg.w, msg.x, msg.y, msg.z)


def quaternion_to_msg(q_wxyz, msg=None):
    """``(w, x, y, z)`` → ``geometry_msgs/Quaternion`` (into ``msg`` if given), by field name."""
    if msg is None:
        msg = Quaternion()
    msg.w = float(q_wxyz[0])
    msg.x = float(q_wxyz[1])
    msg.y = float(q_wxyz[2])
    msg.z = float(q_wxyz[3])
    return msg


def vector_from_msg(msg):
    """``geometry_msgs/Vector3`` or ``Point`` → ``(x, y, z)`` tuple."""
    return (msg.x, msg.y, msg.z)


def _vector_to_msg(v, msg):
    msg.x = float(v[0])
    msg.y = float(v[1])
    msg.z = float(v[2])
    return msg


def wrench_from_msg(msg):
    """
    ``geometry_msgs/WrenchStamped`` → ``(frame_id, force, torque)`` plain values.

    ``force`` and ``torque`` are 3-tuples of floats in the coordinates ``frame_id`` names (N,
    N·m); they are not validated here (see :class:`rbd_ros.sim.inputs.WrenchInputs`).
    """
    return (msg.header.frame_id, vector_from_msg(msg.wrench.force),
            vector_from_msg(msg.wrench.torque))


def wrench_to_msg(frame_id, force, torque, stamp_ns=0):
    """Plain values → ``geometry_msgs/WrenchStamped`` (used by the demo, tests and replay)."""
    msg = WrenchStamped()
    msg.header.stamp = time_to_msg(stamp_ns)
    msg.header.frame_id = frame_id
    _vector_to_msg(force, msg.wrench.force)
    _vector_to_msg(torque, msg.wrench.torque)
    return msg


def diagnostics_to_msg(stamp_ns, name, hardware_id, level, message, values):
    """
    One ``diagnostic_msgs/DiagnosticArray`` with one status.

    :param level: ``'ok'``, ``'warn'`` or ``'error'``.
    :param values: ``{key: value}``; floats are written with ``repr`` (round-trip exact).
    """
    status = DiagnosticStatus(
        level={'ok': DiagnosticStatus.OK, 'warn': DiagnosticStatus.WARN,
               'error': DiagnosticStatus.ERROR}[level],
        name=name, message=message, hardware_id=hardware_id,
        values=[KeyValue(key=key, value=repr(value) if isinstance(value, float) else str(value))
                for key, value in values.items()])
    msg = DiagnosticArray(status=[status])
    msg.header.stamp = time_to_msg(stamp_ns)
    return msg


class _TrajectoryPoints(Sequence):
    """A message's points, each made a :class:`TrajectoryPoint` when it is read."""

    def __init__(self, points):
        self._points = points

    def __len__(self):
        return len(self._points)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return [self[i] for i in range(*k.indices(len(self)))]
        p = self._points[k]
        return TrajectoryPoint(time_from_msg(p.time_from_start), tuple(p.positions),
                               tuple(p.velocities), tuple(p.accelerations), tuple(p.effort))


def trajectory_from_msg(msg):
    """
    Return ``(joint_names, stamp_ns, points)`` of a ``trajectory_msgs/JointTrajectory``.

    ``points`` is a sequence of :class:`rbd_ros.sim.trajectory.TrajectoryPoint` values
    (``time_from_start`` in int ns), each made when it is read: what
    :meth:`rbd_ros.sim.session.SimSession.submit_command` takes, which refuses more than
    :data:`~rbd_ros.sim.joint_commands.MAX_TRAJECTORY_POINTS` from their count alone (100 000
    points took 0.9 s to convert, all of it spent before that refusal did).
    """
    return list(msg.joint_names), time_from_msg(msg.header.stamp), _TrajectoryPoints(msg.points)


def joint_command_from_msg(msg):
    """Return ``(names, position, velocity, effort)`` of a ``sensor_msgs/JointState`` command."""
    return (list(msg.name), list(msg.position), list(msg.velocity), list(msg.effort))
