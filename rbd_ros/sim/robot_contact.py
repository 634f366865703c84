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
URDF robots in a world with contact: :class:`RobotContactWorld` (no rclpy).

A params file with ``robot_names`` and free bodies (``body_names``), obstacles or a ground is
one contact world (:class:`rbd_ros.core.contact.simulator.WorldSimulator`): the free bodies
first, in ``body_names`` order, then every robot's moving links (the bodies
:func:`rbd_ros.sim.robot_placement.place_robot` makes: mass, inertia, folded fixed links),
each a world body; every URDF joint the core has (revolute, continuous, prismatic, planar,
fixed between moving links) is a core joint of the contact step, named ``<robot>/<joint>``.
A robot-only file keeps :class:`rbd_ros.sim.robot_world.RobotWorld` (the joints-only core, no
contact).

**Collision shapes** (:func:`link_shape`). A body's shape comes from the ``<collision>``
elements of the links it carries (the moving link and the massless links folded into it),
each where the URDF puts it, in the body frame (the COM with the link's axes):

- one box, cylinder or sphere whose frame is the body frame (its ``<origin>`` at the link's
  ``<inertial>`` origin, same axes; within 1e-9 m and 1e-9 rad) is that primitive, exact;
- one mesh (with ``scale``) at any pose is that mesh with its vertices moved into the body
  frame (its SDF sampled there);
- anything else (several elements, or a primitive away from the COM or turned) is their
  :func:`rbd_ros.core.contact.mesh_shapes.compound_shape`: the least of the elements' exact
  signed distances sampled on a grid, the elements' surface points, and as the points tried
  against a plane their corners (a box element rests on a plane exactly) and surface points.

A body without collision is refused at start in one line naming the URDF file and the link.

**Links fixed to the world** (``world`` → fixed → ``mount``, :func:`_world_links`): each of
their ``<collision>`` elements is a static obstacle of the world at its placed pose, in the
robot's material: a free body or another link lands on a robot's base.

**Which links touch** (:func:`no_collision_pairs`, the contact step's ``no_collision``; with a
link fixed to the world, ``no_static_collision``): the parent and child links of a joint never
collide with each other (they meet at the joint), and links joined by fixed joints are one
group (a body, or for links fixed to the world the world): a moving link jointed to a link
fixed to the world never collides with any of the robot's links fixed to the world; a
robot's other links do, unless ``robots.<name>.self_collision`` is false;
links of different robots and free bodies always do. A world's own joints (``joint_names``) keep
today's rule: their bodies collide (they are given shapes that clear at the joint).

**Joints.** A URDF joint's ``<dynamics damping friction>`` (or ``robots.<r>.joints.<j>.*``)
is the contact step's joint damping and Coulomb friction, and a ``<mimic>`` one more row of its
joint visits (its ``joint_states`` effort is 0: it has no motor). What the contact step does
not take is refused at start in one line naming the robot's parameter or the URDF joint, from
the core's own refusal.

**Readouts** are :class:`RobotWorld`'s, on the contact world: joint positions and rates from
the bodies' states (:class:`rbd_ros.core.joints.readout.JointReadout`), motor efforts from the
contact step's motors, every joint's wrench from its child's momentum over the last step (see
:meth:`rbd_ros.sim.world_joints.JointedWorldSimulator.joint_wrenches`; a torque about the
child's COM at the middle of the step, then moved to the link origin at the step's end). The
free bodies answer as in any world (``arrays``, ``body_state``, ``set_body_loads``,
``contact_wrench_w``, ``contacts``).
"""

import re

import numpy as np

from rbd_ros.core import ModelError, RbdError
from rbd_ros.core.contact.mesh_shapes import compound_shape, mesh_shape
from rbd_ros.core.contact.simulator import WorldBody
from rbd_ros.core.contact.world import StaticObject, StaticWorld, validate_material
from rbd_ros.core.rotations import quat_multiply, quat_to_matrix
from rbd_ros.sim.config import overlap_error
from rbd_ros.sim.joint_commands import release
from rbd_ros.sim.robot_world import RobotWorld
from rbd_ros.sim.tessellation import shape_triangles
from rbd_ros.sim.world_joints import JointedWorldSimulator, state_entries, WorldJoint

# A primitive's frame is the body frame when its offset is within these (m, rad; else it is
# a compound of one part): far above
# the round-off of composing the URDF's origins (~1e-16), far below any offset a URDF means.
_POSE_TOL = 1e-9
_CORE_JOINT = re.compile(r"joint '([A-Za-z0-9_]+)/([^']+)'\.([a-z_0-9]+): (.*)\Z", re.S)
_DYNAMICS_UNITS = {'damping': 'N·m·s/rad or N·s/m', 'friction': 'N·m or N'}


def _refuse(robot, where, detail):
    """Raise the ModelError of one link's collision, naming the URDF file and the link."""
    field = f'link {where!r}.collision'
    raise ModelError(f'{robot.source}: {field}: {detail}', field=field, detail=detail)


