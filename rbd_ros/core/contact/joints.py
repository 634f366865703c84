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
The joints' side of the contact step (Weinstein, Teran, Fedkiw 2006): two visits, one loop.

A joint is a set of constraint rows between two bodies (:mod:`rbd_ros.core.joints.kernels`:
the rows, their Jacobians and the direct solve of ``J M⁻¹ Jᵀ``, reused here as they are). Its
impulses are ``Jᵀ μ`` with the rows' Jacobian at the bodies' current pose, so they are equal
and opposite on the two bodies (a force pair at the joint point, or a torque pair), and a
free jointed system keeps its momentum.

- :func:`post_stabilize` projects the bodies' twists onto what the joints allow,
  ``u ← u − M⁻¹ Jᵀ (J M⁻¹ Jᵀ)⁻¹ J u`` (``jk._project_velocities``).
- :func:`pre_stabilize` finds the impulse after which the step's own drift (the integrator's
  position update, :func:`_drift`, the very function the step then calls) lands every joint
  on its rows: Newton on ``C(drift(u + M⁻¹ Jᵀ μ)) = 0`` with the chord ``h J M⁻¹ Jᵀ`` (the
  factor at the current pose), until every row's error at the drifted pose is at most
  :data:`~rbd_ros.core.joints.simulator.PROJECTION_TOL`. The positions the step then reaches
  satisfy the joints to that tolerance with no projection of positions afterwards.
- :func:`joint_sweeps` interleaves either visit with a contact stage's Gauss–Seidel sweeps
  (:func:`rbd_ros.core.contact.sweeps._sweeps`): a visit of all joints (one direct solve),
  then the points' targets taken again about the velocities the visit left
  (:func:`retarget`), a sweep of the patches from the impulses they hold and a shock pass
  whose contact graph has the joints as edges (:func:`joint_levels`), until a visit changes
  no velocity by more than :data:`~rbd_ros.core.contact.rows.SWEEP_TOL_M_S`, or the
  velocities after two visits differ by no more (impulses circulating between a patch and a
  joint, see below), at most :data:`JOINT_LOOPS` visits. It ends on a visit, so the joints
  hold to their tolerance; the contacts hold to what the loop converged to
  (``stats[J_LEFT]``).

**Why the targets are taken again.** The contacts' linear prediction is taken about the
candidate pose, the drift at the stage's starting velocities. A jointed body's starting
velocities are the joints' projection of the velocity update: a plank hinged to the world
and lying on a box turns about its hinge at ``ω0 = (m g h/2)(L/2)/I`` when the stage starts,
however still it ends. The linear prediction then misses the second-order part of that turn,
``|r_⊥| (h ω0)²/2`` at a point ``r_⊥`` off the hinge's axis along the normal, the same for
every point of the plank's face: the patch allowed the face a sinking the hinge could not
give it at both of its levers, the patch kept putting impulse on both and the joint kept
taking the difference back, and the loop stalled with the plank sinking (1.1e-7 m/s at
10 ms after 2 s; it fell as h⁴). Taken again about the loop's velocities, the targets agree
with the joints to the loop's tolerance. **The shock pass** (levels with the joints as
edges; a joint to the world grounds a body only where nothing below it does) holds the
bodies under a jointed body while it is solved, so a stack under it takes none of the
loop's alternation; only a patch that bears weight holds (a box squeezed between a
gripper's fingers is not pushed from one held finger onto the other). What is still not
done: a patch is solved as if its bodies were free, not with the joints' effective mass, so
the loop converges at the rate the two levers allow (a factor of ~28 a visit for a plank
on a box), and the joints are visited all at once, not per level with the bodies below
held.

A joint's motor row and limit row take part in both visits: the motors' as
:mod:`rbd_ros.core.contact.motors` says (a velocity row, or a position motor's goal for the
drift), the limits' as one-sided rows (:mod:`rbd_ros.core.contact.limits`: held where the
drift would cross the bound, let go where their impulse would pull or the joint leaves).

