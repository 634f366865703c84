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
The reference side of the contact benchmark: the issue-9 scenes in MuJoCo and PyBullet.

A scene (:class:`Scene`: bodies, one friction coefficient and one restitution for every pair,
gravity, time step) is built by a *world* class, one per engine, with a small interface:

* ``World(scene)``; ``world.step(n)``: ``n`` steps of ``scene.h_s``;
* ``world.state()``: ``(position_w, velocity_w, omega_w)``, arrays ``(N, 3)`` of the bodies'
  centres of mass (m), their velocities (m/s) and angular velocities (rad/s), world frame;
* ``world.set_gravity(gravity_w)`` (m/s^2) and ``world.set_velocity(i, velocity_w, omega_w)``;
* ``world.penetration_m()``: the deepest penetration of any contact now (m, >= 0);
* ``world.close()``; class attributes ``name`` and ``notes`` (what deviates from the scene).

Each measurement is a function ``case(world_cls, h_s, quick=False) -> dict`` of numbers (keys
carry the unit); :func:`measurements` binds it to one world class, giving
``{case_name: fn(h_s, quick)}``. Our simulator gets the same table by a world class of its own
(or by functions with the ``fn(h_s, quick)`` signature), see ``bench_contact.py``.

Scenes (g = 9.81 m/s^2; boxes 1 kg, side 0.2 m, spheres 1 kg, radius 0.1 m, as the table of
``shared/reference/contact-guendelman.md`` was measured; engine defaults except friction and
restitution):

* a slope of angle theta is the plane z = 0 with gravity tilted by theta about y (for one body
  on an infinite plane the same physics as a tilted plane; "down the slope" is +x). A body is
  first settled for :data:`SETTLE_S` under the normal part of gravity only, then the tangential
  part is switched on: "at rest on the slope" is a settled contact in every engine;
* the sliding stop also settles first, then sets v0 = 2 m/s along +x.

