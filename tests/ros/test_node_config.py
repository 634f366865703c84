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

"""The parameter table and NodeConfig (no ROS): defaults, validation messages, round trip."""

from dataclasses import replace as dataclass_replace
import math
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest
from rbd_ros.core import ConfigError, ModelError
from rbd_ros.core import inertia as inertia_mod
from rbd_ros.ros import ros_args
from rbd_ros.sim import build
from rbd_ros.sim import params as sim_params
from rbd_ros.sim import robots as robot_params
from rbd_ros.sim import world_joints as joint_params
from rbd_ros.sim.config import NodeConfig
import yaml

REPO = pathlib.Path(__file__).resolve().parents[2]
ISSUE_NAMES = (
    'mass_kg', 'inertia', 'shape', 'dimensions_m', 'initial_position', 'initial_orientation',
    'initial_linear_velocity', 'initial_angular_velocity', 'gravity', 'linear_damping',
    'angular_damping', 'integrator', 'timestep_s', 'publish_rate_hz', 'real_time_factor',
    'duration_s', 'start_paused', 'world_frame', 'body_frame', 'twist_frame',
    'default_wrench_frame', 'wrench_timeout_s', 'max_force_n', 'max_torque_nm',
    'wrench_input_names', 'publish_clock', 'record_path')


def test_the_table_holds_every_public_name_with_description_and_a_valid_default():
    names = [spec.name for spec in sim_params.PARAMETERS]
    assert len(names) == len(set(names))
    assert set(ISSUE_NAMES) <= set(names)
    for spec in sim_params.PARAMETERS:
        assert spec.description.endswith('.'), spec.name
        if spec.bounds is not None:
            assert spec.bounds[0] <= spec.default <= spec.bounds[1], spec.name
    defaults = NodeConfig.from_parameters({})
    assert defaults.parameters == {s.name: s.default for s in sim_params.PARAMETERS}


def test_defaults_are_the_issue_defaults():
    c = NodeConfig.from_parameters({})
    assert c.model.mass_kg == 1.0
    assert c.timestep_ns == 1_000_000 and c.publish_period_ns == 10_000_000
    assert c.real_time_factor == 1.0 and c.duration_ns == 0 and not c.start_paused
    assert (c.world_frame, c.body_frame, c.twist_frame) == ('world', 'base_link', 'world')
    assert c.default_wrench_frame == 'world' and c.wrench_timeout_ns == 0
    assert not c.publish_clock and c.record_path == ''
    assert np.array_equal(c.model.gravity_w, [0.0, 0.0, 0.0])
    # No inertia and no shape: the default box of msg_config/default.yaml.
    box = inertia_mod.from_shape('box', [0.2, 0.1, 0.05], 1.0)
    assert np.array_equal(c.model.inertia_b, box.inertia_b)


def test_round_trip_through_a_plain_dict_and_yaml():
    params = {'mass_kg': 2.0, 'inertia': [0.1, 0.2, 0.25, 0.01, 0.0, -0.02],
              'initial_orientation': [0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)],
              'wrench_input_names': ['left'], 'wrench_inputs.left.point_b': [0.0, 0.3, 0.0],
              'integrator': 'rk4', 'timestep_s': 0.002, 'twist_frame': 'body'}
    c = NodeConfig.from_parameters(params)
    plain = c.to_parameters()
    again = NodeConfig.from_parameters(yaml.safe_load(yaml.safe_dump(plain)))
    assert again == c
    assert again.to_parameters() == plain


def test_inertia_is_read_in_ros_order_and_orientation_in_xyzw_order():
    c = NodeConfig.from_parameters({
        'inertia': [1.0, 2.0, 2.5, 0.1, 0.2, 0.3],
        'initial_orientation': [0.0, 0.0, math.sqrt(0.5), math.sqrt(0.5)]})
    i_b = c.model.inertia_b
    assert (i_b[0, 0], i_b[1, 1], i_b[2, 2]) == (1.0, 2.0, 2.5)
    assert (i_b[0, 1], i_b[0, 2], i_b[1, 2]) == (0.1, 0.2, 0.3)
    # (w, x, y, z) inside: 90° about z.
    np.testing.assert_allclose(c.initial_state.orientation_wb,
                               [math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)], rtol=0, atol=1e-15)


def test_timestep_must_be_whole_nanoseconds():
    assert NodeConfig.from_parameters({'timestep_s': 0.001}).timestep_ns == 1_000_000
    assert NodeConfig.from_parameters({'timestep_s': 1e-9}).timestep_ns == 1
    assert NodeConfig.from_parameters({'timestep_s': 0.0005}).timestep_ns == 500_000
    with pytest.raises(ConfigError, match=r'timestep_s = .* s: must be a whole number'):
        NodeConfig.from_parameters({'timestep_s': 1.5e-9})


