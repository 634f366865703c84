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
Robots from URDF: :func:`load_urdf` reads one and checks it, with the conventions below.

The XML is parsed strictly by lxml (a malformed file is refused, not recovered) and read by
``yourdfpy``; a ``.xacro`` file is expanded by the ``xacro`` package first. Conventions:

* **Bodies.** Every moving link with an ``<inertial>`` is one body. Its body frame is the
  link's centre of mass with the **link frame's axes** (``R_wb = R_w,link``), so the inertia of
  ``<inertial>`` is rotated by the inertial origin's rpy into link axes:
  ``I_b = R_io I_io R_ioᵀ``.
* **The world.** A root link named ``world`` is the world frame (placed by the root pose); the
  links joined to it by fixed joints are part of the world (no body, no ``<inertial>`` needed)
  and every joint from them has ``parent=None``. Any other root floats.
* **Frames.** A link without ``<inertial>`` on a fixed joint to a moving link is a frame of
  that link's body (its collisions go to that body); a moving link (any other joint type, or
  the floating root) without ``<inertial>`` is refused.
* **Joints.** revolute, continuous, prismatic, planar and fixed become
  :class:`rbd_ros.core.joints.Joint` values (the child's joint frame at zero is the child link
  frame, so ``q_rest`` is the joint origin's rotation in the parent body); ``floating`` joins
  nothing: its child is a free body starting at the joint origin. Planar normal = ``<axis>``;
  its x direction the joint frame's x axis in the plane (its y axis when ``<axis>`` is within
  30° of x), its y direction ``axis × x``: for the usual ``<axis xyz="0 0 1"/>`` the joint
  frame's own x and y (:func:`rbd_ros.core.joints.model.plane_x`). ``<limit effort>`` caps
  each of a planar joint's motors (N for x and y, N m for theta), ``<limit velocity>`` each
  velocity target.
  A revolute or prismatic joint without ``<limit>`` is refused (the URDF spec requires it, and
  urdfdom refuses it; a joint without limits is continuous).
