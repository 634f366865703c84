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
Collision shapes from triangle meshes and compounds: surface points plus a sampled SDF.

The primitives and :class:`~rbd_ros.core.contact.shapes.CollisionShape` itself are in
:mod:`rbd_ros.core.contact.shapes`; this module adds the shapes whose φ is a grid: a mesh
(:func:`mesh_shape`, :func:`load_mesh` from a file, checked: closed, consistently wound, not
self-crossing, not degenerate) and a compound of several shapes at their own poses
(:func:`compound_shape`, a URDF link's ``<collision>`` elements), and :func:`collision_shape`,
either kind from node parameters. A mesh's grid is sampled once and cached on disk
(:func:`sdf_cache_dir`, the cache rule of :mod:`rbd_ros.core.cachedir`).

A mesh's surface points are its vertices plus points on each edge every ``s / 2``.
"""

import hashlib
import math
import numbers
import os
from pathlib import Path
import tempfile
import warnings
import zipfile

import numpy as np

from rbd_ros.core import cachedir, jitcache
from rbd_ros.core.contact import kernels as k
from rbd_ros.core.contact.shapes import (CollisionShape, frozen_array, point_spacing,
                                         primitive_shape, shape_params)
from rbd_ros.core.errors import field_error, ModelError
from rbd_ros.core.inertia import triangle_mesh
from rbd_ros.core.rotations import quat_to_matrix

__all__ = [
    'DEFAULT_SDF_CELLS', 'MAX_SDF_CELLS', 'SDF_PAD_CELLS', 'collision_shape', 'compound_shape',
    'load_mesh', 'mesh_shape', 'sdf_cache_dir',
]

#: SDF grid cells along the largest extent of a mesh's bounding box (spacing ``h = L / cells``).
DEFAULT_SDF_CELLS = 64
#: Largest ``sdf_cells`` accepted: a cube's grid then holds ~263³ nodes (145 MB of float64).
MAX_SDF_CELLS = 256
#: Empty cells of padding around the mesh's bounding box on every side of the SDF grid.
SDF_PAD_CELLS = 3
# Version of the SDF algorithm and cache file layout; part of the cache key.
_SDF_VERSION = b'rbd_ros-sdf-1'
# Smallest relative sizes accepted: a face of area <= 1e-12 L² or a volume <= 1e-12 L³ (L the
# largest extent) is degenerate; float64 round-off on coordinates of size L is ~1e-16 L, so
# real geometry is many orders of magnitude above these floors.
_DEGENERATE_RTOL = 1e-12
# Vertex nudge of the second self-intersection test, relative to the largest extent: far above
# round-off (1e-16), far below any gap between faces of a real mesh that does not share a
# vertex (a mesh with faces closer than 1e-7 x extent is refused as crossing).
_NUDGE_RTOL = 1e-7


# ---------------------------------------------------------------------------------------------
# Meshes


def sdf_cache_dir():
    """Return the SDF cache folder, ``sdf`` in :func:`rbd_ros.core.cachedir.base_dir`."""
    return Path(cachedir.base_dir()) / 'sdf'


def _private_dir(path):
    """Return ``path`` created and checked by the cache rule (:mod:`cachedir`), or None."""
    default = path == sdf_cache_dir()
    refused = cachedir.make_private((str(path.parent), str(path)) if default else (str(path),))
    if refused is not None:
        warnings.warn(f'SDF cache {refused[0]!r}: {refused[1]}; building without it',
                      RuntimeWarning, stacklevel=3)
        return None
    return path


def _sdf_key(vertices, faces, origin, h, counts):
    digest = hashlib.sha256(_SDF_VERSION)
    for array in (vertices.astype('<f8'), faces.astype('<i8'), origin.astype('<f8'),
                  np.array([h], '<f8'), np.array(counts, '<i8')):
        digest.update(str(array.shape).encode())
        digest.update(np.ascontiguousarray(array).tobytes())
    return digest.hexdigest()


def _load_cached(path, key, counts):
    try:
        with np.load(path, allow_pickle=False) as data:
            if str(data['key']) != key:
                return None
            values = np.array(data['values'], dtype=np.float64)
    except (OSError, KeyError, ValueError, EOFError, zipfile.BadZipFile):
        return None  # missing or damaged: rebuilt and rewritten
    if values.shape != tuple(counts) or not np.all(np.isfinite(values)):
        return None
    return values


def _store(path, key, values):
    """Write the grid to ``path`` atomically (a private temporary file, then a rename)."""
    temporary = None
    try:
        with tempfile.NamedTemporaryFile(dir=path.parent, prefix='.tmp-', suffix='.npz',
                                         delete=False) as handle:
            temporary = handle.name
            np.savez(handle, key=np.array(key), values=values)
        os.replace(temporary, path)
    except OSError as exc:
        if temporary is not None and os.path.exists(temporary):
            os.unlink(temporary)
        warnings.warn(f'SDF cache: cannot write {str(path)!r} ({exc})', RuntimeWarning,
                      stacklevel=3)


def _sdf_grid(vertices, faces, cells, cache_dir):
    """Return ``(origin, h, values)`` of the mesh's SDF grid, from the cache when present."""
    low = vertices.min(axis=0)
    extent = vertices.max(axis=0) - low
    h = float(extent.max()) / cells
    counts = tuple(int(math.ceil(e / h)) + 1 + 2 * SDF_PAD_CELLS for e in extent)
    origin = low - SDF_PAD_CELLS * h
    key = _sdf_key(vertices, faces, origin, h, counts)
    folder = None if cache_dir is False else _private_dir(
        sdf_cache_dir() if cache_dir is None else Path(cache_dir))
    if folder is not None:
        values = _load_cached(folder / f'{key}.npz', key, counts)
        if values is not None:
            return origin, h, values
    values = np.zeros(counts)
    jitcache.configured()  # the kernel cache, before a first compile
    k.build_sdf(vertices, faces, origin, h, values)
    if folder is not None:
        _store(folder / f'{key}.npz', key, values)
    return origin, h, values


def _mesh_points(vertices, faces, s):
    edges = np.unique(np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1), axis=0)
    a, b = vertices[edges[:, 0]], vertices[edges[:, 1]]
    parts = np.ceil(2.0 * np.linalg.norm(b - a, axis=1) / s).astype(np.int64)
    pts = [vertices]
    for e in np.flatnonzero(parts > 1):
        t = np.arange(1, parts[e])[:, None] / parts[e]
        pts.append(a[e] + t * (b[e] - a[e]))
    return np.concatenate(pts)


