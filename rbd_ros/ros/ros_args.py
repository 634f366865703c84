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
The parameter overrides that ROS arguments give one node, read the way rcl and rclpy read them.

rclpy has no public accessor for a node's parameter overrides before they are declared (its
``automatically_declare_parameters_from_overrides`` refuses a ``[]`` value and collides with its
own ``qos_overrides.*`` declarations), and the node needs every overriding name: to validate the
values with its own one-line errors, to warn about unknown names and to check the
``qos_overrides.*`` names. So the node owns that path; this module has no rclpy (only PyYAML):

* :func:`ros_rules` walks the ``--ros-args ... [--]`` sections of an argument list and yields the
  parameter rules in order: ``-p``/``--param [node:]name:=value`` and ``--params-file FILE``.
* :class:`ParameterStore` applies them as rcl does (rcl_yaml_param_parser): one store per
  argument list; node sections (``/ns/node``, nested ``ns: node:``, ``/**``, ...) in the order
  they first appear; a ``-p`` rule goes to section ``/**`` (or ``node``); scalars typed by
  rcl's rules (:func:`scalar_value`).
* :func:`node_overrides` merges them for one node as rclpy does: the store of the global
  arguments (``rclpy.init``), then that of the node's own ``cli_args``, then the constructor's
  ``parameter_overrides``; within a store, every section whose name matches the node's fully
  qualified name, in store order, a later value winning. So a ``-p`` rule does not beat a
  node-specific section of a file that appeared after the first ``/**`` section. A section
  name is a pattern: after prefixing ``/`` if missing, each ``/*`` is the regular expression
  ``(/\w+)``, matched against the whole name: ``/**`` is any node, ``/*`` any node in the root
  namespace, ``/ns/*`` any node in ``/ns``, ``/**/node`` a node of that name anywhere.

rcl validates the arguments and the files first (``rclpy.init`` and the node's constructor
fail on a bad rule, a bad file or a mixed-type list), so what is read here is well formed.

Two rcl quirks are kept, since the node must see what rclpy would hand it: a value overrides an
earlier one of the same name and section only if it has the same type (rcl keeps one slot per
type, and rclpy reads the first filled slot in the order bool, integer, double, string,
bool/integer/double/string array), and an empty list ``[]`` fills no slot (alone, the value is
NOT_SET: ``None``). So does an empty mapping ``{}``: rcl reads ``name: {}`` as the parameter
``name`` with no value (NOT_SET), not as an empty namespace.

One addition of ours: a relative path (a name ending in one of :data:`PATH_PARAMETER_ENDINGS`:
``mesh_path``, ``urdf_path``) read from a params file is made relative to that file's
directory (as URDF and SDF resolve their meshes), so a world file and its meshes move
together; ``package://`` and absolute paths, and ``-p`` values (relative to the working
directory), are kept as given.
"""

from fractions import Fraction
import math
import os
import re
import sys

import yaml

#: A params file's relative value of a parameter ending so is relative to that file.
PATH_PARAMETER_ENDINGS = ('mesh_path', 'urdf_path')

PARAM_FLAGS = ('-p', '--param')
PARAMS_FILE_FLAG = '--params-file'
# The other rcl flags that take the next argument as their value (rcl/arguments.h).
VALUE_FLAGS = ('-r', '--remap', '-e', '--enclave', '--log-level', '--log-config-file',
               '--log-file-name')
PARAMS_KEY = 'ros__parameters'
# rclpy reads an rcl variant's first filled slot in this order (_parameter_from_rcl_variant).
SLOT_ORDER = (bool, int, float, str, (bool,), (int,), (float,), (str,))
_LOADER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)  # libyaml, the parser rcl uses
_TRUE = frozenset(('Y', 'y', 'yes', 'Yes', 'YES', 'true', 'True', 'TRUE', 'on', 'On', 'ON'))
_FALSE = frozenset(('N', 'n', 'no', 'No', 'NO', 'false', 'False', 'FALSE', 'off', 'Off', 'OFF'))
_YAML_INF_NAN = frozenset(
    sign + dot for sign in ('', '+', '-') for dot in ('.inf', '.Inf', '.INF')) | frozenset(
    ('.nan', '.NaN', '.NAN'))
_SPACE = '[ \\t\\n\\v\\f\\r]*'  # C isspace()
# strtol(value, &end, 0) consuming the whole string: decimal, 0x hexadecimal or 0 octal.
_C_LONG = re.compile(_SPACE + r'(?P<sign>[+-]?)(?:0[xX](?P<hex>[0-9a-fA-F]+)|0(?P<oct>[0-7]*)'
                     r'|(?P<dec>[1-9][0-9]*))')
# strtod(value, &end) consuming the whole string: decimal or hexadecimal, inf, infinity, nan.
_C_DOUBLE = re.compile(_SPACE + r'(?P<sign>[+-]?)(?:(?P<special>(?i:inf(?:inity)?|nan))'
                       r'(?:\([0-9a-zA-Z_]*\))?'
                       r'|0[xX](?P<hex>[0-9a-fA-F]+\.?[0-9a-fA-F]*|\.[0-9a-fA-F]+)'
                       r'(?:[pP](?P<binexp>[+-]?[0-9]+))?'
                       r'|(?P<dec>(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?))')


class RosArgsError(ValueError):
    """A params file or ``-p`` rule that cannot be read (one line, naming it)."""


def ros_rules(args):
    """
    Yield the parameter rules of ``args`` in order: ``('param', rule)`` or ``('file', path)``.

    Only the ``--ros-args`` sections count (each runs to ``--`` or to the end); other ROS flags
    are skipped with their values.
    """
    args = list(args or ())
    in_ros_args, i = False, 0
    while i < len(args):
        arg = args[i]
        if not in_ros_args:
            in_ros_args = arg == '--ros-args'
        elif arg == '--':
            in_ros_args = False
        elif i + 1 < len(args) and arg in PARAM_FLAGS + (PARAMS_FILE_FLAG,) + VALUE_FLAGS:
            i += 1
            if arg in PARAM_FLAGS:
                yield 'param', args[i]
            elif arg == PARAMS_FILE_FLAG:
                yield 'file', args[i]
        i += 1


def scalar_value(text, quoted=False):
    """
    Return a YAML scalar as rcl types it: bool, int, float or str.

    Unquoted: rcl's bool words (yes/no/on/off/true/false/y/n in three cases), then a whole
    ``strtol(text, 0)`` (so ``0x10`` is 16 and ``010`` is 8) within int64, then the YAML
    ``.inf``/``.nan`` spellings or a whole ``strtod`` (``1e3``, ``inf``, hexadecimal) without
    overflow or underflow; anything else, and every quoted scalar, is a string.
    """
    if quoted:
        return text
    if text in _TRUE:
        return True
    if text in _FALSE:
        return False
    whole = _C_LONG.fullmatch(text)
    if whole:
        digits, base = next((whole[key], base) for key, base in (
            ('hex', 16), ('oct', 8), ('dec', 10)) if whole[key] is not None)
        value = int(digits or '0', base) * (-1 if whole['sign'] == '-' else 1)
        if -2 ** 63 <= value < 2 ** 63:
            return value
    if text in _YAML_INF_NAN:
        value = math.nan if 'n' in text.lower().replace('inf', '') else math.inf
        return -value if text.startswith('-') else value
    value = _c_double(text)
    return text if value is None else value


def _c_double(text):
    """Return ``strtod(text)`` if it takes the whole text without a range error, else None."""
    whole = _C_DOUBLE.fullmatch(text)
    if whole is None:
        return None
    sign = -1 if whole['sign'] == '-' else 1
    if whole['special'] is not None:
        return sign * float(whole['special'])
    try:
        if whole['hex'] is not None:
            value = float.fromhex('0x' + whole['hex'] + 'p' + (whole['binexp'] or '0'))
            mantissa = whole['hex']
        else:
            value = float(whole['dec'])
            mantissa = re.split('[eE]', whole['dec'])[0]
    except OverflowError:
        return None  # ERANGE: overflow
    if math.isinf(value):
        return None  # ERANGE: overflow
    if value < sys.float_info.min and re.search('[1-9a-fA-F]', mantissa) and (
            value == 0.0 or Fraction(value) != _exact(whole)):
        return None  # ERANGE (glibc): the result underflowed to zero or is an inexact subnormal
    return sign * value


def _exact(whole):
    """Return the exact value of a matched (positive, finite) ``strtod`` number."""
    if whole['dec'] is not None:
        return Fraction(whole['dec'])
    integer, _, fraction = whole['hex'].partition('.')
    return Fraction(int(integer + fraction or '0', 16), 16 ** len(fraction)) * Fraction(2) ** int(
        whole['binexp'] or 0)


class ParameterStore:
    """
    What rcl builds from one argument list: node section → parameter name → typed slots.

    Each parameter keeps one slot per type; a value fills its type's slot (a list replaces its
    array slot when its first element arrives), as rcl_yaml_param_parser does.
    """

    def __init__(self):
        self.sections = {}
        self._base_dir = None  # directory of the params file being read, else None

    def _resolve(self, name, value):
        """Make a params file's relative ``*mesh_path`` or ``*urdf_path`` relative to it."""
        if (self._base_dir is not None and name.endswith(PATH_PARAMETER_ENDINGS)
                and isinstance(value, str)
                and value and not value.startswith('package://') and not os.path.isabs(value)):
            return os.path.join(self._base_dir, value)
        return value

    def _slots(self, node_name, name):
        return self.sections.setdefault(node_name, {}).setdefault(name, {})

    def set_node(self, node_name, name, node):
        """Store a composed YAML ``node`` (scalar or sequence of scalars; else: no value)."""
        slots = self._slots(node_name, name)
        if isinstance(node, yaml.ScalarNode):
            value = self._resolve(name, _scalar(node))
            slots[type(value)] = value
        elif isinstance(node, yaml.SequenceNode) and node.value:
            for item in node.value:
                if not isinstance(item, yaml.ScalarNode):
                    # rcl flattens [[a]] to [a] and makes [{x: 1}] a parameter name.x: refused
                    kind = 'list' if isinstance(item, yaml.SequenceNode) else 'map'
                    raise RosArgsError(
                        f'parameter {name}: an item of its list is a {kind} (line '
                        f'{item.start_mark.line + 1}); a value is a scalar or a list of scalars')
            values = [_scalar(item) for item in node.value]
            slots[(type(values[0]),)] = values

    def add_rule(self, rule):
        """Apply a ``-p`` rule ``[node:]name:=yaml value`` (node defaults to ``/**``)."""
        target, _, text = rule.partition(':=')
        node_name, _, name = target.rpartition(':')
        try:
            documents = list(yaml.compose_all(text, Loader=_LOADER))
        except yaml.YAMLError as exc:
            raise RosArgsError(f'-p {rule}: not a YAML value ({_one_line(exc)})') from None
        self._slots(node_name or '/**', name)
        try:
            for document in documents:
                self.set_node(node_name or '/**', name, document)
        except RosArgsError as exc:
            raise RosArgsError(f'-p {rule}: {exc}') from None

    def add_file(self, path):
        """Apply a ROS 2 parameters file."""
        try:
            with open(path, 'rb') as stream:
                documents = list(yaml.compose_all(stream, Loader=_LOADER))
        except OSError as exc:
            raise RosArgsError(f'--params-file {path}: cannot read it ({exc.strerror})') from None
        except yaml.YAMLError as exc:
            raise RosArgsError(f'--params-file {path}: not YAML ({_one_line(exc)})') from None
        self._base_dir = os.path.dirname(os.path.abspath(path))
        try:
            for document in documents:
                if isinstance(document, yaml.MappingNode):
                    self._add_sections((), document)
        except RosArgsError as exc:
            raise RosArgsError(f'--params-file {path}: {exc}') from None
        finally:
            self._base_dir = None

    def _add_sections(self, names, mapping):
        for key, value in mapping.value:
            if key.value.startswith(PARAMS_KEY):
                if isinstance(value, yaml.MappingNode):
                    self._add_parameters('/'.join(names), '', value)
            elif isinstance(value, yaml.MappingNode):
                self._add_sections(names + (key.value,), value)

    def _add_parameters(self, node_name, prefix, mapping):
        for key, value in mapping.value:
            name = prefix + key.value
            if isinstance(value, yaml.MappingNode) and value.value:
                self._add_parameters(node_name, name + '.', value)
            else:  # a scalar, a sequence, or an empty mapping (a name with no value)
                self.set_node(node_name, name, value)

    def values_for(self, node_fqn):
        """Return name → value of every section matching ``node_fqn``, merged in order."""
        merged = {}
        for node_name, params in self.sections.items():
            if matches(node_name, node_fqn):
                for name, slots in params.items():
                    merged[name] = slot_value(slots)
        return merged


