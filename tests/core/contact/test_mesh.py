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
Mesh collision shapes: the grid SDF against analytic φ, files, refusals, the cache.

The grid SDF's documented error bound inside the grid box is ``(√3 / 2) h`` (h the node
spacing; proof in :func:`rbd_ros.core.contact.kernels.phi_grad`); tests use that bound plus
``ROUND_OFF``.  At the nodes themselves the samples are exact distances, compared to
``ROUND_OFF = 1e-12`` m (a few dozen float64 operations on unit-size numbers, ~1e-15 m each).
"""

import math
import os
import stat

import numpy as np
import pytest

from rbd_ros.core.contact import kernels
from rbd_ros.core.contact import load_mesh, mesh_shape, primitive_shape
from rbd_ros.core.contact.mesh_shapes import sdf_cache_dir
from rbd_ros.core.errors import ModelError
from rbd_ros.core.inertia import box as box_inertia
import trimesh

ROUND_OFF = 1e-12
SEED = 20261127
CELLS = 24  # coarse grids keep the test fast; the bound scales with h, so nothing is lost


def bound(shape):
    return 0.5 * math.sqrt(3.0) * shape.params[3]


def grid_points(shape):
    """Every node of the shape's SDF grid, in the order of ``shape.grid.ravel()``."""
    n = shape.grid.shape
    idx = np.stack(np.meshgrid(*(np.arange(m) for m in n), indexing='ij'), -1).reshape(-1, 3)
    return shape.params[:3] + shape.params[3] * idx


def in_grid(shape, points):
    high = shape.params[:3] + shape.params[3] * (np.array(shape.grid.shape) - 1)
    return np.all((points >= shape.params[:3]) & (points <= high), axis=1)


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """Point the SDF cache at a fresh folder for each test."""
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path / 'xdg'))
    return tmp_path / 'xdg' / 'rbd_ros' / 'sdf'


def test_cube_mesh_sdf_matches_the_box_phi(cache):
    mesh = trimesh.creation.box(extents=[1.0, 0.6, 0.4])
    shape = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=CELLS)
    box = primitive_shape('box', [1.0, 0.6, 0.4])
    nodes = grid_points(shape)
    np.testing.assert_allclose(shape.grid.ravel(), box.signed_distance(nodes)[0], rtol=0,
                               atol=ROUND_OFF)
    points = np.random.default_rng(SEED).uniform(-0.8, 0.8, size=(5000, 3))
    points = points[in_grid(shape, points)]
    error = np.abs(shape.signed_distance(points)[0] - box.signed_distance(points)[0])
    assert error.max() <= bound(shape) + ROUND_OFF
    # Away from edges (the box's φ is linear there) trilinear interpolation is exact.
    face = np.array([[0.1, 0.05, 0.35], [0.0, 0.0, -0.3], [0.7, 0.0, 0.0]])
    np.testing.assert_allclose(shape.signed_distance(face)[0], box.signed_distance(face)[0],
                               rtol=0, atol=ROUND_OFF)
    np.testing.assert_allclose(shape.signed_distance(face)[1], box.signed_distance(face)[1],
                               rtol=0, atol=ROUND_OFF)


def test_mesh_mass_properties_come_from_the_polyhedral_integrals(cache):
    mesh = trimesh.creation.box(extents=[1.0, 0.6, 0.4])
    mesh.apply_translation([3.0, -2.0, 1.0])
    shape = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=8)
    np.testing.assert_allclose(shape.mesh_offset_m, [3.0, -2.0, 1.0], rtol=0, atol=ROUND_OFF)
    props = shape.mass_properties(2.0)
    expected = box_inertia(2.0, [1.0, 0.6, 0.4])
    np.testing.assert_allclose(props.com_b, 0.0, atol=ROUND_OFF)
    np.testing.assert_allclose(props.inertia_b, expected.inertia_b, rtol=1e-12, atol=0)


