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
State kinematics against finite differences, and the refusal of bad input.

Kinematics: the lecture's ``x = p + R x̄`` is moved along an exactly known motion and
differentiated numerically; the state's own point velocity and acceleration must match.
Errors: every refusal names the field, so the message is checked for it.
"""

import math

import numpy as np
import pytest

from rbd_ros.core import (accelerations, AppliedWrench, BatchSimulator, BodyModel, BodyState,
                          ConfigError, InputError, INTEGRATORS, ModelError, NonFiniteError,
                          Simulator, Spring)
from rbd_ros.core.rotations import quat_exp, quat_multiply, quat_to_matrix

SEED = 20260122


@pytest.fixture
def moving():
    rng = np.random.default_rng(SEED)
    model = BodyModel(1.7, np.diag([0.4, 0.6, 0.9]), gravity_w=(0.0, 0.0, -9.81))
    state = BodyState(position_w=rng.normal(size=3), orientation_wb=rng.normal(size=4),
                      linear_velocity_w=rng.normal(size=3), angular_velocity_b=rng.normal(size=3))
    return model, state, rng.normal(size=(5, 3))


def _advanced(state, dt, linear_acceleration_w=np.zeros(3), angular_acceleration_w=np.zeros(3)):
    """
    Return the state ``dt`` later along p(t) = p + v t + a t²/2, ω_w(t) = ω_w + α t.

    Orientation: q(t) = exp(ω_w t + α t²/2) q, exact to O(t³) (the commutator term of the
    Magnus expansion is ~ |ω||α| t³ / 12).
    """
    omega_w = state.angular_velocity_w() + angular_acceleration_w * dt
    q = quat_multiply(quat_exp(state.angular_velocity_w() * dt
                               + 0.5 * angular_acceleration_w * dt * dt), state.orientation_wb)
    return BodyState(
        position_w=state.position_w + state.linear_velocity_w * dt
        + 0.5 * linear_acceleration_w * dt * dt,
        orientation_wb=q, linear_velocity_w=state.linear_velocity_w + linear_acceleration_w * dt,
        angular_velocity_b=quat_to_matrix(q).T @ omega_w)


def test_point_velocity_is_the_derivative_of_point_position(moving):
    _, state, points_b = moving
    dt = 1e-6
    central = (_advanced(state, dt).point_w(points_b)
               - _advanced(state, -dt).point_w(points_b)) / (2.0 * dt)
    # Central difference: truncation |ω|² |v|-scale dt² ~ 1e-11; round-off 1e-16 · 3 / dt
    # ~ 3e-10. 1e-8 m/s is 30× the sum.
    assert np.allclose(central, state.point_velocity_w(points_b), rtol=0.0, atol=1e-8)


def test_point_acceleration_is_the_derivative_of_point_velocity(moving):
    model, state, points_b = moving
    springs = [Spring((0.1, 0.2, 0.0), (0.0, 0.0, 0.0), 30.0, 0.5)]
    wrenches = [AppliedWrench(force=(0.0, 2.0, 0.0), point_b=(0.5, 0.0, 0.0))]
    a_w, alpha_w = accelerations(model, state, wrenches, springs)
    dt = 1e-5
    central = (_advanced(state, dt, a_w, alpha_w).point_velocity_w(points_b)
               - _advanced(state, -dt, a_w, alpha_w).point_velocity_w(points_b)) / (2.0 * dt)
    # Truncation O(dt²) ~ 1e-10 (odd Magnus terms cancel in the central difference);
    # round-off 1e-16 · 10 / dt ~ 1e-10. 1e-7 m/s² is far below any wrong term (O(1)).
    assert np.allclose(central, state.point_acceleration_w(points_b, a_w, alpha_w), rtol=0.0,
                       atol=1e-7)


def test_derived_quantities(moving):
    model, state, _ = moving
    rot = quat_to_matrix(state.orientation_wb)
    inertia_w = state.inertia_w(model)
    omega_w = state.angular_velocity_w()
    # All ~20-operation expressions on O(1) numbers: 1e-14 is ~50 ulp.
    assert np.allclose(inertia_w, rot @ model.inertia_b @ rot.T, rtol=0.0, atol=1e-14)
    assert np.allclose(omega_w, rot @ state.angular_velocity_b, rtol=0.0, atol=1e-14)
    assert np.allclose(state.angular_momentum_w(model), inertia_w @ omega_w, rtol=0.0,
                       atol=1e-14)
    assert state.kinetic_energy_rotational(model) == pytest.approx(
        0.5 * omega_w @ inertia_w @ omega_w, rel=1e-14)
    assert np.array_equal(state.linear_momentum_w(model), 1.7 * state.linear_velocity_w)
    assert state.potential_energy(model) == pytest.approx(
        1.7 * 9.81 * state.position_w[2], rel=1e-15)


def test_energy_exchange_in_free_fall():
    # Free fall with midpoint_cayley (exact for constant force): KE + PE is constant to
    # round-off (1e-12 relative: 1000 steps of O(1e-16) roundings, with margin).
    model = BodyModel(2.0, np.diag([1.0, 1.0, 1.0]), gravity_w=(0.0, 0.0, -9.81))
    start = BodyState(linear_velocity_w=(1.0, 0.0, 5.0))
    sim = Simulator(model, start)
    sim.step(1000)
    total0 = start.kinetic_energy(model) + start.potential_energy(model)
    total = sim.state.kinetic_energy(model) + sim.state.potential_energy(model)
    assert total == pytest.approx(total0, rel=1e-12)
    assert sim.state.potential_energy(model) != pytest.approx(start.potential_energy(model))


# --- refused input ----------------------------------------------------------------------------

@pytest.mark.parametrize('field, kwargs', [
    ('position_w', {'position_w': (math.nan, 0.0, 0.0)}),
    ('position_w', {'position_w': (1.0, 2.0)}),
    ('orientation_wb', {'orientation_wb': (0.0, 0.0, 0.0, 0.0)}),
    ('orientation_wb', {'orientation_wb': (1.0, math.inf, 0.0, 0.0)}),
    ('linear_velocity_w', {'linear_velocity_w': (0.0, -math.inf, 0.0)}),
    ('angular_velocity_b', {'angular_velocity_b': (0.0, 0.0, math.nan)}),
    ('time_ns', {'time_ns': 1.5}),
    ('time_ns', {'time_ns': True}),
])
def test_bad_state_is_refused_naming_the_field(field, kwargs):
    with pytest.raises(InputError, match=field):
        BodyState(**kwargs)


@pytest.mark.parametrize('field, make', [
    ('force', lambda: AppliedWrench(force=(math.nan, 0.0, 0.0))),
    ('torque', lambda: AppliedWrench(torque=(0.0, math.inf, 0.0))),
    ('point_b', lambda: AppliedWrench(point_b=(0.0, 0.0, math.nan))),
    ('frame', lambda: AppliedWrench(frame='base_link')),
    ('stiffness_n_per_m', lambda: Spring((0, 0, 0), (0, 0, 0), -1.0)),
    ('damping_n_s_per_m', lambda: Spring((0, 0, 0), (0, 0, 0), 1.0, math.nan)),
    ('rest_length_m', lambda: Spring((0, 0, 0), (0, 0, 0), 1.0, 0.0, -0.1)),
    ('anchor_w', lambda: Spring((0, 0, 0), (math.inf, 0, 0), 1.0)),
])
def test_bad_load_is_refused_naming_the_field(field, make):
    with pytest.raises(InputError, match=field):
        make()


def test_bad_batch_wrench_is_refused():
    batch = BatchSimulator(BodyModel(1.0, np.eye(3)), [BodyState()] * 3)
    force = np.zeros((3, 3))
    force[1, 2] = math.nan
    with pytest.raises(InputError, match='force_w'):
        batch.set_wrenches_w(force, np.zeros((3, 3)))
    with pytest.raises(InputError, match='wrenches'):
        Simulator(BodyModel(1.0, np.eye(3))).set_loads(wrenches=[(1.0, 2.0, 3.0)])


@pytest.mark.parametrize('name', ['euler', 'RK4', '', None])
def test_unknown_integrator_is_a_config_error_naming_it(name):
    with pytest.raises(ConfigError, match='integrator') as info:
        Simulator(BodyModel(1.0, np.eye(3)), integrator=name)
    assert repr(name) in str(info.value)
    assert 'midpoint_cayley' in str(info.value)   # and it lists the valid names


@pytest.mark.parametrize('timestep_ns', [0, -1_000_000, 1.5e6, True, '1ms'])
def test_bad_timestep_is_a_config_error(timestep_ns):
    with pytest.raises(ConfigError, match='timestep_ns') as info:
        Simulator(BodyModel(1.0, np.eye(3)), timestep_ns=timestep_ns)
    assert repr(timestep_ns) in str(info.value)


@pytest.mark.parametrize('field, kwargs', [
    ('mass_kg', {'mass_kg': 0.0}),
    ('mass_kg', {'mass_kg': -1.0}),
    ('mass_kg', {'mass_kg': math.nan}),
    ('not positive definite', {'inertia_b': np.diag([1.0, 1.0, -1.0])}),
    ('not symmetric', {'inertia_b': [[1.0, 0.5, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]}),
    ('triangle inequality', {'inertia_b': np.diag([1.0, 1.0, 3.0])}),
    ('inertia_b', {'inertia_b': np.eye(2)}),
    ('gravity_w', {'gravity_w': (0.0, 0.0, math.inf)}),
    ('linear_damping_per_s', {'linear_damping_per_s': -0.1}),
    ('angular_damping_per_s', {'angular_damping_per_s': math.nan}),
])
def test_bad_model_is_a_model_error(field, kwargs):
    args = {'mass_kg': 1.0, 'inertia_b': np.eye(3)}
    args.update(kwargs)
    with pytest.raises(ModelError, match=field):
        BodyModel(**args)


@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_diverging_step_raises_and_keeps_the_last_finite_state(integrator):
    model = BodyModel(1.0, np.diag([1.0, 2.0, 2.5]))
    sim = Simulator(model, BodyState(angular_velocity_b=(1.0, 2.0, 3.0)), integrator=integrator)
    sim.step(10)
    before = sim.state
    # A finite but absurd torque: the step's ω ~ h τ / I ~ 1e305 rad/s makes the orientation
    # update overflow (|ω|² = inf), so the step must be refused as non-finite, not turned into
    # some rotation.
    sim.set_loads([AppliedWrench(torque=(1e308, -1e308, 1e308), frame='body')])
    with pytest.raises(NonFiniteError, match='non-finite'):
        sim.step(5)
    assert sim.state == before            # refused, not reset, not partially applied
    assert sim.time_ns == before.time_ns
    assert np.all(np.isfinite(sim.arrays[0]))
    # Removing the load lets it continue from there.
    sim.set_loads()
    sim.step()
    assert sim.time_ns == before.time_ns + sim.timestep_ns
