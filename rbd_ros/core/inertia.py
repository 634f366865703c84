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
"""

from dataclasses import dataclass
import math
import numbers
from typing import Tuple

import numpy as np

from rbd_ros.core.errors import field_error, finite_vector, ModelError, positive

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

# Asymmetry allowed in an inertia tensor, relative to its largest entry.  R I R^T and the
# parallel-axis sum of a symmetric tensor are symmetric to a few ulp (~1e-16); 1e-9 leaves a
# wide margin for values copied from other tools while still catching a mistyped product of
# inertia (which is off by its own size, not by 1e-9).  Validation checks; it does not repair:
# callers use the symmetric part 0.5 (I + I^T).
SYMMETRY_RTOL = 1e-9

# Slack in the triangle inequality I1 + I2 >= I3, relative to I3.  Equality holds exactly for
# a flat plate (I3 = I1 + I2, all mass in one plane) and is approached by a thin rod; computed
# eigenvalues carry ~1e-15 relative round-off and CAD exports / URDF files usually print 6 or 7
# significant digits, so an exact plate can come out as I1 + I2 < I3 by up to ~1e-6 I3.  The
# slack admits those; anything beyond it would need mass at negative squared distance.
TRIANGLE_RTOL = 1e-6


def _fmt(values):
    """Format numbers compactly for error messages, e.g. ``[0.1, 0.1, 0.5]``."""
    values = np.asarray(values, dtype=np.float64)
    if values.ndim == 0:
        return f'{float(values):.6g}'
    return '[' + ', '.join(_fmt(v) for v in values) + ']'


def validate_mass(mass_kg, name: str = 'mass_kg') -> float:
    """
    Return ``mass_kg`` as a float after checking it is a finite real number > 0.

    :param mass_kg: mass in kg.
    :param name: the parameter name used in error messages.
    :raises ModelError: naming ``name``, the value in kg and the rule, e.g.
        ``mass_kg: -1.0 kg must be > 0``.
    """
    return positive(mass_kg, name, 'kg', ModelError)


def validate_inertia(inertia, name='inertia') -> np.ndarray:
    """
    Return ``inertia`` as a (3, 3) float64 array after checking it is a physical inertia tensor.

    Checks, in order: shape (3, 3); finite; symmetric to ``SYMMETRY_RTOL`` (1e-9) of the largest
    entry; positive definite (all principal moments > 0); principal moments ``I1 <= I2 <= I3``
    satisfy the triangle inequality ``I1 + I2 >= I3`` to ``TRIANGLE_RTOL`` (1e-6) of ``I3``,
    so the flat-plate limit (equality) passes despite round-off and printed digits.

    :param inertia: kg·m².
    :param name: the parameter name used in error messages.
    :returns: a new array (not symmetrised; callers may use ``0.5 (I + I^T)``).
    :raises ModelError: naming ``name``, the failing condition and the numbers with units.
    """
    try:
        arr = np.array(inertia, dtype=np.float64)
    except (TypeError, ValueError):
        raise field_error(ModelError, name,
                          f'{inertia!r} is not a numeric 3x3 inertia tensor in kg·m²', inertia,
                          'kg·m²') from None
    if arr.shape != (3, 3):
        raise field_error(ModelError, name,
                          f'shape {arr.shape} must be (3, 3) (inertia tensor in kg·m²)', inertia,
                          'kg·m²')
    if not np.all(np.isfinite(arr)):
        raise field_error(ModelError, name, f'{arr.tolist()} kg·m² must be finite', inertia,
                          'kg·m²')
    scale = np.abs(arr).max()
    asymmetry = np.abs(arr - arr.T).max()
    if asymmetry > SYMMETRY_RTOL * scale:
        raise field_error(ModelError, name,
                          f'{arr.tolist()} kg·m² is not symmetric: max |I - I^T| = '
                          f'{asymmetry:.6g} kg·m² > {SYMMETRY_RTOL:g} * {scale:.6g} kg·m²',
                          inertia, 'kg·m²')
    moments = np.linalg.eigvalsh(0.5 * (arr + arr.T))
    if moments[0] <= 0.0:
        raise field_error(ModelError, name,
                          f'not positive definite: principal moments {_fmt(moments)} kg·m² '
                          'must all be > 0', inertia, 'kg·m²')
    lhs = moments[0] + moments[1]
    if lhs < moments[2] * (1.0 - TRIANGLE_RTOL):
        raise field_error(ModelError, name,
                          f'principal moments {_fmt(moments)} kg·m² break the triangle '
                          f'inequality I1 + I2 >= I3 ({_fmt(lhs)} < {_fmt(moments[2])})',
                          inertia, 'kg·m²')
    return arr


def _validate_vector(value, name, unit, size=3):
    return finite_vector(value, name, unit, size, ModelError, frozen=False)


def _validate_length(value, name):
    """Return ``value`` (m) as a float after checking it is finite and > 0."""
    return positive(value, name, 'm', ModelError)


@dataclass(frozen=True, eq=False)
class MassProperties:
    """
    Mass, centre of mass and central inertia of a rigid body, in body coordinates.

    :param mass_kg: total mass in kg, finite and > 0.
    :param com_b: centre of mass in body coordinates, shape (3,), m.
    :param inertia_b: inertia tensor about the COM along the body axes, shape (3, 3), kg·m²;
        validated by :func:`validate_inertia` and stored as its symmetric part.

    The arrays are copies and read-only.  Two values are equal when all fields are equal.
    """

    mass_kg: float
    com_b: np.ndarray
    inertia_b: np.ndarray

    def __post_init__(self):
        mass = validate_mass(self.mass_kg, 'mass_kg')
        com = _validate_vector(self.com_b, 'com_b', 'm')
        inertia = validate_inertia(self.inertia_b, 'inertia_b')
        inertia = 0.5 * (inertia + inertia.T)
        com.flags.writeable = False
        inertia.flags.writeable = False
        object.__setattr__(self, 'mass_kg', mass)
        object.__setattr__(self, 'com_b', com)
        object.__setattr__(self, 'inertia_b', inertia)

    def __eq__(self, other):
        if not isinstance(other, MassProperties):
            return NotImplemented
        return (self.mass_kg == other.mass_kg and np.array_equal(self.com_b, other.com_b)
                and np.array_equal(self.inertia_b, other.inertia_b))

    __hash__ = None

    def inertia_about(self, point_b):
        """Return the inertia (kg·m², body axes) about ``point_b`` (m, body coordinates)."""
        point = _validate_vector(point_b, 'point_b', 'm')
        return parallel_axis(self.inertia_b, self.mass_kg, point - self.com_b)


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


def inertia_from_components(ixx, iyy, izz, ixy=0.0, ixz=0.0, iyz=0.0) -> np.ndarray:
    """
    Return the (3, 3) tensor from its six components in the ROS / URDF order and convention.

    ``ixy``, ``ixz``, ``iyz`` are the matrix entries ``I[0, 1]``, ``I[0, 2]``, ``I[1, 2]``
    (for point masses ``ixy = -sum m x y``), not the positive "products of inertia".  The result
    is not validated; use :func:`validate_inertia` or :class:`MassProperties`.
    """
    return np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]], dtype=np.float64)


def parallel_axis(inertia_com, mass_kg, offset_m) -> np.ndarray:
    """
    Return the inertia about a point displaced by ``offset_m`` from the COM.

    ``I_p = I_com + m (d^T d 1 - d d^T)`` with ``d = offset_m`` (m), same axes as
    ``inertia_com``.  Vectorised: ``offset_m`` may be ``(..., 3)``.
    """
    d = np.asarray(offset_m, dtype=np.float64)
    shift = (np.einsum('...i,...i->...', d, d)[..., None, None] * np.eye(3)
             - d[..., :, None] * d[..., None, :])
    return np.asarray(inertia_com, dtype=np.float64) + mass_kg * shift


def rotate_inertia(inertia, rot) -> np.ndarray:
    """
    Return ``R I R^T``: the tensor ``inertia`` given along frame b re-expressed along frame a.

    With ``rot = R_ab`` (``v_a = R_ab v_b``), ``I_a = R_ab I_b R_ab^T``; e.g. the world inertia
    ``I_w = rotate_inertia(inertia_b, R_wb)``.  Vectorised over leading axes.
    """
    rot = np.asarray(rot, dtype=np.float64)
    return rot @ np.asarray(inertia, dtype=np.float64) @ np.swapaxes(rot, -1, -2)


def principal_axes(inertia) -> Tuple[np.ndarray, np.ndarray]:
    """
    Return ``(moments, rot)`` with ``inertia == rot @ diag(moments) @ rot.T``.

    ``moments`` (kg·m², shape (3,)) are ascending; the columns of ``rot`` are the principal
    axes, and ``rot`` is a proper rotation (``det == +1``; the last column is negated if
    ``numpy.linalg.eigh`` returned a left-handed basis).  If ``inertia`` is ``I_b``, then
    ``rot = R_bp`` maps principal-frame to body coordinates.

    :raises ModelError: if ``inertia`` is not a finite symmetric (3, 3) tensor.
    """
    try:
        arr = np.array(inertia, dtype=np.float64)
    except (TypeError, ValueError):
        raise ModelError(f'inertia: {inertia!r} is not a numeric 3x3 tensor in kg·m²') from None
    if arr.shape != (3, 3) or not np.all(np.isfinite(arr)):
        raise ModelError(f'inertia: {arr.tolist()} kg·m² must be a finite (3, 3) tensor')
    if np.abs(arr - arr.T).max() > SYMMETRY_RTOL * np.abs(arr).max():
        raise ModelError(f'inertia: {arr.tolist()} kg·m² is not symmetric')
    moments, rot = np.linalg.eigh(0.5 * (arr + arr.T))
    if np.linalg.det(rot) < 0.0:
        rot[:, 2] = -rot[:, 2]
    return moments, rot


def point_masses(masses_kg, points_b) -> 'MassProperties':
    """
    Return the mass properties of point masses ``masses_kg`` (kg, (n,)) at ``points_b`` (m).

    ``M = sum m_i``, ``com = sum m_i p_i / M`` and, with ``r_i = p_i - com``,
    ``I = sum m_i (r_i^T r_i 1 - r_i r_i^T)`` (the lecture's definition).

    :raises ModelError: on negative or non-finite masses, a total mass <= 0, or points that do
        not span 3-D (the inertia would not be positive definite).
    """
    masses = np.asarray(masses_kg, dtype=np.float64).reshape(-1)
    points = np.asarray(points_b, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] != masses.size:
        raise ModelError(
            f'points_b: shape {points.shape} must be ({masses.size}, 3) to match masses_kg')
    if not (np.all(np.isfinite(masses)) and np.all(masses >= 0.0)):
        raise ModelError('masses_kg: every point mass must be finite and >= 0 kg')
    if not np.all(np.isfinite(points)):
        raise ModelError('points_b: every point must be finite (m)')
    total = validate_mass(float(masses.sum()), 'masses_kg (total)')
    com = masses @ points / total
    r = points - com
    inertia = (np.eye(3) * np.einsum('n,ni,ni->', masses, r, r)
               - np.einsum('n,ni,nj->ij', masses, r, r))
    return MassProperties(total, com, inertia)


def bounding_box(points_b, mass_kg) -> 'MassProperties':
    """
    Return the lecture's bounding-box approximation of a body sampled by ``points_b`` (m).

    The body is replaced by a uniform solid box: the axis-aligned (body-axes) bounding box of
    the points, of mass ``mass_kg``, with its COM at the box centre (see :func:`box`).

    :raises ModelError: if the points are flat along a body axis (the box has no volume).
    """
    points = np.asarray(points_b, dtype=np.float64)
    if points.ndim != 2 or points.shape[1] != 3 or points.shape[0] == 0:
        raise ModelError(f'points_b: shape {points.shape} must be (n, 3) with n >= 1')
    if not np.all(np.isfinite(points)):
        raise ModelError('points_b: every point must be finite (m)')
    low, high = points.min(axis=0), points.max(axis=0)
    size = high - low
    if np.any(size <= 0.0):
        raise ModelError(
            f'points_b: bounding box size {_fmt(size)} m must be > 0 along every axis')
    shape = box(mass_kg, size)
    return MassProperties(shape.mass_kg, 0.5 * (low + high), shape.inertia_b)


def point_sampling(inside, bounds_min, bounds_max, mass_kg, n, rng=None) -> 'MassProperties':
    """
    Return the lecture's point-sampling approximation of a uniform solid.

    ``n`` points are drawn uniformly in the box ``[bounds_min, bounds_max]`` (m, body
    coordinates); those with ``inside(points)`` true each carry ``mass_kg / k`` (``k`` kept
    points), and :func:`point_masses` gives the COM and inertia.  The error of the moments is
    statistical, ``O(1 / sqrt(k))``.

    :param inside: callable mapping points ``(k, 3)`` to a boolean array ``(k,)``.
    :param n: number of candidate samples.
    :param rng: a ``numpy.random.Generator`` or a seed; ``None`` means seed 0, so a model built
        from the same parameters is the same on every run.
    :raises ModelError: if fewer than 4 points fall inside.
    """
    low = _validate_vector(bounds_min, 'bounds_min', 'm')
    high = _validate_vector(bounds_max, 'bounds_max', 'm')
    if np.any(high <= low):
        raise ModelError(
            f'bounds_max: {_fmt(high)} m must exceed bounds_min {_fmt(low)} m on every axis')
    mass = validate_mass(mass_kg)
    if isinstance(n, bool) or not isinstance(n, (numbers.Integral, np.integer)) or n < 4:
        raise ModelError(f'n: {n!r} samples must be an integer >= 4')
    generator = np.random.default_rng(0 if rng is None else rng)
    points = generator.uniform(low, high, size=(int(n), 3))
    keep = np.asarray(inside(points), dtype=bool).reshape(-1)
    if keep.shape != (int(n),):
        raise ModelError(f'inside: returned shape {keep.shape}, expected ({int(n)},)')
    kept = points[keep]
    if kept.shape[0] < 4:
        raise ModelError(
            f'inside: only {kept.shape[0]} of n = {int(n)} samples fell inside the bounds '
            f'{_fmt(low)} .. {_fmt(high)} m; need at least 4')
    return point_masses(np.full(kept.shape[0], mass / kept.shape[0]), kept)


def _closed_edge_check(faces, n_vertices):
    """Raise ModelError unless every directed edge appears once and its reverse once."""
    edges = faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2).astype(np.int64)
    keys = edges[:, 0] * n_vertices + edges[:, 1]
    reverse = edges[:, 1] * n_vertices + edges[:, 0]
    unique, counts = np.unique(keys, return_counts=True)
    if np.any(counts > 1):
        a, b = divmod(int(unique[np.argmax(counts > 1)]), n_vertices)
        raise ModelError(
            f'faces: directed edge ({a}, {b}) is used by {int(counts.max())} faces; a closed, '
            'consistently oriented mesh uses each directed edge once')
    missing = ~np.isin(reverse, keys)
    if np.any(missing):
        a, b = (int(v) for v in edges[np.argmax(missing)])
        raise ModelError(
            f'faces: edge ({a}, {b}) has no opposite edge ({b}, {a}); the mesh is open or '
            'inconsistently oriented')


def _subexpressions(w0, w1, w2):
    """Eberly's per-triangle polynomial subexpressions in one coordinate (vectorised)."""
    temp0 = w0 + w1
    f1 = temp0 + w2
    temp1 = w0 * w0
    temp2 = temp1 + w1 * temp0
    f2 = temp2 + w2 * f1
    f3 = w0 * temp1 + w1 * temp2 + w2 * f2
    g0 = f2 + w0 * (f1 + w0)
    g1 = f2 + w1 * (f1 + w1)
    g2 = f2 + w2 * (f1 + w2)
    return f1, f2, f3, g0, g1, g2


def triangle_mesh(vertices, faces, mass_kg=None, density=None) -> 'MassProperties':
    """
    Return the exact mass properties of a closed triangle mesh of uniform density.

    The volume integrals of 1, x, y, z, x^2, y^2, z^2, xy, yz, zx are turned into surface
    integrals by the divergence theorem and evaluated exactly per triangle, following
    D. Eberly, "Polyhedral Mass Properties (Revisited)", Geometric Tools (2002), itself a
    simplification of B. Mirtich, "Fast and Accurate Computation of Polyhedral Mass
    Properties", J. Graphics Tools 1(2):31-50 (1996).  The sums are vectorised over faces.
    The vertices are first shifted by their mean, which keeps the COM parallel-axis
    subtraction well conditioned for meshes far from the origin.

    :param vertices: (n, 3) m, body coordinates.
    :param faces: (m, 3) vertex indices, counter-clockwise seen from outside (outward normals
        by the right-hand rule).
    :param mass_kg: total mass in kg; give exactly one of ``mass_kg`` and ``density``.
    :param density: kg/m³.
    :raises ModelError: if both or neither of mass and density are given, on bad arrays or
        indices, if an edge lacks its opposite (open or inconsistently oriented mesh), or if
        the enclosed volume is not > 0 (inverted mesh).
    """
    if (mass_kg is None) == (density is None):
        raise ModelError(
            f'mass_kg: give exactly one of mass_kg (kg) and density (kg/m³); got '
            f'mass_kg={mass_kg!r}, density={density!r}')
    verts = np.asarray(vertices, dtype=np.float64)
    if verts.ndim != 2 or verts.shape[1] != 3 or not np.all(np.isfinite(verts)):
        raise ModelError(f'vertices: shape {verts.shape} must be (n, 3) of finite m')
    tris = np.asarray(faces)
    if (tris.ndim != 2 or tris.shape[1] != 3 or tris.shape[0] < 4
            or not np.issubdtype(tris.dtype, np.integer)):
        raise ModelError(
            f'faces: shape {tris.shape}, dtype {tris.dtype} must be (m >= 4, 3) integers')
    if tris.min() < 0 or tris.max() >= verts.shape[0]:
        raise ModelError(
            f'faces: indices must be in [0, {verts.shape[0] - 1}], got [{tris.min()}, '
            f'{tris.max()}]')
    _closed_edge_check(tris, verts.shape[0])
    origin = verts.mean(axis=0)
    p = verts - origin
    p0, p1, p2 = p[tris[:, 0]], p[tris[:, 1]], p[tris[:, 2]]
    d = np.cross(p1 - p0, p2 - p0)       # twice the area times the outward unit normal
    fx, fy, fz = (_subexpressions(p0[:, k], p1[:, k], p2[:, k]) for k in range(3))
    x0, y0, z0 = p0.T
    x1, y1, z1 = p1.T
    x2, y2, z2 = p2.T
    integral = np.array([
        np.sum(d[:, 0] * fx[0]),
        np.sum(d[:, 0] * fx[1]), np.sum(d[:, 1] * fy[1]), np.sum(d[:, 2] * fz[1]),
        np.sum(d[:, 0] * fx[2]), np.sum(d[:, 1] * fy[2]), np.sum(d[:, 2] * fz[2]),
        np.sum(d[:, 0] * (y0 * fx[3] + y1 * fx[4] + y2 * fx[5])),
        np.sum(d[:, 1] * (z0 * fy[3] + z1 * fy[4] + z2 * fy[5])),
        np.sum(d[:, 2] * (x0 * fz[3] + x1 * fz[4] + x2 * fz[5])),
    ]) * np.array([1 / 6, 1 / 24, 1 / 24, 1 / 24, 1 / 60, 1 / 60, 1 / 60,
                   1 / 120, 1 / 120, 1 / 120])
    volume = integral[0]
    scale = np.abs(p).max() ** 3
    if not volume > 1e-12 * scale:
        raise ModelError(
            f'faces: the mesh encloses volume {volume:.6g} m³; it must be > 0 (faces must be '
            'counter-clockwise seen from outside, i.e. normals pointing out)')
    com = integral[1:4] / volume
    # Second moments about the COM, per unit density: int x^2 dV - V cx^2, etc.
    xx = integral[4] - volume * com[0] ** 2
    yy = integral[5] - volume * com[1] ** 2
    zz = integral[6] - volume * com[2] ** 2
    xy = integral[7] - volume * com[0] * com[1]
    yz = integral[8] - volume * com[1] * com[2]
    zx = integral[9] - volume * com[2] * com[0]
    inertia_unit = np.array([[yy + zz, -xy, -zx], [-xy, xx + zz, -yz], [-zx, -yz, xx + yy]])
    if mass_kg is not None:
        mass = validate_mass(mass_kg)
        rho = mass / volume
    else:
        rho = positive(density, 'density', 'kg/m³', ModelError)
        mass = rho * volume
    return MassProperties(mass, com + origin, rho * inertia_unit)