def _one_line(exc):
    return ' '.join(str(exc).split())


def _scalar(node):
    return scalar_value(node.value, quoted=node.style in ("'", '"'))


def slot_value(slots):
    """Return the value rclpy reads from a parameter's slots: the first filled one, or None."""
    for kind in SLOT_ORDER:
        if kind in slots:
            return slots[kind]
    return None


def matches(node_name, node_fqn):
    """Tell whether the params section ``node_name`` applies to the node ``node_fqn``."""
    pattern = ('' if node_name.startswith('/') else '/') + node_name
    try:
        return re.fullmatch(pattern.replace('/*', r'(/\w+)'), node_fqn, re.ASCII) is not None
    except re.error:
        return False


def store_from_args(args):
    """Return the :class:`ParameterStore` that rcl builds from one argument list."""
    store = ParameterStore()
    for kind, text in ros_rules(args):
        if kind == 'param':
            store.add_rule(text)
        else:
            store.add_file(text)
    return store


def node_overrides(node_fqn, global_args=None, cli_args=None, use_global_arguments=True,
                   parameter_overrides=None):
    """
    Return name → value of the parameter overrides of the node ``node_fqn``, as rclpy sees them.

    :param global_args: the arguments given to ``rclpy.init`` (None: ``sys.argv``, as there).
    :param cli_args: the node's own arguments (``Node(cli_args=...)``).
    :param use_global_arguments: as ``Node(use_global_arguments=...)``.
    :param parameter_overrides: name → value given to ``Node(parameter_overrides=...)``.
    :raises RosArgsError: if a params file cannot be read or a value is not YAML (rcl refuses
        both first, so only if a file changed since, or ``global_args`` are not the arguments
        that ``rclpy.init`` got).
    """
    merged = {}
    if use_global_arguments:
        merged.update(store_from_args(
            sys.argv if global_args is None else global_args).values_for(node_fqn))
    merged.update(store_from_args(cli_args).values_for(node_fqn))
    merged.update(parameter_overrides or {})
    return merged
