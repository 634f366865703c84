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
A patch's friction: Coulomb's cone at its centre and the torsional couple about its normal.

:func:`_coulomb` decides stick or slip; :func:`_friction` applies it to a patch,
:func:`_friction_points` per point.
"""

import math

from rbd_ros.core.contact.linalg import _mat_vec, _tangent_basis
from rbd_ros.core.contact.response import _apply, _point_velocity, _record, _response
from rbd_ros.core.contact.rows import (_inl, _raw, C_FRICTION, C_LAMBDA, C_NORMAL, C_POINT, C_RA,
                                       C_RB, C_TK, C_TK_SET, CENTRE_WORLD_MAX_M, Q_FT, Q_MT)
from rbd_ros.core.layout import S_POS


@_inl
def _tangent_part(inv_mass, inv_inertia_w, i, rx, ry, rz, t1x, t1y, t1z, t2x, t2y, t2z):
    """Return body ``i``'s share ``(k11, k12, k22)`` of a point's 2×2 tangential response."""
    return (_response(inv_mass, inv_inertia_w, i, rx, ry, rz, t1x, t1y, t1z, t1x, t1y, t1z),
            _response(inv_mass, inv_inertia_w, i, rx, ry, rz, t2x, t2y, t2z, t1x, t1y, t1z),
            _response(inv_mass, inv_inertia_w, i, rx, ry, rz, t2x, t2y, t2z, t2x, t2y, t2z))


@_inl
def _tangent_response(inv_mass, inv_inertia_w, a, b, dyn_b, wa, wb, rax, ray, raz, rbx, rby,
                      rbz, t1x, t1y, t1z, t2x, t2y, t2z):
    """Return the 2×2 response ``(k11, k12, k22)`` of a point's tangential velocity."""
    a11, a12, a22 = _tangent_part(inv_mass, inv_inertia_w, a, rax, ray, raz, t1x, t1y, t1z,
                                  t2x, t2y, t2z)
    k11, k12, k22 = wa * a11, wa * a12, wa * a22
    if dyn_b:
        b11, b12, b22 = _tangent_part(inv_mass, inv_inertia_w, b, rbx, rby, rbz, t1x, t1y, t1z,
                                      t2x, t2y, t2z)
        k11 += wb * b11
        k12 += wb * b12
        k22 += wb * b22
    return k11, k12, k22


@_inl
def _coulomb(k11, k12, k22, u1, u2, limit):
    """
    Return the friction impulse ``f`` (2-D) for the slip ``u0`` without friction.

    Sticking, ``f = −K⁻¹ u0``, if ``|f| <= limit``; otherwise sliding with ``|f| = limit``
    opposite to the slip *after* the impulse, ``f = −limit (u0 + K f) / |u0 + K f|``
    (maximal dissipation).  That is ``f = −(K + γ𝟙)⁻¹ u0`` for the one ``γ > 0`` with
    ``|f| = limit``, found by safeguarded Newton steps on ``1/|f(γ)|`` (monotone in ``γ``).
    Solving for the post-impulse slip keeps the sliding direction stable where a fixed
    point on the pre-impulse one oscillates (a small slip against a large impulse).
    """
    det = k11 * k22 - k12 * k12
    f1 = -(k22 * u1 - k12 * u2) / det
    f2 = -(-k12 * u1 + k11 * u2) / det
    if f1 * f1 + f2 * f2 <= limit * limit:
        return f1, f2
    if limit <= 0.0:
        return 0.0, 0.0
    # Eigen-decomposition of the symmetric 2×2 K = Q diag(a, b) Qᵀ by its rotation angle
    # (well defined for any K, isotropic included).
    angle = 0.5 * math.atan2(2.0 * k12, k11 - k22)
    c1, c2 = math.cos(angle), math.sin(angle)
    a = k11 * c1 * c1 + 2.0 * k12 * c1 * c2 + k22 * c2 * c2
    b = k11 * c2 * c2 - 2.0 * k12 * c1 * c2 + k22 * c1 * c1
    # Q = [[c1, -c2], [c2, c1]]: first column the eigenvector of a.
    p1 = c1 * u1 + c2 * u2
    p2 = -c2 * u1 + c1 * u2
    speed = math.sqrt(u1 * u1 + u2 * u2)
    lo = max(0.0, speed / limit - a)
    hi = speed / limit
    g = 0.5 * (lo + hi)
    b = max(b, 0.0)
    for _ in range(60):
        da, db = a + g, b + g
        if da <= 0.0 or db <= 0.0:
            g = 0.5 * (g + hi)
            continue
        size = math.sqrt((p1 / da) ** 2 + (p2 / db) ** 2)
        if size > limit:
            lo = g
        else:
            hi = g
        # Newton on F(γ) = 1/|f(γ)| − 1/limit, kept inside the bracket: F' = −|f|' / |f|²
        # with |f|' = dsize / |f|, so γ − F / F' = γ + F |f|³ / dsize (3–18 rounds where
        # bisection alone takes ~48).
        new = 0.5 * (lo + hi)
        dsize = -((p1 * p1) / da ** 3 + (p2 * p2) / db ** 3)
        if size > 0.0 and dsize < 0.0:
            trial = g + (1.0 / size - 1.0 / limit) * size ** 3 / dsize
            if lo < trial < hi:
                new = trial
        if abs(new - g) <= 1e-15 * g:
            g = new
            break
        g = new
    q1 = -p1 / (a + g)
    q2 = -p2 / (b + g)
    f1 = c1 * q1 - c2 * q2
    f2 = c2 * q1 + c1 * q2
    # Exactly on the cone: rescale the round-off away.
    size = math.sqrt(f1 * f1 + f2 * f2)
    if size == 0.0:
        return 0.0, 0.0
    return f1 * limit / size, f2 * limit / size


