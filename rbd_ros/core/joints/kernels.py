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
The articulated step's entry: the step driver, with the method and a map of its stages.

Bodies are in maximal coordinates, state row ``x[b] = (p_w, q_wb, v_w, ω_b)`` (13 floats). The
constrained accelerations solve the saddle-point system

    ``[[M, Jᵀ], [J, 0]] [a; -λ] = [f; -J̇ u]``,   ``M = diag(m I₃, I_w)``, ``u = (v_w, ω_w)``,

for the body accelerations ``a = (v̇_w, ω̇_w)`` and the multipliers ``λ`` (the constraint
wrench on the bodies is ``Jᵀ λ``, equal and opposite by construction of each row). ``f`` holds
gravity, the body damping as a force (``-m c_v v``, ``-c_ω R I_b ω_b``), the gyroscopic
torque ``-ω × I_w ω`` and each joint's applied force along its coordinate (an effort or
saturated motor, the joint damping ``-d q̇`` and a sliding joint's friction ``-f s``, summed in
:func:`~.dynamics._motor_forces`). A stuck joint's Coulomb friction is a row
(:data:`ROW_FRICTION`) whose multiplier is bounded by the friction, decided at step boundaries.
Two solvers, both direct (:mod:`.solve`):

- **tree** (Baraff 1996): the system's graph with one node a body (6 rows) and one a joint
  (its rows) is a tree when no loop closes; it is factored leaves first by block LDLᵀ, one
  pass linear in the number of joints. A component is rooted at its world joint (or at a
  body when it has none), so every joint node is eliminated after a body and its block is
  negative definite.
- **dense**: with a loop (a body-joint cycle, or two world joints in one component) the
  reduced system ``J M⁻¹ Jᵀ λ = ...`` is built dense and factored by LDLᵀ; a pivot below
  :data:`~.solve.DROP_REL` of its diagonal is a redundant row (a planar four-bar's
  out-of-plane rows) and its multiplier is set to zero.

The same factorisation serves the projections: positions by Newton with the mass-weighted
minimal change (right side ``[0; -C]``), velocities by ``[0; -J u]``.

No kernel here allocates (every buffer is in :data:`ArtWork`), so all are compiled without
numba's reference counting (:func:`rbd_ros.core.jitcache.raw_kernel`, as the contact step's
loops): each call of a function taking ``model`` and ``work`` (some 40 arrays) otherwise paid
two atomic updates per array.

The stages, one module each, in the order a step runs them:

- :mod:`.arrays`: the records (:data:`ArtModel`, :data:`ArtWork`), their columns and codes;
- :mod:`.rows`: body frames and each joint's rows (``C``, ``J``, ``J̇ u``, coordinates);
- :mod:`.solve`: the factorisation and solves (tree and dense);
- :mod:`.active_rows`: which limit, motor and friction rows are held;
- :mod:`.dynamics`: the applied forces, the accelerations, one RK4 sub-step;
- :mod:`.projection`: positions onto the joints, then velocities;
- :mod:`.events`: limit crossings and friction stops located inside a sub-step;
- here: :func:`substeps` (how many sub-steps a step takes) and :func:`step`, the driver.

