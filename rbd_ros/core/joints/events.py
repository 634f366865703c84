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
The articulated step's events inside a sub-step: limit crossings and friction stops.

``_crossing`` finds the free limit crossed deepest after a sub-step; ``_locate`` finds when an
event happened by the Illinois method, each trial a full RK4 sub-step (:mod:`.dynamics`) from
the start kept by ``_save_start`` (and put back by ``_restore``); ``_hold_at_bounds`` holds
the other limits met in the same impact; ``_clamped_rest`` takes the rest of a step whose
event passes ran out. The driver (:func:`rbd_ros.core.joints.kernels.step`) calls them; the
rows held come from :mod:`.active_rows`.
"""

from rbd_ros.core import jitcache
from rbd_ros.core.joints.active_rows import refresh_rows, set_limit
from rbd_ros.core.joints.arrays import (
    B_OMEGA_W, F_ACTIVE0, F_RATE0, F_RATE_END, F_SIGN, F_SIGN0, J_CHILD, J_FRICROW, J_LIMROW,
    J_PARENT, L_HAS_LOWER, L_HAS_UPPER, L_LOWER, L_UPPER, S_TIME, S_TSTAGE)
from rbd_ros.core.joints.dynamics import _end_of_step, _rk4
from rbd_ros.core.joints.projection import _project_positions
from rbd_ros.core.joints.rows import _row_rate, body_derived, joint_rows, limit_coordinate
from rbd_ros.core.joints.solve import factor

_jit = jitcache.raw_kernel()


#: A limit is crossed when the joint is beyond its bound by more than this (rad or m); the
#: crossing is then located inside the step to :data:`LOCATE_TOL`.
CROSS_TOL = 1e-13
LOCATE_TOL = 1e-14
LOCATE_MAX_ITER = 60
#: What :func:`_locate` finds: a limit crossing, or a sliding joint's stop (Coulomb friction).
EVENT_LIMIT = 0
EVENT_STOP = 1


#: A sliding joint's stop inside a step is located until its rate is within this (rad/s or
#: m/s) of zero, as a limit crossing is (:data:`LOCATE_TOL`).
STOP_RATE_TOL = 1e-14


@_jit
def _crossing(model, x, work):
    """Return ``(joint, bound side, excess)`` of the free limit crossed deepest, or (-1, 0, 0)."""
    jint, jlim = model.jint, model.jlim
    best, side, excess = -1, 0, 0.0
    for j in range(jint.shape[0]):
        if jint[j, J_LIMROW] < 0 or work.lim_state[j] != 0:
            continue
        q = limit_coordinate(model, x, j)
        if jlim[j, L_HAS_UPPER] != 0.0 and q - jlim[j, L_UPPER] > max(CROSS_TOL, excess):
            best, side, excess = j, 1, q - jlim[j, L_UPPER]
        if jlim[j, L_HAS_LOWER] != 0.0 and jlim[j, L_LOWER] - q > max(CROSS_TOL, excess):
            best, side, excess = j, -1, jlim[j, L_LOWER] - q
    return best, side, excess


@_jit
def _restore(model, x, work):
    work.stats[S_TSTAGE] = work.stats[S_TIME]
    for b in range(x.shape[0]):
        for i in range(13):
            x[b, i] = work.x0[b, i]
            work.k[0, b, i] = work.k0[b, i]
    for j in range(model.jint.shape[0]):
        if model.jint[j, J_LIMROW] >= 0 and work.lim_state[j] != work.lim0[j]:
            set_limit(model, work, j, work.lim0[j])
    for j in range(model.jint.shape[0]):
        row = model.jint[j, J_FRICROW]
        if row >= 0:
            work.fric[j, F_SIGN] = work.fric[j, F_SIGN0]
            if work.active[row] != work.fric[j, F_ACTIVE0]:
                work.active[row] = int(work.fric[j, F_ACTIVE0])
                refresh_rows(model, work, j)


@_jit
def _joint_speed(model, x, work, j):
    """Return the rate of joint ``j``'s limited coordinate: its limit row's ``J u``."""
    body_derived(model, x, work)
    joint_rows(model, x, work, True)
    jint, row = model.jint, model.jint[j, J_LIMROW]
    s = 0.0
    for side in range(2):
        b = jint[j, J_CHILD] if side == 1 else jint[j, J_PARENT]
        if b >= 0:
            for i in range(3):
                s += (work.jac[row, 6 * side + i] * x[b, 7 + i]
                      + work.jac[row, 6 * side + 3 + i] * work.bd[b, B_OMEGA_W + i])
    return s


@_jit
def _hold_at_bounds(model, x, work):
    """
    Hold every free limit at its bound (to :data:`CROSS_TOL`) moving into it; return how many.

    Called at a stop, so that joints reaching their bounds together stop in one impact: one
    stopped alone would let the other's impulse drive it back into its bound, the two
    released and re-stopped in turn until a sub-step began past a bound.
    """
    jint, jlim = model.jint, model.jlim
    held = 0
    for j in range(jint.shape[0]):
        if jint[j, J_LIMROW] < 0 or work.lim_state[j] != 0:
            continue
        q = limit_coordinate(model, x, j)
        side = 0
        if jlim[j, L_HAS_UPPER] != 0.0 and q - jlim[j, L_UPPER] >= -CROSS_TOL:
            side = 1
        elif jlim[j, L_HAS_LOWER] != 0.0 and jlim[j, L_LOWER] - q >= -CROSS_TOL:
            side = -1
        if side != 0 and side * _joint_speed(model, x, work, j) > 0.0:
            set_limit(model, work, j, side)
            held += 1
    return held


@_jit
def _save_start(model, x, work):
    """Keep the sub-step's start for :func:`_restore`: ``x``, ``ẋ``, the limits and frictions."""
    for b in range(x.shape[0]):
        for i in range(13):
            work.x0[b, i] = x[b, i]
            work.k0[b, i] = work.k[0, b, i]
    for j in range(model.jint.shape[0]):
        work.lim0[j] = work.lim_state[j]
        if model.jint[j, J_FRICROW] >= 0:
            work.fric[j, F_SIGN0] = work.fric[j, F_SIGN]
            work.fric[j, F_ACTIVE0] = work.active[model.jint[j, J_FRICROW]]
            # rows and ω_w are at x (left by the last dynamics evaluation)
            work.fric[j, F_RATE0] = _row_rate(model, x, work, model.jint[j, J_FRICROW], 2)


