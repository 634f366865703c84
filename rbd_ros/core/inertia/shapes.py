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
The mass properties of the primitive solids of uniform density, in closed form, and by name.

:func:`box`, :func:`solid_sphere`, :func:`spherical_shell`, :func:`solid_cylinder`,
:func:`hollow_cylinder`, :func:`solid_ellipsoid`, :func:`capsule`, each centred at the origin
with its formula in its docstring; :func:`from_shape` builds one by name (:data:`SHAPES`) from
its ``dimensions_m``, checked by :func:`shape_dimensions`.
"""

import math

import numpy as np

from rbd_ros.core.errors import field_error, ModelError
from rbd_ros.core.inertia.tensor import (_validate_length, _validate_vector, MassProperties,
                                         validate_mass)


def _central(mass_kg, moments):
    """Return MassProperties with COM at the origin and a diagonal inertia."""
    return MassProperties(mass_kg, np.zeros(3), np.diag(np.asarray(moments, dtype=float)))


def _triaxial(mass_kg, lengths_m, name, divisor):
    """Return the centred solid with ``Ixx = m (y² + z²) / divisor`` etc. (box, ellipsoid)."""
    mass = validate_mass(mass_kg)
    lengths = _validate_vector(lengths_m, name, 'm')
    x, y, z = (_validate_length(s, f'{name}[{i}]') for i, s in enumerate(lengths))
    return _central(mass, [mass * (y * y + z * z) / divisor, mass * (x * x + z * z) / divisor,
                           mass * (x * x + y * y) / divisor])


def box(mass_kg, size_m) -> 'MassProperties':
    """
    Return a solid box of full edge lengths ``size_m = (x, y, z)`` centred at the origin.

    ``Ixx = m (y^2 + z^2) / 12``, ``Iyy = m (x^2 + z^2) / 12``, ``Izz = m (x^2 + y^2) / 12``.
    """
    return _triaxial(mass_kg, size_m, 'size_m', 12.0)


def solid_sphere(mass_kg, radius_m) -> 'MassProperties':
    """Return a solid sphere centred at the origin: ``I = 2 m r^2 / 5`` about every axis."""
    mass = validate_mass(mass_kg)
    r = _validate_length(radius_m, 'radius_m')
    return _central(mass, [0.4 * mass * r * r] * 3)


def spherical_shell(mass_kg, radius_m) -> 'MassProperties':
    """Return a thin spherical shell centred at the origin: ``I = 2 m r^2 / 3``."""
    mass = validate_mass(mass_kg)
    r = _validate_length(radius_m, 'radius_m')
    return _central(mass, [2.0 * mass * r * r / 3.0] * 3)


def solid_cylinder(mass_kg, radius_m, length_m) -> 'MassProperties':
    """
    Return a solid cylinder along z centred at the origin.

    ``Izz = m r^2 / 2``, ``Ixx = Iyy = m (3 r^2 + L^2) / 12``.
    """
    mass = validate_mass(mass_kg)
    r = _validate_length(radius_m, 'radius_m')
    length = _validate_length(length_m, 'length_m')
    transverse = mass * (3.0 * r * r + length * length) / 12.0
    return _central(mass, [transverse, transverse, 0.5 * mass * r * r])


def hollow_cylinder(mass_kg, inner_radius_m, outer_radius_m, length_m) -> 'MassProperties':
    """
    Return a thick-walled tube along z centred at the origin (``inner < outer``).

    ``Izz = m (r1^2 + r2^2) / 2``, ``Ixx = Iyy = m (3 (r1^2 + r2^2) + L^2) / 12``.
    """
    mass = validate_mass(mass_kg)
    r1 = _validate_length(inner_radius_m, 'inner_radius_m')
    r2 = _validate_length(outer_radius_m, 'outer_radius_m')
    length = _validate_length(length_m, 'length_m')
    if r1 >= r2:
        raise ModelError(
            f'inner_radius_m: {r1!r} m must be < outer_radius_m ({r2!r} m)')
    sq = r1 * r1 + r2 * r2
    transverse = mass * (3.0 * sq + length * length) / 12.0
    return _central(mass, [transverse, transverse, 0.5 * mass * sq])


def solid_ellipsoid(mass_kg, semi_axes_m) -> 'MassProperties':
    """
    Return a solid ellipsoid with semi-axes ``(a, b, c)`` along x, y, z, centred at the origin.

    ``Ixx = m (b^2 + c^2) / 5``, ``Iyy = m (a^2 + c^2) / 5``, ``Izz = m (a^2 + b^2) / 5``.
    """
    return _triaxial(mass_kg, semi_axes_m, 'semi_axes_m', 5.0)


def capsule(mass_kg, radius_m, length_m) -> 'MassProperties':
    """
    Return a capsule along z centred at the origin: a cylinder plus two hemispherical caps.

    ``length_m`` is the length ``L`` of the cylindrical part (total length ``L + 2 r``).  The
    mass is split by volume: ``m_c = m V_c / V``, ``m_s = m V_s / V`` with
    ``V_c = pi r^2 L``, ``V_s = 4 pi r^3 / 3`` (both caps).  Each cap of mass ``m_s / 2`` has
    its COM ``3 r / 8`` from its flat face, and about its flat face's centre the same
    transverse moment as a sphere, ``2 (m_s / 2) r^2 / 5``; moving that to the cap's COM and
    then to the capsule centre (``L / 2 + 3 r / 8`` away) gives, for both caps together,
    ``m_s (2 r^2 / 5 + L^2 / 4 + 3 r L / 8)``.  Hence

    ``Izz = m_c r^2 / 2 + 2 m_s r^2 / 5``,
    ``Ixx = Iyy = m_c (3 r^2 + L^2) / 12 + m_s (2 r^2 / 5 + L^2 / 4 + 3 r L / 8)``.
    """
    mass = validate_mass(mass_kg)
    r = _validate_length(radius_m, 'radius_m')
    length = _validate_length(length_m, 'length_m')
    v_cyl = math.pi * r * r * length
    v_caps = 4.0 * math.pi * r ** 3 / 3.0
    m_cyl = mass * v_cyl / (v_cyl + v_caps)
    m_caps = mass * v_caps / (v_cyl + v_caps)
    axial = 0.5 * m_cyl * r * r + 0.4 * m_caps * r * r
    transverse = (m_cyl * (3.0 * r * r + length * length) / 12.0
                  + m_caps * (0.4 * r * r + 0.25 * length * length + 0.375 * r * length))
    return _central(mass, [transverse, transverse, axial])


# name -> (builder, names of the dimensions in order)
_SHAPE_BUILDERS = {
    'box': (lambda m, d: box(m, d), ('x', 'y', 'z')),
    'sphere': (lambda m, d: solid_sphere(m, d[0]), ('radius',)),
    'spherical_shell': (lambda m, d: spherical_shell(m, d[0]), ('radius',)),
    'cylinder': (lambda m, d: solid_cylinder(m, d[0], d[1]), ('radius', 'length')),
    'ellipsoid': (lambda m, d: solid_ellipsoid(m, d), ('a', 'b', 'c')),
    'capsule': (lambda m, d: capsule(m, d[0], d[1]), ('radius', 'length')),
}

#: Shape names accepted by :func:`from_shape`.
SHAPES = tuple(_SHAPE_BUILDERS)


def from_shape(shape, dimensions_m, mass_kg) -> 'MassProperties':
    """
    Return the mass properties of a named solid of uniform density, centred at the origin.

    ==================  =====================================
    ``shape``           ``dimensions_m``
    ==================  =====================================
    ``box``             ``[x, y, z]`` full edge lengths
    ``sphere``          ``[radius]``
    ``spherical_shell`` ``[radius]`` (thin shell)
    ``cylinder``        ``[radius, length]`` (axis z)
    ``ellipsoid``       ``[a, b, c]`` semi-axes along x, y, z
    ``capsule``         ``[radius, length]`` (cylindrical part, axis z)
    ==================  =====================================

    :raises ModelError: for an unknown ``shape``, a wrong number of dimensions, or a dimension
        that is not finite and > 0; the message names ``shape`` or ``dimensions_m``, the value,
        the unit and the rule.
    """
    if shape not in _SHAPE_BUILDERS:
        raise field_error(ModelError, 'shape', f'{shape!r} is not one of {", ".join(SHAPES)}',
                          shape, '')
    builder, _ = _SHAPE_BUILDERS[shape]
    dims = shape_dimensions(shape, dimensions_m)
    return builder(mass_kg, dims)


def shape_dimensions(shape: str, dimensions_m, field: str = '') -> np.ndarray:
    """
    Return the dimensions of ``shape`` (one of :data:`SHAPES`) as a float array, or raise.

    :param field: prefix of the parameter name in messages (e.g. ``'obstacles.ramp.'``).
    :raises ModelError: a wrong number of values or a dimension that is not finite and > 0,
        naming ``<field>dimensions_m``, the value in m and what the shape needs.
    """
    names = _SHAPE_BUILDERS[shape][1]
    expected = '[' + ', '.join(names) + ']'
    try:
        dims = np.array(dimensions_m, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise field_error(ModelError, f'{field}dimensions_m',
                          f'{dimensions_m!r} is not a list of lengths in m '
                          f'({shape!r} needs {expected})', dimensions_m, 'm') from None
    if dims.size != len(names):
        raise field_error(ModelError, f'{field}dimensions_m',
                          f'{dims.tolist()} m has {dims.size} values; shape {shape!r} '
                          f'needs {len(names)}: {expected}', dimensions_m, 'm')
    bad = ~(np.isfinite(dims) & (dims > 0.0))
    if np.any(bad):
        i = int(np.flatnonzero(bad)[0])
        raise field_error(ModelError, f'{field}dimensions_m',
                          f'{dims.tolist()} m for shape {shape!r} {expected}: '
                          f'{names[i]} = {float(dims[i])!r} m must be finite and > 0',
                          dimensions_m, 'm')
    return dims
