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
import math
import os
import stat
import sys

import numpy as np

from rbd_ros.core import (BodyModel, BodyState, ConfigError, DEFAULT_INTEGRATOR, INTEGRATORS,
                          ModelError, NonFiniteError, Simulator)
from rbd_ros.core.contact.shapes import load_mesh, primitive_shape, PRIMITIVES
from rbd_ros.core.contact.simulator import CONTACT_INTEGRATORS, WorldBody, WorldSimulator
from rbd_ros.core.contact.world import (check_overlaps, ground_plane, obstacle, StaticWorld,
                                        validate_material)
from rbd_ros.core.inertia import from_shape, inertia_from_components, SHAPES

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

#: Largest ``dimensions_m`` value and ``mesh_scale`` factor accepted (m, and 1): beyond it the
#: inertia (``m d²``) and contact tolerances leave double precision's useful range.
MAX_SIZE = 1e6

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
              'Sizes of shape (box: [x, y, z]; sphere: [radius]; cylinder: [radius, length]).',
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
              (0.0, 1e9), rule='>= 1e-6'),
    ParamSpec('real_time_factor', DOUBLE, 1.0, '',
              'Sim seconds per wall second; 0 = as fast as possible.', (0.0, 1e6),
              read_only=False, rule='0, or in [0.001, 1e6]'),
    ParamSpec('duration_s', DOUBLE, 0.0, 's',
              'Stop and exit with status 0 after this much sim time; 0 = run until shut down.',
              (0.0, 1e9)),
    ParamSpec('start_paused', BOOL, False, '', 'Start paused (advance with ~/step or ~/pause).'),
    ParamSpec('world_frame', STRING, 'world', '', 'Frame id of the world (inertial) frame.',
              rule='non-empty, differs from body_frame'),
    ParamSpec('body_frame', STRING, 'base_link', '', 'Frame id of the body frame (at the COM).',
              rule='non-empty'),
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
              rule='3 finite values > 0'),
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
    ParamSpec('publish_markers', BOOL, True, '',
              'With contact: publish markers (bodies, contacts) and static_markers (ground, '
              'obstacles) for RViz and Foxglove.'),
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


def recorded_parameters(params):
    """
    Return the parameters of a recording under today's names (the one place that reads old ones).

    A recording stores the node's parameters under the names of the day it was made; a
    recording made before :data:`RENAMED_PARAMETERS` reads as if made today. Other names pass
    through unchanged (:meth:`NodeConfig.from_parameters` judges them).
    """
    return {new_parameter_name(name) or name: value for name, value in params.items()}


def _refuse_old_names(params):
    """Refuse a renamed parameter with one line naming its new name (a params file of old)."""
    for name in sorted(params):
        new = new_parameter_name(name)
        if new is not None:
            raise ConfigError(
                f'parameter {name} = {_fmt(params[name])}: renamed to {new} (a list is never '
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
                  rule='3 finite values > 0'),
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


def _fmt(value):
    """Format a parameter value for a one-line message; a list longer than 8 is cut."""
    if isinstance(value, (list, tuple, np.ndarray)):
        if len(value) > _FMT_ITEMS:
            return ('[' + ', '.join(_fmt(v) for v in value[:3])
                    + f', ... ({len(value)} values)]')
        return '[' + ', '.join(_fmt(v) for v in value) + ']'
    if isinstance(value, str) and len(value) > _FMT_CHARS:
        return repr(value[:_FMT_CHARS]) + f'... ({len(value)} characters)'
    if isinstance(value, float):
        return repr(value)
    return repr(value)


def _fail(spec, value, rule, error=None):
    if error is None:
        error = ModelError if spec.name in _MODEL_PARAMETERS else ConfigError
    unit = f' {spec.unit}' if spec.unit else ''
    raise error(f'parameter {spec.name} = {_fmt(value)}{unit}: {rule}')


