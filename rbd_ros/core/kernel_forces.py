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
The free-body kernels' forces: every load on a body summed in one place.

:func:`net_wrench_w` is the one sum (gravity, applied wrenches and springs, the formula and
frames in its docstring; damping is the integrators' exact flow), ``_omega_dot_b`` Euler's
equations for ``ω̇_b``. Read by the integrators (:mod:`rbd_ros.core.kernel_integrators`) and
the step (:mod:`rbd_ros.core.kernels`); built on :mod:`rbd_ros.core.kernel_rotations`.
"""

import math

from rbd_ros.core import jitcache
from rbd_ros.core.kernel_rotations import _cross, _matvec, _rotate
from rbd_ros.core.layout import (
    L_A, L_B, L_KIND, L_POINT, LOAD_BODY, LOAD_NONE, LOAD_WORLD, P_GRAVITY, P_INERTIA,
    P_INV_INERTIA, P_MASS)

_inl = jitcache.kernel(inline='always')


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
