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
Joint limits in the contact step, as one-sided clamps in the joint visits.

A limit is its joint's limit row of :mod:`rbd_ros.core.joints.kernels` (``ROW_LIMIT``,
``C = q − bound``).

The tree step locates a crossing inside its step and stops the joint there; the contact step
has no sub-steps, so a limit is a **speculative stop**, as its contacts are: the
pre-stabilization, whose drift is the step's own position update, holds a limit's row
(``jk.set_limit``) as soon as the drift would carry the joint beyond its bound
(:func:`catch`), so the step lands the joint on the bound (to ``PROJECTION_TOL``: no
overshoot) with the impulse that takes out its approach, ``Jᵀ μ`` of the row (equal and
opposite on the two bodies). The stop is inelastic: no rebound.

One-sided: a held row's impulses over the step (:data:`~rbd_ros.core.contact.motors.D_STOP`)
may only push the joint off its bound; a row whose total would pull is let go, and a
post-stabilization lets a joint leave its bound when it moves away (:func:`let_go`). Every
step starts with every limit free (:func:`free_all`), so nothing sticks: a joint at rest on
its stop is caught again by each step's drift and takes its load's impulse.
A held limit pauses the joint's motor and friction rows (``jk.set_limit``), as in the tree
step; they try their rows again once the limit is let go.
"""

from rbd_ros.core.contact.motors import D_STOP, friction_row
from rbd_ros.core.contact.rows import _jit
from rbd_ros.core.joints import kernels as jk

#: A held joint leaves its bound when it moves off it faster than this (rad/s or m/s): a rate
#: that a visit held at zero is round-off off it (~1e-17) in the next visit.
LEAVE_RATE = 1e-12


@_jit
def _free(joints, j):
    """
    Let joint ``j``'s limit go; its motor row back on if it drives the joint, unsaturated.

    Its friction row too, if the friction sticks it and no motor row drives it.
    """
    model, work = joints.model, joints.work
    jk.set_limit(model, work, j, 0)
    joints.drive[j, D_STOP] = 0.0
    row = model.jint[j, jk.J_MOTROW]
    if row >= 0:
        mode = work.motor[j, jk.M_MODE]
        if (mode == jk.MOTOR_VELOCITY or mode == jk.MOTOR_POSITION) \
                and work.motor[j, jk.M_SAT] == 0.0:
            work.active[row] = 1
            jk.refresh_rows(model, work, j)
    friction_row(joints, j)


@_jit
def free_all(joints):
    """Free every held limit (the step's start)."""
    for j in range(joints.model.jint.shape[0]):
        if joints.work.lim_state[j] != 0:
            _free(joints, j)
        joints.drive[j, D_STOP] = 0.0


@_jit
def catch(joints):
    """
    Hold every free limit whose bound the drifted pose ``xt`` is beyond; return whether any.

    The rows must then be factored again (at ``jx``) and ``C`` taken again at ``xt``.
    """
    model, work = joints.model, joints.work
    jint, jlim = model.jint, model.jlim
    changed = False
    for j in range(jint.shape[0]):
        if jint[j, jk.J_LIMROW] < 0 or work.lim_state[j] != 0:
            continue
        q = jk.limit_coordinate(model, joints.xt, j)
        if jlim[j, jk.L_HAS_UPPER] != 0.0 and q > jlim[j, jk.L_UPPER]:
            jk.set_limit(model, work, j, 1)
            changed = True
        elif jlim[j, jk.L_HAS_LOWER] != 0.0 and q < jlim[j, jk.L_LOWER]:
            jk.set_limit(model, work, j, -1)
            changed = True
    return changed


@_jit
def let_go(joints, moving):
    """
    Free every held limit that holds its joint by pulling it; return whether any.

    ``moving`` (post-stabilization, rows and ``bd`` at ``jx``): a joint that moves off its
    bound (faster than :data:`LEAVE_RATE`) is freed, so a held row takes out only an approach
    (``J u`` to zero). Else the last solve's impulses are added to the step's (``−yj``: along
    ``q`` on the child), and a limit whose total pulls is freed: a stop at the upper bound may
    only push the joint down (total <= 0), one at the lower bound only up. The rows must then
    be factored again.
    """
    model, work = joints.model, joints.work
    changed = False
    for j in range(model.jint.shape[0]):
        state = work.lim_state[j]
        if state == 0:
            continue
        row = model.jint[j, jk.J_LIMROW]
        if moving:
            pulls = state * jk._row_rate(model, joints.jx, work, row, 2) < -LEAVE_RATE
        else:
            joints.drive[j, D_STOP] -= work.yj[row]
            pulls = state * joints.drive[j, D_STOP] > 0.0
        if pulls:
            _free(joints, j)
            changed = True
    return changed
