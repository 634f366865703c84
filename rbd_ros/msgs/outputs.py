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
One output sample: state → values → CDR bytes (and messages), for the node, replay and tests.

:class:`SampleBuilder` is the only place that turns the simulator's states into the node's
output messages: per body ``<prefix>pose``, ``<prefix>twist``, ``<prefix>odom`` and, with
contact, ``<prefix>contact_wrench`` (the prefix is ``<name>/`` for a body of ``body_names``,
empty for the body of a single-body file: ``pose``, ...); per robot ``<robot>/joint_states``,
``<robot>/odom`` (a floating robot's root link, through :meth:`BodyOutputs.odom`) and
``<robot>/joint_wrenches`` (:mod:`rbd_ros.msgs.robot_outputs`); ``poses`` (every pose, named
bodies only), ``/clock`` and one ``/tf`` message holding world → body for every body (and every
robot link). Each body's
messages come from its :class:`BodyOutputs`. The node publishes the CDR bytes of
:meth:`SampleBuilder.serialize` and records the SAME bytes; replay recomputes the samples with
:meth:`SampleBuilder.message`, built from the same values, so "replay rebuilds exactly what the
node published" holds by construction (a test checks that rclpy deserialises the bytes into
exactly those messages, at the length rclpy serialises them).

Frames (REP 103 / REP 105):

- ``PoseStamped``: the body pose in the world frame (``header.frame_id`` = world frame id).
- ``TwistStamped``: ``twist_frame='world'`` → ``v_w`` and ``ω_w = R ω_b``, ``frame_id`` =
  world frame id; ``'body'`` → ``v_b = Rᵀ v_w`` and ``ω_b``, ``frame_id`` = body frame id.
- ``Odometry``: pose in ``header.frame_id`` (world), twist in ``child_frame_id`` (body) as
  REP 105 requires. Covariances are left zero: the state is the simulator's exact state.
- ``TFMessage``: one transform world → body (translation = position, rotation = orientation).

Velocities are the integrator's own state variables, never finite differences of poses.

