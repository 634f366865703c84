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
Compiled geometry kernels: signed distance φ and its gradient, mesh SDF grids, mesh checks.

A shape is read by the kernels as ``(kind, params, grid)``: ``kind`` an int (the constants
below), ``params`` a float64 array of ``N_SHAPE_PARAM`` entries, ``grid`` a C-contiguous
float64 3-D array (the SDF samples of a mesh; a (1, 1, 1) zero array for every other kind).
Everything is in the shape's own frame (body frame, metres).

====================  ==============================================================
kind                  ``params``
====================  ==============================================================
``KIND_PLANE`` 0      ``[nx, ny, nz, d]``: unit normal ``n`` and offset; φ = n·x − d
``KIND_SPHERE`` 1     ``[r]``
``KIND_BOX`` 2        ``[hx, hy, hz]`` HALF edge lengths
``KIND_CYLINDER`` 3   ``[r, hl]`` radius and HALF length along z
``KIND_CAPSULE`` 4    ``[r, hl]`` radius and HALF length of the cylindrical part along z
``KIND_ELLIPSOID`` 5  ``[a, b, c]`` semi-axes along x, y, z
``KIND_MESH`` 6       ``[ox, oy, oz, h]``: grid origin (node (0, 0, 0)) and node spacing
====================  ==============================================================

φ is negative inside and positive outside.  For the primitives it is the exact signed
Euclidean distance to the surface, so ``|∇φ| = 1`` wherever φ is differentiable; on the medial
set (equidistant from two surface parts, e.g. the centre of a sphere) the returned gradient is
the normal at one of the closest points, chosen deterministically.  The ellipsoid follows
D. Eberly, "Distance from a Point to an Ellipse, an Ellipsoid, or a Hyperellipsoid"
(Geometric Tools, 2013): his case analysis and root bracket, with the 1-D root solved for
``u = s + 1`` (keeps full precision near the medial disk) by Newton steps that cannot overshoot
and a bisection fall-back, to round-off; so φ is the exact distance to round-off (checked
against brute-force minimisation and the closest-point conditions in the tests).  Meshes
interpolate their grid trilinearly: see :func:`phi_grad` for the error bound.  Norms are taken
without overflow or underflow of the squares, and no input raises (no division by zero).

