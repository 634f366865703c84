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
The tree solve of a tree of fixed, revolute, continuous and prismatic joints: articulated form.

:mod:`.solve` picks this form when every joint is one of those kinds (at most one axial row
held: a limit, a motor or a stuck friction), every body hangs from the joint whose child it
is (a component rooted at its world joint, or at a body with no joint above it) and no loop
closes; else its block LDLᵀ. Both solve the same system exactly
(``[[M, Jᵀ], [J, 0]] [yb; yj] = [rb; rj]``); they differ at round-off only.

Each body ``b`` is eliminated together with its joint ``j`` to its parent ``P`` (leaves
first), as Featherstone's articulated-body algorithm does, but on the joint's rows as they are
(no joint coordinates). With ``D̂`` the body's articulated inertia (its own ``M`` plus what its
children pass on) and ``J_c`` (n × 6) the joint's held rows on the child, the rows on the
parent are ``J_P = -J_c T`` (a joint's rows do not see a rigid motion of both bodies), with
``T`` the rigid transport of the parent's twist to the child's centre:
``T (v, ω) = (v + ω × r, ω)``, ``r = p_b - p_P``. Write ``a_b = T a_P + δ₀ + N α``:

- ``S = [J_c; c]`` (6 × 6) completes the rows to a square system. The rows fall into three
  without a linear part (alignment rows; a hinge's axial rows) and three with one (position
  rows; a slider's axial rows), so ``S = [[0, A_z], [E, G]]`` is solved by two 3 × 3 inverses.
  A joint with five rows (one free coordinate) gets the completion ``c``: ``(0, ω_n)`` for a
  hinge (``ω_n = a₁ × a₂`` of its two alignment rows), ``(v_n, 0)`` for a slider
  (``v_n = e₁ × e₂`` of its two position rows); with six, none (the joint is held rigid).
- ``N`` (6 × 1) spans the rows' null space: ``(-E⁻¹ G ω_n, ω_n)`` for a hinge,
  ``(v_n, 0)`` for a slider. ``δ₀ = S⁻¹ [rj; 0]`` satisfies the rows.
- ``α = Nᵀ (r̂ - D̂ (T a_P + δ₀)) / K``, ``K = Nᵀ D̂ N``, ``v = D̂ N``; the parent receives
  ``Tᵀ A T`` (``A = D̂ - v vᵀ / K``, the articulated inertia) and
  ``Tᵀ (r̂ - D̂ δ₀ - v (Nᵀ r̂ - vᵀ δ₀) / K)``.
- The multipliers: ``J_cᵀ yj = r̂ - D̂ a_b`` (consistent), solved with ``Sᵀ``.

A body with no joint above it (a free base) is a root: its ``D̂`` is factored by LDLᵀ.
Per body-joint pair this is a quarter of the block LDLᵀ's arithmetic (a 7-link arm's factor
0.6 µs against 2.0). Storage (the block form's arrays, unused by it here): ``D[b]`` the
articulated inertia ``D̂``; ``Hp[b]`` ``E⁻¹`` (rows 0-2, columns 0-2), ``A_z⁻¹`` (rows 0-2,
columns 3-5) and ``G`` (rows 3-5, columns 0-2); ``W[b]`` row 0 ``N``, row 1 ``v``, row 2
``1/K`` (0: no free coordinate) and ``r``; ``D[n_b + j]`` scratch; ``work.arows[j]`` the
rows in ``S``'s order (-1 the completion); ``y[b]`` ``δ₀``.
"""

from rbd_ros.core import jitcache
from rbd_ros.core.joints.arrays import (
    B_IW, B_POS, J_CHILD, J_KIND, J_PARENT, P_MASS, ROW_ANG, ROW_LIN)
from rbd_ros.core.kernel_rotations import _cross

_jit = jitcache.raw_kernel()
_inl = jitcache.kernel(inline='always')


@_jit
def articulated_ok(model, work):
    """
    Return 1 when :func:`articulated_factor` applies to the held rows, filling ``work.arows``.

    Every joint fixed, revolute, continuous or prismatic, its held rows three without a linear
    part and three with one (five: a joint with its coordinate free); every body the child of
    the joint above it in the elimination tree, or a root.
    """
    n_b = model.prm.shape[0]
    jint, rows, par = model.jint, model.rows, model.node_par
    for b in range(n_b):
        p = par[b]
        if p >= 0 and jint[p - n_b, J_CHILD] != b:
            return 0
    for j in range(jint.shape[0]):
        kind = jint[j, J_KIND]
        if kind > 3:
            return 0
        nz = 0
        nl = 0
        for r in range(work.nrow[j]):
            row = work.jrows[j, r]
            rk = rows[row, 1]
            if rk == ROW_LIN or (rk != ROW_ANG and kind == 3):
                if nl == 3:
                    return 0
                work.arows[j, 3 + nl] = row
                nl += 1
            else:
                if nz == 3:
                    return 0
                work.arows[j, nz] = row
                nz += 1
        if nz + nl < 5:
            return 0
        if nz == 2:
            work.arows[j, 2] = -1
        if nl == 2:
            work.arows[j, 5] = -1
    return 1


@_inl
def _inv3(a0, a1, a2, a3, a4, a5, a6, a7, a8):
    """Return the inverse of the row-major 3×3 ``a`` (adjugate over determinant)."""
    c0 = a4 * a8 - a5 * a7
    c1 = a5 * a6 - a3 * a8
    c2 = a3 * a7 - a4 * a6
    inv = 1.0 / (a0 * c0 + a1 * c1 + a2 * c2)
    return (c0 * inv, (a2 * a7 - a1 * a8) * inv, (a1 * a5 - a2 * a4) * inv,
            c1 * inv, (a0 * a8 - a2 * a6) * inv, (a2 * a3 - a0 * a5) * inv,
            c2 * inv, (a1 * a6 - a0 * a7) * inv, (a0 * a4 - a1 * a3) * inv)


@_inl
def _put3(m, i, r0, c0, a0, a1, a2, a3, a4, a5, a6, a7, a8):
    """Write the row-major 3×3 ``a`` into ``m[i, r0:r0 + 3, c0:c0 + 3]``."""
    m[i, r0, c0], m[i, r0, c0 + 1], m[i, r0, c0 + 2] = a0, a1, a2
    m[i, r0 + 1, c0], m[i, r0 + 1, c0 + 1], m[i, r0 + 1, c0 + 2] = a3, a4, a5
    m[i, r0 + 2, c0], m[i, r0 + 2, c0 + 1], m[i, r0 + 2, c0 + 2] = a6, a7, a8


@_inl
def _mul3(m, i, r0, c0, x0, x1, x2):
    """Return ``B x`` for ``B = m[i, r0:r0 + 3, c0:c0 + 3]``."""
    return (m[i, r0, c0] * x0 + m[i, r0, c0 + 1] * x1 + m[i, r0, c0 + 2] * x2,
            m[i, r0 + 1, c0] * x0 + m[i, r0 + 1, c0 + 1] * x1 + m[i, r0 + 1, c0 + 2] * x2,
            m[i, r0 + 2, c0] * x0 + m[i, r0 + 2, c0 + 1] * x1 + m[i, r0 + 2, c0 + 2] * x2)


@_inl
def _mul3t(m, i, r0, c0, x0, x1, x2):
    """Return ``Bᵀ x`` for ``B = m[i, r0:r0 + 3, c0:c0 + 3]``."""
    return (m[i, r0, c0] * x0 + m[i, r0 + 1, c0] * x1 + m[i, r0 + 2, c0] * x2,
            m[i, r0, c0 + 1] * x0 + m[i, r0 + 1, c0 + 1] * x1 + m[i, r0 + 2, c0 + 1] * x2,
            m[i, r0, c0 + 2] * x0 + m[i, r0 + 1, c0 + 2] * x1 + m[i, r0 + 2, c0 + 2] * x2)


@_inl
def _joint_pair(model, work, b, j):
    """``S``'s inverses, ``G``, ``N``, ``v``, ``1/K`` of body ``b`` and its joint ``j``."""
    jac, ar, Hp, W, D = work.jac, work.arows, work.Hp, work.W, work.D
    # E (linear parts) and G (angular parts) of the rows with a linear part
    if ar[j, 5] < 0:   # a slider's free coordinate: the completion (v_n, 0), v_n = e1 × e2
        r3, r4 = ar[j, 3], ar[j, 4]
        n0, n1, n2 = _cross(jac[r3, 6], jac[r3, 7], jac[r3, 8],
                            jac[r4, 6], jac[r4, 7], jac[r4, 8])
        e = _inv3(jac[r3, 6], jac[r3, 7], jac[r3, 8], jac[r4, 6], jac[r4, 7], jac[r4, 8],
                  n0, n1, n2)
        _put3(Hp, b, 3, 0, jac[r3, 9], jac[r3, 10], jac[r3, 11],
              jac[r4, 9], jac[r4, 10], jac[r4, 11], 0.0, 0.0, 0.0)
        W[b, 0, 0], W[b, 0, 1], W[b, 0, 2] = n0, n1, n2
        W[b, 0, 3] = W[b, 0, 4] = W[b, 0, 5] = 0.0
    else:
        r3, r4, r5 = ar[j, 3], ar[j, 4], ar[j, 5]
        e = _inv3(jac[r3, 6], jac[r3, 7], jac[r3, 8], jac[r4, 6], jac[r4, 7], jac[r4, 8],
                  jac[r5, 6], jac[r5, 7], jac[r5, 8])
        _put3(Hp, b, 3, 0, jac[r3, 9], jac[r3, 10], jac[r3, 11],
              jac[r4, 9], jac[r4, 10], jac[r4, 11], jac[r5, 9], jac[r5, 10], jac[r5, 11])
    _put3(Hp, b, 0, 0, e[0], e[1], e[2], e[3], e[4], e[5], e[6], e[7], e[8])
    # A_z (angular parts of the rows without a linear part)
    r0, r1 = ar[j, 0], ar[j, 1]
    if ar[j, 2] < 0:   # a hinge's free coordinate: the completion (0, ω_n), ω_n = a1 × a2
        w0, w1, w2 = _cross(jac[r0, 9], jac[r0, 10], jac[r0, 11],
                            jac[r1, 9], jac[r1, 10], jac[r1, 11])
        a = _inv3(jac[r0, 9], jac[r0, 10], jac[r0, 11], jac[r1, 9], jac[r1, 10], jac[r1, 11],
                  w0, w1, w2)
        # N = (-E⁻¹ G ω_n, ω_n)
        g0, g1, g2 = _mul3(Hp, b, 3, 0, w0, w1, w2)
        n0, n1, n2 = _mul3(Hp, b, 0, 0, g0, g1, g2)
        W[b, 0, 0], W[b, 0, 1], W[b, 0, 2] = -n0, -n1, -n2
        W[b, 0, 3], W[b, 0, 4], W[b, 0, 5] = w0, w1, w2
    else:
        r2 = ar[j, 2]
        a = _inv3(jac[r0, 9], jac[r0, 10], jac[r0, 11], jac[r1, 9], jac[r1, 10], jac[r1, 11],
                  jac[r2, 9], jac[r2, 10], jac[r2, 11])
    _put3(Hp, b, 0, 3, a[0], a[1], a[2], a[3], a[4], a[5], a[6], a[7], a[8])
    # the articulated inertia A = D̂ - v vᵀ / K into the scratch D[t]
    t = model.prm.shape[0] + j
    if ar[j, 2] < 0 or ar[j, 5] < 0:
        k = 0.0
        for r in range(6):
            s = 0.0
            for c in range(6):
                s += D[b, r, c] * W[b, 0, c]
            W[b, 1, r] = s
            k += W[b, 0, r] * s
        q = 1.0 / k
        W[b, 2, 0] = q
        for r in range(6):
            for c in range(6):
                D[t, r, c] = D[b, r, c] - W[b, 1, r] * W[b, 1, c] * q
    else:
        W[b, 2, 0] = 0.0
        for r in range(6):
            for c in range(6):
                D[t, r, c] = D[b, r, c]


@_inl
def _transport(model, work, b, j, p):
    """Add ``Tᵀ A T`` (``A`` in the scratch ``D[n_b + j]``) to the parent ``p``'s ``D̂``."""
    bd, D, W = work.bd, work.D, work.W
    t = model.prm.shape[0] + j
    r0 = bd[b, B_POS] - bd[p, B_POS]
    r1 = bd[b, B_POS + 1] - bd[p, B_POS + 1]
    r2 = bd[b, B_POS + 2] - bd[p, B_POS + 2]
    W[b, 2, 1], W[b, 2, 2], W[b, 2, 3] = r0, r1, r2
    # A T: columns 3-5 += A[:, 0:3] X, X = -[r]× (X c = c × r)
    for i in range(6):
        a0, a1, a2 = D[t, i, 0], D[t, i, 1], D[t, i, 2]
        D[t, i, 3] += a2 * r1 - a1 * r2
        D[t, i, 4] += a0 * r2 - a2 * r0
        D[t, i, 5] += a1 * r0 - a0 * r1
    # Tᵀ (A T): rows 3-5 += Xᵀ rows 0-2 (Xᵀ c = r × c)
    for c in range(6):
        b0, b1, b2 = D[t, 0, c], D[t, 1, c], D[t, 2, c]
        D[t, 3, c] += r1 * b2 - r2 * b1
        D[t, 4, c] += r2 * b0 - r0 * b2
        D[t, 5, c] += r0 * b1 - r1 * b0
    for r in range(6):
        for c in range(6):
            D[p, r, c] += D[t, r, c]


@_jit
def articulated_factor(model, work):
    """Factor in articulated form (:func:`articulated_ok` returned 1 for the held rows)."""
    n_b = model.prm.shape[0]
    jint, bd, D, par = model.jint, work.bd, work.D, model.node_par
    for b in range(n_b):
        m = model.prm[b, P_MASS]
        for r in range(3):
            for c in range(3):
                D[b, r, c] = m if r == c else 0.0
                D[b, r, 3 + c] = 0.0
                D[b, 3 + r, c] = 0.0
                D[b, 3 + r, 3 + c] = bd[b, B_IW + 3 * r + c]
    for t in range(model.order.shape[0]):
        b = model.order[t]
        if b >= n_b:
            continue
        if par[b] < 0:
            _ldl6(D, b)
            continue
        j = par[b] - n_b
        _joint_pair(model, work, b, j)
        p = jint[j, J_PARENT]
        if p >= 0:
            _transport(model, work, b, j, p)


@_inl
def _ldl6(a, i):
    """LDLᵀ of the symmetric ``a[i]`` (6 × 6) in place (lower part; no pivoting)."""
    for j in range(6):
        d = a[i, j, j]
        for k in range(j):
            d -= a[i, j, k] * a[i, j, k] * a[i, k, k]
        a[i, j, j] = d
        for r in range(j + 1, 6):
            s = a[i, r, j]
            for k in range(j):
                s -= a[i, r, k] * a[i, j, k] * a[i, k, k]
            a[i, r, j] = s / d


@_inl
def _ldl6_solve(a, i, v, vi):
    """Solve ``a[i] z = v[vi, :6]`` in place with the factor of :func:`_ldl6`."""
    for r in range(6):
        s = v[vi, r]
        for k in range(r):
            s -= a[i, r, k] * v[vi, k]
        v[vi, r] = s
    for r in range(6):
        v[vi, r] /= a[i, r, r]
    for r in range(5, -1, -1):
        s = v[vi, r]
        for k in range(r + 1, 6):
            s -= a[i, k, r] * v[vi, k]
        v[vi, r] = s


@_inl
def _times_y(D, y, b):
    """Return ``D[b] y[b]`` (6 × 6 times 6)."""
    s0 = s1 = s2 = s3 = s4 = s5 = 0.0
    for k in range(6):
        s0 += D[b, 0, k] * y[b, k]
        s1 += D[b, 1, k] * y[b, k]
        s2 += D[b, 2, k] * y[b, k]
        s3 += D[b, 3, k] * y[b, k]
        s4 += D[b, 4, k] * y[b, k]
        s5 += D[b, 5, k] * y[b, k]
    return s0, s1, s2, s3, s4, s5


@_jit
def articulated_solve(model, work, rb, rj, yb, yj):
    """:func:`~.solve.solve` with the factor of :func:`articulated_factor`."""
    n_b = model.prm.shape[0]
    jint, order, par = model.jint, model.order, model.node_par
    D, Hp, W, rhs, y, ar = work.D, work.Hp, work.W, work.rhs, work.y, work.arows
    for b in range(n_b):
        for k in range(6):
            rhs[b, k] = rb[b, k]
    for r in range(yj.shape[0]):
        yj[r] = 0.0
    # leaves first: δ₀ = S⁻¹ [rj; 0], then the parent's right side
    for t in range(order.shape[0]):
        b = order[t]
        if b >= n_b or par[b] < 0:
            continue
        j = par[b] - n_b
        z0 = rj[ar[j, 0]]
        z1 = rj[ar[j, 1]]
        z2 = rj[ar[j, 2]] if ar[j, 2] >= 0 else 0.0
        l0 = rj[ar[j, 3]]
        l1 = rj[ar[j, 4]]
        l2 = rj[ar[j, 5]] if ar[j, 5] >= 0 else 0.0
        w0, w1, w2 = _mul3(Hp, b, 0, 3, z0, z1, z2)
        g0, g1, g2 = _mul3(Hp, b, 3, 0, w0, w1, w2)
        v0, v1, v2 = _mul3(Hp, b, 0, 0, l0 - g0, l1 - g1, l2 - g2)
        y[b, 0], y[b, 1], y[b, 2], y[b, 3], y[b, 4], y[b, 5] = v0, v1, v2, w0, w1, w2
        p = jint[j, J_PARENT]
        if p < 0:
            continue
        q = W[b, 2, 0]
        s = 0.0
        if q != 0.0:
            for k in range(6):
                s += W[b, 0, k] * rhs[b, k] - W[b, 1, k] * y[b, k]
            s *= q
        u0, u1, u2, u3, u4, u5 = _times_y(D, y, b)
        u0 = rhs[b, 0] - u0 - s * W[b, 1, 0]
        u1 = rhs[b, 1] - u1 - s * W[b, 1, 1]
        u2 = rhs[b, 2] - u2 - s * W[b, 1, 2]
        u3 = rhs[b, 3] - u3 - s * W[b, 1, 3]
        u4 = rhs[b, 4] - u4 - s * W[b, 1, 4]
        u5 = rhs[b, 5] - u5 - s * W[b, 1, 5]
        c0, c1, c2 = _cross(W[b, 2, 1], W[b, 2, 2], W[b, 2, 3], u0, u1, u2)
        rhs[p, 0] += u0
        rhs[p, 1] += u1
        rhs[p, 2] += u2
        rhs[p, 3] += u3 + c0
        rhs[p, 4] += u4 + c1
        rhs[p, 5] += u5 + c2
    # roots first: a_b = T a_P + δ₀ + N α, then J_cᵀ yj = r̂ - D̂ a_b by Sᵀ
    for t in range(order.shape[0] - 1, -1, -1):
        b = order[t]
        if b >= n_b:
            continue
        if par[b] < 0:
            for k in range(6):
                y[b, k] = rhs[b, k]
            _ldl6_solve(D, b, y, b)
            for k in range(6):
                yb[b, k] = y[b, k]
            continue
        j = par[b] - n_b
        p = jint[j, J_PARENT]
        if p >= 0:
            c0, c1, c2 = _cross(yb[p, 3], yb[p, 4], yb[p, 5], W[b, 2, 1], W[b, 2, 2],
                                W[b, 2, 3])
            y[b, 0] += yb[p, 0] + c0
            y[b, 1] += yb[p, 1] + c1
            y[b, 2] += yb[p, 2] + c2
            y[b, 3] += yb[p, 3]
            y[b, 4] += yb[p, 4]
            y[b, 5] += yb[p, 5]
        q = W[b, 2, 0]
        if q != 0.0:
            s = 0.0
            for k in range(6):
                s += W[b, 0, k] * rhs[b, k] - W[b, 1, k] * y[b, k]
            s *= q
            for k in range(6):
                y[b, k] += s * W[b, 0, k]
        for k in range(6):
            yb[b, k] = y[b, k]
        f0, f1, f2, f3, f4, f5 = _times_y(D, y, b)
        f0, f1, f2 = rhs[b, 0] - f0, rhs[b, 1] - f1, rhs[b, 2] - f2
        f3, f4, f5 = rhs[b, 3] - f3, rhs[b, 4] - f4, rhs[b, 5] - f5
        l0, l1, l2 = _mul3t(Hp, b, 0, 0, f0, f1, f2)
        g0, g1, g2 = _mul3t(Hp, b, 3, 0, l0, l1, l2)
        z0, z1, z2 = _mul3t(Hp, b, 0, 3, f3 - g0, f4 - g1, f5 - g2)
        yj[ar[j, 0]] = z0
        yj[ar[j, 1]] = z1
        if ar[j, 2] >= 0:
            yj[ar[j, 2]] = z2
        yj[ar[j, 3]] = l0
        yj[ar[j, 4]] = l1
        if ar[j, 5] >= 0:
            yj[ar[j, 5]] = l2
