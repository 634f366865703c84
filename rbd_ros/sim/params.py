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
The parameter table: every public parameter's name, type, default, unit, range and rule.

:data:`PARAMETERS` is the one table of the public parameter interface: name, type, default,
unit, description, allowed range and whether it is read-only. The node declares its ROS
parameters from it (:mod:`rbd_ros.ros.parameters`),
:meth:`rbd_ros.sim.config.NodeConfig.from_parameters` validates against it, and a test checks
that the parameter tables of ``doc/parameters.md`` list exactly these names with these defaults
and units. The per-body, per-obstacle and
per-input rows are made by :func:`body_parameter_specs`, :func:`obstacle_parameter_specs` and
:func:`input_parameter_specs`.

Beside it, one module each, all importable from here too: the rule of every value
(:mod:`rbd_ros.sim.param_rules`: :class:`ParamSpec` and its types, coercion, ranges, seconds to
ns, :func:`fail`, the one shape of a bad-value message), the bounds on sizes and counts
(:mod:`rbd_ros.sim.limits`) and the renamed parameters (:mod:`rbd_ros.sim.param_renames`).
"""

from rbd_ros.core import DEFAULT_INTEGRATOR, INTEGRATORS
from rbd_ros.core.simulator import usable_cores
from rbd_ros.sim.limits import (  # noqa: F401 (importable from here, as before)
    MAX_ARRAY_ITEMS, MAX_BODIES, MAX_JOINT_POSITION, MAX_JOINT_RATE, MAX_MESH_FILE_BYTES,
    MAX_POSITION_M, MAX_SIZE, MIN_SIZE)
from rbd_ros.sim.limits import MAX_THREADS
from rbd_ros.sim.param_renames import (  # noqa: F401 (importable from here, as before)
    JOINT_DYNAMICS_PARAMETERS, new_parameter_name, recorded_parameters, refuse_old_names,
    RENAMED_PARAMETERS)
from rbd_ros.sim.param_rules import (BOOL, coerce, DOUBLE, DOUBLE_ARRAY, fail, INTEGER,
                                     ParamSpec, STRING, STRING_ARRAY)
from rbd_ros.sim.param_rules import (  # noqa: F401 (importable from here, as before)
    check_min_size, check_range, fmt, frame_id_problem, NS_PER_S, position3, range_rule, to_ns,
    unit_quaternion, vector3)

#: Frame keywords accepted by ``twist_frame``, ``default_wrench_frame`` and ``.frame``.
FRAME_KEYWORDS = ('world', 'body')

#: Name of the main wrench input (topic ``wrench``) in :class:`rbd_ros.sim.inputs.WrenchInputs`.
MAIN_INPUT = 'wrench'

#: The box used when neither ``inertia`` nor ``shape`` is given (same as msg_config/default.yaml).
DEFAULT_SHAPE = 'box'
DEFAULT_DIMENSIONS_M = (0.2, 0.1, 0.05)

#: ``real_time_factor`` is 0 (as fast as possible) or within these bounds: below 1e-3 a 1 ms step
#: takes more than 1 s of wall time (a value such as 5e-324 freezes the node), above 1e6 the
#: catch-up cap (a backlog of 1000 steps) drops wall time at any step size.
REAL_TIME_FACTOR_RANGE = (1e-3, 1e6)
#: The slowest publish rate, Hz: a publish period of at most 1e6 s (about 11.6 days).
MIN_PUBLISH_RATE_HZ = 1e-6


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
