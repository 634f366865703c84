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
The node's parameters as data, and :class:`NodeConfig`, the validated configuration (no rclpy).

:data:`PARAMETERS` is the one table of the public parameter interface: name, type, default,
unit, description, allowed range and whether it is read-only.  The node declares its ROS
parameters from it (descriptions, ``FloatingPointRange``/``IntegerRange``),
:meth:`NodeConfig.from_parameters` validates against it, and a test checks that the parameter
tables of ``doc/parameters.md`` list exactly these names with these defaults and units.

:meth:`NodeConfig.from_parameters` takes a plain ``dict`` name → value (missing names take their
default) and either returns a frozen :class:`NodeConfig` or raises :class:`ConfigError` /
:class:`ModelError` with one line naming the parameter, its value, its unit and the rule.
:meth:`NodeConfig.to_parameters` returns the plain ``dict`` back (round trip), which is what a
recording stores so that replay can rebuild exactly the same configuration.

Times are converted to integer nanoseconds here, rounded to the nearest nanosecond:
``timestep_s`` must be a whole number of nanoseconds (to 0.001 ns, which absorbs the binary
representation of decimal values such as 0.001), so that sim time is exact; the publish period
is ``round(1e9 / publish_rate_hz)`` ns. A positive time that rounds to 0 ns is refused (it would
silently mean "off"), naming the parameter.

