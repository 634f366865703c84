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
:class:`ArticulatedSimulator`: bodies joined by joints, stepped exactly (no contact yet).

Every link is a body with its own :class:`~rbd_ros.core.state.BodyState`; a joint is a set of
constraint rows between two bodies (or a body and the world), see :data:`ROWS`. A step is one
classical RK4 step of the constrained equations of motion (multipliers from a direct solve,
:mod:`rbd_ros.core.joints.kernels`; a step that turns a body or a joint by more than 0.1 rad is
taken as equal sub-steps that turn none by more), the quaternions renormalised, then a
projection: positions by Newton with the mass-weighted minimal change until every row's error
is at most :data:`PROJECTION_TOL`, then velocities onto the joints' allowed motions. The whole
step is one compiled call that allocates nothing.
"""

from collections import deque
import math
from typing import Sequence

import numpy as np

from rbd_ros.core import jitcache
from rbd_ros.core.errors import (ConfigError, ConvergenceError, finite_scalar, finite_vector,
                                 NonFiniteError, whole_number)
from rbd_ros.core.joints import kernels as jk
from rbd_ros.core.joints.model import (check_position_target, coordinate_units, Joint,
                                       joint_position, joint_velocity, MOTOR_COORDINATES,
                                       MOTOR_KINDS)
from rbd_ros.core.joints.readout import JointReadout
from rbd_ros.core.model import BodyModel
from rbd_ros.core.rotations import quat_to_matrix
from rbd_ros.core.state import BodyState

#: Constraint rows per kind: ``('lin', k)`` is ``C = e_k · d`` (the anchors' separation on the
#: parent's joint axis ``u_k``), ``('ang', k, l)`` is ``C = e_k · f_l`` (parent axis ``u_k``
#: perpendicular to the child's ``w_l``). ``u3 = axis_b``; ``u1 = axis2_b`` for universal and
#: planar joints, else a fixed perpendicular; ``u2 = u3 × u1``; ``w_l`` the same axes in the
#: child at the rest pose.
ROWS = {
    'fixed': (('lin', 0), ('lin', 1), ('lin', 2), ('ang', 1, 2), ('ang', 2, 0), ('ang', 0, 1)),
    'revolute': (('lin', 0), ('lin', 1), ('lin', 2), ('ang', 0, 2), ('ang', 1, 2)),
    'continuous': (('lin', 0), ('lin', 1), ('lin', 2), ('ang', 0, 2), ('ang', 1, 2)),
    'prismatic': (('lin', 0), ('lin', 1), ('ang', 1, 2), ('ang', 2, 0), ('ang', 0, 1)),
    'spherical': (('lin', 0), ('lin', 1), ('lin', 2)),
    'universal': (('lin', 0), ('lin', 1), ('lin', 2), ('ang', 2, 0)),
    'planar': (('lin', 2), ('ang', 0, 2), ('ang', 1, 2)),
}
#: The axis ``k`` (:data:`ROWS`) of each motor coordinate's row, by kind with several.
_MOTOR_AXES = {'planar': (0, 1, 2), 'universal': (2, 0), 'spherical': (0, 1, 2)}
#: Largest row error left by the projection after every step, m (position rows) or the
#: cosine of the angle between two axes that must be perpendicular (alignment rows).
PROJECTION_TOL = 1e-13
#: Newton iterations allowed per projection before the step is refused.
PROJECTION_MAX_ITER = 50
#: The kernels' code of each motor mode of :meth:`ArticulatedSimulator.set_motor`.
_MOTOR_CODES = {'off': jk.MOTOR_OFF, 'effort': jk.MOTOR_EFFORT, 'velocity': jk.MOTOR_VELOCITY,
                'position': jk.MOTOR_POSITION}


def _finite_floats(value, size):
    """
    Return ``value`` as a tuple of ``size`` floats if it is a tuple or list of finite floats.

    Else None (the caller then applies :func:`~rbd_ros.core.errors.finite_vector`, which
    takes any sequence and says what is wrong): the same numbers without a numpy array, for
    a trajectory's reference rates set at every step (~4 µs a joint through numpy).
    """
    if type(value) not in (tuple, list) or len(value) != size:
        return None
    for v in value:
        if not isinstance(v, float) or not math.isfinite(v):
            return None
    return tuple(value)


def _perpendicular(axis):
    """Return a unit vector perpendicular to ``axis`` (the least aligned coordinate axis)."""
    pick = np.zeros(3)
    pick[int(np.argmin(np.abs(axis)))] = 1.0
    u = np.cross(axis, pick)
    return u / np.linalg.norm(u)


def _basis(joint):
    u3 = np.asarray(joint.axis_b, dtype=np.float64)
    u1 = (np.asarray(joint.axis2_b, dtype=np.float64) if joint.kind in ('universal', 'planar')
          else _perpendicular(u3))
    u1 = u1 - (u1 @ u3) * u3
    u1 /= np.linalg.norm(u1)
    return np.array([u1, np.cross(u3, u1), u3])


def _tree(n_bodies, joints):
    """
    Return ``(dense, order, node_par)`` for the body-joint graph (bodies 0.., joints n_b..).

    ``dense`` when a component has a loop: a cycle among bodies or two joints to the world.
    """
    n_j = len(joints)
    adj = [[] for _ in range(n_bodies + n_j)]
    for j, joint in enumerate(joints):
        for b in (joint.parent, joint.child):
            if b is not None:
                adj[n_bodies + j].append(b)
                adj[b].append(n_bodies + j)
    seen = [False] * (n_bodies + n_j)
    par = [-1] * (n_bodies + n_j)
    order = []
    for start in range(n_bodies):
        if seen[start]:
            continue
        # the component: bodies and joints reachable from this body
        comp, queue = [], deque([start])
        seen[start] = True
        while queue:
            i = queue.popleft()
            comp.append(i)
            for k in adj[i]:
                if not seen[k]:
                    seen[k] = True
                    queue.append(k)
        bodies = [i for i in comp if i < n_bodies]
        links = [i for i in comp if i >= n_bodies]
        world = [i for i in links if joints[i - n_bodies].parent is None]
        if len(world) > 1 or len(links) - len(world) > len(bodies) - 1:
            return True, None, None
        root = world[0] if world else bodies[0]
        visited = {root}
        bfs, queue = [], deque([root])
        while queue:
            i = queue.popleft()
            bfs.append(i)
            for k in adj[i]:
                if k not in visited:
                    visited.add(k)
                    par[k] = i
                    queue.append(k)
        order.extend(reversed(bfs))
    return False, np.array(order, dtype=np.int64), np.array(par, dtype=np.int64)


def _check_mimics(joints):
    """Refuse a mimic of an unknown joint, of a joint without one coordinate, or a cycle."""
    by_name = {joint.name: joint for joint in joints}
    for joint in joints:
        if joint.mimic is None:
            continue
        who = f'joint {joint.name!r}.mimic'
        leader = by_name.get(joint.mimic)
        if leader is None:
            raise ConfigError(f'{who}: {joint.mimic!r} is not a joint of this system')
        if leader.kind not in MOTOR_KINDS:
            raise ConfigError(f'{who}: {joint.mimic!r} is a {leader.kind} joint; a mimic '
                              f'follows a {", ".join(MOTOR_KINDS)} joint')
        chain, seen = joint, {joint.name}
        while chain.mimic is not None:
            chain = by_name[chain.mimic]
            if chain.name in seen:
                raise ConfigError(f'{who}: {joint.mimic!r} leads back to {joint.name!r} (a '
                                  'cycle of mimics); one joint of a chain must move freely')
            seen.add(chain.name)


def compiled(dispatcher, args):
    """
    Return ``dispatcher``'s machine code for the types of ``args``, a function of the same args.

    A call through a numba dispatcher first types every argument, ~0.15 µs an array: the
    articulated step's ``model`` and ``work`` (about 45 arrays in two named tuples) cost ~6 µs
    a call that way, a sixth of a 7-link arm's step. ``Dispatcher.compile`` (numba's, what a
    call runs after the typing; from the disk cache, or compiled now) returns the function
    that unboxes the arguments by those types and runs the same machine code, so a caller
    whose arguments keep their types (a simulator's own arrays) types them once.
    """
    return dispatcher.compile(tuple(dispatcher.typeof_pyval(a) for a in args))


def joint_error(model, work, x, rows_kernel=None):
    """
    Return ``(max anchor distance m, max axis angle rad)`` over all joints at ``x`` (N, 13).

    A mimic joint's ``|q - k q_leader - c|`` counts as an angle (rad) when the mimic is
    revolute or continuous, as a distance (m) when prismatic. ``model``, ``work``: the arrays
    of :mod:`rbd_ros.core.joints.kernels`; ``work.con`` is overwritten. ``rows_kernel``:
    :func:`compiled` of ``joint_rows`` for these arrays (None: through its dispatcher).
    Plain floats: the arrays are read as lists once (numpy's per-element reads cost ~60 µs
    for a 7-link arm, more than its step).
    """
    (jk.joint_rows if rows_kernel is None else rows_kernel)(model, x, work, False)
    con, kinds = work.con.tolist(), model.rows[:, 1].tolist()
    prismatic = jk.KIND_CODES['prismatic']
    dist, ang = 0.0, 0.0
    for joint in model.jint.tolist():
        r0, n = joint[jk.J_ROW0], joint[jk.J_NROWS]
        lin = [con[r] for r in range(r0, r0 + n) if kinds[r] == jk.ROW_LIN]
        angs = [abs(con[r]) for r in range(r0, r0 + n) if kinds[r] == jk.ROW_ANG]
        dist = max(dist, math.sqrt(sum(v * v for v in lin)))
        if angs:
            ang = max(ang, math.asin(min(1.0, max(angs))))
        mimic = joint[jk.J_MIMROW]
        if mimic >= 0:
            if joint[jk.J_KIND] == prismatic:
                dist = max(dist, abs(con[mimic]))
            else:
                ang = max(ang, abs(con[mimic]))
    return dist, ang


class ArticulatedSimulator:
    """
    Rigid bodies joined by :class:`~rbd_ros.core.joints.model.Joint` values, no contact.

    :param models: one :class:`~rbd_ros.core.model.BodyModel` per body (its gravity and
        damping act as on a free body; damping enters as the force ``-m c_v v`` and torque
        ``-c_ω I ω``, integrated by RK4 with the rest).
    :param states: one :class:`~rbd_ros.core.state.BodyState` per body, all at the same time.
        They need not satisfy the joints: the constructor projects them, positions first (the
        mass-weighted smallest change, Newton to :data:`PROJECTION_TOL`), then velocities
        (the smallest kinetic-energy change that makes every joint's rows still).
    :param joints: the joints; ``parent=None`` is the world. Trees, branches and loops. A
        joint's ``damping`` is the force ``-damping q̇`` along its coordinate, integrated by
        RK4 with the rest (fourth order; explicit, so stable while ``damping h / I_eff`` is
        below 2.78, ``I_eff`` the inertia the joint moves). Its ``friction`` holds it while
        the force that would hold it is within the friction (a velocity row, checked at
        every step boundary) and slides against ``∓friction`` otherwise; a sliding joint's stop
        is located inside the step as a limit crossing is. A position or velocity motor fixes
        the joint's motion: damping and friction then load the motor (its effort includes
        them), friction being 0 while the joint is at rest (``|q̇| <= 1e-12``). A spherical
        joint's ``cone_rad`` is a limit on the angle between its axis in the parent and in
        the child (:func:`~rbd_ros.core.joints.model.cone_angle`), a stop like the others.
        A joint with ``mimic`` is held at ``q = k q_leader + c`` by one more row (its
        Jacobian the mimic's axial row minus ``k`` times the leader's: equal and opposite
        generalized forces, ``λ`` on the mimic and ``-k λ`` on the leader), projected with
        the others; it couples two joints as a loop does, so the dense solver takes it.
    :param timestep_ns: the fixed step ``h``, integer ns > 0. A step whose start turns a body
        (``|ω|``) or a joint's child relative to its parent (``|ω_c - ω_p|``, any kind) by
        more than :data:`~rbd_ros.core.joints.kernels.SUBSTEP_ROTATION` (0.1 rad) in ``h`` is
        taken as the fewest equal sub-steps that turn none by more (at most
        :data:`~rbd_ros.core.joints.kernels.SUBSTEPS_MAX`), each a step as below: RK4's
        error grows as the fifth power of that angle (:attr:`split_steps` counts them). The
        clock still advances by ``h`` a step; limits, frictions and motors act as in any
        step, their readouts (efforts, wrenches) those of the step's end.
    :param solver: ``'auto'`` (the tree elimination when no loop closes, else dense) or
        ``'dense'`` (always the dense factorisation; the same answers, for checking).
    :param defer_projection: True: the initial projection waits for the first :meth:`step`
        or motor target, so building the simulator runs almost no compiled kernel (a node
        publishes the states as given at t = 0 while its kernels compile). Until then the
        readouts are those of the states as given, :meth:`joint_error` is None, and the errors
        below come from that first call. Either way the steps give the same bits.
    :raises ConfigError: a bad argument (one line naming the joint or body and field).
    :raises ConvergenceError: the initial poses could not be projected onto the joints.
    """

    def __init__(self, models: Sequence[BodyModel], states: Sequence[BodyState],
                 joints: Sequence[Joint], *, timestep_ns: int = 1_000_000,
                 solver: str = 'auto', defer_projection: bool = False):
        models, states, joints = list(models), list(states), list(joints)
        self._timestep_ns = whole_number(timestep_ns, 'timestep_ns', 'ns', positive=True,
                                         error=ConfigError)
        if solver not in ('auto', 'dense'):
            raise ConfigError(f"solver: {solver!r} is not 'auto' or 'dense'")
        if not models:
            raise ConfigError('models: empty; an articulated system needs at least one body')
        if len(states) != len(models):
            raise ConfigError(f'states: {len(states)} states for {len(models)} models; one '
                              'state per body')
        for i, model in enumerate(models):
            if not isinstance(model, BodyModel):
                raise ConfigError(f'models[{i}]: {type(model).__name__} is not a BodyModel')
        for i, state in enumerate(states):
            if not isinstance(state, BodyState):
                raise ConfigError(f'states[{i}]: {type(state).__name__} is not a BodyState')
            if state.time_ns != states[0].time_ns:
                raise ConfigError(f'states[{i}].time_ns: {state.time_ns} ns differs from '
                                  f'states[0].time_ns {states[0].time_ns} ns; one time for all')
        n_b = len(models)
        names = set()
        for i, joint in enumerate(joints):
            if not isinstance(joint, Joint):
                raise ConfigError(f'joints[{i}]: {type(joint).__name__} is not a Joint')
            who = f'joint {joint.name!r}'
            if joint.name in names:
                raise ConfigError(f'{who}.name: used by two joints; names must be unique')
            names.add(joint.name)
            if joint.child >= n_b:
                raise ConfigError(f'{who}.child: {joint.child} is not a body index (0 to '
                                  f'{n_b - 1})')
            if joint.parent is not None and joint.parent >= n_b:
                raise ConfigError(f'{who}.parent: {joint.parent} is not a body index (0 to '
                                  f'{n_b - 1}) or None (world)')
            if joint.parent == joint.child:
                raise ConfigError(f'{who}.parent: {joint.parent} is its own child')
        _check_mimics(joints)
        self._models = tuple(models)
        self._joints = tuple(joints)
        self._readout = JointReadout(joints)
        self._model, self._work, self._slots = self._arrays(models, joints, solver == 'dense')
        self._x = np.zeros((n_b, 13))
        for b, s in enumerate(states):
            self._x[b] = np.concatenate([s.position_w, s.orientation_wb, s.linear_velocity_w,
                                         s.angular_velocity_b])
        self._time_ns = states[0].time_ns
        self._t_call = self._time_ns
        self._split_total = 0
        self._projected = False
        # compiled(), at their first call
        self._step_kernel = self._refresh_kernel = self._rows_kernel = None
        if not defer_projection:
            self._project_initial()

    def _project_initial(self):
        """Project the initial states onto the joints (once, before anything steps them)."""
        if self._projected:
            return
        jitcache.configured()  # the kernel cache, before a first compile
        it = jk.initialize(self._model, self._x, self._work, PROJECTION_TOL,
                           PROJECTION_MAX_ITER)
        if it < 0 or not np.isfinite(self._x).all():
            raise ConvergenceError(
                f'states: the initial poses could not be projected onto the joints in '
                f'{PROJECTION_MAX_ITER} Newton iterations (error {self._work.stats[0]:.3g} m '
                'or rad); start them nearer')
        self._check_finite('the initial projection')
        self._check_branch()
        self._check_limits()
        for j, joint in enumerate(self._joints):
            if joint.kind == 'continuous':
                self._work.angle[j] = joint_position(joint, *self._poses(joint))[0]
        jk._unwrap(self._model, self._x, self._work)
        self._projected = True

    def project_initial(self) -> None:
        """
        Take the initial projection now if it was deferred (``defer_projection``); else nothing.

        For a step that drives these joints' kernels itself (the contact step's joint visits)
        and must start from the projected states: :attr:`states` are those states after it.

        :raises ConvergenceError, ConfigError: as the constructor without deferral.
        """
        self._project_initial()

    @property
    def projected(self) -> bool:
        """Return whether the initial projection has been taken (see ``defer_projection``)."""
        return self._projected

    def _check_branch(self):
        """Refuse a start on a joint's mirror branch (rows satisfied with an axis reversed)."""
        for j, joint in enumerate(self._joints):
            if joint.kind in ('spherical', 'universal'):
                continue
            rot_p = (np.eye(3) if joint.parent is None
                     else quat_to_matrix(self._x[joint.parent, 3:7]))
            rot_c = quat_to_matrix(self._x[joint.child, 3:7])
            basis_p = rot_p @ self._model.jprm[j, jk.J_BASIS_P:jk.J_BASIS_P + 9].reshape(3, 3).T
            basis_c = rot_c @ self._model.jprm[j, jk.J_BASIS_C:jk.J_BASIS_C + 9].reshape(3, 3).T
            cosines = np.sum(basis_p * basis_c, axis=0)
            # the axis kinds need u3 on w3; the orientation-locking kinds every axis on its own
            bad = cosines[2] <= 0.0 if joint.kind in ('revolute', 'continuous', 'planar') \
                else bool(np.any(cosines <= 0.0))
            if bad:
                raise ConfigError(f'states: joint {joint.name!r} starts with its child turned '
                                  "over (an axis reversed against the parent's); start it near "
                                  'its rest orientation q_rest')

    def _check_limits(self):
        for j, joint in enumerate(self._joints):
            if joint.cone_rad is not None:
                angle = jk.limit_coordinate(self._model, self._x, j)
                if angle > joint.cone_rad + jk.CROSS_TOL:
                    raise ConfigError(f'joint {joint.name!r}.cone_rad: the initial angle off the '
                                      f'axis {angle!r} rad is beyond cone_rad '
                                      f'{joint.cone_rad!r} rad')
            if joint.lower is None and joint.upper is None:
                continue
            q = jk.limit_coordinate(self._model, self._x, j)
            unit = 'm' if joint.kind == 'prismatic' else 'rad'
            if joint.upper is not None and q > joint.upper + jk.CROSS_TOL:
                raise ConfigError(f'joint {joint.name!r}.upper: the initial position {q!r} {unit}'
                                  f' is above upper {joint.upper!r} {unit}')
            if joint.lower is not None and q < joint.lower - jk.CROSS_TOL:
                raise ConfigError(f'joint {joint.name!r}.lower: the initial position {q!r} {unit}'
                                  f' is below lower {joint.lower!r} {unit}')

    @staticmethod
    def _arrays(models, joints, force_dense=False):
        n_b, n_j = len(models), len(joints)
        prm = np.zeros((n_b, jk.P_SIZE))
        for b, m in enumerate(models):
            prm[b, jk.P_MASS] = m.mass_kg
            prm[b, jk.P_INERTIA:jk.P_INERTIA + 9] = np.asarray(m.inertia_b).ravel()
            prm[b, jk.P_INERTIA_INV:jk.P_INERTIA_INV + 9] = np.asarray(m.inertia_inv_b).ravel()
            prm[b, jk.P_GRAVITY:jk.P_GRAVITY + 3] = m.gravity_w
            prm[b, jk.P_LIN_DAMP] = m.linear_damping_per_s
            prm[b, jk.P_ANG_DAMP] = m.angular_damping_per_s
        names = [joint.name for joint in joints]
        jint = np.zeros((n_j, jk.J_INT_SIZE), dtype=np.int64)
        jprm = np.zeros((n_j, jk.J_PRM_SIZE))
        jlim = np.zeros((n_j, 4))
        rows = []
        # motor slots (rows of work.motor): joint j's first coordinate in slot j, a planar
        # joint's y and theta after the joints
        slots = [[j] for j in range(n_j)]
        for j, joint in enumerate(joints):
            extra = len(MOTOR_COORDINATES.get(joint.kind, ())) - 1
            if extra > 0:
                start = n_j + sum(len(s) - 1 for s in slots)
                slots[j] += list(range(start, start + extra))
        mrows = -np.ones(max(n_j + sum(len(s) - 1 for s in slots), 1), dtype=np.int64)
        for j, joint in enumerate(joints):
            spec = ROWS[joint.kind]
            limited = (joint.lower is not None or joint.upper is not None
                       or joint.cone_rad is not None)
            limit_row = motor_row = friction_row = mimic_row = -1
            if limited:
                limit_row = len(rows) + len(spec)
                spec = spec + (('limit', 2),)
            if joint.kind in MOTOR_KINDS:
                motor_row = len(rows) + len(spec)
                mrows[j] = motor_row
                spec = spec + (('motor', 2, j),)
            elif joint.kind in MOTOR_COORDINATES:
                # planar: x and y along u1 and u2, theta about u3; universal: θ1 about u3,
                # θ2 about the child's w1; spherical: rx, ry, rz about the parent's own x, y,
                # z (not its u_k); J_MOTROW stays -1 (the one-row-a-joint paths, the
                # contact step's, leave them alone)
                for axis, slot in zip(_MOTOR_AXES[joint.kind], slots[j]):
                    mrows[slot] = len(rows) + len(spec)
                    spec = spec + (('motor', axis, slot),)
            if joint.friction > 0.0:
                friction_row = len(rows) + len(spec)
                spec = spec + (('friction', 2),)
            if joint.mimic is not None:
                mimic_row = len(rows) + len(spec)
                spec = spec + (('mimic', 0, names.index(joint.mimic)),)
            jint[j] = (-1 if joint.parent is None else joint.parent, joint.child,
                       jk.KIND_CODES[joint.kind], len(rows), len(spec), limit_row, motor_row,
                       friction_row, mimic_row)
            jlim[j] = (joint.lower or 0.0, joint.upper or 0.0, joint.lower is not None,
                       joint.upper is not None)
            if joint.cone_rad is not None:   # the angle off the axis has an upper bound only
                jlim[j] = (0.0, joint.cone_rad, False, True)
            basis = _basis(joint)
            rest = quat_to_matrix(np.asarray(joint.q_rest))
            jprm[j, jk.J_ORIGIN_P:jk.J_ORIGIN_P + 3] = joint.origin_parent_b
            jprm[j, jk.J_ORIGIN_C:jk.J_ORIGIN_C + 3] = joint.origin_child_b
            jprm[j, jk.J_BASIS_P:jk.J_BASIS_P + 9] = basis.ravel()
            jprm[j, jk.J_BASIS_C:jk.J_BASIS_C + 9] = (basis @ rest).ravel()   # rows Rᵀ u
            jprm[j, jk.J_QREST:jk.J_QREST + 4] = joint.q_rest
            jprm[j, jk.J_DAMPING] = joint.damping
            jprm[j, jk.J_FRICTION] = joint.friction
            jprm[j, jk.J_MIMIC_K] = joint.mimic_multiplier
            jprm[j, jk.J_MIMIC_C] = joint.mimic_offset
            code = {'lin': jk.ROW_LIN, 'ang': jk.ROW_ANG, 'limit': jk.ROW_LIMIT,
                    'motor': jk.ROW_MOTOR, 'friction': jk.ROW_FRICTION, 'mimic': jk.ROW_MIMIC}
            for r in spec:
                rows.append((j, code[r[0]], r[1], r[2] if len(r) > 2 else 0))
        rows = np.array(rows, dtype=np.int64).reshape(-1, 4)
        n_r = rows.shape[0]
        dense, order, par = _tree(n_b, joints)
        # a mimic row couples two joints (up to four bodies): a loop for the tree elimination
        dense = dense or force_dense or any(joint.mimic is not None for joint in joints)
        n_nodes = n_b + n_j
        dim = np.array([6] * n_b + [len(ROWS[jt.kind]) for jt in joints], dtype=np.int64)
        nrow = dim[n_b:].copy()
        active = np.ones(n_r, dtype=np.int64)
        for column in (jk.J_LIMROW, jk.J_MOTROW, jk.J_FRICROW):
            active[jint[:, column][jint[:, column] >= 0]] = 0
        active[mrows[mrows >= 0]] = 0
        if dense:
            order = np.zeros(0, dtype=np.int64)
            par = -np.ones(n_nodes, dtype=np.int64)
        model = jk.ArtModel(prm, jint, jprm, jlim, rows, order, par, dim.copy(), bool(dense),
                            mrows)
        dn = n_r if dense else 1
        nd = 1 if dense else n_nodes
        # a row's Jacobian: 6 columns a body side, 2 sides (4 for a mimic row: its leader's)
        cols = 24 if any(jt.mimic is not None for jt in joints) else 12
        work = jk.ArtWork(
            bd=np.zeros((n_b, jk.B_SIZE)), jac=np.zeros((max(n_r, 1), cols)),
            con=np.zeros(n_r), bias=np.zeros(n_r), D=np.zeros((nd, 6, 6)),
            Hp=np.zeros((nd, 6, 6)), W=np.zeros((nd, 6, 7)), rhs=np.zeros((nd, 6)),
            y=np.zeros((nd, 6)), A=np.zeros((dn, dn)), mj=np.zeros((max(n_r, 1), cols)),
            drop=np.zeros(dn, dtype=np.int64), k=np.zeros((4, n_b, 13)),
            xs=np.zeros((n_b, 13)), yb=np.zeros((n_b, 6)), yj=np.zeros(n_r),
            lam=np.zeros(n_r), wrench=np.zeros((max(n_j, 1), 6)), angle=np.zeros(max(n_j, 1)),
            stats=np.zeros(jk.S_SIZE), nrow=nrow, dim=dim, active=active,
            lim_state=np.zeros(max(n_j, 1), dtype=np.int64),
            lim0=np.zeros(max(n_j, 1), dtype=np.int64), x0=np.zeros((n_b, 13)),
            k0=np.zeros((n_b, 13)), jrows=np.zeros((max(n_j, 1), 9), dtype=np.int64),
            motor=np.zeros((mrows.shape[0], jk.M_SIZE)),
            fric=np.zeros((max(n_j, 1), jk.F_SIZE)), axial=np.zeros((mrows.shape[0], 2)),
            arows=np.zeros((max(n_j, 1), 6), dtype=np.int64), form=np.zeros(1, dtype=np.int64))
        work.fric[:, jk.F_SIGN] = 2.0   # each joint's friction state: decided at the start
        work.stats[jk.S_SUBSTEPS] = 1.0   # no step taken, none split
        for j, joint in enumerate(joints):
            work.motor[slots[j], jk.M_LIMIT] = (math.inf if joint.effort_limit is None
                                                else joint.effort_limit)
            jk.refresh_rows(model, work, j)
        return model, work, slots

    def _check_finite(self, where):
        if not np.isfinite(self._x).all():
            raise NonFiniteError(f'state: not finite after {where} at t = {self._time_ns} ns')

    def step(self, n_steps: int = 1) -> None:
        """
        Advance ``n_steps`` fixed steps (one compiled call).

        :raises ConvergenceError: the position projection did not reach
            :data:`PROJECTION_TOL` in :data:`PROJECTION_MAX_ITER` iterations.
        :raises NonFiniteError: a step would have made the state non-finite.

        Either way the state and time stay where the failing step began (after a limit stop
        inside that step, or in a step split into sub-steps: where the sub-step began),
        finite.
        """
        n = whole_number(n_steps, 'n_steps', 'steps', error=ConfigError)
        if n == 0:
            return
        self._project_initial()
        h = self._timestep_ns * 1e-9
        self._t_call = self._time_ns
        self._work.stats[jk.S_TIME] = self._work.stats[jk.S_TSTAGE] = self._time_ns * 1e-9
        args = (self._model, self._x, self._work, h, n, PROJECTION_TOL, PROJECTION_MAX_ITER)
        if self._step_kernel is None:
            self._step_kernel = compiled(jk.step, args)
        failed = self._step_kernel(*args)
        self._split_total += int(self._work.stats[jk.S_SPLIT])
        if failed:  # the kernel left the state where the failing step (or sub-step) began
            self._time_ns += (failed - 1) * self._timestep_ns
            if self._work.stats[jk.S_FAIL] == 2.0:
                raise NonFiniteError(
                    f'joints: step {failed} would make the state non-finite at t = '
                    f'{self._time_ns} ns; the state stays at its last finite value')
            raise ConvergenceError(
                f'joints: the position projection did not converge at step {failed} '
                f'(error {self._work.stats[0]:.3g} m or rad) at t = {self._time_ns} ns')
        # finite: the kernel checks the state after every step (and sub-step) and refuses a
        # non-finite one (S_FAIL 2, above)
        self._time_ns += n * self._timestep_ns

    @property
    def timestep_ns(self) -> int:
        """Return the fixed step, ns."""
        return self._timestep_ns

    @property
    def time_ns(self) -> int:
        """Return the sim time, integer ns."""
        return self._time_ns

    @property
    def models(self):
        """Return the body models, a tuple."""
        return self._models

    @property
    def joints(self):
        """Return the joints, a tuple."""
        return self._joints

    @property
    def solver(self) -> str:
        """Return ``'tree'`` (Baraff's block elimination) or ``'dense'`` (a loop closes)."""
        return 'dense' if self._model.dense else 'tree'

    @property
    def last_projection(self):
        """Return ``(max row error after the last call's projections, max iterations)``."""
        return float(self._work.stats[0]), int(self._work.stats[1])

    def set_motor(self, joint_index: int, *, effort=None, velocity=None, position=None,
                  time_constant_s=None, reference_rates=None, refresh=True,
                  coordinate=0) -> None:
        """
        Set (or, with no target, clear) joint ``joint_index``'s motor; held until changed.

        A planar joint has one motor a coordinate (``coordinate`` 0, 1, 2 or ``'x'``, ``'y'``,
        ``'theta'``: the in-plane offsets along ``axis2_b`` and ``axis_b × axis2_b``, m, N,
        and the angle about ``axis_b``, rad, N m), a universal joint two (0, 1 or
        ``'theta1'``, ``'theta2'``: its angles about ``axis_b`` and about its child's
        ``axis2_b``, rad, N m, each in ``(-π, π]``), a spherical joint three (0, 1, 2 or
        ``'rx'``, ``'ry'``, ``'rz'``: the rotation vector of its turn on the parent's axes,
        rad, its relative angular velocity on them, rad/s, and a torque pair about them,
        N m; the three position targets make one target orientation ``q* = exp(φ*)``, and
        each coordinate's error is that of ``ψ = log(e q*⁻¹)``, which follows the response
        below exactly about a fixed axis, as from rest), each as a one-coordinate joint's,
        clipped by the joint's one ``effort_limit`` (N for x and y, N m for the angles);
        other joints have coordinate 0 only.

        One of: ``effort`` (N m or N along the joint coordinate, clipped by the joint's
        ``effort_limit``); ``velocity`` (rad/s or m/s: the joint rate is held at it, enforced
        with the other rows at the end of every step); ``position`` (rad or m) with
        ``time_constant_s`` ``1/ω``: the joint follows ``ë = -2ω ė - ω² e`` exactly (critically
        damped, no overshoot, no steady-state error under gravity), an acceleration row. A
        position or velocity motor needing more than ``effort_limit`` saturates: it pushes with
        ``±effort_limit`` (:meth:`motor_saturated` says so). A held limit pauses the motor.

        ``reference_rates=(q̇*, q̈*)`` makes a position target move: ``q*(t) = q* + q̇* s +
        q̈* s²/2`` with ``s`` the time since now, and ``e = q - q*(t)`` follows the same exact
        response, so a joint that starts on a trajectory stays on it to the step's accuracy
        (a followed trajectory's feed-forward: set it again every step). ``refresh=False``
        leaves the dynamics of the new targets to the caller (:meth:`set_motors`).
        """
        self._project_initial()
        n_j = len(self._joints)
        if isinstance(joint_index, bool) or not isinstance(joint_index, (int, np.integer)) \
                or not 0 <= joint_index < n_j:
            raise ConfigError(f'joint_index: {joint_index!r} is not a joint index (0 to '
                              f'{n_j - 1})')
        joint = self._joints[joint_index]
        who = f'joint {joint.name!r}'
        given = [(name, value) for name, value in (('effort', effort), ('velocity', velocity),
                                                   ('position', position)) if value is not None]
        if given and joint.kind not in MOTOR_COORDINATES:
            raise ConfigError(f'{who}: a {joint.kind} joint takes no motor (only '
                              f'{", ".join(MOTOR_COORDINATES)})')
        names = MOTOR_COORDINATES.get(joint.kind, ('',))
        k = names.index(coordinate) if isinstance(coordinate, str) and coordinate \
            and coordinate in names else coordinate
        if isinstance(k, bool) or not isinstance(k, (int, np.integer)) \
                or not 0 <= k < len(names):
            raise ConfigError(f'{who}.coordinate: {coordinate!r} is not a motor coordinate '
                              f'of a {joint.kind} joint (' + (
                                  ', '.join(f'{i} or {n!r}' for i, n in enumerate(names))
                                  if len(names) > 1 else '0 only') + ')')
        if len(names) > 1:
            who = f'{who}/{names[k]}'
        if given and joint.mimic is not None:
            raise ConfigError(f'{who}: a mimic joint (of {joint.mimic!r}) takes no motor; '
                              f'command {joint.mimic!r}')
        if len(given) > 1:
            raise ConfigError(f'{who}: give one of effort, velocity, position, not '
                              f'{" and ".join(name for name, _ in given)}')
        position_unit, velocity_unit, effort_unit = coordinate_units(joint, k)
        units = {'effort': effort_unit, 'velocity': velocity_unit, 'position': position_unit}
        row = self._work.motor[self._slots[joint_index][k]]
        mode, value = (given[0] if given else ('off', 0.0))
        if given:
            value = finite_scalar(value, f'{who}.{mode}', units[mode], error=ConfigError)
        if mode == 'position':
            if time_constant_s is None:
                raise ConfigError(f'{who}.time_constant_s: None; a position target needs a '
                                  'time constant in s > 0')
            tau = finite_scalar(time_constant_s, f'{who}.time_constant_s', 's',
                                error=ConfigError)
            if not tau > 0.0:
                raise ConfigError(f'{who}.time_constant_s: {tau!r} s must be > 0')
            check_position_target(joint, value, ConfigError, k)
            row[jk.M_OMEGA] = 1.0 / tau
        elif time_constant_s is not None:
            raise ConfigError(f'{who}.time_constant_s: {time_constant_s!r}; only a position '
                              'target takes a time constant')
        rates = (0.0, 0.0)
        if reference_rates is not None:
            if mode != 'position':
                raise ConfigError(f'{who}.reference_rates: {reference_rates!r}; only a '
                                  'position target takes reference rates')
            rates = _finite_floats(reference_rates, 2)
            if rates is None:   # not two finite floats: the one vector rule, its message
                rates = finite_vector(reference_rates, f'{who}.reference_rates',
                                      f'{units[mode]}/s and {units[mode]}/s²', 2,
                                      error=ConfigError)
        row[jk.M_MODE] = _MOTOR_CODES[mode]
        row[jk.M_EFFORT] = value if mode == 'effort' else 0.0
        row[jk.M_VELOCITY] = value if mode == 'velocity' else 0.0
        row[jk.M_POSITION] = value if mode == 'position' else 0.0
        row[jk.M_VREF], row[jk.M_AREF] = rates
        row[jk.M_TREF] = self._work.stats[jk.S_TSTAGE] = self._time_ns * 1e-9
        if refresh:
            self._refresh_dynamics()

    def _refresh_dynamics(self):
        """``ẋ``, ``λ``, wrenches and efforts at the state now (after a change of motors)."""
        args = (self._model, self._x, self._work)
        if self._refresh_kernel is None:
            self._refresh_kernel = compiled(jk.refresh_dynamics, args)
        self._refresh_kernel(*args)

    def set_motors(self, targets, refresh=True) -> None:
        """
        Set several motors at once, as :meth:`set_motor` each (one refresh of the dynamics).

        :param targets: ``(joint_index, keyword arguments of set_motor)`` pairs. A bad one is
            refused before any is set.
        :param refresh: False leaves the dynamics of the new targets to the caller (the
            contact step, which drives these arrays itself).
        """
        self._project_initial()
        saved = self._work.motor.copy()
        try:
            for joint_index, kwargs in targets:
                self.set_motor(joint_index, refresh=False, **kwargs)
        except ConfigError:
            self._work.motor[:] = saved
            raise
        if refresh:
            self._refresh_dynamics()

    def joint_efforts(self) -> np.ndarray:
        """
        Return (n_joints,): each motor's applied effort now, N m or N (0 without a motor).

        An effort motor: its clipped effort; a position or velocity motor: the force its row
        applies (the multiplier), or ``±effort_limit`` when saturated. A mimic joint: its
        mimic row's generalized force along its coordinate, ``λ`` (the leader takes ``-k λ``,
        not included in the leader's effort). A planar or universal joint: NaN, it has one
        effort a coordinate (:meth:`coordinate_efforts`).
        """
        out = self._work.motor[:len(self._joints), jk.M_APPLIED].copy()
        for j in np.flatnonzero(self._model.jint[:, jk.J_MIMROW] >= 0):
            out[j] = self._work.lam[self._model.jint[j, jk.J_MIMROW]]
        for j, slots in enumerate(self._slots):
            if len(slots) > 1:
                out[j] = math.nan   # planar, universal: no one effort (coordinate_efforts)
        return out

    def coordinate_efforts(self, joint_index: int) -> np.ndarray:
        """
        Return joint ``joint_index``'s applied motor effort per motor coordinate, now.

        A planar joint: ``(x N, y N, theta N m)``; a universal joint: ``(θ1, θ2)`` N m; each
        as :meth:`joint_efforts` gives a one-coordinate joint's (in which these joints read
        NaN); a one-coordinate joint: its one effort; others: empty.
        """
        joint = self._joints[joint_index]
        if joint.kind not in MOTOR_COORDINATES:
            return np.zeros(0)
        if len(self._slots[joint_index]) == 1:
            return self.joint_efforts()[joint_index:joint_index + 1]
        return self._work.motor[self._slots[joint_index], jk.M_APPLIED].copy()

    def coordinate_saturated(self, joint_index: int):
        """Return per motor coordinate of the joint True when that motor is saturated."""
        joint = self._joints[joint_index]
        if joint.kind not in MOTOR_COORDINATES:
            return []
        return [bool(self._work.motor[m, jk.M_SAT] != 0.0) for m in self._slots[joint_index]]

    def joint_friction_efforts(self) -> np.ndarray:
        """
        Return (n_joints,): each joint's Coulomb friction now, N m or N, on the child along q.

        A stuck joint: the force that holds it (its friction row's multiplier, within
        ``±friction``); a sliding one: ``-friction·sign(q̇)``; 0 without friction, or while a
        motor row or a limit holds the joint at rest. Damping is not included (``-damping q̇``).
        """
        return np.array([self._work.fric[j, jk.F_APPLIED] for j in range(len(self._joints))])

    def motor_saturated(self):
        """
        Return per joint True when its position or velocity motor is at its effort limit.

        A planar or universal joint: when any of its coordinates' is
        (:meth:`coordinate_saturated`).
        """
        return [any(self._work.motor[m, jk.M_SAT] != 0.0 for m in slots)
                for slots in self._slots]

    @property
    def last_stop(self):
        """
        Return the last limit stop of the last :meth:`step` call, or None if there was none.

        ``(joint index, time ns (float: inside a step), speed removed rad/s or m/s)``; the
        speed is the joint rate just before the stop's impulse (it is zero after); a cone
        limit's is the rate of the angle off the axis, ``ω_rel · n`` (positive).
        """
        stats = self._work.stats
        if stats[jk.S_STOPS] == 0:
            return None
        return (int(stats[jk.S_STOP_JOINT]), self._t_call + stats[jk.S_STOP_TIME] * 1e9,
                float(stats[jk.S_STOP_SPEED]))

    @property
    def clamped_steps(self) -> int:
        """
        Return how many steps of the last :meth:`step` call ran out of event passes.

        A step locates each limit stop and friction stop inside it, one sub-step each, at
        most ``2 n_joints + 2 + 2 n_friction`` of them; a step with more (limits stopped and
        released in turn, as a joint driven into a bound that gravity pulls it off) takes its
        rest in one sub-step whose crossings stop at its end (no joint beyond its bound, the
        time still whole). 0 in an ordinary run.
        """
        return int(self._work.stats[jk.S_CLAMPED])

    @property
    def split_steps(self):
        """
        Return ``(steps split, most sub-steps of one)`` of the last :meth:`step` call.

        A step whose start turns a body or a joint by more than
        :data:`~rbd_ros.core.joints.kernels.SUBSTEP_ROTATION` is taken in equal sub-steps
        (see ``timestep_ns``); ``(0, 1)`` when none was.
        """
        stats = self._work.stats
        return int(stats[jk.S_SPLIT]), int(stats[jk.S_SUBSTEPS])

    @property
    def split_steps_total(self) -> int:
        """Return how many steps since construction were taken in sub-steps."""
        return self._split_total

    @property
    def held_limits(self):
        """Return per joint +1 (held at upper, or a cone limit held), -1 (at lower) or 0."""
        return [int(self._work.lim_state[j]) for j in range(len(self._joints))]

    @property
    def states(self):
        """Return a tuple of :class:`BodyState`, one per body, at :attr:`time_ns`."""
        x = self._x
        return tuple(BodyState(x[b, 0:3], x[b, 3:7], x[b, 7:10], x[b, 10:13], self._time_ns)
                     for b in range(x.shape[0]))

    def _pose(self, b):
        if b is None:
            return None, None
        return self._x[b, 0:3], self._x[b, 3:7]

    def _poses(self, joint):
        pp, qp = self._pose(joint.parent)
        pc, qc = self._pose(joint.child)
        return pp, qp, pc, qc

    def _twist_w(self, b):
        if b is None:
            return None, None
        rot = quat_to_matrix(self._x[b, 3:7])
        return self._x[b, 7:10], rot @ self._x[b, 10:13]

    def joint_positions(self):
        """Return per joint the coordinates of :func:`joint_position` (continuous: unwrapped)."""
        out = []
        for j, joint in enumerate(self._joints):
            q = joint_position(joint, *self._poses(joint))
            if joint.kind == 'continuous' and self._projected:
                q = np.array([self._work.angle[j]])
            out.append(q)
        return out

    def joint_velocities(self):
        """Return per joint the rates of :func:`joint_velocity` (rad/s, m/s)."""
        out = []
        for joint in self._joints:
            pp, qp, pc, qc = self._poses(joint)
            vp, wp = self._twist_w(joint.parent)
            vc, wc = self._twist_w(joint.child)
            out.append(joint_velocity(joint, pp, qp, vp, wp, pc, qc, vc, wc))
        return out

    def state_rows(self):
        """
        Return every body's packed state now, a list of lists of 13 plain floats.

        ``(position_w, q_wb, v_w, ω_b)`` per body, the same bits as :attr:`states` without
        building a :class:`BodyState` per body (what a per-sample readout wants).
        """
        return self._x.tolist()

    def joint_coordinates(self, indices, rows=None, coordinates=None):
        """
        Return ``(positions, rates)`` of the joints ``indices``, plain floats.

        Revolute, continuous and prismatic joints (rad or m, rad/s or m/s), and with
        ``coordinates`` (one per index: None for those, a planar joint's 0, 1, 2 for x, y,
        theta, a universal joint's 0, 1 for θ1, θ2) planar and universal joints' coordinates:
        the values of :meth:`joint_positions` and :meth:`joint_velocities` to round-off,
        computed in plain scalar arithmetic (:mod:`rbd_ros.core.joints.readout`), a few µs a
        joint and the same bits on every machine. A continuous joint's position is its running
        angle, as there.

        :param rows: :meth:`state_rows` if the caller has them already (None: taken now).
        :raises ValueError: a joint of another kind, or a coordinate it does not have.
        """
        rows = self._x.tolist() if rows is None else rows
        read = self._readout.read
        angle = self._work.angle
        positions, rates = [], []
        for n, j in enumerate(indices):
            q, qd = read(rows, j, None if coordinates is None else coordinates[n])
            if self._projected and self._joints[j].kind == 'continuous':
                q = float(angle[j])
            positions.append(q)
            rates.append(qd)
        return positions, rates

    def constraint_wrenches_w(self):
        """
        Return per joint its rows' wrench on the child body: 6 plain floats, world frame.

        Force (N) then torque (N m) about the child's centre of mass, both world frame: the
        multipliers of the last step (zeros before the first), what :meth:`joint_wrenches`
        turns into the joint frame. A loop's redundant rows carry zero (see there).
        """
        return self._work.wrench[:len(self._joints)].tolist()

    def joint_wrenches(self) -> np.ndarray:
        """
        Return (n_joints, 6): force (N) then torque (N m) the parent exerts on the child.

        The multipliers of the current (end-of-step) state: the torque is about the child's
        anchor, both in the child's joint frame (axes ``w_1, w_2, w_3``, ``w_3`` the joint
        axis, see :data:`ROWS`). Redundant rows of a loop (dense solver) carry zero, so a
        loop's split of an internal force among its joints is one of many valid ones.
        """
        out = np.zeros((len(self._joints), 6))
        for j, joint in enumerate(self._joints):
            c = joint.child
            rot = quat_to_matrix(self._x[c, 3:7])
            basis_w = rot @ self._model.jprm[j, jk.J_BASIS_C:jk.J_BASIS_C + 9].reshape(3, 3).T
            force = self._work.wrench[j, 0:3]
            r_c = rot @ joint.origin_child_b
            torque = self._work.wrench[j, 3:6] - np.cross(r_c, force)
            out[j, 0:3] = basis_w.T @ force
            out[j, 3:6] = basis_w.T @ torque
        return out

    def joint_error(self):
        """
        Return ``(max anchor distance m, max axis angle rad)`` over all joints now.

        None before the deferred initial projection (``defer_projection``).
        """
        if not self._projected:
            return None
        if self._rows_kernel is None:
            self._rows_kernel = compiled(jk.joint_rows, (self._model, self._x, self._work, False))
        return joint_error(self._model, self._work, self._x, self._rows_kernel)

    @property
    def motor_slots(self):
        """
        Return per joint its motor slots (rows of ``work.motor``), one a motor coordinate.

        Slot ``j`` is joint ``j``'s (a planar joint's x, a universal joint's θ1); a planar
        joint's y and theta and a universal joint's θ2 are slots after the joints.
        """
        return tuple(tuple(slots) for slots in self._slots)

    def kernel_arrays(self):
        """
        Return ``(model, work)``: the joints' arrays of :mod:`rbd_ros.core.joints.kernels`.

        For a step that drives the joint kernels itself (the contact step's joint visits,
        :mod:`rbd_ros.core.contact.joints`); this simulator's own state is then not stepped.
        """
        return self._model, self._work

    def energy(self) -> float:
        """Return kinetic plus gravitational potential energy, J (zero potential at the origin)."""
        return float(sum(s.kinetic_energy(m) + s.potential_energy(m)
                         for m, s in zip(self._models, self.states)))

    def momentum(self):
        """Return ``(P, L)``: linear (kg m/s), angular about the origin (kg m²/s), world."""
        lin, ang = np.zeros(3), np.zeros(3)
        for m, s in zip(self._models, self.states):
            p = s.linear_momentum_w(m)
            lin += p
            ang += np.cross(s.position_w, p) + s.angular_momentum_w(m)
        return lin, ang
