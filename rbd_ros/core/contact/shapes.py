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
Collision shapes as data: surface points plus a signed distance φ, in the body frame.

Following Guendelman, Bridson and Fedkiw (SIGGRAPH 2003), a body's collision geometry is a set
of surface points and a signed distance function φ (negative inside).  A
:class:`CollisionShape` packs both as plain numpy arrays for the compiled narrow phase:
``kind`` and ``params`` select a closed form (see :mod:`rbd_ros.core.contact.kernels`), and a
mesh adds its vertices, faces and an SDF grid sampled once (and cached on disk): meshes and
compounds are built in :mod:`rbd_ros.core.contact.mesh_shapes`, the primitives and planes here.

Dimensions follow :func:`rbd_ros.core.inertia.from_shape`: box ``[x, y, z]`` full edge lengths;
sphere ``[radius]``; cylinder and capsule ``[radius, length]`` along body z (capsule: the
cylindrical part); ellipsoid ``[a, b, c]`` semi-axes.  Every primitive is centred on the body
origin, which is the centre of mass for uniform density.  A mesh is moved so that its centre of
mass is the body origin (``mesh_offset_m`` records the shift).

Surface points (deterministic, no randomness): with a spacing ``s`` (``spacing_m``; by default
1/8 of the largest extent of the shape's bounding box), smooth surfaces and flat faces are
sampled about every ``s`` and sharp features more densely: every corner of a box, edges and
rims every ``s / 2``.  Per kind:

* box: the 8 corners; each edge of length ``L`` cut into ``ceil(2 L / s)`` equal parts; each
  face an interior grid of ``ceil(Lu / s) × ceil(Lv / s)`` cells (interior nodes only).
* sphere and ellipsoid: the 6 axis tips plus a Fibonacci lattice of ``max(12, ceil(A / s²))``
  points (``A`` the area; Thomsen's approximation for the ellipsoid) mapped from the unit
  sphere by ``diag(a, b, c)``.
* cylinder: both rims at ``max(8, ceil(4π r / s))`` points; side rings every ``s`` with
  ``max(8, ceil(2π r / s))`` points; each cap concentric rings every ``s`` and its centre.
* capsule: the two poles; rings every ``s`` along the cylindrical part (both ends included)
  and over the hemispheres (by polar angle), ``max(6, ceil(2π ρ / s))`` points on a ring of
  radius ``ρ``.
* Every ring's count is rounded up to a multiple of 4 and starts on the +x axis, so the
  extreme points along x and y are sampled.
* mesh: see :mod:`rbd_ros.core.contact.mesh_shapes`.
"""

from dataclasses import dataclass, fields
import math
import numbers

import numpy as np

from rbd_ros.core import jitcache
from rbd_ros.core.contact import kernels as k
from rbd_ros.core.errors import ModelError
from rbd_ros.core.inertia import from_shape, shape_dimensions, triangle_mesh

__all__ = ['CollisionShape', 'PRIMITIVES', 'plane_shape', 'primitive_shape']

#: Shape names accepted by :func:`primitive_shape` (``spherical_shell`` has a sphere's surface).
PRIMITIVES = ('box', 'sphere', 'spherical_shell', 'cylinder', 'capsule', 'ellipsoid')
_KINDS = {'box': k.KIND_BOX, 'sphere': k.KIND_SPHERE, 'spherical_shell': k.KIND_SPHERE,
          'cylinder': k.KIND_CYLINDER, 'capsule': k.KIND_CAPSULE,
          'ellipsoid': k.KIND_ELLIPSOID}
_GOLDEN_ANGLE = math.pi * (3.0 - math.sqrt(5.0))


def _empty_grid():
    return np.zeros((1, 1, 1))


def frozen_array(array, dtype=np.float64):
    """Return ``array`` as a contiguous read-only array of ``dtype`` (a shape's fields)."""
    out = np.ascontiguousarray(np.array(array, dtype=dtype))
    out.flags.writeable = False
    return out


@dataclass(frozen=True, eq=False)
class CollisionShape:
    """
    One body's collision geometry in its body frame (m), as arrays a compiled kernel can read.

    :param shape: ``'plane'``, a name of :data:`PRIMITIVES`, ``'mesh'`` or ``'compound'``
        (:func:`~rbd_ros.core.contact.mesh_shapes.compound_shape`).
    :param kind: the kernel's kind id (``kernels.KIND_*``).
    :param params: float64 (``N_SHAPE_PARAM``,) closed-form parameters (see
        :mod:`rbd_ros.core.contact.kernels`); for a mesh the grid origin and spacing.
    :param dimensions_m: the dimensions as given (``from_shape`` convention); empty for a mesh
        or a plane.
    :param spacing_m: the surface point spacing ``s`` used (m).
    :param points_b: (n, 3) surface points.
    :param bounding_radius_m: radius about the body origin of a ball holding the whole shape
        (``inf`` for a plane).
    :param aabb_min_b: low corner of the body-axes bounding box (``-inf`` for a plane).
    :param aabb_max_b: high corner.
    :param vertices_b: (nv, 3) mesh vertices (empty for other kinds).
    :param faces: (nf, 3) int64 vertex indices, counter-clockwise seen from outside.
    :param grid: float64 (nx, ny, nz) exact signed distances at the nodes
        ``params[0:3] + params[3] * (i, j, k)``; (1, 1, 1) zeros for other kinds.
    :param mesh_offset_m: the mesh's centre of mass in the coordinates of its source (scaled),
        so ``x_source = x_b + mesh_offset_m``; zeros for other kinds.

    Values are built by :func:`primitive_shape`, :func:`plane_shape` and
    :mod:`~rbd_ros.core.contact.mesh_shapes`' :func:`mesh_shape`, :func:`load_mesh` and
    :func:`compound_shape`, which validate their input; the arrays are read-only.
    """

    shape: str
    kind: int
    params: np.ndarray
    dimensions_m: np.ndarray
    spacing_m: float
    points_b: np.ndarray
    bounding_radius_m: float
    aabb_min_b: np.ndarray
    aabb_max_b: np.ndarray
    vertices_b: np.ndarray
    faces: np.ndarray
    grid: np.ndarray
    mesh_offset_m: np.ndarray

    def __eq__(self, other):
        if not isinstance(other, CollisionShape):
            return NotImplemented
        return all(np.array_equal(getattr(self, f.name), getattr(other, f.name))
                   for f in fields(self))

    __hash__ = None

    def __repr__(self):
        if self.kind == k.KIND_MESH:
            detail = (f'vertices={self.vertices_b.shape[0]}, faces={self.faces.shape[0]}, '
                      f'grid={self.grid.shape}, h={float(self.params[3]):.6g} m')
        elif self.kind == k.KIND_PLANE:
            detail = f'normal={self.params[:3].tolist()}, offset_m={float(self.params[3])!r}'
        else:
            detail = f'dimensions_m={self.dimensions_m.tolist()}'
        return f'CollisionShape({self.shape!r}, {detail}, points={self.points_b.shape[0]})'

    def signed_distance(self, points_b):
        """
        Return ``(phi, grad)``: φ (n,) in m and the unit gradient ∇φ (n, 3) at ``points_b``.

        :param points_b: (n, 3) or (3,) points in body coordinates, m.
        """
        points = np.ascontiguousarray(np.asarray(points_b, dtype=np.float64))
        single = points.ndim == 1
        points = points.reshape(-1, 3)
        phi = np.empty(points.shape[0])
        grad = np.empty((points.shape[0], 3))
        jitcache.configured()  # the kernel cache, before a first compile
        k.phi_grad_many(self.kind, self.params, self.grid, points, phi, grad)
        if single:
            return phi[0], grad[0]
        return phi, grad

    def mass_properties(self, mass_kg):
        """
        Return the uniform-density mass properties of this solid of mass ``mass_kg``.

        Primitives use :func:`rbd_ros.core.inertia.from_shape`, meshes the exact polyhedral
        integrals :func:`rbd_ros.core.inertia.triangle_mesh` (COM at the origin up to
        round-off, as the mesh was centred).
        """
        if self.shape == 'compound':
            raise ModelError('shape: a compound has no uniform-density mass properties (its '
                             'parts may overlap); give the body its mass and inertia')
        if self.kind == k.KIND_MESH:
            return triangle_mesh(self.vertices_b, self.faces, mass_kg=mass_kg)
        if self.kind == k.KIND_PLANE:
            raise ModelError('shape: a plane is static; it has no mass properties')
        return from_shape(self.shape, self.dimensions_m, mass_kg)


def shape_params(*values):
    """Return the (``N_SHAPE_PARAM``,) kernel parameters of a shape: ``values``, then zeros."""
    out = np.zeros(k.N_SHAPE_PARAM)
    out[:len(values)] = values
    return out


def point_spacing(spacing_m, extent, field):
    """Return the surface point spacing: ``spacing_m`` checked, or ``extent / 8``."""
    if spacing_m is None:
        return extent / 8.0
    if isinstance(spacing_m, bool) or not isinstance(spacing_m, (numbers.Real, np.number)):
        raise ModelError(f'{field}spacing_m: {spacing_m!r} is not a length in m')
    value = float(spacing_m)
    if not (math.isfinite(value) and value > 0.0):
        raise ModelError(f'{field}spacing_m: {value!r} m must be finite and > 0')
    if value < extent * 1e-3:
        raise ModelError(
            f'{field}spacing_m: {value!r} m is below 1e-3 of the extent {extent!r} m '
            '(over ~1e6 surface points)')
    return value


def _ring(radius, z, count):
    """``count`` rounded up to a multiple of 4 points on a circle, starting on the x axis."""
    count = 4 * math.ceil(count / 4)
    angle = 2.0 * math.pi * np.arange(count) / count
    return np.column_stack([radius * np.cos(angle), radius * np.sin(angle),
                            np.full(count, float(z))])


def _fibonacci(count):
    """``count`` points on the unit sphere, a Fibonacci lattice (deterministic)."""
    i = np.arange(count, dtype=np.float64)
    z = 1.0 - (2.0 * i + 1.0) / count
    rho = np.sqrt(np.maximum(1.0 - z * z, 0.0))
    angle = i * _GOLDEN_ANGLE
    return np.column_stack([rho * np.cos(angle), rho * np.sin(angle), z])


def _box_points(half, s):
    pts = [np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                    dtype=np.float64) * half]
    for axis in range(3):
        a, b = [m for m in range(3) if m != axis]
        parts = math.ceil(4.0 * half[axis] / s)
        t = -half[axis] + 2.0 * half[axis] * np.arange(1, parts) / parts
        for sa in (-1.0, 1.0):
            for sb in (-1.0, 1.0):
                edge = np.zeros((t.size, 3))
                edge[:, axis] = t
                edge[:, a] = sa * half[a]
                edge[:, b] = sb * half[b]
                pts.append(edge)
        nu = math.ceil(2.0 * half[a] / s)
        nv = math.ceil(2.0 * half[b] / s)
        u = -half[a] + 2.0 * half[a] * np.arange(1, nu) / nu
        v = -half[b] + 2.0 * half[b] * np.arange(1, nv) / nv
        uu, vv = np.meshgrid(u, v, indexing='ij')
        for sign in (-1.0, 1.0):
            face = np.zeros((uu.size, 3))
            face[:, a] = uu.ravel()
            face[:, b] = vv.ravel()
            face[:, axis] = sign * half[axis]
            pts.append(face)
    return np.concatenate(pts)


def _cylinder_points(r, hl, s):
    rim = max(8, math.ceil(4.0 * math.pi * r / s))
    side = max(8, math.ceil(2.0 * math.pi * r / s))
    pts = [_ring(r, -hl, rim), _ring(r, hl, rim)]
    parts = math.ceil(2.0 * hl / s)
    for z in -hl + 2.0 * hl * np.arange(1, parts) / parts:
        pts.append(_ring(r, z, side))
    rings = math.ceil(r / s)
    for z in (-hl, hl):
        pts.append(np.array([[0.0, 0.0, z]]))
        for rho in r * np.arange(1, rings) / rings:
            pts.append(_ring(rho, z, max(6, math.ceil(2.0 * math.pi * rho / s))))
    return np.concatenate(pts)


def _capsule_points(r, hl, s):
    side = max(6, math.ceil(2.0 * math.pi * r / s))
    parts = math.ceil(2.0 * hl / s)
    pts = [_ring(r, z, side) for z in -hl + 2.0 * hl * np.arange(parts + 1) / parts]
    polar = max(2, math.ceil(0.5 * math.pi * r / s))
    for sign in (-1.0, 1.0):
        pts.append(np.array([[0.0, 0.0, sign * (hl + r)]]))
        for theta in 0.5 * math.pi * np.arange(1, polar) / polar:
            rho = r * math.sin(theta)
            pts.append(_ring(rho, sign * (hl + r * math.cos(theta)),
                             max(6, math.ceil(2.0 * math.pi * rho / s))))
    return np.concatenate(pts)


def _ellipsoid_points(axes, s):
    a, b, c = axes
    p = 1.6075  # Knud Thomsen's approximation of the area, within 1.061 %
    area = 4.0 * math.pi * (((a * b) ** p + (a * c) ** p + (b * c) ** p) / 3.0) ** (1.0 / p)
    count = max(12, math.ceil(area / (s * s)))
    tips = np.vstack([np.diag(axes), -np.diag(axes)])
    return np.concatenate([tips, _fibonacci(count) * axes])


def primitive_shape(shape, dimensions_m, spacing_m=None, field=''):
    """
    Return the :class:`CollisionShape` of a primitive centred at the body origin.

    :param shape: one of :data:`PRIMITIVES`.
    :param dimensions_m: as :func:`rbd_ros.core.inertia.from_shape`.
    :param spacing_m: surface point spacing (m), or None for 1/8 of the largest extent.
    :param field: prefix of the field names in error messages, e.g. ``'obstacles.ramp.'``.
    :raises ModelError: naming ``<field>shape``, ``<field>dimensions_m`` or
        ``<field>spacing_m``, the value, the unit and the rule.
    """
    if shape not in _KINDS:
        raise ModelError(
            f'{field}shape: {shape!r} is not one of {", ".join(PRIMITIVES + ("mesh",))}')
    dims = shape_dimensions(shape, dimensions_m, field)
    kind = _KINDS[shape]
    if kind == k.KIND_BOX:
        half = 0.5 * dims
        params = shape_params(*half)
        high = half
        radius = float(np.linalg.norm(half))
    elif kind == k.KIND_SPHERE:
        params = shape_params(dims[0])
        high = np.full(3, dims[0])
        radius = float(dims[0])
    elif kind in (k.KIND_CYLINDER, k.KIND_CAPSULE):
        r, hl = float(dims[0]), 0.5 * float(dims[1])
        params = shape_params(r, hl)
        if kind == k.KIND_CYLINDER:
            high = np.array([r, r, hl])
            radius = math.hypot(r, hl)
        else:
            high = np.array([r, r, hl + r])
            radius = hl + r
    else:
        params = shape_params(*dims)
        high = dims.copy()
        radius = float(dims.max())
    s = point_spacing(spacing_m, 2.0 * float(high.max()), field)
    if kind == k.KIND_BOX:
        points = _box_points(high, s)
    elif kind == k.KIND_SPHERE:
        points = _ellipsoid_points(np.full(3, dims[0]), s)
    elif kind == k.KIND_CYLINDER:
        points = _cylinder_points(params[0], params[1], s)
    elif kind == k.KIND_CAPSULE:
        points = _capsule_points(params[0], params[1], s)
    else:
        points = _ellipsoid_points(dims, s)
    return CollisionShape(
        shape=shape, kind=kind, params=frozen_array(params), dimensions_m=frozen_array(dims),
        spacing_m=s, points_b=frozen_array(points), bounding_radius_m=radius,
        aabb_min_b=frozen_array(-high), aabb_max_b=frozen_array(high),
        vertices_b=frozen_array(np.zeros((0, 3))), faces=frozen_array(np.zeros((0, 3)), np.int64),
        grid=frozen_array(_empty_grid()), mesh_offset_m=frozen_array(np.zeros(3)))


def plane_shape(normal, offset_m, field=''):
    """
    Return the half-space ``n·x <= offset_m`` as a :class:`CollisionShape` (φ = n·x − d).

    :param normal: 3 finite numbers, not all zero; normalised to a unit vector (the outward
        normal, pointing out of the solid half-space).
    :param offset_m: signed distance of the plane from the origin along ``n``, m.
    :raises ModelError: naming ``<field>normal`` or ``<field>offset_m``.
    """
    try:
        n = np.array(normal, dtype=np.float64).reshape(3)
    except (TypeError, ValueError):
        raise ModelError(f'{field}normal: {normal!r} is not 3 numbers (a direction)') from None
    norm = float(np.linalg.norm(n))
    if not (np.all(np.isfinite(n)) and norm > 0.0):
        raise ModelError(
            f'{field}normal: {n.tolist()} must be finite and non-zero (a direction)')
    if (isinstance(offset_m, bool) or not isinstance(offset_m, (numbers.Real, np.number))
            or not math.isfinite(float(offset_m))):
        raise ModelError(f'{field}offset_m: {offset_m!r} m must be a finite number')
    n = n / norm
    inf = np.full(3, np.inf)
    return CollisionShape(
        shape='plane', kind=k.KIND_PLANE, params=frozen_array(shape_params(*n, float(offset_m))),
        dimensions_m=frozen_array(np.zeros(0)), spacing_m=math.inf,
        points_b=frozen_array(np.zeros((0, 3))), bounding_radius_m=math.inf,
        aabb_min_b=frozen_array(-inf), aabb_max_b=frozen_array(inf),
        vertices_b=frozen_array(np.zeros((0, 3))), faces=frozen_array(np.zeros((0, 3)), np.int64),
        grid=frozen_array(_empty_grid()), mesh_offset_m=frozen_array(np.zeros(3)))
