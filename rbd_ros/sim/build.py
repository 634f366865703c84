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
The simulator of a configuration, and its first step taken before the node starts.

:func:`make_simulator` is the one place that picks the free-body simulator (one body, no
contact) or the world simulator; :func:`check_first_step` takes the first physics step on a
throw-away simulator, so a configuration whose first step is not finite is refused at start
with one line naming the parameters that most likely caused it.
"""

from dataclasses import replace as dataclass_replace
import math

import numpy as np

from rbd_ros.core import ConfigError, ModelError, NonFiniteError, Simulator
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.params import fail, fmt, PARAMETERS_BY_NAME
from rbd_ros.sim.robot_contact import RobotContactWorld
from rbd_ros.sim.robot_world import RobotWorld
from rbd_ros.sim.world_joints import JointedWorldSimulator

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

    With robots, a :class:`rbd_ros.sim.robot_world.RobotWorld` of them; with robots and free
    bodies, a ground or obstacles, a :class:`rbd_ros.sim.robot_contact.RobotContactWorld`
    (with the world's ``joint_names`` too).

    With contact (named bodies, a ground or obstacles) a :class:`WorldSimulator` of every body
    of ``config.bodies`` and the static world; else the free-body simulator of the one body.
    Both answer ``time_ns``, ``arrays``, ``body_state(i)``, ``set_body_loads(i, ...)``,
    ``step``, ``reset``, ``contact_wrench_w`` and ``contacts`` (None without contact). A world
    with ``joint_names`` is a :class:`rbd_ros.sim.world_joints.JointedWorldSimulator`.

    A world with joints projects its placement onto them at its first step
    (``defer_projection``), as a robot world does: building it compiles nothing, so a cold
    node publishes t = 0 while the first-step check compiles its kernels in the background.
    """
    if config.robots and config.contact:
        return RobotContactWorld(config.robots, config.bodies, config.static_world,
                                 config.integrator, config.timestep_ns, config.world_joints)
    if config.robots:
        return RobotWorld(config.robots, config.timestep_ns)
    if not config.contact:
        (body,) = config.bodies
        return _FreeBodySimulator(body.model, body.initial_state, integrator=config.integrator,
                                  timestep_ns=config.timestep_ns)
    bodies = [WorldBody(b.name, b.model, b.collision_shape, b.material) for b in config.bodies]
    states = [b.initial_state for b in config.bodies]
    if config.world_joints:
        return JointedWorldSimulator(bodies, states, config.static_world, config.world_joints,
                                     integrator=config.integrator,
                                     timestep_ns=config.timestep_ns, defer_projection=True)
    return WorldSimulator(bodies, states, config.static_world, integrator=config.integrator,
                          timestep_ns=config.timestep_ns, threads=config.threads)


def _quantities(state, model):
    """
    Return ``(parameter, what)`` pairs of a body's published quantities that are not finite.

    The kinetic energy ``½ M vᵀv`` (blamed on the linear velocity), ``½ ωᵀ I ω`` and the
    angular momentum ``I ω`` (on the angular velocity): ``/diagnostics`` sums them every second,
    and ``|v|`` above ~1e154 m/s overflows ``vᵀv`` although each component is finite.
    """
    with np.errstate(over='ignore', invalid='ignore'):
        linear = state.kinetic_energy_linear(model)
        rotational = state.kinetic_energy_rotational(model)
        momentum = state.angular_momentum_w(model)
    out = []
    if not math.isfinite(linear):
        out.append(('initial_linear_velocity', 'its kinetic energy ½ m vᵀv overflows'))
    if not (math.isfinite(rotational) and np.all(np.isfinite(momentum))):
        out.append(('initial_angular_velocity',
                    'its rotational energy ½ ωᵀIω or angular momentum Iω overflows'))
    return out


