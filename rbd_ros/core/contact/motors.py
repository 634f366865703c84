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
Joint motors in the contact step, driven by impulses.

A motor acts through its joint's motor row of :mod:`rbd_ros.core.joints.kernels`
(``ROW_MOTOR``, its Jacobian the joint's axial rate).

The commands are :class:`~rbd_ros.core.joints.ArticulatedSimulator`'s (``work.motor``, set by
its ``set_motor``); what each does over one step of :func:`rbd_ros.core.contact.step.
world_step`:

- **effort** ``τ`` (clipped by the joint's effort limit): the impulse ``Jᵀ τ dt`` with each
  velocity update, ``dt = h`` (symplectic Euler) or ``h/2`` at each half kick
  (kick–drift–kick), at the pose the kick is at (:func:`kick`), as gravity is given.
- **velocity** ``v*``: the motor row is a velocity row, ``J u = v*``, in the
  post-stabilization visits (``jk._project_velocities``), and the pre-stabilization lands
  the coordinate on ``q + v* h`` (:func:`motor_rows`).
- **position** ``q*`` with the time constant ``1/ω``: the error ``e = q − q*(s)`` follows
  ``ë = −2ω ė − ω² e`` exactly (Weinstein, Guendelman, Fedkiw 2008): from the step's start
  ``(e₀, ė₀)``, ``e(h) = (e₀ + (ė₀ + ω e₀) h) exp(−ω h)`` and
  ``ė(h) = (ė₀ − ω (ė₀ + ω e₀) h) exp(−ω h)``. The pre-stabilization lands the coordinate on
  ``q*(s + h) + e(h)`` as it lands a joint on its rows (to ``PROJECTION_TOL``), and the
  post-stabilization visits hold the joint's rate at ``q̇*(s) + ė₀`` at the step's start and
  at ``q̇*(s + h) + ė(h)`` at its end (the second contact stage of kick–drift–kick). ``ė₀``
  is the last step's ``ė(h)``, so the coordinates at the step boundaries are the exact
  response's, whatever loads the joint (gravity, contact): the motor takes them up.
  A motor that is set starts from the joint's rate then.

The impulses of a motor row over a step (every visit's multiplier, :func:`tally`) divided by
``h`` are its effort, the step's average. A position or velocity motor whose effort would
exceed its joint's effort limit **saturates**: the step is taken again from its start with
that row off and the motor pushing with ``±effort_limit`` (an effort, :func:`kick`), and it
tries its row again at the next step (:func:`saturate`); the tree step decides the same at
each evaluation of its dynamics.
"""

import math

from rbd_ros.core.contact.rows import _jit
from rbd_ros.core.joints import kernels as jk

#: ``drive`` columns, one row a joint: the motor row's generalized impulse over the step so far
#: (N m s or N s, on the child along q), the coordinate a position motor's drift lands on
#: (rad or m), the rate its exact response has at the step's end (rad/s or m/s), 1 when that
#: rate of the last step is the joint's rate now (0: start from the state's), the time since
#: the target was set (s), the rate the step started from (rad/s or m/s), and the limit
#: row's generalized impulse since it was held (:mod:`rbd_ros.core.contact.limits`).
D_IMPULSE = 0
D_GOAL = 1
D_RATE_END = 2
D_HELD = 3
D_TIME = 4
D_RATE0 = 5
D_STOP = 6
D_SIZE = 7


@_jit
def start(joints, attempt, h):
    """
    Begin a step (``attempt`` 0) or its retry: motor rows on, the motors' goals for the drift.

    ``joints.jx`` holds the state at the step's start. At attempt 0 every position and
    velocity motor tries its row (``jk._motor_rows_on``); a retry keeps the motors
    :func:`saturate` switched off. A velocity motor's goal is ``q + v* h``.
    """
    model, work, drive, jx = joints.model, joints.work, joints.drive, joints.jx
    motor = work.motor
    if attempt == 0:
        jk._motor_rows_on(model, work)
    driven = False
    for j in range(model.jint.shape[0]):
        drive[j, D_IMPULSE] = 0.0
        row = model.jint[j, jk.J_MOTROW]
        if row >= 0 and work.active[row] != 0:
            driven = True
    if not driven:
        return
    jk.body_derived(model, jx, work)
    jk.joint_rows(model, jx, work, True)
    for j in range(model.jint.shape[0]):
        row = model.jint[j, jk.J_MOTROW]
        if row < 0 or work.active[row] == 0:
            continue
        if motor[j, jk.M_MODE] == jk.MOTOR_VELOCITY:
            drive[j, D_GOAL] = work.axial[j, 0] + motor[j, jk.M_VELOCITY] * h
            continue
        w = motor[j, jk.M_OMEGA]
        vr, ar = motor[j, jk.M_VREF], motor[j, jk.M_AREF]
        s = drive[j, D_TIME]
        if attempt == 0:
            drive[j, D_RATE0] = drive[j, D_RATE_END] if drive[j, D_HELD] != 0.0 \
                else jk._row_rate(model, jx, work, row, 2)
        rate = drive[j, D_RATE0]
        e0 = work.axial[j, 0] - (motor[j, jk.M_POSITION] + (vr + 0.5 * ar * s) * s)
        ed0 = rate - (vr + ar * s)
        decay = math.exp(-w * h)
        c = ed0 + w * e0
        s1 = s + h
        drive[j, D_GOAL] = (motor[j, jk.M_POSITION] + (vr + 0.5 * ar * s1) * s1
                            + (e0 + c * h) * decay)
        drive[j, D_RATE_END] = vr + ar * s1 + (ed0 - w * c * h) * decay
        motor[j, jk.M_HOLD] = 1.0
        motor[j, jk.M_HOLD_RATE] = rate


@_jit
def motor_rows(joints):
    """
    Pre-stabilization: each motor row's error after ``jk.joint_rows`` at the drifted pose.

    ``C`` is the coordinate there (``work.axial``) less :data:`D_GOAL`: a position motor's
    exact response, or a velocity motor's ``q + v* h``, so that its coordinate grows by
    exactly ``v* h`` a step whatever the drift's map of rates to turns (kick–drift–kick's
    Cayley map turns by ``2 atan(ω h / 2)``).
    """
    model, work, drive = joints.model, joints.work, joints.drive
    for j in range(model.jint.shape[0]):
        row = model.jint[j, jk.J_MOTROW]
        if row >= 0 and work.active[row] != 0:
            work.con[row] = work.axial[j, 0] - drive[j, D_GOAL]


@_jit
def tally(joints):
    """Add the last solve's motor multipliers (``−yj``: along q on the child) to the step's."""
    model, work, drive = joints.model, joints.work, joints.drive
    for j in range(model.jint.shape[0]):
        row = model.jint[j, jk.J_MOTROW]
        if row >= 0 and work.active[row] != 0:
            drive[j, D_IMPULSE] -= work.yj[row]


@_jit
def kick(joints, dt, end):
    """
    Give every effort motor (and saturated motor) its impulse ``Jᵀ τ dt`` at ``jx``.

    Return whether any did (``jx``'s velocities then changed).

    ``τ`` the effort clipped by the effort limit, or ``±effort_limit`` for a saturated motor;
    ``end``: the kick at the step's end (the post-stabilization then holds a position motor
    at its end rate).
    """
    model, work, drive, jx = joints.model, joints.work, joints.drive, joints.jx
    motor, jint = work.motor, model.jint
    pushed = False
    for j in range(jint.shape[0]):
        row = jint[j, jk.J_MOTROW]
        if row < 0:
            continue
        mode = motor[j, jk.M_MODE]
        if mode == jk.MOTOR_EFFORT or (mode != jk.MOTOR_OFF and motor[j, jk.M_SAT] != 0.0):
            pushed = True
        if end and mode == jk.MOTOR_POSITION and work.active[row] != 0:
            motor[j, jk.M_HOLD_RATE] = drive[j, D_RATE_END]
    if not pushed:
        return False
    jk.body_derived(model, jx, work)
    jk.joint_rows(model, jx, work, True)
    prm, bd, jac = model.prm, work.bd, work.jac
    for j in range(jint.shape[0]):
        row = jint[j, jk.J_MOTROW]
        if row < 0:
            continue
        mode = motor[j, jk.M_MODE]
        if mode == jk.MOTOR_EFFORT:
            tau = min(max(motor[j, jk.M_EFFORT], -motor[j, jk.M_LIMIT]), motor[j, jk.M_LIMIT])
        elif mode != jk.MOTOR_OFF and motor[j, jk.M_SAT] != 0.0:
            tau = motor[j, jk.M_SAT] * motor[j, jk.M_LIMIT]
        else:
            continue
        p = tau * dt
        for side in range(2):
            b = jk._side_body(model, row, side)
            if b < 0:
                continue
            o = 6 * side
            inv_m = 1.0 / prm[b, jk.P_MASS]
            for k in range(3):
                jx[b, 7 + k] += p * jac[row, o + k] * inv_m
            # Δω_b = I_b⁻¹ Rᵀ (p J_ω)
            t0, t1, t2 = jk._mtv(bd, b, jk.B_ROT, p * jac[row, o + 3], p * jac[row, o + 4],
                                 p * jac[row, o + 5])
            t0, t1, t2 = jk._mv(prm, b, jk.P_INERTIA_INV, t0, t1, t2)
            jx[b, 10] += t0
            jx[b, 11] += t1
            jx[b, 12] += t2
    return True


@_jit
def saturate(joints, h):
    """
    Switch off every motor row whose step's effort exceeded its limit; return whether any.

    Such a motor pushes with ``±effort_limit`` (its sign the effort's) when the step is taken
    again (:func:`kick`); its exact response starts again from the joint's state.
    """
    model, work, drive = joints.model, joints.work, joints.drive
    motor = work.motor
    changed = False
    for j in range(model.jint.shape[0]):
        row = model.jint[j, jk.J_MOTROW]
        if row < 0 or work.active[row] == 0:
            continue
        if abs(drive[j, D_IMPULSE]) > motor[j, jk.M_LIMIT] * h:
            motor[j, jk.M_SAT] = 1.0 if drive[j, D_IMPULSE] > 0.0 else -1.0
            motor[j, jk.M_HOLD] = 0.0
            drive[j, D_HELD] = 0.0
            work.active[row] = 0
            jk.refresh_rows(model, work, j)
            changed = True
    return changed


@_jit
def finish(joints, h):
    """
    End a step: the efforts (``work.motor[:, M_APPLIED]``), the targets' time, the unwrap.

    ``jx`` holds the step's end pose, from which each continuous joint's running angle is
    kept (``jk._unwrap``).
    """
    model, work, drive = joints.model, joints.work, joints.drive
    motor = work.motor
    for j in range(model.jint.shape[0]):
        row = model.jint[j, jk.J_MOTROW]
        if row < 0:
            continue
        mode = motor[j, jk.M_MODE]
        drive[j, D_TIME] += h
        # the exact response goes on from this step's end while its row held the joint
        drive[j, D_HELD] = 1.0 if mode == jk.MOTOR_POSITION and work.active[row] != 0 else 0.0
        if mode == jk.MOTOR_EFFORT:
            motor[j, jk.M_APPLIED] = min(max(motor[j, jk.M_EFFORT], -motor[j, jk.M_LIMIT]),
                                         motor[j, jk.M_LIMIT])
        elif work.active[row] != 0:
            motor[j, jk.M_APPLIED] = drive[j, D_IMPULSE] / h
        elif mode != jk.MOTOR_OFF and motor[j, jk.M_SAT] != 0.0:
            motor[j, jk.M_APPLIED] = motor[j, jk.M_SAT] * motor[j, jk.M_LIMIT]
        else:
            motor[j, jk.M_APPLIED] = 0.0
    jk._unwrap(model, joints.jx, work)
