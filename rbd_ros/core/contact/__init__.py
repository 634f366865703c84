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
Collision geometry and the static world: the data the contact stages read.

Shapes (:mod:`~rbd_ros.core.contact.shapes`, meshes and compounds in
:mod:`~rbd_ros.core.contact.mesh_shapes`) are surface points plus a signed distance φ,
evaluated by compiled kernels (:mod:`~rbd_ros.core.contact.kernels`); materials, the static
world and the start-up overlap check are in :mod:`~rbd_ros.core.contact.world`.
"""

from rbd_ros.core.contact.mesh_shapes import collision_shape, load_mesh, mesh_shape
from rbd_ros.core.contact.shapes import CollisionShape, plane_shape, primitive_shape, PRIMITIVES
from rbd_ros.core.contact.world import (check_overlaps, ground_plane, Material, obstacle,
                                        penetration_depth, StaticObject, StaticWorld,
                                        validate_material)

__all__ = [
    'CollisionShape', 'Material', 'PRIMITIVES', 'StaticObject', 'StaticWorld',
    'check_overlaps', 'collision_shape', 'ground_plane', 'load_mesh', 'mesh_shape',
    'obstacle', 'penetration_depth', 'plane_shape', 'primitive_shape', 'validate_material',
]