def test_record_on_error_takes_continue_or_stop():
    assert NodeConfig.from_parameters({}).record_on_error == 'continue'
    assert NodeConfig.from_parameters({'record_on_error': 'stop'}).record_on_error == 'stop'


def test_integer_values_are_accepted_for_doubles():
    # A YAML file may say mass_kg: 2 (an integer); it means 2.0 kg.
    assert NodeConfig.from_parameters({'mass_kg': 2}).model.mass_kg == 2.0


@pytest.mark.parametrize('params, error, text', [
    ({'mass_kg': -1.0}, ModelError, 'parameter mass_kg = -1.0 kg: must be > 0'),
    # the whole rule: it said 'must be in [0, 1e+12]', though 0 is refused
    ({'mass_kg': 1e308}, ModelError,
     'parameter mass_kg = 1e+308 kg: must be > 0 and <= 1e+12'),
    ({'max_force_n': 1e300}, ConfigError,
     'parameter max_force_n = 1e+300 N: must be > 0 and <= 1e+12'),
    ({'record_on_error': 'retry'}, ConfigError,
     "parameter record_on_error = 'retry'"),
    ({'mass_kg': math.inf}, ModelError, 'parameter mass_kg = inf kg: must be finite'),
    ({'inertia': [1.0, 1.0]}, ModelError, 'must have 6 values'),
    ({'inertia': [1.0, 1.0, 3.0, 0.0, 0.0, 0.0]}, ModelError, 'triangle inequality'),
    ({'inertia': [1.0, 2.0, 3.0, 0.0, 0.0, 5.0]}, ModelError, 'positive definite'),
    ({'inertia': [1.0, 1.0, 1.0, 0.0, 0.0, 0.0], 'shape': 'box'}, ModelError, 'not both'),
    ({'dimensions_m': [1.0]}, ModelError, 'needs shape'),
    ({'shape': 'cone'}, ModelError, "parameter shape = 'cone': must be one of"),
    ({'integrator': 'euler'}, ConfigError, "parameter integrator = 'euler': must be one of"),
    ({'timestep_s': 0.0}, ConfigError, 'parameter timestep_s = 0.0 s: must be > 0'),
    ({'publish_rate_hz': 0.0}, ConfigError, 'publish_rate_hz = 0.0 Hz: must be >= 1e-06 (a'),
    ({'real_time_factor': -1.0}, ConfigError, 'real_time_factor = -1.0: must be 0, or in'),
    ({'real_time_factor': 5e-324}, ConfigError,
     'real_time_factor = 5e-324: must be 0 (as fast as possible) or in [0.001, 1e+06]'),
    ({'real_time_factor': 2e6}, ConfigError, 'real_time_factor = 2000000.0: must be in'),
    ({'publish_rate_hz': 1e-300}, ConfigError,
     'publish_rate_hz = 1e-300 Hz: must be >= 1e-06 (a publish period of at most 1e6 s)'),
    ({'timestep_s': 1e-13}, ConfigError,
     'timestep_s = 1e-13 s: rounds to 0 ns: must be at least 1 ns'),
    ({'wrench_timeout_s': 1e-13}, ConfigError,
     'wrench_timeout_s = 1e-13 s: rounds to 0 ns: must be 0 or at least 1 ns'),
    ({'duration_s': 1e-13}, ConfigError, 'duration_s = 1e-13 s: rounds to 0 ns'),
    ({'mass_kg': None}, ModelError, 'parameter mass_kg = None kg: must be a number'),
    ({'twist_frame': 'odom'}, ConfigError, "must be 'world' or 'body'"),
    ({'default_wrench_frame': 'map'}, ConfigError, "must be 'world' or 'body'"),
    ({'body_frame': 'world'}, ConfigError, 'must differ from world_frame'),
    ({'world_frame': ''}, ConfigError, 'must not be empty'),
    # tf2 refuses a frame id with a leading '/'; a NUL or a space made a frame no one can name
    # (all three were broadcast on /tf)
    ({'world_frame': '/world'}, ConfigError, "world_frame = '/world': must not start with '/'"),
    ({'body_frame': 'a b'}, ConfigError, "body_frame = 'a b': holds ' ' at index 1"),
    ({'body_names': ['a'], 'bodies.a.shape': 'sphere', 'bodies.a.dimensions_m': [0.1],
      'bodies.a.body_frame': 'a\x00'}, ConfigError,
     "bodies.a.body_frame = 'a\\x00': holds '\\x00' at index 1: a frame id has no whitespace"),
    ({'body_names': ['a'], 'bodies.a.shape': 'sphere', 'bodies.a.dimensions_m': [0.1],
      'bodies.a.body_frame': '/a'}, ConfigError, "bodies.a.body_frame = '/a': must not start"),
    ({'gravity': [0.0, -9.81]}, ModelError, 'must have 3 values'),
    ({'initial_orientation': [0.0, 0.0, 0.0, 0.0]}, ConfigError, 'norm 0'),
    ({'mas_kg': 1.0}, ConfigError, 'parameter mas_kg = 1.0: unknown parameter name'),
    ({'wrench_inputs.x.topic': 'a'}, ConfigError, 'unknown parameter name'),
    ({'wrench_input_names': ['a', 'a']}, ConfigError, 'distinct'),
    ({'wrench_input_names': ['wrench']}, ConfigError, 'main input'),
    ({'wrench_input_names': ['a b']}, ConfigError, 'letters, digits'),
    ({'wrench_input_names': ['a'], 'wrench_inputs.a.frame': 'odom'}, ConfigError,
     "wrench_inputs.a.frame = 'odom': must be 'world' or 'body'"),
    ({'wrench_input_names': ['a'], 'wrench_inputs.a.topic': 'wrench'}, ConfigError,
     'already used'),
    ({'max_force_n': 0.0}, ConfigError, 'max_force_n = 0.0 N: must be > 0'),
    ({'start_paused': 'yes'}, ConfigError, 'must be true or false'),
])
def test_invalid_values_raise_one_line_naming_parameter_value_and_rule(params, error, text):
    with pytest.raises(error) as info:
        NodeConfig.from_parameters(params)
    message = str(info.value)
    assert '\n' not in message
    assert message.startswith('parameter ')
    assert text in message, message


