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
Narrow phase: the contact and patch tables of one stage from the broad phase's pairs.

Per pair: its points, their normals and reduction, then one patch row; the responses of
patches on static objects are kept for the next stage (:func:`keep_responses`).
"""

import math

import numpy as np

from rbd_ros.core.contact import box_box as bb
from rbd_ros.core.contact import kernels as ck
from rbd_ros.core.contact.linalg import _cross, _one_normal
from rbd_ros.core.contact.manifold import _consistent_normals, _reduce
from rbd_ros.core.contact.points import _box_points, _one_way, _plane_points
from rbd_ros.core.contact.response import _point_velocity
from rbd_ros.core.contact.rows import (_inl, _jit, _raw, C_A, C_B, C_BIAS, C_NORMAL, C_PHASE,
                                       C_PHI, C_POINT, C_RA, C_RB, C_TARGET, C_TOUCH_U, MARGIN_M,
                                       N_CONTACT, N_PATCH, pair_material, PATCH_POINTS,
                                       PHASE_COLLISION, PUSH_FRACTION, PUSH_MAX_M_S, Q_A, Q_B,
                                       Q_CACHED, Q_COUNT, Q_EPS, Q_K, Q_MU, Q_PINV, Q_START,
                                       R_COUNT, R_INV_INERTIA, R_INV_MASS, R_K, R_PINV, R_ROWS,
                                       R_STATIC, TOUCH_M)
from rbd_ros.core.layout import P_GRAVITY, S_POS


@_inl
def _touching(buf, count, vel, x, a, b, n_bodies, h, v_rest):
    """
    Keep the rows of ``buf`` in resting contact now; return their count.

    The contact stage after ``midpoint_cayley``'s second half kick looks ahead over the next
    step's drift, which the next step's collision stage (with restitution) looks at first: it
    must not stop an approaching body early, so it keeps only the points in contact now
    (``φ_now <= TOUCH_M``) that approach no faster than the half kick of gravity can make
    them (``u_n >= −v_rest``); faster ones are impacts, left to the collision stage.
    """
    kept = 0
    for k in range(count):
        px, py, pz = buf[k, 1], buf[k, 2], buf[k, 3]
        ux, uy, uz = _point_velocity(vel, a, px - x[S_POS, a], py - x[S_POS + 1, a],
                                     pz - x[S_POS + 2, a])
        if b < n_bodies:
            bx, by, bz = _point_velocity(vel, b, px - x[S_POS, b], py - x[S_POS + 1, b],
                                         pz - x[S_POS + 2, b])
            ux, uy, uz = ux - bx, uy - by, uz - bz
        un0 = ux * buf[k, 4] + uy * buf[k, 5] + uz * buf[k, 6]
        if buf[k, 0] - h * un0 <= TOUCH_M and un0 >= -v_rest:
            if kept != k:
                for f in range(buf.shape[1]):
                    buf[kept, f] = buf[k, f]
            kept += 1
    return kept


@_jit
def narrow_phase(pairs, n_bodies, x, prm, work, statics, shapes, h, phase, stage):
    """
    Return ``(contacts (C, N_CONTACT), patches (Q, N_PATCH))`` of the candidate ``pairs``.

    ``work`` is the bodies' :class:`~rbd_ros.core.contact.rows.Work` (filled by
    :func:`~rbd_ros.core.contact.bodies.prepare_bodies`), ``statics`` the static objects'
    :class:`~rbd_ros.core.contact.rows.Statics`, ``shapes`` the
    :class:`~rbd_ros.core.contact.rows.Shapes` table.

    Static objects get their fixed pose for both the current and the candidate one.  A patch
    on a static object whose response is in ``responses`` (see :data:`R_STATIC`) starts with
    it (:func:`keep_responses` fills the table).
    """
    n = n_bodies
    vel, inv_mass, inv_inertia_w = work.vel, work.inv_mass, work.inv_inertia_w
    rot, pos_c, rot_c, responses = work.rot, work.pos_c, work.rot_c, work.responses
    st_rot, st_pos = statics.rot, statics.pos
    # Read out of the named tuples once, here: each read inside the loop below would take a
    # reference count (two atomic updates) per pair (see the step's "Reference counts").
    kinds, sparams, pt_off, ppt_off = shapes.kinds, shapes.sparams, shapes.pt_off, shapes.ppt_off
    grid_data, grid_off, grid_dim = shapes.grid_data, shapes.grid_off, shapes.grid_dim
    mu, eps = shapes.mu, shapes.eps
    n_static = st_rot.shape[0]
    # Poses of everything, bodies then statics, current and candidate.
    pose_r = np.empty((n + n_static, 3, 3))
    pose_p = np.empty((n + n_static, 3))
    pose_rc = np.empty((n + n_static, 3, 3))
    pose_pc = np.empty((n + n_static, 3))
    pose_r[:n] = rot
    pose_rc[:n] = rot_c
    pose_p[:n] = x[S_POS:S_POS + 3, :].T
    pose_pc[:n] = pos_c
    pose_r[n:] = st_rot
    pose_rc[n:] = st_rot
    pose_p[n:] = st_pos
    pose_pc[n:] = st_pos
    # Not zeroed (a megabyte per stage for 1000 bodies): each row is filled when it is used.
    # A pair gives at most one patch of at most PATCH_POINTS points.
    contacts = np.empty((PATCH_POINTS * pairs.shape[0], N_CONTACT))
    patches = np.empty((pairs.shape[0], N_PATCH))
    # Room for every point of the two shapes of any pair.
    most = 0
    for s in range(pt_off.shape[0] - 1):
        most = max(most, pt_off[s + 1] - pt_off[s], ppt_off[s + 1] - ppt_off[s])
    buf = np.empty((2 * most + 1, 11))
    near = np.empty(most + 1, dtype=np.bool_)  # per cell of a shape: within reach
    clip = np.empty((bb.CLIP_ROWS, bb.CLIP_COLS))  # box on box: the clipped face
    keep = np.empty(PATCH_POINTS, dtype=np.int64)
    # The pairs are made in _pair_rows, which allocates nothing; it hands back a pair whose
    # normals differ, for _consistent_normals (which allocates) to give one here.
    nc = 0
    nq = 0
    q = 0
    count = -1
    pnx = pny = pnz = 0.0
    while True:
        q, count, nc, nq = _pair_rows(pairs, q, count, pnx, pny, pnz, n, x, prm, vel, inv_mass,
                                      inv_inertia_w, mu, eps, responses, pose_r, pose_p,
                                      pose_rc, pose_pc, shapes, h, phase, stage, buf, near,
                                      clip, keep, contacts, patches, nc, nq)
        if q == pairs.shape[0]:
            break
        pnx, pny, pnz = _consistent_normals(buf, count, pairs[q, 0], pairs[q, 1], kinds, sparams,
                                            grid_data, grid_off, grid_dim, pose_rc)
    return contacts[:nc], patches[:nq]


@_raw
def _pair_rows(pairs, q, count, pnx, pny, pnz, n, x, prm, vel, inv_mass, inv_inertia_w, mu, eps,
               responses, pose_r, pose_p, pose_rc, pose_pc, shapes, h, phase, stage, buf, near,
               clip, keep, contacts, patches, nc, nq):
    """
    Make the patches of ``pairs`` from pair ``q`` on; return ``(q, count, nc, nq)``.

    ``nc``, ``nq``: the next free contact and patch rows.  ``count`` >= 0: pair ``q``'s points
    are in ``buf`` already (``count`` of them) and ``pn`` is their patch normal.  Returns at the
    end (``q`` = the number of pairs, ``count`` -1), or at a pair whose points' normals differ
    (its index, its points in ``buf``): the caller gives them one normal
    (:func:`_consistent_normals`, which allocates) and calls again with it.  One call makes
    every pair of a stage but those: :func:`_pair_points` and :func:`_pair_patch` are inlined
    here, where a call of each per pair copied their ~40 arrays' fields (~3 kB) onto the stack,
    a third of the narrow phase of 100 boxes on a floor.
    """
    while q < pairs.shape[0]:
        a = pairs[q, 0]
        b = pairs[q, 1]
        if count < 0:
            count, mixed = _pair_points(a, b, n, x, prm, vel, pose_r, pose_p, pose_rc, pose_pc,
                                        shapes, h, stage, buf, near, clip)
            if count == 0:
                q += 1
                count = -1
                continue
            if mixed:
                return q, count, nc, nq
            pnx, pny, pnz = buf[0, 4], buf[0, 5], buf[0, 6]
        nc = _pair_patch(a, b, n, x, vel, inv_mass, inv_inertia_w, mu, eps, h, phase, stage,
                         responses, buf, count, keep, pnx, pny, pnz, contacts, patches, nc, nq)
        nq += 1
        q += 1
        count = -1
    return q, -1, nc, nq


@_inl
def _pair_points(a, b, n, x, prm, vel, pose_r, pose_p, pose_rc, pose_pc, shapes, h, stage, buf,
                 near, clip):
    """
    Fill ``buf`` with the contact points of the pair ``(a, b)`` (see :func:`_one_way`).

    Return their count and whether their normals differ.
    """
    kinds, sparams, pts, pt_off = shapes.kinds, shapes.sparams, shapes.pts, shapes.pt_off
    ppts, ppt_off, pt_radius = shapes.ppts, shapes.ppt_off, shapes.pt_radius
    grid_data, grid_off, grid_dim = shapes.grid_data, shapes.grid_off, shapes.grid_dim
    balls, ball_off, cell_of = shapes.balls, shapes.ball_off, shapes.cell_of
    if kinds[b] == ck.KIND_PLANE:
        count = _plane_points(a, b, kinds, ppts, ppt_off, pt_radius, sparams, pose_r,
                              pose_p, pose_rc, pose_pc, a, pose_rc, pose_pc, b, MARGIN_M,
                              buf)
    elif kinds[a] == ck.KIND_BOX and kinds[b] == ck.KIND_BOX:
        count = _box_points(a, b, sparams, pose_r, pose_p, pose_rc, pose_pc, MARGIN_M, clip,
                            buf)
    else:
        # A sphere touches a convex primitive (any shape but a mesh, each φ exact) at one
        # point, which its centre against the other's φ finds exactly; the other's points
        # against the sphere's φ find only near-copies of it.  Two spheres had a patch of two,
        # a lever arm apart, whose response (condition ~1e5) let the collisions of a break of
        # 15 balls at ε = 1 gain 3e-12 of the energy.
        count = 0
        if not (kinds[b] == ck.KIND_SPHERE and kinds[a] != ck.KIND_MESH
                and kinds[a] != ck.KIND_SPHERE):
            count = _one_way(a, b, pts, pt_off, balls, ball_off, cell_of, near, pt_radius,
                             kinds, sparams, grid_data, grid_off, grid_dim, pose_r, pose_p,
                             pose_rc, pose_pc, a, pose_rc, pose_pc, b, MARGIN_M, buf, 0, 1.0)
        if not (kinds[a] == ck.KIND_SPHERE and kinds[b] != ck.KIND_MESH):
            count = _one_way(b, a, pts, pt_off, balls, ball_off, cell_of, near, pt_radius,
                             kinds, sparams, grid_data, grid_off, grid_dim, pose_r, pose_p,
                             pose_rc, pose_pc, b, pose_rc, pose_pc, a, MARGIN_M, buf, count,
                             -1.0)
    if stage == 2:
        ja = 0 if prm.shape[1] == 1 else a
        v_rest = 1e-9 + h * math.sqrt(prm[P_GRAVITY, ja] ** 2 + prm[P_GRAVITY + 1, ja] ** 2
                                      + prm[P_GRAVITY + 2, ja] ** 2)
        if b < n:
            jb = 0 if prm.shape[1] == 1 else b
            v_rest += h * math.sqrt(prm[P_GRAVITY, jb] ** 2 + prm[P_GRAVITY + 1, jb] ** 2
                                    + prm[P_GRAVITY + 2, jb] ** 2)
        count = _touching(buf, count, vel, x, a, b, n, h, v_rest)
    return count, count > 1 and not _one_normal(buf, 0, count, 4)


@_inl
def _pair_patch(a, b, n, x, vel, inv_mass, inv_inertia_w, mu, eps, h, phase, stage, responses,
                buf, count, keep, pnx, pny, pnz, contacts, patches, nc, nq):
    """
    Make patch ``nq`` of the pair ``(a, b)`` from its ``count`` points in ``buf``.

    ``pn``: the patch normal.  The contact rows start at ``nc``; return the next free row.
    """
    if count <= PATCH_POINTS:  # all of them (as _reduce would say, without the call)
        m = count
        for k in range(m):
            keep[k] = k
    else:
        m = _reduce(buf, count, keep, pnx, pny, pnz)
    pair_mu, pair_eps = pair_material(mu[a], eps[a], mu[b], eps[b])
    if phase != PHASE_COLLISION:
        pair_eps = 0.0
    static_b = b >= n
    for f in range(Q_K):
        patches[nq, f] = 0.0
    patches[nq, Q_A] = a
    patches[nq, Q_B] = b
    patches[nq, Q_START] = nc
    patches[nq, Q_COUNT] = m
    patches[nq, Q_MU] = pair_mu
    patches[nq, Q_EPS] = pair_eps
    for k in range(m):
        r = keep[k]
        c = nc
        for f in range(N_CONTACT):
            contacts[c, f] = 0.0
        contacts[c, C_A] = a
        contacts[c, C_B] = b
        contacts[c, C_PHASE] = stage
        contacts[c, C_PHI] = buf[r, 0]
        px, py, pz = buf[r, 1], buf[r, 2], buf[r, 3]
        nx, ny, nz = buf[r, 4], buf[r, 5], buf[r, 6]
        contacts[c, C_POINT] = px
        contacts[c, C_POINT + 1] = py
        contacts[c, C_POINT + 2] = pz
        contacts[c, C_NORMAL] = nx
        contacts[c, C_NORMAL + 1] = ny
        contacts[c, C_NORMAL + 2] = nz
        rax, ray, raz = px - x[S_POS, a], py - x[S_POS + 1, a], pz - x[S_POS + 2, a]
        contacts[c, C_RA] = rax
        contacts[c, C_RA + 1] = ray
        contacts[c, C_RA + 2] = raz
        # Relative normal velocity now.
        ux, uy, uz = _cross(vel[a, 3], vel[a, 4], vel[a, 5], rax, ray, raz)
        ux += vel[a, 0]
        uy += vel[a, 1]
        uz += vel[a, 2]
        if not static_b:
            rbx, rby, rbz = (px - x[S_POS, b], py - x[S_POS + 1, b],
                             pz - x[S_POS + 2, b])
            contacts[c, C_RB] = rbx
            contacts[c, C_RB + 1] = rby
            contacts[c, C_RB + 2] = rbz
            wx, wy, wz = _cross(vel[b, 3], vel[b, 4], vel[b, 5], rbx, rby, rbz)
            ux -= vel[b, 0] + wx
            uy -= vel[b, 1] + wy
            uz -= vel[b, 2] + wz
        un0 = ux * nx + uy * ny + uz * nz
        phi_now = buf[r, 0] - h * un0
        if phi_now >= 0.0:
            bias = un0 - buf[r, 0] / h
        else:
            bias = min(-PUSH_FRACTION * phi_now / h, PUSH_MAX_M_S)
        # Restitution is set at each collision visit, from C_TOUCH_U (_collision_targets).
        contacts[c, C_TARGET] = bias
        contacts[c, C_BIAS] = bias
        contacts[c, C_TOUCH_U] = un0 + (TOUCH_M - buf[r, 0]) / h
        nc += 1
    if static_b:
        _reuse_response(responses, patches, nq, contacts, nc - m, m, a, b, inv_mass,
                        inv_inertia_w)
    return nc


@_inl
def _reuse_response(responses, patches, q, contacts, s0, m, a, b, inv_mass, inv_inertia_w):
    """Give patch ``q`` (body ``a`` on static ``b``) its cached K and K⁺ if they match."""
    if (responses[a, R_STATIC] != b or responses[a, R_COUNT] != m
            or responses[a, R_INV_MASS] != inv_mass[a]):
        return
    for k in range(9):
        if responses[a, R_INV_INERTIA + k] != inv_inertia_w[a, k // 3, k % 3]:
            return
    for k in range(m):
        for d in range(3):
            if (responses[a, R_ROWS + 6 * k + d] != contacts[s0 + k, C_RA + d]
                    or responses[a, R_ROWS + 6 * k + 3 + d] != contacts[s0 + k, C_NORMAL + d]):
                return
    for k in range(PATCH_POINTS * PATCH_POINTS):
        patches[q, Q_K + k] = responses[a, R_K + k]
        patches[q, Q_PINV + k] = responses[a, R_PINV + k]
    patches[q, Q_CACHED] = 2.0


@_raw
def keep_responses(responses, patches, contacts, n_bodies, inv_mass, inv_inertia_w):
    """Store the K and K⁺ of every patch on a static object that computed them."""
    for q in range(patches.shape[0]):
        b = patches[q, Q_B]
        if b < n_bodies or patches[q, Q_CACHED] != 1.0:  # none, or taken from the cache
            continue
        a = int(patches[q, Q_A])
        s0 = int(patches[q, Q_START])
        m = int(patches[q, Q_COUNT])
        responses[a, R_STATIC] = b
        responses[a, R_COUNT] = m
        responses[a, R_INV_MASS] = inv_mass[a]
        for k in range(9):
            responses[a, R_INV_INERTIA + k] = inv_inertia_w[a, k // 3, k % 3]
        for k in range(m):
            for d in range(3):
                responses[a, R_ROWS + 6 * k + d] = contacts[s0 + k, C_RA + d]
                responses[a, R_ROWS + 6 * k + 3 + d] = contacts[s0 + k, C_NORMAL + d]
        for k in range(PATCH_POINTS * PATCH_POINTS):
            responses[a, R_K + k] = patches[q, Q_K + k]
            responses[a, R_PINV + k] = patches[q, Q_PINV + k]


# ---------------------------------------------------------------------------------------------
# The impulses.
