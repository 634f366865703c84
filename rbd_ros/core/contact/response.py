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
A patch's response: how an impulse at a point changes the bodies' velocities.

Also the closed-form ``K`` and ``K⁺`` of a flat patch (:func:`_flat_response`).
"""

from rbd_ros.core.contact.linalg import _cross, _mat_vec, _one_normal, _tangent_basis, SCR_A, SCR_V
from rbd_ros.core.contact.rows import (_inl, _raw, C_NORMAL, C_RA, C_RB, PATCH_POINTS, Q_CACHED,
                                       Q_K, Q_PINV)


@_inl
def _point_velocity(vel, i, rx, ry, rz):
    wx, wy, wz = _cross(vel[i, 3], vel[i, 4], vel[i, 5], rx, ry, rz)
    return vel[i, 0] + wx, vel[i, 1] + wy, vel[i, 2] + wz


@_inl
def _apply(vel, inv_mass, inv_inertia_w, i, scale, rx, ry, rz, jx, jy, jz, mx, my, mz):
    """Apply impulse ``scale·j`` at lever arm ``r`` plus couple ``scale·m`` to body ``i``."""
    im = inv_mass[i] * scale
    vel[i, 0] += im * jx
    vel[i, 1] += im * jy
    vel[i, 2] += im * jz
    tx, ty, tz = _cross(rx, ry, rz, jx, jy, jz)
    tx, ty, tz = scale * (tx + mx), scale * (ty + my), scale * (tz + mz)
    dx, dy, dz = _mat_vec(inv_inertia_w, i, tx, ty, tz)
    vel[i, 3] += dx
    vel[i, 4] += dy
    vel[i, 5] += dz


@_inl
def _record(wrench, i, sign, rx, ry, rz, jx, jy, jz, mx, my, mz):
    wrench[i, 0] += sign * jx
    wrench[i, 1] += sign * jy
    wrench[i, 2] += sign * jz
    tx, ty, tz = _cross(rx, ry, rz, jx, jy, jz)
    wrench[i, 3] += sign * (tx + mx)
    wrench[i, 4] += sign * (ty + my)
    wrench[i, 5] += sign * (tz + mz)


@_inl
def _response(inv_mass, inv_inertia_w, i, rx, ry, rz, dx, dy, dz, ex, ey, ez):
    """``eᵀ K_i d``: velocity change along ``e`` at ``r`` per unit impulse along ``d`` at ``r``."""
    cx, cy, cz = _cross(rx, ry, rz, dx, dy, dz)
    ix, iy, iz = _mat_vec(inv_inertia_w, i, cx, cy, cz)
    wx, wy, wz = _cross(ix, iy, iz, rx, ry, rz)
    return inv_mass[i] * (dx * ex + dy * ey + dz * ez) + wx * ex + wy * ey + wz * ez


@_inl
def _cross_response(inv_mass, inv_inertia_w, i, rlx, rly, rlz, dx, dy, dz, rkx, rky, rkz,
                    ex, ey, ez):
    """``eᵀ Δv(r_k)`` of body ``i`` per unit impulse along ``d`` at ``r_l``."""
    cx, cy, cz = _cross(rlx, rly, rlz, dx, dy, dz)
    ix, iy, iz = _mat_vec(inv_inertia_w, i, cx, cy, cz)
    kx, ky, kz = _cross(rkx, rky, rkz, ex, ey, ez)
    return inv_mass[i] * (dx * ex + dy * ey + dz * ez) + ix * kx + iy * ky + iz * kz


# Rows of a patch solve's scratch table ``scr`` (SCR_ROWS, PATCH_POINTS): everything the

#: :func:`_flat_response` takes a patch only if its points' spread in the tangent plane is
#: far from a line: det S₂ >= this share of (tr S₂)² (4·det/tr² is 1 for a square, 0 on a
#: line), so S₂⁻¹ loses at most ~1e4 ulp; a thinner patch goes the general way.
FLAT_SPREAD_TOL = 1e-4


@_inl
def _tangent_inertia(inv_inertia_w, i, t1x, t1y, t1z, t2x, t2y, t2z):
    """``W_t = T I⁻¹ Tᵀ`` of body ``i`` in the tangent basis ``T = (t1, t2)``: w11, w12, w22."""
    ux, uy, uz = _mat_vec(inv_inertia_w, i, t1x, t1y, t1z)
    vx, vy, vz = _mat_vec(inv_inertia_w, i, t2x, t2y, t2z)
    return (t1x * ux + t1y * uy + t1z * uz,
            0.5 * (t1x * vx + t1y * vy + t1z * vz + t2x * ux + t2y * uy + t2z * uz),
            t2x * vx + t2y * vy + t2z * vz)


@_raw
def _flat_response(patches, q, contacts, s0, m, inv_mass, inv_inertia_w, a, b, dyn_b, scr):
    """
    Set patch ``q``'s K and K⁺ (both bodies free) in closed form if it is flat; tell whether.

    Flat: three or more points and one normal ``n`` (a face on a plane or on a face).  Let
    ``α_k`` be the tangent coordinates (basis ``T``) of ``r_k × n`` for A's lever arms, and
    ``δ`` the (constant) shift to B's.  Each body's response is affine in ``α``, so
    ``K = B C Bᵀ`` with ``B`` the rows ``(1, α_k)``, of full column rank 3, and ``C`` the
    symmetric 3×3 ``[[m_A⁻¹ + m_B⁻¹ + δᵀW_Bδ, (W_B δ)ᵀ], [W_B δ, W_A + W_B]]``
    (``W = T I⁻¹ Tᵀ``, B's terms absent for a static object).  Then
    ``K⁺ = B (BᵀB)⁻¹ C⁻¹ (BᵀB)⁻¹ Bᵀ``; centring ``α`` (``β_k = α_k − ᾱ``) makes ``BᵀB``
    block diagonal, and ``K⁺_kl = f_kᵀ C⁻¹ f_l`` with ``f_k = (1/n_p − ᾱ·e_k, e_k)``,
    ``e_k = S₂⁻¹ β_k``, ``S₂ = Σ β_k β_kᵀ`` (``n_p`` points).  The least-norm inverse of
    four points' rank-3 K (which the general route finds by cofactors and a shifted
    Cholesky) from 2×2 and 3×3 inverses: ~100× closer to exact (test_patch_response), and
    a miss of the response cache, which a resting body's pose makes once a step as it moves
    in its last bits, costs ~0.1 µs instead of ~0.37 µs.
    """
    if m < 3 or not _one_normal(contacts, s0, m, C_NORMAL):
        return False
    nx, ny, nz = contacts[s0, C_NORMAL], contacts[s0, C_NORMAL + 1], contacts[s0, C_NORMAL + 2]
    t1x, t1y, t1z, t2x, t2y, t2z = _tangent_basis(nx, ny, nz)
    nn = nx * nx + ny * ny + nz * nz
    # α_k (scr's SCR_A rows), their mean, and B's shift δ.
    m1 = m2 = d1 = d2 = 0.0
    for k in range(m):
        c = s0 + k
        ax, ay, az = _cross(contacts[c, C_RA], contacts[c, C_RA + 1], contacts[c, C_RA + 2],
                            nx, ny, nz)
        al1 = ax * t1x + ay * t1y + az * t1z
        al2 = ax * t2x + ay * t2y + az * t2z
        scr[SCR_A, k] = al1
        scr[SCR_A + 1, k] = al2
        m1 += al1
        m2 += al2
        if dyn_b:
            bx, by, bz = _cross(contacts[c, C_RB], contacts[c, C_RB + 1],
                                contacts[c, C_RB + 2], nx, ny, nz)
            d1 += bx * t1x + by * t1y + bz * t1z - al1
            d2 += bx * t2x + by * t2y + bz * t2z - al2
    m1 /= m
    m2 /= m
    d1 /= m
    d2 /= m
    s11 = s12 = s22 = 0.0
    for k in range(m):
        b1 = scr[SCR_A, k] - m1
        b2 = scr[SCR_A + 1, k] - m2
        s11 += b1 * b1
        s12 += b1 * b2
        s22 += b2 * b2
    sdet = s11 * s22 - s12 * s12
    if not sdet >= FLAT_SPREAD_TOL * (s11 + s22) * (s11 + s22):
        return False
    # C.
    c11, c12, c22 = _tangent_inertia(inv_inertia_w, a, t1x, t1y, t1z, t2x, t2y, t2z)
    c00 = inv_mass[a] * nn
    c01 = c02 = 0.0
    if dyn_b:
        w11, w12, w22 = _tangent_inertia(inv_inertia_w, b, t1x, t1y, t1z, t2x, t2y, t2z)
        g1 = w11 * d1 + w12 * d2
        g2 = w12 * d1 + w22 * d2
        c00 += inv_mass[b] * nn + d1 * g1 + d2 * g2
        c01, c02 = g1, g2
        c11 += w11
        c12 += w12
        c22 += w22
    # C⁻¹ by cofactors; C is positive definite unless a mass or inertia is not.
    i00 = c11 * c22 - c12 * c12
    i01 = c02 * c12 - c01 * c22
    i02 = c01 * c12 - c02 * c11
    det = c00 * i00 + c01 * i01 + c02 * i02
    if not (det > 1e-12 * c00 * c11 * c22 and i00 > 0.0):
        return False
    i00 /= det
    i01 /= det
    i02 /= det
    i11 = (c00 * c22 - c02 * c02) / det
    i12 = (c01 * c02 - c00 * c12) / det
    i22 = (c00 * c11 - c01 * c01) / det
    # K = B C Bᵀ.
    for k in range(m):
        al1 = scr[SCR_A, k]
        al2 = scr[SCR_A + 1, k]
        r0 = c00 + c01 * al1 + c02 * al2
        r1 = c01 + c11 * al1 + c12 * al2
        r2 = c02 + c12 * al1 + c22 * al2
        for jj in range(k, m):
            v = r0 + r1 * scr[SCR_A, jj] + r2 * scr[SCR_A + 1, jj]
            patches[q, Q_K + PATCH_POINTS * k + jj] = v
            patches[q, Q_K + PATCH_POINTS * jj + k] = v
    # f_k in scr's SCR_V rows, then K⁺ = F C⁻¹ Fᵀ (0 beyond the patch's points).
    f0, f1, f2 = SCR_V, SCR_V + 1, SCR_V + 2
    for k in range(m):
        b1 = scr[SCR_A, k] - m1
        b2 = scr[SCR_A + 1, k] - m2
        scr[f1, k] = (s22 * b1 - s12 * b2) / sdet
        scr[f2, k] = (s11 * b2 - s12 * b1) / sdet
        scr[f0, k] = 1.0 / m - (m1 * scr[f1, k] + m2 * scr[f2, k])
    for k in range(PATCH_POINTS):
        r0 = r1 = r2 = 0.0
        if k < m:
            r0 = i00 * scr[f0, k] + i01 * scr[f1, k] + i02 * scr[f2, k]
            r1 = i01 * scr[f0, k] + i11 * scr[f1, k] + i12 * scr[f2, k]
            r2 = i02 * scr[f0, k] + i12 * scr[f1, k] + i22 * scr[f2, k]
        for jj in range(k, PATCH_POINTS):
            v = 0.0
            if jj < m:
                v = r0 * scr[f0, jj] + r1 * scr[f1, jj] + r2 * scr[f2, jj]
            patches[q, Q_PINV + PATCH_POINTS * k + jj] = v
            patches[q, Q_PINV + PATCH_POINTS * jj + k] = v
    patches[q, Q_CACHED] = 1.0
    return True
