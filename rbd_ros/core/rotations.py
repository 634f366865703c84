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
Rotations: skew matrices, quaternions, rotation matrices, axis-angle and rotation vectors.

Conventions (the same everywhere in rbd_ros):

* A quaternion is an array ``(..., 4)`` ordered ``(w, x, y, z)``; ``w`` is the scalar part.
  Only the message conversions know the ``(x, y, z, w)`` order of ``geometry_msgs``.
* ``q_wb`` is the orientation of the body frame in the world frame.  Its rotation matrix
  ``R_wb = quat_to_matrix(q_wb)`` satisfies ``v_w = R_wb @ v_b`` and
  ``quat_rotate(q_wb, v_b) == R_wb @ v_b``.
* ``quat_multiply(q1, q2)`` is the Hamilton product ``q1 * q2``; it is the rotation "first
  ``q2``, then ``q1``", exactly like ``R1 @ R2``:
  ``quat_to_matrix(quat_multiply(q1, q2)) == quat_to_matrix(q1) @ quat_to_matrix(q2)``.
  Hence ``q_wc = quat_multiply(q_wb, q_bc)``.
* A rotation vector ``rotvec`` (rad) is ``angle * axis`` with a unit ``axis``; the rotation is
  right-handed about ``axis``.  ``quat_exp(rotvec) = exp((0, rotvec / 2))`` and
  ``matrix_exp(rotvec) = expm([rotvec])``.

Every function is vectorised over leading axes, works in float64 and is exact at the angles 0
and pi and accurate (to a few ulp) for angles near them.
"""

import numpy as np

from rbd_ros.core.errors import InputError
from rbd_ros.core.kernels import SINC_SERIES_BELOW

__all__ = [
    'axis_angle_to_matrix',
    'gram_schmidt',
    'matrix_exp',
    'matrix_log',
    'matrix_to_quat',
    'quat_angle_between',
    'quat_canonical',
    'quat_conjugate',
    'quat_exp',
    'quat_from_axis_angle',
    'quat_identity',
    'quat_inverse',
    'quat_log',
    'quat_multiply',
    'quat_normalize',
    'quat_rotate',
    'quat_to_matrix',
    'skew',
]

# Below this |x| the function sin(x) / x is evaluated by its Taylor series
# 1 - x**2 / 6 + x**4 / 120.  The first omitted term is x**6 / 5040, which at x = 1e-4 is
# 2e-28, far below the float64 unit round-off 1.1e-16, so the series is exact to round-off.
# Above the threshold np.sin(x) / x is accurate to about one ulp (x is exact and np.sin is
# faithfully rounded), so the switch-over costs no accuracy; the series is needed only to avoid
# 0 / 0 at x = 0 (and loss of the tiny quotient for subnormal x).  The compiled kernel's
# exponential map switches at the same half-angle: one constant for both.
_SINC_SERIES_BELOW = SINC_SERIES_BELOW


def _as_array(value, last, name):
    """Return ``value`` as a float64 array whose last axis has length ``last``."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InputError(f'{name}: {value!r} is not a numeric array ({exc})') from None
    if arr.ndim == 0 or arr.shape[-1] != last:
        raise InputError(f'{name}: shape {arr.shape} must end in {last}')
    return arr


def _first_bad(mask, arr):
    """Describe the first element of ``arr`` (leading axes) where ``mask`` is true."""
    index = tuple(int(i) for i in np.argwhere(mask)[0])
    where = f' at index {index}' if index else ''
    return where, arr[index]


def _check_finite(arr, name, unit=''):
    """Raise :class:`InputError` if any entry of ``arr`` is not finite."""
    bad = ~np.all(np.isfinite(arr), axis=-1)
    if np.any(bad):
        where, value = _first_bad(bad, arr)
        raise InputError(f'{name}{where}: {value.tolist()}{unit} must be finite')


