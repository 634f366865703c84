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
Robots of a params file: ``robot_names`` and ``robots.<name>.*``, read into :class:`RobotConfig`.

The parameters (these names exactly; a list parameter is never the prefix of its items', so
``ros2 param dump`` can nest them):

- ``robot_names`` (string[]): the robots, each named like a body (:data:`NAME_RULE`).
- ``robots.<name>.urdf_path``: a ``.urdf`` or ``.xacro`` file; relative to the params file
  (made absolute when the file is read), absolute, or ``package://`` through the ament index.
- ``robots.<name>.robot_description``: the URDF XML itself. Exactly one of the two.
- ``robots.<name>.initial_position`` (m) and ``.initial_orientation`` ([x, y, z, w]): the root
  link's frame in the world frame (the ``world`` link's, for a robot fixed to the world).
- ``robots.<name>.initial_joint_positions`` (rad or m) and ``.initial_joint_velocities`` (rad/s
  or m/s): one value per ``joint_states`` entry, in its order (the URDF's revolute,
  continuous and prismatic joints one each, a planar joint three, ``<joint>/x``, ``/y``,
  ``/theta``, in document order), or ``[]`` for zeros.
- ``robots.<name>.friction`` and ``.restitution``: its links' contact material (as a body's
  ``friction`` and ``restitution``), in a world with contact (:mod:`rbd_ros.sim.robot_contact`);
  ``.self_collision`` (default true): its links that are not parent and child of one joint
  collide with each other there (adjacent links never do).
- ``robots.<name>.frame_prefix`` (default empty): put before each of its link names to make
  their TF frame ids (``/tf``, ``odom``'s child frame, the links' ``markers``), as
  robot_state_publisher's ``frame_prefix`` does: two robots from one URDF need one each (e.g.
  ``left/``, ``right/``), since every TF frame of the node must be unique
  (:func:`check_link_frames`). The URDF's ``world`` link of a robot fixed to the world is the
  node's world frame, never prefixed.
- ``robots.<name>.joints.<joint>.position_time_constant_s`` (s, > 0, default
  :data:`DEFAULT_POSITION_TIME_CONSTANT_S`): the time constant of that joint's position
  commands (the exact critically damped response, see :mod:`rbd_ros.core.joints`).
- ``robots.<name>.joints.<joint>.damping`` (N·m·s/rad or N·s/m, >= 0) and ``.friction``
  (N·m or N, >= 0): the joint's viscous damping and Coulomb friction (see
  :class:`rbd_ros.core.joints.Joint`); default the URDF's ``<dynamics damping friction>``, else
  0. A recording stores the values used, so replay does not depend on these defaults. A planar
  joint's ``position_time_constant_s`` is its three coordinates'; its ``.damping`` and
  ``.friction`` must be 0 (the core takes none on a planar joint; its ``<dynamics>`` is kept as
  data only).
- ``command_group_names`` (string[]) with ``command_groups.<g>.robot``, ``.joints`` (string[],
  the group's joints in its order, no mimic joint; ``[]`` = every moving joint of the robot
  but the mimics) and
  ``.interface`` (``position``, ``velocity`` or ``effort``): a ``Float64MultiArray`` on
  ``<g>/commands`` and a ``JointTrajectory`` on ``<g>/joint_trajectory``
  (:mod:`rbd_ros.sim.joint_commands`, :mod:`rbd_ros.sim.trajectory`).