An array parameter given as ``[]`` reaches the node as a value of type NOT_SET (``None``): ROS
YAML cannot type an empty list. :meth:`NodeConfig.from_parameters` reads ``None`` as ``[]`` for
array parameters.
"""

from dataclasses import dataclass, replace as dataclass_replace

import numpy as np

from rbd_ros.core import BodyModel, BodyState, ConfigError, INTEGRATORS, ModelError
from rbd_ros.core.contact.shapes import primitive_shape, PRIMITIVES
from rbd_ros.core.contact.simulator import CONTACT_INTEGRATORS
from rbd_ros.core.contact.world import (check_overlaps, ground_plane, is_valid_name, NAME_RULE,
                                        obstacle, StaticWorld, validate_material)
from rbd_ros.core.inertia import from_shape, inertia_from_components, SHAPES
from rbd_ros.sim import robots as robot_params
from rbd_ros.sim import world_joints as joint_params
from rbd_ros.sim.meshes import check_sizes, mesh_file, mesh_shape
from rbd_ros.sim.params import (body_parameter_specs, BODY_PARAMETERS, check_min_size, check_range,
                                check_real_time_factor, coerce, DEFAULT_DIMENSIONS_M,
                                DEFAULT_SHAPE, DOUBLE, fail, fmt, frame_id_problem, FRAME_KEYWORDS,
                                input_parameter_specs, INTEGER, MAIN_INPUT, MAX_BODIES, NS_PER_S,
                                obstacle_parameter_specs, PARAMETERS, PARAMETERS_BY_NAME,
                                position3, refuse_old_names, to_ns, unit_quaternion, vector3)


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


@dataclass(frozen=True)
class NodeConfig:
    """
    The validated configuration of a rigid-body node (frozen, ROS-free).

    Build it with :meth:`from_parameters`; :meth:`to_parameters` gives the plain dict back.

    Every configuration is a world: :attr:`bodies` holds one :class:`BodyConfig` per body
    (a single-body params file gives a tuple of one), :attr:`static_world` the ground and
    obstacles (None without).

    :ivar bodies: the :class:`BodyConfig` tuple, in ``body_names`` order.
    :ivar integrator: integrator name, a key of ``INTEGRATORS``.
    :ivar timestep_ns: physics step, integer ns.
    :ivar publish_period_ns: state publishing period in sim time, integer ns.
    :ivar real_time_factor: sim s per wall s; 0 = as fast as possible.
    :ivar duration_ns: stop after this sim time, integer ns; 0 = never.
    :ivar wrench_timeout_ns: hold time of a received wrench in sim ns; 0 = until replaced.
    :ivar parameters: the validated parameter values (a name → value dict, arrays as tuples).
    :ivar static_world: the :class:`rbd_ros.core.contact.StaticWorld`, or None.
    :ivar robots: the :class:`rbd_ros.sim.robots.RobotConfig` tuple (``robot_names`` order).
        With free bodies, a ground or obstacles, the robots' links are bodies of one contact
        world (:mod:`rbd_ros.sim.robot_contact`); :attr:`bodies` holds the free bodies only.
    :ivar command_groups: the :class:`rbd_ros.sim.robots.CommandGroup` tuple.
    :ivar world_joints: the :class:`rbd_ros.sim.world_joints.WorldJoint` tuple
        (``joint_names`` order): joints between the bodies of a world.
    """

    bodies: tuple
    integrator: str
    timestep_ns: int
    publish_period_ns: int
    real_time_factor: float
    duration_ns: int
    start_paused: bool
    world_frame: str
    twist_frame: str
    default_wrench_frame: str
    wrench_timeout_ns: int
    max_force_n: float
    max_torque_nm: float
    publish_clock: bool
    publish_tf: bool
    publish_markers: bool
    record_path: str
    record_overwrite: bool
    record_on_error: str
    parameters: dict
    static_world: object = None
    robots: tuple = ()
    command_groups: tuple = ()
    world_joints: tuple = ()

    @property
    def named(self):
        """
        Return True when the bodies are addressed by name (``body_names`` given).

        Their topics, inputs and parameters then carry the name, and a ``poses`` array holds
        every pose; the body of a single-body file has none of that (its prefixes are ``''``).
        """
        return bool(self.parameters['body_names'])

    @property
    def per_body_topics(self):
        """Return whether each body of a world has its own output topics (``per_body_topics``)."""
        return self.parameters['per_body_topics']

    @property
    def threads(self):
        """Return the threads a world's contact step may use (``threads``)."""
        return self.parameters['threads']

    @property
    def contact(self):
        """Return True when a body can touch something: named bodies, a ground or an obstacle."""
        return self.static_world is not None or self.named

    @property
    def wrench_inputs(self):
        """Return every body's :class:`WrenchInputSpec`, in body order, each main input first."""
        return tuple(spec for body in self.bodies for spec in body.wrench_inputs)

    @property
    def body(self):
        """
        Return the only :class:`BodyConfig` (a single-body file's).

        :raises ConfigError: the configuration has more than one body (use :attr:`bodies`).
        """
        if len(self.bodies) != 1:
            raise ConfigError(f'body_names: {len(self.bodies)} bodies, not one: '
                              'use NodeConfig.bodies')
        return self.bodies[0]

    # The only body's fields, read through :attr:`body` (so a world of several refuses them).
    model = property(lambda self: self.body.model, doc="The only body's :class:`BodyModel`.")
    initial_state = property(lambda self: self.body.initial_state,
                             doc="The only body's :class:`BodyState` at time 0.")
    body_frame = property(lambda self: self.body.body_frame, doc="The only body's frame id.")
    collision_shape = property(lambda self: self.body.collision_shape,
                               doc="The only body's collision shape, or None.")
    material = property(lambda self: self.body.material, doc="The only body's material.")

    @classmethod
    def from_parameters(cls, params=None, *, accepted_frames=None):
        """
        Validate ``params`` (name → value; missing names take their defaults) into a config.

        :param accepted_frames: None (a start); a list: the robot link frame refusals
            (:func:`rbd_ros.sim.robots.check_link_frames`) go there instead of being raised,
            for replay of a recording made before those rules (TF frame ids only).

        :raises ConfigError: an unknown name, a wrong type, a value out of range, an unknown
            integrator or frame keyword, a step that is not a whole number of ns, ...
        :raises ModelError: a mass or inertia the core rejects (not positive definite,
            triangle inequality), both ``inertia`` and ``shape`` given, ...
        :raises ConfigError: a renamed parameter under its old name (:data:`RENAMED_PARAMETERS`;
            a recording's parameters go through :func:`recorded_parameters` first).
        """
        params = dict(params or {})
        refuse_old_names(params)
        values = _table_values(params)
        input_names = _input_values(values, params)
        obstacle_names = _obstacle_values(values, params)
        body_inputs = _body_values(values, params)
        robots, groups = _robot_values(values, params)
        joint_params.take_parameters(values, params)
        if params:
            unknown = sorted(params)[0]
            raise ConfigError(
                f'parameter {unknown} = {fmt(params[unknown])}: unknown parameter name '
                '(known: see doc/parameters.md; wrench input, obstacle and body parameters need '
                'their name in wrench_input_names, obstacle_names or body_names)')
        time_settings = _time_settings(values)
        static_world = _static_world(values, obstacle_names)
        integrator = time_settings['integrator']
        if robots:
            bodies = ()
            if body_inputs or static_world is not None:  # one contact world
                _check_contact_integrator(integrator, 'robots in a world with contact')
                if body_inputs:
                    bodies = _world_bodies(values, body_inputs, static_world, integrator)
            world_joints = joint_params.read_world_joints(
                values, {b.name: b for b in bodies}, robots)
            for robot in robots:  # <name>/odom of a floating robot is a body's <name>/odom
                if robot.name in values['body_names']:
                    fail(robot_params.ROBOT_NAMES_SPEC, list(values[robot_params.ROBOT_NAMES]),
                         f"{robot.name!r} is also in body_names: a robot's topics and a "
                         "body's are both '<name>/...'; name them apart")
            _check_time_constants(robots, world_joints, time_settings['timestep_ns'])
            return cls(bodies=bodies, **time_settings,
                       **_frame_settings(values, bodies, robots, accepted_frames),
                       **_limits_and_recording(values), parameters=values,
                       static_world=static_world, robots=robots, command_groups=groups,
                       world_joints=world_joints)
        if groups:
            fail(robot_params.GROUP_NAMES_SPEC, list(values[robot_params.GROUP_NAMES]),
                 'command groups need robots (robot_names is empty)')
        if body_inputs:
            bodies = _world_bodies(values, body_inputs, static_world, integrator)
            settings = {**_frame_settings(values, bodies), **_limits_and_recording(values)}
        else:
            if not values['per_body_topics']:  # a single body's topics are its only outputs
                fail(PARAMETERS_BY_NAME['per_body_topics'], False,
                     'only a world (body_names) can turn its per-body topics off: a single '
                     "body's pose, twist and odom are its only state outputs")
            body = _single_body(values, static_world, integrator)
            settings = {**_frame_settings(values), **_limits_and_recording(values)}
            bodies = (dataclass_replace(
                body, wrench_inputs=_wrench_inputs(values, input_names),
                material=_reraise(PARAMETERS_BY_NAME['friction'], values['friction'],
                                  validate_material, values['friction'], values['restitution'])),)
        world_joints = joint_params.read_world_joints(
            values, {b.name: b for b in bodies} if body_inputs else {})
        _check_time_constants((), world_joints, time_settings['timestep_ns'])
        return cls(bodies=bodies, **time_settings, **settings, parameters=values,
                   static_world=static_world, world_joints=world_joints)

    def to_parameters(self):
        """Return the parameters as a plain dict (lists for arrays), valid for from_parameters."""
        return {name: list(value) if isinstance(value, tuple) else value
                for name, value in self.parameters.items()}

    def all_specs(self):
        """Return the specs of every parameter of this config (table + wrench input ones)."""
        specs = list(PARAMETERS)
        for input_name in self.parameters['wrench_input_names']:
            specs.extend(input_parameter_specs(input_name))
        for obstacle_name in self.parameters['obstacle_names']:
            specs.extend(obstacle_parameter_specs(obstacle_name))
        for body_name in self.parameters['body_names']:
            specs.extend(body_parameter_specs(body_name))
            for input_name in self.parameters[f'bodies.{body_name}.wrench_input_names']:
                specs.extend(_body_input_specs(body_name, input_name))
        for robot in self.robots:
            specs.extend(robot.specs)
        for item in self.command_groups + self.world_joints:
            specs.extend(item.specs)
        return tuple(specs)