def _coerce(spec, value):
    """Return ``value`` as the Python type of ``spec`` or raise ConfigError."""
    kind = spec.kind
    if kind == BOOL:
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        _fail(spec, value, 'must be true or false')
    if kind == INTEGER:
        if isinstance(value, (int, np.integer)) and not isinstance(value, bool):
            return int(value)
        _fail(spec, value, 'must be an integer')
    if kind == DOUBLE:
        if isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(
                value, bool):
            value = float(value)
            if not math.isfinite(value):
                _fail(spec, value, 'must be finite')
            return value
        _fail(spec, value, 'must be a number')
    if kind == STRING:
        if isinstance(value, str):
            return value
        _fail(spec, value, 'must be a string')
    if kind in (DOUBLE_ARRAY, STRING_ARRAY) and value is None:
        return ()  # an empty array given in YAML or on the command line arrives as NOT_SET
    if kind == DOUBLE_ARRAY:
        if isinstance(value, (list, tuple, np.ndarray)) and all(
                isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool)
                for v in value):
            out = tuple(float(v) for v in value)
            if not all(math.isfinite(v) for v in out):
                _fail(spec, value, 'must be finite')
            return out
        _fail(spec, value, 'must be a list of numbers')
    if kind == STRING_ARRAY:
        if isinstance(value, (list, tuple)) and all(isinstance(v, str) for v in value):
            return tuple(value)
        _fail(spec, value, 'must be a list of strings')
    raise AssertionError(kind)  # pragma: no cover - the table only uses the kinds above


def _check_range(spec, value):
    if spec.bounds is not None:
        low, high = spec.bounds
        if value < low and spec.rule:
            _fail(spec, value, f'must be {spec.rule}')
        if not low <= value <= high:
            _fail(spec, value, f'must be in [{low:g}, {high:g}]')


def _to_ns(spec, seconds):
    ns = seconds * NS_PER_S
    rounded = round(ns)
    if abs(ns - rounded) > _NS_TOLERANCE:
        _fail(spec, seconds, 'must be a whole number of nanoseconds')
    if seconds > 0.0 and rounded == 0:
        zero = '' if spec.name == 'timestep_s' else '0 or '
        _fail(spec, seconds, f'rounds to 0 ns: must be {zero}at least 1 ns (1e-9 s)')
    return int(rounded)


def check_real_time_factor(value):
    """
    Return ``value`` as a float if it is a valid ``real_time_factor``, else raise ConfigError.

    Used at start and for a live ``ros2 param set``: 0 (as fast as possible) or within
    :data:`REAL_TIME_FACTOR_RANGE`.
    """
    spec = PARAMETERS_BY_NAME['real_time_factor']
    value = _coerce(spec, value)
    low, high = REAL_TIME_FACTOR_RANGE
    if value != 0.0 and not low <= value <= high:
        _fail(spec, value, f'must be 0 (as fast as possible) or in [{low:g}, {high:g}]')
    return value


def _vector3(spec, values):
    if len(values) != 3:
        _fail(spec, list(values), 'must have 3 values')
    return values


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

    @property
    def named(self):
        """
        Return True when the bodies are addressed by name (``body_names`` given).

        Their topics, inputs and parameters then carry the name, and a ``poses`` array holds
        every pose; the body of a single-body file has none of that (its prefixes are ``''``).
        """
        return bool(self.parameters['body_names'])

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
    def from_parameters(cls, params=None):
        """
        Validate ``params`` (name → value; missing names take their defaults) into a config.

        :raises ConfigError: an unknown name, a wrong type, a value out of range, an unknown
            integrator or frame keyword, a step that is not a whole number of ns, ...
        :raises ModelError: a mass or inertia the core rejects (not positive definite,
            triangle inequality), both ``inertia`` and ``shape`` given, ...
        :raises ConfigError: a renamed parameter under its old name (:data:`RENAMED_PARAMETERS`;
            a recording's parameters go through :func:`recorded_parameters` first).
        """
        params = dict(params or {})
        _refuse_old_names(params)
        values = _table_values(params)
        input_names = _input_values(values, params)
        obstacle_names = _obstacle_values(values, params)
        body_inputs = _body_values(values, params)
        if params:
            unknown = sorted(params)[0]
            raise ConfigError(
                f'parameter {unknown} = {_fmt(params[unknown])}: unknown parameter name '
                '(known: see doc/parameters.md; wrench input, obstacle and body parameters need '
                'their name in wrench_input_names, obstacle_names or body_names)')
        time_settings = _time_settings(values)
        static_world = _static_world(values, obstacle_names)
        integrator = time_settings['integrator']
        if body_inputs:
            bodies = _world_bodies(values, body_inputs, static_world, integrator)
            settings = {**_frame_settings(values, bodies), **_limits_and_recording(values)}
        else:
            body = _single_body(values, static_world, integrator)
            settings = {**_frame_settings(values), **_limits_and_recording(values)}
            bodies = (dataclass_replace(
                body, wrench_inputs=_wrench_inputs(values, input_names),
                material=_reraise(PARAMETERS_BY_NAME['friction'], values['friction'],
                                  validate_material, values['friction'], values['restitution'])),)
        return cls(bodies=bodies, **time_settings, **settings, parameters=values,
                   static_world=static_world)

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
        return tuple(specs)


