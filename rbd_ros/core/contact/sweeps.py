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
A contact stage's solve: warm start, Gauss–Seidel sweeps, shock propagation.

:func:`solve_islands` cuts a stage's patches into the islands of the contact graph and solves
each alone: sweeps over its patches (from the last step's impulses where patches share bodies),
then shock propagation by levels of the contact graph (:func:`_solve_group`), the impulses
written back.  A jointed world's stage is one group (:func:`solve_stage`).

**Joints** (Weinstein, Teran, Fedkiw 2006; see ``/work/shared/reference/joints-weinstein.md``)
are solved by equal and opposite impulses like a patch, in :mod:`rbd_ros.core.contact.joints`:
post-stabilization in :func:`rbd_ros.core.contact.step.world_step` after the collision stage
and after the velocity update; pre-stabilization alternating with :func:`_sweeps` after
:func:`solve_stage` (``joint_sweeps``: a visit of all joints, a sweep of the patches, again).
Each sweep of that loop is followed by a shock pass (:func:`_shock`) whose levels have the
joints as edges (:func:`rbd_ros.core.contact.joints.joint_levels`). Not here yet: a visit
per joint inside :func:`_sweeps` and :func:`_shock` with the lower body held (the joints are
visited all at once between them); limits as a clamp inside the joint's visit, as the normal
impulses' ``λ >= 0``.
"""

import math

import numpy as np

from rbd_ros.core.contact.linalg import _mat_t_vec, _mat_vec, patch_scratch, SCR_FREE
from rbd_ros.core.contact.patch import (_collision_targets, _held, _idle, _normal_velocities,
                                        solve_patch)
from rbd_ros.core.contact.response import _apply, _point_velocity, _record
from rbd_ros.core.contact.rows import (_inl, _jit, _raw, C_BIAS, C_FRICTION, C_LAMBDA, C_NORMAL,
                                       C_RA, C_RB, C_TK_SET, Q_A, Q_B, Q_CACHED, Q_COUNT, Q_EPS,
                                       Q_FT, Q_MU, Q_START, ST_COLD, ST_PATCHES, ST_STAGES,
                                       ST_SWEEPS, SWEEP_TOL_M_S, SWEEPS, VELOCITY_TOL_M_S, W_B,
                                       W_COUNT, W_POINTS, W_SLOTS, W_STRIDE, WARM_COS_MIN,
                                       WARM_LEFT_MAX_M_S, WARM_MATCH_M)
from rbd_ros.core.layout import P_GRAVITY


@_raw
def _levels(patches, n_bodies, level):
    """
    Store in ``level`` (N,) the contact-graph level of the patches' bodies.

    1 on a static object, k + 1 on level k; else big.  Only the patches' bodies are written.
    """
    big = n_bodies + 1
    for q in range(patches.shape[0]):
        level[int(patches[q, Q_A])] = big
        if patches[q, Q_B] < n_bodies:
            level[int(patches[q, Q_B])] = big
    for q in range(patches.shape[0]):
        if patches[q, Q_B] >= n_bodies:
            level[int(patches[q, Q_A])] = 1
    for _ in range(n_bodies):
        moved = False
        for q in range(patches.shape[0]):
            a = int(patches[q, Q_A])
            b = int(patches[q, Q_B])
            if b >= n_bodies:
                continue
            if level[a] + 1 < level[b]:
                level[b] = level[a] + 1
                moved = True
            elif level[b] + 1 < level[a]:
                level[a] = level[b] + 1
                moved = True
        if not moved:
            break


@_raw
def _relative_velocities(patches, contacts, vel, n_bodies, out, compare):
    """
    Store every point's relative velocity in ``out`` (C, 3); with ``compare``, compare first.

    ``compare``: return the largest change since it was last stored (m/s), else 0.
    """
    largest = 0.0
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        s0 = int(patches[q, Q_START])
        for c in range(s0, s0 + int(patches[q, Q_COUNT])):
            ux, uy, uz = _point_velocity(vel, a, contacts[c, C_RA], contacts[c, C_RA + 1],
                                         contacts[c, C_RA + 2])
            if b < n_bodies:
                bx, by, bz = _point_velocity(vel, b, contacts[c, C_RB], contacts[c, C_RB + 1],
                                             contacts[c, C_RB + 2])
                ux, uy, uz = ux - bx, uy - by, uz - bz
            if compare:
                dx, dy, dz = ux - out[c, 0], uy - out[c, 1], uz - out[c, 2]
                largest = max(largest, math.sqrt(dx * dx + dy * dy + dz * dz))
            out[c, 0] = ux
            out[c, 1] = uy
            out[c, 2] = uz
    return largest


@_raw
def _residual(patches, contacts, vel, n_bodies, scr):
    """
    Return the largest violation of the normal complementarity conditions (m/s).

    Per point: how much faster than its target ``bias`` it still approaches, and where it
    holds an impulse, how much faster than that target it separates (the impulse is then too
    large: left, it would push the bodies apart and add energy).  0 at the exact solution.
    A collision patch with restitution (``Q_EPS > 0``) may separate faster with an impulse:
    its visits add impulses, each complementary only to its own targets (see solve_patch).
    """
    largest = 0.0
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        s0 = int(patches[q, Q_START])
        m = int(patches[q, Q_COUNT])
        _normal_velocities(scr, contacts, vel, a, b, b < n_bodies, s0, m)
        added = patches[q, Q_EPS] > 0.0
        for k in range(m):
            gap = scr[SCR_FREE, k] - contacts[s0 + k, C_BIAS]
            largest = max(largest, -gap)
            if contacts[s0 + k, C_LAMBDA] > 0.0 and not added:
                largest = max(largest, gap)
    return largest


@_inl
def _beside(contacts, c, gx, gy, gz, g):
    """Tell whether point ``c``'s normal is not within 60° of gravity (WARM_COS_MIN)."""
    return (abs(contacts[c, C_NORMAL] * gx + contacts[c, C_NORMAL + 1] * gy
                + contacts[c, C_NORMAL + 2] * gz) < WARM_COS_MIN * g)


@_raw
def _warm_start(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, wrench, rot, warm,
                warm_n, slot, prm, sideways):
    """
    Apply the kept impulses of ``slot`` to the matching points (see :data:`W_SLOTS`).

    ``sideways`` (N,) bool is scratch: whether a body has a patch whose normal is not within
    60° of gravity (a neighbour beside it).  Return how many points took a kept impulse.
    """
    shared = prm.shape[1] == 1
    started = 0
    for q in range(patches.shape[0]):
        sideways[int(patches[q, Q_A])] = False
        if patches[q, Q_B] < n_bodies:
            sideways[int(patches[q, Q_B])] = False
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        j = 0 if shared else a
        gx, gy, gz = prm[P_GRAVITY, j], prm[P_GRAVITY + 1, j], prm[P_GRAVITY + 2, j]
        if _beside(contacts, int(patches[q, Q_START]), gx, gy, gz,
                   math.sqrt(gx * gx + gy * gy + gz * gz)):
            sideways[a] = True
            if b < n_bodies:
                sideways[b] = True
    for q in range(patches.shape[0]):
        if patches[q, Q_EPS] > 0.0:
            continue  # a collision visit never takes back what it is given (see solve_patch)
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        j = 0 if shared else a
        gx, gy, gz = prm[P_GRAVITY, j], prm[P_GRAVITY + 1, j], prm[P_GRAVITY + 2, j]
        g = math.sqrt(gx * gx + gy * gy + gz * gz)
        if not g > 0.0:
            continue
        s0 = int(patches[q, Q_START])
        m = int(patches[q, Q_COUNT])
        # A patch all of whose points are beside its bodies (neighbours side by side) takes
        # nothing (each point would be passed over below): not looked up.
        upright = False
        for k in range(m):
            upright = upright or not _beside(contacts, s0 + k, gx, gy, gz, g)
        if not upright:
            continue
        row = -1
        for j in range(warm_n[slot, a]):
            if warm[slot, a, j, W_B] == b:
                row = j
                break
        if row < 0:
            continue
        dyn_b = b < n_bodies
        old = int(warm[slot, a, row, W_COUNT])
        # Beside a neighbour, the matched points take the mean of their kept impulses
        # (C_LAMBDA, 0 from the narrow phase, holds each point's own until then): the
        # patch's load, not its spread (see W_SLOTS).
        spread = not sideways[a] and not (dyn_b and sideways[b])
        used = 0
        total = 0.0
        taken = 0
        for k in range(m):
            c = s0 + k
            rax, ray, raz = contacts[c, C_RA], contacts[c, C_RA + 1], contacts[c, C_RA + 2]
            px, py, pz = _mat_t_vec(rot, a, rax, ray, raz)
            best = -1
            nearest = WARM_MATCH_M * WARM_MATCH_M
            for j in range(old):
                if (used >> j) & 1:
                    continue
                f = W_POINTS + W_STRIDE * j
                dx = px - warm[slot, a, row, f]
                dy = py - warm[slot, a, row, f + 1]
                dz = pz - warm[slot, a, row, f + 2]
                d2 = dx * dx + dy * dy + dz * dz
                if d2 <= nearest:
                    nearest = d2
                    best = j
            if best < 0:
                continue
            used |= 1 << best
            f = W_POINTS + W_STRIDE * best
            lam = warm[slot, a, row, f + 3]
            if not lam > 0.0 or _beside(contacts, c, gx, gy, gz, g):
                continue
            contacts[c, C_LAMBDA] = lam
            # The kept friction, in A's frame until the point is applied (see below).
            contacts[c, C_FRICTION] = warm[slot, a, row, f + 4]
            contacts[c, C_FRICTION + 1] = warm[slot, a, row, f + 5]
            contacts[c, C_FRICTION + 2] = warm[slot, a, row, f + 6]
            total += lam
            taken += 1
        if taken == 0:
            continue
        started += taken
        mean = total / taken
        for k in range(m):
            c = s0 + k
            if contacts[c, C_LAMBDA] == 0.0:
                continue
            rax, ray, raz = contacts[c, C_RA], contacts[c, C_RA + 1], contacts[c, C_RA + 2]
            nx = contacts[c, C_NORMAL]
            ny = contacts[c, C_NORMAL + 1]
            nz = contacts[c, C_NORMAL + 2]
            lam = contacts[c, C_LAMBDA] if spread else mean
            contacts[c, C_LAMBDA] = lam
            fx = fy = fz = 0.0
            if spread:
                # The kept friction to world, onto this tangent plane, inside the cone μ λ.
                fx, fy, fz = _mat_vec(rot, a, contacts[c, C_FRICTION],
                                      contacts[c, C_FRICTION + 1], contacts[c, C_FRICTION + 2])
                fn = fx * nx + fy * ny + fz * nz
                fx, fy, fz = fx - fn * nx, fy - fn * ny, fz - fn * nz
                size = math.sqrt(fx * fx + fy * fy + fz * fz)
                cap = patches[q, Q_MU] * lam
                if size > cap:
                    fx, fy, fz = fx * cap / size, fy * cap / size, fz * cap / size
            contacts[c, C_FRICTION] = fx
            contacts[c, C_FRICTION + 1] = fy
            contacts[c, C_FRICTION + 2] = fz
            patches[q, Q_FT] += fx
            patches[q, Q_FT + 1] += fy
            patches[q, Q_FT + 2] += fz
            jx, jy, jz = lam * nx + fx, lam * ny + fy, lam * nz + fz
            _apply(vel, inv_mass, inv_inertia_w, a, 1.0, rax, ray, raz, jx, jy, jz,
                   0.0, 0.0, 0.0)
            _record(wrench, a, 1.0, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
            if dyn_b:
                rbx, rby, rbz = contacts[c, C_RB], contacts[c, C_RB + 1], contacts[c, C_RB + 2]
                _apply(vel, inv_mass, inv_inertia_w, b, -1.0, rbx, rby, rbz, jx, jy, jz,
                       0.0, 0.0, 0.0)
                _record(wrench, b, -1.0, rbx, rby, rbz, jx, jy, jz, 0.0, 0.0, 0.0)
    return started


@_raw
def _keep_warm(patches, contacts, rot, warm, warm_n, slot, kept):
    """
    Keep the patches' impulses in ``slot`` for the next step (see :data:`W_SLOTS`).

    Each patch's body A has its rows of ``slot`` rewritten and is marked in ``kept`` (N,);
    the caller empties the rows of the bodies no patch kept.
    """
    for q in range(patches.shape[0]):
        warm_n[slot, int(patches[q, Q_A])] = 0
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
        kept[a] = True
        row = warm_n[slot, a]
        if row == W_SLOTS:
            continue
        warm_n[slot, a] = row + 1
        s0 = int(patches[q, Q_START])
        m = int(patches[q, Q_COUNT])
        warm[slot, a, row, W_B] = patches[q, Q_B]
        warm[slot, a, row, W_COUNT] = m
        for k in range(m):
            c = s0 + k
            f = W_POINTS + W_STRIDE * k
            px, py, pz = _mat_t_vec(rot, a, contacts[c, C_RA], contacts[c, C_RA + 1],
                                    contacts[c, C_RA + 2])
            warm[slot, a, row, f] = px
            warm[slot, a, row, f + 1] = py
            warm[slot, a, row, f + 2] = pz
            warm[slot, a, row, f + 3] = contacts[c, C_LAMBDA]
            fx, fy, fz = _mat_t_vec(rot, a, contacts[c, C_FRICTION], contacts[c, C_FRICTION + 1],
                                    contacts[c, C_FRICTION + 2])
            warm[slot, a, row, f + 4] = fx
            warm[slot, a, row, f + 5] = fy
            warm[slot, a, row, f + 6] = fz


@_raw
def _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, scr, coupled,
            warmed, before):
    """
    Run the Gauss–Seidel sweeps of a stage, at most SWEEPS, until they converge; return how many.

    ``warmed``: the points may hold impulses already (a warm start).  ``before`` (C, 3) is
    scratch: a sweep's net change of every point's relative velocity is measured against it,
    since the updates of a sweep can each move by more than the tolerance while cancelling
    (impulses circulating between patches in the null space of a statically indeterminate
    stack), so each update's change alone does not tell when the velocities have converged.
    The comparison at a sweep's end stores the velocities the next sweep is measured against.
    """
    if coupled:
        _relative_velocities(patches, contacts, vel, n_bodies, before, False)
    done = 0
    for sweep in range(SWEEPS if coupled else 1):
        done = sweep + 1
        change = 0.0
        for q in range(patches.shape[0]):
            if sweep == 0:
                # A patch that holds no impulse (none yet, or no warm start) and none of whose
                # points approaches faster than its target takes none, and neither friction
                # (solve_patch would find so).
                a = int(patches[q, Q_A])
                b = int(patches[q, Q_B])
                s0 = int(patches[q, Q_START])
                m = int(patches[q, Q_COUNT])
                _normal_velocities(scr, contacts, vel, a, b, b < n_bodies, s0, m)
                if patches[q, Q_EPS] > 0.0:
                    _collision_targets(patches, q, contacts, s0, m, scr)
                if _idle(scr, contacts, s0, m) and not (warmed and _held(contacts, patches, q)):
                    continue
            change = max(change, solve_patch(q, patches, contacts, vel, inv_mass, inv_inertia_w,
                                             n_bodies, x, 1.0, 1.0, wrench, True, scr,
                                             coupled, sweep == 0))
        net = _relative_velocities(patches, contacts, vel, n_bodies, before, True) if coupled \
            else 0.0
        if change <= VELOCITY_TOL_M_S or net <= SWEEP_TOL_M_S:
            break
    return done


@_jit
def solve_stage(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, shock,
                rot, warm, warm_n, slot, prm, stats):
    """
    Gauss–Seidel sweeps over all the patches as one group, then (``shock``) shock propagation.

    A jointed world's stage (its joint visits alternate with sweeps of every patch: see
    :func:`rbd_ros.core.contact.joints.joint_sweeps`); a world without joints solves each
    island alone (:func:`solve_islands`).  ``slot`` >= 0: the stage's row of the warm-start
    table (see :data:`W_SLOTS`), read before the sweeps and rewritten after them, and of the
    counters ``stats`` (see :data:`ST_STAGES`); -1 for none.  Return whether patches share a
    body (then friction is per point, else per patch).
    """
    uses = np.zeros(n_bodies, dtype=np.int64)
    coupled = False
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        uses[a] += 1
        coupled = coupled or uses[a] > 1
        if b < n_bodies:
            uses[b] += 1
            coupled = coupled or uses[b] > 1
    kept = np.zeros(n_bodies, dtype=np.bool_)
    _solve_group(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, shock,
                 rot, warm, warm_n, slot, prm, stats, coupled, patch_scratch(),
                 np.empty((contacts.shape[0], 3)), np.empty(n_bodies, dtype=np.int64),
                 np.empty(n_bodies, dtype=np.bool_), kept)
    if slot >= 0:
        for i in range(n_bodies):
            if not kept[i]:
                warm_n[slot, i] = 0
    return coupled


@_jit
def solve_islands(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, shock,
                  rot, warm, warm_n, slot, prm, stats):
    """
    Solve each island of the stage's contact graph alone; give lone patches their friction.

    An island is the patches whose bodies touch, directly or through others (a static object
    joins nothing).  Each island is swept (warm start, sweeps until *its* points converge, its
    own cold retry) and shock-propagated as :func:`solve_stage` would solve it were it the
    whole world, so a body's motion never depends on bodies it does not touch: the step of a
    world is the step of each of its islands, bit for bit, whatever else the world holds.  A
    patch that shares no body (an island of one) is solved exactly by one visit, and gets its
    friction per patch (:func:`finish_contacts`); they are solved together, in one pass.
    ``slot``, ``stats`` as :func:`solve_stage`; ``stats`` counts islands, not stages.
    """
    n_p = patches.shape[0]
    # Union-find over the bodies (path halving; the smaller index is the root: deterministic).
    root = np.arange(n_bodies)
    for q in range(n_p):
        b = int(patches[q, Q_B])
        if b >= n_bodies:
            continue
        ra = int(patches[q, Q_A])
        while root[ra] != ra:
            root[ra] = root[root[ra]]
            ra = root[ra]
        rb = b
        while root[rb] != rb:
            root[rb] = root[root[rb]]
            rb = root[rb]
        if ra < rb:
            root[rb] = ra
        elif rb < ra:
            root[ra] = rb
    # Islands numbered by their first patch; the patches of each in their order.
    label = np.full(n_bodies, -1, dtype=np.int64)
    island = np.empty(n_p, dtype=np.int64)
    count = np.zeros(n_p + 1, dtype=np.int64)
    n_isl = 0
    for q in range(n_p):
        r = int(patches[q, Q_A])
        while root[r] != r:
            r = root[r]
        if label[r] < 0:
            label[r] = n_isl
            n_isl += 1
        island[q] = label[r]
        count[label[r] + 1] += 1
    kept = np.zeros(n_bodies, dtype=np.bool_)
    scr = patch_scratch()
    before = np.empty((contacts.shape[0], 3))
    level = np.empty(n_bodies, dtype=np.int64)
    sideways = np.empty(n_bodies, dtype=np.bool_)
    lone = 0
    for k in range(n_isl):
        if count[k + 1] == 1:
            lone += 1
    if lone == n_p or n_isl == 1:   # one group: the patches as they are, no copies
        coupled = lone < n_p
        _solve_group(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench,
                     shock, rot, warm, warm_n, slot, prm, stats, coupled, scr, before, level,
                     sideways, kept)
        if not coupled:
            finish_contacts(contacts, patches)
    else:
        first = np.empty(n_isl + 1, dtype=np.int64)
        first[0] = 0
        for k in range(n_isl):
            first[k + 1] = first[k] + count[k + 1]
        order = np.empty(n_p, dtype=np.int64)
        fill = first[:n_isl].copy()
        for q in range(n_p):
            order[fill[island[q]]] = q
            fill[island[q]] += 1
        if lone > 0:
            rows = np.empty(lone, dtype=np.int64)
            j = 0
            for q in range(n_p):
                if count[island[q] + 1] == 1:
                    rows[j] = q
                    j += 1
            group = _gather(patches, rows)
            _solve_group(group, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench,
                         shock, rot, warm, warm_n, slot, prm, stats, False, scr, before, level,
                         sideways, kept)
            finish_contacts(contacts, group)
            _scatter(patches, rows, group)
        for k in range(n_isl):
            if count[k + 1] == 1:
                continue
            rows = order[first[k]:first[k + 1]]
            group = _gather(patches, rows)
            _solve_group(group, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench,
                         shock, rot, warm, warm_n, slot, prm, stats, True, scr, before, level,
                         sideways, kept)
            _scatter(patches, rows, group)
    if slot >= 0:
        for i in range(n_bodies):
            if not kept[i]:
                warm_n[slot, i] = 0


@_jit
def _gather(patches, rows):
    """Return the rows ``rows`` of ``patches``, in that order (a copy)."""
    group = np.empty((rows.shape[0], patches.shape[1]))
    for j in range(rows.shape[0]):
        group[j, :] = patches[rows[j], :]
    return group


@_raw
def _scatter(patches, rows, group):
    """Write ``group`` back into the rows ``rows`` of ``patches``."""
    for j in range(rows.shape[0]):
        q = rows[j]
        for k in range(patches.shape[1]):
            patches[q, k] = group[j, k]


#: The fields a group's solve writes (see _group_rows): of a point, the target through its
#: friction (C_BIAS, C_LAMBDA, C_PHI, C_FRICTION), then C_TK_SET; of a patch, Q_FT through
#: Q_CACHED (its friction, couple, normal and whether Q_K and Q_PINV hold its response).
_SAVED_C = C_FRICTION + 3 - C_BIAS
_SAVED_Q = Q_CACHED + 1 - Q_FT


@_raw
def _group_rows(patches, contacts, vel, wrench, n_bodies, saved_c, saved_b, restore):
    """
    Copy a group's rows into ``saved_c``, ``saved_b``, or (``restore``) back from them.

    The rows: what its solve writes of its patches' points in ``contacts`` (``saved_c``, in
    patch order: the fields from C_BIAS through C_FRICTION, then C_TK_SET; the tangential
    responses C_TK are computed again once C_TK_SET is 0, the same bits), of its patches
    (``saved_b`` row ``q``'s columns 24 on: Q_FT through Q_CACHED; Q_K and Q_PINV are
    computed again once Q_CACHED is 0), and the velocities and wrenches of each patch's
    bodies (``saved_b`` row ``q``: ``vel`` then ``wrench`` of A, then of B).  A body of
    several patches is saved as often, the same values.  The rest of the rows no solve
    writes (a copy of the whole rows was ~12 % of a step of 1000 boxes side by side).
    """
    r = 0
    for q in range(patches.shape[0]):
        s0 = int(patches[q, Q_START])
        for c in range(s0, s0 + int(patches[q, Q_COUNT])):
            for k in range(_SAVED_C):
                if restore:
                    contacts[c, C_BIAS + k] = saved_c[r, k]
                else:
                    saved_c[r, k] = contacts[c, C_BIAS + k]
            if restore:
                contacts[c, C_TK_SET] = saved_c[r, _SAVED_C]
            else:
                saved_c[r, _SAVED_C] = contacts[c, C_TK_SET]
            r += 1
        for k in range(_SAVED_Q):
            if restore:
                patches[q, Q_FT + k] = saved_b[q, 24 + k]
            else:
                saved_b[q, 24 + k] = patches[q, Q_FT + k]
        for side in range(2):
            i = int(patches[q, Q_A]) if side == 0 else int(patches[q, Q_B])
            if i >= n_bodies:
                continue
            for k in range(6):
                if restore:
                    vel[i, k] = saved_b[q, 12 * side + k]
                    wrench[i, k] = saved_b[q, 12 * side + 6 + k]
                else:
                    saved_b[q, 12 * side + k] = vel[i, k]
                    saved_b[q, 12 * side + 6 + k] = wrench[i, k]


@_jit
def _solve_group(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, shock,
                 rot, warm, warm_n, slot, prm, stats, coupled, scr, before, level, sideways,
                 kept):
    """
    Sweep one group of patches (warm start, sweeps, cold retry), then propagate its shocks.

    ``coupled``: its patches share bodies (else each is solved exactly by one visit, with no
    warm start and no shock propagation).  ``scr``, ``before`` (C, 3), ``level`` (N,) and
    ``sideways`` (N,) are scratch, only the group's rows used; ``kept`` (N,) marks the bodies
    whose warm-start rows of ``slot`` the group rewrote (see :func:`_keep_warm`).
    """
    warmed = slot >= 0 and coupled
    if warmed:
        # Kept to start again from zero should the warm-started sweeps end with the normal
        # conditions violated by more than WARM_LEFT_MAX_M_S (see _residual): an impulse
        # carried over onto a point now separating would push it apart, adding energy; from
        # zero the sweeps err on the side of too little, which shock propagation makes up.
        # Within it the warm answer is the better one (from zero the sweeps end at their cap
        # and a resting column's bottom box read 3.5 N of contact force for its 9.81 N).
        # Only the group's rows: its points, and the velocities and wrenches of its bodies.
        n_rows = 0
        for q in range(patches.shape[0]):
            n_rows += int(patches[q, Q_COUNT])
        saved_c = np.empty((n_rows, _SAVED_C + 1))
        saved_b = np.empty((patches.shape[0], 24 + _SAVED_Q))
        _group_rows(patches, contacts, vel, wrench, n_bodies, saved_c, saved_b, False)
        started = _warm_start(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, wrench,
                              rot, warm, warm_n, slot, prm, sideways)
        swept = _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench,
                        scr, coupled, True, before)
        left = _residual(patches, contacts, vel, n_bodies, scr)
        # Kept either way: the sweeps go on from there next step, so a stack that needs more
        # sweeps than the cap (a tall column converges by ~0.97 a sweep) gets them over steps.
        _keep_warm(patches, contacts, rot, warm, warm_n, slot, kept)
        # (A group no point of which took a kept impulse was solved from zero already: its
        # sweeps were those of the retry, bit for bit.)
        if left > WARM_LEFT_MAX_M_S and started > 0:
            _group_rows(patches, contacts, vel, wrench, n_bodies, saved_c, saved_b, True)
            swept += _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x,
                             wrench, scr, coupled, False, before)
            stats[slot, ST_COLD] += 1.0
    else:
        swept = _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench,
                        scr, coupled, False, before)
    if coupled and slot >= 0:
        stats[slot, ST_STAGES] += 1.0
        stats[slot, ST_SWEEPS] += swept
        stats[slot, ST_PATCHES] += patches.shape[0]
    if not shock or not coupled:
        return
    _levels(patches, n_bodies, level)
    low = np.empty(patches.shape[0], dtype=np.int64)
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        low[q] = level[a] if b >= n_bodies else min(level[a], level[b])
    _shock(np.argsort(low, kind='mergesort'), level, patches, contacts, vel, inv_mass,
           inv_inertia_w, n_bodies, x, wrench, scr)


@_raw
def _shock(order, level, patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench,
           scr):
    """Solve the patches in ``order``, a patch's lower body held (see :func:`solve_stage`)."""
    for q in order:
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        wa = 1.0
        wb = 1.0
        if b < n_bodies:
            if level[a] < level[b]:
                wa = 0.0
            elif level[b] < level[a]:
                wb = 0.0
        solve_patch(q, patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wa, wb,
                    wrench, True, scr, True, False)


@_raw
def finish_contacts(contacts, patches):
    """Give each point its share ``λ_k / Σλ`` of its patch's friction impulse."""
    for q in range(patches.shape[0]):
        s0 = int(patches[q, Q_START])
        m = int(patches[q, Q_COUNT])
        total = 0.0
        for k in range(s0, s0 + m):
            total += contacts[k, C_LAMBDA]
        if total <= 0.0:
            continue
        for k in range(s0, s0 + m):
            share = contacts[k, C_LAMBDA] / total
            for d in range(3):
                contacts[k, C_FRICTION + d] = share * patches[q, Q_FT + d]