The simulators (:mod:`rbd_ros.core.joints.simulator`, the contact step's joint stages in
:mod:`rbd_ros.core.contact`) read the kernels and columns as ``kernels.X``: they are imported
here for that.
"""

import math

from rbd_ros.core import jitcache
from rbd_ros.core.joints.active_rows import (  # noqa: F401
    _friction_event, _motor_rows_on, FRICTION_REST_RATE, refresh_rows, set_limit)
from rbd_ros.core.joints.arrays import (  # noqa: F401
    ArtModel, ArtWork, B_OMEGA_W, B_ROT, B_SIZE, F_APPLIED, F_RATE0, F_RATE_END, F_SIGN, F_SIGN0,
    F_SIZE, J_BASIS_C, J_BASIS_P, J_CHILD, J_DAMPING, J_FRICROW, J_FRICTION, J_INT_SIZE, J_KIND,
    J_LIMROW, J_MIMIC_C, J_MIMIC_K, J_MIMROW, J_MOTROW, J_NROWS, J_ORIGIN_C, J_ORIGIN_P, J_PARENT,
    J_PRM_SIZE, J_QREST, J_ROW0, KIND_CODES, L_HAS_LOWER, L_HAS_UPPER, L_LOWER, L_UPPER, M_APPLIED,
    M_AREF, M_EFFORT, M_HOLD, M_HOLD_RATE, M_LIMIT, M_MODE, M_OMEGA, M_POSITION, M_SAT, M_SIZE,
    M_TREF, M_VELOCITY, M_VREF, MOTOR_EFFORT, MOTOR_OFF, MOTOR_POSITION, MOTOR_VELOCITY,
    P_ANG_DAMP, P_GRAVITY, P_INERTIA, P_INERTIA_INV, P_LIN_DAMP, P_MASS, P_SIZE, ROW_ANG,
    ROW_FRICTION, ROW_LIMIT, ROW_LIN, ROW_MIMIC, ROW_MOTOR, S_CLAMPED, S_ERR, S_FAIL, S_ITER,
    S_SIZE, S_SPLIT, S_STOP_JOINT, S_STOP_SPEED, S_STOP_TIME, S_STOPS, S_SUBSTEPS, S_TIME,
    S_TSTAGE)
from rbd_ros.core.joints.dynamics import (  # noqa: F401
    _end_of_step, _rk4, initialize, refresh_dynamics)
from rbd_ros.core.joints.events import (  # noqa: F401
    _clamped_rest, _crossing, _hold_at_bounds, _joint_speed, _locate, _restore, _save_start,
    CROSS_TOL, EVENT_LIMIT, EVENT_STOP)
from rbd_ros.core.joints.projection import (  # noqa: F401
    _max_abs, _project_positions, _project_velocities, _unwrap)
from rbd_ros.core.joints.rows import (  # noqa: F401
    _mtv, _mv, _rot_of, _row_rate, _side_body, body_derived, joint_rows, limit_coordinate)
from rbd_ros.core.joints.solve import factor, solve  # noqa: F401

_jit = jitcache.raw_kernel()
_inl = jitcache.kernel(inline='always')


#: A step is split into equal sub-steps when a body, or a joint's child relative to its
#: parent, would turn by more than this (rad) in it at the rates of the step's start
#: (:func:`substeps`). RK4's error grows as the fifth power of the angle turned per step:
#: the double pendulum from horizontal at 10 ms, whose elbow turns up to 0.23 rad a step,
#: gave max |dE| / (m g L) 1.4e-3 over 60 s unsplit; 2.3e-5 split at 0.1 rad (18 % more
#: RK4 steps), 2.2e-4 at 0.15, 1.6e-5 with bodies' rates alone at 0.05 (57 % more).
SUBSTEP_ROTATION = 0.1
#: The most sub-steps one step is split into (a bound on one step's cost: a rotation of
#: 1.6 rad a step still gives 0.1 rad a sub-step).
SUBSTEPS_MAX = 16


@_inl
def _omega_w(x, b):
    """Return body ``b``'s angular velocity in the world frame (zeros for the world, -1)."""
    if b < 0:
        return 0.0, 0.0, 0.0
    r = _rot_of(x, b)
    w0, w1, w2 = x[b, 10], x[b, 11], x[b, 12]
    return (r[0] * w0 + r[1] * w1 + r[2] * w2, r[3] * w0 + r[4] * w1 + r[5] * w2,
            r[6] * w0 + r[7] * w1 + r[8] * w2)


@_jit
def substeps(model, x, h):
    """
    Return how many equal sub-steps the step ``h`` from ``x`` is taken in (1: not split).

    The fewest that turn no body (``|ω|``) and no joint (``|ω_child - ω_parent|``, world
    frame: a hinge's rate, a ball's, a universal or planar joint's rotation alike) by more
    than :data:`SUBSTEP_ROTATION` each at the rates of ``x``, at most :data:`SUBSTEPS_MAX`.
    A slide is left out: a joint moving at a constant rate is integrated exactly, and what
    makes its acceleration change fast is a rotation (its own body's or its parent's).
    """
    top = 0.0
    for b in range(x.shape[0]):
        top = max(top, x[b, 10] * x[b, 10] + x[b, 11] * x[b, 11] + x[b, 12] * x[b, 12])
    jint = model.jint
    for j in range(jint.shape[0]):
        if jint[j, J_PARENT] < 0:
            continue   # a joint to the world turns as its child, counted above
        c0, c1, c2 = _omega_w(x, jint[j, J_CHILD])
        p0, p1, p2 = _omega_w(x, jint[j, J_PARENT])
        top = max(top, (c0 - p0) ** 2 + (c1 - p1) ** 2 + (c2 - p2) ** 2)
    turn = math.sqrt(top) * h
    if not turn > SUBSTEP_ROTATION:   # not split (a non-finite rate is refused by the step)
        return 1
    return int(min(SUBSTEPS_MAX, math.ceil(turn / SUBSTEP_ROTATION)))