def _check_mesh(mesh, where, field, where_field):
    """Refuse open, inconsistently wound, degenerate, inverted or self-intersecting meshes."""
    vertices = np.asarray(mesh.vertices, dtype=np.float64)
    faces = np.asarray(mesh.faces, dtype=np.int64)
    if faces.shape[0] < 4 or vertices.shape[0] < 4:
        raise ModelError(
            f'{where}: has {faces.shape[0]} faces and {vertices.shape[0]} vertices; a closed '
            'mesh needs at least 4 of each', field=where_field)
    if not np.all(np.isfinite(vertices)):
        raise ModelError(f'{where}: has non-finite vertex coordinates', field=where_field)
    extent = float((vertices.max(axis=0) - vertices.min(axis=0)).max())
    area = 0.5 * np.linalg.norm(np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]],
                                         vertices[faces[:, 2]] - vertices[faces[:, 0]]), axis=1)
    if not extent > 0.0 or np.any(area <= _DEGENERATE_RTOL * extent * extent):
        bad = int(np.argmin(area))
        raise ModelError(
            f'{where}: face {bad} has area {float(area[bad]):.6g} m², degenerate (<= '
            f'{_DEGENERATE_RTOL:g} × extent²; extent {extent:.6g} m)', field=where_field)
    if not mesh.is_watertight:
        raise ModelError(
            f'{where}: the mesh is open (not watertight): some edge is not shared by exactly '
            'two faces', field=where_field)
    if not mesh.is_winding_consistent:
        raise ModelError(
            f'{where}: inconsistent winding: adjacent faces disagree on orientation',
            field=where_field)
    corners = (vertices - vertices.mean(axis=0))[faces]  # centred: no cancellation far out
    volume = float(np.einsum('ij,ij->', corners[:, 0],
                             np.cross(corners[:, 1], corners[:, 2]))) / 6.0
    if abs(volume) <= _DEGENERATE_RTOL * extent ** 3:
        raise ModelError(f'{where}: encloses volume {volume:.6g} m³; it must be > 0',
                         field=where_field)
    if volume < 0.0:
        raise ModelError(
            f'{where}: encloses volume {volume:.6g} m³ < 0: the faces are wound clockwise seen '
            'from outside (normals point in)', field=where_field)
    low = np.stack([vertices[faces[:, m]] for m in range(3)]).min(axis=0)
    high = np.stack([vertices[faces[:, m]] for m in range(3)]).max(axis=0)
    order = np.argsort(low[:, 0], kind='stable').astype(np.int64)
    jitcache.configured()  # the kernel cache, before a first compile
    s, t = k.first_self_intersection(vertices, faces, order, low, high)
    if s < 0:
        # Strict signs miss crossings along an edge or a diagonal of the other's faces (a box
        # and its copy offset by half its size): again with every vertex nudged by a fixed
        # pseudo-random _NUDGE_RTOL x extent, which makes those crossings proper ones.
        nudge = np.random.default_rng(20261203).uniform(-1.0, 1.0, vertices.shape)
        moved = np.ascontiguousarray(vertices + _NUDGE_RTOL * extent * nudge)
        low, high = moved[faces].min(axis=1), moved[faces].max(axis=1)
        order = np.argsort(low[:, 0], kind='stable').astype(np.int64)
        s, t = k.first_self_intersection(moved, faces, order, low, high)
    if s >= 0:
        raise ModelError(f'{where}: self-intersecting: faces {s} and {t} cross each other',
                         field=where_field)
    return vertices, faces