* **Joint order.** :attr:`Robot.moving_joints` are the ``joint_states`` entries: the revolute,
  continuous and prismatic joints, one entry each (the joint's name), and the planar joints,
  three entries each, ``<joint>/x``, ``<joint>/y``, ``<joint>/theta`` (MoveIt's names of a
  planar joint's variables; :func:`rbd_ros.sim.joint_commands.coordinate_entries`), in the
  order of the URDF's joint elements: the order of ``joint_positions`` too. Floating joints
  start at zero and are not listed.
* **Dynamics.** ``<dynamics damping friction>`` of a revolute, continuous or prismatic joint
  become its core joint's ``damping`` (N m s/rad or N s/m) and ``friction`` (N m or N), each
  >= 0 (the robot's ``robots.<name>.joints.<joint>.damping`` and ``.friction`` parameters
  override them); a planar joint's are kept as data only.
* **Mimic.** ``<mimic joint multiplier offset>`` on a revolute, continuous or prismatic joint
  of one of those kinds holds ``q = multiplier q_joint + offset`` exactly (the core joint's
  ``mimic``, a constraint row). Its initial position and velocity follow its leader's (a value
  given for it must agree); it takes no command. Refused with one line naming the joint: a
  mimic of itself, of an unknown joint, of a joint of another kind, a cycle of mimics, a
  non-finite multiplier or offset.
* **Kept as data, not simulated yet:** ``<limit velocity>`` (it clips commanded velocities in
  :mod:`rbd_ros.sim.joint_commands`).
* **Collisions.** Every ``<collision>`` (box, cylinder, sphere, mesh with scale) becomes a
  :class:`RobotCollision`: the shape centred in its own frame and that frame's pose in the body
  frame, all of them, in order (a world with contact makes them one shape a body,
  :mod:`rbd_ros.sim.robot_contact`).

Every error is one line that names the file (or ``robot_description``), the link or joint and
the field with its value and unit.

The stages, one module each: :mod:`.urdf_robot` the values (:class:`Robot`, its links, joints
and collisions; :func:`refuse`, the one shape of an error), :mod:`.urdf_xml` the file or text
read and parsed strictly, :mod:`.urdf_elements` each inertial, collision and joint read and
checked; here :func:`load_urdf`, which puts them together: the tree, its bodies, the mimics.
Their public names are importable from here too, as before.
"""

import os

import numpy as np
from rbd_ros.core.errors import ConfigError, ModelError
from rbd_ros.sim.joint_commands import coordinate_entries
from rbd_ros.sim.urdf_elements import (_collision, _inertial, _joint_values, _matrix,
                                       _translation, frozen_pose)
from rbd_ros.sim.urdf_elements import MAX_MASS_KG  # noqa: F401 (importable from here)
from rbd_ros.sim.urdf_robot import (  # noqa: F401 (importable from here, as before)
    DESCRIPTION, LIMITED_TYPES, RobotCollision)
from rbd_ros.sim.urdf_robot import (MOVING_TYPES, refuse, Robot, RobotJoint, RobotLink,
                                    STATE_TYPES, URDF_JOINT_TYPES)
from rbd_ros.sim.urdf_xml import _parse, _read


def _check_tree(source, robot):
    """Return ``(root name, parent joint of each link)``; refuse unknown links and loops."""
    names = [link.name for link in robot.links]
    for kind, items in (('link', robot.links), ('joint', robot.joints)):
        seen = set()
        for item in items:
            if item.name in seen:
                refuse(ModelError, source, f'{kind} {item.name!r}', 'named twice; names must be '
                       'unique')
            seen.add(item.name)
    parent_of = {}
    for joint in robot.joints:
        who = f'joint {joint.name!r}'
        if joint.type not in URDF_JOINT_TYPES:
            refuse(ModelError, source, f'{who}.type', f'{joint.type!r} is not one of '
                   f'{", ".join(URDF_JOINT_TYPES)}', joint.type)
        for field in ('parent', 'child'):
            if getattr(joint, field) not in names:
                refuse(ModelError, source, f'{who}.{field}', f'link {getattr(joint, field)!r} '
                       'is not a link of the robot', getattr(joint, field))
        if joint.child in parent_of:
            refuse(ModelError, source, f'{who}.child', f'link {joint.child!r} is already the '
                   f'child of joint {parent_of[joint.child].name!r}: a link with two parents '
                   'is a loop, and a URDF is a tree', joint.child)
        parent_of[joint.child] = joint
    roots = [name for name in names if name not in parent_of]
    if len(roots) != 1:
        detail = ('every link is a child: the joints form a loop' if not roots else
                  f'{len(roots)} root links ({", ".join(map(repr, roots))}); a URDF is one tree')
        refuse(ModelError, source, 'links', detail)
    # a loop not through the root leaves links unreached from it
    reached, frontier = {roots[0]}, [roots[0]]
    while frontier:
        name = frontier.pop()
        for joint in robot.joints:
            if joint.parent == name and joint.child not in reached:
                reached.add(joint.child)
                frontier.append(joint.child)
    loose = [name for name in names if name not in reached]
    if loose:
        refuse(ModelError, source, f'link {loose[0]!r}', 'is on a loop of joints not reached '
               f'from the root {roots[0]!r}; a URDF is a tree')
    return roots[0], parent_of


def load_urdf(path=None, *, xml=None) -> Robot:
    """
    Return the :class:`Robot` of a URDF file (``.urdf``, ``.xacro``) or of its XML text.

    :param path: a file path or ``package://`` URI; relative meshes are relative to its folder.
    :param xml: the XML itself (``robot_description``); relative meshes are relative to the
        working directory. Give exactly one of the two.
    :raises ConfigError: the file is missing, not XML, not a URDF, or xacro fails.
    :raises ModelError: a link, joint or collision is wrong (see the module docstring).
    """
    if (path is None) == (xml is None):
        raise ConfigError('urdf: give a urdf_path or a robot_description, exactly one')
    source, data = _read(path, xml)
    base_dir = os.path.dirname(os.path.abspath(source)) if xml is None else os.getcwd()
    parsed = _parse(source, data)
    root, parent_of = _check_tree(source, parsed)
    by_name = {link.name: link for link in parsed.links}
    fixed_to_world = root == 'world'
    # carrier of each link: (body index or None, 4x4 of the link in the carrier's frame)
    carriers, body_links = {}, []

    def new_body(link):
        if inertials[link.name] is None:
            joint = parent_of.get(link.name)
            how = 'the floating root' if joint is None else f'on {joint.type} joint ' \
                f'{joint.name!r}'
            refuse(ModelError, source, f'link {link.name!r}.inertial', f'missing: a moving '
                   f'link ({how}) needs <inertial> with mass and inertia')
        body_links.append(link.name)
        return len(body_links) - 1, _translation(-inertials[link.name][1])

    inertials = {link.name: _inertial(source, link) for link in parsed.links}
    order = [root]
    for name in order:
        order.extend(j.child for j in parsed.joints if j.parent == name)
    for name in order:
        joint = parent_of.get(name)
        if joint is None:
            carriers[name] = (None, np.eye(4)) if fixed_to_world else new_body(by_name[name])
        elif joint.type == 'fixed' and (carriers[joint.parent][0] is None
                                        or inertials[name] is None):
            body, pose = carriers[joint.parent]
            carriers[name] = (body, pose @ _matrix(joint.origin))
        else:
            carriers[name] = new_body(by_name[name])
    # bodies in URDF link order (the tree order built them parent first)
    link_order = [link.name for link in parsed.links if link.name in body_links]
    renumber = {body_links.index(name): k for k, name in enumerate(link_order)}
    links = []
    for link in parsed.links:
        body, pose = carriers[link.name]
        position, quat = frozen_pose(pose)
        collisions = tuple(_collision(source, link, k, element, base_dir, pose)
                           for k, element in enumerate(link.collisions))
        inertial = inertials[link.name]
        mass, com, inertia = inertial if inertial is not None else (None, None, None)
        links.append(RobotLink(link.name, None if body is None else renumber[body], position,
                               quat, mass, com, inertia, collisions))
    joints, core = [], 0
    for joint in parsed.joints:
        values = _joint_values(source, joint)
        child_body = carriers[joint.child][0]
        owns = child_body is not None and body_links[child_body] == joint.child
        index = None
        if owns and joint.type != 'floating':
            index, core = core, core + 1
        origin = _matrix(joint.origin)
        origin.flags.writeable = False
        joints.append(RobotJoint(joint.name, joint.type, joint.parent, joint.child, origin,
                                 values[7], *values[:7], index))
    _check_mimics(source, joints)
    entries = [(entry, joint.name, k) for joint in joints if joint.kind in STATE_TYPES
               for entry, k in coordinate_entries(joint.name, joint.kind)]
    names = {joint.name for joint in joints}
    for entry, joint, _ in entries:
        if entry != joint and entry in names:
            refuse(ModelError, source, f'joint {entry!r}', f'has the name of planar joint '
                   f"{joint!r}'s joint_states entry {entry!r}; rename one", entry)
    return Robot(parsed.name, source, data.decode(), tuple(links), tuple(joints),
                 tuple(link_order), tuple(e[0] for e in entries), fixed_to_world, root,
                 tuple((joint, k) for _, joint, k in entries))


def _check_mimics(source, joints):
    """Refuse a ``<mimic>`` of itself, of an unknown joint or another kind, or a cycle."""
    by_name = {joint.name: joint for joint in joints}
    for joint in joints:
        if joint.mimic is None:
            continue
        field, leader = f'joint {joint.name!r}.mimic.joint', joint.mimic[0]
        if joint.kind not in MOVING_TYPES:
            refuse(ModelError, source, field, f'{leader!r}; a {joint.kind} joint cannot mimic '
                   f'(only {", ".join(MOVING_TYPES)} can)', leader)
        if leader == joint.name:
            refuse(ModelError, source, field, f'{leader!r} is the joint itself', leader)
        if leader not in by_name:
            refuse(ModelError, source, field, f'{leader!r} is not a joint of this robot', leader)
        if by_name[leader].kind not in MOVING_TYPES:
            refuse(ModelError, source, field, f'{leader!r} is a {by_name[leader].kind} joint; a '
                   f'mimic follows a {", ".join(MOVING_TYPES)} joint', leader)
        chain, seen = by_name[leader], {joint.name}
        while chain is not None:
            if chain.name in seen:
                refuse(ModelError, source, field, f'{leader!r} leads back to {joint.name!r} (a '
                       'cycle of mimics)', leader)
            seen.add(chain.name)
            chain = None if chain.mimic is None else by_name[chain.mimic[0]]
