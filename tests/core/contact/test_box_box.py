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
Box on box contact points (separating axes and face clipping) against worked geometry.

The references are built here from the poses, independently of the clipping: the corners of
one face inside the other, and edges crossing at a known height.

Tolerance ``ROUND_OFF = 1e-15`` m: coordinates are at most ~0.3 m (ulp 5.6e-17 m) and each
value is a dozen products and sums of them, so a few ulps; a wrong point is off by
millimetres.
"""

import math

import numpy as np
import pytest
from rbd_ros.core.contact import box_box as bb

ROUND_OFF = 1e-15
MARGIN = 1e-3
SEED = 20261202


def turn(axis, angle):
    """Rotation matrix by ``angle`` (rad) about the unit ``axis`` (Rodrigues)."""
    k = np.asarray(axis, dtype=float)
    kx = np.array([[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]])
    return np.eye(3) + math.sin(angle) * kx + (1.0 - math.cos(angle)) * kx @ kx


def points(half, rot, pos):
    """Run :func:`box_box` on boxes 0 (``a``) and 1 (``b``)."""
    poly = np.empty((bb.CLIP_ROWS, bb.CLIP_COLS))
    out = np.full((8, 4), np.nan)
    count, nx, ny, nz, incident = bb.box_box(
        np.asarray(half, dtype=float), np.asarray(rot, dtype=float),
        np.asarray(pos, dtype=float), 0, 1, MARGIN, poly, out)
    return out[:count], np.array([nx, ny, nz]), incident


def face_corners(half, rot, pos, sign):
    """Return the four corners of a box's face along its z axis (``sign`` ±1), world frame."""
    return np.array([pos + rot @ (np.array([sx, sy, sign]) * half)
                     for sx in (-1.0, 1.0) for sy in (-1.0, 1.0)])


def inside_face(point, half, rot, pos):
    """Tell whether ``point`` projects inside the box's z face (to round-off)."""
    local = rot.T @ (point - pos)
    return abs(local[0]) <= half[0] + ROUND_OFF and abs(local[1]) <= half[1] + ROUND_OFF


@pytest.mark.parametrize('trial', range(20))
def test_a_box_on_a_box_touches_at_the_corners_of_their_faces_overlap(trial):
    # A box (a) sunk a depth d into a box (b) below it, turned about the vertical by any angle
    # and shifted so their faces overlap in part: the contact is the overlap of the two faces,
    # a convex polygon whose corners are the corners of either face inside the other and the
    # crossings of their edges.  Every corner of a face inside the other must be a point, every
    # point must lie in both faces, and every point is at depth d along the vertical.
    rng = np.random.default_rng([SEED, trial])
    half_a = rng.uniform(0.02, 0.15, 3)
    half_b = rng.uniform(0.02, 0.15, 3)
    rot_a = turn([0.0, 0.0, 1.0], rng.uniform(-math.pi, math.pi))
    rot_b = turn([0.0, 0.0, 1.0], rng.uniform(-math.pi, math.pi))
    depth = rng.uniform(1e-7, 5e-4)
    pos_b = rng.uniform(-0.1, 0.1, 3)
    # a's centre over b's face, inside both faces by 60 % of their smallest half side: the
    # faces overlap by far more than the depth across, so the vertical is the separating axis.
    shift = rng.uniform(-0.4, 0.4, 2) * min(half_a[:2].min(), half_b[:2].min())
    pos_a = pos_b + np.array([shift[0], shift[1], half_a[2] + half_b[2] - depth])
    got, normal, incident = points([half_a, half_b], [rot_a, rot_b], [pos_a, pos_b])
    # The normal is out of b (below) towards a: +z, exactly (z is an axis of both boxes).
    np.testing.assert_array_equal(np.abs(normal), [0.0, 0.0, 1.0])
    assert normal[2] == 1.0
    assert 3 <= len(got) <= 8
    # Depth d at every point, along the vertical.
    np.testing.assert_allclose(got[:, 0], -depth, rtol=0, atol=ROUND_OFF)
    low_a = face_corners(half_a, rot_a, pos_a, -1.0)
    top_b = face_corners(half_b, rot_b, pos_b, 1.0)
    # The points lie on the incident box's face, in both faces.
    face_z = (low_a if incident == 0 else top_b)[0, 2]
    np.testing.assert_allclose(got[:, 3], face_z, rtol=0, atol=ROUND_OFF)
    for p in got[:, 1:]:
        assert inside_face(p, half_a, rot_a, pos_a)
        assert inside_face(p, half_b, rot_b, pos_b)
    # Each corner of either face inside the other (seen from above) is one of the points.
    for corners, other in ((low_a, (half_b, rot_b, pos_b)), (top_b, (half_a, rot_a, pos_a))):
        for corner in corners:
            if inside_face(corner, *other):
                gap = np.linalg.norm(got[:, 1:3] - corner[:2], axis=1).min()
                assert gap <= 4 * ROUND_OFF, (corner, got)


