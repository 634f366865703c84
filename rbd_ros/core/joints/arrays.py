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
The articulated step's records: the arrays that describe the system and its work buffers.

:data:`ArtModel` (constant after construction) and :data:`ArtWork` (preallocated: nothing is
allocated inside a step), and the named columns of their arrays (``prm``, ``jint``, ``jprm``,
``jlim``, ``work.bd``, ``work.motor``, ``work.fric``, ``work.stats``), the joint kind and row
kind codes and the motor modes. Every stage reads these names; nothing here is compiled (numba
folds the module-level ``int`` constants into the kernels as literals). The step's stages, in
order: :mod:`.rows`, :mod:`.solve`, :mod:`.projection`, :mod:`.active_rows`, :mod:`.dynamics`,
:mod:`.events`, and the driver :mod:`rbd_ros.core.joints.kernels`.
"""

from collections import namedtuple


#: Joint kind codes (the order of :data:`rbd_ros.core.joints.model.JOINT_KINDS`).
KIND_CODES = {'fixed': 0, 'revolute': 1, 'continuous': 2, 'prismatic': 3, 'spherical': 4,
              'universal': 5, 'planar': 6}
#: Row kinds: a position row ``C = e_k · d`` and an alignment row ``C = e_k · f_l``.
ROW_LIN = 0
ROW_ANG = 1
#: A limit row: ``C = q - bound`` (``q`` the revolute angle or prismatic offset on ``axis_b``,
#: or a spherical joint's angle off ``axis_b``, bounded by its cone;
#: :func:`~.rows.limit_coordinate`).
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
B_POS = 27       # the body's position p_w (the articulated form's lever arms)
B_SIZE = 30

#: The arrays that describe the system (constant after construction). ``mrows``: the motor
#: row of each motor slot (a row of ``work.motor``), -1 for none: slot ``j`` is joint ``j``'s
#: (a one-coordinate joint's, a planar joint's x, a universal joint's θ1), the slots after the
#: joints the other coordinates'; a motor row's slot is ``rows[row, 3]``, its axis
#: ``rows[row, 2]``.
ArtModel = namedtuple('ArtModel', 'prm jint jprm jlim rows order node_par node_dim dense mrows')
#: Preallocated work arrays (nothing is allocated inside a step).
ArtWork = namedtuple('ArtWork', 'bd jac con bias D Hp W rhs y A mj drop k xs yb yj lam '
                     'wrench angle stats nrow dim active lim_state lim0 x0 k0 jrows motor fric '
                     'axial arows form')
# work.arows: each joint's held rows in the articulated form's order (:mod:`.articulated`);
# work.form[0]: 1 when the last factor was in that form, 0 in the block LDLᵀ (or dense)
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


# jlim columns: lower, upper, has lower, has upper
L_LOWER = 0
L_UPPER = 1
L_HAS_LOWER = 2
L_HAS_UPPER = 3
# stats: 0 max |C| after the last projection, 1 projection iterations (max), 2 failure flag,
# 3 number of stops in the last call, 4 joint of the last stop, 5 the speed it removed
# (rad/s or m/s, signed), 6 its time from the start of the call (s), 7 the steps of the last
# call whose event passes ran out (their rest taken by :func:`~.events._clamped_rest`), 8 the
# sim time (s) of the current sub-step's start, 9 the time (s) of the state being evaluated (an
# RK4 stage's), 10 the steps of the last call split into sub-steps (:func:`~.kernels.substeps`),
# 11 the most sub-steps one step of the last call took (1 when none was split)
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
