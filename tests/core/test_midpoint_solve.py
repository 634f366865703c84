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
The implicit midpoint solve of ``midpoint_cayley`` at large ``h|ω|``: converged or refused.

The solve ``m = Π + (h/2) m × I⁻¹m`` converges to round-off for moderate rotations per step; at
``h|ω|`` of a few radians its fixed-point start diverges and Newton may not recover. Such a
step must be refused with a :class:`ConvergenceError` that names ``h|ω|`` and what to change,
never accepted as a wrong (energy-violating) state, nor reported as "forces or velocities too
large".
"""

import numpy as np
import pytest

from rbd_ros.core import (BatchSimulator, BodyModel, BodyState, ConvergenceError,
                          NonFiniteError, Simulator)
from rbd_ros.core.simulator import MIDPOINT_SAFE_ROTATION_RAD

T_HANDLE = BodyModel(0.3, np.diag([0.0010, 0.0030, 0.0038]))
# A converged solve keeps |Π|² and ΠᵀI⁻¹Π (twice the kinetic energy) to round-off: each is a
# sum of three squares recomputed from a state carrying ~1 ulp per component, amplified by at
# most ~h|ω| ≲ 10 in the solve: ~1e-14 relative (measured ≤ 4e-15). 1e-12 leaves room; an
# unconverged step is off by O(1) or more.
INVARIANT_RTOL = 1e-12


def _random_model(rng):
    """Return a 1 kg body with random principal moments (triangle inequality) and axes."""
    while True:
        moments = np.sort(rng.uniform(0.01, 1.0, size=3))
        if moments[0] + moments[1] >= moments[2]:
            break
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return BodyModel(1.0, q @ np.diag(moments) @ q.T)


def _invariants(model, omega_b):
    momentum = model.inertia_b @ omega_b
    return np.array([momentum @ momentum, omega_b @ momentum])


def test_a_step_whose_solve_does_not_converge_is_refused_and_says_why():
    # The case: h|ω| ≈ 10 (10 rad/s about the T-handle's intermediate axis, 1 s step).
    start = BodyState(angular_velocity_b=(0.1, 10.0, 0.2))
    sim = Simulator(T_HANDLE, start, integrator='midpoint_cayley', timestep_ns=1_000_000_000)
    with pytest.raises(ConvergenceError) as info:
        sim.step()
    message = str(info.value)
    print(f'\n{message}')
    assert isinstance(info.value, NonFiniteError)   # every NonFiniteError handler applies
    assert '\n' not in message
    assert 'did not converge' in message and 'too large' not in message
    speed = float(np.linalg.norm(start.angular_velocity_b))
    assert f'h|ω| = {1.0 * speed:.3g} rad' in message
    assert f'|ω| = {speed:.3g} rad/s' in message and 'h = 1000000000 ns' in message
    assert 'smaller timestep_s' in message and 'rk4' in message
    assert f'< {MIDPOINT_SAFE_ROTATION_RAD / speed:.3g} s' in message
    # Refused: the state and the time stay where they were.
    assert sim.state == start and sim.time_ns == 0
    # What the message advises works: the same spin at h|ω| = 0.5 rad steps fine.
    smaller = Simulator(T_HANDLE, start, integrator='midpoint_cayley', timestep_ns=50_000_000)
    smaller.step(20)
    assert smaller.time_ns == 1_000_000_000


def test_a_batch_names_the_bodies_whose_solve_failed():
    slow = BodyState(angular_velocity_b=(0.1, 1.0, 0.2))     # h|ω| ≈ 1: converges
    fast = BodyState(angular_velocity_b=(0.1, 10.0, 0.2))    # h|ω| ≈ 10: does not
    batch = BatchSimulator(T_HANDLE, [slow, fast, slow, fast], timestep_ns=1_000_000_000)
    with pytest.raises(ConvergenceError, match=r'body\(ies\) \[1, 3\]'):
        batch.step()
    assert batch.times_ns.tolist() == [1_000_000_000, 0, 1_000_000_000, 0]


@pytest.mark.parametrize('rotation_rad', [0.5, 1.0, 1.9, 3.0, 4.0, 5.0, 6.0, 8.0, 10.0])
def test_a_step_is_either_converged_to_round_off_or_refused(rotation_rad):
    # Random inertias and spin axes at a given h|ω|: every accepted step keeps both quadratic
    # invariants (so its solve converged); every other step is refused as a ConvergenceError.
    # Below MIDPOINT_SAFE_ROTATION_RAD none may be refused (the documented limit).
    rng = np.random.default_rng(round(100 * rotation_rad))
    refused = 0
    for _ in range(60):
        model = _random_model(rng)
        omega_b = rng.normal(size=3)
        omega_b *= 10.0 / np.linalg.norm(omega_b)
        dt_ns = round(rotation_rad / 10.0 * 1e9)
        sim = Simulator(model, BodyState(angular_velocity_b=omega_b), timestep_ns=dt_ns)
        try:
            sim.step()
        except ConvergenceError as exc:
            assert 'h|ω| = ' in str(exc)
            assert sim.time_ns == 0
            refused += 1
            continue
        before = _invariants(model, omega_b)
        after = _invariants(model, sim.state.angular_velocity_b)
        assert np.allclose(after, before, rtol=INVARIANT_RTOL, atol=0.0), (
            f'accepted a step that broke the invariants at h|ω| = {rotation_rad} rad: '
            f'{before} -> {after}')
    print(f'\nh|ω| = {rotation_rad} rad: {refused} of 60 steps refused')
    if rotation_rad < MIDPOINT_SAFE_ROTATION_RAD:
        assert refused == 0


def test_a_spinning_cube_is_never_refused_on_round_off():
    # An isotropic body: ω × Iω = 0, so the exact flow keeps ω constant and the solve's answer
    # is ω itself, at any h|ω|. The cross product the solve evaluates is then round-off of its
    # terms, h/2 |Π| |ω|, which h|ω| = 550 rad (a 2 kg 0.2 m cube spun by a 1e6 N m torque)
    # makes ~280 ulp of |Π|: a convergence test against |Π| alone refused 88 of these 200
    # spins. Each must be taken, ω kept to that round-off: ~h|ω| ulp of |ω| a step, 5 steps,
    # ~1e-12 of |ω| at most (measured 1.6e-13); 1e-11 leaves room; an unconverged step is O(1).
    moment = 2.0 / 6.0 * 0.2 ** 2
    cube = BodyModel(2.0, np.eye(3) * moment)
    rng = np.random.default_rng(1)
    for _ in range(200):
        omega_b = rng.normal(size=3)
        omega_b *= 5.5e5 / np.linalg.norm(omega_b)
        sim = Simulator(cube, BodyState(angular_velocity_b=omega_b), timestep_ns=1_000_000)
        sim.step(5)
        drift = np.linalg.norm(sim.state.angular_velocity_b - omega_b) / np.linalg.norm(omega_b)
        assert drift < 1e-11, drift
        assert abs(np.linalg.norm(sim.state.orientation_wb) - 1.0) < 1e-12