def test_an_empty_array_that_arrives_as_not_set_means_the_empty_default():
    # ROS YAML cannot type [] ('inertia: []' in a params file, '-p inertia:=[]'): rclpy hands
    # the node a NOT_SET value, None. For an array parameter that is the documented [].
    c = NodeConfig.from_parameters({'inertia': None, 'dimensions_m': None,
                                    'wrench_input_names': None})
    assert c == NodeConfig.from_parameters({})
    assert c.parameters['inertia'] == () and c.parameters['wrench_input_names'] == ()


def test_real_time_factor_check_for_live_changes():
    assert sim_params.check_real_time_factor(0.0) == 0.0
    assert sim_params.check_real_time_factor(1e-3) == 1e-3
    assert sim_params.check_real_time_factor(1e6) == 1e6
    for bad in (5e-324, 9.99e-4, 1.0000001e6, -1.0, math.inf, math.nan):
        with pytest.raises(ConfigError, match='parameter real_time_factor = '):
            sim_params.check_real_time_factor(bad)


@pytest.mark.parametrize('params, name', [
    ({'initial_angular_velocity': [1e200, 0.0, 0.0]}, 'initial_angular_velocity'),
    ({'initial_angular_velocity': [0.0, 1e200, 0.0], 'integrator': 'rk4'},
     'initial_angular_velocity'),
    ({'initial_linear_velocity': [1e308, 0.0, 0.0], 'timestep_s': 1.0,
      'gravity': [1e308, 0.0, 0.0]}, 'initial_linear_velocity'),
    # within MAX_JOINT_RATE but far too fast for a 1 ms step of the arm: its RK4 step blows
    # up (the projection does not converge); the message named no parameter
    ({'robot_names': ['arm'], 'robots.arm.urdf_path': str(REPO / 'msg_config' / 'urdf' /
                                                          'arm3.urdf'),
      'robots.arm.initial_joint_velocities': [1e6, 0.0, 0.0]},
     'robots.arm.initial_joint_velocities'),
])
def test_a_non_finite_first_step_is_refused_naming_the_parameter(params, name):
    # Each value is finite and valid on its own; the first physics step overflows.
    config = NodeConfig.from_parameters(params)
    with pytest.raises(ConfigError) as info:
        build.check_first_step(config)
    message = str(info.value)
    assert message.startswith(f'parameter {name} = ') and 'not finite' in message, message
    assert '\n' not in message
    build.check_first_step(NodeConfig.from_parameters({}))  # the defaults step finitely


def test_msg_config_files_are_valid_configs():
    files = sorted((REPO / 'msg_config').glob('*.yaml'))
    assert len(files) >= 4
    for path in files:
        # Read as the node reads it: a relative mesh_path is relative to the file.
        params = ros_args.store_from_args(['--ros-args', '--params-file', str(path)]).values_for(
            '/rigid_body_node')
        NodeConfig.from_parameters(params)


def test_config_and_session_do_not_import_rclpy():
    code = ('import sys; import rbd_ros.sim.config, rbd_ros.sim.inputs, rbd_ros.sim.session, '
            'rbd_ros.msgs.conversions; '
            'print(sorted(m for m in sys.modules if m.startswith("rclpy")))')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                         cwd=REPO, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == '[]'


