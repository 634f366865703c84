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
A robot read from URDF, as values: :class:`Robot`, its links, joints and collisions.

The joint types (:data:`URDF_JOINT_TYPES` and the kinds the conventions group them in) and
:func:`refuse`, the one shape of a URDF error: the file (or ``robot_description``), the link or
joint and field, its value and unit. What the values mean: :mod:`rbd_ros.sim.urdf`.
"""

from dataclasses import dataclass
from typing import Any, NoReturn, Optional, Tuple, Type

import numpy as np
from rbd_ros.core.contact.shapes import CollisionShape
from rbd_ros.core.errors import RbdError

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
