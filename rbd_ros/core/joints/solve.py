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
The articulated step's factorisation and solves of ``[[M, Jᵀ], [J, 0]]``: tree and dense.

:func:`factor` at the configuration of ``work.bd`` and ``work.jac`` (filled by :mod:`.rows`),
then :func:`solve` for any right side: the dynamics (:mod:`.dynamics`) and both projections
(:mod:`.projection`) reuse one factor. A tree of one-coordinate (and fixed) joints is
factored in articulated form (:mod:`.articulated`); otherwise two direct solvers (see
:mod:`rbd_ros.core.joints.kernels`): the **tree**, block LDLᵀ leaves first over the body-joint
graph (``_tree_factor``, with ``_eliminate``, ``_down``, ``_up`` per node, their common block
sizes unrolled by ``_unrolled``), and the **dense** LDLᵀ of ``J M⁻¹ Jᵀ`` for a loop
(``_dense_factor``), dropping a redundant row whose pivot is below :data:`DROP_REL` of its
diagonal.
"""

from rbd_ros.core import jitcache
from rbd_ros.core.joints.arrays import B_IW, B_ROT, J_CHILD, P_INERTIA_INV, P_MASS
from rbd_ros.core.joints.articulated import (
    articulated_factor, articulated_ok, articulated_solve)
from rbd_ros.core.joints.rows import _mtv, _mv, _n_sides, _side_body

_jit = jitcache.raw_kernel()
_inl = jitcache.kernel(inline='always')


#: A dense pivot below this fraction of its row's diagonal marks a redundant row.
DROP_REL = 1e-9


@_inl
def _ldl(a, i, n):
    """LDLᵀ of the symmetric ``a[i, :n, :n]`` in place (lower part; no pivoting)."""
    for j in range(n):
        d = a[i, j, j]
        for k in range(j):
            d -= a[i, j, k] * a[i, j, k] * a[i, k, k]
        a[i, j, j] = d
        for r in range(j + 1, n):
            s = a[i, r, j]
            for k in range(j):
                s -= a[i, r, k] * a[i, j, k] * a[i, k, k]
            a[i, r, j] = s / d


@_inl
def _ldl_solve_col(a, i, n, v, vi, col):
    """Solve ``a[i] z = v[vi, :n, col]`` in place with the LDLᵀ factor of :func:`_ldl`."""
    for r in range(n):
        s = v[vi, r, col]
        for k in range(r):
            s -= a[i, r, k] * v[vi, k, col]
        v[vi, r, col] = s
    for r in range(n):
        v[vi, r, col] /= a[i, r, r]
    for r in range(n - 1, -1, -1):
        s = v[vi, r, col]
        for k in range(r + 1, n):
            s -= a[i, k, r] * v[vi, k, col]
        v[vi, r, col] = s


@_inl
def _ldl_solve_vec(a, i, n, v, vi):
    for r in range(n):
        s = v[vi, r]
        for k in range(r):
            s -= a[i, r, k] * v[vi, k]
        v[vi, r] = s
    for r in range(n):
        v[vi, r] /= a[i, r, r]
    for r in range(n - 1, -1, -1):
        s = v[vi, r]
        for k in range(r + 1, n):
            s -= a[i, k, r] * v[vi, k]
        v[vi, r] = s


@_jit
def factor(model, work):
    """
    Factor the saddle-point system at the configuration of ``work.bd`` and ``work.jac``.

    A tree of fixed, revolute, continuous and prismatic joints is factored in articulated form
    (:mod:`.articulated`, ``work.form[0] = 1``); another tree by block LDLᵀ; a loop dense.
    """
    work.form[0] = 0
    if model.dense:
        _dense_factor(model, work)
    elif articulated_ok(model, work):
        work.form[0] = 1
        articulated_factor(model, work)
    else:
        _tree_factor(model, work)


@_jit
def _tree_factor(model, work):
    n_b = model.prm.shape[0]
    jint, bd, jac = model.jint, work.bd, work.jac
    D, Hp, W = work.D, work.Hp, work.W
    dim, par = work.dim, model.node_par
    for i in range(dim.shape[0]):
        for r in range(6):
            for c in range(6):
                D[i, r, c] = 0.0
    for b in range(n_b):
        m = model.prm[b, P_MASS]
        D[b, 0, 0] = D[b, 1, 1] = D[b, 2, 2] = m
        for r in range(3):
            for c in range(3):
                D[b, 3 + r, 3 + c] = bd[b, B_IW + 3 * r + c]
    for i in range(dim.shape[0]):
        p = par[i]
        if p < 0:
            continue
        if i < n_b:
            b, j = i, p - n_b
        else:
            b, j = p, i - n_b
        off = 6 if jint[j, J_CHILD] == b else 0
        for r in range(work.nrow[j]):
            row = work.jrows[j, r]
            for a in range(6):
                if i < n_b:
                    Hp[i, a, r] = jac[row, off + a]
                else:
                    Hp[i, r, a] = jac[row, off + a]
    for t in range(model.order.shape[0]):
        i = model.order[t]
        p = par[i]
        _sized_eliminate(D, Hp, W, W, i, dim[i], p, dim[p] if p >= 0 else 0)


def _unrolled(block):
    """
    Return ``block`` with the common block sizes as constants, so that its loops unroll.

    ``block`` is :func:`_eliminate`, :func:`_down` or :func:`_up`. A body (6) next to a joint of
    3 to 6 rows, either way round; other sizes take the loops.
    The arithmetic is the same in every branch: only the loop bounds become constants. One
    function per operation: numba inlines a helper's IR before it prunes branches, so one
    function taking the operation as an argument compiled all three operations' code at each
    of its call sites (three times the joint kinds' IR, ~60 CPU-s of a cold compile).
    """
    @_inl
    def sized(D, Hp, u, v, i, di, p, dp):
        if di == 6:
            if dp == 5:
                block(D, Hp, u, v, i, 6, p, 5)
            elif dp == 6:
                block(D, Hp, u, v, i, 6, p, 6)
            elif dp == 4:
                block(D, Hp, u, v, i, 6, p, 4)
            elif dp == 3:
                block(D, Hp, u, v, i, 6, p, 3)
            else:
                block(D, Hp, u, v, i, 6, p, dp)
        elif dp == 6:
            if di == 5:
                block(D, Hp, u, v, i, 5, p, 6)
            elif di == 4:
                block(D, Hp, u, v, i, 4, p, 6)
            elif di == 3:
                block(D, Hp, u, v, i, 3, p, 6)
            else:
                block(D, Hp, u, v, i, di, p, 6)
        else:
            block(D, Hp, u, v, i, di, p, dp)
    return sized


@_inl
def _eliminate(D, Hp, W, _, i, di, p, dp):
    """
    Factor node ``i`` (LDLᵀ of its ``di`` block) and subtract its Schur complement from ``p``'s.

    ``dp`` is the size of parent ``p``'s block (unused when ``p < 0``, a root). The fourth
    argument is unused: the same arguments as :func:`_down` and :func:`_up` (:func:`_unrolled`).
    """
    _ldl(D, i, di)
    if p < 0:
        return
    # Z = L⁻¹ H (forward substitution only, into W), then D_p -= Zᵀ diag⁻¹ Z
    for c in range(dp):
        for r in range(di):
            s = Hp[i, r, c]
            for k in range(r):
                s -= D[i, r, k] * W[i, k, c]
            W[i, r, c] = s
    for k in range(di):
        W[i, k, 6] = 1.0 / D[i, k, k]
    for a in range(dp):
        for c in range(a + 1):
            s = 0.0
            for k in range(di):
                s += W[i, k, a] * W[i, k, c] * W[i, k, 6]
            D[p, a, c] -= s


@_jit
def _dense_factor(model, work):
    rows, bd, jac, mj, A = model.rows, work.bd, work.jac, work.mj, work.A
    n_r = rows.shape[0]
    prm = model.prm
    # M⁻¹ Jᵀ per row and body side: linear / m, angular R I_b⁻¹ Rᵀ
    for row in range(n_r):
        for side in range(_n_sides(model, row)):
            b = _side_body(model, row, side)
            o = 6 * side
            if b < 0:
                for k in range(6):
                    mj[row, o + k] = 0.0
                continue
            inv_m = 1.0 / prm[b, P_MASS]
            for k in range(3):
                mj[row, o + k] = jac[row, o + k] * inv_m
            t0, t1, t2 = _mtv(bd, b, B_ROT, jac[row, o + 3], jac[row, o + 4], jac[row, o + 5])
            t0, t1, t2 = _mv(prm, b, P_INERTIA_INV, t0, t1, t2)
            mj[row, o + 3], mj[row, o + 4], mj[row, o + 5] = _mv(bd, b, B_ROT, t0, t1, t2)
    for r in range(n_r):
        for s in range(r + 1):
            acc = 0.0
            for sr in range(_n_sides(model, r)):
                br = _side_body(model, r, sr)
                if br < 0:
                    continue
                for ss in range(_n_sides(model, s)):
                    bs = _side_body(model, s, ss)
                    if bs != br:
                        continue
                    for k in range(6):
                        acc += jac[r, 6 * sr + k] * mj[s, 6 * ss + k]
            A[r, s] = acc
    # LDLᵀ with redundant rows dropped
    for j in range(n_r):
        diag = A[j, j]
        d = diag
        for k in range(j):
            d -= A[j, k] * A[j, k] * A[k, k]
        if d <= DROP_REL * diag or diag <= 0.0 or work.active[j] == 0:
            work.drop[j] = 1
            A[j, j] = 1.0
            for r in range(j + 1, n_r):
                A[r, j] = 0.0
            for k in range(j):
                A[j, k] = 0.0
            continue
        work.drop[j] = 0
        A[j, j] = d
        for r in range(j + 1, n_r):
            s = A[r, j]
            for k in range(j):
                s -= A[r, k] * A[j, k] * A[k, k]
            A[r, j] = s / d


@_inl
def _down(D, Hp, y, rhs, i, di, p, dp):
    """Forward step of node ``i``: ``y_i = D_i⁻¹ rhs_i``, then ``rhs_p -= H_iᵀ y_i``."""
    for k in range(di):
        y[i, k] = rhs[i, k]
    _ldl_solve_vec(D, i, di, y, i)
    if p < 0:
        return
    for a in range(dp):
        s = 0.0
        for k in range(di):
            s += Hp[i, k, a] * y[i, k]
        rhs[p, a] -= s


@_inl
def _up(D, Hp, y, rhs, i, di, p, dp):
    """Backward step of node ``i`` (``p >= 0``): ``y_i -= D_i⁻¹ H_i y_p`` (``rhs_i`` spent)."""
    for k in range(di):
        s = 0.0
        for a in range(dp):
            s += Hp[i, k, a] * y[p, a]
        rhs[i, k] = s
    _ldl_solve_vec(D, i, di, rhs, i)
    for k in range(di):
        y[i, k] -= rhs[i, k]


_sized_eliminate = _unrolled(_eliminate)
_sized_down = _unrolled(_down)
_sized_up = _unrolled(_up)


@_jit
def solve(model, work, rb, rj, yb, yj):
    """
    Solve ``[[M, Jᵀ], [J, 0]] [yb; yj] = [rb; rj]`` with the factor of :func:`factor`.

    ``rb`` (n_b, 6) body rows (force, torque; world), ``rj`` (n_rows) joint rows.
    """
    if work.form[0] == 1:
        articulated_solve(model, work, rb, rj, yb, yj)
        return
    n_b = model.prm.shape[0]
    jint, rows = model.jint, model.rows
    if not model.dense:
        rhs, y, D = work.rhs, work.y, work.D
        dim, par = work.dim, model.node_par
        for b in range(n_b):
            for k in range(6):
                rhs[b, k] = rb[b, k]
        for j in range(jint.shape[0]):
            for r in range(work.nrow[j]):
                rhs[n_b + j, r] = rj[work.jrows[j, r]]
        order = model.order
        Hp = work.Hp
        # forward: rhs_p -= Hᵀ D_i⁻¹ rhs_i (z_i = D_i⁻¹ rhs_i kept in y)
        for t in range(order.shape[0]):
            i = order[t]
            p = par[i]
            _sized_down(D, Hp, y, rhs, i, dim[i], p, dim[p] if p >= 0 else 0)
        # backward, root first: y_i = D_i⁻¹ (rhs_i - H y_p) = z_i - D_i⁻¹ H y_p
        for t in range(order.shape[0] - 1, -1, -1):
            i = order[t]
            p = par[i]
            if p >= 0:
                _sized_up(D, Hp, y, rhs, i, dim[i], p, dim[p])
        for b in range(n_b):
            for k in range(6):
                yb[b, k] = y[b, k]
        for r in range(yj.shape[0]):
            yj[r] = 0.0
        for j in range(jint.shape[0]):
            for r in range(work.nrow[j]):
                yj[work.jrows[j, r]] = y[n_b + j, r]
        return
    # dense: A yj = J M⁻¹ rb - rj, yb = M⁻¹ (rb - Jᵀ yj)
    A, mj, jac, bd, prm = work.A, work.mj, work.jac, work.bd, model.prm
    n_r = rows.shape[0]
    for b in range(n_b):
        inv_m = 1.0 / prm[b, P_MASS]
        for k in range(3):
            yb[b, k] = rb[b, k] * inv_m
        t0, t1, t2 = _mtv(bd, b, B_ROT, rb[b, 3], rb[b, 4], rb[b, 5])
        t0, t1, t2 = _mv(prm, b, P_INERTIA_INV, t0, t1, t2)
        yb[b, 3], yb[b, 4], yb[b, 5] = _mv(bd, b, B_ROT, t0, t1, t2)
    for r in range(n_r):
        s = -rj[r]
        for side in range(_n_sides(model, r)):
            b = _side_body(model, r, side)
            if b >= 0:
                for k in range(6):
                    s += jac[r, 6 * side + k] * yb[b, k]
        yj[r] = s
    for r in range(n_r):
        s = yj[r]
        for k in range(r):
            s -= A[r, k] * yj[k]
        yj[r] = s
    for r in range(n_r):
        yj[r] = 0.0 if work.drop[r] else yj[r] / A[r, r]
    for r in range(n_r - 1, -1, -1):
        s = yj[r]
        for k in range(r + 1, n_r):
            s -= A[k, r] * yj[k]
        yj[r] = 0.0 if work.drop[r] else s
    for r in range(n_r):
        for side in range(_n_sides(model, r)):
            b = _side_body(model, r, side)
            if b >= 0:
                for k in range(6):
                    yb[b, k] -= mj[r, 6 * side + k] * yj[r]
