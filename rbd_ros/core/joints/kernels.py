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
The articulated step's numba kernels: constraint rows, the direct solve, RK4 and projection.

Bodies are in maximal coordinates, state row ``x[b] = (p_w, q_wb, v_w, ω_b)`` (13 floats). The
constrained accelerations solve the saddle-point system

    ``[[M, Jᵀ], [J, 0]] [a; -λ] = [f; -J̇ u]``,   ``M = diag(m I₃, I_w)``, ``u = (v_w, ω_w)``,

for the body accelerations ``a = (v̇_w, ω̇_w)`` and the multipliers ``λ`` (the constraint
wrench on the bodies is ``Jᵀ λ``, equal and opposite by construction of each row). ``f`` holds
gravity, the body damping as a force (``-m c_v v``, ``-c_ω R I_b ω_b``), the gyroscopic
torque ``-ω × I_w ω`` and each joint's applied force along its coordinate (an effort or
saturated motor, the joint damping ``-d q̇`` and a sliding joint's friction ``-f s``, summed in
:func:`_motor_forces`). A stuck joint's Coulomb friction is a row (:data:`ROW_FRICTION`) whose
multiplier is bounded by the friction, decided at step boundaries. Two solvers, both direct:

- **tree** (Baraff 1996): the system's graph with one node a body (6 rows) and one a joint
  (its rows) is a tree when no loop closes; it is factored leaves first by block LDLᵀ, one
  pass linear in the number of joints. A component is rooted at its world joint (or at a
  body when it has none), so every joint node is eliminated after a body and its block is
  negative definite.
- **dense**: with a loop (a body-joint cycle, or two world joints in one component) the
  reduced system ``J M⁻¹ Jᵀ λ = ...`` is built dense and factored by LDLᵀ; a pivot below
  :data:`DROP_REL` of its diagonal is a redundant row (a planar four-bar's out-of-plane rows)
  and its multiplier is set to zero.

The same factorisation serves the projections: positions by Newton with the mass-weighted
minimal change (right side ``[0; -C]``), velocities by ``[0; -J u]``.

No kernel here allocates (every buffer is in :data:`ArtWork`), so all are compiled without
numba's reference counting (:func:`rbd_ros.core.jitcache.raw_kernel`, as the contact step's
loops): each call of a function taking ``model`` and ``work`` (some 40 arrays) otherwise paid
two atomic updates per array.
"""

from collections import namedtuple
import math

from rbd_ros.core import jitcache

_jit = jitcache.raw_kernel()
_inl = jitcache.kernel(inline='always')

#: Joint kind codes (the order of :data:`rbd_ros.core.joints.model.JOINT_KINDS`).
KIND_CODES = {'fixed': 0, 'revolute': 1, 'continuous': 2, 'prismatic': 3, 'spherical': 4,
              'universal': 5, 'planar': 6}
#: Row kinds: a position row ``C = e_k · d`` and an alignment row ``C = e_k · f_l``.
ROW_LIN = 0
ROW_ANG = 1
#: A limit row: ``C = q - bound`` (``q`` the revolute angle or prismatic offset on ``axis_b``,
#: or a spherical joint's angle off ``axis_b``, bounded by its cone; :func:`limit_coordinate`).
ROW_LIMIT = 2
#: A motor row: the joint rate held at a velocity target, or the critically damped
#: acceleration toward a position target; absent from the position projection. A planar
#: joint has three, one a coordinate: x and y (``e_k · d``, ``k`` 0 and 1: a force pair along
#: the in-plane axis) and theta (the twist about ``axis_b``: a torque pair); a universal joint
#: two: θ1 about ``axis_b`` (``k`` 2, as a revolute joint's) and θ2 about the child's cross
#: axis (``k`` 0, a torque pair about ``R_c w1``).
ROW_MOTOR = 3
#: A friction row: the joint's rate held at zero while its Coulomb friction sticks it (a
#: velocity row, ``q̈ = 0`` inside the step), its multiplier bounded by the friction; absent
#: from the position projection. Only joints with friction have one.
ROW_FRICTION = 4
#: A mimic row: ``C = q_m - k q_l - c`` between a mimic joint ``m`` (the row's joint) and its
#: leader ``l`` (``rows[row, 3]``), ``k`` and ``c`` in ``jprm`` (:data:`J_MIMIC_K`,
#: :data:`J_MIMIC_C`). Its Jacobian spans four bodies: columns 0-11 the mimic joint's axial
#: row (parent, child), 12-23 ``-k`` times the leader's; always held, so the dense solver.
ROW_MIMIC = 5
MOTOR_OFF = 0
MOTOR_EFFORT = 1
MOTOR_VELOCITY = 2
MOTOR_POSITION = 3
# work.motor columns: mode, effort (N m or N), velocity target, position target, omega (1/s),
# effort limit (inf for none), saturation sign (-1, 0, 1), applied effort (the readout), and a
# position target's reference rate and acceleration at its time M_TREF (s): the target moves
# as q* + q̇* s + q̈* s²/2, s the time since M_TREF (a followed trajectory's feed-forward);
# then 1 when a velocity projection holds a position motor's rate at M_HOLD_RATE (rad/s or m/s;
# only the contact step's does, :mod:`rbd_ros.core.contact.motors`)
M_MODE = 0
M_EFFORT = 1
M_VELOCITY = 2
M_POSITION = 3
M_OMEGA = 4
M_LIMIT = 5
M_SAT = 6
M_APPLIED = 7
M_VREF = 8
M_AREF = 9
M_TREF = 10
M_HOLD = 11
M_HOLD_RATE = 12
M_SIZE = 13
#: A limit is crossed when the joint is beyond its bound by more than this (rad or m); the
#: crossing is then located inside the step to :data:`LOCATE_TOL`.
CROSS_TOL = 1e-13
LOCATE_TOL = 1e-14
LOCATE_MAX_ITER = 60
#: What :func:`_locate` finds: a limit crossing, or a sliding joint's stop (Coulomb friction).
EVENT_LIMIT = 0
EVENT_STOP = 1
#: A joint whose motor row drives it is at rest for its friction while ``|q̇|`` is at most this
#: (rad/s or m/s): friction then adds no force and leaves the motor to hold it. The same bound
#: decides whether a joint starts stuck.
FRICTION_REST_RATE = 1e-12
#: A dense pivot below this fraction of its row's diagonal marks a redundant row.
DROP_REL = 1e-9

# prm columns (one row a body)
P_MASS = 0
P_INERTIA = 1
P_INERTIA_INV = 10
P_GRAVITY = 19
P_LIN_DAMP = 22
P_ANG_DAMP = 23
P_SIZE = 24
# jint columns (one row a joint)
J_PARENT = 0
J_CHILD = 1
J_KIND = 2
J_ROW0 = 3
J_NROWS = 4      # rows of the kind, plus one for a limit (the last; active or not)
J_LIMROW = 5     # index of the limit row, or -1
J_MOTROW = 6     # index of the motor row (1-dof kinds), or -1 (planar, universal: mrows)
J_FRICROW = 7    # index of the friction row (joints with friction), or -1
J_MIMROW = 8     # index of the mimic row (a mimic joint), or -1
J_INT_SIZE = 9
# jprm columns
J_ORIGIN_P = 0
J_ORIGIN_C = 3
J_BASIS_P = 6    # u1, u2, u3 in parent coordinates (u3 = axis_b)
J_BASIS_C = 15   # the same three at rest, in child coordinates
J_QREST = 24
J_DAMPING = 28   # viscous damping, N m s/rad or N s/m
J_FRICTION = 29  # Coulomb friction, N m or N
J_MIMIC_K = 30   # a mimic joint's multiplier (its leader's coordinate unit to its own)
J_MIMIC_C = 31   # a mimic joint's offset, rad or m
J_PRM_SIZE = 32
# bd columns (derived per body at one configuration)
B_ROT = 0
B_IW = 9
B_FORCE = 18
B_OMEGA_W = 24
B_SIZE = 27

#: The arrays that describe the system (constant after construction). ``mrows``: the motor
#: row of each motor slot (a row of ``work.motor``), -1 for none: slot ``j`` is joint ``j``'s
#: (a one-coordinate joint's, a planar joint's x, a universal joint's θ1), the slots after the
#: joints the other coordinates'; a motor row's slot is ``rows[row, 3]``, its axis
#: ``rows[row, 2]``.
ArtModel = namedtuple('ArtModel', 'prm jint jprm jlim rows order node_par node_dim dense mrows')
#: Preallocated work arrays (nothing is allocated inside a step).
ArtWork = namedtuple('ArtWork', 'bd jac con bias D Hp W rhs y A mj drop k xs yb yj lam '
                     'wrench angle stats nrow dim active lim_state lim0 x0 k0 jrows motor fric '
                     'axial')
# work.axial columns: each one-coordinate joint's coordinate (rad, running for continuous
# joints; m) and its axial row's J̇ u, from the last joint_rows (the mimic rows' parts)
# work.fric columns: the friction state (the sliding direction s = ±1, the friction force
# being -friction s; 0 stuck, its row held when no motor row or limit holds the joint; 2 not
# decided yet), the state and the row's activity saved at a sub-step's start, the friction's
# generalized force on the child along q (the readout), the joint's rate at the sub-step's
# start and at the end of the last (trial) step before its stop, and 1 when that end stopped it
F_SIGN = 0
F_SIGN0 = 1
F_ACTIVE0 = 2
F_APPLIED = 3
F_RATE0 = 4
F_RATE_END = 5
F_STOPPED = 6
F_SIZE = 7
#: A sliding joint's stop inside a step is located until its rate is within this (rad/s or
#: m/s) of zero, as a limit crossing is (:data:`LOCATE_TOL`).
STOP_RATE_TOL = 1e-14
# jlim columns: lower, upper, has lower, has upper
L_LOWER = 0
L_UPPER = 1
L_HAS_LOWER = 2
L_HAS_UPPER = 3
# stats: 0 max |C| after the last projection, 1 projection iterations (max), 2 failure flag,
# 3 number of stops in the last call, 4 joint of the last stop, 5 the speed it removed
# (rad/s or m/s, signed), 6 its time from the start of the call (s), 7 the steps of the last
# call whose event passes ran out (their rest taken by :func:`_clamped_rest`), 8 the sim time
# (s) of the current sub-step's start, 9 the time (s) of the state being evaluated (an RK4
# stage's), 10 the steps of the last call split into sub-steps (:func:`substeps`), 11 the most
# sub-steps one step of the last call took (1 when none was split)
S_ERR = 0
S_ITER = 1
S_FAIL = 2
S_STOPS = 3
S_STOP_JOINT = 4
S_STOP_SPEED = 5
S_STOP_TIME = 6
S_CLAMPED = 7
S_TIME = 8
S_TSTAGE = 9
S_SPLIT = 10
S_SUBSTEPS = 11
S_SIZE = 12
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
def _cross(a0, a1, a2, b0, b1, b2):
    return a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0


@_inl
def _rot_from_q(qw, qx, qy, qz, out, i, off):
    """Write ``R(q/|q|)`` row-major into ``out[i, off:off + 9]``."""
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
    out[i, off + 0] = 1.0 - s * (qy * qy + qz * qz)
    out[i, off + 1] = s * (qx * qy - qw * qz)
    out[i, off + 2] = s * (qx * qz + qw * qy)
    out[i, off + 3] = s * (qx * qy + qw * qz)
    out[i, off + 4] = 1.0 - s * (qx * qx + qz * qz)
    out[i, off + 5] = s * (qy * qz - qw * qx)
    out[i, off + 6] = s * (qx * qz - qw * qy)
    out[i, off + 7] = s * (qy * qz + qw * qx)
    out[i, off + 8] = 1.0 - s * (qx * qx + qy * qy)


@_inl
def _rot_of(x, b):
    """Return the 9 entries of ``R(q/|q|)`` of body ``b``, row-major (as :func:`_rot_from_q`)."""
    qw, qx, qy, qz = x[b, 3], x[b, 4], x[b, 5], x[b, 6]
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
    return (1.0 - s * (qy * qy + qz * qz), s * (qx * qy - qw * qz), s * (qx * qz + qw * qy),
            s * (qx * qy + qw * qz), 1.0 - s * (qx * qx + qz * qz), s * (qy * qz - qw * qx),
            s * (qx * qz - qw * qy), s * (qy * qz + qw * qx), 1.0 - s * (qx * qx + qy * qy))


@_inl
def _mv(m, i, off, x0, x1, x2):
    """Return ``A v`` for the row-major 3×3 ``A`` in ``m[i, off:off + 9]``."""
    return (m[i, off] * x0 + m[i, off + 1] * x1 + m[i, off + 2] * x2,
            m[i, off + 3] * x0 + m[i, off + 4] * x1 + m[i, off + 5] * x2,
            m[i, off + 6] * x0 + m[i, off + 7] * x1 + m[i, off + 8] * x2)


@_inl
def _mtv(m, i, off, x0, x1, x2):
    """Return ``Aᵀ v`` for the row-major 3×3 ``A`` in ``m[i, off:off + 9]``."""
    return (m[i, off] * x0 + m[i, off + 3] * x1 + m[i, off + 6] * x2,
            m[i, off + 1] * x0 + m[i, off + 4] * x1 + m[i, off + 7] * x2,
            m[i, off + 2] * x0 + m[i, off + 5] * x1 + m[i, off + 8] * x2)


@_inl
def _side_body(model, row, side):
    """Return the body of ``jac`` columns ``6 side..6 side + 5`` of ``row`` (-1: none, world)."""
    if side < 2:
        j = model.rows[row, 0]
    elif model.rows[row, 1] == ROW_MIMIC:
        j = model.rows[row, 3]
    else:
        return -1
    return model.jint[j, J_CHILD] if side % 2 == 1 else model.jint[j, J_PARENT]


@_inl
def _n_sides(model, row):
    """Return the number of body sides of ``row``'s Jacobian: 4 for a mimic row, else 2."""
    return 4 if model.rows[row, 1] == ROW_MIMIC else 2


