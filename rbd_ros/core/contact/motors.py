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
(``ROW_MOTOR``, its Jacobian the joint's axial rate). Motors are kept by *slot* (a row of
``work.motor`` and of ``drive``; ``model.mrows`` the motor row of each): slot ``j`` is joint
``j``'s (a one-coordinate joint's, a planar joint's x, a universal joint's θ1), the slots
after the joints a planar joint's y and theta and a universal joint's θ2, so a planar or
universal joint's coordinates are driven one a slot, each exactly as a one-coordinate joint
(a planar joint's x and y as a prismatic joint's, its theta and a universal joint's angles as
a revolute joint's). Friction, damping and limits are per joint (one-coordinate joints only,
whose slot is the joint's index).

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

**Coulomb friction** ``f`` of a joint is a velocity target 0 with the effort bound ``f``,
solved as the motors are: its friction row (``ROW_FRICTION``, the joint's axial Jacobian) is a
velocity row ``J u = 0`` in the post-stabilization visits, and the pre-stabilization lands
the coordinate where the step started (:data:`D_REST`), so a joint that sticks does not move
at all. Its impulses over the step (:data:`D_FRICTION`) are the effort holding it; one beyond
``f h`` lets it slip: the step is taken again with the row off and the friction pushing with
``f`` against the slip (``work.fric[j, F_SIGN]``, the sliding direction ``s``, the force
``-f s``; :func:`kick`), ``s`` opposite to the holding effort. So a sliding joint slows at
``f`` exactly and stops in the step whose stop needs no more than ``f h``, where it stays
while the effort holding it is within ``f``. Every step starts by trying the row again
(:func:`start`). A joint whose position or velocity motor row drives it (or whose limit
holds it) has its row off: the friction then pushes against the joint's rate at the step's
start, ``-f sign(q̇)``, 0 while ``|q̇| <= FRICTION_REST_RATE``, and the motor takes it up (its
effort includes it), as in the tree step. The friction's effort over the step is
``work.fric[j, F_APPLIED]`` (:func:`finish`).

**Damping** ``d`` is the exact flow of ``-d q̇`` over the step (:func:`damp`), between
two projections with every row on (:func:`rbd_ros.core.contact.joints.damp`, where
:func:`rbd_ros.core.contact.step.world_step` puts it): a joint its motor, limit or friction
holds has the rate of its hold when the flow acts, so at rest the damping does nothing.
"""

import math

from rbd_ros.core.contact.rows import _inl, _jit
from rbd_ros.core.joints import kernels as jk
from rbd_ros.core.joints.rows import _joint_turn

#: ``drive`` columns, one row a motor slot (slot ``j`` is joint ``j``'s): the motor row's
#: generalized impulse over the step so far (N m s or N s, on the child along q), the
#: coordinate a position motor's drift lands on (rad or m), the rate its exact response has at
#: the step's end (rad/s or m/s), 1 when that rate of the last step is the joint's rate now (0:
#: start from the state's), the time since the target was set (s), the rate the step started
#: from (rad/s or m/s), and, per joint (its slot), the limit row's generalized impulse since it
#: was held (:mod:`rbd_ros.core.contact.limits`), the friction row's generalized impulse over
#: the step (N m s or N s, on the child along q) and the coordinate a stuck joint stays at (rad
#: or m: the step's start).
D_IMPULSE = 0
D_GOAL = 1
D_RATE_END = 2
D_HELD = 3
D_TIME = 4
D_RATE0 = 5
D_STOP = 6
D_FRICTION = 7
D_REST = 8
#: A ball joint's turn ``e = q_pc q_rest⁻¹`` at the step's start (w, x, y, z; its first slot's
#: row), from which its velocity motors' goal turns (:func:`_ball_rows`).
D_TURN = 9
D_SIZE = 13


@_jit
def friction_row(joints, j):
    """
    Set joint ``j``'s friction row on when its friction sticks it and nothing else holds it.

    On: friction (a row), not slipping (``F_SIGN`` 0), no limit held, no motor row on.
    """
    model, work = joints.model, joints.work
    row = model.jint[j, jk.J_FRICROW]
    if row < 0:
        return
    motor_row = model.jint[j, jk.J_MOTROW]
    want = 1 if (work.fric[j, jk.F_SIGN] == 0.0 and work.lim_state[j] == 0
                 and work.active[motor_row] == 0) else 0
    if work.active[row] != want:
        work.active[row] = want
        jk.refresh_rows(model, work, j)


@_jit
def count_friction(joints):
    """Return the number of joints with Coulomb friction (each may slip once a step)."""
    n = 0
    for j in range(joints.model.jint.shape[0]):
        if joints.model.jint[j, jk.J_FRICROW] >= 0:
            n += 1
    return n


@_jit
def start(joints, attempt, h):
    """
    Begin a step (``attempt`` 0) or its retry: motor rows on, the motors' goals for the drift.

    ``joints.jx`` holds the state at the step's start. At attempt 0 every position and
    velocity motor tries its row (``jk._motor_rows_on``), and every joint with friction its
    friction row unless a motor row drives it (its friction then pushes against its rate);
    a retry keeps the motors and frictions :func:`saturate` switched off. A velocity motor's
    goal is ``q + v* h``, a stuck joint's ``q``.
    """
    model, work, drive, jx = joints.model, joints.work, joints.drive, joints.jx
    motor, jint = work.motor, model.jint
    mrows = model.mrows
    if attempt == 0:
        jk._motor_rows_on(model, work)
    driven = False
    rubbing = False
    for m in range(mrows.shape[0]):
        drive[m, D_IMPULSE] = 0.0
        row = mrows[m]
        if row >= 0 and work.active[row] != 0:
            driven = True
    for j in range(jint.shape[0]):
        if jint[j, jk.J_FRICROW] >= 0:
            drive[j, D_FRICTION] = 0.0
            rubbing = True
    if not driven and not rubbing:
        return
    jk.body_derived(model, jx, work)
    jk.joint_rows(model, jx, work, True)
    if rubbing:
        for j in range(jint.shape[0]):
            if jint[j, jk.J_FRICROW] < 0:
                continue
            drive[j, D_REST] = work.axial[j, 0]
            if attempt == 0:
                work.fric[j, jk.F_SIGN] = 0.0
                row = jint[j, jk.J_MOTROW]
                if work.active[row] != 0:   # the motor moves it: friction against its rate
                    rate = jk._row_rate(model, jx, work, row, 2)
                    if abs(rate) > jk.FRICTION_REST_RATE:
                        work.fric[j, jk.F_SIGN] = 1.0 if rate > 0.0 else -1.0
            friction_row(joints, j)
    if not driven:
        return
    for m in range(mrows.shape[0]):   # motor slots (see the module docstring)
        row = mrows[m]
        if row < 0 or work.active[row] == 0:
            continue
        j = model.rows[row, 0]
        ball = jint[j, jk.J_KIND] == _BALL
        if ball:   # its turn now, what its goal turn starts from (_ball_rows)
            drive[j, D_TURN], drive[j, D_TURN + 1], drive[j, D_TURN + 2], \
                drive[j, D_TURN + 3] = _joint_turn(model, jx, j)
        if motor[m, jk.M_MODE] == jk.MOTOR_VELOCITY:
            # a ball joint's goal: the turn ω* h from the step's start (_ball_rows)
            drive[m, D_GOAL] = (0.0 if ball else work.axial[m, 0]) \
                + motor[m, jk.M_VELOCITY] * h
            continue
        w = motor[m, jk.M_OMEGA]
        vr, ar = motor[m, jk.M_VREF], motor[m, jk.M_AREF]
        s = drive[m, D_TIME]
        if attempt == 0:
            drive[m, D_RATE0] = drive[m, D_RATE_END] if drive[m, D_HELD] != 0.0 \
                else jk._row_rate(model, jx, work, row, 2)
        rate = drive[m, D_RATE0]
        e0 = work.axial[m, 0] - (motor[m, jk.M_POSITION] + (vr + 0.5 * ar * s) * s)
        ed0 = rate - (vr + ar * s)
        decay = math.exp(-w * h)
        c = ed0 + w * e0
        s1 = s + h
        drive[m, D_GOAL] = (motor[m, jk.M_POSITION] + (vr + 0.5 * ar * s1) * s1
                            + (e0 + c * h) * decay)
        drive[m, D_RATE_END] = vr + ar * s1 + (ed0 - w * c * h) * decay
        motor[m, jk.M_HOLD] = 1.0
        motor[m, jk.M_HOLD_RATE] = rate


@_jit
def motor_rows(joints):
    """
    Pre-stabilization: each motor row's error after ``jk.joint_rows`` at the drifted pose.

    ``C`` is the coordinate there (``work.axial``) less :data:`D_GOAL`: a position motor's
    exact response, or a velocity motor's ``q + v* h``, so that its coordinate grows by
    exactly ``v* h`` a step whatever the drift's map of rates to turns (kick–drift–kick's
    Cayley map turns by ``2 atan(ω h / 2)``). A friction row's ``C`` is the coordinate less
    :data:`D_REST`: a stuck joint does not move over the step.
    """
    model, work, drive = joints.model, joints.work, joints.drive
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row >= 0 and work.active[row] != 0:
            j = model.rows[row, 0]
            if model.jint[j, jk.J_KIND] == _BALL:
                if m == j:   # its three rows at once, from its first slot
                    _ball_rows(joints, j)
                continue
            work.con[row] = _turn(model, j, row, work.axial[m, 0] - drive[m, D_GOAL])
    for j in range(model.jint.shape[0]):
        row = model.jint[j, jk.J_FRICROW]
        if row >= 0 and work.active[row] != 0:   # a stuck joint stays where it started
            work.con[row] = _turn(model, j, row, work.axial[j, 0] - drive[j, D_REST])


@_inl
def _qmul(aw, ax, ay, az, bw, bx, by, bz):
    """Return the Hamilton product ``a ⊗ b`` of two quaternions (w, x, y, z)."""
    return (aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw)


@_inl
def _qexp(v0, v1, v2):
    """Return ``exp(v)``, the unit quaternion of the rotation vector ``v``."""
    n = math.sqrt(v0 * v0 + v1 * v1 + v2 * v2)
    if n == 0.0:
        return 1.0, 0.0, 0.0, 0.0
    s = math.sin(0.5 * n) / n
    return math.cos(0.5 * n), s * v0, s * v1, s * v2


@_inl
def _qlog(w, x, y, z):
    """Return the rotation vector of the unit quaternion ``(w, x, y, z)``, ``|v| <= π``."""
    if w < 0.0:
        w, x, y, z = -w, -x, -y, -z
    sv = math.sqrt(x * x + y * y + z * z)
    scale = 2.0 * math.atan2(sv, w) / sv if sv > 0.0 else 2.0
    return scale * x, scale * y, scale * z


@_inl
def _ball_slot(model, j, axis):
    """Return ``(row, slot)`` of ball joint ``j``'s motor row about the parent's ``axis``."""
    row0 = model.jint[j, jk.J_ROW0]
    for r in range(model.jint[j, jk.J_NROWS]):
        row = row0 + r
        if model.rows[row, 1] == jk.ROW_MOTOR and model.rows[row, 2] == axis:
            return row, model.rows[row, 3]
    return -1, -1


@_inl
def _ball_goal(work, drive, row, m, mode, fallback):
    """Return slot ``m``'s part of a ball joint's goal (``fallback``: its row not of ``mode``)."""
    if work.active[row] != 0 and work.motor[m, jk.M_MODE] == mode:
        return drive[m, D_GOAL]
    return fallback


@_jit
def _ball_rows(joints, j):
    """
    Pre-stabilization: ball joint ``j``'s motor rows' ``C``, its turn's error at the drift.

    ``C = log(e g⁻¹)`` on the parent's axes, ``e`` the turn at the drifted pose (``xt``) and
    ``g`` the goal turn, so near the goal ``C`` moves with the rows' own rates (``ω_rel`` on
    those axes) and Newton converges as on any row (``ψ − γ`` in the target's chart would
    not: its rate is ``J_l⁻¹(ψ) ω_rel``, a chord that stalls past ``|ψ|`` ~ 1.9 rad):

    - position targets (no velocity motor on): ``g = exp(γ) q*``, ``γ_k`` the exact
      response's error at the step's end (``D_GOAL − φ*_k``, :func:`start`), or, for a
      coordinate without a row, its error at the drift (it is left where the drift takes it);
    - with a velocity motor on: ``g = exp(δ) e₀`` from the turn at the step's start ``e₀``,
      ``δ_k = ω*_k h`` (the exact turn at a constant ``ω_rel``), a position target's
      coordinate change ``γ_k − ψ₀_k`` (exact when alone on the axis of its error), or the
      drift's own turn for a coordinate without a row.
    """
    model, work, drive, xt = joints.model, joints.work, joints.drive, joints.xt
    motor = work.motor
    r0, m0 = _ball_slot(model, j, 0)
    r1, m1 = _ball_slot(model, j, 1)
    r2, m2 = _ball_slot(model, j, 2)
    t0, t1, t2 = motor[m0, jk.M_POSITION], motor[m1, jk.M_POSITION], motor[m2, jk.M_POSITION]
    sw, sx, sy, sz = _qexp(t0, t1, t2)   # q*
    ew, ex, ey, ez = _joint_turn(model, xt, j)
    spin = False
    for r, m in ((r0, m0), (r1, m1), (r2, m2)):
        if work.active[r] != 0 and motor[m, jk.M_MODE] == jk.MOTOR_VELOCITY:
            spin = True
    pos = jk.MOTOR_POSITION
    if not spin:
        qw, qx, qy, qz = _qmul(ew, ex, ey, ez, sw, -sx, -sy, -sz)
        p0, p1, p2 = _qlog(qw, qx, qy, qz)
        qw, qx, qy, qz = _qexp(_ball_goal(work, drive, r0, m0, pos, p0 + t0) - t0,
                               _ball_goal(work, drive, r1, m1, pos, p1 + t1) - t1,
                               _ball_goal(work, drive, r2, m2, pos, p2 + t2) - t2)
        gw, gx, gy, gz = _qmul(qw, qx, qy, qz, sw, sx, sy, sz)
    else:
        aw, ax, ay, az = (drive[j, D_TURN], drive[j, D_TURN + 1], drive[j, D_TURN + 2],
                          drive[j, D_TURN + 3])
        qw, qx, qy, qz = _qmul(ew, ex, ey, ez, aw, -ax, -ay, -az)
        d0, d1, d2 = _qlog(qw, qx, qy, qz)   # the drift's turn
        qw, qx, qy, qz = _qmul(aw, ax, ay, az, sw, -sx, -sy, -sz)
        s0, s1, s2 = _qlog(qw, qx, qy, qz)   # ψ₀
        vel = jk.MOTOR_VELOCITY
        d0 = _ball_goal(work, drive, r0, m0, vel, _ball_goal(work, drive, r0, m0, pos,
                                                             d0 + t0 + s0) - t0 - s0)
        d1 = _ball_goal(work, drive, r1, m1, vel, _ball_goal(work, drive, r1, m1, pos,
                                                             d1 + t1 + s1) - t1 - s1)
        d2 = _ball_goal(work, drive, r2, m2, vel, _ball_goal(work, drive, r2, m2, pos,
                                                             d2 + t2 + s2) - t2 - s2)
        qw, qx, qy, qz = _qexp(d0, d1, d2)
        gw, gx, gy, gz = _qmul(qw, qx, qy, qz, aw, ax, ay, az)
    qw, qx, qy, qz = _qmul(ew, ex, ey, ez, gw, -gx, -gy, -gz)
    c0, c1, c2 = _qlog(qw, qx, qy, qz)
    for r, c in ((r0, c0), (r1, c1), (r2, c2)):
        if work.active[r] != 0:
            work.con[r] = c


#: The kind codes of the joints whose angles are measured in (−π, π]: a revolute joint's,
#: a universal joint's two and a planar joint's theta (its row about ``u3``, axis 2).
_REVOLUTE = jk.KIND_CODES['revolute']
_UNIVERSAL = jk.KIND_CODES['universal']
_PLANAR = jk.KIND_CODES['planar']
_BALL = jk.KIND_CODES['spherical']


@_inl
def _turn(model, j, row, d):
    """
    Return joint ``j``'s coordinate difference ``d`` on ``row``; an angle's beyond ±π: the turn.

    A revolute joint's angle is measured in (−π, π] (a continuous joint's is its running angle),
    so a joint turning through ±π over the step lands 2π away from a goal set before it: a
    velocity motor's ``q + v* h`` was missed by ~2π and the world paused. So are a universal
    joint's angles and a planar joint's theta. Within ±π, ``d`` as it is (the same bits).
    """
    kind = model.jint[j, jk.J_KIND]
    angle = kind == _REVOLUTE or kind == _UNIVERSAL or (
        kind == _PLANAR and model.rows[row, 2] == 2)
    if angle and abs(d) > math.pi:
        return d - 2.0 * math.pi * math.floor(d / (2.0 * math.pi) + 0.5)
    return d


@_jit
def tally(joints):
    """Add the last solve's motor and friction multipliers (``−yj``: along q on the child)."""
    model, work, drive = joints.model, joints.work, joints.drive
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row >= 0 and work.active[row] != 0:
            drive[m, D_IMPULSE] -= work.yj[row]
    for j in range(model.jint.shape[0]):
        row = model.jint[j, jk.J_FRICROW]
        if row >= 0 and work.active[row] != 0:
            drive[j, D_FRICTION] -= work.yj[row]


