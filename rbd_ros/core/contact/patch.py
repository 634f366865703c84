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
One patch's impulses in a sweep (:func:`solve_patch`).

The normal block (an active-set solve of ``K λ = bias − u``, ``λ >= 0``), the collision
stage's restitution targets, then the patch's friction (:mod:`~rbd_ros.core.contact.friction`).
"""

import math

from rbd_ros.core.contact.friction import _friction, _friction_points, _lambda_sum
from rbd_ros.core.contact.linalg import (_pinv_small, SCR_ACTIVE, SCR_BASE, SCR_BEST, SCR_FREE,
                                         SCR_FULL, SCR_K, SCR_LAM, SCR_PINV, SCR_RHS)
from rbd_ros.core.contact.response import (_apply, _cross_response, _flat_response,
                                           _point_velocity, _record)
from rbd_ros.core.contact.rows import (_inl, _raw, C_BIAS, C_LAMBDA, C_NORMAL, C_POINT, C_RA, C_RB,
                                       C_TARGET, C_TOUCH_U, IDLE_TOL_M_S, PATCH_ITERATIONS,
                                       PATCH_POINTS, Q_A, Q_B, Q_CACHED, Q_COUNT, Q_EPS, Q_K, Q_MU,
                                       Q_NORMAL, Q_PINV, Q_START, VELOCITY_TOL_M_S)


@_raw
def _solve_small(scr, m, kept):
    """
    Set SCR_LAM to the least-norm solution of ``K[A, A] λ = rhs[A]`` (others 0).

    ``kept``: every point is active and SCR_FULL holds ``K⁺`` already (see
    :func:`_normal_block`): it is copied, not computed again (the same bits).
    """
    if kept:
        for r in range(m):
            for c in range(m):
                scr[SCR_PINV + r, c] = scr[SCR_FULL + r, c]
    else:
        _pinv_small(scr, m)
    for r in range(m):
        acc = 0.0
        for c in range(m):
            acc += scr[SCR_PINV + r, c] * scr[SCR_RHS, c]
        scr[SCR_LAM, r] = acc


@_inl
def _idle(scr, contacts, s0, m):
    """
    Tell whether no normal impulse is the answer: no point approaches faster than its target.

    Then it is the least-norm feasible set: any other feasible λ has ``λᵀKλ = λᵀ rhs <= 0``,
    so ``Kλ = 0`` and it changes no velocity.  The common case of bodies at rest before the
    velocity update, and of touching neighbours that press nothing.  ``scr``'s SCR_FREE row
    holds the velocities without the patch's impulses; a point may fall short of its target
    by :data:`IDLE_TOL_M_S` (round-off velocities of neighbours at rest).
    """
    for k in range(m):
        if contacts[s0 + k, C_BIAS] - scr[SCR_FREE, k] > IDLE_TOL_M_S:
            return False
    return True


@_inl
def _complementary(scr, contacts, s0, m):
    """
    Tell whether the held impulses solve the patch's problem for the velocities as they are.

    ``u_n = bias`` (to VELOCITY_TOL_M_S) where ``λ > 0``, ``u_n >= bias`` where ``λ = 0``;
    ``scr``'s SCR_FREE row holds ``u_n`` with the held impulses, and λ counts from SCR_BASE
    (a collision visit's start, else 0).  Where ``K`` is singular
    (four coplanar points) other impulses give the same velocities; keeping the held ones,
    instead of moving to the least-norm one of them, stops them circulating between the
    patches of a stack from sweep to sweep, and a warm-started stage is done in a sweep.
    """
    for k in range(m):
        gap = scr[SCR_FREE, k] - contacts[s0 + k, C_BIAS]
        if gap < -VELOCITY_TOL_M_S:
            return False
        if contacts[s0 + k, C_LAMBDA] > scr[SCR_BASE, k] and gap > VELOCITY_TOL_M_S:
            return False
    return True


@_inl
def _held(contacts, patches, q):
    """Tell whether a point of patch ``q`` holds a normal impulse."""
    s0 = int(patches[q, Q_START])
    for k in range(s0, s0 + int(patches[q, Q_COUNT])):
        if contacts[k, C_LAMBDA] != 0.0:
            return True
    return False


@_inl
def _normal_velocities(scr, contacts, vel, a, b, dyn_b, s0, m):
    """Set ``scr``'s SCR_FREE row to the normal velocities ``u_n`` of the points s0 … s0+m-1."""
    for k in range(m):
        c = s0 + k
        ux, uy, uz = _point_velocity(vel, a, contacts[c, C_RA], contacts[c, C_RA + 1],
                                     contacts[c, C_RA + 2])
        if dyn_b:
            bx, by, bz = _point_velocity(vel, b, contacts[c, C_RB], contacts[c, C_RB + 1],
                                         contacts[c, C_RB + 2])
            ux, uy, uz = ux - bx, uy - by, uz - bz
        scr[SCR_FREE, k] = (ux * contacts[c, C_NORMAL] + uy * contacts[c, C_NORMAL + 1]
                            + uz * contacts[c, C_NORMAL + 2])


@_inl
def _normal_block(patches, q, s0, m, contacts, vel, inv_mass, inv_inertia_w, a, b, dyn_b,
                  wa, wb, wrench, scr, free_known, fresh, known):
    """
    Set the normal impulses of one patch exactly; return the largest Δu (m/s) and ``known``.

    The complementarity problem ``u_n >= bias, λ >= 0, λ (u_n − bias) = 0`` of its (at most
    four) points: the least-norm solution with every point active first (its response ``K``
    and pseudo-inverse are computed once per stage and kept in the patch row), then, if that
    is not feasible, every other active set (:func:`_solve_small` for each).  ``fresh``: a
    collision visit (see :func:`solve_patch`): the impulses solved for are added to SCR_BASE,
    the ones the visit started from, instead of replacing them.

    ``known`` says what an earlier call of the same visit left in ``scr`` (``K``, its lever
    arms, normals and weights being fixed within the visit): 0 nothing, 1 ``K`` of a pair not
    in the patch row (a body held: shock propagation) in SCR_K, 2 also ``K⁺`` of every point
    in SCR_FULL.  Neither is computed again: the same bits, without shock propagation's
    pseudo-inverses at every one of a visit's friction iterations.
    """
    free_pair = wa == 1.0 and (not dyn_b or wb == 1.0)
    cached = free_pair and patches[q, Q_CACHED] != 0.0
    if not free_known:  # (else the caller has just set SCR_FREE for these velocities)
        _normal_velocities(scr, contacts, vel, a, b, dyn_b, s0, m)
    held = False
    for k in range(m):
        held = held or contacts[s0 + k, C_LAMBDA] != scr[SCR_BASE, k]
        scr[SCR_ACTIVE, k] = 0.0
        scr[SCR_LAM, k] = 0.0
        scr[SCR_BEST, k] = 0.0
    if not held and _idle(scr, contacts, s0, m):
        return 0.0, known  # nothing held, nothing to hold
    if held and _complementary(scr, contacts, s0, m):
        return 0.0, known  # what is held already solves it: keep it (see _complementary)
    if free_pair and not cached:
        cached = _flat_response(patches, q, contacts, s0, m, inv_mass, inv_inertia_w, a, b,
                                dyn_b, scr)
    for k in range(m if cached or known == 0 else 0):
        ck = s0 + k
        nkx = contacts[ck, C_NORMAL]
        nky = contacts[ck, C_NORMAL + 1]
        nkz = contacts[ck, C_NORMAL + 2]
        for jj in range(k, m):
            if cached:
                v = patches[q, Q_K + PATCH_POINTS * k + jj]
            else:
                cl = s0 + jj
                v = wa * _cross_response(
                    inv_mass, inv_inertia_w, a, contacts[cl, C_RA], contacts[cl, C_RA + 1],
                    contacts[cl, C_RA + 2], contacts[cl, C_NORMAL], contacts[cl, C_NORMAL + 1],
                    contacts[cl, C_NORMAL + 2], contacts[ck, C_RA], contacts[ck, C_RA + 1],
                    contacts[ck, C_RA + 2], nkx, nky, nkz)
                if dyn_b:
                    v += wb * _cross_response(
                        inv_mass, inv_inertia_w, b, contacts[cl, C_RB], contacts[cl, C_RB + 1],
                        contacts[cl, C_RB + 2], contacts[cl, C_NORMAL],
                        contacts[cl, C_NORMAL + 1], contacts[cl, C_NORMAL + 2],
                        contacts[ck, C_RB], contacts[ck, C_RB + 1], contacts[ck, C_RB + 2],
                        nkx, nky, nkz)
            scr[SCR_K + k, jj] = v
            scr[SCR_K + jj, k] = v
    if not cached and known == 0:
        known = 1
    # Velocities without this patch's normal impulses (beyond a visit's base): u0 = u − K λ.
    for k in range(m):
        acc = scr[SCR_FREE, k]
        for jj in range(m):
            acc -= scr[SCR_K + k, jj] * (contacts[s0 + jj, C_LAMBDA] - scr[SCR_BASE, jj])
        scr[SCR_FREE, k] = acc
    if _idle(scr, contacts, s0, m):
        return _apply_normals(scr, SCR_BEST, s0, m, contacts, vel, inv_mass, inv_inertia_w,
                              a, b, dyn_b, wa, wb, wrench, fresh), known
    for k in range(m):
        scr[SCR_RHS, k] = contacts[s0 + k, C_BIAS] - scr[SCR_FREE, k]
    if free_pair and not cached:
        for k in range(m):
            scr[SCR_ACTIVE, k] = 1.0
        _pinv_small(scr, m)
        for k in range(m):
            for jj in range(m):
                patches[q, Q_K + PATCH_POINTS * k + jj] = scr[SCR_K + k, jj]
                patches[q, Q_PINV + PATCH_POINTS * k + jj] = scr[SCR_PINV + k, jj]
        patches[q, Q_CACHED] = 1.0
        cached = True
    if cached:
        # The full set from the kept pseudo-inverse; feasible means done.
        feasible = True
        for k in range(m):
            acc = 0.0
            for jj in range(m):
                acc += patches[q, Q_PINV + PATCH_POINTS * k + jj] * scr[SCR_RHS, jj]
            scr[SCR_LAM, k] = acc
            if acc < 0.0:
                feasible = False
        if feasible:
            return _apply_normals(scr, SCR_LAM, s0, m, contacts, vel, inv_mass,
                                  inv_inertia_w, a, b, dyn_b, wa, wb, wrench, fresh), known
    # Every active set in a fixed order; of the feasible ones (λ >= 0 on it, u_n >= bias off
    # it) the one with the least |λ| wins.  Where K is singular (coplanar points) several
    # are feasible with the same velocities; the least-norm one spreads the load evenly
    # instead of putting it on a diagonal pair, which would twist the bodies apart.
    chosen = -1
    least = math.inf
    closest = -1  # the set violating its conditions least, should round-off leave none
    smallest = math.inf
    # All points first: if that least-norm solution is feasible it is the answer (every
    # solution has the same velocities, so it is the least-norm one of them all).  The empty
    # set (no impulse: nothing approaches) is tried too.
    full = (1 << m) - 1
    last = -1  # the set SCR_ACTIVE, SCR_PINV and SCR_LAM hold
    for mask in range(full, -1, -1):
        for k in range(m):
            scr[SCR_ACTIVE, k] = 1.0 if (mask >> k & 1) == 1 else 0.0
        _solve_small(scr, m, mask == full and known == 2 and not cached)
        last = mask
        if mask == full and known == 1 and not cached:
            for r in range(m):
                for c in range(m):
                    scr[SCR_FULL + r, c] = scr[SCR_PINV + r, c]
            known = 2
        ok = True
        norm = 0.0
        worst = 0.0
        for k in range(m):
            lam = scr[SCR_LAM, k]
            if scr[SCR_ACTIVE, k] != 0.0:
                norm += lam * lam
                if lam < 0.0:
                    ok = False
                    worst = max(worst, -lam * scr[SCR_K + k, k])
            else:
                u = scr[SCR_FREE, k]
                for jj in range(m):
                    u += scr[SCR_K + k, jj] * scr[SCR_LAM, jj]
                bias = contacts[s0 + k, C_BIAS]
                if u < bias - 1e-9 * (abs(scr[SCR_RHS, k]) + 1e-12):
                    ok = False
                    worst = max(worst, bias - u)
        if worst < smallest:
            smallest = worst
            closest = mask
        if ok and norm < least * (1.0 - 1e-12):
            least = norm
            chosen = mask
            if mask == full:
                break
    if chosen < 0:
        chosen = closest   # round-off left none feasible: the nearest one, clamped below
    if chosen != last:     # (else its λ is in SCR_LAM already, the same bits)
        for k in range(m):
            scr[SCR_ACTIVE, k] = 1.0 if (chosen >> k & 1) == 1 else 0.0
        _solve_small(scr, m, chosen == full and known == 2 and not cached)
    for k in range(m):
        scr[SCR_BEST, k] = max(scr[SCR_LAM, k], 0.0)
    return _apply_normals(scr, SCR_BEST, s0, m, contacts, vel, inv_mass, inv_inertia_w, a, b,
                          dyn_b, wa, wb, wrench, fresh), known


@_raw
def _apply_normals(scr, row, s0, m, contacts, vel, inv_mass, inv_inertia_w, a, b, dyn_b, wa,
                   wb, wrench, fresh):
    """Make the normal impulses ``scr[row]`` (+ SCR_BASE if ``fresh``); return the largest Δu."""
    change = 0.0
    for k in range(m):
        c = s0 + k
        lam = scr[row, k] + scr[SCR_BASE, k] if fresh else scr[row, k]
        d = lam - contacts[c, C_LAMBDA]
        if d == 0.0:
            continue
        contacts[c, C_LAMBDA] = lam
        jx = d * contacts[c, C_NORMAL]
        jy = d * contacts[c, C_NORMAL + 1]
        jz = d * contacts[c, C_NORMAL + 2]
        rax, ray, raz = contacts[c, C_RA], contacts[c, C_RA + 1], contacts[c, C_RA + 2]
        _apply(vel, inv_mass, inv_inertia_w, a, wa, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
        _record(wrench, a, 1.0, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
        if dyn_b:
            rbx, rby, rbz = contacts[c, C_RB], contacts[c, C_RB + 1], contacts[c, C_RB + 2]
            _apply(vel, inv_mass, inv_inertia_w, b, -wb, rbx, rby, rbz, jx, jy, jz,
                   0.0, 0.0, 0.0)
            _record(wrench, b, -1.0, rbx, rby, rbz, jx, jy, jz, 0.0, 0.0, 0.0)
        change = max(change, abs(d) * scr[SCR_K + k, k])
    return change


@_inl
def _collision_targets(patches, q, contacts, s0, m, scr):
    """
    Set the targets of a collision visit to patch ``q`` from the velocities in SCR_FREE.

    A point approaching (``u_n < 0``) that would end the step inside the other shape or
    within TOUCH_M of it (``u_n < C_TOUCH_U``) is to leave at ``−ε u_n``; any other keeps
    C_TARGET.  (Within TOUCH_M: two boxes meeting face on exactly at the step's end have
    φ = ±round-off at their corners, and restitution on some of them only spun them apart.)
    """
    eps = patches[q, Q_EPS]
    for k in range(m):
        c = s0 + k
        u = scr[SCR_FREE, k]
        bias = contacts[c, C_TARGET]
        if u < 0.0 and u < contacts[c, C_TOUCH_U]:
            bias = max(bias, -eps * u)
        contacts[c, C_BIAS] = bias


# Not inlined (compiled once, called): the sweeps and the shock propagation each inlined it, with
# the normal block and the friction inside it, which was 11 s of the contact step's first compile
# each; the call costs the resting and stacked benchmarks 0-6 % (issue 25).
@_raw
def solve_patch(q, patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wa, wb,
                wrench, friction, scr, per_point, free_known):
    """
    Iterate the normal impulses and the friction of patch ``q``; return the largest Δu (m/s).

    ``wa``, ``wb`` scale the inverse masses of A and B (0 holds a body as if of infinite mass:
    a static object, or a lower level in shock propagation); the impulses are recorded in
    ``wrench`` (N, 6) for both bodies all the same.  ``per_point``: friction by
    :func:`_friction_points` (patches that share a body) instead of the patch's own
    :func:`_friction`.  ``free_known``: ``scr``'s SCR_FREE row already holds the points'
    normal velocities (:func:`_normal_velocities`) for ``vel`` as it is.

    A patch with restitution in the collision stage (``Q_EPS > 0``) is solved as the paper
    processes collisions: each visit is a new collision, its targets taken from the approach
    velocities at the visit (:func:`_collision_targets`), its impulses added to the ones the
    visit started from, which it never takes back.  So in a row of touching balls the
    impulse of each collision is handed on to the next pair within one sweep (Newton's
    cradle).  Accumulated instead, towards targets fixed at the stage's start, the row
    answered as one block: a later sweep pulling a pair's impulse back to the least one that
    keeps its target would have pushed apart again what had already exchanged its motion.
    Every other patch accumulates, clamped to ``λ >= 0`` in total (projected Gauss–Seidel).
    """
    a = int(patches[q, Q_A])
    b = int(patches[q, Q_B])
    dyn_b = b < n_bodies
    s0 = int(patches[q, Q_START])
    m = int(patches[q, Q_COUNT])
    mu = patches[q, Q_MU]
    fresh = patches[q, Q_EPS] > 0.0
    if fresh:
        if not free_known:
            _normal_velocities(scr, contacts, vel, a, b, dyn_b, s0, m)
            free_known = True
        _collision_targets(patches, q, contacts, s0, m, scr)
    for k in range(m):
        scr[SCR_BASE, k] = contacts[s0 + k, C_LAMBDA] if fresh else 0.0
    biggest = 0.0
    known = 0  # what the normal block has kept in scr for the visit's next rounds
    for it in range(PATCH_ITERATIONS):
        # Normal impulses: the patch's small LCP solved exactly (see _normal_block), for the
        # velocities as they are; another round is needed only if friction then changes them
        # by more than the tolerance (solving again would give the same impulses).
        change, known = _normal_block(patches, q, s0, m, contacts, vel, inv_mass, inv_inertia_w,
                                      a, b, dyn_b, wa, wb, wrench, scr, free_known and it == 0,
                                      fresh, known)
        biggest = max(biggest, change)
        slip = 0.0
        if per_point:
            if friction and mu > 0.0:
                slip = _friction_points(q, patches, contacts, vel, inv_mass, inv_inertia_w, a,
                                        b, dyn_b, wa, wb, wrench, s0, m, mu)
        else:
            # Friction of the patch at its normal-impulse centre.
            total = 0.0
            for k in range(s0, s0 + m):
                total += contacts[k, C_LAMBDA]
            cx, cy, cz = _lambda_sum(contacts, s0, m, C_POINT)
            nbx, nby, nbz = _lambda_sum(contacts, s0, m, C_NORMAL)
            nn = math.sqrt(nbx * nbx + nby * nby + nbz * nbz)
            if friction and total > 0.0 and mu > 0.0 and nn > 0.0:
                cx, cy, cz = cx / total, cy / total, cz / total
                nbx, nby, nbz = nbx / nn, nby / nn, nbz / nn
                patches[q, Q_NORMAL] = nbx
                patches[q, Q_NORMAL + 1] = nby
                patches[q, Q_NORMAL + 2] = nbz
                slip = _friction(q, patches, contacts, vel, inv_mass, inv_inertia_w, a, b,
                                 dyn_b, x, wa, wb, wrench, total, cx, cy, cz, nbx, nby, nbz,
                                 s0, m, mu)
        biggest = max(biggest, slip)
        if slip <= VELOCITY_TOL_M_S:
            break
    return biggest
