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
Contact points of one shape against the φ of the other, at the candidate poses.

Surface points in cells (:func:`_one_way`), two boxes (:mod:`~rbd_ros.core.contact.box_box`)
and the lowest points against a plane in closed form (:func:`_plane_points`).
"""

import math

from rbd_ros.core.contact import box_box as bb
from rbd_ros.core.contact import kernels as ck
from rbd_ros.core.contact.linalg import _mat_t_vec, _mat_vec
from rbd_ros.core.contact.rows import _inl, _raw, CULL_SLACK_M, PHI_LIPSCHITZ_MESH


@_inl
def _grid_of(grid_data, grid_off, grid_dim, s):
    o = grid_off[s]
    nx, ny, nz = grid_dim[s, 0], grid_dim[s, 1], grid_dim[s, 2]
    return grid_data[o:o + nx * ny * nz].reshape((nx, ny, nz))


@_inl
def _push_point(buf, count, phi, rx, ry, rz, pos_x, ix, gwx, gwy, gwz, lx, ly, lz, flip):
    """Append a row ``[φ, point_w(3), n_w(3), point_y(3), flip]`` to ``buf`` (point = pos + r)."""
    buf[count, 0] = phi
    buf[count, 1] = pos_x[ix, 0] + rx
    buf[count, 2] = pos_x[ix, 1] + ry
    buf[count, 3] = pos_x[ix, 2] + rz
    buf[count, 4] = flip * gwx
    buf[count, 5] = flip * gwy
    buf[count, 6] = flip * gwz
    buf[count, 7] = lx
    buf[count, 8] = ly
    buf[count, 9] = lz
    buf[count, 10] = flip
    return count + 1


@_raw
def _one_way(sx, sy, pts, pt_off, balls, ball_off, cell_of, near, pt_radius, kinds, sparams,
             grid_data, grid_off, grid_dim, rot_x, pos_x, rot_xc, pos_xc, ix, rot_yc, pos_yc,
             iy, margin, buf, count, flip):
    """
    Append the points of shape ``sx`` that come near shape ``sy`` (not a plane) to ``buf``.

    Points of ``sx`` (pose index ``ix``) within ``margin`` of ``sy`` at the candidate poses
    become rows ``[φ, point_w(3), n_w(3), point_y(3), flip]``: ``n_w = flip ∇φ_y`` in the
    world, the point in y's candidate frame.  ``buf`` has room for every point.  Return the
    new count.

    The points are grouped in cells of at most :data:`CHUNK_POINTS` with a ball around each
    (``balls``, ``ball_off`` per shape; ``cell_of`` per point, its cell's index among its
    shape's cells): a cell is skipped when φ at its centre, less the ball's radius times φ's
    Lipschitz bound, is beyond the margin, for then none of its points is within reach.  The
    points left are tried in their own order, so the rows are exactly those without the
    test.  ``near`` is scratch, a flag per cell of ``sx``.
    """
    radius = pt_radius[sx]
    kind = kinds[sy]
    grid = _grid_of(grid_data, grid_off, grid_dim, sy)
    prm = sparams[sy]
    lipschitz = PHI_LIPSCHITZ_MESH if kind == ck.KIND_MESH else 1.0
    c0 = ball_off[sx]
    # Every cell's flag is set before it is read.  A shape of one cell (a sphere's centre, a
    # small capsule's axis) is simply tried: its test would cost what trying it costs.
    near[0] = True
    first = c0 + 1 if ball_off[sx + 1] - c0 == 1 else c0
    for ci in range(first, ball_off[sx + 1]):
        wx, wy, wz = _mat_vec(rot_xc, ix, balls[ci, 0], balls[ci, 1], balls[ci, 2])
        lx, ly, lz = _mat_t_vec(rot_yc, iy, wx + pos_xc[ix, 0] - pos_yc[iy, 0],
                                wy + pos_xc[ix, 1] - pos_yc[iy, 1],
                                wz + pos_xc[ix, 2] - pos_yc[iy, 2])
        phi = ck.phi_grad(kind, prm, grid, lx, ly, lz)[0]
        near[ci - c0] = phi - radius - lipschitz * balls[ci, 3] < margin + CULL_SLACK_M
    for n in range(pt_off[sx], pt_off[sx + 1]):
        if not near[cell_of[n]]:
            continue
        bx, by, bz = pts[n, 0], pts[n, 1], pts[n, 2]
        # Candidate world point, then into y's candidate frame.
        wx, wy, wz = _mat_vec(rot_xc, ix, bx, by, bz)
        wx, wy, wz = wx + pos_xc[ix, 0], wy + pos_xc[ix, 1], wz + pos_xc[ix, 2]
        lx, ly, lz = _mat_t_vec(rot_yc, iy, wx - pos_yc[iy, 0], wy - pos_yc[iy, 1],
                                wz - pos_yc[iy, 2])
        phi, gx, gy, gz = ck.phi_grad(kind, prm, grid, lx, ly, lz)
        phi -= radius
        if not phi < margin:
            continue
        gwx, gwy, gwz = _mat_vec(rot_yc, iy, gx, gy, gz)
        # The contact point on x's surface in the current configuration.
        rx, ry, rz = _mat_vec(rot_x, ix, bx, by, bz)
        count = _push_point(buf, count, phi, rx - radius * gwx, ry - radius * gwy,
                            rz - radius * gwz, pos_x, ix, gwx, gwy, gwz, lx, ly, lz, flip)
    return count


@_raw
def _box_points(a, b, sparams, pose_r, pose_p, pose_rc, pose_pc, margin, clip, buf):
    """
    Fill ``buf`` with the points of boxes ``a`` and ``b`` as :func:`_one_way` would.

    The points and their depths come from :func:`box_box.box_box` at the candidate poses:
    points of one box's face clipped by the other's (or one point edge on edge), all with the
    one normal of the separating axis.  Each is a material point of its box, so its row has
    where that point is now.  Return the count.
    """
    count, nx, ny, nz, ix = bb.box_box(sparams, pose_rc, pose_pc, a, b, margin, clip, buf)
    iy = b if ix == a else a
    flip = 1.0 if ix == a else -1.0
    for k in range(count):
        bx, by, bz = _mat_t_vec(pose_rc, ix, buf[k, 1] - pose_pc[ix, 0],
                                buf[k, 2] - pose_pc[ix, 1], buf[k, 3] - pose_pc[ix, 2])
        rx, ry, rz = _mat_vec(pose_r, ix, bx, by, bz)
        lx, ly, lz = _mat_t_vec(pose_rc, iy, buf[k, 1] - pose_pc[iy, 0],
                                buf[k, 2] - pose_pc[iy, 1], buf[k, 3] - pose_pc[iy, 2])
        _push_point(buf, k, buf[k, 0], rx, ry, rz, pose_p, ix, flip * nx, flip * ny,
                    flip * nz, lx, ly, lz, flip)
    return count


#: A cylinder tilted less than this (rad) from a plane's normal rests on the points of its rim
#: at fixed angles in its frame (the lowest point's direction is round-off there).
RIM_UPRIGHT_RAD = 1e-9


@_inl
def _rim_angle(nx, ny):
    """Return the angle in a cylinder's frame of its rim's lowest point for the normal ``n``."""
    if nx * nx + ny * ny <= RIM_UPRIGHT_RAD * RIM_UPRIGHT_RAD:
        return 0.0
    return math.atan2(-ny, -nx)


@_inl
def _support_ellipsoid(sparams, s, nx, ny, nz):
    """Return the point of ellipsoid ``s`` lowest along the unit normal ``n`` (its frame)."""
    ax, ay, az = sparams[s, 0] * nx, sparams[s, 1] * ny, sparams[s, 2] * nz
    size = math.sqrt(ax * ax + ay * ay + az * az)
    return -sparams[s, 0] * ax / size, -sparams[s, 1] * ay / size, -sparams[s, 2] * az / size


@_inl
def _push_plane_point(buf, count, phi, bx, by, bz, cx, cy, cz, radius, rot_x, pos_x, rot_xc,
                      pos_xc, ix, rot_yc, pos_yc, iy, gwx, gwy, gwz):
    """
    Append a point of x near the plane y (normal ``gw``) to ``buf`` as :func:`_push_point`.

    ``b`` (x's frame) is the point in the candidate pose, at φ; ``c`` (x's frame) is where the
    impulse acts in the current pose (``b`` for a material point), ``radius`` below it.
    """
    wx, wy, wz = _mat_vec(rot_xc, ix, bx, by, bz)
    lx, ly, lz = _mat_t_vec(rot_yc, iy, wx + pos_xc[ix, 0] - pos_yc[iy, 0],
                            wy + pos_xc[ix, 1] - pos_yc[iy, 1],
                            wz + pos_xc[ix, 2] - pos_yc[iy, 2])
    rx, ry, rz = _mat_vec(rot_x, ix, cx, cy, cz)
    return _push_point(buf, count, phi, rx - radius * gwx, ry - radius * gwy,
                       rz - radius * gwz, pos_x, ix, gwx, gwy, gwz, lx, ly, lz, 1.0)


@_inl
def _plane_points(sx, sy, kinds, ppts, ppt_off, pt_radius, sparams, rot_x, pos_x, rot_xc,
                  pos_xc, ix, rot_yc, pos_yc, iy, margin, buf):
    """
    Fill ``buf`` with the points of shape ``sx`` near the plane ``sy`` as :func:`_one_way`.

    A plane's φ is linear: ``φ(b) = n_x · b + offset`` for a point ``b`` in x's frame, with
    the plane normal ``n_x`` in x's candidate frame (3 products a point instead of a pose
    change).  Only the points that can be lowest (``ppts``) are tried; a cylinder's and an
    ellipsoid's are in closed form instead (a cylinder's sampled rims made it roll as a
    polygon: down 20° for 1 s it fell 10 % short at 1 ms, 18 % at 10 ms).  Return the count.
    """
    radius = pt_radius[sx]
    gwx, gwy, gwz = _mat_vec(rot_yc, iy, sparams[sy, 0], sparams[sy, 1], sparams[sy, 2])
    pnx, pny, pnz = _mat_t_vec(rot_xc, ix, gwx, gwy, gwz)
    offset = (gwx * (pos_xc[ix, 0] - pos_yc[iy, 0]) + gwy * (pos_xc[ix, 1] - pos_yc[iy, 1])
              + gwz * (pos_xc[ix, 2] - pos_yc[iy, 2]) - sparams[sy, 3] - radius)
    count = 0
    if kinds[sx] == ck.KIND_CYLINDER:
        # Each rim circle's lowest point in closed form, and the points a quarter, a half and
        # three quarters round from it (a cylinder on its cap rests on those four).  φ comes
        # from the candidate pose; the impulse acts where the same point is now (its angle
        # from the current normal): a rolling cylinder turns h ω a step, and the candidate's
        # lowest material point, ahead of the contact line now, would brake it.
        qnx, qny, qnz = _mat_t_vec(rot_x, ix, gwx, gwy, gwz)
        r, hl = sparams[sx, 0], sparams[sx, 1]
        cand = _rim_angle(pnx, pny)
        now = _rim_angle(qnx, qny)
        for side in (-1.0, 1.0):
            for quarter in range(4):
                turn = 0.5 * math.pi * quarter
                bx, by, bz = r * math.cos(cand + turn), r * math.sin(cand + turn), side * hl
                phi = pnx * bx + pny * by + pnz * bz + offset
                if phi < margin:
                    count = _push_plane_point(
                        buf, count, phi, bx, by, bz, r * math.cos(now + turn),
                        r * math.sin(now + turn), bz, radius, rot_x, pos_x, rot_xc, pos_xc,
                        ix, rot_yc, pos_yc, iy, gwx, gwy, gwz)
        return count
    if kinds[sx] == ck.KIND_ELLIPSOID:
        # The support point −A² n / |A n| (A = diag of the semi-axes), as for the cylinder.
        bx, by, bz = _support_ellipsoid(sparams, sx, pnx, pny, pnz)
        phi = pnx * bx + pny * by + pnz * bz + offset
        if phi < margin:
            qnx, qny, qnz = _mat_t_vec(rot_x, ix, gwx, gwy, gwz)
            cx, cy, cz = _support_ellipsoid(sparams, sx, qnx, qny, qnz)
            count = _push_plane_point(buf, count, phi, bx, by, bz, cx, cy, cz, radius, rot_x,
                                      pos_x, rot_xc, pos_xc, ix, rot_yc, pos_yc, iy, gwx, gwy,
                                      gwz)
        return count
    for n in range(ppt_off[sx], ppt_off[sx + 1]):
        bx, by, bz = ppts[n, 0], ppts[n, 1], ppts[n, 2]
        phi = pnx * bx + pny * by + pnz * bz + offset
        if phi < margin:
            count = _push_plane_point(buf, count, phi, bx, by, bz, bx, by, bz, radius, rot_x,
                                      pos_x, rot_xc, pos_xc, ix, rot_yc, pos_yc, iy, gwx, gwy,
                                      gwz)
    return count
