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
Mesh files as hostile input (issue 30, item 2): each refused at start in one line, exit 2.

Each case starts ``rigid_body_node`` with a real params file naming the mesh of a world's body
(or of the single body), the way a user does, and expects exit status 2 and one stderr line
naming the parameter, its value and what is wrong, before anything is recorded. A relative
path that leaves the params file's directory with ``../..`` is allowed (as URDF and SDF
resolve their meshes; the same file could name any absolute path): that run is recorded with
the mesh attached and replays from the attachment.
"""

import bz2
import gzip
import io
import lzma
import struct
import time
import zipfile

from conftest import write_params
import numpy as np
import pytest
from rbd_ros.bag.reader import open_bag
from rbd_ros.bag.replay import replay_bag
from rbd_ros.sim import limits
from rbd_ros.sim.meshes import mesh_data_problem, MIN_MESH_SCALE
from rbd_ros.sim.params import MAX_MESH_FILE_BYTES
import trimesh

MAX_LINE = 400  # characters: a refusal is one readable line
#: A refusal happens while the parameters are checked, before any physics: the node's own
#: start (rclpy, numpy, numba imports) is ~5 s here; 60 s only separates "refused at start"
#: from "building the mesh" (~20 min for 2 million triangles at ~0.6 ms a triangle).
REFUSED_WITHIN_S = 60.0


def _box():
    return trimesh.creation.box(extents=[0.2, 0.2, 0.2])


def _export(tmp, name, mesh):
    path = tmp / name
    mesh.export(str(path))
    return str(path)


def _raw_stl(tmp, name, vertices, faces):
    path = tmp / name
    path.write_bytes(trimesh.exchange.stl.export_stl(
        trimesh.Trimesh(vertices, faces, process=False)))
    return str(path)


def _empty(tmp):
    (tmp / 'empty.stl').write_bytes(b'')
    return str(tmp / 'empty.stl')


def _billion_header(tmp):
    """Return a binary STL whose header claims 10^9 triangles, followed by 10 of them."""
    path = tmp / 'billion.stl'
    path.write_bytes(bytes(80) + struct.pack('<I', 10 ** 9) + bytes(50 * 10))
    return str(path)


def _nan_vertex(tmp):
    box = _box()
    vertices = np.array(box.vertices)
    vertices[0, 0] = np.nan
    return _raw_stl(tmp, 'nan.stl', vertices, box.faces)


def _open(tmp):
    box = _box()
    return _raw_stl(tmp, 'open.stl', box.vertices, box.faces[:-1])


def _inverted(tmp):
    box = _box()
    return _raw_stl(tmp, 'inverted.stl', box.vertices, box.faces[:, ::-1])


def _two_boxes(tmp):
    """Return two boxes overlapping by half their size, as one closed mesh (crossing faces)."""
    other = _box()
    other.apply_translation([0.1, 0.1, 0.1])
    return _export(tmp, 'two_boxes.stl', trimesh.util.concatenate([_box(), other]))


def _prism_obj(tmp, n=500_000):
    """
    Return an OBJ of a closed prism over an n-gon: 2 n vertices, 4 n - 4 triangles.

    Two n-gon caps and n quads: 2 million triangles in ~50 MB, under MAX_MESH_FILE_BYTES, so
    only the triangle count can refuse it.
    """
    angle = np.linspace(0.0, 2.0 * np.pi, n, endpoint=False)
    ring = np.stack([np.cos(angle), np.sin(angle)], axis=1)
    lines = [f'v {x:.6f} {y:.6f} {z}' for z in (0, 1) for x, y in ring]
    i = np.arange(n)
    lines.append('f ' + ' '.join(map(str, i[::-1] + 1)))
    lines.append('f ' + ' '.join(map(str, i + n + 1)))
    lines += [f'f {a + 1} {b + 1} {b + n + 1} {a + n + 1}' for a, b in zip(i, (i + 1) % n)]
    path = tmp / 'prism.obj'
    path.write_text('\n'.join(lines) + '\n')
    assert path.stat().st_size < MAX_MESH_FILE_BYTES
    return str(path)


def _two_million_stl(tmp):
    """Return a binary STL of 2 million triangles (100 MB, sparse: no disk, no time)."""
    path = tmp / 'two_million.stl'
    with open(path, 'wb') as f:
        f.write(bytes(80) + struct.pack('<I', 2_000_000))
        f.truncate(84 + 50 * 2_000_000)
    return str(path)


def _zipped(tmp):
    """Return a zip of a valid STL (trimesh would have unpacked it, whatever its size)."""
    buffer = io.BytesIO()
    with zipfile.ZipFile(buffer, 'w', zipfile.ZIP_DEFLATED) as archive:
        archive.writestr('box.stl', trimesh.exchange.stl.export_stl(_box()))
    (tmp / 'box.zip').write_bytes(buffer.getvalue())
    return str(tmp / 'box.zip')


def _directory(tmp):
    (tmp / 'folder.stl').mkdir()
    return str(tmp / 'folder.stl')


def _random_bytes(tmp):
    """Return a binary STL of 12 triangles of random bytes (NaNs among its float32 values)."""
    path = tmp / 'random.stl'
    path.write_bytes(bytes(80) + struct.pack('<I', 12)
                     + np.random.default_rng(0).bytes(50 * 12))
    return str(path)


def _scaled_box(tmp, factor):
    """Return a binary STL of the 0.2 m box with its coordinates times ``factor``."""
    box = _box()
    return _raw_stl(tmp, f'box_{factor:g}.stl', np.array(box.vertices) * factor, box.faces)


def _obstacle(mesh_path):
    """Return a world of a ball on a floor beside a mesh obstacle 'o' of ``mesh_path``."""
    return {'body_names': ['a'], 'bodies.a.shape': 'sphere', 'bodies.a.dimensions_m': [0.1],
            'bodies.a.initial_position': [0.0, 0.0, 1.0], 'obstacle_names': ['o'],
            'obstacles.o.shape': 'mesh', 'obstacles.o.mesh_path': mesh_path,
            'obstacles.o.position': [3.0, 0.0, 0.5]}


def _body(mesh_path, **fields):
    """Return a world of one body 'a' shaped by ``mesh_path``, plus its other ``fields``."""
    return {'body_names': ['a'], 'bodies.a.mesh_path': mesh_path,
            'bodies.a.initial_position': [0.0, 0.0, 1.0],
            **{f'bodies.a.{k}': v for k, v in fields.items()}}


FIELD = 'parameter bodies.a.mesh_path = '
CASES = {  # id: (tmp_path -> parameters, words the one line must hold)
    'missing': (lambda tmp: _body(str(tmp / 'nowhere.stl')),
                [FIELD, "nowhere.stl' does not exist"]),
    'directory': (lambda tmp: _body(_directory(tmp)), [FIELD, 'is not a regular file']),
    'dev-zero': (lambda tmp: _body('/dev/zero'), [FIELD + "'/dev/zero'", 'not a regular file']),
    'zero-bytes': (lambda tmp: _body(_empty(tmp)), [FIELD, 'is empty (0 bytes)']),
    'billion-header': (lambda tmp: _body(_billion_header(tmp)),
                       [FIELD, 'is not an STL file (584 bytes, not the 84 + 50 x 1000000000']),
    'nan-vertex': (lambda tmp: _body(_nan_vertex(tmp)),
                   [FIELD, 'has non-finite vertex coordinates']),
    'open': (lambda tmp: _body(_open(tmp)), [FIELD, 'the mesh is open (not watertight)']),
    'inverted': (lambda tmp: _body(_inverted(tmp)), [FIELD, 'wound clockwise']),
    'self-intersecting': (lambda tmp: _body(_two_boxes(tmp)), [FIELD, 'self-intersecting']),
    'two-million-obj': (lambda tmp: _body(_prism_obj(tmp)),
                        [FIELD, 'has at least', 'more than the limit of '
                         f'{limits.MAX_MESH_TRIANGLES} (rbd_ros.sim.limits.MAX_MESH_TRIANGLES)']),
    'two-million-stl': (lambda tmp: _body(_two_million_stl(tmp)),
                        [FIELD, 'is 100000084 bytes, more than the limit of '
                         f'{MAX_MESH_FILE_BYTES} bytes']),
    'zip': (lambda tmp: _body(_zipped(tmp)), [FIELD, 'is zip-compressed data, not a mesh']),
    # 1e30 x the box (float32 holds it): the mesh library's vertex merge overflowed and the
    # refusal said "has 12 faces and 1 vertices"; 1e-9 x: every vertex merged, the same words
    'huge-coordinates': (lambda tmp: _body(_scaled_box(tmp, 1e30)),
                         [FIELD, 'spans 2e+29 m (coordinates x mesh_scale), outside the sizes '
                          'a body may have, [1e-06, 1e+06] m']),
    'tiny-coordinates': (lambda tmp: _body(_scaled_box(tmp, 1e-9)),
                         [FIELD, 'spans 2e-10 m (coordinates x mesh_scale)']),
    'scaled-past-max-size': (lambda tmp: _body(_scaled_box(tmp, 10.0), mesh_scale=[1e6, 1.0, 1.0]),
                             [FIELD, 'spans 2e+06 m (coordinates x mesh_scale)']),
    # numpy's "invalid value encountered in cast" warnings came before the line (3 lines)
    'random-bytes': (lambda tmp: _body(_random_bytes(tmp)), [FIELD, 'non-finite vertex']),
    # an obstacle's mesh was 'parameter obstacles.o.mesh_path: <path>: ...', a body's '... = '
    'obstacle-open': (lambda tmp: _obstacle(_open(tmp)),
                      ["parameter obstacles.o.mesh_path = '", 'the mesh is open']),
    'scale-0': (lambda tmp: _body(_export(tmp, 'box.stl', _box()), mesh_scale=[0.0, 1.0, 1.0]),
                ['parameter bodies.a.mesh_scale = [0.0, 1.0, 1.0]',
                 f'must be 3 factors in [{MIN_MESH_SCALE:g}, 1e+06]']),
    'scale-1e-300': (lambda tmp: _body(_export(tmp, 'box.stl', _box()), mesh_scale=[1e-300] * 3),
                     ['parameter bodies.a.mesh_scale = [1e-300, 1e-300, 1e-300]',
                      f'must be 3 factors in [{MIN_MESH_SCALE:g}, 1e+06]']),
    'missing-package': (lambda tmp: _body('package://no_such_pkg/m.stl'),
                        [FIELD + "'package://no_such_pkg/m.stl'", "package 'no_such_pkg'"]),
    'single-body-nan': (lambda tmp: {'mesh_path': _nan_vertex(tmp)},
                        ['parameter mesh_path = ', 'has non-finite vertex coordinates']),
    'single-body-scale': (lambda tmp: {'mesh_path': _export(tmp, 'box.stl', _box()),
                                       'mesh_scale': [1e-300] * 3},
                          ['parameter mesh_scale = [1e-300, 1e-300, 1e-300]']),
}


@pytest.mark.parametrize('case', sorted(CASES))
def test_a_hostile_mesh_is_refused_at_start_in_one_line(start_node, tmp_path, case):
    make, words = CASES[case]
    params = {**make(tmp_path), 'record_path': str(tmp_path / 'bag')}
    start = time.monotonic()
    node = start_node(params)
    assert node.wait(120) == 2, node.stderr  # 120 s: a loaded machine
    took = time.monotonic() - start
    print(f'{case}: refused {took:.1f} s after the start (the node start included)')
    lines = [line for line in node.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, lines
    assert lines[0].startswith('rigid_body_node: ') and len(lines[0]) <= MAX_LINE, lines[0]
    for word in words:
        assert word in lines[0], lines[0]
    assert not (tmp_path / 'bag').exists()  # refused before the recorder opened anything
    assert took < REFUSED_WITHIN_S


def test_a_relative_path_may_leave_the_params_directory(start_node, tmp_path):
    """``../../box.stl`` from ``a/b/world.yaml``: allowed, recorded, replayed from the bag."""
    mesh = _export(tmp_path, 'box.stl', _box())
    folder = tmp_path / 'a' / 'b'
    folder.mkdir(parents=True)
    params = write_params(folder / 'world.yaml', {
        **_body('../../box.stl'), 'duration_s': 0.05, 'real_time_factor': 0.0,
        'record_path': str(tmp_path / 'bag')})
    node = start_node(params_file=params)
    assert node.wait(300) == 0, node.stderr  # 300 s: a first build of the box's SDF under load
    bag = open_bag(str(tmp_path / 'bag'))
    name = str(folder / '../../box.stl')  # joined to the params file's directory, as written
    assert bag.attachments() == {name: open(mesh, 'rb').read()}
    (tmp_path / 'box.stl').unlink()  # replay reads the attachment, not the file it names
    assert replay_bag(bag).match


def _compressed(kind):
    data = trimesh.exchange.stl.export_stl(_box())
    return {'gzip': gzip.compress, 'bzip2': bz2.compress, 'xz': lzma.compress}[kind](data)


@pytest.mark.parametrize('name, data, problem', [
    ('box.stl', trimesh.exchange.stl.export_stl(_box()), None),
    ('box.STL', trimesh.exchange.stl.export_stl_ascii(_box()).encode(), None),
    ('box.obj', trimesh.exchange.obj.export_obj(_box()).encode(), None),
    ('box.stl', _compressed('gzip'), 'is gzip-compressed data, not a mesh'),
    ('box.stl', _compressed('bzip2'), 'is bzip2-compressed data, not a mesh'),
    ('box.stl', _compressed('xz'), 'is xz-compressed data, not a mesh'),
    ('box.ply', b'ply\nformat ascii 1.0\n', "is a '.ply' file; a mesh is an STL or OBJ file"),
    ('box', b'solid x\n', "is a 'suffix-less' file"),
    ('box.stl', b'solid x\nendsolid x\n', 'holds no triangles'),
    ('box.stl', b'solid x\nfacet normal 0 0 1\nouter loop\nvertex 1e999 0 0\n', 'non-finite'),
    ('box.obj', b'v 0 0 0\nv 1 0 0\nv 0 1 inf\nf 1 2 3\n', 'non-finite'),
    ('box.obj', b'v 0 0 0\n', 'holds no triangles'),
    ('box.obj', b'f ' + b' '.join(b'%d' % i for i in range(1, 200_004)) + b'\n',
     'has at least 200001 triangles, more than the limit of 200000'),
], ids=['binary-stl', 'ascii-stl', 'obj', 'gzip', 'bzip2', 'xz', 'ply', 'no-suffix',
        'ascii-empty', 'stl-overflow', 'obj-inf', 'obj-no-face', 'obj-count'])
def test_mesh_bytes_are_judged_before_the_mesh_library_reads_them(name, data, problem):
    found = mesh_data_problem(name, data)
    assert (found is None) if problem is None else (problem in found), found
