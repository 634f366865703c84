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
The compiled step kernel: one scalar per-body step, shared by every path that steps a body.

The packed arrays it works on (state ``x`` (13, N), parameters ``prm`` (26, N) or
(26, 1), loads ``ld`` (N, K, 12), times ``t`` (N,) int64 ns) are laid out in
:mod:`rbd_ros.core.layout`, whose named offsets are the only row numbers used here.

The single-body simulator, the batch, the node and the replay all go through :func:`advance`
(or its parallel twin, which calls the same per-body function), so identical inputs give
bit-identical states. ``fastmath`` is off: IEEE semantics, no reassociation.
"""

import math

import numba as nb
import numpy as np
from rbd_ros.core import jitcache
from rbd_ros.core.layout import (L_A, L_B, L_KIND, L_POINT, LOAD_BODY, LOAD_NONE, LOAD_WORLD,
                                 N_STATE, P_ANG_DAMPING, P_DIAGONAL, P_GRAVITY, P_INERTIA,
                                 P_INV_INERTIA, P_INV_MASS, P_LIN_DAMPING, P_MASS, S_OMEGA,
                                 S_POS, S_QUAT, S_VEL)

# Integrator ids; names, orders and documentation live in rbd_ros.core.integrators.
SE_MATRIX = 0
SE_AXIS_ANGLE = 1
SE_QUAT_EXP = 2
SE_QUAT_LINEAR = 3
RK4 = 4
MIDPOINT_CAYLEY = 5


# Below this half-angle x (rad) sin(x)/x and cos(x) are taken from their Taylor series
# (next terms x⁶/5040 < 2e-28 and x⁶/720 < 2e-27: exact to round-off); rbd_ros.core.rotations
# uses the same threshold, so the kernel and the numpy rotations switch at the same angle.
SINC_SERIES_BELOW = 1e-4

# Newton iterations of the implicit midpoint solve stop when the update is below this many
# units of round-off of |Π|; 4 ulp is the floor the iteration reaches in practice (the residual
# itself carries ~1 ulp per term), and stopping there keeps the step energy-exact to round-off.
_NEWTON_TOL_ULPS = 4.0 * 2.220446049250313e-16
_NEWTON_MAX_ITER = 30
# When Newton runs out of iterations, the solve counts as converged only if the residual of
# ``m − Π − (h/2) m × I⁻¹m`` is within this many units of round-off of its largest term: a
# solve that stalls at the round-off floor is kept, one that diverged (measured from h|ω| ≈ 3
# rad on) is refused instead of returning a wrong, energy-violating state.
_RESIDUAL_TOL_ULPS = 64.0 * 2.220446049250313e-16
# Fixed-point iterations tried before Newton; at h|ω| = 1e-3 they reach round-off in ~5.
_FIXED_POINT_ITER = 8

# numba's on-disk cache is chosen by jitcache.configured() when a simulator is built, not
# here (see :mod:`rbd_ros.core.jitcache`). numba keys its cache by this file, not by the values
# of the globals it imports from layout.py, so the directory is one per layout
# (``layout-<fingerprint hash>``): a changed offset compiles afresh instead of running machine
# code built for the old one.
_jit = jitcache.kernel()
# Small helpers are inlined at numba IR level: measured 20-25 % faster per body-step than
# leaving them to LLVM, for a longer first compilation (cached on disk afterwards).
_inl = jitcache.kernel(inline='always')


@_inl
def _cross(ax, ay, az, bx, by, bz):
    return ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx


@_inl
def _qmul(aw, ax, ay, az, bw, bx, by, bz):
    """Hamilton product ``a ⊗ b`` (apply ``b`` first, then ``a``)."""
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


@_inl
def _rotate(qw, qx, qy, qz, vx, vy, vz):
    """``R(q) v`` for unit ``q``: ``v + 2w (u × v) + 2 u × (u × v)``, ``u = (x, y, z)``."""
    tx, ty, tz = _cross(qx, qy, qz, vx, vy, vz)
    tx, ty, tz = 2.0 * tx, 2.0 * ty, 2.0 * tz
    cx, cy, cz = _cross(qx, qy, qz, tx, ty, tz)
    return vx + qw * tx + cx, vy + qw * ty + cy, vz + qw * tz + cz


@_inl
def _rotate_inv(qw, qx, qy, qz, vx, vy, vz):
    """``R(q)ᵀ v`` for unit ``q``."""
    return _rotate(qw, -qx, -qy, -qz, vx, vy, vz)


@_inl
def _to_body(qw, qx, qy, qz, tx, ty, tz):
    """Return ``R(q)ᵀ τ``, skipping the work for a zero torque (the common free-body case)."""
    if tx == 0.0 and ty == 0.0 and tz == 0.0:
        return 0.0, 0.0, 0.0
    return _rotate_inv(qw, qx, qy, qz, tx, ty, tz)


@_inl
def _matvec(prm, off, j, x, y, z):
    """Return ``A v`` for the row-major 3×3 ``A`` stored in ``prm[off:off + 9, j]``."""
    if prm[P_DIAGONAL, j] != 0.0:
        return prm[off, j] * x, prm[off + 4, j] * y, prm[off + 8, j] * z
    return (prm[off, j] * x + prm[off + 1, j] * y + prm[off + 2, j] * z,
            prm[off + 3, j] * x + prm[off + 4, j] * y + prm[off + 5, j] * z,
            prm[off + 6, j] * x + prm[off + 7, j] * y + prm[off + 8, j] * z)


@_inl
def _normalize_q(qw, qx, qy, qz):
    """``q / |q|``; NaN when ``|q|²`` is 0 or overflows, so the step is refused as non-finite."""
    n2 = qw * qw + qx * qx + qy * qy + qz * qz
    if not (0.0 < n2 < math.inf):
        return math.nan, math.nan, math.nan, math.nan
    s = 1.0 / math.sqrt(n2)
    return qw * s, qx * s, qy * s, qz * s


@_inl
def _read_state(x, i):
    """Return body ``i``'s state column as the 13-tuple ``(p_w, q_wb, v_w, ω_b)``."""
    return (x[S_POS, i], x[S_POS + 1, i], x[S_POS + 2, i],
            x[S_QUAT, i], x[S_QUAT + 1, i], x[S_QUAT + 2, i], x[S_QUAT + 3, i],
            x[S_VEL, i], x[S_VEL + 1, i], x[S_VEL + 2, i],
            x[S_OMEGA, i], x[S_OMEGA + 1, i], x[S_OMEGA + 2, i])


