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
The static world of a configuration: the ground plane (``ground.*``) and ``obstacle_names``.

A stage of :meth:`rbd_ros.sim.config.NodeConfig.from_parameters`: each obstacle's shape (a
primitive, or a mesh file with its scale), pose and material checked, naming its parameter
``obstacles.<name>.*``, into one :class:`rbd_ros.core.contact.StaticWorld`.
"""

from rbd_ros.core import ModelError
from rbd_ros.core.contact.shapes import PRIMITIVES
from rbd_ros.core.contact.world import ground_plane, obstacle, StaticWorld, validate_material
from rbd_ros.sim.config_bodies import _reraise, _unit_quaternion
from rbd_ros.sim.meshes import check_sizes, mesh_file
from rbd_ros.sim.params import (check_min_size, fail, fmt, obstacle_parameter_specs,
                                PARAMETERS_BY_NAME, position3)


def _static_world(values, obstacle_names):
    """Return the :class:`StaticWorld` of ``ground.*`` and ``obstacle_names``, or None if empty."""
    p = PARAMETERS_BY_NAME
    ground = None
    if values['ground.enabled']:
        material = _reraise(p['ground.friction'], values['ground.friction'], validate_material,
                            values['ground.friction'], values['ground.restitution'], 'ground.')
        ground = ground_plane((0.0, 0.0, 1.0), values['ground.height_m'], material)
    obstacles = []
    for name in obstacle_names:
        specs = {spec.name.rsplit('.', 1)[1]: spec for spec in obstacle_parameter_specs(name)}
        get = {key: values[spec.name] for key, spec in specs.items()}
        q_wxyz = _unit_quaternion(specs['orientation'], get['orientation'])
        check_sizes(specs['dimensions_m'], get['dimensions_m'], specs['mesh_scale'],
                    get['mesh_scale'])
        check_min_size(specs['dimensions_m'], get['dimensions_m'])
        position3(specs['position'], get['position'])
        if get['shape'] == 'mesh':
            if not get['mesh_path']:
                fail(specs['mesh_path'], '', "must be a mesh file when shape is 'mesh'")
            if get['dimensions_m']:
                fail(specs['dimensions_m'], get['dimensions_m'],
                     "is not used by shape 'mesh' (its size is the file's times mesh_scale)",
                     ModelError)
            resolved = mesh_file(get['mesh_path'], specs['mesh_path'].name,
                                 get['mesh_scale'])
        elif get['shape'] not in PRIMITIVES:
            fail(specs['shape'], get['shape'],
                 'must be one of ' + ', '.join(PRIMITIVES) + ' or mesh', ModelError)
        else:
            if get['mesh_path']:
                fail(specs['mesh_path'], get['mesh_path'],
                     f"is not used by shape {get['shape']!r}: only shape 'mesh' takes a file",
                     ModelError)
            if tuple(get['mesh_scale']) != tuple(specs['mesh_scale'].default):
                fail(specs['mesh_scale'], get['mesh_scale'],
                     f"is not used by shape {get['shape']!r}: only shape 'mesh' is scaled",
                     ModelError)
            resolved = None
        try:
            obstacles.append(obstacle(
                name, get['shape'], get['dimensions_m'], resolved, get['mesh_scale'],
                get['position'], q_wxyz, get['friction'], get['restitution']))
        except ModelError as exc:
            # 'obstacles.<name>.mesh_path: <path>: why' as a body's 'parameter <field> =
            # <value>: <path>: why' (the value as given, then the file it resolved to)
            message, key = str(exc), (exc.field or '').rpartition('.')[2]
            if key in ('mesh_path', 'mesh_scale') and message.startswith(exc.field + ': '):
                message = (f'{exc.field} = {fmt(get[key])}: '
                           f'{message[len(exc.field) + 2:]}')
            raise ModelError(f'parameter {message}', field=exc.field) from None
    if ground is None and not obstacles:
        return None
    return StaticWorld(ground, tuple(obstacles))
