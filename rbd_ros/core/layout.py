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
The layouts of the compiled kernel's packed arrays: named offsets plus pack and unpack.

This module is the only place that knows which row holds what; the kernel
(:mod:`rbd_ros.core.kernels`), the simulators and the tests use these names. The offsets are
plain module-level ``int`` constants, which numba folds into the compiled code as literals, so
naming them costs nothing at run time. All arrays are float64 (times int64).

* **State** ``x`` (``N_STATE`` = 13, N), one column per body: ``S_POS`` 0–2 COM position
  ``p_w`` (m); ``S_QUAT`` 3–6 orientation ``q_wb = (w, x, y, z)`` with ``v_w = R(q) v_b``;
  ``S_VEL`` 7–9 COM velocity ``v_w`` (m/s); ``S_OMEGA`` 10–12 angular velocity ``ω_b`` in BODY
  coordinates (rad/s).
* **Parameters** ``prm`` (``N_PARAM`` = 26, N), or (26, 1) when all bodies share one model:
  ``P_MASS`` 0 mass ``M`` (kg); ``P_INV_MASS`` 1 ``1/M``; ``P_INERTIA`` 2–10 ``I_b``
  row-major (kg·m²); ``P_INV_INERTIA`` 11–19 ``I_b⁻¹`` row-major; ``P_GRAVITY`` 20–22 ``g_w``
  (m/s²); ``P_LIN_DAMPING`` 23 ``c_v`` (1/s); ``P_ANG_DAMPING`` 24 ``c_ω`` (1/s);
  ``P_DIAGONAL`` 25 1.0 when ``I_b`` is diagonal (a principal body frame: the 3×3 products skip
  the zero entries), else 0.0.
* **Loads** ``ld`` (N, K, ``N_LOAD`` = 12): one row per load,
  ``[kind, point_b(3), a(3), b(3), 0, 0]`` with ``L_KIND`` 0, ``L_POINT`` 1–3 (body point
  relative to the COM, m), ``L_A`` 4–6, ``L_B`` 7–9. Kind ``LOAD_WORLD`` (1): wrench in world
  coordinates, ``a`` force (N), ``b`` couple (N·m); ``LOAD_BODY`` (2): the same in body
  coordinates; ``LOAD_SPRING`` (3): spring, ``a`` anchor_w (m), ``b = (k N/m, c N·s/m,
  l0 m)``; ``LOAD_NONE`` (0): unused row.
