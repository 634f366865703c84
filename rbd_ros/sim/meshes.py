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
Mesh files named by ``*mesh_path`` parameters: resolved, opened safely, read, checked for size.

A path is a file path or a ``package://`` URI (resolved through the ament index); the file must
be a regular file of at most :data:`rbd_ros.sim.params.MAX_MESH_FILE_BYTES`, opened without
following a swap of the file between the check and the read. Every failure names the
parameter and the file.

Its bytes are checked before the mesh library reads them (:func:`mesh_data_problem`, also
for a recording's attachments): an STL or OBJ file (by its name), not compressed data (nothing
is ever decompressed: trimesh would expand a ``.zip`` or ``.bz2`` whatever its size), whose
triangle count (read from the file without building anything) is at most
:data:`rbd_ros.sim.limits.MAX_MESH_TRIANGLES`, with finite vertex coordinates.
"""

import math
import os
import re
import stat
import struct
import sys

import numpy as np
from rbd_ros.core import ModelError
from rbd_ros.core.contact.mesh_shapes import load_mesh
from rbd_ros.sim.limits import MAX_MESH_TRIANGLES
from rbd_ros.sim.params import (fail, MAX_MESH_FILE_BYTES, MAX_POSITION_M, MAX_SIZE,
                                MIN_SIZE)

#: The mesh file types read (by the name's suffix, any case): STL (binary or ASCII) and OBJ.
MESH_SUFFIXES = ('.stl', '.obj')
#: Smallest ``mesh_scale`` factor: below it a mesh of a metre becomes smaller than 1e-6 m, where
#: the degenerate-face test's ``extent²`` (and the inertia, ``m d²``) lose double precision.
MIN_MESH_SCALE = 1e-6
# The first bytes of compressed or archive data, the mesh library would expand them.
_COMPRESSED = ((b'\x1f\x8b', 'gzip'), (b'BZh', 'bzip2'), (b'\xfd7zXZ\x00', 'xz'),
               (b'\x28\xb5\x2f\xfd', 'zstd'), (b'PK\x03\x04', 'zip'), (b'PK\x05\x06', 'zip'),
               (b"7z\xbc\xaf'\x1c", '7z'), (b'\x04\x22\x4d\x18', 'lz4'))
# One binary STL facet: normal, three vertices (float32), attribute byte count.
_FACET = np.dtype([('normal', '<f4', 3), ('vertices', '<f4', (3, 3)), ('attribute', '<u2')])
_NUMBER = rb'([^\s]+)'
_STL_VERTEX = re.compile(rb'vertex\s+' + rb'\s+'.join([_NUMBER] * 3))
_OBJ_VERTEX = re.compile(rb'^v[ \t]+' + rb'[ \t]+'.join([_NUMBER] * 3), re.MULTILINE)
_OBJ_FACE = re.compile(rb'^f[ \t]([^\r\n]*)', re.MULTILINE)


_NOT_FINITE = 'has non-finite vertex coordinates'


def _coordinates(values):
    """
    Return ``values`` (an array, or number tokens as bytes) as float64 ``(n, 3)``, or None.

    None when some value is not finite or no number at all. Quiet: random bytes read as
    float32 hold NaNs, whose cast warned on stderr beside the one-line refusal.
    """
    try:
        with np.errstate(all='ignore'):
            array = np.asarray(values, dtype=np.float64).reshape(-1, 3)
    except ValueError:
        return None  # a token that is no number at all
    return array if np.all(np.isfinite(array)) else None


def _stl_problem(data):
    """
    Return ``(triangles, problem, vertex coordinates)`` of STL bytes.

    Binary if its size matches the triangle count of its header, else ASCII.
    """
    if len(data) >= 84:
        (declared,) = struct.unpack_from('<I', data, 80)
        if 84 + 50 * declared == len(data):
            points = _coordinates(np.frombuffer(data, _FACET, count=declared,
                                                offset=84)['vertices'])
            return declared, None if points is not None else _NOT_FINITE, points
    else:
        declared = None
    if not data.lstrip()[:5].lower() == b'solid':
        size = ('' if declared is None else
                f', not the 84 + 50 x {declared} its header declares for a binary STL')
        return 0, (f'is not an STL file ({len(data)} bytes{size}; no ASCII "solid" at the '
                   'start)'), None
    triangles = data.count(b'facet')  # 'facet normal' opens one, 'endfacet' closes it
    triangles //= 2
    points = _coordinates([v for m in _STL_VERTEX.finditer(data) for v in m.groups()])
    return triangles, None if points is not None else _NOT_FINITE, points


def _obj_problem(data):
    """Return ``(triangles, problem, vertex coordinates)`` of OBJ bytes."""
    triangles = 0
    for face in _OBJ_FACE.finditer(data):  # one line at a time: no list of all the lines
        triangles += max(0, len(face.group(1).split()) - 2)
        if triangles > MAX_MESH_TRIANGLES:  # refused for its count: the rest is not read
            return triangles, (
                f'has at least {triangles} triangles, more than the limit of '
                f'{MAX_MESH_TRIANGLES} (rbd_ros.sim.limits.MAX_MESH_TRIANGLES)'), None
    points = _coordinates([v for m in _OBJ_VERTEX.finditer(data) for v in m.groups()])
    return triangles, None if points is not None else _NOT_FINITE, points


def _check_data(name, data):
    """Return ``(problem or None, vertex coordinates (n, 3) or None)`` of a mesh file's bytes."""
    if not data:
        return 'is empty (0 bytes)', None
    for magic, kind in _COMPRESSED:
        if data.startswith(magic):
            return (f'is {kind}-compressed data, not a mesh (compressed meshes are refused: '
                    'nothing is decompressed)'), None
    suffix = os.path.splitext(str(name))[1].lower()
    if suffix not in MESH_SUFFIXES:
        return (f'is a {suffix or "suffix-less"!r} file; a mesh is an STL or OBJ file '
                f'({", ".join(MESH_SUFFIXES)})'), None
    triangles, problem, points = (_stl_problem if suffix == '.stl' else _obj_problem)(data)
    if problem is None and triangles == 0:
        problem = 'holds no triangles'
    elif problem is None and triangles > MAX_MESH_TRIANGLES:
        problem = (f'has {triangles} triangles, more than the limit of {MAX_MESH_TRIANGLES} '
                   '(rbd_ros.sim.limits.MAX_MESH_TRIANGLES)')
    return problem, points


