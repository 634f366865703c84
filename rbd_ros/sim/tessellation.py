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
Triangles of a collision shape's surface in its body frame, for drawing (m; no ROS, no numba).

:func:`shape_triangles` returns ``(n, 3, 3)`` float64 triangles (triangle, corner, xyz), each
wound counter-clockwise seen from outside (outward normal ``(b - a) × (c - a)``), in the
shape's body frame (the body origin is the centre of mass; a mesh's ``vertices_b`` are already
moved there, see ``CollisionShape.mesh_offset_m``).  Every vertex lies on the exact surface
(up to round-off); the flat triangles between them cut inside curved surfaces by at most
``r (1 - cos(π / segments))``.

Per kind (dimensions as :func:`rbd_ros.core.inertia.from_shape`; cylinder and capsule run
along body z):

* box: 12 triangles, two per face.
* sphere, ellipsoid, cylinder, capsule: surfaces of revolution about z, ``segments`` points
  per ring starting on +x (as the collision rings), rings every ``π / rings`` of polar angle
  on the round parts; the ellipsoid is the unit sphere's tessellation scaled by its semi-axes.
* mesh: its own faces; compound (:func:`rbd_ros.core.contact.mesh_shapes.compound_shape`): its
  parts' surfaces, as it was given them.
* plane: a square of side ``plane_size_m`` on the plane, centred at the point of the plane
  nearest the body origin (a plane is infinite; this is the part drawn).
"""

import colorsys
import math
from typing import Sequence, Tuple, TYPE_CHECKING

import numpy as np

from rbd_ros.core.errors import ModelError
from rbd_ros.core.rotations import quat_to_matrix

if TYPE_CHECKING:  # pragma: no cover - annotations only
    from rbd_ros.core.contact import CollisionShape

__all__ = ['DEFAULT_PLANE_SIZE_M', 'DEFAULT_RINGS', 'DEFAULT_SEGMENTS', 'body_color',
           'plane_frame', 'shape_triangles']

#: Points per ring of a round shape (a multiple of 4, so the extremes along x and y are hit).
DEFAULT_SEGMENTS = 24
#: Rings over a half turn of polar angle (sphere: pole to pole; capsule: both caps together).
DEFAULT_RINGS = 12
#: Side of the square drawn for an infinite plane, m.
DEFAULT_PLANE_SIZE_M = 20.0


def body_color(index: int) -> Tuple[float, float, float, float]:
    """
    Return body ``index``'s drawing colour ``(r, g, b, a)``: hue ``index × 0.618034`` turns.

    Golden-ratio steps of hue keep neighbouring indices far apart on the colour wheel and the
    colour of a body fixed whatever the number of bodies (saturation 0.65, value 0.9, opaque).
    Markers and animations use it, so a body has one colour everywhere.
    """
    hue = (int(index) * 0.6180339887498949) % 1.0
    return colorsys.hsv_to_rgb(hue, 0.65, 0.9) + (1.0,)


def _revolve(rho, z, segments):
    """Triangles of the surface swept by the profile ``(rho_i, z_i)`` (bottom to top) about z."""
    angle = 2.0 * math.pi * np.arange(segments) / segments
    cos, sin = np.cos(angle), np.sin(angle)
    rings = np.stack([np.column_stack([r * cos, r * sin, np.full(segments, h)])
                      for r, h in zip(rho, z)])
    nxt = np.roll(np.arange(segments), -1)
    out = []
    for i in range(len(rho) - 1):
        a, b = rings[i], rings[i][nxt]
        c, d = rings[i + 1][nxt], rings[i + 1]
        if rho[i] > 0.0:  # (a, b, c) collapses at a pole below
            out.append(np.stack([a, b, c], axis=1))
        if rho[i + 1] > 0.0:  # (a, c, d) collapses at a pole above
            out.append(np.stack([a, c, d], axis=1))
    return np.concatenate(out)


def _arc(radius, z_centre, theta_from, theta_to, count):
    """Profile of a circular arc: polar angle θ from the +z axis, ``count + 1`` points."""
    theta = np.linspace(theta_from, theta_to, count + 1)
    rho = radius * np.sin(theta)
    rho[np.isclose(theta, 0.0) | np.isclose(theta, math.pi)] = 0.0  # exact poles
    return rho, z_centre + radius * np.cos(theta)


def _box(half):
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                       dtype=np.float64) * half
    # Corner index = 4 * (x > 0) + 2 * (y > 0) + (z > 0); each face as two CCW triangles.
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5),  # -x, +x
             (0, 4, 5), (0, 5, 1), (2, 3, 7), (2, 7, 6),  # -y, +y
             (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]  # -z, +z
    return corners[np.array(faces)]


def plane_frame(normal: Sequence[float], offset_m: float) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return ``(centre_b, q_bp)``: the plane's point nearest the origin and its frame.

    ``q_bp`` (w, x, y, z) turns the z axis onto the unit ``normal`` by the shortest rotation
    (a half turn about x when the normal is −z).
    """
    n = np.asarray(normal, dtype=np.float64)
    n = n / np.linalg.norm(n)
    w = 1.0 + n[2]
    if w < 1e-12:  # n = -z: any half turn about a horizontal axis
        quat = np.array([0.0, 1.0, 0.0, 0.0])
    else:
        # q = (1 + z·n, z × n) normalised: the half-angle quaternion from z to n.
        quat = np.array([w, -n[1], n[0], 0.0])
        quat = quat / np.linalg.norm(quat)
    return float(offset_m) * n, quat