@_jit
def step(model, x, work, h, n_steps, tol, max_iter):
    """
    ``n_steps`` classical RK4 steps of the constrained ODE, each followed by the projection.

    A step whose start turns a body or a joint fast (:func:`substeps`) is taken as that many
    equal sub-steps, each a step below; the rest of this text calls either a step. They are
    counted in ``stats[S_SPLIT]`` and ``stats[S_SUBSTEPS]``.
    A limit crossed inside a step (by more than :data:`CROSS_TOL`) splits it: the crossing
    time is found by the Illinois method on ``q(RK4(x0, τ)) - bound`` (each trial a full RK4
    sub-step and projection from the step's start) until ``|q - bound| <= LOCATE_TOL``; there
    the limit row is made active, the velocity projection stops the joint dead (an equal and
    opposite impulse: the inelastic stop) and the rest of the step is taken with the row held.
    A sub-step that begins at or (within :data:`CROSS_TOL`) past a bound and goes on into it
    stops at its start; every other free limit at its bound and moving into it is held in the
    same impact (:func:`_hold_at_bounds`).
    A sliding joint whose rate crosses zero inside a step (Coulomb friction) splits it the same
    way: the time its rate reaches zero is found by the Illinois method to
    :data:`~.events.STOP_RATE_TOL`, the joint sticks there (its friction row held, the velocity
    projection taking out what is left of its rate) and the rest of the step is taken from
    there, stuck or, if its load exceeds its friction, sliding the other way.
    A step has ``2 n_joints + 2 + 2 n_friction`` such passes; one whose events outnumber them
    (limits stopped and released in turn) takes its rest in one sub-step whose crossings are
    clamped at its end (:func:`_clamped_rest`, counted in ``stats[S_CLAMPED]``), so every
    step advances the state and the clock by ``h``.
    ``work.k[0]`` must hold ``ẋ`` at ``x`` (left there by :func:`initialize` and by every
    step). Return 0, or the step index + 1 at which the position projection failed.
    """
    worst = 0.0
    worst_it = 0
    work.stats[S_STOPS] = 0.0
    work.stats[S_CLAMPED] = 0.0
    work.stats[S_SPLIT] = 0.0
    work.stats[S_SUBSTEPS] = 1.0
    n_friction = 0
    for j in range(model.jint.shape[0]):
        if model.jint[j, J_FRICROW] >= 0:
            n_friction += 1
    n_passes = 2 * model.jint.shape[0] + 2 + 2 * n_friction
    s, sub, n_sub, hs = 0, 0, 1, h
    while s < n_steps:   # step s, its sub-step sub of n_sub, each hs long
        if sub == 0:
            n_sub = substeps(model, x, h)
            hs = h / n_sub   # h itself when not split
            if n_sub > 1:
                work.stats[S_SPLIT] += 1.0
                work.stats[S_SUBSTEPS] = max(work.stats[S_SUBSTEPS], float(n_sub))
        left = hs
        for p in range(n_passes + 1):
            _save_start(model, x, work)
            if p == n_passes:
                # the event passes are used up (limits stopped and released in turn, as a
                # position target moving beyond a bound that gravity pulls the joint off):
                # the rest of the step is one sub-step, its crossings clamped at its end
                it, j, speed = _clamped_rest(model, x, work, left, tol, max_iter)
                if it < 0:
                    _restore(model, x, work)  # stays finite: back to the sub-step start
                    work.stats[S_FAIL] = 1.0
                    return s + 1
                if j >= 0:
                    work.stats[S_STOPS] += 1.0
                    work.stats[S_STOP_JOINT] = j
                    work.stats[S_STOP_SPEED] = speed
                    work.stats[S_STOP_TIME] = ((s + 1) * h if sub == n_sub - 1
                                               else s * h + (sub + 1) * hs)
                work.stats[S_CLAMPED] += 1.0
                work.stats[S_TIME] += left
                work.stats[S_TSTAGE] = work.stats[S_TIME]
                worst = max(worst, work.stats[S_ERR])
                worst_it = max(worst_it, it)
                break
            it = _rk4(model, x, work, left, tol, max_iter)
            if it < 0:
                _restore(model, x, work)  # stays finite: back to the sub-step start
                work.stats[S_FAIL] = 1.0
                return s + 1
            j, side, excess = _crossing(model, x, work)
            if j < 0:
                jf = _friction_event(model, work) if n_friction > 0 else -1
                if jf < 0:
                    work.stats[S_TIME] += left
                    worst = max(worst, work.stats[S_ERR])
                    worst_it = max(worst_it, it)
                    break
                # a sliding joint stopped inside the sub-step: locate when its rate reached
                # zero, g(τ) = -s q̇(τ): g(0) < 0 < g(left), stick it there, go on
                sign = work.fric[jf, F_SIGN0]
                tau, g = _locate(model, x, work, EVENT_STOP, jf, sign, 0.0,
                                 -sign * work.fric[jf, F_RATE0], left,
                                 -sign * work.fric[jf, F_RATE_END], hs, tol, max_iter)
                if tau < 0.0:   # the projection failed; x is back at the sub-step start
                    work.stats[S_FAIL] = 1.0
                    return s + 1
                if g < 0.0 and work.fric[jf, F_SIGN] == sign:
                    # within STOP_RATE_TOL short of zero and still sliding: stick it now
                    work.fric[jf, F_SIGN] = 0.0
                    work.active[model.jint[jf, J_FRICROW]] = 1
                    refresh_rows(model, work, jf)
                    joint_rows(model, x, work, True)   # _end_of_step takes the rows as x's
                    _end_of_step(model, x, work)
                work.stats[S_TIME] += tau
                work.stats[S_TSTAGE] = work.stats[S_TIME]
                worst = max(worst, work.stats[S_ERR])
                worst_it = max(worst_it, it)
                left -= tau
                if left <= 1e-12 * hs:
                    work.stats[S_TIME] += left   # the clock takes the step whole
                    break
                continue
            bound = model.jlim[j, L_UPPER] if side > 0 else model.jlim[j, L_LOWER]
            g_start = side * (limit_coordinate(model, work.x0, j) - bound)
            if g_start >= 0.0:
                # the sub-step began at or (by less than CROSS_TOL) past the bound and went on
                # into it: the crossing is its start, no search (one would extrapolate to
                # τ < 0); stop there
                _restore(model, x, work)
                tau = 0.0
            else:
                # g(τ) = side (q(τ) - bound): g(0) < 0 < g(left) = excess
                tau, _ = _locate(model, x, work, EVENT_LIMIT, j, side, bound, g_start, left,
                                 excess, hs, tol, max_iter)
                if tau < 0.0:   # the projection failed; x is back at the sub-step start
                    work.stats[S_FAIL] = 1.0
                    return s + 1
            # stop dead: hold the bound as an equality row, project positions onto it,
            # then the velocity projection takes out the speed into the stop; every other
            # free limit at its bound and moving into it is held in the same impact
            speed = _joint_speed(model, x, work, j)
            set_limit(model, work, j, side)
            _hold_at_bounds(model, x, work)
            body_derived(model, x, work)
            joint_rows(model, x, work, True)
            factor(model, work)
            if _project_positions(model, x, work, tol, max_iter, 0) < 0:
                _restore(model, x, work)  # stays finite: back to the sub-step start
                work.stats[S_FAIL] = 1.0
                return s + 1
            _end_of_step(model, x, work)
            work.stats[S_STOPS] += 1.0
            work.stats[S_STOP_JOINT] = j
            work.stats[S_STOP_SPEED] = speed
            work.stats[S_STOP_TIME] = s * h + sub * hs + (hs - left) + tau
            work.stats[S_TIME] += tau
            work.stats[S_TSTAGE] = work.stats[S_TIME]
            worst = max(worst, work.stats[S_ERR])
            left -= tau
            if left <= 1e-12 * hs:
                work.stats[S_TIME] += left   # the clock takes the step whole
                break
        for b in range(x.shape[0]):  # a step that is not finite is refused, not kept
            for i in range(13):
                if not math.isfinite(x[b, i]):
                    _restore(model, x, work)
                    work.stats[S_FAIL] = 2.0
                    return s + 1
        sub += 1
        if sub == n_sub:
            s, sub = s + 1, 0
    work.stats[S_ERR] = worst
    work.stats[S_ITER] = worst_it
    return 0