@_inl
def _rubs(model, work, j):
    """Return the friction force joint ``j`` pushes with over this step (``-f s``; 0 stuck)."""
    if model.jint[j, jk.J_FRICROW] < 0:
        return 0.0
    sign = work.fric[j, jk.F_SIGN]
    if sign == 1.0 or sign == -1.0:
        return -model.jprm[j, jk.J_FRICTION] * sign
    return 0.0


@_jit
def kick(joints, dt, end):
    """
    Give every effort motor (and saturated motor, slipping friction) ``Jᵀ τ dt`` at ``jx``.

    Return whether any did (``jx``'s velocities then changed).

    ``τ`` the effort clipped by the effort limit, or ``±effort_limit`` for a saturated motor,
    plus a slipping joint's friction ``-f s``; ``end``: the kick at the step's end (the
    post-stabilization then holds a position motor at its end rate).
    """
    model, work, drive, jx = joints.model, joints.work, joints.drive, joints.jx
    motor, mrows = work.motor, model.mrows
    pushed = False
    for m in range(mrows.shape[0]):   # motor slots; friction is a one-coordinate joint's (m = j)
        row = mrows[m]
        if row < 0:
            continue
        j = model.rows[row, 0]
        mode = motor[m, jk.M_MODE]
        if mode == jk.MOTOR_EFFORT or (mode != jk.MOTOR_OFF and motor[m, jk.M_SAT] != 0.0):
            pushed = True
        if _rubs(model, work, j) != 0.0:
            pushed = True
        if end and mode == jk.MOTOR_POSITION and work.active[row] != 0:
            motor[m, jk.M_HOLD_RATE] = drive[m, D_RATE_END]
    if not pushed:
        return False
    jk.body_derived(model, jx, work)
    jk.joint_rows(model, jx, work, True)
    for m in range(mrows.shape[0]):
        row = mrows[m]
        if row < 0:
            continue
        j = model.rows[row, 0]
        mode = motor[m, jk.M_MODE]
        if mode == jk.MOTOR_EFFORT:
            tau = min(max(motor[m, jk.M_EFFORT], -motor[m, jk.M_LIMIT]), motor[m, jk.M_LIMIT])
        elif mode != jk.MOTOR_OFF and motor[m, jk.M_SAT] != 0.0:
            tau = motor[m, jk.M_SAT] * motor[m, jk.M_LIMIT]
        elif _rubs(model, work, j) == 0.0:
            continue
        else:
            tau = 0.0
        rub = _rubs(model, work, j)
        if rub != 0.0:
            tau += rub
        _push(model, work, jx, row, tau * dt)
    return True


