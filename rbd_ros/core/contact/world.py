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
Materials, the static world and the start-up overlap check.

A static object has infinite mass: nothing moves it.  The world holds at most one infinite
ground plane and any number of named static shapes at fixed poses; each has a
:class:`Material`.  Poses are ``(position_w, orientation_wb)`` with ``x_w = R(q_wb) x_b +
position_w`` and quaternions ``(w, x, y, z)`` as everywhere inside rbd_ros.

Pair rule (one rule for every pair, body-body and body-static): the friction coefficient of a
pair is the geometric mean ``μ = sqrt(μ_a μ_b)`` and its restitution the larger one,
``ε = max(ε_a, ε_b)`` (Box2D's ``b2MixFriction`` / ``b2MixRestitution``).  Reasons: both
are symmetric; a material meeting itself keeps its own values; a frictionless surface (ice,
μ = 0) makes every pair frictionless, and a bouncy ball bounces on any floor.
"""

from dataclasses import dataclass, field
import math
import numbers
import re

import numpy as np

from rbd_ros.core import jitcache
from rbd_ros.core.contact import kernels as k
from rbd_ros.core.contact.rows import pair_material
from rbd_ros.core.contact.shapes import collision_shape, CollisionShape, plane_shape
from rbd_ros.core.errors import field_error, InputError, ModelError
from rbd_ros.core.rotations import quat_normalize, quat_to_matrix

__all__ = [
    'DEFAULT_OVERLAP_TOLERANCE_M', 'Material', 'StaticObject', 'StaticWorld', 'check_overlaps',
    'ground_plane', 'obstacle', 'penetration_depth', 'phi_error_bound', 'validate_material',
]

#: Default depth (m) by which bodies may overlap at start before :func:`check_overlaps` refuses.
DEFAULT_OVERLAP_TOLERANCE_M = 1e-3
_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]*\Z')
#: The one rule for a name of a body, obstacle or input, in words (see :func:`is_valid_name`).
NAME_RULE = 'letters, digits and _ (not starting with a digit)'


def is_valid_name(name) -> bool:
    """Return whether ``name`` is a valid body, obstacle or input name (:data:`NAME_RULE`)."""
    return isinstance(name, str) and _NAME.match(name) is not None


def _coefficient(value, name, low, high, rule):
    if isinstance(value, bool) or not isinstance(value, (numbers.Real, np.number)):
        raise field_error(ModelError, name, f'{value!r} is not a number (dimensionless)',
                          value, '')
    number = float(value)
    if not (math.isfinite(number) and low <= number <= high):
        raise field_error(ModelError, name, f'{number!r} (dimensionless) must be {rule}', value,
                          '')
    return number


def validate_material(friction, restitution, field=''):
    """
    Return a :class:`Material` after checking ``0 <= friction`` and ``0 <= restitution <= 1``.

    :param field: prefix of the field names in error messages, e.g. ``'obstacles.ramp.'``.
    :raises ModelError: naming ``<field>friction`` or ``<field>restitution``, the value and the
        rule.
    """
    mu = _coefficient(friction, f'{field}friction', 0.0, math.inf,
                      'finite and >= 0 (Coulomb friction coefficient μ)')
    eps = _coefficient(restitution, f'{field}restitution', 0.0, 1.0,
                       'in [0, 1] (coefficient of restitution ε)')
    return Material(mu, eps)


@dataclass(frozen=True)
class Material:
    """
    Contact material of a body or a static object.

    :param friction: Coulomb friction coefficient μ >= 0 (one value: static and kinetic equal).
    :param restitution: coefficient of restitution ε in [0, 1]: the normal relative velocity
        after a collision is ``-ε`` times the one before.
    """

    friction: float = 0.5
    restitution: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, 'friction', _coefficient(
            self.friction, 'friction', 0.0, math.inf,
            'finite and >= 0 (Coulomb friction coefficient μ)'))
        object.__setattr__(self, 'restitution', _coefficient(
            self.restitution, 'restitution', 0.0, 1.0,
            'in [0, 1] (coefficient of restitution ε)'))

    def combine(self, other):
        """Return the pair's material (:func:`~rbd_ros.core.contact.rows.pair_material`)."""
        jitcache.configured()  # the kernel cache, before a first compile
        return Material(*(float(v) for v in pair_material(
            self.friction, self.restitution, other.friction, other.restitution)))


def _pose(position_w, orientation_wb, field):
    try:
        position = np.array(position_w, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ModelError(f'{field}position_w: {position_w!r} is not 3 numbers in m') from None
    if not np.all(np.isfinite(position)):
        raise ModelError(f'{field}position_w: {position.tolist()} m must be finite')
    try:
        quat = quat_normalize(np.array(orientation_wb, dtype=np.float64).reshape(4),
                              f'{field}orientation_wb')
    except (TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise ModelError(str(exc)) from None
        raise ModelError(
            f'{field}orientation_wb: {orientation_wb!r} is not a quaternion (w, x, y, z)'
        ) from None
    position.flags.writeable = False
    quat.flags.writeable = False
    return position, quat


@dataclass(frozen=True, eq=False)
class StaticObject:
    """
    A named static shape at a fixed pose (infinite mass).

    :param name: an identifier (letters, digits, ``_``; not starting with a digit).
    :param shape: its :class:`CollisionShape` in its own frame.
    :param position_w: m, where its frame's origin is.
    :param orientation_wb: ``q_wb`` (w, x, y, z), normalised when built.
    :param material: its :class:`Material`.
    """

    name: str
    shape: CollisionShape
    position_w: np.ndarray = field(default=(0.0, 0.0, 0.0))
    orientation_wb: np.ndarray = field(default=(1.0, 0.0, 0.0, 0.0))
    material: Material = field(default_factory=Material)

    def __post_init__(self):
        if not is_valid_name(self.name):
            raise ModelError(
                f'name: {self.name!r} must be an identifier (letters, digits, _; not starting '
                'with a digit)')
        if not isinstance(self.shape, CollisionShape):
            raise ModelError(
                f'{self.name}.shape: a {type(self.shape).__name__} is not a CollisionShape')
        if not isinstance(self.material, Material):
            raise ModelError(f'{self.name}.material: {self.material!r} is not a Material')
        position, quat = _pose(self.position_w, self.orientation_wb, f'{self.name}.')
        object.__setattr__(self, 'position_w', position)
        object.__setattr__(self, 'orientation_wb', quat)

    def __eq__(self, other):
        if not isinstance(other, StaticObject):
            return NotImplemented
        return (self.name == other.name and self.shape == other.shape
                and np.array_equal(self.position_w, other.position_w)
                and np.array_equal(self.orientation_wb, other.orientation_wb)
                and self.material == other.material)

    __hash__ = None


def ground_plane(normal_w=(0.0, 0.0, 1.0), offset_m=0.0, material=None, name='ground'):
    """
    Return the infinite ground ``n·x_w <= offset_m`` as a :class:`StaticObject`.

    φ = n·x − offset with ``n`` the unit outward normal (normalised here); the solid side is
    ``φ < 0``.

    :raises ModelError: naming ``<name>.normal``, ``<name>.offset_m`` or the material field.
    """
    shape = plane_shape(normal_w, offset_m, field=f'{name}.')
    if material is None:
        material = Material()
    elif not isinstance(material, Material):
        material = validate_material(*material, field=f'{name}.')
    return StaticObject(name, shape, material=material)


def obstacle(name, shape, dimensions_m=None, mesh_path=None, mesh_scale=(1.0, 1.0, 1.0),
             position_w=(0.0, 0.0, 0.0), orientation_wb=(1.0, 0.0, 0.0, 0.0), friction=0.5,
             restitution=0.0, spacing_m=None, cache_dir=None):
    """
    Build a static obstacle from parameters; every error names ``obstacles.<name>.<field>``.

    :param shape: one of :data:`rbd_ros.core.contact.shapes.PRIMITIVES` or ``'mesh'``.
    :raises ModelError: e.g. ``obstacles.ramp.dimensions_m: [0.0, 1.0, 1.0] m for shape 'box'
        [x, y, z]: x = 0.0 m must be finite and > 0``.
    """
    if not is_valid_name(name):
        raise ModelError(
            f'obstacles: name {name!r} must be an identifier (letters, digits, _; not starting '
            'with a digit)')
    where = f'obstacles.{name}.'
    material = validate_material(friction, restitution, where)
    geometry = collision_shape(shape, dimensions_m, mesh_path, mesh_scale, spacing_m,
                               field=where, cache_dir=cache_dir)
    position, quat = _pose(position_w, orientation_wb, where)
    return StaticObject(name, geometry, position, quat, material)


@dataclass(frozen=True, eq=False)
class StaticWorld:
    """
    The static part of a world: an optional infinite ground plane and named static shapes.

    :param ground: a :class:`StaticObject` whose shape is a plane (see :func:`ground_plane`),
        or None.
    :param obstacles: static objects of other shapes, names unique (and not the ground's).
    """

    ground: StaticObject = None
    obstacles: tuple = ()

    def __post_init__(self):
        if self.ground is not None and (not isinstance(self.ground, StaticObject)
                                        or self.ground.shape.kind != k.KIND_PLANE):
            what = getattr(getattr(self.ground, 'shape', None), 'shape', type(self.ground))
            raise ModelError(
                f'ground: a {what!r} object; the ground must be a plane (see ground_plane)')
        obstacles = tuple(self.obstacles)
        names = set() if self.ground is None else {self.ground.name}
        for item in obstacles:
            if not isinstance(item, StaticObject):
                raise ModelError(f'obstacles: a {type(item).__name__} is not a StaticObject')
            if item.shape.kind == k.KIND_PLANE:
                raise ModelError(
                    f'obstacles.{item.name}.shape: a plane; the world has one plane, its '
                    'ground')
            if item.name in names:
                raise ModelError(f'obstacles.{item.name}: the name is used twice')
            names.add(item.name)
        object.__setattr__(self, 'obstacles', obstacles)

    def __eq__(self, other):
        if not isinstance(other, StaticWorld):
            return NotImplemented
        return self.ground == other.ground and self.obstacles == other.obstacles

    __hash__ = None

    def objects(self):
        """Return ``(label, StaticObject)`` pairs: the ground first, then the obstacles."""
        out = [] if self.ground is None else [(self.ground.name, self.ground)]
        return out + [(f'obstacles.{o.name}', o) for o in self.obstacles]


def phi_error_bound(shape):
    """Return the bound (m) on |φ − exact signed distance|: 0, or ``(√3 / 2) h`` for a mesh."""
    if shape.kind == k.KIND_MESH:
        return 0.5 * math.sqrt(3.0) * float(shape.params[3])
    return 0.0


def _one_way(shape_a, rot_a, pos_a, shape_b, rot_b, pos_b):
    """Deepest ``-φ_B`` over A's surface points (m) and that point in world coordinates."""
    if shape_a.points_b.shape[0] == 0:
        return -math.inf, None
    rot_ba = np.ascontiguousarray(rot_b.T @ rot_a)
    trans_ba = np.ascontiguousarray(rot_b.T @ (pos_a - pos_b))
    jitcache.configured()  # the kernel cache, before a first compile
    phi, index = k.min_phi_posed(shape_b.kind, shape_b.params, shape_b.grid, rot_ba, trans_ba,
                                 shape_a.points_b)
    return -phi - phi_error_bound(shape_b), rot_a @ shape_a.points_b[index] + pos_a


def penetration_depth(shape_a, position_a, orientation_a, shape_b, position_b, orientation_b):
    """
    Return ``(depth_m, point_w)``: how deep the two posed shapes overlap, and where.

    The depth is the largest ``-φ`` of either shape at the other's surface points, less the φ
    error bound of the shape evaluated (:func:`phi_error_bound`), so a mesh resting on a
    surface is not reported as overlapping because of its grid; ``depth <= 0`` means no
    overlap was found.  Being measured at surface points, the depth can underestimate the
    true overlap of curved or sharp parts by up to about the point spacing.  Bounding balls
    cull far pairs first (the depth is then ``-inf``).
    """
    rot_a = quat_to_matrix(np.asarray(orientation_a, dtype=np.float64))
    rot_b = quat_to_matrix(np.asarray(orientation_b, dtype=np.float64))
    pos_a = np.asarray(position_a, dtype=np.float64)
    pos_b = np.asarray(position_b, dtype=np.float64)
    gap = float(np.linalg.norm(pos_a - pos_b))
    if gap > shape_a.bounding_radius_m + shape_b.bounding_radius_m:
        return -math.inf, None
    depth_a, point_a = _one_way(shape_a, rot_a, pos_a, shape_b, rot_b, pos_b)
    depth_b, point_b = _one_way(shape_b, rot_b, pos_b, shape_a, rot_a, pos_a)
    if depth_b > depth_a:
        depth_a, point_a = depth_b, point_b
    for centre in (_centre_depth(shape_a, rot_a, pos_a, shape_b, rot_b, pos_b),
                   _centre_depth(shape_b, rot_b, pos_b, shape_a, rot_a, pos_a)):
        if centre[0] > depth_a:
            depth_a, point_a = centre
    return depth_a, point_a


def _centre_depth(shape_a, rot_a, pos_a, shape_b, rot_b, pos_b):
    """
    Overlap depth (m) proven by A's origin, and that point: ``min(-φ_A(o_A), -φ_B(o_A))``.

    Surface points miss coincident or nested shapes (on coincident surfaces φ reads 0): a ball
    of that radius about A's origin lies inside both shapes (less the φ error bounds).
    """
    if shape_a.kind == k.KIND_PLANE:
        return -math.inf, None
    inside_a = -float(shape_a.signed_distance(np.zeros(3))[0]) - phi_error_bound(shape_a)
    in_b = rot_b.T @ (pos_a - pos_b)
    inside_b = -float(shape_b.signed_distance(in_b)[0]) - phi_error_bound(shape_b)
    return min(inside_a, inside_b), pos_a.copy()


def check_overlaps(bodies, world=None, tolerance_m=DEFAULT_OVERLAP_TOLERANCE_M):
    """
    Refuse bodies that start inside a static object or inside each other.

    :param bodies: ``(name, shape, position_w, orientation_wb)`` per body.
    :param world: a :class:`StaticWorld`, or None.
    :param tolerance_m: overlap depth (m) accepted, e.g. bodies placed exactly in contact.
    :raises ModelError: for the first overlap deeper than ``tolerance_m``, naming
        ``bodies.<name>.position_w``, its value, the depth in m and the other object.
    """
    tolerance = _coefficient(tolerance_m, 'tolerance_m', 0.0, math.inf, 'finite and >= 0 m')
    posed = []
    for name, shape, position_w, orientation_wb in bodies:
        if not is_valid_name(name):
            raise ModelError(
                f'bodies: name {name!r} must be an identifier (letters, digits, _; not starting '
                'with a digit)')
        if not isinstance(shape, CollisionShape):
            raise ModelError(
                f'bodies.{name}.shape: a {type(shape).__name__} is not a CollisionShape')
        position, quat = _pose(position_w, orientation_wb, f'bodies.{name}.')
        posed.append((name, shape, position, quat))
    statics = [] if world is None else world.objects()
    statics = [(label, o.shape, o.position_w, o.orientation_wb) for label, o in statics]
    centres = np.array([p for _, _, p, _ in posed]).reshape(-1, 3)
    radii = np.array([s.bounding_radius_m for _, s, _, _ in posed])
    for i, (name, shape, position, quat) in enumerate(posed):
        # Bounding balls cull far bodies first, all at once (a 10 000-body world has 5e7
        # pairs): only bodies whose balls meet (with a relative slack of 1e-12 for the
        # round-off of the two norms) go on to penetration_depth, which checks them exactly.
        gap = np.linalg.norm(centres[i + 1:] - centres[i], axis=1)
        near = i + 1 + np.flatnonzero(gap <= (radii[i] + radii[i + 1:]) * (1.0 + 1e-12))
        others = statics + [(f'bodies.{posed[j][0]}',) + posed[j][1:] for j in near]
        for label, other, other_position, other_quat in others:
            depth, point = penetration_depth(shape, position, quat, other, other_position,
                                             other_quat)
            if depth > tolerance:
                rule = (f'puts the body {depth:.6g} m deep inside {label} (at '
                        f'{np.round(point, 6).tolist()} m; tolerance {tolerance:g} m)')
                raise ModelError(f'bodies.{name}.position_w: {position.tolist()} m {rule}',
                                 field=f'bodies.{name}.position_w', value=position.tolist(),
                                 unit='m', rule=rule)