def _table_values(params):
    """Take the table's parameters out of ``params`` (defaults for the missing ones); coerce."""
    values = {}
    for spec in PARAMETERS:
        value = coerce(spec, params.pop(spec.name, spec.default))
        if spec.kind in (DOUBLE, INTEGER):
            check_range(spec, value)
        values[spec.name] = value
    return values


def _input_values(values, params):
    """Check ``wrench_input_names``; move each input's parameters from ``params`` to ``values``."""
    spec = PARAMETERS_BY_NAME['wrench_input_names']
    names = values['wrench_input_names']
    _check_names(spec, names, 'input')
    if MAIN_INPUT in names:
        fail(spec, list(names), f'{MAIN_INPUT!r} is the main input')
    for name in names:
        for input_spec in input_parameter_specs(name):
            values[input_spec.name] = coerce(
                input_spec, params.pop(input_spec.name, input_spec.default))
    return names


def _obstacle_values(values, params):
    """Check ``obstacle_names``; move each obstacle's parameters from ``params`` to ``values``."""
    spec = PARAMETERS_BY_NAME['obstacle_names']
    names = values['obstacle_names']
    _check_names(spec, names, 'obstacle')
    if 'ground' in names:
        fail(spec, list(names), "'ground' is the ground plane (ground.*)")
    for name in names:
        for obstacle_spec in obstacle_parameter_specs(name):
            value = coerce(obstacle_spec, params.pop(obstacle_spec.name, obstacle_spec.default))
            if obstacle_spec.kind == DOUBLE:
                check_range(obstacle_spec, value)
            values[obstacle_spec.name] = value
    return names


