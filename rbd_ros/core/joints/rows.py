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
The articulated step's constraint rows: body frames, joint coordinates, ``C``, ``J``, ``J̇ u``.

First stage of every evaluation: :func:`body_derived` fills each body's rotation, world inertia,
free wrench and ``ω_w``; :func:`joint_rows` each joint's rows (position, alignment, limit,
motor, friction, mimic) at a state; :func:`limit_coordinate` and :func:`_row_rate` read one
joint's coordinate and one row's rate. The 3×3 helpers (``_mv``, ``_mtv``, ``_rot_of``) serve
the later stages too. Next: the factorisation and solves (:mod:`.solve`); the records are in
:mod:`.arrays`.
"""

import math

from rbd_ros.core import jitcache
from rbd_ros.core.joints.arrays import (
    B_FORCE, B_IW, B_OMEGA_W, B_POS, B_ROT, J_BASIS_C, J_BASIS_P, J_CHILD, J_FRICROW, J_KIND,
    J_MIMIC_C, J_MIMIC_K, J_MIMROW, J_MOTROW, J_NROWS, J_ORIGIN_C, J_ORIGIN_P, J_PARENT, J_QREST,
    J_ROW0, L_LOWER, L_UPPER, M_AREF, M_MODE, M_OMEGA, M_POSITION, M_TREF, M_VREF, MOTOR_POSITION,
    P_ANG_DAMP, P_GRAVITY, P_INERTIA, P_LIN_DAMP, P_MASS, ROW_FRICTION, ROW_LIMIT, ROW_LIN,
    ROW_MIMIC, ROW_MOTOR, S_TSTAGE)
from rbd_ros.core.kernel_rotations import _cross, _qmul

_jit = jitcache.raw_kernel()
_inl = jitcache.kernel(inline='always')


@_inl
def _rot_from_q(qw, qx, qy, qz, out, i, off):
    """Write ``R(q/|q|)`` row-major into ``out[i, off:off + 9]``."""
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
    out[i, off + 0] = 1.0 - s * (qy * qy + qz * qz)
    out[i, off + 1] = s * (qx * qy - qw * qz)
    out[i, off + 2] = s * (qx * qz + qw * qy)
    out[i, off + 3] = s * (qx * qy + qw * qz)
    out[i, off + 4] = 1.0 - s * (qx * qx + qz * qz)
    out[i, off + 5] = s * (qy * qz - qw * qx)
    out[i, off + 6] = s * (qx * qz - qw * qy)
    out[i, off + 7] = s * (qy * qz + qw * qx)
    out[i, off + 8] = 1.0 - s * (qx * qx + qy * qy)


@_inl
def _rot_of(x, b):
    """Return the 9 entries of ``R(q/|q|)`` of body ``b``, row-major (as :func:`_rot_from_q`)."""
    qw, qx, qy, qz = x[b, 3], x[b, 4], x[b, 5], x[b, 6]
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
    return (1.0 - s * (qy * qy + qz * qz), s * (qx * qy - qw * qz), s * (qx * qz + qw * qy),
            s * (qx * qy + qw * qz), 1.0 - s * (qx * qx + qz * qz), s * (qy * qz - qw * qx),
            s * (qx * qz - qw * qy), s * (qy * qz + qw * qx), 1.0 - s * (qx * qx + qy * qy))


@_inl
def _mv(m, i, off, x0, x1, x2):
    """Return ``A v`` for the row-major 3×3 ``A`` in ``m[i, off:off + 9]``."""
    return (m[i, off] * x0 + m[i, off + 1] * x1 + m[i, off + 2] * x2,
            m[i, off + 3] * x0 + m[i, off + 4] * x1 + m[i, off + 5] * x2,
            m[i, off + 6] * x0 + m[i, off + 7] * x1 + m[i, off + 8] * x2)


@_inl
def _mtv(m, i, off, x0, x1, x2):
    """Return ``Aᵀ v`` for the row-major 3×3 ``A`` in ``m[i, off:off + 9]``."""
    return (m[i, off] * x0 + m[i, off + 3] * x1 + m[i, off + 6] * x2,
            m[i, off + 1] * x0 + m[i, off + 4] * x1 + m[i, off + 7] * x2,
            m[i, off + 2] * x0 + m[i, off + 5] * x1 + m[i, off + 8] * x2)


@_inl
def _side_body(model, row, side):
    """Return the body of ``jac`` columns ``6 side..6 side + 5`` of ``row`` (-1: none, world)."""
    if side < 2:
        j = model.rows[row, 0]
    elif model.rows[row, 1] == ROW_MIMIC:
        j = model.rows[row, 3]
    else:
        return -1
    return model.jint[j, J_CHILD] if side % 2 == 1 else model.jint[j, J_PARENT]


@_inl
def _n_sides(model, row):
    """Return the number of body sides of ``row``'s Jacobian: 4 for a mimic row, else 2."""
    return 4 if model.rows[row, 1] == ROW_MIMIC else 2