@_jit
def body_derived(model, x, work):
    """Fill ``work.bd``: rotation, world inertia, free wrench ``f`` (world) and ``ω_w``."""
    prm, bd = model.prm, work.bd
    for b in range(x.shape[0]):
        _rot_from_q(x[b, 3], x[b, 4], x[b, 5], x[b, 6], bd, b, B_ROT)
        # I_w = R I_b Rᵀ
        for r in range(3):
            for c in range(3):
                s = 0.0
                for k in range(3):
                    for m in range(3):
                        s += (bd[b, B_ROT + 3 * r + k] * prm[b, P_INERTIA + 3 * k + m]
                              * bd[b, B_ROT + 3 * c + m])
                bd[b, B_IW + 3 * r + c] = s
        mass = prm[b, P_MASS]
        cv = prm[b, P_LIN_DAMP]
        for k in range(3):
            bd[b, B_FORCE + k] = mass * (prm[b, P_GRAVITY + k] - cv * x[b, 7 + k])
        w0, w1, w2 = x[b, 10], x[b, 11], x[b, 12]
        h0, h1, h2 = _mv(prm, b, P_INERTIA, w0, w1, w2)
        # τ_b = -c_ω I_b ω_b - ω_b × I_b ω_b (damping and the gyroscopic term), then world
        g0, g1, g2 = _cross(w0, w1, w2, h0, h1, h2)
        ca = prm[b, P_ANG_DAMP]
        t0, t1, t2 = _mv(bd, b, B_ROT, -ca * h0 - g0, -ca * h1 - g1, -ca * h2 - g2)
        bd[b, B_FORCE + 3], bd[b, B_FORCE + 4], bd[b, B_FORCE + 5] = t0, t1, t2
        o0, o1, o2 = _mv(bd, b, B_ROT, w0, w1, w2)
        bd[b, B_OMEGA_W], bd[b, B_OMEGA_W + 1], bd[b, B_OMEGA_W + 2] = o0, o1, o2


@_inl
def _twist(model, x, j):
    """Return the angle of ``q_pc q_rest⁻¹`` about ``axis_b`` (rad, in (-pi, pi])."""
    return _twist_on(model, x, j, J_BASIS_P + 6)


@_inl
def _twist_on(model, x, j, off):
    """
    Return ``2 atan2(e_v · u, e_w)``, ``e = q_pc q_rest⁻¹`` (``e_w >= 0``), ``u = jprm[j, off:]``.

    ``u = u3 = axis_b``: a revolute angle; ``u = u1 = axis2_b`` of a universal joint: its second
    angle (``e = q_a(θ1) q_b(θ2)`` with ``a ⊥ b``: ``e_w = c1 c2``, ``e_v · b = c1 s2``).
    """
    jint, jprm = model.jint, model.jprm
    par, c = jint[j, J_PARENT], jint[j, J_CHILD]
    if par >= 0:
        pw, px, py, pz = x[par, 3], -x[par, 4], -x[par, 5], -x[par, 6]
    else:
        pw, px, py, pz = 1.0, 0.0, 0.0, 0.0
    cw, cx, cy, cz = x[c, 3], x[c, 4], x[c, 5], x[c, 6]
    aw = pw * cw - px * cx - py * cy - pz * cz
    ax = pw * cx + px * cw + py * cz - pz * cy
    ay = pw * cy - px * cz + py * cw + pz * cx
    az = pw * cz + px * cy - py * cx + pz * cw
    rw, rx, ry, rz = (jprm[j, J_QREST], -jprm[j, J_QREST + 1], -jprm[j, J_QREST + 2],
                      -jprm[j, J_QREST + 3])
    ew = aw * rw - ax * rx - ay * ry - az * rz
    ex = aw * rx + ax * rw + ay * rz - az * ry
    ey = aw * ry - ax * rz + ay * rw + az * rx
    ez = aw * rz + ax * ry - ay * rx + az * rw
    if ew < 0.0:
        ew, ex, ey, ez = -ew, -ex, -ey, -ez
    u = ex * jprm[j, off] + ey * jprm[j, off + 1] + ez * jprm[j, off + 2]
    return 2.0 * math.atan2(u, ew)


@_inl
def _cone_angle(model, x, j):
    """
    Return the angle of a spherical joint's axis in the child off the parent's (rad, [0, pi]).

    ``e = R_P u3`` (``u3 = axis_b``), ``f = R_c w3`` (the same axis in the child at rest), the
    angle ``atan2(|e × f|, e · f)``: what a cone limit bounds.
    """
    jint, jprm = model.jint, model.jprm
    par, c = jint[j, J_PARENT], jint[j, J_CHILD]
    m0, m1, m2 = jprm[j, J_BASIS_C + 6], jprm[j, J_BASIS_C + 7], jprm[j, J_BASIS_C + 8]
    c00, c01, c02, c10, c11, c12, c20, c21, c22 = _rot_of(x, c)
    f0 = c00 * m0 + c01 * m1 + c02 * m2
    f1 = c10 * m0 + c11 * m1 + c12 * m2
    f2 = c20 * m0 + c21 * m1 + c22 * m2
    m0, m1, m2 = jprm[j, J_BASIS_P + 6], jprm[j, J_BASIS_P + 7], jprm[j, J_BASIS_P + 8]
    if par >= 0:
        p00, p01, p02, p10, p11, p12, p20, p21, p22 = _rot_of(x, par)
        e0 = p00 * m0 + p01 * m1 + p02 * m2
        e1 = p10 * m0 + p11 * m1 + p12 * m2
        e2 = p20 * m0 + p21 * m1 + p22 * m2
    else:
        e0, e1, e2 = m0, m1, m2
    n0, n1, n2 = _cross(e0, e1, e2, f0, f1, f2)
    return math.atan2(math.sqrt(n0 * n0 + n1 * n1 + n2 * n2), e0 * f0 + e1 * f1 + e2 * f2)


