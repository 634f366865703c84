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
A URDF's XML: the file read (a ``.xacro`` expanded) or the text taken, and parsed strictly.

lxml parses it (malformed XML is refused, not recovered); the elements yourdfpy would read
loosely are checked first, each error naming its line: every link and joint named, every joint
with its parent and child, the ``<limit>`` a revolute or prismatic joint needs, every
``<origin>`` 3 finite numbers within :data:`rbd_ros.sim.limits.MAX_POSITION_M`. Then yourdfpy
reads it for :mod:`rbd_ros.sim.urdf`.
"""

import io
import math
import os
from pathlib import Path
import warnings

from lxml import etree
from rbd_ros.core.errors import ConfigError, ModelError
from rbd_ros.sim.meshes import resolve_mesh_path
from rbd_ros.sim.params import MAX_POSITION_M
from rbd_ros.sim.urdf_robot import DESCRIPTION, LIMITED_TYPES, refuse
import yourdfpy


def _read(path=None, xml=None):
    """Return ``(source, xml bytes)``: the file (xacro expanded) or the text."""
    if xml is not None:
        return DESCRIPTION, xml.encode() if isinstance(xml, str) else bytes(xml)
    path = resolve_mesh_path(str(path), 'urdf_path')
    source = str(path)
    if not os.path.isfile(path):
        raise ConfigError(f'urdf_path: {source!r} does not exist or is not a file',
                          field='urdf_path', value=source)
    if source.endswith('.xacro'):
        try:
            import xacro
        except ImportError:
            raise ConfigError(f'urdf_path: {source!r}: the xacro package is not installed '
                              '(pip install xacro), so a .xacro file cannot be expanded',
                              field='urdf_path', value=source) from None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter('ignore')
                return source, xacro.process_file(source).toxml().encode()
        except Exception as exc:  # xacro raises XacroException, ExpatError, OSError, ...
            reason = ' '.join(str(exc).split()) or type(exc).__name__
            raise ConfigError(f'{source}: xacro failed: {reason}', field='urdf_path',
                              value=source) from None
    return source, Path(path).read_bytes()


def _parse(source, data):
    """Return the yourdfpy robot of ``data``, refusing malformed XML with its line."""
    try:
        root = etree.fromstring(data, etree.XMLParser(remove_blank_text=True))
    except etree.XMLSyntaxError as exc:
        refuse(ConfigError, source, 'xml', f'malformed XML: {exc}')
    if root.tag != 'robot':
        refuse(ConfigError, source, 'xml', f'the root element is <{root.tag}>, not <robot>')
    for element in root.iter('link', 'joint'):
        if not element.get('name'):
            refuse(ModelError, source, f'<{element.tag}> (line {element.sourceline})',
                   'has no name attribute')
    for element in root.iter('joint'):
        for tag in ('parent', 'child'):
            found = element.find(tag)
            if found is None or not found.get('link'):
                refuse(ModelError, source, f'joint {element.get("name")!r}.{tag}',
                       f'missing (line {element.sourceline}): a joint needs <{tag} link=...>')
        kind = element.get('type')
        if kind in LIMITED_TYPES and element.find('limit') is None:
            # the URDF spec requires it (urdfdom, so robot_state_publisher, refuses the file)
            refuse(ModelError, source, f'joint {element.get("name")!r}.limit',
                   f'missing (line {element.sourceline}): a {kind} joint needs <limit '
                   'lower=... upper=... effort=... velocity=.../> (a joint without limits is '
                   'continuous)')
    for element in root.iter('origin'):
        if element.getparent().tag in ('joint', 'inertial', 'collision', 'visual'):
            _check_origin(source, element)
    try:
        return yourdfpy.URDF.load(io.BytesIO(data), build_scene_graph=False,
                                  build_collision_scene_graph=False, load_meshes=False,
                                  load_collision_meshes=False).robot
    except (KeyError, ValueError, TypeError, AttributeError, IndexError) as exc:
        refuse(ConfigError, source, 'xml', f'not a valid URDF ({type(exc).__name__}: {exc})')


def _origin_field(element):
    """Return an ``<origin>``'s field: ``joint 'j'.origin``, ``link 'a'.collision[0].origin``."""
    owner = element.getparent()
    if owner.tag == 'joint':
        return f'joint {owner.get("name")!r}.origin'
    link = owner.getparent()
    if owner.tag in ('inertial', 'collision', 'visual') and link is not None \
            and link.tag == 'link':
        where = owner.tag
        if owner.tag != 'inertial':
            where += f'[{link.findall(owner.tag).index(owner)}]'
        return f'link {link.get("name")!r}.{where}.origin'
    return f'{owner.tag}.origin'


def _check_origin(source, element):
    """
    Refuse an ``<origin>`` that is not 3 finite numbers or lies too far away, naming it.

    ``xyz`` and ``rpy`` must be 3 finite numbers, ``xyz`` within :data:`MAX_POSITION_M` (as a
    body's ``initial_position``). yourdfpy would build a NaN pose from ``nan`` (refused much
    later, naming a rotation but no file or joint), and a frame 1e300 m away made the first
    step fail without a name.
    """
    for attribute, unit in (('xyz', 'm'), ('rpy', 'rad')):
        text = element.get(attribute)
        if text is None:
            continue
        field = f'{_origin_field(element)}.{attribute}'
        try:
            values = [float(v) for v in text.split()]
        except ValueError:
            values = None
        if values is None or len(values) != 3:
            refuse(ModelError, source, field, f'{text!r} must be 3 numbers in {unit} '
                   f'(line {element.sourceline})', text, unit)
        if not all(math.isfinite(v) for v in values):
            refuse(ModelError, source, field, f'{values} {unit} must be finite '
                   f'(line {element.sourceline})', values, unit)
        if attribute == 'xyz' and any(abs(v) > MAX_POSITION_M for v in values):
            refuse(ModelError, source, field, f'{values} m: every component must be within '
                   f'±{MAX_POSITION_M:g} m (line {element.sourceline})', values, unit)