def _check_initial_quantities(config):
    """Refuse, naming the body's parameter, an initial state whose energies overflow."""
    for body in config.bodies:
        for base, what in _quantities(body.initial_state, body.model):
            spec = PARAMETERS_BY_NAME[base]
            name = f'{body.parameter_prefix}{base}'
            who = f'body {body.name!r}: ' if body.parameter_prefix else ''
            fail(dataclass_replace(spec, name=name), config.parameters[name],
                 f'the first physics step is not finite ({who}{what})', ConfigError)


def _step_once(config):
    """Take one step on a new simulator; raise NonFiniteError if any body's energy is not."""
    simulator = make_simulator(config)
    simulator.step(1)
    for i, body in enumerate(config.bodies):
        wrong = _quantities(simulator.body_state(i), body.model)
        if wrong:
            raise NonFiniteError(f'state: after the first step body {body.name!r}: '
                                 f'{wrong[0][1]}')


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
        raise ConfigError(f'parameter {names[0]} = {fmt(params[names[0]])}{unit}: the first '
                          f'physics step is not finite ({reason})')


def _blame_robot_rates(params, reason):
    """
    Raise naming the ``robots.<name>.initial_joint_velocities`` without which the step is finite.

    A rate within :data:`~rbd_ros.sim.params.MAX_JOINT_RATE` can still be too fast for the
    step (a chain's RK4 step blows up, the projection does not converge). Returns if no
    robot's rates are to blame.
    """
    for robot in params.get('robot_names', ()):
        name = f'robots.{robot}.initial_joint_velocities'
        if params.get(name) and _finite_with(params, {name: []}):
            raise ConfigError(f'parameter {name} = {fmt(params[name])} rad/s or m/s: the first '
                              f'physics step is not finite ({reason})', field=name,
                              value=params[name], unit='rad/s or m/s')


def kernel_kind(config):
    """
    Return the kind of compiled step ``config``'s first step needs (:data:`jitcache.KIND_MODULES`).

    ``joints`` for robots that touch nothing, ``world_joints`` for a world with ``joint_names``
    or with robots that have joints (the contact step compiled with the joints' visits, a
    specialisation of its own), ``contact`` for any other world that can touch something,
    else ``free``.
    """
    if config.robots and not config.contact:
        return 'joints'
    if config.world_joints or any(robot.placement.joints for robot in config.robots):
        return 'world_joints'
    return 'contact' if config.contact else 'free'


def check_first_step(config):
    """
    Take one physics step from the initial state on a throw-away simulator.

    Valid parameters can still make the first step non-finite (``initial_angular_velocity:
    [1e200, 0.0, 0.0]`` overflows); the node refuses them at start instead of pausing on its
    first step. This also compiles the physics kernel.

    Every body of a world is checked: its initial kinetic energy and angular momentum first
    (named without a trial step), then the step, then each body's energies after it.

    :raises ConfigError: naming the parameter that makes the step non-finite: the body's
        velocity whose energy overflows, else the first of :data:`_FIRST_STEP_SUSPECTS` whose
        default value makes the step finite (in a world, the body found by halving), a
        robot's joint rates after a world's bodies.
    """
    _check_initial_quantities(config)
    try:
        _step_once(config)
        return
    except NonFiniteError as exc:
        reason = str(exc)
    params = config.to_parameters()
    _blame_world_body(params, reason)  # returns at once without body_names
    _blame_robot_rates(params, reason)  # and without robot_names
    for name in _FIRST_STEP_SUSPECTS:
        spec = PARAMETERS_BY_NAME[name]
        default = list(spec.default) if isinstance(spec.default, tuple) else spec.default
        if params[name] == default:
            continue
        try:
            _step_once(NodeConfig.from_parameters({**params, name: default}))
        except (ModelError, ConfigError, NonFiniteError):
            continue  # still not finite, or not a valid configuration without this value
        fail(spec, params[name], f'the first physics step is not finite ({reason})',
             ConfigError)
    raise ConfigError(f'parameters: the first physics step is not finite ({reason})')