def link_shape(robot, body):
    """
    Return the :class:`CollisionShape` of body ``body`` of ``robot`` (a URDF ``Robot``).

    See the module docstring for how the ``<collision>`` elements become one shape.

    :raises ModelError: one line naming the URDF file, the link and why.
    """
    carried = [link for link in robot.links if link.body == body]
    name = robot.body_links[body]
    elements = [(link.name, c) for link in carried for c in link.collisions]
    if not elements:
        _refuse(robot, name, 'none: in a world with contact every moving link needs one '
                '<collision> (box, cylinder, sphere or mesh), as the contact step has no body '
                'that touches nothing')
    if len(elements) == 1:
        where, collision = elements[0]
        shape = collision.shape
        rot = quat_to_matrix(collision.orientation_b)
        offset = float(np.abs(collision.position_b).max())
        turn = float(np.abs(rot - np.eye(3)).max())
        if shape.shape == 'mesh':
            if offset == 0.0 and turn == 0.0:
                return shape
            vertices = shape.vertices_b @ rot.T + collision.position_b
            return mesh_shape(vertices, shape.faces, centre=False,
                              field=f'{robot.source}: link {where!r}.collision.')
        if offset <= _POSE_TOL and turn <= _POSE_TOL:
            return shape
    return compound_shape([(c.shape, c.position_b, c.orientation_b) for _, c in elements],
                          [shape_triangles(c.shape) for _, c in elements],
                          field=f'{robot.source}: link {name!r}.collision.')


def no_collision_pairs(robots, offsets):
    """
    Return the body index pairs of the robots' links that never collide with each other.

    Parent and child of every URDF joint between two moving links (adjacent links), and every
    pair of a robot's links when its ``self_collision`` is false. ``offsets``: each robot's
    first body index in the world.
    """
    pairs = set()
    for robot, first in zip(robots, offsets):
        links = {link.name: link.body for link in robot.robot.links}
        count = len(robot.robot.body_links)
        if not robot.self_collision:
            pairs.update((first + a, first + b) for a in range(count)
                         for b in range(a + 1, count))
            continue
        for joint in robot.robot.joints:
            a, b = links[joint.parent], links[joint.child]
            if a is not None and b is not None and a != b:
                pairs.add((first + min(a, b), first + max(a, b)))
    return sorted(pairs)


def _world_links(robots):
    """
    Return the robots' links fixed to the world as static objects, their labels and skips.

    One :class:`StaticObject` per ``<collision>`` of every link that is part of the world
    (``world`` → fixed → ...), at its pose in the world (the root's placement times the
    element's pose in the root frame), in the robot's material. ``skip``: the ``(body index
    within the robot, static name)`` pairs that never collide: a moving link jointed to a
    world link and every link of the robot fixed to the world (adjacent links never collide,
    and fixed joints make the robot's world links one rigid group: the world), or every pair
    when the robot's ``self_collision`` is false.
    """
    objects, labels, skips = [], {}, []
    for robot in robots:
        urdf = robot.robot
        material = validate_material(robot.friction, robot.restitution)
        root_p, root_q = robot.placement.link_poses_w[urdf.root]
        root_rot = quat_to_matrix(root_q)
        names = {}
        for index, link in enumerate(urdf.links):
            if link.body is not None:
                continue
            for k, collision in enumerate(link.collisions):
                name = f'_{robot.name}__w{index}_{k}'
                position = root_rot @ collision.position_b + root_p
                orientation = quat_multiply(root_q, collision.orientation_b)
                objects.append(StaticObject(name, collision.shape, position, orientation,
                                            material))
                labels[f'obstacles.{name}'] = f'link {link.name!r} of robot {robot.name!r}'
                names.setdefault(link.name, []).append(name)
        links = {link.name: link.body for link in urdf.links}
        every = [n for group in names.values() for n in group]
        if not robot.self_collision:
            skips.append([(b, n) for b in range(len(urdf.body_links)) for n in every])
            continue
        adjacent = sorted({links[joint.child] for joint in urdf.joints
                           if links[joint.parent] is None and links[joint.child] is not None})
        skips.append([(b, n) for b in adjacent for n in every])
    return objects, labels, skips


