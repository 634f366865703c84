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
from typing import NamedTuple

import numpy as np

from rbd_ros.core import jitcache
from rbd_ros.core.contact import kernels as k
from rbd_ros.core.contact.mesh_shapes import collision_shape
from rbd_ros.core.contact.rows import pair_material
from rbd_ros.core.contact.shapes import CollisionShape, plane_shape
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


class _Posed(NamedTuple):
    """A shape at a pose: ``x_w = rot_wb x_b + position_w``."""

    shape: CollisionShape
    rot_wb: np.ndarray
    position_w: np.ndarray


def _posed(shape, position_w, orientation_wb):
    rot = quat_to_matrix(np.asarray(orientation_wb, dtype=np.float64))
    return _Posed(shape, rot, np.asarray(position_w, dtype=np.float64).reshape(3))


def _phi_w(posed, points_w):
    """Return φ (n,) and ∇φ (n, 3), world axes, of a posed shape at world points (n, 3)."""
    points_b = (np.asarray(points_w) - posed.position_w) @ posed.rot_wb
    phi, grad_b = posed.shape.signed_distance(points_b)
    return phi, grad_b @ posed.rot_wb.T


def _support_b(shape, u_b):
    """
    Return ``(h, point_b)``: the support ``h(u) = max_{x in S} u·x`` and a point attaining it.

    Closed forms per primitive (``u`` a unit vector in body axes); a mesh's maximum is at a
    vertex.
    """
    p = shape.params
    if shape.kind == k.KIND_SPHERE:
        return float(p[0]), p[0] * u_b
    if shape.kind == k.KIND_BOX:
        point = np.where(u_b < 0.0, -1.0, 1.0) * p[:3]
        return float(u_b @ point), point
    if shape.kind in (k.KIND_CYLINDER, k.KIND_CAPSULE):
        r, hl = float(p[0]), float(p[1])
        rho = math.hypot(u_b[0], u_b[1])
        z = math.copysign(hl, u_b[2])
        if shape.kind == k.KIND_CYLINDER:
            rim = (r * u_b[:2] / rho) if rho > 0.0 else np.zeros(2)
            point = np.array([rim[0], rim[1], z])
        else:
            point = np.array([0.0, 0.0, z]) + r * u_b
        return float(u_b @ point), point
    if shape.kind == k.KIND_ELLIPSOID:
        scaled = p[:3] * u_b
        h = float(np.linalg.norm(scaled))
        return h, p[:3] * scaled / h
    index = int(np.argmax(shape.vertices_b @ u_b))
    return float(shape.vertices_b[index] @ u_b), shape.vertices_b[index]


def _plane_depth(plane, other):
    """
    Depth of a shape below a plane, exact: ``d − n·c + h(−Rᵀ n)`` (the support function).

    The plane's solid side is ``n·x <= d``; the deepest point of the other shape is where its
    support in the direction ``−n`` is attained.
    """
    n_w = plane.shape.params[:3]
    offset = float(plane.shape.params[3])
    h, point_b = _support_b(other.shape, -(other.rot_wb.T @ n_w))
    depth = offset - float(n_w @ other.position_w) + h
    return depth, other.rot_wb @ point_b + other.position_w


def _core_segment(posed):
    """Return ``(p0_w, p1_w, radius)``: a sphere's or capsule's core segment and radius."""
    r, hl = float(posed.shape.params[0]), 0.0
    if posed.shape.kind == k.KIND_CAPSULE:
        hl = float(posed.shape.params[1])
    axis = posed.rot_wb[:, 2] * hl
    return posed.position_w - axis, posed.position_w + axis, r


def _closest_on_segments(p1, q1, p2, q2):
    """
    Return the closest points of segments ``p1 q1`` and ``p2 q2``, points included.

    Ericson, Real-Time Collision Detection (2005), 5.1.9.
    """
    d1, d2, r = q1 - p1, q2 - p2, p1 - p2
    a, e, f = float(d1 @ d1), float(d2 @ d2), float(d2 @ r)
    tiny = 1e-300
    if a <= tiny and e <= tiny:
        return p1, p2
    if a <= tiny:
        s, t = 0.0, min(max(f / e, 0.0), 1.0)
    else:
        c = float(d1 @ r)
        if e <= tiny:
            s, t = min(max(-c / a, 0.0), 1.0), 0.0
        else:
            b = float(d1 @ d2)
            denom = a * e - b * b
            s = min(max((b * f - c * e) / denom, 0.0), 1.0) if denom > 0.0 else 0.0
            t = (b * s + f) / e
            if t < 0.0:
                s, t = min(max(-c / a, 0.0), 1.0), 0.0
            elif t > 1.0:
                s, t = min(max((b - c) / a, 0.0), 1.0), 1.0
    return p1 + s * d1, p2 + t * d2


