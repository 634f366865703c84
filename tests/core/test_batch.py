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
(N >= ``PARALLEL_MIN_BODIES``), shared and per-body models, and every integrator.
"""

import numpy as np
import pytest

from rbd_ros.core import (AppliedWrench, BatchSimulator, BodyModel, BodyState, INTEGRATORS,
                          NonFiniteError, Simulator, Spring, step)
from rbd_ros.core.simulator import PARALLEL_MIN_BODIES

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


@pytest.mark.parametrize('n', [7, PARALLEL_MIN_BODIES], ids=['serial', 'threaded'])
@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_vectorised_wrenches_equal_single_bodies(integrator, n):
    rng = np.random.default_rng(SEED + n)
    states = _random_states(rng, n)
    models = _random_models(rng, 4)
    per_body = [models[k % 4] for k in range(n)]
    force_w = rng.normal(size=(n, 3))
    torque_w = rng.normal(size=(n, 3))
    batch = BatchSimulator(per_body, states, integrator=integrator)
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


@pytest.mark.parametrize('n', [5, PARALLEL_MIN_BODIES], ids=['serial', 'threaded'])
def test_determinism_two_runs_and_reset(n):
    rng = np.random.default_rng(SEED)
    states = _random_states(rng, n)
    force_w = rng.normal(size=(n, 3))
    torque_w = rng.normal(size=(n, 3))
    model = _random_models(rng, 2)[1]
    results = []
    for _ in range(2):
        batch = BatchSimulator(model, states)
        batch.set_wrenches_w(force_w, torque_w)
        batch.step(N_STEPS)
        results.append(batch.arrays[0].copy())
    assert np.array_equal(results[0], results[1])
    batch.reset()
    assert batch.step_count == 0
    batch.step(N_STEPS)
    assert np.array_equal(batch.arrays[0], results[0])


@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_functional_step_equals_simulator_step(integrator):
    rng = np.random.default_rng(SEED)
    state = _random_states(rng, 1)[0]
    model = _random_models(rng, 2)[1]
    wrenches, springs = _random_loads(rng, 3)
    sim = Simulator(model, state, integrator=integrator, timestep_ns=2_000_000)
    sim.set_loads(wrenches, springs)
    sim.step()
    stepped = step(model, state, integrator=integrator, timestep_ns=2_000_000,
                   wrenches=wrenches, springs=springs)
    assert stepped == sim.state
    assert stepped.time_ns == state.time_ns + 2_000_000


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
    assert np.array_equal(sim.state.orientation_wb, sim.arrays[0][3:7, 0])
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
