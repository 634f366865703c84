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
Tests of :mod:`rbd_ros.core.rotations`: analytic references, round trips, random invariants.

Tolerances.  Every function here is a handful (< 30) of float64 operations on numbers of
magnitude <= 4, each rounded to within half an ulp (1.1e-16), so results of unit magnitude are
good to a few times 1e-16.  ``ROUND_OFF = 1e-14`` (about 45 ulp) is that bound with a safety
margin; a wrong sign, order or factor shows up at 1e-3 or more.
"""

import numpy as np
import pytest

from rbd_ros.core import kernels, rotations
from rbd_ros.core.errors import InputError
from rbd_ros.core.rotations import (
    axis_angle_to_matrix,
    gram_schmidt,
    matrix_exp,
    matrix_log,
    matrix_to_quat,
    quat_angle_between,
    quat_canonical,
    quat_conjugate,
    quat_exp,
    quat_from_axis_angle,
    quat_identity,
    quat_inverse,
    quat_log,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_to_matrix,
    skew,
)

ROUND_OFF = 1e-14
SEED = 20260122
N_RANDOM = 2000


@pytest.fixture
def rng():
    return np.random.default_rng(SEED)


def random_quats(rng, n=N_RANDOM):
    q = rng.normal(size=(n, 4))
    return q / np.linalg.norm(q, axis=-1, keepdims=True)


def random_rotvecs(rng, n=N_RANDOM, max_angle=np.pi):
    axis = rng.normal(size=(n, 3))
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    return axis * rng.uniform(0.0, max_angle, size=(n, 1))


# --- analytic references -------------------------------------------------------------------


def test_skew_is_cross_product(rng):
    a = rng.normal(size=(50, 3))
    b = rng.normal(size=(50, 3))
    np.testing.assert_allclose(
        np.einsum('nij,nj->ni', skew(a), b), np.cross(a, b), rtol=0, atol=ROUND_OFF)
    np.testing.assert_array_equal(skew(a), -np.swapaxes(skew(a), -1, -2))
    np.testing.assert_array_equal(skew([1.0, 2.0, 3.0]),
                                  [[0, -3, 2], [3, 0, -1], [-2, 1, 0]])


def test_quarter_turn_about_z_maps_basis_vectors():
    q = quat_from_axis_angle([0.0, 0.0, 1.0], np.pi / 2)
    rot = quat_to_matrix(q)
    ex, ey, ez = np.eye(3)
    for apply in (lambda v: rot @ v, lambda v: quat_rotate(q, v),
                  lambda v: axis_angle_to_matrix([0, 0, 2.0], np.pi / 2) @ v,
                  lambda v: matrix_exp([0, 0, np.pi / 2]) @ v):
        np.testing.assert_allclose(apply(ex), ey, atol=ROUND_OFF)
        np.testing.assert_allclose(apply(ey), -ex, atol=ROUND_OFF)
        np.testing.assert_allclose(apply(ez), ez, atol=ROUND_OFF)
    np.testing.assert_allclose(q, [np.sqrt(0.5), 0, 0, np.sqrt(0.5)], atol=ROUND_OFF)


def test_composition_is_first_q2_then_q1():
    qz = quat_from_axis_angle([0, 0, 1], np.pi / 2)
    qx = quat_from_axis_angle([1, 0, 0], np.pi / 2)
    # First about x (y -> z), then about z (z stays): y -> z.
    q = quat_multiply(qz, qx)
    np.testing.assert_allclose(quat_rotate(q, [0, 1, 0]), [0, 0, 1], atol=ROUND_OFF)
    # The other order: first about z (y -> -x), then about x (-x stays): y -> -x.
    q = quat_multiply(qx, qz)
    np.testing.assert_allclose(quat_rotate(q, [0, 1, 0]), [-1, 0, 0], atol=ROUND_OFF)


def test_exact_at_zero():
    np.testing.assert_array_equal(quat_exp(np.zeros(3)), [1, 0, 0, 0])
    np.testing.assert_array_equal(quat_log(quat_identity()), [0, 0, 0])
    np.testing.assert_array_equal(matrix_exp(np.zeros(3)), np.eye(3))
    np.testing.assert_array_equal(matrix_log(np.eye(3)), [0, 0, 0])
    np.testing.assert_array_equal(matrix_to_quat(np.eye(3)), [1, 0, 0, 0])
    np.testing.assert_array_equal(quat_from_axis_angle(np.zeros(3), 0.0), [1, 0, 0, 0])
    np.testing.assert_array_equal(axis_angle_to_matrix(np.zeros(3), 0.0), np.eye(3))
    assert quat_angle_between([1, 0, 0, 0], [-1, 0, 0, 0]) == 0.0


@pytest.mark.parametrize('axis', [(1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 0), (-1, 2, 3)])
def test_half_turn_matrix_to_quat(axis):
    axis = np.asarray(axis, dtype=float) / np.linalg.norm(axis)
    rot = 2.0 * np.outer(axis, axis) - np.eye(3)   # exact 180 degree rotation about axis
    q = matrix_to_quat(rot)
    assert abs(q[0]) < ROUND_OFF
    # Canonical sign: first non-zero of x, y, z positive (w is 0 to round-off).
    np.testing.assert_allclose(q[1:], axis * np.sign(axis[np.flatnonzero(axis)[0]]),
                               atol=ROUND_OFF)
    np.testing.assert_allclose(quat_to_matrix(q), rot, atol=ROUND_OFF)
    rotvec = matrix_log(rot)
    assert np.linalg.norm(rotvec) == pytest.approx(np.pi, abs=ROUND_OFF)
    np.testing.assert_allclose(matrix_exp(rotvec), rot, atol=ROUND_OFF)


@pytest.mark.parametrize('angle', [0.0, 1e-300, 1e-12, 1e-9, 1e-4, 1e-3, 1.0, np.pi / 2,
                                   np.pi - 1e-3, np.pi - 1e-9, np.pi])
def test_exp_log_round_trip_at_special_angles(angle, rng):
    axes = rng.normal(size=(20, 3))
    axes /= np.linalg.norm(axes, axis=-1, keepdims=True)
    rotvec = axes * angle
    q = quat_exp(rotvec)
    np.testing.assert_allclose(np.linalg.norm(q, axis=-1), 1.0, atol=ROUND_OFF)
    rot = quat_to_matrix(q)
    np.testing.assert_allclose(rot, axis_angle_to_matrix(axes, angle), atol=ROUND_OFF)
    if angle <= 1e-5:
        # Second-order Taylor expm: the omitted third-order term is at most |r|^3 / 6, which
        # is < 1.7e-16 for |r| <= 1e-5, below ROUND_OFF.
        k = skew(rotvec)
        np.testing.assert_allclose(rot, np.eye(3) + k + k @ k / 2, rtol=0, atol=ROUND_OFF)
    for back in (quat_log(q), matrix_log(rot), matrix_log(matrix_exp(rotvec))):
        if angle == np.pi:
            # At exactly pi, r and -r are the same rotation; log may return either.
            sign = np.sign(np.sum(back * rotvec, axis=-1, keepdims=True))
            back = back * sign
        # Relative to the angle near 0 (the small-angle paths keep full relative
        # precision), absolute near pi (the matrix entries carry ~1e-16 absolute error).
        np.testing.assert_allclose(back, rotvec, rtol=ROUND_OFF, atol=ROUND_OFF)
    np.testing.assert_allclose(quat_angle_between(quat_identity(), q), angle,
                               rtol=ROUND_OFF, atol=ROUND_OFF)


# --- seeded random invariants --------------------------------------------------------------


def test_random_rotate_equals_matrix_product(rng):
    q = random_quats(rng)
    v = rng.normal(size=(N_RANDOM, 3))
    rot = quat_to_matrix(q)
    np.testing.assert_allclose(quat_rotate(q, v), np.einsum('nij,nj->ni', rot, v),
                               atol=ROUND_OFF)
    np.testing.assert_allclose(np.linalg.norm(quat_rotate(q, v), axis=-1),
                               np.linalg.norm(v, axis=-1), atol=ROUND_OFF)
    # A non-unit quaternion rotates like its normalised self.
    np.testing.assert_allclose(quat_rotate(3.0 * q, v), quat_rotate(q, v), atol=ROUND_OFF)
    np.testing.assert_allclose(quat_to_matrix(0.5 * q), rot, atol=ROUND_OFF)


def test_random_matrices_are_rotations(rng):
    rot = quat_to_matrix(random_quats(rng))
    np.testing.assert_allclose(np.swapaxes(rot, -1, -2) @ rot, np.broadcast_to(np.eye(3),
                               rot.shape), atol=ROUND_OFF)
    np.testing.assert_allclose(np.linalg.det(rot), 1.0, atol=ROUND_OFF)


def test_random_composition_matches_matrix_product(rng):
    q1, q2 = random_quats(rng), random_quats(rng)
    np.testing.assert_allclose(quat_to_matrix(quat_multiply(q1, q2)),
                               quat_to_matrix(q1) @ quat_to_matrix(q2), atol=ROUND_OFF)


def test_random_matrix_quat_round_trip(rng):
    q = random_quats(rng)
    back = matrix_to_quat(quat_to_matrix(q))
    np.testing.assert_allclose(back, quat_canonical(q), atol=ROUND_OFF)
    assert np.all(back[:, 0] >= 0.0)


def test_random_exp_log_round_trip(rng):
    rotvec = random_rotvecs(rng)
    np.testing.assert_allclose(quat_log(quat_exp(rotvec)), rotvec, atol=ROUND_OFF)
    np.testing.assert_allclose(matrix_log(matrix_exp(rotvec)), rotvec, atol=ROUND_OFF)
    q = random_quats(rng)
    np.testing.assert_allclose(quat_exp(quat_log(q)), quat_canonical(q), atol=ROUND_OFF)
    assert np.all(np.linalg.norm(quat_log(q), axis=-1) <= np.pi)


def test_random_axis_angle_forms_agree(rng):
    axis = rng.normal(size=(N_RANDOM, 3)) * 5.0      # axis need not be unit
    angle = rng.uniform(-2 * np.pi, 2 * np.pi, size=N_RANDOM)
    np.testing.assert_allclose(quat_to_matrix(quat_from_axis_angle(axis, angle)),
                               axis_angle_to_matrix(axis, angle), atol=ROUND_OFF)
    unit = axis / np.linalg.norm(axis, axis=-1, keepdims=True)
    np.testing.assert_allclose(matrix_exp(unit * angle[:, None]),
                               axis_angle_to_matrix(axis, angle), atol=ROUND_OFF)


def test_random_inverse_and_conjugate(rng):
    q = rng.normal(size=(N_RANDOM, 4)) * 3.0
    np.testing.assert_allclose(quat_multiply(q, quat_inverse(q)),
                               np.broadcast_to([1.0, 0, 0, 0], q.shape), atol=ROUND_OFF)
    u = quat_normalize(q)
    np.testing.assert_allclose(quat_conjugate(u), quat_inverse(u), atol=ROUND_OFF)
    v = rng.normal(size=(N_RANDOM, 3))
    np.testing.assert_allclose(quat_rotate(quat_conjugate(u), quat_rotate(u, v)), v,
                               atol=ROUND_OFF)


def test_random_angle_between(rng):
    q = random_quats(rng)
    rotvec = random_rotvecs(rng)
    q2 = quat_multiply(q, quat_exp(rotvec))
    angle = np.linalg.norm(rotvec, axis=-1)
    np.testing.assert_allclose(quat_angle_between(q, q2), angle, atol=ROUND_OFF)
    np.testing.assert_allclose(quat_angle_between(-q, q2), angle, atol=ROUND_OFF)
    np.testing.assert_allclose(quat_angle_between(q2, q), angle, atol=ROUND_OFF)


def test_canonical_sign():
    np.testing.assert_array_equal(quat_canonical([-2.0, 0, 0, 0]), [1, 0, 0, 0])
    np.testing.assert_array_equal(quat_canonical([0.0, -1, 0, 0]), [0, 1, 0, 0])
    np.testing.assert_array_equal(quat_canonical([0.0, 0, -1, 0]), [0, 0, 1, 0])
    np.testing.assert_array_equal(quat_canonical([0.0, 0, 0, -3]), [0, 0, 0, 1])
    np.testing.assert_array_equal(quat_canonical([[0.0, 0, 3, -4]]), [[0, 0, 0.6, -0.8]])
    np.testing.assert_array_equal(quat_canonical([-0.6, 0, 0, 0.8]), [0.6, 0, 0, -0.8])


def test_vectorised_over_leading_axes(rng):
    q = random_quats(rng, 24).reshape(2, 3, 4, 4)
    v = rng.normal(size=(2, 3, 4, 3))
    assert quat_to_matrix(q).shape == (2, 3, 4, 3, 3)
    assert matrix_to_quat(quat_to_matrix(q)).shape == (2, 3, 4, 4)
    assert quat_rotate(q, v).shape == (2, 3, 4, 3)
    assert quat_log(q).shape == (2, 3, 4, 3)
    assert quat_angle_between(q, q).shape == (2, 3, 4)
    # Broadcasting one quaternion against many vectors.
    np.testing.assert_allclose(quat_rotate(q[0, 0, 0], v),
                               np.einsum('ij,...j->...i', quat_to_matrix(q[0, 0, 0]), v),
                               atol=ROUND_OFF)


# --- Gram-Schmidt --------------------------------------------------------------------------


def test_gram_schmidt_identity_on_exact_rotation(rng):
    rot = quat_to_matrix(random_quats(rng))
    np.testing.assert_allclose(gram_schmidt(rot), rot, atol=ROUND_OFF)


def test_gram_schmidt_repairs_drift(rng):
    # The lecture's option 1, R <- (I + h [w]) R, drifts from SO(3) by O(h^2) per step.
    rot = np.eye(3)
    omega = np.array([0.3, -1.2, 2.0])
    for _ in range(1000):
        rot = (np.eye(3) + 0.01 * skew(omega)) @ rot
    assert np.abs(rot.T @ rot - np.eye(3)).max() > 1e-2    # really drifted
    fixed = gram_schmidt(rot)
    np.testing.assert_allclose(fixed.T @ fixed, np.eye(3), atol=ROUND_OFF)
    assert np.linalg.det(fixed) == pytest.approx(1.0, abs=ROUND_OFF)
    # Column 0 keeps its direction; column 1 stays in the span of the original c0, c1.
    np.testing.assert_allclose(fixed[:, 0], rot[:, 0] / np.linalg.norm(rot[:, 0]),
                               atol=ROUND_OFF)
    assert abs(np.dot(np.cross(rot[:, 0], rot[:, 1]), fixed[:, 1])) < ROUND_OFF * 10
    # Random perturbations of many rotations, vectorised.
    noisy = quat_to_matrix(random_quats(rng)) + 1e-3 * rng.normal(size=(N_RANDOM, 3, 3))
    fixed = gram_schmidt(noisy)
    np.testing.assert_allclose(np.swapaxes(fixed, -1, -2) @ fixed,
                               np.broadcast_to(np.eye(3), fixed.shape), atol=ROUND_OFF)
    np.testing.assert_allclose(np.linalg.det(fixed), 1.0, atol=ROUND_OFF)


def test_gram_schmidt_is_right_handed_even_for_a_reflection():
    reflection = np.diag([1.0, 1.0, -1.0])
    np.testing.assert_array_equal(gram_schmidt(reflection), np.eye(3))


# --- refused inputs ------------------------------------------------------------------------


def test_zero_quaternion_refused():
    with pytest.raises(InputError, match=r'q: quaternion \(w, x, y, z\) = \[0.0, 0.0, 0.0, '
                                         r'0.0\] has norm 0.0; it must be finite and non-zero'):
        quat_normalize([0.0, 0.0, 0.0, 0.0])
    with pytest.raises(InputError, match=r'q_wb at index \(1,\): .*nan.*has norm nan'):
        quat_normalize([[1.0, 0, 0, 0], [np.nan, 0, 0, 0]], name='q_wb')
    with pytest.raises(InputError, match='norm inf'):
        quat_to_matrix([np.inf, 0, 0, 0])
    with pytest.raises(InputError, match='norm 0.0'):
        quat_inverse([0.0, 0, 0, 0])
    with pytest.raises(InputError, match='norm 0.0'):
        quat_rotate([0.0, 0, 0, 0], [1.0, 0, 0])


def test_zero_axis_with_angle_refused():
    with pytest.raises(InputError, match=r'axis: \[0.0, 0.0, 0.0\] has no direction but '
                                         r'angle_rad is 0.5 rad'):
        quat_from_axis_angle([0.0, 0.0, 0.0], 0.5)
    with pytest.raises(InputError, match='axis at index'):
        axis_angle_to_matrix([[1.0, 0, 0], [0, 0, 0]], [0.1, 0.2])


def test_bad_shapes_and_values_refused():
    with pytest.raises(InputError, match=r'q: shape \(3,\) must end in 4'):
        quat_to_matrix([1.0, 0, 0])
    with pytest.raises(InputError, match=r'rot: shape \(3, 2\) must end in \(3, 3\)'):
        matrix_to_quat(np.zeros((3, 2)))
    with pytest.raises(InputError, match='rotvec: .*nan.* rad must be finite'):
        quat_exp([np.nan, 0, 0])
    with pytest.raises(InputError, match='cannot be orthonormalised'):
        gram_schmidt(np.ones((3, 3)))


# The compiled kernel's rotation helpers and this module are two implementations of the same
# maths (the kernel works on scalars in registers, this module on numpy arrays). They must
# agree: same sign rule, same small-angle switch, results within ROUND_OFF (a few ulp of unit
# magnitude; the two evaluate the same formulas in a different order).


def test_kernel_and_rotations_share_the_small_angle_threshold():
    assert rotations._SINC_SERIES_BELOW == kernels.SINC_SERIES_BELOW == 1e-4


@pytest.mark.parametrize('half_angle', [0.0, 1e-9, 5e-5, 0.99e-4, 1e-4, 1.01e-4, 5e-4,
                                        2e-3, 0.3, 1.5, 3.0])
def test_kernel_exponential_map_agrees_with_quat_exp(half_angle, rng):
    for _ in range(50):
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        h = 1e-3
        omega = axis * (2.0 * half_angle / h)
        compiled = np.array(kernels._quat_exp_half(*omega, h))
        np.testing.assert_allclose(compiled, quat_exp(h * omega), rtol=0, atol=ROUND_OFF)


def test_kernel_quaternion_helpers_agree_with_rotations(rng):
    for q, p, v in zip(random_quats(rng, 500), random_quats(rng, 500), rng.normal(size=(500, 3))):
        np.testing.assert_allclose(kernels._qmul(*q, *p), quat_multiply(q, p), rtol=0,
                                   atol=ROUND_OFF)
        np.testing.assert_allclose(kernels._rotate(*q, *v), quat_rotate(q, v), rtol=0,
                                   atol=ROUND_OFF * 4)
        np.testing.assert_allclose(kernels._rotate_inv(*q, *v),
                                   quat_rotate(quat_conjugate(q), v), rtol=0, atol=ROUND_OFF * 4)
        np.testing.assert_allclose(kernels._quat_to_matrix(*q), quat_to_matrix(q), rtol=0,
                                   atol=ROUND_OFF)
        axis, angle = v, float(np.linalg.norm(v))
        np.testing.assert_allclose(kernels._rotation_about(*axis, 1.0),
                                   axis_angle_to_matrix(axis, angle), rtol=0, atol=ROUND_OFF)


def test_kernel_matrix_to_quat_has_the_same_sign_rule(rng):
    # The kernel picks the hemisphere of the previous orientation; matrix_to_quat does the same
    # with reference=, and without it the canonical sign (w >= 0).
    for q, previous in zip(random_quats(rng, 1000), random_quats(rng, 1000)):
        rot = quat_to_matrix(q)
        compiled = np.array(kernels._matrix_to_quat(rot, *previous))
        ours = matrix_to_quat(rot, reference=previous)
        np.testing.assert_allclose(compiled, ours, rtol=0, atol=ROUND_OFF)
        assert compiled @ previous >= 0.0
        assert matrix_to_quat(rot)[0] >= 0.0
    # Half turns: every Shepperd branch, both signs.
    for axis in np.eye(3):
        rot = axis_angle_to_matrix(axis, np.pi)
        for previous in (np.r_[0.0, axis], np.r_[0.0, -axis]):
            np.testing.assert_allclose(kernels._matrix_to_quat(rot, *previous),
                                       matrix_to_quat(rot, reference=previous), rtol=0,
                                       atol=ROUND_OFF)


def test_kernel_gram_schmidt_agrees_with_rotations(rng):
    for q in random_quats(rng, 300):
        drifted = quat_to_matrix(q) + 1e-3 * rng.normal(size=(3, 3))
        compiled = drifted.copy()
        kernels._gram_schmidt(compiled)
        np.testing.assert_allclose(compiled, gram_schmidt(drifted), rtol=0, atol=ROUND_OFF)