@_inl
def _write_state(x, i, s):
    """Store the 13-tuple ``s = (p_w, q_wb, v_w, ω_b)`` as body ``i``'s state column."""
    x[S_POS, i], x[S_POS + 1, i], x[S_POS + 2, i] = s[0], s[1], s[2]
    x[S_QUAT, i], x[S_QUAT + 1, i], x[S_QUAT + 2, i], x[S_QUAT + 3, i] = s[3], s[4], s[5], s[6]
    x[S_VEL, i], x[S_VEL + 1, i], x[S_VEL + 2, i] = s[7], s[8], s[9]
    x[S_OMEGA, i], x[S_OMEGA + 1, i], x[S_OMEGA + 2, i] = s[10], s[11], s[12]


@_inl
def net_wrench_w(px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz, prm, ld, i, j):
    """
    Sum everything acting on body ``i`` into a net force and torque about its COM (world).

    ``prm[:, j]`` holds the body's parameters (``j = i``, or 0 when the bodies share one).

    ``F = M g + Σ_k f_k`` and ``τ = Σ_k (r_k × f_k + τ_k)`` with ``r_k = R point_b,k`` the
    lever arm from the COM (the lecture's ``τ = Σ r × f``; gravity acts at the COM and adds
    no torque). Wrench loads come in world coordinates (kind 1) or body coordinates (kind 2,
    rotated by ``R``); springs (kind 3) act at ``x = p + r`` with the force in
    :class:`rbd_ros.core.loads.Spring`, using the point velocity ``v + ω_w × r``.
    Damping is not summed here: the integrators apply it as its exact exponential flow (split
    around the step, or as RK4's integrating factor; see :class:`rbd_ros.core.model.BodyModel`).
    """
    m = prm[P_MASS, j]
    fx = m * prm[P_GRAVITY, j]
    fy = m * prm[P_GRAVITY + 1, j]
    fz = m * prm[P_GRAVITY + 2, j]
    tx, ty, tz = 0.0, 0.0, 0.0
    for k in range(ld.shape[1]):
        kind = ld[i, k, L_KIND]
        if kind == LOAD_NONE:
            continue
        rx, ry, rz = 0.0, 0.0, 0.0
        if ld[i, k, L_POINT] != 0.0 or ld[i, k, L_POINT + 1] != 0.0 \
                or ld[i, k, L_POINT + 2] != 0.0:
            rx, ry, rz = _rotate(qw, qx, qy, qz,
                                 ld[i, k, L_POINT], ld[i, k, L_POINT + 1], ld[i, k, L_POINT + 2])
        if kind == LOAD_WORLD:
            gx, gy, gz = ld[i, k, L_A], ld[i, k, L_A + 1], ld[i, k, L_A + 2]
            cx, cy, cz = ld[i, k, L_B], ld[i, k, L_B + 1], ld[i, k, L_B + 2]
        elif kind == LOAD_BODY:
            gx, gy, gz = _rotate(qw, qx, qy, qz,
                                 ld[i, k, L_A], ld[i, k, L_A + 1], ld[i, k, L_A + 2])
            cx, cy, cz = _rotate(qw, qx, qy, qz,
                                 ld[i, k, L_B], ld[i, k, L_B + 1], ld[i, k, L_B + 2])
        else:   # LOAD_SPRING: a = anchor_w, b = (k, c, l0)
            stiffness, damping, rest = ld[i, k, L_B], ld[i, k, L_B + 1], ld[i, k, L_B + 2]
            dx = px + rx - ld[i, k, L_A]
            dy = py + ry - ld[i, k, L_A + 1]
            dz = pz + rz - ld[i, k, L_A + 2]
            ow_x, ow_y, ow_z = _rotate(qw, qx, qy, qz, wx, wy, wz)
            ux, uy, uz = _cross(ow_x, ow_y, ow_z, rx, ry, rz)
            ux, uy, uz = vx + ux, vy + uy, vz + uz
            if rest > 0.0:
                length = math.sqrt(dx * dx + dy * dy + dz * dz)
                if length > 0.0:
                    nx, ny, nz = dx / length, dy / length, dz / length
                    mag = stiffness * (length - rest) + damping * (ux * nx + uy * ny + uz * nz)
                    gx, gy, gz = -mag * nx, -mag * ny, -mag * nz
                else:
                    gx, gy, gz = 0.0, 0.0, 0.0
            else:
                gx = -stiffness * dx - damping * ux
                gy = -stiffness * dy - damping * uy
                gz = -stiffness * dz - damping * uz
            cx, cy, cz = 0.0, 0.0, 0.0
        fx, fy, fz = fx + gx, fy + gy, fz + gz
        lx, ly, lz = _cross(rx, ry, rz, gx, gy, gz)
        tx, ty, tz = tx + lx + cx, ty + ly + cy, tz + lz + cz
    return fx, fy, fz, tx, ty, tz


