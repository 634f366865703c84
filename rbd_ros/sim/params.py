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
The parameter table and the rule of every value: names, types, units, ranges, messages.

:data:`PARAMETERS` is the one table of the public parameter interface: name, type, default,
unit, description, allowed range and whether it is read-only. The node declares its ROS
parameters from it (:mod:`rbd_ros.ros.parameters`),
:meth:`rbd_ros.sim.config.NodeConfig.from_parameters` validates against it, and a test checks
that the parameter tables of ``doc/parameters.md`` list exactly these names with these defaults
and units. The per-body, per-obstacle and
per-input rows are made by :func:`body_parameter_specs`, :func:`obstacle_parameter_specs` and
:func:`input_parameter_specs`. :func:`fail` is the one shape of a bad-value message: the
parameter, its value, its unit and the rule, on one line.

Times are converted to integer nanoseconds here (:func:`to_ns`), rounded to the nearest
nanosecond: a time in seconds must be a whole number of nanoseconds (to 0.001 ns, which absorbs
the binary representation of decimal values such as 0.001), so that sim time is exact. A
positive time that rounds to 0 ns is refused (it would silently mean "off"), naming the
parameter.
"""

from dataclasses import dataclass
import math

import numpy as np

from rbd_ros.core import ConfigError, DEFAULT_INTEGRATOR, INTEGRATORS, ModelError
from rbd_ros.core.simulator import usable_cores

# ROS parameter types, by the names rcl_interfaces/ParameterType uses (lower case).
BOOL = 'bool'
INTEGER = 'integer'
DOUBLE = 'double'
STRING = 'string'
DOUBLE_ARRAY = 'double_array'
STRING_ARRAY = 'string_array'

#: Frame keywords accepted by ``twist_frame``, ``default_wrench_frame`` and ``.frame``.
FRAME_KEYWORDS = ('world', 'body')

#: Name of the main wrench input (topic ``wrench``) in :class:`rbd_ros.sim.inputs.WrenchInputs`.
MAIN_INPUT = 'wrench'

#: Most bodies a world may have (``bodies``): start-up checks and the contact step are measured
#: up to 1000 bodies; far more makes start-up take minutes.
MAX_BODIES = 5000

#: Most threads ``threads`` may ask for.
MAX_THREADS = 1024

#: Most items an array parameter may hold (10 x MAX_BODIES): more than any list a world needs
#: (``body_names`` holds at most MAX_BODIES). A recording's configuration is read with the same
#: bound, so a bag claiming 10^5 bodies is refused while it is parsed.
MAX_ARRAY_ITEMS = 10 * MAX_BODIES

#: Largest ``dimensions_m`` value and ``mesh_scale`` factor accepted (m, and 1): beyond it the
#: inertia (``m d²``) and contact tolerances leave double precision's useful range.
MAX_SIZE = 1e6

#: Smallest ``dimensions_m`` value accepted, m: over 500 times the float64 spacing of
#: coordinates at :data:`MAX_POSITION_M` (1.9e-9 m), so a body's faces stay apart after
#: ``R x_b + p``; a size of 1e-300 m would put both faces of a plate on one coordinate.
MIN_SIZE = 1e-6

#: Largest ``|initial_position|`` and obstacle ``position`` component accepted, m: there
#: float64 coordinates are 1.9e-9 m apart, six orders below the 1 mm start-overlap tolerance;
#: at 1e300 m a body's surface points all round to its centre.
MAX_POSITION_M = 1e7

#: Largest ``|initial joint position|`` of a robot's joint, rad or m: a continuous joint has
#: no limits to hold it, and at 1e7 rad float64 still resolves 1.9e-9 rad (at 1e300 rad a
#: whole turn is below its spacing); the same number as :data:`MAX_POSITION_M`.
MAX_JOINT_POSITION = 1e7

#: Largest ``|initial joint velocity|`` of a robot's joint, rad/s or m/s: a joint at it covers
#: :data:`MAX_JOINT_POSITION` in 1 s, the longest ``timestep_s``; a rate of 1e200 made the
#: first step non-finite.
MAX_JOINT_RATE = 1e7

_FMT_ITEMS = 8  # a listed value longer than this is cut in messages (one bounded line)
_FMT_CHARS = 200

#: Largest ``*mesh_path`` file accepted (read to build the shape, and embedded in a recording).
MAX_MESH_FILE_BYTES = 64 * 1024 * 1024

#: The box used when neither ``inertia`` nor ``shape`` is given (same as msg_config/default.yaml).
DEFAULT_SHAPE = 'box'
DEFAULT_DIMENSIONS_M = (0.2, 0.1, 0.05)

NS_PER_S = 1_000_000_000  # the one ns-per-second constant of rbd_ros
# A time in seconds must be within this many ns of a whole number of ns: float64 writes decimal
# steps such as 0.001 s with a relative error <= 2^-53, far below 1e-3 ns for any step < 1e3 s.
_NS_TOLERANCE = 1e-3

#: ``real_time_factor`` is 0 (as fast as possible) or within these bounds: below 1e-3 a 1 ms step
#: takes more than 1 s of wall time (a value such as 5e-324 freezes the node), above 1e6 the
#: catch-up cap (a backlog of 1000 steps) drops wall time at any step size.
REAL_TIME_FACTOR_RANGE = (1e-3, 1e6)
#: The slowest publish rate, Hz: a publish period of at most 1e6 s (about 11.6 days).
MIN_PUBLISH_RATE_HZ = 1e-6


@dataclass(frozen=True)
class ParamSpec:
    """
    One public parameter.

    :param name: the ROS parameter name.
    :param kind: one of ``bool``, ``integer``, ``double``, ``string``, ``double_array``,
        ``string_array``.
    :param default: the default value (a tuple for arrays).
    :param unit: SI unit ('' for none).
    :param description: one sentence for ``ros2 param describe`` and ``doc/parameters.md``.
    :param bounds: ``(low, high)`` closed bounds for numbers (also advertised to ROS as
        ``FloatingPointRange``/``IntegerRange``), or None.
    :param read_only: True when a live change would make no sense.
    :param rule: the rule beyond the range, in words (for doc/parameters.md), or ''.
    """

    name: str
    kind: str
    default: object
    unit: str
    description: str
    bounds: tuple = None
    read_only: bool = True
    rule: str = ''


_BIG = 1e12  # upper bound advertised for quantities with no natural limit

PARAMETERS = (
    ParamSpec('mass_kg', DOUBLE, 1.0, 'kg', 'Mass of the body.', (0.0, _BIG), rule='> 0'),
    ParamSpec('inertia', DOUBLE_ARRAY, (), 'kg·m²',
              'Inertia about the COM in body coordinates, [ixx, iyy, izz, ixy, ixz, iyz] '
              '(ROS order); [] = use shape.',
              rule='6 values, positive definite, triangle inequality; not with shape'),
    ParamSpec('shape', STRING, '', '',
              "Alternative to inertia: a core shape ('box', 'sphere', 'cylinder', ...); "
              "'' with inertia [] = a 0.2 x 0.1 x 0.05 m box.", rule='not with inertia'),
    ParamSpec('dimensions_m', DOUBLE_ARRAY, (), 'm',
              'Sizes of shape (box: [x, y, z] edges; sphere, spherical_shell: [radius]; '
              "cylinder, capsule: [radius, length], a capsule's length its cylindrical part; "
              'ellipsoid: [a, b, c] semi-axes).',
              rule='as the shape needs'),
    ParamSpec('initial_position', DOUBLE_ARRAY, (0.0, 0.0, 0.0), 'm',
              'Initial COM position, world frame.', rule='3 finite values'),
    ParamSpec('initial_orientation', DOUBLE_ARRAY, (0.0, 0.0, 0.0, 1.0), '',
              'Initial orientation quaternion [x, y, z, w] (geometry_msgs order), body to '
              'world.', rule='4 finite values, norm within 1e-3 of 1 (then normalised)'),
    ParamSpec('initial_linear_velocity', DOUBLE_ARRAY, (0.0, 0.0, 0.0), 'm/s',
              'Initial COM velocity, world frame.', rule='3 finite values'),
    ParamSpec('initial_angular_velocity', DOUBLE_ARRAY, (0.0, 0.0, 0.0), 'rad/s',
              'Initial angular velocity, body frame.', rule='3 finite values'),
    ParamSpec('gravity', DOUBLE_ARRAY, (0.0, 0.0, 0.0), 'm/s²',
              'Gravitational acceleration, world frame.', rule='3 finite values'),
    ParamSpec('linear_damping', DOUBLE, 0.0, '1/s',
              'Linear velocity decays as exp(-c t) (exact flow).', (0.0, _BIG)),
    ParamSpec('angular_damping', DOUBLE, 0.0, '1/s',
              'Angular velocity decays as exp(-c t) (exact flow).', (0.0, _BIG)),
    ParamSpec('integrator', STRING, DEFAULT_INTEGRATOR, '',
              'Integrator: ' + ', '.join(INTEGRATORS) + '.', rule='one of the names'),
    ParamSpec('timestep_s', DOUBLE, 0.001, 's', 'Fixed physics step.', (0.0, 1.0),
              rule='> 0, a whole number of ns (at least 1 ns)'),
    ParamSpec('publish_rate_hz', DOUBLE, 100.0, 'Hz',
              'State publishing rate in sim time (at most once per physics step).',
              (MIN_PUBLISH_RATE_HZ, 1e9),
              rule=f'>= {MIN_PUBLISH_RATE_HZ:g} (a publish period of at most 1e6 s)'),
    ParamSpec('real_time_factor', DOUBLE, 1.0, '',
              'Sim seconds per wall second; 0 = as fast as possible.', (0.0, 1e6),
              read_only=False, rule='0, or in [0.001, 1e6]'),
    ParamSpec('duration_s', DOUBLE, 0.0, 's',
              'Stop and exit with status 0 after this much sim time; 0 = run until shut down.',
              (0.0, 1e9)),
    ParamSpec('start_paused', BOOL, False, '', 'Start paused (advance with ~/step or ~/pause).'),
    ParamSpec('world_frame', STRING, 'world', '', 'Frame id of the world (inertial) frame.',
              rule='non-empty, no leading / or whitespace, differs from body_frame'),
    ParamSpec('body_frame', STRING, 'base_link', '', 'Frame id of the body frame (at the COM).',
              rule='non-empty, no leading / or whitespace'),
    ParamSpec('twist_frame', STRING, 'world', '',
              "Frame of the twist topic: 'world' or 'body'.", rule="'world' or 'body'"),
    ParamSpec('default_wrench_frame', STRING, 'world', '',
              "How a wrench with an empty frame_id is read: 'world' or 'body'.",
              rule="'world' or 'body'"),
    ParamSpec('wrench_timeout_s', DOUBLE, 0.0, 's',
              'A received wrench is held this long in sim time; 0 = until replaced.',
              (0.0, 1e9)),
    ParamSpec('max_force_n', DOUBLE, 1e6, 'N',
              'Wrenches with a larger |force| are rejected and counted.', (0.0, _BIG),
              rule='> 0'),
    ParamSpec('max_torque_nm', DOUBLE, 1e6, 'N·m',
              'Wrenches with a larger |torque| are rejected and counted.', (0.0, _BIG),
              rule='> 0'),
    ParamSpec('max_drag_point_m', DOUBLE, 1e3, 'm',
              'Drag and /clicked_point points with a larger |point| (world frame) are rejected '
              'and counted; drag springs obey max_force_n and max_torque_nm too.', (0.0, _BIG),
              rule='> 0'),
    ParamSpec('wrench_input_names', STRING_ARRAY, (), '',
              'Names of extra wrench inputs, each with wrench_inputs.<name>.topic, .frame and '
              '.point_b.', rule='distinct names of letters, digits and _'),
    ParamSpec('friction', DOUBLE, 0.5, '',
              'Coulomb friction coefficient μ of the body (a pair: sqrt(μ_a μ_b)).',
              (0.0, _BIG), rule='>= 0'),
    ParamSpec('restitution', DOUBLE, 0.0, '',
              'Coefficient of restitution ε of the body (a pair: the larger).', (0.0, 1.0)),
    ParamSpec('mesh_path', STRING, '', '',
              'Collision and mass shape from a closed STL/OBJ mesh in m (relative to the params '
              "file, or package://); '' = shape.", rule='not with inertia; shape empty or mesh'),
    ParamSpec('mesh_scale', DOUBLE_ARRAY, (1.0, 1.0, 1.0), '',
              'Scale factors x, y, z applied to the mesh_path coordinates.',
              rule='3 factors in [1e-6, 1e6]'),
    ParamSpec('ground.enabled', BOOL, False, '',
              'A static ground plane z = ground.height_m (world frame) the body rests on.'),
    ParamSpec('ground.height_m', DOUBLE, 0.0, 'm', 'Height of the ground plane, world z.',
              (-_BIG, _BIG)),
    ParamSpec('ground.friction', DOUBLE, 0.5, '', 'Coulomb friction coefficient μ of the ground.',
              (0.0, _BIG), rule='>= 0'),
    ParamSpec('ground.restitution', DOUBLE, 0.0, '', 'Coefficient of restitution ε of the ground.',
              (0.0, 1.0)),
    ParamSpec('obstacle_names', STRING_ARRAY, (), '',
              'Names of static obstacles, each with obstacles.<name>.shape, .dimensions_m, '
              '.mesh_path, .mesh_scale, .position, .orientation, .friction and .restitution.',
              rule='distinct names of letters, digits and _'),
    ParamSpec('drag_point_b', DOUBLE_ARRAY, (0.0, 0.0, 0.0), 'm',
              'Where a drag (topic drag) holds the body, body frame, relative to the COM.',
              rule='3 finite values'),
    ParamSpec('drag_stiffness_n_per_m', DOUBLE, 50.0, 'N/m',
              'Stiffness k of the zero-length drag spring (drag, /clicked_point).',
              (0.0, _BIG)),
    ParamSpec('drag_damping_n_s_per_m', DOUBLE, 5.0, 'N·s/m',
              'Damping c of the drag spring: f = -k d - c v at the held point.', (0.0, _BIG)),
    ParamSpec('drag_click_radius_m', DOUBLE, 0.05, 'm',
              'A /clicked_point this near a body surface grabs it there.', (0.0, _BIG)),
    ParamSpec('body_names', STRING_ARRAY, (), '',
              'Names of the bodies of a world, each with bodies.<name>.* (the per-body '
              'parameters above); [] = one body from the parameters above.',
              rule='distinct names of letters, digits and _; not with per-body parameters'),
    ParamSpec('joint_names', STRING_ARRAY, (), '',
              'Joints between the bodies of a world (body_names), each with joints.<name>.* '
              '(see doc/joints.md).', rule='distinct names of letters, digits and _'),
    ParamSpec('robot_names', STRING_ARRAY, (), '',
              'Robots read from URDF, each with robots.<name>.* (see doc/robots.md).',
              rule='distinct names of letters, digits and _, none in body_names'),
    ParamSpec('command_group_names', STRING_ARRAY, (), '',
              'Joint groups commanded as forward_command_controller and '
              'joint_trajectory_controller are, each with command_groups.<name>.*.',
              rule='distinct names of letters, digits and _'),
    ParamSpec('publish_markers', BOOL, True, '',
              'With contact: publish markers (bodies, contacts) and static_markers (ground, '
              'obstacles) for RViz and Foxglove.'),
    ParamSpec('per_body_topics', BOOL, True, '',
              "A world's per-body output topics (<body>/pose, twist, odom, contact_wrench); "
              'false leaves poses, /tf, markers and the inputs.',
              rule='true without body_names'),
    ParamSpec('threads', INTEGER, usable_cores(), '',
              "Threads a world's contact step may use (groups of bodies out of each other's "
              'reach on threads, the same bits whatever the count); default: the CPUs this '
              'process may use.', (1, MAX_THREADS), rule='>= 1'),
    ParamSpec('publish_clock', BOOL, False, '', 'Publish /clock (sim time).'),
    ParamSpec('publish_tf', BOOL, True, '',
              'Broadcast world -> body on /tf (only when tf2_msgs is importable).'),
    ParamSpec('record_path', STRING, '', '', "Record the run to this MCAP path; '' = off."),
    ParamSpec('record_overwrite', BOOL, False, '',
              'Allow record_path to replace an existing recording.'),
    ParamSpec('record_on_error', STRING, 'continue', '',
              "When a recording write fails mid-run (disk full, ...): 'continue' simulating "
              "without recording, or 'stop' the node; either way the exit status is 1.",
              rule="'continue' or 'stop'"),
)

PARAMETERS_BY_NAME = {spec.name: spec for spec in PARAMETERS}

#: The list parameters renamed so that no parameter name is the prefix of another (at a '.'):
#: ``ros2 param dump`` nests names on '.', and a list cannot hold its items (``bodies`` and
#: ``bodies.a.mass_kg``). Old name → new name; the items (``bodies.<name>.*``,
#: ``obstacles.<name>.*``, ``wrench_inputs.<name>.*``) keep their names. Per body,
#: ``bodies.<name>.wrench_inputs`` became ``bodies.<name>.wrench_input_names``.
RENAMED_PARAMETERS = {'bodies': 'body_names', 'obstacles': 'obstacle_names',
                      'wrench_inputs': 'wrench_input_names'}


def new_parameter_name(name):
    """Return the new name of the renamed parameter ``name``, or None if it was not renamed."""
    if name in RENAMED_PARAMETERS:
        return RENAMED_PARAMETERS[name]
    parts = name.split('.')
    if len(parts) == 3 and parts[0] == 'bodies' and parts[2] == 'wrench_inputs':
        return f'bodies.{parts[1]}.wrench_input_names'
    return None


#: A robot joint's parameters that recordings made before joint damping and friction were
#: simulated lack: those runs simulated them as 0, whatever the URDF's ``<dynamics>`` said.
JOINT_DYNAMICS_PARAMETERS = ('damping', 'friction')


def recorded_parameters(params):
    """
    Return the parameters of a recording under today's names (the one place that reads old ones).

    A recording stores the node's parameters under the names of the day it was made; a
    recording made before :data:`RENAMED_PARAMETERS` reads as if made today. Other names pass
    through unchanged (:meth:`NodeConfig.from_parameters` judges them). Every recording of a
    robot holds each moving joint's ``robots.<name>.joints.<joint>.position_time_constant_s``;
    one without that joint's :data:`JOINT_DYNAMICS_PARAMETERS` was made when they were not
    simulated, so they read as 0 (not the URDF's ``<dynamics>``, which that run ignored).

    :raises ConfigError: an old name and its new one both in ``params`` (no recording holds
        both; which list would be meant?).
    """
    today = {name: new_parameter_name(name) or name for name in params}
    for name in sorted(params):
        new = today[name]
        if new != name and new in params:
            raise ConfigError(
                f'parameters {name} = {fmt(params[name])} and {new} = {fmt(params[new])}: one '
                f'list under its old and its new name ({name} was renamed to {new}); a '
                'recording holds one of them')
    out = {today[name]: value for name, value in params.items()}
    suffix = '.position_time_constant_s'
    for name in [name for name in out if name.startswith('robots.') and name.endswith(suffix)]:
        for field in JOINT_DYNAMICS_PARAMETERS:
            out.setdefault(f'{name[:-len(suffix)]}.{field}', 0.0)
    return out


def refuse_old_names(params):
    """Refuse a renamed parameter with one line naming its new name (a params file of old)."""
    for name in sorted(params):
        new = new_parameter_name(name)
        if new is not None:
            raise ConfigError(
                f'parameter {name} = {fmt(params[name])}: renamed to {new} (a list is never '
                f'the prefix of its items; the items {name}.<name>.* keep their names)')


# Parameters of the body model: their errors are ModelError, the others' ConfigError.
_MODEL_PARAMETERS = frozenset((
    'mass_kg', 'inertia', 'shape', 'dimensions_m', 'gravity', 'linear_damping',
    'angular_damping', 'friction', 'restitution', 'mesh_path', 'mesh_scale', 'ground.friction',
    'ground.restitution'))


def input_parameter_specs(name):
    """
    Return the three :class:`ParamSpec` of the extra wrench input ``name``.

    ``wrench_inputs.<name>.topic`` (default ``wrench_<name>``, relative), ``.frame``
    (``'world'``/``'body'``: how a message with an empty ``frame_id`` is read, default ``body``)
    and ``.point_b`` (application point of the force in body coordinates, m, default the COM).
    """
    prefix = f'wrench_inputs.{name}.'
    return (
        ParamSpec(prefix + 'topic', STRING, f'wrench_{name}', '',
                  f'Topic of wrench input {name!r} (relative name).', rule='non-empty'),
        ParamSpec(prefix + 'frame', STRING, 'body', '',
                  f"How wrench input {name!r} reads an empty frame_id: 'world' or 'body'.",
                  rule="'world' or 'body'"),
        ParamSpec(prefix + 'point_b', DOUBLE_ARRAY, (0.0, 0.0, 0.0), 'm',
                  f'Application point of input {name!r}, body frame, relative to the COM.',
                  rule='3 finite values'),
    )


#: The per-body parameters: in a world each body has them as ``bodies.<name>.<parameter>``.
BODY_PARAMETERS = (
    'mass_kg', 'inertia', 'shape', 'dimensions_m', 'mesh_path', 'mesh_scale', 'friction',
    'restitution', 'initial_position', 'initial_orientation', 'initial_linear_velocity',
    'initial_angular_velocity', 'linear_damping', 'angular_damping', 'body_frame',
    'drag_point_b', 'wrench_input_names')


def body_parameter_specs(name):
    """
    Return the :class:`ParamSpec` of body ``name`` of a world (``bodies.<name>.*``).

    The per-body parameters of the table (:data:`BODY_PARAMETERS`), with the same types,
    defaults, units and rules, except ``body_frame``, whose default is the body's name.
    """
    prefix = f'bodies.{name}.'
    specs = []
    for base in BODY_PARAMETERS:
        spec = PARAMETERS_BY_NAME[base]
        default = name if base == 'body_frame' else spec.default
        specs.append(ParamSpec(prefix + base, spec.kind, default, spec.unit,
                               f'Body {name!r}: {spec.description[0].lower()}'
                               f'{spec.description[1:]}', spec.bounds, spec.read_only,
                               spec.rule))
    return tuple(specs)


def obstacle_parameter_specs(name):
    """
    Return the :class:`ParamSpec` of the static obstacle ``name`` (``obstacles.<name>.*``).

    Its shape (a primitive with ``dimensions_m``, or ``mesh`` with ``mesh_path`` and
    ``mesh_scale``), its pose in the world frame (``position``, ``orientation`` [x, y, z, w])
    and its material.
    """
    prefix = f'obstacles.{name}.'
    return (
        ParamSpec(prefix + 'shape', STRING, 'box', '',
                  f"Shape of obstacle {name!r}: a primitive ('box', 'sphere', 'cylinder', "
                  "'capsule', 'ellipsoid') or 'mesh'.", rule='one of the names'),
        ParamSpec(prefix + 'dimensions_m', DOUBLE_ARRAY, (), 'm',
                  f'Sizes of obstacle {name!r} (as dimensions_m of the body).',
                  rule='as the shape needs'),
        ParamSpec(prefix + 'mesh_path', STRING, '', '',
                  f"Mesh file of obstacle {name!r} when its shape is 'mesh'.",
                  rule='a closed STL/OBJ mesh'),
        ParamSpec(prefix + 'mesh_scale', DOUBLE_ARRAY, (1.0, 1.0, 1.0), '',
                  f'Scale factors x, y, z of the mesh of obstacle {name!r}.',
                  rule='3 factors in [1e-6, 1e6]'),
        ParamSpec(prefix + 'position', DOUBLE_ARRAY, (0.0, 0.0, 0.0), 'm',
                  f'Position of obstacle {name!r} (its shape frame), world frame.',
                  rule='3 finite values'),
        ParamSpec(prefix + 'orientation', DOUBLE_ARRAY, (0.0, 0.0, 0.0, 1.0), '',
                  f'Orientation of obstacle {name!r}, quaternion [x, y, z, w].',
                  rule='4 finite values, norm within 1e-3 of 1'),
        ParamSpec(prefix + 'friction', DOUBLE, 0.5, '',
                  f'Coulomb friction coefficient μ of obstacle {name!r}.', (0.0, _BIG),
                  rule='>= 0'),
        ParamSpec(prefix + 'restitution', DOUBLE, 0.0, '',
                  f'Coefficient of restitution ε of obstacle {name!r}.', (0.0, 1.0)),
    )


def fmt(value):
    """Format a parameter value for a one-line message; a list longer than 8 is cut."""
    if isinstance(value, (list, tuple, np.ndarray)):
        if len(value) > _FMT_ITEMS:
            return ('[' + ', '.join(fmt(v) for v in value[:3])
                    + f', ... ({len(value)} values)]')
        return '[' + ', '.join(fmt(v) for v in value) + ']'
    if isinstance(value, str) and len(value) > _FMT_CHARS:
        return repr(value[:_FMT_CHARS]) + f'... ({len(value)} characters)'
    if isinstance(value, float):
        return repr(value)
    return repr(value)


def fail(spec, value, rule, error=None):
    """Raise the one-line error of a bad value: parameter, value, unit and rule."""
    if error is None:  # a body's own parameter (bodies.<name>.mass_kg) is its base's kind
        base = spec.name.split('.', 2)[2] if spec.name.startswith('bodies.') else spec.name
        error = ModelError if base in _MODEL_PARAMETERS else ConfigError
    unit = f' {spec.unit}' if spec.unit else ''
    raise error(f'parameter {spec.name} = {fmt(value)}{unit}: {rule}', field=spec.name,
                value=value, unit=spec.unit, detail=f'{fmt(value)}{unit}: {rule}', rule=rule)


def coerce(spec, value):
    """Return ``value`` as the Python type of ``spec`` or raise ConfigError."""
    kind = spec.kind
    if kind == BOOL:
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        fail(spec, value, 'must be true or false')
    if kind == INTEGER:
        if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
            return int(value)
        fail(spec, value, 'must be an integer')
    if kind == DOUBLE:
        if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
                value, bool):
            value = float(value)
            if not math.isfinite(value):
                fail(spec, value, 'must be finite')
            return value
        fail(spec, value, 'must be a number')
    if kind == STRING:
        if isinstance(value, str):
            return value
        fail(spec, value, 'must be a string')
    if kind in (DOUBLE_ARRAY, STRING_ARRAY) and value is None:
        return ()  # an empty array given in YAML or on the command line arrives as NOT_SET
    if kind in (DOUBLE_ARRAY, STRING_ARRAY) and isinstance(value, (list, tuple, np.ndarray)) \
            and len(value) > MAX_ARRAY_ITEMS:
        fail(spec, value, f'more than {MAX_ARRAY_ITEMS} items (rbd_ros.sim.params.'
             'MAX_ARRAY_ITEMS)')
    if kind == DOUBLE_ARRAY:
        if isinstance(value, (list, tuple, np.ndarray)) and all(
                isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
                for v in value):
            out = tuple(float(v) for v in value)
            if not all(math.isfinite(v) for v in out):
                fail(spec, value, 'must be finite')
            return out
        fail(spec, value, 'must be a list of numbers')
    if kind == STRING_ARRAY:
        if isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
            return tuple(value)
        fail(spec, value, 'must be a list of strings')
    raise AssertionError(kind)  # pragma: no cover - the table only uses the kinds above


def frame_id_problem(frame):
    """
    Return why ``frame`` cannot be a tf2 frame id, or None.

    tf2 refuses an empty id and one starting with ``/`` (``lookupTransform`` raises "frame_ids
    cannot start with a '/'"); a whitespace or control character (a NUL ends the id in C)
    would make a frame that no one can name back.
    """
    if not frame:
        return 'must not be empty'
    if frame.startswith('/'):
        return "must not start with '/' (tf2 refuses such frame ids)"
    for index, char in enumerate(frame):
        if char.isspace() or not char.isprintable():
            return (f'holds {char!r} at index {index}: a frame id has no whitespace or '
                    'control characters')
    return None


def check_range(spec, value):
    """
    Refuse a number outside ``spec.bounds``: the one home of every range and ``> 0`` rule.

    A rule that starts with ``> `` excludes its lower bound (``mass_kg``, ``timestep_s``, ...).
    """
    if spec.bounds is not None:
        low, high = spec.bounds
        if spec.rule and (value < low or value == low and spec.rule.startswith('> ')):
            fail(spec, value, f'must be {spec.rule}')
        if not low <= value <= high:
            fail(spec, value, f'must be {range_rule(spec)}')


def range_rule(spec):
    """
    Return the words of ``spec``'s whole numeric rule: ``> 0 and <= 1e+12``, ``in [0, 1]``.

    A rule that starts with ``> `` or ``>= `` gives the lower side (``mass_kg`` excludes 0,
    which ``bounds`` cannot say), the bounds the upper.
    """
    low, high = spec.bounds
    if spec.rule.startswith(('> ', '>= ')):
        return f'{spec.rule.split(",")[0]} and <= {high:g}'
    return f'in [{low:g}, {high:g}]'


def to_ns(spec, seconds):
    """Return ``seconds`` of ``spec`` as whole ns, or refuse it (not whole, or rounding to 0)."""
    ns = seconds * NS_PER_S
    rounded = round(ns)
    if abs(ns - rounded) > _NS_TOLERANCE:
        fail(spec, seconds, 'must be a whole number of nanoseconds')
    if seconds > 0.0 and rounded == 0:
        zero = '' if spec.name == 'timestep_s' else '0 or '
        fail(spec, seconds, f'rounds to 0 ns: must be {zero}at least 1 ns (1e-9 s)')
    return int(rounded)


def check_real_time_factor(value):
    """
    Return ``value`` as a float if it is a valid ``real_time_factor``, else raise ConfigError.

    Used at start and for a live ``ros2 param set``: 0 (as fast as possible) or within
    :data:`REAL_TIME_FACTOR_RANGE`.
    """
    spec = PARAMETERS_BY_NAME['real_time_factor']
    value = coerce(spec, value)
    low, high = REAL_TIME_FACTOR_RANGE
    if value != 0.0 and not low <= value <= high:
        fail(spec, value, f'must be 0 (as fast as possible) or in [{low:g}, {high:g}]')
    return value


def vector3(spec, values):
    """Return ``values`` if it holds 3 values, else refuse it naming ``spec``."""
    if len(values) != 3:
        fail(spec, list(values), 'must have 3 values')
    return values


def position3(spec, values):
    """Return ``values`` if it is a position of 3 values within :data:`MAX_POSITION_M`."""
    vector3(spec, values)
    if any(not abs(v) <= MAX_POSITION_M for v in values):
        fail(spec, list(values), f'every component must be within ±{MAX_POSITION_M:g} m '
             '(float64 coordinates keep sub-micrometre resolution there)')
    return values


def unit_quaternion(spec, q_xyzw):
    """
    Return ``q_xyzw`` ([x, y, z, w], norm within 1e-3 of 1) as a unit ``(w, x, y, z)`` tuple.

    The one check of every orientation parameter (bodies, obstacles, robots' roots).
    """
    if len(q_xyzw) != 4:
        fail(spec, list(q_xyzw), 'must have 4 values [x, y, z, w]')
    norm = math.hypot(*q_xyzw)  # scaled: the norm of [1e300, 0, 0, 1e300] is not inf
    if abs(norm - 1.0) > 1e-3:
        fail(spec, list(q_xyzw),
             f'norm {norm:.6g} must be within 1e-3 of 1 ([x, y, z, w] order)')
    x, y, z, w = (float(v) / norm for v in q_xyzw)
    return (w, x, y, z)


def check_min_size(spec, dims):
    """Refuse a ``dimensions_m`` value below :data:`MIN_SIZE` (finite, > 0 is the core's)."""
    small = [v for v in dims if 0.0 < v < MIN_SIZE]
    if small:
        fail(spec, list(dims), f'{small[0]!r} m is below the smallest size {MIN_SIZE:g} m '
             '(faces closer than float64 resolves at the largest positions)', ModelError)
