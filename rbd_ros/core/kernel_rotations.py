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
The free-body kernels' quaternion and rotation helpers (compiled; no state of their own).

Vector and quaternion products (``_cross``, ``_qmul``, ``_rotate``, ``_rotate_inv``), the
state column's read and write (``_read_state``, ``_write_state``), ``R(q)`` and back
(``_quat_to_matrix``, ``_matrix_to_quat``, ``_gram_schmidt``), the rotation by ``ω h``
(``_rotation_about``, ``_quat_exp_half``, their series below :data:`SINC_SERIES_BELOW`).
Quaternions are ``(w, x, y, z)`` with ``v_w = R(q) v_b``. Used by the forces
(:mod:`rbd_ros.core.kernel_forces`), the integrators (:mod:`rbd_ros.core.kernel_integrators`),
the step (:mod:`rbd_ros.core.kernels`) and the contact step (:mod:`rbd_ros.core.contact`).
"""

import math

import numpy as np
from rbd_ros.core import jitcache
from rbd_ros.core.layout import P_DIAGONAL, S_OMEGA, S_POS, S_QUAT, S_VEL

# Below this half-angle x (rad) sin(x)/x and cos(x) are taken from their Taylor series
# (next terms x⁶/5040 < 2e-28 and x⁶/720 < 2e-27: exact to round-off); rbd_ros.core.rotations
# uses the same threshold, so the kernel and the numpy rotations switch at the same angle.
SINC_SERIES_BELOW = 1e-4

_jit = jitcache.kernel()
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
