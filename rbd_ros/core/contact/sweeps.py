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

:func:`solve_stage` sweeps over the patches (from the last step's impulses where patches share
bodies), then propagates shocks by levels of the contact graph, and writes the impulses back.

**Joints** (Weinstein, Teran, Fedkiw 2006; see ``/work/shared/reference/joints-weinstein.md``)
are solved by equal and opposite impulses like a patch, in :mod:`rbd_ros.core.contact.joints`:
post-stabilization in :func:`rbd_ros.core.contact.step.world_step` after the collision stage
and after the velocity update; pre-stabilization alternating with :func:`_sweeps` after
:func:`solve_stage` (``joint_sweeps``: a visit of all joints, a sweep of the patches, again).
Not here yet: a joint as an edge of :func:`_levels` (a body hanging from a joint one level
above its parent) and a visit per joint inside :func:`_sweeps` and :func:`_shock` with the
lower body held; limits as a clamp inside the joint's visit, as the normal impulses'
``λ >= 0``.
"""

import math

import numpy as np

from rbd_ros.core.contact.linalg import _mat_t_vec, _mat_vec, patch_scratch, SCR_FREE
from rbd_ros.core.contact.patch import (_collision_targets, _held, _idle, _normal_velocities,
                                        solve_patch)
from rbd_ros.core.contact.response import _apply, _point_velocity, _record
from rbd_ros.core.contact.rows import (_inl, _jit, _raw, C_BIAS, C_FRICTION, C_LAMBDA, C_NORMAL,
                                       C_RA, C_RB, Q_A, Q_B, Q_COUNT, Q_EPS, Q_FT, Q_MU, Q_START,
                                       ST_COLD, ST_PATCHES, ST_STAGES, ST_SWEEPS, SWEEP_TOL_M_S,
                                       SWEEPS, VELOCITY_TOL_M_S, W_B, W_COUNT, W_POINTS, W_SLOTS,
                                       W_STRIDE, WARM_COS_MIN,
                                       WARM_LEFT_MAX_M_S, WARM_MATCH_M)
from rbd_ros.core.layout import P_GRAVITY


@_jit
def _levels(patches, n_bodies):
    """Contact-graph level of every body: 1 on a static object, k + 1 on level k; else big."""
    big = n_bodies + 1
    level = np.full(n_bodies, big, dtype=np.int64)
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
    return level


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
    sideways[:] = False
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
        row = -1
        for j in range(warm_n[slot, a]):
            if warm[slot, a, j, W_B] == b:
                row = j
                break
        if row < 0:
            continue
        dyn_b = b < n_bodies
        s0 = int(patches[q, Q_START])
        m = int(patches[q, Q_COUNT])
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
def _keep_warm(patches, contacts, rot, warm, warm_n, slot):
    """Keep the stage's impulses in ``slot`` for the next step (see :data:`W_SLOTS`)."""
    warm_n[slot, :] = 0
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
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
    Gauss–Seidel sweeps over the patches, then (``shock``) one shock-propagation pass.

    ``slot`` >= 0: the stage's row of the warm-start table (see :data:`W_SLOTS`), read before
    the sweeps and rewritten after them, and of the counters ``stats`` (see
    :data:`ST_STAGES`); -1 for none.  Return whether patches share a body (then friction is
    per point, else per patch).
    """
    scr = patch_scratch()
    before = np.empty((contacts.shape[0], 3))  # scratch of _sweeps
    # Patches that share no body are independent: each is solved to convergence by its own
    # iterations, so one sweep is exact and shock propagation has nothing to order.
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
    warmed = slot >= 0 and coupled
    if warmed:
        # Kept to start again from zero should the warm-started sweeps end with the normal
        # conditions violated by more than WARM_LEFT_MAX_M_S (see _residual): an impulse
        # carried over onto a point now separating would push it apart, adding energy; from
        # zero the sweeps err on the side of too little, which shock propagation makes up.
        # Within it the warm answer is the better one (from zero the sweeps end at their cap
        # and a resting column's bottom box read 3.5 N of contact force for its 9.81 N).
        saved = (contacts.copy(), patches.copy(), vel.copy(), wrench.copy())
        started = _warm_start(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, wrench,
                              rot, warm, warm_n, slot, prm, np.empty(n_bodies, dtype=np.bool_))
        swept = _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench,
                        scr, coupled, True, before)
        left = _residual(patches, contacts, vel, n_bodies, scr)
        # Kept either way: the sweeps go on from there next step, so a stack that needs more
        # sweeps than the cap (a tall column converges by ~0.97 a sweep) gets them over steps.
        _keep_warm(patches, contacts, rot, warm, warm_n, slot)
        # (A stage no point of which took a kept impulse was solved from zero already: its
        # sweeps were those of the retry, bit for bit.)
        if left > WARM_LEFT_MAX_M_S and started > 0:
            contacts[:] = saved[0]
            patches[:] = saved[1]
            vel[:] = saved[2]
            wrench[:] = saved[3]
            swept += _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x,
                             wrench, scr, coupled, False, before)
            stats[slot, ST_COLD] += 1.0
    else:
        if slot >= 0:
            warm_n[slot, :] = 0
        swept = _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench,
                        scr, coupled, False, before)
    if coupled and slot >= 0:
        stats[slot, ST_STAGES] += 1.0
        stats[slot, ST_SWEEPS] += swept
        stats[slot, ST_PATCHES] += patches.shape[0]
    if not shock or not coupled:
        return coupled
    level = _levels(patches, n_bodies)
    low = np.empty(patches.shape[0], dtype=np.int64)
    for q in range(patches.shape[0]):
        a = int(patches[q, Q_A])
        b = int(patches[q, Q_B])
        low[q] = level[a] if b >= n_bodies else min(level[a], level[b])
    _shock(np.argsort(low, kind='mergesort'), level, patches, contacts, vel, inv_mass,
           inv_inertia_w, n_bodies, x, wrench, scr)
    return coupled


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