def _body_input_specs(body, name):
    """Return the specs of the extra wrench input ``name`` of world body ``body``."""
    return tuple(dataclass_replace(spec, name=f'bodies.{body}.{spec.name}')
                 for spec in input_parameter_specs(name))


def _check_names(spec, names, what):
    """Refuse a name that breaks the one name rule (``NAME_RULE``) or a name given twice."""
    for name in names:
        if not is_valid_name(name):
            fail(spec, list(names), f'{what} name {name!r} must be {NAME_RULE}')
    if len(set(names)) != len(names):
        fail(spec, list(names), 'names must be distinct')


def _body_values(values, params):
    """
    Check ``body_names``; take each body's parameters out of ``params`` into ``values``.

    Returns ``{body: its extra input names}`` (empty without ``body_names``).
    """
    names = values['body_names']
    if len(names) > MAX_BODIES:
        fail(PARAMETERS_BY_NAME['body_names'], list(names),
             f'{len(names)} bodies exceed the limit of {MAX_BODIES}')
    _check_names(PARAMETERS_BY_NAME['body_names'], names, 'body')
    out = {}
    for name in names:
        for spec in body_parameter_specs(name):
            value = coerce(spec, params.pop(spec.name, spec.default))
            if spec.kind in (DOUBLE, INTEGER):
                check_range(spec, value)
            values[spec.name] = value
        inputs_spec = PARAMETERS_BY_NAME['wrench_input_names']
        inputs = values[f'bodies.{name}.wrench_input_names']
        try:
            _check_names(inputs_spec, inputs, 'input')
            if MAIN_INPUT in inputs:
                fail(inputs_spec, list(inputs), f'{MAIN_INPUT!r} is the main input')
        except ConfigError as exc:
            raise exc.renamed(f'bodies.{name}.wrench_input_names') from None
        for input_name in inputs:
            for spec in _body_input_specs(name, input_name):
                values[spec.name] = coerce(spec, params.pop(spec.name, spec.default))
        out[name] = inputs
    return out


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


def _robot_values(values, params):
    """
    Read the robots and command groups; move their parameters from ``params`` to ``values``.

    A ``robots.*`` or ``command_groups.*`` name that no robot or group declares stays in
    ``params`` (an unknown parameter).
    """
    given = {name: value for name, value in params.items()
             if name.startswith(('robots.', 'command_groups.'))}
    for name in (robot_params.ROBOT_NAMES, robot_params.GROUP_NAMES):  # from the table
        given[name] = values[name]
    robots = robot_params.read_robots(given, values['gravity'])
    groups = robot_params.read_command_groups(given, robots)
    specs = [spec for item in robots + groups for spec in item.specs]
    for spec in specs:
        values[spec.name] = coerce(spec, params.pop(spec.name, spec.default))
    return robots, groups


def _check_time_constants(robots, world_joints, timestep_ns):
    """
    Refuse a joint's ``position_time_constant_s`` below the step.

    The motor's response is the critically damped one only while the step resolves it
    (``ω h <= 1``, ``ω = 1 / τ``). Measured on the gripper's finger at h = 1 ms with an
    effort limit out of reach: τ = h moves it as the closed form does (its error within 5 %
    over the move's first five steps), never past the target; τ = h/2 overshoots by a third of
    the move; τ = h/2.5 rings for ~20 steps; τ = h/2.9 overshoots to the joint's limit and
    stays held there; τ = h/3.3 stops the world (the projection did not converge). A time
    constant the step cannot resolve is a setting to refuse, not a response to approximate.
    """
    step_s = timestep_ns / NS_PER_S
    given = [(spec, constant) for robot in robots
             for spec, constant in zip(
                 [s for s in robot.specs if s.name.endswith('.position_time_constant_s')],
                 robot.time_constants_s)]
    given += [(next(s for s in joint.specs if s.name.endswith('.position_time_constant_s')),
               joint.time_constant_s) for joint in world_joints]
    for spec, constant in given:
        if constant < step_s:
            fail(spec, constant, f'must be >= the step, timestep_s = {step_s:g} s: a motor '
                 'faster than a step overshoots, and below ~timestep_s / 3 drives the joint '
                 'to its limit or stops the world')


