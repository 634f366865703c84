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
The articulated step's projections: positions onto the joints, then velocities.

After an RK4 sub-step (:mod:`.dynamics`), :func:`_project_positions` moves the state back onto
``C(x) = 0`` by Newton with the minimal mass-weighted change (right side ``[0; -C]``), and
:func:`_project_velocities` removes ``J u`` (right side ``[0; -J u]``, a velocity motor's row
held at its target), both through the factor of :mod:`.solve`. :func:`_unwrap` keeps each
continuous joint's running angle. Rows come from :mod:`.rows`.
"""

import math

from rbd_ros.core import jitcache
from rbd_ros.core.joints.arrays import (
    B_ROT, J_KIND, M_HOLD, M_HOLD_RATE, M_MODE, M_VELOCITY, MOTOR_POSITION, MOTOR_VELOCITY,
    ROW_MIMIC, ROW_MOTOR, S_ERR)
from rbd_ros.core.joints.rows import _mtv, _row_rate, _twist, body_derived, joint_rows
from rbd_ros.core.joints.solve import factor, solve

_jit = jitcache.raw_kernel()
_inl = jitcache.kernel(inline='always')


@_inl
def _max_abs(v):
    m = 0.0
    for i in range(v.shape[0]):
        a = abs(v[i])
        if not a <= m:
            m = a if a == a else math.inf
    return m


@_jit
def _apply_dx(x, yb):
    """``p += dp``, ``q ← exp(dθ_w / 2) ⊗ q`` (world-frame rotation increment), renormalised."""
    for b in range(x.shape[0]):
        for k in range(3):
            x[b, k] += yb[b, k]
        t0, t1, t2 = yb[b, 3], yb[b, 4], yb[b, 5]
        ang = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        if ang == 0.0:
            continue
        cw = math.cos(0.5 * ang)
        sk = math.sin(0.5 * ang) / ang
        dx, dy, dz = sk * t0, sk * t1, sk * t2
        qw, qx, qy, qz = x[b, 3], x[b, 4], x[b, 5], x[b, 6]
        nw = cw * qw - dx * qx - dy * qy - dz * qz
        nx = cw * qx + dx * qw + dy * qz - dz * qy
        ny = cw * qy - dx * qz + dy * qw + dz * qx
        nz = cw * qz + dx * qy - dy * qx + dz * qw
        s = 1.0 / math.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
        x[b, 3], x[b, 4], x[b, 5], x[b, 6] = nw * s, nx * s, ny * s, nz * s


@_jit
def _project_positions(model, x, work, tol, max_iter, refactor_after):
    """
    Newton on ``C(x) = 0`` with the minimal mass-weighted change ``dx = -M⁻¹ Jᵀ μ``.

    The first ``refactor_after`` iterations reuse the factor already in ``work`` (a chord
    step: the last RK4 stage's, O(h) away); later ones refactor at the current ``x``.
    Return the iterations taken, or -1 when ``max|C| <= tol`` was not reached. On success
    every row (``C``, ``J``, ``J̇ u``) is left at the final ``x``, for
    :func:`~.dynamics._end_of_step`: the checks after an iteration, and one that refactors,
    fill them whole (the first check of a chord step only ``C``).
    """
    zero = work.xs[:, 0:6]
    for b in range(zero.shape[0]):
        for k in range(6):
            zero[b, k] = 0.0
    for it in range(max_iter + 1):
        full = it > 0 or refactor_after == 0
        joint_rows(model, x, work, full)
        err = _max_abs(work.con)
        work.stats[S_ERR] = err
        if err <= tol:
            if not full:
                joint_rows(model, x, work, True)
            return it
        if it == max_iter:
            break
        if it >= refactor_after:
            body_derived(model, x, work)   # the rows are x's (full: it > 0 or refactor_after 0)
            factor(model, work)
        for r in range(work.con.shape[0]):
            work.bias[r] = -work.con[r]
        solve(model, work, zero, work.bias, work.yb, work.yj)
        _apply_dx(x, work.yb)
    return -1


@_jit
def _project_velocities(model, x, work):
    """With rows and factor at ``x``: ``u ← u - M⁻¹ Jᵀ (J M⁻¹ Jᵀ)⁻¹ J u``."""
    rows, bd = model.rows, work.bd
    zero = work.xs[:, 0:6]
    for b in range(zero.shape[0]):
        for k in range(6):
            zero[b, k] = 0.0
    for r in range(rows.shape[0]):
        # the side count as a constant in each branch, so that the loop unrolls (read from
        # the row, it cost a 7-link arm's step 4 %; a tree has no mimic row)
        if rows[r, 1] == ROW_MIMIC:
            s = _row_rate(model, x, work, r, 4)
        else:
            s = _row_rate(model, x, work, r, 2)
        work.bias[r] = -s
        if rows[r, 1] == ROW_MOTOR:
            # a velocity target is a velocity row, J u = v*; a position target's row is an
            # acceleration row only, so the projection leaves that rate alone (unless the
            # contact step holds it at its exact response's rate, M_HOLD)
            m = rows[r, 3]   # the motor slot
            mode = work.motor[m, M_MODE]
            if mode == MOTOR_VELOCITY:
                work.bias[r] = work.motor[m, M_VELOCITY] - s
            elif mode == MOTOR_POSITION and work.motor[m, M_HOLD] != 0.0:
                work.bias[r] = work.motor[m, M_HOLD_RATE] - s
            else:
                work.bias[r] = 0.0
    solve(model, work, zero, work.bias, work.yb, work.yj)
    yb = work.yb
    for b in range(x.shape[0]):
        for k in range(3):
            x[b, 7 + k] += yb[b, k]
        t0, t1, t2 = _mtv(bd, b, B_ROT, yb[b, 3], yb[b, 4], yb[b, 5])
        x[b, 10] += t0
        x[b, 11] += t1
        x[b, 12] += t2


@_jit
def _unwrap(model, x, work):
    """Keep each continuous joint's running angle (twist of ``q_pc q_rest⁻¹`` on ``axis_b``)."""
    jint = model.jint
    for j in range(jint.shape[0]):
        if jint[j, J_KIND] != 2:
            continue
        delta = _twist(model, x, j) - work.angle[j]
        delta -= 2.0 * math.pi * math.floor(delta / (2.0 * math.pi) + 0.5)
        work.angle[j] += delta
