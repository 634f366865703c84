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
The compiled step kernel: one scalar per-body step, shared by every path that steps a body.

The packed arrays it works on (state ``x`` (13, N), parameters ``prm`` (26, N) or
(26, 1), loads ``ld`` (N, K, 12), times ``t`` (N,) int64 ns) are laid out in
:mod:`rbd_ros.core.layout`, whose named offsets are the only row numbers used here.

The single-body simulator, the batch, the node and the replay all go through :func:`advance`
(or its parallel twin, which calls the same per-body function), so identical inputs give
bit-identical states. ``fastmath`` is off: IEEE semantics, no reassociation.

This module is the step's entry: :func:`step_body` (one body, ``n`` steps, the method chosen by
id), :func:`advance` and ``advance_parallel`` over bodies, ``midpoint_solve_check`` and
``net_wrench_batch``. Its stages, one module each: the rotation helpers
(:mod:`rbd_ros.core.kernel_rotations`), the forces' one sum (:mod:`rbd_ros.core.kernel_forces`)
and the integrators (:mod:`rbd_ros.core.kernel_integrators`). What other modules read as
``kernels.X`` (integrator ids, helpers the contact step inlines) is imported here for them.
"""

import math

import numba as nb
import numpy as np
from rbd_ros.core import jitcache
from rbd_ros.core.kernel_forces import net_wrench_w
from rbd_ros.core.kernel_integrators import (  # noqa: F401
    _free_rotation_midpoint, _midpoint_cayley, _rk4, _symplectic_euler, MIDPOINT_CAYLEY,
    midpoint_drift, midpoint_first_kick, midpoint_second_kick, RK4, SE_AXIS_ANGLE, SE_MATRIX,
    se_position, SE_QUAT_EXP, SE_QUAT_LINEAR, se_velocity)
from rbd_ros.core.kernel_rotations import (  # noqa: F401
    _cross, _gram_schmidt, _matrix_to_quat, _matvec, _normalize_q, _qmul, _quat_exp_half,
    _quat_to_matrix, _read_state, _rotate, _rotate_inv, _rotation_about, _write_state,
    SINC_SERIES_BELOW)
from rbd_ros.core.layout import N_STATE, P_ANG_DAMPING, P_INV_INERTIA, P_LIN_DAMPING

# numba's on-disk cache is chosen by jitcache.configured() when a simulator is built, not
# here (see :mod:`rbd_ros.core.jitcache`). numba keys its cache by this file, not by the values
# of the globals it imports from layout.py, so the directory is one per layout
# (``layout-<fingerprint hash>``): a changed offset compiles afresh instead of running machine
# code built for the old one.
_jit = jitcache.kernel()
# Small helpers are inlined at numba IR level: measured 20-25 % faster per body-step than
# leaving them to LLVM, for a longer first compilation (cached on disk afterwards).
_inl = jitcache.kernel(inline='always')


@_inl
def _all_finite(s):
    for k in range(N_STATE):
        if not math.isfinite(s[k]):
            return False
    return True


@_jit
def step_body(x, prm, ld, t, i, j, method, h, dt_ns, n_steps):
    """
    Advance body ``i`` (parameters in column ``j`` of ``prm``) by up to ``n_steps`` steps.

    Each step is computed in registers and written back only if every component is finite;
    otherwise the body stays at its last finite state. Returns the number of steps taken.
    The serial :func:`advance` (single bodies) calls it compiled on its own; the batch kernel
    :func:`advance_parallel` inlines the same code (:data:`_step_body_inline`): there a
    compiled call per body (its array arguments and their reference counts) costs ~20 ns of
    ~128 per body-step with one step per call (10 000 bodies, 1 thread, CPU time: 7.8 → 11.7
    M body-steps/s); same numbers. Inlining it into :func:`advance` too would lengthen the
    first compilation of the single-body path from ≈ 17 s to ≈ 26 s of CPU.
    """
    damped = prm[P_LIN_DAMPING, j] != 0.0 or prm[P_ANG_DAMPING, j] != 0.0
    decay_v_half = 1.0
    decay_w_half = 1.0
    decay_v = 1.0
    decay_w = 1.0
    if damped:
        decay_v_half = math.exp(-0.5 * h * prm[P_LIN_DAMPING, j])
        decay_w_half = math.exp(-0.5 * h * prm[P_ANG_DAMPING, j])
        decay_v = math.exp(-h * prm[P_LIN_DAMPING, j])
        decay_w = math.exp(-h * prm[P_ANG_DAMPING, j])
    # RK4 takes the damping inside its step (integrating factor, fourth order); the others
    # get its exact flow split half before and half after the step (Strang splitting).
    split = damped and method != RK4
    s = _read_state(x, i)
    done = 0
    for _ in range(n_steps):
        px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = s
        if split:
            vx, vy, vz = vx * decay_v_half, vy * decay_v_half, vz * decay_v_half
            wx, wy, wz = wx * decay_w_half, wy * decay_w_half, wz * decay_w_half
        if method == MIDPOINT_CAYLEY:
            new = _midpoint_cayley(prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
                                   vx, vy, vz, wx, wy, wz)
        elif method == RK4:
            new = _rk4(prm, ld, i, j, h,
                       (px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz),
                       decay_v_half, decay_v, decay_w_half, decay_w)
        else:
            new = _symplectic_euler(method, prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
                                    vx, vy, vz, wx, wy, wz)
        if split:
            new = (new[0], new[1], new[2], new[3], new[4], new[5], new[6],
                   new[7] * decay_v_half, new[8] * decay_v_half, new[9] * decay_v_half,
                   new[10] * decay_w_half, new[11] * decay_w_half, new[12] * decay_w_half)
        if not _all_finite(new):
            break
        s = new
        done += 1
    _write_state(x, i, s)
    t[i] += done * dt_ns
    return done


# The same Python function, inlined at numba IR level where it is called (never compiled or
# cached on its own): one source for both kernels.
_step_body_inline = jitcache.kernel(inline='always')(getattr(step_body, 'py_func', step_body))


@_jit
def advance(x, prm, ld, t, method, h, dt_ns, n_steps):
    """Advance every body ``n_steps`` steps; return how many bodies stopped early (non-finite)."""
    shared = prm.shape[1] == 1
    failed = 0
    for i in range(x.shape[1]):
        j = 0 if shared else i
        if step_body(x, prm, ld, t, i, j, method, h, dt_ns, n_steps) != n_steps:
            failed += 1
    return failed


@jitcache.kernel(parallel=True)
def advance_parallel(x, prm, ld, t, method, h, dt_ns, n_steps):
    """:func:`advance` over threads; each body runs the same scalar code (bit-identical)."""
    n = x.shape[1]
    shared = prm.shape[1] == 1
    done = np.empty(n, dtype=np.int64)
    for i in nb.prange(n):
        # i - i keeps j the type of the prange index (a literal 0 would not unify).
        done[i] = _step_body_inline(x, prm, ld, t, i, i - i if shared else i, method, h,
                                    dt_ns, n_steps)
    failed = 0
    for i in range(n):
        if done[i] != n_steps:
            failed += 1
    return failed


@_jit
def midpoint_solve_check(x, prm, ld, i, j, h):
    """
    Redo the implicit midpoint solve of body ``i``'s next ``midpoint_cayley`` step.

    Same arithmetic as :func:`step_body` up to the solve (damping half step, first kick).
    Returns ``(converged, |ω| rad/s)`` with ``ω = I_b⁻¹ Π`` the angular velocity the solve
    starts from. Overflow is not a convergence failure: when ``Π``, ``ω`` or the size
    ``h |Π| |ω|`` of the solve's gyroscopic term is not finite, it reports converged (the
    step is then refused as plainly non-finite).
    """
    # e^{-0} is exactly 1.0 and x * 1.0 == x: the same numbers as step_body, damped or not.
    vh = math.exp(-0.5 * h * prm[P_LIN_DAMPING, j])
    wh = math.exp(-0.5 * h * prm[P_ANG_DAMPING, j])
    px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = _read_state(x, i)
    _, _, _, lx, ly, lz = midpoint_first_kick(
        prm, ld, i, j, h, px, py, pz, qw, qx, qy, qz,
        vx * vh, vy * vh, vz * vh, wx * wh, wy * wh, wz * wh)
    wx, wy, wz = _matvec(prm, P_INV_INERTIA, j, lx, ly, lz)
    speed = math.sqrt(wx * wx + wy * wy + wz * wz)
    if not math.isfinite(h * speed * math.sqrt(lx * lx + ly * ly + lz * lz)):
        return True, speed
    return _free_rotation_midpoint(prm, j, h, lx, ly, lz)[6], speed


@_jit
def net_wrench_batch(x, prm, ld, out):
    """Net world force (rows 0–2) and torque about the COM (rows 3–5) of every body."""
    shared = prm.shape[1] == 1
    for i in range(x.shape[1]):
        j = 0 if shared else i
        px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz = _read_state(x, i)
        w = net_wrench_w(px, py, pz, qw, qx, qy, qz, vx, vy, vz, wx, wy, wz, prm, ld, i, j)
        for k in range(6):
            out[k, i] = w[k]