Where each runs is :func:`rbd_ros.core.contact.step.world_step`'s order. Velocities are either
the state's (``x``: ``v_w``, ``ω_b``) or a stage's (``vel``: ``v_w``, ``ω_w``).
"""

from collections import namedtuple
import math

import numpy as np

from rbd_ros.core import kernels as kk
from rbd_ros.core.contact import limits as cl
from rbd_ros.core.contact import motors as cm
from rbd_ros.core.contact.linalg import patch_scratch
from rbd_ros.core.contact.patch import solve_patch
from rbd_ros.core.contact.rows import (_inl, _jit, _raw, C_BIAS, C_NORMAL, C_PHI, C_RA, C_RB,
                                       C_TARGET, PUSH_FRACTION, PUSH_MAX_M_S, Q_A, Q_B, Q_COUNT,
                                       Q_START, SWEEP_TOL_M_S)
from rbd_ros.core.contact.sweeps import _beside, _residual, _sweeps
from rbd_ros.core.joints import kernels as jk
from rbd_ros.core.joints.simulator import PROJECTION_MAX_ITER, PROJECTION_TOL
from rbd_ros.core.layout import P_GRAVITY, P_INERTIA, S_OMEGA, S_POS, S_QUAT, S_VEL

#: What a jointed world's step carries: the joints' ``model`` and ``work``
#: (:data:`rbd_ros.core.joints.kernels.ArtModel`, ``ArtWork``), the state in the joints'
#: layout ``jx`` (N, 13) and a drifted copy ``xt`` (N, 13), ``jointed`` (N,) bool (a body of
#: some joint), ``stats``: see :data:`J_ERR` and after, ``drive`` (n_joints,
#: :data:`~rbd_ros.core.contact.motors.D_SIZE`), the motors' and frictions' state in the step,
#: and ``rows_on`` (n_rows,) int, where the damping flow keeps the rows' activity
#: (:func:`~rbd_ros.core.contact.motors.damp`).
JointStage = namedtuple('JointStage', ('model', 'work', 'jx', 'xt', 'jointed', 'stats',
                                       'drive', 'rows_on'))
#: stats: the largest row error a pre-stabilization left at its drifted pose (m or the cosine
#: of a right angle), its most Newton iterations, the most visits of one stage's joint loop,
#: 1 once a pre-stabilization failed to reach the tolerance, and the largest violation of the
#: contacts' normal conditions a joint loop ended with (m/s, :func:`~rbd_ros.core.contact.
#: sweeps._residual`).
J_ERR = 0
J_ITER = 1
J_LOOPS = 2
J_FAIL = 3
J_LEFT = 4
J_STATS = 5
#: What a stage does with the joints (none, post- or pre-stabilization visits), and the cap
#: of visits of one stage's joint loop.
VISIT_NONE = 0
VISIT_POST = 1
VISIT_PRE = 2
JOINT_LOOPS = 64


@_jit
def _load(joints, x, vel, from_vel):
    """Fill ``jx`` from ``x`` (poses), velocities from ``vel`` (``from_vel``) or ``x``."""
    jx = joints.jx
    for b in range(jx.shape[0]):
        for k in range(3):
            jx[b, k] = x[S_POS + k, b]
        for k in range(4):
            jx[b, 3 + k] = x[S_QUAT + k, b]
        if from_vel:
            for k in range(3):
                jx[b, 7 + k] = vel[b, k]
            jx[b, 10], jx[b, 11], jx[b, 12] = kk._rotate_inv(
                jx[b, 3], jx[b, 4], jx[b, 5], jx[b, 6], vel[b, 3], vel[b, 4], vel[b, 5])
        else:
            for k in range(3):
                jx[b, 7 + k] = x[S_VEL + k, b]
                jx[b, 10 + k] = x[S_OMEGA + k, b]


@_jit
def _store(joints, x):
    """Write ``jx``'s velocities of the jointed bodies back into ``x``."""
    jx = joints.jx
    for b in range(jx.shape[0]):
        if joints.jointed[b]:
            for k in range(3):
                x[S_VEL + k, b] = jx[b, 7 + k]
                x[S_OMEGA + k, b] = jx[b, 10 + k]


