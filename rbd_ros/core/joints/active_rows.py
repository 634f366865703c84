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
The articulated step's active rows: which limit, motor and friction rows are held.

A limit row is held at its bound and released when its multiplier would pull
(:func:`set_limit`, ``_release``); a position or velocity motor's row is on unless a held
limit pauses it, and switched off when its multiplier exceeds the effort limit (``_saturate``);
a stuck joint's friction row is held until its multiplier exceeds the friction, and a sliding
joint sticks when its rate reaches zero (``_friction_*``). Each change rebuilds the joint's
list of rows (:func:`refresh_rows`). Also the readouts of the motors' and frictions' efforts.
Called by the dynamics (:mod:`.dynamics`, at each evaluation) and by the events
(:mod:`.events`); a row's rate comes from :mod:`.rows`.
"""

from rbd_ros.core import jitcache
from rbd_ros.core.joints.arrays import (
    F_APPLIED, F_RATE0, F_RATE_END, F_SIGN, F_SIGN0, F_STOPPED, J_FRICROW, J_FRICTION, J_KIND,
    J_LIMROW, J_MOTROW, J_NROWS, J_ROW0, M_APPLIED, M_EFFORT, M_LIMIT, M_MODE, M_SAT,
    MOTOR_EFFORT, MOTOR_OFF, MOTOR_POSITION, MOTOR_VELOCITY, ROW_MOTOR)
from rbd_ros.core.joints.rows import _row_rate

_jit = jitcache.raw_kernel()
_inl = jitcache.kernel(inline='always')


#: A joint whose motor row drives it is at rest for its friction while ``|q̇|`` is at most this
#: (rad/s or m/s): friction then adds no force and leaves the motor to hold it. The same bound
#: decides whether a joint starts stuck.
FRICTION_REST_RATE = 1e-12


@_jit
def refresh_rows(model, work, j):
    """Rebuild joint ``j``'s list of active rows (``work.jrows``, ``nrow``, its node's size)."""
    n = 0
    row0 = model.jint[j, J_ROW0]
    for r in range(model.jint[j, J_NROWS]):
        if work.active[row0 + r] != 0:
            work.jrows[j, n] = row0 + r
            n += 1
    work.nrow[j] = n
    work.dim[model.prm.shape[0] + j] = n


@_jit
def set_limit(model, work, j, state):
    """Hold joint ``j``'s limit row at its upper (``state`` 1) or lower (-1) bound; 0 frees."""
    work.lim_state[j] = state
    work.active[model.jint[j, J_LIMROW]] = 1 if state != 0 else 0
    motor_row = model.jint[j, J_MOTROW]
    if motor_row >= 0 and state != 0:
        work.active[motor_row] = 0   # a held limit pauses the joint's motor
    if model.jint[j, J_KIND] == 4 and state != 0:
        # and a ball joint's three (its cone limit held): they are back at the next boundary
        row0 = model.jint[j, J_ROW0]
        for r in range(model.jint[j, J_NROWS]):
            if model.rows[row0 + r, 1] == ROW_MOTOR:
                work.active[row0 + r] = 0
    friction_row = model.jint[j, J_FRICROW]
    if friction_row >= 0 and state != 0:
        work.active[friction_row] = 0   # and its friction: the stop holds it
    refresh_rows(model, work, j)


@_jit
def _release(model, work):
    """Release every held limit whose multiplier would pull (no sticking); return how many."""
    jint, lam = model.jint, work.lam
    released = 0
    for j in range(jint.shape[0]):
        state = work.lim_state[j]
        if state == 0:
            continue
        # the row's multiplier is the generalized force along q on the child: a stop at the
        # upper bound may only push down (λ <= 0), one at the lower bound only up (λ >= 0)
        if state * lam[jint[j, J_LIMROW]] > 0.0:
            set_limit(model, work, j, 0)
            released += 1
    return released


@_jit
def _saturate(model, work):
    """
    Switch off every motor row whose multiplier exceeds the effort limit; return how many.

    A saturated motor pushes with ``±effort_limit`` instead (see :func:`~.dynamics._motor_forces`).
    """
    lam, motor = work.lam, work.motor
    changed = 0
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row < 0 or work.active[row] == 0:
            continue
        if abs(lam[row]) > motor[m, M_LIMIT]:
            motor[m, M_SAT] = 1.0 if lam[row] > 0.0 else -1.0
            work.active[row] = 0
            refresh_rows(model, work, model.rows[row, 0])
            changed += 1
    return changed


@_inl
def _set_active(model, work, j, row, want):
    """Set row ``row`` of joint ``j`` active (1) or not (0); return 1 if that changed it."""
    if work.active[row] == want:
        return 0
    work.active[row] = want
    refresh_rows(model, work, j)
    return 1


@_jit
def _motor_rows_on(model, work):
    """Turn on the row of every position / velocity motor not paused by a held limit."""
    motor = work.motor
    changed = 0
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row < 0:
            continue
        j = model.rows[row, 0]
        mode = motor[m, M_MODE]
        want = 1 if ((mode == MOTOR_VELOCITY or mode == MOTOR_POSITION)
                     and work.lim_state[j] == 0) else 0
        motor[m, M_SAT] = 0.0
        changed += _set_active(model, work, j, row, want)
    return changed