Pair rules. MuJoCo takes the larger friction of two geoms: every geom gets mu. Bullet multiplies
the two bodies' friction and restitution coefficients: every body (the plane too) gets
sqrt(mu) and sqrt(eps), so every pair has mu and eps. MuJoCo has no restitution coefficient:
for eps > 0 its world uses the solref trick (a contact spring of time constant 0.02 s, MuJoCo's
default, with the damping ratio zeta of a linear oscillator whose rebound is eps,
eps = exp(-pi zeta / sqrt(1 - zeta^2))); it is reported as such.
"""

import dataclasses
import importlib.util
import math
import statistics
import time

import numpy as np

G = 9.81
SETTLE_S = 0.5
BOX_SIDE_M = 0.2
SPHERE_RADIUS_M = 0.1
MASS_KG = 1.0


@dataclasses.dataclass(frozen=True)
class Body:
    """One dynamic body: ``shape`` 'box' (``size_m`` = side) or 'sphere' (radius), at rest."""

    shape: str
    size_m: float
    mass_kg: float
    position_w: tuple


@dataclasses.dataclass(frozen=True)
class Scene:
    """Bodies on the plane z = 0 (normal +z); ``mu`` and ``restitution`` hold for every pair."""

    h_s: float
    bodies: tuple
    mu: float
    restitution: float = 0.0
    gravity_w: tuple = (0.0, 0.0, -G)


def scalar_inertia(body):
    """Scalar moment of inertia of a cube or a solid sphere about its centre, kg m^2."""
    if body.shape == 'box':
        return body.mass_kg * body.size_m ** 2 / 6.0
    return 0.4 * body.mass_kg * body.size_m ** 2


def kinetic_energy(bodies, velocity_w, omega_w):
    """Total kinetic energy, J (cubes and spheres: isotropic inertia, so any frame of omega)."""
    mass = np.array([b.mass_kg for b in bodies])
    inertia = np.array([scalar_inertia(b) for b in bodies])
    return float(0.5 * (mass @ (velocity_w ** 2).sum(axis=1)
                        + inertia @ (omega_w ** 2).sum(axis=1)))


def installed(module):
    """Whether ``module`` can be imported (the engines are benchmark-only extras)."""
    return importlib.util.find_spec(module) is not None


def _rotate(quat_wxyz, vectors, inverse=False):
    """Rotate ``vectors`` (N, 3) by unit quaternions (N, 4) w-first: R v (or R^T v)."""
    w = quat_wxyz[:, :1]
    u = quat_wxyz[:, 1:] * (-1.0 if inverse else 1.0)
    t = 2.0 * np.cross(u, vectors)
    return vectors + w * t + np.cross(u, t)


def solref_damping_ratio(restitution):
    """Damping ratio of a linear oscillator whose rebound speed ratio is ``restitution``."""
    log_eps = math.log(restitution)
    # eps = 1 gives 0, which MuJoCo takes for a "mixed solref format" and replaces by its
    # default (critically damped, no rebound at all): the smallest positive ratio instead.
    return max(-log_eps / math.sqrt(math.pi ** 2 + log_eps ** 2), 1e-9)


class MujocoWorld:
    """MuJoCo (soft contact, its default Newton solver, pyramidal cone, Euler integrator)."""

    name = 'MuJoCo'
    notes = ('defaults (Euler, Newton solver, pyramidal cone, condim 3, solref 0.02 1); '
             'restitution by the solref trick')
    SOLREF_TIMECONST_S = 0.02

    def __init__(self, scene):
        import mujoco
        self._mj = mujoco
        self.scene = scene
        self.n = len(scene.bodies)
        mu = f'{scene.mu!r} 0.005 0.0001'
        solref = ''
        if scene.restitution > 0.0:
            solref = (f' solref="{self.SOLREF_TIMECONST_S!r} '
                      f'{solref_damping_ratio(scene.restitution)!r}"')
        geoms = []
        for b in scene.bodies:
            if b.shape == 'box':
                shape = f'type="box" size="{b.size_m / 2} {b.size_m / 2} {b.size_m / 2}"'
            else:
                shape = f'type="sphere" size="{b.size_m}"'
            x, y, z = b.position_w
            geoms.append(f'<body pos="{x!r} {y!r} {z!r}"><freejoint/><geom {shape} '
                         f'mass="{b.mass_kg!r}" friction="{mu}"{solref}/></body>')
        gx, gy, gz = scene.gravity_w
        # The arena must hold the contacts of every body (MuJoCo refuses 10 000 boxes with its
        # default size): 50 kB a body, measured ~40 kB for a box on the plane.
        memory_mb = 16 + self.n // 20
        xml = (f'<mujoco><size memory="{memory_mb}M"/><option timestep="{scene.h_s!r}" '
               f'gravity="{gx!r} {gy!r} {gz!r}"/><worldbody><geom type="plane" '
               f'size="0 0 1" friction="{mu}"{solref}/>{"".join(geoms)}</worldbody></mujoco>')
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        mujoco.mj_forward(self.model, self.data)

    def step(self, n):
        self._mj.mj_step(self.model, self.data, nstep=n)

    def _quat(self):
        return self.data.qpos.reshape(self.n, 7)[:, 3:]

    def state(self):
        qpos = self.data.qpos.reshape(self.n, 7)
        qvel = self.data.qvel.reshape(self.n, 6)
        # A free joint's linear velocity is in the world frame, its angular one in the body's.
        return qpos[:, :3].copy(), qvel[:, :3].copy(), _rotate(qpos[:, 3:], qvel[:, 3:])

    def set_gravity(self, gravity_w):
        self.model.opt.gravity[:] = gravity_w

    def set_velocity(self, i, velocity_w, omega_w):
        qvel = self.data.qvel.reshape(self.n, 6)
        qvel[i, :3] = velocity_w
        qvel[i, 3:] = _rotate(self._quat()[i:i + 1], np.array([omega_w], float), True)[0]

    def penetration_m(self):
        dist = self.data.contact.dist[:self.data.ncon]
        return float(max(0.0, -dist.min())) if len(dist) else 0.0

    def close(self):
        pass


class BulletWorld:
    """PyBullet (sequential impulses, 50 iterations), DIRECT mode (one thread), defaults."""

    name = 'PyBullet'
    notes = ('defaults (50 solver iterations, btMultiBody with its default damping 0.04, '
             'no sleeping); friction and restitution sqrt(value) per body, as Bullet multiplies')

    def __init__(self, scene, damping=None):
        import pybullet
        self._pb = p = pybullet
        self.scene = scene
        self.client = c = p.connect(p.DIRECT)
        p.setTimeStep(scene.h_s, physicsClientId=c)
        p.setGravity(*scene.gravity_w, physicsClientId=c)
        plane = p.createMultiBody(0.0, p.createCollisionShape(p.GEOM_PLANE, physicsClientId=c),
                                  physicsClientId=c)
        shapes = {}
        self.ids = []
        for b in scene.bodies:
            key = (b.shape, b.size_m)
            if key not in shapes:
                if b.shape == 'box':
                    shapes[key] = p.createCollisionShape(
                        p.GEOM_BOX, halfExtents=[b.size_m / 2] * 3, physicsClientId=c)
                else:
                    shapes[key] = p.createCollisionShape(
                        p.GEOM_SPHERE, radius=b.size_m, physicsClientId=c)
            self.ids.append(p.createMultiBody(b.mass_kg, shapes[key], basePosition=b.position_w,
                                              physicsClientId=c))
        extra = {} if damping is None else {'linearDamping': damping, 'angularDamping': damping}
        for uid in [plane] + self.ids:
            p.changeDynamics(uid, -1, lateralFriction=math.sqrt(scene.mu),
                             restitution=math.sqrt(scene.restitution), physicsClientId=c,
                             **extra)

    def step(self, n):
        step, c = self._pb.stepSimulation, self.client
        for _ in range(n):
            step(physicsClientId=c)

    def state(self):
        p, c = self._pb, self.client
        pos = np.array([p.getBasePositionAndOrientation(i, physicsClientId=c)[0]
                        for i in self.ids])
        vel = np.array([p.getBaseVelocity(i, physicsClientId=c) for i in self.ids])
        return pos, vel[:, 0], vel[:, 1]

    def set_gravity(self, gravity_w):
        self._pb.setGravity(*gravity_w, physicsClientId=self.client)

    def set_velocity(self, i, velocity_w, omega_w):
        self._pb.resetBaseVelocity(self.ids[i], list(velocity_w), list(omega_w),
                                   physicsClientId=self.client)

    def penetration_m(self):
        points = self._pb.getContactPoints(physicsClientId=self.client)
        return float(max([0.0] + [-pt[8] for pt in points]))

    def close(self):
        self._pb.disconnect(self.client)


class BulletWorldNoDamping(BulletWorld):
    """PyBullet as :class:`BulletWorld` with its default linear and angular damping set to 0."""

    name = 'PyBullet, damping 0'
    notes = 'as PyBullet, with linearDamping = angularDamping = 0'

    def __init__(self, scene):
        super().__init__(scene, damping=0.0)


ENGINES = {'MuJoCo': ('mujoco', MujocoWorld), 'PyBullet': ('pybullet', BulletWorld)}


def engine_version(module):
    """Return the installed version of an engine's module, or None."""
    if not installed(module):
        return None
    from importlib.metadata import version
    return version(module)