@_jit
def _drift(joints, prm, method, h):
    """
    Fill ``xt``'s poses with the step's position update of ``jx`` (the integrator's own).

    ``midpoint_cayley``: :func:`rbd_ros.core.kernels.midpoint_drift` from ``Π_b = I_b ω_b``
    (what :func:`~rbd_ros.core.contact.step.world_step` passes for a jointed body); else
    :func:`rbd_ros.core.kernels.se_position`. The same inputs give the same bits there.
    """
    jx, xt = joints.jx, joints.xt
    shared = prm.shape[1] == 1
    for b in range(jx.shape[0]):
        if not joints.jointed[b]:
            continue
        j = 0 if shared else b
        px, py, pz = jx[b, 0], jx[b, 1], jx[b, 2]
        qw, qx, qy, qz = jx[b, 3], jx[b, 4], jx[b, 5], jx[b, 6]
        vx, vy, vz = jx[b, 7], jx[b, 8], jx[b, 9]
        wx, wy, wz = jx[b, 10], jx[b, 11], jx[b, 12]
        if method == kk.MIDPOINT_CAYLEY:
            lx, ly, lz = kk._matvec(prm, P_INERTIA, j, wx, wy, wz)
            px, py, pz, qw, qx, qy, qz, lx, ly, lz, wx, wy, wz, _ = kk.midpoint_drift(
                prm, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, lx, ly, lz)
        else:
            px, py, pz, qw, qx, qy, qz = kk.se_position(
                method, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz)
        xt[b, 0], xt[b, 1], xt[b, 2] = px, py, pz
        xt[b, 3], xt[b, 4], xt[b, 5], xt[b, 6] = qw, qx, qy, qz


@_jit
def _factor_here(joints):
    """Rows, Jacobians and the factor of ``J M⁻¹ Jᵀ`` at ``jx``'s pose."""
    jk.body_derived(joints.model, joints.jx, joints.work)
    jk.joint_rows(joints.model, joints.jx, joints.work, True)
    jk.factor(joints.model, joints.work)


@_inl
def _largest(yb):
    """Return the largest entry of a twist change ``yb`` (N, 6): m/s or rad/s."""
    m = 0.0
    for b in range(yb.shape[0]):
        for k in range(6):
            m = max(m, abs(yb[b, k]))
    return m


@_jit
def post_stabilize(joints, x, vel, from_vel):
    """
    Project the twists onto the joints (``J u = 0``); return the largest change (m/s, rad/s).

    ``from_vel``: the twists are a stage's ``vel`` (world ``ω``), changed in place; else the
    state's in ``x``.
    """
    _load(joints, x, vel, from_vel)
    _factor_here(joints)
    if cl.let_go(joints, True):
        jk.factor(joints.model, joints.work)
    jk._project_velocities(joints.model, joints.jx, joints.work)
    cm.tally(joints)
    cl.let_go(joints, False)
    yb = joints.work.yb
    if from_vel:
        for b in range(yb.shape[0]):
            if joints.jointed[b]:
                for k in range(6):
                    vel[b, k] += yb[b, k]
    else:
        _store(joints, x)
    return _largest(yb)