@_jit
def body_derived(model, x, work):
    """Fill ``work.bd``: rotation, world inertia, position, free wrench ``f`` (world), ``ω_w``."""
    prm, bd = model.prm, work.bd
    for b in range(x.shape[0]):
        bd[b, B_POS], bd[b, B_POS + 1], bd[b, B_POS + 2] = x[b, 0], x[b, 1], x[b, 2]
        _rot_from_q(x[b, 3], x[b, 4], x[b, 5], x[b, 6], bd, b, B_ROT)
        # I_w = R I_b Rᵀ; a diagonal I_b (principal axes, as most bodies) skips the products
        # with its zeros: a finite x + (±0) is x, and a sum from +0 never turns -0, so the
        # entries are the same bits as the full sum's
        diagonal = (prm[b, P_INERTIA + 1] == 0.0 and prm[b, P_INERTIA + 2] == 0.0
                    and prm[b, P_INERTIA + 3] == 0.0 and prm[b, P_INERTIA + 5] == 0.0
                    and prm[b, P_INERTIA + 6] == 0.0 and prm[b, P_INERTIA + 7] == 0.0)
        for r in range(3):
            for c in range(3):
                s = 0.0
                if diagonal:
                    for k in range(3):
                        s += (bd[b, B_ROT + 3 * r + k] * prm[b, P_INERTIA + 4 * k]
                              * bd[b, B_ROT + 3 * c + k])
                else:
                    for k in range(3):
                        for m in range(3):
                            s += (bd[b, B_ROT + 3 * r + k] * prm[b, P_INERTIA + 3 * k + m]
                                  * bd[b, B_ROT + 3 * c + m])
                bd[b, B_IW + 3 * r + c] = s
    body_rates(model, x, work)


@_jit
def body_rates(model, x, work):
    """
    Fill ``work.bd``'s free wrench ``f`` (world) and ``ω_w`` from ``x``'s velocities.

    The part of :func:`body_derived` that the velocities change: the rotations in ``work.bd``
    must be ``x``'s (a velocity projection, or a change of the held rows, keeps them).
    """
    prm, bd = model.prm, work.bd
    for b in range(x.shape[0]):
        mass = prm[b, P_MASS]
        cv = prm[b, P_LIN_DAMP]
        for k in range(3):
            bd[b, B_FORCE + k] = mass * (prm[b, P_GRAVITY + k] - cv * x[b, 7 + k])
        w0, w1, w2 = x[b, 10], x[b, 11], x[b, 12]
        h0, h1, h2 = _mv(prm, b, P_INERTIA, w0, w1, w2)
        # τ_b = -c_ω I_b ω_b - ω_b × I_b ω_b (damping and the gyroscopic term), then world
        g0, g1, g2 = _cross(w0, w1, w2, h0, h1, h2)
        ca = prm[b, P_ANG_DAMP]
        t0, t1, t2 = _mv(bd, b, B_ROT, -ca * h0 - g0, -ca * h1 - g1, -ca * h2 - g2)
        bd[b, B_FORCE + 3], bd[b, B_FORCE + 4], bd[b, B_FORCE + 5] = t0, t1, t2
        o0, o1, o2 = _mv(bd, b, B_ROT, w0, w1, w2)
        bd[b, B_OMEGA_W], bd[b, B_OMEGA_W + 1], bd[b, B_OMEGA_W + 2] = o0, o1, o2


@_inl
def _twist(model, x, j):
    """Return the angle of ``q_pc q_rest⁻¹`` about ``axis_b`` (rad, in (-pi, pi])."""
    return _twist_on(model, x, j, J_BASIS_P + 6)


