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
The inertia tensor: :class:`MassProperties`, the checks of a mass and a tensor, its operations.

:func:`validate_mass` and :func:`validate_inertia` (symmetric, positive definite, the triangle
inequality, with the tolerances they allow), :class:`MassProperties` (mass, COM, central
inertia, validated and frozen), and the tensor's operations: :func:`inertia_from_components`
(ROS / URDF order), :func:`parallel_axis`, :func:`rotate_inertia`, :func:`principal_axes`.
Conventions and units: :mod:`rbd_ros.core.inertia`.
"""

from dataclasses import dataclass
from typing import Tuple

import numpy as np

from rbd_ros.core.errors import field_error, finite_vector, ModelError, positive

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