@_jit
def pre_stabilize(joints, x, vel, from_vel, prm, method, h):
    """
    Give the joints the impulses after which the drift satisfies them; return the change.

    Newton with the chord ``h J M⁻¹ Jᵀ`` (rows and factor at the current pose, so every
    impulse is ``Jᵀ μ`` there): ``μ`` solves ``h J M⁻¹ Jᵀ μ = −C(drift(u))`` and
    ``u += M⁻¹ Jᵀ μ``, until every row's error at the drifted pose is at most
    :data:`PROJECTION_TOL` (else ``stats[J_FAIL]`` is set). ``from_vel`` as :func:`post_stabilize`.
    Return the largest change of a twist component one iteration made (m/s, rad/s).
    """
    model, work, jx, stats = joints.model, joints.work, joints.jx, joints.stats
    _load(joints, x, vel, from_vel)
    _factor_here(joints)
    zero = work.xs[:, 0:6]
    for b in range(zero.shape[0]):
        for k in range(6):
            zero[b, k] = 0.0
    bd, yb = work.bd, work.yb
    total = 0.0
    for it in range(PROJECTION_MAX_ITER + 1):
        _drift(joints, prm, method, h)
        jk.joint_rows(model, joints.xt, work, False)   # C at the drifted pose; J stays here
        if cl.catch(joints):   # the drift crosses a limit: hold its row (J is at jx already)
            jk.factor(model, work)
            jk.joint_rows(model, joints.xt, work, False)
        cm.motor_rows(joints)
        err = jk._max_abs(work.con)
        if err <= PROJECTION_TOL:
            stats[J_ERR] = max(stats[J_ERR], err)
            stats[J_ITER] = max(stats[J_ITER], it)
            break
        if it == PROJECTION_MAX_ITER:
            stats[J_ERR] = max(stats[J_ERR], err)
            stats[J_FAIL] = 1.0
            break
        for r in range(work.con.shape[0]):
            work.bias[r] = -work.con[r] / h
        jk.solve(model, work, zero, work.bias, yb, work.yj)
        cm.tally(joints)
        if cl.let_go(joints, False):
            jk.factor(model, work)
        for b in range(jx.shape[0]):
            if not joints.jointed[b]:
                continue
            for k in range(3):
                jx[b, 7 + k] += yb[b, k]
            if from_vel:
                for k in range(6):
                    vel[b, k] += yb[b, k]
                jx[b, 10], jx[b, 11], jx[b, 12] = kk._rotate_inv(
                    jx[b, 3], jx[b, 4], jx[b, 5], jx[b, 6], vel[b, 3], vel[b, 4], vel[b, 5])
            else:
                t0, t1, t2 = jk._mtv(bd, b, jk.B_ROT, yb[b, 3], yb[b, 4], yb[b, 5])
                jx[b, 10] += t0
                jx[b, 11] += t1
                jx[b, 12] += t2
        total = max(total, _largest(yb))
    if not from_vel:
        _store(joints, x)
    return total


@_jit
def motors_start(joints, x, vel, attempt, h):
    """Begin a step's motors from the state ``x`` (:func:`~rbd_ros.core.contact.motors.start`)."""
    _load(joints, x, vel, False)
    cl.free_all(joints)
    cm.start(joints, attempt, h)


@_jit
def motors_kick(joints, x, vel, dt, end):
    """Give ``x`` the effort motors' impulses over ``dt`` (:func:`~.motors.kick`)."""
    _load(joints, x, vel, False)
    if cm.kick(joints, dt, end):
        _store(joints, x)


@_jit
def damp(joints, x, vel, dt, project_first):
    """
    Give ``x`` the exact flow of the joints' damping over ``dt`` (:func:`~.motors.damp`).

    ``project_first``: the twists are a kick's, projected first (:func:`post_stabilize`, the
    motor, limit and friction rows on), so the flow acts on the rates the joints have after
    the kick, not on the kick's: a joint that its motor, limit or friction holds is at rest,
    and its damping does nothing (flowing the kicked rate took ``d`` times gravity's kick
    off what the motor then held, an O(h) error in its effort); else they are projected
    already. The caller projects again after (the flow moves a held joint, which the rows
    take back: a motor's effort includes the damping it overcomes). Return whether any joint
    has damping: nothing (not a bit) is done otherwise.
    """
    damped = False
    for j in range(joints.model.jint.shape[0]):
        if joints.model.jprm[j, jk.J_DAMPING] != 0.0:
            damped = True
    if not damped:
        return False
    if project_first:
        post_stabilize(joints, x, vel, False)
    _load(joints, x, vel, False)
    cm.damp(joints, dt)
    _store(joints, x)
    return True


@_jit
def motors_finish(joints, x, vel, h):
    """End a step's motors at the state ``x`` (:func:`~rbd_ros.core.contact.motors.finish`)."""
    _load(joints, x, vel, False)
    cm.finish(joints, h)


@_jit
def visit(joints, x, vel, from_vel, prm, method, h, kind):
    """One visit of every joint of ``kind`` (:data:`VISIT_POST` or :data:`VISIT_PRE`)."""
    if kind == VISIT_PRE:
        return pre_stabilize(joints, x, vel, from_vel, prm, method, h)
    return post_stabilize(joints, x, vel, from_vel)


