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
Core values <-> ROS messages, by field name: the only module that knows geometry_msgs order.

Inside rbd_ros a quaternion is ``(w, x, y, z)`` with ``v_w = R(q) v_b``; geometry_msgs writes
``x, y, z, w`` fields. Every conversion here goes by field name, never by position, except the
two plain-sequence helpers :func:`xyzw_to_wxyz` and :func:`wxyz_to_xyzw` (used for the
``initial_orientation`` parameter, which is written in geometry_msgs order).

Frames (REP 103 / REP 105):

- ``PoseStamped``: the body pose in the world frame (``header.frame_id`` = world frame id).
- ``TwistStamped``: ``twist_frame='world'`` → ``v_w`` and ``ω_w = R ω_b``, ``frame_id`` =
  world frame id; ``'body'`` → ``v_b = Rᵀ v_w`` and ``ω_b``, ``frame_id`` = body frame id.
- ``Odometry``: pose in ``header.frame_id`` (world), twist in ``child_frame_id`` (body) as REP 105
  requires. Covariances are left zero: the state is the simulator's exact state.

Velocities are the integrator's own state variables, never finite differences of poses.
Message classes are plain rosidl Python classes; importing them does not import rclpy.
"""

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped, TransformStamped, TwistStamped, WrenchStamped
from nav_msgs.msg import Odometry
import numpy as np
from rosgraph_msgs.msg import Clock

_NS_PER_S = 1_000_000_000


def xyzw_to_wxyz(q_xyzw):
    """Reorder a plain ``[x, y, z, w]`` sequence (geometry_msgs order) to ``(w, x, y, z)``."""
    x, y, z, w = q_xyzw
    return (w, x, y, z)


def wxyz_to_xyzw(q_wxyz):
    """Reorder a plain ``(w, x, y, z)`` sequence to ``[x, y, z, w]`` (geometry_msgs order)."""
    w, x, y, z = q_wxyz
    return (x, y, z, w)


def time_to_msg(time_ns):
    """Integer ns (>= 0) → ``builtin_interfaces/Time`` (``sec``, ``nanosec`` in [0, 1e9))."""
    sec, nanosec = divmod(int(time_ns), _NS_PER_S)
    return Time(sec=sec, nanosec=nanosec)


def time_from_msg(msg):
    """``builtin_interfaces/Time`` → integer ns."""
    return int(msg.sec) * _NS_PER_S + int(msg.nanosec)


def quaternion_to_msg(q_wxyz, msg):
    """Write ``(w, x, y, z)`` into a ``geometry_msgs/Quaternion`` ``msg`` by field name."""
    msg.w = float(q_wxyz[0])
    msg.x = float(q_wxyz[1])
    msg.y = float(q_wxyz[2])
    msg.z = float(q_wxyz[3])
    return msg


def quaternion_from_msg(msg):
    """``geometry_msgs/Quaternion`` → ``(w, x, y, z)`` tuple, by field name."""
    return (msg.w, msg.x, msg.y, msg.z)


def _vector_to_msg(v, msg):
    msg.x = float(v[0])
    msg.y = float(v[1])
    msg.z = float(v[2])
    return msg


def _vector_from_msg(msg):
    return (msg.x, msg.y, msg.z)


def _pose_into(state, pose):
    _vector_to_msg(state.position_w, pose.position)
    quaternion_to_msg(state.orientation_wb, pose.orientation)


def state_to_pose(state, world_frame):
    """:class:`BodyState` → ``PoseStamped`` of the COM in ``world_frame``, stamped at sim time."""
    msg = PoseStamped()
    msg.header.stamp = time_to_msg(state.time_ns)
    msg.header.frame_id = world_frame
    _pose_into(state, msg.pose)
    return msg


def twist_components(state, twist_frame, rot_wb=None):
    """
    Return ``(linear, angular)`` velocity arrays of ``state`` in ``twist_frame``.

    ``'world'``: ``(v_w, ω_w = R ω_b)``; ``'body'``: ``(v_b = Rᵀ v_w, ω_b)``.

    :param rot_wb: ``state.rotation_wb()`` if the caller has it already (it is costly).

    The arithmetic (the core's ``angular_velocity_w()`` and ``Rᵀ v_w`` summed left to right) is
    part of the recorded reference: replay recomputes these messages bit for bit. ``Rᵀ v_w`` is
    written out rather than left to a BLAS matrix product, whose kernel (with or without fused
    multiply-add) depends on the CPU and would change the last bit from machine to machine.
    """
    if twist_frame == 'world':
        return state.linear_velocity_w, state.angular_velocity_w()
    if twist_frame == 'body':
        r = state.rotation_wb() if rot_wb is None else rot_wb
        v = state.linear_velocity_w
        v_b = np.array([r[0, i] * v[0] + r[1, i] * v[1] + r[2, i] * v[2] for i in range(3)])
        return v_b, state.angular_velocity_b
    raise ValueError(f"twist_frame: {twist_frame!r} must be 'world' or 'body'")


def state_to_twist(state, twist_frame, world_frame, body_frame, rot_wb=None):
    """:class:`BodyState` → ``TwistStamped`` in ``twist_frame``, named in ``header.frame_id``."""
    msg = TwistStamped()
    msg.header.stamp = time_to_msg(state.time_ns)
    msg.header.frame_id = world_frame if twist_frame == 'world' else body_frame
    linear, angular = twist_components(state, twist_frame, rot_wb)
    _vector_to_msg(linear, msg.twist.linear)
    _vector_to_msg(angular, msg.twist.angular)
    return msg


def state_to_odometry(state, world_frame, body_frame, rot_wb=None):
    """:class:`BodyState` → ``Odometry`` (REP 105: pose in world, twist in the body frame)."""
    msg = Odometry()
    msg.header.stamp = time_to_msg(state.time_ns)
    msg.header.frame_id = world_frame
    msg.child_frame_id = body_frame
    _pose_into(state, msg.pose.pose)
    linear, angular = twist_components(state, 'body', rot_wb)
    _vector_to_msg(linear, msg.twist.twist.linear)
    _vector_to_msg(angular, msg.twist.twist.angular)
    return msg


def state_to_messages(state, twist_frame, world_frame, body_frame):
    """Return ``(PoseStamped, TwistStamped, Odometry)`` of one sample, computing R once."""
    rot_wb = state.rotation_wb()
    return (state_to_pose(state, world_frame),
            state_to_twist(state, twist_frame, world_frame, body_frame, rot_wb),
            state_to_odometry(state, world_frame, body_frame, rot_wb))


def state_to_transform(state, world_frame, body_frame):
    """:class:`BodyState` → ``TransformStamped`` world → body (for /tf)."""
    msg = TransformStamped()
    msg.header.stamp = time_to_msg(state.time_ns)
    msg.header.frame_id = world_frame
    msg.child_frame_id = body_frame
    _vector_to_msg(state.position_w, msg.transform.translation)
    quaternion_to_msg(state.orientation_wb, msg.transform.rotation)
    return msg


def wrench_from_msg(msg):
    """
    ``geometry_msgs/WrenchStamped`` → ``(frame_id, force, torque)`` plain values.

    ``force`` and ``torque`` are 3-tuples of floats in the coordinates ``frame_id`` names (N,
    N·m); they are not validated here (see :class:`rbd_ros.inputs.WrenchInputs`).
    """
    return (msg.header.frame_id, _vector_from_msg(msg.wrench.force),
            _vector_from_msg(msg.wrench.torque))


def wrench_to_msg(frame_id, force, torque, stamp_ns=0):
    """Plain values → ``geometry_msgs/WrenchStamped`` (used by the demo, tests and replay)."""
    msg = WrenchStamped()
    msg.header.stamp = time_to_msg(stamp_ns)
    msg.header.frame_id = frame_id
    _vector_to_msg(force, msg.wrench.force)
    _vector_to_msg(torque, msg.wrench.torque)
    return msg


def clock_to_msg(time_ns):
    """Integer ns → ``rosgraph_msgs/Clock``."""
    return Clock(clock=time_to_msg(time_ns))


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
