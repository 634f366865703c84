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

r"""
Message definitions (``ros2msg`` schema texts) and RIHS01 type hashes, without rclpy.

The texts are built the way rosbag2's ``LocalMessageDefinitionSource`` (Jazzy) builds them: the
root ``.msg`` file verbatim (comments included), then every dependency once, depth-first
pre-order with children in lexicographic order, each as
``'\n' + '=' * 80 + '\nMSG: pkg/Type\n'`` followed by its verbatim text.  The ``.msg`` files
and the ``.json`` type descriptions (which carry the RIHS01 hashes) come from the installed
interface packages' ``share/`` directories (the PyPI wheels install them under
``<venv>/share``; a stock Jazzy install under each prefix of ``AMENT_PREFIX_PATH``).  If a
package's files cannot be found, the ``rosbags`` typestore for Jazzy is used instead (same
field layout and hash; comments stripped).
"""

import functools
import json
import os
import re
import sys

from rbd_ros.core.errors import RecordingError

SEPARATOR = '=' * 80


class SchemaError(RecordingError):
    """A message type is malformed or has no definition to record it with (names the type)."""


_PRIMITIVES = frozenset((
    'bool', 'byte', 'char', 'float32', 'float64', 'int8', 'uint8', 'int16', 'uint16',
    'int32', 'uint32', 'int64', 'uint64', 'string', 'wstring'))

# A field line: the type (maybe with a package, array or bound suffix) then a name.
_FIELD_RE = re.compile(r'^\s*([A-Za-z][\w/]*)(?:\[[^\]]*\]|<=\d+)*\s+[A-Za-z]\w*')


def _share_dirs():
    dirs = [os.path.join(sys.prefix, 'share')]
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix:
            dirs.append(os.path.join(prefix, 'share'))
    return dirs


def _split(type_name):
    """Split ``pkg/msg/Type`` or ``pkg/Type`` into ``(pkg, Type)``."""
    parts = type_name.split('/')
    if len(parts) == 3 and parts[1] == 'msg':
        return parts[0], parts[2]
    if len(parts) == 2:
        return parts[0], parts[1]
    raise SchemaError(f'message type {type_name!r} is not of the form pkg/msg/Type')


@functools.lru_cache(maxsize=None)
def _find_share_file(pkg, name, ext):
    for share in _share_dirs():
        path = os.path.join(share, pkg, 'msg', f'{name}.{ext}')
        if os.path.isfile(path):
            return path
    return None


def _dependencies(pkg, text):
    """Return the sorted set of ``pkg/Type`` names the ``.msg`` text refers to."""
    deps = set()
    for line in text.splitlines():
        line = line.split('#', 1)[0]
        match = _FIELD_RE.match(line)
        if not match:
            continue
        field_type = match.group(1)
        if field_type in _PRIMITIVES:
            continue
        if field_type == 'Header':
            deps.add('std_msgs/Header')
        elif '/' in field_type:
            dep_pkg, dep_name = _split(field_type)
            deps.add(f'{dep_pkg}/{dep_name}')
        else:
            deps.add(f'{pkg}/{field_type}')
    return sorted(deps)


def _local_definition(type_name):
    pkg, name = _split(type_name)
    root = _find_share_file(pkg, name, 'msg')
    if root is None:
        return None
    with open(root, encoding='utf-8') as f:
        root_text = f.read()
    parts = [root_text]
    seen = {f'{pkg}/{name}'}

    def visit(dep_pkg, text):
        for dep in _dependencies(dep_pkg, text):
            if dep in seen:
                continue
            seen.add(dep)
            d_pkg, d_name = dep.split('/')
            path = _find_share_file(d_pkg, d_name, 'msg')
            if path is None:
                raise FileNotFoundError(dep)
            with open(path, encoding='utf-8') as f:
                dep_text = f.read()
            parts.append(f'\n{SEPARATOR}\nMSG: {dep}\n{dep_text}')
            visit(d_pkg, dep_text)

    try:
        visit(pkg, root_text)
    except FileNotFoundError:
        return None
    return ''.join(parts)


@functools.lru_cache(maxsize=None)
def _typestore():
    from rosbags.typesys import get_typestore, Stores
    return get_typestore(Stores.ROS2_JAZZY)


@functools.lru_cache(maxsize=None)
def message_definition(type_name: str) -> bytes:
    """
    Return the ``ros2msg`` schema text of ``type_name`` (``pkg/msg/Type``) as bytes.

    :raises SchemaError: the type is malformed or known neither to the installed packages nor
        to rosbags.
    """
    text = _local_definition(type_name)
    if text is None:
        try:
            text = _typestore().generate_msgdef(type_name, ros_version=2)[0]
        except Exception as exc:  # rosbags raises its own TypesysError family
            raise SchemaError(
                f'message type {type_name!r}: no .msg definition found under '
                f'{_share_dirs()} nor in the rosbags Jazzy typestore ({exc})') from None
    return text.encode('utf-8')


@functools.lru_cache(maxsize=None)
def type_hash(type_name: str) -> str:
    """Return the RIHS01 type description hash of ``type_name``, or ``''`` if unknown."""
    pkg, name = _split(type_name)
    path = _find_share_file(pkg, name, 'json')
    full = f'{pkg}/msg/{name}'
    if path is not None:
        with open(path, encoding='utf-8') as f:
            for entry in json.load(f).get('type_hashes', ()):
                if entry.get('type_name') == full:
                    return entry['hash_string']
    try:
        return _typestore().hash_rihs01(full)
    except Exception:  # rosbags raises its own TypesysError family
        return ''