@_inl
def _moved(vel, last):
    """Return the largest change of a twist component since ``last`` (m/s, rad/s)."""
    m = 0.0
    for b in range(vel.shape[0]):
        for k in range(6):
            m = max(m, abs(vel[b, k] - last[b, k]))
    return m


@_inl
def _moved_by(vx, vy, vz, wx, wy, wz, rx, ry, rz, h):
    """
    Return how far the candidate drift at ``(v, ω)`` (world) moves the point at lever ``r``.

    ``h v + (Rot(h ω) − I) r``, the rotation exact as :func:`~rbd_ros.core.contact.bodies.
    prepare_bodies` turns a candidate: ``2 w (u × r) + 2 u × (u × r)`` of its half-angle
    quaternion ``(w, u)``, with no cancellation of ``r`` against itself.
    """
    qw, qx, qy, qz = kk._quat_exp_half(wx, wy, wz, h)
    tx, ty, tz = kk._cross(qx, qy, qz, rx, ry, rz)
    tx, ty, tz = 2.0 * tx, 2.0 * ty, 2.0 * tz
    cx, cy, cz = kk._cross(qx, qy, qz, tx, ty, tz)
    return h * vx + qw * tx + cx, h * vy + qw * ty + cy, h * vz + qw * tz + cz


@_raw
def retarget(patches, contacts, vel, vel0, radius, n_bodies, h):
    """
    Take every point's target again, linearised about the velocities ``vel`` instead of ``vel0``.

    The narrow phase predicts a point's gap after the drift linearly about the candidate pose
    (the drift at the stage's velocities ``vel0``): ``φ_next = φ_cand + h (u_n − u_n0)``. The
    turn the candidate took is not linear in ``ω``: a point at a lever ``r`` off the axis it
    turns about moves by ``(Rot(h ω) − I) r``, not ``h ω × r``. A jointed body's rates at the
    stage's start are the joints' projection of the velocity update (a plank hinged to the
    world turns about its hinge at ``ω0``, however still it ends), so its contacts saw a gap
    that is not there, ``|r_⊥| (h ω0)²/2``, which the joints, solved exactly, could not give
    them: the two disagreed and the loop stalled with the contact creeping. Here, with the
    drift's displacement ``D(u) = h v + (Rot(h ω) − I) r`` of each body's point (A's less B's):
    the gap now ``φ_now = φ_cand − D(u0)·n``, and about ``u1 = vel``
    ``φ_next = φ_now + D(u1)·n + h (u_n − u_n1)``; the target ``u_n >= u_n1 − (φ_now +
    D(u1)·n)/h``, or, inside (``φ_now < 0``), the push-out ``−PUSH_FRACTION φ_now / h`` (at
    most ``PUSH_MAX_M_S``), as the narrow phase sets them. At ``vel = vel0`` the speculative
    target is the narrow phase's. The point is taken as a material point of each body; a
    sphere's or capsule's (``radius`` (N,), the bodies' ``Shapes.pt_radius``) is its centre or
    axis point, ``radius`` inside along the normal, whose turn does not move its surface
    (a cylinder's rim point and an ellipsoid's support point are not material points: their
    targets keep an error of the order of ``(h Δω)²`` times their size). ``vel``, ``vel0``
    (N, 6): ``v_w``, ``ω_w``.
    """
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        s0 = int(patches[q, Q_START])
        for c in range(s0, s0 + int(patches[q, Q_COUNT])):
            nx = contacts[c, C_NORMAL]
            ny = contacts[c, C_NORMAL + 1]
            nz = contacts[c, C_NORMAL + 2]
            k = radius[a]   # A's surface point is its centre's less k n (n points from B to A)
            rx = contacts[c, C_RA] + k * nx
            ry = contacts[c, C_RA + 1] + k * ny
            rz = contacts[c, C_RA + 2] + k * nz
            dx, dy, dz = _moved_by(vel0[a, 0], vel0[a, 1], vel0[a, 2], vel0[a, 3], vel0[a, 4],
                                   vel0[a, 5], rx, ry, rz, h)
            d0 = dx * nx + dy * ny + dz * nz
            dx, dy, dz = _moved_by(vel[a, 0], vel[a, 1], vel[a, 2], vel[a, 3], vel[a, 4],
                                   vel[a, 5], rx, ry, rz, h)
            d1 = dx * nx + dy * ny + dz * nz
            ux, uy, uz = kk._cross(vel[a, 3], vel[a, 4], vel[a, 5], rx, ry, rz)
            un = (vel[a, 0] + ux) * nx + (vel[a, 1] + uy) * ny + (vel[a, 2] + uz) * nz
            if b < n_bodies:
                k = radius[b]
                rx = contacts[c, C_RB] - k * nx
                ry = contacts[c, C_RB + 1] - k * ny
                rz = contacts[c, C_RB + 2] - k * nz
                dx, dy, dz = _moved_by(vel0[b, 0], vel0[b, 1], vel0[b, 2], vel0[b, 3],
                                       vel0[b, 4], vel0[b, 5], rx, ry, rz, h)
                d0 -= dx * nx + dy * ny + dz * nz
                dx, dy, dz = _moved_by(vel[b, 0], vel[b, 1], vel[b, 2], vel[b, 3], vel[b, 4],
                                       vel[b, 5], rx, ry, rz, h)
                d1 -= dx * nx + dy * ny + dz * nz
                ux, uy, uz = kk._cross(vel[b, 3], vel[b, 4], vel[b, 5], rx, ry, rz)
                un -= (vel[b, 0] + ux) * nx + (vel[b, 1] + uy) * ny + (vel[b, 2] + uz) * nz
            gap = contacts[c, C_PHI] - d0
            if gap >= 0.0:
                bias = un - (gap + d1) / h
            else:
                bias = min(-PUSH_FRACTION * gap / h, PUSH_MAX_M_S)
            contacts[c, C_BIAS] = bias
            contacts[c, C_TARGET] = bias


