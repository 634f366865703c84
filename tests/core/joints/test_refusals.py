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

"""A step the articulated core cannot take is refused and the state stays finite (the rule)."""

import numpy as np
import pytest
from rbd_ros.core import BodyModel, BodyState, NonFiniteError
from rbd_ros.core.joints import ArticulatedSimulator, Joint


def _pendulum():
    rod = BodyModel(1.0, np.diag([1 / 12, 1 / 12, 1e-3]), gravity_w=(0.0, 0.0, -9.81))
    hinge = Joint('pivot', 'revolute', None, 0, origin_child_b=(0.0, 0.0, 0.5),
                  axis_b=(0.0, 1.0, 0.0))
    return ArticulatedSimulator([rod], [BodyState(position_w=(0.0, 0.0, -0.5))], [hinge])


def _column(sim):
    return np.concatenate([np.concatenate((s.position_w, s.orientation_wb, s.linear_velocity_w,
                                           s.angular_velocity_b)) for s in sim.states])


def test_an_effort_that_overflows_the_state_is_refused_and_the_state_stays_finite():
    sim = _pendulum()
    sim.step(10)
    before, t_before = _column(sim), sim.time_ns
    sim.set_motor(0, effort=1e308)  # finite, no effort limit: the step overflows
    with pytest.raises(NonFiniteError):  # ConvergenceError is one too
        sim.step(5)
    # Refused at the first step of the call: the state and time are those it started from.
    assert sim.time_ns == t_before
    assert np.array_equal(_column(sim), before)
    # And the simulator goes on once the effort is taken away.
    sim.set_motor(0, effort=0.0)
    sim.step(10)
    assert sim.time_ns == t_before + 10 * sim.timestep_ns
    assert np.isfinite(_column(sim)).all()
    distance_m, angle_rad = sim.joint_error()
    assert distance_m <= 1e-12 and angle_rad <= 1e-12
