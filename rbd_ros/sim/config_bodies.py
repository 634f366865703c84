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
The bodies of a configuration: :class:`BodyConfig`, its shape, model, start and inputs.

A stage of :meth:`rbd_ros.sim.config.NodeConfig.from_parameters`: the one body of a params file
without ``body_names`` (:func:`_single_body`), or every body of a world (:func:`_world_bodies`,
each body's errors naming its own parameter ``bodies.<name>.*``, then their overlaps). A body's
collision shape is a mesh file, a primitive or none (inertia only); its model the given inertia
or its shape's; its start the initial pose and velocities; its wrench inputs
:class:`WrenchInputSpec`.
"""

from dataclasses import dataclass, replace as dataclass_replace

import numpy as np

from rbd_ros.core import BodyModel, BodyState, ConfigError, ModelError
from rbd_ros.core.contact.shapes import primitive_shape
from rbd_ros.core.contact.simulator import CONTACT_INTEGRATORS
from rbd_ros.core.contact.world import check_overlaps, validate_material
from rbd_ros.core.inertia import from_shape, inertia_from_components, SHAPES
from rbd_ros.sim.config_settings import _check_contact_integrator
from rbd_ros.sim.meshes import check_sizes, mesh_shape
from rbd_ros.sim.params import (BODY_PARAMETERS, check_min_size, DEFAULT_DIMENSIONS_M,
                                DEFAULT_SHAPE, fail, fmt, FRAME_KEYWORDS, input_parameter_specs,
                                MAIN_INPUT, PARAMETERS, PARAMETERS_BY_NAME, position3,
                                unit_quaternion, vector3)


@dataclass(frozen=True)
class BodyConfig:
    """
    One body: name, model, start, collision shape, material, frame, inputs and drag point.

    A params file without ``body_names`` is a world of one such body, named ``'body'``, whose
    topics, inputs and parameters carry no prefix (``pose``, ``wrench``, ``drag``, ``mass_kg``);
    a body of ``body_names`` carries its name (``<name>/pose``, ``bodies.<name>.mass_kg``).

    :ivar name: its name in ``body_names`` (``'body'`` for the body of a single-body file).
    :ivar model: its :class:`BodyModel`.
    :ivar initial_state: its :class:`BodyState` at time 0.
    :ivar collision_shape: its :class:`rbd_ros.core.contact.CollisionShape` (None for a body
        given by its inertia only, which cannot touch anything).
    :ivar material: its :class:`rbd_ros.core.contact.Material`.
    :ivar body_frame: its frame id (default its name).
    :ivar wrench_inputs: its :class:`WrenchInputSpec` tuple; names and topics are
        ``<name>/wrench``, ``<name>/wrench_<input>`` (relative), so they are unique in the
        world and the node's namespace still applies.
    :ivar drag_point_b: where a drag pulls, body frame, m.
    :ivar prefix: the prefix of its topics and input names: ``'<name>/'``, or ``''``.
    :ivar parameter_prefix: the prefix of its parameters: ``'bodies.<name>.'``, or ``''``.
    """

    name: str
    model: BodyModel
    initial_state: BodyState
    collision_shape: object
    material: object
    body_frame: str
    wrench_inputs: tuple
    drag_point_b: tuple = (0.0, 0.0, 0.0)
    prefix: str = ''
    parameter_prefix: str = ''

    @property
    def label(self):
        """Return the body's name as its topics carry it, else its frame id (markers' text)."""
        return self.prefix.rstrip('/') or self.body_frame


@dataclass(frozen=True)
class WrenchInputSpec:
    """
    One wrench input: its name, topic, default frame keyword and application point.

    :param name: ``'wrench'`` for the main input, else the name listed in ``wrench_input_names``.
    :param topic: the (relative) topic name.
    :param frame: ``'world'`` or ``'body'``: how a message with an empty ``frame_id`` is read.
    :param point_b: application point of the force, body frame relative to the COM, m.
    """

    name: str
    topic: str
    frame: str
    point_b: tuple = (0.0, 0.0, 0.0)


def _renamed(body, exc):
    """Return ``exc`` (ModelError/ConfigError) naming the body's own parameter."""
    if exc.field in BODY_PARAMETERS:
        return exc.renamed(f'bodies.{body}.{exc.field}')
    return exc


