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
The joints' coordinates and rates from the body states, in plain float arithmetic.

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

- planar: ``x = d · e_x``, ``y = d · e_y`` (``d`` the prismatic offset vector above, in parent
  coordinates, ``e_x = axis2_b``, ``e_y = a × e_x``), their rates likewise, ``theta`` and its
  rate as a revolute joint's;
- universal: ``θ1 = 2 atan2(e_v · a, e_w)``, ``θ2 = 2 atan2(e_v · b, e_w)`` (``b = axis2_b``),
  ``θ̇1 = ω_rel · a``, ``θ̇2 = ω_rel · R_pc R_restᵀ b`` (the child's cross axis);
- spherical: ``(rx, ry, rz) = 2 atan2(|e_v|, e_w) e_v / |e_v|`` (the rotation vector of ``e``),
  their rates the relative angular velocity ``ω_rel = R_pc ω_c − ω_p`` (not the rotation
  vector's rate: the two agree while the joint turns about a fixed axis through its rest pose);

with ``a`` the joint axis in parent coordinates and a world parent the identity at the origin.
A row is a body's packed state ``(p, q_wb, v_w, ω_b)``, 13 floats.
"""

import math

#: The joint kinds with one coordinate.
KINDS = ('revolute', 'continuous', 'prismatic')
#: The kinds read here: those, and the planar (x, y, theta), universal (θ1, θ2) and spherical
#: (rx, ry, rz) joints' each coordinate.
READ_KINDS = KINDS + ('planar', 'universal', 'spherical')
_COUNTS = {'planar': 3, 'universal': 2, 'spherical': 3}


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
    Read the joints of a list of :class:`~rbd_ros.core.joints.model.Joint`.

    :param joints: the joints (any kinds; only those of :data:`READ_KINDS` can be read).
    """

    def __init__(self, joints):
        self._specs = []
        self._second = []   # per joint: (axis2_b, a × axis2_b, R_restᵀ axis2_b), plain floats
        for joint in joints:
            qr = [float(v) for v in joint.q_rest]
            self._specs.append((
                joint.kind, joint.parent, joint.child,
                tuple(float(v) for v in joint.axis_b),
                tuple(float(v) for v in joint.origin_parent_b),
                tuple(float(v) for v in joint.origin_child_b),
                (qr[0], -qr[1], -qr[2], -qr[3])))
            b = tuple(float(v) for v in joint.axis2_b)
            self._second.append((b, cross(self._specs[-1][3], b),
                                 rotate(qr[0], -qr[1], -qr[2], -qr[3], *b)))

    def read(self, rows, j, coordinate=None):
        """
        Return joint ``j``'s ``(position, rate)``, plain floats, from the bodies' ``rows``.

        :param rows: every body's packed state, 13 floats each (a list of lists).
        :param coordinate: a planar joint's (0 x, 1 y, 2 theta), a universal joint's (0 θ1,
            1 θ2) or a spherical joint's (0 rx, 1 ry, 2 rz); None for a one-coordinate joint.
        :raises ValueError: joint ``j`` is not of a kind in :data:`READ_KINDS`, or a
            coordinate it does not have.
        """
        kind, parent, child, (a0, a1, a2), op, oc, q_rest_inv = self._specs[j]
        c = rows[child]
        if kind == 'prismatic':
            return self._prismatic(rows, parent, c, a0, a1, a2, op, oc)
        if coordinate is None and kind not in KINDS:
            raise ValueError(f'joint {j}: a {kind} joint has no single coordinate')
        if coordinate is not None and (kind not in READ_KINDS[len(KINDS):] or not (
                0 <= coordinate < _COUNTS[kind])):
            raise ValueError(f'joint {j}: a {kind} joint has no coordinate {coordinate!r}')
        if kind == 'planar' and coordinate < 2:
            d, u = self._offset(rows, parent, c, op, oc)
            e = self._second[j][coordinate]
            return (d[0] * e[0] + d[1] * e[1] + d[2] * e[2],
                    u[0] * e[0] + u[1] * e[1] + u[2] * e[2])
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
        wx, wy, wz = rotate(*q_pc, c[10], c[11], c[12])
        if kind == 'spherical':
            sv = math.sqrt(ex * ex + ey * ey + ez * ez)
            scale = 2.0 * math.atan2(sv, ew) / sv if sv > 0.0 else 2.0
            return ((ex, ey, ez)[coordinate] * scale,
                    (wx - wpx, wy - wpy, wz - wpz)[coordinate])
        if kind == 'universal' and coordinate == 1:
            b0, b1, b2 = self._second[j][0]
            f0, f1, f2 = rotate(*q_pc, *self._second[j][2])   # the child's cross axis, parent
            return (2.0 * math.atan2(ex * b0 + ey * b1 + ez * b2, ew),
                    (wx - wpx) * f0 + (wy - wpy) * f1 + (wz - wpz) * f2)
        position = 2.0 * math.atan2(ex * a0 + ey * a1 + ez * a2, ew)
        rate = (wx - wpx) * a0 + (wy - wpy) * a1 + (wz - wpz) * a2
        return position, rate

    @staticmethod
    def _prismatic(rows, parent, c, a0, a1, a2, op, oc):
        """Return a prismatic joint's offset along its axis and its rate (see the module)."""
        (dx, dy, dz), (ux, uy, uz) = JointReadout._offset(rows, parent, c, op, oc)
        return dx * a0 + dy * a1 + dz * a2, ux * a0 + uy * a1 + uz * a2

    @staticmethod
    def _offset(rows, parent, c, op, oc):
        """Return the anchors' offset ``d`` and its rate ``u``, parent coordinates."""
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
        return (dx, dy, dz), rotate(pw, -px, -py, -pz, ux, uy, uz)
