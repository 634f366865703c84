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
A world of bodies with collision shapes and a static world, stepped with contact.

:class:`WorldSimulator` is a :class:`~rbd_ros.core.simulator.BatchSimulator` (same state
layout, loads and accessors) whose step is the contact step of
:mod:`rbd_ros.core.contact.step`.  It is built once from frozen values
(:class:`WorldBody`, :class:`~rbd_ros.core.contact.world.StaticWorld`), which are checked
then: materials, shapes, bodies starting inside each other or inside the static world, and
whether the integrator can take contact.  Bodies may be joined by
:class:`~rbd_ros.core.joints.model.Joint` values (``joints=``): the step then gives the joints
their impulses where Weinstein, Teran and Fedkiw 2006 put them (see
:mod:`rbd_ros.core.contact.joints`).
"""

from dataclasses import dataclass, field
import math
from typing import Optional, Sequence

import numpy as np

from rbd_ros.core import jitcache, layout
from rbd_ros.core.contact import joints as cj
from rbd_ros.core.contact import kernels as ck
from rbd_ros.core.contact import limits as cl
from rbd_ros.core.contact import motors as cm
from rbd_ros.core.contact import rows as cs
from rbd_ros.core.contact.parallel import ParallelStep
from rbd_ros.core.contact.shapes import CollisionShape
from rbd_ros.core.contact.step import world_step
from rbd_ros.core.contact.world import (check_overlaps, DEFAULT_OVERLAP_TOLERANCE_M, Material,
                                        StaticWorld)
from rbd_ros.core.errors import (ConfigError, ConvergenceError, finite_vector, ModelError,
                                 NonFiniteError, whole_number)
from rbd_ros.core.integrators import DEFAULT_INTEGRATOR, integrator_info
from rbd_ros.core.joints import kernels as jk
from rbd_ros.core.joints import simulator as joints_simulator
from rbd_ros.core.joints.model import Joint, MOTOR_COORDINATES
from rbd_ros.core.model import BodyModel
from rbd_ros.core.rotations import quat_to_matrix
from rbd_ros.core.simulator import BatchSimulator, usable_cores
from rbd_ros.core.state import BodyState

__all__ = ['CONTACT_INTEGRATORS', 'Contacts', 'WorldBody', 'WorldSimulator']

#: Integrators that take contact, and how each splits into velocity and position updates.
CONTACT_INTEGRATORS = {
    'midpoint_cayley': 'kick–drift–kick: contact after each half kick (second order)',
    'symplectic_euler_matrix': 'velocity update, contact, then positions (first order)',
    'symplectic_euler_axis_angle': 'velocity update, contact, then positions (first order)',
    'symplectic_euler_quat_exp': 'velocity update, contact, then positions (first order)',
    'symplectic_euler_quat_linear': 'velocity update, contact, then positions (first order)',
}


@dataclass(frozen=True, eq=False)
class WorldBody:
    """
    One body of a world: its name, mass model, collision shape and material.

    :param name: an identifier, used in error messages (``bodies.<name>.<field>``).
    :param model: its :class:`BodyModel` (mass, inertia, gravity, damping).
    :param shape: its :class:`CollisionShape` (not a plane).
    :param material: its :class:`Material`.
    """

    name: str
    model: BodyModel
    shape: CollisionShape
    material: Material = field(default_factory=Material)

    def __post_init__(self):
        where = f'bodies.{self.name}.'
        if not isinstance(self.model, BodyModel):
            raise ModelError(f'{where}model: a {type(self.model).__name__} is not a BodyModel')
        if not isinstance(self.shape, CollisionShape):
            raise ModelError(
                f'{where}shape: a {type(self.shape).__name__} is not a CollisionShape')
        if self.shape.kind == ck.KIND_PLANE:
            raise ModelError(f'{where}shape: a plane is static; a body needs a solid shape')
        if not isinstance(self.material, Material):
            raise ModelError(f'{where}material: {self.material!r} is not a Material')


@dataclass(frozen=True)
class Contacts:
    """
    The contact points of one step, one row each (every stage of the step).

    :ivar body_a: (C,) int index of body A.
    :ivar body_b: (C,) int index of body B, or ``-1 - s`` for static object ``s`` (the ground
        first, then the obstacles, as :meth:`StaticWorld.objects`).
    :ivar point_w: (C, 3) world contact point, m.
    :ivar normal_w: (C, 3) unit normal; the impulse on A is along it.
    :ivar impulse_w: (C, 3) impulse on A (N·s): ``λ n`` plus the point's share of its patch
        friction (B gets the opposite).
    :ivar stage: (C,) int: 0 collisions, 1 first contact stage, 2 second (kick–drift–kick).
    """

    body_a: np.ndarray
    body_b: np.ndarray
    point_w: np.ndarray
    normal_w: np.ndarray
    impulse_w: np.ndarray
    stage: np.ndarray

    def __len__(self):
        return int(self.body_a.shape[0])


def _capsule_axis(radius, half_length, spacing):
    count = max(2, math.ceil(2.0 * half_length / spacing) + 1)
    return np.column_stack([np.zeros(count), np.zeros(count),
                            np.linspace(-half_length, half_length, count)])


def _contact_points(shape):
    """Return ``(points, plane_points, radius)``: what a shape tests against others and planes."""
    if shape.kind == ck.KIND_SPHERE:
        centre = np.zeros((1, 3))
        return centre, centre, float(shape.params[0])
    if shape.kind == ck.KIND_CAPSULE:
        axis = _capsule_axis(shape.params[0], shape.params[1], shape.spacing_m)
        return axis, axis, float(shape.params[0])
    points = shape.points_b
    if shape.kind == ck.KIND_BOX:
        # A linear function on a box is lowest at a corner: the first 8 points.
        return points, points[:8], 0.0
    if shape.kind == ck.KIND_MESH:
        return points, shape.vertices_b, 0.0
    if shape.kind in (ck.KIND_CYLINDER, ck.KIND_ELLIPSOID):
        # Its lowest points against a plane are in closed form (points._plane_points).
        return points, points[:0], 0.0
    return points, points, 0.0


def _kd_order(points, index):
    """
    Return ``index`` reordered so that every run of ``cs.CHUNK_POINTS`` is a compact cell.

    Recursive halving along the widest extent (a k-d tree whose leaves hold
    ``cs.CHUNK_POINTS`` points, but the last); ties keep their order (a stable sort).
    """
    if len(index) <= cs.CHUNK_POINTS:
        return index
    sub = points[index]
    axis = int(np.argmax(sub.max(axis=0) - sub.min(axis=0)))
    index = index[np.argsort(sub[:, axis], kind='stable')]
    half = cs.CHUNK_POINTS * math.ceil(len(index) / (2 * cs.CHUNK_POINTS))
    return np.concatenate([_kd_order(points, index[:half]), _kd_order(points, index[half:])])


def _chunked(points):
    """
    Group ``points`` into compact cells of at most ``cs.CHUNK_POINTS``; return their balls.

    Return ``((cells, 4) centre and radius of each cell, (points,) the cell of each point)``,
    cells as the leaves of :func:`_kd_order`.  The points keep their order (it decides ties
    when a patch's points are chosen).  The narrow phase skips a cell when φ at its centre
    says no point of it can be within reach (:func:`rbd_ros.core.contact.points._one_way`).
    """
    order = _kd_order(points, np.arange(len(points)))
    cell_of = np.empty(len(points), dtype=np.int64)
    balls = []
    for i in range(0, len(points), cs.CHUNK_POINTS):
        run = order[i:i + cs.CHUNK_POINTS]
        cell_of[run] = len(balls)
        centre = points[run].mean(axis=0)
        balls.append([*centre, np.sqrt(((points[run] - centre) ** 2).sum(axis=1)).max()])
    return np.array(balls, dtype=np.float64).reshape(-1, 4), cell_of


def _shape_table(shapes, materials, skip=np.zeros(0, dtype=np.int64)):
    """
    Pack shapes and materials into the tuple of arrays the compiled stages read.

    ``skip``: the sorted keys ``a N + b`` (``a < b``) of the body pairs that never collide.
    """
    kinds = np.array([s.kind for s in shapes], dtype=np.int64)
    sparams = np.ascontiguousarray(np.stack([s.params for s in shapes]))
    pts, ppts, radius, balls, cells = [], [], [], [], []
    for shape in shapes:
        if shape.kind == ck.KIND_PLANE:
            pts.append(np.zeros((0, 3)))
            ppts.append(np.zeros((0, 3)))
            balls.append(np.zeros((0, 4)))
            cells.append(np.zeros(0, dtype=np.int64))
            radius.append(0.0)
            continue
        p, pp, r = _contact_points(shape)
        ball, cell = _chunked(np.asarray(p, dtype=np.float64))
        pts.append(p)
        ppts.append(pp)
        balls.append(ball)
        cells.append(cell)
        radius.append(r)
    pt_off = np.concatenate([[0], np.cumsum([len(p) for p in pts])]).astype(np.int64)
    ch_off = np.concatenate([[0], np.cumsum([len(b) for b in balls])]).astype(np.int64)
    ppt_off = np.concatenate([[0], np.cumsum([len(p) for p in ppts])]).astype(np.int64)
    grids = [np.ascontiguousarray(s.grid, dtype=np.float64) for s in shapes]
    grid_off = np.concatenate([[0], np.cumsum([g.size for g in grids])[:-1]]).astype(np.int64)
    grid_dim = np.array([g.shape for g in grids], dtype=np.int64)
    bound = np.array([s.bounding_radius_m for s in shapes], dtype=np.float64)
    return cs.Shapes(
        kinds=kinds, sparams=sparams, pts=np.ascontiguousarray(np.concatenate(pts)),
        pt_off=pt_off, ppts=np.ascontiguousarray(np.concatenate(ppts)), ppt_off=ppt_off,
        pt_radius=np.array(radius, dtype=np.float64), bound_r=bound,
        grid_data=np.ascontiguousarray(np.concatenate([g.ravel() for g in grids])),
        grid_off=grid_off, grid_dim=grid_dim,
        mu=np.array([m.friction for m in materials], dtype=np.float64),
        eps=np.array([m.restitution for m in materials], dtype=np.float64),
        balls=np.ascontiguousarray(np.concatenate(balls)), ball_off=ch_off,
        cell_of=np.concatenate(cells), skip=skip)


def _static_table(objects):
    """Pack the static objects' kinds, parameters, poses and world bounding boxes."""
    m = len(objects)
    kinds = np.array([o.shape.kind for o in objects], dtype=np.int64)
    params = np.zeros((m, ck.N_SHAPE_PARAM))
    rot = np.zeros((m, 3, 3))
    pos = np.zeros((m, 3))
    lo = np.full((m, 3), -np.inf)
    hi = np.full((m, 3), np.inf)
    for s, obj in enumerate(objects):
        params[s] = obj.shape.params
        rot[s] = quat_to_matrix(obj.orientation_wb)
        pos[s] = obj.position_w
        if obj.shape.kind != ck.KIND_PLANE:
            corners = np.array([[x, y, z] for x in (obj.shape.aabb_min_b[0],
                                                    obj.shape.aabb_max_b[0])
                                for y in (obj.shape.aabb_min_b[1], obj.shape.aabb_max_b[1])
                                for z in (obj.shape.aabb_min_b[2], obj.shape.aabb_max_b[2])])
            world = corners @ rot[s].T + pos[s]
            lo[s] = world.min(axis=0)
            hi[s] = world.max(axis=0)
    return cs.Statics(kinds, params, rot, pos, lo, hi)


class WorldSimulator(BatchSimulator):
    """
    Bodies with collision shapes in a static world, stepped with frictional contact.

    :param bodies: the :class:`WorldBody` values, names unique.
    :param states: one :class:`BodyState` per body.
    :param static: a :class:`StaticWorld` (ground plane and obstacles), or None.
    :param integrator: one of :data:`CONTACT_INTEGRATORS`.
    :param timestep_ns: the fixed step ``h``, integer nanoseconds > 0.
    :param overlap_tolerance_m: how deep bodies may start inside each other or the static world.
    :param joints: :class:`~rbd_ros.core.joints.model.Joint` values between the bodies (by
        index, ``parent=None`` the world), as :class:`~rbd_ros.core.joints.ArticulatedSimulator`
        takes them and checks them; the states are projected onto them first, as there
        (with ``defer_projection``, at the first step).
        Motors as there (:meth:`set_motor`); limits (``lower``, ``upper``, and a spherical
        joint's ``cone_rad``, the angle of its axis off the parent's) as speculative
        inelastic stops (:mod:`rbd_ros.core.contact.limits`: a cone stop takes out the swing
        into the rim alone); ``damping`` as its exact flow
        over each velocity update and ``friction`` as a velocity target 0 bounded by the
        friction (:mod:`rbd_ros.core.contact.motors`: a joint sticks exactly while the effort
        holding it is within its friction, else slides against it); a mimic as one more row
        of the visits. A jointed body collides as any
        other; two bodies of one joint collide with each other too (give them shapes that
        clear at the joint, or list them in ``no_collision``).
    :param no_collision: body index pairs ``(a, b)`` that never collide with each other
        (neither checked for overlap at the start nor paired by the broad phase): a robot's
        adjacent links, its links without self-collision.
    :param no_static_collision: ``(body index, static object name)`` pairs that never collide
        likewise: a robot's moving link and the link fixed to the world it is jointed to.
    :param defer_projection: True: the projection onto the joints waits for the first
        :meth:`step`, motor command or :meth:`reset`, so building the world compiles and runs no
        joint kernel (a cold node publishes the states as given at t = 0 while its kernels
        compile). Until then :meth:`joint_error` is None and the bodies are where ``states``
        put them; the start's overlap check is taken on those states and again on the projected
        ones, and its errors, and the projection's, come from that first call. Either way the
        steps give the same bits.
    :param threads: threads the step may use, >= 1 (default: the CPUs this process may run
        on). With two or more, groups of bodies out of each other's reach are stepped on
        threads, checked, and the step is the serial one's to the bit whatever the count
        (:mod:`rbd_ros.core.contact.parallel`); a world with joints steps on one.
    :raises ModelError: a bad body, or bodies starting inside each other or the static world.
    :raises ConfigError: an integrator that cannot take contact; a bad or unsupported joint.
    :raises ConvergenceError: states that could not be projected onto the joints.
    """

    def __init__(self, bodies: Sequence[WorldBody], states: Sequence[BodyState],
                 static: Optional[StaticWorld] = None, *,
                 integrator: str = DEFAULT_INTEGRATOR, timestep_ns: int = 1_000_000,
                 overlap_tolerance_m: float = DEFAULT_OVERLAP_TOLERANCE_M,
                 joints: Sequence[Joint] = (), no_collision=(), no_static_collision=(),
                 defer_projection: bool = False, threads: Optional[int] = None):
        jitcache.configured()  # the kernel cache, before a first compile
        threads = usable_cores() if threads is None else whole_number(
            threads, 'threads', 'threads', positive=True, error=ConfigError)
        bodies = tuple(bodies)
        states = tuple(states)
        info = integrator_info(integrator)
        if info.name not in CONTACT_INTEGRATORS:
            raise ConfigError(
                f'integrator: {info.name!r} cannot take contact (its stages re-evaluate the '
                'forces inside the step, so there is no velocity update to put contact '
                f'impulses after); use one of {sorted(CONTACT_INTEGRATORS)}')
        if static is None:
            static = StaticWorld()
        if not isinstance(static, StaticWorld):
            raise ModelError(f'static: a {type(static).__name__} is not a StaticWorld')
        names = set()
        for body in bodies:
            if not isinstance(body, WorldBody):
                raise ModelError(f'bodies: a {type(body).__name__} is not a WorldBody')
            if body.name in names:
                raise ModelError(f'bodies.{body.name}: the name is used twice')
            names.add(body.name)
        if len(states) != len(bodies):
            raise ConfigError(f'states: {len(states)} states for {len(bodies)} bodies')
        self._joints = tuple(joints)
        self._joint_stage = None
        self._deferred = None  # with a deferred projection: the start's overlap check, again
        if self._joints:
            states = self._project_onto_joints(bodies, states, timestep_ns, defer_projection)
        n = len(bodies)
        skip = set()
        for a, b in no_collision:
            if not (0 <= a < n and 0 <= b < n and a != b):
                raise ConfigError(f'no_collision: pair ({a}, {b}) must be two different body '
                                  f'indices in [0, {n - 1}]')
            skip.add((min(a, b), max(a, b)))
        labelled = static.objects()
        static_index = {o.name: s for s, (_, o) in enumerate(labelled)}
        static_skip = set()
        for a, name in no_static_collision:
            if not (0 <= a < n and name in static_index):
                raise ConfigError(f'no_static_collision: pair ({a}, {name!r}) must be a body '
                                  f'index in [0, {n - 1}] and the name of a static object')
            static_skip.add((a, static_index[name]))
        pairs = skip | {(a, labelled[s][0]) for a, s in static_skip}
        check_overlaps([(b.name, b.shape, s.position_w, s.orientation_wb)
                        for b, s in zip(bodies, states)], static, overlap_tolerance_m, pairs)
        if defer_projection and self._joints:
            self._deferred = (overlap_tolerance_m, pairs)
        super().__init__([b.model for b in bodies], states, integrator=integrator,
                         timestep_ns=timestep_ns, threads=1)
        self._bodies = bodies
        self._static = static
        objects = [o for _, o in labelled]
        m = n + len(objects)  # the broad phase's pair key: a m + b, static s as b = n + s
        keys = [a * m + b for a, b in skip] + [a * m + n + s for a, s in static_skip]
        self._geo = _shape_table([b.shape for b in bodies] + [o.shape for o in objects],
                                 [b.material for b in bodies] + [o.material for o in objects],
                                 np.array(sorted(keys), dtype=np.int64))
        self._statics = _static_table(objects)
        self._wrench = np.zeros((n, 6))
        self._ws = cs.Work(
            vel=np.zeros((n, 6)), inv_mass=np.zeros(n), inv_inertia_w=np.zeros((n, 3, 3)),
            rot=np.zeros((n, 3, 3)), pos_c=np.zeros((n, 3)), rot_c=np.zeros((n, 3, 3)),
            touched=np.zeros(n, dtype=np.bool_), responses=np.full((n, cs.N_RESPONSE), -1.0),
            warm=np.zeros((3, n, cs.W_SLOTS, cs.W_FIELDS)),
            warm_n=np.zeros((3, n), dtype=np.int64), stats=np.zeros((3, cs.N_SOLVE_STATS)),
            span=np.zeros((n, 6)))
        self._contacts = np.zeros((0, cs.N_CONTACT))
        self._world_threads = threads
        self._parallel = (ParallelStep(self, threads) if threads > 1 and not self._joints
                          else None)

    def _project_onto_joints(self, bodies, states, timestep_ns, defer):
        """
        Check the joints, build their stage; return the states projected onto them.

        ``defer``: return the states as given; :meth:`_project_deferred` projects them later.
        """
        for i, joint in enumerate(self._joints):
            if not isinstance(joint, Joint):
                raise ConfigError(f'joints[{i}]: {type(joint).__name__} is not a Joint')
        articulated = joints_simulator.ArticulatedSimulator(
            [b.model for b in bodies], states, self._joints, timestep_ns=timestep_ns,
            defer_projection=defer)
        model, work = articulated.kernel_arrays()
        n = len(bodies)
        jointed = np.zeros(n, dtype=np.bool_)
        for joint in self._joints:
            jointed[joint.child] = True
            if joint.parent is not None:
                jointed[joint.parent] = True
        self._articulated = articulated   # checks and sets the motors' commands
        self._joint_stage = cj.JointStage(model, work, np.zeros((n, 13)), np.zeros((n, 13)),
                                          jointed, np.zeros(cj.J_STATS),
                                          np.zeros((work.motor.shape[0], cm.D_SIZE)),
                                          np.zeros(model.rows.shape[0], dtype=np.int64))
        return articulated.states

    def _project_deferred(self):
        """
        Take a deferred projection onto the joints (``defer_projection``) now; else nothing.

        The bodies then stand where the projection puts them and the world is as the
        constructor without deferral leaves it (overlaps checked on the projected states,
        :meth:`reset` going back to them), so every step after gives the same bits.
        """
        if self._deferred is None:
            return
        tolerance_m, pairs = self._deferred
        articulated = self._articulated
        articulated.project_initial()
        states = articulated.states
        check_overlaps([(b.name, b.shape, s.position_w, s.orientation_wb)
                        for b, s in zip(self._bodies, states)], self._static, tolerance_m,
                       pairs)
        self._deferred = None
        for i, state in enumerate(states):
            self._x[:, i] = layout.pack_state(state)
        self._initial_states = tuple(states)

    @property
    def threads(self) -> int:
        """Return the threads the step may use (``threads``; a world with joints uses one)."""
        return self._world_threads

    @property
    def joints(self):
        """Return the joints, a tuple (empty without)."""
        return self._joints

    def joint_error(self):
        """
        Return ``(max anchor distance m, max axis angle rad)`` over all joints now, or None.

        None for a world without joints.  The step keeps both at most
        :data:`~rbd_ros.core.joints.simulator.PROJECTION_TOL` (see :meth:`step`).
        """
        if self._joint_stage is None or self._deferred is not None:
            return None
        stage = self._joint_stage
        x = np.ascontiguousarray(self._x.T)
        return joints_simulator.joint_error(stage.model, stage.work, x)

    def _articulated_or_refuse(self):
        if self._joint_stage is None:
            raise ConfigError('joint_index: a world without joints has no motors')
        return self._articulated

    def set_motor(self, joint_index: int, **targets) -> None:
        """
        Set (or, with no target, clear) joint ``joint_index``'s motor; held until changed.

        The arguments, their checks and their meaning are those of
        :meth:`rbd_ros.core.joints.ArticulatedSimulator.set_motor` (``effort``, ``velocity``,
        or ``position`` with ``time_constant_s`` and optional ``reference_rates``); the
        contact step drives them by impulses (:mod:`rbd_ros.core.contact.motors`): an effort
        as a force through each velocity update, a velocity target as a velocity row (the
        coordinate growing by ``v* h`` a step), a position target's exact critically damped
        response as the coordinate the joint lands on at every step's end. A position or
        velocity motor that would need more than the joint's ``effort_limit`` over a step
        saturates (the step is taken again with it pushing ``±effort_limit``).

        :raises ConfigError: a bad joint index or target (one line naming the joint, value
            and unit).
        """
        self.set_motors([(joint_index, targets)])

    def set_motors(self, targets) -> None:
        """Set several motors at once, as :meth:`set_motor` each; a bad one sets none."""
        articulated = self._articulated_or_refuse()
        targets = list(targets)
        self._project_deferred()
        articulated.set_motors(targets, refresh=False)
        drive, motor = self._joint_stage.drive, self._joint_stage.work.motor
        for joint_index, kwargs in targets:
            names = MOTOR_COORDINATES.get(self._joints[joint_index].kind, ('',))
            coordinate = kwargs.get('coordinate', 0)
            k = names.index(coordinate) if isinstance(coordinate, str) else int(coordinate)
            slot = articulated.motor_slots[joint_index][k]
            drive[slot, :] = 0.0   # its time from now, its rate from the state's
            motor[slot, jk.M_HOLD] = 0.0
            motor[slot, jk.M_SAT] = 0.0

    def joint_efforts(self) -> np.ndarray:
        """
        Return (n_joints,): each motor's effort over the last step, N m or N (0 without).

        An effort motor: its clipped effort; a position or velocity motor: its row's impulses
        over the step divided by ``h`` (the step's average force along the joint coordinate
        on the child), or ``±effort_limit`` when saturated. A planar, universal or spherical
        joint: NaN, it has one effort a coordinate (:meth:`coordinate_efforts`).
        """
        articulated = self._articulated_or_refuse()
        out = self._joint_stage.work.motor[:len(self._joints), jk.M_APPLIED].copy()
        for j, slots in enumerate(articulated.motor_slots):
            if len(slots) > 1:
                out[j] = math.nan
        return out

    def coordinate_efforts(self, joint_index: int) -> np.ndarray:
        """
        Return joint ``joint_index``'s motor effort over the last step per motor coordinate.

        A planar joint: ``(x N, y N, theta N m)``; a universal joint: ``(θ1, θ2)`` N m; a
        spherical joint ``(rx, ry, rz)`` N m (about the parent's axes); a one-coordinate
        joint: its one effort; others: empty. Each as :meth:`joint_efforts`
        gives a one-coordinate joint's.
        """
        articulated = self._articulated_or_refuse()
        if self._joints[joint_index].kind not in MOTOR_COORDINATES:
            return np.zeros(0)
        slots = list(articulated.motor_slots[joint_index])
        return self._joint_stage.work.motor[slots, jk.M_APPLIED].copy()

    def coordinate_saturated(self, joint_index: int):
        """Return per motor coordinate of the joint True when that motor is saturated."""
        return self._articulated_or_refuse().coordinate_saturated(joint_index)

    def running_angles(self):
        """
        Return per joint its running angle, rad, plain floats: a continuous joint's position.

        Not wrapped: the step keeps it at every step's end (``jk._unwrap``: the twist's change
        over one step taken as the nearest to zero mod 2π), so it counts whole turns at any
        rate below π rad a step, however many steps a call takes; a reset starts it again
        from the states' twist. 0 for the other kinds. Empty without joints.
        """
        if self._joint_stage is None:
            return []
        if self._deferred is not None:  # the states as given: a continuous joint's position
            return [float(q[0]) if joint.kind == 'continuous' else 0.0 for joint, q
                    in zip(self._joints, self._articulated.joint_positions())]
        return self._joint_stage.work.angle[:len(self._joints)].tolist()

    def joint_friction_efforts(self) -> np.ndarray:
        """
        Return (n_joints,): each joint's Coulomb friction over the last step, N m or N.

        On the child along q, as :meth:`rbd_ros.core.joints.ArticulatedSimulator.
        joint_friction_efforts`: a stuck joint's holding effort (its friction row's impulses
        over the step divided by ``h``, within ``±friction``); a slipping or driven one's
        ``-friction·sign(q̇)``; 0 without friction, or while a motor or a limit holds it at
        rest. Not in :meth:`joint_efforts` (the motors'), nor is the damping.
        """
        self._articulated_or_refuse()
        stage = self._joint_stage
        return np.where(stage.model.jint[:, jk.J_FRICROW] >= 0,
                        stage.work.fric[:len(self._joints), jk.F_APPLIED], 0.0)

    def motor_saturated(self):
        """Return per joint True when its position or velocity motor is at its effort limit."""
        return self._articulated_or_refuse().motor_saturated()

    @property
    def held_limits(self):
        """Return per joint +1 (held at upper at the last step's end), -1 (at lower) or 0."""
        return [] if self._joint_stage is None else self._articulated.held_limits

    @property
    def joint_stats(self):
        """
        Return the joints' figures of the last :meth:`step` call, or None without joints.

        ``(largest row error a pre-stabilization left at its drifted pose (m or rad), its
        most Newton iterations, the most joint visits of one contact stage, the largest
        violation of the contacts' normal conditions such a stage ended with (m/s))``.
        """
        if self._joint_stage is None:
            return None
        stats = self._joint_stage.stats
        return (float(stats[cj.J_ERR]), int(stats[cj.J_ITER]), int(stats[cj.J_LOOPS]),
                float(stats[cj.J_LEFT]))

    @property
    def bodies(self):
        """Return the :class:`WorldBody` values, in index order."""
        return self._bodies

    @property
    def time_ns(self) -> int:
        """Return the world's sim time, int ns (every body's)."""
        return int(self._t[0]) if self.size else 0

    @property
    def static(self) -> StaticWorld:
        """Return the static world."""
        return self._static

    def reset(self, states=None) -> None:
        """
        Put every body back to its initial state (or to ``states``); no contacts.

        With joints, ``states`` are projected onto them first, as the constructor does (and
        checked against the limits); the motors keep their commands and start their
        responses again from the new states.

        :raises ConfigError: a bad state, or one beyond a joint's limit.
        :raises ConvergenceError: states that could not be projected onto the joints.
        """
        stage = getattr(self, '_joint_stage', None)
        if stage is not None and hasattr(self, '_bodies'):   # not from the constructor
            self._project_deferred()  # the initial states it goes back to are the projected
            states = self._initial_states if states is None else tuple(states)
            if len(states) != self.size:
                raise ConfigError(f'states: {len(states)} states for {self.size} bodies')
            projected = joints_simulator.ArticulatedSimulator(
                [b.model for b in self._bodies], states, self._joints,
                timestep_ns=self._timestep_ns)
            stage.work.angle[:] = projected.kernel_arrays()[1].angle
            stage.drive[:] = 0.0
            stage.work.motor[:, jk.M_HOLD] = 0.0
            cl.free_all(stage)
            states = projected.states
        if getattr(self, '_parallel', None) is not None:
            self._parallel.settle()
        super().reset(states)
        if hasattr(self, '_wrench'):
            self._wrench[:] = 0.0
            self._ws.warm_n[:] = 0  # no warm start from before the reset
            self._ws.stats[:] = 0.0
            self._contacts = np.zeros((0, cs.N_CONTACT))

    def step(self, n: int = 1) -> None:
        """
        Advance the world ``n`` fixed steps.

        :raises NonFiniteError: if a step would leave a body non-finite; the whole world then
            stays at its last finite state.
        """
        joints = self._joint_stage
        if joints is not None:
            self._project_deferred()
            joints.stats[:] = 0.0
        if self._parallel is not None:
            done, contacts = self._parallel.step(n)
        else:
            done, contacts = world_step(self._x, self._params, self._loads, self._t,
                                        self._info.kernel_id, self._h, self._timestep_ns, n,
                                        tuple(self._geo), tuple(self._statics), self._wrench,
                                        tuple(self._ws), joints)  # plain tuples: see world_step
        self._step_count += done
        if contacts is not None:   # None: the parts hold them (ParallelStep.contacts)
            self._contacts = contacts
        if joints is not None and joints.stats[cj.J_FAIL] != 0.0:
            raise ConvergenceError(
                f'joints: the pre-stabilization did not reach {cj.PROJECTION_TOL} m or rad in '
                f'{cj.PROJECTION_MAX_ITER} iterations (error {joints.stats[cj.J_ERR]:.3g}) at '
                f't = {int(self._t[0])} ns; the world was left at the start of that step')
        if done != n:
            raise NonFiniteError(
                f'state: the step at t = {int(self._t[0])} ns would be non-finite (forces, '
                f'velocities or spin too large for h = {self._timestep_ns} ns with '
                f'{self.integrator}); the world was left at its last finite state')

    def solve_stats(self) -> dict:
        """
        Return the counters of the contact stages whose patches share bodies, per stage.

        ``{'stages', 'sweeps', 'cold', 'patches'}``, each a tuple of three (the collision
        stage, the first contact stage, the second: ``midpoint_cayley`` only), summed since
        the simulator was built or reset (see :data:`~rbd_ros.core.contact.rows.ST_STAGES`):
        coupled stages solved, Gauss–Seidel sweeps run, warm-started stages solved again from
        zero, their patches.
        """
        s = self._ws.stats if self._parallel is None else self._parallel.stats()
        return {name: tuple(float(v) for v in s[:, k]) for name, k in (
            ('stages', cs.ST_STAGES), ('sweeps', cs.ST_SWEEPS), ('cold', cs.ST_COLD),
            ('patches', cs.ST_PATCHES))}

    def set_gravity_w(self, gravity_w) -> None:
        """Set every body's gravitational acceleration (m/s², world) from the next step on."""
        gravity = finite_vector(gravity_w, 'gravity_w', 'm/s²', error=ModelError)
        self._params[layout.P_GRAVITY:layout.P_GRAVITY + 3, :] = gravity[:, None]

    @property
    def contacts(self) -> Contacts:
        """Return the contact points of the last step (copies)."""
        c = self._contacts if self._parallel is None else self._parallel.contacts()
        n = self.size
        b = c[:, cs.C_B].astype(np.int64)
        normal = c[:, cs.C_NORMAL:cs.C_NORMAL + 3].copy()
        impulse = c[:, cs.C_LAMBDA, None] * normal + c[:, cs.C_FRICTION:cs.C_FRICTION + 3]
        return Contacts(c[:, cs.C_A].astype(np.int64), np.where(b >= n, n - 1 - b, b),
                        c[:, cs.C_POINT:cs.C_POINT + 3].copy(), normal, impulse,
                        c[:, cs.C_PHASE].astype(np.int64))

    @property
    def contact_wrench_w(self) -> np.ndarray:
        """
        Return (N, 6): each body's net contact force (N) and torque (N·m) over the last step.

        Force and torque about the body's COM, world frame, averaged over the step (the total
        contact impulse / h): what a force-torque sensor at the COM would read.
        """
        return self._wrench.copy()