def _check_cells(sdf_cells, field):
    if (isinstance(sdf_cells, bool) or not isinstance(sdf_cells, (numbers.Integral, np.integer))
            or not 4 <= sdf_cells <= MAX_SDF_CELLS):
        raise ModelError(
            f'{field}sdf_cells: {sdf_cells!r} must be an integer in [4, {MAX_SDF_CELLS}]')
    return int(sdf_cells)


def _mesh_from_trimesh(mesh, where, where_field, field, spacing_m, sdf_cells, centre,
                       cache_dir):
    cells = _check_cells(sdf_cells, field)
    vertices, faces = _check_mesh(mesh, where, field, where_field)
    offset = np.zeros(3)
    if centre:
        offset = triangle_mesh(vertices, faces, density=1.0).com_b
        vertices = vertices - offset
    vertices = np.ascontiguousarray(vertices)
    faces = np.ascontiguousarray(faces)
    low = vertices.min(axis=0)
    high = vertices.max(axis=0)
    s = point_spacing(spacing_m, float((high - low).max()), field)
    origin, h, values = _sdf_grid(vertices, faces, cells, cache_dir)
    return CollisionShape(
        shape='mesh', kind=k.KIND_MESH, params=frozen_array(shape_params(*origin, h)),
        dimensions_m=frozen_array(np.zeros(0)), spacing_m=s,
        points_b=frozen_array(_mesh_points(vertices, faces, s)),
        bounding_radius_m=float(np.linalg.norm(vertices, axis=1).max()),
        aabb_min_b=frozen_array(low), aabb_max_b=frozen_array(high),
        vertices_b=frozen_array(vertices), faces=frozen_array(faces, np.int64),
        grid=frozen_array(values), mesh_offset_m=frozen_array(offset))


def _trimesh():
    import trimesh  # imported on first use: a mesh library is only needed for meshes
    return trimesh


