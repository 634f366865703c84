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
The compiled contact step (Guendelman, Bridson, Fedkiw 2003): named stages over packed arrays.

One step, in the paper's order (:func:`world_step`):

1. **Collisions** (:data:`PHASE_COLLISION`): candidate poses from the current velocities,
   broad phase, narrow phase, and impulses with restitution ε on the current velocities.
   A pair with ε > 0 is a new collision at every visit of a sweep, its restitution taken
   from its approach velocity then (see :func:`solve_patch`), so a row of touching balls
   hands the motion on (Newton's cradle).
2. **Velocities**: the forces (gravity, wrenches, springs) through the integrator's velocity
   update: the whole step for symplectic Euler, the first half kick for ``midpoint_cayley``.
3. **Contacts** (:data:`PHASE_CONTACT`): candidates from the new velocities, impulses with
   ε = 0, Gauss–Seidel sweeps over the patches, then one **shock propagation** pass: bodies are
   put in levels of the contact graph from the static world up, and a patch between two
   levels is solved with the lower body held as if of infinite mass.  Where patches share
   bodies (a stack) the sweeps start from the normal impulses the same stage of the last
   step ended with (a **warm start**, :data:`W_SLOTS`); they stop when a sweep changes no
   point's relative velocity by more than :data:`SWEEP_TOL_M_S`.  So a resting stack's
   sweeps converge, in two or three, and each box's recorded contact force is its weight;
   from zero they ran to their cap and shock propagation made up the rest.
4. **Positions** with the final velocities.  ``midpoint_cayley`` (kick–drift–kick) then does
   its second half kick and a second contact stage, so the friction of each half kick acts on
   the velocity the drift uses: a box sliding to a stop decelerates by exactly ``μ g`` over
   every whole step and stops within O(h²) of the exact distance.

**Detection.** Every stage maps each body's contact points (its surface points; a sphere's
centre and a capsule's axis with their radius) to the candidate pose of the other shape and
evaluates φ there.  A point whose candidate φ is below :data:`MARGIN_M` is a contact with
the linear prediction ``φ_next = φ_cand + h (u_n − u_n0)``; its impulse keeps ``φ_next >= 0``
(so a falling body lands on the surface, not above it), while a point already inside
(``φ_now = φ_cand − h u_n0 < 0``) is pushed out by at most :data:`PUSH_FRACTION` of its depth
per step and no faster than :data:`PUSH_MAX_M_S`.  Against a plane only the points that can
be lowest are tested: a box's corners, a mesh's vertices; a cylinder's (its rims' lowest points
and the rim points a quarter turn on) and an ellipsoid's (its support point) in closed form.
Two boxes (bodies or a static box) take their points from :mod:`~rbd_ros.core.contact.box_box`
instead: the separating axis of least overlap, then the face of one clipped by the other's (or
one point edge on edge), all points with one normal.  A face resting on a face has the corners
of their overlap, at most eight before the reduction, where the sampled surface points gave
~100 a pair to try, keep and reduce, and points on the other box's edges needed
:func:`_consistent_normals`' repairs.