@_jit
def limit_coordinate(model, x, j):
    """
    Return joint ``j``'s limited coordinate (rad or m).

    A revolute angle, a prismatic offset, or a spherical joint's angle off its axis (its cone
    limit's, :func:`_cone_angle`).
    """
    if model.jint[j, J_KIND] == 4:
        return _cone_angle(model, x, j)
    if model.jint[j, J_KIND] != 3:
        return _twist(model, x, j)
    jint, jprm = model.jint, model.jprm
    par, c = jint[j, J_PARENT], jint[j, J_CHILD]
    # d = (p_c + R_c o_c) - (p_P + R_P o_P), then its component on R_P u3
    qw, qx, qy, qz = x[c, 3], x[c, 4], x[c, 5], x[c, 6]
    s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
    o0, o1, o2 = jprm[j, J_ORIGIN_C], jprm[j, J_ORIGIN_C + 1], jprm[j, J_ORIGIN_C + 2]
    d0 = x[c, 0] + (1.0 - s * (qy * qy + qz * qz)) * o0 + s * (qx * qy - qw * qz) * o1 \
        + s * (qx * qz + qw * qy) * o2
    d1 = x[c, 1] + s * (qx * qy + qw * qz) * o0 + (1.0 - s * (qx * qx + qz * qz)) * o1 \
        + s * (qy * qz - qw * qx) * o2
    d2 = x[c, 2] + s * (qx * qz - qw * qy) * o0 + s * (qy * qz + qw * qx) * o1 \
        + (1.0 - s * (qx * qx + qy * qy)) * o2
    u0, u1, u2 = jprm[j, J_BASIS_P + 6], jprm[j, J_BASIS_P + 7], jprm[j, J_BASIS_P + 8]
    o0, o1, o2 = jprm[j, J_ORIGIN_P], jprm[j, J_ORIGIN_P + 1], jprm[j, J_ORIGIN_P + 2]
    if par >= 0:
        qw, qx, qy, qz = x[par, 3], x[par, 4], x[par, 5], x[par, 6]
        s = 2.0 / (qw * qw + qx * qx + qy * qy + qz * qz)
        r00, r01, r02 = 1.0 - s * (qy * qy + qz * qz), s * (qx * qy - qw * qz), \
            s * (qx * qz + qw * qy)
        r10, r11, r12 = s * (qx * qy + qw * qz), 1.0 - s * (qx * qx + qz * qz), \
            s * (qy * qz - qw * qx)
        r20, r21, r22 = s * (qx * qz - qw * qy), s * (qy * qz + qw * qx), \
            1.0 - s * (qx * qx + qy * qy)
        d0 -= x[par, 0] + r00 * o0 + r01 * o1 + r02 * o2
        d1 -= x[par, 1] + r10 * o0 + r11 * o1 + r12 * o2
        d2 -= x[par, 2] + r20 * o0 + r21 * o1 + r22 * o2
        e0 = r00 * u0 + r01 * u1 + r02 * u2
        e1 = r10 * u0 + r11 * u1 + r12 * u2
        e2 = r20 * u0 + r21 * u1 + r22 * u2
    else:
        d0 -= o0
        d1 -= o1
        d2 -= o2
        e0, e1, e2 = u0, u1, u2
    return d0 * e0 + d1 * e1 + d2 * e2