@_inl
def _twist_on(model, x, j, off):
    """
    Return ``2 atan2(e_v · u, e_w)``, ``e = q_pc q_rest⁻¹`` (``e_w >= 0``), ``u = jprm[j, off:]``.

    ``u = u3 = axis_b``: a revolute angle; ``u = u1 = axis2_b`` of a universal joint: its second
    angle (``e = q_a(θ1) q_b(θ2)`` with ``a ⊥ b``: ``e_w = c1 c2``, ``e_v · b = c1 s2``).
    """
    jprm = model.jprm
    ew, ex, ey, ez = _joint_turn(model, x, j)
    if ew < 0.0:
        ew, ex, ey, ez = -ew, -ex, -ey, -ez
    u = ex * jprm[j, off] + ey * jprm[j, off + 1] + ez * jprm[j, off + 2]
    return 2.0 * math.atan2(u, ew)


@_inl
def _joint_turn(model, x, j):
    """Return ``e = q_pc q_rest⁻¹`` of joint ``j`` (parent coordinates; either sign)."""
    jint, jprm = model.jint, model.jprm
    par, c = jint[j, J_PARENT], jint[j, J_CHILD]
    if par >= 0:
        pw, px, py, pz = x[par, 3], -x[par, 4], -x[par, 5], -x[par, 6]
    else:
        pw, px, py, pz = 1.0, 0.0, 0.0, 0.0
    aw, ax, ay, az = _qmul(pw, px, py, pz, x[c, 3], x[c, 4], x[c, 5], x[c, 6])
    return _qmul(aw, ax, ay, az, jprm[j, J_QREST], -jprm[j, J_QREST + 1],
                 -jprm[j, J_QREST + 2], -jprm[j, J_QREST + 3])


@_inl
def _ball_coordinate(model, x, work, j, k):
    """
    Return a ball joint's motor coordinate ``k`` (0 rx, 1 ry, 2 rz): ``φ*_k + ψ_k``.

    ``φ*`` the rotation vector of its three motor slots' position targets (parent
    coordinates; 0 for a slot with none), ``q* = exp(φ*)``, and ``ψ = log(e q*⁻¹)`` the
    rotation vector of the error (``e = q_pc q_rest⁻¹``, the shorter way round, ``|ψ| <= π``),
    whose spatial rate is the relative angular velocity in parent coordinates: a rotation about
    a fixed axis through ``q*`` has ``ψ̇ = ω_rel``, so its motor rows (``ω_rel`` on the parent's
    axes) follow ``ψ̈ = −2ω ψ̇ − ω² ψ`` exactly there.
    """
    jint, rows, motor = model.jint, model.rows, work.motor
    t0 = t1 = t2 = 0.0
    row0 = jint[j, J_ROW0]
    for r in range(jint[j, J_NROWS]):
        if rows[row0 + r, 1] == ROW_MOTOR:
            a = rows[row0 + r, 2]
            v = motor[rows[row0 + r, 3], M_POSITION]
            if a == 0:
                t0 = v
            elif a == 1:
                t1 = v
            else:
                t2 = v
    n = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
    tw, s = 1.0, 0.0
    if n > 0.0:
        tw, s = math.cos(0.5 * n), math.sin(0.5 * n) / n
    tx, ty, tz = -s * t0, -s * t1, -s * t2   # q*⁻¹
    aw, ax, ay, az = _joint_turn(model, x, j)
    ew, ex, ey, ez = _qmul(aw, ax, ay, az, tw, tx, ty, tz)
    if ew < 0.0:
        ew, ex, ey, ez = -ew, -ex, -ey, -ez
    sv = math.sqrt(ex * ex + ey * ey + ez * ez)
    scale = 2.0 * math.atan2(sv, ew) / sv if sv > 0.0 else 2.0
    if k == 0:
        return t0 + scale * ex
    if k == 1:
        return t1 + scale * ey
    return t2 + scale * ez


@_inl
def _cone_angle(model, x, j):
    """
    Return the angle of a spherical joint's axis in the child off the parent's (rad, [0, pi]).

    ``e = R_P u3`` (``u3 = axis_b``), ``f = R_c w3`` (the same axis in the child at rest), the
    angle ``atan2(|e × f|, e · f)``: what a cone limit bounds.
    """
    jint, jprm = model.jint, model.jprm
    par, c = jint[j, J_PARENT], jint[j, J_CHILD]
    m0, m1, m2 = jprm[j, J_BASIS_C + 6], jprm[j, J_BASIS_C + 7], jprm[j, J_BASIS_C + 8]
    c00, c01, c02, c10, c11, c12, c20, c21, c22 = _rot_of(x, c)
    f0 = c00 * m0 + c01 * m1 + c02 * m2
    f1 = c10 * m0 + c11 * m1 + c12 * m2
    f2 = c20 * m0 + c21 * m1 + c22 * m2
    m0, m1, m2 = jprm[j, J_BASIS_P + 6], jprm[j, J_BASIS_P + 7], jprm[j, J_BASIS_P + 8]
    if par >= 0:
        p00, p01, p02, p10, p11, p12, p20, p21, p22 = _rot_of(x, par)
        e0 = p00 * m0 + p01 * m1 + p02 * m2
        e1 = p10 * m0 + p11 * m1 + p12 * m2
        e2 = p20 * m0 + p21 * m1 + p22 * m2
    else:
        e0, e1, e2 = m0, m1, m2
    n0, n1, n2 = _cross(e0, e1, e2, f0, f1, f2)
    return math.atan2(math.sqrt(n0 * n0 + n1 * n1 + n2 * n2), e0 * f0 + e1 * f1 + e2 * f2)


