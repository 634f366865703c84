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
Observed order of convergence of every integrator, measured, not assumed.

Smooth test problem: an asymmetric body (``I = diag(1, 2, 3)`` kg·m²) tumbling at
``|ω| ≈ 1.3`` rad/s under gravity, a constant world force and a constant body torque, for 1 s.
Reference: RK4 at 0.1 ms (10 000 steps), whose own error (~1e-8 · (0.1/40)⁴ ≈ 4e-19 from
truncation, ~2e-12 from round-off, measured against RK4 at 0.05 ms) is at least 80× below the
smallest error used in a ratio below.

The error is the largest of the position, velocity and angular velocity component errors and
the orientation angle error. The observed order between ``h`` and ``h/2`` is
``log2(e(h) / e(h/2))``; it equals the method's order up to the next term of the error
expansion, a relative ``O(h|ω|) ≲ 0.05`` at the steps used here, so each observed order must be
within ±0.1 of the nominal one (ratio bands 1.87–2.14 for order 1, 3.73–4.29 for order 2,
14.9–17.1 for order 4).
"""

import math

import numpy as np
import pytest

from rbd_ros.core import AppliedWrench, BodyModel, BodyState, INTEGRATORS, Simulator
from rbd_ros.core.rotations import quat_angle_between, quat_from_axis_angle

MODEL = BodyModel(2.0, np.diag([1.0, 2.0, 3.0]), gravity_w=(0.0, 0.0, -9.81))
START = BodyState(position_w=(0.1, 0.2, 0.3), orientation_wb=quat_from_axis_angle((1, 2, 3), 0.7),
                  linear_velocity_w=(1.0, 0.0, 0.5), angular_velocity_b=(1.0, 0.5, -0.7))
LOADS = [AppliedWrench(force=(1.0, 2.0, -1.0), frame='world'),
         AppliedWrench(torque=(0.3, -0.2, 0.4), frame='body')]
DURATION_NS = 1_000_000_000
# Step sizes (ns) per nominal order: errors well above the reference's 2e-12 and in the
# asymptotic regime.
STEPS_NS = {1: (10_000_000, 5_000_000, 2_500_000),
            2: (20_000_000, 10_000_000, 5_000_000),
            4: (40_000_000, 20_000_000, 10_000_000)}
NOMINAL_ORDER = {'rk4': 4, 'midpoint_cayley': 2}


def _run(integrator, dt_ns):
    sim = Simulator(MODEL, START, integrator=integrator, timestep_ns=dt_ns)
    sim.set_loads(LOADS)
    sim.step(DURATION_NS // dt_ns)
    assert sim.time_ns == DURATION_NS
    return sim.state


def _rotation_error(state, reference):
    return max(np.abs(state.angular_velocity_b - reference.angular_velocity_b).max(),
               float(quat_angle_between(state.orientation_wb, reference.orientation_wb)))


def _error(state, reference):
    return max(np.abs(state.position_w - reference.position_w).max(),
               np.abs(state.linear_velocity_w - reference.linear_velocity_w).max(),
               _rotation_error(state, reference))


@pytest.fixture(scope='module')
def reference():
    fine = _run('rk4', 100_000)
    finer = _run('rk4', 50_000)
    # The reference is good to round-off (the claim in the module docstring).
    assert _error(fine, finer) < 1e-11
    return fine


@pytest.mark.parametrize('part', ['whole state', 'rotation only'])
@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_observed_order(integrator, part, reference):
    # 'rotation only' (ω_b and the orientation angle) isolates each orientation update; the
    # whole-state error of the SE variants is dominated by the translation's a h t / 2.
    order = NOMINAL_ORDER.get(integrator, 1)
    measure = _error if part == 'whole state' else _rotation_error
    errors = [measure(_run(integrator, dt_ns), reference) for dt_ns in STEPS_NS[order]]
    observed = [math.log2(errors[k] / errors[k + 1]) for k in range(len(errors) - 1)]
    print(f'\n{integrator} ({part}): errors {", ".join(f"{e:.3e}" for e in errors)} at h = '
          f'{", ".join(f"{h / 1e6:g}" for h in STEPS_NS[order])} ms; observed orders '
          f'{", ".join(f"{p:.3f}" for p in observed)} (ratios '
          f'{", ".join(f"{2.0 ** p:.2f}" for p in observed)})')
    assert errors[-1] > 50.0 * 2e-12   # resolvable above the reference's round-off
    for p in observed:
        assert abs(p - order) <= 0.1