def _rounded_pair_depth(a, b):
    """Depth of two spheres/capsules, exact: ``r_a + r_b − |closest points of the cores|``."""
    pa, qa, ra = _core_segment(a)
    pb, qb, rb = _core_segment(b)
    ca, cb = _closest_on_segments(pa, qa, pb, qb)
    gap = float(np.linalg.norm(cb - ca))
    direction = (cb - ca) / gap if gap > 0.0 else np.zeros(3)
    # The middle of the overlap along the line of the closest points.
    return ra + rb - gap, ca + direction * 0.5 * (ra + gap - rb)


def _rounded_depth(rounded, other):
    """
    Depth of a sphere or capsule (core segment S, radius r) in another shape X, a lower bound.

    ``r − min_{p in S} φ_X(p)``: the ball of radius r about any core point lies in the
    capsule, and φ_X is 1-Lipschitz, so moving it out of X takes at least ``r − φ_X(p)``.  It
    is the exact penetration depth for a sphere in a convex X and whenever S is outside X.
    φ_X is convex for convex X, so a golden-section search along S finds its minimum; a mesh
    is sampled first (33 points) and refined about the best.
    """
    p0, p1, r = _core_segment(rounded)
    err = phi_error_bound(other.shape)

    def phi(t):
        return float(_phi_w(other, (p0 + t * (p1 - p0))[None, :])[0][0])

    if not np.any(p1 != p0):
        return r - phi(0.0) - err, p0.copy()
    ts = np.linspace(0.0, 1.0, 33)
    values = _phi_w(other, p0 + ts[:, None] * (p1 - p0))[0]
    i = int(np.argmin(values))
    lo, hi = ts[max(i - 1, 0)], ts[min(i + 1, 32)]
    ratio = 0.5 * (math.sqrt(5.0) - 1.0)
    x1, x2 = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
    f1, f2 = phi(x1), phi(x2)
    for _ in range(60):  # the bracket shrinks by 0.618 a round: 1e-13 of the segment
        if f1 <= f2:
            hi, x2, f2 = x2, x1, f1
            x1 = hi - ratio * (hi - lo)
            f1 = phi(x1)
        else:
            lo, x1, f1 = x1, x2, f2
            x2 = lo + ratio * (hi - lo)
            f2 = phi(x2)
    best_t, best = min(((ts[i], float(values[i])), (x1, f1), (x2, f2)), key=lambda v: v[1])
    return r - best - err, p0 + best_t * (p1 - p0)


def _box_sat(a, b):
    """
    Penetration depth of two boxes by the separating-axis test, exact.

    Along a unit axis L the boxes' projections overlap by ``Σ h_a|L·a_i| + Σ h_b|L·b_i| −
    |L·(c_b − c_a)|``; moving one box by that much along L separates them, and the least
    translation that separates two boxes is along one of the 15 axes (3 + 3 face normals,
    9 edge cross products; Gottschalk, Lin and Manocha 1996), so the depth is the least
    overlap (negative: separated).  Cross products of parallel edges are skipped (their
    directions are covered by the face normals).
    """
    axes_a, axes_b = a.rot_wb.T, b.rot_wb.T  # rows: each box's axes in world coordinates
    cross = np.cross(axes_a[:, None, :], axes_b[None, :, :]).reshape(9, 3)
    norms = np.linalg.norm(cross, axis=1)
    keep = norms > 1e-9
    axes = np.vstack([axes_a, axes_b, cross[keep] / norms[keep, None]])
    half_a, half_b = a.shape.params[:3], b.shape.params[:3]
    delta = b.position_w - a.position_w
    overlap = (np.abs(axes @ axes_a.T) @ half_a + np.abs(axes @ axes_b.T) @ half_b
               - np.abs(axes @ delta))
    i = int(np.argmin(overlap))
    axis = axes[i] if axes[i] @ delta >= 0.0 else -axes[i]
    reach = float(np.abs(axes_a @ axis) @ half_a)  # box a's extent along the axis
    return float(overlap[i]), a.position_w + axis * (reach - 0.5 * float(overlap[i]))