@_jit
def limit_coordinate(model, x, j):
    """
    Return joint ``j``'s limited coordinate (rad or m).

    A revolute angle, a prismatic offset, or a spherical joint's angle off its axis (its cone
    limit's, :func:`_cone_angle`).
    """
    if model.jint[j, J_KIND] == 4:
        return _cone_angle(model, x, j)
    if model.jint[j, J_KIND] != 3:
        return _twist(model, x, j)
    jint, jprm = model.jint, model.jprm
    par, c = jint[j, J_PARENT], jint[j, J_CHILD]
    # d = (p_c + R_c o_c) - (p_P + R_P o_P), then its component on R_P u3
    qw, qx, qy, qz = x[c, 3], x[c, 4], x[c, 5], x[c, 6]
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
    o0, o1, o2 = jprm[j, J_ORIGIN_C], jprm[j, J_ORIGIN_C + 1], jprm[j, J_ORIGIN_C + 2]
    d0 = x[c, 0] + (1.0 - s * (qy * qy + qz * qz)) * o0 + s * (qx * qy - qw * qz) * o1 \
        + s * (qx * qz + qw * qy) * o2
    d1 = x[c, 1] + s * (qx * qy + qw * qz) * o0 + (1.0 - s * (qx * qx + qz * qz)) * o1 \
        + s * (qy * qz - qw * qx) * o2
    d2 = x[c, 2] + s * (qx * qz - qw * qy) * o0 + s * (qy * qz + qw * qx) * o1 \
        + (1.0 - s * (qx * qx + qy * qy)) * o2
    u0, u1, u2 = jprm[j, J_BASIS_P + 6], jprm[j, J_BASIS_P + 7], jprm[j, J_BASIS_P + 8]
    o0, o1, o2 = jprm[j, J_ORIGIN_P], jprm[j, J_ORIGIN_P + 1], jprm[j, J_ORIGIN_P + 2]
    if par >= 0:
        qw, qx, qy, qz = x[par, 3], x[par, 4], x[par, 5], x[par, 6]
        s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
        r00, r01, r02 = 1.0 - s * (qy * qy + qz * qz), s * (qx * qy - qw * qz), \
            s * (qx * qz + qw * qy)
        r10, r11, r12 = s * (qx * qy + qw * qz), 1.0 - s * (qx * qx + qz * qz), \
            s * (qy * qz - qw * qx)
        r20, r21, r22 = s * (qx * qz - qw * qy), s * (qy * qz + qw * qx), \
            1.0 - s * (qx * qx + qy * qy)
        d0 -= x[par, 0] + r00 * o0 + r01 * o1 + r02 * o2
        d1 -= x[par, 1] + r10 * o0 + r11 * o1 + r12 * o2
        d2 -= x[par, 2] + r20 * o0 + r21 * o1 + r22 * o2
        e0 = r00 * u0 + r01 * u1 + r02 * u2
        e1 = r10 * u0 + r11 * u1 + r12 * u2
        e2 = r20 * u0 + r21 * u1 + r22 * u2
    else:
        d0 -= o0
        d1 -= o1
        d2 -= o2
        e0, e1, e2 = u0, u1, u2
    return d0 * e0 + d1 * e1 + d2 * e2


