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
The given parameters sorted into values: the table's and each named item's, coerced.

:meth:`rbd_ros.sim.config.NodeConfig.from_parameters`'s first stage. Each function takes its
parameters out of the given ``params`` (what is left at the end is an unknown name) into
``values`` (missing names take their defaults), coerced to the spec's type and range-checked:
the table (:data:`rbd_ros.sim.params.PARAMETERS`), each extra wrench input, each obstacle, each
body of a world with its own inputs, each robot and command group. The name lists
(``wrench_input_names``, ``obstacle_names``, ``body_names``) are checked against the one name
rule here.
"""

from dataclasses import replace as dataclass_replace

from rbd_ros.core import ConfigError
from rbd_ros.core.contact.world import is_valid_name, NAME_RULE
from rbd_ros.sim import robots as robot_params
from rbd_ros.sim.params import (body_parameter_specs, check_range, coerce, DOUBLE, fail,
                                input_parameter_specs, INTEGER, MAIN_INPUT, MAX_BODIES,
                                obstacle_parameter_specs, PARAMETERS, PARAMETERS_BY_NAME)


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
