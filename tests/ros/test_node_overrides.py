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
The node reads its parameter overrides from its ROS arguments itself (:mod:`rbd_ros.ros.ros_args`).

rclpy has no public accessor for them, so the node no longer reads rclpy's private
``Node._parameter_overrides``; it must still see exactly what rclpy sees: which params-file
sections apply to it (``/**``, namespaced and nested names, ``/*`` patterns, a remapped node
name), in which order (a later file, a ``-p`` rule), and rcl's typing of every scalar. The
node tests go through real node processes and ``ros2 param get``'s service call; the parser
is also compared with rclpy itself (a node that declares its overrides, public API) and with
the C library's ``strtol``/``strtod`` that rcl types scalars with.
"""

import array
import ctypes
import ctypes.util
import math
from pathlib import Path
import subprocess
import sys

import pytest
from rbd_ros.core import ConfigError
from rbd_ros.ros import ros_args
from rbd_ros.ros.node import RigidBodyNode
from rcl_interfaces.srv import GetParameters
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from rclpy.parameter import parameter_value_to_python
from ros_probe import Probe

REPO = Path(__file__).resolve().parents[2]


def get_values(namespace, node_name, names):
    """``ros2 param get <namespace>/<node_name> <name>`` for each name: name → value."""
    probe = Probe(namespace, inputs=(), outputs=())
    try:
        client = probe.node.create_client(GetParameters, f'{node_name}/get_parameters')
        probe.wait(client.service_is_ready, 60.0, f'{node_name}/get_parameters')
        future = client.call_async(GetParameters.Request(names=list(names)))
        probe.wait(future.done, 20.0, 'the get_parameters response')
        values = future.result().values
    finally:
        probe.close()
    assert len(values) == len(names), values
    return {name: parameter_value_to_python(value) for name, value in zip(names, values)}


def write(path, text):
    """Write ``text`` to ``path``; return the path as a string."""
    Path(path).write_text(text)
    return str(path)


def test_params_file_sections_apply_as_rclpy_applies_them(start_node, tmp_path):
    # Wildcard /**, a namespaced node name, the nested namespace form, /**/name and /ns/*
    # patterns apply; /* (root namespace only) does not; a later file and a later -p rule win
    # over a /** value; a namespaced section that comes after /** wins over it.
    namespace = f'/rbd_overrides_{id(tmp_path) % 100000}'
    first = write(tmp_path / 'first.yaml', f"""
/**:
  ros__parameters:
    body_frame: wildcard_body
    world_frame: first_file_world
    max_force_n: 100.0
    max_torque_nm: 300.0
{namespace}/rigid_body_node:
  ros__parameters:
    body_frame: namespaced_body
/*:
  ros__parameters:
    linear_damping: 0.5
{namespace[1:]}:
  rigid_body_node:
    ros__parameters:
      angular_damping: 0.25
/**/rigid_body_node:
  ros__parameters:
    wrench_timeout_s: 0.75
{namespace}/*:
  ros__parameters:
    not_a_parameter: 1
""")
    second = write(tmp_path / 'second.yaml', """
/**:
  ros__parameters:
    world_frame: second_file_world
""")
    node = start_node(namespace=namespace, extra_args=[
        '--params-file', first, '--params-file', second, '-p', 'max_force_n:=200.0'])
    expected = {'body_frame': 'namespaced_body', 'world_frame': 'second_file_world',
                'max_force_n': 200.0, 'max_torque_nm': 300.0, 'linear_damping': 0.0,
                'angular_damping': 0.25, 'wrench_timeout_s': 0.75}
    assert get_values(namespace, 'rigid_body_node', expected) == expected
    assert 'ignoring unknown parameter not_a_parameter = 1' in node.stderr, node.stderr
    assert node.stop() == 0, node.stderr


def test_a_node_name_remap_changes_which_section_applies(start_node, tmp_path):
    namespace = f'/rbd_remap_{id(tmp_path) % 100000}'
    params = write(tmp_path / 'params.yaml', f"""
{namespace}/rigid_body_node:
  ros__parameters:
    body_frame: not_for_body_b
    mass_kg: 5.0
{namespace}/body_b:
  ros__parameters:
    body_frame: for_body_b
    mass_kg: 7.0
""")
    node = start_node(namespace=namespace,
                      extra_args=['-r', '__node:=body_b', '--params-file', params])
    expected = {'body_frame': 'for_body_b', 'mass_kg': 7.0}
    assert get_values(namespace, 'body_b', expected) == expected
    assert node.stop() == 0, node.stderr


def test_a_bad_value_in_a_namespaced_section_gives_one_line_and_exit_2(start_node, tmp_path):
    namespace = '/rbd_bad_section'
    params = write(tmp_path / 'params.yaml', f"""
{namespace}/rigid_body_node:
  ros__parameters:
    mass_kg: -2.0
""")
    node = start_node(namespace=namespace, extra_args=['--params-file', params])
    assert node.wait(60) == 2, node.stderr
    lines = [line for line in node.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and 'parameter mass_kg = -2.0 kg' in lines[0], lines


# Argument lists whose overrides rclpy can declare (no [] value: it refuses NOT_SET).
def _cases(tmp_path):
    wildcard_and_node = write(tmp_path / 'a.yaml', """
/**:
  ros__parameters:
    mass: 9
    flag: Yes
    hexadecimal: 0x10
    octal: 010
    not_octal: 08
    exponent: 1e3
    hex_double: 0x1p3
    inf: .inf
    minus_inf: -.Inf
    underscores: 1_000
    quoted: '5'
    tilde: ~
    nested:
      a: 1
      b:
        c: x
    doubles: [1.0, 2.5]
/rigid_body_node:
  ros__parameters:
    mass: 2
    strings: [a, 'b']
rigid_body_node:
  ros__parameters:
    mass: 3
    bools: [on, off]
""")
    sections = write(tmp_path / 'b.yaml', """
ns:
  deep:
    rigid_body_node:
      ros__parameters:
        nested_form: 1
/ns/*:
  ros__parameters:
    ns_star: 1
/*:
  ros__parameters:
    root_star: 1
/**/deep/rigid_body_node:
  ros__parameters:
    deep_anywhere: 1
/*/*/*:
  ros__parameters:
    three: 1
""")
    return [
        ['--ros-args', '--params-file', wildcard_and_node],
        ['--ros-args', '--params-file', wildcard_and_node, '-p', 'mass:=2.5', '-p', 'mass:=4',
         '-p', 'rigid_body_node:only_root:=1', '-p', 'text:=hello world'],
        ['--ros-args', '-r', '__ns:=/ns', '--params-file', sections, '--params-file',
         wildcard_and_node],
        ['--ros-args', '-r', '__ns:=/ns/deep', '--params-file', sections, '-p', 'nested_form:=2'],
        ['--ros-args', '-r', '__node:=other', '--params-file', wildcard_and_node],
        ['prog', '-p', 'not_ros:=1', '--ros-args', '--log-level', 'warn', '-p', 'a:=[true, no]',
         '-p', 'a:=[1, 2]', '-p', 'c:=5', '-p', 'c:=[1]', '-p', 'd:=[1]', '-p', 'd:=5', '-p',
         'x:=1', '-p', 'x:=true', '-p', 'z:=1.5', '-p', 'z:=2', '-p', 'w:="s"', '-p', 'w:=2',
         '--', 'not_ros:=2', '--ros-args', '-e', '/enclave', '-p', 'late:=0x1F'],
    ]


def _declared(context_args, cli_args=None):
    """Return what rclpy itself declares from the overrides: its node name, name → value."""
    context = Context()
    rclpy.init(args=context_args, context=context)
    try:
        node = Node('rigid_body_node', context=context, cli_args=cli_args,
                    automatically_declare_parameters_from_overrides=True)
        names = node.list_parameters([], 0).names
        values = {name: node.get_parameter(name).value for name in names
                  if name not in ('use_sim_time', 'start_type_description_service')}
        fqn = node.get_fully_qualified_name()
        node.destroy_node()
        return fqn, values
    finally:
        rclpy.try_shutdown(context=context)


def _typed(values):
    """Name → (type, value), a list for any array (rclpy may hold an array.array)."""
    return {name: ('list', [(type(v).__name__, v) for v in value])
            if isinstance(value, (list, tuple, array.array)) else (type(value).__name__, value)
            for name, value in values.items()}


def test_the_overrides_are_what_rclpy_declares_from_the_same_arguments(tmp_path):
    # The same values, of the same types (rcl's typing, rcl's one-slot-per-type overriding),
    # from the same sections, through the global arguments and a node's own cli_args.
    for args in _cases(tmp_path):
        fqn, declared = _declared(args)
        ours = ros_args.node_overrides(fqn, global_args=args)
        assert declared and _typed(ours) == _typed(declared), (args, fqn)
    global_args, local_args = _cases(tmp_path)[0], ['--ros-args', '-r', '__ns:=/ns', '-p',
                                                    'mass:=7', '--params-file',
                                                    str(tmp_path / 'b.yaml')]
    fqn, declared = _declared(global_args, local_args)
    assert fqn == '/ns/rigid_body_node'
    ours = ros_args.node_overrides(fqn, global_args=global_args, cli_args=local_args)
    assert _typed(ours) == _typed(declared)
    assert ros_args.node_overrides(fqn, global_args, local_args, use_global_arguments=False,
                                   parameter_overrides={'mass': 1.5}) == {
        'mass': 1.5, 'ns_star': 1}


def test_an_empty_list_is_not_set_and_sets_nothing():
    # What rclpy hands over for '-p inertia:=[]' (its NOT_SET, None); after a typed list, []
    # leaves the list (rcl fills no slot).
    assert ros_args.node_overrides('/rigid_body_node', ['--ros-args', '-p', 'inertia:=[]']) \
        == {'inertia': None}
    assert ros_args.node_overrides('/rigid_body_node', [
        '--ros-args', '-p', 'inertia:=[1.0, 2.0]', '-p', 'inertia:=[]']) == {
        'inertia': [1.0, 2.0]}


def test_an_empty_mapping_is_a_name_with_no_value(tmp_path):
    # rcl reads 'name: {}' as the parameter 'name', NOT_SET (rclpy holds it as such: checked
    # by hand, rclpy has no public accessor), not as an empty namespace; read as one, a
    # world's qos_overrides.<body topic>.depth: {} was dropped without a word (issue 30).
    path = write(tmp_path / 'empty.yaml', """
/**:
  ros__parameters:
    mass: 2
    qos_overrides./a/drag.subscription.depth: {}
""")
    assert ros_args.node_overrides('/rigid_body_node', ['--ros-args', '--params-file', path]) \
        == {'mass': 2, 'qos_overrides./a/drag.subscription.depth': None}


def _libc():
    libc = ctypes.CDLL(ctypes.util.find_library('c'), use_errno=True)
    libc.strtol.restype = ctypes.c_long
    libc.strtol.argtypes = [ctypes.c_char_p, ctypes.POINTER(ctypes.c_char_p), ctypes.c_int]
    libc.strtod.restype = ctypes.c_double
    libc.strtod.argtypes = [ctypes.c_char_p, ctypes.POINTER(ctypes.c_char_p)]
    return libc


def _c_typed(libc, text):
    """Type an unquoted scalar as rcl's get_value() does, with the C library's numbers."""
    if text in ('Y', 'y', 'yes', 'Yes', 'YES', 'true', 'True', 'TRUE', 'on', 'On', 'ON'):
        return True
    if text in ('N', 'n', 'no', 'No', 'NO', 'false', 'False', 'FALSE', 'off', 'Off', 'OFF'):
        return False
    data, end = text.encode(), ctypes.c_char_p()
    ctypes.set_errno(0)
    value = libc.strtol(data, ctypes.byref(end), 0)
    if ctypes.get_errno() == 0 and data and end.value == b'':
        return value
    if text in ('.nan', '.NaN', '.NAN'):
        return math.nan
    if text.lstrip('+-') in ('.inf', '.Inf', '.INF'):
        return -math.inf if text.startswith('-') else math.inf
    ctypes.set_errno(0)
    value = libc.strtod(data, ctypes.byref(end))
    if ctypes.get_errno() == 0 and data and end.value == b'':
        return value
    return text


SCALARS = [
    '0', '-0', '00', '7', '+5', '-12', '0x10', '-0x1F', '010', '08', '09.5', '0x', '1_000',
    '9223372036854775807', '9223372036854775808', '-9223372036854775808',
    '-9223372036854775809', '1.', '.5', '.', '-', '1e3', '1E+3', '1e', '.e3', '1.5.5', '0x.8',
    '0x1.', '0x1p3', '0X1P-3', '0x1p', '0x1.8p1', 'inf', '-inf', 'INF', 'Infinity', 'nan', 'NaN',
    '-nan', 'nan(abc)', 'nan()', '.inf', '-.Inf', '+.INF', '.nan', '.NaN', '1e400', '1e-400',
    '1e-320', '2e-323', '0x1p-1074', '0x1p-1080', '2.2250738585072014e-308', '0e-400',
    '4.9406564584124654e-324', 'yes', 'Off', 'TRUE', 'tRue', 'y', 'abc', ' 7', '7 ', '12\n',
    '1,5', '\u0663', '~', 'null',
]


def test_scalars_are_typed_as_rcl_types_them_with_the_c_library():
    libc = _libc()
    for text in SCALARS:
        ours, theirs = ros_args.scalar_value(text), _c_typed(libc, text)
        same = type(ours) is type(theirs) and (ours == theirs or (
            isinstance(ours, float) and math.isnan(ours) and math.isnan(theirs)))
        assert same, (text, ours, theirs)
    assert ros_args.scalar_value('5', quoted=True) == '5'
    assert ros_args.scalar_value('yes', quoted=True) == 'yes'


def test_the_ros_args_sections_are_read_in_order():
    rules = list(ros_args.ros_rules([
        'prog', '-p', 'a:=1', '--params-file', 'x', '--ros-args', '-r', '-p', '--param',
        'b:=2', '--log-level', 'warn', '--params-file', 'f.yaml', '--', '-p', 'c:=3',
        '--ros-args', '--ros-args', '-p', 'd:=4', '-p']))
    assert rules == [('param', 'b:=2'), ('file', 'f.yaml'), ('param', 'd:=4')]


def test_arguments_that_rcl_did_not_read_give_one_line_naming_them(tmp_path):
    # In process, global_args may differ from what rclpy.init got (which validated its own):
    # a missing or broken params file, or a -p value that is not YAML, is one ConfigError line.
    broken = write(tmp_path / 'broken.yaml', '/**:\n  ros__parameters:\n    mass_kg: [1.0\n')
    context = Context()
    rclpy.init(args=[], context=context)
    try:
        for args, texts in [
                (['--params-file', str(tmp_path / 'missing.yaml')],
                 ['--params-file', 'missing.yaml', 'cannot read it']),
                (['--params-file', broken], ['--params-file', 'broken.yaml', 'not YAML']),
                (['-p', 'mass_kg:=[1.0'], ['-p mass_kg:=[1.0', 'not a YAML value'])]:
            with pytest.raises(ConfigError) as raised:
                RigidBodyNode(['--ros-args', *args], context=context)
            message = str(raised.value)
            assert '\n' not in message and all(text in message for text in texts), message
    finally:
        rclpy.try_shutdown(context=context)


@pytest.mark.parametrize('value, kind', [('[[a]]', 'list'), ('[{x: 1}]', 'map'),
                                         ('[1.0, [2.0], 3.0]', 'list')])
def test_a_list_holding_a_list_or_a_map_is_refused_naming_the_parameter(tmp_path, value, kind):
    # rcl takes them (it flattens [[a]] to [a], makes [{x: 1}] a parameter 'joint_names.x');
    # the overrides' own reading raised AttributeError: a traceback and exit 1
    path = write(tmp_path / 'nested.yaml', f'/**:\n  ros__parameters:\n    joint_names: {value}\n')
    with pytest.raises(ros_args.RosArgsError) as raised:
        ros_args.node_overrides('/rigid_body_node', ['--ros-args', '--params-file', path])
    assert str(raised.value) == (f'--params-file {path}: parameter joint_names: an item of its '
                                 f'list is a {kind} (line 3); a value is a scalar or a list of '
                                 'scalars')
    with pytest.raises(ros_args.RosArgsError) as raised:
        ros_args.node_overrides('/rigid_body_node', ['--ros-args', '-p', f'joint_names:={value}'])
    assert str(raised.value).startswith(f'-p joint_names:={value}: parameter joint_names: an '
                                        f'item of its list is a {kind} (line 1)'), raised.value


def test_a_nested_list_in_a_params_file_stops_the_node_with_one_line(start_node, tmp_path):
    path = write(tmp_path / 'nested.yaml', '/**:\n  ros__parameters:\n    joint_names: [[a]]\n')
    node = start_node(extra_args=['--params-file', path])
    assert node.wait(60) == 2, node.stderr
    lines = [line for line in node.stderr.splitlines() if line.strip()]
    assert lines == [f'rigid_body_node: --params-file {path}: parameter joint_names: an item '
                     'of its list is a list (line 3); a value is a scalar or a list of '
                     'scalars'], lines


def test_no_private_rclpy_attribute_is_read_for_the_overrides():
    # Issue 8 item 8: no private API of a dependency.
    found = [f'{path.relative_to(REPO)}:{number}'
             for path in sorted((REPO / 'rbd_ros').rglob('*.py'))
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if '_parameter_overrides' in line]
    assert found == [], found


def test_the_overrides_module_does_not_import_rclpy():
    code = ('import sys\nimport rbd_ros.ros.ros_args\n'
            'print(sorted(m for m in sys.modules if m.split(".")[0] == "rclpy"))\n')
    proc = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          cwd=REPO, timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip() == '[]', (proc.stdout, proc.stderr)