def test_the_docs_document_every_parameter():
    reference = (REPO / 'doc' / 'parameters.md').read_text()
    for spec in (sim_params.PARAMETERS + sim_params.input_parameter_specs('<name>')
                 + sim_params.obstacle_parameter_specs('<name>')
                 + robot_params.robot_parameter_specs('<name>')
                 + robot_params.joint_parameter_specs('<name>', '<joint>')
                 + robot_params.group_parameter_specs('<name>')
                 + joint_params.joint_parameter_specs('<name>')):
        assert f'| `{spec.name}` |' in reference, spec.name


README_TYPES = {sim_params.BOOL: 'bool', sim_params.INTEGER: 'integer',
                sim_params.DOUBLE: 'double', sim_params.STRING: 'string',
                sim_params.DOUBLE_ARRAY: 'double[]', sim_params.STRING_ARRAY: 'string[]'}


def _readme_value(text):
    text = text.strip('`')
    if text == "''":
        return ''
    try:
        return float(text)
    except ValueError:
        value = yaml.safe_load(text)
        return tuple(value) if isinstance(value, list) else value


def _documented_rows():
    """Return doc/parameters.md's table rows by name: (type, default, unit, meaning, rule)."""
    rows = {}
    for line in (REPO / 'doc' / 'parameters.md').read_text(encoding='utf-8').splitlines():
        cells = [c.strip() for c in re.split(r'(?<!\\)\|', line)[1:-1]]  # '\|' is text
        if line.startswith('| `') and len(cells) == 6 and cells[1] in README_TYPES.values():
            rows[cells[0].strip('`')] = cells[1:]
    return rows


def _documented_specs():
    """Return every ParamSpec as the table names it (``<name>``, ``<joint>``)."""
    return list(sim_params.PARAMETERS) + [
        dataclass_replace(spec, name=spec.name.replace('.x.', '.<name>.'),
                          default=spec.default.replace('_x', '_<name>')
                          if spec.kind == sim_params.STRING else spec.default)
        for spec in sim_params.input_parameter_specs('x')] + [
        dataclass_replace(spec, name=spec.name.replace('.x.', '.<name>.'))
        for spec in sim_params.obstacle_parameter_specs('x')] + list(
        robot_params.robot_parameter_specs('<name>')
        + robot_params.joint_parameter_specs('<name>', '<joint>')
        + robot_params.group_parameter_specs('<name>')
        + joint_params.joint_parameter_specs('<name>'))


def test_the_documented_parameter_table_is_the_parameter_table():
    rows = _documented_rows()
    specs = _documented_specs()
    assert sorted(rows) == sorted(spec.name for spec in specs)
    for spec in specs:
        kind, default, unit = rows[spec.name][:3]
        assert kind == README_TYPES[spec.kind], spec.name
        assert unit == spec.unit, spec.name
        expected = spec.default
        if spec.name == 'threads':   # the machine's: the CPUs this process may use
            expected = 'CPUs'
        if spec.kind == sim_params.DOUBLE:
            expected = float(expected)
        assert _readme_value(default) == expected, spec.name


def _doc_number(value):
    """Return ``value`` as doc/parameters.md writes it: ``1e12``, ``1e-6``, ``0.001``, ``1``."""
    return re.sub(r'e\+?(-?)0*(\d)', r'e\1\2', f'{value:g}')


def test_the_documented_rules_state_every_upper_bound():
    # a bounded number's rule in the table states its upper bound, as its error message does
    # (mass_kg's 1e12 was in neither: 1e308 kg was refused as 'must be in [0, 1e+12]')
    rows = _documented_rows()
    for spec in _documented_specs():
        if spec.kind != sim_params.DOUBLE or spec.bounds is None:
            continue
        rule = rows[spec.name][4]
        high = re.escape(_doc_number(spec.bounds[1]))
        assert re.search(rf'(≤ |, ){high}( |,|\]|$)', rule), (spec.name, rule)


def test_the_advertised_range_starts_at_the_smallest_accepted_value():
    # ros2 param describe shows floating_point_range's from_value: it must be what check_range
    # accepts, not below it (publish_rate_hz advertised 0.0 while its rule refused < 1e-6).
    from rbd_ros.ros import parameters as ros_parameters
    for spec in sim_params.PARAMETERS:
        if spec.kind != sim_params.DOUBLE or spec.bounds is None:
            continue
        (advertised,) = ros_parameters.descriptor(spec).floating_point_range
        sim_params.check_range(spec, advertised.from_value)  # accepted: raises if refused
        below = math.nextafter(advertised.from_value, -math.inf)
        with pytest.raises((ConfigError, ModelError), match=f'parameter {spec.name} = '):
            sim_params.check_range(spec, below)