def _sinc(x):
    """Return ``sin(x) / x`` (1 at 0), to round-off for every float64 ``x``."""
    x = np.asarray(x, dtype=np.float64)
    small = np.abs(x) < _SINC_SERIES_BELOW
    x2 = x * x
    series = 1.0 - x2 / 6.0 + x2 * x2 / 120.0
    safe_x = np.where(small, 1.0, x)
    return np.where(small, series, np.sin(safe_x) / safe_x)


def skew(a) -> np.ndarray:
    """
    Return the skew-symmetric cross-product matrix ``[a]``.

    ``skew(a) @ b == np.cross(a, b)`` for every ``b``; ``skew(a).T == -skew(a)``.

    :param a: vector(s), shape ``(..., 3)``.
    :returns: shape ``(..., 3, 3)``.
    """
    a = _as_array(a, 3, 'a')
    x, y, z = a[..., 0], a[..., 1], a[..., 2]
    zero = np.zeros_like(x)
    return np.stack(
        [
            np.stack([zero, -z, y], axis=-1),
            np.stack([z, zero, -x], axis=-1),
            np.stack([-y, x, zero], axis=-1),
        ],
        axis=-2,
    )


def quat_identity(shape=()) -> np.ndarray:
    """Return identity quaternion(s) ``(1, 0, 0, 0)`` of shape ``shape + (4,)``."""
    q = np.zeros(tuple(shape) + (4,))
    q[..., 0] = 1.0
    return q


def quat_multiply(q1, q2) -> np.ndarray:
    """
    Return the Hamilton product ``q1 * q2``: the rotation "first ``q2``, then ``q1``".

    ``q1 * q2 = (w1 w2 - v1 . v2,  w1 v2 + w2 v1 + v1 x v2)``, so that
    ``quat_to_matrix(q1 * q2) == quat_to_matrix(q1) @ quat_to_matrix(q2)``
    and ``q_wc = quat_multiply(q_wb, q_bc)``.

    :param q1: quaternion(s) ``(w, x, y, z)``, shape ``(..., 4)``.
    :param q2: quaternion(s) ``(w, x, y, z)``, shape ``(..., 4)``; broadcasts with ``q1``.
    :returns: shape ``(..., 4)``; unit if both inputs are unit.
    """
    q1 = _as_array(q1, 4, 'q1')
    q2 = _as_array(q2, 4, 'q2')
    w1, v1 = q1[..., :1], q1[..., 1:]
    w2, v2 = q2[..., :1], q2[..., 1:]
    w = w1 * w2 - np.sum(v1 * v2, axis=-1, keepdims=True)
    v = w1 * v2 + w2 * v1 + np.cross(v1, v2)
    return np.concatenate([w, v], axis=-1)


def quat_conjugate(q) -> np.ndarray:
    """
    Return the conjugate ``(w, -x, -y, -z)``.

    For a unit quaternion this is the inverse rotation: ``q_bw = quat_conjugate(q_wb)``.
    """
    q = _as_array(q, 4, 'q')
    return q * np.array([1.0, -1.0, -1.0, -1.0])


def _norm_checked(q, name):
    """Return ``|q|`` with a trailing axis, raising :class:`InputError` on zero or non-finite."""
    norm = np.linalg.norm(q, axis=-1, keepdims=True)
    bad = ~(np.isfinite(norm[..., 0]) & (norm[..., 0] > 0.0))
    if np.any(bad):
        where, value = _first_bad(bad, q)
        raise InputError(
            f'{name}{where}: quaternion (w, x, y, z) = {value.tolist()} has norm '
            f'{float(np.linalg.norm(value))!r}; it must be finite and non-zero')
    return norm


def quat_inverse(q) -> np.ndarray:
    """
    Return ``q^-1 = conj(q) / |q|^2``, so that ``q * q^-1 == (1, 0, 0, 0)``.

    :raises InputError: if ``|q|`` is zero or not finite.
    """
    q = _as_array(q, 4, 'q')
    norm = _norm_checked(q, 'q')
    return quat_conjugate(q) / (norm * norm)