def _table_values(params):
    """Take the table's parameters out of ``params`` (defaults for the missing ones); coerce."""
    values = {}
    for spec in PARAMETERS:
        value = _coerce(spec, params.pop(spec.name, spec.default))
        if spec.kind in (DOUBLE, INTEGER):
            _check_range(spec, value)
        values[spec.name] = value
    return values


def _input_values(values, params):
    """Check ``wrench_input_names``; move each input's parameters from ``params`` to ``values``."""
    spec = PARAMETERS_BY_NAME['wrench_input_names']
    names = values['wrench_input_names']
    for name in names:
        if not name or not (name.replace('_', 'a').isalnum() and name.isascii()):
            _fail(spec, list(names), f'input name {name!r} must be letters, digits and _')
        if name == MAIN_INPUT:
            _fail(spec, list(names), f'{MAIN_INPUT!r} is the main input')
    if len(set(names)) != len(names):
        _fail(spec, list(names), 'names must be distinct')
    for name in names:
        for input_spec in input_parameter_specs(name):
            values[input_spec.name] = _coerce(
                input_spec, params.pop(input_spec.name, input_spec.default))
    return names


def _obstacle_values(values, params):
    """Check ``obstacle_names``; move each obstacle's parameters from ``params`` to ``values``."""
    spec = PARAMETERS_BY_NAME['obstacle_names']
    names = values['obstacle_names']
    for name in names:
        if not name or not (name.replace('_', 'a').isalnum() and name.isascii()) \
                or name[0].isdigit():
            _fail(spec, list(names), f'obstacle name {name!r} must be letters, digits and _ '
                  '(not starting with a digit)')
        if name == 'ground':
            _fail(spec, list(names), "'ground' is the ground plane (ground.*)")
    if len(set(names)) != len(names):
        _fail(spec, list(names), 'names must be distinct')
    for name in names:
        for obstacle_spec in obstacle_parameter_specs(name):
            value = _coerce(obstacle_spec, params.pop(obstacle_spec.name, obstacle_spec.default))
            if obstacle_spec.kind == DOUBLE:
                _check_range(obstacle_spec, value)
            values[obstacle_spec.name] = value
    return names


def _body_input_specs(body, name):
    """Return the specs of the extra wrench input ``name`` of world body ``body``."""
    return tuple(dataclass_replace(spec, name=f'bodies.{body}.{spec.name}')
                 for spec in input_parameter_specs(name))


def _check_names(spec, names, what):
    for name in names:
        if not name or not (name.replace('_', 'a').isalnum() and name.isascii()) \
                or name[0].isdigit():
            _fail(spec, list(names), f'{what} name {name!r} must be letters, digits and _ '
                  '(not starting with a digit)')
    if len(set(names)) != len(names):
        _fail(spec, list(names), 'names must be distinct')