@_jit
def joint_rows(model, x, work, full):
    """
    Fill ``work.con`` (the errors ``C``) and, if ``full``, ``work.jac`` and ``work.bias``.

    Rows of joint ``j`` between parent ``P`` (or the world) and child ``c``, with the anchors
    ``r_P = R_P o_P``, ``r_c = R_c o_c``, the separation ``d = (p_c + r_c) - (p_P + r_P)``,
    the parent's joint basis ``e_k = R_P u_k`` and the child's ``f_l = R_c w_l``:

    - position row ``C = e_k · d``: ``J`` has ``v_c: e``, ``ω_c: r_c × e``, ``v_P: -e``,
      ``ω_P: -(p_c + r_c - p_P) × e``; ``J̇ u = e·(ω_c×(ω_c×r_c) - ω_P×(ω_P×r_P))
      + 2 (ω_P×e)·ḋ + (ω_P×(ω_P×e))·d``;
    - alignment row ``C = e_k · f_l``: ``J`` has ``ω_c: f × e``, ``ω_P: e × f``;
      ``J̇ u = (ω_P×(ω_P×e))·f + 2 (ω_P×e)·(ω_c×f) + e·(ω_c×(ω_c×f))``.

    ``jac`` columns: ``v_P, ω_P, v_c, ω_c`` (world); ``ω`` are world angular velocities.
    """
    jint, jprm, rows = model.jint, model.jprm, model.rows
    jac, con, bias = work.jac, work.con, work.bias
    for j in range(jint.shape[0]):
        par = jint[j, J_PARENT]
        c = jint[j, J_CHILD]
        row0 = jint[j, J_ROW0]
        # child rotation
        c00, c01, c02, c10, c11, c12, c20, c21, c22 = _rot_of(x, c)
        if par >= 0:
            p00, p01, p02, p10, p11, p12, p20, p21, p22 = _rot_of(x, par)
            pp0, pp1, pp2 = x[par, 0], x[par, 1], x[par, 2]
            vp0, vp1, vp2 = x[par, 7], x[par, 8], x[par, 9]
            wb0, wb1, wb2 = x[par, 10], x[par, 11], x[par, 12]
            wp0 = p00 * wb0 + p01 * wb1 + p02 * wb2
            wp1 = p10 * wb0 + p11 * wb1 + p12 * wb2
            wp2 = p20 * wb0 + p21 * wb1 + p22 * wb2
        else:
            p00, p01, p02, p10, p11, p12, p20, p21, p22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, \
                0.0, 1.0
            pp0 = pp1 = pp2 = 0.0
            vp0 = vp1 = vp2 = 0.0
            wp0 = wp1 = wp2 = 0.0
        wb0, wb1, wb2 = x[c, 10], x[c, 11], x[c, 12]
        wc0 = c00 * wb0 + c01 * wb1 + c02 * wb2
        wc1 = c10 * wb0 + c11 * wb1 + c12 * wb2
        wc2 = c20 * wb0 + c21 * wb1 + c22 * wb2
        o0, o1, o2 = jprm[j, J_ORIGIN_P], jprm[j, J_ORIGIN_P + 1], jprm[j, J_ORIGIN_P + 2]
        rp0 = p00 * o0 + p01 * o1 + p02 * o2
        rp1 = p10 * o0 + p11 * o1 + p12 * o2
        rp2 = p20 * o0 + p21 * o1 + p22 * o2
        o0, o1, o2 = jprm[j, J_ORIGIN_C], jprm[j, J_ORIGIN_C + 1], jprm[j, J_ORIGIN_C + 2]
        rc0 = c00 * o0 + c01 * o1 + c02 * o2
        rc1 = c10 * o0 + c11 * o1 + c12 * o2
        rc2 = c20 * o0 + c21 * o1 + c22 * o2
        # child anchor relative to the parent's centre, and the separation d
        xc0 = x[c, 0] + rc0 - pp0
        xc1 = x[c, 1] + rc1 - pp1
        xc2 = x[c, 2] + rc2 - pp2
        d0, d1, d2 = xc0 - rp0, xc1 - rp1, xc2 - rp2
        if full:
            t0, t1, t2 = _cross(wc0, wc1, wc2, rc0, rc1, rc2)
            u0, u1, u2 = _cross(wp0, wp1, wp2, rp0, rp1, rp2)
            dd0 = x[c, 7] + t0 - vp0 - u0
            dd1 = x[c, 8] + t1 - vp1 - u1
            dd2 = x[c, 9] + t2 - vp2 - u2
            a0, a1, a2 = _cross(wc0, wc1, wc2, t0, t1, t2)
            b0, b1, b2 = _cross(wp0, wp1, wp2, u0, u1, u2)
            acc0, acc1, acc2 = a0 - b0, a1 - b1, a2 - b2
        # the joint's coordinate (a twist or cone angle: atan2 and two quaternion products),
        # computed at most once for its limit and motor rows and only where it is read: an
        # active limit or motor row's C, and work.axial (mimic rows, the dense solver's; the
        # contact step's friction and motor drives)
        coord_j = 0.0
        have_coord = False
        keep_axial = model.dense or jint[j, J_FRICROW] >= 0
        for r in range(jint[j, J_NROWS]):
            row = row0 + r
            if rows[row, 1] == ROW_MIMIC:
                continue   # filled below, once every joint's axial row is
            k = rows[row, 2]
            m0, m1, m2 = (jprm[j, J_BASIS_P + 3 * k], jprm[j, J_BASIS_P + 3 * k + 1],
                          jprm[j, J_BASIS_P + 3 * k + 2])
            ball = jint[j, J_KIND] == 4
            if ball and rows[row, 1] == ROW_MOTOR:
                # a ball joint's motor rows turn about the parent's own axes x, y, z: its
                # coordinates rx, ry, rz are a rotation vector's in parent coordinates
                m0 = 1.0 if k == 0 else 0.0
                m1 = 1.0 if k == 1 else 0.0
                m2 = 1.0 if k == 2 else 0.0
            e0 = p00 * m0 + p01 * m1 + p02 * m2
            e1 = p10 * m0 + p11 * m1 + p12 * m2
            e2 = p20 * m0 + p21 * m1 + p22 * m2
            kind = rows[row, 1]
            coord = 0.0
            rate = 0.0
            axial = kind == ROW_LIMIT or kind == ROW_MOTOR or kind == ROW_FRICTION
            need = work.active[row] != 0 and kind != ROW_FRICTION or (
                kind == ROW_MOTOR and keep_axial)
            # a planar joint's x and y motor rows are position rows along u1, u2
            in_plane = jint[j, J_KIND] == 6 and k != 2
            if kind == ROW_LIMIT and ball:
                # a spherical joint's cone limit, C = θ - cone, θ the angle between e = R_P u3
                # and f = R_c w3: θ̇ = ω_rel · n, n = p / |p|, p = e × f (the swing axis), so
                # J has ω_c: n, ω_P: -n (a torque pair); J̇ u = ω_rel · ṅ with
                # ṗ = (ω_P × e) × f + e × (ω_c × f), ṅ = (ṗ - n (n · ṗ)) / |p|
                if full:
                    m0, m1, m2 = (jprm[j, J_BASIS_C + 6], jprm[j, J_BASIS_C + 7],
                                  jprm[j, J_BASIS_C + 8])
                    f0 = c00 * m0 + c01 * m1 + c02 * m2
                    f1 = c10 * m0 + c11 * m1 + c12 * m2
                    f2 = c20 * m0 + c21 * m1 + c22 * m2
                    n0, n1, n2 = _cross(e0, e1, e2, f0, f1, f2)
                    sn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
                    r0, r1, r2 = wc0 - wp0, wc1 - wp1, wc2 - wp2
                    for i in range(12):
                        jac[row, i] = 0.0
                    if sn > 0.0:
                        h0, h1, h2 = _cross(wp0, wp1, wp2, e0, e1, e2)
                        a0, a1, a2 = _cross(h0, h1, h2, f0, f1, f2)
                        s0, s1, s2 = _cross(wc0, wc1, wc2, f0, f1, f2)
                        b0, b1, b2 = _cross(e0, e1, e2, s0, s1, s2)
                        pd0, pd1, pd2 = a0 + b0, a1 + b1, a2 + b2
                        n0, n1, n2 = n0 / sn, n1 / sn, n2 / sn
                        rate = r0 * n0 + r1 * n1 + r2 * n2
                        bias[row] = (r0 * pd0 + r1 * pd1 + r2 * pd2
                                     - rate * (n0 * pd0 + n1 * pd1 + n2 * pd2)) / sn
                    else:
                        # on the axis the swing axis is undefined; a cone (> 0) is never held
                        # there: any axis across e keeps the free row finite
                        m0, m1, m2 = jprm[j, J_BASIS_P], jprm[j, J_BASIS_P + 1], \
                            jprm[j, J_BASIS_P + 2]
                        n0 = p00 * m0 + p01 * m1 + p02 * m2
                        n1 = p10 * m0 + p11 * m1 + p12 * m2
                        n2 = p20 * m0 + p21 * m1 + p22 * m2
                        rate = r0 * n0 + r1 * n1 + r2 * n2
                        bias[row] = 0.0
                    jac[row, 3], jac[row, 4], jac[row, 5] = -n0, -n1, -n2
                    jac[row, 9], jac[row, 10], jac[row, 11] = n0, n1, n2
                if need and not have_coord:
                    coord_j = _cone_angle(model, x, j)
                    have_coord = True
                coord = coord_j
            elif axial and jint[j, J_KIND] == 5 and k == 0:
                # a universal joint's second angle θ2, about the child's cross axis
                # f = R_c w1 (held perpendicular to e = R_P axis_b by its alignment row):
                # ω_rel = θ̇1 e + θ̇2 f, so θ̇2 = ω_rel · f exactly; J has ω_c: f, ω_P: -f
                # (a torque pair), J̇ u = ω_rel · (ω_c × f)
                if full:
                    m0, m1, m2 = (jprm[j, J_BASIS_C], jprm[j, J_BASIS_C + 1],
                                  jprm[j, J_BASIS_C + 2])
                    f0 = c00 * m0 + c01 * m1 + c02 * m2
                    f1 = c10 * m0 + c11 * m1 + c12 * m2
                    f2 = c20 * m0 + c21 * m1 + c22 * m2
                    for i in range(12):
                        jac[row, i] = 0.0
                    jac[row, 3], jac[row, 4], jac[row, 5] = -f0, -f1, -f2
                    jac[row, 9], jac[row, 10], jac[row, 11] = f0, f1, f2
                    s0, s1, s2 = _cross(wc0, wc1, wc2, f0, f1, f2)
                    r0, r1, r2 = wc0 - wp0, wc1 - wp1, wc2 - wp2
                    bias[row] = r0 * s0 + r1 * s1 + r2 * s2
                    rate = r0 * f0 + r1 * f1 + r2 * f2
                if need:
                    coord = _twist_on(model, x, j, J_BASIS_P)
            elif axial and jint[j, J_KIND] != 3 and not in_plane:
                # revolute / continuous (and a planar joint's theta, a ball joint's motor
                # rows): the relative rotation rate about e = R_P axis_b (R_P x, y, z)
                if full:
                    for i in range(12):
                        jac[row, i] = 0.0
                    jac[row, 3], jac[row, 4], jac[row, 5] = -e0, -e1, -e2
                    jac[row, 9], jac[row, 10], jac[row, 11] = e0, e1, e2
                    h0, h1, h2 = _cross(wp0, wp1, wp2, e0, e1, e2)
                    bias[row] = (wc0 - wp0) * h0 + (wc1 - wp1) * h1 + (wc2 - wp2) * h2
                    rate = (wc0 - wp0) * e0 + (wc1 - wp1) * e1 + (wc2 - wp2) * e2
                if ball:
                    if need:
                        coord = _ball_coordinate(model, x, work, j, k)
                else:
                    if need and not have_coord:
                        coord_j = _twist(model, x, j)
                        if jint[j, J_KIND] == 2:
                            delta = coord_j - work.angle[j]
                            coord_j = work.angle[j] + delta - 2.0 * math.pi * math.floor(
                                delta / (2.0 * math.pi) + 0.5)
                        have_coord = True
                    coord = coord_j
            elif kind == ROW_LIN or axial:
                coord = e0 * d0 + e1 * d1 + e2 * d2
                con[row] = coord
                if full:
                    jac[row, 0], jac[row, 1], jac[row, 2] = -e0, -e1, -e2
                    g0, g1, g2 = _cross(xc0, xc1, xc2, e0, e1, e2)
                    jac[row, 3], jac[row, 4], jac[row, 5] = -g0, -g1, -g2
                    jac[row, 6], jac[row, 7], jac[row, 8] = e0, e1, e2
                    g0, g1, g2 = _cross(rc0, rc1, rc2, e0, e1, e2)
                    jac[row, 9], jac[row, 10], jac[row, 11] = g0, g1, g2
                    h0, h1, h2 = _cross(wp0, wp1, wp2, e0, e1, e2)
                    n0, n1, n2 = _cross(wp0, wp1, wp2, h0, h1, h2)
                    bias[row] = (e0 * acc0 + e1 * acc1 + e2 * acc2
                                 + 2.0 * (h0 * dd0 + h1 * dd1 + h2 * dd2)
                                 + n0 * d0 + n1 * d1 + n2 * d2)
                    rate = e0 * dd0 + e1 * dd1 + e2 * dd2 + h0 * d0 + h1 * d1 + h2 * d2
            else:
                li = rows[row, 3]
                m0, m1, m2 = (jprm[j, J_BASIS_C + 3 * li], jprm[j, J_BASIS_C + 3 * li + 1],
                              jprm[j, J_BASIS_C + 3 * li + 2])
                f0 = c00 * m0 + c01 * m1 + c02 * m2
                f1 = c10 * m0 + c11 * m1 + c12 * m2
                f2 = c20 * m0 + c21 * m1 + c22 * m2
                con[row] = e0 * f0 + e1 * f1 + e2 * f2
                if full:
                    g0, g1, g2 = _cross(e0, e1, e2, f0, f1, f2)
                    jac[row, 0] = jac[row, 1] = jac[row, 2] = 0.0
                    jac[row, 3], jac[row, 4], jac[row, 5] = g0, g1, g2
                    jac[row, 6] = jac[row, 7] = jac[row, 8] = 0.0
                    jac[row, 9], jac[row, 10], jac[row, 11] = -g0, -g1, -g2
                    h0, h1, h2 = _cross(wp0, wp1, wp2, e0, e1, e2)
                    n0, n1, n2 = _cross(wp0, wp1, wp2, h0, h1, h2)
                    s0, s1, s2 = _cross(wc0, wc1, wc2, f0, f1, f2)
                    t0, t1, t2 = _cross(wc0, wc1, wc2, s0, s1, s2)
                    bias[row] = (n0 * f0 + n1 * f1 + n2 * f2
                                 + 2.0 * (h0 * s0 + h1 * s1 + h2 * s2)
                                 + e0 * t0 + e1 * t1 + e2 * t2)
            if kind == ROW_LIMIT:
                con[row] = coord - (model.jlim[j, L_UPPER] if work.lim_state[j] > 0
                                    else model.jlim[j, L_LOWER])
            elif kind == ROW_MOTOR:
                # not a position row: the projection leaves the motor's coordinate alone
                con[row] = 0.0
                m = rows[row, 3]   # the motor slot (j, or a later coordinate's, ArtModel)
                if need:
                    work.axial[m, 0] = coord
                if full:
                    work.axial[m, 1] = bias[row]
                if full and work.motor[m, M_MODE] == MOTOR_POSITION:
                    # e'' = -2 w e' - w^2 e, e = q - q*(t): the exact critically damped
                    # response about the (moving) target
                    w = work.motor[m, M_OMEGA]
                    vr, ar = work.motor[m, M_VREF], work.motor[m, M_AREF]
                    ds = work.stats[S_TSTAGE] - work.motor[m, M_TREF]
                    qr = work.motor[m, M_POSITION] + (vr + 0.5 * ar * ds) * ds
                    bias[row] += 2.0 * w * (rate - vr - ar * ds) + w * w * (coord - qr) - ar
            elif kind == ROW_FRICTION:
                con[row] = 0.0   # a velocity row: the projection leaves the coordinate alone
            if work.active[row] == 0:
                con[row] = 0.0
                if full:
                    bias[row] = 0.0
    # mimic rows, C = q_m - k q_l - c: J = (J_m, -k J_l) (the two joints' motor rows' J),
    # J̇ u = (J̇ u)_m - k (J̇ u)_l
    for j in range(jint.shape[0]):
        row = jint[j, J_MIMROW]
        if row < 0:
            continue
        lead = rows[row, 3]
        k = jprm[j, J_MIMIC_K]
        con[row] = work.axial[j, 0] - k * work.axial[lead, 0] - jprm[j, J_MIMIC_C]
        if full:
            rm, rl = jint[j, J_MOTROW], jint[lead, J_MOTROW]
            for i in range(12):
                jac[row, i] = jac[rm, i]
                jac[row, 12 + i] = -k * jac[rl, i]
            bias[row] = work.axial[j, 1] - k * work.axial[lead, 1]


@_inl
def _row_rate(model, x, work, r, sides):
    """
    Return row ``r``'s ``J u`` at ``x`` over its first ``sides`` body sides.

    ``sides`` a constant (2, or 4 for a mimic row), so the loop unrolls; ``work.jac`` and
    ``work.bd`` filled at ``x``.
    """
    jac, bd = work.jac, work.bd
    s = 0.0
    for side in range(sides):
        b = _side_body(model, r, side)
        if b >= 0:
            o = 6 * side
            for k in range(3):
                s += jac[r, o + k] * x[b, 7 + k] + jac[r, o + 3 + k] * bd[b, B_OMEGA_W + k]
    return s
