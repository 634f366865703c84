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
Tests of :mod:`rbd_ros.core.inertia`.

Each closed form is checked against independent computations of the same solid: a fine grid
of point masses, a tessellated triangle mesh and random point sampling.  Tolerances:

* ``ROUND_OFF = 1e-13`` relative: closed forms and exact mesh integrals are tens of float64
  operations on unit-scale numbers (each <= 1.1e-16 relative), so 1e-13 is ~1000 ulp of
  margin; any wrong coefficient is off by percent.
* Grid and mesh tolerances are derived where they are used.
"""

import numpy as np
import pytest

from rbd_ros.core.errors import ModelError
from rbd_ros.core.inertia import (
    bounding_box,
    box,
    capsule,
    from_shape,
    hollow_cylinder,
    inertia_from_components,
    MassProperties,
    parallel_axis,
    point_masses,
    point_sampling,
    principal_axes,
    rotate_inertia,
    SHAPES,
    solid_cylinder,
    solid_ellipsoid,
    solid_sphere,
    spherical_shell,
    triangle_mesh,
    validate_inertia,
    validate_mass,
)
from rbd_ros.core.rotations import quat_to_matrix

ROUND_OFF = 1e-13
SEED = 20260122


def rel_err(actual, expected):
    """Largest entry error relative to the largest entry of ``expected``."""
    return np.abs(np.asarray(actual) - expected).max() / np.abs(expected).max()


# --- reference solids ----------------------------------------------------------------------


def grid_points(low, high, n):
    """Cell centres of an n x n x n grid over the box [low, high]."""
    axes = [np.linspace(lo, hi, n, endpoint=False) + (hi - lo) / (2 * n)
            for lo, hi in zip(low, high)]
    return np.stack(np.meshgrid(*axes, indexing='ij'), axis=-1).reshape(-1, 3)


def grid_solid(inside, low, high, mass_kg, n):
    points = grid_points(low, high, n)
    points = points[inside(points)]
    return point_masses(np.full(len(points), mass_kg / len(points)), points)


def box_mesh(size, centre=(0.0, 0.0, 0.0)):
    """Return a closed, outward-oriented 12-triangle mesh of a box."""
    corners = np.array([[x, y, z] for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)])
    vertices = corners * np.asarray(size) + np.asarray(centre)
    # Vertex index = 4 ix + 2 iy + iz.  Each quad is listed counter-clockwise from outside.
    quads = [(0, 1, 3, 2), (4, 6, 7, 5),      # x = -, x = +
             (0, 4, 5, 1), (2, 3, 7, 6),      # y = -, y = +
             (0, 2, 6, 4), (1, 5, 7, 3)]      # z = -, z = +
    faces = [(a, b, c) for a, b, c, _ in quads] + [(a, c, d) for a, _, c, d in quads]
    return vertices, np.array(faces)


def revolution_mesh(radii, heights, n_phi):
    """
    Return a closed mesh of a solid of revolution about z, inscribed in the true surface.

    ``radii``/``heights`` is the profile from the bottom pole (radius 0) to the top pole
    (radius 0); interior profile points become rings of ``n_phi`` vertices.
    """
    radii, heights = np.asarray(radii, float), np.asarray(heights, float)
    phi = 2 * np.pi * np.arange(n_phi) / n_phi
    rings = [np.stack([r * np.cos(phi), r * np.sin(phi), np.full(n_phi, z)], axis=-1)
             for r, z in zip(radii[1:-1], heights[1:-1])]
    vertices = np.concatenate([[[0, 0, heights[0]]], *rings, [[0, 0, heights[-1]]]])
    top = len(vertices) - 1
    j = np.arange(n_phi)
    k = (j + 1) % n_phi
    ring = [1 + i * n_phi for i in range(len(rings))]
    faces = [np.stack([np.zeros(n_phi, int), ring[0] + k, ring[0] + j], axis=-1)]
    for lower, upper in zip(ring[:-1], ring[1:]):
        faces.append(np.stack([lower + j, lower + k, upper + k], axis=-1))
        faces.append(np.stack([lower + j, upper + k, upper + j], axis=-1))
    faces.append(np.stack([np.full(n_phi, top), ring[-1] + j, ring[-1] + k], axis=-1))
    return vertices, np.concatenate(faces)


def sphere_mesh(radius, n):
    theta = np.linspace(np.pi, 0.0, n + 1)
    return revolution_mesh(radius * np.sin(theta), radius * np.cos(theta), 2 * n)


def capsule_mesh(radius, length, n):
    theta = np.linspace(np.pi, np.pi / 2, n + 1)          # bottom cap, pole to equator
    r_cap, z_cap = radius * np.sin(theta), radius * np.cos(theta) - length / 2
    radii = np.concatenate([r_cap, r_cap[::-1]])
    heights = np.concatenate([z_cap, -z_cap[::-1]])
    return revolution_mesh(radii, heights, 4 * n)


def cylinder_mesh(radius, length, n_phi):
    return revolution_mesh([0, radius, radius, 0], [-length / 2, -length / 2, length / 2,
                                                    length / 2], n_phi)


def in_capsule(radius, length):
    def inside(p):
        nearest = np.clip(p[:, 2], -length / 2, length / 2)
        return p[:, 0] ** 2 + p[:, 1] ** 2 + (p[:, 2] - nearest) ** 2 < radius ** 2
    return inside


# Solids: (closed form, inside test, bounds low, bounds high, mesh or None).
R_SPHERE = 0.7
SEMI_AXES = np.array([0.3, 0.5, 0.9])
R_CYL, L_CYL = 0.5, 1.5
R_CAP, L_CAP = 0.4, 1.0
MASS = 2.5

SOLIDS = {
    'sphere': (solid_sphere(MASS, R_SPHERE), lambda p: np.sum(p * p, 1) < R_SPHERE ** 2,
               [-R_SPHERE] * 3, [R_SPHERE] * 3),
    'ellipsoid': (solid_ellipsoid(MASS, SEMI_AXES),
                  lambda p: np.sum((p / SEMI_AXES) ** 2, 1) < 1, -SEMI_AXES, SEMI_AXES),
    'cylinder': (solid_cylinder(MASS, R_CYL, L_CYL),
                 lambda p: p[:, 0] ** 2 + p[:, 1] ** 2 < R_CYL ** 2,
                 [-R_CYL, -R_CYL, -L_CYL / 2], [R_CYL, R_CYL, L_CYL / 2]),
    'capsule': (capsule(MASS, R_CAP, L_CAP), in_capsule(R_CAP, L_CAP),
                [-R_CAP, -R_CAP, -L_CAP / 2 - R_CAP], [R_CAP, R_CAP, L_CAP / 2 + R_CAP]),
}

MESHES = {
    'sphere': lambda n: sphere_mesh(R_SPHERE, n),
    'ellipsoid': lambda n: ((lambda v, f: (v / R_SPHERE * SEMI_AXES, f))(
        *sphere_mesh(R_SPHERE, n))),
    'cylinder': lambda n: cylinder_mesh(R_CYL, L_CYL, 2 * n),
    'capsule': lambda n: capsule_mesh(R_CAP, L_CAP, n),
}

# A grid of cell centres (120 cells across the bounding box) rasterises a curved solid; the
# misclassified cells lie in a boundary layer one cell thick.  The crude bound on the resulting
# relative error of the normalised moments is the layer's volume fraction, ~3 h / R = 5e-2,
# but the in/out decisions are nearly unbiased, so the errors of cells counted in and cells
# left out largely cancel: over grids of 60, 120 and 240 cells the worst relative error of
# these four solids was 4.6e-4 (2.6e-4 at 120).  GRID_RTOL = 2e-3 is 8x that, and 15x tighter
# than the 3 % by which a textbook slip in the capsule (shifting the cap's moment about its
# flat face instead of about its COM) would be off; test_grid_detects_capsule_slip checks
# that margin.
GRID_N = 120
GRID_RTOL = 2e-3


@pytest.mark.parametrize('name', sorted(SOLIDS))
def test_closed_form_matches_point_grid(name):
    reference, inside, low, high = SOLIDS[name]
    grid = grid_solid(inside, low, high, MASS, GRID_N)
    # The grids are symmetric about the origin, so their COM is 0 to round-off.
    np.testing.assert_allclose(grid.com_b, 0.0, atol=1e-12)
    assert rel_err(grid.inertia_b, reference.inertia_b) < GRID_RTOL


def test_box_matches_point_grid():
    size = np.array([0.4, 1.0, 2.2])
    n = 50
    grid = grid_solid(lambda p: np.ones(len(p), bool), -size / 2, size / 2, MASS, n)
    # Cell centres of an n-cell grid of [-L/2, L/2] have mean square L^2 (1 - 1 / n^2) / 12
    # exactly, so every moment is low by exactly the factor (1 - 1 / n^2).  The grid sums
    # n^3 = 125000 terms; naive summation error is bounded by n^3 * 1.1e-16 = 1.4e-11 relative,
    # hence 1e-10 (the 1 / n^2 = 4e-4 correction itself is 4 million times larger).
    np.testing.assert_allclose(grid.inertia_b, box(MASS, size).inertia_b * (1 - 1 / n ** 2),
                               rtol=1e-10, atol=1e-10 * MASS)


def test_grid_detects_capsule_slip():
    reference, inside, low, high = SOLIDS['capsule']
    r, length = R_CAP, L_CAP
    v_cyl, v_caps = np.pi * r * r * length, 4 * np.pi * r ** 3 / 3
    m_caps = MASS * v_caps / (v_cyl + v_caps)
    # Wrong: cap moment about its flat face shifted as if it were about the cap's COM.
    slip = m_caps * ((length / 2 + 3 * r / 8) ** 2 - (0.25 * length ** 2 + 0.375 * r * length))
    wrong = reference.inertia_b + np.diag([slip, slip, 0.0])
    grid = grid_solid(inside, low, high, MASS, GRID_N)
    assert rel_err(grid.inertia_b, wrong) > 10 * GRID_RTOL


# A mesh inscribed in a curved surface with polygons of angular step a = pi / n is short of
# the true radius by a factor ~ cos(a / 2), so the normalised moments are off by O(a^2).
# Doubling n must cut the error by ~4 (asserted > 3), and at n = 64 the error must be below
# a^2 = (pi / 64)^2 = 2.4e-3 (observed: 8e-4 for the sphere, the worst of the four).
@pytest.mark.parametrize('name', sorted(MESHES))
def test_closed_form_is_limit_of_meshes(name):
    reference = SOLIDS[name][0]
    errors = []
    for n in (32, 64):
        mesh = triangle_mesh(*MESHES[name](n), mass_kg=MASS)
        np.testing.assert_allclose(mesh.com_b, 0.0, atol=1e-12)
        errors.append(rel_err(mesh.inertia_b, reference.inertia_b))
    assert errors[1] < errors[0] / 3
    assert errors[1] < (np.pi / 64) ** 2


def test_box_mesh_equals_box_formula_to_round_off():
    size = np.array([0.4, 1.0, 2.2])
    reference = box(MASS, size)
    mesh = triangle_mesh(*box_mesh(size), mass_kg=MASS)
    assert mesh.mass_kg == MASS
    np.testing.assert_allclose(mesh.com_b, 0.0, atol=ROUND_OFF)
    np.testing.assert_allclose(mesh.inertia_b, reference.inertia_b, rtol=0,
                               atol=ROUND_OFF * MASS)
    # Density instead of mass: mass = rho V.
    dense = triangle_mesh(*box_mesh(size), density=1000.0)
    assert dense.mass_kg == pytest.approx(1000.0 * np.prod(size), rel=ROUND_OFF)


def test_box_mesh_far_from_origin_and_rotated():
    size = np.array([0.4, 1.0, 2.2])
    centre = np.array([1e3, -2e3, 5e2])
    rot = quat_to_matrix([0.9, 0.1, -0.3, 0.2])
    vertices, faces = box_mesh(size)
    mesh = triangle_mesh(vertices @ rot.T + centre, faces, mass_kg=MASS)
    np.testing.assert_allclose(mesh.com_b, centre, rtol=0, atol=1e-10)
    # Coordinates ~2e3 m carry 2e3 * 1.1e-16 = 2e-13 m absolute error against unit-scale
    # differences; with the vertices centred before integrating, the result keeps ~1e-12
    # relative accuracy (without centring it would lose ~(2e3)^2 * 1e-16 = 4e-10).
    np.testing.assert_allclose(mesh.inertia_b, rotate_inertia(box(MASS, size).inertia_b, rot),
                               rtol=0, atol=1e-11 * MASS)


def test_bad_meshes_refused():
    vertices, faces = box_mesh([1.0, 1.0, 1.0])
    with pytest.raises(ModelError, match=r'faces: the mesh encloses volume -1 m³; it must '
                                         r'be > 0'):
        triangle_mesh(vertices, faces[:, ::-1], mass_kg=1.0)
    with pytest.raises(ModelError, match=r'faces: edge \(\d+, \d+\) has no opposite edge'):
        triangle_mesh(vertices, faces[1:], mass_kg=1.0)
    flipped = faces.copy()
    flipped[0] = flipped[0, ::-1]
    with pytest.raises(ModelError, match='directed edge'):
        triangle_mesh(vertices, flipped, mass_kg=1.0)
    with pytest.raises(ModelError, match='give exactly one of mass_kg'):
        triangle_mesh(vertices, faces, mass_kg=1.0, density=2.0)
    with pytest.raises(ModelError, match='give exactly one of mass_kg'):
        triangle_mesh(vertices, faces)
    with pytest.raises(ModelError, match=r'faces: indices must be in \[0, 7\]'):
        triangle_mesh(vertices, faces + 1, mass_kg=1.0)
    with pytest.raises(ModelError, match='density: -3.0 kg/m³ must be > 0'):
        triangle_mesh(vertices, faces, density=-3.0)


# --- point sampling and bounding box -------------------------------------------------------


def test_point_sampling_converges_like_one_over_sqrt_n():
    reference, inside, low, high = SOLIDS['capsule']
    seeds = range(16)

    def rms_error(n):
        errors = [rel_err(point_sampling(inside, low, high, MASS, n,
                                         np.random.default_rng([SEED, s])).inertia_b,
                          reference.inertia_b) for s in seeds]
        return np.sqrt(np.mean(np.square(errors)))

    coarse, fine = rms_error(2_000), rms_error(32_000)
    # Monte Carlo error ~ 1 / sqrt(n): 16x the samples should cut it ~4x.  The RMS over 16
    # seeds has itself ~18 % relative spread (1 / sqrt(2 * 16)), so [2.5, 6.5] is a > 3-sigma
    # window around 4 for the ratio.
    assert 2.5 < coarse / fine < 6.5
    # At 32000 candidates (~70 % kept) the 1-sigma error of a moment is ~1 / sqrt(2e4) ~ 7e-3
    # relative; 2e-2 is ~3 sigma for the RMS.
    assert fine < 2e-2


def test_point_sampling_default_rng_is_reproducible():
    reference, inside, low, high = SOLIDS['sphere']
    a = point_sampling(inside, low, high, MASS, 1000)
    b = point_sampling(inside, low, high, MASS, 1000)
    assert a == b
    assert a.mass_kg == pytest.approx(MASS, rel=ROUND_OFF)
    with pytest.raises(ModelError, match=r'inside: only 0 of n = 100 samples fell inside'):
        point_sampling(lambda p: np.zeros(len(p), bool), low, high, MASS, 100)


def test_bounding_box():
    rng = np.random.default_rng(SEED)
    points = rng.uniform([-1.0, 2.0, 0.5], [3.0, 2.5, 4.5], size=(500, 3))
    approx = bounding_box(points, MASS)
    low, high = points.min(axis=0), points.max(axis=0)
    np.testing.assert_allclose(approx.com_b, (low + high) / 2, rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(approx.inertia_b, box(MASS, high - low).inertia_b, rtol=0,
                               atol=ROUND_OFF * MASS)
    with pytest.raises(ModelError, match=r'points_b: bounding box size \[4, 0, 1\] m'):
        bounding_box([[0, 0, 0], [4, 0, 1.0]], MASS)


# --- point masses, identities ----------------------------------------------------------------


def random_body(rng, n=50):
    masses = rng.uniform(0.1, 2.0, size=n)
    points = rng.normal(size=(n, 3)) * [0.3, 1.0, 2.0] + [1.0, -2.0, 0.5]
    return masses, points


def test_point_masses_definition_and_kinetic_energy():
    rng = np.random.default_rng(SEED)
    masses, points = random_body(rng)
    body = point_masses(masses, points)
    assert body.mass_kg == pytest.approx(masses.sum(), rel=ROUND_OFF)
    np.testing.assert_allclose(body.com_b, np.average(points, axis=0, weights=masses),
                               atol=ROUND_OFF)
    r = points - body.com_b
    explicit = sum(m * (ri @ ri * np.eye(3) - np.outer(ri, ri)) for m, ri in zip(masses, r))
    assert rel_err(body.inertia_b, explicit) < ROUND_OFF
    # Rotational kinetic energy: 1/2 w^T I w == sum 1/2 m |w x r|^2 (the lecture's identity).
    for omega in rng.normal(size=(10, 3)):
        expected = 0.5 * np.sum(masses * np.sum(np.cross(omega, r) ** 2, axis=1))
        assert 0.5 * omega @ body.inertia_b @ omega == pytest.approx(expected, rel=ROUND_OFF)


def test_parallel_axis_and_rotate_inertia():
    rng = np.random.default_rng(SEED)
    masses, points = random_body(rng)
    body = point_masses(masses, points)
    about_origin = sum(m * (p @ p * np.eye(3) - np.outer(p, p)) for m, p in zip(masses, points))
    shifted = parallel_axis(body.inertia_b, body.mass_kg, -body.com_b)
    assert rel_err(shifted, about_origin) < ROUND_OFF
    np.testing.assert_allclose(body.inertia_about(np.zeros(3)), shifted, rtol=0,
                               atol=ROUND_OFF * np.abs(shifted).max())
    # Rotating the points rotates the COM and the tensor: I' = R I R^T.
    rot = quat_to_matrix(rng.normal(size=4))
    turned = point_masses(masses, points @ rot.T)
    np.testing.assert_allclose(turned.com_b, rot @ body.com_b, atol=ROUND_OFF * 10)
    assert rel_err(rotate_inertia(body.inertia_b, rot), turned.inertia_b) < ROUND_OFF
    # Vectorised over offsets.
    offsets = rng.normal(size=(4, 3))
    batch = parallel_axis(body.inertia_b, body.mass_kg, offsets)
    assert batch.shape == (4, 3, 3)
    np.testing.assert_allclose(batch[2], parallel_axis(body.inertia_b, body.mass_kg,
                                                       offsets[2]))


def test_principal_axes_reconstructs_and_is_right_handed():
    rng = np.random.default_rng(SEED)
    for _ in range(50):
        body = point_masses(*random_body(rng, 20))
        moments, rot = principal_axes(body.inertia_b)
        assert np.all(np.diff(moments) >= 0.0)
        assert np.linalg.det(rot) == pytest.approx(1.0, abs=ROUND_OFF)
        np.testing.assert_allclose(rot.T @ rot, np.eye(3), atol=ROUND_OFF)
        assert rel_err(rot @ np.diag(moments) @ rot.T, body.inertia_b) < ROUND_OFF
        assert rel_err(rotate_inertia(body.inertia_b, rot.T), np.diag(moments)) < ROUND_OFF


def test_inertia_from_components_uses_ros_convention():
    tensor = inertia_from_components(1.0, 2.0, 3.0, ixy=-0.1, ixz=0.2, iyz=-0.3)
    np.testing.assert_array_equal(tensor, [[1.0, -0.1, 0.2], [-0.1, 2.0, -0.3],
                                           [0.2, -0.3, 3.0]])
    # Unit masses at +-(1, 1, 0) give ixy = -sum m x y = -2 as the matrix entry (the masses at
    # +-(0, 0, 1) only make the body three-dimensional).
    body = point_masses([1.0] * 4, [[1.0, 1.0, 0.0], [-1.0, -1.0, 0.0], [0, 0, 1.0],
                                    [0, 0, -1.0]])
    assert body.inertia_b[0, 1] == -2.0


# --- shapes ----------------------------------------------------------------------------------


def test_shape_closed_forms():
    np.testing.assert_allclose(np.diag(solid_sphere(5.0, 2.0).inertia_b), [8.0] * 3)
    np.testing.assert_allclose(np.diag(spherical_shell(3.0, 2.0).inertia_b), [8.0] * 3)
    np.testing.assert_allclose(np.diag(box(12.0, (1.0, 2.0, 3.0)).inertia_b), [13, 10, 5])
    np.testing.assert_allclose(np.diag(solid_cylinder(12.0, 1.0, 3.0).inertia_b),
                               [12.0, 12.0, 6.0])
    np.testing.assert_allclose(np.diag(hollow_cylinder(12.0, 1.0, 2.0, 3.0).inertia_b),
                               [24.0, 24.0, 30.0])
    # Capsule limits: as L -> 0 a sphere, as r -> 0 (r << L) a thin rod m L^2 / 12.
    np.testing.assert_allclose(capsule(5.0, 2.0, 1e-12).inertia_b,
                               solid_sphere(5.0, 2.0).inertia_b, rtol=1e-11)
    rod = capsule(3.0, 1e-6, 2.0).inertia_b
    assert rod[0, 0] == pytest.approx(3.0 * 4.0 / 12.0, rel=1e-5)


def test_spherical_shell_is_difference_of_spheres():
    # A thin shell is the limit of a solid sphere minus a slightly smaller one; relative
    # error O(dr / r) = 1e-6, tolerance 1e-5.
    r, dr, rho = 1.0, 1e-6, 1.0
    m_out, m_in = rho * 4 / 3 * np.pi * r ** 3, rho * 4 / 3 * np.pi * (r - dr) ** 3
    shell_i = 0.4 * (m_out * r ** 2 - m_in * (r - dr) ** 2)
    shell = spherical_shell(m_out - m_in, r).inertia_b[0, 0]
    assert shell == pytest.approx(shell_i, rel=1e-5)


@pytest.mark.parametrize('shape, dims, expected', [
    ('box', [1.0, 2.0, 3.0], box(MASS, [1.0, 2.0, 3.0])),
    ('sphere', [0.5], solid_sphere(MASS, 0.5)),
    ('spherical_shell', [0.5], spherical_shell(MASS, 0.5)),
    ('cylinder', [0.5, 2.0], solid_cylinder(MASS, 0.5, 2.0)),
    ('ellipsoid', [0.3, 0.5, 0.9], solid_ellipsoid(MASS, [0.3, 0.5, 0.9])),
    ('capsule', [0.4, 1.0], capsule(MASS, 0.4, 1.0)),
])
def test_from_shape_dispatch(shape, dims, expected):
    assert from_shape(shape, dims, MASS) == expected


def test_shapes_tuple():
    assert SHAPES == ('box', 'sphere', 'spherical_shell', 'cylinder', 'ellipsoid', 'capsule')


def test_from_shape_refuses_bad_input():
    with pytest.raises(ModelError, match=r"shape: 'cube' is not one of box, sphere"):
        from_shape('cube', [1.0], MASS)
    with pytest.raises(ModelError, match=r'dimensions_m: \[1.0, 2.0\] m has 2 values; shape '
                                         r"'box' needs 3: \[x, y, z\]"):
        from_shape('box', [1.0, 2.0], MASS)
    with pytest.raises(ModelError, match=r"dimensions_m: \[0.5, -2.0\] m for shape 'cylinder' "
                                         r'\[radius, length\]: length = -2.0 m must be finite '
                                         r'and > 0'):
        from_shape('cylinder', [0.5, -2.0], MASS)
    with pytest.raises(ModelError, match=r'radius = nan m'):
        from_shape('sphere', [float('nan')], MASS)
    with pytest.raises(ModelError, match=r'mass_kg: -1.0 kg must be > 0'):
        from_shape('sphere', [1.0], -1.0)


# --- validation ------------------------------------------------------------------------------


def test_validate_mass():
    assert validate_mass(2) == 2.0
    assert validate_mass(np.float32(0.5)) == 0.5
    for value, message in [(0.0, 'mass_kg: 0.0 kg must be > 0'),
                           (-1.5, 'mass_kg: -1.5 kg must be > 0'),
                           (float('nan'), 'mass_kg: nan kg must be finite'),
                           (float('inf'), 'mass_kg: inf kg must be finite'),
                           ('1', "mass_kg: '1' is not a number in kg"),
                           (True, 'mass_kg: True is not a number in kg')]:
        with pytest.raises(ModelError) as info:
            validate_mass(value)
        assert str(info.value) == message
    with pytest.raises(ModelError, match='^link_mass: 0.0 kg'):
        validate_mass(0.0, name='link_mass')


def test_validate_inertia_messages():
    with pytest.raises(ModelError) as info:
        validate_inertia(np.diag([0.1, 0.1, 0.5]))
    assert str(info.value) == ('inertia: principal moments [0.1, 0.1, 0.5] kg·m² break the '
                               'triangle inequality I1 + I2 >= I3 (0.2 < 0.5)')
    with pytest.raises(ModelError) as info:
        validate_inertia(np.diag([1.0, 2.0, -0.5]), name='inertia_b')
    assert str(info.value) == ('inertia_b: not positive definite: principal moments '
                               '[-0.5, 1, 2] kg·m² must all be > 0')
    with pytest.raises(ModelError, match=r'inertia: .* is not symmetric: max \|I - I\^T\| = '
                                         r'0.2 kg·m² > 1e-09 \* 2 kg·m²'):
        validate_inertia(inertia_from_components(1.0, 2.0, 2.0) + [[0, 0.2, 0], [0] * 3,
                                                                   [0] * 3])
    with pytest.raises(ModelError, match=r'inertia: shape \(2, 2\) must be \(3, 3\)'):
        validate_inertia(np.eye(2))
    with pytest.raises(ModelError, match=r'inertia: .*nan.* kg·m² must be finite'):
        validate_inertia(np.diag([1.0, np.nan, 1.0]))
    with pytest.raises(ModelError, match='inertia_b: principal moments'):
        MassProperties(1.0, np.zeros(3), np.diag([0.1, 0.1, 0.5]))


def test_triangle_inequality_slack():
    # A flat plate (all mass in z = 0) has I3 = I1 + I2 exactly; it must pass despite
    # round-off in the eigenvalues.
    rng = np.random.default_rng(SEED)
    plate = point_masses(rng.uniform(0.1, 1.0, 30),
                         np.c_[rng.normal(size=(30, 2)), np.zeros(30)])
    moments, _ = principal_axes(plate.inertia_b)
    assert moments[2] == pytest.approx(moments[0] + moments[1], rel=ROUND_OFF)
    # Printed-digit error of 1e-7 relative passes; 1e-5 (beyond TRIANGLE_RTOL = 1e-6) fails.
    validate_inertia(np.diag([1.0, 2.0, 3.0 * (1 + 1e-7)]))
    with pytest.raises(ModelError, match=r'\(3 < 3.00003\)'):
        validate_inertia(np.diag([1.0, 2.0, 3.0 * (1 + 1e-5)]))
    # A thin rod (tiny but positive I1) passes: 0 + I2 >= I3 holds with equality.
    validate_inertia(np.diag([1e-12, 1.0, 1.0]))


def test_mass_properties_is_frozen_value():
    body = MassProperties(2.0, [0.0, 0.1, 0.0], np.diag([1.0, 2.0, 2.5]))
    with pytest.raises(ValueError):
        body.inertia_b[0, 0] = 5.0
    with pytest.raises(ValueError):
        body.com_b[0] = 1.0
    with pytest.raises(AttributeError):
        body.mass_kg = 3.0
    assert body == MassProperties(2, (0.0, 0.1, 0.0), np.diag([1.0, 2.0, 2.5]))
    assert body != MassProperties(2.0, (0.0, 0.1, 0.0), np.diag([1.0, 2.0, 2.6]))
    with pytest.raises(ModelError, match=r'com_b: \[nan, 0.0, 0.0\] m must be finite'):
        MassProperties(2.0, [np.nan, 0, 0], np.eye(3))
    with pytest.raises(ModelError, match=r'mass_kg: 0.0 kg must be > 0'):
        MassProperties(0.0, np.zeros(3), np.eye(3))