* **Times** ``t`` (N,) int64 nanoseconds.
"""

import hashlib
import os

import numpy as np

# State rows (13, N).
S_POS = 0
S_QUAT = 3
S_VEL = 7
S_OMEGA = 10
N_STATE = 13
#: The same rows as slices, for code outside the kernels (rows of a column or of the array).
POS = slice(S_POS, S_QUAT)
QUAT = slice(S_QUAT, S_VEL)
VEL = slice(S_VEL, S_OMEGA)
OMEGA = slice(S_OMEGA, N_STATE)

# Parameter rows (26, N).
P_MASS = 0
P_INV_MASS = 1
P_INERTIA = 2
P_INV_INERTIA = 11
P_GRAVITY = 20
P_LIN_DAMPING = 23
P_ANG_DAMPING = 24
P_DIAGONAL = 25
N_PARAM = 26

# Load row fields (N, K, 12) and kinds.
L_KIND = 0
L_POINT = 1
L_A = 4
L_B = 7
N_LOAD = 12
LOAD_NONE = 0
LOAD_WORLD = 1
LOAD_BODY = 2
LOAD_SPRING = 3


# Every constant above, in a fixed order: numba's disk cache of the kernels is kept per value
# of this (numba keys it by the kernel file, not by the values of the globals it imports from
# here), see fingerprint_hash().
FINGERPRINT = (S_POS, S_QUAT, S_VEL, S_OMEGA, N_STATE, P_MASS, P_INV_MASS, P_INERTIA,
               P_INV_INERTIA, P_GRAVITY, P_LIN_DAMPING, P_ANG_DAMPING, P_DIAGONAL, N_PARAM,
               L_KIND, L_POINT, L_A, L_B, N_LOAD, LOAD_NONE, LOAD_WORLD, LOAD_BODY, LOAD_SPRING)


#: The compiled-kernel sources (relative to ``rbd_ros/core``).  A compiled function embeds the
#: machine code of every function it calls or inlines, but numba checks only the caller's own
#: file before loading it from its cache: the contact step inlines the integrator's kicks
#: from ``kernels.py``, so an edit there would otherwise leave a stale step in the cache.
KERNEL_SOURCES = ('layout.py', 'jitcache.py', 'kernels.py', 'kernel_rotations.py',
                  'kernel_forces.py', 'kernel_integrators.py', 'contact/kernels.py',
                  'contact/box_box.py', 'contact/rows.py', 'contact/linalg.py',
                  'contact/bodies.py', 'contact/broad_phase.py', 'contact/points.py',
                  'contact/manifold.py', 'contact/narrow_phase.py', 'contact/response.py',
                  'contact/patch.py', 'contact/friction.py', 'contact/sweeps.py',
                  'contact/step.py', 'contact/joints.py', 'contact/motors.py',
                  'contact/limits.py', 'joints/kernels.py', 'joints/arrays.py',
                  'joints/rows.py', 'joints/solve.py', 'joints/articulated.py',
                  'joints/projection.py', 'joints/active_rows.py', 'joints/dynamics.py',
                  'joints/events.py')


def fingerprint_hash() -> str:
    """
    Return 12 hex digits of SHA-256 over :data:`FINGERPRINT` and the kernel sources.

    It names the kernel cache directory, so a changed offset or any changed kernel source
    compiles afresh instead of running machine code built for the old one.
    """
    digest = hashlib.sha256(repr(FINGERPRINT).encode('ascii'))
    here = os.path.dirname(os.path.abspath(__file__))
    for name in KERNEL_SOURCES:
        with open(os.path.join(here, name), 'rb') as source:
            digest.update(source.read())
    return digest.hexdigest()[:12]


def pack_state(state) -> np.ndarray:
    """Return the state column (``N_STATE``,) of a :class:`~rbd_ros.core.state.BodyState`."""
    column = np.empty(N_STATE)
    column[S_POS:S_POS + 3] = state.position_w
    column[S_QUAT:S_QUAT + 4] = state.orientation_wb
    column[S_VEL:S_VEL + 3] = state.linear_velocity_w
    column[S_OMEGA:S_OMEGA + 3] = state.angular_velocity_b
    return column


def unpack_state(column) -> dict:
    """
    Return the fields of a state column as ``BodyState`` keyword arguments (views, no copy).

    ``BodyState(**unpack_state(x[:, i]), time_ns=t[i])`` rebuilds body ``i``.
    """
    return {'position_w': column[S_POS:S_POS + 3],
            'orientation_wb': column[S_QUAT:S_QUAT + 4],
            'linear_velocity_w': column[S_VEL:S_VEL + 3],
            'angular_velocity_b': column[S_OMEGA:S_OMEGA + 3]}


def pack_params(model) -> np.ndarray:
    """Return the parameter column (``N_PARAM``,) of a :class:`~rbd_ros.core.model.BodyModel`."""
    column = np.empty(N_PARAM)
    column[P_MASS] = model.mass_kg
    column[P_INV_MASS] = 1.0 / model.mass_kg
    column[P_INERTIA:P_INERTIA + 9] = model.inertia_b.reshape(9)
    column[P_INV_INERTIA:P_INV_INERTIA + 9] = model.inertia_inv_b.reshape(9)
    column[P_GRAVITY:P_GRAVITY + 3] = model.gravity_w
    column[P_LIN_DAMPING] = model.linear_damping_per_s
    column[P_ANG_DAMPING] = model.angular_damping_per_s
    inertia = model.inertia_b
    diagonal = np.count_nonzero(inertia - np.diag(np.diag(inertia))) == 0
    column[P_DIAGONAL] = 1.0 if diagonal else 0.0
    return column


def pack_wrench(rows, kind, point_b, force, torque) -> None:
    """
    Fill load row(s) ``(..., N_LOAD)`` in place with a wrench (``LOAD_WORLD`` or ``LOAD_BODY``).

    ``point_b`` (m), ``force`` (N) and ``torque`` (N·m) broadcast over the leading axes.
    """
    rows[..., L_KIND] = kind
    rows[..., L_POINT:L_POINT + 3] = point_b
    rows[..., L_A:L_A + 3] = force
    rows[..., L_B:L_B + 3] = torque


def pack_spring(rows, point_b, anchor_w, stiffness, damping, rest_length) -> None:
    """Fill load row(s) in place with a spring: ``a = anchor_w``, ``b = (k, c, l0)``."""
    rows[..., L_KIND] = LOAD_SPRING
    rows[..., L_POINT:L_POINT + 3] = point_b
    rows[..., L_A:L_A + 3] = anchor_w
    rows[..., L_B] = stiffness
    rows[..., L_B + 1] = damping
    rows[..., L_B + 2] = rest_length


def unpack_load(row) -> dict:
    """Return the fields of a load row: ``kind`` (int), ``point_b``, ``a``, ``b`` (views)."""
    return {'kind': int(row[L_KIND]), 'point_b': row[L_POINT:L_POINT + 3],
            'a': row[L_A:L_A + 3], 'b': row[L_B:L_B + 3]}