def _body_values(values, params):
    """
    Check ``body_names``; take each body's parameters out of ``params`` into ``values``.

    Returns ``{body: its extra input names}`` (empty without ``body_names``).
    """
    names = values['body_names']
    if len(names) > MAX_BODIES:
        _fail(PARAMETERS_BY_NAME['body_names'], list(names),
              f'{len(names)} bodies exceed the limit of {MAX_BODIES}')
    _check_names(PARAMETERS_BY_NAME['body_names'], names, 'body')
    out = {}
    for name in names:
        for spec in body_parameter_specs(name):
            value = _coerce(spec, params.pop(spec.name, spec.default))
            if spec.kind in (DOUBLE, INTEGER):
                _check_range(spec, value)
            values[spec.name] = value
        inputs_spec = PARAMETERS_BY_NAME['wrench_input_names']
        inputs = values[f'bodies.{name}.wrench_input_names']
        try:
            _check_names(inputs_spec, inputs, 'input')
            if MAIN_INPUT in inputs:
                _fail(inputs_spec, list(inputs), f'{MAIN_INPUT!r} is the main input')
        except ConfigError as exc:
            raise ConfigError(str(exc).replace('parameter wrench_input_names',
                                               f'parameter bodies.{name}.wrench_input_names'))
        for input_name in inputs:
            for spec in _body_input_specs(name, input_name):
                values[spec.name] = _coerce(spec, params.pop(spec.name, spec.default))
        out[name] = inputs
    return out


def _renamed(body, exc):
    """Return ``exc`` (ModelError/ConfigError) with per-body parameter names prefixed."""
    message = str(exc)
    for base in sorted(BODY_PARAMETERS, key=len, reverse=True):
        message = message.replace(f'parameter {base}', f'parameter bodies.{body}.{base}')
    return type(exc)(message)


def _world_bodies(values, body_inputs, static_world, integrator):
    """Build every body of a world; refuse top-level per-body values and overlaps."""
    for base in BODY_PARAMETERS:
        spec = PARAMETERS_BY_NAME[base]
        if values[base] != spec.default:
            _fail(spec, values[base], f'with body_names, each body has its own: set '
                  f'bodies.<name>.{base} instead')
    if integrator not in CONTACT_INTEGRATORS:
        _fail(PARAMETERS_BY_NAME['integrator'], integrator,
              'cannot take contact (a world of bodies): use one of '
              + ', '.join(CONTACT_INTEGRATORS))
    bodies = []
    for name, inputs in body_inputs.items():
        sub = dict(values)
        for base in BODY_PARAMETERS:
            sub[base] = values[f'bodies.{name}.{base}']
        for input_name in inputs:
            for spec in input_parameter_specs(input_name):
                sub[spec.name] = values[f'bodies.{name}.{spec.name}']
        try:
            collision = _collision_shape(sub)
            model = _model(sub, collision)
            state = _initial_state(sub)
            if collision is None:
                raise ModelError(
                    f'parameter inertia = {_fmt(sub["inertia"])} kg·m²: a body given only by '
                    'its inertia has no collision shape; give shape and dimensions_m, or '
                    'mesh_path')
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
                                 _vector3(point_spec, sub['drag_point_b']),
                                 prefix=f'{name}/', parameter_prefix=f'bodies.{name}.'))
    try:
        check_overlaps([(b.name, b.collision_shape, b.initial_state.position_w,
                         b.initial_state.orientation_wb) for b in bodies], static_world)
    except ModelError as exc:
        # 'bodies.<name>.position_w: [..] m puts ...' → name the parameter.
        message = str(exc)
        head, _, rest = message.partition('.position_w: ')
        raise ModelError(f'parameter {head}.initial_position = {rest}') from None
    return tuple(bodies)


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
                     f'the ament index (source its workspace) nor in {share}')


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
        raise ModelError(f'{where} does not exist or is not a file ({exc.strerror})') from None
    info = os.fstat(fd)
    problem = None
    if not stat.S_ISREG(info.st_mode):
        problem = 'is not a regular file (a mesh file is read whole)'
    elif info.st_size > MAX_MESH_FILE_BYTES:
        problem = (f'is {info.st_size} bytes, more than the limit of {MAX_MESH_FILE_BYTES} '
                   'bytes')
    if problem:
        os.close(fd)
        raise ModelError(f'{where} {problem}')
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
                         f'{MAX_MESH_FILE_BYTES} bytes')
    return data


def _mesh(spec_path, spec_scale, path, scale):
    """Load the mesh of a ``*mesh_path`` parameter, errors naming the parameter."""
    file_path = mesh_file(path, spec_path.name)
    field = spec_path.name[:-len('mesh_path')]
    try:
        return load_mesh(file_path, scale, field=field)
    except ModelError as exc:
        message = str(exc)
        blamed = spec_scale if message.startswith(field + 'mesh_scale') else spec_path
        value = scale if blamed is spec_scale else path
        _fail(blamed, value, message.split(': ', 1)[-1] if ': ' in message else message)