@_inl
def _below(level, a, b):
    """Put whichever of bodies ``a``, ``b`` is two levels above the other one above it."""
    if level[a] + 1 < level[b]:
        level[b] = level[a] + 1
        return True
    if level[b] + 1 < level[a]:
        level[a] = level[b] + 1
        return True
    return False


@_raw
def _relax(patches, jint, n_bodies, level):
    """Lower ``level`` along every patch and every joint between bodies until it holds still."""
    for _ in range(n_bodies):
        moved = False
        for q in range(patches.shape[0]):
            b = int(patches[q, Q_B])
            if b < n_bodies and _below(level, int(patches[q, Q_A]), b):
                moved = True
        for j in range(jint.shape[0]):
            a = jint[j, jk.J_PARENT]
            if a >= 0 and _below(level, a, jint[j, jk.J_CHILD]):
                moved = True
        if not moved:
            break


@_raw
def joint_levels(patches, jint, n_bodies, level):
    """
    Store in ``level`` (N,) every body's level in the contact graph with the joints as edges.

    As :func:`~rbd_ros.core.contact.sweeps._levels`: 1 on a static object, k + 1 next to
    level k, through a patch or a joint between two bodies; else ``N + 1``. A body that no
    chain of patches and joints joins to a static object stands on its joints to the world
    (level 1; a shelf hinged to a wall, and what lies on it, above): a joint to the world
    does not pull a body that rests on something below it down to the ground level (a
    plank hinged at one end and lying on a box is above the box, and the box held under it).
    """
    big = n_bodies + 1
    for i in range(n_bodies):
        level[i] = big
    for q in range(patches.shape[0]):
        if patches[q, Q_B] >= n_bodies:
            level[int(patches[q, Q_A])] = 1
    _relax(patches, jint, n_bodies, level)
    hung = False
    for j in range(jint.shape[0]):
        b = jint[j, jk.J_CHILD]
        if jint[j, jk.J_PARENT] < 0 and level[b] == big:
            level[b] = 1
            hung = True
    if hung:
        _relax(patches, jint, n_bodies, level)


