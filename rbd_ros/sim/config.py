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
:class:`NodeConfig`, the validated configuration of a node (no rclpy), and the map of its stages.

:meth:`NodeConfig.from_parameters` takes a plain ``dict`` name → value (missing names take their
default) and either returns a frozen :class:`NodeConfig` or raises :class:`ConfigError` /
:class:`ModelError` with one line naming the parameter, its value, its unit and the rule.
:meth:`NodeConfig.to_parameters` returns the plain ``dict`` back (round trip), which is what a
recording stores so that replay can rebuild exactly the same configuration.

An array parameter given as ``[]`` reaches the node as a value of type NOT_SET (``None``): ROS
YAML cannot type an empty list. :meth:`NodeConfig.from_parameters` reads ``None`` as ``[]`` for
array parameters.

The parameters (names, types, units, ranges, the rule of every value) are
:mod:`rbd_ros.sim.params`. :meth:`NodeConfig.from_parameters` reads them in stages, one module
each, in this order:

- :mod:`.config_values`: the given names sorted into the table's values and each named item's
  (wrench inputs, obstacles, bodies, robots, command groups), coerced and range-checked;
- :mod:`.config_settings`: the integrator and times, the frames, the wrench limits and the
  recording; motors' time constants against the step;
- :mod:`.config_obstacles`: the static world (``ground.*`` and ``obstacle_names``);
- :mod:`.config_bodies`: :class:`BodyConfig` and :class:`WrenchInputSpec`, each body's shape,
  model, start, material and inputs, a world's bodies and their overlaps;
- :mod:`rbd_ros.sim.robots` and :mod:`rbd_ros.sim.world_joints`: robots, joints between bodies.