def _check_sizes(dims_spec, dims, scale_spec, scale):
    """Refuse a ``dimensions_m`` or ``mesh_scale`` value that is not finite or above MAX_SIZE."""
    if any(not math.isfinite(v) or abs(v) > MAX_SIZE for v in dims):
        _fail(dims_spec, dims, f'every size must be finite and at most {MAX_SIZE:g} m',
              ModelError)
    if len(scale) != 3 or any(not (0.0 < v <= MAX_SIZE) for v in scale):
        _fail(scale_spec, scale, f'must be 3 factors in (0, {MAX_SIZE:g}]', ModelError)


def _collision_shape(values):
    """Return the body's collision shape: the mesh, the (default) primitive, or None."""
    p = PARAMETERS_BY_NAME
    shape, path = values['shape'], values['mesh_path']
    _check_sizes(p['dimensions_m'], values['dimensions_m'], p['mesh_scale'],
                 values['mesh_scale'])
    if path:
        if values['inertia']:
            raise ModelError(
                f'parameter inertia = {_fmt(values["inertia"])} kg·m² and parameter mesh_path = '
                f'{path!r}: give either inertia or mesh_path, not both')
        if shape not in ('', 'mesh'):
            _fail(p['shape'], shape, "must be '' or 'mesh' with mesh_path")
        if values['dimensions_m']:
            _fail(p['dimensions_m'], values['dimensions_m'], 'is not used with mesh_path')
        return _mesh(p['mesh_path'], p['mesh_scale'], path, values['mesh_scale'])
    if shape == 'mesh':
        _fail(p['mesh_path'], path, "must be a mesh file when shape is 'mesh'")
    if values['mesh_scale'] != p['mesh_scale'].default:
        _fail(p['mesh_scale'], values['mesh_scale'], 'needs mesh_path')
    if values['inertia']:
        return None
    if not shape:
        shape, dims = DEFAULT_SHAPE, DEFAULT_DIMENSIONS_M
    else:
        dims = values['dimensions_m']
    if shape not in SHAPES:
        return None  # _model names the shape
    try:
        return primitive_shape(shape, dims)
    except ModelError:
        return None  # _model names the dimensions, as it did before shapes could collide


