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
The one-coordinate joints' position and rate from the body states, in plain float arithmetic.

What a robot publishes every sample (``joint_states``), so it must be cheap and the same bits on
every machine: plain Python floats in a fixed order (no numpy, no BLAS, no compiled kernel to
wait for at t = 0), a few µs a joint where the numpy readout
(:func:`~rbd_ros.core.joints.model.joint_position`, :func:`~rbd_ros.core.joints.model.
joint_velocity`) took ~0.5 ms. The same definitions as those, equal to them to round-off:

- revolute, continuous: ``q = 2 atan2(e_v · a, e_w)`` with ``e = q_pc q_rest⁻¹`` (``e_w >= 0``),
  ``q̇ = (R_pc ω_c − ω_p) · a`` (body-frame angular velocities, ``R_pc = R_wpᵀ R_wc``: the
  relative angular velocity in parent coordinates);
- prismatic: ``q = R_wpᵀ (A_c − A_p) · a`` (the anchors ``A = p + R o``), ``q̇ = R_wpᵀ (v_c +
  ω_c × (A_c − p_c) − v_p − ω_p × (A_c − p_p)) · a`` (world-frame ``ω``);

with ``a`` the joint axis in parent coordinates and a world parent the identity at the origin.
A row is a body's packed state ``(p, q_wb, v_w, ω_b)``, 13 floats.
"""

import math

#: The joint kinds read here (one coordinate each).
KINDS = ('revolute', 'continuous', 'prismatic')


def multiply(a, b):
    """Return the Hamilton product ``a ⊗ b`` of quaternions ``(w, x, y, z)``, plain floats."""
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw)


def cross(a, b):
    """Return ``a × b`` of two 3-vectors, plain floats."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def rotate(w, x, y, z, vx, vy, vz):
    """Return ``R(q) v`` for a unit quaternion ``q = (w, x, y, z)``, plain floats."""
    tx = 2.0 * (y * vz - z * vy)
    ty = 2.0 * (z * vx - x * vz)
    tz = 2.0 * (x * vy - y * vx)
    return (vx + w * tx + (y * tz - z * ty),
            vy + w * ty + (z * tx - x * tz),
            vz + w * tz + (x * ty - y * tx))


class JointReadout:
    """
    Read the one-coordinate joints of a list of :class:`~rbd_ros.core.joints.model.Joint`.

    :param joints: the joints (any kinds; only those of :data:`KINDS` can be read).
    """

    def __init__(self, joints):
        self._specs = []
        for joint in joints:
            qr = [float(v) for v in joint.q_rest]
            self._specs.append((
                joint.kind, joint.parent, joint.child,
                tuple(float(v) for v in joint.axis_b),
                tuple(float(v) for v in joint.origin_parent_b),
                tuple(float(v) for v in joint.origin_child_b),
                (qr[0], -qr[1], -qr[2], -qr[3])))

    def read(self, rows, j):
        """
        Return joint ``j``'s ``(position, rate)``, plain floats, from the bodies' ``rows``.

        :param rows: every body's packed state, 13 floats each (a list of lists).
        :raises ValueError: joint ``j`` is not of a kind in :data:`KINDS`.
        """
        kind, parent, child, (a0, a1, a2), op, oc, q_rest_inv = self._specs[j]
        c = rows[child]
        if kind == 'prismatic':
            return self._prismatic(rows, parent, c, a0, a1, a2, op, oc)
        if kind not in KINDS:
            raise ValueError(f'joint {j}: a {kind} joint has no single coordinate')
        qc = (c[3], c[4], c[5], c[6])
        if parent is None:
            q_pc = qc
            wpx = wpy = wpz = 0.0
        else:
            p = rows[parent]
            q_pc = multiply((p[3], -p[4], -p[5], -p[6]), qc)
            wpx, wpy, wpz = p[10], p[11], p[12]
        ew, ex, ey, ez = multiply(q_pc, q_rest_inv)
        if ew < 0.0:
            ew, ex, ey, ez = -ew, -ex, -ey, -ez
        position = 2.0 * math.atan2(ex * a0 + ey * a1 + ez * a2, ew)
        wx, wy, wz = rotate(*q_pc, c[10], c[11], c[12])
        rate = (wx - wpx) * a0 + (wy - wpy) * a1 + (wz - wpz) * a2
        return position, rate

    @staticmethod
    def _prismatic(rows, parent, c, a0, a1, a2, op, oc):
        """Return a prismatic joint's offset along its axis and its rate (see the module)."""
        if parent is None:
            pw, px, py, pz = 1.0, 0.0, 0.0, 0.0
            ppx = ppy = ppz = vpx = vpy = vpz = wpx = wpy = wpz = 0.0
        else:
            p = rows[parent]
            ppx, ppy, ppz, pw, px, py, pz, vpx, vpy, vpz = p[0:10]
            wpx, wpy, wpz = rotate(pw, px, py, pz, p[10], p[11], p[12])
        qc = c[3], c[4], c[5], c[6]
        rcx, rcy, rcz = rotate(*qc, *oc)
        acx, acy, acz = c[0] + rcx, c[1] + rcy, c[2] + rcz
        rpx, rpy, rpz = rotate(pw, px, py, pz, *op)
        dx, dy, dz = rotate(pw, -px, -py, -pz, acx - (ppx + rpx), acy - (ppy + rpy),
                            acz - (ppz + rpz))
        wcx, wcy, wcz = rotate(*qc, c[10], c[11], c[12])
        sx, sy, sz = acx - ppx, acy - ppy, acz - ppz
        ux = c[7] + (wcy * rcz - wcz * rcy) - vpx - (wpy * sz - wpz * sy)
        uy = c[8] + (wcz * rcx - wcx * rcz) - vpy - (wpz * sx - wpx * sz)
        uz = c[9] + (wcx * rcy - wcy * rcx) - vpz - (wpx * sy - wpy * sx)
        ux, uy, uz = rotate(pw, -px, -py, -pz, ux, uy, uz)
        return dx * a0 + dy * a1 + dz * a2, ux * a0 + uy * a1 + uz * a2