def quat_normalize(q, name: str = 'q') -> np.ndarray:
    """
    Return ``q / |q|``.

    :param q: quaternion(s) ``(w, x, y, z)``, shape ``(..., 4)``.
    :param name: the parameter name used in error messages.
    :raises InputError: if ``|q|`` is zero or not finite; the message names ``name`` and the
        value.
    """
    q = _as_array(q, 4, name)
    return q / _norm_checked(q, name)


def quat_canonical(q, name: str = 'q') -> np.ndarray:
    """
    Return ``q / |q|`` with a canonical sign (``q`` and ``-q`` are the same rotation).

    The sign makes ``w > 0``; if ``w == 0`` exactly, the first non-zero of ``x, y, z`` is made
    positive.  Two quaternions of the same rotation therefore have the same canonical form
    (up to round-off when ``w`` is within round-off of 0).

    :raises InputError: if ``|q|`` is zero or not finite.
    """
    q = quat_normalize(q, name)
    first = np.argmax(q != 0.0, axis=-1)[..., None]
    sign = np.where(np.take_along_axis(q, first, axis=-1) < 0.0, -1.0, 1.0)
    return q * sign


def quat_rotate(q, v) -> np.ndarray:
    """
    Rotate vector(s) ``v`` by quaternion(s) ``q``, equal to ``quat_to_matrix(q) @ v``.

    Computed directly as ``q * (0, v) * q^-1``, i.e. with ``u = (x, y, z)``,
    ``t = 2 u x v / |q|^2`` and ``v' = v + w t + u x t``.  With ``q = q_wb`` this maps body
    coordinates to world coordinates: ``v_w = quat_rotate(q_wb, v_b)``.  ``q`` need not be
    unit; the rotation of ``q / |q|`` is applied.

    :param q: quaternion(s) ``(w, x, y, z)``, shape ``(..., 4)``.
    :param v: vector(s), shape ``(..., 3)``; broadcasts with ``q``.
    :raises InputError: if ``|q|`` is zero or not finite.
    """
    q = _as_array(q, 4, 'q')
    v = _as_array(v, 3, 'v')
    norm = _norm_checked(q, 'q')
    w, u = q[..., :1], q[..., 1:]
    t = (2.0 / (norm * norm)) * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def quat_to_matrix(q) -> np.ndarray:
    """
    Return the rotation matrix ``R`` of quaternion(s) ``q``.

    For ``q = q_wb``, ``R = R_wb`` satisfies ``v_w = R @ v_b``.  ``q`` need not be unit; the
    matrix of ``q / |q|`` is returned (``s = 2 / |q|^2`` in the usual formula), so it is
    orthogonal to round-off with determinant +1.

    :param q: quaternion(s) ``(w, x, y, z)``, shape ``(..., 4)``.
    :returns: shape ``(..., 3, 3)``.
    :raises InputError: if ``|q|`` is zero or not finite.
    """
    q = _as_array(q, 4, 'q')
    norm = _norm_checked(q, 'q')[..., 0]
    s = 2.0 / (norm * norm)
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    xx, yy, zz = s * x * x, s * y * y, s * z * z
    xy, xz, yz = s * x * y, s * x * z, s * y * z
    wx, wy, wz = s * w * x, s * w * y, s * w * z
    return np.stack(
        [
            np.stack([1.0 - (yy + zz), xy - wz, xz + wy], axis=-1),
            np.stack([xy + wz, 1.0 - (xx + zz), yz - wx], axis=-1),
            np.stack([xz - wy, yz + wx, 1.0 - (xx + yy)], axis=-1),
        ],
        axis=-2,
    )


