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
Joints between the bodies of a world, without a URDF: ``joint_names`` and ``joints.<name>.*``.

The parameters (these names exactly; the list is not the prefix of its items, so
``ros2 param dump`` can nest them), for a world of named bodies (``body_names``):

- ``joint_names`` (string[]): the joints, each named like a body
  (:data:`rbd_ros.core.contact.world.NAME_RULE`).
- ``joints.<name>.type``: one of :data:`KINDS`.
- ``joints.<name>.parent``: a body of ``body_names``, or ``world`` (the default);
  ``joints.<name>.child``: a body of ``body_names``, not the parent.
- ``joints.<name>.position`` (m) and ``.axis`` (unit vector, normalised here): the joint point
  and axis in the world frame, at the bodies' initial poses. The joint coordinate is 0 there:
  the child's rest pose relative to the parent (``q_rest``) is the initial one.
- ``joints.<name>.axis2`` (unit vector, world frame, at the initial poses; planar and universal
  joints only, ``[0, 0, 0]`` the default): the core's ``axis2_b``, perpendicular to ``.axis``
  (to 1e-9 once both are normalised). A universal joint's second axis (the child's side of the
  cross; ``theta1`` turns about ``.axis``, ``theta2`` about it), a planar joint's x direction
  (``.axis`` its normal, y = axis × axis2). Default: the world x axis in the plane across
  ``.axis`` (the y axis when ``.axis`` is within 30° of x;
  :func:`rbd_ros.core.joints.model.plane_x`), as a URDF planar joint's.
- ``joints.<name>.lower`` and ``.upper`` (rad or m): revolute and prismatic limits; both 0 (the
  defaults) for none. ``.cone_rad`` (rad, in (0, π]): a spherical joint's cone limit, the
  angle of its axis in the child off the axis in the parent (both ``.axis`` at the initial
  poses) at most ``cone_rad``; 0 (the default) for none. ``.effort_limit`` (N·m or N) and
  ``.velocity_limit`` (rad/s or m/s): the motor's caps, 0 (the default) for none.
  ``.damping`` (N·m·s/rad or N·s/m) and ``.friction`` (N·m or N), >= 0, and
  ``.position_time_constant_s`` (s, > 0) as a robot joint's (:mod:`rbd_ros.sim.robots`).

Everything is handed to the core's :class:`~rbd_ros.core.joints.model.Joint` as given (origins
and axis turned into the bodies' frames): limits, damping (its exact flow) and Coulomb
friction (a joint sticks while the effort holding it is within it) are the contact step's
(:mod:`rbd_ros.core.contact.motors`); what the core refuses in a world with contact is refused
at start under the parameter's name (:func:`parameter_error`), so this module needs no change
when the core accepts it.