@_inl
def _push(model, work, jx, row, p):
    """Give ``jx`` the generalized impulse ``p`` along ``row`` (``M⁻¹ Jᵀ p``, ``jac`` at jx)."""
    prm, bd, jac = model.prm, work.bd, work.jac
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


@_jit
def saturate(joints, h):
    """
    Switch off every motor row whose step's effort exceeded its limit; return whether any.

    Such a motor pushes with ``±effort_limit`` (its sign the effort's) when the step is taken
    again (:func:`kick`); its exact response starts again from the joint's state. Likewise a
    friction row whose step's effort exceeded the friction: the joint slips, against it.
    """
    model, work, drive = joints.model, joints.work, joints.drive
    motor = work.motor
    changed = False
    for j in range(model.jint.shape[0]):
        row = model.jint[j, jk.J_FRICROW]
        if row >= 0 and work.active[row] != 0 \
                and abs(drive[j, D_FRICTION]) > model.jprm[j, jk.J_FRICTION] * h:
            # it slides away from the effort that would have held it
            work.fric[j, jk.F_SIGN] = -1.0 if drive[j, D_FRICTION] > 0.0 else 1.0
            work.active[row] = 0
            jk.refresh_rows(model, work, j)
            changed = True
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row < 0 or work.active[row] == 0:
            continue
        if abs(drive[m, D_IMPULSE]) > motor[m, jk.M_LIMIT] * h:
            motor[m, jk.M_SAT] = 1.0 if drive[m, D_IMPULSE] > 0.0 else -1.0
            motor[m, jk.M_HOLD] = 0.0
            drive[m, D_HELD] = 0.0
            work.active[row] = 0
            jk.refresh_rows(model, work, model.rows[row, 0])
            changed = True
    return changed