def _model(values, collision=None):
    """Build the :class:`BodyModel`: mass, inertia (given, or of a shape), gravity, damping."""
    p = PARAMETERS_BY_NAME
    mass_kg = values['mass_kg']
    if not mass_kg > 0.0:
        _fail(p['mass_kg'], mass_kg, 'must be > 0')
    inertia = values['inertia']
    shape = values['shape']
    dims = values['dimensions_m']
    if inertia and shape:
        raise ModelError(
            f'parameter inertia = {_fmt(inertia)} kg·m² and parameter shape = {shape!r}: '
            'give either inertia or shape (with dimensions_m), not both')
    if dims and not shape:
        _fail(p['dimensions_m'], dims, 'needs shape (or remove it and give inertia)')
    if values['mesh_path']:
        inertia_b = collision.mass_properties(mass_kg).inertia_b
    elif inertia:
        if len(inertia) != 6:
            _fail(p['inertia'], inertia, 'must have 6 values [ixx, iyy, izz, ixy, ixz, iyz]')
        inertia_b = _reraise(p['inertia'], inertia, inertia_from_components, *inertia)
    else:
        if not shape:
            shape, dims = DEFAULT_SHAPE, DEFAULT_DIMENSIONS_M
        if shape not in SHAPES:
            _fail(p['shape'], shape, 'must be one of ' + ', '.join(SHAPES), ModelError)
        inertia_b = _reraise(p['dimensions_m'], dims, from_shape, shape, dims,
                             mass_kg).inertia_b
    gravity = _vector3(p['gravity'], values['gravity'])
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
        _check_sizes(specs['dimensions_m'], get['dimensions_m'], specs['mesh_scale'],
                     get['mesh_scale'])
        _vector3(specs['position'], get['position'])
        if get['shape'] == 'mesh':
            if not get['mesh_path']:
                _fail(specs['mesh_path'], '', "must be a mesh file when shape is 'mesh'")
            if get['dimensions_m']:
                _fail(specs['dimensions_m'], get['dimensions_m'],
                      "is not used by shape 'mesh' (its size is the file's times mesh_scale)",
                      ModelError)
            resolved = mesh_file(get['mesh_path'], specs['mesh_path'].name)
        elif get['shape'] not in PRIMITIVES:
            _fail(specs['shape'], get['shape'],
                  'must be one of ' + ', '.join(PRIMITIVES) + ' or mesh', ModelError)
        else:
            if get['mesh_path']:
                _fail(specs['mesh_path'], get['mesh_path'],
                      f"is not used by shape {get['shape']!r}: only shape 'mesh' takes a file",
                      ModelError)
            if tuple(get['mesh_scale']) != tuple(specs['mesh_scale'].default):
                _fail(specs['mesh_scale'], get['mesh_scale'],
                      f"is not used by shape {get['shape']!r}: only shape 'mesh' is scaled",
                      ModelError)
            resolved = None
        try:
            obstacles.append(obstacle(
                name, get['shape'], get['dimensions_m'], resolved, get['mesh_scale'],
                get['position'], q_wxyz, get['friction'], get['restitution']))
        except ModelError as exc:
            raise ModelError(f'parameter {exc}') from None
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
            f'parameter inertia = {_fmt(values["inertia"])} kg·m²: a body given only by its '
            'inertia has no collision shape; with ground.enabled or obstacle_names give shape '
            'and dimensions_m, or mesh_path')
    if integrator not in CONTACT_INTEGRATORS:
        _fail(p['integrator'], integrator,
              'cannot take contact (ground.enabled or obstacle_names): use one of '
              + ', '.join(CONTACT_INTEGRATORS))
    try:
        check_overlaps([('body', collision, initial_state.position_w,
                         initial_state.orientation_wb)], static_world)
    except ModelError as exc:
        reason = str(exc).split(' m puts the body ', 1)[-1]
        _fail(p['initial_position'], values['initial_position'], 'puts the body ' + reason,
              ModelError)


def _unit_quaternion(spec, q_xyzw):
    """Return ``q_xyzw`` ([x, y, z, w], norm within 1e-3 of 1) as a unit (w, x, y, z) array."""
    if len(q_xyzw) != 4:
        _fail(spec, q_xyzw, 'must have 4 values [x, y, z, w]')
    norm = math.hypot(*q_xyzw)  # scaled: the norm of [1e300, 0, 0, 1e300] is not inf
    if abs(norm - 1.0) > 1e-3:
        _fail(spec, q_xyzw, f'norm {norm:.6g} must be within 1e-3 of 1 ([x, y, z, w] order)')
    return np.asarray(xyzw_to_wxyz(q_xyzw)) / norm


def xyzw_to_wxyz(q_xyzw):
    """Reorder a plain ``[x, y, z, w]`` sequence (geometry_msgs order) to ``(w, x, y, z)``."""
    x, y, z, w = q_xyzw
    return (w, x, y, z)


def _initial_state(values):
    """Build the :class:`BodyState` at time 0 (``initial_orientation`` is [x, y, z, w])."""
    p = PARAMETERS_BY_NAME
    position = _vector3(p['initial_position'], values['initial_position'])
    q_wxyz = _unit_quaternion(p['initial_orientation'], values['initial_orientation'])
    velocity = _vector3(p['initial_linear_velocity'], values['initial_linear_velocity'])
    omega_b = _vector3(p['initial_angular_velocity'], values['initial_angular_velocity'])
    return BodyState(position_w=np.array(position), orientation_wb=q_wxyz,
                     linear_velocity_w=np.array(velocity), angular_velocity_b=np.array(omega_b),
                     time_ns=0)


