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
The closed-form response of a flat patch against exact rational arithmetic.

``_flat_response`` gives the normal response K of a body's patch on a static object or on a
second body, and its Moore–Penrose pseudo-inverse K⁺, in closed form when every point has
one normal.  The reference here takes the same float inputs (lever arms, normal, inverse
masses and inertias), builds K from its definition, per body
``K_kl = m⁻¹ n·n + (r_k × n)ᵀ I⁻¹ (r_l × n)``, in
:class:`fractions.Fraction` (no rounding), and inverts it through a full-rank factorisation
``K = F X`` (Ben-Israel & Greville, *Generalized Inverses*, §1.7: ``K⁺ = Xᵀ(XXᵀ)⁻¹(FᵀF)⁻¹Fᵀ``),
which knows nothing of the patch's structure.
"""

from fractions import Fraction

import numpy as np
import pytest
from rbd_ros.core.contact import linalg, response, rows


def _exact_matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(len(b))) for j in range(len(b[0]))]
            for i in range(len(a))]


def _exact_t(a):
    return [list(row) for row in zip(*a)]


def _exact_inverse(a):
    """Gauss–Jordan inverse of a square Fraction matrix."""
    n = len(a)
    w = [list(row) + [Fraction(int(i == j)) for j in range(n)] for i, row in enumerate(a)]
    for c in range(n):
        p = next(r for r in range(c, n) if w[r][c] != 0)
        w[c], w[p] = w[p], w[c]
        w[c] = [v / w[c][c] for v in w[c]]
        for r in range(n):
            if r != c and w[r][c] != 0:
                f = w[r][c]
                w[r] = [v - f * u for v, u in zip(w[r], w[c])]
    return [row[n:] for row in w]


def _exact_pinv(k, rank):
    """K⁺ of a rank-``rank`` Fraction matrix whose first ``rank`` columns are independent."""
    f = [row[:rank] for row in k]
    ft = _exact_t(f)
    x = _exact_matmul(_exact_inverse(_exact_matmul(ft, f)), _exact_matmul(ft, k))
    xt = _exact_t(x)
    return _exact_matmul(_exact_matmul(xt, _exact_inverse(_exact_matmul(x, xt))),
                         _exact_matmul(_exact_inverse(_exact_matmul(ft, f)), ft))


def _exact_response(lever_arms, normal, inv_mass, inv_inertia):
    n = [Fraction(v) for v in normal]
    w = [[Fraction(v) for v in row] for row in inv_inertia]
    arms = []
    for r in lever_arms:
        r = [Fraction(v) for v in r]
        arms.append([r[1] * n[2] - r[2] * n[1], r[2] * n[0] - r[0] * n[2],
                     r[0] * n[1] - r[1] * n[0]])
    im = Fraction(inv_mass) * sum(v * v for v in n)
    return [[im + sum(ak[i] * w[i][j] * al[j] for i in range(3) for j in range(3))
             for al in arms] for ak in arms]


def _inertia(rng):
    a = rng.normal(size=(3, 3))
    return np.linalg.inv(a @ a.T + 0.05 * np.eye(3))   # of any positive definite kg·m²


def _patch(rng, count, normal, spread_m, offset_m, body_b=False):
    """
    Return a patch of ``count`` points of one normal: body A = 1 on body B = 0 or a static.

    Lever arms on a grid of 2⁻¹² m, so that B's (A's shifted by the COMs' offset) are exact
    in floating point and the exact K has rank 3, as it has mathematically.
    """
    contacts = np.zeros((2 + count, rows.N_CONTACT))
    arms = np.round((rng.normal(size=(count, 3)) * spread_m + offset_m) * 4096.0) / 4096.0
    contacts[2:, rows.C_RA:rows.C_RA + 3] = arms
    contacts[2:, rows.C_NORMAL:rows.C_NORMAL + 3] = normal
    inv_inertia_w = np.zeros((2, 3, 3))
    inv_inertia_w[1] = _inertia(rng)
    inv_mass = np.array([0.0, 1.0 / rng.uniform(0.1, 5.0)])
    arms_b = None
    if body_b:
        arms_b = arms + np.round(rng.normal(size=3) * 0.1 * 4096.0) / 4096.0
        contacts[2:, rows.C_RB:rows.C_RB + 3] = arms_b
        inv_inertia_w[0] = _inertia(rng)
        inv_mass[0] = 1.0 / rng.uniform(0.1, 5.0)
    return contacts, arms, arms_b, inv_mass, inv_inertia_w


def _flat(contacts, count, inv_mass, inv_inertia_w, body_b=False):
    patches = np.zeros((2, rows.N_PATCH))
    ok = response._flat_response(patches, 1, contacts, 2, count, inv_mass, inv_inertia_w, 1,
                                 0 if body_b else 2, body_b, linalg.patch_scratch())
    k = patches[1, rows.Q_K:rows.Q_K + 16].reshape(4, 4)
    pinv = patches[1, rows.Q_PINV:rows.Q_PINV + 16].reshape(4, 4)
    return ok, k, pinv, patches[1, rows.Q_CACHED]


@pytest.mark.parametrize('count', [3, 4])
@pytest.mark.parametrize('tilted', [False, True])
@pytest.mark.parametrize('body_b', [False, True])
def test_flat_response_is_the_exact_pseudo_inverse(count, tilted, body_b):
    rng = np.random.default_rng(count + 10 * tilted + 100 * body_b)
    checked = 0
    errors, general = [], []
    for _ in range(25):
        normal = np.array([0.0, 0.0, 1.0])
        if tilted:
            normal = rng.normal(size=3)
            normal /= np.linalg.norm(normal)
        # Points spread about 5 cm round a spot up to ~10 cm from the COM, as a face of a
        # box or a mesh gives; the random inertia makes K up to ~1e6 ill-conditioned.
        contacts, arms, arms_b, inv_mass, inv_inertia_w = _patch(
            rng, count, normal, 0.05, rng.normal(size=3) * 0.1, body_b)
        ok, k, pinv, cached = _flat(contacts, count, inv_mass, inv_inertia_w, body_b)
        if not ok:  # a sliver of a triangle (det S₂ below FLAT_SPREAD_TOL): not flat enough
            continue
        assert cached == 1.0
        checked += 1
        exact_k = _exact_response(arms, normal, inv_mass[1], inv_inertia_w[1])
        if body_b:
            k_b = _exact_response(arms_b, normal, inv_mass[0], inv_inertia_w[0])
            exact_k = [[u + v for u, v in zip(row, row_b)] for row, row_b in zip(exact_k, k_b)]
        exact_pinv = _exact_pinv(exact_k, 3)  # one normal: rank 3 (4 points) or 3 (3)
        exact_k = np.array(exact_k, dtype=float)
        exact_pinv = np.array(exact_pinv, dtype=float)
        # K: a few roundings of terms of one sign, so a few ulp of its largest entry.
        assert np.abs(k[:count, :count] - exact_k).max() <= 1e-14 * np.abs(exact_k).max()
        # K⁺ from inverses of S₂ (2×2) and C (3×3), both far from singular (by
        # FLAT_SPREAD_TOL and positive definite inertia): over 300 random patches of each
        # kind, median 1e-15 and at most 2.2e-13 (static) and 5.9e-13 (two bodies) of its
        # largest entry, against a median of 1-3e-13 and at most 0.8-1.5e-9 for the general
        # route of _pinv_small on the exact K.  5e-12 leaves a margin and still fails any
        # wrong term (those are O(1) relative).
        scale = np.abs(exact_pinv).max()
        errors.append(np.abs(pinv[:count, :count] - exact_pinv).max() / scale)
        assert errors[-1] <= 5e-12
        assert not pinv[count:].any() and not pinv[:, count:].any()
        # The general route (_pinv_small) on the exact K rounded to floats, for comparison.
        scr = linalg.patch_scratch()
        scr[linalg.SCR_K:linalg.SCR_K + count, :count] = exact_k
        scr[linalg.SCR_ACTIVE, :count] = 1.0
        linalg._pinv_small(scr, count)
        general.append(np.abs(scr[linalg.SCR_PINV:linalg.SCR_PINV + count, :count]
                              - exact_pinv).max() / scale)
    assert checked >= 20  # (about 1 % of random triangles are slivers)
    # What the README says: ~100× closer to exact than the general route (medians 1e-15
    # against 1-3e-13 over 300 patches; 60-2000× apart in these eight cases); asserted
    # with a margin: 10×.
    assert np.median(errors) * 10.0 <= np.median(general)


def test_flat_response_leaves_other_patches_to_the_general_route():
    rng = np.random.default_rng(7)
    normal = np.array([0.0, 0.0, 1.0])
    # Two points: B = [1, α] cannot have rank 3.
    contacts, _, _, inv_mass, inv_inertia_w = _patch(rng, 2, normal, 0.05, 0.0)
    assert not _flat(contacts, 2, inv_mass, inv_inertia_w)[0]
    # Four points on a line in the tangent plane: S₂ singular.
    contacts, _, _, inv_mass, inv_inertia_w = _patch(rng, 4, normal, 0.05, 0.0)
    contacts[2:, rows.C_RA:rows.C_RA + 3] = [[0.01 * k, 0.02 * k, -0.05] for k in range(4)]
    assert not _flat(contacts, 4, inv_mass, inv_inertia_w)[0]
    # Normals that differ in their last bit: not one normal.
    contacts, _, _, inv_mass, inv_inertia_w = _patch(rng, 4, normal, 0.05, 0.0)
    contacts[4, rows.C_NORMAL + 1] = 1e-17
    ok, _, _, cached = _flat(contacts, 4, inv_mass, inv_inertia_w)
    assert not ok and cached == 0.0