:class:`JointedWorldSimulator` is the world's simulator with them: a
:class:`~rbd_ros.core.contact.simulator.WorldSimulator` that also reads its joints out as a
robot's are (``joint_states``, ``joint_wrenches``; :mod:`rbd_ros.msgs.robot_outputs`); the
wrenches from the bodies' momentum over the last step, as the contact step does not report
its joint impulses.
:class:`WorldJointInputs` is the ``joint_command`` input: every command is checked as a
robot's is (a rejected one counted in ``/diagnostics``) and drives the contact step's motors.
"""

from dataclasses import dataclass
import math
import re
from typing import Optional, Tuple

import numpy as np
from rbd_ros.core import kernels, RbdError
from rbd_ros.core.contact.simulator import WorldSimulator
from rbd_ros.core.joints.model import Joint, MOTOR_COORDINATES, plane_x
from rbd_ros.core.joints.readout import cross, JointReadout, rotate
from rbd_ros.core.rotations import quat_conjugate, quat_multiply, quat_to_matrix
from rbd_ros.sim.joint_commands import (CommandInput, coordinate_entries, JointSpec,
                                        motor_settings, release, RobotInputs)
from rbd_ros.sim.params import (coerce, DOUBLE, DOUBLE_ARRAY, fail, fmt, MAX_BODIES,
                                PARAMETERS_BY_NAME, ParamSpec, position3, STRING)
from rbd_ros.sim.robots import (DEFAULT_POSITION_TIME_CONSTANT_S, list_names,
                                MAX_JOINT_DYNAMICS, param_value)

JOINT_NAMES = 'joint_names'
JOINT_NAMES_SPEC = PARAMETERS_BY_NAME[JOINT_NAMES]
#: The joint kinds a world's joint may have (the core's).
KINDS = ('fixed', 'revolute', 'continuous', 'prismatic', 'spherical', 'universal', 'planar')
#: The kinds with a second axis (``.axis2``).
_TWO_AXES = ('universal', 'planar')
#: The parent that is the world frame (not a body).
WORLD = 'world'
_MAX = 1e12  # the bound advertised for a quantity with no natural limit (as params')
# The core Joint's fields -> the parameter that gives them.
_CORE_FIELDS = {'kind': 'type', 'parent': 'parent', 'child': 'child', 'axis_b': 'axis',
                'axis2_b': 'axis2',
                'origin_parent_b': 'position', 'origin_child_b': 'position',
                'lower': 'lower', 'upper': 'upper', 'cone_rad': 'cone_rad',
                'effort_limit': 'effort_limit',
                'damping': 'damping', 'friction': 'friction'}
_CORE_UNIT = re.compile(r'\A(?: (?:N m s/rad|N s/m|N m|rad|N|m)\b)?;? ?')
_CORE_MESSAGE = re.compile(r"joint '([A-Za-z0-9_]+)'\.([a-z_0-9]+): (.*)\Z", re.S)


def joint_parameter_specs(name: str) -> Tuple[ParamSpec, ...]:
    """Return the :class:`ParamSpec` of world joint ``name`` (``joints.<name>.*``)."""
    prefix = f'joints.{name}.'
    who = f'Joint {name!r}'
    return (
        ParamSpec(prefix + 'type', STRING, '', '', f'{who}: its kind.',
                  rule='one of ' + ', '.join(KINDS)),
        ParamSpec(prefix + 'parent', STRING, WORLD, '',
                  f"{who}: its parent body, or 'world' (the world frame).",
                  rule="one of body_names, or 'world'"),
        ParamSpec(prefix + 'child', STRING, '', '', f'{who}: its child body.',
                  rule='one of body_names, not the parent'),
        ParamSpec(prefix + 'position', DOUBLE_ARRAY, (0.0, 0.0, 0.0), 'm',
                  f'{who}: the joint point, world frame, at the initial poses.',
                  rule='3 finite values'),
        ParamSpec(prefix + 'axis', DOUBLE_ARRAY, (0.0, 0.0, 1.0), '',
                  f'{who}: the joint axis, world frame, at the initial poses (normalised).',
                  rule='3 finite values, not all 0'),
        ParamSpec(prefix + 'axis2', DOUBLE_ARRAY, (0.0, 0.0, 0.0), '',
                  f"{who}: a universal joint's second axis (theta2's), a planar joint's x "
                  'direction; world frame, at the initial poses (normalised); [0, 0, 0] = the '
                  'world x axis in the plane across .axis (y when .axis is within 30° of x).',
                  rule='3 finite values, perpendicular to .axis; planar and universal only'),
        ParamSpec(prefix + 'lower', DOUBLE, 0.0, 'rad or m',
                  f'{who}: lower limit of a revolute or prismatic joint (0 at the initial '
                  'poses); lower = upper = 0: no limits.', (-_MAX, _MAX), rule='<= upper'),
        ParamSpec(prefix + 'upper', DOUBLE, 0.0, 'rad or m',
                  f'{who}: upper limit; lower = upper = 0: no limits.', (-_MAX, _MAX),
                  rule='>= lower'),
        ParamSpec(prefix + 'cone_rad', DOUBLE, 0.0, 'rad',
                  f'{who}: cone limit of a spherical joint: its axis in the child at most this '
                  'far off the axis in the parent (both .axis at the initial poses); 0 = none.',
                  (0.0, math.pi), rule='0 (none) or in (0, π], spherical joints only'),
        ParamSpec(prefix + 'effort_limit', DOUBLE, 0.0, 'N·m or N',
                  f"{who}: cap of its motor's effort; 0 = none.", (0.0, _MAX), rule='>= 0'),
        ParamSpec(prefix + 'velocity_limit', DOUBLE, 0.0, 'rad/s or m/s',
                  f'{who}: cap of its velocity targets; 0 = none.', (0.0, _MAX), rule='>= 0'),
        ParamSpec(prefix + 'damping', DOUBLE, 0.0, 'N·m·s/rad or N·s/m',
                  f'{who}: viscous damping, the force -damping·q̇ along the joint.',
                  (0.0, MAX_JOINT_DYNAMICS), rule='>= 0'),
        ParamSpec(prefix + 'friction', DOUBLE, 0.0, 'N·m or N',
                  f'{who}: Coulomb friction: the joint sticks while the force holding it is '
                  'within it, else slides against it.', (0.0, MAX_JOINT_DYNAMICS),
                  rule='>= 0'),
        ParamSpec(prefix + 'position_time_constant_s', DOUBLE,
                  DEFAULT_POSITION_TIME_CONSTANT_S, 's',
                  f'{who}: time constant of its position commands (critically damped).',
                  (0.0, 1e6), rule='> 0, >= timestep_s'),
    )


@dataclass(frozen=True)
class WorldJoint:
    """
    One joint of a world, as its parameters give it.

    :ivar name: its name in ``joint_names``.
    :ivar joint: the core :class:`~rbd_ros.core.joints.model.Joint` (bodies by index in
        ``body_names`` order, ``parent=None`` the world).
    :ivar velocity_limit: the cap of its velocity targets (rad/s or m/s), None for none.
    :ivar time_constant_s: its position commands' time constant, s.
    :ivar specs: its parameters.
    """

    name: str
    joint: Joint
    velocity_limit: Optional[float]
    time_constant_s: float
    specs: Tuple[ParamSpec, ...]

    @property
    def moving(self) -> bool:
        """Return whether it is in ``joint_states`` (one entry a coordinate)."""
        return self.joint.kind in MOTOR_COORDINATES

    @property
    def entries(self) -> Tuple[Tuple[str, Optional[int]], ...]:
        """Return its ``joint_states`` entries: ``(name, coordinate)`` (see coordinate_entries)."""
        return coordinate_entries(self.name, self.joint.kind)


def state_entries(world_joints):
    """
    Return the ``joint_states`` entries of ``world_joints``: ``(name, joint index, coordinate)``.

    In ``joint_names`` order, a planar joint's three (``<joint>/x``, ``/y``, ``/theta``), a
    universal joint's two (``<joint>/theta1``, ``/theta2``) and a spherical joint's three
    (``<joint>/rx``, ``/ry``, ``/rz``: the rotation vector of its turn in the parent's axes)
    together; fixed joints have none.
    """
    return tuple((entry, k, coordinate) for k, joint in enumerate(world_joints)
                 for entry, coordinate in joint.entries)


def _vector(spec, value):
    if len(value) != 3:
        fail(spec, list(value), 'must have 3 values')
    return tuple(float(v) for v in value)


def _robot_link(value, robots):
    """Return ``(robot, link)`` when ``value`` names a robot's link (``link`` or ``r/link``)."""
    for robot in robots:
        for link in robot.robot.links:
            if value in (link.name, f'{robot.name}/{link.name}'):
                return robot.name, link.name
    return None


def _not_a_body(spec, value, names, robots, world=''):
    """Refuse ``value`` as a joint's body: not one of ``body_names`` (say so for a link)."""
    link = _robot_link(value, robots)
    if link is not None:
        fail(spec, value, f'is link {link[1]!r} of robot {link[0]!r}, not a body: a world '
             f"joint joins the bodies of body_names ({names}){world}; a robot's links are "
             'joined by its URDF')
    fail(spec, value, f'must be one of body_names ({names}){world}')


def _read_joint(params, name, bodies, robots):
    specs = joint_parameter_specs(name)
    by = {spec.name.rsplit('.', 1)[1]: spec for spec in specs}
    v = {base: param_value(params, spec) for base, spec in by.items()}
    if v['type'] not in KINDS:
        fail(by['type'], v['type'], 'must be one of ' + ', '.join(KINDS))
    names = ', '.join(bodies)
    if v['child'] == WORLD:
        fail(by['child'], WORLD, 'the world does not move: a child is a body of body_names '
             f'({names}); make the world the parent')
    if v['child'] not in bodies:
        _not_a_body(by['child'], v['child'], names, robots)
    if v['parent'] != WORLD and v['parent'] not in bodies:
        _not_a_body(by['parent'], v['parent'], names, robots, " or 'world'")
    if v['parent'] == v['child']:
        fail(by['parent'], v['parent'], 'is the child too: a body cannot be jointed to itself')
    position = _vector(by['position'], position3(by['position'], v['position']))
    axis = _vector(by['axis'], v['axis'])
    if sum(a * a for a in axis) == math.inf:  # (0, 1e300, 1e300): a direction, scaled to 1
        axis = tuple(a / max(abs(b) for b in axis) for a in axis)
    if not math.sqrt(sum(a * a for a in axis)) > 1e-12:
        fail(by['axis'], list(axis), 'has zero length: a joint axis needs a direction')
    child = bodies[v['child']]
    parent = None if v['parent'] == WORLD else bodies[v['parent']]
    q_wc, p_c = child.initial_state.orientation_wb, child.initial_state.position_w
    if parent is None:
        q_pc, axis_p, origin_p = q_wc, axis, position
    else:
        q_wp, p_p = parent.initial_state.orientation_wb, parent.initial_state.position_w
        rot_pw = quat_to_matrix(q_wp).T
        q_pc = quat_multiply(quat_conjugate(q_wp), q_wc)
        axis_p = rot_pw @ axis
        origin_p = rot_pw @ (position - p_p)
    limited = v['lower'] != 0.0 or v['upper'] != 0.0
    axis2 = _vector(by['axis2'], v['axis2'])
    extra = {}
    if any(axis2) and v['type'] not in _TWO_AXES:
        fail(by['axis2'], list(axis2), f'a {v["type"]} joint has no second axis (planar and '
             'universal joints have); leave it [0, 0, 0]')
    if v['type'] in _TWO_AXES:
        if sum(a * a for a in axis2) == math.inf:
            axis2 = tuple(a / max(abs(b) for b in axis2) for a in axis2)
        norm = math.sqrt(sum(a * a for a in axis2))
        unit_axis = np.asarray(axis) / math.sqrt(sum(a * a for a in axis))
        if not any(axis2):
            axis2 = tuple(plane_x(unit_axis))
        elif not norm > 1e-12:
            fail(by['axis2'], list(axis2), 'has zero length: a second axis needs a direction')
        else:
            axis2 = tuple(np.asarray(axis2) / norm)
            if abs(float(np.dot(axis2, unit_axis))) > 1e-9:
                fail(by['axis2'], list(axis2), f'must be perpendicular to .axis '
                     f'{unit_axis.tolist()} (their dot product within 1e-9)')
        extra['axis2_b'] = tuple(axis2) if parent is None else tuple(rot_pw @ axis2)
    try:
        order = list(bodies)
        joint = Joint(name, v['type'], None if parent is None else order.index(v['parent']),
                      order.index(v['child']), origin_parent_b=tuple(origin_p),
                      origin_child_b=tuple(quat_to_matrix(q_wc).T @ (position - p_c)),
                      axis_b=tuple(axis_p), q_rest=tuple(q_pc),
                      lower=v['lower'] if limited else None,
                      upper=v['upper'] if limited else None,
                      cone_rad=v['cone_rad'] or None,
                      effort_limit=v['effort_limit'] or None, damping=v['damping'],
                      friction=v['friction'], **extra)
    except RbdError as exc:
        raise parameter_error(exc, {name: v}) from None
    return WorldJoint(name, joint, v['velocity_limit'] or None,
                      v['position_time_constant_s'], specs)


def read_world_joints(params, bodies, robots=()) -> Tuple[WorldJoint, ...]:
    """
    Return the :class:`WorldJoint` of every joint of ``params`` (a dict name → value).

    :param bodies: the world's bodies, name → :class:`rbd_ros.sim.config.BodyConfig` in
        ``body_names`` order (empty for a file without ``body_names``).
    :param robots: the file's :class:`rbd_ros.sim.robots.RobotConfig` tuple: a world joint
        joins free bodies (and the world) only; one naming a robot's link is refused saying so.
    :raises ConfigError, ModelError: one line naming the parameter, its value and unit.
    """
    names = list_names(params, JOINT_NAMES_SPEC, MAX_BODIES)
    if names and not bodies:
        fail(JOINT_NAMES_SPEC, list(names), 'joints join the bodies of a world: give '
             'body_names (and bodies.<name>.*)')
    return tuple(_read_joint(params, name, bodies, robots) for name in names)


def parameter_error(exc, given):
    """
    Return the core's error about a joint's field as the parameter error naming it.

    ``joint 'door'.friction: 0.5; a fixed joint takes no friction ...`` becomes
    ``parameter joints.door.friction = 0.5 N·m or N: a fixed joint takes no friction ...``;
    any other error is returned as it is.

    :param given: joint name → its parameter values (base name → value).
    """
    match = _CORE_MESSAGE.match(str(exc))
    if not match or match.group(2) not in _CORE_FIELDS:
        return exc
    name, field, detail = match.groups()
    base = _CORE_FIELDS[field]
    spec = next(s for s in joint_parameter_specs(name) if s.name.endswith('.' + base))
    value = given.get(name, {}).get(base, getattr(exc, 'value', None))
    if detail.startswith(fmt(value)):  # the value again, in the core's unit: said already
        detail = _CORE_UNIT.sub('', detail[len(fmt(value)):], count=1)
    if base in ('lower', 'upper'):  # the core's None is this file's lower = upper = 0
        detail = detail.replace('(leave it None)', '(leave lower = upper = 0: no limits)')
    unit = f' {spec.unit}' if spec.unit else ''
    return type(exc)(f'parameter {spec.name} = {fmt(value)}{unit}: {detail}', field=spec.name,
                     value=value, unit=spec.unit, detail=detail)


def _groups(joints):
    """Return each joint's group: the least body index of the bodies its joints connect."""
    root = {}

    def find(b):
        while root.get(b, b) != b:
            b = root[b]
        return b
    for joint in joints:
        if joint.parent is not None:
            a, b = find(joint.parent), find(joint.child)
            root[max(a, b)] = min(a, b)
    return [find(joint.child) for joint in joints]


def _tree_order(joints):
    """
    Return ``(joint indices children first, body → the joints it is the parent of)``.

    Only the joints of groups (bodies connected by joints) that form trees: each body the child
    of one joint at most and no loop (a loop's split of an internal force among its joints is
    not given by the bodies' motion); a group that does not is left out (its joints' wrenches
    are NaN), and the others, a robot's beside it, keep theirs.
    """
    group = _groups(joints)
    seen, bad = set(), set()
    for k, joint in enumerate(joints):
        if joint.child in seen:
            bad.add(group[k])
        seen.add(joint.child)
    below = {}  # body -> the joints it is the parent of
    for k, joint in enumerate(joints):
        if joint.parent is not None:
            below.setdefault(joint.parent, []).append(k)
    order, done = [], set()
    pending = [k for k in range(len(joints)) if group[k] not in bad]
    while pending:
        ready = [k for k in pending if all(c in done for c in below.get(joints[k].child, ()))]
        if not ready:  # the rest wait on a loop: their groups are not trees
            bad.update(group[k] for k in pending)
            break
        order += ready
        done.update(ready)
        pending = [k for k in pending if k not in done]
    return [k for k in order if group[k] not in bad], below


def _spin_w(row, inertia):
    """Return the angular momentum ``Π_w = R I_b ω_b`` of a packed state row, plain floats."""
    wx, wy, wz = row[10], row[11], row[12]
    spin_b = (i[0] * wx + i[1] * wy + i[2] * wz for i in inertia)
    return rotate(row[3], row[4], row[5], row[6], *spin_b)


class JointedWorldSimulator(WorldSimulator):
    """
    A world with joints between its bodies, read out per sample as a robot is.

    :param world_joints: the :class:`WorldJoint` tuple; the other arguments are
        :class:`~rbd_ros.core.contact.simulator.WorldSimulator`'s.
    :raises ConfigError, ModelError: what the core refuses, named as the parameter.

    The readouts (plain floats, the same bits on every machine; :mod:`rbd_ros.core.joints.
    readout`) take an ``index`` for the interface of :class:`rbd_ros.sim.robot_world.RobotWorld`
    (a world's joints are one group, index 0):

    - :meth:`joint_states`: per one-coordinate joint (revolute, continuous, prismatic; in
      ``joint_names`` order) its position (rad or m; a continuous joint's not wrapped: the
      running angle the step keeps, :meth:`~rbd_ros.core.contact.simulator.WorldSimulator.
      running_angles`, 6π after three turns), rate and its motor's effort over the last step
      (N m or N; 0 without a motor).
    - :meth:`joint_wrenches`: per joint (``joint_names`` order) the force (N) and torque (N m)
      the parent exerts on the child over the last step, in the child body's frame, the torque
      about the joint point; see there. NaN at time 0, after a reset, and for the joints of a
      group (bodies connected by joints) that does not form a tree (a loop); the other groups
      keep theirs.
    """

    def __init__(self, bodies, states, static, world_joints, **kwargs):
        self.world_joints = tuple(world_joints)
        joints = [j.joint for j in self.world_joints]
        self._nan = [[math.nan] * 6 for _ in joints]
        try:
            super().__init__(bodies, states, static, joints=joints, **kwargs)
        except RbdError as exc:
            given = {j.name: {base: getattr(j.joint, field) for field, base
                              in _CORE_FIELDS.items() if base not in ('position', 'axis')}
                     for j in self.world_joints}
            raise parameter_error(exc, given) from None
        self._readout = JointReadout(joints)
        entries = state_entries(self.world_joints)
        self._moving = tuple(k for _, k, _ in entries)
        self._coordinates = tuple(c for _, _, c in entries)
        self._continuous = frozenset(k for k, j in enumerate(joints) if j.kind == 'continuous')
        self._time_constants_s = tuple(self.world_joints[k].time_constant_s for k in self._moving)
        self._tree = _tree_order(joints)
        self._masses = [b.model.mass_kg for b in self.bodies]
        self._inertias = [b.model.inertia_b.tolist() for b in self.bodies]
        self._before = None  # the packed states at the start of the last step, (13, N)
        self._wrenches = (None, self._nan)  # (time ns, rows) of the last readout

    @property
    def articulated(self):
        """Return what answers ``joint_error()`` for ``/diagnostics`` (this simulator)."""
        return self

    def step(self, n: int = 1) -> None:
        """
        Advance ``n`` steps, keeping the states at the start of the last (for the wrenches).

        The core's chunking does not change the result, so the last step taken apart gives
        the same bits as one call of ``n``.
        """
        self._before, self._wrenches = None, (None, self._nan)
        if n < 1:
            return super().step(n)
        if n > 1:
            super().step(n - 1)
        before = self._x.copy()
        super().step(1)
        self._before = before

    def reset(self, states=None) -> None:
        """Put every body back to its initial state; the wrenches are NaN until a step."""
        super().reset(states)
        self._before, self._wrenches = None, (None, self._nan)

    def joint_coordinates(self, indices, coordinates=None):
        """
        Return ``(positions, rates)`` of the joints ``indices``, plain floats.

        ``coordinates``: one per index, None for a one-coordinate joint, a planar, universal
        or spherical joint's coordinate
        (:meth:`~rbd_ros.core.joints.ArticulatedSimulator.joint_coordinates`).
        """
        rows = self._x.T.tolist()
        read = self._readout.read
        running = self.running_angles()
        positions, rates = [], []
        for n, j in enumerate(indices):
            q, qd = read(rows, j, None if coordinates is None else coordinates[n])
            positions.append(running[j] if j in self._continuous else q)
            rates.append(qd)
        return positions, rates

    def joint_states(self, index=0):
        """
        Return ``(positions, rates, efforts)`` of the ``joint_states`` entries, plain floats.

        One a one-coordinate joint, one a coordinate of a planar, universal or spherical joint
        (:func:`state_entries`); a coordinate's effort its motor's (``coordinate_efforts``).
        """
        positions, rates = self.joint_coordinates(self._moving, self._coordinates)
        efforts = self.joint_efforts()
        return positions, rates, [float(efforts[k]) if c is None
                                  else float(self.coordinate_efforts(k)[c])
                                  for k, c in zip(self._moving, self._coordinates)]

    def joint_wrenches(self, index=0):
        """
        Return per joint ``(fx, fy, fz, tx, ty, tz)``: the parent's wrench on the child.

        From each body's momentum over the last step (the core's contact step does not report
        its joint impulses), children first: the child ``c`` of joint ``j`` gets, averaged over
        the step, world frame, about its COM,

        ``f_j = m (v₁ − v₀)/h − ½ (F₀ + F₁) − f_contact + Σ_k f_k`` and
        ``τ_j = (Π₁ − Π₀)/h − ½ (T₀ + T₁) − τ_contact + Σ_k (τ_k + (c_k − c) × f_k)``,

        ``Π = R I_b ω_b``, ``(F, T)`` the net gravity and applied loads at the step's two ends
        (:func:`rbd_ros.core.kernels.net_wrench_batch`, the forces' one sum), the contact wrench
        of :attr:`contact_wrench_w`, ``k`` the joints whose parent is ``c`` (their reaction on
        it; ``c_k`` their children's COM, each COM at the middle of the step), then
        ``f = R_cᵀ f_j`` and ``τ = R_cᵀ τ_j − o_c × f`` about the joint point (``o_c`` =
        ``origin_child_b``), ``R_c`` the child's orientation at the middle of the step
        (``(q₀ + q₁)/|q₀ + q₁|``), where the step's impulses act on average: a force turning
        with the body is then off by O((ω h)²), not O(ω h). For the two ends' load average to
        be the step's, loads are constant or smooth over a step; a body's
        ``linear_damping``/``angular_damping`` (applied as an exact flow, not a force) reads as
        part of its joint's wrench. A joint's own damping and friction are transmitted by the
        joint, so they are part of its wrench (the torque or force along its axis).
        """
        time_ns, rows = self._wrenches
        if time_ns == self.time_ns:
            return rows
        rows = self._nan
        if self._before is not None:
            rows = self._momentum_wrenches()
        self._wrenches = (self.time_ns, rows)
        return rows

    def child_wrenches_w(self):
        """
        Return per joint ``(f, τ)``: the parent's wrench on the child, world frame, about its COM.

        Each a 3-list of plain floats (N, N m), averaged over the last step and computed from
        the bodies' momentum as :meth:`joint_wrenches` says (before its turn into the child's
        frame); None at time 0 and after a reset; a joint's entry None where its joints do not
        form a tree.
        """
        if self._before is None:
            return None
        return self._world_wrenches()[0]

    def _world_wrenches(self):
        n = self.size
        net0, net1 = np.zeros((6, n)), np.zeros((6, n))
        kernels.net_wrench_batch(self._before, self._params, self._loads, net0)
        kernels.net_wrench_batch(self._x, self._params, self._loads, net1)
        x0, x1 = self._before.T.tolist(), self._x.T.tolist()
        net0, net1, contact = net0.T.tolist(), net1.T.tolist(), self._wrench.tolist()
        inv_h = 1.0 / self._h
        order, below = self._tree
        joints = self.joints
        world = [None] * len(joints)
        for k in order:
            c = joints[k].child
            a, b, m = x0[c], x1[c], self._masses[c]
            spin0, spin1 = _spin_w(a, self._inertias[c]), _spin_w(b, self._inertias[c])
            f = [m * (b[7 + i] - a[7 + i]) * inv_h - 0.5 * (net0[c][i] + net1[c][i])
                 - contact[c][i] for i in range(3)]
            t = [(spin1[i] - spin0[i]) * inv_h - 0.5 * (net0[c][3 + i] + net1[c][3 + i])
                 - contact[c][3 + i] for i in range(3)]
            for kk in below.get(c, ()):
                fk, tk = world[kk]
                ck = joints[kk].child
                d = [0.5 * ((x0[ck][i] + x1[ck][i]) - (a[i] + b[i])) for i in range(3)]
                arm = cross(d, fk)
                f = [f[i] + fk[i] for i in range(3)]
                t = [t[i] + tk[i] + arm[i] for i in range(3)]
            world[k] = (f, t)
        return world, x0, x1

    def _momentum_wrenches(self):
        world, x0, x1 = self._world_wrenches()
        joints = self.joints
        rows = [None] * len(joints)
        for k, wrench in enumerate(world):
            if wrench is None:  # not in a tree
                rows[k] = self._nan[k]
                continue
            f, t = wrench
            a, b = x0[joints[k].child], x1[joints[k].child]
            # the child's frame at the middle of the step: (q₀ + q₁)/|q₀ + q₁|, inverted
            qw, qx, qy, qz = (a[i] + b[i] for i in range(3, 7))
            norm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
            qw, qx, qy, qz = qw / norm, -qx / norm, -qy / norm, -qz / norm
            f_b = rotate(qw, qx, qy, qz, *f)
            lever = cross(joints[k].origin_child_b.tolist(), f_b)
            t_b = rotate(qw, qx, qy, qz, *t)
            rows[k] = [*f_b, *(t_b[i] - lever[i] for i in range(3))]
        return rows

    def link_poses(self, index=0):
        """Return no frames: each body is on ``/tf`` already (world → body)."""
        return []

    def set_targets(self, index, targets) -> None:
        """
        Hold motor targets on joints: ``(entry, mode, value, rates or None)``.

        ``entry`` indexes the ``joint_states`` entries (:func:`state_entries`); a position
        target takes the joint's ``position_time_constant_s``. What
        :class:`rbd_ros.sim.joint_commands.RobotInputs` asks of a robot's world.
        """
        self.set_motors(motor_settings(targets, self._moving, self._time_constants_s,
                                       self._coordinates))

    def release(self, index, joint) -> None:
        """Turn the motor of ``joint_states`` entry ``joint`` off (the coordinate is free)."""
        release(self, self._moving[joint], self._coordinates[joint])


class WorldJointInputs(RobotInputs):
    """
    The world joints' ``joint_command`` (``sensor_msgs/JointState`` by name), as a robot's.

    A command is checked as a robot's is (unknown or repeated joint names, lengths, finite
    values, limits: :func:`rbd_ros.sim.joint_commands.joint_state_targets`; a rejected one is
    counted in ``/diagnostics``, ``commands_rejected_<reason>``), applied at the next step
    start on the core's motors (:meth:`JointedWorldSimulator.set_targets`) and held in sim time
    like a wrench (``wrench_timeout_s``). No group commands or trajectories: those are a
    robot's.

    Beside robots (``robots``, ``groups``: a world with both) it is their
    :class:`~rbd_ros.sim.joint_commands.RobotInputs` too, the world's joints one more group
    after them (index ``len(robots)``, as :class:`rbd_ros.sim.robot_contact.RobotContactWorld`
    reads them out).
    """

    def __init__(self, world_joints, timeout_ns=0, robots=(), groups=()):
        super().__init__(robots, groups, timeout_ns)
        spec = CommandInput('joint_command', 'joint_command', len(self.robots),
                            owner="the world's joint_names")
        self.inputs[spec.name] = spec
        self.received[spec.name] = 0
        self._specs.append(tuple(JointSpec(entry, j.joint, j.velocity_limit, coordinate)
                                 for j in world_joints for entry, coordinate in j.entries))


def take_parameters(values, params):
    """Move each listed joint's parameters from ``params`` to ``values`` (coerced, defaults)."""
    for name in list_names(values, JOINT_NAMES_SPEC, MAX_BODIES):
        for spec in joint_parameter_specs(name):
            values[spec.name] = coerce(spec, params.pop(spec.name, spec.default))