def _time_settings(values):
    """Check integrator, step, publish period, real-time factor, duration, wrench timeout."""
    p = PARAMETERS_BY_NAME
    if values['integrator'] not in INTEGRATORS:
        _fail(p['integrator'], values['integrator'], 'must be one of ' + ', '.join(INTEGRATORS))
    if not values['timestep_s'] > 0.0:
        _fail(p['timestep_s'], values['timestep_s'], 'must be > 0')
    timestep_ns = _to_ns(p['timestep_s'], values['timestep_s'])
    if not values['publish_rate_hz'] > 0.0:
        _fail(p['publish_rate_hz'], values['publish_rate_hz'], 'must be > 0')
    if values['publish_rate_hz'] < MIN_PUBLISH_RATE_HZ:
        _fail(p['publish_rate_hz'], values['publish_rate_hz'],
              f'must be >= {MIN_PUBLISH_RATE_HZ:g} Hz (a publish period of at most 1e6 s)')
    check_real_time_factor(values['real_time_factor'])
    return {'integrator': values['integrator'], 'timestep_ns': timestep_ns,
            'publish_period_ns': max(1, round(NS_PER_S / values['publish_rate_hz'])),
            'real_time_factor': values['real_time_factor'],
            'duration_ns': _to_ns(p['duration_s'], values['duration_s']),
            'start_paused': values['start_paused'],
            'wrench_timeout_ns': _to_ns(p['wrench_timeout_s'], values['wrench_timeout_s'])}


def _frame_settings(values, bodies=()):
    """Check the frame ids and keywords; the optional outputs (``/clock``, ``/tf``)."""
    p = PARAMETERS_BY_NAME
    seen = {values['world_frame']: 'world_frame'}
    for body in bodies:
        if not body.parameter_prefix:
            continue  # the top-level body_frame: checked below
        spec = PARAMETERS_BY_NAME['body_frame']
        where = f'{body.parameter_prefix}body_frame'
        if not body.body_frame:
            _fail(dataclass_replace(spec, name=where), body.body_frame, 'must not be empty')
        if body.body_frame in seen:
            _fail(dataclass_replace(spec, name=where), body.body_frame,
                  f'is already the frame of {seen[body.body_frame]}')
        seen[body.body_frame] = where
    for name in ('world_frame', 'body_frame'):
        if not values[name]:
            _fail(p[name], values[name], 'must not be empty')
    if values['world_frame'] == values['body_frame']:
        _fail(p['body_frame'], values['body_frame'], 'must differ from world_frame')
    for name in ('twist_frame', 'default_wrench_frame'):
        if values[name] not in FRAME_KEYWORDS:
            _fail(p[name], values[name], "must be 'world' or 'body'")
    return {name: values[name] for name in (
        'world_frame', 'twist_frame', 'default_wrench_frame', 'publish_clock', 'publish_tf',
        'publish_markers')}


def _limits_and_recording(values):
    """Check the wrench limits and the ``record_*`` settings."""
    p = PARAMETERS_BY_NAME
    if values['record_on_error'] not in ('continue', 'stop'):
        _fail(p['record_on_error'], values['record_on_error'], "must be 'continue' or 'stop'")
    for name in ('max_force_n', 'max_torque_nm', 'max_drag_point_m'):
        if not values[name] > 0.0:
            _fail(p[name], values[name], 'must be > 0')
    _vector3(p['drag_point_b'], values['drag_point_b'])
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
            _fail(topic_spec, topic, 'must not be empty')
        if topic in topics:
            _fail(topic_spec, topic, 'is already used by another wrench input')
        topics.add(topic)
        frame = values[frame_spec.name]
        if frame not in FRAME_KEYWORDS:
            _fail(frame_spec, frame, "must be 'world' or 'body'")
        point_b = _vector3(point_spec, values[point_spec.name])
        inputs.append(WrenchInputSpec(name, topic, frame, point_b))
    return tuple(inputs)


def _reraise(spec, value, func, *args):
    """Call ``func(*args)``; re-raise a core ModelError/ConfigError naming the parameter."""
    try:
        return func(*args)
    except (ModelError, ConfigError) as exc:
        message = str(exc)
        if not message.startswith((spec.name + ':', spec.name + ' ')):
            unit = f' {spec.unit}' if spec.unit else ''
            message = f'{spec.name} = {_fmt(value)}{unit}: {message}'
        raise type(exc)(f'parameter {message}') from None


# Parameters that shape the first physics step, in the order they are blamed when that step is
# not finite: each is put back to its default in turn until the step becomes finite.
_FIRST_STEP_SUSPECTS = ('initial_angular_velocity', 'initial_linear_velocity',
                        'initial_position', 'gravity', 'mass_kg', 'inertia', 'dimensions_m',
                        'linear_damping', 'angular_damping', 'timestep_s')


