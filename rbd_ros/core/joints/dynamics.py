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
The articulated step's dynamics: forces, accelerations, limits decided, one RK4 sub-step.

``_motor_forces`` is the one sum of each joint's applied force (effort or saturated motor,
damping, sliding friction); ``_accelerations`` and ``_dynamics_solve`` give ``ẋ`` and ``λ`` at
a state through :mod:`.rows` and :mod:`.solve`; ``_dynamics_at`` (and
:func:`refresh_dynamics`) decides the active rows (:mod:`.active_rows`) until none changes;
``_rk4`` takes one classical RK4 sub-step and the projections (:mod:`.projection`), and
``_end_of_step`` what follows them (velocity projection, next ``ẋ``). :func:`initialize`
projects a start state. The events inside a step (:mod:`.events`) and the driver
(:mod:`rbd_ros.core.joints.kernels`) call these.
"""

import math

from rbd_ros.core import jitcache
from rbd_ros.core.joints.active_rows import (
    _applied_efforts, _friction_efforts, _friction_rows, _friction_slip, _friction_stops,
    _motor_rows_on, _release, _saturate)
from rbd_ros.core.joints.arrays import (
    B_FORCE, B_ROT, F_SIGN, J_CHILD, J_DAMPING, J_FRICROW, J_FRICTION, J_PARENT, M_EFFORT, M_LIMIT,
    M_MODE, M_SAT, MOTOR_EFFORT, MOTOR_OFF, S_ITER, S_TIME, S_TSTAGE)
from rbd_ros.core.joints.projection import _project_positions, _project_velocities, _unwrap
from rbd_ros.core.joints.rows import _mtv, _row_rate, body_derived, body_rates, joint_rows
from rbd_ros.core.joints.solve import factor, solve

_jit = jitcache.raw_kernel()


@_jit
def _accelerations(model, x, work, kout):
    """Rows, factor and solve at ``x``; write ``ẋ`` into ``kout`` and ``λ`` into ``work.lam``."""
    body_derived(model, x, work)
    joint_rows(model, x, work, True)
    factor(model, work)
    _motor_forces(model, x, work)
    _dynamics_solve(model, x, work, kout)


@_jit
def _motor_forces(model, x, work):
    """
    Add each joint's applied generalized force to ``work.bd``'s wrenches: the one sum.

    ``τ = τ_motor - d q̇ - f s``: an effort motor's clipped effort (or a saturated motor's
    ``±effort_limit``), the viscous damping ``d`` at the joint rate ``q̇ = J u`` of the state
    being evaluated, and a sliding joint's Coulomb friction ``f`` against its sliding direction
    ``s`` (fixed for the step). ``τ`` along the joint coordinate acts through the motor row's
    Jacobian, ``f += Jᵀ τ``: equal and opposite on the two bodies (a torque pair about the
    axis, or a force pair at the child's anchor along the axis). A joint with none of them is
    skipped, so its arithmetic is that of a joint without damping and friction.
    """
    jint, jprm, motor, jac, bd = model.jint, model.jprm, work.motor, work.jac, work.bd
    for m in range(model.mrows.shape[0]):   # motor slots: slot j is joint j's (see ArtModel)
        row = model.mrows[m]
        if row < 0:
            continue
        j = model.rows[row, 0]
        mode = motor[m, M_MODE]
        tau = 0.0
        push = False
        if mode == MOTOR_EFFORT:
            tau = min(max(motor[m, M_EFFORT], -motor[m, M_LIMIT]), motor[m, M_LIMIT])
            push = True
        elif mode != MOTOR_OFF and motor[m, M_SAT] != 0.0 and work.lim_state[j] == 0:
            tau = motor[m, M_SAT] * motor[m, M_LIMIT]
            push = True
        damping = jprm[j, J_DAMPING]
        if damping != 0.0:
            tau -= damping * _row_rate(model, x, work, row, 2)
            push = True
        sign = work.fric[j, F_SIGN]
        if sign == 1.0 or sign == -1.0:
            tau -= jprm[j, J_FRICTION] * sign
            push = True
        if not push:
            continue
        for side in range(2):
            b = jint[j, J_CHILD] if side == 1 else jint[j, J_PARENT]
            if b >= 0:
                for k in range(6):
                    bd[b, B_FORCE + k] += tau * jac[row, 6 * side + k]


@_jit
def _dynamics_solve(model, x, work, kout):
    """With rows and factor at ``x``: accelerations into ``kout`` (``ẋ``), ``λ``, wrenches."""
    bd, yb, yj, bias, lam = work.bd, work.yb, work.yj, work.bias, work.lam
    for r in range(bias.shape[0]):
        bias[r] = -bias[r]
    solve(model, work, bd[:, B_FORCE:B_FORCE + 6], bias, yb, yj)
    for r in range(bias.shape[0]):
        lam[r] = -yj[r]
    for b in range(x.shape[0]):
        qw, qx, qy, qz = x[b, 3], x[b, 4], x[b, 5], x[b, 6]
        w0, w1, w2 = x[b, 10], x[b, 11], x[b, 12]
        kout[b, 0], kout[b, 1], kout[b, 2] = x[b, 7], x[b, 8], x[b, 9]
        # q̇ = ½ q ⊗ (0, ω_b)
        kout[b, 3] = 0.5 * (-qx * w0 - qy * w1 - qz * w2)
        kout[b, 4] = 0.5 * (qw * w0 + qy * w2 - qz * w1)
        kout[b, 5] = 0.5 * (qw * w1 - qx * w2 + qz * w0)
        kout[b, 6] = 0.5 * (qw * w2 + qx * w1 - qy * w0)
        kout[b, 7], kout[b, 8], kout[b, 9] = yb[b, 0], yb[b, 1], yb[b, 2]
        # ω̇_b = Rᵀ ω̇_w (Ṙᵀ ω_w = -Rᵀ (ω_w × ω_w) = 0)
        a0, a1, a2 = _mtv(bd, b, B_ROT, yb[b, 3], yb[b, 4], yb[b, 5])
        kout[b, 10], kout[b, 11], kout[b, 12] = a0, a1, a2


@_jit
def _wrenches(model, work):
    """``work.wrench[j]``: ``Σ λ J_c`` of joint ``j``'s rows: force, torque about the child COM."""
    jint, jac, lam, wr = model.jint, work.jac, work.lam, work.wrench
    for j in range(jint.shape[0]):
        for k in range(6):
            wr[j, k] = 0.0
        for r in range(work.nrow[j]):
            row = work.jrows[j, r]
            for k in range(6):
                wr[j, k] += lam[row] * jac[row, 6 + k]


@_jit
def refresh_dynamics(model, x, work):
    """Recompute ``ẋ`` (k1), ``λ``, wrenches and efforts at ``x`` after a change of motors."""
    _dynamics_at(model, x, work, True, False)


@_jit
def _dynamics_at(model, x, work, refactor, frames):
    """
    ``ẋ`` into ``work.k[0]`` and ``λ`` at ``x``, deciding limits and saturation.

    ``frames``: ``work.bd``'s rotations and world inertias are already ``x``'s (only the
    velocities changed since :func:`body_derived`), so only the rates are refreshed.

    Held limits whose multiplier would pull are released; motor rows are tried on and a
    motor whose multiplier exceeds its effort limit is saturated; a stuck joint's friction row
    is held unless a motor row or a limit holds the joint, and let go (sliding) when its
    multiplier exceeds the friction; each change refactors.
    """
    if _motor_rows_on(model, work) > 0:
        refactor = True
    n_friction = 0
    for j in range(model.jint.shape[0]):
        if model.jint[j, J_FRICROW] >= 0:
            n_friction += 1
    for it in range(2 * model.jint.shape[0] + 2 + 2 * n_friction):
        # f and ω_w at the current velocities (the positions stay: later passes and fresh
        # frames need the rates alone, the same bits)
        if frames or it > 0:
            body_rates(model, x, work)
        else:
            body_derived(model, x, work)
        joint_rows(model, x, work, True)   # J̇ u at the current velocities
        if it == 0 and n_friction > 0 and _friction_rows(model, x, work, True) > 0:
            refactor = True
        if refactor:
            factor(model, work)
        _motor_forces(model, x, work)
        _dynamics_solve(model, x, work, work.k[0])
        changed = _release(model, work)
        if changed > 0:
            _motor_rows_on(model, work)   # a released joint's motor resumes
        changed += _saturate(model, work)
        if n_friction > 0:
            changed += _friction_slip(model, work)
            changed += _friction_rows(model, x, work, False)
        if changed == 0:
            break
        refactor = True
    _wrenches(model, work)
    _applied_efforts(model, work)
    if n_friction > 0:
        _friction_efforts(model, work)


@_jit
def _end_of_step(model, x, work):
    """
    Factor at the projected positions, project velocities, then ``ẋ`` (next k1) and ``λ``.

    Right after a :func:`~.projection._project_positions` that converged: it left every row
    (``C``, ``J``, ``J̇ u``) at ``x``.
    """
    body_derived(model, x, work)
    _friction_stops(model, x, work)
    factor(model, work)
    _project_velocities(model, x, work)
    _dynamics_at(model, x, work, False, True)
    _unwrap(model, x, work)


@_jit
def initialize(model, x, work, tol, max_iter):
    """Project ``x`` onto the joints (full Newton), then velocities; fill k1, λ, wrenches."""
    it = _project_positions(model, x, work, tol, max_iter, 0)
    work.stats[S_ITER] = it
    _end_of_step(model, x, work)
    return it


@_jit
def _rk4(model, x, work, h, tol, max_iter):
    """One RK4 step of size ``h`` from ``x`` (``work.k[0]`` = ``ẋ``) and the projections."""
    k, xs = work.k, work.xs
    n_b = x.shape[0]
    t0 = work.stats[S_TIME]
    for stage in range(1, 4):
        c = 0.5 * h if stage < 3 else h
        for b in range(n_b):
            for i in range(13):
                xs[b, i] = x[b, i] + c * k[stage - 1, b, i]
        work.stats[S_TSTAGE] = t0 + c
        _accelerations(model, xs, work, k[stage])
    for b in range(n_b):
        for i in range(13):
            x[b, i] += (h / 6.0) * (k[0, b, i] + 2.0 * (k[1, b, i] + k[2, b, i]) + k[3, b, i])
        qw, qx, qy, qz = x[b, 3], x[b, 4], x[b, 5], x[b, 6]
        q = 1.0 / math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        x[b, 3], x[b, 4], x[b, 5], x[b, 6] = qw * q, qx * q, qy * q, qz * q
    work.stats[S_TSTAGE] = t0 + h
    it = _project_positions(model, x, work, tol, max_iter, 3)
    if it < 0:
        return it
    _end_of_step(model, x, work)
    return it