@_jit
def joint_rows(model, x, work, full):
    """
    Fill ``work.con`` (the errors ``C``) and, if ``full``, ``work.jac`` and ``work.bias``.

    Rows of joint ``j`` between parent ``P`` (or the world) and child ``c``, with the anchors
    ``r_P = R_P o_P``, ``r_c = R_c o_c``, the separation ``d = (p_c + r_c) - (p_P + r_P)``,
    the parent's joint basis ``e_k = R_P u_k`` and the child's ``f_l = R_c w_l``:

    - position row ``C = e_k · d``: ``J`` has ``v_c: e``, ``ω_c: r_c × e``, ``v_P: -e``,
      ``ω_P: -(p_c + r_c - p_P) × e``; ``J̇ u = e·(ω_c×(ω_c×r_c) - ω_P×(ω_P×r_P))
      + 2 (ω_P×e)·ḋ + (ω_P×(ω_P×e))·d``;
    - alignment row ``C = e_k · f_l``: ``J`` has ``ω_c: f × e``, ``ω_P: e × f``;
      ``J̇ u = (ω_P×(ω_P×e))·f + 2 (ω_P×e)·(ω_c×f) + e·(ω_c×(ω_c×f))``.

    ``jac`` columns: ``v_P, ω_P, v_c, ω_c`` (world); ``ω`` are world angular velocities.
    """
    jint, jprm, rows = model.jint, model.jprm, model.rows
    jac, con, bias = work.jac, work.con, work.bias
    for j in range(jint.shape[0]):
        par = jint[j, J_PARENT]
        c = jint[j, J_CHILD]
        row0 = jint[j, J_ROW0]
        # child rotation
        c00, c01, c02, c10, c11, c12, c20, c21, c22 = _rot_of(x, c)
        if par >= 0:
            p00, p01, p02, p10, p11, p12, p20, p21, p22 = _rot_of(x, par)
            pp0, pp1, pp2 = x[par, 0], x[par, 1], x[par, 2]
            vp0, vp1, vp2 = x[par, 7], x[par, 8], x[par, 9]
            wb0, wb1, wb2 = x[par, 10], x[par, 11], x[par, 12]
            wp0 = p00 * wb0 + p01 * wb1 + p02 * wb2
            wp1 = p10 * wb0 + p11 * wb1 + p12 * wb2
            wp2 = p20 * wb0 + p21 * wb1 + p22 * wb2
        else:
            p00, p01, p02, p10, p11, p12, p20, p21, p22 = 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, \
                0.0, 1.0
            pp0 = pp1 = pp2 = 0.0
            vp0 = vp1 = vp2 = 0.0
            wp0 = wp1 = wp2 = 0.0
        wb0, wb1, wb2 = x[c, 10], x[c, 11], x[c, 12]
        wc0 = c00 * wb0 + c01 * wb1 + c02 * wb2
        wc1 = c10 * wb0 + c11 * wb1 + c12 * wb2
        wc2 = c20 * wb0 + c21 * wb1 + c22 * wb2
        o0, o1, o2 = jprm[j, J_ORIGIN_P], jprm[j, J_ORIGIN_P + 1], jprm[j, J_ORIGIN_P + 2]
        rp0 = p00 * o0 + p01 * o1 + p02 * o2
        rp1 = p10 * o0 + p11 * o1 + p12 * o2
        rp2 = p20 * o0 + p21 * o1 + p22 * o2
        o0, o1, o2 = jprm[j, J_ORIGIN_C], jprm[j, J_ORIGIN_C + 1], jprm[j, J_ORIGIN_C + 2]
        rc0 = c00 * o0 + c01 * o1 + c02 * o2
        rc1 = c10 * o0 + c11 * o1 + c12 * o2
        rc2 = c20 * o0 + c21 * o1 + c22 * o2
        # child anchor relative to the parent's centre, and the separation d
        xc0 = x[c, 0] + rc0 - pp0
        xc1 = x[c, 1] + rc1 - pp1
        xc2 = x[c, 2] + rc2 - pp2
        d0, d1, d2 = xc0 - rp0, xc1 - rp1, xc2 - rp2
        if full:
            t0, t1, t2 = _cross(wc0, wc1, wc2, rc0, rc1, rc2)
            u0, u1, u2 = _cross(wp0, wp1, wp2, rp0, rp1, rp2)
            dd0 = x[c, 7] + t0 - vp0 - u0
            dd1 = x[c, 8] + t1 - vp1 - u1
            dd2 = x[c, 9] + t2 - vp2 - u2
            a0, a1, a2 = _cross(wc0, wc1, wc2, t0, t1, t2)
            b0, b1, b2 = _cross(wp0, wp1, wp2, u0, u1, u2)
            acc0, acc1, acc2 = a0 - b0, a1 - b1, a2 - b2
        # the joint's coordinate (a twist or cone angle: atan2 and two quaternion products),
        # computed at most once for its limit and motor rows and only where it is read: an
        # active limit or motor row's C, and work.axial (mimic rows, the dense solver's; the
        # contact step's friction and motor drives)
        coord_j = 0.0
        have_coord = False
        keep_axial = model.dense or jint[j, J_FRICROW] >= 0
        for r in range(jint[j, J_NROWS]):
            row = row0 + r
            if rows[row, 1] == ROW_MIMIC:
                continue   # filled below, once every joint's axial row is
            k = rows[row, 2]
            m0, m1, m2 = (jprm[j, J_BASIS_P + 3 * k], jprm[j, J_BASIS_P + 3 * k + 1],
                          jprm[j, J_BASIS_P + 3 * k + 2])
            e0 = p00 * m0 + p01 * m1 + p02 * m2
            e1 = p10 * m0 + p11 * m1 + p12 * m2
            e2 = p20 * m0 + p21 * m1 + p22 * m2
            kind = rows[row, 1]
            coord = 0.0
            rate = 0.0
            axial = kind == ROW_LIMIT or kind == ROW_MOTOR or kind == ROW_FRICTION
            need = work.active[row] != 0 and kind != ROW_FRICTION or (
                kind == ROW_MOTOR and keep_axial)
            # a planar joint's x and y motor rows are position rows along u1, u2
            in_plane = jint[j, J_KIND] == 6 and k != 2
            if axial and jint[j, J_KIND] == 4:
                # a spherical joint's cone limit, C = θ - cone, θ the angle between e = R_P u3
                # and f = R_c w3: θ̇ = ω_rel · n, n = p / |p|, p = e × f (the swing axis), so
                # J has ω_c: n, ω_P: -n (a torque pair); J̇ u = ω_rel · ṅ with
                # ṗ = (ω_P × e) × f + e × (ω_c × f), ṅ = (ṗ - n (n · ṗ)) / |p|
                if full:
                    m0, m1, m2 = (jprm[j, J_BASIS_C + 6], jprm[j, J_BASIS_C + 7],
                                  jprm[j, J_BASIS_C + 8])
                    f0 = c00 * m0 + c01 * m1 + c02 * m2
                    f1 = c10 * m0 + c11 * m1 + c12 * m2
                    f2 = c20 * m0 + c21 * m1 + c22 * m2
                    n0, n1, n2 = _cross(e0, e1, e2, f0, f1, f2)
                    sn = math.sqrt(n0 * n0 + n1 * n1 + n2 * n2)
                    r0, r1, r2 = wc0 - wp0, wc1 - wp1, wc2 - wp2
                    for i in range(12):
                        jac[row, i] = 0.0
                    if sn > 0.0:
                        h0, h1, h2 = _cross(wp0, wp1, wp2, e0, e1, e2)
                        a0, a1, a2 = _cross(h0, h1, h2, f0, f1, f2)
                        s0, s1, s2 = _cross(wc0, wc1, wc2, f0, f1, f2)
                        b0, b1, b2 = _cross(e0, e1, e2, s0, s1, s2)
                        pd0, pd1, pd2 = a0 + b0, a1 + b1, a2 + b2
                        n0, n1, n2 = n0 / sn, n1 / sn, n2 / sn
                        rate = r0 * n0 + r1 * n1 + r2 * n2
                        bias[row] = (r0 * pd0 + r1 * pd1 + r2 * pd2
                                     - rate * (n0 * pd0 + n1 * pd1 + n2 * pd2)) / sn
                    else:
                        # on the axis the swing axis is undefined; a cone (> 0) is never held
                        # there: any axis across e keeps the free row finite
                        m0, m1, m2 = jprm[j, J_BASIS_P], jprm[j, J_BASIS_P + 1], \
                            jprm[j, J_BASIS_P + 2]
                        n0 = p00 * m0 + p01 * m1 + p02 * m2
                        n1 = p10 * m0 + p11 * m1 + p12 * m2
                        n2 = p20 * m0 + p21 * m1 + p22 * m2
                        rate = r0 * n0 + r1 * n1 + r2 * n2
                        bias[row] = 0.0
                    jac[row, 3], jac[row, 4], jac[row, 5] = -n0, -n1, -n2
                    jac[row, 9], jac[row, 10], jac[row, 11] = n0, n1, n2
                if need and not have_coord:
                    coord_j = _cone_angle(model, x, j)
                    have_coord = True
                coord = coord_j
            elif axial and jint[j, J_KIND] == 5 and k == 0:
                # a universal joint's second angle θ2, about the child's cross axis
                # f = R_c w1 (held perpendicular to e = R_P axis_b by its alignment row):
                # ω_rel = θ̇1 e + θ̇2 f, so θ̇2 = ω_rel · f exactly; J has ω_c: f, ω_P: -f
                # (a torque pair), J̇ u = ω_rel · (ω_c × f)
                if full:
                    m0, m1, m2 = (jprm[j, J_BASIS_C], jprm[j, J_BASIS_C + 1],
                                  jprm[j, J_BASIS_C + 2])
                    f0 = c00 * m0 + c01 * m1 + c02 * m2
                    f1 = c10 * m0 + c11 * m1 + c12 * m2
                    f2 = c20 * m0 + c21 * m1 + c22 * m2
                    for i in range(12):
                        jac[row, i] = 0.0
                    jac[row, 3], jac[row, 4], jac[row, 5] = -f0, -f1, -f2
                    jac[row, 9], jac[row, 10], jac[row, 11] = f0, f1, f2
                    s0, s1, s2 = _cross(wc0, wc1, wc2, f0, f1, f2)
                    r0, r1, r2 = wc0 - wp0, wc1 - wp1, wc2 - wp2
                    bias[row] = r0 * s0 + r1 * s1 + r2 * s2
                    rate = r0 * f0 + r1 * f1 + r2 * f2
                if need:
                    coord = _twist_on(model, x, j, J_BASIS_P)
            elif axial and jint[j, J_KIND] != 3 and not in_plane:
                # revolute / continuous (and a planar joint's theta): the relative rotation
                # rate about e = R_P axis_b
                if full:
                    for i in range(12):
                        jac[row, i] = 0.0
                    jac[row, 3], jac[row, 4], jac[row, 5] = -e0, -e1, -e2
                    jac[row, 9], jac[row, 10], jac[row, 11] = e0, e1, e2
                    h0, h1, h2 = _cross(wp0, wp1, wp2, e0, e1, e2)
                    bias[row] = (wc0 - wp0) * h0 + (wc1 - wp1) * h1 + (wc2 - wp2) * h2
                    rate = (wc0 - wp0) * e0 + (wc1 - wp1) * e1 + (wc2 - wp2) * e2
                if need and not have_coord:
                    coord_j = _twist(model, x, j)
                    if jint[j, J_KIND] == 2:
                        delta = coord_j - work.angle[j]
                        coord_j = work.angle[j] + delta - 2.0 * math.pi * math.floor(
                            delta / (2.0 * math.pi) + 0.5)
                    have_coord = True
                coord = coord_j
            elif kind == ROW_LIN or axial:
                coord = e0 * d0 + e1 * d1 + e2 * d2
                con[row] = coord
                if full:
                    jac[row, 0], jac[row, 1], jac[row, 2] = -e0, -e1, -e2
                    g0, g1, g2 = _cross(xc0, xc1, xc2, e0, e1, e2)
                    jac[row, 3], jac[row, 4], jac[row, 5] = -g0, -g1, -g2
                    jac[row, 6], jac[row, 7], jac[row, 8] = e0, e1, e2
                    g0, g1, g2 = _cross(rc0, rc1, rc2, e0, e1, e2)
                    jac[row, 9], jac[row, 10], jac[row, 11] = g0, g1, g2
                    h0, h1, h2 = _cross(wp0, wp1, wp2, e0, e1, e2)
                    n0, n1, n2 = _cross(wp0, wp1, wp2, h0, h1, h2)
                    bias[row] = (e0 * acc0 + e1 * acc1 + e2 * acc2
                                 + 2.0 * (h0 * dd0 + h1 * dd1 + h2 * dd2)
                                 + n0 * d0 + n1 * d1 + n2 * d2)
                    rate = e0 * dd0 + e1 * dd1 + e2 * dd2 + h0 * d0 + h1 * d1 + h2 * d2
            else:
                li = rows[row, 3]
                m0, m1, m2 = (jprm[j, J_BASIS_C + 3 * li], jprm[j, J_BASIS_C + 3 * li + 1],
                              jprm[j, J_BASIS_C + 3 * li + 2])
                f0 = c00 * m0 + c01 * m1 + c02 * m2
                f1 = c10 * m0 + c11 * m1 + c12 * m2
                f2 = c20 * m0 + c21 * m1 + c22 * m2
                con[row] = e0 * f0 + e1 * f1 + e2 * f2
                if full:
                    g0, g1, g2 = _cross(e0, e1, e2, f0, f1, f2)
                    jac[row, 0] = jac[row, 1] = jac[row, 2] = 0.0
                    jac[row, 3], jac[row, 4], jac[row, 5] = g0, g1, g2
                    jac[row, 6] = jac[row, 7] = jac[row, 8] = 0.0
                    jac[row, 9], jac[row, 10], jac[row, 11] = -g0, -g1, -g2
                    h0, h1, h2 = _cross(wp0, wp1, wp2, e0, e1, e2)
                    n0, n1, n2 = _cross(wp0, wp1, wp2, h0, h1, h2)
                    s0, s1, s2 = _cross(wc0, wc1, wc2, f0, f1, f2)
                    t0, t1, t2 = _cross(wc0, wc1, wc2, s0, s1, s2)
                    bias[row] = (n0 * f0 + n1 * f1 + n2 * f2
                                 + 2.0 * (h0 * s0 + h1 * s1 + h2 * s2)
                                 + e0 * t0 + e1 * t1 + e2 * t2)
            if kind == ROW_LIMIT:
                con[row] = coord - (model.jlim[j, L_UPPER] if work.lim_state[j] > 0
                                    else model.jlim[j, L_LOWER])
            elif kind == ROW_MOTOR:
                # not a position row: the projection leaves the motor's coordinate alone
                con[row] = 0.0
                m = rows[row, 3]   # the motor slot (j, or a later coordinate's, ArtModel)
                if need:
                    work.axial[m, 0] = coord
                if full:
                    work.axial[m, 1] = bias[row]
                if full and work.motor[m, M_MODE] == MOTOR_POSITION:
                    # e'' = -2 w e' - w^2 e, e = q - q*(t): the exact critically damped
                    # response about the (moving) target
                    w = work.motor[m, M_OMEGA]
                    vr, ar = work.motor[m, M_VREF], work.motor[m, M_AREF]
                    ds = work.stats[S_TSTAGE] - work.motor[m, M_TREF]
                    qr = work.motor[m, M_POSITION] + (vr + 0.5 * ar * ds) * ds
                    bias[row] += 2.0 * w * (rate - vr - ar * ds) + w * w * (coord - qr) - ar
            elif kind == ROW_FRICTION:
                con[row] = 0.0   # a velocity row: the projection leaves the coordinate alone
            if work.active[row] == 0:
                con[row] = 0.0
                if full:
                    bias[row] = 0.0
    # mimic rows, C = q_m - k q_l - c: J = (J_m, -k J_l) (the two joints' motor rows' J),
    # J̇ u = (J̇ u)_m - k (J̇ u)_l
    for j in range(jint.shape[0]):
        row = jint[j, J_MIMROW]
        if row < 0:
            continue
        lead = rows[row, 3]
        k = jprm[j, J_MIMIC_K]
        con[row] = work.axial[j, 0] - k * work.axial[lead, 0] - jprm[j, J_MIMIC_C]
        if full:
            rm, rl = jint[j, J_MOTROW], jint[lead, J_MOTROW]
            for i in range(12):
                jac[row, i] = jac[rm, i]
                jac[row, 12 + i] = -k * jac[rl, i]
            bias[row] = work.axial[j, 1] - k * work.axial[lead, 1]


@_inl
def _ldl(a, i, n):
    """LDLᵀ of the symmetric ``a[i, :n, :n]`` in place (lower part; no pivoting)."""
    for j in range(n):
        d = a[i, j, j]
        for k in range(j):
            d -= a[i, j, k] * a[i, j, k] * a[i, k, k]
        a[i, j, j] = d
        for r in range(j + 1, n):
            s = a[i, r, j]
            for k in range(j):
                s -= a[i, r, k] * a[i, j, k] * a[i, k, k]
            a[i, r, j] = s / d


@_inl
def _ldl_solve_col(a, i, n, v, vi, col):
    """Solve ``a[i] z = v[vi, :n, col]`` in place with the LDLᵀ factor of :func:`_ldl`."""
    for r in range(n):
        s = v[vi, r, col]
        for k in range(r):
            s -= a[i, r, k] * v[vi, k, col]
        v[vi, r, col] = s
    for r in range(n):
        v[vi, r, col] /= a[i, r, r]
    for r in range(n - 1, -1, -1):
        s = v[vi, r, col]
        for k in range(r + 1, n):
            s -= a[i, k, r] * v[vi, k, col]
        v[vi, r, col] = s


@_inl
def _ldl_solve_vec(a, i, n, v, vi):
    for r in range(n):
        s = v[vi, r]
        for k in range(r):
            s -= a[i, r, k] * v[vi, k]
        v[vi, r] = s
    for r in range(n):
        v[vi, r] /= a[i, r, r]
    for r in range(n - 1, -1, -1):
        s = v[vi, r]
        for k in range(r + 1, n):
            s -= a[i, k, r] * v[vi, k]
        v[vi, r] = s


@_jit
def factor(model, work):
    """Factor the saddle-point system at the configuration of ``work.bd`` and ``work.jac``."""
    if model.dense:
        _dense_factor(model, work)
    else:
        _tree_factor(model, work)