def steps(seconds, h_s):
    return max(1, int(round(seconds / h_s)))


def _box(z=BOX_SIDE_M / 2, x=0.0, y=0.0, side=BOX_SIDE_M):
    return Body('box', side, MASS_KG, (x, y, z))


def _settled_on_slope(world_cls, h_s, body, mu, theta, restitution=0.0):
    """Build a world with ``body`` settled under g cos theta, then tilt gravity by theta."""
    world = world_cls(Scene(h_s, (body,), mu, restitution, (0.0, 0.0, -G * math.cos(theta))))
    world.step(steps(SETTLE_S, h_s))
    world.set_gravity((G * math.sin(theta), 0.0, -G * math.cos(theta)))
    return world


def sliding_stop(world_cls, h_s, quick=False):
    """Slide a settled box (mu 0.5) off at v0 2 m/s along x: distance to the stop, error."""
    mu, v0 = 0.5, 2.0
    exact = v0 ** 2 / (2 * mu * G)
    world = world_cls(Scene(h_s, (_box(),), mu))
    try:
        world.step(steps(SETTLE_S, h_s))
        x0 = world.state()[0][0, 0]
        world.set_velocity(0, (v0, 0.0, 0.0), (0.0, 0.0, 0.0))
        t_stop = None
        n = steps(1.5 * v0 / (mu * G) + 0.3, h_s)
        for i in range(1, n + 1):
            world.step(1)
            speed = np.linalg.norm(world.state()[1][0, :2])
            if t_stop is None and speed < 1e-3:
                t_stop = i * h_s
        x = world.state()[0][0, 0]
    finally:
        world.close()
    return {'distance_m': x - x0, 'error_pct': 100.0 * ((x - x0) / exact - 1.0),
            'stop_time_s': math.nan if t_stop is None else t_stop}


