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
The parameters renamed since a release: refused under their old names, read so in recordings.

A params file of old names is refused with one line naming the new one
(:func:`refuse_old_names`); a recording's parameters are read under today's names
(:func:`recorded_parameters`, the one place that reads old ones).
"""

from rbd_ros.core import ConfigError
from rbd_ros.sim.param_rules import fmt

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