def _world_bodies(values, body_inputs, static_world, integrator):
    """Build every body of a world; refuse top-level per-body values and overlaps."""
    for base in BODY_PARAMETERS:
        spec = PARAMETERS_BY_NAME[base]
        if values[base] != spec.default:
            fail(spec, values[base], f'with body_names, each body has its own: set '
                 f'bodies.<name>.{base} instead')
    _check_contact_integrator(integrator, 'a world of bodies')
    bodies = []
    # Each body's values are the table's with its own on top: a copy of the table only (the
    # whole of ``values`` holds every body's parameters, so copying it made start-up quadratic).
    table = {spec.name: values[spec.name] for spec in PARAMETERS}
    shapes = {}  # one CollisionShape for equal primitives (read-only arrays, shared)
    for name, inputs in body_inputs.items():
        sub = dict(table)
        for base in BODY_PARAMETERS:
            sub[base] = values[f'bodies.{name}.{base}']
        for input_name in inputs:
            for spec in input_parameter_specs(input_name):
                sub[spec.name] = values[f'bodies.{name}.{spec.name}']
        try:
            collision = _collision_shape(sub, shapes)
            model = _model(sub, collision)
            state = _initial_state(sub)
            if collision is None:
                fail(PARAMETERS_BY_NAME['inertia'], sub['inertia'], 'a body given only by its '
                     'inertia has no collision shape; give shape and dimensions_m, or '
                     'mesh_path', ModelError)
            material = validate_material(sub['friction'], sub['restitution'])
            specs = _wrench_inputs(sub, inputs)
        except (ModelError, ConfigError) as exc:
            raise _renamed(name, exc) from None
        specs = tuple(WrenchInputSpec(f'{name}/{spec.name}', f'{name}/{spec.topic}',
                                      spec.frame, spec.point_b) for spec in specs)
        point_spec = dataclass_replace(PARAMETERS_BY_NAME['drag_point_b'],
                                       name=f'bodies.{name}.drag_point_b')
        bodies.append(BodyConfig(name, model, state, collision, material,
                                 sub['body_frame'], specs,
                                 vector3(point_spec, sub['drag_point_b']),
                                 prefix=f'{name}/', parameter_prefix=f'bodies.{name}.'))
    try:
        check_overlaps([(b.name, b.collision_shape, b.initial_state.position_w,
                         b.initial_state.orientation_wb) for b in bodies], static_world)
    except ModelError as exc:
        raise overlap_error(exc) from None
    return tuple(bodies)


def overlap_error(exc):
    """
    Return the core's overlap error naming the parameter ``bodies.<name>.initial_position``.

    The core names ``bodies.<name>.position_w``; any other error is returned as it is.
    """
    if not (exc.field or '').endswith('.position_w'):
        return exc
    field = exc.field[:-len('position_w')] + 'initial_position'
    return ModelError(f'parameter {field} = {exc.detail}', field=field, value=exc.value,
                      unit=exc.unit, detail=exc.detail, rule=exc.rule)


def _single_body(values, static_world, integrator):
    """
    Build the one body of a params file without ``body_names`` (no name prefixes).

    Its shape, model and start; the caller adds its inputs and material after the frame and
    limit checks (the order in which a file's errors are reported).
    """
    collision = _collision_shape(values)
    model = _model(values, collision)
    initial_state = _initial_state(values)
    _check_contact(values, collision, static_world, initial_state, integrator)
    return BodyConfig('body', model, initial_state, collision, None, values['body_frame'], (),
                      values['drag_point_b'])


def _collision_shape(values, cache=None):
    """
    Return the body's collision shape: the mesh, the (default) primitive, or None.

    :param cache: a dict that keeps the primitives built, by shape and dimensions, so that
        bodies of one size share one shape (its surface points); None: no sharing.
    """
    p = PARAMETERS_BY_NAME
    shape, path = values['shape'], values['mesh_path']
    check_sizes(p['dimensions_m'], values['dimensions_m'], p['mesh_scale'],
                values['mesh_scale'])
    check_min_size(p['dimensions_m'], values['dimensions_m'])
    if path:
        if values['inertia']:
            raise ModelError(
                f'parameter inertia = {fmt(values["inertia"])} kg·m² and parameter mesh_path = '
                f'{path!r}: give either inertia or mesh_path, not both')
        if shape not in ('', 'mesh'):
            fail(p['shape'], shape, "must be '' or 'mesh' with mesh_path")
        if values['dimensions_m']:
            fail(p['dimensions_m'], values['dimensions_m'], 'is not used with mesh_path')
        return mesh_shape(p['mesh_path'], p['mesh_scale'], path, values['mesh_scale'])
    if shape == 'mesh':
        fail(p['mesh_path'], path, "must be a mesh file when shape is 'mesh'")
    if values['mesh_scale'] != p['mesh_scale'].default:
        fail(p['mesh_scale'], values['mesh_scale'], 'needs mesh_path')
    if values['inertia']:
        return None
    if not shape:
        shape, dims = DEFAULT_SHAPE, DEFAULT_DIMENSIONS_M
    else:
        dims = values['dimensions_m']
    if shape not in SHAPES:
        return None  # _model names the shape
    key = (shape, tuple(dims))
    if cache is not None and key in cache:
        return cache[key]
    try:
        collision = primitive_shape(shape, dims)
    except ModelError:
        return None  # _model names the dimensions, as it did before shapes could collide
    if cache is not None:
        cache[key] = collision
    return collision