@_jit
def _tree_factor(model, work):
    n_b = model.prm.shape[0]
    jint, bd, jac = model.jint, work.bd, work.jac
    D, Hp, W = work.D, work.Hp, work.W
    dim, par = work.dim, model.node_par
    for i in range(dim.shape[0]):
        for r in range(6):
            for c in range(6):
                D[i, r, c] = 0.0
    for b in range(n_b):
        m = model.prm[b, P_MASS]
        D[b, 0, 0] = D[b, 1, 1] = D[b, 2, 2] = m
        for r in range(3):
            for c in range(3):
                D[b, 3 + r, 3 + c] = bd[b, B_IW + 3 * r + c]
    for i in range(dim.shape[0]):
        p = par[i]
        if p < 0:
            continue
        if i < n_b:
            b, j = i, p - n_b
        else:
            b, j = p, i - n_b
        off = 6 if jint[j, J_CHILD] == b else 0
        for r in range(work.nrow[j]):
            row = work.jrows[j, r]
            for a in range(6):
                if i < n_b:
                    Hp[i, a, r] = jac[row, off + a]
                else:
                    Hp[i, r, a] = jac[row, off + a]
    for t in range(model.order.shape[0]):
        i = model.order[t]
        p = par[i]
        _sized(D, Hp, W, work.y, work.rhs, i, dim[i], p, dim[p] if p >= 0 else 0,
               OP_ELIMINATE)


#: What :func:`_sized` does at a node: factor it, or its forward or backward solve step.
OP_ELIMINATE = 0
OP_DOWN = 1
OP_UP = 2


@_inl
def _block(D, Hp, W, y, rhs, i, di, p, dp, op):
    """Node ``i``'s :func:`_eliminate` (``W``), :func:`_down` or :func:`_up` (``y``, ``rhs``)."""
    if op == OP_ELIMINATE:
        _eliminate(D, Hp, W, i, di, p, dp)
    elif op == OP_DOWN:
        _down(D, Hp, y, rhs, i, di, p, dp)
    else:
        _up(D, Hp, y, rhs, i, di, p, dp)


@_inl
def _sized(D, Hp, W, y, rhs, i, di, p, dp, op):
    """
    :func:`_block` with the common block sizes as constants, so that its loops unroll.

    A body (6) next to a joint of 3 to 6 rows, either way round; other sizes take the loops.
    The arithmetic is the same in every branch: only the loop bounds become constants. ``op``
    is a constant at every call, so each call keeps one operation.
    """
    if di == 6:
        if dp == 5:
            _block(D, Hp, W, y, rhs, i, 6, p, 5, op)
        elif dp == 6:
            _block(D, Hp, W, y, rhs, i, 6, p, 6, op)
        elif dp == 4:
            _block(D, Hp, W, y, rhs, i, 6, p, 4, op)
        elif dp == 3:
            _block(D, Hp, W, y, rhs, i, 6, p, 3, op)
        else:
            _block(D, Hp, W, y, rhs, i, 6, p, dp, op)
    elif dp == 6:
        if di == 5:
            _block(D, Hp, W, y, rhs, i, 5, p, 6, op)
        elif di == 4:
            _block(D, Hp, W, y, rhs, i, 4, p, 6, op)
        elif di == 3:
            _block(D, Hp, W, y, rhs, i, 3, p, 6, op)
        else:
            _block(D, Hp, W, y, rhs, i, di, p, 6, op)
    else:
        _block(D, Hp, W, y, rhs, i, di, p, dp, op)


@_inl
def _eliminate(D, Hp, W, i, di, p, dp):
    """
    Factor node ``i`` (LDLᵀ of its ``di`` block) and subtract its Schur complement from ``p``'s.

    ``dp`` is the size of parent ``p``'s block (unused when ``p < 0``, a root).
    """
    _ldl(D, i, di)
    if p < 0:
        return
    # Z = L⁻¹ H (forward substitution only, into W), then D_p -= Zᵀ diag⁻¹ Z
    for c in range(dp):
        for r in range(di):
            s = Hp[i, r, c]
            for k in range(r):
                s -= D[i, r, k] * W[i, k, c]
            W[i, r, c] = s
    for k in range(di):
        W[i, k, 6] = 1.0 / D[i, k, k]
    for a in range(dp):
        for c in range(a + 1):
            s = 0.0
            for k in range(di):
                s += W[i, k, a] * W[i, k, c] * W[i, k, 6]
            D[p, a, c] -= s


@_jit
def _dense_factor(model, work):
    rows, bd, jac, mj, A = model.rows, work.bd, work.jac, work.mj, work.A
    n_r = rows.shape[0]
    prm = model.prm
    # M⁻¹ Jᵀ per row and body side: linear / m, angular R I_b⁻¹ Rᵀ
    for row in range(n_r):
        for side in range(_n_sides(model, row)):
            b = _side_body(model, row, side)
            o = 6 * side
            if b < 0:
                for k in range(6):
                    mj[row, o + k] = 0.0
                continue
            inv_m = 1.0 / prm[b, P_MASS]
            for k in range(3):
                mj[row, o + k] = jac[row, o + k] * inv_m
            t0, t1, t2 = _mtv(bd, b, B_ROT, jac[row, o + 3], jac[row, o + 4], jac[row, o + 5])
            t0, t1, t2 = _mv(prm, b, P_INERTIA_INV, t0, t1, t2)
            mj[row, o + 3], mj[row, o + 4], mj[row, o + 5] = _mv(bd, b, B_ROT, t0, t1, t2)
    for r in range(n_r):
        for s in range(r + 1):
            acc = 0.0
            for sr in range(_n_sides(model, r)):
                br = _side_body(model, r, sr)
                if br < 0:
                    continue
                for ss in range(_n_sides(model, s)):
                    bs = _side_body(model, s, ss)
                    if bs != br:
                        continue
                    for k in range(6):
                        acc += jac[r, 6 * sr + k] * mj[s, 6 * ss + k]
            A[r, s] = acc
    # LDLᵀ with redundant rows dropped
    for j in range(n_r):
        diag = A[j, j]
        d = diag
        for k in range(j):
            d -= A[j, k] * A[j, k] * A[k, k]
        if d <= DROP_REL * diag or diag <= 0.0 or work.active[j] == 0:
            work.drop[j] = 1
            A[j, j] = 1.0
            for r in range(j + 1, n_r):
                A[r, j] = 0.0
            for k in range(j):
                A[j, k] = 0.0
            continue
        work.drop[j] = 0
        A[j, j] = d
        for r in range(j + 1, n_r):
            s = A[r, j]
            for k in range(j):
                s -= A[r, k] * A[j, k] * A[k, k]
            A[r, j] = s / d


@_inl
def _down(D, Hp, y, rhs, i, di, p, dp):
    """Forward step of node ``i``: ``y_i = D_i⁻¹ rhs_i``, then ``rhs_p -= H_iᵀ y_i``."""
    for k in range(di):
        y[i, k] = rhs[i, k]
    _ldl_solve_vec(D, i, di, y, i)
    if p < 0:
        return
    for a in range(dp):
        s = 0.0
        for k in range(di):
            s += Hp[i, k, a] * y[i, k]
        rhs[p, a] -= s


@_inl
def _up(D, Hp, y, rhs, i, di, p, dp):
    """Backward step of node ``i`` (``p >= 0``): ``y_i -= D_i⁻¹ H_i y_p`` (``rhs_i`` spent)."""
    for k in range(di):
        s = 0.0
        for a in range(dp):
            s += Hp[i, k, a] * y[p, a]
        rhs[i, k] = s
    _ldl_solve_vec(D, i, di, rhs, i)
    for k in range(di):
        y[i, k] -= rhs[i, k]


@_jit
def solve(model, work, rb, rj, yb, yj):
    """
    Solve ``[[M, Jᵀ], [J, 0]] [yb; yj] = [rb; rj]`` with the factor of :func:`factor`.

    ``rb`` (n_b, 6) body rows (force, torque; world), ``rj`` (n_rows) joint rows.
    """
    n_b = model.prm.shape[0]
    jint, rows = model.jint, model.rows
    if not model.dense:
        rhs, y, D = work.rhs, work.y, work.D
        dim, par = work.dim, model.node_par
        for b in range(n_b):
            for k in range(6):
                rhs[b, k] = rb[b, k]
        for j in range(jint.shape[0]):
            for r in range(work.nrow[j]):
                rhs[n_b + j, r] = rj[work.jrows[j, r]]
        order = model.order
        Hp = work.Hp
        # forward: rhs_p -= Hᵀ D_i⁻¹ rhs_i (z_i = D_i⁻¹ rhs_i kept in y)
        for t in range(order.shape[0]):
            i = order[t]
            p = par[i]
            _sized(D, Hp, work.W, y, rhs, i, dim[i], p, dim[p] if p >= 0 else 0, OP_DOWN)
        # backward, root first: y_i = D_i⁻¹ (rhs_i - H y_p) = z_i - D_i⁻¹ H y_p
        for t in range(order.shape[0] - 1, -1, -1):
            i = order[t]
            p = par[i]
            if p >= 0:
                _sized(D, Hp, work.W, y, rhs, i, dim[i], p, dim[p], OP_UP)
        for b in range(n_b):
            for k in range(6):
                yb[b, k] = y[b, k]
        for r in range(yj.shape[0]):
            yj[r] = 0.0
        for j in range(jint.shape[0]):
            for r in range(work.nrow[j]):
                yj[work.jrows[j, r]] = y[n_b + j, r]
        return
    # dense: A yj = J M⁻¹ rb - rj, yb = M⁻¹ (rb - Jᵀ yj)
    A, mj, jac, bd, prm = work.A, work.mj, work.jac, work.bd, model.prm
    n_r = rows.shape[0]
    for b in range(n_b):
        inv_m = 1.0 / prm[b, P_MASS]
        for k in range(3):
            yb[b, k] = rb[b, k] * inv_m
        t0, t1, t2 = _mtv(bd, b, B_ROT, rb[b, 3], rb[b, 4], rb[b, 5])
        t0, t1, t2 = _mv(prm, b, P_INERTIA_INV, t0, t1, t2)
        yb[b, 3], yb[b, 4], yb[b, 5] = _mv(bd, b, B_ROT, t0, t1, t2)
    for r in range(n_r):
        s = -rj[r]
        for side in range(_n_sides(model, r)):
            b = _side_body(model, r, side)
            if b >= 0:
                for k in range(6):
                    s += jac[r, 6 * side + k] * yb[b, k]
        yj[r] = s
    for r in range(n_r):
        s = yj[r]
        for k in range(r):
            s -= A[r, k] * yj[k]
        yj[r] = s
    for r in range(n_r):
        yj[r] = 0.0 if work.drop[r] else yj[r] / A[r, r]
    for r in range(n_r - 1, -1, -1):
        s = yj[r]
        for k in range(r + 1, n_r):
            s -= A[k, r] * yj[k]
        yj[r] = 0.0 if work.drop[r] else s
    for r in range(n_r):
        for side in range(_n_sides(model, r)):
            b = _side_body(model, r, side)
            if b >= 0:
                for k in range(6):
                    yb[b, k] -= mj[r, 6 * side + k] * yj[r]