def test_icosphere_sdf_matches_the_sphere_phi_within_bound_and_facet_depth(cache):
    radius = 0.5
    mesh = trimesh.creation.icosphere(subdivisions=2, radius=radius)
    shape = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=CELLS)
    sphere = primitive_shape('sphere', [radius])
    # The icosphere's vertices lie on the sphere; its faces dip inside by at most the
    # sagitta r - (distance of the nearest face plane to the centre).  φ of the mesh and of the
    # sphere differ by at most that Hausdorff distance, plus the grid bound.
    v = mesh.vertices[mesh.faces]
    normal = np.cross(v[:, 1] - v[:, 0], v[:, 2] - v[:, 0])
    plane = np.abs(np.einsum('ij,ij->i', normal / np.linalg.norm(normal, axis=1)[:, None],
                             v[:, 0]))
    sagitta = radius - plane.min()
    assert 0.0 < sagitta < 0.01
    points = np.random.default_rng(SEED).uniform(-0.7, 0.7, size=(4000, 3))
    points = points[in_grid(shape, points)]
    error = np.abs(shape.signed_distance(points)[0] - sphere.signed_distance(points)[0])
    assert error.max() <= bound(shape) + sagitta + ROUND_OFF
    # Deep inside, φ is dominated by the radius: sign and size right.
    assert shape.signed_distance([0.0, 0.0, 0.0])[0] < -radius + sagitta + bound(shape)


def l_block():
    """Return an L prism: the profile (0,0) (2,0) (2,1) (1,1) (1,2) (0,2), z from 0 to 1."""
    profile = [(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]
    vertices = [(x, y, 0.0) for x, y in profile] + [(x, y, 1.0) for x, y in profile]
    cap = [(0, 1, 2), (0, 2, 3), (0, 3, 4), (0, 4, 5)]  # counter-clockwise seen from +z
    faces = [(c, b, a) for a, b, c in cap] + [(a + 6, b + 6, c + 6) for a, b, c in cap]
    for i in range(6):
        j = (i + 1) % 6
        faces += [(i, j, j + 6), (i, j + 6, i + 6)]
    return np.array(vertices, dtype=float), np.array(faces)


def l_block_phi(points):
    """Return the exact φ of the L prism: nearest of its ten axis-aligned boundary rectangles."""
    rects = [((0, 0, 0), (2, 1, 0)), ((0, 1, 0), (1, 2, 0)), ((0, 0, 1), (2, 1, 1)),
             ((0, 1, 1), (1, 2, 1)), ((0, 0, 0), (2, 0, 1)), ((2, 0, 0), (2, 1, 1)),
             ((1, 1, 0), (2, 1, 1)), ((1, 1, 0), (1, 2, 1)), ((0, 2, 0), (1, 2, 1)),
             ((0, 0, 0), (0, 2, 1))]
    dist = np.min([np.linalg.norm(points - np.clip(points, lo, hi), axis=1)
                   for lo, hi in rects], axis=0)
    x, y, z = points.T
    inside = ((z > 0) & (z < 1) & (x > 0) & (y > 0)
              & (((x < 2) & (y < 1)) | ((x < 1) & (y < 2))))
    return np.where(inside, -dist, dist)


def test_nonconvex_l_block_concavity_is_outside(cache):
    vertices, faces = l_block()
    shape = mesh_shape(vertices, faces, sdf_cells=CELLS, centre=False)
    nodes = grid_points(shape)
    np.testing.assert_allclose(shape.grid.ravel(), l_block_phi(nodes), rtol=0, atol=ROUND_OFF)
    # Points in the notch are outside: (1.5, 1.5) is 0.5 m from the notch walls x = 1 and
    # y = 1; (1.2, 1.1) is 0.1 m from the wall y = 1.  Both are inside the convex hull.
    values = shape.signed_distance([[1.5, 1.5, 0.5], [1.2, 1.1, 0.3]])[0]
    assert np.all(values > 0.0)
    np.testing.assert_allclose(values, [0.5, 0.1], rtol=0, atol=bound(shape))
    points = np.random.default_rng(SEED).uniform(-0.5, 2.5, size=(4000, 3))
    points = points[in_grid(shape, points)]
    error = np.abs(shape.signed_distance(points)[0] - l_block_phi(points))
    assert error.max() <= bound(shape) + ROUND_OFF
    # A convex hull would fill the notch; surface points include the notch's corner edge.
    assert np.any(np.all(shape.points_b == [1.0, 1.0, 0.5], axis=1))


def test_outside_the_grid_phi_is_the_boundary_value_plus_the_gap(cache):
    mesh = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    shape = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=8)
    edge = shape.params[0] + shape.params[3] * (shape.grid.shape[0] - 1)
    far = np.array([edge + 2.0, 0.0, 0.0])
    value, grad = shape.signed_distance(far)
    assert value == pytest.approx(shape.signed_distance([edge, 0.0, 0.0])[0] + 2.0,
                                  abs=ROUND_OFF)
    assert value == pytest.approx(edge + 2.0 - 0.5, abs=ROUND_OFF)  # the box face is exact
    np.testing.assert_allclose(grad, [1.0, 0.0, 0.0], atol=ROUND_OFF)


