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
"""

from dataclasses import dataclass
import io
import math
import os
from pathlib import Path
from typing import Any, NoReturn, Optional, Tuple, Type
import warnings

from lxml import etree
import numpy as np
from rbd_ros.core.contact.mesh_shapes import load_mesh
from rbd_ros.core.contact.shapes import CollisionShape, primitive_shape
from rbd_ros.core.errors import ConfigError, ModelError, RbdError
from rbd_ros.core.inertia import validate_inertia, validate_mass
from rbd_ros.core.rotations import matrix_to_quat
from rbd_ros.sim.joint_commands import coordinate_entries
from rbd_ros.sim.meshes import resolve_mesh_path
from rbd_ros.sim.params import MAX_MESH_FILE_BYTES, MAX_POSITION_M, PARAMETERS_BY_NAME
import yourdfpy

#: Every URDF joint type.
URDF_JOINT_TYPES = ('revolute', 'continuous', 'prismatic', 'fixed', 'floating', 'planar')
#: The joint types with one coordinate (one entry of ``joint_states`` each).
MOVING_TYPES = ('revolute', 'continuous', 'prismatic')
#: The joint types in ``joint_states``: one entry a coordinate (a planar joint's three).
STATE_TYPES = MOVING_TYPES + ('planar',)
#: The joint types whose ``<limit>`` the URDF spec requires.
LIMITED_TYPES = ('revolute', 'prismatic')
#: The source name of a URDF given as XML text (the ROS parameter's name).
DESCRIPTION = 'robot_description'


@dataclass(frozen=True)
class RobotCollision:
    """
    One ``<collision>``: a shape centred in its frame, and that frame in the body frame.

    ``position_l`` and ``orientation_l``: that frame in its link's frame (its ``<origin>``).
    ``mesh_file``: a mesh's ``(filename as the URDF gives it, the file loaded, scale)``, else
    None.
    """

    shape: CollisionShape
    position_b: np.ndarray
    orientation_b: np.ndarray
    position_l: np.ndarray
    orientation_l: np.ndarray
    mesh_file: Optional[Tuple[str, str, Tuple[float, float, float]]] = None


@dataclass(frozen=True)
class RobotLink:
    """
    One URDF link.

    :param body: index of the body that carries it (into :attr:`Robot.body_links`), or None
        when it is part of the world.
    :param position_b, orientation_b: the link frame in that body's frame (m; ``w, x, y, z``);
        for a world link, in the root link's frame.
    :param mass_kg, com_m, inertia_b: its ``<inertial>`` (COM in link coordinates; inertia
        about the COM in link axes, kg m²), or None when it has none.
    """

    name: str
    body: Optional[int]
    position_b: np.ndarray
    orientation_b: np.ndarray
    mass_kg: Optional[float]
    com_m: Optional[np.ndarray]
    inertia_b: Optional[np.ndarray]
    collisions: Tuple[RobotCollision, ...]


@dataclass(frozen=True)
class RobotJoint:
    """
    One URDF joint as written (SI units; ``origin`` in the parent link, ``axis`` unit, in it).

    ``velocity`` (the ``<limit>`` velocity), ``damping`` and ``friction`` (``<dynamics>``, N m
    s/rad or N s/m and N m or N; simulated on revolute, continuous and prismatic joints) and
    ``mimic`` (``(joint, multiplier, offset)``: held, see the module docstring); ``core`` is
    the index of its :class:`rbd_ros.core.joints.Joint` in
    :attr:`rbd_ros.sim.robot_placement.Placement.joints`, or None (folded fixed joints,
    floating).
    """

    name: str
    kind: str
    parent: str
    child: str
    origin: np.ndarray
    axis: np.ndarray
    lower: Optional[float]
    upper: Optional[float]
    effort: Optional[float]
    velocity: Optional[float]
    damping: float
    friction: float
    mimic: Optional[tuple]
    core: Optional[int]


@dataclass(frozen=True)
class Robot:
    """
    A robot read from URDF: links and joints in document order, plus what the core needs.

    :param urdf: the XML as loaded (after xacro): what ``robot_description`` publishes.
    :param body_links: the link of each body, in body order (URDF link order).
    :param moving_joints: the joint_states entries, in order (see the module docstring).
    :param coordinates: per entry of ``moving_joints``, ``(its joint's name, its coordinate)``:
        None for a one-coordinate joint, 0, 1, 2 for a planar joint's x, y, theta.
    :param fixed_to_world: the root link is ``world``.
    """

    name: str
    source: str
    urdf: str
    links: Tuple[RobotLink, ...]
    joints: Tuple[RobotJoint, ...]
    body_links: Tuple[str, ...]
    moving_joints: Tuple[str, ...]
    fixed_to_world: bool
    root: str
    coordinates: Tuple[Tuple[str, Optional[int]], ...] = ()

    @property
    def state_joints(self) -> Tuple[str, ...]:
        """Return the joints with entries in ``joint_states``, in order, each once."""
        return tuple(dict.fromkeys(joint for joint, _ in self.coordinates))

    def entry(self, name: str) -> Tuple[RobotJoint, Optional[int]]:
        """Return the joint and coordinate of ``joint_states`` entry ``name``."""
        joint, coordinate = self.coordinates[self.moving_joints.index(name)]
        return self.joint(joint), coordinate

    def link(self, name: str) -> RobotLink:
        """Return the link called ``name``."""
        return next(link for link in self.links if link.name == name)

    def joint(self, name: str) -> RobotJoint:
        """Return the joint called ``name``."""
        return next(joint for joint in self.joints if joint.name == name)


def refuse(error: Type[RbdError], source: str, field: str, detail: str, value: Any = None,
           unit: Optional[str] = None) -> NoReturn:
    """Raise ``error('<source>: <field>: <detail>')`` carrying field, value and unit."""
    raise error(f'{source}: {field}: {detail}', field=field, value=value, unit=unit,
                detail=detail)


def _read(path=None, xml=None):
    """Return ``(source, xml bytes)``: the file (xacro expanded) or the text."""
    if xml is not None:
        return DESCRIPTION, xml.encode() if isinstance(xml, str) else bytes(xml)
    path = resolve_mesh_path(str(path), 'urdf_path')
    source = str(path)
    if not os.path.isfile(path):
        raise ConfigError(f'urdf_path: {source!r} does not exist or is not a file',
                          field='urdf_path', value=source)
    if source.endswith('.xacro'):
        try:
            import xacro
        except ImportError:
            raise ConfigError(f'urdf_path: {source!r}: the xacro package is not installed '
                              '(pip install xacro), so a .xacro file cannot be expanded',
                              field='urdf_path', value=source) from None
        try:
            with warnings.catch_warnings():
                warnings.simplefilter('ignore')
                return source, xacro.process_file(source).toxml().encode()
        except Exception as exc:  # xacro raises XacroException, ExpatError, OSError, ...
            reason = ' '.join(str(exc).split()) or type(exc).__name__
            raise ConfigError(f'{source}: xacro failed: {reason}', field='urdf_path',
                              value=source) from None
    return source, Path(path).read_bytes()


def _parse(source, data):
    """Return the yourdfpy robot of ``data``, refusing malformed XML with its line."""
    try:
        root = etree.fromstring(data, etree.XMLParser(remove_blank_text=True))
    except etree.XMLSyntaxError as exc:
        refuse(ConfigError, source, 'xml', f'malformed XML: {exc}')
    if root.tag != 'robot':
        refuse(ConfigError, source, 'xml', f'the root element is <{root.tag}>, not <robot>')
    for element in root.iter('link', 'joint'):
        if not element.get('name'):
            refuse(ModelError, source, f'<{element.tag}> (line {element.sourceline})',
                   'has no name attribute')
    for element in root.iter('joint'):
        for tag in ('parent', 'child'):
            found = element.find(tag)
            if found is None or not found.get('link'):
                refuse(ModelError, source, f'joint {element.get("name")!r}.{tag}',
                       f'missing (line {element.sourceline}): a joint needs <{tag} link=...>')
        kind = element.get('type')
        if kind in LIMITED_TYPES and element.find('limit') is None:
            # the URDF spec requires it (urdfdom, so robot_state_publisher, refuses the file)
            refuse(ModelError, source, f'joint {element.get("name")!r}.limit',
                   f'missing (line {element.sourceline}): a {kind} joint needs <limit '
                   'lower=... upper=... effort=... velocity=.../> (a joint without limits is '
                   'continuous)')
    for element in root.iter('origin'):
        if element.getparent().tag in ('joint', 'inertial', 'collision', 'visual'):
            _check_origin(source, element)
    try:
        return yourdfpy.URDF.load(io.BytesIO(data), build_scene_graph=False,
                                  build_collision_scene_graph=False, load_meshes=False,
                                  load_collision_meshes=False).robot
    except (KeyError, ValueError, TypeError, AttributeError, IndexError) as exc:
        refuse(ConfigError, source, 'xml', f'not a valid URDF ({type(exc).__name__}: {exc})')


def _origin_field(element):
    """Return an ``<origin>``'s field: ``joint 'j'.origin``, ``link 'a'.collision[0].origin``."""
    owner = element.getparent()
    if owner.tag == 'joint':
        return f'joint {owner.get("name")!r}.origin'
    link = owner.getparent()
    if owner.tag in ('inertial', 'collision', 'visual') and link is not None \
            and link.tag == 'link':
        where = owner.tag
        if owner.tag != 'inertial':
            where += f'[{link.findall(owner.tag).index(owner)}]'
        return f'link {link.get("name")!r}.{where}.origin'
    return f'{owner.tag}.origin'


def _check_origin(source, element):
    """
    Refuse an ``<origin>`` that is not 3 finite numbers or lies too far away, naming it.

    ``xyz`` and ``rpy`` must be 3 finite numbers, ``xyz`` within :data:`MAX_POSITION_M` (as a
    body's ``initial_position``). yourdfpy would build a NaN pose from ``nan`` (refused much
    later, naming a rotation but no file or joint), and a frame 1e300 m away made the first
    step fail without a name.
    """
    for attribute, unit in (('xyz', 'm'), ('rpy', 'rad')):
        text = element.get(attribute)
        if text is None:
            continue
        field = f'{_origin_field(element)}.{attribute}'
        try:
            values = [float(v) for v in text.split()]
        except ValueError:
            values = None
        if values is None or len(values) != 3:
            refuse(ModelError, source, field, f'{text!r} must be 3 numbers in {unit} '
                   f'(line {element.sourceline})', text, unit)
        if not all(math.isfinite(v) for v in values):
            refuse(ModelError, source, field, f'{values} {unit} must be finite '
                   f'(line {element.sourceline})', values, unit)
        if attribute == 'xyz' and any(abs(v) > MAX_POSITION_M for v in values):
            refuse(ModelError, source, field, f'{values} m: every component must be within '
                   f'±{MAX_POSITION_M:g} m (line {element.sourceline})', values, unit)


def _number(value, source, field, unit, default=None):
    if value is None:
        return default
    try:
        number = float(value)
    except (TypeError, ValueError):
        refuse(ModelError, source, field, f'{value!r} is not a number in {unit}', value, unit)
    if not math.isfinite(number):
        refuse(ModelError, source, field, f'{number!r} {unit} must be finite', value, unit)
    return number


def _matrix(origin):
    """Return the 4x4 of a yourdfpy origin (None: identity)."""
    return np.eye(4) if origin is None else np.asarray(origin, dtype=np.float64)


def frozen_pose(matrix: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """Return ``(position, quaternion w x y z)`` of a 4x4, frozen."""
    position = np.array(matrix[:3, 3])
    quat = matrix_to_quat(matrix[:3, :3])
    position.flags.writeable = quat.flags.writeable = False
    return position, quat


def _translation(vector):
    out = np.eye(4)
    out[:3, 3] = vector
    return out


#: A link's largest mass (kg): the bound of a body's ``mass_kg`` parameter.
MAX_MASS_KG = PARAMETERS_BY_NAME['mass_kg'].bounds[1]


def _inertial(source, link):
    """Return ``(mass, com in link, inertia about com in link axes)`` or None."""
    inertial = link.inertial
    if inertial is None:
        return None
    who = f'link {link.name!r}'
    if inertial.mass is None:
        refuse(ModelError, source, f'{who}.inertial.mass', 'missing; <inertial> needs <mass>')
    try:
        mass = validate_mass(inertial.mass, 'mass')
    except RbdError as exc:
        refuse(ModelError, source, f'{who}.inertial.mass', exc.detail or str(exc),
               inertial.mass, 'kg')
    if mass > MAX_MASS_KG:  # 1e308 kg under gravity: an infinite force in the first step
        refuse(ModelError, source, f'{who}.inertial.mass',
               f"{mass!r} kg must be <= {MAX_MASS_KG:g} (the mass_kg parameter's bound)",
               mass, 'kg')
    frame = _matrix(inertial.origin)
    raw = np.asarray(inertial.inertia if inertial.inertia is not None else np.zeros((3, 3)))
    try:
        validate_inertia(raw, 'inertia')
    except RbdError as exc:
        refuse(ModelError, source, f'{who}.inertial.inertia', exc.detail or str(exc),
               raw.tolist(), 'kg m²')
    rot = frame[:3, :3]
    inertia = rot @ raw @ rot.T
    inertia = 0.5 * (inertia + inertia.T)
    return mass, np.array(frame[:3, 3]), inertia


def _collision(source, link, index, element, base_dir, to_body):
    """Return the :class:`RobotCollision` of one ``<collision>`` (pose ``to_body`` · origin)."""
    who = f'link {link.name!r}.collision[{index}]'
    geometry = element.geometry
    mesh_file = None
    try:
        if geometry is None:
            refuse(ModelError, source, who, 'has no <geometry>')
        if geometry.box is not None:
            shape = primitive_shape('box', geometry.box.size, field=f'{who}.box.')
        elif geometry.cylinder is not None:
            shape = primitive_shape('cylinder', (geometry.cylinder.radius,
                                                 geometry.cylinder.length),
                                    field=f'{who}.cylinder.')
        elif geometry.sphere is not None:
            shape = primitive_shape('sphere', (geometry.sphere.radius,), field=f'{who}.sphere.')
        elif geometry.mesh is not None:
            filename = geometry.mesh.filename or ''
            path = filename[len('file://'):] if filename.startswith('file://') else filename
            path = resolve_mesh_path(path, f'{who}.mesh.filename')
            if not os.path.isabs(path):
                path = os.path.join(base_dir, path)
            if not os.path.isfile(path):
                refuse(ModelError, source, f'{who}.mesh.filename',
                       f'{filename!r} ({path}) does not exist or is not a file', filename)
            size = os.path.getsize(path)
            if size > MAX_MESH_FILE_BYTES:  # the limit of every mesh file, before it is read
                refuse(ModelError, source, f'{who}.mesh.filename',
                       f'{filename!r} ({path}) is {size} bytes, more than the limit of '
                       f'{MAX_MESH_FILE_BYTES} bytes', filename)
            scale = geometry.mesh.scale
            scale = (1.0, 1.0, 1.0) if scale is None else np.broadcast_to(scale, 3)
            shape = load_mesh(path, scale, centre=False, field=f'{who}.mesh.')
            mesh_file = (filename, path, tuple(float(f) for f in scale))
        else:
            refuse(ModelError, source, who, 'has no box, cylinder, sphere or mesh')
    except RbdError as exc:
        if str(exc).startswith(source):
            raise
        raise type(exc)(f'{source}: {exc}', field=exc.field, value=exc.value,
                        unit=exc.unit, detail=exc.detail) from None
    origin = _matrix(element.origin)
    position, quat = frozen_pose(to_body @ origin)
    return RobotCollision(shape, position, quat, *frozen_pose(origin), mesh_file)


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


def _joint_values(source, joint):
    """Return the checked number fields of one joint."""
    who = f'joint {joint.name!r}'
    rotary = joint.type in ('revolute', 'continuous')
    unit = 'rad' if rotary else 'm'
    limit, dynamics = joint.limit, joint.dynamics
    lower = upper = effort = velocity = None
    if limit is not None:
        lower = _number(limit.lower, source, f'{who}.limit.lower', unit)
        upper = _number(limit.upper, source, f'{who}.limit.upper', unit)
        effort = _number(limit.effort, source, f'{who}.limit.effort',
                         'N m' if rotary else 'N')
        velocity = _number(limit.velocity, source, f'{who}.limit.velocity',
                           'rad/s' if rotary else 'm/s')
        for name, value in (('effort', effort), ('velocity', velocity)):
            if value is not None and value < 0.0:
                refuse(ModelError, source, f'{who}.limit.{name}', f'{value!r} must be >= 0',
                       value)
    if joint.type not in ('revolute', 'prismatic'):
        lower = upper = None   # URDF: continuous and the others ignore lower and upper
    else:
        # The URDF spec: lower and upper default to 0. urdfdom reads them so, and with it
        # robot_state_publisher, ros2_control's joint limits and MoveIt; taken as no limits,
        # the simulated joint moved where the controllers reading the same file hold it.
        lower = 0.0 if lower is None else lower
        upper = 0.0 if upper is None else upper
    if lower is not None and upper is not None and lower > upper:
        refuse(ModelError, source, f'{who}.limit.lower', f'{lower!r} {unit} is above upper '
               f'{upper!r} {unit}', lower, unit)
    damping = friction = 0.0
    if dynamics is not None:
        units = {'damping': 'N m s/rad' if rotary else 'N s/m',
                 'friction': 'N m' if rotary else 'N'}
        damping = _number(dynamics.damping, source, f'{who}.dynamics.damping',
                          units['damping'], 0.0)
        friction = _number(dynamics.friction, source, f'{who}.dynamics.friction',
                           units['friction'], 0.0)
        for name, value in (('damping', damping), ('friction', friction)):
            if value < 0.0:
                refuse(ModelError, source, f'{who}.dynamics.{name}',
                       f'{value!r} {units[name]} must be >= 0', value, units[name])
    mimic = None
    if joint.mimic is not None:
        mimic = (joint.mimic.joint, _number(joint.mimic.multiplier, source,
                                            f'{who}.mimic.multiplier', 'per leader unit', 1.0),
                 _number(joint.mimic.offset, source, f'{who}.mimic.offset', unit, 0.0))
    axis = np.asarray(joint.axis if joint.axis is not None else (1.0, 0.0, 0.0), float)
    norm = 0.0
    if axis.shape == (3,):
        with np.errstate(over='ignore'):
            norm = float(np.linalg.norm(axis))
        if norm == math.inf and np.isfinite(axis).all():
            # (0, 1e300, 1e300) is a direction whose norm overflows: scale it to 1 first
            axis = axis / np.abs(axis).max()
            norm = float(np.linalg.norm(axis))
    if joint.type != 'fixed' and joint.type != 'floating' and not (
            math.isfinite(norm) and norm > 1e-12):
        refuse(ModelError, source, f'{who}.axis', f'{axis.tolist()} is not a direction',
               axis.tolist())
    axis = axis / norm if norm > 0.0 else np.array([1.0, 0.0, 0.0])
    return lower, upper, effort, velocity, damping, friction, mimic, axis


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