@_jit
def _clamped_rest(model, x, work, h, tol, max_iter):
    """
    Take ``h``, the rest of a step whose event passes ran out, as one sub-step, limits clamped.

    One RK4 sub-step and projection; then every free limit crossed in it (by more than
    :data:`CROSS_TOL`) is held at its bound, with every other free limit at its bound and
    moving into it (:func:`_hold_at_bounds`), the positions are projected onto them and the
    velocity projection takes out the speed into them: an inelastic stop at the sub-step's
    end instead of at its crossing, so no joint ends beyond its bound. Return ``(iterations,
    the joint crossed deepest or -1, its rate before the stop)``; iterations < 0 when a
    projection failed (the caller restores the sub-step's start).
    """
    it = _rk4(model, x, work, h, tol, max_iter)
    if it < 0:
        return it, -1, 0.0
    first, speed = -1, 0.0
    j, side, _ = _crossing(model, x, work)
    while j >= 0:
        if first < 0:
            first, speed = j, _joint_speed(model, x, work, j)
        set_limit(model, work, j, side)
        j, side, _ = _crossing(model, x, work)
    if first < 0:
        return it, -1, 0.0
    _hold_at_bounds(model, x, work)
    body_derived(model, x, work)
    joint_rows(model, x, work, True)
    factor(model, work)
    it_stop = _project_positions(model, x, work, tol, max_iter, 0)
    if it_stop < 0:
        return it_stop, first, speed
    _end_of_step(model, x, work)
    return max(it, it_stop), first, speed


@_jit
def _locate(model, x, work, event, j, side, bound, g_lo, hi, g_hi, h, tol, max_iter):
    """
    Find when an event inside the sub-step from ``work.x0`` happened; return ``(τ, g(τ))``.

    The Illinois method (regula falsi halving the end that stays) on ``g`` over ``(0, hi)``,
    ``g(0) = g_lo <= 0 < g(hi) = g_hi``, each trial a full RK4 sub-step and projection from
    the sub-step's start, until ``|g| <=`` the event's tolerance or the bracket is below
    ``1e-15 h``. ``event`` selects ``g``: :data:`EVENT_LIMIT`, joint ``j``'s limit crossing,
    ``g = side (q - bound)`` to :data:`LOCATE_TOL`; :data:`EVENT_STOP`, its sliding stop,
    ``g = -side q̇`` (``side`` its sliding direction) to :data:`STOP_RATE_TOL`. ``x`` is left
    at the last trial. ``τ = -1`` when a trial's projection failed (``x`` back at the start).
    """
    lo = 0.0
    tau = hi
    g = g_hi
    g_tol = LOCATE_TOL if event == EVENT_LIMIT else STOP_RATE_TOL
    for _ in range(LOCATE_MAX_ITER):
        tau = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
        _restore(model, x, work)
        if _rk4(model, x, work, tau, tol, max_iter) < 0:
            _restore(model, x, work)  # stays finite: back to the sub-step start
            return -1.0, g
        if event == EVENT_LIMIT:
            g = side * (limit_coordinate(model, x, j) - bound)
        else:
            g = -side * work.fric[j, F_RATE_END]
        if abs(g) <= g_tol or hi - lo <= 1e-15 * h:
            break
        if g > 0.0:
            hi, g_hi = tau, g
            g_lo *= 0.5   # Illinois: halve the end that stays
        else:
            lo, g_lo = tau, g
            g_hi *= 0.5
    return tau, g
