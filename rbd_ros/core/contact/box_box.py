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
The contact points of two boxes: separating axes, then the incident face clipped.

Two boxes in contact touch face on face, edge on face, corner on face or edge across edge.
Their points come from the separating-axis test (Gottschalk, Lin, Manocha, "OBBTree", SIGGRAPH
1996: the three face normals of each box and the nine cross products of their edges), not from
sampled surface points against φ:

* Along an axis ``L`` (unit) the boxes are apart by
  ``s = |L · (p_a − p_b)| − Σ_k h_a,k |L · A_k| − Σ_k h_b,k |L · B_k|`` (``A_k``, ``B_k`` the
  box axes in the world, ``h`` the half edge lengths).  If some axis has ``s`` beyond the
  margin there is no contact; otherwise the axis with the largest ``s`` (the least overlap) is
  the contact normal.  A face of ``a`` is preferred to one of ``b``, and a face to an edge pair,
  unless the other separates by more than :data:`FACE_BIAS_M`: flush faces tie to round-off,
  and the choice must not flip from step to step on it.
* **Face contact** (Gregorius, "Robust contact creation for physics simulations", GDC 2015;
  Box2D's ``b2CollidePolygons``): the face of the *reference* box along that axis, the face of
  the other (*incident*) box most opposed to it, and the incident face clipped by the
  reference face's four side planes (Sutherland–Hodgman).  Every clipped vertex is a point of
  the incident box's face; its ``φ`` is its signed distance from the reference face's plane.
  So a box on a box gets the corners of the overlap of their faces exactly, at most eight.
* **Edge contact**: the two edges along the axis's pair of directions that face each other;
  one point, the closest point of the ``a`` edge to the ``b`` edge, ``φ = s``.

Everything is at the poses given (the candidate poses of a contact stage).  Nothing
allocates; loops are fixed, so results are bit-identical run after run.
"""

import math

from rbd_ros.core import jitcache


#: Flush faces give equal separations to round-off: the face of ``a`` stays the reference
#: unless ``b``'s separates by more than this (m), and a face stays the contact normal unless
#: an edge pair separates by more.  A normal chosen that way is off the best axis by at most
#: ~this over the boxes' size in angle (1e-5 rad for 0.1 m boxes), and a point's φ by at most
#: this: well inside the margin, and not a creep (it does not accumulate).
FACE_BIAS_M = 1e-6
#: Edge pairs closer to parallel than this (sine of their angle) have no cross product worth
#: the name; the face axes cover them.
PARALLEL_SIN = 1e-6
#: Clipped vertices closer than this (m, in every coordinate) are one point.  Faces whose
#: edges lie on each other's side planes (equal boxes stacked flush, or boxes side by side
#: meeting their diagonal neighbours edge on edge) clip to vertices repeated to round-off,
#: and two points at one place make a patch's response singular.
MERGE_M = 1e-9
#: Rows of the scratch :func:`box_box` clips in: two polygons of at most eight vertices.
CLIP_ROWS = 16
#: Columns of a clip row: the reference face's two tangent coordinates and the height above
#: it (φ), then the world point.
CLIP_COLS = 6

_raw = jitcache.raw_kernel()
#: The helpers :func:`box_box` calls ~25 times a pair are inlined: a call copied the fields of
#: the arrays it takes onto the stack.
_inl = jitcache.kernel(inline='always')


@_inl
def _clip(poly, src, n, dst, col, sign, limit):
    """
    Clip the polygon in rows ``src … src+n-1`` of ``poly`` to ``sign · poly[:, col] <= limit``.

    Write the result from row ``dst`` (Sutherland–Hodgman: a vertex inside is kept, an edge
    crossing the plane adds the crossing); return its vertex count (at most ``n + 1``).
    Everything in a row is affine along an edge, so every column is interpolated alike.
    """
    m = 0
    for k in range(n):
        p = src + k
        q = src + (k + 1) % n
        fp = sign * poly[p, col] - limit
        fq = sign * poly[q, col] - limit
        if fp <= 0.0:
            for c in range(CLIP_COLS):
                poly[dst + m, c] = poly[p, c]
            m += 1
        if (fp <= 0.0) != (fq <= 0.0):
            t = fp / (fp - fq)
            for c in range(CLIP_COLS):
                poly[dst + m, c] = poly[p, c] + t * (poly[q, c] - poly[p, c])
            poly[dst + m, col] = sign * limit  # on the plane, not a round-off beside it
            m += 1
    return m


@_inl
def _repeated(poly, k, out, count):
    """Tell whether clipped vertex ``k`` is within :data:`MERGE_M` of a point in ``out``."""
    for j in range(count):
        if (abs(poly[k, 3] - out[j, 1]) <= MERGE_M and abs(poly[k, 4] - out[j, 2]) <= MERGE_M
                and abs(poly[k, 5] - out[j, 3]) <= MERGE_M):
            return True
    return False


@_inl
def _extent(half, rot, i, lx, ly, lz):
    """Return how far box ``i`` (``half``, axes ``rot[i]``) reaches from its centre along ``l``."""
    r = 0.0
    for k in range(3):
        r += half[i, k] * abs(lx * rot[i, 0, k] + ly * rot[i, 1, k] + lz * rot[i, 2, k])
    return r


@_inl
def _faces(half, rot, s, t, dx, dy, dz):
    """Return the largest separation of boxes ``s``, ``t`` along ``s``'s face normals, its axis."""
    best = -math.inf
    face = 0
    for i in range(3):
        lx, ly, lz = rot[s, 0, i], rot[s, 1, i], rot[s, 2, i]
        gap = (abs(dx * lx + dy * ly + dz * lz) - half[s, i]
               - _extent(half, rot, t, lx, ly, lz))
        if gap > best:
            best = gap
            face = i
    return best, face


@_raw
def box_box(half, rot, pos, a, b, margin, poly, out):
    """
    Find the contact points of boxes ``a`` and ``b``; return ``(count, nx, ny, nz, incident)``.

    ``half[s]``: box ``s``'s half edge lengths; ``rot[s]`` (columns: its axes in the world)
    and ``pos[s]``: its pose.  ``poly``: scratch of :data:`CLIP_ROWS` × :data:`CLIP_COLS`.
    Rows ``out[k] = [φ, x, y, z]`` (m) for the ``count`` points with ``φ < margin``: a point
    of box ``incident`` (``a`` or ``b``) in the world and its signed distance from the other
    box along the normal ``n``, the unit normal out of ``b`` towards ``a`` (the impulse on
    ``a`` is along ``+n``).  ``count`` is 0 where some axis separates the boxes by the margin
    or more.
    """
    dx = pos[a, 0] - pos[b, 0]
    dy = pos[a, 1] - pos[b, 1]
    dz = pos[a, 2] - pos[b, 2]
    best_a, face_a = _faces(half, rot, a, b, dx, dy, dz)
    best_b, face_b = _faces(half, rot, b, a, dx, dy, dz)
    if best_a >= margin or best_b >= margin:
        return 0, 0.0, 0.0, 0.0, a
    best_e = -math.inf
    edge_a = 0
    edge_b = 0
    ex, ey, ez = 0.0, 0.0, 0.0
    for i in range(3):
        for j in range(3):
            ax, ay, az = rot[a, 0, i], rot[a, 1, i], rot[a, 2, i]
            bx, by, bz = rot[b, 0, j], rot[b, 1, j], rot[b, 2, j]
            lx, ly, lz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
            size = math.sqrt(lx * lx + ly * ly + lz * lz)
            if size < PARALLEL_SIN:
                continue
            lx, ly, lz = lx / size, ly / size, lz / size
            s = (abs(dx * lx + dy * ly + dz * lz) - _extent(half, rot, a, lx, ly, lz)
                 - _extent(half, rot, b, lx, ly, lz))
            if s >= margin:
                return 0, 0.0, 0.0, 0.0, a
            if s > best_e:
                best_e = s
                edge_a = i
                edge_b = j
                ex, ey, ez = lx, ly, lz
    on_b = best_b > best_a + FACE_BIAS_M
    best_f = best_b if on_b else best_a
    if best_e > best_f + FACE_BIAS_M:
        return _edge_point(half, rot, pos, a, b, edge_a, edge_b, ex, ey, ez, best_e, out)
    if on_b:
        return _face_points(half, rot, pos, b, a, face_b, margin, poly, out, 1.0)
    return _face_points(half, rot, pos, a, b, face_a, margin, poly, out, -1.0)


@_raw
def _face_points(half, rot, pos, r, c, i, margin, poly, out, toward_a):
    """
    Clip the face of box ``c`` (incident) most opposed to face ``i`` of box ``r`` (reference).

    ``toward_a``: +1 where ``r`` is ``b`` (the reference face's outward normal is ``n``), −1
    where it is ``a``.  Return as :func:`box_box`.
    """
    # The reference face's outward normal, towards the incident box.
    nx, ny, nz = rot[r, 0, i], rot[r, 1, i], rot[r, 2, i]
    if ((pos[c, 0] - pos[r, 0]) * nx + (pos[c, 1] - pos[r, 1]) * ny
            + (pos[c, 2] - pos[r, 2]) * nz) < 0.0:
        nx, ny, nz = -nx, -ny, -nz
    # The incident face: its outward normal most opposed to n (ties to the lowest axis).
    j = 0
    most = -1.0
    for k in range(3):
        d = abs(rot[c, 0, k] * nx + rot[c, 1, k] * ny + rot[c, 2, k] * nz)
        if d > most:
            most = d
            j = k
    side = -1.0 if rot[c, 0, j] * nx + rot[c, 1, j] * ny + rot[c, 2, j] * nz > 0.0 else 1.0
    cx = pos[c, 0] + side * half[c, j] * rot[c, 0, j]
    cy = pos[c, 1] + side * half[c, j] * rot[c, 1, j]
    cz = pos[c, 2] + side * half[c, j] * rot[c, 2, j]
    u = (j + 1) % 3
    v = (j + 2) % 3
    # The reference face's tangent axes.
    t1 = (i + 1) % 3
    t2 = (i + 2) % 3
    for k in range(4):
        su = 1.0 if k == 0 or k == 3 else -1.0
        sv = 1.0 if k < 2 else -1.0
        wx = cx + su * half[c, u] * rot[c, 0, u] + sv * half[c, v] * rot[c, 0, v]
        wy = cy + su * half[c, u] * rot[c, 1, u] + sv * half[c, v] * rot[c, 1, v]
        wz = cz + su * half[c, u] * rot[c, 2, u] + sv * half[c, v] * rot[c, 2, v]
        ox, oy, oz = wx - pos[r, 0], wy - pos[r, 1], wz - pos[r, 2]
        poly[k, 0] = ox * rot[r, 0, t1] + oy * rot[r, 1, t1] + oz * rot[r, 2, t1]
        poly[k, 1] = ox * rot[r, 0, t2] + oy * rot[r, 1, t2] + oz * rot[r, 2, t2]
        poly[k, 2] = ox * nx + oy * ny + oz * nz - half[r, i]
        poly[k, 3] = wx
        poly[k, 4] = wy
        poly[k, 5] = wz
    # Four planes, the polygon moving between the two halves of the scratch.
    m = _clip(poly, 0, 4, 8, 0, 1.0, half[r, t1])
    m = _clip(poly, 8, m, 0, 0, -1.0, half[r, t1])
    m = _clip(poly, 0, m, 8, 1, 1.0, half[r, t2])
    m = _clip(poly, 8, m, 0, 1, -1.0, half[r, t2])
    count = 0
    for k in range(m):
        if not poly[k, 2] < margin or _repeated(poly, k, out, count):
            continue
        out[count, 0] = poly[k, 2]
        out[count, 1] = poly[k, 3]
        out[count, 2] = poly[k, 4]
        out[count, 3] = poly[k, 5]
        count += 1
    return count, toward_a * nx, toward_a * ny, toward_a * nz, c


@_raw
def _edge_point(half, rot, pos, a, b, i, j, lx, ly, lz, s, out):
    """
    Return the edge-on-edge point of :func:`box_box` along ``l`` = ``A_i × B_j`` (unit).

    ``s``: the separation along ``l``, below the margin (:func:`box_box` has checked).
    """
    if (lx * (pos[a, 0] - pos[b, 0]) + ly * (pos[a, 1] - pos[b, 1])
            + lz * (pos[a, 2] - pos[b, 2])) < 0.0:
        lx, ly, lz = -lx, -ly, -lz
    # a's edge along A_i lowest along l, b's along B_j highest.
    pax, pay, paz = pos[a, 0], pos[a, 1], pos[a, 2]
    pbx, pby, pbz = pos[b, 0], pos[b, 1], pos[b, 2]
    for k in range(3):
        if k != i:
            sa = half[a, k] * (-1.0 if lx * rot[a, 0, k] + ly * rot[a, 1, k]
                               + lz * rot[a, 2, k] > 0.0 else 1.0)
            pax += sa * rot[a, 0, k]
            pay += sa * rot[a, 1, k]
            paz += sa * rot[a, 2, k]
        if k != j:
            sb = half[b, k] * (1.0 if lx * rot[b, 0, k] + ly * rot[b, 1, k]
                               + lz * rot[b, 2, k] > 0.0 else -1.0)
            pbx += sb * rot[b, 0, k]
            pby += sb * rot[b, 1, k]
            pbz += sb * rot[b, 2, k]
    # The point of the line p_a + σ A_i closest to the line p_b + τ B_j, kept on a's edge.
    ax, ay, az = rot[a, 0, i], rot[a, 1, i], rot[a, 2, i]
    bx, by, bz = rot[b, 0, j], rot[b, 1, j], rot[b, 2, j]
    rx, ry, rz = pax - pbx, pay - pby, paz - pbz
    c = ax * bx + ay * by + az * bz
    e1 = ax * rx + ay * ry + az * rz
    e2 = bx * rx + by * ry + bz * rz
    sigma = (c * e2 - e1) / (1.0 - c * c)
    sigma = min(max(sigma, -half[a, i]), half[a, i])
    out[0, 0] = s
    out[0, 1] = pax + sigma * ax
    out[0, 2] = pay + sigma * ay
    out[0, 3] = paz + sigma * az
    return 1, lx, ly, lz, a
