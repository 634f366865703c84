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
Mass properties from data: point masses, a bounding box, a sampled inside test, a closed mesh.

:func:`point_masses` sums them exactly; :func:`bounding_box` is the solid box around points;
:func:`point_sampling` estimates a solid's from a seeded Monte-Carlo sampling of its inside
test; :func:`triangle_mesh` integrates a closed, consistently oriented triangle mesh exactly
(Eberly's polyhedral mass properties, see :mod:`rbd_ros.core.inertia`).
"""

import numbers

import numpy as np

from rbd_ros.core.errors import ModelError, positive
from rbd_ros.core.inertia.shapes import box
from rbd_ros.core.inertia.tensor import _fmt, _validate_vector, MassProperties, validate_mass


def point_masses(masses_kg, points_b) -> 'MassProperties':
    """
    Return the mass properties of point masses ``masses_kg`` (kg, (n,)) at ``points_b`` (m).

    ``M = sum m_i``, ``com = sum m_i p_i / M`` and, with ``r_i = p_i - com``,
    ``I = sum m_i (r_i^T r_i 1 - r_i r_i^T)`` (the lecture's definition).

    :raises ModelError: on negative or non-finite masses, a total mass <= 0, or points that do
        not span 3-D (the inertia would not be positive definite).
    """
    masses = np.asarray(masses_kg, dtype=np.float64).reshape(-1)
    points = np.asarray(points_b, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] != masses.size:
        raise ModelError(
            f'points_b: shape {points.shape} must be ({masses.size}, 3) to match masses_kg')
    if not (np.all(np.isfinite(masses)) and np.all(masses >= 0.0)):
        raise ModelError('masses_kg: every point mass must be finite and >= 0 kg')
    if not np.all(np.isfinite(points)):
        raise ModelError('points_b: every point must be finite (m)')
    total = validate_mass(float(masses.sum()), 'masses_kg (total)')
    com = masses @ points / total
    r = points - com
    inertia = (np.eye(3) * np.einsum('n,ni,ni->', masses, r, r)
               - np.einsum('n,ni,nj->ij', masses, r, r))
    return MassProperties(total, com, inertia)


def bounding_box(points_b, mass_kg) -> 'MassProperties':
    """
    Return the lecture's bounding-box approximation of a body sampled by ``points_b`` (m).

    The body is replaced by a uniform solid box: the axis-aligned (body-axes) bounding box of
    the points, of mass ``mass_kg``, with its COM at the box centre (see :func:`box`).

    :raises ModelError: if the points are flat along a body axis (the box has no volume).
    """
    points = np.asarray(points_b, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] == 0:
        raise ModelError(f'points_b: shape {points.shape} must be (n, 3) with n >= 1')
    if not np.all(np.isfinite(points)):
        raise ModelError('points_b: every point must be finite (m)')
    low, high = points.min(axis=0), points.max(axis=0)
    size = high - low
    if np.any(size <= 0.0):
        raise ModelError(
            f'points_b: bounding box size {_fmt(size)} m must be > 0 along every axis')
    shape = box(mass_kg, size)
    return MassProperties(shape.mass_kg, 0.5 * (low + high), shape.inertia_b)


def point_sampling(inside, bounds_min, bounds_max, mass_kg, n, rng=None) -> 'MassProperties':
    """
    Return the lecture's point-sampling approximation of a uniform solid.

    ``n`` points are drawn uniformly in the box ``[bounds_min, bounds_max]`` (m, body
    coordinates); those with ``inside(points)`` true each carry ``mass_kg / k`` (``k`` kept
    points), and :func:`point_masses` gives the COM and inertia.  The error of the moments is
    statistical, ``O(1 / sqrt(k))``.

    :param inside: callable mapping points ``(k, 3)`` to a boolean array ``(k,)``.
    :param n: number of candidate samples.
    :param rng: a ``numpy.random.Generator`` or a seed; ``None`` means seed 0, so a model built
        from the same parameters is the same on every run.
    :raises ModelError: if fewer than 4 points fall inside.
    """
    low = _validate_vector(bounds_min, 'bounds_min', 'm')
    high = _validate_vector(bounds_max, 'bounds_max', 'm')
    if np.any(high <= low):
        raise ModelError(
            f'bounds_max: {_fmt(high)} m must exceed bounds_min {_fmt(low)} m on every axis')
    mass = validate_mass(mass_kg)
    if isinstance(n, bool) or not isinstance(n, (numbers.Integral, np.integer)) or n < 4:
        raise ModelError(f'n: {n!r} samples must be an integer >= 4')
    generator = np.random.default_rng(0 if rng is None else rng)
    points = generator.uniform(low, high, size=(int(n), 3))
    keep = np.asarray(inside(points), dtype=bool).reshape(-1)
    if keep.shape != (int(n),):
        raise ModelError(f'inside: returned shape {keep.shape}, expected ({int(n)},)')
    kept = points[keep]
    if kept.shape[0] < 4:
        raise ModelError(
            f'inside: only {kept.shape[0]} of n = {int(n)} samples fell inside the bounds '
            f'{_fmt(low)} .. {_fmt(high)} m; need at least 4')
    return point_masses(np.full(kept.shape[0], mass / kept.shape[0]), kept)


def _closed_edge_check(faces, n_vertices):
    """Raise ModelError unless every directed edge appears once and its reverse once."""
    edges = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64)
    keys = edges[:, 0] * n_vertices + edges[:, 1]
    reverse = edges[:, 1] * n_vertices + edges[:, 0]
    unique, counts = np.unique(keys, return_counts=True)
    if np.any(counts > 1):
        a, b = divmod(int(unique[np.argmax(counts > 1)]), n_vertices)
        raise ModelError(
            f'faces: directed edge ({a}, {b}) is used by {int(counts.max())} faces; a closed, '
            'consistently oriented mesh uses each directed edge once')
    missing = ~np.isin(reverse, keys)
    if np.any(missing):
        a, b = (int(v) for v in edges[np.argmax(missing)])
        raise ModelError(
            f'faces: edge ({a}, {b}) has no opposite edge ({b}, {a}); the mesh is open or '
            'inconsistently oriented')


def _subexpressions(w0, w1, w2):
    """Eberly's per-triangle polynomial subexpressions in one coordinate (vectorised)."""
    temp0 = w0 + w1
    f1 = temp0 + w2
    temp1 = w0 * w0
    temp2 = temp1 + w1 * temp0
    f2 = temp2 + w2 * f1
    f3 = w0 * temp1 + w1 * temp2 + w2 * f2
    g0 = f2 + w0 * (f1 + w0)
    g1 = f2 + w1 * (f1 + w1)
    g2 = f2 + w2 * (f1 + w2)
    return f1, f2, f3, g0, g1, g2


def triangle_mesh(vertices, faces, mass_kg=None, density=None) -> 'MassProperties':
    """
    Return the exact mass properties of a closed triangle mesh of uniform density.

    The volume integrals of 1, x, y, z, x^2, y^2, z^2, xy, yz, zx are turned into surface
    integrals by the divergence theorem and evaluated exactly per triangle, following
    D. Eberly, "Polyhedral Mass Properties (Revisited)", Geometric Tools (2002), itself a
    simplification of B. Mirtich, "Fast and Accurate Computation of Polyhedral Mass
    Properties", J. Graphics Tools 1(2):31-50 (1996).  The sums are vectorised over faces.
    The vertices are first shifted by their mean, which keeps the COM parallel-axis
    subtraction well conditioned for meshes far from the origin.

    :param vertices: (n, 3) m, body coordinates.
    :param faces: (m, 3) vertex indices, counter-clockwise seen from outside (outward normals
        by the right-hand rule).
    :param mass_kg: total mass in kg; give exactly one of ``mass_kg`` and ``density``.
    :param density: kg/m³.
    :raises ModelError: if both or neither of mass and density are given, on bad arrays or
        indices, if an edge lacks its opposite (open or inconsistently oriented mesh), or if
        the enclosed volume is not > 0 (inverted mesh).
    """
    if (mass_kg is None) == (density is None):
        raise ModelError(
            f'mass_kg: give exactly one of mass_kg (kg) and density (kg/m³); got '
            f'mass_kg={mass_kg!r}, density={density!r}')
    verts = np.asarray(vertices, dtype=np.float64)
    if verts.ndim != 2 or verts.shape[1] != 3 or not np.all(np.isfinite(verts)):
        raise ModelError(f'vertices: shape {verts.shape} must be (n, 3) of finite m')
    tris = np.asarray(faces)
    if (tris.ndim != 2 or tris.shape[1] != 3 or tris.shape[0] < 4
            or not np.issubdtype(tris.dtype, np.integer)):
        raise ModelError(
            f'faces: shape {tris.shape}, dtype {tris.dtype} must be (m >= 4, 3) integers')
    if tris.min() < 0 or tris.max() >= verts.shape[0]:
        raise ModelError(
            f'faces: indices must be in [0, {verts.shape[0] - 1}], got [{tris.min()}, '
            f'{tris.max()}]')
    _closed_edge_check(tris, verts.shape[0])
    origin = verts.mean(axis=0)
    p = verts - origin
    p0, p1, p2 = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
    d = np.cross(p1 - p0, p2 - p0)       # twice the area times the outward unit normal
    fx, fy, fz = (_subexpressions(p0[:, k], p1[:, k], p2[:, k]) for k in range(3))
    x0, y0, z0 = p0.T
    x1, y1, z1 = p1.T
    x2, y2, z2 = p2.T
    integral = np.array([
        np.sum(d[:, 0] * fx[0]),
        np.sum(d[:, 0] * fx[1]), np.sum(d[:, 1] * fy[1]), np.sum(d[:, 2] * fz[1]),
        np.sum(d[:, 0] * fx[2]), np.sum(d[:, 1] * fy[2]), np.sum(d[:, 2] * fz[2]),
        np.sum(d[:, 0] * (y0 * fx[3] + y1 * fx[4] + y2 * fx[5])),
        np.sum(d[:, 1] * (z0 * fy[3] + z1 * fy[4] + z2 * fy[5])),
        np.sum(d[:, 2] * (x0 * fz[3] + x1 * fz[4] + x2 * fz[5])),
    ]) * np.array([1 / 6, 1 / 24, 1 / 24, 1 / 24, 1 / 60, 1 / 60, 1 / 60,
                   1 / 120, 1 / 120, 1 / 120])
    volume = integral[0]
    scale = np.abs(p).max() ** 3
    if not volume > 1e-12 * scale:
        raise ModelError(
            f'faces: the mesh encloses volume {volume:.6g} m³; it must be > 0 (faces must be '
            'counter-clockwise seen from outside, i.e. normals pointing out)')
    com = integral[1:4] / volume
    # Second moments about the COM, per unit density: int x^2 dV - V cx^2, etc.
    xx = integral[4] - volume * com[0] ** 2
    yy = integral[5] - volume * com[1] ** 2
    zz = integral[6] - volume * com[2] ** 2
    xy = integral[7] - volume * com[0] * com[1]
    yz = integral[8] - volume * com[1] * com[2]
    zx = integral[9] - volume * com[2] * com[0]
    inertia_unit = np.array([[yy + zz, -xy, -zx], [-xy, xx + zz, -yz], [-zx, -yz, xx + yy]])
    if mass_kg is not None:
        mass = validate_mass(mass_kg)
        rho = mass / volume
    else:
        rho = positive(density, 'density', 'kg/m³', ModelError)
        mass = rho * volume
    return MassProperties(mass, com + origin, rho * inertia_unit)