**Patches.** The points of one body pair are reduced to at most four (the deepest, the
farthest from it, then the two that span the largest area): the convex hull of a flat patch,
which is all a rigid contact needs.  Normal impulses are accumulated per point and clamped
to ``>= 0``.  Friction is decided per patch, not per point (four coplanar points make friction
statically indeterminate): the tangential impulse at the patch's normal-impulse-weighted
centre that makes the patch stick is accepted if it lies inside the cone
``|f_t| <= μ Σλ_n``; otherwise the patch slides with ``f_t = −μ Σλ_n û_t``, opposite to its
slip (Coulomb's law exactly, no linearised pyramid).  A torsional couple about the patch
normal sticks likewise up to ``μ Σ λ_k |r_k − c|``.

Everything is serial and in a fixed order (pairs sorted by body index), so results are
bit-identical run after run.

**Cost.** Three things keep a resting body cheap: a patch whose points approach no faster
than their targets (to :data:`IDLE_TOL_M_S`, the sweeps' tolerance, the one of the three that
changes results, at round-off) takes no impulse without building its response
(:func:`_idle`); a body's patch on a static object reuses its response ``K`` and
``K⁺`` while their inputs are the same bits (:data:`R_STATIC`); and a body's surface points
are tried in cells, a cell skipped when φ at its centre puts it out of reach (:func:`_one_way`).
``K⁺`` of a flat patch (one normal, three or more points spread in the plane) is in closed
form (:func:`_flat_response`); otherwise it comes from a Cholesky factor when ``K`` is well
conditioned, from a rank-one deflation when it lacks one rank, else from Jacobi
eigen-decomposition (:func:`_pinv_small`).

**Reference counts.** Numba counts references to arrays atomically: every array a function
takes, and every array passed to an inlined helper inside a loop with branches, costs two
atomic updates per call (its pruning pass removes them only in simple control flow).  For
1000 resting boxes that was 171 000 increments a step, and with their decrements ~60 % of
the step.  So every function that allocates nothing (the loops per pair, per patch, per
body, and the helpers they call) is compiled without reference counting (:data:`_raw`,
numba's ``_nrt=False``), and the functions that allocate (the broad phase's and the narrow
phase's buffers, a stage's scratch) only call them: about 3 000 are left a step.  A raw
function cannot call one that allocates (numba compiles the callee without reference
counting too), which is why :func:`_consistent_normals`, which sorts, is called from
:func:`narrow_phase` between :func:`_pair_points` and :func:`_pair_patch`.
"""

import math

import numpy as np

from rbd_ros.core import jitcache
from rbd_ros.core import kernels as kk
from rbd_ros.core.contact import box_box as bb
from rbd_ros.core.contact import kernels as ck
from rbd_ros.core.layout import (N_STATE, P_ANG_DAMPING, P_GRAVITY, P_INERTIA, P_INV_INERTIA,
                                 P_INV_MASS, P_LIN_DAMPING, S_OMEGA, S_POS, S_QUAT, S_VEL)

PHASE_COLLISION = 0
PHASE_CONTACT = 1
#: Candidate φ (m) below which a point is a (speculative) contact.
MARGIN_M = 1e-3
#: A point within this gap (m) of the other shape counts as touching now.
TOUCH_M = 1e-5
#: Share of a penetration depth the impulses remove per step, and the speed cap of that.
PUSH_FRACTION = 0.2
PUSH_MAX_M_S = 0.1
#: Gauss–Seidel sweeps over all patches per stage, and the iterations of one patch.
SWEEPS = 24
PATCH_ITERATIONS = 64
#: A sweep that changes no velocity by more than this (m/s) ends the stage early; a patch's
#: iterations end once its friction changes none by more.
VELOCITY_TOL_M_S = 1e-13
#: A sweep that changes no point's relative velocity by more than this (m/s) in all ends the
#: stage early too (see solve_stage).
SWEEP_TOL_M_S = 1e-12
#: A patch none of whose points approaches faster than its target by more than this (m/s)
#: takes no normal impulse (:func:`_idle`): the sweeps' own tolerance.  Below it a point may
#: sink at most this fast, until the push-out of its depth (20 % of it a step) outruns it:
#: at a depth of 5 h × this, 5e-15 m at 1 ms.  Boxes side by side, touching and pressing
#: nothing, have depths and relative velocities of round-off (~1e-17 m, ~1e-13 m/s): judged
#: exactly, about half their patches were solved in every sweep and all in shock propagation:
#: ~85 % of a step of 1000 of them (40 ms against 7.7 for MuJoCo).
IDLE_TOL_M_S = SWEEP_TOL_M_S
#: A point given its patch's normal takes its depth along it (see _consistent_normals) only
#: where that is deeper than its φ by more than this (m).  Differences at round-off are left
#: alone: they only reorder _reduce's near-ties, and a grid of boxes side by side, whose
#: diagonal neighbours meet edge to edge as wedges balanced at round-off, started to move
#: when they were taken (1000 boxes: 1e-8 J within 6 steps).  A flush stack can sink at most
#: this far before its corners show the depth.
FLUSH_DEPTH_MIN_M = 1e-12
#: ... and only where the step left the other shape along the patch normal: a step of length
#: ``s`` that leaves by a face at an angle α to it reads ``s (1 − cos α)`` too deep, which
#: may be at most this (m).  Boxes side by side meet their diagonal neighbours edge to edge;
#: before ck.EDGE_ROUNDOFF_M their patch normal could be tilted from the faces by 7°, which
#: read as 1.8 µm of depth.  The push-out could not remove it (the grid is jammed), so the
#: sweeps ran to their cap every stage: a step of 1000 such boxes took 3.5–7 s instead of
#: 0.3 s.  1e-11 m keeps a corner 5e-8 m outside the other box's side (α = 2e-4 rad) reading
#: the face's depth.
DEPTH_READ_ERROR_M = 1e-11
#: At most this many points per patch.
PATCH_POINTS = 4
#: Surface points are grouped in cells of this many, a cell skipped when its ball is out of
#: reach (see _one_way).
CHUNK_POINTS = 16
#: A Lipschitz bound of a mesh's φ: the trilinear interpolant of exact distances has
#: |∂φ/∂x_k| <= 1 in a cell (|∇φ| <= √3), and outside the grid box φ adds the distance to it.
PHI_LIPSCHITZ_MESH = 1.0 + math.sqrt(3.0)
#: Slack (m) on the skip test of a cell, against round-off in φ at its centre.
CULL_SLACK_M = 1e-9
#: How much depth counts against reach when _reduce picks a patch's extreme points (m/m):
#: 2 or more keeps a box under a push inside its cone on an equal box still; 10 let the
#: 5-layer pyramid at 10 ms drift 8 µm; 4 keeps both (and the 10-box column) at rest.
REDUCE_DEPTH_WEIGHT = 4.0

# Contact record fields (rows of the (C, N_CONTACT) float64 contact table).
C_A = 0          # body index of A
C_B = 1          # body index of B, or N + s for static object s
C_POINT = 2      # world contact point (current configuration), 3
C_NORMAL = 5     # unit normal: the impulse on A is along +n, 3
C_RA = 8         # lever arm from A's COM, 3
C_RB = 11        # lever arm from B's COM (0 for static), 3
C_BIAS = 14      # target: u_n >= bias after the stage (m/s)
C_LAMBDA = 15    # accumulated normal impulse (N·s)
C_PHI = 16       # candidate φ (m)
C_FRICTION = 17  # this point's share of the patch friction impulse (N·s), 3
C_PHASE = 20     # the stage: 0 collision, 1 first contact stage, 2 second
C_TARGET = 21    # the target without restitution (m/s): C_BIAS of a contact stage
C_TOUCH_U = 22   # restitution applies while u_n is below this (m/s): the point then ends the
#                  step within TOUCH_M of the other shape (see _collision_targets)
N_CONTACT = 23

# Patch record fields (rows of the (Q, N_PATCH) float64 patch table).
Q_A = 0
Q_B = 1
Q_START = 2      # first contact row
Q_COUNT = 3
Q_MU = 4
Q_FT = 5         # accumulated tangential friction impulse, world vector, 3
Q_MT = 8         # accumulated torsional couple about the patch normal (N·m·s)
Q_NORMAL = 9     # patch normal (unit, λ-weighted mean), 3
Q_CACHED = 12    # Q_K and Q_PINV hold this stage's normal response (both bodies free): 1.0
#                  computed in this stage, 2.0 taken from the response cache (R_*), else 0.0
Q_K = 13         # K_nn of the points, row-major PATCH_POINTS², fixed within a stage
Q_PINV = 29      # its pseudo-inverse, the same layout
Q_EPS = 45       # restitution of the pair in the collision stage, else 0 (see solve_patch)
N_PATCH = 46

# Response cache of a body's patch on a static object (rows of the (N, N_RESPONSE) table kept
# from stage to stage and step to step): the patch's K and pseudo-inverse with what they are a
# function of.  A body at rest meets the same lever arms, normals and inverse inertia from
# one stage to the next, bit for bit (always from the last stage of a step to the first of
# the next, which no drift separates); a hit reuses the values, so results are the same as
# recomputing them, whatever the cache held before.
R_STATIC = 0     # the static object's index (N + s), or -1 for none
R_COUNT = 1      # the patch's points
R_ROWS = 2       # per point: lever arm from A's COM (3) and normal (3)
R_INV_MASS = R_ROWS + 6 * PATCH_POINTS
R_INV_INERTIA = R_INV_MASS + 1   # R I_b⁻¹ Rᵀ of A, row-major, 9
R_K = R_INV_INERTIA + 9
R_PINV = R_K + PATCH_POINTS * PATCH_POINTS
N_RESPONSE = R_PINV + PATCH_POINTS * PATCH_POINTS

# Warm start of coupled contact stages (the (3, N, W_SLOTS, W_FIELDS) table and its (3, N)
# counts, kept from step to step, one row per stage of the step): a stage whose patches share
# bodies (a stack) starts its Gauss–Seidel sweeps from the normal impulses the same stage of
# the last step ended its sweeps with (before shock propagation), instead of from zero.  From
# zero the sweeps converge by ~0.8 a sweep in a pyramid and ran to their cap every step, so
# shock propagation finished the job and recorded the lower boxes' reactions short (it
# moves only the upper body); from the last step's answer a resting stack is done in two or
# three sweeps.  Rows per body A (the pair's lower index), one per patch, at most W_SLOTS.
# A point takes the λ of the last step's point of the same pair within WARM_MATCH_M in A's
# body frame, and only where its normal is within 60° of gravity (WARM_COS_MIN): what holds
# weight up.  A body with a neighbour beside it (a patch whose normal is not within 60° of
# gravity) carries its load over, not how the load is spread: the matched points of its
# patches all start from the mean of their kept impulses.  Carried point by point, a spread
# that leaned a box (more weight on its outer corners, neighbours pressing its top) leaned
# it again the next step: boxes side by side built an arch pressing each other at the top,
# held by the floor's friction, ~20 % stronger a step, until the sweeps ran to their cap
# every stage (1000 boxes: 3.5–7 s a step from step ~55).  Elsewhere the spread is carried:
# a pyramid's lower boxes bear their loads off centre, and from the mean its sweeps ended
# short of converged every step (recorded reactions off by 0.16 N, as from zero).
# Sideways contacts and friction start from zero: carried over, they let boxes side by side
# squeeze each other, held by the floor's friction, until the squeeze let go.
# A warm-started stage whose answer still violates the normal conditions by more than
# WARM_LEFT_MAX_M_S (see _residual) is solved again from zero (see solve_stage).
W_SLOTS = 8
W_B = 0          # the other body (N + s for a static object)
W_COUNT = 1      # the patch's points
W_POINTS = 2     # per point: from A's COM in A's frame (3), then λ
W_STRIDE = 4
W_FIELDS = W_POINTS + W_STRIDE * PATCH_POINTS
WARM_MATCH_M = 1e-4
WARM_COS_MIN = 0.5
WARM_LEFT_MAX_M_S = 1e-6

_jit = jitcache.kernel()
_inl = jitcache.kernel(inline='always')
#: Functions that allocate nothing (the loops per pair, per patch, per body) are compiled
#: without numba's reference counting (see the module docstring, "Reference counts").
_raw = jitcache.kernel(_nrt=False)


_cross = kk._cross  # the free-body kernel's, not a second copy


@_inl
def _mat_vec(m, i, x, y, z):
    """``m[i] @ v`` for a (N, 3, 3) array."""
    return (m[i, 0, 0] * x + m[i, 0, 1] * y + m[i, 0, 2] * z,
            m[i, 1, 0] * x + m[i, 1, 1] * y + m[i, 1, 2] * z,
            m[i, 2, 0] * x + m[i, 2, 1] * y + m[i, 2, 2] * z)


@_inl
def _mat_t_vec(m, i, x, y, z):
    """``m[i].T @ v`` for a (N, 3, 3) array."""
    return (m[i, 0, 0] * x + m[i, 1, 0] * y + m[i, 2, 0] * z,
            m[i, 0, 1] * x + m[i, 1, 1] * y + m[i, 2, 1] * z,
            m[i, 0, 2] * x + m[i, 1, 2] * y + m[i, 2, 2] * z)


@_inl
def _set_rotation(out, i, qw, qx, qy, qz):
    """Write ``R(q)`` into ``out[i]`` (q unit)."""
    out[i, 0, 0] = 1.0 - 2.0 * (qy * qy + qz * qz)
    out[i, 0, 1] = 2.0 * (qx * qy - qw * qz)
    out[i, 0, 2] = 2.0 * (qx * qz + qw * qy)
    out[i, 1, 0] = 2.0 * (qx * qy + qw * qz)
    out[i, 1, 1] = 1.0 - 2.0 * (qx * qx + qz * qz)
    out[i, 1, 2] = 2.0 * (qy * qz - qw * qx)
    out[i, 2, 0] = 2.0 * (qx * qz - qw * qy)
    out[i, 2, 1] = 2.0 * (qy * qz + qw * qx)
    out[i, 2, 2] = 1.0 - 2.0 * (qx * qx + qy * qy)


# ---------------------------------------------------------------------------------------------
# Poses: current and candidate, world velocities and inverse inertias.


@_raw
def prepare_bodies(x, prm, vel, inv_mass, inv_inertia_w, rot, pos_c, rot_c, h, same_pose):
    """
    Fill the per-body arrays a stage reads from the state ``x`` (velocities as stored there).

    ``vel`` (N, 6): ``v_w`` and ``ω_w``; ``inv_mass`` (N,); ``inv_inertia_w`` (N, 3, 3)
    ``R I_b⁻¹ Rᵀ``; ``rot`` (N, 3, 3) current ``R``; ``pos_c`` (N, 3) and ``rot_c`` the
    candidate pose after ``h`` at these velocities (exact rotation by ``h ω``).
    ``same_pose``: ``rot`` and ``inv_inertia_w`` already hold this pose's values (the last
    stage saw the same orientations and parameters), so they are kept.
    """
    shared = prm.shape[1] == 1
    for i in range(x.shape[1]):
        j = 0 if shared else i
        qw, qx, qy, qz = x[S_QUAT, i], x[S_QUAT + 1, i], x[S_QUAT + 2, i], x[S_QUAT + 3, i]
        if not same_pose:
            _set_rotation(rot, i, qw, qx, qy, qz)
        wbx, wby, wbz = x[S_OMEGA, i], x[S_OMEGA + 1, i], x[S_OMEGA + 2, i]
        wx, wy, wz = _mat_vec(rot, i, wbx, wby, wbz)
        vel[i, 0] = x[S_VEL, i]
        vel[i, 1] = x[S_VEL + 1, i]
        vel[i, 2] = x[S_VEL + 2, i]
        vel[i, 3] = wx
        vel[i, 4] = wy
        vel[i, 5] = wz
        inv_mass[i] = prm[P_INV_MASS, j]
        if not same_pose:
            for r in range(3):
                for c in range(3):
                    acc = 0.0
                    for m in range(3):
                        for n in range(3):
                            acc += (rot[i, r, m] * prm[P_INV_INERTIA + 3 * m + n, j]
                                    * rot[i, c, n])
                    inv_inertia_w[i, r, c] = acc
        for k in range(3):
            pos_c[i, k] = x[S_POS + k, i] + h * vel[i, k]
        dw, dx, dy, dz = kk._quat_exp_half(wbx, wby, wbz, h)
        cw, cx, cy, cz = kk._qmul(qw, qx, qy, qz, dw, dx, dy, dz)
        cw, cx, cy, cz = kk._normalize_q(cw, cx, cy, cz)
        _set_rotation(rot_c, i, cw, cx, cy, cz)


@_raw
def store_velocities(x, prm, vel, touched):
    """Write ``v_w`` and ``ω_b = Rᵀ ω_w`` of the bodies a stage touched back into ``x``."""
    for i in range(x.shape[1]):
        if not touched[i]:
            continue
        x[S_VEL, i] = vel[i, 0]
        x[S_VEL + 1, i] = vel[i, 1]
        x[S_VEL + 2, i] = vel[i, 2]
        qw, qx, qy, qz = x[S_QUAT, i], x[S_QUAT + 1, i], x[S_QUAT + 2, i], x[S_QUAT + 3, i]
        bx, by, bz = kk._rotate_inv(qw, qx, qy, qz, vel[i, 3], vel[i, 4], vel[i, 5])
        x[S_OMEGA, i] = bx
        x[S_OMEGA + 1, i] = by
        x[S_OMEGA + 2, i] = bz


# ---------------------------------------------------------------------------------------------
# Broad phase: sort and sweep along x over the bodies; every body against each static object.


@_raw
def _sweep(order, lo, hi, pairs):
    """
    Write the pairs whose boxes ``lo``, ``hi`` overlap into ``pairs``, swept in ``order``.

    Return how many overlap; only as many as ``pairs`` has rows are written.
    """
    n = order.shape[0]
    count = 0
    for oi in range(n):
        a = order[oi]
        for oj in range(oi + 1, n):
            b = order[oj]
            if lo[b, 0] > hi[a, 0]:
                break
            if (lo[b, 1] > hi[a, 1] or lo[a, 1] > hi[b, 1]
                    or lo[b, 2] > hi[a, 2] or lo[a, 2] > hi[b, 2]):
                continue
            if count < pairs.shape[0]:
                pairs[count, 0] = min(a, b)
                pairs[count, 1] = max(a, b)
            count += 1
    return count


@_jit
def broad_phase(x, pos_c, bound_r, n_bodies, st_kind, st_params, st_lo, st_hi, margin):
    """
    Return the candidate pairs ``(P, 2)`` int64, in a fixed order.

    Body-body pairs ``(a, b)`` with ``a < b`` sorted, then body-static ``(a, N + s)``.

    Each body's box holds its bounding ball at the current and the candidate pose, grown by
    ``margin``; bodies are sorted by the low x of their box and swept, so the cost is
    O(N log N + pairs).
    """
    n = n_bodies
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    for i in range(n):
        r = bound_r[i] + margin
        for k in range(3):
            a = x[S_POS + k, i]
            b = pos_c[i, k]
            lo[i, k] = min(a, b) - r
            hi[i, k] = max(a, b) + r
    order = np.argsort(lo[:, 0], kind='mergesort')
    pairs = np.empty((4 * n + 16, 2), dtype=np.int64)
    count = _sweep(order, lo, hi, pairs)
    if count > pairs.shape[0]:  # more overlaps than room: sweep again with room for all
        pairs = np.empty((count, 2), dtype=np.int64)
        _sweep(order, lo, hi, pairs)
    body_pairs = pairs[:count]
    # Fixed processing order whatever the sort did with ties: by (a, b).
    key = body_pairs[:, 0] * n + body_pairs[:, 1]
    body_pairs = body_pairs[np.argsort(key, kind='mergesort')]
    statics = np.empty((n * st_kind.shape[0], 2), dtype=np.int64)
    ns = 0
    for a in range(n):
        for s in range(st_kind.shape[0]):
            if st_kind[s] == ck.KIND_PLANE:
                nx, ny, nz, d = st_params[s, 0], st_params[s, 1], st_params[s, 2], st_params[s, 3]
                near = min(nx * x[S_POS, a] + ny * x[S_POS + 1, a] + nz * x[S_POS + 2, a],
                           nx * pos_c[a, 0] + ny * pos_c[a, 1] + nz * pos_c[a, 2]) - d
                if near > bound_r[a] + margin:
                    continue
            elif (lo[a, 0] > st_hi[s, 0] or st_lo[s, 0] > hi[a, 0]
                  or lo[a, 1] > st_hi[s, 1] or st_lo[s, 1] > hi[a, 1]
                  or lo[a, 2] > st_hi[s, 2] or st_lo[s, 2] > hi[a, 2]):
                continue
            statics[ns, 0] = a
            statics[ns, 1] = n + s
            ns += 1
    out = np.empty((body_pairs.shape[0] + ns, 2), dtype=np.int64)
    out[:body_pairs.shape[0]] = body_pairs
    out[body_pairs.shape[0]:] = statics[:ns]
    return out


# ---------------------------------------------------------------------------------------------
# Narrow phase: points of one shape against the φ of the other, at the candidate poses.


@_inl
def _grid_of(grid_data, grid_off, grid_dim, s):
    o = grid_off[s]
    nx, ny, nz = grid_dim[s, 0], grid_dim[s, 1], grid_dim[s, 2]
    return grid_data[o:o + nx * ny * nz].reshape((nx, ny, nz))


@_inl
def _push_point(buf, count, phi, rx, ry, rz, pos_x, ix, gwx, gwy, gwz, lx, ly, lz, flip):
    """Append a row ``[φ, point_w(3), n_w(3), point_y(3), flip]`` to ``buf`` (point = pos + r)."""
    buf[count, 0] = phi
    buf[count, 1] = pos_x[ix, 0] + rx
    buf[count, 2] = pos_x[ix, 1] + ry
    buf[count, 3] = pos_x[ix, 2] + rz
    buf[count, 4] = flip * gwx
    buf[count, 5] = flip * gwy
    buf[count, 6] = flip * gwz
    buf[count, 7] = lx
    buf[count, 8] = ly
    buf[count, 9] = lz
    buf[count, 10] = flip
    return count + 1


@_raw
def _one_way(sx, sy, pts, pt_off, balls, ball_off, cell_of, near, pt_radius, kinds, sparams,
             grid_data, grid_off, grid_dim, rot_x, pos_x, rot_xc, pos_xc, ix, rot_yc, pos_yc,
             iy, margin, buf, count, flip):
    """
    Append the points of shape ``sx`` that come near shape ``sy`` (not a plane) to ``buf``.

    Points of ``sx`` (pose index ``ix``) within ``margin`` of ``sy`` at the candidate poses
    become rows ``[φ, point_w(3), n_w(3), point_y(3), flip]``: ``n_w = flip ∇φ_y`` in the
    world, the point in y's candidate frame.  ``buf`` has room for every point.  Return the
    new count.

    The points are grouped in cells of at most :data:`CHUNK_POINTS` with a ball around each
    (``balls``, ``ball_off`` per shape; ``cell_of`` per point, its cell's index among its
    shape's cells): a cell is skipped when φ at its centre, less the ball's radius times φ's
    Lipschitz bound, is beyond the margin, for then none of its points is within reach.  The
    points left are tried in their own order, so the rows are exactly those without the
    test.  ``near`` is scratch, a flag per cell of ``sx``.
    """
    radius = pt_radius[sx]
    kind = kinds[sy]
    grid = _grid_of(grid_data, grid_off, grid_dim, sy)
    prm = sparams[sy]
    lipschitz = PHI_LIPSCHITZ_MESH if kind == ck.KIND_MESH else 1.0
    c0 = ball_off[sx]
    # Every cell's flag is set before it is read.  A shape of one cell (a sphere's centre, a
    # small capsule's axis) is simply tried: its test would cost what trying it costs.
    near[0] = True
    first = c0 + 1 if ball_off[sx + 1] - c0 == 1 else c0
    for ci in range(first, ball_off[sx + 1]):
        wx, wy, wz = _mat_vec(rot_xc, ix, balls[ci, 0], balls[ci, 1], balls[ci, 2])
        lx, ly, lz = _mat_t_vec(rot_yc, iy, wx + pos_xc[ix, 0] - pos_yc[iy, 0],
                                wy + pos_xc[ix, 1] - pos_yc[iy, 1],
                                wz + pos_xc[ix, 2] - pos_yc[iy, 2])
        phi = ck.phi_grad(kind, prm, grid, lx, ly, lz)[0]
        near[ci - c0] = phi - radius - lipschitz * balls[ci, 3] < margin + CULL_SLACK_M
    for n in range(pt_off[sx], pt_off[sx + 1]):
        if not near[cell_of[n]]:
            continue
        bx, by, bz = pts[n, 0], pts[n, 1], pts[n, 2]
        # Candidate world point, then into y's candidate frame.
        wx, wy, wz = _mat_vec(rot_xc, ix, bx, by, bz)
        wx, wy, wz = wx + pos_xc[ix, 0], wy + pos_xc[ix, 1], wz + pos_xc[ix, 2]
        lx, ly, lz = _mat_t_vec(rot_yc, iy, wx - pos_yc[iy, 0], wy - pos_yc[iy, 1],
                                wz - pos_yc[iy, 2])
        phi, gx, gy, gz = ck.phi_grad(kind, prm, grid, lx, ly, lz)
        phi -= radius
        if not phi < margin:
            continue
        gwx, gwy, gwz = _mat_vec(rot_yc, iy, gx, gy, gz)
        # The contact point on x's surface in the current configuration.
        rx, ry, rz = _mat_vec(rot_x, ix, bx, by, bz)
        count = _push_point(buf, count, phi, rx - radius * gwx, ry - radius * gwy,
                            rz - radius * gwz, pos_x, ix, gwx, gwy, gwz, lx, ly, lz, flip)
    return count


@_raw
def _box_points(a, b, sparams, pose_r, pose_p, pose_rc, pose_pc, margin, clip, buf):
    """
    Fill ``buf`` with the points of boxes ``a`` and ``b`` as :func:`_one_way` would.

    The points and their depths come from :func:`box_box.box_box` at the candidate poses:
    points of one box's face clipped by the other's (or one point edge on edge), all with the
    one normal of the separating axis.  Each is a material point of its box, so its row has
    where that point is now.  Return the count.
    """
    count, nx, ny, nz, ix = bb.box_box(sparams, pose_rc, pose_pc, a, b, margin, clip, buf)
    iy = b if ix == a else a
    flip = 1.0 if ix == a else -1.0
    for k in range(count):
        bx, by, bz = _mat_t_vec(pose_rc, ix, buf[k, 1] - pose_pc[ix, 0],
                                buf[k, 2] - pose_pc[ix, 1], buf[k, 3] - pose_pc[ix, 2])
        rx, ry, rz = _mat_vec(pose_r, ix, bx, by, bz)
        lx, ly, lz = _mat_t_vec(pose_rc, iy, buf[k, 1] - pose_pc[iy, 0],
                                buf[k, 2] - pose_pc[iy, 1], buf[k, 3] - pose_pc[iy, 2])
        _push_point(buf, k, buf[k, 0], rx, ry, rz, pose_p, ix, flip * nx, flip * ny,
                    flip * nz, lx, ly, lz, flip)
    return count


#: A cylinder tilted less than this (rad) from a plane's normal rests on the points of its rim
#: at fixed angles in its frame (the lowest point's direction is round-off there).
RIM_UPRIGHT_RAD = 1e-9


@_inl
def _rim_angle(nx, ny):
    """Return the angle in a cylinder's frame of its rim's lowest point for the normal ``n``."""
    if nx * nx + ny * ny <= RIM_UPRIGHT_RAD * RIM_UPRIGHT_RAD:
        return 0.0
    return math.atan2(-ny, -nx)


@_inl
def _support_ellipsoid(sparams, s, nx, ny, nz):
    """Return the point of ellipsoid ``s`` lowest along the unit normal ``n`` (its frame)."""
    ax, ay, az = sparams[s, 0] * nx, sparams[s, 1] * ny, sparams[s, 2] * nz
    size = math.sqrt(ax * ax + ay * ay + az * az)
    return -sparams[s, 0] * ax / size, -sparams[s, 1] * ay / size, -sparams[s, 2] * az / size


@_inl
def _push_plane_point(buf, count, phi, bx, by, bz, cx, cy, cz, radius, rot_x, pos_x, rot_xc,
                      pos_xc, ix, rot_yc, pos_yc, iy, gwx, gwy, gwz):
    """
    Append a point of x near the plane y (normal ``gw``) to ``buf`` as :func:`_push_point`.

    ``b`` (x's frame) is the point in the candidate pose, at φ; ``c`` (x's frame) is where the
    impulse acts in the current pose (``b`` for a material point), ``radius`` below it.
    """
    wx, wy, wz = _mat_vec(rot_xc, ix, bx, by, bz)
    lx, ly, lz = _mat_t_vec(rot_yc, iy, wx + pos_xc[ix, 0] - pos_yc[iy, 0],
                            wy + pos_xc[ix, 1] - pos_yc[iy, 1],
                            wz + pos_xc[ix, 2] - pos_yc[iy, 2])
    rx, ry, rz = _mat_vec(rot_x, ix, cx, cy, cz)
    return _push_point(buf, count, phi, rx - radius * gwx, ry - radius * gwy,
                       rz - radius * gwz, pos_x, ix, gwx, gwy, gwz, lx, ly, lz, 1.0)


@_inl
def _plane_points(sx, sy, kinds, ppts, ppt_off, pt_radius, sparams, rot_x, pos_x, rot_xc,
                  pos_xc, ix, rot_yc, pos_yc, iy, margin, buf):
    """
    Fill ``buf`` with the points of shape ``sx`` near the plane ``sy`` as :func:`_one_way`.

    A plane's φ is linear: ``φ(b) = n_x · b + offset`` for a point ``b`` in x's frame, with
    the plane normal ``n_x`` in x's candidate frame (3 products a point instead of a pose
    change).  Only the points that can be lowest (``ppts``) are tried; a cylinder's and an
    ellipsoid's are in closed form instead (a cylinder's sampled rims made it roll as a
    polygon: down 20° for 1 s it fell 10 % short at 1 ms, 18 % at 10 ms).  Return the count.
    """
    radius = pt_radius[sx]
    gwx, gwy, gwz = _mat_vec(rot_yc, iy, sparams[sy, 0], sparams[sy, 1], sparams[sy, 2])
    pnx, pny, pnz = _mat_t_vec(rot_xc, ix, gwx, gwy, gwz)
    offset = (gwx * (pos_xc[ix, 0] - pos_yc[iy, 0]) + gwy * (pos_xc[ix, 1] - pos_yc[iy, 1])
              + gwz * (pos_xc[ix, 2] - pos_yc[iy, 2]) - sparams[sy, 3] - radius)
    count = 0
    if kinds[sx] == ck.KIND_CYLINDER:
        # Each rim circle's lowest point in closed form, and the points a quarter, a half and
        # three quarters round from it (a cylinder on its cap rests on those four).  φ comes
        # from the candidate pose; the impulse acts where the same point is now (its angle
        # from the current normal): a rolling cylinder turns h ω a step, and the candidate's
        # lowest material point, ahead of the contact line now, would brake it.
        qnx, qny, qnz = _mat_t_vec(rot_x, ix, gwx, gwy, gwz)
        r, hl = sparams[sx, 0], sparams[sx, 1]
        cand = _rim_angle(pnx, pny)
        now = _rim_angle(qnx, qny)
        for side in (-1.0, 1.0):
            for quarter in range(4):
                turn = 0.5 * math.pi * quarter
                bx, by, bz = r * math.cos(cand + turn), r * math.sin(cand + turn), side * hl
                phi = pnx * bx + pny * by + pnz * bz + offset
                if phi < margin:
                    count = _push_plane_point(
                        buf, count, phi, bx, by, bz, r * math.cos(now + turn),
                        r * math.sin(now + turn), bz, radius, rot_x, pos_x, rot_xc, pos_xc,
                        ix, rot_yc, pos_yc, iy, gwx, gwy, gwz)
        return count
    if kinds[sx] == ck.KIND_ELLIPSOID:
        # The support point −A² n / |A n| (A = diag of the semi-axes), as for the cylinder.
        bx, by, bz = _support_ellipsoid(sparams, sx, pnx, pny, pnz)
        phi = pnx * bx + pny * by + pnz * bz + offset
        if phi < margin:
            qnx, qny, qnz = _mat_t_vec(rot_x, ix, gwx, gwy, gwz)
            cx, cy, cz = _support_ellipsoid(sparams, sx, qnx, qny, qnz)
            count = _push_plane_point(buf, count, phi, bx, by, bz, cx, cy, cz, radius, rot_x,
                                      pos_x, rot_xc, pos_xc, ix, rot_yc, pos_yc, iy, gwx, gwy,
                                      gwz)
        return count
    for n in range(ppt_off[sx], ppt_off[sx + 1]):
        bx, by, bz = ppts[n, 0], ppts[n, 1], ppts[n, 2]
        phi = pnx * bx + pny * by + pnz * bz + offset
        if phi < margin:
            count = _push_plane_point(buf, count, phi, bx, by, bz, bx, by, bz, radius, rot_x,
                                      pos_x, rot_xc, pos_xc, ix, rot_yc, pos_yc, iy, gwx, gwy,
                                      gwz)
    return count


@_inl
def _one_normal(rows, first, count, col):
    """
    Tell whether rows ``first … first+count-1`` have one normal (columns ``col … col+2``).

    A face on a plane or a face: ``buf`` rows in the narrow phase, a patch's contact rows in
    :func:`_flat_response`.
    """
    for k in range(first + 1, first + count):
        if (rows[k, col] != rows[first, col] or rows[k, col + 1] != rows[first, col + 1]
                or rows[k, col + 2] != rows[first, col + 2]):
            return False
    return True


@_jit
def _consistent_normals(buf, count, a, b, kinds, sparams, grid_data, grid_off, grid_dim,
                        pose_rc):
    """
    Give points on an edge or corner of the other shape their patch's normal; return it.

    (Two boxes never come here: :func:`_box_points` gives their points one normal.  The box
    examples below are how this was found; it serves every other pair, a mesh's or a
    cylinder's face on a box's, say.)

    ∇φ is ambiguous where the shape it is taken of has an edge or a corner: a box placed
    exactly on another has its bottom edges on the lower box's top edges, where φ's gradient
    may point sideways, and a corner a hair outside the lower box's footprint gets a gradient
    tilted by anything up to 90° from the round-off of its position.

    The patch normal ``n̄``: the candidates are the deepest point of each distinct normal, in
    order of depth, up to 16 normals (where faces lie flush every point ties in φ to
    round-off, so the deepest 16 points may all be edge points).  The candidate with the
    largest depth-weighted support within ~25° (cos > 0.9) gives the patch's direction;
    among the candidates in that cone, the one whose own normal has the largest support (to
    ~1e-6 rad: one face seen from either shape) is ``n̄``: the face's normal, not a tilted
    edge normal in the cone's middle, whose wide support also takes in the tilted normals on
    its side.  A tilt matters however small: one below atan μ makes the patch a self-locking
    wedge whose normal and friction impulses can grow without bound.

    Any other point takes ``n̄`` if ``n̄`` is also a normal of the surface there (in its
    normal cone): a step of :data:`MARGIN_M` / 4 out of the other shape along ``n̄`` raises
    φ by the step (to 1 %; on a smooth surface that holds within ~8° of ``n̄``).  Its φ then
    becomes its depth along ``n̄`` as the step measures it, ``φ(p + step n̄) − step``, where
    that is deeper by more than :data:`FLUSH_DEPTH_MIN_M` (and by at most 1 % of the step,
    which the cone test allows) and the step left the other shape along ``n̄`` (∇φ there is
    ``n̄`` to within :data:`DEPTH_READ_ERROR_M`): an upper box's corner on the lower box's
    side plane has φ = the distance to that side, about 0, however deep it is below the top
    face, so a sinking would show no depth to push out and the stack would creep down.  (A
    point a distance e outside the other box's side reads ~e² / (2 step) less than the
    face's depth: at most 1.3e-8 m where the cone test passes, a fixed offset, not a creep.)
    A point deeper than the step stays on that side plane for the whole step (a box dropped
    onto an equal box, its corners on the lower box's side faces, or two equal boxes meeting
    face on): where the patch is deeper than the step, such a point steps out from the
    patch's depth instead and takes ``n̄`` if it has left the other shape there and φ then
    rises along ``n̄`` as the step (its depth is the difference).  Before, those corners kept
    their side normals and φ = 0: one interior point took the whole impulse, off centre (two
    equal boxes meeting face on at ε = 1 came apart spinning with 57 % of the energy; a box
    dropped on an equal one came to rest tilted, 1.7 mm deep in it at 10 ms).  A peg
    touching the side of a hole fails both tests and keeps its own normal and φ.
    """
    order = np.argsort(buf[:count, 0])
    cand = np.empty(16, dtype=np.int64)
    n_cand = 0
    for ii in range(count):
        i = order[ii]
        fresh = True
        for c in range(n_cand):
            j = cand[c]
            if buf[i, 4] == buf[j, 4] and buf[i, 5] == buf[j, 5] and buf[i, 6] == buf[j, 6]:
                fresh = False
                break
        if fresh:
            cand[n_cand] = i
            n_cand += 1
            if n_cand == 16:
                break
    wide = np.empty(16)
    tight = np.empty(16)
    best = 0
    for c in range(n_cand):
        i = cand[c]
        w = 0.0
        t = 0.0
        for k in range(count):
            d = buf[k, 4] * buf[i, 4] + buf[k, 5] * buf[i, 5] + buf[k, 6] * buf[i, 6]
            if d > 0.9:
                w += MARGIN_M - buf[k, 0]
                if d > 1.0 - 1e-12:
                    t += MARGIN_M - buf[k, 0]
        wide[c] = w
        tight[c] = t
        if w > wide[best]:
            best = c
    i = cand[best]
    top = best
    for c in range(n_cand):
        j = cand[c]
        if (tight[c] > tight[top] and buf[j, 4] * buf[i, 4] + buf[j, 5] * buf[i, 5]
                + buf[j, 6] * buf[i, 6] > 0.9):
            top = c
    best = cand[top]
    sx, sy, sz = buf[best, 4], buf[best, 5], buf[best, 6]
    step = 0.25 * MARGIN_M
    # A step that leaves the other shape from as deep as the patch's deepest point.
    reach = step - min(buf[order[0], 0], 0.0)
    for k in range(count):
        if buf[k, 4] == sx and buf[k, 5] == sy and buf[k, 6] == sz:
            continue
        # The shape whose φ gave this point: b for flip +1 (n = ∇φ_b), a for flip −1.
        y = b if buf[k, 10] > 0.0 else a
        # Out of y along n̄ (+n̄ for y = b, whose outward normal it is; −n̄ for y = a).
        dx, dy, dz = buf[k, 10] * sx, buf[k, 10] * sy, buf[k, 10] * sz
        lx, ly, lz = _mat_t_vec(pose_rc, y, dx, dy, dz)
        grid = _grid_of(grid_data, grid_off, grid_dim, y)
        phi0 = ck.phi_grad(kinds[y], sparams[y], grid, buf[k, 7], buf[k, 8], buf[k, 9])[0]
        phi1, gx, gy, gz = ck.phi_grad(kinds[y], sparams[y], grid, buf[k, 7] + step * lx,
                                       buf[k, 8] + step * ly, buf[k, 9] + step * lz)
        out = step
        if abs((phi1 - phi0) - step) > 0.01 * step and reach > step:
            # Deeper than the step, a point on the other shape's side plane (a box dropped
            # onto an equal box: its bottom corners lie on the lower box's side faces) stays
            # on it for the whole step, φ = 0.  Step out from the patch's depth instead:
            # where n̄ is the normal the point leaves by, φ then rises along n̄ as the step.
            out = reach
            phi1, gx, gy, gz = ck.phi_grad(kinds[y], sparams[y], grid, buf[k, 7] + reach * lx,
                                           buf[k, 8] + reach * ly, buf[k, 9] + reach * lz)
            phi2 = ck.phi_grad(kinds[y], sparams[y], grid, buf[k, 7] + (reach + step) * lx,
                               buf[k, 8] + (reach + step) * ly,
                               buf[k, 9] + (reach + step) * lz)[0]
            if not (phi1 > 0.0 and abs((phi2 - phi1) - step) <= 0.01 * step):
                continue
        elif abs((phi1 - phi0) - step) > 0.01 * step:
            continue
        buf[k, 4] = sx
        buf[k, 5] = sy
        buf[k, 6] = sz
        # (buf's φ is phi0 less the point radius: shift it by the same difference.)
        # (A step that left by a face tilted from n̄ reads too deep: see DEPTH_READ_ERROR_M.)
        deeper = (phi1 - out) - phi0
        if (deeper < -FLUSH_DEPTH_MIN_M
                and out * (1.0 - (gx * lx + gy * ly + gz * lz)) <= DEPTH_READ_ERROR_M):
            buf[k, 0] += deeper
    return sx, sy, sz


@_raw
def _reduce(buf, count, keep, nx, ny, nz):
    """
    Choose up to PATCH_POINTS rows of ``buf[:count]`` spanning the patch; fill ``keep``.

    Areas are measured across the patch normal ``n`` (not a point's own normal, which may be
    an edge's sideways one).
    """
    if count <= PATCH_POINTS:
        for k in range(count):
            keep[k] = k
        return count
    best = 0
    for k in range(1, count):
        if buf[k, 0] < buf[best, 0]:
            best = k
    keep[0] = best
    # Extreme points are scored by distance less REDUCE_DEPTH_WEIGHT × φ: of two points at
    # nearly the same place the deeper one wins (a box on an equal box: the lower box's top
    # corner, pushed a hair outside the upper box's footprint, has φ = that offset sideways,
    # while the upper box's own corner beside it has the true depth 0).
    far = -math.inf
    i1 = -1
    for k in range(count):
        d = math.sqrt((buf[k, 1] - buf[best, 1]) ** 2 + (buf[k, 2] - buf[best, 2]) ** 2
                      + (buf[k, 3] - buf[best, 3]) ** 2) - REDUCE_DEPTH_WEIGHT * buf[k, 0]
        if d > far:
            far = d
            i1 = k
    far = ((buf[i1, 1] - buf[best, 1]) ** 2 + (buf[i1, 2] - buf[best, 2]) ** 2
           + (buf[i1, 3] - buf[best, 3]) ** 2)
    if far <= 1e-24:
        return 1
    # Where depths tie (a face resting on a face), the extreme point farthest from i1 spans
    # more of the patch than the deepest one: take it unless the deepest is clearly deeper.
    far0 = -math.inf
    i0 = best
    for k in range(count):
        d = math.sqrt((buf[k, 1] - buf[i1, 1]) ** 2 + (buf[k, 2] - buf[i1, 2]) ** 2
                      + (buf[k, 3] - buf[i1, 3]) ** 2) - REDUCE_DEPTH_WEIGHT * buf[k, 0]
        if d > far0:
            far0 = d
            i0 = k
    far0 = ((buf[i0, 1] - buf[i1, 1]) ** 2 + (buf[i0, 2] - buf[i1, 2]) ** 2
            + (buf[i0, 3] - buf[i1, 3]) ** 2)
    if buf[i0, 0] <= buf[best, 0] + 0.1 * MARGIN_M:
        best = i0
        keep[0] = best
        far = far0
    keep[1] = i1
    ex = buf[i1, 1] - buf[best, 1]
    ey = buf[i1, 2] - buf[best, 2]
    ez = buf[i1, 3] - buf[best, 3]
    span = math.sqrt(far)
    area = 0.0
    i2 = -1
    for k in range(count):
        cx, cy, cz = _cross(ex, ey, ez, buf[k, 1] - buf[best, 1], buf[k, 2] - buf[best, 2],
                            buf[k, 3] - buf[best, 3])
        s = abs(cx * nx + cy * ny + cz * nz) - REDUCE_DEPTH_WEIGHT * span * buf[k, 0]
        if s > area:
            area = s
            i2 = k
    if i2 < 0:
        return 2
    cx, cy, cz = _cross(ex, ey, ez, buf[i2, 1] - buf[best, 1], buf[i2, 2] - buf[best, 2],
                        buf[i2, 3] - buf[best, 3])
    if abs(cx * nx + cy * ny + cz * nz) <= 1e-12 * far:
        return 2
    keep[2] = i2
    cx, cy, cz = _cross(ex, ey, ez, buf[i2, 1] - buf[best, 1], buf[i2, 2] - buf[best, 2],
                        buf[i2, 3] - buf[best, 3])
    side = cx * nx + cy * ny + cz * nz
    area = 0.0
    i3 = -1
    for k in range(count):
        cx, cy, cz = _cross(ex, ey, ez, buf[k, 1] - buf[best, 1], buf[k, 2] - buf[best, 2],
                            buf[k, 3] - buf[best, 3])
        s = -(cx * nx + cy * ny + cz * nz) * (1.0 if side > 0.0 else -1.0)
        if s <= 1e-12 * far:
            continue
        s -= REDUCE_DEPTH_WEIGHT * span * buf[k, 0]
        if s > area:
            area = s
            i3 = k
    if i3 < 0:
        return 3
    keep[3] = i3
    return 4


@_inl
def _touching(buf, count, vel, x, a, b, n_bodies, h, v_rest):
    """
    Keep the rows of ``buf`` in resting contact now; return their count.

    The contact stage after ``midpoint_cayley``'s second half kick looks ahead over the next
    step's drift, which the next step's collision stage (with restitution) looks at first: it
    must not stop an approaching body early, so it keeps only the points in contact now
    (``φ_now <= TOUCH_M``) that approach no faster than the half kick of gravity can make
    them (``u_n >= −v_rest``); faster ones are impacts, left to the collision stage.
    """
    kept = 0
    for k in range(count):
        px, py, pz = buf[k, 1], buf[k, 2], buf[k, 3]
        ux, uy, uz = _point_velocity(vel, a, px - x[S_POS, a], py - x[S_POS + 1, a],
                                     pz - x[S_POS + 2, a])
        if b < n_bodies:
            bx, by, bz = _point_velocity(vel, b, px - x[S_POS, b], py - x[S_POS + 1, b],
                                         pz - x[S_POS + 2, b])
            ux, uy, uz = ux - bx, uy - by, uz - bz
        un0 = ux * buf[k, 4] + uy * buf[k, 5] + uz * buf[k, 6]
        if buf[k, 0] - h * un0 <= TOUCH_M and un0 >= -v_rest:
            if kept != k:
                for f in range(buf.shape[1]):
                    buf[kept, f] = buf[k, f]
            kept += 1
    return kept


@_jit
def narrow_phase(pairs, n_bodies, x, prm, vel, rot, pos_c, rot_c, inv_mass, inv_inertia_w,
                 st_rot, st_pos, kinds, sparams, pts, pt_off, ppts, ppt_off, pt_radius,
                 grid_data, grid_off, grid_dim, mu, eps, h, phase, stage, responses, balls,
                 ball_off, cell_of):
    """
    Return ``(contacts (C, N_CONTACT), patches (Q, N_PATCH))`` of the candidate ``pairs``.

    Static objects get their fixed pose for both the current and the candidate one.  A patch
    on a static object whose response is in ``responses`` (see :data:`R_STATIC`) starts with
    it (:func:`keep_responses` fills the table).
    """
    n = n_bodies
    n_static = st_rot.shape[0]
    # Poses of everything, bodies then statics, current and candidate.
    pose_r = np.empty((n + n_static, 3, 3))
    pose_p = np.empty((n + n_static, 3))
    pose_rc = np.empty((n + n_static, 3, 3))
    pose_pc = np.empty((n + n_static, 3))
    pose_r[:n] = rot
    pose_rc[:n] = rot_c
    pose_p[:n] = x[S_POS:S_POS + 3, :].T
    pose_pc[:n] = pos_c
    pose_r[n:] = st_rot
    pose_rc[n:] = st_rot
    pose_p[n:] = st_pos
    pose_pc[n:] = st_pos
    # Not zeroed (a megabyte per stage for 1000 bodies): each row is filled when it is used.
    # A pair gives at most one patch of at most PATCH_POINTS points.
    contacts = np.empty((PATCH_POINTS * pairs.shape[0], N_CONTACT))
    patches = np.empty((pairs.shape[0], N_PATCH))
    # Room for every point of the two shapes of any pair.
    most = 0
    for s in range(pt_off.shape[0] - 1):
        most = max(most, pt_off[s + 1] - pt_off[s], ppt_off[s + 1] - ppt_off[s])
    buf = np.empty((2 * most + 1, 11))
    near = np.empty(most + 1, dtype=np.bool_)  # per cell of a shape: within reach
    clip = np.empty((bb.CLIP_ROWS, bb.CLIP_COLS))  # box on box: the clipped face
    keep = np.empty(PATCH_POINTS, dtype=np.int64)
    # This loop only calls: the functions it calls take no reference counts (see _raw), and
    # _consistent_normals, which allocates, runs only where a pair's normals differ.
    nc = 0
    nq = 0
    for q in range(pairs.shape[0]):
        a = pairs[q, 0]
        b = pairs[q, 1]
        count, mixed = _pair_points(a, b, n, x, prm, vel, pose_r, pose_p, pose_rc, pose_pc,
                                    kinds, sparams, pts, pt_off, ppts, ppt_off, pt_radius,
                                    grid_data, grid_off, grid_dim, h, stage, balls, ball_off,
                                    cell_of, buf, near, clip)
        if count == 0:
            continue
        pnx, pny, pnz = buf[0, 4], buf[0, 5], buf[0, 6]
        if mixed:
            pnx, pny, pnz = _consistent_normals(buf, count, a, b, kinds, sparams, grid_data,
                                                grid_off, grid_dim, pose_rc)
        nc = _pair_patch(a, b, n, x, vel, inv_mass, inv_inertia_w, mu, eps, h, phase, stage,
                         responses, buf, count, keep, pnx, pny, pnz, contacts, patches, nc, nq)
        nq += 1
    return contacts[:nc], patches[:nq]


@_raw
def _pair_points(a, b, n, x, prm, vel, pose_r, pose_p, pose_rc, pose_pc, kinds, sparams, pts,
                 pt_off, ppts, ppt_off, pt_radius, grid_data, grid_off, grid_dim, h, stage,
                 balls, ball_off, cell_of, buf, near, clip):
    """
    Fill ``buf`` with the contact points of the pair ``(a, b)`` (see :func:`_one_way`).

    Return their count and whether their normals differ.
    """
    if kinds[b] == ck.KIND_PLANE:
        count = _plane_points(a, b, kinds, ppts, ppt_off, pt_radius, sparams, pose_r,
                              pose_p, pose_rc, pose_pc, a, pose_rc, pose_pc, b, MARGIN_M,
                              buf)
    elif kinds[a] == ck.KIND_BOX and kinds[b] == ck.KIND_BOX:
        count = _box_points(a, b, sparams, pose_r, pose_p, pose_rc, pose_pc, MARGIN_M, clip,
                            buf)
    else:
        # A sphere touches a convex primitive (any shape but a mesh, each φ exact) at one
        # point, which its centre against the other's φ finds exactly; the other's points
        # against the sphere's φ find only near-copies of it.  Two spheres had a patch of two,
        # a lever arm apart, whose response (condition ~1e5) let the collisions of a break of
        # 15 balls at ε = 1 gain 3e-12 of the energy.
        count = 0
        if not (kinds[b] == ck.KIND_SPHERE and kinds[a] != ck.KIND_MESH
                and kinds[a] != ck.KIND_SPHERE):
            count = _one_way(a, b, pts, pt_off, balls, ball_off, cell_of, near, pt_radius,
                             kinds, sparams, grid_data, grid_off, grid_dim, pose_r, pose_p,
                             pose_rc, pose_pc, a, pose_rc, pose_pc, b, MARGIN_M, buf, 0, 1.0)
        if not (kinds[a] == ck.KIND_SPHERE and kinds[b] != ck.KIND_MESH):
            count = _one_way(b, a, pts, pt_off, balls, ball_off, cell_of, near, pt_radius,
                             kinds, sparams, grid_data, grid_off, grid_dim, pose_r, pose_p,
                             pose_rc, pose_pc, b, pose_rc, pose_pc, a, MARGIN_M, buf, count,
                             -1.0)
    if stage == 2:
        ja = 0 if prm.shape[1] == 1 else a
        v_rest = 1e-9 + h * math.sqrt(prm[P_GRAVITY, ja] ** 2 + prm[P_GRAVITY + 1, ja] ** 2
                                      + prm[P_GRAVITY + 2, ja] ** 2)
        if b < n:
            jb = 0 if prm.shape[1] == 1 else b
            v_rest += h * math.sqrt(prm[P_GRAVITY, jb] ** 2 + prm[P_GRAVITY + 1, jb] ** 2
                                    + prm[P_GRAVITY + 2, jb] ** 2)
        count = _touching(buf, count, vel, x, a, b, n, h, v_rest)
    return count, count > 1 and not _one_normal(buf, 0, count, 4)


@_raw
def _pair_patch(a, b, n, x, vel, inv_mass, inv_inertia_w, mu, eps, h, phase, stage, responses,
                buf, count, keep, pnx, pny, pnz, contacts, patches, nc, nq):
    """
    Make patch ``nq`` of the pair ``(a, b)`` from its ``count`` points in ``buf``.

    ``pn``: the patch normal.  The contact rows start at ``nc``; return the next free row.
    """
    if count <= PATCH_POINTS:  # all of them (as _reduce would say, without the call)
        m = count
        for k in range(m):
            keep[k] = k
    else:
        m = _reduce(buf, count, keep, pnx, pny, pnz)
    pair_mu = math.sqrt(mu[a] * mu[b])
    pair_eps = max(eps[a], eps[b]) if phase == PHASE_COLLISION else 0.0
    static_b = b >= n
    for f in range(Q_K):
        patches[nq, f] = 0.0
    patches[nq, Q_A] = a
    patches[nq, Q_B] = b
    patches[nq, Q_START] = nc
    patches[nq, Q_COUNT] = m
    patches[nq, Q_MU] = pair_mu
    patches[nq, Q_EPS] = pair_eps
    for k in range(m):
        r = keep[k]
        c = nc
        for f in range(N_CONTACT):
            contacts[c, f] = 0.0
        contacts[c, C_A] = a
        contacts[c, C_B] = b
        contacts[c, C_PHASE] = stage
        contacts[c, C_PHI] = buf[r, 0]
        px, py, pz = buf[r, 1], buf[r, 2], buf[r, 3]
        nx, ny, nz = buf[r, 4], buf[r, 5], buf[r, 6]
        contacts[c, C_POINT] = px
        contacts[c, C_POINT + 1] = py
        contacts[c, C_POINT + 2] = pz
        contacts[c, C_NORMAL] = nx
        contacts[c, C_NORMAL + 1] = ny
        contacts[c, C_NORMAL + 2] = nz
        rax, ray, raz = px - x[S_POS, a], py - x[S_POS + 1, a], pz - x[S_POS + 2, a]
        contacts[c, C_RA] = rax
        contacts[c, C_RA + 1] = ray
        contacts[c, C_RA + 2] = raz
        # Relative normal velocity now.
        ux, uy, uz = _cross(vel[a, 3], vel[a, 4], vel[a, 5], rax, ray, raz)
        ux += vel[a, 0]
        uy += vel[a, 1]
        uz += vel[a, 2]
        if not static_b:
            rbx, rby, rbz = (px - x[S_POS, b], py - x[S_POS + 1, b],
                             pz - x[S_POS + 2, b])
            contacts[c, C_RB] = rbx
            contacts[c, C_RB + 1] = rby
            contacts[c, C_RB + 2] = rbz
            wx, wy, wz = _cross(vel[b, 3], vel[b, 4], vel[b, 5], rbx, rby, rbz)
            ux -= vel[b, 0] + wx
            uy -= vel[b, 1] + wy
            uz -= vel[b, 2] + wz
        un0 = ux * nx + uy * ny + uz * nz
        phi_now = buf[r, 0] - h * un0
        if phi_now >= 0.0:
            bias = un0 - buf[r, 0] / h
        else:
            bias = min(-PUSH_FRACTION * phi_now / h, PUSH_MAX_M_S)
        # Restitution is set at each collision visit, from C_TOUCH_U (_collision_targets).
        contacts[c, C_TARGET] = bias
        contacts[c, C_BIAS] = bias
        contacts[c, C_TOUCH_U] = un0 + (TOUCH_M - buf[r, 0]) / h
        nc += 1
    if static_b:
        _reuse_response(responses, patches, nq, contacts, nc - m, m, a, b, inv_mass,
                        inv_inertia_w)
    return nc


@_inl
def _reuse_response(responses, patches, q, contacts, s0, m, a, b, inv_mass, inv_inertia_w):
    """Give patch ``q`` (body ``a`` on static ``b``) its cached K and K⁺ if they match."""
    if (responses[a, R_STATIC] != b or responses[a, R_COUNT] != m
            or responses[a, R_INV_MASS] != inv_mass[a]):
        return
    for k in range(9):
        if responses[a, R_INV_INERTIA + k] != inv_inertia_w[a, k // 3, k % 3]:
            return
    for k in range(m):
        for d in range(3):
            if (responses[a, R_ROWS + 6 * k + d] != contacts[s0 + k, C_RA + d]
                    or responses[a, R_ROWS + 6 * k + 3 + d] != contacts[s0 + k, C_NORMAL + d]):
                return
    for k in range(PATCH_POINTS * PATCH_POINTS):
        patches[q, Q_K + k] = responses[a, R_K + k]
        patches[q, Q_PINV + k] = responses[a, R_PINV + k]
    patches[q, Q_CACHED] = 2.0


@_raw
def keep_responses(responses, patches, contacts, n_bodies, inv_mass, inv_inertia_w):
    """Store the K and K⁺ of every patch on a static object that computed them."""
    for q in range(patches.shape[0]):
        b = patches[q, Q_B]
        if b < n_bodies or patches[q, Q_CACHED] != 1.0:  # none, or taken from the cache
            continue
        a = int(patches[q, Q_A])
        s0 = int(patches[q, Q_START])
        m = int(patches[q, Q_COUNT])
        responses[a, R_STATIC] = b
        responses[a, R_COUNT] = m
        responses[a, R_INV_MASS] = inv_mass[a]
        for k in range(9):
            responses[a, R_INV_INERTIA + k] = inv_inertia_w[a, k // 3, k % 3]
        for k in range(m):
            for d in range(3):
                responses[a, R_ROWS + 6 * k + d] = contacts[s0 + k, C_RA + d]
                responses[a, R_ROWS + 6 * k + 3 + d] = contacts[s0 + k, C_NORMAL + d]
        for k in range(PATCH_POINTS * PATCH_POINTS):
            responses[a, R_K + k] = patches[q, Q_K + k]
            responses[a, R_PINV + k] = patches[q, Q_PINV + k]


# ---------------------------------------------------------------------------------------------
# The impulses.


@_inl
def _point_velocity(vel, i, rx, ry, rz):
    wx, wy, wz = _cross(vel[i, 3], vel[i, 4], vel[i, 5], rx, ry, rz)
    return vel[i, 0] + wx, vel[i, 1] + wy, vel[i, 2] + wz


@_inl
def _apply(vel, inv_mass, inv_inertia_w, i, scale, rx, ry, rz, jx, jy, jz, mx, my, mz):
    """Apply impulse ``scale·j`` at lever arm ``r`` plus couple ``scale·m`` to body ``i``."""
    im = inv_mass[i] * scale
    vel[i, 0] += im * jx
    vel[i, 1] += im * jy
    vel[i, 2] += im * jz
    tx, ty, tz = _cross(rx, ry, rz, jx, jy, jz)
    tx, ty, tz = scale * (tx + mx), scale * (ty + my), scale * (tz + mz)
    dx, dy, dz = _mat_vec(inv_inertia_w, i, tx, ty, tz)
    vel[i, 3] += dx
    vel[i, 4] += dy
    vel[i, 5] += dz


@_inl
def _record(wrench, i, sign, rx, ry, rz, jx, jy, jz, mx, my, mz):
    wrench[i, 0] += sign * jx
    wrench[i, 1] += sign * jy
    wrench[i, 2] += sign * jz
    tx, ty, tz = _cross(rx, ry, rz, jx, jy, jz)
    wrench[i, 3] += sign * (tx + mx)
    wrench[i, 4] += sign * (ty + my)
    wrench[i, 5] += sign * (tz + mz)


@_inl
def _response(inv_mass, inv_inertia_w, i, rx, ry, rz, dx, dy, dz, ex, ey, ez):
    """``eᵀ K_i d``: velocity change along ``e`` at ``r`` per unit impulse along ``d`` at ``r``."""
    cx, cy, cz = _cross(rx, ry, rz, dx, dy, dz)
    ix, iy, iz = _mat_vec(inv_inertia_w, i, cx, cy, cz)
    wx, wy, wz = _cross(ix, iy, iz, rx, ry, rz)
    return inv_mass[i] * (dx * ex + dy * ey + dz * ez) + wx * ex + wy * ey + wz * ez


@_inl
def _cross_response(inv_mass, inv_inertia_w, i, rlx, rly, rlz, dx, dy, dz, rkx, rky, rkz,
                    ex, ey, ez):
    """``eᵀ Δv(r_k)`` of body ``i`` per unit impulse along ``d`` at ``r_l``."""
    cx, cy, cz = _cross(rlx, rly, rlz, dx, dy, dz)
    ix, iy, iz = _mat_vec(inv_inertia_w, i, cx, cy, cz)
    kx, ky, kz = _cross(rkx, rky, rkz, ex, ey, ez)
    return inv_mass[i] * (dx * ex + dy * ey + dz * ez) + ix * kx + iy * ky + iz * kz


# Rows of a patch solve's scratch table ``scr`` (SCR_ROWS, PATCH_POINTS): everything the
# normal block works on, indexed in place (no row views: each would be reference counted).
SCR_K = 0                           # K of the points, PATCH_POINTS rows
SCR_FREE = PATCH_POINTS             # u without the patch's normal impulses
SCR_RHS = SCR_FREE + 1              # bias − u0
SCR_LAM = SCR_FREE + 2              # λ of the active set being tried
SCR_BEST = SCR_FREE + 3             # the chosen λ
SCR_ACTIVE = SCR_FREE + 4           # 1.0 for the points in the active set
SCR_IDX = SCR_FREE + 5              # the active points' indices
SCR_PINV = SCR_FREE + 6             # (K_AA)⁺ scattered to the points, PATCH_POINTS rows
SCR_A = SCR_PINV + PATCH_POINTS     # K_AA compacted, then the eigenvalues on its diagonal
SCR_V = SCR_A + PATCH_POINTS        # eigenvectors, or the inverse of a fast path
SCR_LOW = SCR_V + PATCH_POINTS      # a Cholesky factor
SCR_INV_LOW = SCR_LOW + PATCH_POINTS  # its inverse
SCR_U = SCR_INV_LOW + PATCH_POINTS  # a null vector (one row)
SCR_SHIFTED = SCR_U + 1             # K_AA + s u uᵀ
SCR_BASE = SCR_SHIFTED + PATCH_POINTS  # the normal impulses a collision visit starts from
SCR_ROWS = SCR_BASE + 1


@_jit
def patch_scratch():
    """Return a scratch table for :func:`solve_patch` (one per thread)."""
    return np.empty((SCR_ROWS, PATCH_POINTS))


@_raw
def _eigh_small(w, a0, p, v0):
    """
    Diagonalise the symmetric ``w[a0:a0+p, :p]`` in place by cyclic Jacobi rotations.

    Afterwards its diagonal holds the eigenvalues and the columns of ``w[v0:v0+p, :p]`` the
    eigenvectors (Rutishauser's rotation formulas, no trigonometric functions).
    """
    for r in range(p):
        for c in range(p):
            w[v0 + r, c] = 1.0 if r == c else 0.0
    for _ in range(30):
        off = 0.0
        for r in range(p):
            for c in range(r + 1, p):
                off += w[a0 + r, c] * w[a0 + r, c]
        if off <= 1e-60:
            break
        for r in range(p):
            for c in range(r + 1, p):
                if w[a0 + r, c] == 0.0:
                    continue
                theta = (w[a0 + c, c] - w[a0 + r, r]) / (2.0 * w[a0 + r, c])
                t = 1.0 / (abs(theta) + math.sqrt(theta * theta + 1.0))
                if theta < 0.0:
                    t = -t
                cs_ = 1.0 / math.sqrt(t * t + 1.0)
                sn = t * cs_
                for k in range(p):
                    akr, akc = w[a0 + k, r], w[a0 + k, c]
                    w[a0 + k, r] = cs_ * akr - sn * akc
                    w[a0 + k, c] = sn * akr + cs_ * akc
                for k in range(p):
                    ark, ack = w[a0 + r, k], w[a0 + c, k]
                    w[a0 + r, k] = cs_ * ark - sn * ack
                    w[a0 + c, k] = sn * ark + cs_ * ack
                for k in range(p):
                    vkr, vkc = w[v0 + k, r], w[v0 + k, c]
                    w[v0 + k, r] = cs_ * vkr - sn * vkc
                    w[v0 + k, c] = sn * vkr + cs_ * vkc


#: The fast paths of :func:`_pinv_small` take a Cholesky factor only if every pivot is at
#: least this share of the largest diagonal entry (an inverse then accurate to ~1e-13; two
#: balls colliding off-centre give a K of condition 6e4, whose Cholesky inverse was off by
#: 2e-12 and let an elastic collision gain that much energy): else the eigen-decomposition.
PIVOT_TOL = 1e-3


@_raw
def _spd_inverse(w, a0, p, tol, o0):
    """
    Invert the symmetric ``w[a0:a0+p, :p]`` by Cholesky into ``w[o0:o0+p, :p]``.

    False (and nothing written) if a pivot is <= ``tol``.  Uses the rows ``SCR_LOW`` and
    ``SCR_INV_LOW`` of ``w``.
    """
    lo = SCR_LOW
    il = SCR_INV_LOW
    for j in range(p):
        for k in range(p):
            w[lo + j, k] = 0.0
            w[il + j, k] = 0.0
    for j in range(p):
        d = w[a0 + j, j]
        for k in range(j):
            d -= w[lo + j, k] * w[lo + j, k]
        if not d > tol:
            return False
        w[lo + j, j] = math.sqrt(d)
        for i in range(j + 1, p):
            acc = w[a0 + i, j]
            for k in range(j):
                acc -= w[lo + i, k] * w[lo + j, k]
            w[lo + i, j] = acc / w[lo + j, j]
    # L⁻¹ (lower triangular), then the inverse L⁻ᵀ L⁻¹.
    for j in range(p):
        w[il + j, j] = 1.0 / w[lo + j, j]
        for i in range(j + 1, p):
            acc = 0.0
            for k in range(j, i):
                acc -= w[lo + i, k] * w[il + k, j]
            w[il + i, j] = acc / w[lo + i, i]
    for r in range(p):
        for c in range(r, p):
            acc = 0.0
            for k in range(c, p):
                acc += w[il + k, r] * w[il + k, c]
            w[o0 + r, c] = acc
            w[o0 + c, r] = acc
    return True


@_inl
def _skip(k, s):
    """Return the ``k``-th index of ``0, 1, …`` with ``s`` left out."""
    return k if k < s else k + 1


@_raw
def _cofactor(w, a0, p, r, c):
    """Return the cofactor ``(−1)^(r+c) det(a less row r, column c)`` of ``w[a0:a0+p, :p]``."""
    r0, r1, r2 = a0 + _skip(0, r), a0 + _skip(1, r), a0 + _skip(2, r)
    c0, c1, c2 = _skip(0, c), _skip(1, c), _skip(2, c)
    if p == 1:
        det = 1.0
    elif p == 2:
        det = w[r0, c0]
    elif p == 3:
        det = w[r0, c0] * w[r1, c1] - w[r0, c1] * w[r1, c0]
    else:
        det = (w[r0, c0] * (w[r1, c1] * w[r2, c2] - w[r1, c2] * w[r2, c1])
               - w[r0, c1] * (w[r1, c0] * w[r2, c2] - w[r1, c2] * w[r2, c0])
               + w[r0, c2] * (w[r1, c0] * w[r2, c1] - w[r1, c1] * w[r2, c0]))
    return -det if (r + c) % 2 == 1 else det


@_raw
def _deflated_inverse(w, a0, p, top, o0):
    """
    Pseudo-inverse of a symmetric PSD ``w[a0:a0+p, :p]`` of rank ``p − 1`` into ``w[o0:]``.

    False if it is not of that rank.  The adjugate of such a matrix is ``c u uᵀ`` with ``u``
    its unit null vector (four points of one normal on a rigid body always have one: the
    normal impulses that sum to no force and no moment), so
    ``a⁺ = (a + s u uᵀ)⁻¹ − u uᵀ / s``.  Checked: ``|a u|`` must be round-off and
    ``a + s u uᵀ`` well conditioned, else the caller decomposes.
    """
    j = -1
    big = 0.0
    for k in range(p):
        d = _cofactor(w, a0, p, k, k)
        if d > big:
            big = d
            j = k
    if j < 0:
        return False
    u = SCR_U
    norm = 0.0
    for k in range(p):
        w[u, k] = _cofactor(w, a0, p, j, k)
        norm += w[u, k] * w[u, k]
    norm = math.sqrt(norm)
    for k in range(p):
        w[u, k] /= norm
    for r in range(p):
        acc = 0.0
        for c in range(p):
            acc += w[a0 + r, c] * w[u, c]
        if abs(acc) > 1e-9 * top:
            return False
    sh = SCR_SHIFTED
    for r in range(p):
        for c in range(p):
            w[sh + r, c] = w[a0 + r, c] + top * w[u, r] * w[u, c]
    if not _spd_inverse(w, sh, p, PIVOT_TOL * top, o0):
        return False
    for r in range(p):
        for c in range(p):
            w[o0 + r, c] -= w[u, r] * w[u, c] / top
    return True


@_raw
def _pinv_small(scr, m):
    """
    Set ``scr``'s SCR_PINV rows to the pseudo-inverse of ``K[A, A]`` (0 off the active set).

    ``K`` is ``scr``'s SCR_K rows, ``A`` the points flagged in its SCR_ACTIVE row.  ``K`` is
    symmetric positive semi-definite (a contact response); eigenvalues below 1e-9 of the
    largest count as zero.  Four coplanar points leave a rigid body's normal impulses
    indeterminate along one direction: the least-norm solution shares the load
    symmetrically instead of in an order-dependent way, and a nearly singular direction (a
    normal tilted by round-off) cannot produce a huge impulse.  A well-conditioned matrix is
    inverted by Cholesky, one of rank one less (a flat patch :func:`_flat_response` did not
    take, or a subset of one) by :func:`_deflated_inverse`; anything else by Jacobi
    eigen-decomposition.
    """
    p = 0
    for k in range(m):
        for jj in range(m):
            scr[SCR_PINV + k, jj] = 0.0
        if scr[SCR_ACTIVE, k] != 0.0:
            scr[SCR_IDX, p] = k
            p += 1
    if p == 0:
        return
    diag = 0.0
    for r in range(p):
        for c in range(p):
            scr[SCR_A + r, c] = scr[SCR_K + int(scr[SCR_IDX, r]), int(scr[SCR_IDX, c])]
        diag = max(diag, scr[SCR_A + r, r])
    if diag <= 0.0:
        return
    if (_spd_inverse(scr, SCR_A, p, PIVOT_TOL * diag, SCR_V)
            or (p > 1 and _deflated_inverse(scr, SCR_A, p, diag, SCR_V))):
        for r in range(p):
            for c in range(p):
                scr[SCR_PINV + int(scr[SCR_IDX, r]), int(scr[SCR_IDX, c])] = scr[SCR_V + r, c]
        return
    _eigh_small(scr, SCR_A, p, SCR_V)
    top = 0.0
    for r in range(p):
        top = max(top, scr[SCR_A + r, r])
    if top <= 0.0:
        return
    for e in range(p):
        sigma = scr[SCR_A + e, e]
        if sigma <= 1e-9 * top:
            continue
        for r in range(p):
            for c in range(p):
                scr[SCR_PINV + int(scr[SCR_IDX, r]), int(scr[SCR_IDX, c])] += (
                    scr[SCR_V + r, e] * scr[SCR_V + c, e] / sigma)


#: :func:`_flat_response` takes a patch only if its points' spread in the tangent plane is
#: far from a line: det S₂ >= this share of (tr S₂)² (4·det/tr² is 1 for a square, 0 on a
#: line), so S₂⁻¹ loses at most ~1e4 ulp; a thinner patch goes the general way.
FLAT_SPREAD_TOL = 1e-4


@_inl
def _tangent_inertia(inv_inertia_w, i, t1x, t1y, t1z, t2x, t2y, t2z):
    """``W_t = T I⁻¹ Tᵀ`` of body ``i`` in the tangent basis ``T = (t1, t2)``: w11, w12, w22."""
    ux, uy, uz = _mat_vec(inv_inertia_w, i, t1x, t1y, t1z)
    vx, vy, vz = _mat_vec(inv_inertia_w, i, t2x, t2y, t2z)
    return (t1x * ux + t1y * uy + t1z * uz,
            0.5 * (t1x * vx + t1y * vy + t1z * vz + t2x * ux + t2y * uy + t2z * uz),
            t2x * vx + t2y * vy + t2z * vz)


@_raw
def _flat_response(patches, q, contacts, s0, m, inv_mass, inv_inertia_w, a, b, dyn_b, scr):
    """
    Set patch ``q``'s K and K⁺ (both bodies free) in closed form if it is flat; tell whether.

    Flat: three or more points and one normal ``n`` (a face on a plane or on a face).  Let
    ``α_k`` be the tangent coordinates (basis ``T``) of ``r_k × n`` for A's lever arms, and
    ``δ`` the (constant) shift to B's.  Each body's response is affine in ``α``, so
    ``K = B C Bᵀ`` with ``B`` the rows ``(1, α_k)``, of full column rank 3, and ``C`` the
    symmetric 3×3 ``[[m_A⁻¹ + m_B⁻¹ + δᵀW_Bδ, (W_B δ)ᵀ], [W_B δ, W_A + W_B]]``
    (``W = T I⁻¹ Tᵀ``, B's terms absent for a static object).  Then
    ``K⁺ = B (BᵀB)⁻¹ C⁻¹ (BᵀB)⁻¹ Bᵀ``; centring ``α`` (``β_k = α_k − ᾱ``) makes ``BᵀB``
    block diagonal, and ``K⁺_kl = f_kᵀ C⁻¹ f_l`` with ``f_k = (1/n_p − ᾱ·e_k, e_k)``,
    ``e_k = S₂⁻¹ β_k``, ``S₂ = Σ β_k β_kᵀ`` (``n_p`` points).  The least-norm inverse of
    four points' rank-3 K (which the general route finds by cofactors and a shifted
    Cholesky) from 2×2 and 3×3 inverses: ~100× closer to exact (test_patch_response), and
    a miss of the response cache, which a resting body's pose makes once a step as it moves
    in its last bits, costs ~0.1 µs instead of ~0.37 µs.
    """
    if m < 3 or not _one_normal(contacts, s0, m, C_NORMAL):
        return False
    nx, ny, nz = contacts[s0, C_NORMAL], contacts[s0, C_NORMAL + 1], contacts[s0, C_NORMAL + 2]
    t1x, t1y, t1z, t2x, t2y, t2z = _tangent_basis(nx, ny, nz)
    nn = nx * nx + ny * ny + nz * nz
    # α_k (scr's SCR_A rows), their mean, and B's shift δ.
    m1 = m2 = d1 = d2 = 0.0
    for k in range(m):
        c = s0 + k
        ax, ay, az = _cross(contacts[c, C_RA], contacts[c, C_RA + 1], contacts[c, C_RA + 2],
                            nx, ny, nz)
        al1 = ax * t1x + ay * t1y + az * t1z
        al2 = ax * t2x + ay * t2y + az * t2z
        scr[SCR_A, k] = al1
        scr[SCR_A + 1, k] = al2
        m1 += al1
        m2 += al2
        if dyn_b:
            bx, by, bz = _cross(contacts[c, C_RB], contacts[c, C_RB + 1],
                                contacts[c, C_RB + 2], nx, ny, nz)
            d1 += bx * t1x + by * t1y + bz * t1z - al1
            d2 += bx * t2x + by * t2y + bz * t2z - al2
    m1 /= m
    m2 /= m
    d1 /= m
    d2 /= m
    s11 = s12 = s22 = 0.0
    for k in range(m):
        b1 = scr[SCR_A, k] - m1
        b2 = scr[SCR_A + 1, k] - m2
        s11 += b1 * b1
        s12 += b1 * b2
        s22 += b2 * b2
    sdet = s11 * s22 - s12 * s12
    if not sdet >= FLAT_SPREAD_TOL * (s11 + s22) * (s11 + s22):
        return False
    # C.
    c11, c12, c22 = _tangent_inertia(inv_inertia_w, a, t1x, t1y, t1z, t2x, t2y, t2z)
    c00 = inv_mass[a] * nn
    c01 = c02 = 0.0
    if dyn_b:
        w11, w12, w22 = _tangent_inertia(inv_inertia_w, b, t1x, t1y, t1z, t2x, t2y, t2z)
        g1 = w11 * d1 + w12 * d2
        g2 = w12 * d1 + w22 * d2
        c00 += inv_mass[b] * nn + d1 * g1 + d2 * g2
        c01, c02 = g1, g2
        c11 += w11
        c12 += w12
        c22 += w22
    # C⁻¹ by cofactors; C is positive definite unless a mass or inertia is not.
    i00 = c11 * c22 - c12 * c12
    i01 = c02 * c12 - c01 * c22
    i02 = c01 * c12 - c02 * c11
    det = c00 * i00 + c01 * i01 + c02 * i02
    if not (det > 1e-12 * c00 * c11 * c22 and i00 > 0.0):
        return False
    i00 /= det
    i01 /= det
    i02 /= det
    i11 = (c00 * c22 - c02 * c02) / det
    i12 = (c01 * c02 - c00 * c12) / det
    i22 = (c00 * c11 - c01 * c01) / det
    # K = B C Bᵀ.
    for k in range(m):
        al1 = scr[SCR_A, k]
        al2 = scr[SCR_A + 1, k]
        r0 = c00 + c01 * al1 + c02 * al2
        r1 = c01 + c11 * al1 + c12 * al2
        r2 = c02 + c12 * al1 + c22 * al2
        for jj in range(k, m):
            v = r0 + r1 * scr[SCR_A, jj] + r2 * scr[SCR_A + 1, jj]
            patches[q, Q_K + PATCH_POINTS * k + jj] = v
            patches[q, Q_K + PATCH_POINTS * jj + k] = v
    # f_k in scr's SCR_V rows, then K⁺ = F C⁻¹ Fᵀ (0 beyond the patch's points).
    f0, f1, f2 = SCR_V, SCR_V + 1, SCR_V + 2
    for k in range(m):
        b1 = scr[SCR_A, k] - m1
        b2 = scr[SCR_A + 1, k] - m2
        scr[f1, k] = (s22 * b1 - s12 * b2) / sdet
        scr[f2, k] = (s11 * b2 - s12 * b1) / sdet
        scr[f0, k] = 1.0 / m - (m1 * scr[f1, k] + m2 * scr[f2, k])
    for k in range(PATCH_POINTS):
        r0 = r1 = r2 = 0.0
        if k < m:
            r0 = i00 * scr[f0, k] + i01 * scr[f1, k] + i02 * scr[f2, k]
            r1 = i01 * scr[f0, k] + i11 * scr[f1, k] + i12 * scr[f2, k]
            r2 = i02 * scr[f0, k] + i12 * scr[f1, k] + i22 * scr[f2, k]
        for jj in range(k, PATCH_POINTS):
            v = 0.0
            if jj < m:
                v = r0 * scr[f0, jj] + r1 * scr[f1, jj] + r2 * scr[f2, jj]
            patches[q, Q_PINV + PATCH_POINTS * k + jj] = v
            patches[q, Q_PINV + PATCH_POINTS * jj + k] = v
    patches[q, Q_CACHED] = 1.0
    return True


@_raw
def _solve_small(scr, m):
    """Set SCR_LAM to the least-norm solution of ``K[A, A] λ = rhs[A]`` (others 0)."""
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
                  wa, wb, wrench, scr, free_known, fresh):
    """
    Set the normal impulses of one patch exactly; return the largest Δu (m/s).

    The complementarity problem ``u_n >= bias, λ >= 0, λ (u_n − bias) = 0`` of its (at most
    four) points: the least-norm solution with every point active first (its response ``K``
    and pseudo-inverse are computed once per stage and kept in the patch row), then, if that
    is not feasible, every other active set (:func:`_solve_small` for each).  ``fresh``: a
    collision visit (see :func:`solve_patch`): the impulses solved for are added to SCR_BASE,
    the ones the visit started from, instead of replacing them.
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
        return 0.0  # nothing held, nothing to hold
    if held and _complementary(scr, contacts, s0, m):
        return 0.0  # what is held already solves it: keep it (see _complementary)
    if free_pair and not cached:
        cached = _flat_response(patches, q, contacts, s0, m, inv_mass, inv_inertia_w, a, b,
                                dyn_b, scr)
    for k in range(m):
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
    # Velocities without this patch's normal impulses (beyond a visit's base): u0 = u − K λ.
    for k in range(m):
        acc = scr[SCR_FREE, k]
        for jj in range(m):
            acc -= scr[SCR_K + k, jj] * (contacts[s0 + jj, C_LAMBDA] - scr[SCR_BASE, jj])
        scr[SCR_FREE, k] = acc
    if _idle(scr, contacts, s0, m):
        return _apply_normals(scr, SCR_BEST, s0, m, contacts, vel, inv_mass, inv_inertia_w,
                              a, b, dyn_b, wa, wb, wrench, fresh)
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
                                  inv_inertia_w, a, b, dyn_b, wa, wb, wrench, fresh)
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
    for mask in range(full, -1, -1):
        for k in range(m):
            scr[SCR_ACTIVE, k] = 1.0 if (mask >> k & 1) == 1 else 0.0
        _solve_small(scr, m)
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
    for k in range(m):
        scr[SCR_ACTIVE, k] = 1.0 if (chosen >> k & 1) == 1 else 0.0
    _solve_small(scr, m)
    for k in range(m):
        scr[SCR_BEST, k] = max(scr[SCR_LAM, k], 0.0)
    return _apply_normals(scr, SCR_BEST, s0, m, contacts, vel, inv_mass, inv_inertia_w, a, b,
                          dyn_b, wa, wb, wrench, fresh)


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


@_inl
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
    for it in range(PATCH_ITERATIONS):
        # Normal impulses: the patch's small LCP solved exactly (see _normal_block), for the
        # velocities as they are; another round is needed only if friction then changes them
        # by more than the tolerance (solving again would give the same impulses).
        biggest = max(biggest, _normal_block(patches, q, s0, m, contacts, vel, inv_mass,
                                             inv_inertia_w, a, b, dyn_b, wa, wb, wrench, scr,
                                             free_known and it == 0, fresh))
        slip = 0.0
        if per_point:
            if friction and mu > 0.0:
                slip = _friction_points(q, patches, contacts, vel, inv_mass, inv_inertia_w, a,
                                        b, dyn_b, wa, wb, wrench, s0, m, mu)
        else:
            # Friction of the patch at its normal-impulse centre.
            total = 0.0
            cx = cy = cz = 0.0
            nbx = nby = nbz = 0.0
            for k in range(s0, s0 + m):
                lam = contacts[k, C_LAMBDA]
                total += lam
                cx += lam * contacts[k, C_POINT]
                cy += lam * contacts[k, C_POINT + 1]
                cz += lam * contacts[k, C_POINT + 2]
                nbx += lam * contacts[k, C_NORMAL]
                nby += lam * contacts[k, C_NORMAL + 1]
                nbz += lam * contacts[k, C_NORMAL + 2]
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


@_inl
def _tangent_response(inv_mass, inv_inertia_w, a, b, dyn_b, wa, wb, rax, ray, raz, rbx, rby,
                      rbz, t1x, t1y, t1z, t2x, t2y, t2z):
    """Return the 2×2 response ``(k11, k12, k22)`` of a point's tangential velocity."""
    k11 = wa * _response(inv_mass, inv_inertia_w, a, rax, ray, raz, t1x, t1y, t1z,
                         t1x, t1y, t1z)
    k12 = wa * _response(inv_mass, inv_inertia_w, a, rax, ray, raz, t2x, t2y, t2z,
                         t1x, t1y, t1z)
    k22 = wa * _response(inv_mass, inv_inertia_w, a, rax, ray, raz, t2x, t2y, t2z,
                         t2x, t2y, t2z)
    if dyn_b:
        k11 += wb * _response(inv_mass, inv_inertia_w, b, rbx, rby, rbz, t1x, t1y, t1z,
                              t1x, t1y, t1z)
        k12 += wb * _response(inv_mass, inv_inertia_w, b, rbx, rby, rbz, t2x, t2y, t2z,
                              t1x, t1y, t1z)
        k22 += wb * _response(inv_mass, inv_inertia_w, b, rbx, rby, rbz, t2x, t2y, t2z,
                              t2x, t2y, t2z)
    return k11, k12, k22


@_inl
def _tangent_basis(nx, ny, nz):
    """Two unit vectors completing ``n`` to a right-handed orthonormal basis."""
    if abs(nx) < 0.57735:
        tx, ty, tz = 0.0, -nz, ny
    else:
        tx, ty, tz = nz, 0.0, -nx
    s = 1.0 / math.sqrt(tx * tx + ty * ty + tz * tz)
    tx, ty, tz = tx * s, ty * s, tz * s
    sx, sy, sz = _cross(nx, ny, nz, tx, ty, tz)
    return tx, ty, tz, sx, sy, sz


@_inl
def _coulomb(k11, k12, k22, u1, u2, limit):
    """
    Return the friction impulse ``f`` (2-D) for the slip ``u0`` without friction.

    Sticking, ``f = −K⁻¹ u0``, if ``|f| <= limit``; otherwise sliding with ``|f| = limit``
    opposite to the slip *after* the impulse, ``f = −limit (u0 + K f) / |u0 + K f|``
    (maximal dissipation).  That is ``f = −(K + γ𝟙)⁻¹ u0`` for the one ``γ > 0`` with
    ``|f| = limit``, found by safeguarded Newton steps on ``1/|f(γ)|`` (monotone in ``γ``).
    Solving for the post-impulse slip keeps the sliding direction stable where a fixed
    point on the pre-impulse one oscillates (a small slip against a large impulse).
    """
    det = k11 * k22 - k12 * k12
    f1 = -(k22 * u1 - k12 * u2) / det
    f2 = -(-k12 * u1 + k11 * u2) / det
    if f1 * f1 + f2 * f2 <= limit * limit:
        return f1, f2
    if limit <= 0.0:
        return 0.0, 0.0
    # Eigen-decomposition of the symmetric 2×2 K = Q diag(a, b) Qᵀ by its rotation angle
    # (well defined for any K, isotropic included).
    angle = 0.5 * math.atan2(2.0 * k12, k11 - k22)
    c1, c2 = math.cos(angle), math.sin(angle)
    a = k11 * c1 * c1 + 2.0 * k12 * c1 * c2 + k22 * c2 * c2
    b = k11 * c2 * c2 - 2.0 * k12 * c1 * c2 + k22 * c1 * c1
    # Q = [[c1, -c2], [c2, c1]]: first column the eigenvector of a.
    p1 = c1 * u1 + c2 * u2
    p2 = -c2 * u1 + c1 * u2
    speed = math.sqrt(u1 * u1 + u2 * u2)
    lo = max(0.0, speed / limit - a)
    hi = speed / limit
    g = 0.5 * (lo + hi)
    b = max(b, 0.0)
    for _ in range(60):
        da, db = a + g, b + g
        if da <= 0.0 or db <= 0.0:
            g = 0.5 * (g + hi)
            continue
        size = math.sqrt((p1 / da) ** 2 + (p2 / db) ** 2)
        if size > limit:
            lo = g
        else:
            hi = g
        # Newton on 1/|f(γ)| − 1/limit, kept inside the bracket.
        new = 0.5 * (lo + hi)
        dsize = -((p1 * p1) / da ** 3 + (p2 * p2) / db ** 3)
        if size > 0.0 and dsize < 0.0:
            trial = g - (1.0 / size - 1.0 / limit) * size ** 3 / dsize
            if lo < trial < hi:
                new = trial
        if abs(new - g) <= 1e-15 * g:
            g = new
            break
        g = new
    q1 = -p1 / (a + g)
    q2 = -p2 / (b + g)
    f1 = c1 * q1 - c2 * q2
    f2 = c2 * q1 + c1 * q2
    # Exactly on the cone: rescale the round-off away.
    size = math.sqrt(f1 * f1 + f2 * f2)
    if size == 0.0:
        return 0.0, 0.0
    return f1 * limit / size, f2 * limit / size


@_inl
def _friction(q, patches, contacts, vel, inv_mass, inv_inertia_w, a, b, dyn_b, x, wa, wb,
              wrench, total, cx, cy, cz, nx, ny, nz, s0, m, mu):
    """One friction update of patch ``q``: stick if the cone allows, else slide; return Δu."""
    rax, ray, raz = cx - x[S_POS, a], cy - x[S_POS + 1, a], cz - x[S_POS + 2, a]
    ux, uy, uz = _point_velocity(vel, a, rax, ray, raz)
    rbx = rby = rbz = 0.0
    if dyn_b:
        rbx, rby, rbz = cx - x[S_POS, b], cy - x[S_POS + 1, b], cz - x[S_POS + 2, b]
        bx, by, bz = _point_velocity(vel, b, rbx, rby, rbz)
        ux, uy, uz = ux - bx, uy - by, uz - bz
    t1x, t1y, t1z, t2x, t2y, t2z = _tangent_basis(nx, ny, nz)
    u1 = ux * t1x + uy * t1y + uz * t1z
    u2 = ux * t2x + uy * t2y + uz * t2z
    # 2×2 response of the tangential velocity at c to a tangential impulse at c.
    k11, k12, k22 = _tangent_response(inv_mass, inv_inertia_w, a, b, dyn_b, wa, wb, rax, ray,
                                      raz, rbx, rby, rbz, t1x, t1y, t1z, t2x, t2y, t2z)
    det = k11 * k22 - k12 * k12
    fx, fy, fz = patches[q, Q_FT], patches[q, Q_FT + 1], patches[q, Q_FT + 2]
    f1 = fx * t1x + fy * t1y + fz * t1z
    f2 = fx * t2x + fy * t2y + fz * t2z
    limit = mu * total
    change = 0.0
    if det > 0.0:
        # Slip without this patch's friction, u0 = u − K f; sticking needs f = −K⁻¹ u0.
        w1 = u1 - (k11 * f1 + k12 * f2)
        w2 = u2 - (k12 * f1 + k22 * f2)
        n1, n2 = _coulomb(k11, k12, k22, w1, w2, limit)
        d1, d2 = n1 - f1, n2 - f2
        if d1 != 0.0 or d2 != 0.0:
            jx = d1 * t1x + d2 * t2x
            jy = d1 * t1y + d2 * t2y
            jz = d1 * t1z + d2 * t2z
            patches[q, Q_FT] = fx + jx
            patches[q, Q_FT + 1] = fy + jy
            patches[q, Q_FT + 2] = fz + jz
            _apply(vel, inv_mass, inv_inertia_w, a, wa, rax, ray, raz, jx, jy, jz,
                   0.0, 0.0, 0.0)
            _record(wrench, a, 1.0, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
            if dyn_b:
                _apply(vel, inv_mass, inv_inertia_w, b, -wb, rbx, rby, rbz, jx, jy, jz,
                       0.0, 0.0, 0.0)
                _record(wrench, b, -1.0, rbx, rby, rbz, jx, jy, jz, 0.0, 0.0, 0.0)
            change = max(abs(d1) * k11, abs(d2) * k22)
    # Torsion: a couple about the patch normal, up to μ Σ λ_k |r_k − c|.
    arm = 0.0
    for k in range(s0, s0 + m):
        dx = contacts[k, C_POINT] - cx
        dy = contacts[k, C_POINT + 1] - cy
        dz = contacts[k, C_POINT + 2] - cz
        dn = dx * nx + dy * ny + dz * nz
        arm += contacts[k, C_LAMBDA] * math.sqrt(max(dx * dx + dy * dy + dz * dz - dn * dn,
                                                     0.0))
    if arm > 0.0:
        ix, iy, iz = _mat_vec(inv_inertia_w, a, nx, ny, nz)
        kss = wa * (ix * nx + iy * ny + iz * nz)
        if dyn_b:
            ix, iy, iz = _mat_vec(inv_inertia_w, b, nx, ny, nz)
            kss += wb * (ix * nx + iy * ny + iz * nz)
        if kss > 0.0:
            spin = vel[a, 3] * nx + vel[a, 4] * ny + vel[a, 5] * nz
            if dyn_b:
                spin -= vel[b, 3] * nx + vel[b, 4] * ny + vel[b, 5] * nz
            old = patches[q, Q_MT]
            new = old - spin / kss
            cap = mu * arm
            new = min(max(new, -cap), cap)
            d = new - old
            if d != 0.0:
                patches[q, Q_MT] = new
                mx, my, mz = d * nx, d * ny, d * nz
                _apply(vel, inv_mass, inv_inertia_w, a, wa, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                       mx, my, mz)
                _record(wrench, a, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, mx, my, mz)
                if dyn_b:
                    _apply(vel, inv_mass, inv_inertia_w, b, -wb, 0.0, 0.0, 0.0, 0.0, 0.0,
                           0.0, mx, my, mz)
                    _record(wrench, b, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, mx, my, mz)
                change = max(change, abs(d) * kss)
    return change


@_raw
def _friction_points(q, patches, contacts, vel, inv_mass, inv_inertia_w, a, b, dyn_b, wa, wb,
                     wrench, s0, m, mu):
    """
    One friction update of every point of patch ``q`` in its own cone; return the largest Δu.

    Each point keeps its own tangential impulse ``f_k`` (``C_FRICTION``), always applied at
    that point and in its own tangent plane, so ``u0 = u − K_k f_k`` undoes exactly what was
    applied before: sticking ``f_k = −K_k⁻¹ u0`` if ``|f_k| <= μ λ_k``, else sliding on the
    cone (:func:`_coulomb`).  Used where patches share a body: the patch friction at a moving
    normal-impulse centre leaves a couple each iteration that Gauss–Seidel over coupled
    patches amplifies.  Four points sticking also hold the twist, so no torsion term.
    """
    change = 0.0
    for c in range(s0, s0 + m):
        nx, ny, nz = contacts[c, C_NORMAL], contacts[c, C_NORMAL + 1], contacts[c, C_NORMAL + 2]
        rax, ray, raz = contacts[c, C_RA], contacts[c, C_RA + 1], contacts[c, C_RA + 2]
        rbx, rby, rbz = contacts[c, C_RB], contacts[c, C_RB + 1], contacts[c, C_RB + 2]
        ux, uy, uz = _point_velocity(vel, a, rax, ray, raz)
        if dyn_b:
            bx, by, bz = _point_velocity(vel, b, rbx, rby, rbz)
            ux, uy, uz = ux - bx, uy - by, uz - bz
        t1x, t1y, t1z, t2x, t2y, t2z = _tangent_basis(nx, ny, nz)
        k11, k12, k22 = _tangent_response(inv_mass, inv_inertia_w, a, b, dyn_b, wa, wb, rax, ray,
                                          raz, rbx, rby, rbz, t1x, t1y, t1z, t2x, t2y, t2z)
        if not k11 * k22 - k12 * k12 > 0.0:
            continue
        fx = contacts[c, C_FRICTION]
        fy = contacts[c, C_FRICTION + 1]
        fz = contacts[c, C_FRICTION + 2]
        f1 = fx * t1x + fy * t1y + fz * t1z
        f2 = fx * t2x + fy * t2y + fz * t2z
        u1 = ux * t1x + uy * t1y + uz * t1z
        u2 = ux * t2x + uy * t2y + uz * t2z
        w1 = u1 - (k11 * f1 + k12 * f2)
        w2 = u2 - (k12 * f1 + k22 * f2)
        n1, n2 = _coulomb(k11, k12, k22, w1, w2, mu * max(contacts[c, C_LAMBDA], 0.0))
        d1, d2 = n1 - f1, n2 - f2
        if d1 == 0.0 and d2 == 0.0:
            continue
        jx = d1 * t1x + d2 * t2x
        jy = d1 * t1y + d2 * t2y
        jz = d1 * t1z + d2 * t2z
        contacts[c, C_FRICTION] = fx + jx
        contacts[c, C_FRICTION + 1] = fy + jy
        contacts[c, C_FRICTION + 2] = fz + jz
        patches[q, Q_FT] += jx
        patches[q, Q_FT + 1] += jy
        patches[q, Q_FT + 2] += jz
        _apply(vel, inv_mass, inv_inertia_w, a, wa, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
        _record(wrench, a, 1.0, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
        if dyn_b:
            _apply(vel, inv_mass, inv_inertia_w, b, -wb, rbx, rby, rbz, jx, jy, jz,
                   0.0, 0.0, 0.0)
            _record(wrench, b, -1.0, rbx, rby, rbz, jx, jy, jz, 0.0, 0.0, 0.0)
        change = max(change, abs(d1) * k11, abs(d2) * k22)
    return change


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
    Store every point's relative velocity in ``out`` (C, 3), or compare with it.

    ``compare``: return the largest change since it was stored (m/s), else 0.
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
            else:
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
    60° of gravity (a neighbour beside it).
    """
    shared = prm.shape[1] == 1
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
            total += lam
            taken += 1
        if taken == 0:
            continue
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
            jx, jy, jz = lam * nx, lam * ny, lam * nz
            _apply(vel, inv_mass, inv_inertia_w, a, 1.0, rax, ray, raz, jx, jy, jz,
                   0.0, 0.0, 0.0)
            _record(wrench, a, 1.0, rax, ray, raz, jx, jy, jz, 0.0, 0.0, 0.0)
            if dyn_b:
                rbx, rby, rbz = contacts[c, C_RB], contacts[c, C_RB + 1], contacts[c, C_RB + 2]
                _apply(vel, inv_mass, inv_inertia_w, b, -1.0, rbx, rby, rbz, jx, jy, jz,
                       0.0, 0.0, 0.0)
                _record(wrench, b, -1.0, rbx, rby, rbz, jx, jy, jz, 0.0, 0.0, 0.0)


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


@_raw
def _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, scr, coupled,
            warmed, before):
    """
    Run the Gauss–Seidel sweeps of a stage, at most SWEEPS, until they converge.

    ``warmed``: the points may hold impulses already (a warm start).  ``before`` (C, 3) is
    scratch: a sweep's net change of every point's relative velocity is measured against it,
    since the updates of a sweep can each move by more than the tolerance while cancelling
    (impulses circulating between patches in the null space of a statically indeterminate
    stack), so each update's change alone does not tell when the velocities have converged.
    """
    for sweep in range(SWEEPS if coupled else 1):
        if coupled:
            _relative_velocities(patches, contacts, vel, n_bodies, before, False)
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


@_jit
def solve_stage(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, shock,
                rot, warm, warm_n, slot, prm):
    """
    Gauss–Seidel sweeps over the patches, then (``shock``) one shock-propagation pass.

    ``slot`` >= 0: the stage's row of the warm-start table (see :data:`W_SLOTS`), read before
    the sweeps and rewritten after them; -1 for none.  Return whether patches share a body
    (then friction is per point, else per patch).
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
        _warm_start(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, wrench, rot,
                    warm, warm_n, slot, prm, np.empty(n_bodies, dtype=np.bool_))
        _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, scr,
                coupled, True, before)
        left = _residual(patches, contacts, vel, n_bodies, scr)
        # Kept either way: the sweeps go on from there next step, so a stack that needs more
        # sweeps than the cap (a tall column converges by ~0.97 a sweep) gets them over steps.
        _keep_warm(patches, contacts, rot, warm, warm_n, slot)
        if left > WARM_LEFT_MAX_M_S:
            contacts[:] = saved[0]
            patches[:] = saved[1]
            vel[:] = saved[2]
            wrench[:] = saved[3]
            _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, scr,
                    coupled, False, before)
    else:
        if slot >= 0:
            warm_n[slot, :] = 0
        _sweeps(patches, contacts, vel, inv_mass, inv_inertia_w, n_bodies, x, wrench, scr,
                coupled, False, before)
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


# ---------------------------------------------------------------------------------------------
# The step.


@_jit
def contact_stage(x, prm, geo, st_kind, st_params, st_rot, st_pos, st_lo, st_hi, h, phase,
                  stage, shock, wrench, ws, same_pose):
    """
    One detection-and-impulse stage on the velocities stored in ``x``; return the contacts.

    ``geo`` is the shape table tuple (see :func:`world_step`), ``ws`` the per-body work arrays;
    ``same_pose``: no orientation changed since the last stage (see :func:`prepare_bodies`).
    """
    (kinds, sparams, pts, pt_off, ppts, ppt_off, pt_radius, bound_r, grid_data, grid_off,
     grid_dim, mu, eps, balls, ball_off, cell_of) = geo
    vel, inv_mass, inv_inertia_w, rot, pos_c, rot_c, touched, responses, warm, warm_n = ws
    slot = stage  # each stage of the step starts from its own last answer
    n = x.shape[1]
    prepare_bodies(x, prm, vel, inv_mass, inv_inertia_w, rot, pos_c, rot_c, h, same_pose)
    pairs = broad_phase(x, pos_c, bound_r, n, st_kind, st_params, st_lo, st_hi, MARGIN_M)
    contacts, patches = narrow_phase(
        pairs, n, x, prm, vel, rot, pos_c, rot_c, inv_mass, inv_inertia_w, st_rot, st_pos, kinds,
        sparams, pts, pt_off, ppts, ppt_off, pt_radius, grid_data, grid_off, grid_dim, mu, eps,
        h, phase, stage, responses, balls, ball_off, cell_of)
    if patches.shape[0] == 0:
        if slot >= 0:
            warm_n[slot, :] = 0
        return contacts
    touched[:] = False
    for q in range(patches.shape[0]):
        touched[int(patches[q, Q_A])] = True
        if patches[q, Q_B] < n:
            touched[int(patches[q, Q_B])] = True
    if not solve_stage(patches, contacts, vel, inv_mass, inv_inertia_w, n, x, wrench, shock,
                       rot, warm, warm_n, slot, prm):
        finish_contacts(contacts, patches)
    keep_responses(responses, patches, contacts, n, inv_mass, inv_inertia_w)
    store_velocities(x, prm, vel, touched)
    return contacts


@_inl
def _all_finite(x, i):
    for k in range(N_STATE):
        if not math.isfinite(x[k, i]):
            return False
    return True


@_raw
def _half_damping(x, prm, h):
    """Apply half a step of every body's exact damping flow to its velocities."""
    shared = prm.shape[1] == 1
    for i in range(x.shape[1]):
        j = 0 if shared else i
        cv, cw = prm[P_LIN_DAMPING, j], prm[P_ANG_DAMPING, j]
        if cv != 0.0 or cw != 0.0:
            dv, dw = math.exp(-0.5 * h * cv), math.exp(-0.5 * h * cw)
            for k in range(3):
                x[S_VEL + k, i] *= dv
                x[S_OMEGA + k, i] *= dw


@_jit
def world_step(x, prm, ld, t, method, h, dt_ns, n_steps, geo, statics, wrench, ws):
    """
    Advance the world ``n_steps`` steps; return ``(steps done, contacts of the last step)``.

    ``statics`` = ``(st_kind, st_params, st_rot, st_pos, st_lo, st_hi)``.  ``wrench`` (N, 6)
    receives the net contact force and torque about each COM (world) averaged over the last
    step.  A step that would leave any body non-finite is undone for every body (the world
    stays at its last finite state) and the loop stops.
    """
    st_kind, st_params, st_rot, st_pos, st_lo, st_hi = statics
    n = x.shape[1]
    shared = prm.shape[1] == 1
    saved = np.empty_like(x)
    c0 = c1 = c2 = np.zeros((0, N_CONTACT))
    done = 0
    same_pose = False  # the pose arrays in ws hold the current pose (see prepare_bodies)
    for _ in range(n_steps):
        saved[:] = x
        wrench[:] = 0.0
        # Damping's exact flow, half before and half after the step (as the free kernel).
        _half_damping(x, prm, h)
        # 1. Collisions with restitution on the current velocities.
        c0 = contact_stage(x, prm, geo, st_kind, st_params, st_rot, st_pos, st_lo, st_hi, h,
                           PHASE_COLLISION, 0, False, wrench, ws, same_pose)
        if method == kk.MIDPOINT_CAYLEY:
            lmom = np.empty((n, 3))
            # 2. First half kick.
            for i in range(n):
                j = 0 if shared else i
                px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = kk._read_state(x, i)
                vx, vy, vz, lx, ly, lz = kk.midpoint_first_kick(
                    prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz)
                x[S_VEL, i], x[S_VEL + 1, i], x[S_VEL + 2, i] = vx, vy, vz
                wx, wy, wz = kk._matvec(prm, P_INV_INERTIA, j, lx, ly, lz)
                x[S_OMEGA, i], x[S_OMEGA + 1, i], x[S_OMEGA + 2, i] = wx, wy, wz
                lmom[i, 0], lmom[i, 1], lmom[i, 2] = lx, ly, lz
            # 3. Contacts on the kicked velocities.
            c1 = contact_stage(x, prm, geo, st_kind, st_params, st_rot, st_pos, st_lo, st_hi,
                               h, PHASE_CONTACT, 1, True, wrench, ws, True)
            touched = ws[6]
            # 4. Drift; then the second half kick and its contact stage.
            for i in range(n):
                j = 0 if shared else i
                px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = kk._read_state(x, i)
                if c1.shape[0] > 0 and touched[i]:
                    lx, ly, lz = kk._matvec(prm, P_INERTIA, j, wx, wy, wz)
                else:
                    lx, ly, lz = lmom[i, 0], lmom[i, 1], lmom[i, 2]
                (px, py, pz, qw, qx, qy, qz, lx, ly, lz, wx, wy, wz,
                 converged) = kk.midpoint_drift(prm, j, h, px, py, pz, qw, qx, qy, qz,
                                                vx, vy, vz, lx, ly, lz)
                if not converged:
                    px = math.nan
                vx, vy, vz, wx, wy, wz = kk.midpoint_second_kick(
                    prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz,
                    lx, ly, lz, wx, wy, wz)
                kk._write_state(x, i, (px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz))
            c2 = contact_stage(x, prm, geo, st_kind, st_params, st_rot, st_pos, st_lo, st_hi,
                               h, PHASE_CONTACT, 2, True, wrench, ws, False)
            same_pose = True  # the next step's first stage sees this pose
        else:
            for i in range(n):
                j = 0 if shared else i
                px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = kk._read_state(x, i)
                vx, vy, vz, wx, wy, wz = kk.se_velocity(
                    prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz)
                kk._write_state(x, i, (px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz))
            c1 = contact_stage(x, prm, geo, st_kind, st_params, st_rot, st_pos, st_lo, st_hi,
                               h, PHASE_CONTACT, 1, True, wrench, ws, True)
            for i in range(n):
                px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = kk._read_state(x, i)
                px, py, pz, qw, qx, qy, qz = kk.se_position(
                    method, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz)
                kk._write_state(x, i, (px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz))
        _half_damping(x, prm, h)
        ok = True
        for i in range(n):
            if not _all_finite(x, i):
                ok = False
                break
        if not ok:
            x[:] = saved
            break
        for i in range(n):
            t[i] += dt_ns
        done += 1
    inv_h = 1.0 / h
    for i in range(n):
        for k in range(6):
            wrench[i, k] *= inv_h
    # The contacts of the last step (c2 is empty unless the method has a second stage).
    return done, np.concatenate((c0, c1, c2))