``fastmath`` is off (IEEE semantics), nothing allocates in :func:`phi_grad`, and no randomness
is used anywhere.
"""

import math

import numpy as np

from rbd_ros.core import jitcache

KIND_PLANE = 0
KIND_SPHERE = 1
KIND_BOX = 2
KIND_CYLINDER = 3
KIND_CAPSULE = 4
KIND_ELLIPSOID = 5
KIND_MESH = 6
N_SHAPE_PARAM = 8
#: A point outside a box or a cylinder by at most this (m) takes the nearest face's normal,
#: not the direction from the nearest edge or corner: that close the direction is the
#: round-off of the point's coordinates.  Boxes side by side meet their diagonal neighbours
#: edge on edge; their edge points got normals anywhere between the two faces' (and tilted
#: up or down at the corners).  In a grid of 1000 boxes a patch normal tilted 7° like that
#: read 1.8 µm of depth that was not there (see rows.DEPTH_READ_ERROR_M), and one tilted
#: from the faces by less than atan μ can lock as a wedge (see manifold._consistent_normals).
#: φ is the exact distance all the same.
EDGE_ROUNDOFF_M = 1e-12

# Eberly's root is found by Newton steps from the left end of his bracket (see _root), with
# bisection as the fall-back: Newton gains a factor >= 1.5 in u = s + 1 per step far from the
# root and converges quadratically near it (~5-10 steps usually).  Bisection stops when the
# bracket is narrower than 2^-52 u or has no float64 inside.  The caps only guard against a NaN.
_NEWTON_MAX = 200
_BISECT_MAX = 2200
_S_RTOL = 2.220446049250313e-16

_jit = jitcache.kernel()
_inl = jitcache.kernel(inline='always')
#: For functions that allocate nothing and run per point: compiled without numba's reference
#: counting (its ``_nrt`` option), which costs two atomic updates per array argument per call
#: (see :mod:`rbd_ros.core.contact.step`, "Reference counts").
_raw = jitcache.raw_kernel()


@_jit
def _norm(x, y, z):
    """Return ``|(x, y, z)|`` without overflow or underflow of the squares."""
    m = max(abs(x), abs(y), abs(z))
    if 1e-150 < m < 1e150:
        return math.sqrt(x * x + y * y + z * z)
    if m == 0.0 or not m < math.inf:
        return m
    x /= m
    y /= m
    z /= m
    return m * math.sqrt(x * x + y * y + z * z)


@_inl
def _unit_or(x, y, z, fx, fy, fz):
    """Return ``(x, y, z) / |(x, y, z)|``, or ``(fx, fy, fz)`` for the zero vector."""
    n = _norm(x, y, z)
    if n > 0.0:
        return x / n, y / n, z / n
    return fx, fy, fz


@_inl
def _sphere(r, x, y, z):
    gx, gy, gz = _unit_or(x, y, z, 0.0, 0.0, 1.0)
    return _norm(x, y, z) - r, gx, gy, gz


@_inl
def _sign(v):
    return -1.0 if v < 0.0 else 1.0


@_jit
def _box(hx, hy, hz, x, y, z):
    """Exact signed distance to the box ``|x| <= hx`` etc. and its gradient."""
    qx = abs(x) - hx
    qy = abs(y) - hy
    qz = abs(z) - hz
    d = 0.0
    if qx > 0.0 or qy > 0.0 or qz > 0.0:
        ox = max(qx, 0.0)
        oy = max(qy, 0.0)
        oz = max(qz, 0.0)
        d = _norm(ox, oy, oz)
        if d > EDGE_ROUNDOFF_M:
            return d, _sign(x) * ox / d, _sign(y) * oy / d, _sign(z) * oz / d
    # Inside, on the surface or outside by round-off (then φ stays the distance ``d``): the
    # nearest face's normal, ties to the lowest axis.
    if qx >= qy and qx >= qz:
        return d if d > 0.0 else qx, _sign(x), 0.0, 0.0
    if qy >= qz:
        return d if d > 0.0 else qy, 0.0, _sign(y), 0.0
    return d if d > 0.0 else qz, 0.0, 0.0, _sign(z)


@_jit
def _cylinder(r, hl, x, y, z):
    """Exact signed distance to the solid cylinder ``rho <= r``, ``|z| <= hl``."""
    rho = _norm(x, y, 0.0)
    if rho > 0.0:
        ex = x / rho
        ey = y / rho
    else:
        ex = 1.0
        ey = 0.0
    dr = rho - r
    dz = abs(z) - hl
    sz = _sign(z)
    d = 0.0
    if dr > 0.0 or dz > 0.0:
        a = max(dr, 0.0)
        b = max(dz, 0.0)
        d = _norm(a, b, 0.0)
        if d > EDGE_ROUNDOFF_M:
            return d, ex * a / d, ey * a / d, sz * b / d
    # Inside, on the surface or outside a rim by round-off (see _box).
    if dr >= dz:
        return d if d > 0.0 else dr, ex, ey, 0.0
    return d if d > 0.0 else dz, 0.0, 0.0, sz


@_jit
def _capsule(r, hl, x, y, z):
    """Exact signed distance to the capsule around the segment ``|z| <= hl`` on the z axis."""
    cz = min(max(z, -hl), hl)
    dz = z - cz
    n = _norm(x, y, dz)
    if n > 0.0:
        return n - r, x / n, y / n, dz / n
    return -r, 1.0, 0.0, 0.0


@_jit
def _robust_length(a, b, c):
    m = max(abs(a), abs(b), abs(c))
    if m == 0.0:
        return 0.0
    a /= m
    b /= m
    c /= m
    return m * math.sqrt(a * a + b * b + c * c)


@_jit
def _ellipse_closest(e0, e1, y0, y1):
    """Closest point on the ellipse with semi-axes ``e0 >= e1`` to ``(y0, y1)``, both >= 0."""
    z0 = y0 / e0
    z1 = y1 / e1
    if z1 > 0.0:
        if z0 > 0.0:
            g = z0 * z0 + z1 * z1 - 1.0
            if g != 0.0:
                r0 = (e0 / e1) * (e0 / e1)
                d0 = ((e0 - e1) / e1) * ((e0 + e1) / e1)
                u = _root(r0, 1.0, d0, 0.0, z0, 0.0, z1, g)
                return r0 * y0 / (u + d0), y1 / u
            return y0, y1
        return 0.0, e1
    denom0 = e0 * e0 - e1 * e1
    numer0 = e0 * y0
    if numer0 < denom0:
        xde0 = numer0 / denom0
        return e0 * xde0, e1 * math.sqrt(max(1.0 - xde0 * xde0, 0.0))
    return e0, 0.0


@_jit
def _root(r0, r1, d0, d1, z0, z1, z2, g):
    """
    Return ``u = s + 1`` at Eberly's root ``s > -1``, with ``d_i = r_i - 1`` given exactly.

    Eberly's function ``F(s) = (r0 z0/(s+r0))² + (r1 z1/(s+r1))² + (z2/(s+1))² - 1`` is
    solved in ``u = s + 1 > 0``: ``F = (r0 z0/(u+d0))² + (r1 z1/(u+d1))² + (z2/u)² - 1``.  Near
    the medial disk ``u`` is tiny and ``z2 / u`` must keep its relative precision, which ``s``
    (absolute precision ~1e-16) would lose.  Bracket: ``F(z2) >= 0 >= F(u1)`` with ``u1 = 1``
    inside (``g < 0``) or ``|(r0 z0, r1 z1, z2)|`` outside.  ``F`` is decreasing and convex in
    ``u``, so Newton steps from the left end never pass the root; they stop when a step is
    below ``_S_RTOL u`` (quadratic convergence: the root is then known to round-off).  Should
    Newton not get there in ``_NEWTON_MAX`` steps, or leave the bracket through round-off,
    bisection finishes on the bracket.  An ellipse is the case ``z1 = 0``.
    """
    n0 = r0 * z0
    n1 = r1 * z1
    u0 = z2
    u1 = 1.0 if g < 0.0 else _robust_length(n0, n1, z2)
    for _ in range(_NEWTON_MAX):
        i0 = 1.0 / (u0 + d0)
        i1 = 1.0 / (u0 + d1)
        i2 = 1.0 / u0
        a = n0 * i0
        b = n1 * i1
        c = z2 * i2
        f = a * a + b * b + c * c - 1.0
        if f <= 0.0:
            return u0
        step = f / (2.0 * (a * a * i0 + b * b * i1 + c * c * i2))
        t = u0 + step
        if not t < u1:
            break
        if step <= _S_RTOL * u0:
            return t
        u0 = t
    u = 0.5 * (u0 + u1)
    for _ in range(_BISECT_MAX):
        u = 0.5 * (u0 + u1)
        if u == u0 or u == u1 or u1 - u0 <= _S_RTOL * u0:
            break
        a = n0 / (u + d0)
        b = n1 / (u + d1)
        c = z2 / u
        g = a * a + b * b + c * c - 1.0
        if g > 0.0:
            u0 = u
        elif g < 0.0:
            u1 = u
        else:
            break
    return u


@_jit
def _ellipsoid_closest(e0, e1, e2, y0, y1, y2):
    """Closest point on the ellipsoid ``e0 >= e1 >= e2`` to ``(y0, y1, y2)``, all >= 0."""
    z0 = y0 / e0
    z1 = y1 / e1
    z2 = y2 / e2
    if z2 > 0.0:
        if z1 > 0.0:
            if z0 > 0.0:
                g = z0 * z0 + z1 * z1 + z2 * z2 - 1.0
                if g != 0.0:
                    r0 = (e0 / e2) * (e0 / e2)
                    r1 = (e1 / e2) * (e1 / e2)
                    d0 = ((e0 - e2) / e2) * ((e0 + e2) / e2)
                    d1 = ((e1 - e2) / e2) * ((e1 + e2) / e2)
                    u = _root(r0, r1, d0, d1, z0, z1, z2, g)
                    return r0 * y0 / (u + d0), r1 * y1 / (u + d1), y2 / u
                return y0, y1, y2
            x1, x2 = _ellipse_closest(e1, e2, y1, y2)
            return 0.0, x1, x2
        if z0 > 0.0:
            x0, x2 = _ellipse_closest(e0, e2, y0, y2)
            return x0, 0.0, x2
        return 0.0, 0.0, e2
    denom0 = e0 * e0 - e2 * e2
    denom1 = e1 * e1 - e2 * e2
    numer0 = e0 * y0
    numer1 = e1 * y1
    if numer0 < denom0 and numer1 < denom1:
        xde0 = numer0 / denom0
        xde1 = numer1 / denom1
        discr = 1.0 - xde0 * xde0 - xde1 * xde1
        if discr > 0.0:
            return e0 * xde0, e1 * xde1, e2 * math.sqrt(discr)
    x0, x1 = _ellipse_closest(e0, e1, y0, y1)
    return x0, x1, 0.0


@_inl
def _pick(axis, i0, i1, c0, c1, c2):
    """Return the coordinate of the sorted-axes point that belongs to ``axis``."""
    if axis == i0:
        return c0
    if axis == i1:
        return c1
    return c2


@_jit
def _ellipsoid(a, b, c, x, y, z):
    """
    Exact signed distance to the ellipsoid ``(x/a)² + (y/b)² + (z/c)² <= 1`` (Eberly).

    The point is reflected into the first octant and the axes sorted descending; the closest
    point ``x*`` is found there and mapped back.  The gradient is the outward unit normal at
    ``x*`` (``∝ (x*/a², y*/b², z*/c²)``), which equals ``±(p − x*)/|p − x*|`` off the surface.
    """
    ax = (a, b, c)
    p = (abs(x), abs(y), abs(z))
    # Indices of the axes in descending order of length (ties keep x before y before z).
    i0, i1, i2 = 0, 1, 2
    if ax[i1] > ax[i0]:
        i0, i1 = i1, i0
    if ax[i2] > ax[i1]:
        i1, i2 = i2, i1
        if ax[i1] > ax[i0]:
            i0, i1 = i1, i0
    c0, c1, c2 = _ellipsoid_closest(ax[i0], ax[i1], ax[i2], p[i0], p[i1], p[i2])
    qx = _pick(0, i0, i1, c0, c1, c2)
    qy = _pick(1, i0, i1, c0, c1, c2)
    qz = _pick(2, i0, i1, c0, c1, c2)
    dx = p[0] - qx
    dy = p[1] - qy
    dz = p[2] - qz
    dist = _norm(dx, dy, dz)
    inside = (x / a) ** 2 + (y / b) ** 2 + (z / c) ** 2 < 1.0
    nx, ny, nz = _unit_or(qx / (a * a), qy / (b * b), qz / (c * c), 0.0, 0.0, 1.0)
    phi = -dist if inside else dist
    return phi, _sign(x) * nx, _sign(y) * ny, _sign(z) * nz


@_inl
def _cell(x, n):
    """Return the cell ``floor(x)`` clamped to ``[0, n - 2]``, 0 for nan (no int of a nan)."""
    cell = math.floor(x)
    if not cell >= 0.0:
        return 0
    if cell > n - 2.0:
        return n - 2
    return int(cell)


@_raw
def _grid_sample(grid, x, y, z):
    """Trilinear value and gradient of ``grid`` at grid coordinates inside ``[0, n - 1]``."""
    nx, ny, nz = grid.shape
    i = _cell(x, nx)
    j = _cell(y, ny)
    k = _cell(z, nz)
    u = x - i
    v = y - j
    w = z - k
    c000 = grid[i, j, k]
    c100 = grid[i + 1, j, k]
    c010 = grid[i, j + 1, k]
    c110 = grid[i + 1, j + 1, k]
    c001 = grid[i, j, k + 1]
    c101 = grid[i + 1, j, k + 1]
    c011 = grid[i, j + 1, k + 1]
    c111 = grid[i + 1, j + 1, k + 1]
    c00 = c000 + u * (c100 - c000)
    c10 = c010 + u * (c110 - c010)
    c01 = c001 + u * (c101 - c001)
    c11 = c011 + u * (c111 - c011)
    c0 = c00 + v * (c10 - c00)
    c1 = c01 + v * (c11 - c01)
    value = c0 + w * (c1 - c0)
    # Partial derivatives of the trilinear interpolant (per unit grid coordinate).
    dx0 = (c100 - c000) + v * ((c110 - c010) - (c100 - c000))
    dx1 = (c101 - c001) + v * ((c111 - c011) - (c101 - c001))
    gx = dx0 + w * (dx1 - dx0)
    gy = (c10 - c00) + w * ((c11 - c01) - (c10 - c00))
    gz = c1 - c0
    return value, gx, gy, gz


@_raw
def _mesh(params, grid, x, y, z):
    """Trilinear grid SDF; outside the grid box: boundary value plus distance to the box."""
    h = params[3]
    gx = (x - params[0]) / h
    gy = (y - params[1]) / h
    gz = (z - params[2]) / h
    nx, ny, nz = grid.shape
    cx = min(max(gx, 0.0), nx - 1.0)
    cy = min(max(gy, 0.0), ny - 1.0)
    cz = min(max(gz, 0.0), nz - 1.0)
    value, dx, dy, dz = _grid_sample(grid, cx, cy, cz)
    ox = (gx - cx) * h
    oy = (gy - cy) * h
    oz = (gz - cz) * h
    out = _norm(ox, oy, oz)
    if out > 0.0:
        return value + out, ox / out, oy / out, oz / out
    ux, uy, uz = _unit_or(dx, dy, dz, 0.0, 0.0, 1.0)
    return value, ux, uy, uz


@_raw
def phi_grad(kind, params, grid, x, y, z):
    """
    Return ``(φ, ∂φ/∂x, ∂φ/∂y, ∂φ/∂z)`` of a shape at the point ``(x, y, z)`` (its frame, m).

    For a mesh (``KIND_MESH``) φ is the trilinear interpolant of the grid samples, which are
    exact signed distances at the nodes.  The exact signed distance φ* is 1-Lipschitz and the
    trilinear weights ``w_i`` of the 8 corners ``c_i`` sum to 1, so inside the grid box
    ``|φ − φ*| <= Σ w_i |c_i − p| <= (Σ w_i |c_i − p|²)^½ = h (Σ_k u_k (1 − u_k))^½
    <= (√3 / 2) h`` for a node spacing ``h`` (``u_k`` the fractional cell coordinates); where
    φ* is smooth the error is second order, O(h² κ).  The gradient returned is the
    normalised gradient of the interpolant (a unit contact normal).  Outside the grid box φ is
    the interpolated value at the nearest point ``c`` of the box plus ``|p − c|`` (an upper
    bound of φ* within the same error) and the gradient is ``(p − c)/|p − c|``.
    """
    if kind == KIND_PLANE:
        return (params[0] * x + params[1] * y + params[2] * z - params[3],
                params[0], params[1], params[2])
    if kind == KIND_SPHERE:
        return _sphere(params[0], x, y, z)
    if kind == KIND_BOX:
        return _box(params[0], params[1], params[2], x, y, z)
    if kind == KIND_CYLINDER:
        return _cylinder(params[0], params[1], x, y, z)
    if kind == KIND_CAPSULE:
        return _capsule(params[0], params[1], x, y, z)
    if kind == KIND_ELLIPSOID:
        return _ellipsoid(params[0], params[1], params[2], x, y, z)
    if kind == KIND_MESH:
        return _mesh(params, grid, x, y, z)
    return math.nan, math.nan, math.nan, math.nan


@_raw
def phi_grad_many(kind, params, grid, points, out_phi, out_grad):
    """Fill ``out_phi`` (n,) and ``out_grad`` (n, 3) with :func:`phi_grad` of each point."""
    for n in range(points.shape[0]):
        phi, gx, gy, gz = phi_grad(kind, params, grid, points[n, 0], points[n, 1],
                                   points[n, 2])
        out_phi[n] = phi
        out_grad[n, 0] = gx
        out_grad[n, 1] = gy
        out_grad[n, 2] = gz


@_raw
def min_phi_posed(kind, params, grid, rot_ba, trans_ba, points_a):
    """
    Return ``(min φ, index)`` over ``points_a`` mapped into the shape's frame.

    ``x_b = rot_ba x_a + trans_ba``: ``rot_ba`` (3, 3) and ``trans_ba`` (3,) map the points'
    frame a into the shape's frame b.
    """
    best = math.inf
    index = -1
    for n in range(points_a.shape[0]):
        px = points_a[n, 0]
        py = points_a[n, 1]
        pz = points_a[n, 2]
        x = rot_ba[0, 0] * px + rot_ba[0, 1] * py + rot_ba[0, 2] * pz + trans_ba[0]
        y = rot_ba[1, 0] * px + rot_ba[1, 1] * py + rot_ba[1, 2] * pz + trans_ba[1]
        z = rot_ba[2, 0] * px + rot_ba[2, 1] * py + rot_ba[2, 2] * pz + trans_ba[2]
        phi = phi_grad(kind, params, grid, x, y, z)[0]
        if phi < best:
            best = phi
            index = n
    return best, index


# ---------------------------------------------------------------------------------------------
# Meshes: exact point-triangle distance, winding number, the SDF grid, self-intersection.


@_inl
def _dot(ax, ay, az, bx, by, bz):
    return ax * bx + ay * by + az * bz


@_jit
def point_triangle_dist2(px, py, pz, v, f):
    """
    Return the squared distance from ``p`` to the triangle ``v[f]``.

    C. Ericson, Real-Time Collision Detection (2005), 5.1.5: the closest point is found by
    testing the Voronoi regions of the vertices, the edges and the face, in that order.
    """
    ax, ay, az = v[f[0], 0], v[f[0], 1], v[f[0], 2]
    bx, by, bz = v[f[1], 0], v[f[1], 1], v[f[1], 2]
    cx, cy, cz = v[f[2], 0], v[f[2], 1], v[f[2], 2]
    abx, aby, abz = bx - ax, by - ay, bz - az
    acx, acy, acz = cx - ax, cy - ay, cz - az
    apx, apy, apz = px - ax, py - ay, pz - az
    d1 = _dot(abx, aby, abz, apx, apy, apz)
    d2 = _dot(acx, acy, acz, apx, apy, apz)
    if d1 <= 0.0 and d2 <= 0.0:
        qx, qy, qz = ax, ay, az
    else:
        bpx, bpy, bpz = px - bx, py - by, pz - bz
        d3 = _dot(abx, aby, abz, bpx, bpy, bpz)
        d4 = _dot(acx, acy, acz, bpx, bpy, bpz)
        cpx, cpy, cpz = px - cx, py - cy, pz - cz
        d5 = _dot(abx, aby, abz, cpx, cpy, cpz)
        d6 = _dot(acx, acy, acz, cpx, cpy, cpz)
        vc = d1 * d4 - d3 * d2
        vb = d5 * d2 - d1 * d6
        va = d3 * d6 - d5 * d4
        if d3 >= 0.0 and d4 <= d3:
            qx, qy, qz = bx, by, bz
        elif vc <= 0.0 and d1 >= 0.0 and d3 <= 0.0:
            t = d1 / (d1 - d3)
            qx, qy, qz = ax + t * abx, ay + t * aby, az + t * abz
        elif d6 >= 0.0 and d5 <= d6:
            qx, qy, qz = cx, cy, cz
        elif vb <= 0.0 and d2 >= 0.0 and d6 <= 0.0:
            t = d2 / (d2 - d6)
            qx, qy, qz = ax + t * acx, ay + t * acy, az + t * acz
        elif va <= 0.0 and (d4 - d3) >= 0.0 and (d5 - d6) >= 0.0:
            t = (d4 - d3) / ((d4 - d3) + (d5 - d6))
            qx, qy, qz = bx + t * (cx - bx), by + t * (cy - by), bz + t * (cz - bz)
        else:
            denom = 1.0 / (va + vb + vc)
            s = vb * denom
            t = vc * denom
            qx = ax + s * abx + t * acx
            qy = ay + s * aby + t * acy
            qz = az + s * abz + t * acz
    dx, dy, dz = px - qx, py - qy, pz - qz
    return dx * dx + dy * dy + dz * dz


@_jit
def winding_number(px, py, pz, v, faces):
    """
    Generalised winding number of a closed triangle mesh around ``p``: 1 inside, 0 outside.

    Sum of the signed solid angles of the triangles seen from ``p`` over 4π (A. Van Oosterom
    and J. Strackee, IEEE Trans. Biomed. Eng. 30(2), 1983:
    ``tan(Ω/2) = a·(b×c) / (|a||b||c| + (a·b)|c| + (b·c)|a| + (c·a)|b|)``).
    """
    total = 0.0
    for t in range(faces.shape[0]):
        ax = v[faces[t, 0], 0] - px
        ay = v[faces[t, 0], 1] - py
        az = v[faces[t, 0], 2] - pz
        bx = v[faces[t, 1], 0] - px
        by = v[faces[t, 1], 1] - py
        bz = v[faces[t, 1], 2] - pz
        cx = v[faces[t, 2], 0] - px
        cy = v[faces[t, 2], 1] - py
        cz = v[faces[t, 2], 2] - pz
        la = math.sqrt(ax * ax + ay * ay + az * az)
        lb = math.sqrt(bx * bx + by * by + bz * bz)
        lc = math.sqrt(cx * cx + cy * cy + cz * cz)
        det = (ax * (by * cz - bz * cy) + ay * (bz * cx - bx * cz)
               + az * (bx * cy - by * cx))
        div = (la * lb * lc + _dot(ax, ay, az, bx, by, bz) * lc
               + _dot(bx, by, bz, cx, cy, cz) * la + _dot(cx, cy, cz, ax, ay, az) * lb)
        total += 2.0 * math.atan2(det, div)
    return total / (4.0 * math.pi)


@_jit
def build_sdf(vertices, faces, origin, h, grid):
    """
    Fill ``grid`` (nx, ny, nz) with the exact signed distance to the closed mesh at its nodes.

    The nodes are ``origin + h (i, j, k)``.

    Unsigned distance: the exact minimum over triangles of the point-triangle distance; a
    triangle is skipped when its bounding sphere is farther than the best distance so far
    (started from the previous node's closest triangle), which changes no value.

    Sign: the nodes are visited in index order; a node takes the side of an already signed
    neighbour ``q`` (one step back along an axis) when ``d(q) > h``: the open ball of radius
    ``d(q)`` around ``q`` holds no surface point and contains the segment to the node.  Other
    nodes (within about ``h`` of the surface) take the side of their winding number (inside
    when > 1/2).  A node exactly on the surface has φ = 0 whatever its side.
    """
    nf = faces.shape[0]
    cen = np.empty((nf, 3))
    rad = np.empty(nf)
    for t in range(nf):
        for k in range(3):
            cen[t, k] = (vertices[faces[t, 0], k] + vertices[faces[t, 1], k]
                         + vertices[faces[t, 2], k]) / 3.0
        r2 = 0.0
        for m in range(3):
            dx = vertices[faces[t, m], 0] - cen[t, 0]
            dy = vertices[faces[t, m], 1] - cen[t, 1]
            dz = vertices[faces[t, m], 2] - cen[t, 2]
            r2 = max(r2, dx * dx + dy * dy + dz * dz)
        # Rounded up by 1e-12 relative so that no float64 rounding can cull the closest one.
        rad[t] = math.sqrt(r2) * (1.0 + 1e-12)
    nx, ny, nz = grid.shape
    inside = np.zeros((nx, ny, nz), dtype=np.bool_)
    last = 0
    # A neighbour's side is trusted when its distance exceeds h by a margin far above the
    # ~1e-15 relative error of the distances.
    trust = h * (1.0 + 1e-9)
    for i in range(nx):
        px = origin[0] + h * i
        for j in range(ny):
            py = origin[1] + h * j
            for k in range(nz):
                pz = origin[2] + h * k
                best2 = point_triangle_dist2(px, py, pz, vertices, faces[last])
                best = math.sqrt(best2)
                for t in range(nf):
                    dx = px - cen[t, 0]
                    dy = py - cen[t, 1]
                    dz = pz - cen[t, 2]
                    # Skip when |p - c| - r > best, i.e. |p - c|² > (best + r)².
                    reach = best + rad[t]
                    if dx * dx + dy * dy + dz * dz > reach * reach:
                        continue
                    d2 = point_triangle_dist2(px, py, pz, vertices, faces[t])
                    if d2 < best2:
                        best2 = d2
                        best = math.sqrt(d2)
                        last = t
                signed = False
                if i > 0 and grid[i - 1, j, k] > trust:
                    inside[i, j, k] = inside[i - 1, j, k]
                    signed = True
                elif j > 0 and grid[i, j - 1, k] > trust:
                    inside[i, j, k] = inside[i, j - 1, k]
                    signed = True
                elif k > 0 and grid[i, j, k - 1] > trust:
                    inside[i, j, k] = inside[i, j, k - 1]
                    signed = True
                if not signed:
                    inside[i, j, k] = winding_number(px, py, pz, vertices, faces) > 0.5
                # Store the unsigned distance until every neighbour test has read it.
                grid[i, j, k] = best
    for i in range(nx):
        for j in range(ny):
            for k in range(nz):
                if inside[i, j, k]:
                    grid[i, j, k] = -grid[i, j, k]


@_inl
def _orient(ax, ay, az, bx, by, bz, cx, cy, cz, dx, dy, dz):
    """Six times the signed volume of the tetrahedron ``a b c d`` (> 0: d below abc)."""
    ux, uy, uz = ax - dx, ay - dy, az - dz
    vx, vy, vz = bx - dx, by - dy, bz - dz
    wx, wy, wz = cx - dx, cy - dy, cz - dz
    return (ux * (vy * wz - vz * wy) + uy * (vz * wx - vx * wz) + uz * (vx * wy - vy * wx))


@_jit
def _segment_crosses(v, p, q, f):
    """Return whether the segment ``v[p] v[q]`` properly crosses the triangle ``v[f]``."""
    a, b, c = f[0], f[1], f[2]
    sp = _orient(v[a, 0], v[a, 1], v[a, 2], v[b, 0], v[b, 1], v[b, 2], v[c, 0], v[c, 1],
                 v[c, 2], v[p, 0], v[p, 1], v[p, 2])
    sq = _orient(v[a, 0], v[a, 1], v[a, 2], v[b, 0], v[b, 1], v[b, 2], v[c, 0], v[c, 1],
                 v[c, 2], v[q, 0], v[q, 1], v[q, 2])
    if not ((sp > 0.0 and sq < 0.0) or (sp < 0.0 and sq > 0.0)):
        return False
    s1 = _orient(v[p, 0], v[p, 1], v[p, 2], v[q, 0], v[q, 1], v[q, 2], v[a, 0], v[a, 1],
                 v[a, 2], v[b, 0], v[b, 1], v[b, 2])
    s2 = _orient(v[p, 0], v[p, 1], v[p, 2], v[q, 0], v[q, 1], v[q, 2], v[b, 0], v[b, 1],
                 v[b, 2], v[c, 0], v[c, 1], v[c, 2])
    s3 = _orient(v[p, 0], v[p, 1], v[p, 2], v[q, 0], v[q, 1], v[q, 2], v[c, 0], v[c, 1],
                 v[c, 2], v[a, 0], v[a, 1], v[a, 2])
    return (s1 > 0.0 and s2 > 0.0 and s3 > 0.0) or (s1 < 0.0 and s2 < 0.0 and s3 < 0.0)


@_jit
def _triangles_cross(v, f, g):
    for m in range(3):
        if _segment_crosses(v, f[m], f[(m + 1) % 3], g):
            return True
        if _segment_crosses(v, g[m], g[(m + 1) % 3], f):
            return True
    return False


@_jit
def first_self_intersection(vertices, faces, order, lo, hi):
    """
    Return the first pair ``(s, t)`` of crossing faces that share no vertex, or ``(-1, -1)``.

    Broad phase: a sweep over the faces in ``order`` (ascending ``lo[:, 0]``, the AABB minima),
    testing each face against the following faces whose AABB overlaps on all three axes.
    Narrow phase: an edge of one triangle properly crossing the interior of the other (strict
    sign tests of float64 orientation determinants).  Faces that share a vertex and coplanar
    overlaps are not tested: a closed, consistently wound mesh that passed the edge checks
    intersects itself transversally, which this finds.
    """
    n = order.shape[0]
    for a in range(n):
        s = order[a]
        for b in range(a + 1, n):
            t = order[b]
            if lo[t, 0] > hi[s, 0]:
                break
            if (lo[t, 1] > hi[s, 1] or lo[s, 1] > hi[t, 1] or lo[t, 2] > hi[s, 2]
                    or lo[s, 2] > hi[t, 2]):
                continue
            shared = False
            for m in range(3):
                for k in range(3):
                    if faces[s, m] == faces[t, k]:
                        shared = True
            if shared:
                continue
            if _triangles_cross(vertices, faces[s], faces[t]):
                return min(s, t), max(s, t)
    return -1, -1