@_jit
def finish(joints, h):
    """
    End a step: the efforts (``work.motor[:, M_APPLIED]``), the targets' time, the unwrap.

    The frictions' efforts too (``work.fric[:, F_APPLIED]``): a stuck joint's row impulses
    over ``h``, a slipping or driven one's ``-f s``.

    ``jx`` holds the step's end pose, from which each continuous joint's running angle is
    kept (``jk._unwrap``).
    """
    model, work, drive = joints.model, joints.work, joints.drive
    motor = work.motor
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row < 0:
            continue
        mode = motor[m, jk.M_MODE]
        drive[m, D_TIME] += h
        # the exact response goes on from this step's end while its row held the joint
        drive[m, D_HELD] = 1.0 if mode == jk.MOTOR_POSITION and work.active[row] != 0 else 0.0
        if mode == jk.MOTOR_EFFORT:
            motor[m, jk.M_APPLIED] = min(max(motor[m, jk.M_EFFORT], -motor[m, jk.M_LIMIT]),
                                         motor[m, jk.M_LIMIT])
        elif work.active[row] != 0:
            motor[m, jk.M_APPLIED] = drive[m, D_IMPULSE] / h
        elif mode != jk.MOTOR_OFF and motor[m, jk.M_SAT] != 0.0:
            motor[m, jk.M_APPLIED] = motor[m, jk.M_SAT] * motor[m, jk.M_LIMIT]
        else:
            motor[m, jk.M_APPLIED] = 0.0
    for j in range(model.jint.shape[0]):
        if model.jint[j, jk.J_FRICROW] >= 0:
            fric_row = model.jint[j, jk.J_FRICROW]
            work.fric[j, jk.F_APPLIED] = (drive[j, D_FRICTION] / h if work.active[fric_row] != 0
                                          else _rubs(model, work, j))
    jk._unwrap(model, joints.jx, work)