@_raw
def _bears(patches, q, contacts, prm):
    """
    Tell whether patch ``q`` bears weight: a point's normal within 60° of its A's gravity.

    (:func:`~rbd_ros.core.contact.sweeps._beside`'s rule, as the warm start's.) None does
    without gravity.
    """
    a = int(patches[q, Q_A])
    j = 0 if prm.shape[1] == 1 else a
    gx, gy, gz = prm[P_GRAVITY, j], prm[P_GRAVITY + 1, j], prm[P_GRAVITY + 2, j]
    g = math.sqrt(gx * gx + gy * gy + gz * gz)
    if not g > 0.0:
        return False
    s0 = int(patches[q, Q_START])
    for c in range(s0, s0 + int(patches[q, Q_COUNT])):
        if not _beside(contacts, c, gx, gy, gz, g):
            return True
    return False


@_jit
def _joint_shock(joints, patches, contacts, vel, inv_mass, inv_inertia_w, x, wrench, scr, level,
                 prm):
    """
    Shock propagation over the stage's patches by :func:`joint_levels`, the lower body held.

    The pass :func:`~rbd_ros.core.contact.sweeps._solve_group` ends a stage with
    (:func:`~rbd_ros.core.contact.sweeps._shock`), its levels seeing the joints: so a stack
    under a jointed body is solved from the ground up, each box held under the one above it,
    and the loop's next visit moves the jointed bodies alone. Only a patch that bears weight
    (:func:`_bears`) holds its lower body: a box squeezed sideways between two fingers of a
    gripper (each a level below it through its joints) is solved with both free, not pushed
    from one held finger onto the other.
    """
    n = x.shape[1]
    joint_levels(patches, joints.model.jint, n, level)
    low = np.empty(patches.shape[0], dtype=np.int64)
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        low[q] = level[a] if b >= n else min(level[a], level[b])
    for q in np.argsort(low, kind='mergesort'):
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        wa = 1.0
        wb = 1.0
        if b < n and _bears(patches, q, contacts, prm):
            if level[a] < level[b]:
                wa = 0.0
            elif level[b] < level[a]:
                wb = 0.0
        solve_patch(q, patches, contacts, vel, inv_mass, inv_inertia_w, n, x, wa, wb, wrench,
                    True, scr, True, False)


@_jit
def joint_sweeps(joints, kind, patches, contacts, vel, vel0, radius, inv_mass, inv_inertia_w,
                 x, wrench, coupled, shock, prm, method, h):
    """
    Alternate joint visits and sweeps of a stage's patches; end on a visit (see the module).

    The patches hold the impulses of the stage's own sweeps already (and go on from them,
    clamped in total, as a warm start does). Before each sweep the points' targets are taken
    again about the velocities the visit left (:func:`retarget`; ``vel0``: the stage's
    velocities at its start, which its candidates drifted with; ``radius``: the bodies'
    ``Shapes.pt_radius``); after it, with ``shock``
    and patches that share bodies (``coupled``), a shock pass with the joints in the
    contact graph's levels (:func:`_joint_shock`).
    """
    n = x.shape[1]
    scr = patch_scratch()
    before = np.empty((contacts.shape[0], 3))
    last = np.empty_like(vel)   # the velocities after the last visit
    level = np.empty(n, dtype=np.int64)
    loops = 0
    for loop in range(JOINT_LOOPS):
        loops = loop + 1
        change = visit(joints, x, vel, True, prm, method, h, kind)
        if change <= SWEEP_TOL_M_S or loop == JOINT_LOOPS - 1:
            break
        if loop > 0 and _moved(vel, last) <= SWEEP_TOL_M_S:
            break   # the velocities are still: the impulses only circulate (see the module)
        last[:] = vel
        retarget(patches, contacts, vel, vel0, radius, n, h)
        _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n, x, wrench, scr, coupled,
                True, before)
        if shock and coupled:
            _joint_shock(joints, patches, contacts, vel, inv_mass, inv_inertia_w, x, wrench,
                         scr, level, prm)
    stats = joints.stats
    stats[J_LOOPS] = max(stats[J_LOOPS], loops)
    stats[J_LEFT] = max(stats[J_LEFT], _residual(patches, contacts, vel, n, scr))