A joint's parameters are known only once its URDF is read, so :func:`read_robots` reads the
robots first and then the joints' values. With no command a joint is free: there is no hidden
motor, and no damping or friction but what the URDF or the parameters give.
"""

from dataclasses import dataclass, replace
from typing import Dict, List, Mapping, Optional, Tuple

from rbd_ros.core import ConfigError, RbdError
from rbd_ros.core.contact.world import is_valid_name, NAME_RULE
from rbd_ros.core.joints.model import coordinate_units
from rbd_ros.sim.joint_commands import INTERFACES, JointSpec
from rbd_ros.sim.params import (BOOL, check_range, coerce, DOUBLE, DOUBLE_ARRAY, fail,
                                frame_id_problem,
                                PARAMETERS_BY_NAME, ParamSpec, position3, STRING,
                                STRING_ARRAY, unit_quaternion)

#: The robots' and the command groups' list parameters (in the table of rbd_ros.sim.params).
ROBOT_NAMES = 'robot_names'
GROUP_NAMES = 'command_group_names'
#: Default ``position_time_constant_s`` of every joint, s.
DEFAULT_POSITION_TIME_CONSTANT_S = 0.05
#: At most this many robots a file (a bound on start-up work).
MAX_ROBOTS = 100
#: The bound advertised for a joint's damping and friction (no natural limit; as params').
MAX_JOINT_DYNAMICS = 1e12

ROBOT_NAMES_SPEC = PARAMETERS_BY_NAME[ROBOT_NAMES]
GROUP_NAMES_SPEC = PARAMETERS_BY_NAME[GROUP_NAMES]


def group_parameter_specs(name: str) -> Tuple[ParamSpec, ...]:
    """Return the :class:`ParamSpec` of command group ``name`` (``command_groups.<name>.*``)."""
    prefix = f'command_groups.{name}.'
    return (
        ParamSpec(prefix + 'robot', STRING, '', '', f'Group {name!r}: its robot.',
                  rule='one of robot_names'),
        ParamSpec(prefix + 'joints', STRING_ARRAY, (), '',
                  f'Group {name!r}: its joints in command order (joint_states names: a '
                  "planar joint's <joint>/x, /y, /theta); [] = every moving joint but the "
                  'mimics.',
                  rule="joint_states names of the group's robot, each once, no mimic"),
        ParamSpec(prefix + 'interface', STRING, 'position', '',
                  f"Group {name!r}: what <group>/commands values are: 'position', "
                  "'velocity' or 'effort'.", rule='one of position, velocity, effort'),
    )


@dataclass(frozen=True)
class CommandGroup:
    """
    One command group: a robot's joints, commanded together.

    :ivar name: its name in ``command_group_names`` (its topics: ``<name>/commands``,
        ``<name>/joint_trajectory``).
    :ivar robot: the index of its robot in :func:`read_robots`' tuple.
    :ivar joints: its joints, as indices into that robot's moving joints, in command order.
    :ivar interface: one of :data:`~rbd_ros.sim.joint_commands.INTERFACES`.
    :ivar specs: its parameters.
    """

    name: str
    robot: int
    joints: Tuple[int, ...]
    interface: str
    specs: Tuple[ParamSpec, ...]


def read_command_groups(params, robots) -> Tuple[CommandGroup, ...]:
    """
    Return the :class:`CommandGroup` of every group of ``params``, checked against ``robots``.

    :raises ConfigError: one line naming the parameter and its value.
    """
    names = list_names(params, GROUP_NAMES_SPEC, MAX_ROBOTS)
    by_name = {robot.name: k for k, robot in enumerate(robots)}
    groups = []
    for name in names:
        specs = group_parameter_specs(name)
        robot_spec, joints_spec, interface_spec = specs
        robot_name = param_value(params, robot_spec)
        if robot_name not in by_name:
            fail(robot_spec, robot_name, f'must be one of robot_names ({", ".join(by_name)})')
        robot = robots[by_name[robot_name]]
        joints = param_value(params, joints_spec) or robot.command_joints
        index = []
        for joint in joints:
            if joint not in robot.joint_names:
                fail(joints_spec, list(joints), f'{joint!r} is not a moving joint of robot '
                     f'{robot_name!r} ({", ".join(robot.joint_names)})')
            leader = robot.robot.entry(joint)[0].mimic
            if leader is not None:
                fail(joints_spec, list(joints), f'{joint!r} is a mimic joint (of '
                     f'{leader[0]!r}) and takes no command; list {leader[0]!r}')
            if robot.joint_names.index(joint) in index:
                fail(joints_spec, list(joints), f'{joint!r} is listed twice')
            index.append(robot.joint_names.index(joint))
        interface = param_value(params, interface_spec)
        if interface not in INTERFACES:
            fail(interface_spec, interface, f'must be one of {", ".join(INTERFACES)}')
        groups.append(CommandGroup(name, by_name[robot_name], tuple(index), interface, specs))
    return tuple(groups)


def robot_parameter_specs(name: str) -> Tuple[ParamSpec, ...]:
    """Return the :class:`ParamSpec` of robot ``name`` (``robots.<name>.*``), joints aside."""
    prefix = f'robots.{name}.'
    return (
        ParamSpec(prefix + 'urdf_path', STRING, '', '',
                  f'Robot {name!r}: its .urdf or .xacro file (relative to the params file, '
                  'absolute, or package://).', rule='not with robot_description'),
        ParamSpec(prefix + 'robot_description', STRING, '', '',
                  f'Robot {name!r}: its URDF XML itself.', rule='not with urdf_path'),
        ParamSpec(prefix + 'initial_position', DOUBLE_ARRAY, (0.0, 0.0, 0.0), 'm',
                  f"Robot {name!r}: its root link's frame origin, world frame.",
                  rule='3 finite values'),
        ParamSpec(prefix + 'initial_orientation', DOUBLE_ARRAY, (0.0, 0.0, 0.0, 1.0), '',
                  f"Robot {name!r}: its root link's orientation [x, y, z, w], world frame.",
                  rule='4 finite values, norm within 1e-3 of 1 (then normalised)'),
        ParamSpec(prefix + 'initial_joint_positions', DOUBLE_ARRAY, (), 'rad or m',
                  f'Robot {name!r}: one position per joint_states entry, in its order (a '
                  'planar joint: x, y, theta); [] = zeros.',
                  rule='one value per entry, within its limits and ±1e7'),
        ParamSpec(prefix + 'initial_joint_velocities', DOUBLE_ARRAY, (), 'rad/s or m/s',
                  f'Robot {name!r}: one velocity per joint_states entry, in its order; '
                  '[] = zeros.', rule='one value per entry, within ±1e7'),
        ParamSpec(prefix + 'friction', DOUBLE, 0.5, '',
                  f'Robot {name!r}: Coulomb friction coefficient μ of its links (a pair: '
                  'sqrt(μ_a μ_b)); in a world with contact.', (0.0, MAX_JOINT_DYNAMICS),
                  rule='>= 0'),
        ParamSpec(prefix + 'restitution', DOUBLE, 0.0, '',
                  f'Robot {name!r}: coefficient of restitution ε of its links (a pair: the '
                  'larger); in a world with contact.', (0.0, 1.0)),
        ParamSpec(prefix + 'self_collision', BOOL, True, '',
                  f'Robot {name!r}: in a world with contact, its links that are not parent '
                  'and child of one joint collide with each other.'),
        ParamSpec(prefix + 'frame_prefix', STRING, '', '',
                  f'Robot {name!r}: put before its link names to make their TF frame ids '
                  "(as robot_state_publisher's frame_prefix; the world link excepted).",
                  rule='empty, or no leading / (tf2 refuses it), whitespace or control '
                       'characters; every TF frame of the node unique'),
    )


def joint_parameter_specs(robot: str, joint: str, damping: float = 0.0,
                          friction: float = 0.0, planar: bool = False) -> Tuple[ParamSpec, ...]:
    """
    Return the :class:`ParamSpec` of moving joint ``joint`` of ``robot``.

    ``damping`` and ``friction`` are the defaults of its ``.damping`` and ``.friction``: the
    URDF's ``<dynamics>`` values (0 without; a ``planar`` joint's 0 whatever the URDF says:
    the core takes none on it).
    """
    prefix = f'robots.{robot}.joints.{joint}.'
    who = f'Robot {robot!r}, joint {joint!r}'
    if planar:
        damping = friction = 0.0
    return (ParamSpec(prefix + 'position_time_constant_s', DOUBLE,
                      DEFAULT_POSITION_TIME_CONSTANT_S, 's',
                      f'{who}: time constant of its position commands (critically damped).',
                      (0.0, 1e6), rule='> 0, >= timestep_s'),
            ParamSpec(prefix + 'damping', DOUBLE, float(damping), 'N·m·s/rad or N·s/m',
                      f'{who}: viscous damping, the force -damping·q̇ along the joint; default '
                      "the URDF's <dynamics damping>, else 0.", (0.0, MAX_JOINT_DYNAMICS),
                      rule='>= 0'),
            ParamSpec(prefix + 'friction', DOUBLE, float(friction), 'N·m or N',
                      f'{who}: Coulomb friction: the joint sticks while the force holding it '
                      "is within it, else slides against it; default the URDF's <dynamics "
                      'friction>, else 0.', (0.0, MAX_JOINT_DYNAMICS), rule='>= 0'))


@dataclass(frozen=True)
class RobotConfig:
    """
    One robot: its URDF as read, its placement at time 0 and its joints' settings.

    :ivar name: its name in ``robot_names``.
    :ivar robot: the :class:`rbd_ros.sim.urdf.Robot` (``robot.urdf`` is what
        ``<name>/robot_description`` publishes).
    :ivar placement: the :class:`rbd_ros.sim.robot_placement.Placement` at time 0 (bodies,
        states, joints).
    :ivar time_constants_s: per joint with ``joint_states`` entries (``robot.state_joints``
        order: a planar joint once), its position time constant, s.
    :ivar specs: every parameter of this robot, its joints' included.
    :ivar friction, restitution: its links' contact material (a world with contact).
    :ivar self_collision: its non-adjacent links collide with each other (a world with contact).
    """

    name: str
    robot: object  # rbd_ros.sim.urdf.Robot
    placement: object  # rbd_ros.sim.robot_placement.Placement
    time_constants_s: Tuple[float, ...]
    specs: Tuple[ParamSpec, ...]
    friction: float = 0.5
    restitution: float = 0.0
    self_collision: bool = True
    frame_prefix: str = ''

    def link_frame(self, link: str, world_frame: str) -> str:
        """
        Return the TF frame id of URDF link ``link``: ``frame_prefix`` + its name.

        The ``world`` link of a robot fixed to the world is the node's ``world_frame``.
        """
        if link == 'world' and self.robot.fixed_to_world:
            return world_frame
        return self.frame_prefix + link

    @property
    def joint_names(self) -> Tuple[str, ...]:
        """Return the ``joint_states`` entries, in order (a planar joint's three)."""
        return self.robot.moving_joints

    @property
    def command_joints(self) -> Tuple[str, ...]:
        """Return the entries that take commands: all but the mimics', in order."""
        return tuple(name for name in self.robot.moving_joints
                     if self.robot.entry(name)[0].mimic is None)

    @property
    def entry_time_constants_s(self) -> Tuple[float, ...]:
        """Return per ``joint_states`` entry its joint's position time constant, s."""
        by_joint = dict(zip(self.robot.state_joints, self.time_constants_s))
        return tuple(by_joint[joint] for joint, _ in self.robot.coordinates)

    def joint_specs(self) -> Tuple[JointSpec, ...]:
        """Return each entry's :class:`~rbd_ros.sim.joint_commands.JointSpec`."""
        joints = self.placement.joints
        out = []
        for name in self.robot.moving_joints:
            joint, coordinate = self.robot.entry(name)
            out.append(JointSpec(name, joints[joint.core], joint.velocity, coordinate))
        return tuple(out)

    def units(self, joint: str) -> Tuple[str, str, str]:
        """Return ``(position, velocity, effort)`` units of a ``joint_states`` entry."""
        joint, coordinate = self.robot.entry(joint)
        return coordinate_units(joint, coordinate or 0)   # reads the kind only


def param_value(params, spec):
    """Return the coerced value of ``spec`` in ``params`` (its default when absent)."""
    value = params.get(spec.name, spec.default)
    value = coerce(spec, value)
    if spec.kind == DOUBLE:
        check_range(spec, value)
    return value


def _renamed(prefix, exc):
    """Return ``exc`` naming its field under ``prefix`` (``robots.arm.urdf_path``)."""
    field = getattr(exc, 'field', None)
    if field in ('urdf_path', 'initial_position', 'initial_orientation') or (
            field and field.startswith(('initial_joint_positions', 'initial_joint_velocities'))):
        return exc.renamed(prefix + field)
    return exc


def _read_robot(params, name, gravity_w):
    specs = robot_parameter_specs(name)
    by_base = {spec.name.rsplit('.', 1)[1]: spec for spec in specs}
    values = {base: param_value(params, spec) for base, spec in by_base.items()}
    prefix = f'robots.{name}.'
    path, xml = values['urdf_path'], values['robot_description']
    if bool(path) == bool(xml):
        given = 'both' if path else 'neither'
        raise ConfigError(f'parameter {prefix}urdf_path / {prefix}robot_description: {given} '
                          'given; give exactly one (a URDF file, or its XML)',
                          field=prefix + 'urdf_path', value=path)
    # A prefix starts every link frame of the robot: the frame id rule of every frame holds.
    problem = values['frame_prefix'] and frame_id_problem(values['frame_prefix'])
    if problem:
        fail(by_base['frame_prefix'], values['frame_prefix'], problem)
    position = position3(by_base['initial_position'], values['initial_position'])
    orientation = unit_quaternion(by_base['initial_orientation'], values['initial_orientation'])
    # Imported here: yourdfpy, lxml and trimesh cost ~0.5 s, paid only by files with robots.
    from rbd_ros.sim.robot_placement import place_robot
    from rbd_ros.sim.urdf import load_urdf
    try:
        robot = load_urdf(path) if path else load_urdf(xml=xml)
        placement = place_robot(
            robot, position, orientation,
            values['initial_joint_positions'] or None, values['initial_joint_velocities'] or None,
            gravity_w=gravity_w)
    except RbdError as exc:
        raise _renamed(prefix, exc) from None
    joint_specs = tuple(s for joint in robot.state_joints
                        for s in joint_parameter_specs(name, joint, robot.joint(joint).damping,
                                                       robot.joint(joint).friction,
                                                       robot.joint(joint).kind == 'planar'))
    given = {spec.name: param_value(params, spec) for spec in joint_specs}
    joints = list(placement.joints)
    for joint in robot.state_joints:
        core, base = robot.joint(joint).core, f'{prefix}joints.{joint}.'
        if robot.joint(joint).kind == 'planar':   # the core takes none: 0 only
            for field in ('damping', 'friction'):
                if given[base + field] != 0.0:
                    spec = next(s for s in joint_specs if s.name == base + field)
                    fail(spec, given[base + field], f'a planar joint takes no {field} (only '
                         'revolute, continuous and prismatic joints do); leave it 0')
            continue
        joints[core] = replace(joints[core], damping=given[base + 'damping'],
                               friction=given[base + 'friction'])
    constants = tuple(given[f'{prefix}joints.{joint}.position_time_constant_s']
                      for joint in robot.state_joints)
    return RobotConfig(name, robot, replace(placement, joints=tuple(joints)), constants,
                       specs + joint_specs, values['friction'], values['restitution'],
                       values['self_collision'], values['frame_prefix'])


def read_robots(params: Dict[str, object], gravity_w=(0.0, 0.0, 0.0)) -> Tuple[RobotConfig, ...]:
    """
    Return the :class:`RobotConfig` of every robot of ``params`` (a dict name → value).

    :param gravity_w: the world's gravity (m/s²), on every link.
    :raises ConfigError, ModelError: one line naming the parameter (or the URDF's file, link,
        joint and field), its value and unit.
    """
    names = list_names(params, ROBOT_NAMES_SPEC, MAX_ROBOTS)
    return tuple(_read_robot(params, name, gravity_w) for name in names)


def check_link_frames(world_frame: str, taken: Mapping[str, str], robots,
                      accepted: Optional[List[str]] = None) -> None:
    """
    Refuse a robot link whose TF frame id is already another frame's, in one line.

    :param taken: frame id → what owns it (``world_frame``, ``bodies.<b>.body_frame``): the
        node's other frames.
    :param robots: the :class:`RobotConfig` values; each link's frame is
        :meth:`RobotConfig.link_frame` (two robots from one URDF need their own
        ``frame_prefix``: ``/tf`` would otherwise carry two poses for one frame).
    :param accepted: None at start; a list (replay of a recording made before these rules):
        each refusal's line goes there instead (TF frame ids only: the physics is the same).
    :raises ConfigError: naming the robot's ``frame_prefix``, the link, the frame and its owner.
    """
    def refuse(spec, value, problem):
        try:
            fail(spec, value, problem)
        except ConfigError as exc:
            if accepted is None:
                raise
            accepted.append(str(exc))

    seen = dict(taken)
    for robot in robots:
        spec = next(s for s in robot.specs if s.name.endswith('.frame_prefix'))
        for link in robot.robot.links:
            frame = robot.link_frame(link.name, world_frame)
            if frame == world_frame and link.name == 'world':
                continue  # the world link is the world frame itself
            problem = frame_id_problem(frame)  # the URDF's link name (the prefix is checked)
            if problem:
                refuse(spec, robot.frame_prefix,
                       f'link {link.name!r} of robot {robot.name!r} would be TF frame '
                       f'{frame!r}, which {problem}')
            if frame in seen:
                refuse(spec, robot.frame_prefix,
                       f'link {link.name!r} of robot {robot.name!r} would be TF frame '
                       f'{frame!r}, already the frame of {seen[frame]} (a frame_prefix makes '
                       f"the robot's frames its own, e.g. '{robot.name}/')")
            seen.setdefault(frame, f'link {link.name!r} of robot {robot.name!r}')


def list_names(params, spec, most):
    """Return the names of list parameter ``spec``: at most ``most``, valid, unique."""
    names = coerce(spec, params.get(spec.name, ()))
    if len(names) > most:
        fail(spec, list(names), f'{len(names)} names; at most {most}')
    seen = set()
    for name in names:
        if not is_valid_name(name):
            fail(spec, list(names), f'{name!r}: {NAME_RULE}')
        if name in seen:
            fail(spec, list(names), f'{name!r} is listed twice')
        seen.add(name)
    return names
