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
One parameter's record, :class:`ParamSpec`, and the rule of every value: types, ranges, messages.

The kinds of value (ROS parameter types), :func:`coerce` (a value to its kind's Python type),
:func:`check_range` (the one home of every range and ``> 0`` rule), :func:`to_ns`, the checks of
vectors, positions, quaternions, sizes and frame ids, and :func:`fail`, the one shape of a
bad-value message: the parameter, its value, its unit and the rule, on one line. The table
itself is :mod:`rbd_ros.sim.params`; the bounds are :mod:`rbd_ros.sim.limits`.

Times are converted to integer nanoseconds here (:func:`to_ns`), rounded to the nearest
nanosecond: a time in seconds must be a whole number of nanoseconds (to 0.001 ns, which absorbs
the binary representation of decimal values such as 0.001), so that sim time is exact. A
positive time that rounds to 0 ns is refused (it would silently mean "off"), naming the
parameter.
"""

from dataclasses import dataclass
import math

import numpy as np

from rbd_ros.core import ConfigError, ModelError
from rbd_ros.sim.limits import MAX_ARRAY_ITEMS, MAX_POSITION_M, MIN_SIZE

# ROS parameter types, by the names rcl_interfaces/ParameterType uses (lower case).
BOOL = 'bool'
INTEGER = 'integer'
DOUBLE = 'double'
STRING = 'string'
DOUBLE_ARRAY = 'double_array'
STRING_ARRAY = 'string_array'

_FMT_ITEMS = 8  # a listed value longer than this is cut in messages (one bounded line)
_FMT_CHARS = 200

NS_PER_S = 1_000_000_000  # the one ns-per-second constant of rbd_ros
# A time in seconds must be within this many ns of a whole number of ns: float64 writes decimal
# steps such as 0.001 s with a relative error <= 2^-53, far below 1e-3 ns for any step < 1e3 s.
_NS_TOLERANCE = 1e-3


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


# Parameters of the body model: their errors are ModelError, the others' ConfigError.
_MODEL_PARAMETERS = frozenset((
    'mass_kg', 'inertia', 'shape', 'dimensions_m', 'gravity', 'linear_damping',
    'angular_damping', 'friction', 'restitution', 'mesh_path', 'mesh_scale', 'ground.friction',
    'ground.restitution'))


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