def _link_bodies(robots):
    """Return the robots' link bodies as :class:`WorldBody` values and their labels."""
    bodies, labels = [], {}
    for r, robot in enumerate(robots):
        material = validate_material(robot.friction, robot.restitution)
        for k, name in enumerate(robot.robot.body_links):
            body_name = f'_{robot.name}__{k}'
            labels[body_name] = f'link {name!r} of robot {robot.name!r}'
            bodies.append(WorldBody(body_name, robot.placement.models[k],
                                    link_shape(robot.robot, k), material))
    return bodies, labels


class _RobotCore(JointedWorldSimulator):
    """The contact world with the readouts :class:`RobotWorld` asks of its core."""

    def state_rows(self):
        """Return every body's packed state as a list of 13 plain floats."""
        return self._x.T.tolist()

    def constraint_wrenches_w(self):
        """Return per joint the parent's wrench on the child (6 floats, world, about its COM)."""
        world = self.child_wrenches_w()
        nan = (float('nan'),) * 6
        if world is None:
            return [nan for _ in self.joints]
        return [nan if w is None else (*w[0], *w[1]) for w in world]


class RobotContactWorld(RobotWorld):
    """
    The robots of a params file in one contact world with its free bodies and static world.

    :param robots: the :class:`rbd_ros.sim.robots.RobotConfig` tuple.
    :param bodies: the free bodies' :class:`rbd_ros.sim.config.BodyConfig` tuple.
    :param static: the :class:`rbd_ros.core.contact.StaticWorld` (or None).
    :param integrator: a contact integrator. :param timestep_ns: the fixed step, int ns.
    :param world_joints: the world's own joints between free bodies (``joint_names``, the
        :class:`rbd_ros.sim.world_joints.WorldJoint` tuple): the contact step's first joints,
        read out as one more group after the robots (index ``len(robots)``), as
        :class:`rbd_ros.sim.world_joints.JointedWorldSimulator` reads them.
    :raises ModelError, ConfigError: one line naming the parameter or the URDF's link or joint.
    """

    def __init__(self, robots, bodies, static, integrator, timestep_ns, world_joints=()):
        free = [WorldBody(b.name, b.model, b.collision_shape, b.material) for b in bodies]
        self._free = len(free)
        world_joints = tuple(world_joints)
        self._world_joints = len(world_joints)
        self._assemble(robots, timestep_ns, len(free), len(world_joints))
        if world_joints:  # their group, after the robots': joint_states order, time constants
            entries = state_entries(world_joints)
            self._moving.append(tuple(k for _, k, _ in entries))
            self._coordinates.append(tuple(c for _, _, c in entries))
            self._time_constants_s.append(tuple(world_joints[k].time_constant_s
                                                for _, k, _ in entries))
        links, labels = _link_bodies(self.robots)
        fixed, fixed_labels, skips = _world_links(self.robots)
        labels.update(fixed_labels)
        if fixed:
            static = StaticWorld(None if static is None else static.ground,
                                 (() if static is None else tuple(static.obstacles))
                                 + tuple(fixed))
        _, link_states, joints = self._args
        world_joints += tuple(WorldJoint(joint.name, joint, None, 0.0, ()) for joint in joints)
        states = [b.initial_state for b in bodies] + list(link_states)
        offsets = [b0 for b0, _ in self._bodies]
        try:
            self._sim = _RobotCore(free + links, states, static, world_joints,
                                   integrator=integrator, timestep_ns=timestep_ns,
                                   no_collision=no_collision_pairs(self.robots, offsets),
                                   no_static_collision=[(first + b, name) for first, pairs
                                                        in zip(offsets, skips)
                                                        for b, name in pairs],
                                   defer_projection=True)
        except RbdError as exc:
            raise self._named(exc, labels) from None

    def _named(self, exc, labels):
        """Return the core's error naming the robot's parameter, URDF joint or link."""
        text = str(exc)
        match = _CORE_JOINT.match(text)
        if match:
            name, joint, field, detail = match.groups()
            robot = next(r for r in self.robots if r.name == name)
            if field in _DYNAMICS_UNITS:
                parameter = f'robots.{name}.joints.{joint}.{field}'
                value = getattr(robot.placement.joints[robot.robot.joint(joint).core], field)
                unit = _DYNAMICS_UNITS[field]
                if detail.startswith(f'{value!r}; '):  # the value again: said already
                    detail = detail[len(f'{value!r}; '):]
                return type(exc)(f'parameter {parameter} = {value!r} {unit}: {detail}',
                                 field=parameter, value=value, unit=unit, detail=detail)
            detail = detail.replace(f"'{name}/", "'")  # the core's joint names, the URDF's
            return type(exc)(f'{robot.robot.source}: joint {joint!r}.{field}: {detail}',
                             field=f'joint {joint!r}.{field}', detail=detail)
        field = getattr(exc, 'field', None) or ''
        link = labels.get(field[len('bodies.'):-len('.position_w')])
        if link is not None:  # a link inside something: the robot's placement puts it there
            robot = field[len('bodies._'):].rsplit('__', 1)[0]
            field = f'robots.{robot}.initial_position'
            rule = exc.rule.replace('puts the body', f'puts {link}', 1)
            text = (f'parameter {field} (with .initial_orientation and '
                    f'.initial_joint_positions) {rule}')
            exc = type(exc)(text, field=field, detail=rule)
        else:
            exc = overlap_error(exc)
        text = str(exc)
        for key in sorted(labels, key=len, reverse=True):  # a name before its prefixes
            where = key if key.startswith('obstacles.') else f'bodies.{key}'
            text = text.replace(where, labels[key])
        if text == str(exc):
            return exc
        return type(exc)(text, field=exc.field, detail=getattr(exc, 'detail', None))

    def joint_wrenches(self, r: int):
        """
        Return robot ``r``'s joint wrenches (:meth:`RobotWorld.joint_wrenches`).

        ``r = len(robots)``: the world's own joints', ``joint_names`` order, as
        :meth:`rbd_ros.sim.world_joints.JointedWorldSimulator.joint_wrenches` gives them.
        """
        if r == len(self.robots):
            return self._sim.joint_wrenches()[:self._world_joints]
        return super().joint_wrenches(r)

    def link_poses(self, r: int):
        """Return robot ``r``'s link poses; none for the world's joints (bodies on /tf)."""
        if r == len(self.robots):
            return []
        return super().link_poses(r)

    def reset(self) -> None:
        """Back to every body's and robot's placement at time 0, every motor off."""
        self._sim.reset()
        for moving, coordinates in zip(self._moving, self._coordinates):
            for j, k in zip(moving, coordinates):
                release(self._sim, j, k)

    @property
    def arrays(self):
        """Return the free bodies' packed states and times (views: the links follow them)."""
        x, t = self._sim.arrays
        return x[:, :self._free], t[:self._free]

    @property
    def world(self):
        """Return the contact world itself (every body: the free bodies, then the links)."""
        return self._sim

    @property
    def contact_wrench_w(self):
        """Return (N, 6): each body's net contact force and torque over the last step."""
        return self._sim.contact_wrench_w

    @property
    def contacts(self):
        """Return the contact points of the last step."""
        return self._sim.contacts

    def __getattr__(self, name):
        # body_state, set_body_loads, bodies, joint_error, ... : the world's
        if name.startswith('_'):
            raise AttributeError(name)
        return getattr(self._sim, name)