def _model(values, collision=None):
    """Build the :class:`BodyModel`: mass, inertia (given, or of a shape), gravity, damping."""
    p = PARAMETERS_BY_NAME
    mass_kg = values['mass_kg']
    inertia = values['inertia']
    shape = values['shape']
    dims = values['dimensions_m']
    if inertia and shape:
        raise ModelError(
            f'parameter inertia = {fmt(inertia)} kg·m² and parameter shape = {shape!r}: '
            'give either inertia or shape (with dimensions_m), not both')
    if dims and not shape:
        fail(p['dimensions_m'], dims, 'needs shape (or remove it and give inertia)')
    if values['mesh_path']:
        inertia_b = collision.mass_properties(mass_kg).inertia_b
    elif inertia:
        if len(inertia) != 6:
            fail(p['inertia'], inertia, 'must have 6 values [ixx, iyy, izz, ixy, ixz, iyz]')
        inertia_b = _reraise(p['inertia'], inertia, inertia_from_components, *inertia)
    else:
        if not shape:
            shape, dims = DEFAULT_SHAPE, DEFAULT_DIMENSIONS_M
        if shape not in SHAPES:
            fail(p['shape'], shape, 'must be one of ' + ', '.join(SHAPES), ModelError)
        inertia_b = _reraise(p['dimensions_m'], dims, from_shape, shape, dims,
                             mass_kg).inertia_b
    gravity = vector3(p['gravity'], values['gravity'])
    return _reraise(p['inertia'] if inertia else p['dimensions_m'], inertia or dims, BodyModel,
                    mass_kg, inertia_b, gravity, values['linear_damping'],
                    values['angular_damping'])


def _check_contact(values, collision, static_world, initial_state, integrator):
    """Refuse contact without a shape, with an integrator that cannot take it, or overlapping."""
    if static_world is None:
        return
    p = PARAMETERS_BY_NAME
    if collision is None:
        raise ModelError(
            f'parameter inertia = {fmt(values["inertia"])} kg·m²: a body given only by its '
            'inertia has no collision shape; with ground.enabled or obstacle_names give shape '
            'and dimensions_m, or mesh_path')
    if integrator not in CONTACT_INTEGRATORS:
        fail(p['integrator'], integrator,
             'cannot take contact (ground.enabled or obstacle_names): use one of '
             + ', '.join(CONTACT_INTEGRATORS))
    try:
        check_overlaps([('body', collision, initial_state.position_w,
                         initial_state.orientation_wb)], static_world)
    except ModelError as exc:
        fail(p['initial_position'], values['initial_position'], exc.rule, ModelError)


def _unit_quaternion(spec, q_xyzw):
    """Return ``q_xyzw`` as a unit (w, x, y, z) array (:func:`params.unit_quaternion`)."""
    return np.asarray(unit_quaternion(spec, q_xyzw))


def xyzw_to_wxyz(q_xyzw):
    """Reorder a plain ``[x, y, z, w]`` sequence (geometry_msgs order) to ``(w, x, y, z)``."""
    x, y, z, w = q_xyzw
    return (w, x, y, z)


def _initial_state(values):
    """Build the :class:`BodyState` at time 0 (``initial_orientation`` is [x, y, z, w])."""
    p = PARAMETERS_BY_NAME
    position = position3(p['initial_position'], values['initial_position'])
    q_wxyz = _unit_quaternion(p['initial_orientation'], values['initial_orientation'])
    velocity = vector3(p['initial_linear_velocity'], values['initial_linear_velocity'])
    omega_b = vector3(p['initial_angular_velocity'], values['initial_angular_velocity'])
    return BodyState(position_w=np.array(position), orientation_wb=q_wxyz,
                     linear_velocity_w=np.array(velocity), angular_velocity_b=np.array(omega_b),
                     time_ns=0)


def _wrench_inputs(values, input_names):
    """Build the :class:`WrenchInputSpec` tuple: the main input, then each extra one."""
    inputs = [WrenchInputSpec(MAIN_INPUT, 'wrench', values['default_wrench_frame'])]
    topics = {'wrench'}
    for name in input_names:
        topic_spec, frame_spec, point_spec = input_parameter_specs(name)
        topic = values[topic_spec.name]
        if not topic:
            fail(topic_spec, topic, 'must not be empty')
        if topic in topics:
            fail(topic_spec, topic, 'is already used by another wrench input')
        topics.add(topic)
        frame = values[frame_spec.name]
        if frame not in FRAME_KEYWORDS:
            fail(frame_spec, frame, "must be 'world' or 'body'")
        point_b = vector3(point_spec, values[point_spec.name])
        inputs.append(WrenchInputSpec(name, topic, frame, point_b))
    return tuple(inputs)


def _reraise(spec, value, func, *args):
    """Call ``func(*args)``; re-raise a core ModelError/ConfigError naming the parameter."""
    try:
        return func(*args)
    except (ModelError, ConfigError) as exc:
        if exc.field == spec.name:  # the core named the parameter: say it is one
            raise type(exc)(f'parameter {exc}', field=spec.name, value=value, unit=spec.unit,
                            detail=exc.detail, rule=exc.rule) from None
        fail(spec, value, str(exc), type(exc))