@_inl
def _refresh_spin(model, x, work):
    """Refresh ``work.bd``'s world angular velocities from ``x``'s (the pose unchanged)."""
    bd = work.bd
    for b in range(x.shape[0]):
        bd[b, jk.B_OMEGA_W], bd[b, jk.B_OMEGA_W + 1], bd[b, jk.B_OMEGA_W + 2] = jk._mv(
            bd, b, jk.B_ROT, x[b, 10], x[b, 11], x[b, 12])


@_jit
def damp(joints, dt):
    """
    Give ``jx`` the exact flow of every joint's damping ``-d q̇`` over ``dt``, joint by joint.

    The flow of one damped joint in the mechanism its joints' own rows make (its limit,
    motor and friction rows off: the visits after it take up what they hold, so a motor's
    effort includes the damping it overcomes): a generalized force along ``q`` moves the
    bodies along ``δu = P M⁻¹ Jᵀ`` (the constrained response to a unit force, one solve with
    the factor of the rows), so ``q̇' = −d a q̇`` with ``a = J δu`` (the joint's inverse
    effective inertia) and ``q̇(dt) = q̇ exp(−d a dt)`` exactly: the impulse
    ``q̇ (exp(−d a dt) − 1) / a`` along ``δu``. The twists are first projected onto the rows
    (the rate is then the mechanism's); the caller has projected them with the limit, motor
    and friction rows on, so a held joint's rate is the one it is held at. One damped
    joint (a hinge or slider to the world, the joints' rows alone) decays exactly as
    ``exp(−d t / I)``; several are taken in index order, a splitting of their coupled flow
    (each exact, the coupling O(dt²)).
    """
    model, work, jx, saved = joints.model, joints.work, joints.jx, joints.rows_on
    jint, jprm, active = model.jint, model.jprm, work.active
    for r in range(active.shape[0]):
        saved[r] = active[r]
    for m in range(model.mrows.shape[0]):   # every motor row (a planar joint's three)
        if model.mrows[m] >= 0:
            active[model.mrows[m]] = 0
    for j in range(jint.shape[0]):
        for column in (jk.J_LIMROW, jk.J_FRICROW):
            row = jint[j, column]
            if row >= 0:
                active[row] = 0
        jk.refresh_rows(model, work, j)
    jk.body_derived(model, jx, work)
    jk.joint_rows(model, jx, work, True)
    jk.factor(model, work)
    jk._project_velocities(model, jx, work)
    rb, rj, yb, jac = work.xs[:, 0:6], work.bias, work.yb, work.jac
    for j in range(jint.shape[0]):
        d = jprm[j, jk.J_DAMPING]
        if d == 0.0:
            continue
        row = jint[j, jk.J_MOTROW]
        _refresh_spin(model, jx, work)
        rate = jk._row_rate(model, jx, work, row, 2)
        for b in range(rb.shape[0]):
            for k in range(6):
                rb[b, k] = 0.0
        for r in range(rj.shape[0]):
            rj[r] = 0.0
        for side in range(2):
            b = jk._side_body(model, row, side)
            if b >= 0:
                for k in range(6):
                    rb[b, k] += jac[row, 6 * side + k]
        jk.solve(model, work, rb, rj, yb, work.yj)
        a = 0.0
        for side in range(2):
            b = jk._side_body(model, row, side)
            if b >= 0:
                for k in range(6):
                    a += jac[row, 6 * side + k] * yb[b, k]
        if not a > 0.0:
            continue
        p = rate * math.expm1(-d * a * dt) / a
        for b in range(jx.shape[0]):
            for k in range(3):
                jx[b, 7 + k] += p * yb[b, k]
            t0, t1, t2 = jk._mtv(work.bd, b, jk.B_ROT, p * yb[b, 3], p * yb[b, 4],
                                 p * yb[b, 5])
            jx[b, 10] += t0
            jx[b, 11] += t1
            jx[b, 12] += t2
    for r in range(active.shape[0]):
        active[r] = saved[r]
    for j in range(jint.shape[0]):
        jk.refresh_rows(model, work, j)