@pytest.mark.parametrize('suffix', ['stl', 'obj'])
def test_stl_and_obj_files_load_like_the_arrays(cache, tmp_path, suffix):
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=0.3)
    mesh.apply_translation([0.1, 0.0, 0.0])
    path = tmp_path / f'ball.{suffix}'
    mesh.export(str(path))
    loaded = load_mesh(path, mesh_scale=[2.0, 1.0, 1.0], sdf_cells=12)
    scaled = mesh_shape(mesh.vertices * [2.0, 1.0, 1.0], mesh.faces, sdf_cells=12)
    assert loaded.faces.shape == scaled.faces.shape
    np.testing.assert_allclose(loaded.mesh_offset_m, [0.2, 0.0, 0.0], atol=1e-6)
    points = np.random.default_rng(SEED).uniform(-0.6, 0.6, size=(500, 3))
    # Files store coordinates in float32 (STL) or printed decimals (OBJ): ~1e-7 relative on
    # coordinates of 0.6 m, so the two φ agree to well under 1e-5 m.
    np.testing.assert_allclose(loaded.signed_distance(points)[0],
                               scaled.signed_distance(points)[0], rtol=0, atol=1e-5)
    props = loaded.mass_properties(1.0)
    np.testing.assert_allclose(props.com_b, 0.0, atol=1e-9)


def write(path, data):
    path.write_bytes(data)
    return path


def bad_meshes():
    box = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    v, f = np.array(box.vertices), np.array(box.faces)
    flipped = f.copy()
    flipped[3] = flipped[3, ::-1]
    overlap = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    overlap.apply_translation([0.5, 0.3, 0.2])
    both = trimesh.util.concatenate([box, overlap])
    square = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=float)
    # Both sides of a square, split along different diagonals: closed, consistently wound,
    # every face of non-zero area, and flat.
    flat = np.array([[0, 1, 2], [0, 2, 3], [1, 0, 3], [1, 3, 2]])
    sliver = v.copy()
    sliver[f[0, 0]] = sliver[f[0, 1]]  # two corners of one face collapse
    return [
        ('open', v, f[:-1], 'open (not watertight)'),
        ('winding', v, flipped, 'inconsistent winding'),
        ('inverted', v, f[:, ::-1], 'wound clockwise'),
        ('self-intersecting', both.vertices, both.faces, 'self-intersecting'),
        ('zero volume', square, flat, 'volume 0 m³'),
        ('degenerate', sliver, f, 'degenerate'),
    ]


@pytest.mark.parametrize('label, vertices, faces, needle', bad_meshes(),
                         ids=[b[0] for b in bad_meshes()])
def test_bad_meshes_are_refused_with_the_reason(cache, label, vertices, faces, needle):
    with pytest.raises(ModelError) as info:
        mesh_shape(vertices, faces, field='bodies.hull.', sdf_cells=8)
    assert str(info.value).startswith('bodies.hull.mesh: ')
    assert needle in str(info.value)


def test_bad_mesh_arrays_and_grid_sizes_are_refused(cache):
    box = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    with pytest.raises(ModelError, match=r'^b\.vertices: shape \(8, 2\) must be \(n, 3\)'):
        mesh_shape(box.vertices[:, :2], box.faces, field='b.')
    with pytest.raises(ModelError, match=r'^b\.faces: shape \(12, 3\), dtype int64 must be .* '
                                         r'indices in \[0, 7\]'):
        mesh_shape(box.vertices, box.faces + 1, field='b.')
    for cells in (3, 257, 10.0, True):
        with pytest.raises(ModelError, match=rf'^b\.sdf_cells: {cells!r} must be an integer in '
                                             r'\[4, 256\]'):
            mesh_shape(box.vertices, box.faces, sdf_cells=cells, field='b.')