Speed: one sample costs a few µs (plain float arithmetic and one ``struct.pack`` per message)
where numpy on single quaternions and rclpy's serialiser took 50-70 µs a message. The
arithmetic is the recorded reference, bit for bit: ``R`` is the core's
:func:`rbd_ros.core.rotations.quat_to_matrix` written out (``|q|²`` summed left to right, as
numpy's ``linalg.norm`` does for 4 values), ``ω_w`` is
:func:`rbd_ros.core.rotations.quat_rotate` written out, and ``Rᵀ v_w`` is summed left to
right (never a BLAS product, whose fused multiply-adds depend on the CPU).

No rclpy here: the message classes are plain rosidl Python classes. CDR is XCDR1 little
endian (encapsulation ``00 01 00 00``; alignment counted after those 4 bytes), as rmw
serialises these types; padding bytes are zeros (rclpy's serialiser leaves them uninitialised,
so two serialisations of one message could differ there).
"""

import collections
import functools
import math

from geometry_msgs.msg import (PoseArray, PoseStamped, TransformStamped, TwistStamped,
                               Vector3, Wrench, WrenchStamped)
from nav_msgs.msg import Odometry
import numpy as np
from rbd_ros.core import BodyState, layout
from rbd_ros.msgs import conversions as conv
from rbd_ros.msgs import type_names as types
from rbd_ros.msgs.body_bytes import BodiesBytes, FixedLayout, twists
from rbd_ros.msgs.cdr import cdr_string as _cdr_string, layout as _layout
from rbd_ros.msgs.robot_outputs import JointOutputs, RobotOutputs
from rbd_ros.sim.params import NS_PER_S
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState, MultiDOFJointState
from std_msgs.msg import Header

try:  # tf2_msgs is on every Jazzy install but not in the PyPI wheels.
    from tf2_msgs.msg import TFMessage
except ImportError:  # pragma: no cover - depends on the install
    TFMessage = None

# The state rows of a column (rbd_ros.core.layout), bound once for the hot path.
_POS, _QUAT, _VEL, _OMEGA = layout.POS, layout.QUAT, layout.VEL, layout.OMEGA
#: Output kinds in publishing order, with their message types.
KINDS = ('pose', 'twist', 'odom', 'contact_wrench', 'clock', 'tf')
TYPE_NAMES = {'pose': types.POSE_STAMPED, 'twist': types.TWIST_STAMPED,
              'odom': types.ODOMETRY, 'contact_wrench': types.WRENCH_STAMPED,
              'clock': types.CLOCK, 'tf': types.TF_MESSAGE}
MESSAGE_TYPES = {'pose': PoseStamped, 'twist': TwistStamped, 'odom': Odometry,
                 'contact_wrench': WrenchStamped, 'clock': Clock, 'tf': TFMessage}

_ENCAPSULATION = b'\x00\x01\x00\x00'  # CDR little endian, no options
_COVARIANCE_BYTES = 36 * 8  # float64[36] of zeros
# |q|² this close to 1 keeps a simulator's quaternion as BodyState keeps it (BodyState allows
# 8 eps; half of that leaves room for a different summation order there).
_UNIT_NORM_SQ_TOL = 4 * np.finfo(np.float64).eps


class BodyOutputs:
    """
    The output messages of one body, as CDR bytes or message objects (a part of SampleBuilder).

    :param config: frames and switches: ``world_frame``, ``body_frame``, ``twist_frame``,
        ``publish_clock``, ``publish_tf``, ``contact``. :class:`SampleBuilder` builds each
        body's with ``publish_clock`` and ``publish_tf`` off (it writes those for all bodies).
    :param tf: False leaves ``/tf`` out whatever ``publish_tf`` says (tf2_msgs missing).
    """

    def __init__(self, config, tf=True):
        self.world_frame, self.body_frame = config.world_frame, config.body_frame
        self.twist_frame = config.twist_frame
        if self.twist_frame not in ('world', 'body'):
            raise ValueError(f"twist_frame: {self.twist_frame!r} must be 'world' or 'body'")
        self.kinds = ('pose', 'twist', 'odom') \
            + (('contact_wrench',) if config.contact else ()) \
            + (('clock',) if config.publish_clock else ()) \
            + (('tf',) if tf and config.publish_tf and TFMessage is not None else ())
        world, body = _cdr_string(self.world_frame), _cdr_string(self.body_frame)
        twist_frame = world if self.twist_frame == 'world' else body
        header = ('i', 'I')
        self._pose = _layout(*header, world, *'d' * 7)
        self._twist = _layout(*header, twist_frame, *'d' * 6)
        self._odom = _layout(*header, world, body, *'d' * 7, _COVARIANCE_BYTES, *'d' * 6,
                             _COVARIANCE_BYTES)
        self._wrench = _layout(*header, world, *'d' * 6)
        self._clock = _layout(*header)
        self._tf = _layout('I', *header, world, body, *'d' * 7)
        self._consts = (world, body, twist_frame)

    def values(self, state):
        """
        Return the sample's plain floats ``(p, q, twist, twist_b)`` of ``state``.

        ``p = (x, y, z)`` m, ``q = (w, x, y, z)``, ``twist = (vx, vy, vz, ωx, ωy, ωz)`` in
        ``twist_frame`` (m/s, rad/s), ``twist_b`` the same in the body frame (odometry).
        """
        return _values(state.position_w.tolist(), state.orientation_wb.tolist(),
                       state.linear_velocity_w.tolist(), state.angular_velocity_b.tolist(),
                       self.twist_frame == 'world')

    def column_values(self, column):
        """
        Return :meth:`values` from a simulator's packed 13-float state column (no BodyState).

        A quaternion not unit to round-off goes through :class:`BodyState` (which normalises
        it), so the result is always that of :meth:`values` on ``simulator.state``.
        """
        return self.list_values(column.tolist())

    def list_values(self, x):
        """Return :meth:`column_values` of the column given as a list of its 13 floats."""
        q = x[_QUAT]
        if abs(((q[0] * q[0] + q[1] * q[1]) + q[2] * q[2]) + q[3] * q[3] - 1.0) \
                > _UNIT_NORM_SQ_TOL:
            return self.values(BodyState(x[_POS], q, x[_VEL], x[_OMEGA]))
        return _values(x[_POS], q, x[_VEL], x[_OMEGA],
                       self.twist_frame == 'world')

    def serialize(self, time_ns, values, contact_wrench=None):
        """
        Return ``[(kind, CDR bytes)]`` of one sample, in :data:`KINDS` order.

        :param contact_wrench: ``(force_w, torque_w)`` (N, N·m about the COM, world frame) for
            the ``contact_wrench`` kind (a row of
            :attr:`rbd_ros.sim.session.SimSession.contact_wrenches_w`).
        """
        (px, py, pz), (qw, qx, qy, qz), twist, twist_b = values
        sec, nanosec = divmod(time_ns, NS_PER_S)
        world, body, twist_frame = self._consts
        enc = _ENCAPSULATION
        out = [
            ('pose', self._pose.pack(enc, sec, nanosec, len(world), world,
                                     px, py, pz, qx, qy, qz, qw)),
            ('twist', self._twist.pack(enc, sec, nanosec, len(twist_frame), twist_frame,
                                       *twist)),
            ('odom', self.odom(time_ns, values))]
        kinds = self.kinds
        if 'contact_wrench' in kinds:
            force, torque = contact_wrench
            out.append(('contact_wrench', self._wrench.pack(
                enc, sec, nanosec, len(world), world, *force, *torque)))
        if 'clock' in kinds:
            out.append(('clock', self._clock.pack(enc, sec, nanosec)))
        if 'tf' in kinds:
            out.append(('tf', self._tf.pack(enc, 1, sec, nanosec, len(world), world,
                                            len(body), body, px, py, pz, qx, qy, qz, qw)))
        return out

    def odom(self, time_ns, values):
        """
        Return the CDR bytes of the ``Odometry`` of :meth:`values` at ``time_ns``.

        Pose in the world frame, twist in the body frame (REP 105): the one odom writer, for
        the free bodies and a floating robot's root link alike.
        """
        (px, py, pz), (qw, qx, qy, qz), _, twist_b = values
        sec, nanosec = divmod(time_ns, NS_PER_S)
        world, body, _ = self._consts
        return self._odom.pack(_ENCAPSULATION, sec, nanosec, len(world), world, len(body), body,
                               px, py, pz, qx, qy, qz, qw, *twist_b)

    def messages(self, state, contact_wrench=None):
        """Return ``{kind: message}`` of one sample of ``state`` (new objects each call)."""
        return {kind: self.message(kind, state, contact_wrench) for kind in self.kinds}

    def message(self, kind, state, contact_wrench=None):
        """Return a new message of ``kind`` (any of :data:`KINDS`) for ``state``."""
        (px, py, pz), (qw, qx, qy, qz), twist, twist_b = self.values(state)
        stamp = state.time_ns
        if kind == 'contact_wrench':
            return conv.wrench_to_msg(self.world_frame, *contact_wrench, stamp_ns=stamp)
        if kind == 'clock':
            return Clock(clock=conv.time_to_msg(stamp))
        if kind == 'pose':
            msg = PoseStamped()
            _header(msg.header, stamp, self.world_frame)
            _pose(msg.pose, px, py, pz, qw, qx, qy, qz)
        elif kind == 'twist':
            msg = TwistStamped()
            _header(msg.header, stamp,
                    self.world_frame if self.twist_frame == 'world' else self.body_frame)
            _twist(msg.twist, twist)
        elif kind == 'odom':
            msg = Odometry()
            _header(msg.header, stamp, self.world_frame)
            msg.child_frame_id = self.body_frame
            _pose(msg.pose.pose, px, py, pz, qw, qx, qy, qz)
            _twist(msg.twist.twist, twist_b)
        elif kind == 'tf' and TFMessage is not None:
            transform = TransformStamped()
            _header(transform.header, stamp, self.world_frame)
            transform.child_frame_id = self.body_frame
            translation, rotation = transform.transform.translation, transform.transform.rotation
            translation.x, translation.y, translation.z = px, py, pz
            rotation.x, rotation.y, rotation.z, rotation.w = qx, qy, qz, qw
            msg = TFMessage(transforms=[transform])
        else:
            raise ValueError(f'kind: {kind!r} is not one of {KINDS} (tf needs tf2_msgs)')
        return msg


def sample_builder(config, tf=True):
    """Return a (shared) :class:`SampleBuilder` for ``config``."""
    if config.robots or getattr(config, 'world_joints', ()):  # not shared: built from joints
        return SampleBuilder(config, tf)
    bodies = tuple((b.prefix, b.body_frame) for b in config.bodies)
    return _cached_builder(config.world_frame, config.twist_frame, config.publish_clock,
                           config.publish_tf and tf, config.contact, config.named, bodies,
                           getattr(config, 'per_body_topics', True))


#: Per-body output kinds, in publishing order (topics ``<prefix>pose``, ...).
BODY_KINDS = ('pose', 'twist', 'odom', 'contact_wrench')


def topic_of(kind):
    """Return the topic of an output kind: ``/clock`` and ``/tf`` absolute, the rest relative."""
    return '/' + kind if kind in ('clock', 'tf') else kind


def type_of(kind):
    """Return the message class of an output kind (``<body>/pose`` is a ``pose``)."""
    if kind == 'poses':
        return PoseArray
    base = kind.rsplit('/', 1)[-1]
    if base == 'joint_states':
        return JointState
    if base == 'joint_wrenches':
        return MultiDOFJointState
    return MESSAGE_TYPES[kind.rsplit('/', 1)[-1]]


class SampleBuilder:
    """
    The output messages of one sample of every body, as CDR bytes (node) or messages (replay).

    In :attr:`kinds` order: per body (config order) its :class:`BodyOutputs` kinds under its
    prefix; ``poses`` (``geometry_msgs/PoseArray``: every body's pose, world frame) when the
    bodies are named (:attr:`rbd_ros.sim.config.NodeConfig.named`); ``clock``; one ``tf``
    message holding world → body for every body. Built once per configuration
    (:func:`sample_builder` shares them).

    :param config: a :class:`rbd_ros.sim.config.NodeConfig`.
    :param tf: False leaves ``/tf`` out whatever ``publish_tf`` says (tf2_msgs missing, or a
        caller that does not output it).

    With ``per_body_topics`` off (a world only), :attr:`kinds` has no per-body kinds.
    """

    def __init__(self, config, tf=True):
        self.world_frame = config.world_frame
        self.prefixes = tuple(body.prefix for body in config.bodies)
        self.bodies = tuple(BodyOutputs(_Frames(
            config.world_frame, body.body_frame, config.twist_frame, False, False,
            config.contact)) for body in config.bodies)
        self.robots = tuple(RobotOutputs(robot, r, config.world_frame)
                            for r, robot in enumerate(getattr(config, 'robots', ())))
        joints = getattr(config, 'world_joints', ())
        if joints:  # the world's joints: joint_states and joint_wrenches, no prefix; their
            # readouts' index after the robots' (RobotContactWorld's, 0 without robots)
            self.robots += (JointOutputs('', len(self.robots),
                                         [e for j in joints for e, _ in j.entries],
                                         [j.name for j in joints]),)
        self.per_body = getattr(config, 'per_body_topics', True) or not config.named
        self.kinds = tuple(prefix + kind for prefix, body in zip(self.prefixes, self.bodies)
                           for kind in body.kinds if self.per_body) \
            + tuple(kind for robot in self.robots for kind in robot.kinds) \
            + (('poses',) if config.named else ()) \
            + (('clock',) if config.publish_clock else ()) \
            + (('tf',) if tf and config.publish_tf and TFMessage is not None else ())
        world = _cdr_string(self.world_frame)
        header = ('i', 'I')
        n = len(self.bodies)
        self._poses = _layout(*header, world, 'I', *'d' * (7 * n))
        self._clock = _layout(*header)
        fields = ['I']
        for body in config.bodies:
            fields += [*header, world, _cdr_string(body.body_frame), *'d' * 7]
        for robot in self.robots:
            fields += robot.tf_fields()
        self._tf = _layout(*fields)
        self._tf_count = n + sum(len(robot.transforms) for robot in self.robots)
        # A floating robot's odom: its root link frame through the free bodies' odom writer.
        self._robot_odom = {robot.index: BodyOutputs(_Frames(
            config.world_frame, robot.root_frame, 'body', False, False, False))
            for robot in self.robots if robot.odom_kind}
        self._world = world
        self._frames = [_cdr_string(body.body_frame) for body in config.bodies]
        # poses and (without robots) /tf as templates whose stamps and doubles each sample
        # writes, every body's at once; with robots, /tf is packed field by field.
        zero = (0.0,) * 7
        self._poses_bytes = FixedLayout(self._poses, (
            _ENCAPSULATION, 0, 0, len(world), world, n, *zero * n)) if n else None
        self._tf_bytes = FixedLayout(self._tf, (_ENCAPSULATION, n, *(
            v for frame in self._frames for v in (0, 0, len(world), world, len(frame), frame,
                                                  *zero)))) if n and not self.robots else None
        # What serialize needs on its hot path, decided once.
        self._has_poses, self._has_clock, self._has_tf = (
            kind in self.kinds for kind in ('poses', 'clock', 'tf'))
        # The fast path of a world of one unnamed body (a single-body params file): that body's
        # BodyOutputs writes clock and tf too, in the same order and the same bytes (a TF
        # message of one transform), so a sample is one call (~1 µs less per sample).
        self._single = None
        if len(self.bodies) == 1 and not config.named and not self.prefixes[0]:
            body = config.bodies[0]
            self._single = BodyOutputs(_Frames(
                config.world_frame, body.body_frame, config.twist_frame, self._has_clock,
                self._has_tf, config.contact))
            assert self._single.kinds == self.kinds, (self._single.kinds, self.kinds)
        self._prefixed = tuple(tuple(prefix + kind for kind in body.kinds) if prefix else None
                               for prefix, body in zip(self.prefixes, self.bodies))
        self._body_kinds = frozenset(kind for kinds in self._prefixed if kinds
                                     for kind in kinds) if self.per_body else frozenset()
        self._bodies_bytes = BodiesBytes(self.bodies, [
            prefixed or body.kinds for prefixed, body in zip(self._prefixed, self.bodies)],
            _UNIT_NORM_SQ_TOL) if self.bodies else None

    def body_index(self, kind):
        """Return the index of the body of a per-body kind (``<prefix>pose``), or None."""
        head, _, base = kind.rpartition('/')
        prefix = head + '/' if head else ''
        if base not in BODY_KINDS or prefix not in self.prefixes:
            return None
        return self.prefixes.index(prefix)

    def serialize(self, time_ns, columns, wrenches=None, robots=None, wanted=None):
        """
        Return ``[(kind, CDR bytes)]`` of one sample, in :attr:`kinds` order.

        :param columns: (13, N) packed states (:attr:`rbd_ros.sim.session.SimSession.columns`).
        :param wrenches: (N, 6) contact force and torque per body (N, N·m; world, about COMs),
            or None without contact
            (:attr:`rbd_ros.sim.session.SimSession.contact_wrenches_w`).
        :param robots: the :class:`rbd_ros.sim.robot_world.RobotWorld` of a robot file, the
            :class:`rbd_ros.sim.world_joints.JointedWorldSimulator` of a world with joints.
        :param wanted: the kinds to build (a set; the others are neither built nor returned),
            or None for every kind. The bytes of a kind do not depend on which others are built.
        """
        single = self._single
        if single is not None:
            out = single.serialize(time_ns, single.list_values(columns[:, 0].tolist()), None
                                   if wrenches is None else (wrenches[0, :3].tolist(),
                                                             wrenches[0, 3:].tolist()))
            return out if wanted is None else [item for item in out if item[0] in wanted]
        out = []
        has = self._has_poses, self._has_tf, self.per_body
        if wanted is not None:
            has = ('poses' in wanted and has[0], 'tf' in wanted and has[1],
                   has[2] and not wanted.isdisjoint(self._body_kinds))
        sec, nanosec = divmod(time_ns, NS_PER_S)
        world = self._world
        rows = None  # every body's x, y, z, qx, qy, qz, qw, for poses and tf
        if self.bodies and (has[2] or has[0] or has[1]):
            rows = self._bodies_sample(time_ns, columns, wrenches, wanted if has[2] else (),
                                       out, has[0] or has[1])
        tf = None  # with robots: the fields of tf, packed at once
        if has[1] and self._tf_bytes is None:
            tf = []
            for frame, row in zip(self._frames, () if rows is None else rows.tolist()):
                tf += (sec, nanosec, len(world), world, len(frame), frame, *row)
        for robot in self.robots:
            if wanted is None or robot.kind in wanted:
                out.append((robot.kind, robot.joint_states(time_ns, robots)))
            odom = robot.odom_kind
            if odom and (wanted is None or odom in wanted):
                builder = self._robot_odom[robot.index]
                out.append((odom, builder.odom(
                    time_ns, builder.list_values(robots.root_state(robot.index)))))
            if wanted is None or robot.wrench_kind in wanted:
                out.append((robot.wrench_kind, robot.joint_wrenches(time_ns, robots)))
            if tf is not None:
                tf += robot.tf_values(sec, nanosec, robots.link_poses(robot.index))
        if has[0]:
            out.append(('poses', self._poses.pack(_ENCAPSULATION, sec, nanosec, len(world),
                                                  world, 0) if rows is None
                        else self._poses_bytes.serialize(time_ns, rows)))
        if self._has_clock and (wanted is None or 'clock' in wanted):
            out.append(('clock', self._clock.pack(_ENCAPSULATION, sec, nanosec)))
        if has[1]:
            out.append(('tf', self._tf_bytes.serialize(time_ns, rows) if tf is None
                        else self._tf.pack(_ENCAPSULATION, self._tf_count, *tf)))
        return out

    def _bodies_sample(self, time_ns, columns, wrenches, wanted, out, poses):
        """
        Append each body's wanted kinds to ``out``; with ``poses``, return the poses' rows.

        All bodies at once (:class:`rbd_ros.msgs.body_bytes.BodiesBytes`); the rows are
        (N, 7) ``x, y, z, qx, qy, qz, qw``, as ``poses`` and ``/tf`` carry them.

        :param wanted: None (every kind) or the per-body kinds to build (empty: none).
        """
        bodies = self._bodies_bytes
        sample = bodies.values(columns)
        if wanted is None or wanted:
            out += bodies.serialize(time_ns, sample, wrenches, wanted)
        if poses:
            return np.concatenate([sample[0], sample[1][:, [1, 2, 3, 0]]], axis=1)
        return None

    def poses_wxyz(self, columns):
        """
        Return every body's ``(positions (N, 3), quaternions (N, 4) w first)`` as ``poses``.

        The values the pose topics carry (:meth:`BodyOutputs.list_values`), for all bodies at
        once: a quaternion not unit to round-off goes through its body's values.
        """
        positions = np.ascontiguousarray(columns[_POS].T)
        quats = np.ascontiguousarray(columns[_QUAT].T)
        qw, qx, qy, qz = columns[_QUAT]
        off = np.abs(((qw * qw + qx * qx) + qy * qy) + qz * qz - 1.0) > _UNIT_NORM_SQ_TOL
        for i in np.flatnonzero(off):
            p, q = self.bodies[i].column_values(columns[:, i])[:2]
            positions[i], quats[i] = p, q
        return positions, quats

    def robot_message(self, kind, time_ns, robots):
        """
        Return a new message of a robot kind now (``<robot>/joint_states``, ``odom``, ...).

        :param robots: the :class:`rbd_ros.sim.robot_world.RobotWorld`.
        """
        robot = next(robot for robot in self.robots if kind in robot.kinds)
        r = robot.index
        if kind == robot.odom_kind:
            x = robots.root_state(r)
            return self._robot_odom[r].message(
                'odom', BodyState(x[_POS], x[_QUAT], x[_VEL], x[_OMEGA], time_ns))
        if kind == robot.wrench_kind:
            wrenches = [Wrench(force=Vector3(x=fx, y=fy, z=fz),
                               torque=Vector3(x=tx, y=ty, z=tz))
                        for fx, fy, fz, tx, ty, tz in robots.joint_wrenches(r)]
            return MultiDOFJointState(
                header=Header(stamp=conv.time_to_msg(time_ns), frame_id=''),
                joint_names=list(robot.wrench_joints), wrench=wrenches)
        position, velocity, effort = robots.joint_states(r)
        return JointState(header=Header(stamp=conv.time_to_msg(time_ns), frame_id=''),
                          name=list(robot.joint_names), position=position, velocity=velocity,
                          effort=effort)

    def message(self, kind, state, contact_wrench=None):
        """
        Return a new message of the per-body ``kind`` (``<prefix>pose``, ...) or ``clock``.

        :param state: the :class:`rbd_ros.core.BodyState` of that kind's body (for ``clock``,
            any body's: only its time is read).
        :param contact_wrench: that body's ``(force_w, torque_w)`` for ``contact_wrench``.
        """
        if kind == 'clock':
            return Clock(clock=conv.time_to_msg(state.time_ns))
        index = self.body_index(kind)
        if index is None:
            raise ValueError(f'kind: {kind!r} is not a per-body kind of this configuration '
                             f'({", ".join(self.kinds)}) nor clock')
        return self.bodies[index].message(kind.rsplit('/', 1)[-1], state, contact_wrench)


@functools.lru_cache(maxsize=16)
def _cached_builder(world_frame, twist_frame, publish_clock, publish_tf, contact, named,
                    bodies, per_body_topics):
    config = _Config(world_frame, twist_frame, publish_clock, publish_tf, contact, named,
                     tuple(_Body(prefix, frame) for prefix, frame in bodies), per_body_topics)
    return SampleBuilder(config)


_Config = collections.namedtuple(
    '_Config',
    'world_frame twist_frame publish_clock publish_tf contact named bodies per_body_topics')
_Body = collections.namedtuple('_Body', 'prefix body_frame')
_Frames = collections.namedtuple(
    '_Frames', 'world_frame body_frame twist_frame publish_clock publish_tf contact')


def _header(header, time_ns, frame_id):
    header.stamp = conv.time_to_msg(time_ns)
    header.frame_id = frame_id


def _pose(pose, px, py, pz, qw, qx, qy, qz):
    position, orientation = pose.position, pose.orientation
    position.x, position.y, position.z = px, py, pz
    orientation.x, orientation.y, orientation.z, orientation.w = qx, qy, qz, qw


def _twist(twist, values):
    linear, angular = twist.linear, twist.angular
    linear.x, linear.y, linear.z, angular.x, angular.y, angular.z = values


def _values(p, q, v, omega_b, twist_world):
    """Compute the sample's values by the scalar path (module docstring: why each sum so)."""
    twist, twist_b = twists(q, v, omega_b, twist_world, math.sqrt)
    return p, q, twist, twist_b