def slope_hold(world_cls, h_s, quick=False):
    """Hold a box at rest on 20 degrees, mu 0.5, 10 s (2 s with ``quick``): how far it moves."""
    duration = 2.0 if quick else 10.0
    world = _settled_on_slope(world_cls, h_s, _box(), 0.5, math.radians(20.0))
    try:
        p0 = world.state()[0][0]
        world.step(steps(duration / 2, h_s))
        p_half = world.state()[0][0]
        world.step(steps(duration / 2, h_s))
        p1 = world.state()[0][0]
    finally:
        world.close()
    return {'duration_s': duration, 'moved_m': float(np.linalg.norm(p1 - p0)),
            'creep_mm_per_s': 1e3 * float(np.linalg.norm(p1 - p_half)) / (duration / 2)}


def slope_slide(world_cls, h_s, quick=False):
    """Release a box on 30 degrees, mu 0.3: x(1 s) against 1/2 g (sin - mu cos) t^2."""
    theta, mu = math.radians(30.0), 0.3
    exact = 0.5 * G * (math.sin(theta) - mu * math.cos(theta))
    world = _settled_on_slope(world_cls, h_s, _box(), mu, theta)
    try:
        x0 = world.state()[0][0, 0]
        world.step(steps(1.0, h_s))
        x = world.state()[0][0, 0] - x0
    finally:
        world.close()
    return {'x_1s_m': x, 'error_pct': 100.0 * (x / exact - 1.0)}


def bounce(world_cls, h_s, quick=False):
    """Drop a sphere from 1 m (gap under it), eps 0.8: first three apexes / 1 m vs eps^(2k)."""
    eps, drop = 0.8, 1.0
    r = SPHERE_RADIUS_M
    world = world_cls(Scene(h_s, (Body('sphere', r, MASS_KG, (0.0, 0.0, r + drop)),), 0.5, eps))
    apexes, v_down, v_up = [], 0.0, 0.0
    try:
        rising, top = False, -math.inf
        for _ in range(steps(3.2, h_s)):
            world.step(1)
            pos, vel, _ = world.state()
            gap, vz = pos[0, 2] - r, vel[0, 2]
            if not apexes:
                v_down = min(v_down, vz) if not rising else v_down
                v_up = max(v_up, vz)
            if vz > 0.0:
                rising, top = True, max(top, gap)
            elif rising:
                apexes.append(max(top, gap))
                rising, top = False, -math.inf
                if len(apexes) == 3:
                    break
    finally:
        world.close()
    apexes += [math.nan] * (3 - len(apexes))
    # The speed ratio out of / into the first impact, exactly eps (it shows an engine that
    # launches the ball, where the apexes are never reached in the 3.2 s run).
    out = {'rebound1_speed_ratio': v_up / -v_down}
    for k, apex in enumerate(apexes, 1):
        out[f'apex{k}_per_h'] = apex / drop
        out[f'apex{k}_error_pct'] = 100.0 * (apex / drop / eps ** (2 * k) - 1.0)
    return out


def rolling(world_cls, h_s, quick=False):
    """Roll a sphere down 30 degrees, mu 0.5: acceleration vs 5/7 g sin, contact slip."""
    theta, r = math.radians(30.0), SPHERE_RADIUS_M
    exact = 5.0 / 7.0 * G * math.sin(theta)
    world = _settled_on_slope(world_cls, h_s, Body('sphere', r, MASS_KG, (0.0, 0.0, r)), 0.5,
                              theta)
    times, speeds, slips = [], [], []
    try:
        n = steps(1.0, h_s)
        for i in range(1, n + 1):
            world.step(1)
            _, vel, omega = world.state()
            # Velocity of the sphere's material point at the contact, r below the centre.
            slip = vel[0] + np.cross(omega[0], (0.0, 0.0, -r))
            if i * h_s >= 0.1:
                times.append(i * h_s)
                speeds.append(vel[0, 0])
                slips.append(float(np.linalg.norm(slip[:2])))
    finally:
        world.close()
    accel = float(np.polyfit(times, speeds, 1)[0])
    return {'accel_m_s2': accel, 'error_pct': 100.0 * (accel / exact - 1.0),
            'slip_max_m_s': max(slips)}