@_inl
def _lambda_sum(contacts, s0, m, col):
    """Return ``Σ_k λ_k v_k`` over the patch's points ``s0 .. s0 + m``, ``v_k`` at ``col`` (3)."""
    sx = sy = sz = 0.0
    for k in range(s0, s0 + m):
        lam = contacts[k, C_LAMBDA]
        sx += lam * contacts[k, col]
        sy += lam * contacts[k, col + 1]
        sz += lam * contacts[k, col + 2]
    return sx, sy, sz


@_inl
def _friction(q, patches, contacts, vel, inv_mass, inv_inertia_w, a, b, dyn_b, x, wa, wb,
              wrench, total, cx, cy, cz, nx, ny, nz, s0, m, mu):
    """
    One friction update of patch ``q``: stick if the cone allows, else slide; return Δu.

    ``(cx, cy, cz)`` is the patch's centre ``Σ λ_k p_k / total`` in world coordinates; its
    lever arms are ``c − x``, or, beyond :data:`CENTRE_WORLD_MAX_M`, the λ-weighted means of
    the points' own (``C_RA``, ``C_RB``: exact to their size however far out), the torsion's
    arms ``p_k − c`` then ``r_k − r`` likewise.
    """
    col = C_POINT
    if max(abs(cx), abs(cy), abs(cz)) <= CENTRE_WORLD_MAX_M:
        rax, ray, raz = cx - x[S_POS, a], cy - x[S_POS + 1, a], cz - x[S_POS + 2, a]
        rbx = rby = rbz = 0.0
        if dyn_b:
            rbx, rby, rbz = cx - x[S_POS, b], cy - x[S_POS + 1, b], cz - x[S_POS + 2, b]
    else:
        col = C_RA
        rax, ray, raz = _lambda_sum(contacts, s0, m, C_RA)
        rbx, rby, rbz = _lambda_sum(contacts, s0, m, C_RB)
        rax, ray, raz = rax / total, ray / total, raz / total
        rbx, rby, rbz = rbx / total, rby / total, rbz / total
        cx, cy, cz = rax, ray, raz
    ux, uy, uz = _point_velocity(vel, a, rax, ray, raz)
    if dyn_b:
        bx, by, bz = _point_velocity(vel, b, rbx, rby, rbz)
        ux, uy, uz = ux - bx, uy - by, uz - bz
    t1x, t1y, t1z, t2x, t2y, t2z = _tangent_basis(nx, ny, nz)
    u1 = ux * t1x + uy * t1y + uz * t1z
    u2 = ux * t2x + uy * t2y + uz * t2z
    # 2×2 response of the tangential velocity at c to a tangential impulse at c.
    k11, k12, k22 = _tangent_response(inv_mass, inv_inertia_w, a, b, dyn_b, wa, wb, rax, ray,
                                      raz, rbx, rby, rbz, t1x, t1y, t1z, t2x, t2y, t2z)
    det = k11 * k22 - k12 * k12
    fx, fy, fz = patches[q, Q_FT], patches[q, Q_FT + 1], patches[q, Q_FT + 2]
    f1 = fx * t1x + fy * t1y + fz * t1z
    f2 = fx * t2x + fy * t2y + fz * t2z
    limit = mu * total
    change = 0.0
    if det > 0.0:
        # Slip without this patch's friction, u0 = u − K f; sticking needs f = −K⁻¹ u0.
        w1 = u1 - (k11 * f1 + k12 * f2)
        w2 = u2 - (k12 * f1 + k22 * f2)
        n1, n2 = _coulomb(k11, k12, k22, w1, w2, limit)
        d1, d2 = n1 - f1, n2 - f2
        if d1 != 0.0 or d2 != 0.0:
            jx = d1 * t1x + d2 * t2x
            jy = d1 * t1y + d2 * t2y
            jz = d1 * t1z + d2 * t2z
            patches[q, Q_FT] = fx + jx
            patches[q, Q_FT + 1] = fy + jy
            patches[q, Q_FT + 2] = fz + jz
            _apply(vel, inv_mass, inv_inertia_w, a, wa, rax, ray, raz, jx, jy, jz,
                   0.0, 0.0, 0.0)
            _record(wrench, a, 1.0, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
            if dyn_b:
                _apply(vel, inv_mass, inv_inertia_w, b, -wb, rbx, rby, rbz, jx, jy, jz,
                       0.0, 0.0, 0.0)
                _record(wrench, b, -1.0, rbx, rby, rbz, jx, jy, jz, 0.0, 0.0, 0.0)
            change = max(abs(d1) * k11, abs(d2) * k22)
    # Torsion: a couple about the patch normal, up to μ Σ λ_k |r_k − c|.
    arm = 0.0
    for k in range(s0, s0 + m):
        dx = contacts[k, col] - cx
        dy = contacts[k, col + 1] - cy
        dz = contacts[k, col + 2] - cz
        dn = dx * nx + dy * ny + dz * nz
        arm += contacts[k, C_LAMBDA] * math.sqrt(max(dx * dx + dy * dy + dz * dz - dn * dn,
                                                     0.0))
    if arm > 0.0:
        ix, iy, iz = _mat_vec(inv_inertia_w, a, nx, ny, nz)
        kss = wa * (ix * nx + iy * ny + iz * nz)
        if dyn_b:
            ix, iy, iz = _mat_vec(inv_inertia_w, b, nx, ny, nz)
            kss += wb * (ix * nx + iy * ny + iz * nz)
        if kss > 0.0:
            spin = vel[a, 3] * nx + vel[a, 4] * ny + vel[a, 5] * nz
            if dyn_b:
                spin -= vel[b, 3] * nx + vel[b, 4] * ny + vel[b, 5] * nz
            old = patches[q, Q_MT]
            new = old - spin / kss
            cap = mu * arm
            new = min(max(new, -cap), cap)
            d = new - old
            if d != 0.0:
                patches[q, Q_MT] = new
                mx, my, mz = d * nx, d * ny, d * nz
                _apply(vel, inv_mass, inv_inertia_w, a, wa, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                       mx, my, mz)
                _record(wrench, a, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, mx, my, mz)
                if dyn_b:
                    _apply(vel, inv_mass, inv_inertia_w, b, -wb, 0.0, 0.0, 0.0, 0.0, 0.0,
                           0.0, mx, my, mz)
                    _record(wrench, b, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, mx, my, mz)
                change = max(change, abs(d) * kss)
    return change


@_raw
def _friction_points(q, patches, contacts, vel, inv_mass, inv_inertia_w, a, b, dyn_b, wa, wb,
                     wrench, s0, m, mu):
    """
    One friction update of every point of patch ``q`` in its own cone; return the largest Δu.

    Each point keeps its own tangential impulse ``f_k`` (``C_FRICTION``), always applied at
    that point and in its own tangent plane, so ``u0 = u − K_k f_k`` undoes exactly what was
    applied before: sticking ``f_k = −K_k⁻¹ u0`` if ``|f_k| <= μ λ_k``, else sliding on the
    cone (:func:`_coulomb`).  Used where patches share a body: the patch friction at a moving
    normal-impulse centre leaves a couple each iteration that Gauss–Seidel over coupled
    patches amplifies.  Four points sticking also hold the twist, so no torsion term.
    Each body's share of a point's tangential response is kept in the contact row
    (``C_TK``): the lever arms and inverse inertias are fixed within a stage, so the kept
    shares, scaled by ``wa`` and ``wb``, are the same bits as computing them again (shock
    propagation's held bodies included).
    """
    change = 0.0
    for c in range(s0, s0 + m):
        nx, ny, nz = contacts[c, C_NORMAL], contacts[c, C_NORMAL + 1], contacts[c, C_NORMAL + 2]
        rax, ray, raz = contacts[c, C_RA], contacts[c, C_RA + 1], contacts[c, C_RA + 2]
        rbx, rby, rbz = contacts[c, C_RB], contacts[c, C_RB + 1], contacts[c, C_RB + 2]
        ux, uy, uz = _point_velocity(vel, a, rax, ray, raz)
        if dyn_b:
            bx, by, bz = _point_velocity(vel, b, rbx, rby, rbz)
            ux, uy, uz = ux - bx, uy - by, uz - bz
        t1x, t1y, t1z, t2x, t2y, t2z = _tangent_basis(nx, ny, nz)
        if contacts[c, C_TK_SET] == 0.0:
            a11, a12, a22 = _tangent_part(inv_mass, inv_inertia_w, a, rax, ray, raz, t1x, t1y,
                                          t1z, t2x, t2y, t2z)
            contacts[c, C_TK], contacts[c, C_TK + 1], contacts[c, C_TK + 2] = a11, a12, a22
            if dyn_b:
                b11, b12, b22 = _tangent_part(inv_mass, inv_inertia_w, b, rbx, rby, rbz, t1x,
                                              t1y, t1z, t2x, t2y, t2z)
                contacts[c, C_TK + 3], contacts[c, C_TK + 4] = b11, b12
                contacts[c, C_TK + 5] = b22
            contacts[c, C_TK_SET] = 1.0
        # As _tangent_response, from the kept shares (the same bits).
        k11 = wa * contacts[c, C_TK]
        k12 = wa * contacts[c, C_TK + 1]
        k22 = wa * contacts[c, C_TK + 2]
        if dyn_b:
            k11 += wb * contacts[c, C_TK + 3]
            k12 += wb * contacts[c, C_TK + 4]
            k22 += wb * contacts[c, C_TK + 5]
        if not k11 * k22 - k12 * k12 > 0.0:
            continue
        fx = contacts[c, C_FRICTION]
        fy = contacts[c, C_FRICTION + 1]
        fz = contacts[c, C_FRICTION + 2]
        f1 = fx * t1x + fy * t1y + fz * t1z
        f2 = fx * t2x + fy * t2y + fz * t2z
        u1 = ux * t1x + uy * t1y + uz * t1z
        u2 = ux * t2x + uy * t2y + uz * t2z
        w1 = u1 - (k11 * f1 + k12 * f2)
        w2 = u2 - (k12 * f1 + k22 * f2)
        n1, n2 = _coulomb(k11, k12, k22, w1, w2, mu * max(contacts[c, C_LAMBDA], 0.0))
        d1, d2 = n1 - f1, n2 - f2
        if d1 == 0.0 and d2 == 0.0:
            continue
        jx = d1 * t1x + d2 * t2x
        jy = d1 * t1y + d2 * t2y
        jz = d1 * t1z + d2 * t2z
        contacts[c, C_FRICTION] = fx + jx
        contacts[c, C_FRICTION + 1] = fy + jy
        contacts[c, C_FRICTION + 2] = fz + jz
        patches[q, Q_FT] += jx
        patches[q, Q_FT + 1] += jy
        patches[q, Q_FT + 2] += jz
        _apply(vel, inv_mass, inv_inertia_w, a, wa, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
        _record(wrench, a, 1.0, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
        if dyn_b:
            _apply(vel, inv_mass, inv_inertia_w, b, -wb, rbx, rby, rbz, jx, jy, jz,
                   0.0, 0.0, 0.0)
            _record(wrench, b, -1.0, rbx, rby, rbz, jx, jy, jz, 0.0, 0.0, 0.0)
        change = max(change, abs(d1) * k11, abs(d2) * k22)
    return change
