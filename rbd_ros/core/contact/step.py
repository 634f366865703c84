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
   levels is solved with the lower body held as if of infinite mass.  Each **island** of the
   contact graph (the patches whose bodies touch, directly or through others) is solved alone
   (:func:`~rbd_ros.core.contact.sweeps.solve_islands`), so a body's motion never depends on
   bodies it does not touch.  Where patches share bodies (a stack) the sweeps start from the
   normal impulses (and each point's friction) the same stage of the last step ended with (a
   **warm start**, :data:`W_SLOTS`); they stop when a sweep changes no point of the island's
   relative velocity by more than :data:`SWEEP_TOL_M_S` (``WorldSimulator.solve_stats``
   counts them).  So a resting stack's
   sweeps converge, in two or three, and each box's recorded contact force is its weight;
   from zero they ran to their cap and shock propagation made up the rest.
4. **Positions** with the final velocities.  ``midpoint_cayley`` (kick–drift–kick) then does
   its second half kick and a second contact stage, so the friction of each half kick acts on
   the velocity the drift uses: a box sliding to a stop decelerates by exactly ``μ g`` over
   every whole step and stops within O(h²) of the exact distance.

A world with joints (:mod:`rbd_ros.core.contact.joints`) also post-stabilizes them after 1 and
2, and pre-stabilizes them (post-stabilizes, in the second contact stage) alternating with the
sweeps of 3, each sweep with the points' targets taken again about the velocities reached and
followed by a shock pass whose levels see the joints (``joint_sweeps``).

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
bit-identical run after run.  A world without joints is separable: stepping two groups of
bodies that never come within reach of each other gives each group the bits it gets alone
(``tests/core/contact/test_islands.py``).  A jointed world's stages are solved as one group
(its joint visits alternate with sweeps of every patch).

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
:func:`rbd_ros.core.jitcache.raw_kernel`), and the functions that allocate (the broad
phase's and the narrow phase's buffers, a stage's scratch) only call them: about 3 000 are
left a step.  A raw
function cannot call one that allocates (numba compiles the callee without reference
counting too), which is why :func:`_consistent_normals`, which sorts, is called from
:func:`narrow_phase` between two calls of ``_pair_rows``, which makes the pairs' points and
patches.
"""

import math

import numpy as np

from rbd_ros.core import kernels as kk
from rbd_ros.core.contact.bodies import prepare_bodies, store_velocities
from rbd_ros.core.contact.broad_phase import broad_phase
from rbd_ros.core.contact.joints import (damp, J_FAIL, joint_sweeps, motors_finish,
                                         motors_kick, motors_start, post_stabilize, visit,
                                         VISIT_NONE, VISIT_POST, VISIT_PRE)
from rbd_ros.core.contact.motors import count_friction, saturate
from rbd_ros.core.contact.narrow_phase import keep_responses, narrow_phase
from rbd_ros.core.contact.rows import (_inl, _jit, _raw, MARGIN_M, N_CONTACT, PHASE_COLLISION,
                                       PHASE_CONTACT, Q_A, Q_B, Shapes, Statics, Work)
from rbd_ros.core.contact.sweeps import finish_contacts, solve_islands, solve_stage
from rbd_ros.core.layout import (N_STATE, P_ANG_DAMPING, P_INERTIA, P_INV_INERTIA, P_LIN_DAMPING,
                                 S_OMEGA, S_VEL)


# ---------------------------------------------------------------------------------------------
# The step.


@_jit
def contact_stage(x, prm, shapes, statics, h, phase, stage, shock, wrench, work, same_pose,
                  joints, kind, method):
    """
    One detection-and-impulse stage on the velocities stored in ``x``; return the contacts.

    ``shapes``, ``statics`` and ``work`` are the :class:`~rbd_ros.core.contact.rows.Shapes`,
    :class:`~rbd_ros.core.contact.rows.Statics` and :class:`~rbd_ros.core.contact.rows.Work`
    of the world; ``same_pose``: no orientation changed since the last stage (see
    :func:`prepare_bodies`).  The stages in order: the bodies' poses and velocities, the broad
    phase, the narrow phase, the sweeps with shock propagation, the velocities back.
    ``joints``: None, or the world's :class:`~rbd_ros.core.contact.joints.JointStage`, whose
    visits of ``kind`` (``VISIT_*``) then alternate with the sweeps and end the stage (a visit
    alone when nothing touches); ``method`` is the integrator (a pre-stabilization drifts as
    it does).  numba compiles a ``None`` world without any of the joints' code.
    """
    vel, inv_mass, inv_inertia_w = work.vel, work.inv_mass, work.inv_inertia_w
    rot, pos_c, rot_c, touched = work.rot, work.pos_c, work.rot_c, work.touched
    responses, warm, warm_n = work.responses, work.warm, work.warm_n
    slot = stage  # each stage of the step starts from its own last answer
    n = x.shape[1]
    prepare_bodies(x, prm, vel, inv_mass, inv_inertia_w, rot, pos_c, rot_c, h, same_pose)
    pairs = broad_phase(x, pos_c, shapes.bound_r, n, statics.kind, statics.params, statics.lo,
                        statics.hi, MARGIN_M, shapes.skip, work.span)
    contacts, patches = narrow_phase(pairs, n, x, prm, work, statics, shapes, h, phase, stage)
    if patches.shape[0] == 0:
        if slot >= 0:
            warm_n[slot, :] = 0
        if joints is not None:
            if kind != VISIT_NONE:
                visit(joints, x, vel, False, prm, method, h, kind)
        return contacts
    touched[:] = False
    for q in range(patches.shape[0]):
        touched[int(patches[q, Q_A])] = True
        if patches[q, Q_B] < n:
            touched[int(patches[q, Q_B])] = True
    if joints is None:
        solve_islands(patches, contacts, vel, inv_mass, inv_inertia_w, n, x, wrench, shock, rot,
                      warm, warm_n, slot, prm, work.stats)
    else:
        vel0 = vel.copy()   # the velocities the candidates drifted with (see retarget)
        coupled = solve_stage(patches, contacts, vel, inv_mass, inv_inertia_w, n, x, wrench,
                              shock, rot, warm, warm_n, slot, prm, work.stats)
        if kind != VISIT_NONE:
            for i in range(n):
                touched[i] = touched[i] or joints.jointed[i]
            joint_sweeps(joints, kind, patches, contacts, vel, vel0, shapes.pt_radius, inv_mass,
                         inv_inertia_w, x, wrench, coupled, shock, prm, method, h)
        if not coupled:
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
def world_step(x, prm, ld, t, method, h, dt_ns, n_steps, shape_fields, static_fields, wrench,
               work_fields, joints):
    """
    Advance the world ``n_steps`` steps; return ``(steps done, contacts of the last step)``.

    ``shape_fields``, ``static_fields``, ``work_fields``: the fields of the world's
    :class:`~rbd_ros.core.contact.rows.Shapes`, :class:`~rbd_ros.core.contact.rows.Statics`
    and :class:`~rbd_ros.core.contact.rows.Work` as plain tuples, named again here: numba
    types a named tuple argument in Python at every call (measured 0.9 µs each, 3 % of a step
    of a 10-box column), a plain tuple in its C fast path.  ``wrench`` (N, 6)
    receives the net contact force and torque about each COM (world) averaged over the last
    step.  A step that would leave any body non-finite is undone for every body (the world
    stays at its last finite state) and the loop stops.

    ``joints``: None, or the :class:`~rbd_ros.core.contact.joints.JointStage` of a jointed
    world, whose visits go where Weinstein, Teran and Fedkiw put them: post-stabilization
    after the collision stage and after the velocity update, pre-stabilization alternating
    with the sweeps of the contact stage before the drift (:func:`contact_stage`), and, with
    kick–drift–kick, post-stabilization alternating with the second contact stage's sweeps.
    A step whose pre-stabilization misses its tolerance is undone like a non-finite one
    (``joints.stats[J_FAIL]`` says which). The joints' motors (:mod:`~rbd_ros.core.contact.
    motors`) begin each step from its start (``motors_start``), give their efforts with each
    velocity update (``motors_kick``) and their rows in the visits; a step in which a position
    or velocity motor needed more than its effort limit, or a stuck joint more than its
    friction, is taken again from its start with that motor saturated or that joint slipping
    (``saturate``), at most once more per joint and friction. The joints' damping is its
    exact flow between two post-stabilizations, never on a kick's rates before they are
    projected: symplectic Euler kick, project, damp, project; kick–drift–kick half the flow
    before its first half kick and half after its second (kick, project, damp, project:
    its contact stage then sees the rates the joints have), symmetric as the bodies'
    damping, so the damped motion stays second order.
    Limits (:mod:`~rbd_ros.core.contact.limits`) are freed at each step's start and held by
    the pre-stabilization where the drift would cross them.
    """
    shapes, statics, work = Shapes(*shape_fields), Statics(*static_fields), Work(*work_fields)
    n = x.shape[1]
    shared = prm.shape[1] == 1
    saved = np.empty_like(x)
    c0 = c1 = c2 = np.zeros((0, N_CONTACT))
    done = 0
    same_pose = False  # the pose arrays in ws hold the current pose (see prepare_bodies)
    for _ in range(n_steps):
        saved[:] = x
        attempts = 1
        if joints is not None:
            attempts = joints.work.motor.shape[0] + 1 + count_friction(joints)
        ok = True
        for attempt in range(attempts):
            if attempt > 0:   # a motor beyond its effort limit: the step again, it saturated
                x[:] = saved
                # The pose arrays hold the failed attempt's poses, not the step's start: made
                # again from x, as for the first step of a call (else the result would depend
                # on where the call's chunks end: a replay would not match its node).
                same_pose = False
            wrench[:] = 0.0
            if joints is not None:
                motors_start(joints, x, work.vel, attempt, h)
            # Damping's exact flow, half before and half after the step (as the free kernel).
            _half_damping(x, prm, h)
            # 1. Collisions with restitution on the current velocities.
            c0 = contact_stage(x, prm, shapes, statics, h, PHASE_COLLISION, 0, False, wrench,
                               work, same_pose, joints, VISIT_NONE, method)
            if joints is not None:
                post_stabilize(joints, x, work.vel, False)
            if method == kk.MIDPOINT_CAYLEY:
                # The joints' damping: half its flow before the first half kick, half after
                # the second, each between two projections (symmetric, as the bodies').
                if joints is not None:
                    if damp(joints, x, work.vel, 0.5 * h, False):
                        post_stabilize(joints, x, work.vel, False)
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
                if joints is not None:
                    motors_kick(joints, x, work.vel, 0.5 * h, False)
                    post_stabilize(joints, x, work.vel, False)
                # 3. Contacts on the kicked velocities.
                c1 = contact_stage(x, prm, shapes, statics, h, PHASE_CONTACT, 1, True, wrench,
                                   work, True, joints, VISIT_PRE, method)
                touched = work.touched
                # 4. Drift; then the second half kick and its contact stage.
                for i in range(n):
                    j = 0 if shared else i
                    px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = kk._read_state(x, i)
                    spun = c1.shape[0] > 0 and touched[i]
                    if joints is not None:
                        spun = spun or joints.jointed[i]   # the joints' visits changed its ω
                    if spun:
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
                if joints is not None:
                    motors_kick(joints, x, work.vel, 0.5 * h, True)
                    # The damped joints' rates are the rows' again before the contacts.
                    if damp(joints, x, work.vel, 0.5 * h, True):
                        post_stabilize(joints, x, work.vel, False)
                c2 = contact_stage(x, prm, shapes, statics, h, PHASE_CONTACT, 2, True, wrench,
                                   work, False, joints, VISIT_POST, method)
                same_pose = True  # the next step's first stage sees this pose
            else:
                for i in range(n):
                    j = 0 if shared else i
                    px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = kk._read_state(x, i)
                    vx, vy, vz, wx, wy, wz = kk.se_velocity(
                        prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz)
                    kk._write_state(x, i, (px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz))
                if joints is not None:
                    motors_kick(joints, x, work.vel, h, False)
                    damp(joints, x, work.vel, h, True)
                    post_stabilize(joints, x, work.vel, False)
                c1 = contact_stage(x, prm, shapes, statics, h, PHASE_CONTACT, 1, True, wrench,
                                   work, True, joints, VISIT_PRE, method)
                for i in range(n):
                    px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = kk._read_state(x, i)
                    px, py, pz, qw, qx, qy, qz = kk.se_position(
                        method, h, px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz)
                    kk._write_state(x, i, (px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz))
            _half_damping(x, prm, h)
            for i in range(n):
                if not _all_finite(x, i):
                    ok = False
                    break
            if joints is not None:
                if joints.stats[J_FAIL] != 0.0:
                    ok = False
            if not ok:
                break
            redo = False
            if joints is not None:
                redo = saturate(joints, h)
            if not redo:
                break
        if not ok:
            x[:] = saved
            break
        if joints is not None:
            motors_finish(joints, x, work.vel, h)
        for i in range(n):
            t[i] += dt_ns
        done += 1
    inv_h = 1.0 / h
    for i in range(n):
        for k in range(6):
            wrench[i, k] *= inv_h
    # The contacts of the last step (c2 is empty unless the method has a second stage).
    return done, np.concatenate((c0, c1, c2))