def test_edges_crossing_touch_at_one_point_at_their_depth():
    # Two cubes of half side s, the lower turned 45° about y (a top edge along y at height
    # s√2), the upper 45° about x (a bottom edge along x at z_a − s√2), the upper sunk d: the
    # edges cross above the origin, at depth d, and the normal is vertical.
    s = 0.05
    depth = 2e-4
    top = s * math.sqrt(2.0)
    rot_b = turn([0.0, 1.0, 0.0], math.pi / 4)
    rot_a = turn([1.0, 0.0, 0.0], math.pi / 4)
    pos_a = np.array([0.0, 0.0, 2.0 * top - depth])
    got, normal, incident = points([[s] * 3] * 2, [rot_a, rot_b], [pos_a, np.zeros(3)])
    assert len(got) == 1
    assert incident == 0
    np.testing.assert_allclose(normal, [0.0, 0.0, 1.0], rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(got[0, 0], -depth, rtol=0, atol=ROUND_OFF)
    # The point of the upper cube's edge over the crossing.
    np.testing.assert_allclose(got[0, 1:], [0.0, 0.0, top - depth], rtol=0, atol=ROUND_OFF)


@pytest.mark.parametrize('gap', [0.5 * MARGIN, 1.5 * MARGIN])
def test_boxes_apart_touch_only_within_the_margin(gap):
    # Side by side along x, a gap apart: within the margin the face gives its points at φ =
    # the gap (a speculative contact); beyond it, none.
    half = [0.05, 0.04, 0.03]
    got, normal, _ = points([half, half], [np.eye(3)] * 2,
                            [[2 * half[0] + gap, 0.0, 0.0], [0.0, 0.0, 0.0]])
    if gap >= MARGIN:
        assert len(got) == 0
        return
    assert len(got) == 4
    np.testing.assert_array_equal(normal, [1.0, 0.0, 0.0])
    np.testing.assert_allclose(got[:, 0], gap, rtol=0, atol=ROUND_OFF)


def test_a_tilted_box_on_a_box_rests_on_its_lowest_edge():
    # A box turned 10° about x on a wider box, its lowest edge 1e-4 m deep: the face of the
    # lower box is the reference, the two ends of that edge are the deepest points (depth
    # 1e-4 m), and the other points of the clipped face are shallower by the tilt.
    half_a = np.array([0.05, 0.04, 0.03])
    half_b = np.array([0.2, 0.2, 0.05])
    tilt = math.radians(10.0)
    rot_a = turn([1.0, 0.0, 0.0], tilt)
    low = (half_a[1] * math.sin(tilt) + half_a[2] * math.cos(tilt))  # centre over lowest edge
    pos_a = np.array([0.0, 0.0, half_b[2] + low - 1e-4])
    got, normal, incident = points([half_a, half_b], [rot_a, np.eye(3)], [pos_a, np.zeros(3)])
    np.testing.assert_array_equal(normal, [0.0, 0.0, 1.0])
    assert incident == 0
    deepest = np.sort(got[:, 0])[:2]
    np.testing.assert_allclose(deepest, -1e-4, rtol=0, atol=ROUND_OFF)
    # The far edge of the bottom face is 2 h_y sin 10° = 0.0139 m up: beyond the margin, so
    # only the low edge's two corners are points.
    assert len(got) == 2
    np.testing.assert_allclose(np.abs(got[:, 1]), half_a[0], rtol=0, atol=ROUND_OFF)