# Directions of the pattern search in _deepest_point: the 26 neighbours of a cube's centre.
_PATTERN = np.array([(x, y, z) for x in (-1, 0, 1) for y in (-1, 0, 1) for z in (-1, 0, 1)
                     if (x, y, z) != (0, 0, 0)], dtype=np.float64)
_PATTERN /= np.linalg.norm(_PATTERN, axis=1)[:, None]


def _deepest_point(a, b):
    """
    Depth of two shapes as ``max_p −(φ_a(p) + φ_b(p))`` less the φ error bounds: a lower bound.

    The ball of radius ``−φ_a(p)`` about p lies in a, and φ_b is 1-Lipschitz, so separating
    it from b takes a translation of at least ``−φ_a(p) − φ_b(p)``: for every p this is at
    most the penetration depth, and when the shapes are apart (or touch) it is at most minus
    their distance, so bodies placed exactly in contact are never refused.  For convex shapes
    ``φ_a + φ_b`` is convex; its minimum is sought from the best of both shapes' surface
    points, their origins and the midpoint of the origins, by a pattern search (26 directions
    and the descent direction, the step halved down to 1e-9 of the smaller bounding radius).
    """
    points = np.vstack([a.shape.points_b @ a.rot_wb.T + a.position_w,
                        b.shape.points_b @ b.rot_wb.T + b.position_w,
                        a.position_w, b.position_w, 0.5 * (a.position_w + b.position_w)])

    def f(pts):
        phi_a, grad_a = _phi_w(a, pts)
        phi_b, grad_b = _phi_w(b, pts)
        return phi_a + phi_b, grad_a + grad_b

    values, grads = f(points)
    i = int(np.argmin(values))
    point, best, grad = points[i], float(values[i]), grads[i]
    scale = min(a.shape.bounding_radius_m, b.shape.bounding_radius_m)
    step = 0.25 * scale
    for _ in range(400):
        if step < 1e-9 * scale:
            break
        length = float(np.linalg.norm(grad))
        dirs = _PATTERN if length == 0.0 else np.vstack([_PATTERN, -grad / length])
        trial = point + step * dirs
        values, grads = f(trial)
        j = int(np.argmin(values))
        if values[j] < best:
            point, best, grad = trial[j], float(values[j]), grads[j]
        else:
            step *= 0.5
    return -best - phi_error_bound(a.shape) - phi_error_bound(b.shape), point


_ROUNDED = (k.KIND_SPHERE, k.KIND_CAPSULE)


def _pair_depth(a, b):
    """Return ``(depth_m, point_w)`` of two posed shapes (see :func:`penetration_depth`)."""
    gap = float(np.linalg.norm(a.position_w - b.position_w))
    if gap > (a.shape.bounding_radius_m + b.shape.bounding_radius_m) * (1.0 + 1e-12):
        return -math.inf, None
    kind_a, kind_b = a.shape.kind, b.shape.kind
    if kind_a == k.KIND_PLANE:
        return _plane_depth(a, b)
    if kind_b == k.KIND_PLANE:
        return _plane_depth(b, a)
    if kind_a in _ROUNDED and kind_b in _ROUNDED:
        return _rounded_pair_depth(a, b)
    if kind_a == k.KIND_BOX and kind_b == k.KIND_BOX:
        return _box_sat(a, b)
    if kind_a in _ROUNDED:
        return _rounded_depth(a, b)
    if kind_b in _ROUNDED:
        return _rounded_depth(b, a)
    return _deepest_point(a, b)


def penetration_depth(shape_a, position_a, orientation_a, shape_b, position_b, orientation_b):
    """
    Return ``(depth_m, point_w)``: how deep the two posed shapes overlap, and where.

    The depth is the penetration depth (the shortest translation that separates them), exact
    for a shape against a plane (its support function), two boxes (separating axes), two
    spheres or capsules (the distance of their core segments) and a sphere in a convex shape
    (``r − φ``); for the other pairs (cylinders, ellipsoids, meshes, a capsule in a shape)
    it is a lower bound, the depth of the deepest ball inside both (see
    :func:`_deepest_point`), exact when they are apart or touch and for coincident or
    crossing shapes.  A mesh's φ error bound (:func:`phi_error_bound`) is taken off, so a mesh
    resting on a surface is not reported as overlapping because of its grid.  ``depth <= 0``
    means no overlap; bounding balls cull far pairs first (the depth is then ``-inf``).  No
    pair placed exactly in contact gets a depth above round-off.
    """
    return _pair_depth(_posed(shape_a, position_a, orientation_a),
                       _posed(shape_b, position_b, orientation_b))