def test_bad_mesh_files_are_refused_naming_mesh_path(cache, tmp_path):
    with pytest.raises(ModelError, match=r"^obstacles\.rock\.mesh_path: '.*nowhere\.stl' does "
                                         r'not exist'):
        load_mesh(tmp_path / 'nowhere.stl', field='obstacles.rock.')
    garbage = write(tmp_path / 'garbage.stl', b'\x00\x01 not an stl at all')
    with pytest.raises(ModelError, match=r"^mesh_path: '.*garbage\.stl' (is not a readable "
                                         r'mesh|holds no triangles)'):
        load_mesh(garbage)
    with pytest.raises(ModelError, match=r'^mesh_path: None is not a file path'):
        load_mesh(None)
    text = write(tmp_path / 'notes.txt', b'hello\n')
    with pytest.raises(ModelError, match=r"^mesh_path: '.*notes\.txt' is not a readable mesh"):
        load_mesh(text)
    half = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    half.faces = half.faces[:-2]
    open_path = tmp_path / 'open.stl'
    half.export(str(open_path))
    with pytest.raises(ModelError, match=r"^mesh_path: '.*open\.stl': the mesh is open"):
        load_mesh(open_path)
    good = tmp_path / 'good.stl'
    trimesh.creation.box(extents=[1.0, 1.0, 1.0]).export(str(good))
    for scale, shown in [([1.0, 0.0, 1.0], r'\[1\.0, 0\.0, 1\.0\]'),
                         ([1.0, 1.0], r'\[1\.0, 1\.0\]'),
                         ([1.0, float('nan'), 1.0], r'\[1\.0, nan, 1\.0\]'),
                         ('big', "'big'")]:
        with pytest.raises(ModelError, match=rf'^mesh_scale: {shown}'):
            load_mesh(good, mesh_scale=scale)


def test_sdf_cache_hit_gives_identical_arrays_in_a_private_folder(cache, monkeypatch):
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=0.4)
    first = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=10)
    assert cache == sdf_cache_dir()
    assert stat.S_IMODE(os.stat(cache).st_mode) == 0o700
    files = sorted(cache.iterdir())
    assert len(files) == 1 and files[0].suffix == '.npz'
    with np.load(files[0], allow_pickle=False) as data:  # plain arrays, no pickled objects
        assert data['values'].dtype == np.float64

    def no_build(*args):
        raise AssertionError('the SDF was rebuilt despite the cache')

    monkeypatch.setattr(kernels, 'build_sdf', no_build)
    second = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=10)
    assert second == first
    assert second.grid.tobytes() == first.grid.tobytes()
    # Another grid resolution is another key: not served from this file.
    with pytest.raises(AssertionError, match='rebuilt'):
        mesh_shape(mesh.vertices, mesh.faces, sdf_cells=11)


def test_an_existing_cache_folder_is_made_private(cache):
    cache.mkdir(parents=True, mode=0o755)
    os.chmod(cache, 0o755)
    mesh = trimesh.creation.box(extents=[1.0, 1.0, 1.0])
    mesh_shape(mesh.vertices, mesh.faces, sdf_cells=6)
    assert stat.S_IMODE(os.stat(cache).st_mode) == 0o700
    assert len(list(cache.glob('*.npz'))) == 1


def test_a_corrupt_cache_file_is_rebuilt(cache):
    mesh = trimesh.creation.icosphere(subdivisions=1, radius=0.4)
    first = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=10)
    (path,) = cache.iterdir()
    path.write_bytes(b'PK\x03\x04 truncated')
    again = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=10)
    assert again.grid.tobytes() == first.grid.tobytes()
    with np.load(path, allow_pickle=False) as data:
        assert np.array_equal(data['values'], first.grid)


def test_building_a_mesh_twice_without_cache_gives_identical_bytes(cache):
    vertices, faces = l_block()
    a = mesh_shape(vertices, faces, sdf_cells=12, cache_dir=False)
    b = mesh_shape(vertices, faces, sdf_cells=12, cache_dir=False)
    assert not cache.exists()
    for name in ('grid', 'points_b', 'vertices_b', 'faces', 'params'):
        assert getattr(a, name).tobytes() == getattr(b, name).tobytes()


