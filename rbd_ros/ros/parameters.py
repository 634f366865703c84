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
The node's parameters as ROS parameters: which names are ours, their descriptors, declaration.

The table itself (names, types, units, ranges, rules) is :data:`rbd_ros.sim.params.PARAMETERS`;
this module only says how a row of it becomes an rclpy parameter, so that ``ros2 param
describe`` shows the unit, the range and the rule the node enforces.
"""

import math

from rbd_ros.sim import params as sim_params
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType)
from rclpy.parameter import Parameter

_TYPES = {sim_params.BOOL: ParameterType.PARAMETER_BOOL,
          sim_params.INTEGER: ParameterType.PARAMETER_INTEGER,
          sim_params.DOUBLE: ParameterType.PARAMETER_DOUBLE,
          sim_params.STRING: ParameterType.PARAMETER_STRING,
          sim_params.DOUBLE_ARRAY: ParameterType.PARAMETER_DOUBLE_ARRAY,
          sim_params.STRING_ARRAY: ParameterType.PARAMETER_STRING_ARRAY}
_ARRAY_TYPES = {sim_params.DOUBLE_ARRAY: Parameter.Type.DOUBLE_ARRAY,
                sim_params.STRING_ARRAY: Parameter.Type.STRING_ARRAY}
#: Parameters rclpy or launch set on every node: neither ours nor worth a warning.
RCLPY_PARAMETERS = ('use_sim_time', 'start_type_description_service')
# Parameters whose names depend on a list (wrench_input_names, obstacle_names, body_names):
# wrench_inputs.<name>.*, obstacles.<name>.*, bodies.<name>.*
_DYNAMIC_PREFIXES = ('wrench_inputs.', 'obstacles.', 'bodies.', 'robots.', 'command_groups.',
                     'joints.')


def is_ours(name):
    """Return whether ``name`` is for the config (a renamed one too: it refuses it by name)."""
    return (name in sim_params.PARAMETERS_BY_NAME or name.startswith(_DYNAMIC_PREFIXES)
            or name in sim_params.RENAMED_PARAMETERS)


def is_rclpys(name):
    """Return whether rclpy takes ``name`` itself (``use_sim_time``, ``qos_overrides.*``)."""
    return name in RCLPY_PARAMETERS or name.startswith('qos_overrides.')


def descriptor(spec):
    """Return the :class:`ParameterDescriptor` of a :class:`rbd_ros.sim.params.ParamSpec`."""
    result = ParameterDescriptor(
        name=spec.name, type=_TYPES[spec.kind], read_only=spec.read_only,
        description=spec.description + (f' [{spec.unit}]' if spec.unit else ''),
        additional_constraints=spec.rule)
    if spec.bounds is not None and spec.kind == sim_params.DOUBLE:
        low = float(spec.bounds[0])
        if spec.rule.startswith('> 0') and low == 0.0:
            # (0, high] of the doubles is the closed [smallest positive double, high]: the
            # range excludes 0 and admits every positive double up to the upper bound (left
            # out, ros2 param describe showed no upper bound at all).
            low = math.ulp(0.0)
        result.floating_point_range = [FloatingPointRange(
            from_value=low, to_value=float(spec.bounds[1]))]
    elif spec.bounds is not None and spec.kind == sim_params.INTEGER:
        result.integer_range = [IntegerRange(
            from_value=int(spec.bounds[0]), to_value=int(spec.bounds[1]))]
    return result


def declare(node, spec, value):
    """Declare ``spec`` on ``node`` with ``value``, validated already (overrides ignored)."""
    described = descriptor(spec)
    if isinstance(value, tuple) and not value:
        # rclpy cannot infer the type of []: declare it writable by type, give it the typed
        # value [] (so that get_parameters, hence ros2 param dump/get, returns a value for
        # every name), then make it read-only.
        writable = ParameterDescriptor()
        writable.type = described.type
        node.declare_parameter(spec.name, _ARRAY_TYPES[spec.kind], writable,
                               ignore_override=True)
        node.set_parameters([Parameter(spec.name, _ARRAY_TYPES[spec.kind], [])])
        node.set_descriptor(spec.name, described)
        return
    if isinstance(value, tuple):
        value = list(value)
    node.declare_parameter(spec.name, value, described, ignore_override=True)


def coerce_parameters(params):
    """
    Return ``params`` with an integer ``real_time_factor`` as a double.

    ``ros2 param set <node> real_time_factor 2`` sends an INTEGER, which rclpy would refuse
    against the DOUBLE descriptor; a params file's ``real_time_factor: 2`` is accepted.
    """
    return [Parameter(p.name, Parameter.Type.DOUBLE, float(p.value))
            if p.name == 'real_time_factor' and p.type_ == Parameter.Type.INTEGER else p
            for p in params]