def _near_pairs(centres, radii):
    """
    Return, per body ``i``, the sorted bodies ``j > i`` whose bounding balls meet body i's.

    Sort and sweep along the axis of the largest spread of the centres (``O(n log n)`` plus
    the overlapping intervals), then the balls' test on the candidates; a relative slack of
    1e-12 allows for the round-off of the two norms.
    """
    n = len(radii)
    near = [[] for _ in range(n)]
    if n < 2:
        return near
    axis = int(np.argmax(np.ptp(centres, axis=0)))
    slack = 1e-9 * (radii + np.abs(centres[:, axis]))
    lo = centres[:, axis] - radii - slack
    hi = centres[:, axis] + radii + slack
    order = np.argsort(lo, kind='stable')
    ends = np.searchsorted(lo[order], hi[order], side='right')
    for rank in range(n):
        i = order[rank]
        others = order[rank + 1:ends[rank]]
        if others.size == 0:
            continue
        gap = np.linalg.norm(centres[others] - centres[i], axis=1)
        for j in others[gap <= (radii[i] + radii[others]) * (1.0 + 1e-12)]:
            near[min(i, j)].append(max(i, j))
    return [sorted(js) for js in near]


def check_overlaps(bodies, world=None, tolerance_m=DEFAULT_OVERLAP_TOLERANCE_M, skip=()):
    """
    Refuse bodies that start inside a static object or inside each other.

    Each pair's depth is :func:`penetration_depth`'s; far pairs are culled by a sort and
    sweep of the bounding balls (near-linear in the number of bodies when they are spread
    out).  The first overlap in body order is named: the body, then the static objects, then
    the later bodies.

    :param bodies: ``(name, shape, position_w, orientation_wb)`` per body.
    :param world: a :class:`StaticWorld`, or None.
    :param tolerance_m: overlap depth (m) accepted, e.g. bodies placed exactly in contact.
    :param skip: body index pairs ``(i, j)`` that never collide (not checked), and pairs
        ``(i, label)`` of a body and a static object (its :meth:`StaticWorld.objects` label).
    :raises ModelError: for the first overlap deeper than ``tolerance_m``, naming
        ``bodies.<name>.position_w``, its value, the depth in m and the other object.
    """
    tolerance = _coefficient(tolerance_m, 'tolerance_m', 0.0, math.inf, 'finite and >= 0 m')
    names, posed = [], []
    for name, shape, position_w, orientation_wb in bodies:
        if not is_valid_name(name):
            raise ModelError(
                f'bodies: name {name!r} must be an identifier (letters, digits, _; not starting '
                'with a digit)')
        if not isinstance(shape, CollisionShape):
            raise ModelError(
                f'bodies.{name}.shape: a {type(shape).__name__} is not a CollisionShape')
        position, quat = _pose(position_w, orientation_wb, f'bodies.{name}.')
        names.append(name)
        posed.append(_Posed(shape, quat_to_matrix(quat), position))
    statics = [] if world is None else world.objects()
    statics = [(label, _posed(o.shape, o.position_w, o.orientation_wb)) for label, o in statics]
    centres = np.array([p.position_w for p in posed]).reshape(-1, 3)
    radii = np.array([p.shape.bounding_radius_m for p in posed])
    near = _near_pairs(centres, radii)
    for i, body in enumerate(posed):
        others = [(label, o) for label, o in statics if (i, label) not in skip]
        others += [(f'bodies.{names[j]}', posed[j]) for j in near[i] if (i, j) not in skip]
        for label, other in others:
            depth, point = _pair_depth(body, other)
            if depth > tolerance:
                rule = (f'puts the body {depth:.6g} m deep inside {label} (at '
                        f'{np.round(point, 6).tolist()} m; tolerance {tolerance:g} m)')
                position = body.position_w
                raise ModelError(f'bodies.{names[i]}.position_w: {position.tolist()} m {rule}',
                                 field=f'bodies.{names[i]}.position_w',
                                 value=position.tolist(), unit='m', rule=rule)