@_inl
def _omega_dot_b(prm, j, wx, wy, wz, tbx, tby, tbz):
    """Euler's equations in the body frame: ``ω̇_b = I_b⁻¹ (τ_b − ω_b × I_b ω_b)``."""
    lx, ly, lz = _matvec(prm, P_INERTIA, j, wx, wy, wz)
    gx, gy, gz = _cross(wx, wy, wz, lx, ly, lz)
    return _matvec(prm, P_INV_INERTIA, j, tbx - gx, tby - gy, tbz - gz)


@_jit
def _quat_to_matrix(qw, qx, qy, qz):
    m = np.empty((3, 3))
    m[0, 0] = 1.0 - 2.0 * (qy * qy + qz * qz)
    m[0, 1] = 2.0 * (qx * qy - qw * qz)
    m[0, 2] = 2.0 * (qx * qz + qw * qy)
    m[1, 0] = 2.0 * (qx * qy + qw * qz)
    m[1, 1] = 1.0 - 2.0 * (qx * qx + qz * qz)
    m[1, 2] = 2.0 * (qy * qz - qw * qx)
    m[2, 0] = 2.0 * (qx * qz - qw * qy)
    m[2, 1] = 2.0 * (qy * qz + qw * qx)
    m[2, 2] = 1.0 - 2.0 * (qx * qx + qy * qy)
    return m


