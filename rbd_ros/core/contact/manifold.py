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
From a pair's contact points to a patch: one normal, at most four points.

:func:`_consistent_normals` gives the points one consistent normal; :func:`_reduce` keeps at
most :data:`~rbd_ros.core.contact.rows.PATCH_POINTS` of them.
"""

import math

import numpy as np

from rbd_ros.core.contact import kernels as ck
from rbd_ros.core.contact.linalg import _cross, _mat_t_vec
from rbd_ros.core.contact.points import _grid_of
from rbd_ros.core.contact.rows import (_jit, _raw, DEPTH_READ_ERROR_M, FLUSH_DEPTH_MIN_M, MARGIN_M,
                                       PATCH_POINTS, REDUCE_DEPTH_WEIGHT)


@_jit
def _consistent_normals(buf, count, a, b, kinds, sparams, grid_data, grid_off, grid_dim,
                        pose_rc):
    """
    Give points on an edge or corner of the other shape their patch's normal; return it.

    (Two boxes never come here: :func:`_box_points` gives their points one normal.  The box
    examples below are how this was found; it serves every other pair, a mesh's or a
    cylinder's face on a box's, say.)

    ∇φ is ambiguous where the shape it is taken of has an edge or a corner: a box placed
    exactly on another has its bottom edges on the lower box's top edges, where φ's gradient
    may point sideways, and a corner a hair outside the lower box's footprint gets a gradient
    tilted by anything up to 90° from the round-off of its position.

    The patch normal ``n̄``: the candidates are the deepest point of each distinct normal, in
    order of depth, up to 16 normals (where faces lie flush every point ties in φ to
    round-off, so the deepest 16 points may all be edge points).  The candidate with the
    largest depth-weighted support within ~25° (cos > 0.9) gives the patch's direction;
    among the candidates in that cone, the one whose own normal has the largest support (to
    ~1e-6 rad: one face seen from either shape) is ``n̄``: the face's normal, not a tilted
    edge normal in the cone's middle, whose wide support also takes in the tilted normals on
    its side.  A tilt matters however small: one below atan μ makes the patch a self-locking
    wedge whose normal and friction impulses can grow without bound.

    Any other point takes ``n̄`` if ``n̄`` is also a normal of the surface there (in its
    normal cone): a step of :data:`MARGIN_M` / 4 out of the other shape along ``n̄`` raises
    φ by the step (to 1 %; on a smooth surface that holds within ~8° of ``n̄``).  Its φ then
    becomes its depth along ``n̄`` as the step measures it, ``φ(p + step n̄) − step``, where
    that is deeper by more than :data:`FLUSH_DEPTH_MIN_M` (and by at most 1 % of the step,
    which the cone test allows) and the step left the other shape along ``n̄`` (∇φ there is
    ``n̄`` to within :data:`DEPTH_READ_ERROR_M`): an upper box's corner on the lower box's
    side plane has φ = the distance to that side, about 0, however deep it is below the top
    face, so a sinking would show no depth to push out and the stack would creep down.  (A
    point a distance e outside the other box's side reads ~e² / (2 step) less than the
    face's depth: at most 1.3e-8 m where the cone test passes, a fixed offset, not a creep.)
    A point deeper than the step stays on that side plane for the whole step (a box dropped
    onto an equal box, its corners on the lower box's side faces, or two equal boxes meeting
    face on): where the patch is deeper than the step, such a point steps out from the
    patch's depth instead and takes ``n̄`` if it has left the other shape there and φ then
    rises along ``n̄`` as the step (its depth is the difference).  Before, those corners kept
    their side normals and φ = 0: one interior point took the whole impulse, off centre (two
    equal boxes meeting face on at ε = 1 came apart spinning with 57 % of the energy; a box
    dropped on an equal one came to rest tilted, 1.7 mm deep in it at 10 ms).  A peg
    touching the side of a hole fails both tests and keeps its own normal and φ.
    """
    order = np.argsort(buf[:count, 0])
    cand = np.empty(16, dtype=np.int64)
    n_cand = 0
    for ii in range(count):
        i = order[ii]
        fresh = True
        for c in range(n_cand):
            j = cand[c]
            if buf[i, 4] == buf[j, 4] and buf[i, 5] == buf[j, 5] and buf[i, 6] == buf[j, 6]:
                fresh = False
                break
        if fresh:
            cand[n_cand] = i
            n_cand += 1
            if n_cand == 16:
                break
    wide = np.empty(16)
    tight = np.empty(16)
    best = 0
    for c in range(n_cand):
        i = cand[c]
        w = 0.0
        t = 0.0
        for k in range(count):
            d = buf[k, 4] * buf[i, 4] + buf[k, 5] * buf[i, 5] + buf[k, 6] * buf[i, 6]
            if d > 0.9:
                w += MARGIN_M - buf[k, 0]
                if d > 1.0 - 1e-12:
                    t += MARGIN_M - buf[k, 0]
        wide[c] = w
        tight[c] = t
        if w > wide[best]:
            best = c
    i = cand[best]
    top = best
    for c in range(n_cand):
        j = cand[c]
        if (tight[c] > tight[top] and buf[j, 4] * buf[i, 4] + buf[j, 5] * buf[i, 5]
                + buf[j, 6] * buf[i, 6] > 0.9):
            top = c
    best = cand[top]
    sx, sy, sz = buf[best, 4], buf[best, 5], buf[best, 6]
    step = 0.25 * MARGIN_M
    # A step that leaves the other shape from as deep as the patch's deepest point.
    reach = step - min(buf[order[0], 0], 0.0)
    for k in range(count):
        if buf[k, 4] == sx and buf[k, 5] == sy and buf[k, 6] == sz:
            continue
        # The shape whose φ gave this point: b for flip +1 (n = ∇φ_b), a for flip −1.
        y = b if buf[k, 10] > 0.0 else a
        # Out of y along n̄ (+n̄ for y = b, whose outward normal it is; −n̄ for y = a).
        dx, dy, dz = buf[k, 10] * sx, buf[k, 10] * sy, buf[k, 10] * sz
        lx, ly, lz = _mat_t_vec(pose_rc, y, dx, dy, dz)
        grid = _grid_of(grid_data, grid_off, grid_dim, y)
        phi0 = ck.phi_grad(kinds[y], sparams[y], grid, buf[k, 7], buf[k, 8], buf[k, 9])[0]
        phi1, gx, gy, gz = ck.phi_grad(kinds[y], sparams[y], grid, buf[k, 7] + step * lx,
                                       buf[k, 8] + step * ly, buf[k, 9] + step * lz)
        out = step
        if abs((phi1 - phi0) - step) > 0.01 * step and reach > step:
            # Deeper than the step, a point on the other shape's side plane (a box dropped
            # onto an equal box: its bottom corners lie on the lower box's side faces) stays
            # on it for the whole step, φ = 0.  Step out from the patch's depth instead:
            # where n̄ is the normal the point leaves by, φ then rises along n̄ as the step.
            out = reach
            phi1, gx, gy, gz = ck.phi_grad(kinds[y], sparams[y], grid, buf[k, 7] + reach * lx,
                                           buf[k, 8] + reach * ly, buf[k, 9] + reach * lz)
            phi2 = ck.phi_grad(kinds[y], sparams[y], grid, buf[k, 7] + (reach + step) * lx,
                               buf[k, 8] + (reach + step) * ly,
                               buf[k, 9] + (reach + step) * lz)[0]
            if not (phi1 > 0.0 and abs((phi2 - phi1) - step) <= 0.01 * step):
                continue
        elif abs((phi1 - phi0) - step) > 0.01 * step:
            continue
        buf[k, 4] = sx
        buf[k, 5] = sy
        buf[k, 6] = sz
        # (buf's φ is phi0 less the point radius: shift it by the same difference.)
        # (A step that left by a face tilted from n̄ reads too deep: see DEPTH_READ_ERROR_M.)
        deeper = (phi1 - out) - phi0
        if (deeper < -FLUSH_DEPTH_MIN_M
                and out * (1.0 - (gx * lx + gy * ly + gz * lz)) <= DEPTH_READ_ERROR_M):
            buf[k, 0] += deeper
    return sx, sy, sz


@_raw
def _reduce(buf, count, keep, nx, ny, nz):
    """
    Choose up to PATCH_POINTS rows of ``buf[:count]`` spanning the patch; fill ``keep``.

    Areas are measured across the patch normal ``n`` (not a point's own normal, which may be
    an edge's sideways one).
    """
    if count <= PATCH_POINTS:
        for k in range(count):
            keep[k] = k
        return count
    best = 0
    for k in range(1, count):
        if buf[k, 0] < buf[best, 0]:
            best = k
    keep[0] = best
    # Extreme points are scored by distance less REDUCE_DEPTH_WEIGHT × φ: of two points at
    # nearly the same place the deeper one wins (a box on an equal box: the lower box's top
    # corner, pushed a hair outside the upper box's footprint, has φ = that offset sideways,
    # while the upper box's own corner beside it has the true depth 0).
    far = -math.inf
    i1 = -1
    for k in range(count):
        d = math.sqrt((buf[k, 1] - buf[best, 1]) ** 2 + (buf[k, 2] - buf[best, 2]) ** 2
                      + (buf[k, 3] - buf[best, 3]) ** 2) - REDUCE_DEPTH_WEIGHT * buf[k, 0]
        if d > far:
            far = d
            i1 = k
    far = ((buf[i1, 1] - buf[best, 1]) ** 2 + (buf[i1, 2] - buf[best, 2]) ** 2
           + (buf[i1, 3] - buf[best, 3]) ** 2)
    if far <= 1e-24:
        return 1
    # Where depths tie (a face resting on a face), the extreme point farthest from i1 spans
    # more of the patch than the deepest one: take it unless the deepest is clearly deeper.
    far0 = -math.inf
    i0 = best
    for k in range(count):
        d = math.sqrt((buf[k, 1] - buf[i1, 1]) ** 2 + (buf[k, 2] - buf[i1, 2]) ** 2
                      + (buf[k, 3] - buf[i1, 3]) ** 2) - REDUCE_DEPTH_WEIGHT * buf[k, 0]
        if d > far0:
            far0 = d
            i0 = k
    far0 = ((buf[i0, 1] - buf[i1, 1]) ** 2 + (buf[i0, 2] - buf[i1, 2]) ** 2
            + (buf[i0, 3] - buf[i1, 3]) ** 2)
    if buf[i0, 0] <= buf[best, 0] + 0.1 * MARGIN_M:
        best = i0
        keep[0] = best
        far = far0
    keep[1] = i1
    ex = buf[i1, 1] - buf[best, 1]
    ey = buf[i1, 2] - buf[best, 2]
    ez = buf[i1, 3] - buf[best, 3]
    span = math.sqrt(far)
    area = 0.0
    i2 = -1
    for k in range(count):
        cx, cy, cz = _cross(ex, ey, ez, buf[k, 1] - buf[best, 1], buf[k, 2] - buf[best, 2],
                            buf[k, 3] - buf[best, 3])
        s = abs(cx * nx + cy * ny + cz * nz) - REDUCE_DEPTH_WEIGHT * span * buf[k, 0]
        if s > area:
            area = s
            i2 = k
    if i2 < 0:
        return 2
    cx, cy, cz = _cross(ex, ey, ez, buf[i2, 1] - buf[best, 1], buf[i2, 2] - buf[best, 2],
                        buf[i2, 3] - buf[best, 3])
    if abs(cx * nx + cy * ny + cz * nz) <= 1e-12 * far:
        return 2
    keep[2] = i2
    cx, cy, cz = _cross(ex, ey, ez, buf[i2, 1] - buf[best, 1], buf[i2, 2] - buf[best, 2],
                        buf[i2, 3] - buf[best, 3])
    side = cx * nx + cy * ny + cz * nz
    area = 0.0
    i3 = -1
    for k in range(count):
        cx, cy, cz = _cross(ex, ey, ez, buf[k, 1] - buf[best, 1], buf[k, 2] - buf[best, 2],
                            buf[k, 3] - buf[best, 3])
        s = -(cx * nx + cy * ny + cz * nz) * (1.0 if side > 0.0 else -1.0)
        if s <= 1e-12 * far:
            continue
        s -= REDUCE_DEPTH_WEIGHT * span * buf[k, 0]
        if s > area:
            area = s
            i3 = k
    if i3 < 0:
        return 3
    keep[3] = i3
    return 4
