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
The joint model: kinds, frames, limits and the joint coordinate readout.

Conventions: a joint's frame is ``origin_parent_b`` in the parent body (world coordinates when
the parent is the world) and ``origin_child_b`` in the child; ``axis_b`` is given in parent
coordinates and is the child's axis too at the rest pose ``q_rest`` (the child orientation
relative to the parent, ``R_pc``, at joint coordinate zero; identity by default). Angles in
rad, lengths in m. Continuous joints are not wrapped: :func:`unwrap_angle` keeps a running
angle from one readout to the next.
"""

from dataclasses import dataclass
import math
from typing import Optional

import numpy as np

from rbd_ros.core.errors import finite_scalar, finite_vector, ModelError
from rbd_ros.core.rotations import quat_conjugate, quat_multiply, quat_normalize, quat_to_matrix

#: Joint kinds and the number of joint coordinates each has.
JOINT_KINDS = {'fixed': 0, 'revolute': 1, 'continuous': 1, 'prismatic': 1, 'spherical': 3,
               'universal': 2, 'planar': 3}
_LIMITED = ('revolute', 'prismatic')
#: Joint kinds with one coordinate: the only ones that take damping, friction or a mimic.
MOTOR_KINDS = ('revolute', 'continuous', 'prismatic')
#: Each kind that takes motors, and the names of its motor coordinates: one motor a
#: coordinate (``''`` the one coordinate of a one-coordinate joint). A planar joint's are its
#: in-plane offsets along ``axis2_b`` and ``axis_b × axis2_b`` (m) and its angle about
#: ``axis_b`` (rad); a universal joint's its angles about ``axis_b`` and about ``axis2_b``
#: (rad); a spherical (ball) joint's the rotation vector of its turn in parent coordinates
#: (rad; their rates the relative angular velocity, rad/s): the coordinates of
#: :func:`joint_position`.
MOTOR_COORDINATES = {'revolute': ('',), 'continuous': ('',), 'prismatic': ('',),
                     'planar': ('x', 'y', 'theta'), 'universal': ('theta1', 'theta2'),
                     'spherical': ('rx', 'ry', 'rz')}
_TWO_AXES = ('universal', 'planar')


def _unit_axis(value, name: str) -> np.ndarray:
    axis = finite_vector(value, name, 'unit vector', error=ModelError, frozen=False)
    norm = float(np.linalg.norm(axis))
    if not norm > 1e-12:
        raise ModelError(f'{name}: {axis.tolist()} has zero length; a joint axis needs a '
                         'direction')
    axis /= norm
    axis.flags.writeable = False
    return axis


def plane_x(axis) -> np.ndarray:
    """
    Return a planar joint's x direction for its normal ``axis`` (unit, joint frame).

    The joint frame's x axis projected into the plane, normalised; its y axis when ``axis`` is
    within 30° of x (``|x · axis| > cos 30°``; then ``|y · axis| <= sin 30°``, as the squares of
    the two sum to at most 1). For ``axis = z`` it is x, so the planar joint's x and y are the
    joint frame's.
    """
    axis = np.asarray(axis, dtype=np.float64)
    for candidate in (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0])):
        inplane = candidate - float(candidate @ axis) * axis
        norm = float(np.linalg.norm(inplane))
        if norm >= 0.5:
            return inplane / norm
    raise AssertionError('unreachable: x or y is at least 45° off a unit axis')


@dataclass(frozen=True)
class Joint:
    """
    One joint, validated when built.

    :param name: joint name, used in every error message.
    :param kind: one of :data:`JOINT_KINDS`.
    :param parent: parent body index, or ``None`` for the world.
    :param child: child body index.
    :param axis_b: revolute/continuous/prismatic/universal first axis; planar normal (parent).
    :param axis2_b: universal second axis (child side of the cross, at rest perpendicular to
        ``axis_b``); planar in-plane x direction. Unused by other kinds.
    :param lower, upper: revolute (rad) or prismatic (m) limits; ``None`` for no limit.
    :param cone_rad: spherical joints: the cone limit's half angle, rad, ``0 < cone_rad <= pi``:
        the angle between the joint axis in the parent (``axis_b``) and in the child (the same
        axis carried by ``q_rest``) may not exceed it (:func:`cone_angle`); ``None`` for none.
    :param effort_limit: |motor effort| cap, N m or N; ``None`` for no cap.
    :param damping: viscous damping along the joint coordinate, the generalized force
        ``-damping q̇`` (N m s/rad rotary, N s/m prismatic), >= 0; one-coordinate kinds only.
    :param friction: Coulomb friction along the joint coordinate (N m rotary, N prismatic),
        >= 0: the joint sticks while the force that holds it is within ``friction`` and slides
        against ``∓friction`` otherwise; one-coordinate kinds only.
    :param mimic: the name of the joint this one mimics, or ``None``: the coordinate is held
        at ``q = mimic_multiplier q_leader + mimic_offset`` by a constraint row (URDF
        ``<mimic>``); both joints one-coordinate kinds (revolute, continuous, prismatic, in any
        pairing: the multiplier carries the units). A mimic joint takes no motor.
    :param mimic_multiplier: ``k``, finite (rad/rad, m/m, m/rad or rad/m).
    :param mimic_offset: ``c``, finite, rad or m (this joint's unit).
    """

    name: str
    kind: str
    parent: Optional[int]
    child: int
    origin_parent_b: tuple = (0.0, 0.0, 0.0)
    origin_child_b: tuple = (0.0, 0.0, 0.0)
    axis_b: tuple = (0.0, 0.0, 1.0)
    axis2_b: tuple = (1.0, 0.0, 0.0)
    q_rest: tuple = (1.0, 0.0, 0.0, 0.0)
    lower: Optional[float] = None
    upper: Optional[float] = None
    cone_rad: Optional[float] = None
    effort_limit: Optional[float] = None
    damping: float = 0.0
    friction: float = 0.0
    mimic: Optional[str] = None
    mimic_multiplier: float = 1.0
    mimic_offset: float = 0.0

    def __post_init__(self):
        """Validate every field; one :class:`ModelError` line naming the joint and field."""
        who = f'joint {self.name!r}'
        if self.kind not in JOINT_KINDS:
            raise ModelError(f'{who}.kind: {self.kind!r} is not one of '
                             f'{", ".join(JOINT_KINDS)}')
        if isinstance(self.child, bool) or not isinstance(self.child, (int, np.integer)) \
                or self.child < 0:
            raise ModelError(f'{who}.child: {self.child!r} must be a body index >= 0')
        if self.parent is not None and (isinstance(self.parent, bool)
                                        or not isinstance(self.parent, (int, np.integer))
                                        or self.parent < 0 or self.parent == self.child):
            raise ModelError(f'{who}.parent: {self.parent!r} must be None (world) or a body '
                             'index >= 0 other than the child')
        unit = 'rad' if self.kind in ('revolute', 'continuous', 'spherical') else 'm'
        set_ = object.__setattr__
        set_(self, 'origin_parent_b', finite_vector(self.origin_parent_b,
                                                    f'{who}.origin_parent_b', 'm',
                                                    error=ModelError))
        set_(self, 'origin_child_b', finite_vector(self.origin_child_b, f'{who}.origin_child_b',
                                                   'm', error=ModelError))
        set_(self, 'axis_b', _unit_axis(self.axis_b, f'{who}.axis_b'))
        axis2 = _unit_axis(self.axis2_b, f'{who}.axis2_b')
        if self.kind in _TWO_AXES:
            if abs(float(axis2 @ self.axis_b)) > 1e-9:
                raise ModelError(f'{who}.axis2_b: {axis2.tolist()} must be perpendicular to '
                                 f'axis_b {self.axis_b.tolist()}')
        set_(self, 'axis2_b', axis2)
        q_rest = finite_vector(self.q_rest, f'{who}.q_rest', 'quaternion (w, x, y, z)', size=4,
                               error=ModelError, frozen=False)
        if not abs(float(np.linalg.norm(q_rest)) - 1.0) < 1e-9:
            raise ModelError(f'{who}.q_rest: {q_rest.tolist()} must be a unit quaternion')
        q_rest = quat_normalize(q_rest)
        q_rest.flags.writeable = False
        set_(self, 'q_rest', q_rest)
        for field in ('lower', 'upper'):
            value = getattr(self, field)
            if value is not None:
                if self.kind not in _LIMITED:
                    raise ModelError(f'{who}.{field}: {value!r}; a {self.kind} joint has no '
                                     'limits (revolute and prismatic have)')
                set_(self, field, finite_scalar(value, f'{who}.{field}', unit,
                                                error=ModelError))
        if self.lower is not None and self.upper is not None and self.lower > self.upper:
            raise ModelError(f'{who}.lower: {self.lower!r} {unit} must be <= upper '
                             f'{self.upper!r} {unit}')
        if self.cone_rad is not None:
            if self.kind != 'spherical':
                raise ModelError(f'{who}.cone_rad: {self.cone_rad!r}; only a spherical joint '
                                 'has a cone limit')
            cone = finite_scalar(self.cone_rad, f'{who}.cone_rad', 'rad', minimum=0.0,
                                 strict=True, error=ModelError)
            if cone > math.pi:
                raise ModelError(f'{who}.cone_rad: {cone!r} rad must be <= pi')
            set_(self, 'cone_rad', cone)
        if self.effort_limit is not None:
            set_(self, 'effort_limit', finite_scalar(
                self.effort_limit, f'{who}.effort_limit', 'N m' if unit == 'rad' else 'N',
                minimum=0.0, error=ModelError))
        rotary = unit == 'rad'
        for field, field_unit in (('damping', 'N m s/rad' if rotary else 'N s/m'),
                                  ('friction', 'N m' if rotary else 'N')):
            value = finite_scalar(getattr(self, field), f'{who}.{field}', field_unit,
                                  minimum=0.0, error=ModelError)
            if value != 0.0 and self.kind not in MOTOR_KINDS:
                raise ModelError(f'{who}.{field}: {value!r}; a {self.kind} joint takes no '
                                 f'{field} (only {", ".join(MOTOR_KINDS)} do)')
            set_(self, field, value)
        set_(self, 'mimic_multiplier', finite_scalar(self.mimic_multiplier,
                                                     f'{who}.mimic_multiplier', 'per leader unit',
                                                     error=ModelError))
        set_(self, 'mimic_offset', finite_scalar(self.mimic_offset, f'{who}.mimic_offset',
                                                 unit, error=ModelError))
        if self.mimic is not None:
            if not isinstance(self.mimic, str):
                raise ModelError(f'{who}.mimic: {self.mimic!r} is not a joint name')
            if self.mimic == self.name:
                raise ModelError(f'{who}.mimic: {self.mimic!r} is the joint itself; a joint '
                                 'cannot mimic itself')
            if self.kind not in MOTOR_KINDS:
                raise ModelError(f'{who}.mimic: {self.mimic!r}; a {self.kind} joint cannot '
                                 f'mimic (only {", ".join(MOTOR_KINDS)} can)')

    @property
    def dof(self) -> int:
        """Return the number of joint coordinates."""
        return JOINT_KINDS[self.kind]


def _relative(joint: Joint, pos_p_w, q_wp, pos_c_w, q_wc):
    """Return ``(R_wp, q_err, d_p)``: parent rotation, ``q_pc q_rest^-1``, anchor offset (p)."""
    if q_wp is None:
        q_wp = np.array([1.0, 0.0, 0.0, 0.0])
        pos_p_w = np.zeros(3)
    rot_wp = quat_to_matrix(np.asarray(q_wp, dtype=np.float64))
    rot_wc = quat_to_matrix(np.asarray(q_wc, dtype=np.float64))
    q_pc = quat_multiply(quat_conjugate(q_wp), q_wc)
    q_err = quat_multiply(q_pc, quat_conjugate(joint.q_rest))
    if q_err[0] < 0.0:
        q_err = -q_err
    anchor_c_w = np.asarray(pos_c_w, dtype=np.float64) + rot_wc @ joint.origin_child_b
    anchor_p_w = np.asarray(pos_p_w, dtype=np.float64) + rot_wp @ joint.origin_parent_b
    return rot_wp, q_err, rot_wp.T @ (anchor_c_w - anchor_p_w)


def _twist_angle(q_err, axis) -> float:
    return 2.0 * math.atan2(float(q_err[1:] @ axis), float(q_err[0]))


def joint_position(joint: Joint, pos_p_w, q_wp, pos_c_w, q_wc) -> np.ndarray:
    """
    Return the joint coordinates from the two body poses (parent ``None`` pose: the world).

    revolute/continuous: angle about ``axis_b`` in (-pi, pi] (see :func:`unwrap_angle`);
    prismatic: anchor offset along ``axis_b`` (m); spherical: rotation vector of
    ``q_pc q_rest^-1`` in parent coordinates (rad); universal: angles about ``axis_b`` and
    ``axis2_b`` (swing-twist split); planar: in-plane x, y (m) on ``axis2_b`` and
    ``axis_b x axis2_b``, and the angle about ``axis_b``; fixed: empty.
    """
    _, q_err, d_p = _relative(joint, pos_p_w, q_wp, pos_c_w, q_wc)
    axis = joint.axis_b
    if joint.kind in ('revolute', 'continuous'):
        return np.array([_twist_angle(q_err, axis)])
    if joint.kind == 'prismatic':
        return np.array([float(d_p @ axis)])
    if joint.kind == 'spherical':
        s = float(np.linalg.norm(q_err[1:]))
        angle = 2.0 * math.atan2(s, float(q_err[0]))
        return q_err[1:] * (angle / s) if s > 0.0 else np.zeros(3)
    if joint.kind == 'universal':
        # q_err = q_a(theta1) q_b(theta2): the first about axis_b, then the second about axis2_b
        a, b = axis, joint.axis2_b
        w, v = float(q_err[0]), q_err[1:]
        # q = (c1 + s1 a)(c2 + s2 b): w = c1 c2, v.a = s1 c2, v.b = c1 s2 (half angles)
        theta1 = 2.0 * math.atan2(float(v @ a), w)
        theta2 = 2.0 * math.atan2(float(v @ b), w)
        return np.array([theta1, theta2])
    if joint.kind == 'planar':
        ex = joint.axis2_b
        ey = np.cross(axis, ex)
        return np.array([float(d_p @ ex), float(d_p @ ey), _twist_angle(q_err, axis)])
    return np.zeros(0)


def cone_angle(joint: Joint, q_wp, q_wc) -> float:
    """
    Return the angle a cone limit bounds: the child's joint axis off the parent's, rad.

    ``e = R_wp axis_b`` and ``f = R_wc R_rest^T axis_b`` (the axis carried into the child at
    rest), angle ``atan2(|e x f|, e . f)``; it is 0 at the rest pose and ignores the twist
    about the axis. A world parent passes ``q_wp = None``.
    """
    rot_wp = np.eye(3) if q_wp is None else quat_to_matrix(np.asarray(q_wp, dtype=np.float64))
    rot_wc = quat_to_matrix(np.asarray(q_wc, dtype=np.float64))
    axis = joint.axis_b
    e = rot_wp @ axis
    f = rot_wc @ (quat_to_matrix(joint.q_rest).T @ axis)
    return math.atan2(float(np.linalg.norm(np.cross(e, f))), float(e @ f))


def joint_velocity(joint: Joint, pos_p_w, q_wp, vel_p_w, omega_p_w, pos_c_w, q_wc, vel_c_w,
                   omega_c_w) -> np.ndarray:
    """
    Return the joint coordinate rates (rad/s, m/s) from world-frame body velocities.

    Revolute, continuous, prismatic, planar and universal: the coordinate rates (a universal
    joint's second, the relative angular velocity on the child's cross axis: exact, the two
    axes being perpendicular); spherical: the relative angular velocity in parent coordinates
    (rad/s). A world parent passes ``None`` poses.
    """
    if q_wp is None:
        q_wp, pos_p_w = np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3)
        vel_p_w, omega_p_w = np.zeros(3), np.zeros(3)
    rot_wp, _, _ = _relative(joint, pos_p_w, q_wp, pos_c_w, q_wc)
    rot_wc = quat_to_matrix(np.asarray(q_wc, dtype=np.float64))
    omega_rel_p = rot_wp.T @ (np.asarray(omega_c_w, float) - np.asarray(omega_p_w, float))
    anchor_c_w = np.asarray(pos_c_w, float) + rot_wc @ joint.origin_child_b
    vel_anchor_c = np.asarray(vel_c_w, float) + np.cross(omega_c_w, anchor_c_w - pos_c_w)
    # rate of the offset seen in the (rotating) parent frame
    vel_rel_p = rot_wp.T @ (vel_anchor_c - np.asarray(vel_p_w, float)
                            - np.cross(omega_p_w, anchor_c_w - np.asarray(pos_p_w, float)))
    axis = joint.axis_b
    if joint.kind in ('revolute', 'continuous'):
        return np.array([float(omega_rel_p @ axis)])
    if joint.kind == 'prismatic':
        return np.array([float(vel_rel_p @ axis)])
    if joint.kind == 'spherical':
        return omega_rel_p
    if joint.kind == 'universal':
        # the child's cross axis in parent coordinates: R_pc R_rest^T axis2_b
        cross_p = rot_wp.T @ rot_wc @ quat_to_matrix(joint.q_rest).T @ joint.axis2_b
        return np.array([float(omega_rel_p @ axis), float(omega_rel_p @ cross_p)])
    if joint.kind == 'planar':
        ex = joint.axis2_b
        return np.array([float(vel_rel_p @ ex), float(vel_rel_p @ np.cross(axis, ex)),
                         float(omega_rel_p @ axis)])
    return np.zeros(0)


def unwrap_angle(previous_rad: float, reading_rad: float) -> float:
    """Return the running angle nearest ``previous_rad`` equal to ``reading_rad`` mod 2 pi."""
    return previous_rad + math.remainder(reading_rad - previous_rad, 2.0 * math.pi)


def coordinate_units(joint: Joint, coordinate: int = 0):
    """
    Return ``(position, velocity, effort)`` units of motor coordinate ``coordinate``.

    Rotary (``rad``, ``rad/s``, ``N m``) for revolute, continuous, universal and spherical
    joints and a planar joint's theta (coordinate 2); linear (``m``, ``m/s``, ``N``) otherwise.
    """
    rotary = joint.kind in ('revolute', 'continuous', 'universal', 'spherical') or (
        joint.kind == 'planar' and coordinate == 2)
    return ('rad', 'rad/s', 'N m') if rotary else ('m', 'm/s', 'N')


def check_position_target(joint: Joint, value: float, error=ModelError,
                          coordinate: int = 0) -> None:
    """
    Refuse a position target the joint cannot hold: beyond a limit, or out of ``(-π, π]``.

    A revolute angle must be in ``(-π, π]``, and so must a planar joint's theta (coordinate
    2; its x and y take any value) and both angles of a universal joint; a continuous joint
    takes any angle, and so does a spherical joint's each coordinate (the target orientation
    is ``exp`` of the three's rotation vector, whatever its length).

    The one rule of a position target:
    :meth:`~rbd_ros.core.joints.ArticulatedSimulator.set_motor` applies it, and
    the node's joint commands check it when a command arrives.

    :raises error: one line naming the joint, the value and its unit.
    """
    unit = coordinate_units(joint, coordinate)[0]
    who = f'joint {joint.name!r}'
    if joint.kind == 'spherical':
        return
    if joint.kind in ('planar', 'universal'):
        name = MOTOR_COORDINATES[joint.kind][coordinate]
        if (joint.kind == 'universal' or coordinate == 2) and not -math.pi < value <= math.pi:
            raise error(f'{who}/{name}.position: {value!r} rad must be in (-pi, pi] for a '
                        f"{joint.kind} joint's {name}")
        return
    for bound, ok in (('lower', joint.lower is None or value >= joint.lower),
                      ('upper', joint.upper is None or value <= joint.upper)):
        if not ok:
            raise error(f'{who}.position: {value!r} {unit} is beyond {bound} '
                        f'{getattr(joint, bound)!r} {unit}')
    if joint.kind == 'revolute' and not -math.pi < value <= math.pi:
        raise error(f'{who}.position: {value!r} rad must be in (-pi, pi] for a revolute '
                    'joint (a continuous joint takes any angle)')