def cradle(world_cls, h_s, quick=False):
    """
    Strike a row of 4 touching spheres with a fifth at 1 m/s, eps 1, mu 0, no gravity.

    The row floats 1 m above the plane, the striker starts 5 cm from it; after 0.5 s: the
    share of the momentum the last ball carries (exact 1), the largest speed left to the
    others (exact 0), and the kinetic energy over the start's (exact 1).
    """
    r, count, gap = SPHERE_RADIUS_M, 5, 0.05
    bodies = tuple(Body('sphere', r, MASS_KG, (2.0 * r * k + (gap if k else 0.0), 0.0, 1.0))
                   for k in range(count))
    world = world_cls(Scene(h_s, bodies, 0.0, 1.0, gravity_w=(0.0, 0.0, 0.0)))
    try:
        world.set_velocity(0, (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        world.step(steps(0.5, h_s))
        _, vel, omega = world.state()
    finally:
        world.close()
    return {'last_share': float(vel[-1, 0]),
            'others_max_m_s': float(np.abs(vel[:-1]).max()),
            'energy_ratio': kinetic_energy(bodies, vel, omega) / (0.5 * MASS_KG)}


def column_scene_bodies(count=10):
    """Stack ``count`` boxes (side 0.2 m) exactly touching, the lowest on the plane."""
    return tuple(_box(z=BOX_SIDE_M * (i + 0.5)) for i in range(count))


def pyramid_scene_bodies(layers=5, gap_m=0.02):
    """
    Build a 2D pyramid: ``layers`` boxes at the bottom, ``gap_m`` apart, one fewer a layer up.

    Each box is centred over the gap between the two below it (it rests on both).
    """
    pitch = BOX_SIDE_M + gap_m
    bodies = []
    for layer in range(layers):
        count = layers - layer
        x0 = -0.5 * (count - 1) * pitch
        bodies += [_box(z=BOX_SIDE_M * (layer + 0.5), x=x0 + i * pitch) for i in range(count)]
    return tuple(bodies)


def _stack(world_cls, h_s, bodies, quick):
    """
    Stand ``bodies`` (the last is the top) for 10 s (2 s): top drift, KE, penetration.

    The top's drift is taken from where it was placed (it includes the settling of the
    contacts) and, separately, from t = 1 s to the end; the wall time is that of the steps
    alone, over the whole run (the first step, which may compile, excluded), and apart over
    the first second (the settling) and the rest; the CPU time (``time.process_time``: not
    the waits of a shared machine) over the whole run likewise.  A world with a
    ``breakdown()`` adds its figures (ours: sweeps per stage, cold restarts).
    """
    duration = 2.0 if quick else 10.0
    world = world_cls(Scene(h_s, bodies, 0.5))
    try:
        p0 = world.state()[0][-1]
        world.step(1)
        t, cpu = time.perf_counter(), time.process_time()
        world.step(steps(1.0, h_s) - 1)
        wall = wall_1s = time.perf_counter() - t
        cpu = time.process_time() - cpu
        pen_1s = world.penetration_m()
        p_1s = world.state()[0][-1]
        if duration > 2.0:
            t, c = time.perf_counter(), time.process_time()
            world.step(steps(duration - 2.0, h_s))
            wall += time.perf_counter() - t
            cpu += time.process_time() - c
        ke_max = 0.0
        for _ in range(steps(1.0, h_s)):
            t, c = time.perf_counter(), time.process_time()
            world.step(1)
            wall += time.perf_counter() - t
            cpu += time.process_time() - c
            _, vel, omega = world.state()
            ke_max = max(ke_max, kinetic_energy(bodies, vel, omega))
        p1 = world.state()[0][-1]
        pen_end = world.penetration_m()
        extra = world.breakdown() if hasattr(world, 'breakdown') else {}
    finally:
        world.close()
    d = p1 - p0
    return {**extra, 'duration_s': duration, 'top_drift_m': float(np.linalg.norm(d)),
            'top_sideways_m': float(np.linalg.norm(d[:2])), 'top_dz_m': float(d[2]),
            'top_drift_after_1s_m': float(np.linalg.norm(p1 - p_1s)),
            'ke_max_last_s_J': ke_max, 'penetration_1s_m': pen_1s,
            'penetration_end_m': pen_end,
            'ms_per_step': 1e3 * wall / (steps(duration, h_s) - 1),
            'ms_per_step_first_1s': 1e3 * wall_1s / (steps(1.0, h_s) - 1),
            'ms_per_step_after_1s': 1e3 * (wall - wall_1s) / steps(duration - 1.0, h_s),
            'cpu_ms_per_step': 1e3 * cpu / (steps(duration, h_s) - 1)}


def stack_column(world_cls, h_s, quick=False):
    """Stand a column of 10 boxes on the plane, 10 s (2 s with ``quick``)."""
    return _stack(world_cls, h_s, column_scene_bodies(), quick)


def stack_pyramid(world_cls, h_s, quick=False):
    """Stand a 5-layer pyramid of 15 boxes on the plane, 10 s (2 s with ``quick``)."""
    return _stack(world_cls, h_s, pyramid_scene_bodies(), quick)


COST_SIDE_M = 0.1
COST_PITCH_M = 0.2


def grid_scene(count, h_s=0.001, side_m=COST_SIDE_M, pitch_m=COST_PITCH_M):
    """Lay ``count`` boxes of 1 kg on the plane, row by row in a square grid, ``pitch_m`` apart."""
    width = math.ceil(math.sqrt(count))
    bodies = tuple(Body('box', side_m, MASS_KG,
                        (pitch_m * (i % width), pitch_m * (i // width), side_m / 2))
                   for i in range(count))
    return Scene(h_s, bodies, 0.5)


def step_cost(world_cls, count, h_s=0.001, quick=False, runs=None, pitch_m=COST_PITCH_M):
    """
    Wall time of a step with ``count`` boxes resting on the plane (settled first), one thread.

    Settles for 0.2 s (0.05 s with ``quick``), then the median over ``runs`` (7; 3 with
    ``quick``) runs of as many steps as take ~0.2 s (~0.05 s), counted from a 5-step probe.
    """
    runs = runs or (3 if quick else 7)
    span = 0.05 if quick else 0.2
    world = world_cls(grid_scene(count, h_s, pitch_m=pitch_m))
    try:
        world.step(steps(span, h_s))
        t = time.perf_counter()
        world.step(5)
        per_run = max(3, int(span / max((time.perf_counter() - t) / 5, 1e-6)))
        walls = []
        for _ in range(runs):
            t = time.perf_counter()
            world.step(per_run)
            walls.append((time.perf_counter() - t) / per_run)
        speed = float(np.linalg.norm(world.state()[1], axis=1).max())
    finally:
        world.close()
    wall = statistics.median(walls)
    return {'ms_per_step': 1e3 * wall, 'body_steps_per_s': count / wall,
            'us_per_body_step': 1e6 * wall / count, 'max_speed_m_s': speed,
            'steps_timed': per_run * runs}


def cost_1000(world_cls, h_s=0.001, quick=False):
    """Time 1000 boxes (side 0.1 m, 0.2 m apart) resting on the plane."""
    return step_cost(world_cls, 1000, h_s, quick)


def cost_1000_touching(world_cls, h_s=0.001, quick=False):
    """Time the same 1000 boxes side by side (pitch 0.1 m), neighbours touching."""
    return step_cost(world_cls, 1000, h_s, quick, pitch_m=COST_SIDE_M)


def cost_per_body(world_cls, h_s=0.001, quick=False):
    """Time 100, 1000, 10 000 (``quick``: 100, 1000) resting boxes: µs per body-step."""
    out = {}
    for count in (100, 1000) if quick else (100, 1000, 10000):
        out[f'us_per_body_step_{count}'] = step_cost(world_cls, count, h_s, quick)[
            'us_per_body_step']
    values = list(out.values())
    out['flatness_max_over_min'] = max(values) / min(values)
    return out


def measurements(world_cls):
    """``{case_name: fn(h_s, quick)}`` of every case for one engine's world class."""
    def bind(case):
        def measure(h_s, quick=False):
            return case(world_cls, h_s, quick)
        measure.__doc__ = case.__doc__
        return measure
    return {name: bind(case) for name, case in CASES.items()}


CASES = {'sliding_stop': sliding_stop, 'slope_hold': slope_hold, 'slope_slide': slope_slide,
         'bounce': bounce, 'rolling': rolling, 'cradle': cradle, 'stack_column': stack_column,
         'stack_pyramid': stack_pyramid, 'cost_1000': cost_1000,
         'cost_1000_touching': cost_1000_touching, 'cost_per_body': cost_per_body}
# What each case's table is headed with.
TITLES = {
    'sliding_stop': 'box 1 kg, side 0.2 m, settled, then v0 = 2 m/s; mu 0.5: distance to the stop '
                    '(exact v0^2 / (2 mu g)) and the time it takes',
    'slope_hold': 'box at rest on a 20 degree slope, mu 0.5: distance moved over the run and '
                  'creep speed over its second half',
    'slope_slide': 'box released on a 30 degree slope, mu 0.3: x(1 s) (exact '
                   '1/2 g (sin - mu cos) t^2)',
    'bounce': 'sphere 1 kg, r 0.1 m, dropped from a 1 m gap, eps 0.8: rebound speed ratio of the '
              'first impact and the first three apex gaps / 1 m (exact eps^(2k)); MuJoCo: solref '
              'trick (timeconst 0.02 s, damping ratio from eps)',
    'rolling': 'sphere r 0.1 m released on a 30 degree slope, mu 0.5: acceleration fitted to v(t) '
               'over 0.1-1 s (exact 5/7 g sin) and the largest slip of the contact point',
    'cradle': "Newton's cradle: 5 spheres (1 kg, r 0.1 m) in a row, the first at 1 m/s into the "
              'other four, eps 1, mu 0, no gravity: after 0.5 s the share of the momentum in the '
              'last, the largest speed of the others, the energy ratio; MuJoCo: solref trick',
    'stack_column': 'column of 10 boxes (1 kg, side 0.2 m), mu 0.5: top box drift from its '
                    'placement and from t = 1 s, largest kinetic energy in the last second, '
                    'deepest penetration at 1 s and at the end, wall time per step',
    'stack_pyramid': '5-layer 2D pyramid of 15 boxes (1 kg, side 0.2 m, 2 cm gaps), mu 0.5: the '
                     'same figures',
    'cost_1000': '1000 boxes (1 kg, side 0.1 m) resting on the plane in a grid, 0.2 m pitch, '
                 'settled: wall time per step, median of runs',
    'cost_1000_touching': 'the same 1000 boxes at a 0.1 m pitch (neighbours touch, pressing '
                          'nothing)',
    'cost_per_body': 'cost per body-step of 100, 1000, 10 000 resting boxes (0.2 m pitch; '
                     '--quick: 100, 1000) and the largest over the least (flat: 1)'}
# The time steps each case is measured at, s.
STEPS_S = {name: (0.001,) if name.startswith('cost') else (0.001, 0.01) for name in CASES}


def _exact():
    slide = 0.5 * G * (math.sin(math.radians(30.0)) - 0.3 * math.cos(math.radians(30.0)))
    stack = {'top_drift_m': 0.0, 'top_sideways_m': 0.0, 'top_dz_m': 0.0,
             'top_drift_after_1s_m': 0.0, 'ke_max_last_s_J': 0.0}
    return {
        'sliding_stop': {'distance_m': 2.0 ** 2 / (2 * 0.5 * G), 'error_pct': 0.0,
                         'stop_time_s': 2.0 / (0.5 * G)},
        'slope_hold': {'moved_m': 0.0, 'creep_mm_per_s': 0.0},
        'slope_slide': {'x_1s_m': slide, 'error_pct': 0.0},
        'bounce': {'rebound1_speed_ratio': 0.8, 'apex1_per_h': 0.8 ** 2, 'apex1_error_pct': 0.0,
                   'apex2_per_h': 0.8 ** 4, 'apex2_error_pct': 0.0, 'apex3_per_h': 0.8 ** 6,
                   'apex3_error_pct': 0.0},
        'rolling': {'accel_m_s2': 5.0 / 7.0 * G * math.sin(math.radians(30.0)),
                    'error_pct': 0.0, 'slip_max_m_s': 0.0},
        'cradle': {'last_share': 1.0, 'others_max_m_s': 0.0, 'energy_ratio': 1.0},
        'stack_column': stack, 'stack_pyramid': stack}


# The exact answer of each figure that has one: ``{case_name: {key: value}}``.
EXACT = _exact()
