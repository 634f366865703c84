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
Signed distances of the primitive collision shapes against independent references.

Tolerances:

* ``ROUND_OFF = 1e-12`` m: a closed-form φ is a few dozen float64 operations on numbers of
  size <= 10 m (each rounding <= 1.1e-16 relative, ~1e-15 m), so 1e-12 m leaves ~1000 ulp of
  margin, while a wrong formula is off by millimetres at least.
* Finite differences: central differences with step ``FD_STEP = 1e-6`` m have truncation
  error ``O(step² |φ'''|)`` ~1e-12 for curvatures ~1/m, and round-off ``ulp(φ) / step`` ~1e-10;
  ``FD_TOL = 1e-6`` is far above both and far below a wrong gradient (off by O(1)).
* Dense sampling: bounds derived where used.
"""

import math

import numpy as np
import pytest

from rbd_ros.core.contact import primitive_shape
from rbd_ros.core.contact.shapes import plane_shape
from rbd_ros.core.errors import ModelError

ROUND_OFF = 1e-12
FD_STEP = 1e-6
FD_TOL = 1e-6
SEED = 20261126


def phi(shape, points):
    return shape.signed_distance(np.asarray(points, dtype=float))[0]


# (shape, dimensions, point, exact signed distance) worked out by hand.
KNOWN = [
    ('sphere', [0.5], [0.0, 0.0, 0.0], -0.5),
    ('sphere', [0.5], [3.0, 4.0, 0.0], 4.5),
    ('sphere', [0.5], [0.0, 0.3, 0.0], -0.2),
    ('box', [1.0, 2.0, 3.0], [0.0, 0.0, 0.0], -0.5),
    ('box', [1.0, 2.0, 3.0], [2.0, 0.0, 0.0], 1.5),
    ('box', [1.0, 2.0, 3.0], [1.5, 2.0, 0.0], math.hypot(1.0, 1.0)),
    ('box', [1.0, 2.0, 3.0], [1.5, 3.0, 3.5], math.sqrt(1.0 + 4.0 + 4.0)),
    ('box', [1.0, 2.0, 3.0], [0.2, -0.7, 1.0], -0.3),
    ('cylinder', [0.5, 2.0], [0.0, 0.0, 0.0], -0.5),
    ('cylinder', [0.5, 2.0], [0.0, 0.0, 0.8], -0.2),
    ('cylinder', [0.5, 2.0], [3.0, 4.0, 0.0], 4.5),
    ('cylinder', [0.5, 2.0], [0.0, 0.0, -4.0], 3.0),
    ('cylinder', [0.5, 2.0], [0.0, 1.5, 2.0], math.hypot(1.0, 1.0)),
    ('capsule', [0.5, 2.0], [0.0, 0.0, 0.0], -0.5),
    ('capsule', [0.5, 2.0], [0.0, 0.0, 4.0], 2.5),
    ('capsule', [0.5, 2.0], [3.0, 0.0, 5.0], 4.5),
    ('capsule', [0.5, 2.0], [0.0, -2.0, 0.7], 1.5),
    ('ellipsoid', [3.0, 2.0, 1.0], [0.0, 0.0, 0.0], -1.0),
    ('ellipsoid', [3.0, 2.0, 1.0], [5.0, 0.0, 0.0], 2.0),
    ('ellipsoid', [3.0, 2.0, 1.0], [0.0, -4.0, 0.0], 2.0),
    ('ellipsoid', [3.0, 2.0, 1.0], [0.0, 0.0, 0.25], -0.75),
    ('ellipsoid', [1.0, 1.0, 1.0], [1.0, 1.0, 1.0], math.sqrt(3.0) - 1.0),
]


@pytest.mark.parametrize('shape, dims, point, expected', KNOWN)
def test_phi_at_points_worked_out_by_hand(shape, dims, point, expected):
    assert abs(phi(primitive_shape(shape, dims), [point])[0] - expected) <= ROUND_OFF


def test_plane_phi_is_the_signed_height_above_it():
    plane = plane_shape([0.0, 0.0, 2.0], 0.5)  # normalised: z <= 0.5 is solid
    values, grad = plane.signed_distance(np.array([[1.0, 2.0, 0.5], [0.0, 0.0, -1.0],
                                                   [5.0, 5.0, 3.0]]))
    np.testing.assert_allclose(values, [0.0, -1.5, 2.5], rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(grad, [[0.0, 0.0, 1.0]] * 3, rtol=0, atol=ROUND_OFF)


def box_surface_samples(half, n):
    """Points on the box surface on an (n+1)² grid per face (spacing <= 2 max(half) / n)."""
    t = np.linspace(-1.0, 1.0, n + 1)
    uu, vv = (g.ravel() for g in np.meshgrid(t, t, indexing='ij'))
    faces = []
    for axis in range(3):
        a, b = [m for m in range(3) if m != axis]
        for sign in (-1.0, 1.0):
            face = np.zeros((uu.size, 3))
            face[:, a] = uu * half[a]
            face[:, b] = vv * half[b]
            face[:, axis] = sign * half[axis]
            faces.append(face)
    return np.concatenate(faces)


def test_box_phi_matches_the_distance_to_a_dense_sampling_of_its_surface():
    half = np.array([0.5, 1.0, 1.5])
    box = primitive_shape('box', 2.0 * half)
    n = 150
    surface = box_surface_samples(half, n)
    rng = np.random.default_rng(SEED)
    points = rng.uniform(-2.5, 2.5, size=(200, 3))
    nearest = np.array([np.sqrt(((surface - p) ** 2).sum(axis=1)).min() for p in points])
    inside = np.all(np.abs(points) < half, axis=1)
    expected = np.where(inside, -nearest, nearest)
    # The exact closest point lies in a grid cell of side <= 2 * 1.5 / 150 = 0.02 m, so some
    # sample is within half its diagonal, 0.02 / sqrt(2) m, and no sample is closer than the
    # exact distance: the sampled distance overestimates |φ| by at most 0.0142 m, while a
    # wrong formula (e.g. the inside distance of the farthest face) is off by 0.1 m or more.
    cell = 2.0 * half.max() / n
    err = np.abs(phi(box, points)) - np.abs(expected)
    assert np.all(err <= ROUND_OFF)
    assert np.all(err >= -cell / math.sqrt(2.0) - ROUND_OFF)
    assert np.array_equal(np.sign(phi(box, points)), np.sign(expected))


def inside_exact(shape, dims, points):
    x, y, z = points.T
    if shape == 'sphere':
        return x * x + y * y + z * z < dims[0] ** 2
    if shape == 'box':
        return np.all(np.abs(points) < 0.5 * np.asarray(dims), axis=1)
    if shape == 'cylinder':
        return (x * x + y * y < dims[0] ** 2) & (np.abs(z) < 0.5 * dims[1])
    if shape == 'capsule':
        cz = np.clip(z, -0.5 * dims[1], 0.5 * dims[1])
        return x * x + y * y + (z - cz) ** 2 < dims[0] ** 2
    return (x / dims[0]) ** 2 + (y / dims[1]) ** 2 + (z / dims[2]) ** 2 < 1.0


SHAPES = [('sphere', [0.7]), ('box', [1.0, 0.4, 1.6]), ('cylinder', [0.6, 1.5]),
          ('capsule', [0.3, 1.2]), ('ellipsoid', [1.2, 0.5, 0.8])]


@pytest.mark.parametrize('shape, dims', SHAPES)
def test_sign_inside_and_outside(shape, dims):
    solid = primitive_shape(shape, dims)
    points = np.random.default_rng(SEED).uniform(-1.5, 1.5, size=(4000, 3))
    values = phi(solid, points)
    inside = inside_exact(shape, dims, points)
    assert inside.any() and (~inside).any()
    assert np.all(values[inside] < 0.0)
    assert np.all(values[~inside] > 0.0)


@pytest.mark.parametrize('shape, dims', SHAPES)
def test_gradient_is_unit_and_matches_finite_differences(shape, dims):
    solid = primitive_shape(shape, dims)
    points = np.random.default_rng(SEED + 1).uniform(-1.5, 1.5, size=(2000, 3))
    values, grad = solid.signed_distance(points)
    fd = np.empty_like(points)
    for axis in range(3):
        step = np.zeros(3)
        step[axis] = FD_STEP
        fd[:, axis] = (phi(solid, points + step) - phi(solid, points - step)) / (2 * FD_STEP)
    # Away from the medial set the central difference is the gradient; near it (where two
    # closest points compete) one of the two one-sided slopes differs.  Keep the points whose
    # finite-difference gradient is unit length: there φ is differentiable across the stencil.
    smooth = np.abs(np.linalg.norm(fd, axis=1) - 1.0) < FD_TOL
    assert smooth.mean() > 0.9
    np.testing.assert_allclose(np.linalg.norm(grad, axis=1), 1.0, rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(grad[smooth], fd[smooth], rtol=0, atol=FD_TOL)
    assert np.all(np.isfinite(values))


def ellipsoid_brute_force(axes, point):
    """Distance from ``point`` to the ellipsoid surface by grid search with zooming windows."""
    a, b, c = axes

    def surface(theta, lon):
        return np.stack([a * np.sin(theta) * np.cos(lon), b * np.sin(theta) * np.sin(lon),
                         c * np.cos(theta)], axis=-1)

    theta, lon = np.meshgrid(np.linspace(0.0, math.pi, 401), np.linspace(-math.pi, math.pi, 801),
                             indexing='ij')
    dist = np.linalg.norm(surface(theta, lon) - point, axis=-1)
    i = np.unravel_index(np.argmin(dist), dist.shape)
    t0, l0, best = theta[i], lon[i], dist[i]
    width = 2.0 * math.pi / 400
    for _ in range(9):
        tt, ll = np.meshgrid(t0 + np.linspace(-width, width, 41),
                             l0 + np.linspace(-width, width, 41), indexing='ij')
        dist = np.linalg.norm(surface(tt, ll) - point, axis=-1)
        i = np.unravel_index(np.argmin(dist), dist.shape)
        t0, l0, best = tt[i], ll[i], dist[i]
        width /= 10.0
    return best


@pytest.mark.parametrize('point', [
    [4.0, 3.0, 2.0], [0.5, 0.3, 0.2], [-1.0, 1.7, 0.1], [2.9, 0.0, 0.0], [0.0, 0.0, 0.99],
    [1.0, 0.5, 0.0], [0.0, 2.5, -1.5], [-0.2, -0.1, -0.05], [2.0, 1.0, 0.5],
])
def test_ellipsoid_distance_matches_brute_force_minimisation(point):
    axes = (3.0, 2.0, 1.0)
    solid = primitive_shape('ellipsoid', axes)
    point = np.array(point)
    expected = ellipsoid_brute_force(axes, point)
    inside = np.sum((point / axes) ** 2) < 1.0
    # The zoom ends with a parameter step of 2π/400/1e8/20 ~ 1e-11 rad; at the minimum the
    # distance is quadratic in the parameter error (~R δ² < 1e-20 m), and if the zoom had left
    # the true basin the error would be ~the coarse grid spacing, 0.02 m.  1e-9 m separates
    # these by far.
    assert abs(phi(solid, [point])[0] - (-expected if inside else expected)) <= 1e-9


def test_ellipsoid_closest_point_is_stationary():
    """φ's closest point ``p − φ ∇φ`` lies on the ellipsoid and ∇φ is its normal there."""
    axes = np.array([3.0, 2.0, 1.0])
    solid = primitive_shape('ellipsoid', axes)
    rng = np.random.default_rng(SEED + 2)
    # Anywhere, and just off the medial disk z = 0 inside (where the closest point's z is
    # y_z / (s + 1) with s + 1 tiny: an ill-conditioned quotient unless s + 1 is solved for).
    near_medial = np.column_stack([rng.uniform(-1.5, 1.5, (500, 2)),
                                   rng.uniform(-1e-12, 1e-12, 500)])
    points = np.concatenate([rng.uniform(-4.0, 4.0, size=(2000, 3)), near_medial,
                             rng.uniform(-1e-3, 1e-3, size=(500, 3))])
    values, grad = solid.signed_distance(points)
    closest = points - values[:, None] * grad
    # The ellipsoid's level value (x/a)² + ... is 1 to round-off (~1e-15 per term, with
    # terms up to ~4): 1e-12 of margin.
    np.testing.assert_allclose(((closest / axes) ** 2).sum(axis=1), 1.0, rtol=0, atol=1e-12)
    normal = closest / axes ** 2
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    np.testing.assert_allclose(grad, normal, rtol=0, atol=1e-12)


@pytest.mark.parametrize('shape, dims', SHAPES)
def test_surface_points_lie_on_the_surface_and_inside_the_bounds(shape, dims):
    solid = primitive_shape(shape, dims)
    assert solid.points_b.shape[0] >= 12
    np.testing.assert_allclose(phi(solid, solid.points_b), 0.0, rtol=0, atol=ROUND_OFF)
    radius = np.linalg.norm(solid.points_b, axis=1)
    assert radius.max() <= solid.bounding_radius_m + ROUND_OFF
    assert np.all(solid.points_b >= solid.aabb_min_b - ROUND_OFF)
    assert np.all(solid.points_b <= solid.aabb_max_b + ROUND_OFF)
    # The extremes along each axis are sampled: the bounding box is tight.
    np.testing.assert_allclose(solid.points_b.max(axis=0), solid.aabb_max_b, atol=ROUND_OFF)


def test_box_points_follow_the_documented_rule():
    size = np.array([1.0, 0.5, 0.25])
    box = primitive_shape('box', size, spacing_m=0.25)
    # corners 8; edges: 4 per axis cut into ceil(2 L / s) parts -> parts - 1 interior points;
    # faces: 2 per axis, (ceil(Lu / s) - 1) (ceil(Lv / s) - 1) interior nodes.
    parts = np.ceil(2.0 * size / 0.25).astype(int)
    cells = np.ceil(size / 0.25).astype(int)
    faces = 2 * ((cells[1] - 1) * (cells[2] - 1) + (cells[0] - 1) * (cells[2] - 1)
                 + (cells[0] - 1) * (cells[1] - 1))
    assert box.points_b.shape[0] == 8 + 4 * int((parts - 1).sum()) + faces
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    for corner in corners * size / 2:
        assert np.any(np.all(box.points_b == corner, axis=1))
    # Denser at the edges: along the x edge at (y, z) = (0.25, 0.125) the spacing is s / 2.
    on_edge = box.points_b[(box.points_b[:, 1] == 0.25) & (box.points_b[:, 2] == 0.125)]
    np.testing.assert_allclose(np.diff(np.sort(on_edge[:, 0])), 0.125, atol=ROUND_OFF)


@pytest.mark.parametrize('shape, dims', SHAPES)
def test_extreme_points_give_finite_values_without_raising(shape, dims):
    solid = primitive_shape(shape, dims)
    high = solid.aabb_max_b
    # Offsets whose squares underflow, subnormal coordinates, the origin, far away.
    points = np.array([[high[0] + 1e-170, 0.0, 0.0], [high[0] + 1e-170, high[1] + 1e-170, 0.0],
                       [1e-300, 1e-310, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 1e-320],
                       [1e150, -1e150, 1e150], [0.0, high[1], 0.0]])
    values, grad = solid.signed_distance(points)
    assert np.all(np.isfinite(values)) and np.all(np.isfinite(grad))
    np.testing.assert_allclose(np.linalg.norm(grad, axis=1), 1.0, rtol=0, atol=ROUND_OFF)


@pytest.mark.parametrize('shape', ['box', 'cylinder'])
def test_outside_gaps_whose_square_underflows_give_the_gap(shape):
    """A gap of 1e-170 m from a 1e-160 m shape: its square (1e-340) underflows to 0."""
    solid = primitive_shape(shape, [1e-160, 1e-160, 1e-160][:2 if shape == 'cylinder' else 3])
    gap = 1e-170
    value, grad = solid.signed_distance([solid.aabb_max_b[0] + gap, 0.0, 0.0])
    # The coordinate 1e-160 + 1e-170 rounds at ~1e-176: the gap is exact to ~1e-6 relative.
    assert value == pytest.approx(gap, rel=1e-5)
    np.testing.assert_array_equal(grad, [1.0, 0.0, 0.0])


@pytest.mark.parametrize('shape, dims, corner', [
    ('box', [0.2, 0.2, 0.2], [0.1, 0.1, 0.0]),       # the edge x = y = 0.1
    ('box', [0.2, 0.2, 0.2], [0.1, 0.1, 0.1]),       # a corner
    ('cylinder', [0.1, 0.2], [0.1, 0.0, 0.1]),       # the top rim
])
def test_a_point_outside_an_edge_by_round_off_takes_a_face_normal(shape, dims, corner):
    # A point a few ulps outside an edge or a corner: the direction from the edge is the
    # round-off of its coordinates (here (1, 2, 3) ulps: 27° from either face before the
    # change), and a patch normal tilted like that locked boxes side by side into wedges.
    # It takes the face normal of its largest outward offset; φ stays the exact distance.
    solid = primitive_shape(shape, dims)
    point = np.array(corner, dtype=float)
    for axis, ulps in enumerate([1, 2, 3]):
        for _ in range(ulps if corner[axis] != 0.0 else 0):
            point[axis] = np.nextafter(point[axis], 1.0)
    value, grad = solid.signed_distance(point)
    # Exact reference: the offsets are exact differences of nearby floats (Sterbenz).
    if shape == 'box':
        offsets = [max(point[k] - 0.1, 0.0) for k in range(3)]
        faces = np.eye(3)
    else:
        offsets = [math.hypot(point[0], point[1]) - 0.1, point[2] - 0.1]
        faces = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    assert 0.0 < max(offsets) < 1e-15
    assert value == pytest.approx(math.hypot(*offsets), rel=1e-12)
    np.testing.assert_array_equal(grad, faces[int(np.argmax(offsets))])
    # A real gap (1e-9 m, not round-off) keeps the direction from the edge.
    far = np.array(corner) + 1e-9 * (np.array(corner) != 0.0)
    value, grad = solid.signed_distance(far)
    bent = (np.array(corner) != 0.0) / math.sqrt(np.count_nonzero(corner))
    np.testing.assert_allclose(grad, bent, rtol=0, atol=1e-6)


def test_building_twice_gives_identical_bytes():
    for shape, dims in SHAPES:
        a = primitive_shape(shape, dims)
        b = primitive_shape(shape, dims)
        assert a == b
        assert a.points_b.tobytes() == b.points_b.tobytes()
        assert a.params.tobytes() == b.params.tobytes()


@pytest.mark.parametrize('shape, dims, needle', [
    ('box', [0.0, 1.0, 1.0],
     "dimensions_m: [0.0, 1.0, 1.0] m for shape 'box' [x, y, z]: x = 0.0 m"),
    ('sphere', [-1.0], 'radius = -1.0 m must be finite and > 0'),
    ('cylinder', [0.5, float('nan')], 'length = nan m'),
    ('capsule', [0.5], "has 1 values; shape 'capsule' needs 2"),
    ('ellipsoid', [1.0, 1.0, float('inf')], 'c = inf m'),
    ('cone', [1.0], "shape: 'cone' is not one of"),
])
def test_bad_dimensions_are_refused_with_the_field_named(shape, dims, needle):
    with pytest.raises(ModelError) as info:
        primitive_shape(shape, dims, field='bodies.b1.')
    assert 'bodies.b1.' in str(info.value)
    assert needle in str(info.value)


def test_bad_spacing_and_plane_are_refused():
    with pytest.raises(ModelError, match=r'spacing_m: 0\.0 m must be finite and > 0'):
        primitive_shape('sphere', [1.0], spacing_m=0.0)
    with pytest.raises(ModelError, match=r'ground\.normal: \[0\.0, 0\.0, 0\.0\]'):
        plane_shape([0.0, 0.0, 0.0], 0.0, field='ground.')
    with pytest.raises(ModelError, match=r'offset_m: nan m must be a finite number'):
        plane_shape([0.0, 0.0, 1.0], float('nan'))
