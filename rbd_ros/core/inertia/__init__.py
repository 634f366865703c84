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
Mass properties: mass, centre of mass and inertia tensor of a rigid body.

The inertia tensor about a point ``o`` is ``I = sum_i m_i (r_i^T r_i 1 - r_i r_i^T)``, or
``int rho (r^T r 1 - r r^T) dV`` for a continuum, with ``r`` measured from ``o``.  Unless a
name says otherwise, inertia is about the centre of mass (COM) in body coordinates
(``inertia_b``, kg·m²); the world inertia is ``I_w = R_wb I_b R_wb^T`` (:func:`rotate_inertia`).

Sources: closed forms are the standard ones (e.g. the list of moments of inertia linked from
the lecture); the triangle-mesh integrals follow D. Eberly, "Polyhedral Mass Properties
(Revisited)", Geometric Tools, 2002 (after B. Mirtich, "Fast and Accurate Computation of
Polyhedral Mass Properties", J. Graphics Tools 1(2), 1996).

Units: kg, m, kg·m², kg/m³.  Off-diagonal entries are the matrix entries ``I[0, 1]`` etc.
(``ixy = -sum m x y``), the ROS / URDF convention.

One module a part, every name importable from here:

- :mod:`.tensor`: :class:`MassProperties`, the checks of a mass and of an inertia tensor
  (symmetric, positive definite, the triangle inequality), and the tensor's operations
  (components, parallel axis, rotation, principal axes);
- :mod:`.shapes`: the closed forms of the primitive solids and :func:`from_shape` by name;
- :mod:`.mesh`: mass properties from data: point masses, a bounding box, sampling an inside
  test, and a closed triangle mesh.
"""

from rbd_ros.core.inertia.mesh import bounding_box, point_masses, point_sampling, triangle_mesh
from rbd_ros.core.inertia.shapes import (box, capsule, from_shape, hollow_cylinder,
                                         shape_dimensions, SHAPES, solid_cylinder,
                                         solid_ellipsoid, solid_sphere, spherical_shell)
from rbd_ros.core.inertia.tensor import (  # noqa: F401 (the tolerances, importable from here)
    inertia_from_components, MassProperties, parallel_axis, principal_axes, rotate_inertia,
    SYMMETRY_RTOL, TRIANGLE_RTOL, validate_inertia, validate_mass)

__all__ = [
    'MassProperties',
    'SHAPES',
    'bounding_box',
    'box',
    'capsule',
    'from_shape',
    'hollow_cylinder',
    'inertia_from_components',
    'parallel_axis',
    'point_masses',
    'point_sampling',
    'principal_axes',
    'rotate_inertia',
    'shape_dimensions',
    'solid_cylinder',
    'solid_ellipsoid',
    'solid_sphere',
    'spherical_shell',
    'triangle_mesh',
    'validate_inertia',
    'validate_mass',
]