@_jit
def _accelerations(model, x, work, kout):
    """Rows, factor and solve at ``x``; write ``ẋ`` into ``kout`` and ``λ`` into ``work.lam``."""
    body_derived(model, x, work)
    joint_rows(model, x, work, True)
    factor(model, work)
    _motor_forces(model, x, work)
    _dynamics_solve(model, x, work, kout)


@_jit
def _motor_forces(model, x, work):
    """
    Add each joint's applied generalized force to ``work.bd``'s wrenches: the one sum.

    ``τ = τ_motor - d q̇ - f s``: an effort motor's clipped effort (or a saturated motor's
    ``±effort_limit``), the viscous damping ``d`` at the joint rate ``q̇ = J u`` of the state
    being evaluated, and a sliding joint's Coulomb friction ``f`` against its sliding direction
    ``s`` (fixed for the step). ``τ`` along the joint coordinate acts through the motor row's
    Jacobian, ``f += Jᵀ τ``: equal and opposite on the two bodies (a torque pair about the
    axis, or a force pair at the child's anchor along the axis). A joint with none of them is
    skipped, so its arithmetic is that of a joint without damping and friction.
    """
    jint, jprm, motor, jac, bd = model.jint, model.jprm, work.motor, work.jac, work.bd
    for m in range(model.mrows.shape[0]):   # motor slots: slot j is joint j's (see ArtModel)
        row = model.mrows[m]
        if row < 0:
            continue
        j = model.rows[row, 0]
        mode = motor[m, M_MODE]
        tau = 0.0
        push = False
        if mode == MOTOR_EFFORT:
            tau = min(max(motor[m, M_EFFORT], -motor[m, M_LIMIT]), motor[m, M_LIMIT])
            push = True
        elif mode != MOTOR_OFF and motor[m, M_SAT] != 0.0 and work.lim_state[j] == 0:
            tau = motor[m, M_SAT] * motor[m, M_LIMIT]
            push = True
        damping = jprm[j, J_DAMPING]
        if damping != 0.0:
            tau -= damping * _row_rate(model, x, work, row, 2)
            push = True
        sign = work.fric[j, F_SIGN]
        if sign == 1.0 or sign == -1.0:
            tau -= jprm[j, J_FRICTION] * sign
            push = True
        if not push:
            continue
        for side in range(2):
            b = jint[j, J_CHILD] if side == 1 else jint[j, J_PARENT]
            if b >= 0:
                for k in range(6):
                    bd[b, B_FORCE + k] += tau * jac[row, 6 * side + k]


@_jit
def _dynamics_solve(model, x, work, kout):
    """With rows and factor at ``x``: accelerations into ``kout`` (``ẋ``), ``λ``, wrenches."""
    bd, yb, yj, bias, lam = work.bd, work.yb, work.yj, work.bias, work.lam
    for r in range(bias.shape[0]):
        bias[r] = -bias[r]
    solve(model, work, bd[:, B_FORCE:B_FORCE + 6], bias, yb, yj)
    for r in range(bias.shape[0]):
        lam[r] = -yj[r]
    for b in range(x.shape[0]):
        qw, qx, qy, qz = x[b, 3], x[b, 4], x[b, 5], x[b, 6]
        w0, w1, w2 = x[b, 10], x[b, 11], x[b, 12]
        kout[b, 0], kout[b, 1], kout[b, 2] = x[b, 7], x[b, 8], x[b, 9]
        # q̇ = ½ q ⊗ (0, ω_b)
        kout[b, 3] = 0.5 * (-qx * w0 - qy * w1 - qz * w2)
        kout[b, 4] = 0.5 * (qw * w0 + qy * w2 - qz * w1)
        kout[b, 5] = 0.5 * (qw * w1 - qx * w2 + qz * w0)
        kout[b, 6] = 0.5 * (qw * w2 + qx * w1 - qy * w0)
        kout[b, 7], kout[b, 8], kout[b, 9] = yb[b, 0], yb[b, 1], yb[b, 2]
        # ω̇_b = Rᵀ ω̇_w (Ṙᵀ ω_w = -Rᵀ (ω_w × ω_w) = 0)
        a0, a1, a2 = _mtv(bd, b, B_ROT, yb[b, 3], yb[b, 4], yb[b, 5])
        kout[b, 10], kout[b, 11], kout[b, 12] = a0, a1, a2


@_jit
def _wrenches(model, work):
    """``work.wrench[j]``: ``Σ λ J_c`` of joint ``j``'s rows: force, torque about the child COM."""
    jint, jac, lam, wr = model.jint, work.jac, work.lam, work.wrench
    for j in range(jint.shape[0]):
        for k in range(6):
            wr[j, k] = 0.0
        for r in range(work.nrow[j]):
            row = work.jrows[j, r]
            for k in range(6):
                wr[j, k] += lam[row] * jac[row, 6 + k]


@_inl
def _max_abs(v):
    m = 0.0
    for i in range(v.shape[0]):
        a = abs(v[i])
        if not a <= m:
            m = a if a == a else math.inf
    return m


@_jit
def _apply_dx(x, yb):
    """``p += dp``, ``q ← exp(dθ_w / 2) ⊗ q`` (world-frame rotation increment), renormalised."""
    for b in range(x.shape[0]):
        for k in range(3):
            x[b, k] += yb[b, k]
        t0, t1, t2 = yb[b, 3], yb[b, 4], yb[b, 5]
        ang = math.sqrt(t0 * t0 + t1 * t1 + t2 * t2)
        if ang == 0.0:
            continue
        cw = math.cos(0.5 * ang)
        sk = math.sin(0.5 * ang) / ang
        dx, dy, dz = sk * t0, sk * t1, sk * t2
        qw, qx, qy, qz = x[b, 3], x[b, 4], x[b, 5], x[b, 6]
        nw = cw * qw - dx * qx - dy * qy - dz * qz
        nx = cw * qx + dx * qw + dy * qz - dz * qy
        ny = cw * qy - dx * qz + dy * qw + dz * qx
        nz = cw * qz + dx * qy - dy * qx + dz * qw
        s = 1.0 / math.sqrt(nw * nw + nx * nx + ny * ny + nz * nz)
        x[b, 3], x[b, 4], x[b, 5], x[b, 6] = nw * s, nx * s, ny * s, nz * s


@_jit
def _project_positions(model, x, work, tol, max_iter, refactor_after):
    """
    Newton on ``C(x) = 0`` with the minimal mass-weighted change ``dx = -M⁻¹ Jᵀ μ``.

    The first ``refactor_after`` iterations reuse the factor already in ``work`` (a chord
    step: the last RK4 stage's, O(h) away); later ones refactor at the current ``x``.
    Return the iterations taken, or -1 when ``max|C| <= tol`` was not reached.
    """
    zero = work.xs[:, 0:6]
    for b in range(zero.shape[0]):
        for k in range(6):
            zero[b, k] = 0.0
    for it in range(max_iter + 1):
        joint_rows(model, x, work, False)
        err = _max_abs(work.con)
        work.stats[S_ERR] = err
        if err <= tol:
            return it
        if it == max_iter:
            break
        if it >= refactor_after:
            body_derived(model, x, work)
            joint_rows(model, x, work, True)
            factor(model, work)
        for r in range(work.con.shape[0]):
            work.bias[r] = -work.con[r]
        solve(model, work, zero, work.bias, work.yb, work.yj)
        _apply_dx(x, work.yb)
    return -1


@_inl
def _row_rate(model, x, work, r, sides):
    """
    Return row ``r``'s ``J u`` at ``x`` over its first ``sides`` body sides.

    ``sides`` a constant (2, or 4 for a mimic row), so the loop unrolls; ``work.jac`` and
    ``work.bd`` filled at ``x``.
    """
    jac, bd = work.jac, work.bd
    s = 0.0
    for side in range(sides):
        b = _side_body(model, r, side)
        if b >= 0:
            o = 6 * side
            for k in range(3):
                s += jac[r, o + k] * x[b, 7 + k] + jac[r, o + 3 + k] * bd[b, B_OMEGA_W + k]
    return s


@_jit
def _project_velocities(model, x, work):
    """With rows and factor at ``x``: ``u ← u - M⁻¹ Jᵀ (J M⁻¹ Jᵀ)⁻¹ J u``."""
    rows, bd = model.rows, work.bd
    zero = work.xs[:, 0:6]
    for b in range(zero.shape[0]):
        for k in range(6):
            zero[b, k] = 0.0
    for r in range(rows.shape[0]):
        # the side count as a constant in each branch, so that the loop unrolls (read from
        # the row, it cost a 7-link arm's step 4 %; a tree has no mimic row)
        if rows[r, 1] == ROW_MIMIC:
            s = _row_rate(model, x, work, r, 4)
        else:
            s = _row_rate(model, x, work, r, 2)
        work.bias[r] = -s
        if rows[r, 1] == ROW_MOTOR:
            # a velocity target is a velocity row, J u = v*; a position target's row is an
            # acceleration row only, so the projection leaves that rate alone (unless the
            # contact step holds it at its exact response's rate, M_HOLD)
            m = rows[r, 3]   # the motor slot
            mode = work.motor[m, M_MODE]
            if mode == MOTOR_VELOCITY:
                work.bias[r] = work.motor[m, M_VELOCITY] - s
            elif mode == MOTOR_POSITION and work.motor[m, M_HOLD] != 0.0:
                work.bias[r] = work.motor[m, M_HOLD_RATE] - s
            else:
                work.bias[r] = 0.0
    solve(model, work, zero, work.bias, work.yb, work.yj)
    yb = work.yb
    for b in range(x.shape[0]):
        for k in range(3):
            x[b, 7 + k] += yb[b, k]
        t0, t1, t2 = _mtv(bd, b, B_ROT, yb[b, 3], yb[b, 4], yb[b, 5])
        x[b, 10] += t0
        x[b, 11] += t1
        x[b, 12] += t2