@_jit
def _matrix_to_quat(m, pw, px, py, pz):
    """
    Shepperd's method; the sign is chosen nearest to the previous ``p`` (continuity).

    The same branch choice and sign rule as :func:`rbd_ros.core.rotations.matrix_to_quat`
    with ``reference=p`` (``q·p >= 0``); ``tests/core/test_rotations.py`` checks they agree.
    """
    trace = m[0, 0] + m[1, 1] + m[2, 2]
    if trace >= m[0, 0] and trace >= m[1, 1] and trace >= m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + trace)
        w, x = 0.25 * s, (m[2, 1] - m[1, 2]) / s
        y, z = (m[0, 2] - m[2, 0]) / s, (m[1, 0] - m[0, 1]) / s
    elif m[0, 0] >= m[1, 1] and m[0, 0] >= m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        w, x = (m[2, 1] - m[1, 2]) / s, 0.25 * s
        y, z = (m[0, 1] + m[1, 0]) / s, (m[0, 2] + m[2, 0]) / s
    elif m[1, 1] >= m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        w, x = (m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s
        y, z = 0.25 * s, (m[1, 2] + m[2, 1]) / s
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        w, x = (m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s
        y, z = (m[1, 2] + m[2, 1]) / s, 0.25 * s
    if w * pw + x * px + y * py + z * pz < 0.0:
        w, x, y, z = -w, -x, -y, -z
    return _normalize_q(w, x, y, z)


@_jit
def _gram_schmidt(m):
    """
    Orthonormalise the columns of ``m`` in place: c0, c1 ⟂ c0, c2 = c0 × c1.

    A column whose squared norm is 0 or overflows fills ``m`` with NaN, so the step is refused
    as non-finite rather than turned into some rotation.
    """
    sq0 = m[0, 0] ** 2 + m[1, 0] ** 2 + m[2, 0] ** 2
    if not (0.0 < sq0 < math.inf):
        m[:, :] = math.nan
        return
    n0 = 1.0 / math.sqrt(sq0)
    for r in range(3):
        m[r, 0] *= n0
    d = m[0, 0] * m[0, 1] + m[1, 0] * m[1, 1] + m[2, 0] * m[2, 1]
    for r in range(3):
        m[r, 1] -= d * m[r, 0]
    sq1 = m[0, 1] ** 2 + m[1, 1] ** 2 + m[2, 1] ** 2
    if not (0.0 < sq1 < math.inf):
        m[:, :] = math.nan
        return
    n1 = 1.0 / math.sqrt(sq1)
    for r in range(3):
        m[r, 1] *= n1
    c = _cross(m[0, 0], m[1, 0], m[2, 0], m[0, 1], m[1, 1], m[2, 1])
    for r in range(3):
        m[r, 2] = c[r]


@_jit
def _matmul3(a, b):
    """Return ``a b`` for 3×3 matrices (numba's ``@`` would need BLAS through scipy)."""
    out = np.empty((3, 3))
    for r in range(3):
        for c in range(3):
            out[r, c] = a[r, 0] * b[0, c] + a[r, 1] * b[1, c] + a[r, 2] * b[2, c]
    return out


@_jit
def _rotation_about(wx, wy, wz, h):
    """Rodrigues: ``Rot(h|ω|, ω/|ω|)``; exact, with the identity for ``ω = 0``."""
    rot = np.eye(3)
    speed = math.sqrt(wx * wx + wy * wy + wz * wz)
    if speed == 0.0:
        return rot
    angle = h * speed
    ax, ay, az = wx / speed, wy / speed, wz / speed
    c, s = math.cos(angle), math.sin(angle)
    t = 1.0 - c
    rot[0, 0] = c + t * ax * ax
    rot[0, 1] = t * ax * ay - s * az
    rot[0, 2] = t * ax * az + s * ay
    rot[1, 0] = t * ax * ay + s * az
    rot[1, 1] = c + t * ay * ay
    rot[1, 2] = t * ay * az - s * ax
    rot[2, 0] = t * ax * az - s * ay
    rot[2, 1] = t * ay * az + s * ax
    rot[2, 2] = c + t * az * az
    return rot


@_inl
def _quat_exp_half(wx, wy, wz, h):
    """``exp((0, h ω / 2))``: rotation by ``h|ω|`` about ``ω``; Taylor series near 0."""
    speed = math.sqrt(wx * wx + wy * wy + wz * wz)
    half = 0.5 * h * speed
    if half < SINC_SERIES_BELOW:
        # sin(x)/x = 1 - x²/6 + x⁴/120 - ...; at x < 1e-4 the next term (x⁶/5040 < 2e-28)
        # is far below double round-off, so the truncated series is exact to the last bit.
        x2 = half * half
        sinc = 1.0 - x2 / 6.0 + x2 * x2 / 120.0
        c = 1.0 - x2 / 2.0 + x2 * x2 / 24.0
    else:
        sinc = math.sin(half) / half
        c = math.cos(half)
    k = 0.5 * h * sinc
    return c, k * wx, k * wy, k * wz


@_jit
def _orient_matrix(method, h, qw, qx, qy, qz, wx, wy, wz):
    """Apply the lecture's matrix orientation updates to ``R(q)``; return the new ``q``."""
    rot = _quat_to_matrix(qw, qx, qy, qz)
    owx, owy, owz = _rotate(qw, qx, qy, qz, wx, wy, wz)
    if method == SE_MATRIX:
        # R ← (𝟙 + h [ω_w]) R, then Gram–Schmidt.
        new = rot.copy()
        for c in range(3):
            ex, ey, ez = _cross(owx, owy, owz, rot[0, c], rot[1, c], rot[2, c])
            new[0, c] += h * ex
            new[1, c] += h * ey
            new[2, c] += h * ez
        _gram_schmidt(new)
    else:
        # R ← Rot(h|ω_w|, ω_w/|ω_w|) R
        new = _matmul3(_rotation_about(owx, owy, owz, h), rot)
    for r in range(3):
        for c in range(3):
            if not math.isfinite(new[r, c]):
                # Overflow (or Gram–Schmidt refused a column): refuse the step.
                return math.nan, math.nan, math.nan, math.nan
    qw, qx, qy, qz = _matrix_to_quat(new, qw, qx, qy, qz)
    return qw, qx, qy, qz


@_inl
def se_velocity(prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz):
    """Return symplectic Euler's ``(v_w, ω_b)`` after ``h`` of the start-of-step wrench."""
    # Net force and torque at the state of the start of the step (the lecture's scheme).
    fx, fy, fz, tx, ty, tz = net_wrench_w(
        px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz, prm, ld, i, j)
    inv_m = prm[P_INV_MASS, j]
    vx, vy, vz = vx + h * fx * inv_m, vy + h * fy * inv_m, vz + h * fz * inv_m
    tbx, tby, tbz = _to_body(qw, qx, qy, qz, tx, ty, tz)
    ax, ay, az = _omega_dot_b(prm, j, wx, wy, wz, tbx, tby, tbz)
    return vx, vy, vz, wx + h * ax, wy + h * ay, wz + h * az


@_inl
def se_position(method, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz):
    """Return symplectic Euler's ``(p_w, q_wb)`` after ``h`` at the new velocities."""
    px, py, pz = px + h * vx, py + h * vy, pz + h * vz
    if method == SE_QUAT_EXP:
        # q ← exp(h ω_w / 2) ⊗ q  ≡  q ⊗ exp(h ω_b / 2)
        dw, dx, dy, dz = _quat_exp_half(wx, wy, wz, h)
        nw, nx, ny, nz = _qmul(qw, qx, qy, qz, dw, dx, dy, dz)
        qw, qx, qy, qz = _normalize_q(nw, nx, ny, nz)
    elif method == SE_QUAT_LINEAR:
        # q ← normalize(q + h ½ (0, ω_w) ⊗ q)  ≡  normalize(q + h ½ q ⊗ (0, ω_b))
        dw, dx, dy, dz = _qmul(qw, qx, qy, qz, 0.0, wx, wy, wz)
        k = 0.5 * h
        qw, qx, qy, qz = _normalize_q(qw + k * dw, qx + k * dx, qy + k * dy, qz + k * dz)
    else:
        qw, qx, qy, qz = _orient_matrix(method, h, qw, qx, qy, qz, wx, wy, wz)
    return px, py, pz, qw, qx, qy, qz


@_inl
def _symplectic_euler(method, prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
                      vx, vy, vz, wx, wy, wz):
    vx, vy, vz, wx, wy, wz = se_velocity(prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
                                         vx, vy, vz, wx, wy, wz)
    px, py, pz, qw, qx, qy, qz = se_position(method, h, px, py, pz, qw, qx, qy, qz,
                                             vx, vy, vz, wx, wy, wz)
    return px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz


@_jit
def _derivative(prm, ld, i, j, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz):
    """Undamped right-hand side of the Newton–Euler ODE for RK4: (ṗ, q̇, v̇, ω̇_b)."""
    nw, nx, ny, nz = _normalize_q(qw, qx, qy, qz)
    fx, fy, fz, tx, ty, tz = net_wrench_w(
        px, py, pz, nw, nx, ny, nz, vx, vy, vz, wx, wy, wz, prm, ld, i, j)
    tbx, tby, tbz = _to_body(nw, nx, ny, nz, tx, ty, tz)
    ax, ay, az = _omega_dot_b(prm, j, wx, wy, wz, tbx, tby, tbz)
    dw, dx, dy, dz = _qmul(qw, qx, qy, qz, 0.0, wx, wy, wz)
    inv_m = prm[P_INV_MASS, j]
    return (vx, vy, vz, 0.5 * dw, 0.5 * dx, 0.5 * dy, 0.5 * dz,
            fx * inv_m, fy * inv_m, fz * inv_m, ax, ay, az)


@_jit
def _rk4(prm, ld, i, j, h, y, ev_half, ev, ew_half, ew):
    """
    One classical Runge–Kutta 4 step with the damping as an integrating factor (Lawson).

    The ODE is ``ẏ = N(y) + L y`` with ``N`` the undamped Newton–Euler right-hand side
    (:func:`_derivative`) and ``L`` the damping, ``−c_v`` on ``v_w`` and ``−c_ω`` on ``ω_b``.
    Classical RK4 is applied to ``u(τ) = e^{−τL} y(t + τ)``, whose ODE is smooth, so the step
    is fourth order with damping on; with ``E(τ) = e^{τL}`` (``ev_half = e^{−c_v h/2}``,
    ``ev = e^{−c_v h}``, likewise ``ew_half``, ``ew`` for ``ω_b``):

    ``k1 = N(y)``, ``k2 = N(E(h/2)(y + h/2 k1))``, ``k3 = N(E(h/2) y + h/2 k2)``,
    ``k4 = N(E(h) y + h E(h/2) k3)``,
    ``y ← E(h) y + h/6 (E(h) k1 + 2 E(h/2) (k2 + k3) + k4)``.

    Damping alone is then the exact flow ``v ← e^{−c_v h} v`` (Lawson 1967, SIAM J. Numer.
    Anal. 4, 372–380; Hochbruck & Ostermann, Acta Numerica 19 (2010) 209–286, §2.7). Without
    damping every factor is exactly 1.0 and this is classical RK4 bit for bit.
    """
    k1 = _derivative(prm, ld, i, j, *y)
    y2 = (y[0] + 0.5 * h * k1[0], y[1] + 0.5 * h * k1[1], y[2] + 0.5 * h * k1[2],
          y[3] + 0.5 * h * k1[3], y[4] + 0.5 * h * k1[4], y[5] + 0.5 * h * k1[5],
          y[6] + 0.5 * h * k1[6], ev_half * (y[7] + 0.5 * h * k1[7]),
          ev_half * (y[8] + 0.5 * h * k1[8]), ev_half * (y[9] + 0.5 * h * k1[9]),
          ew_half * (y[10] + 0.5 * h * k1[10]), ew_half * (y[11] + 0.5 * h * k1[11]),
          ew_half * (y[12] + 0.5 * h * k1[12]))
    k2 = _derivative(prm, ld, i, j, *y2)
    y3 = (y[0] + 0.5 * h * k2[0], y[1] + 0.5 * h * k2[1], y[2] + 0.5 * h * k2[2],
          y[3] + 0.5 * h * k2[3], y[4] + 0.5 * h * k2[4], y[5] + 0.5 * h * k2[5],
          y[6] + 0.5 * h * k2[6], ev_half * y[7] + 0.5 * h * k2[7],
          ev_half * y[8] + 0.5 * h * k2[8], ev_half * y[9] + 0.5 * h * k2[9],
          ew_half * y[10] + 0.5 * h * k2[10], ew_half * y[11] + 0.5 * h * k2[11],
          ew_half * y[12] + 0.5 * h * k2[12])
    k3 = _derivative(prm, ld, i, j, *y3)
    y4 = (y[0] + h * k3[0], y[1] + h * k3[1], y[2] + h * k3[2], y[3] + h * k3[3],
          y[4] + h * k3[4], y[5] + h * k3[5], y[6] + h * k3[6],
          ev * y[7] + h * (ev_half * k3[7]), ev * y[8] + h * (ev_half * k3[8]),
          ev * y[9] + h * (ev_half * k3[9]), ew * y[10] + h * (ew_half * k3[10]),
          ew * y[11] + h * (ew_half * k3[11]), ew * y[12] + h * (ew_half * k3[12]))
    k4 = _derivative(prm, ld, i, j, *y4)
    s = h / 6.0
    out = (y[0] + s * (k1[0] + 2.0 * k2[0] + 2.0 * k3[0] + k4[0]),
           y[1] + s * (k1[1] + 2.0 * k2[1] + 2.0 * k3[1] + k4[1]),
           y[2] + s * (k1[2] + 2.0 * k2[2] + 2.0 * k3[2] + k4[2]),
           y[3] + s * (k1[3] + 2.0 * k2[3] + 2.0 * k3[3] + k4[3]),
           y[4] + s * (k1[4] + 2.0 * k2[4] + 2.0 * k3[4] + k4[4]),
           y[5] + s * (k1[5] + 2.0 * k2[5] + 2.0 * k3[5] + k4[5]),
           y[6] + s * (k1[6] + 2.0 * k2[6] + 2.0 * k3[6] + k4[6]),
           ev * y[7] + s * (ev * k1[7] + 2.0 * (ev_half * k2[7]) + 2.0 * (ev_half * k3[7])
                            + k4[7]),
           ev * y[8] + s * (ev * k1[8] + 2.0 * (ev_half * k2[8]) + 2.0 * (ev_half * k3[8])
                            + k4[8]),
           ev * y[9] + s * (ev * k1[9] + 2.0 * (ev_half * k2[9]) + 2.0 * (ev_half * k3[9])
                            + k4[9]),
           ew * y[10] + s * (ew * k1[10] + 2.0 * (ew_half * k2[10])
                             + 2.0 * (ew_half * k3[10]) + k4[10]),
           ew * y[11] + s * (ew * k1[11] + 2.0 * (ew_half * k2[11])
                             + 2.0 * (ew_half * k3[11]) + k4[11]),
           ew * y[12] + s * (ew * k1[12] + 2.0 * (ew_half * k2[12])
                             + 2.0 * (ew_half * k3[12]) + k4[12]))
    qw, qx, qy, qz = _normalize_q(out[3], out[4], out[5], out[6])
    return (out[0], out[1], out[2], qw, qx, qy, qz, out[7], out[8], out[9],
            out[10], out[11], out[12])


@_inl
def _solve3(a, bx, by, bz):
    """Solve the 3×3 system ``a x = b`` by Cramer's rule (a is well conditioned here)."""
    c00 = a[1, 1] * a[2, 2] - a[1, 2] * a[2, 1]
    c01 = a[1, 2] * a[2, 0] - a[1, 0] * a[2, 2]
    c02 = a[1, 0] * a[2, 1] - a[1, 1] * a[2, 0]
    det = a[0, 0] * c00 + a[0, 1] * c01 + a[0, 2] * c02
    c10 = a[0, 2] * a[2, 1] - a[0, 1] * a[2, 2]
    c11 = a[0, 0] * a[2, 2] - a[0, 2] * a[2, 0]
    c12 = a[0, 1] * a[2, 0] - a[0, 0] * a[2, 1]
    c20 = a[0, 1] * a[1, 2] - a[0, 2] * a[1, 1]
    c21 = a[0, 2] * a[1, 0] - a[0, 0] * a[1, 2]
    c22 = a[0, 0] * a[1, 1] - a[0, 1] * a[1, 0]
    inv = 1.0 / det
    return ((c00 * bx + c10 * by + c20 * bz) * inv,
            (c01 * bx + c11 * by + c21 * bz) * inv,
            (c02 * bx + c12 * by + c22 * bz) * inv)


@_inl
def _free_rotation_midpoint(prm, j, h, lx, ly, lz):
    """
    Implicit midpoint on the body angular momentum ``Π`` of a torque-free body.

    Solves ``m = Π_n + (h/2) m × I⁻¹ m`` to round-off (fixed-point iteration, then Newton's
    method if that contracts slowly) and returns
    ``(Π_{n+1} = 2m − Π_n, ω_mid = I⁻¹ m, converged)``. Both ``|Π|²`` and ``Πᵀ I⁻¹ Π`` are
    quadratic invariants of Euler's equations, which the implicit midpoint rule preserves
    exactly. ``converged`` is False when Newton ran out of iterations with a residual above
    round-off (large ``h|ω|``: the fixed-point start diverges and Newton does not recover);
    the caller must then refuse the step.
    """
    half = 0.5 * h
    scale = _NEWTON_TOL_ULPS * math.sqrt(lx * lx + ly * ly + lz * lz)
    # Fixed-point iteration m ← Π + (h/2) m × I⁻¹m first: it contracts by about h|ω| per
    # iteration, so for the usual h|ω| ≪ 1 it reaches round-off in a few cheap iterations.
    mx, my, mz = lx, ly, lz
    for _ in range(_FIXED_POINT_ITER):
        wx, wy, wz = _matvec(prm, P_INV_INERTIA, j, mx, my, mz)
        cx, cy, cz = _cross(mx, my, mz, wx, wy, wz)
        nx, ny, nz = lx + half * cx, ly + half * cy, lz + half * cz
        dx, dy, dz = nx - mx, ny - my, nz - mz
        mx, my, mz = nx, ny, nz
        if max(abs(dx), abs(dy), abs(dz)) <= scale:
            wx, wy, wz = _matvec(prm, P_INV_INERTIA, j, mx, my, mz)
            return 2.0 * mx - lx, 2.0 * my - ly, 2.0 * mz - lz, wx, wy, wz, True
    # Slow contraction (large h|ω|): Newton's method, quadratically convergent.
    jac = np.empty((3, 3))
    converged = False
    for _ in range(_NEWTON_MAX_ITER):
        wx, wy, wz = _matvec(prm, P_INV_INERTIA, j, mx, my, mz)
        cx, cy, cz = _cross(mx, my, mz, wx, wy, wz)
        rx = mx - lx - half * cx
        ry = my - ly - half * cy
        rz = mz - lz - half * cz
        # J = 𝟙 − (h/2) ([m] I⁻¹ − [I⁻¹ m])
        for c in range(3):
            ix = prm[P_INV_INERTIA + c, j]
            iy = prm[P_INV_INERTIA + 3 + c, j]
            iz = prm[P_INV_INERTIA + 6 + c, j]
            sx, sy, sz = _cross(mx, my, mz, ix, iy, iz)
            jac[0, c] = -half * sx
            jac[1, c] = -half * sy
            jac[2, c] = -half * sz
        jac[0, 1] -= half * wz
        jac[0, 2] += half * wy
        jac[1, 0] += half * wz
        jac[1, 2] -= half * wx
        jac[2, 0] -= half * wy
        jac[2, 1] += half * wx
        jac[0, 0] += 1.0
        jac[1, 1] += 1.0
        jac[2, 2] += 1.0
        dx, dy, dz = _solve3(jac, rx, ry, rz)
        mx, my, mz = mx - dx, my - dy, mz - dz
        if max(abs(dx), abs(dy), abs(dz)) <= scale:
            converged = True
            break
    wx, wy, wz = _matvec(prm, P_INV_INERTIA, j, mx, my, mz)
    if not converged:
        cx, cy, cz = _cross(mx, my, mz, wx, wy, wz)
        cx, cy, cz = half * cx, half * cy, half * cz
        residual = max(abs(mx - lx - cx), abs(my - ly - cy), abs(mz - lz - cz))
        # The cross product's round-off is relative to the size of its terms, h/2 |m| |ω|,
        # not to its value: for a body of (nearly) equal principal moments the terms cancel
        # and the value is round-off alone, which h|ω| amplifies (a 0.2 m cube at h|ω| = 550
        # rad was refused with a residual of ~280 ulp of |m|, all of it that round-off).
        terms = half * max(abs(mx), abs(my), abs(mz)) * max(abs(wx), abs(wy), abs(wz))
        size = max(abs(mx), abs(my), abs(mz), abs(lx), abs(ly), abs(lz),
                   abs(cx), abs(cy), abs(cz), terms)
        # NaN-safe: a NaN or infinite residual is not converged.
        converged = residual <= _RESIDUAL_TOL_ULPS * size
    return 2.0 * mx - lx, 2.0 * my - ly, 2.0 * mz - lz, wx, wy, wz, converged


@_inl
def midpoint_first_kick(prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz):
    """Half a step of force and torque as impulses: return ``(v_w, Π_b = I_b ω_b + h/2 τ_b)``."""
    half = 0.5 * h
    inv_m = prm[P_INV_MASS, j]
    fx, fy, fz, tx, ty, tz = net_wrench_w(
        px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz, prm, ld, i, j)
    vx, vy, vz = vx + half * fx * inv_m, vy + half * fy * inv_m, vz + half * fz * inv_m
    lx, ly, lz = _matvec(prm, P_INERTIA, j, wx, wy, wz)
    tbx, tby, tbz = _to_body(qw, qx, qy, qz, tx, ty, tz)
    lx, ly, lz = lx + half * tbx, ly + half * tby, lz + half * tbz
    return vx, vy, vz, lx, ly, lz


@_inl
def midpoint_drift(prm, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, lx, ly, lz):
    """
    Drift: exact free translation; torque-free rotation by implicit midpoint + Cayley.

    Returns ``(p_w, q_wb, Π_b, ω_b, converged)`` with ``ω_b = I_b⁻¹ Π_b`` at the end.
    """
    half = 0.5 * h
    px, py, pz = px + h * vx, py + h * vy, pz + h * vz
    lx, ly, lz, mx, my, mz, converged = _free_rotation_midpoint(prm, j, h, lx, ly, lz)
    # cay(h[ω]) is the rotation with quaternion (1, h ω / 2) / |(1, h ω / 2)|.
    nw, nx, ny, nz = _qmul(qw, qx, qy, qz, 1.0, half * mx, half * my, half * mz)
    qw, qx, qy, qz = _normalize_q(nw, nx, ny, nz)
    wx, wy, wz = _matvec(prm, P_INV_INERTIA, j, lx, ly, lz)
    return px, py, pz, qw, qx, qy, qz, lx, ly, lz, wx, wy, wz, converged


@_inl
def midpoint_second_kick(prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz,
                         lx, ly, lz, wx, wy, wz):
    """Return ``(v_w, ω_b)`` after the second half kick (the wrench at the new pose)."""
    half = 0.5 * h
    inv_m = prm[P_INV_MASS, j]
    fx, fy, fz, tx, ty, tz = net_wrench_w(
        px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz, prm, ld, i, j)
    vx, vy, vz = vx + half * fx * inv_m, vy + half * fy * inv_m, vz + half * fz * inv_m
    tbx, tby, tbz = _to_body(qw, qx, qy, qz, tx, ty, tz)
    if tbx != 0.0 or tby != 0.0 or tbz != 0.0:
        lx, ly, lz = lx + half * tbx, ly + half * tby, lz + half * tbz
        wx, wy, wz = _matvec(prm, P_INV_INERTIA, j, lx, ly, lz)
    return vx, vy, vz, wx, wy, wz


@_inl
def _midpoint_cayley(prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz):
    # Kick: half a step of force and torque, as impulses on v and on Π_b = I_b ω_b.
    vx, vy, vz, lx, ly, lz = midpoint_first_kick(prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
                                                 vx, vy, vz, wx, wy, wz)
    px, py, pz, qw, qx, qy, qz, lx, ly, lz, wx, wy, wz, converged = midpoint_drift(
        prm, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, lx, ly, lz)
    if not converged:
        # Refused like a non-finite step; midpoint_solve_check() tells the two apart.
        nan = math.nan
        return nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan, nan
    vx, vy, vz, wx, wy, wz = midpoint_second_kick(prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
                                                  vx, vy, vz, lx, ly, lz, wx, wy, wz)
    return px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz


@_inl
def _all_finite(s):
    for k in range(N_STATE):
        if not math.isfinite(s[k]):
            return False
    return True


@_jit
def step_body(x, prm, ld, t, i, j, method, h, dt_ns, n_steps):
    """
    Advance body ``i`` (parameters in column ``j`` of ``prm``) by up to ``n_steps`` steps.

    Each step is computed in registers and written back only if every component is finite;
    otherwise the body stays at its last finite state. Returns the number of steps taken.
    The serial :func:`advance` (single bodies) calls it compiled on its own; the batch kernel
    :func:`advance_parallel` inlines the same code (:data:`_step_body_inline`): there a
    compiled call per body (its array arguments and their reference counts) costs ~20 ns of
    ~128 per body-step with one step per call (10 000 bodies, 1 thread, CPU time: 7.8 → 11.7
    M body-steps/s); same numbers. Inlining it into :func:`advance` too would lengthen the
    first compilation of the single-body path from ≈ 17 s to ≈ 26 s of CPU.
    """
    damped = prm[P_LIN_DAMPING, j] != 0.0 or prm[P_ANG_DAMPING, j] != 0.0
    decay_v_half = 1.0
    decay_w_half = 1.0
    decay_v = 1.0
    decay_w = 1.0
    if damped:
        decay_v_half = math.exp(-0.5 * h * prm[P_LIN_DAMPING, j])
        decay_w_half = math.exp(-0.5 * h * prm[P_ANG_DAMPING, j])
        decay_v = math.exp(-h * prm[P_LIN_DAMPING, j])
        decay_w = math.exp(-h * prm[P_ANG_DAMPING, j])
    # RK4 takes the damping inside its step (integrating factor, fourth order); the others
    # get its exact flow split half before and half after the step (Strang splitting).
    split = damped and method != RK4
    s = _read_state(x, i)
    done = 0
    for _ in range(n_steps):
        px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = s
        if split:
            vx, vy, vz = vx * decay_v_half, vy * decay_v_half, vz * decay_v_half
            wx, wy, wz = wx * decay_w_half, wy * decay_w_half, wz * decay_w_half
        if method == MIDPOINT_CAYLEY:
            new = _midpoint_cayley(prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
                                   vx, vy, vz, wx, wy, wz)
        elif method == RK4:
            new = _rk4(prm, ld, i, j, h,
                       (px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz),
                       decay_v_half, decay_v, decay_w_half, decay_w)
        else:
            new = _symplectic_euler(method, prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
                                    vx, vy, vz, wx, wy, wz)
        if split:
            new = (new[0], new[1], new[2], new[3], new[4], new[5], new[6],
                   new[7] * decay_v_half, new[8] * decay_v_half, new[9] * decay_v_half,
                   new[10] * decay_w_half, new[11] * decay_w_half, new[12] * decay_w_half)
        if not _all_finite(new):
            break
        s = new
        done += 1
    _write_state(x, i, s)
    t[i] += done * dt_ns
    return done


# The same Python function, inlined at numba IR level where it is called (never compiled or
# cached on its own): one source for both kernels.
_step_body_inline = jitcache.kernel(inline='always')(getattr(step_body, 'py_func', step_body))


@_jit
def advance(x, prm, ld, t, method, h, dt_ns, n_steps):
    """Advance every body ``n_steps`` steps; return how many bodies stopped early (non-finite)."""
    shared = prm.shape[1] == 1
    failed = 0
    for i in range(x.shape[1]):
        j = 0 if shared else i
        if step_body(x, prm, ld, t, i, j, method, h, dt_ns, n_steps) != n_steps:
            failed += 1
    return failed


@jitcache.kernel(parallel=True)
def advance_parallel(x, prm, ld, t, method, h, dt_ns, n_steps):
    """:func:`advance` over threads; each body runs the same scalar code (bit-identical)."""
    n = x.shape[1]
    shared = prm.shape[1] == 1
    done = np.empty(n, dtype=np.int64)
    for i in nb.prange(n):
        # i - i keeps j the type of the prange index (a literal 0 would not unify).
        done[i] = _step_body_inline(x, prm, ld, t, i, i - i if shared else i, method, h,
                                    dt_ns, n_steps)
    failed = 0
    for i in range(n):
        if done[i] != n_steps:
            failed += 1
    return failed


@_jit
def midpoint_solve_check(x, prm, ld, i, j, h):
    """
    Redo the implicit midpoint solve of body ``i``'s next ``midpoint_cayley`` step.

    Same arithmetic as :func:`step_body` up to the solve (damping half step, first kick).
    Returns ``(converged, |ω| rad/s)`` with ``ω = I_b⁻¹ Π`` the angular velocity the solve
    starts from. Overflow is not a convergence failure: when ``Π``, ``ω`` or the size
    ``h |Π| |ω|`` of the solve's gyroscopic term is not finite, it reports converged (the
    step is then refused as plainly non-finite).
    """
    # e^{-0} is exactly 1.0 and x * 1.0 == x: the same numbers as step_body, damped or not.
    vh = math.exp(-0.5 * h * prm[P_LIN_DAMPING, j])
    wh = math.exp(-0.5 * h * prm[P_ANG_DAMPING, j])
    px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = _read_state(x, i)
    _, _, _, lx, ly, lz = midpoint_first_kick(
        prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
        vx * vh, vy * vh, vz * vh, wx * wh, wy * wh, wz * wh)
    wx, wy, wz = _matvec(prm, P_INV_INERTIA, j, lx, ly, lz)
    speed = math.sqrt(wx * wx + wy * wy + wz * wz)
    if not math.isfinite(h * speed * math.sqrt(lx * lx + ly * ly + lz * lz)):
        return True, speed
    return _free_rotation_midpoint(prm, j, h, lx, ly, lz)[6], speed


@_jit
def net_wrench_batch(x, prm, ld, out):
    """Net world force (rows 0–2) and torque about the COM (rows 3–5) of every body."""
    shared = prm.shape[1] == 1
    for i in range(x.shape[1]):
        j = 0 if shared else i
        px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = _read_state(x, i)
        w = net_wrench_w(px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz, prm, ld, i, j)
        for k in range(6):
            out[k, i] = w[k]
