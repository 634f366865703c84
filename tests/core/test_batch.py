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
The batched path against single bodies, determinism, and the functional ``step``.

Every path runs the same compiled per-body function on the same numbers, so the bound here is
not "round-off" but zero: results must be BIT-IDENTICAL (``np.array_equal``), which replay
relies on. This holds for the serial kernel (small N) and the threaded one
(N >= ``PARALLEL_MIN_BODIES``), shared and per-body models, and every integrator. What that
shared kernel computes is checked here against an independent numpy reference of every
integrator (to round-off), so the bit-equalities do not merely compare the code with itself.
"""

import os

import numba
import numpy as np
import pytest

from rbd_ros.core import (AppliedWrench, BatchSimulator, BodyModel, BodyState, ConfigError,
                          INTEGRATORS, NonFiniteError, Simulator, Spring, step)
from rbd_ros.core.layout import S_QUAT
from rbd_ros.core.simulator import choose_threads, free_cores, PARALLEL_MIN_BODIES
from reference_loads import spring_force_w

SEED = 20260122
N_STEPS = 25


def _random_states(rng, n):
    return [BodyState(position_w=rng.normal(size=3), orientation_wb=rng.normal(size=4),
                      linear_velocity_w=rng.normal(size=3),
                      angular_velocity_b=3.0 * rng.normal(size=3), time_ns=5_000_000)
            for _ in range(n)]


def _random_models(rng, n):
    models = []
    for k in range(n):
        moments = rng.uniform(0.5, 1.0, size=3)
        inertia = np.diag(moments)
        if k % 2:
            # Rotate half of them off their principal frame: a full (non-diagonal) inertia.
            q = rng.normal(size=4)
            q /= np.linalg.norm(q)
            w, x, y, z = q
            rot = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])
            inertia = rot @ inertia @ rot.T
        models.append(BodyModel(rng.uniform(0.5, 5.0), inertia, gravity_w=(0.0, 0.0, -9.81),
                                linear_damping_per_s=0.1 * (k % 3),
                                angular_damping_per_s=0.05 * (k % 2)))
    return models


def _random_loads(rng, k):
    """Return a different mix of loads for body ``k`` (0 to 3 wrenches, 0 or 1 spring)."""
    wrenches = [AppliedWrench(force=rng.normal(size=3), torque=rng.normal(size=3),
                              frame=('world', 'body')[j % 2], point_b=0.2 * rng.normal(size=3))
                for j in range(k % 4)]
    springs = [Spring(0.1 * rng.normal(size=3), rng.normal(size=3), 20.0, 0.5,
                      rest_length_m=0.3 * (k % 2))] * (k % 2)
    return wrenches, springs


def _assert_bit_identical(batch, singles):
    x, times_ns = batch.arrays
    for i, single in enumerate(singles):
        xs, ts = single.arrays
        assert np.array_equal(x[:, i], xs[:, 0]), f'body {i}'
        assert times_ns[i] == ts[0]


@pytest.mark.parametrize('per_body_models', [False, True], ids=['shared', 'per-body'])
@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_small_batch_with_mixed_loads_equals_single_bodies(integrator, per_body_models):
    rng = np.random.default_rng(SEED)
    n = 9
    states = _random_states(rng, n)
    models = _random_models(rng, n) if per_body_models else _random_models(rng, 1)[0]
    batch = BatchSimulator(models, states, integrator=integrator)
    singles = []
    for k in range(n):
        wrenches, springs = _random_loads(rng, k)
        batch.set_body_loads(k, wrenches, springs)
        single = Simulator(models[k] if per_body_models else models, states[k],
                           integrator=integrator)
        single.set_loads(wrenches, springs)
        singles.append(single)
    batch.step(N_STEPS)
    for single in singles:
        single.step(N_STEPS)
    _assert_bit_identical(batch, singles)
    # And it moved (the comparison is not of untouched initial states).
    assert not np.array_equal(batch.arrays[0][:, 0], np.concatenate(
        (states[0].position_w, states[0].orientation_wb, states[0].linear_velocity_w,
         states[0].angular_velocity_b)))


@pytest.mark.parametrize('n, threads', [(7, None), (PARALLEL_MIN_BODIES, 2)],
                         ids=['serial', 'threaded'])
@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_vectorised_wrenches_equal_single_bodies(integrator, n, threads):
    rng = np.random.default_rng(SEED + n)
    states = _random_states(rng, n)
    models = _random_models(rng, 4)
    per_body = [models[k % 4] for k in range(n)]
    force_w = rng.normal(size=(n, 3))
    torque_w = rng.normal(size=(n, 3))
    batch = BatchSimulator(per_body, states, integrator=integrator, threads=threads)
    assert batch.threads == (1 if threads is None else 2)
    batch.set_wrenches_w(force_w, torque_w)
    batch.step(3)
    batch.step(2)   # two calls: the state carries over between kernel calls
    singles = []
    for k in range(n):
        single = Simulator(per_body[k], states[k], integrator=integrator)
        single.set_loads([AppliedWrench(force=force_w[k], torque=torque_w[k], frame='world')])
        single.step(5)
        singles.append(single)
    _assert_bit_identical(batch, singles)


@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_batch_of_one_equals_simulator(integrator):
    rng = np.random.default_rng(SEED)
    state = _random_states(rng, 1)[0]
    model = _random_models(rng, 2)[1]
    wrenches, springs = _random_loads(rng, 3)
    batch = BatchSimulator(model, [state], integrator=integrator)
    batch.set_body_loads(0, wrenches, springs)
    single = Simulator(model, state, integrator=integrator)
    single.set_loads(wrenches, springs)
    batch.step(N_STEPS)
    single.step(N_STEPS)
    assert batch.body_state(0) == single.state


@pytest.mark.parametrize('n, threads', [(5, None), (PARALLEL_MIN_BODIES, 2)],
                         ids=['serial', 'threaded'])
def test_determinism_two_runs_and_reset(n, threads):
    rng = np.random.default_rng(SEED)
    states = _random_states(rng, n)
    force_w = rng.normal(size=(n, 3))
    torque_w = rng.normal(size=(n, 3))
    model = _random_models(rng, 2)[1]
    results = []
    for _ in range(2):
        batch = BatchSimulator(model, states, threads=threads)
        batch.set_wrenches_w(force_w, torque_w)
        batch.step(N_STEPS)
        results.append(batch.arrays[0].copy())
    assert np.array_equal(results[0], results[1])
    batch.reset()
    assert batch.step_count == 0
    batch.step(N_STEPS)
    assert np.array_equal(batch.arrays[0], results[0])


# --- an independent numpy reference of every integrator ------------------------------------
# Written from the documented methods (rbd_ros.core.integrators, loads, model), in another
# formulation than the kernel where the method allows it: rotation matrices instead of
# quaternions, world-frame Euler equations with I_w = R I_b Rᵀ for symplectic Euler, a matrix
# Cayley transform, RK4 written on the integrating-factor ODE itself.

def _hat(a):
    return np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])


def _matrix(q):
    w, x, y, z = np.asarray(q) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _qmul(a, b):
    aw, av, bw, bv = a[0], np.asarray(a[1:]), b[0], np.asarray(b[1:])
    return np.concatenate(([aw * bw - av @ bv], aw * bv + bw * av + np.cross(av, bv)))


def _net(model, p, rot, v, omega_w, wrenches, springs):
    """F = M g + Σ f, τ = Σ (r × f + τ_c) with r = R point_b; springs as Spring documents."""
    force, torque = model.mass_kg * model.gravity_w, np.zeros(3)
    for wrench in wrenches:
        r = rot @ wrench.point_b
        f, couple = wrench.force, wrench.torque
        if wrench.frame == 'body':
            f, couple = rot @ f, rot @ couple
        force, torque = force + f, torque + np.cross(r, f) + couple
    for spring in springs:
        f, r = spring_force_w(spring, p, rot, v, omega_w)
        force, torque = force + f, torque + np.cross(r, f)
    return force, torque


def _reference_step(integrator, model, p, rot, v, omega_b, h, wrenches, springs):
    """One step of ``integrator``: (p, R, v_w, ω_b) -> the same, numpy only."""
    inertia, inverse = model.inertia_b, np.linalg.inv(model.inertia_b)
    c_v, c_w = model.linear_damping_per_s, model.angular_damping_per_s
    if integrator == 'rk4':
        def nonlinear(y):   # the undamped right-hand side on (p, q, v, ω_b)
            rot_y = _matrix(y[3:7])
            f, t = _net(model, y[0:3], rot_y, y[7:10], rot_y @ y[10:13], wrenches, springs)
            w = y[10:13]
            return np.concatenate((y[7:10], 0.5 * _qmul(y[3:7], np.concatenate(([0.0], w))),
                                   f / model.mass_kg,
                                   inverse @ (rot_y.T @ t - np.cross(w, inertia @ w))))

        def factor(tau):    # e^{τL}: the damping flow
            return np.concatenate((np.ones(7), np.full(3, np.exp(-c_v * tau)),
                                   np.full(3, np.exp(-c_w * tau))))

        def transformed(tau, u):   # u(τ) = e^{-τL} y: classical RK4 on u' = e^{-τL} N(e^{τL} u)
            return nonlinear(factor(tau) * u) / factor(tau)

        u = np.concatenate((p, _quat(rot), v, omega_b))
        k1 = transformed(0.0, u)
        k2 = transformed(h / 2, u + h / 2 * k1)
        k3 = transformed(h / 2, u + h / 2 * k2)
        k4 = transformed(h, u + h * k3)
        y = factor(h) * (u + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4))
        return y[0:3], _matrix(y[3:7]), y[7:10], y[10:13]
    # Everything else: the exact damping flow, half before and half after the step.
    v, omega_b = v * np.exp(-c_v * h / 2), omega_b * np.exp(-c_w * h / 2)
    if integrator == 'midpoint_cayley':
        f, t = _net(model, p, rot, v, rot @ omega_b, wrenches, springs)
        v = v + h / 2 * f / model.mass_kg
        momentum = inertia @ omega_b + h / 2 * rot.T @ t
        p = p + h * v
        mid = momentum.copy()
        for _ in range(100):   # m = Π + h/2 m × I⁻¹ m, contracting by ~h|ω| ≈ 0.02
            mid = momentum + h / 2 * np.cross(mid, inverse @ mid)
        momentum = 2 * mid - momentum
        a = h * _hat(inverse @ mid)
        rot = rot @ np.linalg.solve(np.eye(3) - a / 2, np.eye(3) + a / 2)   # Cayley
        f, t = _net(model, p, rot, v, rot @ (inverse @ momentum), wrenches, springs)
        v = v + h / 2 * f / model.mass_kg
        omega_b = inverse @ (momentum + h / 2 * rot.T @ t)
    else:
        omega_w = rot @ omega_b
        f, t = _net(model, p, rot, v, omega_w, wrenches, springs)
        inertia_w = rot @ inertia @ rot.T
        v = v + h * f / model.mass_kg
        omega_w = omega_w + h * np.linalg.solve(inertia_w,
                                                t - np.cross(omega_w, inertia_w @ omega_w))
        p = p + h * v
        omega_b = rot.T @ omega_w
        if integrator == 'symplectic_euler_matrix':
            new = (np.eye(3) + h * _hat(omega_w)) @ rot
            c0 = new[:, 0] / np.linalg.norm(new[:, 0])
            c1 = new[:, 1] - (c0 @ new[:, 1]) * c0
            c1 = c1 / np.linalg.norm(c1)
            rot = np.column_stack((c0, c1, np.cross(c0, c1)))
        elif integrator in ('symplectic_euler_axis_angle', 'symplectic_euler_quat_exp'):
            angle = h * np.linalg.norm(omega_w)   # Rodrigues: exp(h [ω_w]) R
            k = _hat(omega_w / np.linalg.norm(omega_w))
            rot = (np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k) @ rot
        else:
            q = _quat(rot)
            q = q + h / 2 * _qmul(np.concatenate(([0.0], omega_w)), q)
            rot = _matrix(q)
    return p, rot, v * np.exp(-c_v * h / 2), omega_b * np.exp(-c_w * h / 2)


def _quat(rot):
    """Return the unit quaternion (w first, w > 0) of a rotation matrix away from 180°."""
    w = 0.5 * np.sqrt(1.0 + np.trace(rot))
    return np.array([w, (rot[2, 1] - rot[1, 2]) / (4 * w), (rot[0, 2] - rot[2, 0]) / (4 * w),
                     (rot[1, 0] - rot[0, 1]) / (4 * w)])


@pytest.mark.parametrize('case', range(4))
@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_functional_step_matches_an_independent_numpy_reference(integrator, case):
    # Cases 0-3: diagonal and full inertias; damping none, linear + angular, linear, angular;
    # no loads (gravity only), a wrench and a zero-length spring, two wrenches (world, body),
    # three wrenches and a spring with a rest length.
    rng = np.random.default_rng(SEED + case)
    state = _random_states(rng, 1)[0]
    model = _random_models(rng, 4)[case]
    wrenches, springs = _random_loads(rng, case)
    if case == 1:
        springs = [Spring(0.1 * rng.normal(size=3), rng.normal(size=3), 20.0, 0.5)]
    dt_ns, n = 2_000_000, 5
    sim = Simulator(model, state, integrator=integrator, timestep_ns=dt_ns)
    sim.set_loads(wrenches, springs)
    stepped = state
    for _ in range(n):
        stepped = step(model, stepped, integrator=integrator, timestep_ns=dt_ns,
                       wrenches=wrenches, springs=springs)
        sim.step()
        # The value form and the simulator run the same kernel: bit for bit.
        assert stepped == sim.state
    assert stepped.time_ns == state.time_ns + n * dt_ns
    p, rot = state.position_w, _matrix(state.orientation_wb)
    v, omega_b = state.linear_velocity_w, state.angular_velocity_b
    for _ in range(n):
        p, rot, v, omega_b = _reference_step(integrator, model, p, rot, v, omega_b, dt_ns * 1e-9,
                                             wrenches, springs)
    # Same method, other formulation: they differ by round-off only, a few ulp of O(1-10)
    # quantities per step (~1e-14) over 5 steps of Lipschitz factor 1 + O(h) (~1e-13). A
    # wrong term (a stale ω, a missed frame rotation, a mis-split damping) shows at
    # O(h² |ω̇|) ≳ 1e-7. 1e-11 sits between.
    tol = 1e-11
    assert np.allclose(stepped.position_w, p, rtol=0.0, atol=tol)
    assert np.allclose(stepped.linear_velocity_w, v, rtol=0.0, atol=tol)
    assert np.allclose(stepped.angular_velocity_b, omega_b, rtol=0.0, atol=tol)
    assert np.allclose(_matrix(stepped.orientation_wb), rot, rtol=0.0, atol=tol)
    # And the step moved the body well beyond that tolerance (not a comparison at rest).
    assert np.abs(stepped.angular_velocity_b - state.angular_velocity_b).max() > 1e3 * tol


@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_restarting_from_a_reported_state_is_bit_identical(integrator):
    # A replay or a node that restarts from ``sim.state`` must continue exactly as the
    # original run does: the reported BodyState has to carry the kernel's numbers unchanged.
    rng = np.random.default_rng(SEED)
    state = _random_states(rng, 1)[0]
    model = _random_models(rng, 2)[1]
    wrenches, springs = _random_loads(rng, 3)
    sim = Simulator(model, state, integrator=integrator)
    sim.set_loads(wrenches, springs)
    sim.step(100)
    assert np.array_equal(sim.state.orientation_wb, sim.arrays[0][S_QUAT:S_QUAT + 4, 0])
    restarted = Simulator(model, sim.state, integrator=integrator)
    restarted.set_loads(wrenches, springs)
    sim.step(50)
    restarted.step(50)
    assert restarted.state == sim.state


def test_one_diverging_body_does_not_stop_the_others():
    rng = np.random.default_rng(SEED)
    states = _random_states(rng, 4)
    model = BodyModel(1.0, np.diag([1.0, 2.0, 2.5]))
    batch = BatchSimulator(model, states, integrator='symplectic_euler_quat_exp')
    force_w = np.zeros((4, 3))
    torque_w = np.zeros((4, 3))
    torque_w[2] = (1e308, 1e308, 0.0)   # finite input, but h τ / I overflows
    batch.set_wrenches_w(force_w, torque_w)
    before = batch.arrays[0][:, 2].copy()
    with pytest.raises(NonFiniteError, match=r'\[2\]'):
        batch.step(10)
    x, times_ns = batch.arrays
    assert np.array_equal(x[:, 2], before)           # left at its last finite state
    assert times_ns[2] == states[2].time_ns          # and its time did not advance
    assert np.all(times_ns[[0, 1, 3]] == states[0].time_ns + 10 * batch.timestep_ns)
    assert np.all(np.isfinite(x))


def test_results_do_not_depend_on_the_thread_count():
    # 2 × PARALLEL_MIN_BODIES bodies: the automatic choice may use 1 or 2 threads; fixed counts
    # 1, 2 and 3 (more threads than cores) and a count changed between calls all agree bit for
    # bit with the serial kernel.
    n = 2 * PARALLEL_MIN_BODIES
    rng = np.random.default_rng(SEED + 1)
    states = _random_states(rng, n)
    model = _random_models(rng, 2)[1]
    force_w, torque_w = rng.normal(size=(n, 3)), rng.normal(size=(n, 3))
    results = {}
    for threads in (1, 2, 3, None):
        batch = BatchSimulator(model, states, threads=threads)
        batch.set_wrenches_w(force_w, torque_w)
        batch.step(4)
        results[threads] = batch.arrays[0].copy()
    for threads in (2, 3, None):
        assert np.array_equal(results[threads], results[1]), f'threads={threads}'
    mixed = BatchSimulator(model, states, threads=2)
    mixed.set_wrenches_w(force_w, torque_w)
    mixed.step(2)
    mixed._set_threads(1)   # as if the load changed between calls
    mixed.step(2)
    assert np.array_equal(mixed.arrays[0], results[1])


def test_thread_choice():
    pool = numba.config.NUMBA_NUM_THREADS
    assert choose_threads(PARALLEL_MIN_BODIES - 1) == 1          # too few bodies for threads
    assert 1 <= choose_threads(10 * PARALLEL_MIN_BODIES) <= min(pool, free_cores())
    assert choose_threads(10, threads=1) == 1
    assert choose_threads(10, threads=pool + 5) == pool            # capped at numba's pool
    assert 1 <= free_cores() <= len(os.sched_getaffinity(0))
    assert BatchSimulator(_random_models(np.random.default_rng(0), 1)[0],
                          _random_states(np.random.default_rng(0), 3)).threads == 1
    for bad in (0, -1, 1.5, True, '2'):
        with pytest.raises(ConfigError, match=f'threads: {bad!r} threads must be a positive'):
            BatchSimulator(_random_models(np.random.default_rng(0), 1)[0],
                           _random_states(np.random.default_rng(0), 3), threads=bad)


def test_automatic_threads_time_both_candidates():
    # The automatic choice times a step on 1 thread and on one per core, and then runs the
    # faster; results stay bit-identical to a fixed single thread (checked above).
    n = 2 * PARALLEL_MIN_BODIES
    rng = np.random.default_rng(SEED + 2)
    batch = BatchSimulator(_random_models(rng, 1)[0], _random_states(rng, n))
    most = min(numba.config.NUMBA_NUM_THREADS, len(os.sched_getaffinity(0)), 2)
    assert batch._candidates == ((1, most) if most > 1 else (1,))
    for _ in range(3):
        batch.step()
    assert set(batch._cost_s) == set(batch._candidates)
    assert all(cost > 0.0 for cost in batch._cost_s.values())
    assert batch.threads in batch._candidates