def matrix_to_quat(rot, reference=None) -> np.ndarray:
    """
    Return the unit quaternion ``q`` with ``quat_to_matrix(q) == rot``.

    Shepperd's method (S. W. Shepperd, "Quaternion from rotation matrix", J. Guidance and
    Control 1(3), 1978): of the four equivalent formulas, the one that divides by the largest of
    ``|w|, |x|, |y|, |z|`` is used, so the result is accurate for every angle including 180
    degrees.  Each candidate is ``4 q_k q`` and is normalised, which also gives a sensible
    answer for a slightly non-orthogonal ``rot`` (use :func:`gram_schmidt` for a drifted one).
    The sign is canonical (see :func:`quat_canonical`), or, with ``reference``, the one nearest
    to it (``q · reference >= 0``): the kernel's rule for a trajectory, which keeps ``q``
    continuous from step to step.

    :param rot: rotation matrix(es), shape ``(..., 3, 3)``, with ``v_w = rot @ v_b``.
    :param reference: optional quaternion(s) ``(..., 4)`` whose hemisphere ``q`` is put in.
    :returns: shape ``(..., 4)``, ``(w, x, y, z)``.
    :raises InputError: if ``rot`` is not ``(..., 3, 3)`` or not finite.
    """
    rot = np.asarray(rot, dtype=np.float64)
    if rot.ndim < 2 or rot.shape[-2:] != (3, 3):
        raise InputError(f'rot: shape {rot.shape} must end in (3, 3)')
    if not np.all(np.isfinite(rot)):
        raise InputError(f'rot: {rot.tolist()} must be finite')
    m00, m01, m02 = rot[..., 0, 0], rot[..., 0, 1], rot[..., 0, 2]
    m10, m11, m12 = rot[..., 1, 0], rot[..., 1, 1], rot[..., 1, 2]
    m20, m21, m22 = rot[..., 2, 0], rot[..., 2, 1], rot[..., 2, 2]
    trace = m00 + m11 + m22
    # Row k of `candidates` is 4 q_k (w, x, y, z) computed from the formula that divides by
    # q_k; 4 q_k^2 is on the diagonal, so the largest diagonal picks the best-conditioned one.
    candidates = np.stack(
        [
            np.stack([1.0 + trace, m21 - m12, m02 - m20, m10 - m01], axis=-1),
            np.stack([m21 - m12, 1.0 + m00 - m11 - m22, m01 + m10, m02 + m20], axis=-1),
            np.stack([m02 - m20, m01 + m10, 1.0 - m00 + m11 - m22, m12 + m21], axis=-1),
            np.stack([m10 - m01, m02 + m20, m12 + m21, 1.0 - m00 - m11 + m22], axis=-1),
        ],
        axis=-2,
    )
    diagonal = np.stack([1.0 + trace, 1.0 + m00 - m11 - m22, 1.0 - m00 + m11 - m22,
                         1.0 - m00 - m11 + m22], axis=-1)
    best = np.argmax(diagonal, axis=-1)[..., None, None]
    q = np.take_along_axis(candidates, best, axis=-2)[..., 0, :]
    if reference is None:
        return quat_canonical(q, 'rot')
    reference = _as_array(reference, 4, 'reference')
    q = quat_normalize(q, 'rot')
    return np.where(np.sum(q * reference, axis=-1, keepdims=True) < 0.0, -q, q)


def _axis_and_angle(axis, angle_rad):
    """Return ``(unit axis (..., 3), angle (..., 1))``; a zero axis is allowed for angle 0."""
    axis = _as_array(axis, 3, 'axis')
    angle = np.asarray(angle_rad, dtype=np.float64)[..., None]
    _check_finite(axis, 'axis')
    if not np.all(np.isfinite(angle)):
        raise InputError(f'angle_rad: {np.asarray(angle_rad).tolist()} rad must be finite')
    axis, angle = np.broadcast_arrays(axis, angle)
    angle = angle[..., :1]
    norm = np.linalg.norm(axis, axis=-1, keepdims=True)
    zero_axis = norm == 0.0
    bad = (zero_axis & (angle != 0.0))[..., 0]
    if np.any(bad):
        where, value = _first_bad(bad, angle[..., 0])
        raise InputError(
            f'axis{where}: [0.0, 0.0, 0.0] has no direction but angle_rad is {float(value)!r} '
            'rad; a zero axis is only allowed with a zero angle')
    unit = np.where(zero_axis, 0.0, axis / np.where(zero_axis, 1.0, norm))
    return unit, angle