def mesh_shape(vertices, faces, spacing_m=None, sdf_cells=DEFAULT_SDF_CELLS, centre=True,
               field='', cache_dir=None):
    """
    Return the :class:`CollisionShape` of a closed triangle mesh given as arrays (m).

    :param vertices: (n, 3) m.
    :param faces: (m, 3) integer vertex indices, counter-clockwise seen from outside.
    :param spacing_m: surface point spacing (m), or None for 1/8 of the largest extent.
    :param sdf_cells: SDF grid cells along the largest extent (the error bound of φ is
        ``(√3 / 2) h`` with ``h = extent / sdf_cells``).
    :param centre: move the mesh so its centre of mass is the body origin.
    :param field: prefix of the field names in error messages.
    :param cache_dir: SDF cache folder; None for :func:`sdf_cache_dir`, False for no cache.
    :raises ModelError: naming ``<field>vertices``/``<field>faces`` for a bad array, or the
        mesh (``<field>mesh``) and why it is refused: open, inconsistently wound, degenerate,
        zero or negative volume, self-intersecting.
    """
    try:
        verts = np.array(vertices, dtype=np.float64)
    except (TypeError, ValueError):
        raise ModelError(f'{field}vertices: {vertices!r} is not an (n, 3) array in m') from None
    tris = np.asarray(faces)
    if verts.ndim != 2 or verts.shape[1] != 3:
        raise ModelError(f'{field}vertices: shape {verts.shape} must be (n, 3) (m)')
    if (tris.ndim != 2 or tris.shape[1] != 3 or not np.issubdtype(tris.dtype, np.integer)
            or (tris.size and (tris.min() < 0 or tris.max() >= verts.shape[0]))):
        raise ModelError(
            f'{field}faces: shape {tris.shape}, dtype {tris.dtype} must be (m, 3) integer '
            f'indices in [0, {verts.shape[0] - 1}]')
    mesh = _trimesh().Trimesh(vertices=verts, faces=tris.astype(np.int64), process=False)
    return _mesh_from_trimesh(mesh, f'{field}mesh', f'{field}mesh', field, spacing_m, sdf_cells,
                              centre,
                              cache_dir)