@_jit
def _unwrap(model, x, work):
    """Keep each continuous joint's running angle (twist of ``q_pc q_rest⁻¹`` on ``axis_b``)."""
    jint = model.jint
    for j in range(jint.shape[0]):
        if jint[j, J_KIND] != 2:
            continue
        delta = _twist(model, x, j) - work.angle[j]
        delta -= 2.0 * math.pi * math.floor(delta / (2.0 * math.pi) + 0.5)
        work.angle[j] += delta


@_jit
def refresh_rows(model, work, j):
    """Rebuild joint ``j``'s list of active rows (``work.jrows``, ``nrow``, its node's size)."""
    n = 0
    row0 = model.jint[j, J_ROW0]
    for r in range(model.jint[j, J_NROWS]):
        if work.active[row0 + r] != 0:
            work.jrows[j, n] = row0 + r
            n += 1
    work.nrow[j] = n
    work.dim[model.prm.shape[0] + j] = n


@_jit
def set_limit(model, work, j, state):
    """Hold joint ``j``'s limit row at its upper (``state`` 1) or lower (-1) bound; 0 frees."""
    work.lim_state[j] = state
    work.active[model.jint[j, J_LIMROW]] = 1 if state != 0 else 0
    motor_row = model.jint[j, J_MOTROW]
    if motor_row >= 0 and state != 0:
        work.active[motor_row] = 0   # a held limit pauses the joint's motor
    friction_row = model.jint[j, J_FRICROW]
    if friction_row >= 0 and state != 0:
        work.active[friction_row] = 0   # and its friction: the stop holds it
    refresh_rows(model, work, j)


@_jit
def _release(model, work):
    """Release every held limit whose multiplier would pull (no sticking); return how many."""
    jint, lam = model.jint, work.lam
    released = 0
    for j in range(jint.shape[0]):
        state = work.lim_state[j]
        if state == 0:
            continue
        # the row's multiplier is the generalized force along q on the child: a stop at the
        # upper bound may only push down (λ <= 0), one at the lower bound only up (λ >= 0)
        if state * lam[jint[j, J_LIMROW]] > 0.0:
            set_limit(model, work, j, 0)
            released += 1
    return released


@_jit
def _saturate(model, work):
    """
    Switch off every motor row whose multiplier exceeds the effort limit; return how many.

    A saturated motor pushes with ``±effort_limit`` instead (see :func:`_motor_forces`).
    """
    lam, motor = work.lam, work.motor
    changed = 0
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row < 0 or work.active[row] == 0:
            continue
        if abs(lam[row]) > motor[m, M_LIMIT]:
            motor[m, M_SAT] = 1.0 if lam[row] > 0.0 else -1.0
            work.active[row] = 0
            refresh_rows(model, work, model.rows[row, 0])
            changed += 1
    return changed


@_inl
def _set_active(model, work, j, row, want):
    """Set row ``row`` of joint ``j`` active (1) or not (0); return 1 if that changed it."""
    if work.active[row] == want:
        return 0
    work.active[row] = want
    refresh_rows(model, work, j)
    return 1


@_jit
def _motor_rows_on(model, work):
    """Turn on the row of every position / velocity motor not paused by a held limit."""
    motor = work.motor
    changed = 0
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row < 0:
            continue
        j = model.rows[row, 0]
        mode = motor[m, M_MODE]
        want = 1 if ((mode == MOTOR_VELOCITY or mode == MOTOR_POSITION)
                     and work.lim_state[j] == 0) else 0
        motor[m, M_SAT] = 0.0
        changed += _set_active(model, work, j, row, want)
    return changed


@_jit
def _applied_efforts(model, work):
    motor = work.motor
    for m in range(model.mrows.shape[0]):
        row = model.mrows[m]
        if row < 0:
            continue
        mode = motor[m, M_MODE]
        if mode == MOTOR_EFFORT:
            motor[m, M_APPLIED] = min(max(motor[m, M_EFFORT], -motor[m, M_LIMIT]),
                                      motor[m, M_LIMIT])
        elif work.active[row] != 0:
            motor[m, M_APPLIED] = work.lam[row]
        elif mode != MOTOR_OFF and motor[m, M_SAT] != 0.0:
            motor[m, M_APPLIED] = motor[m, M_SAT] * motor[m, M_LIMIT]
        else:
            motor[m, M_APPLIED] = 0.0


@_jit
def _friction_rows(model, x, work, update):
    """
    Hold the friction row of every stuck joint that no motor row or limit holds; return changes.

    With ``update`` (at a step boundary, rows at ``x``), a joint driven by its motor row or
    held at a limit, or not decided yet, takes its friction state from its rate: at rest
    (``|q̇| <= FRICTION_REST_RATE``: 0) or sliding along ``sign(q̇)``.
    """
    jint, fric = model.jint, work.fric
    changed = 0
    for j in range(jint.shape[0]):
        row = jint[j, J_FRICROW]
        if row < 0:
            continue
        motor_on = work.active[jint[j, J_MOTROW]] != 0
        held = work.lim_state[j] != 0
        if update and (motor_on or held or fric[j, F_SIGN] == 2.0):
            rate = _row_rate(model, x, work, row, 2)
            if abs(rate) <= FRICTION_REST_RATE:
                fric[j, F_SIGN] = 0.0
            else:
                fric[j, F_SIGN] = 1.0 if rate > 0.0 else -1.0
        want = 1 if (fric[j, F_SIGN] == 0.0 and not motor_on and not held) else 0
        changed += _set_active(model, work, j, row, want)
    return changed


@_jit
def _friction_slip(model, work):
    """
    Let go every stuck joint whose holding force exceeds its friction; return how many.

    The row's multiplier ``λ`` is the force along ``q`` that would hold the joint; beyond the
    friction it slides the other way, ``s = -sign(λ)``, against the force ``-f s = f sign(λ)``.
    """
    jint, jprm, lam, fric = model.jint, model.jprm, work.lam, work.fric
    changed = 0
    for j in range(jint.shape[0]):
        row = jint[j, J_FRICROW]
        if row < 0 or work.active[row] == 0:
            continue
        if abs(lam[row]) > jprm[j, J_FRICTION]:
            fric[j, F_SIGN] = -1.0 if lam[row] > 0.0 else 1.0
            work.active[row] = 0
            refresh_rows(model, work, j)
            changed += 1
    return changed


@_jit
def _friction_stops(model, x, work):
    """
    Stick every sliding joint whose rate has reached or crossed zero (rows at ``x``).

    Its friction row is held, so the velocity projection that follows stops it. Each sliding
    joint's rate here is kept (``F_RATE_END``) and a joint stopped here is marked
    (``F_STOPPED``): :func:`step` locates a stop that crossed zero inside the step, so what
    the projection takes out is at most :data:`STOP_RATE_TOL`.
    """
    jint, fric = model.jint, work.fric
    for j in range(jint.shape[0]):
        row = jint[j, J_FRICROW]
        if row < 0:
            continue
        fric[j, F_STOPPED] = 0.0
        sign = fric[j, F_SIGN]
        if not (sign == 1.0 or sign == -1.0) or work.active[jint[j, J_MOTROW]] != 0 \
                or work.lim_state[j] != 0:
            continue
        rate = _row_rate(model, x, work, row, 2)
        fric[j, F_RATE_END] = rate
        if sign * rate <= 0.0:
            fric[j, F_SIGN] = 0.0
            fric[j, F_STOPPED] = 1.0
            work.active[row] = 1
            refresh_rows(model, work, j)


@_jit
def _friction_event(model, work):
    """
    Return the joint whose sliding stopped first inside the last sub-step, or -1.

    A joint that slid at the sub-step's start and whose rate crossed zero strictly by its end;
    the first by the linear estimate ``r0 / (r0 - r_end)`` of when (``r = s q̇``).
    """
    jint, fric = model.jint, work.fric
    best, first = -1, 2.0
    for j in range(jint.shape[0]):
        if jint[j, J_FRICROW] < 0 or fric[j, F_STOPPED] == 0.0:
            continue
        sign = fric[j, F_SIGN0]
        r0, r1 = sign * fric[j, F_RATE0], sign * fric[j, F_RATE_END]
        if (sign == 1.0 or sign == -1.0) and r0 > 0.0 and r1 < 0.0 and r0 / (r0 - r1) < first:
            best, first = j, r0 / (r0 - r1)
    return best


@_jit
def _friction_efforts(model, work):
    """``work.fric[:, F_APPLIED]``: each friction's generalized force on the child along q."""
    jint, jprm, fric = model.jint, model.jprm, work.fric
    for j in range(jint.shape[0]):
        row = jint[j, J_FRICROW]
        if row < 0:
            fric[j, F_APPLIED] = 0.0
        elif work.active[row] != 0:
            fric[j, F_APPLIED] = work.lam[row]
        elif fric[j, F_SIGN] == 1.0 or fric[j, F_SIGN] == -1.0:
            fric[j, F_APPLIED] = -jprm[j, J_FRICTION] * fric[j, F_SIGN]
        else:
            fric[j, F_APPLIED] = 0.0


@_jit
def refresh_dynamics(model, x, work):
    """Recompute ``ẋ`` (k1), ``λ``, wrenches and efforts at ``x`` after a change of motors."""
    _dynamics_at(model, x, work, True)


@_jit
def _dynamics_at(model, x, work, refactor):
    """
    ``ẋ`` into ``work.k[0]`` and ``λ`` at ``x``, deciding limits and saturation.

    Held limits whose multiplier would pull are released; motor rows are tried on and a
    motor whose multiplier exceeds its effort limit is saturated; a stuck joint's friction row
    is held unless a motor row or a limit holds the joint, and let go (sliding) when its
    multiplier exceeds the friction; each change refactors.
    """
    if _motor_rows_on(model, work) > 0:
        refactor = True
    n_friction = 0
    for j in range(model.jint.shape[0]):
        if model.jint[j, J_FRICROW] >= 0:
            n_friction += 1
    for it in range(2 * model.jint.shape[0] + 2 + 2 * n_friction):
        body_derived(model, x, work)   # f and ω_w at the current velocities
        joint_rows(model, x, work, True)   # J̇ u at the current velocities
        if it == 0 and n_friction > 0 and _friction_rows(model, x, work, True) > 0:
            refactor = True
        if refactor:
            factor(model, work)
        _motor_forces(model, x, work)
        _dynamics_solve(model, x, work, work.k[0])
        changed = _release(model, work)
        if changed > 0:
            _motor_rows_on(model, work)   # a released joint's motor resumes
        changed += _saturate(model, work)
        if n_friction > 0:
            changed += _friction_slip(model, work)
            changed += _friction_rows(model, x, work, False)
        if changed == 0:
            break
        refactor = True
    _wrenches(model, work)
    _applied_efforts(model, work)
    if n_friction > 0:
        _friction_efforts(model, work)