def quat_from_axis_angle(axis, angle_rad) -> np.ndarray:
    """
    Return ``q = (cos(angle / 2), sin(angle / 2) axis / |axis|)``.

    The rotation is right-handed by ``angle_rad`` about ``axis``; ``axis`` need not be unit.
    A zero axis with a zero angle gives the identity.

    :param axis: shape ``(..., 3)``.
    :param angle_rad: shape ``(...)``; broadcasts with ``axis``.
    :raises InputError: on a zero axis with a non-zero angle, or non-finite input.
    """
    unit, angle = _axis_and_angle(axis, angle_rad)
    half = 0.5 * angle
    return np.concatenate([np.cos(half), np.sin(half) * unit], axis=-1)


def axis_angle_to_matrix(axis, angle_rad) -> np.ndarray:
    """
    Return ``Rot(angle, axis)`` by Rodrigues' formula ``I + sin(t) [k] + (1 - cos(t)) [k]^2``.

    ``k = axis / |axis|`` and ``t = angle_rad``; the rotation is right-handed about ``k``.
    A zero axis with a zero angle gives the identity.

    :param axis: shape ``(..., 3)``.
    :param angle_rad: shape ``(...)``; broadcasts with ``axis``.
    :returns: shape ``(..., 3, 3)``.
    :raises InputError: on a zero axis with a non-zero angle, or non-finite input.
    """
    unit, angle = _axis_and_angle(axis, angle_rad)
    k = skew(unit)
    angle = angle[..., None]
    return np.eye(3) + np.sin(angle) * k + (1.0 - np.cos(angle)) * (k @ k)


def quat_exp(rotvec) -> np.ndarray:
    """
    Return the unit quaternion of the rotation by ``|rotvec|`` rad about ``rotvec / |rotvec|``.

    ``quat_exp(r) = exp((0, r / 2)) = (cos(t / 2), sinc(t / 2) r / 2)`` with ``t = |r|`` and
    ``sinc(x) = sin(x) / x``.  ``sinc`` uses its Taylor series for ``x < 1e-4``, the kernel's
    ``SINC_SERIES_BELOW`` (truncation error ``x**6 / 5040 < 2e-28``), so the result is
    accurate to round-off for every angle, including exactly 0 (identity).  Angles above pi
    give ``w < 0``; the rotation is still right.

    :param rotvec: rotation vector(s) in rad, shape ``(..., 3)``.
    :returns: shape ``(..., 4)``.
    """
    rotvec = _as_array(rotvec, 3, 'rotvec')
    _check_finite(rotvec, 'rotvec', ' rad')
    half = 0.5 * np.linalg.norm(rotvec, axis=-1, keepdims=True)
    return np.concatenate([np.cos(half), 0.5 * _sinc(half) * rotvec], axis=-1)


def quat_log(q) -> np.ndarray:
    """
    Return the rotation vector ``r`` with ``quat_exp(r) == +-q / |q|`` and ``|r|`` in ``[0, pi]``.

    With the sign chosen so that ``w >= 0``, the angle is ``t = 2 atan2(|v|, w)``, accurate near
    both 0 and pi, and ``r = t v / |v| = 2 v / sinc(t / 2)`` (as ``|v| = sin(t / 2)``), which has
    no 0 / 0 at ``t = 0``.  At exactly pi both ``r`` and ``-r`` are valid; the canonical sign of
    :func:`quat_canonical` picks one.

    :param q: quaternion(s) ``(w, x, y, z)``, shape ``(..., 4)``; need not be unit.
    :returns: shape ``(..., 3)``, rad.
    :raises InputError: if ``|q|`` is zero or not finite.
    """
    q = quat_canonical(q)
    w, v = q[..., :1], q[..., 1:]
    angle = 2.0 * np.arctan2(np.linalg.norm(v, axis=-1, keepdims=True), w)
    return 2.0 * v / _sinc(0.5 * angle)