@_jit
def _applied_efforts(model, work):
    motor = work.motor
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row < 0:
            continue
        mode = motor[m, M_MODE]
        if mode == MOTOR_EFFORT:
            motor[m, M_APPLIED] = min(max(motor[m, M_EFFORT], -motor[m, M_LIMIT]),
                                      motor[m, M_LIMIT])
        elif work.active[row] != 0:
            motor[m, M_APPLIED] = work.lam[row]
        elif mode != MOTOR_OFF and motor[m, M_SAT] != 0.0:
            motor[m, M_APPLIED] = motor[m, M_SAT] * motor[m, M_LIMIT]
        else:
            motor[m, M_APPLIED] = 0.0


@_jit
def _friction_rows(model, x, work, update):
    """
    Hold the friction row of every stuck joint that no motor row or limit holds; return changes.

    With ``update`` (at a step boundary, rows at ``x``), a joint driven by its motor row or
    held at a limit, or not decided yet, takes its friction state from its rate: at rest
    (``|q̇| <= FRICTION_REST_RATE``: 0) or sliding along ``sign(q̇)``.
    """
    jint, fric = model.jint, work.fric
    changed = 0
    for j in range(jint.shape[0]):
        row = jint[j, J_FRICROW]
        if row < 0:
            continue
        motor_on = work.active[jint[j, J_MOTROW]] != 0
        held = work.lim_state[j] != 0
        if update and (motor_on or held or fric[j, F_SIGN] == 2.0):
            rate = _row_rate(model, x, work, row, 2)
            if abs(rate) <= FRICTION_REST_RATE:
                fric[j, F_SIGN] = 0.0
            else:
                fric[j, F_SIGN] = 1.0 if rate > 0.0 else -1.0
        want = 1 if (fric[j, F_SIGN] == 0.0 and not motor_on and not held) else 0
        changed += _set_active(model, work, j, row, want)
    return changed


@_jit
def _friction_slip(model, work):
    """
    Let go every stuck joint whose holding force exceeds its friction; return how many.

    The row's multiplier ``λ`` is the force along ``q`` that would hold the joint; beyond the
    friction it slides the other way, ``s = -sign(λ)``, against the force ``-f s = f sign(λ)``.
    """
    jint, jprm, lam, fric = model.jint, model.jprm, work.lam, work.fric
    changed = 0
    for j in range(jint.shape[0]):
        row = jint[j, J_FRICROW]
        if row < 0 or work.active[row] == 0:
            continue
        if abs(lam[row]) > jprm[j, J_FRICTION]:
            fric[j, F_SIGN] = -1.0 if lam[row] > 0.0 else 1.0
            work.active[row] = 0
            refresh_rows(model, work, j)
            changed += 1
    return changed


@_jit
def _friction_stops(model, x, work):
    """
    Stick every sliding joint whose rate has reached or crossed zero (rows at ``x``).

    Its friction row is held, so the velocity projection that follows stops it. Each sliding
    joint's rate here is kept (``F_RATE_END``) and a joint stopped here is marked
    (``F_STOPPED``): :func:`~.kernels.step` locates a stop that crossed zero inside the step, so
    what the projection takes out is at most :data:`~.events.STOP_RATE_TOL`.
    """
    jint, fric = model.jint, work.fric
    for j in range(jint.shape[0]):
        row = jint[j, J_FRICROW]
        if row < 0:
            continue
        fric[j, F_STOPPED] = 0.0
        sign = fric[j, F_SIGN]
        if not (sign == 1.0 or sign == -1.0) or work.active[jint[j, J_MOTROW]] != 0 \
                or work.lim_state[j] != 0:
            continue
        rate = _row_rate(model, x, work, row, 2)
        fric[j, F_RATE_END] = rate
        if sign * rate <= 0.0:
            fric[j, F_SIGN] = 0.0
            fric[j, F_STOPPED] = 1.0
            work.active[row] = 1
            refresh_rows(model, work, j)


@_jit
def _friction_event(model, work):
    """
    Return the joint whose sliding stopped first inside the last sub-step, or -1.

    A joint that slid at the sub-step's start and whose rate crossed zero strictly by its end;
    the first by the linear estimate ``r0 / (r0 - r_end)`` of when (``r = s q̇``).
    """
    jint, fric = model.jint, work.fric
    best, first = -1, 2.0
    for j in range(jint.shape[0]):
        if jint[j, J_FRICROW] < 0 or fric[j, F_STOPPED] == 0.0:
            continue
        sign = fric[j, F_SIGN0]
        r0, r1 = sign * fric[j, F_RATE0], sign * fric[j, F_RATE_END]
        if (sign == 1.0 or sign == -1.0) and r0 > 0.0 and r1 < 0.0 and r0 / (r0 - r1) < first:
            best, first = j, r0 / (r0 - r1)
    return best


@_jit
def _friction_efforts(model, work):
    """``work.fric[:, F_APPLIED]``: each friction's generalized force on the child along q."""
    jint, jprm, fric = model.jint, model.jprm, work.fric
    for j in range(jint.shape[0]):
        row = jint[j, J_FRICROW]
        if row < 0:
            fric[j, F_APPLIED] = 0.0
        elif work.active[row] != 0:
            fric[j, F_APPLIED] = work.lam[row]
        elif fric[j, F_SIGN] == 1.0 or fric[j, F_SIGN] == -1.0:
            fric[j, F_APPLIED] = -jprm[j, J_FRICTION] * fric[j, F_SIGN]
        else:
            fric[j, F_APPLIED] = 0.0