class _FreeBodySimulator(Simulator):
    """
    The free-body :class:`Simulator` with the per-body interface of a :class:`WorldSimulator`.

    A body that can touch nothing steps without the contact kernels (a cold start compiles
    the free-body kernels only); :meth:`set_body_loads` keeps the free body's own load rows
    (:meth:`Simulator.set_loads`), and there is no contact wrench and no contact.
    """

    contact_wrench_w = None
    contacts = None

    def set_body_loads(self, index, wrenches=(), springs=()):
        """Hold these loads on the body (``index`` 0) from the next step until replaced."""
        self.set_loads(wrenches, springs)


def make_simulator(config):
    """
    Return the simulator of ``config``: the one place that chooses it.

    With contact (named bodies, a ground or obstacles) a :class:`WorldSimulator` of every body
    of ``config.bodies`` and the static world; else the free-body simulator of the one body.
    Both answer ``time_ns``, ``arrays``, ``body_state(i)``, ``set_body_loads(i, ...)``,
    ``step``, ``reset``, ``contact_wrench_w`` and ``contacts`` (None without contact).
    """
    if not config.contact:
        (body,) = config.bodies
        return _FreeBodySimulator(body.model, body.initial_state, integrator=config.integrator,
                                  timestep_ns=config.timestep_ns)
    return WorldSimulator(
        [WorldBody(b.name, b.model, b.collision_shape, b.material) for b in config.bodies],
        [b.initial_state for b in config.bodies], config.static_world,
        integrator=config.integrator, timestep_ns=config.timestep_ns)


def _step_once(config):
    make_simulator(config).step(1)


def _finite_with(params, overrides):
    """Return whether the first step is finite with ``overrides`` applied to ``params``."""
    try:
        _step_once(NodeConfig.from_parameters({**params, **overrides}))
    except (ModelError, ConfigError, NonFiniteError):
        return False
    return True


def _blame_world_body(params, reason):
    """
    Raise naming the ``bodies.<name>.<suspect>`` whose default makes the first step finite.

    For each suspect, all bodies' values go back to the default at once; if that helps, halving
    finds the body (``S + S log2 N`` trial steps at most). Returns if no single one is to blame.
    """
    for suspect in _FIRST_STEP_SUSPECTS:
        spec = PARAMETERS_BY_NAME[suspect]
        default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
        names = [f'bodies.{body}.{suspect}' for body in params.get('body_names', ())
                 if params.get(f'bodies.{body}.{suspect}', default) != default]
        if not names or not _finite_with(params, dict.fromkeys(names, default)):
            continue
        while len(names) > 1:
            half = names[:len(names) // 2]
            names = half if _finite_with(params, dict.fromkeys(half, default)) else \
                names[len(names) // 2:]
        unit = f' {spec.unit}' if spec.unit else ''
        raise ConfigError(f'parameter {names[0]} = {_fmt(params[names[0]])}{unit}: the first '
                          f'physics step is not finite ({reason})')


def check_first_step(config):
    """
    Take one physics step from the initial state on a throw-away simulator.

    Valid parameters can still make the first step non-finite (``initial_angular_velocity:
    [1e200, 0.0, 0.0]`` overflows); the node refuses them at start instead of pausing on its
    first step. This also compiles the physics kernel.

    :raises ConfigError: naming the parameter that makes the step non-finite: the first of
        :data:`_FIRST_STEP_SUSPECTS` whose default value makes the step finite.
    """
    try:
        _step_once(config)
        return
    except NonFiniteError as exc:
        reason = str(exc)
    params = config.to_parameters()
    _blame_world_body(params, reason)  # returns at once without body_names
    for name in _FIRST_STEP_SUSPECTS:
        spec = PARAMETERS_BY_NAME[name]
        default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
        if params[name] == default:
            continue
        try:
            _step_once(NodeConfig.from_parameters({**params, name: default}))
        except (ModelError, ConfigError, NonFiniteError):
            continue  # still not finite, or not a valid configuration without this value
        _fail(spec, params[name], f'the first physics step is not finite ({reason})',
              ConfigError)
    raise ConfigError(f'parameters: the first physics step is not finite ({reason})')
