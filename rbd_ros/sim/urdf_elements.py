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
A URDF's elements read into checked values: inertials, collisions, joints; origins as poses.

:mod:`rbd_ros.sim.urdf`'s readers of one element each: ``<inertial>`` (mass and inertia checked
by the core's rules, the inertia rotated into link axes), ``<collision>`` (a primitive or a
mesh file, checked before it is read, posed in its body), a joint's numbers (``<limit>``,
``<dynamics>``, ``<mimic>``, ``<axis>``), each error naming the link or joint and field.
"""

import math
import os
from typing import Tuple

import numpy as np
from rbd_ros.core.contact.mesh_shapes import load_mesh
from rbd_ros.core.contact.shapes import primitive_shape
from rbd_ros.core.errors import ModelError, RbdError
from rbd_ros.core.inertia import validate_inertia, validate_mass
from rbd_ros.core.rotations import matrix_to_quat
from rbd_ros.sim.meshes import resolve_mesh_path
from rbd_ros.sim.params import MAX_MESH_FILE_BYTES, PARAMETERS_BY_NAME
from rbd_ros.sim.urdf_robot import refuse, RobotCollision


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
