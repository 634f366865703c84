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
"""

import math
import os
import stat
import sys

from rbd_ros.core import ModelError
from rbd_ros.core.contact.shapes import load_mesh
from rbd_ros.sim.params import fail, MAX_MESH_FILE_BYTES, MAX_SIZE


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


def mesh_file(value, field):
    """
    Return the resolved file of the ``*mesh_path`` parameter ``field = value`` after checking it.

    It must be a regular file (never a FIFO, a device such as ``/dev/zero``, a directory) of at
    most :data:`MAX_MESH_FILE_BYTES` bytes.

    :raises ModelError: one line naming ``field``, its value and the reason.
    """
    path, fd = _open_mesh_file(value, field)
    os.close(fd)
    return path


def read_mesh_file(value, field):
    """Return the bytes of the ``*mesh_path`` parameter ``field`` (checked as by mesh_file)."""
    _, fd = _open_mesh_file(value, field)
    with os.fdopen(fd, 'rb') as stream:
        data = stream.read(MAX_MESH_FILE_BYTES + 1)
    if len(data) > MAX_MESH_FILE_BYTES:
        raise ModelError(f'parameter {field} = {value!r}: more than the limit of '
                         f'{MAX_MESH_FILE_BYTES} bytes', field=field, value=value)
    return data


def mesh_shape(spec_path, spec_scale, path, scale):
    """Load the mesh of a ``*mesh_path`` parameter, errors naming the parameter."""
    file_path = mesh_file(path, spec_path.name)
    field = spec_path.name[:-len('mesh_path')]
    try:
        return load_mesh(file_path, scale, field=field)
    except ModelError as exc:
        blamed = spec_scale if exc.field == field + 'mesh_scale' else spec_path
        value = scale if blamed is spec_scale else path
        fail(blamed, value, str(exc) if exc.detail is None else exc.detail)


def check_sizes(dims_spec, dims, scale_spec, scale):
    """Refuse a ``dimensions_m`` or ``mesh_scale`` value that is not finite or above MAX_SIZE."""
    if any(not math.isfinite(v) or abs(v) > MAX_SIZE for v in dims):
        fail(dims_spec, dims, f'every size must be finite and at most {MAX_SIZE:g} m',
             ModelError)
    if len(scale) != 3 or any(not (0.0 < v <= MAX_SIZE) for v in scale):
        fail(scale_spec, scale, f'must be 3 factors in (0, {MAX_SIZE:g}]', ModelError)