:class:`BodyConfig`, :class:`WrenchInputSpec`, :func:`overlap_error` and :func:`xyzw_to_wxyz`
are importable from here too.
"""

from dataclasses import dataclass, replace as dataclass_replace

from rbd_ros.core import ConfigError
from rbd_ros.core.contact.world import validate_material
from rbd_ros.sim import robots as robot_params
from rbd_ros.sim import world_joints as joint_params
from rbd_ros.sim.config_bodies import _reraise, _single_body, _world_bodies, _wrench_inputs
from rbd_ros.sim.config_bodies import (  # noqa: F401 (importable from here, as before)
    BodyConfig, overlap_error, WrenchInputSpec, xyzw_to_wxyz)
from rbd_ros.sim.config_obstacles import _static_world
from rbd_ros.sim.config_settings import (_check_contact_integrator, _check_time_constants,
                                         _frame_settings, _limits_and_recording, _time_settings)
from rbd_ros.sim.config_values import (_body_input_specs, _body_values, _input_values,
                                       _obstacle_values, _robot_values, _table_values)
from rbd_ros.sim.params import (body_parameter_specs, fail, fmt, input_parameter_specs,
                                obstacle_parameter_specs, PARAMETERS, PARAMETERS_BY_NAME,
                                refuse_old_names)


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
    :ivar robots: the :class:`rbd_ros.sim.robots.RobotConfig` tuple (``robot_names`` order).
        With free bodies, a ground or obstacles, the robots' links are bodies of one contact
        world (:mod:`rbd_ros.sim.robot_contact`); :attr:`bodies` holds the free bodies only.
    :ivar command_groups: the :class:`rbd_ros.sim.robots.CommandGroup` tuple.
    :ivar world_joints: the :class:`rbd_ros.sim.world_joints.WorldJoint` tuple
        (``joint_names`` order): joints between the bodies of a world.
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
    robots: tuple = ()
    command_groups: tuple = ()
    world_joints: tuple = ()

    @property
    def named(self):
        """
        Return True when the bodies are addressed by name (``body_names`` given).

        Their topics, inputs and parameters then carry the name, and a ``poses`` array holds
        every pose; the body of a single-body file has none of that (its prefixes are ``''``).
        """
        return bool(self.parameters['body_names'])

    @property
    def per_body_topics(self):
        """Return whether each body of a world has its own output topics (``per_body_topics``)."""
        return self.parameters['per_body_topics']

    @property
    def threads(self):
        """Return the threads a world's contact step may use (``threads``)."""
        return self.parameters['threads']

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
    def from_parameters(cls, params=None, *, accepted_frames=None):
        """
        Validate ``params`` (name → value; missing names take their defaults) into a config.

        :param accepted_frames: None (a start); a list: the robot link frame refusals
            (:func:`rbd_ros.sim.robots.check_link_frames`) go there instead of being raised,
            for replay of a recording made before those rules (TF frame ids only).

        :raises ConfigError: an unknown name, a wrong type, a value out of range, an unknown
            integrator or frame keyword, a step that is not a whole number of ns, ...
        :raises ModelError: a mass or inertia the core rejects (not positive definite,
            triangle inequality), both ``inertia`` and ``shape`` given, ...
        :raises ConfigError: a renamed parameter under its old name (:data:`RENAMED_PARAMETERS`;
            a recording's parameters go through :func:`recorded_parameters` first).
        """
        params = dict(params or {})
        refuse_old_names(params)
        values = _table_values(params)
        input_names = _input_values(values, params)
        obstacle_names = _obstacle_values(values, params)
        body_inputs = _body_values(values, params)
        robots, groups = _robot_values(values, params)
        joint_params.take_parameters(values, params)
        if params:
            unknown = sorted(params)[0]
            raise ConfigError(
                f'parameter {unknown} = {fmt(params[unknown])}: unknown parameter name '
                '(known: see doc/parameters.md; wrench input, obstacle and body parameters need '
                'their name in wrench_input_names, obstacle_names or body_names)')
        time_settings = _time_settings(values)
        static_world = _static_world(values, obstacle_names)
        integrator = time_settings['integrator']
        if robots:
            bodies = ()
            if body_inputs or static_world is not None:  # one contact world
                _check_contact_integrator(integrator, 'robots in a world with contact')
                if body_inputs:
                    bodies = _world_bodies(values, body_inputs, static_world, integrator)
            world_joints = joint_params.read_world_joints(
                values, {b.name: b for b in bodies}, robots)
            for robot in robots:  # <name>/odom of a floating robot is a body's <name>/odom
                if robot.name in values['body_names']:
                    fail(robot_params.ROBOT_NAMES_SPEC, list(values[robot_params.ROBOT_NAMES]),
                         f"{robot.name!r} is also in body_names: a robot's topics and a "
                         "body's are both '<name>/...'; name them apart")
            _check_time_constants(robots, world_joints, time_settings['timestep_ns'])
            return cls(bodies=bodies, **time_settings,
                       **_frame_settings(values, bodies, robots, accepted_frames),
                       **_limits_and_recording(values), parameters=values,
                       static_world=static_world, robots=robots, command_groups=groups,
                       world_joints=world_joints)
        if groups:
            fail(robot_params.GROUP_NAMES_SPEC, list(values[robot_params.GROUP_NAMES]),
                 'command groups need robots (robot_names is empty)')
        if body_inputs:
            bodies = _world_bodies(values, body_inputs, static_world, integrator)
            settings = {**_frame_settings(values, bodies), **_limits_and_recording(values)}
        else:
            if not values['per_body_topics']:  # a single body's topics are its only outputs
                fail(PARAMETERS_BY_NAME['per_body_topics'], False,
                     'only a world (body_names) can turn its per-body topics off: a single '
                     "body's pose, twist and odom are its only state outputs")
            body = _single_body(values, static_world, integrator)
            settings = {**_frame_settings(values), **_limits_and_recording(values)}
            bodies = (dataclass_replace(
                body, wrench_inputs=_wrench_inputs(values, input_names),
                material=_reraise(PARAMETERS_BY_NAME['friction'], values['friction'],
                                  validate_material, values['friction'], values['restitution'])),)
        world_joints = joint_params.read_world_joints(
            values, {b.name: b for b in bodies} if body_inputs else {})
        _check_time_constants((), world_joints, time_settings['timestep_ns'])
        return cls(bodies=bodies, **time_settings, **settings, parameters=values,
                   static_world=static_world, world_joints=world_joints)

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
        for robot in self.robots:
            specs.extend(robot.specs)
        for item in self.command_groups + self.world_joints:
            specs.extend(item.specs)
        return tuple(specs)