def _plane(shape, size_m):
    centre, quat = plane_frame(shape.params[:3], shape.params[3])
    half = 0.5 * size_m
    square = np.array([[-half, -half, 0.0], [half, -half, 0.0], [half, half, 0.0],
                       [-half, half, 0.0]])
    corners = square @ quat_to_matrix(quat).T + centre
    return corners[np.array([(0, 1, 2), (0, 2, 3)])]


def shape_triangles(shape: 'CollisionShape', segments: int = DEFAULT_SEGMENTS,
                    rings: int = DEFAULT_RINGS,
                    plane_size_m: float = DEFAULT_PLANE_SIZE_M) -> np.ndarray:
    """
    Return the ``(n, 3, 3)`` triangles of a :class:`CollisionShape`'s surface, body frame, m.

    :param shape: a :class:`rbd_ros.core.contact.CollisionShape`.
    :param segments: points per ring of a round shape, an integer >= 4 (rounded up to a
        multiple of 4).
    :param rings: rings over a half turn of polar angle, an integer >= 2.
    :param plane_size_m: side of the square drawn for a plane, m > 0.
    :raises ModelError: naming ``segments``, ``rings`` or ``plane_size_m`` and the value.
    """
    if isinstance(segments, bool) or not isinstance(segments, int) or segments < 4:
        raise ModelError(f'segments: {segments!r} must be an integer >= 4 (points per ring)')
    if isinstance(rings, bool) or not isinstance(rings, int) or rings < 2:
        raise ModelError(f'rings: {rings!r} must be an integer >= 2 (rings per half turn)')
    if not (isinstance(plane_size_m, (int, float)) and math.isfinite(plane_size_m)
            and plane_size_m > 0.0):
        raise ModelError(f'plane_size_m: {plane_size_m!r} m must be finite and > 0')
    segments = 4 * math.ceil(segments / 4)
    kind = shape.shape
    if kind in ('mesh', 'compound'):
        return np.ascontiguousarray(shape.vertices_b[shape.faces])
    if kind == 'plane':
        return _plane(shape, float(plane_size_m))
    dims = np.asarray(shape.dimensions_m, dtype=np.float64)
    if kind == 'box':
        return _box(0.5 * dims)
    if kind in ('sphere', 'spherical_shell', 'ellipsoid'):
        rho, z = _arc(1.0, 0.0, math.pi, 0.0, rings)
        axes = np.full(3, dims[0]) if kind != 'ellipsoid' else dims
        return _revolve(rho, z, segments) * axes
    if kind == 'cylinder':
        r, hl = float(dims[0]), 0.5 * float(dims[1])
        return _revolve(np.array([0.0, r, r, 0.0]), np.array([-hl, -hl, hl, hl]), segments)
    if kind == 'capsule':
        r, hl = float(dims[0]), 0.5 * float(dims[1])
        half = max(1, rings // 2)
        rho_lo, z_lo = _arc(r, -hl, math.pi, 0.5 * math.pi, half)
        rho_hi, z_hi = _arc(r, hl, 0.5 * math.pi, 0.0, half)
        return _revolve(np.concatenate([rho_lo, rho_hi]), np.concatenate([z_lo, z_hi]),
                        segments)
    raise ModelError(f'shape: {kind!r} has no tessellation')