def test_a_compound_of_two_crossing_boxes_is_their_union():
    # A 0.4 x 0.1 x 0.1 m bar along x and one along y turned a quarter turn about z and
    # lifted 0.05 m, crossing it: φ is the least of the two boxes' exact distances (the
    # union's exact distance outside, a lower bound of its depth inside) to the grid's
    # interpolation bound, at 2000 random points of the grid box.
    from rbd_ros.core.contact.mesh_shapes import compound_shape
    from rbd_ros.sim.tessellation import shape_triangles
    bar = primitive_shape('box', [0.4, 0.1, 0.1])
    turn = (math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4))
    lift = np.array([0.0, 0.0, 0.05])
    parts = [(bar, np.zeros(3), (1.0, 0.0, 0.0, 0.0)), (bar, lift, turn)]
    shape = compound_shape(parts, [shape_triangles(bar)] * 2, sdf_cells=CELLS)
    assert shape.shape == 'compound' and shape.kind == kernels.KIND_MESH
    rng = np.random.default_rng(SEED)
    points = rng.uniform(-0.3, 0.3, (2000, 3))
    first = bar.signed_distance(points)[0]
    rot = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])  # the turn, x_b = R x
    second = bar.signed_distance((points - lift) @ rot)[0]
    exact = np.minimum(first, second)
    phi = shape.signed_distance(points)[0]
    inside = shape.aabb_min_b <= points
    inside = np.all(inside & (points <= shape.aabb_max_b), axis=1)
    worst = float(np.abs(phi - exact)[inside].max())
    print(f'\ncompound of two bars: |φ - min(φ1, φ2)| <= {worst:.3g} m, bound {bound(shape):.3g}')
    assert worst <= bound(shape) + ROUND_OFF
    # Surface points: none inside the other bar (so none where the bars cross), every corner
    # of the lower bar's bottom kept; the plane points (vertices) hold the 16 corners.
    phi_points = np.minimum(bar.signed_distance(shape.points_b)[0],
                            bar.signed_distance((shape.points_b - lift) @ rot)[0])
    assert np.abs(phi_points).max() <= ROUND_OFF
    corners = {tuple(np.round(v, 12)) for v in shape.vertices_b}
    assert {(x, y, -0.05) for x in (-0.2, 0.2) for y in (-0.05, 0.05)} <= corners
    with pytest.raises(ModelError, match='no uniform-density mass properties'):
        shape.mass_properties(1.0)


def test_a_compound_with_a_mesh_part_takes_its_exact_distance():
    # A URDF link's mesh element at an offset beside a sphere: the mesh part's φ at the nodes
    # is its exact distance (build_sdf on the moved vertices), so at random points φ is within
    # the grid's bound of min(box, sphere) computed in closed form (the mesh is a box).
    from rbd_ros.core.contact.mesh_shapes import compound_shape
    from rbd_ros.sim.tessellation import shape_triangles
    cube = trimesh.creation.box(extents=(0.2, 0.2, 0.2))
    mesh = mesh_shape(cube.vertices, cube.faces, centre=False, cache_dir=False)
    ball = primitive_shape('sphere', [0.1])
    offset = np.array([0.15, 0.0, 0.0])
    shape = compound_shape([(mesh, offset, (1.0, 0.0, 0.0, 0.0)),
                            (ball, -offset, (1.0, 0.0, 0.0, 0.0))],
                           [shape_triangles(mesh), shape_triangles(ball)], sdf_cells=CELLS)
    points = np.random.default_rng(SEED).uniform(shape.aabb_min_b, shape.aabb_max_b,
                                                 (2000, 3))  # inside the grid box
    exact = np.minimum(primitive_shape('box', [0.2, 0.2, 0.2]).signed_distance(
        points - offset)[0], np.linalg.norm(points + offset, axis=1) - 0.1)
    worst = float(np.abs(shape.signed_distance(points)[0] - exact).max())
    print(f'\ncompound of a mesh box and a sphere: |φ - exact| <= {worst:.3g} m, bound '
          f'{bound(shape):.3g}')
    assert worst <= bound(shape) + ROUND_OFF
