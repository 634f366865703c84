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
The bodies' side of a contact stage: poses, velocities and inverse inertias in and out.

:func:`prepare_bodies` fills the current and candidate poses, world velocities and inverse
inertias before a stage; :func:`store_velocities` writes the velocities back after it.
"""

from rbd_ros.core import kernels as kk
from rbd_ros.core.contact.linalg import _mat_vec, _set_rotation
from rbd_ros.core.contact.rows import _raw
from rbd_ros.core.layout import P_INV_INERTIA, P_INV_MASS, S_OMEGA, S_POS, S_QUAT, S_VEL


@_raw
def prepare_bodies(x, prm, vel, inv_mass, inv_inertia_w, rot, pos_c, rot_c, h, same_pose):
    """
    Fill the per-body arrays a stage reads from the state ``x`` (velocities as stored there).

    ``vel`` (N, 6): ``v_w`` and ``ω_w``; ``inv_mass`` (N,); ``inv_inertia_w`` (N, 3, 3)
    ``R I_b⁻¹ Rᵀ``; ``rot`` (N, 3, 3) current ``R``; ``pos_c`` (N, 3) and ``rot_c`` the
    candidate pose after ``h`` at these velocities (exact rotation by ``h ω``).
    ``same_pose``: ``rot`` and ``inv_inertia_w`` already hold this pose's values (the last
    stage saw the same orientations and parameters), so they are kept.
    """
    shared = prm.shape[1] == 1
    for i in range(x.shape[1]):
        j = 0 if shared else i
        qw, qx, qy, qz = x[S_QUAT, i], x[S_QUAT + 1, i], x[S_QUAT + 2, i], x[S_QUAT + 3, i]
        if not same_pose:
            _set_rotation(rot, i, qw, qx, qy, qz)
        wbx, wby, wbz = x[S_OMEGA, i], x[S_OMEGA + 1, i], x[S_OMEGA + 2, i]
        wx, wy, wz = _mat_vec(rot, i, wbx, wby, wbz)
        vel[i, 0] = x[S_VEL, i]
        vel[i, 1] = x[S_VEL + 1, i]
        vel[i, 2] = x[S_VEL + 2, i]
        vel[i, 3] = wx
        vel[i, 4] = wy
        vel[i, 5] = wz
        inv_mass[i] = prm[P_INV_MASS, j]
        if not same_pose:
            for r in range(3):
                for c in range(3):
                    acc = 0.0
                    for m in range(3):
                        for n in range(3):
                            acc += (rot[i, r, m] * prm[P_INV_INERTIA + 3 * m + n, j]
                                    * rot[i, c, n])
                    inv_inertia_w[i, r, c] = acc
        for k in range(3):
            pos_c[i, k] = x[S_POS + k, i] + h * vel[i, k]
        dw, dx, dy, dz = kk._quat_exp_half(wbx, wby, wbz, h)
        cw, cx, cy, cz = kk._qmul(qw, qx, qy, qz, dw, dx, dy, dz)
        cw, cx, cy, cz = kk._normalize_q(cw, cx, cy, cz)
        _set_rotation(rot_c, i, cw, cx, cy, cz)


@_raw
def store_velocities(x, prm, vel, touched):
    """Write ``v_w`` and ``ω_b = Rᵀ ω_w`` of the bodies a stage touched back into ``x``."""
    for i in range(x.shape[1]):
        if not touched[i]:
            continue
        x[S_VEL, i] = vel[i, 0]
        x[S_VEL + 1, i] = vel[i, 1]
        x[S_VEL + 2, i] = vel[i, 2]
        qw, qx, qy, qz = x[S_QUAT, i], x[S_QUAT + 1, i], x[S_QUAT + 2, i], x[S_QUAT + 3, i]
        bx, by, bz = kk._rotate_inv(qw, qx, qy, qz, vel[i, 3], vel[i, 4], vel[i, 5])
        x[S_OMEGA, i] = bx
        x[S_OMEGA + 1, i] = by
        x[S_OMEGA + 2, i] = bz


# ---------------------------------------------------------------------------------------------
# Broad phase: sort and sweep along x over the bodies; every body against each static object.