def matrix_exp(rotvec) -> np.ndarray:
    """
    Return ``expm([rotvec]) = Rot(|rotvec|, rotvec / |rotvec|)``, exact at 0.

    :param rotvec: rad, shape ``(..., 3)``.
    :returns: shape ``(..., 3, 3)``.
    """
    return quat_to_matrix(quat_exp(rotvec))


def matrix_log(rot) -> np.ndarray:
    """
    Return the rotation vector ``r`` (angle in ``[0, pi]``) with ``matrix_exp(r) == rot``.

    Computed as ``quat_log(matrix_to_quat(rot))``, which is accurate near 0 and pi (unlike
    ``acos((trace - 1) / 2)``).

    :param rot: shape ``(..., 3, 3)``.
    :returns: shape ``(..., 3)``, rad.
    """
    return quat_log(matrix_to_quat(rot))


def gram_schmidt(rot) -> np.ndarray:
    """
    Return the right-handed orthonormal matrix nearest in the Gram-Schmidt sense to ``rot``.

    Column 0 is normalised; column 1 is made orthogonal to it and normalised; column 2 is
    ``c0 x c1``, so the result satisfies ``R.T @ R == I`` and ``det(R) == +1`` to round-off.
    An exact rotation is returned unchanged to round-off.  Used to repair a rotation matrix
    that drifted during integration.

    :param rot: shape ``(..., 3, 3)``.
    :raises InputError: if the first two columns are not finite or are (nearly) parallel.
    """
    rot = np.asarray(rot, dtype=np.float64)
    if rot.ndim < 2 or rot.shape[-2:] != (3, 3):
        raise InputError(f'rot: shape {rot.shape} must end in (3, 3)')
    c0 = rot[..., :, 0]
    c1 = rot[..., :, 1]
    n0 = np.linalg.norm(c0, axis=-1, keepdims=True)
    c1 = c1 - np.sum(c0 * c1, axis=-1, keepdims=True) / (n0 * n0) * c0
    n1 = np.linalg.norm(c1, axis=-1, keepdims=True)
    scale = np.maximum(n0, np.linalg.norm(rot[..., :, 1], axis=-1, keepdims=True))
    bad = ~(np.isfinite(n0) & np.isfinite(n1) & (n0 > 0.0) & (n1 > 1e-12 * scale))[..., 0]
    if np.any(bad):
        where, value = _first_bad(bad, rot)
        raise InputError(
            f'rot{where}: {value.tolist()} has zero, non-finite or parallel first two columns; '
            'it cannot be orthonormalised')
    c0 = c0 / n0
    c1 = c1 / n1
    c2 = np.cross(c0, c1)
    return np.stack([c0, c1, c2], axis=-1)


def quat_angle_between(q1, q2) -> np.ndarray:
    """
    Return the geodesic angle in rad, in ``[0, pi]``, of the rotation taking ``q1`` to ``q2``.

    ``angle = 2 atan2(|v|, |w|)`` of ``d = conj(q1) * q2`` (both normalised first), which is
    invariant to the sign of either quaternion and accurate near 0 and pi.

    :param q1: shape ``(..., 4)``.
    :param q2: shape ``(..., 4)``; broadcasts with ``q1``.
    :returns: shape ``(...)``.
    """
    d = quat_multiply(quat_conjugate(quat_normalize(q1, 'q1')), quat_normalize(q2, 'q2'))
    return 2.0 * np.arctan2(np.linalg.norm(d[..., 1:], axis=-1), np.abs(d[..., 0]))