@_jit
def _end_of_step(model, x, work):
    """Factor at the projected positions, project velocities, then ``ẋ`` (next k1) and ``λ``."""
    body_derived(model, x, work)
    joint_rows(model, x, work, True)
    _friction_stops(model, x, work)
    factor(model, work)
    _project_velocities(model, x, work)
    _dynamics_at(model, x, work, False)
    _unwrap(model, x, work)


@_jit
def initialize(model, x, work, tol, max_iter):
    """Project ``x`` onto the joints (full Newton), then velocities; fill k1, λ, wrenches."""
    it = _project_positions(model, x, work, tol, max_iter, 0)
    work.stats[S_ITER] = it
    _end_of_step(model, x, work)
    return it


@_jit
def _rk4(model, x, work, h, tol, max_iter):
    """One RK4 step of size ``h`` from ``x`` (``work.k[0]`` = ``ẋ``) and the projections."""
    k, xs = work.k, work.xs
    n_b = x.shape[0]
    t0 = work.stats[S_TIME]
    for stage in range(1, 4):
        c = 0.5 * h if stage < 3 else h
        for b in range(n_b):
            for i in range(13):
                xs[b, i] = x[b, i] + c * k[stage - 1, b, i]
        work.stats[S_TSTAGE] = t0 + c
        _accelerations(model, xs, work, k[stage])
    for b in range(n_b):
        for i in range(13):
            x[b, i] += (h / 6.0) * (k[0, b, i] + 2.0 * (k[1, b, i] + k[2, b, i]) + k[3, b, i])
        qw, qx, qy, qz = x[b, 3], x[b, 4], x[b, 5], x[b, 6]
        q = 1.0 / math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
        x[b, 3], x[b, 4], x[b, 5], x[b, 6] = qw * q, qx * q, qy * q, qz * q
    work.stats[S_TSTAGE] = t0 + h
    it = _project_positions(model, x, work, tol, max_iter, 3)
    if it < 0:
        return it
    _end_of_step(model, x, work)
    return it


@_jit
def _crossing(model, x, work):
    """Return ``(joint, bound side, excess)`` of the free limit crossed deepest, or (-1, 0, 0)."""
    jint, jlim = model.jint, model.jlim
    best, side, excess = -1, 0, 0.0
    for j in range(jint.shape[0]):
        if jint[j, J_LIMROW] < 0 or work.lim_state[j] != 0:
            continue
        q = limit_coordinate(model, x, j)
        if jlim[j, L_HAS_UPPER] != 0.0 and q - jlim[j, L_UPPER] > max(CROSS_TOL, excess):
            best, side, excess = j, 1, q - jlim[j, L_UPPER]
        if jlim[j, L_HAS_LOWER] != 0.0 and jlim[j, L_LOWER] - q > max(CROSS_TOL, excess):
            best, side, excess = j, -1, jlim[j, L_LOWER] - q
    return best, side, excess


@_jit
def _restore(model, x, work):
    work.stats[S_TSTAGE] = work.stats[S_TIME]
    for b in range(x.shape[0]):
        for i in range(13):
            x[b, i] = work.x0[b, i]
            work.k[0, b, i] = work.k0[b, i]
    for j in range(model.jint.shape[0]):
        if model.jint[j, J_LIMROW] >= 0 and work.lim_state[j] != work.lim0[j]:
            set_limit(model, work, j, work.lim0[j])
    for j in range(model.jint.shape[0]):
        row = model.jint[j, J_FRICROW]
        if row >= 0:
            work.fric[j, F_SIGN] = work.fric[j, F_SIGN0]
            if work.active[row] != work.fric[j, F_ACTIVE0]:
                work.active[row] = int(work.fric[j, F_ACTIVE0])
                refresh_rows(model, work, j)


@_jit
def _joint_speed(model, x, work, j):
    """Return the rate of joint ``j``'s limited coordinate: its limit row's ``J u``."""
    body_derived(model, x, work)
    joint_rows(model, x, work, True)
    jint, row = model.jint, model.jint[j, J_LIMROW]
    s = 0.0
    for side in range(2):
        b = jint[j, J_CHILD] if side == 1 else jint[j, J_PARENT]
        if b >= 0:
            for i in range(3):
                s += (work.jac[row, 6 * side + i] * x[b, 7 + i]
                      + work.jac[row, 6 * side + 3 + i] * work.bd[b, B_OMEGA_W + i])
    return s


@_jit
def _hold_at_bounds(model, x, work):
    """
    Hold every free limit at its bound (to :data:`CROSS_TOL`) moving into it; return how many.

    Called at a stop, so that joints reaching their bounds together stop in one impact: one
    stopped alone would let the other's impulse drive it back into its bound, the two
    released and re-stopped in turn until a sub-step began past a bound.
    """
    jint, jlim = model.jint, model.jlim
    held = 0
    for j in range(jint.shape[0]):
        if jint[j, J_LIMROW] < 0 or work.lim_state[j] != 0:
            continue
        q = limit_coordinate(model, x, j)
        side = 0
        if jlim[j, L_HAS_UPPER] != 0.0 and q - jlim[j, L_UPPER] >= -CROSS_TOL:
            side = 1
        elif jlim[j, L_HAS_LOWER] != 0.0 and jlim[j, L_LOWER] - q >= -CROSS_TOL:
            side = -1
        if side != 0 and side * _joint_speed(model, x, work, j) > 0.0:
            set_limit(model, work, j, side)
            held += 1
    return held


@_jit
def _save_start(model, x, work):
    """Keep the sub-step's start for :func:`_restore`: ``x``, ``ẋ``, the limits and frictions."""
    for b in range(x.shape[0]):
        for i in range(13):
            work.x0[b, i] = x[b, i]
            work.k0[b, i] = work.k[0, b, i]
    for j in range(model.jint.shape[0]):
        work.lim0[j] = work.lim_state[j]
        if model.jint[j, J_FRICROW] >= 0:
            work.fric[j, F_SIGN0] = work.fric[j, F_SIGN]
            work.fric[j, F_ACTIVE0] = work.active[model.jint[j, J_FRICROW]]
            # rows and ω_w are at x (left by the last dynamics evaluation)
            work.fric[j, F_RATE0] = _row_rate(model, x, work, model.jint[j, J_FRICROW], 2)


@_jit
def _clamped_rest(model, x, work, h, tol, max_iter):
    """
    Take ``h``, the rest of a step whose event passes ran out, as one sub-step, limits clamped.

    One RK4 sub-step and projection; then every free limit crossed in it (by more than
    :data:`CROSS_TOL`) is held at its bound, with every other free limit at its bound and
    moving into it (:func:`_hold_at_bounds`), the positions are projected onto them and the
    velocity projection takes out the speed into them: an inelastic stop at the sub-step's
    end instead of at its crossing, so no joint ends beyond its bound. Return ``(iterations,
    the joint crossed deepest or -1, its rate before the stop)``; iterations < 0 when a
    projection failed (the caller restores the sub-step's start).
    """
    it = _rk4(model, x, work, h, tol, max_iter)
    if it < 0:
        return it, -1, 0.0
    first, speed = -1, 0.0
    j, side, _ = _crossing(model, x, work)
    while j >= 0:
        if first < 0:
            first, speed = j, _joint_speed(model, x, work, j)
        set_limit(model, work, j, side)
        j, side, _ = _crossing(model, x, work)
    if first < 0:
        return it, -1, 0.0
    _hold_at_bounds(model, x, work)
    body_derived(model, x, work)
    joint_rows(model, x, work, True)
    factor(model, work)
    it_stop = _project_positions(model, x, work, tol, max_iter, 0)
    if it_stop < 0:
        return it_stop, first, speed
    _end_of_step(model, x, work)
    return max(it, it_stop), first, speed


@_jit
def _locate(model, x, work, event, j, side, bound, g_lo, hi, g_hi, h, tol, max_iter):
    """
    Find when an event inside the sub-step from ``work.x0`` happened; return ``(τ, g(τ))``.

    The Illinois method (regula falsi halving the end that stays) on ``g`` over ``(0, hi)``,
    ``g(0) = g_lo <= 0 < g(hi) = g_hi``, each trial a full RK4 sub-step and projection from
    the sub-step's start, until ``|g| <=`` the event's tolerance or the bracket is below
    ``1e-15 h``. ``event`` selects ``g``: :data:`EVENT_LIMIT`, joint ``j``'s limit crossing,
    ``g = side (q - bound)`` to :data:`LOCATE_TOL`; :data:`EVENT_STOP`, its sliding stop,
    ``g = -side q̇`` (``side`` its sliding direction) to :data:`STOP_RATE_TOL`. ``x`` is left
    at the last trial. ``τ = -1`` when a trial's projection failed (``x`` back at the start).
    """
    lo = 0.0
    tau = hi
    g = g_hi
    g_tol = LOCATE_TOL if event == EVENT_LIMIT else STOP_RATE_TOL
    for _ in range(LOCATE_MAX_ITER):
        tau = (lo * g_hi - hi * g_lo) / (g_hi - g_lo)
        _restore(model, x, work)
        if _rk4(model, x, work, tau, tol, max_iter) < 0:
            _restore(model, x, work)  # stays finite: back to the sub-step start
            return -1.0, g
        if event == EVENT_LIMIT:
            g = side * (limit_coordinate(model, x, j) - bound)
        else:
            g = -side * work.fric[j, F_RATE_END]
        if abs(g) <= g_tol or hi - lo <= 1e-15 * h:
            break
        if g > 0.0:
            hi, g_hi = tau, g
            g_lo *= 0.5   # Illinois: halve the end that stays
        else:
            lo, g_lo = tau, g
            g_hi *= 0.5
    return tau, g


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
    :data:`STOP_RATE_TOL`, the joint sticks there (its friction row held, the velocity
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