def _check_scale(mesh_scale, field):
    try:
        scale = np.array(mesh_scale, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise field_error(ModelError, f'{field}mesh_scale',
                          f'{mesh_scale!r} is not 3 positive scale factors', mesh_scale,
                          '') from None
    if scale.size != 3 or not np.all(np.isfinite(scale) & (scale > 0.0)):
        raise ModelError(
            f'{field}mesh_scale: {scale.tolist()} must be 3 finite factors > 0 (x, y, z)',
            field=f'{field}mesh_scale', value=mesh_scale, unit='',
            detail=f'{scale.tolist()} must be 3 finite factors > 0 (x, y, z)')
    return scale


def load_mesh(mesh_path, mesh_scale=(1.0, 1.0, 1.0), spacing_m=None,
              sdf_cells=DEFAULT_SDF_CELLS, centre=True, field='', cache_dir=None):
    """
    Load a closed triangle mesh from a file (STL, OBJ, or another format trimesh reads).

    The file is read by ``trimesh.load(path, force='mesh')`` (duplicate vertices merged, so an
    STL triangle soup becomes an indexed mesh); its coordinates, in metres, are multiplied by
    ``mesh_scale`` per axis, and the result goes through :func:`mesh_shape`'s checks.

    :raises ModelError: naming ``<field>mesh_path`` and the path when the file is missing,
        unreadable, holds no triangles, or is refused by the mesh checks; naming
        ``<field>mesh_scale`` when it is not 3 finite factors > 0.
    """
    scale = _check_scale(mesh_scale, field)
    if not isinstance(mesh_path, (str, os.PathLike)) or str(mesh_path) == '':
        raise ModelError(f'{field}mesh_path: {mesh_path!r} is not a file path',
                         field=f'{field}mesh_path')
    where = f'{field}mesh_path: {str(mesh_path)!r}'
    path = Path(mesh_path)
    if not path.is_file():
        raise ModelError(f'{where} does not exist or is not a file', field=f'{field}mesh_path')
    try:
        mesh = _trimesh().load(str(path), force='mesh')
    except Exception as exc:  # trimesh raises many exception types for a bad file
        reason = (str(exc).splitlines() or [type(exc).__name__])[0]
        raise ModelError(f'{where} is not a readable mesh ({reason})',
                         field=f'{field}mesh_path') from None
    faces = getattr(mesh, 'faces', None)
    if faces is None or len(faces) == 0:
        raise ModelError(f'{where} holds no triangles', field=f'{field}mesh_path')
    mesh = _trimesh().Trimesh(vertices=np.asarray(mesh.vertices, dtype=np.float64) * scale,
                              faces=np.asarray(mesh.faces, dtype=np.int64), process=False)
    return _mesh_from_trimesh(mesh, where, f'{field}mesh_path', field, spacing_m, sdf_cells,
                              centre, cache_dir)


# ---------------------------------------------------------------------------------------------
# Compounds

# A part's surface point is dropped when it lies deeper than this inside another part,
# relative to the compound's largest extent: far above the round-off of moving the points
# (~1e-16 x extent), far below any overlap a model means.
_INSIDE_RTOL = 1e-9
# A compound's grid has at least this many cells across its thinnest part (a rod's radius is
# then resolved), down to MAX_SDF_CELLS along its largest extent and within
# _MAX_COMPOUND_NODES nodes (16 MB of float64), but never coarser than sdf_cells.
_THIN_CELLS = 8
_MAX_COMPOUND_NODES = 2_000_000


def _corners(low, high):
    """Return the 8 corners (8, 3) of the box ``[low, high]``."""
    return np.array([[(low, high)[i][0], (low, high)[j][1], (low, high)[m][2]]
                     for i in (0, 1) for j in (0, 1) for m in (0, 1)], dtype=np.float64)


def compound_shape(parts, surfaces, sdf_cells=DEFAULT_SDF_CELLS, field=''):
    """
    Return one body's :class:`CollisionShape` made of several shapes, each at its own pose.

    What a URDF link with several ``<collision>`` elements, or one away from its centre of
    mass, is. The compound is a ``KIND_MESH`` shape for the contact step (``shape`` is
    ``'compound'``), in the body frame:

    * φ: the SDF grid (at least ``sdf_cells`` along the largest extent of the parts'
      bounding boxes, finer when a part is thin: 8 cells across the thinnest part's bounding
      box, up to :data:`MAX_SDF_CELLS` along the extent and 2e6 nodes; :data:`SDF_PAD_CELLS`
      of padding) holds at each node the least of the parts' exact
      signed distances (a primitive's closed form, a mesh's exact distance as
      :func:`mesh_shape` computes it), interpolated as a mesh's. That minimum is the union's
      exact signed distance outside the union and on its surface; inside, where parts
      overlap, its magnitude is at most the true depth (the contact normal there may point
      to the other part). It is 1-Lipschitz, so the mesh's bound ``(√3 / 2) h`` on the
      interpolation holds.
    * surface points: every part's, moved into the body frame, but those deeper than
      1e-9 × the largest extent inside another part (not on the union's surface).
    * ``vertices_b`` and ``faces``: the parts' ``surfaces`` (what is drawn), then every
      surface point not already a corner (in no face): a plane meets the compound at one of
      these, so a box part rests on a plane exactly at its corners, a round part within its
      point spacing's sag.

    :param parts: ``(shape, position_b, orientation_b)`` per part: a primitive or mesh
        :class:`CollisionShape` in its own frame, and that frame's origin (m) and rotation
        (``w, x, y, z``) in the body frame: ``x_b = R(q) x_part + position_b``.
    :param surfaces: per part, its surface triangles (n, 3, 3) in its own frame, m.
    :param field: prefix of the field names in error messages.
    :raises ModelError: no parts, a plane or compound among them, or a non-finite pose.
    """
    parts = list(parts)
    if not parts or len(surfaces) != len(parts):
        raise ModelError(f'{field}parts: {len(parts)} parts and {len(surfaces)} surfaces; a '
                         'compound needs at least one part and a surface for each')
    cells = _check_cells(sdf_cells, field)
    posed = []
    for index, (shape, position, orientation) in enumerate(parts):
        if not isinstance(shape, CollisionShape) or shape.kind == k.KIND_PLANE \
                or shape.shape == 'compound':
            raise ModelError(f'{field}parts[{index}]: {shape!r} is not a primitive or a mesh')
        position = np.asarray(position, dtype=np.float64).reshape(3)
        quat = np.asarray(orientation, dtype=np.float64).reshape(4)
        if not (np.all(np.isfinite(position)) and np.all(np.isfinite(quat))):
            raise ModelError(f'{field}parts[{index}]: pose {position.tolist()} m, '
                             f'{quat.tolist()} must be finite')
        posed.append((shape, quat_to_matrix(quat / np.linalg.norm(quat)), position))
    boxes = np.concatenate([_corners(s.aabb_min_b, s.aabb_max_b) @ rot.T + pos
                            for s, rot, pos in posed])
    low, high = boxes.min(axis=0), boxes.max(axis=0)
    extent = float((high - low).max())
    thinnest = min(float((s.aabb_max_b - s.aabb_min_b).min()) for s, _, _ in posed)
    h = max(extent / MAX_SDF_CELLS, min(extent / cells, thinnest / _THIN_CELLS))

    def node_counts(spacing):
        return tuple(int(math.ceil(e / spacing)) + 1 + 2 * SDF_PAD_CELLS for e in high - low)

    while h < extent / cells and math.prod(node_counts(h)) > _MAX_COMPOUND_NODES:
        h = min(1.25 * h, extent / cells)
    counts = node_counts(h)
    origin = low - SDF_PAD_CELLS * h
    axes = [origin[m] + h * np.arange(counts[m]) for m in range(3)]
    nodes = np.stack(np.meshgrid(*axes, indexing='ij'), axis=-1).reshape(-1, 3)
    jitcache.configured()  # the kernel cache, before a first compile
    values = np.full(counts, np.inf)
    for shape, rot, pos in posed:  # each part's exact φ at every node
        part = np.zeros(counts)
        if shape.kind == k.KIND_MESH:
            k.build_sdf(np.ascontiguousarray(shape.vertices_b @ rot.T + pos), shape.faces,
                        origin, h, part)
        else:
            k.phi_grad_many(shape.kind, shape.params, shape.grid,
                            np.ascontiguousarray((nodes - pos) @ rot), part.reshape(-1),
                            np.empty((nodes.shape[0], 3)))
        values = np.minimum(values, part)
    points = []
    for index, (shape, rot, pos) in enumerate(posed):
        mine = shape.points_b @ rot.T + pos
        keep = np.ones(mine.shape[0], dtype=bool)
        for other, (o_shape, o_rot, o_pos) in enumerate(posed):
            if other != index:
                phi, _ = o_shape.signed_distance((mine - o_pos) @ o_rot)
                keep &= phi >= -_INSIDE_RTOL * extent
        points.append(mine[keep])
    points = np.concatenate(points)
    tris = np.concatenate([np.asarray(tri, dtype=np.float64).reshape(-1, 3) @ rot.T + pos
                           for tri, (_, rot, pos) in zip(surfaces, posed)])
    vertices, index = np.unique(np.concatenate([tris, points]), axis=0, return_inverse=True)
    faces = np.asarray(index).reshape(-1)[:tris.shape[0]]
    radius = max(float(np.linalg.norm(pos)) + s.bounding_radius_m for s, _, pos in posed)
    return CollisionShape(
        shape='compound', kind=k.KIND_MESH, params=frozen_array(shape_params(*origin, h)),
        dimensions_m=frozen_array(np.zeros(0)), spacing_m=min(s.spacing_m for s, _, _ in posed),
        points_b=frozen_array(points), bounding_radius_m=radius, aabb_min_b=frozen_array(low),
        aabb_max_b=frozen_array(high), vertices_b=frozen_array(vertices),
        faces=frozen_array(faces.reshape(-1, 3), np.int64), grid=frozen_array(values),
        mesh_offset_m=frozen_array(np.zeros(3)))


def collision_shape(shape, dimensions_m=None, mesh_path=None, mesh_scale=(1.0, 1.0, 1.0),
                    spacing_m=None, sdf_cells=DEFAULT_SDF_CELLS, field='', cache_dir=None):
    """
    Return a :class:`CollisionShape` from parameters: a primitive, or ``'mesh'`` from a file.

    :param shape: one of :data:`PRIMITIVES` (with ``dimensions_m``) or ``'mesh'`` (with
        ``mesh_path`` and ``mesh_scale``).
    :raises ModelError: as :func:`primitive_shape` and :func:`load_mesh`.
    """
    if shape == 'mesh':
        return load_mesh(mesh_path, mesh_scale, spacing_m, sdf_cells, field=field,
                         cache_dir=cache_dir)
    return primitive_shape(shape, dimensions_m, spacing_m, field)