def mesh_data_problem(name, data):
    """
    Return why the bytes ``data`` of the mesh file ``name`` cannot be read, or None.

    Refused before the mesh library sees them: empty; compressed or archive data (gzip,
    bzip2, xz, zstd, lz4, zip, 7z: never decompressed); a name not ending in one of
    :data:`MESH_SUFFIXES`; an STL that is neither binary (84 + 50 bytes a triangle) nor ASCII;
    no triangles, more than :data:`MAX_MESH_TRIANGLES`, or a non-finite vertex coordinate.
    Costs one pass over the bytes; nothing is built.
    """
    return _check_data(name, data)[0]


def mesh_size_problem(points, scale):
    """
    Return why vertex coordinates ``points`` (n, 3) times ``scale`` make no body, or None.

    The scaled mesh must span from :data:`MIN_SIZE` to :data:`MAX_SIZE` m (the sizes a
    primitive's ``dimensions_m`` may have) and lie within ±:data:`MAX_POSITION_M` of its
    origin. The mesh library merges vertices closer than 1e-8 (in file units): a mesh far
    smaller collapsed to one vertex, and one of 1e29 m overflowed that rounding, both then
    refused as "1 vertices".
    """
    if points is None or not len(points):
        return None
    with np.errstate(all='ignore'):
        scaled = points * np.asarray(scale, dtype=np.float64)
        span = float((scaled.max(axis=0) - scaled.min(axis=0)).max())
        far = float(np.abs(scaled).max())
    if not (MIN_SIZE <= span <= MAX_SIZE):
        return (f'spans {span:.6g} m (coordinates x mesh_scale), outside the sizes a body may '
                f'have, [{MIN_SIZE:g}, {MAX_SIZE:g}] m')
    if not far <= MAX_POSITION_M:
        return (f'has a vertex {far:.6g} m from its origin (coordinates x mesh_scale), beyond '
                f'±{MAX_POSITION_M:g} m')
    return None


def resolve_mesh_path(path, field):
    """
    Return ``path`` as a file path: ``package://<pkg>/rest`` against ``<pkg>``'s share.

    The share directory is, in this order: the ament index's (an installed or sourced
    workspace); the installed share of this Python environment, ``<sys.prefix>/share/<pkg>``
    (where ``pip install`` puts this package's data files); for ``rbd_ros`` itself run from a
    source tree, the source tree's root, which holds the same ``msg_config/`` files.  Relative
    paths stay relative (to the working directory; a params file's relative paths were made
    absolute when it was read).

    :raises ModelError: one line naming the parameter ``field`` when no share has the package.
    """
    prefix = 'package://'
    if not path.startswith(prefix):
        return path
    package, _, rest = path[len(prefix):].partition('/')
    try:
        from ament_index_python.packages import get_package_share_directory
        return os.path.join(get_package_share_directory(package), rest)
    except (ImportError, LookupError, ValueError, OSError):  # OSError: no AMENT_PREFIX_PATH
        pass
    share = os.path.join(sys.prefix, 'share', package)
    if package and os.path.isfile(os.path.join(share, 'package.xml')):
        return os.path.join(share, rest)
    source = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    if package == 'rbd_ros' and os.path.isfile(os.path.join(source, 'package.xml')):
        return os.path.join(source, rest)
    raise ModelError(f'parameter {field} = {path!r}: package {package!r} is found neither in '
                     f'the ament index (source its workspace) nor in {share}', field=field,
                     value=path)