def _check_contact_integrator(integrator, what):
    """Refuse an integrator that cannot take contact (``what`` says which world needs it)."""
    if integrator not in CONTACT_INTEGRATORS:
        fail(PARAMETERS_BY_NAME['integrator'], integrator,
             f'cannot take contact ({what}): use one of ' + ', '.join(CONTACT_INTEGRATORS))


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


def _time_settings(values):
    """Check integrator, step, publish period, real-time factor, duration, wrench timeout."""
    p = PARAMETERS_BY_NAME
    if values['integrator'] not in INTEGRATORS:
        fail(p['integrator'], values['integrator'], 'must be one of ' + ', '.join(INTEGRATORS))
    timestep_ns = to_ns(p['timestep_s'], values['timestep_s'])
    check_real_time_factor(values['real_time_factor'])
    return {'integrator': values['integrator'], 'timestep_ns': timestep_ns,
            'publish_period_ns': max(1, round(NS_PER_S / values['publish_rate_hz'])),
            'real_time_factor': values['real_time_factor'],
            'duration_ns': to_ns(p['duration_s'], values['duration_s']),
            'start_paused': values['start_paused'],
            'wrench_timeout_ns': to_ns(p['wrench_timeout_s'], values['wrench_timeout_s'])}


def _frame_settings(values, bodies=(), robots=(), accepted_frames=None):
    """
    Check the frame ids and keywords; the optional outputs (``/clock``, ``/tf``).

    Every frame is the node's one: the world's, each body's, each robot link's
    (:func:`rbd_ros.sim.robots.check_link_frames`, after the others; ``accepted_frames``: see
    :meth:`NodeConfig.from_parameters`).
    """
    p = PARAMETERS_BY_NAME
    seen = {values['world_frame']: 'world_frame'}
    for body in bodies:
        if not body.parameter_prefix:
            continue  # the top-level body_frame: checked below
        spec = PARAMETERS_BY_NAME['body_frame']
        where = f'{body.parameter_prefix}body_frame'
        problem = frame_id_problem(body.body_frame)
        if problem:
            fail(dataclass_replace(spec, name=where), body.body_frame, problem)
        if body.body_frame in seen:
            fail(dataclass_replace(spec, name=where), body.body_frame,
                 f'is already the frame of {seen[body.body_frame]}')
        seen[body.body_frame] = where
    for name in ('world_frame', 'body_frame'):
        problem = frame_id_problem(values[name])
        if problem:
            fail(p[name], values[name], problem)
    if values['world_frame'] == values['body_frame']:
        fail(p['body_frame'], values['body_frame'], 'must differ from world_frame')
    for name in ('twist_frame', 'default_wrench_frame'):
        if values[name] not in FRAME_KEYWORDS:
            fail(p[name], values[name], "must be 'world' or 'body'")
    robot_params.check_link_frames(values['world_frame'], seen, robots, accepted_frames)
    return {name: values[name] for name in (
        'world_frame', 'twist_frame', 'default_wrench_frame', 'publish_clock', 'publish_tf',
        'publish_markers')}


def _limits_and_recording(values):
    """Check the wrench limits and the ``record_*`` settings."""
    p = PARAMETERS_BY_NAME
    if values['record_on_error'] not in ('continue', 'stop'):
        fail(p['record_on_error'], values['record_on_error'], "must be 'continue' or 'stop'")
    vector3(p['drag_point_b'], values['drag_point_b'])
    return {name: values[name] for name in (
        'max_force_n', 'max_torque_nm', 'record_path', 'record_overwrite', 'record_on_error')}


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


# Parameters that shape the first physics step, in the order they are blamed when that step is
# not finite: each is put back to its default in turn until the step becomes finite.
