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
Small linear algebra of the contact step: 3×3 products, rotations, bases, pseudo-inverses.

The pseudo-inverse is the one of a patch's (at most 4×4) normal response ``K``, computed in
place in the scratch table ``scr`` (``SCR_*`` rows, :func:`patch_scratch`).
"""

import math

import numpy as np

from rbd_ros.core import kernels as kk
from rbd_ros.core.contact.rows import _inl, _jit, _raw, PATCH_POINTS


_cross = kk._cross  # the free-body kernel's, not a second copy


@_inl
def _mat_vec(m, i, x, y, z):
    """``m[i] @ v`` for a (N, 3, 3) array."""
    return (m[i, 0, 0] * x + m[i, 0, 1] * y + m[i, 0, 2] * z,
            m[i, 1, 0] * x + m[i, 1, 1] * y + m[i, 1, 2] * z,
            m[i, 2, 0] * x + m[i, 2, 1] * y + m[i, 2, 2] * z)


@_inl
def _mat_t_vec(m, i, x, y, z):
    """``m[i].T @ v`` for a (N, 3, 3) array."""
    return (m[i, 0, 0] * x + m[i, 1, 0] * y + m[i, 2, 0] * z,
            m[i, 0, 1] * x + m[i, 1, 1] * y + m[i, 2, 1] * z,
            m[i, 0, 2] * x + m[i, 1, 2] * y + m[i, 2, 2] * z)


@_inl
def _set_rotation(out, i, qw, qx, qy, qz):
    """Write ``R(q)`` into ``out[i]`` (q unit)."""
    out[i, 0, 0] = 1.0 - 2.0 * (qy * qy + qz * qz)
    out[i, 0, 1] = 2.0 * (qx * qy - qw * qz)
    out[i, 0, 2] = 2.0 * (qx * qz + qw * qy)
    out[i, 1, 0] = 2.0 * (qx * qy + qw * qz)
    out[i, 1, 1] = 1.0 - 2.0 * (qx * qx + qz * qz)
    out[i, 1, 2] = 2.0 * (qy * qz - qw * qx)
    out[i, 2, 0] = 2.0 * (qx * qz - qw * qy)
    out[i, 2, 1] = 2.0 * (qy * qz + qw * qx)
    out[i, 2, 2] = 1.0 - 2.0 * (qx * qx + qy * qy)


# ---------------------------------------------------------------------------------------------
# Poses: current and candidate, world velocities and inverse inertias.


@_inl
def _one_normal(rows, first, count, col):
    """
    Tell whether rows ``first … first+count-1`` have one normal (columns ``col … col+2``).

    A face on a plane or a face: ``buf`` rows in the narrow phase, a patch's contact rows in
    :func:`_flat_response`.
    """
    for k in range(first + 1, first + count):
        if (rows[k, col] != rows[first, col] or rows[k, col + 1] != rows[first, col + 1]
                or rows[k, col + 2] != rows[first, col + 2]):
            return False
    return True


@_inl
def _tangent_basis(nx, ny, nz):
    """Two unit vectors completing ``n`` to a right-handed orthonormal basis."""
    if abs(nx) < 0.57735:
        tx, ty, tz = 0.0, -nz, ny
    else:
        tx, ty, tz = nz, 0.0, -nx
    s = 1.0 / math.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx * s, ty * s, tz * s
    sx, sy, sz = _cross(nx, ny, nz, tx, ty, tz)
    return tx, ty, tz, sx, sy, sz


# normal block works on, indexed in place (no row views: each would be reference counted).
SCR_K = 0                           # K of the points, PATCH_POINTS rows
SCR_FREE = PATCH_POINTS             # u without the patch's normal impulses
SCR_RHS = SCR_FREE + 1              # bias − u0
SCR_LAM = SCR_FREE + 2              # λ of the active set being tried
SCR_BEST = SCR_FREE + 3             # the chosen λ
SCR_ACTIVE = SCR_FREE + 4           # 1.0 for the points in the active set
SCR_IDX = SCR_FREE + 5              # the active points' indices
SCR_PINV = SCR_FREE + 6             # (K_AA)⁺ scattered to the points, PATCH_POINTS rows
SCR_A = SCR_PINV + PATCH_POINTS     # K_AA compacted, then the eigenvalues on its diagonal
SCR_V = SCR_A + PATCH_POINTS        # eigenvectors, or the inverse of a fast path
SCR_LOW = SCR_V + PATCH_POINTS      # a Cholesky factor
SCR_INV_LOW = SCR_LOW + PATCH_POINTS  # its inverse
SCR_U = SCR_INV_LOW + PATCH_POINTS  # a null vector (one row)
SCR_SHIFTED = SCR_U + 1             # K_AA + s u uᵀ
SCR_BASE = SCR_SHIFTED + PATCH_POINTS  # the normal impulses a collision visit starts from
SCR_FULL = SCR_BASE + 1             # (K)⁺ of every point, kept through one patch's visit
SCR_ROWS = SCR_FULL + PATCH_POINTS


@_jit
def patch_scratch():
    """Return a scratch table for :func:`solve_patch` (one per thread)."""
    return np.empty((SCR_ROWS, PATCH_POINTS))


@_raw
def _eigh_small(w, a0, p, v0):
    """
    Diagonalise the symmetric ``w[a0:a0+p, :p]`` in place by cyclic Jacobi rotations.

    Afterwards its diagonal holds the eigenvalues and the columns of ``w[v0:v0+p, :p]`` the
    eigenvectors (Rutishauser's rotation formulas, no trigonometric functions).
    """
    for r in range(p):
        for c in range(p):
            w[v0 + r, c] = 1.0 if r == c else 0.0
    for _ in range(30):
        off = 0.0
        for r in range(p):
            for c in range(r + 1, p):
                off += w[a0 + r, c] * w[a0 + r, c]
        if off <= 1e-60:
            break
        for r in range(p):
            for c in range(r + 1, p):
                if w[a0 + r, c] == 0.0:
                    continue
                theta = (w[a0 + c, c] - w[a0 + r, r]) / (2.0 * w[a0 + r, c])
                t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                cs_ = 1.0 / math.sqrt(t * t + 1.0)
                sn = t * cs_
                for k in range(p):
                    akr, akc = w[a0 + k, r], w[a0 + k, c]
                    w[a0 + k, r] = cs_ * akr - sn * akc
                    w[a0 + k, c] = sn * akr + cs_ * akc
                for k in range(p):
                    ark, ack = w[a0 + r, k], w[a0 + c, k]
                    w[a0 + r, k] = cs_ * ark - sn * ack
                    w[a0 + c, k] = sn * ark + cs_ * ack
                for k in range(p):
                    vkr, vkc = w[v0 + k, r], w[v0 + k, c]
                    w[v0 + k, r] = cs_ * vkr - sn * vkc
                    w[v0 + k, c] = sn * vkr + cs_ * vkc


#: The fast paths of :func:`_pinv_small` take a Cholesky factor only if every pivot is at
#: least this share of the largest diagonal entry (an inverse then accurate to ~1e-13; two
#: balls colliding off-centre give a K of condition 6e4, whose Cholesky inverse was off by
#: 2e-12 and let an elastic collision gain that much energy): else the eigen-decomposition.
PIVOT_TOL = 1e-3


@_raw
def _spd_inverse(w, a0, p, tol, o0):
    """
    Invert the symmetric ``w[a0:a0+p, :p]`` by Cholesky into ``w[o0:o0+p, :p]``.

    False (and nothing written) if a pivot is <= ``tol``.  Uses the rows ``SCR_LOW`` and
    ``SCR_INV_LOW`` of ``w``.
    """
    lo = SCR_LOW
    il = SCR_INV_LOW
    for j in range(p):
        for k in range(p):
            w[lo + j, k] = 0.0
            w[il + j, k] = 0.0
    for j in range(p):
        d = w[a0 + j, j]
        for k in range(j):
            d -= w[lo + j, k] * w[lo + j, k]
        if not d > tol:
            return False
        w[lo + j, j] = math.sqrt(d)
        for i in range(j + 1, p):
            acc = w[a0 + i, j]
            for k in range(j):
                acc -= w[lo + i, k] * w[lo + j, k]
            w[lo + i, j] = acc / w[lo + j, j]
    # L⁻¹ (lower triangular), then the inverse L⁻ᵀ L⁻¹.
    for j in range(p):
        w[il + j, j] = 1.0 / w[lo + j, j]
        for i in range(j + 1, p):
            acc = 0.0
            for k in range(j, i):
                acc -= w[lo + i, k] * w[il + k, j]
            w[il + i, j] = acc / w[lo + i, i]
    for r in range(p):
        for c in range(r, p):
            acc = 0.0
            for k in range(c, p):
                acc += w[il + k, r] * w[il + k, c]
            w[o0 + r, c] = acc
            w[o0 + c, r] = acc
    return True


@_inl
def _skip(k, s):
    """Return the ``k``-th index of ``0, 1, …`` with ``s`` left out."""
    return k if k < s else k + 1


@_raw
def _cofactor(w, a0, p, r, c):
    """Return the cofactor ``(−1)^(r+c) det(a less row r, column c)`` of ``w[a0:a0+p, :p]``."""
    r0, r1, r2 = a0 + _skip(0, r), a0 + _skip(1, r), a0 + _skip(2, r)
    c0, c1, c2 = _skip(0, c), _skip(1, c), _skip(2, c)
    if p == 1:
        det = 1.0
    elif p == 2:
        det = w[r0, c0]
    elif p == 3:
        det = w[r0, c0] * w[r1, c1] - w[r0, c1] * w[r1, c0]
    else:
        det = (w[r0, c0] * (w[r1, c1] * w[r2, c2] - w[r1, c2] * w[r2, c1])
               - w[r0, c1] * (w[r1, c0] * w[r2, c2] - w[r1, c2] * w[r2, c0])
               + w[r0, c2] * (w[r1, c0] * w[r2, c1] - w[r1, c1] * w[r2, c0]))
    return -det if (r + c) % 2 == 1 else det


@_raw
def _deflated_inverse(w, a0, p, top, o0):
    """
    Pseudo-inverse of a symmetric PSD ``w[a0:a0+p, :p]`` of rank ``p − 1`` into ``w[o0:]``.

    False if it is not of that rank.  The adjugate of such a matrix is ``c u uᵀ`` with ``u``
    its unit null vector (four points of one normal on a rigid body always have one: the
    normal impulses that sum to no force and no moment), so
    ``a⁺ = (a + s u uᵀ)⁻¹ − u uᵀ / s``.  Checked: ``|a u|`` must be round-off and
    ``a + s u uᵀ`` well conditioned, else the caller decomposes.
    """
    j = -1
    big = 0.0
    for k in range(p):
        d = _cofactor(w, a0, p, k, k)
        if d > big:
            big = d
            j = k
    if j < 0:
        return False
    u = SCR_U
    norm = 0.0
    for k in range(p):
        w[u, k] = _cofactor(w, a0, p, j, k)
        norm += w[u, k] * w[u, k]
    norm = math.sqrt(norm)
    for k in range(p):
        w[u, k] /= norm
    for r in range(p):
        acc = 0.0
        for c in range(p):
            acc += w[a0 + r, c] * w[u, c]
        if abs(acc) > 1e-9 * top:
            return False
    sh = SCR_SHIFTED
    for r in range(p):
        for c in range(p):
            w[sh + r, c] = w[a0 + r, c] + top * w[u, r] * w[u, c]
    if not _spd_inverse(w, sh, p, PIVOT_TOL * top, o0):
        return False
    for r in range(p):
        for c in range(p):
            w[o0 + r, c] -= w[u, r] * w[u, c] / top
    return True


@_raw
def _pinv_small(scr, m):
    """
    Set ``scr``'s SCR_PINV rows to the pseudo-inverse of ``K[A, A]`` (0 off the active set).

    ``K`` is ``scr``'s SCR_K rows, ``A`` the points flagged in its SCR_ACTIVE row.  ``K`` is
    symmetric positive semi-definite (a contact response); eigenvalues below 1e-9 of the
    largest count as zero.  Four coplanar points leave a rigid body's normal impulses
    indeterminate along one direction: the least-norm solution shares the load
    symmetrically instead of in an order-dependent way, and a nearly singular direction (a
    normal tilted by round-off) cannot produce a huge impulse.  A well-conditioned matrix is
    inverted by Cholesky, one of rank one less (a flat patch :func:`_flat_response` did not
    take, or a subset of one) by :func:`_deflated_inverse`; anything else by Jacobi
    eigen-decomposition.
    """
    p = 0
    for k in range(m):
        for jj in range(m):
            scr[SCR_PINV + k, jj] = 0.0
        if scr[SCR_ACTIVE, k] != 0.0:
            scr[SCR_IDX, p] = k
            p += 1
    if p == 0:
        return
    diag = 0.0
    for r in range(p):
        for c in range(p):
            scr[SCR_A + r, c] = scr[SCR_K + int(scr[SCR_IDX, r]), int(scr[SCR_IDX, c])]
        diag = max(diag, scr[SCR_A + r, r])
    if diag <= 0.0:
        return
    if (_spd_inverse(scr, SCR_A, p, PIVOT_TOL * diag, SCR_V)
            or (p > 1 and _deflated_inverse(scr, SCR_A, p, diag, SCR_V))):
        for r in range(p):
            for c in range(p):
                scr[SCR_PINV + int(scr[SCR_IDX, r]), int(scr[SCR_IDX, c])] = scr[SCR_V + r, c]
        return
    _eigh_small(scr, SCR_A, p, SCR_V)
    top = 0.0
    for r in range(p):
        top = max(top, scr[SCR_A + r, r])
    if top <= 0.0:
        return
    for e in range(p):
        sigma = scr[SCR_A + e, e]
        if sigma <= 1e-9 * top:
            continue
        for r in range(p):
            for c in range(p):
                scr[SCR_PINV + int(scr[SCR_IDX, r]), int(scr[SCR_IDX, c])] += (
                    scr[SCR_V + r, e] * scr[SCR_V + c, e] / sigma)