def _open_mesh_file(value, field):
    """
    Open the file of ``field = value`` without blocking; return ``(resolved path, fd)``.

    :raises ModelError: it does not exist, is not a regular file or is too big.
    """
    path = resolve_mesh_path(value, field)
    where = f'parameter {field} = {value!r}: {path!r}'
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | getattr(os, 'O_CLOEXEC', 0))
    except OSError as exc:
        raise ModelError(f'{where} does not exist or is not a file ({exc.strerror})',
                         field=field, value=value) from None
    info = os.fstat(fd)
    problem = None
    if not stat.S_ISREG(info.st_mode):
        problem = 'is not a regular file (a mesh file is read whole)'
    elif info.st_size > MAX_MESH_FILE_BYTES:
        problem = (f'is {info.st_size} bytes, more than the limit of {MAX_MESH_FILE_BYTES} '
                   'bytes')
    if problem:
        os.close(fd)
        raise ModelError(f'{where} {problem}', field=field, value=value)
    return path, fd


def mesh_file(value, field, scale=None):
    """
    Return the resolved file of the ``*mesh_path`` parameter ``field = value`` after checking it.

    It must be a regular file (never a FIFO, a device such as ``/dev/zero``, a directory) of at
    most :data:`MAX_MESH_FILE_BYTES` bytes, whose bytes pass :func:`mesh_data_problem`; given
    its ``mesh_scale``, its size must pass :func:`mesh_size_problem`.

    :raises ModelError: one line naming ``field``, its value and the reason.
    """
    path, data = _read(value, field)
    problem, points = _check_data(path, data)
    if problem is None and scale is not None and len(scale) == 3 and all(
            MIN_MESH_SCALE <= v <= MAX_SIZE for v in scale):  # else the scale's own check
        problem = mesh_size_problem(points, scale)
    if problem is not None:
        raise ModelError(f'parameter {field} = {value!r}: {path!r} {problem}', field=field,
                         value=value)
    return path


def _read(value, field):
    """Return ``(resolved path, bytes)`` of the ``*mesh_path`` parameter ``field = value``."""
    path, fd = _open_mesh_file(value, field)
    with os.fdopen(fd, 'rb') as stream:
        data = stream.read(MAX_MESH_FILE_BYTES + 1)
    if len(data) > MAX_MESH_FILE_BYTES:
        raise ModelError(f'parameter {field} = {value!r}: more than the limit of '
                         f'{MAX_MESH_FILE_BYTES} bytes', field=field, value=value)
    return path, data


def read_mesh_file(value, field):
    """Return the bytes of the ``*mesh_path`` parameter ``field`` (checked as by mesh_file)."""
    return _read(value, field)[1]


def mesh_shape(spec_path, spec_scale, path, scale):
    """Load the mesh of a ``*mesh_path`` parameter, errors naming the parameter."""
    file_path = mesh_file(path, spec_path.name, scale)
    field = spec_path.name[:-len('mesh_path')]
    try:
        shape = load_mesh(file_path, scale, field=field)
    except ModelError as exc:
        blamed = spec_scale if exc.field == field + 'mesh_scale' else spec_path
        value = scale if blamed is spec_scale else path
        fail(blamed, value, str(exc) if exc.detail is None else exc.detail)
    return shape


def check_sizes(dims_spec, dims, scale_spec, scale):
    """Refuse a ``dimensions_m`` or ``mesh_scale`` value that is not finite or above MAX_SIZE."""
    if any(not math.isfinite(v) or abs(v) > MAX_SIZE for v in dims):
        fail(dims_spec, dims, f'every size must be finite and at most {MAX_SIZE:g} m',
             ModelError)
    if len(scale) != 3 or any(not (MIN_MESH_SCALE <= v <= MAX_SIZE) for v in scale):
        fail(scale_spec, scale, f'must be 3 factors in [{MIN_MESH_SCALE:g}, {MAX_SIZE:g}]',
             ModelError)
