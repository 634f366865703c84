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
The free-body kernels' integrators: one step of a body by each method, selected by id.

The ids (:data:`SE_MATRIX` ... :data:`MIDPOINT_CAYLEY`; names, orders and what each conserves
are in :mod:`rbd_ros.core.integrators`); the symplectic Euler family (``se_velocity``,
``se_position``, the orientation updates of ``_orient_matrix``), classical RK4 with the damping
as its integrating factor (``_rk4``), and the implicit midpoint with Cayley rotation
(``midpoint_first_kick``, ``midpoint_drift``, ``midpoint_second_kick``, its Newton solve
``_free_rotation_midpoint``). Forces come from :mod:`rbd_ros.core.kernel_forces`; the driver
that picks a method per step is :func:`rbd_ros.core.kernels.step_body`; the contact step
inlines the kicks and drift.
"""

import math

import numpy as np
from rbd_ros.core import jitcache
from rbd_ros.core.kernel_forces import _omega_dot_b, net_wrench_w
from rbd_ros.core.kernel_rotations import (
    _cross, _gram_schmidt, _matmul3, _matrix_to_quat, _matvec, _normalize_q, _qmul, _quat_exp_half,
    _quat_to_matrix, _rotate, _rotation_about, _to_body)
from rbd_ros.core.layout import P_INERTIA, P_INV_INERTIA, P_INV_MASS

# Integrator ids; names, orders and documentation live in rbd_ros.core.integrators.
SE_MATRIX = 0
SE_AXIS_ANGLE = 1
SE_QUAT_EXP = 2
SE_QUAT_LINEAR = 3
RK4 = 4
MIDPOINT_CAYLEY = 5

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

_jit = jitcache.kernel()
_inl = jitcache.kernel(inline='always')


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
