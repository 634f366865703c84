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
The one place that sums loads (``net_wrench_w``) against independent numpy formulas.

Tolerance ``TOL = 1e-13`` absolute: every component is at most ~30 float64 operations on
numbers of magnitude <= 20 (forces in N, lever arms in m), each rounded to 1.1e-16 relative,
so the two computations agree to ~1e-14; a wrong sign, frame or factor is off by O(1).
"""

import numpy as np
import pytest

from rbd_ros.core import (accelerations, AppliedWrench, BodyModel, BodyState, net_wrench_w,
                          Simulator, Spring)
from rbd_ros.core.rotations import quat_to_matrix
from reference_loads import spring_force_w

TOL = 1e-13
SEED = 20260122


@pytest.fixture
def body():
    rng = np.random.default_rng(SEED)
    model = BodyModel(2.5, np.array([[1.0, 0.1, 0.0], [0.1, 1.5, -0.2], [0.0, -0.2, 2.0]]),
                      gravity_w=(0.0, 0.0, -9.81))
    state = BodyState(position_w=rng.normal(size=3), orientation_wb=rng.normal(size=4),
                      linear_velocity_w=rng.normal(size=3), angular_velocity_b=rng.normal(size=3))
    return model, state, rng


def _spring_reference(model, state, spring):
    rot = quat_to_matrix(state.orientation_wb)
    f, r_w = spring_force_w(spring, state.position_w, rot, state.linear_velocity_w,
                            rot @ state.angular_velocity_b)
    return f, np.cross(r_w, f)


@pytest.mark.parametrize('rest_length_m', [0.0, 0.4])
def test_spring_force_and_torque(body, rest_length_m):
    model, state, rng = body
    spring = Spring(point_b=(0.3, -0.1, 0.2), anchor_w=(1.0, 2.0, -1.0), stiffness_n_per_m=15.0,
                    damping_n_s_per_m=0.7, rest_length_m=rest_length_m)
    force, torque = net_wrench_w(model, state, springs=[spring])
    f_ref, t_ref = _spring_reference(model, state, spring)
    assert np.allclose(force, f_ref + model.mass_kg * model.gravity_w, rtol=0.0, atol=TOL)
    assert np.allclose(torque, t_ref, rtol=0.0, atol=TOL)


def test_spring_at_zero_length_with_rest_length_gives_no_force():
    model = BodyModel(1.0, np.eye(3))
    spring = Spring((0.0, 0.0, 0.0), (1.0, 1.0, 1.0), 10.0, 1.0, rest_length_m=0.5)
    force, torque = net_wrench_w(model, BodyState(position_w=(1.0, 1.0, 1.0)), springs=[spring])
    # No direction is defined at d = 0: the kernel returns 0, not NaN.
    assert np.array_equal(force, np.zeros(3)) and np.array_equal(torque, np.zeros(3))


def test_body_frame_wrench_is_rotated_to_world(body):
    model, state, _ = body
    rot = quat_to_matrix(state.orientation_wb)
    force_b, torque_b, point_b = np.array([1.0, -2.0, 0.5]), np.array([0.3, 0.1, -0.4]), \
        np.array([0.2, 0.0, -0.3])
    force, torque = net_wrench_w(
        model, state, [AppliedWrench(force=force_b, torque=torque_b, frame='body',
                                     point_b=point_b)])
    assert np.allclose(force, rot @ force_b + model.mass_kg * model.gravity_w, rtol=0.0,
                       atol=TOL)
    # τ = r_w × f_w + τ_c,w = R (r_b × f_b + τ_c,b).
    assert np.allclose(torque, rot @ (np.cross(point_b, force_b) + torque_b), rtol=0.0,
                       atol=TOL)


def test_loads_superpose(body):
    model, state, rng = body
    loads = [AppliedWrench(force=rng.normal(size=3), torque=rng.normal(size=3), frame=frame,
                           point_b=rng.normal(size=3)) for frame in ('world', 'body', 'world')]
    springs = [Spring(rng.normal(size=3), rng.normal(size=3), 12.0, 0.3, 0.2),
               Spring(rng.normal(size=3), rng.normal(size=3), 7.0, 0.0, 0.0)]
    total_f, total_t = net_wrench_w(model, state, loads, springs)
    free = BodyModel(model.mass_kg, model.inertia_b)   # no gravity: parts add without it
    sum_f, sum_t = np.zeros(3), np.zeros(3)
    for part in [{'wrenches': [w]} for w in loads] + [{'springs': [s]} for s in springs]:
        f, t = net_wrench_w(free, state, **part)
        sum_f += f
        sum_t += t
    assert np.allclose(total_f, sum_f + model.mass_kg * model.gravity_w, rtol=0.0, atol=TOL)
    assert np.allclose(total_t, sum_t, rtol=0.0, atol=TOL)


def test_accelerations_match_the_kernel(body):
    # One symplectic Euler step is v ← v + h a, ω_b ← ω_b + h ω̇_b with α_w = R ω̇_b (since
    # ω_w = R ω_b and Ṙ ω_b = ω_w × ω_w = 0): finite differences of one step recover a, α.
    model, state, rng = body
    loads = [AppliedWrench(force=(1.0, 0.5, -0.2), torque=(0.1, -0.3, 0.2), frame='body',
                           point_b=(0.1, 0.2, 0.0))]
    springs = [Spring((0.2, 0.0, 0.1), (0.5, 0.5, 0.5), 8.0, 0.4)]
    a_w, alpha_w = accelerations(model, state, loads, springs)
    h = 1e-6
    sim = Simulator(model, state, integrator='symplectic_euler_quat_exp', timestep_ns=1000)
    sim.set_loads(loads, springs)
    sim.step()
    rot = quat_to_matrix(state.orientation_wb)
    a_fd = (sim.state.linear_velocity_w - state.linear_velocity_w) / h
    alpha_fd = rot @ (sim.state.angular_velocity_b - state.angular_velocity_b) / h
    # Cancellation error of the difference: ~1e-16 · |v| / h ≈ 1e-9 for |v|, |ω| ~ 2.
    assert np.allclose(a_fd, a_w, rtol=0.0, atol=1e-8)
    assert np.allclose(alpha_fd, alpha_w, rtol=0.0, atol=1e-8)
    assert np.linalg.norm(alpha_w) > 0.1 and np.linalg.norm(a_w) > 1.0
