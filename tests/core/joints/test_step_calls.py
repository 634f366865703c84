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

"""The simulator's cheap calls (kernels' machine code, plain-float rates): the same bits."""

import math

import numpy as np
import pytest

from rbd_ros.core import ConfigError
from rbd_ros.core.joints import ArticulatedSimulator
from rbd_ros.core.joints import kernels as jk
from rbd_ros.core.joints.simulator import joint_error, PROJECTION_MAX_ITER, PROJECTION_TOL
from tests.core.joints.test_articulated import hanging_arm

STEP_NS = 1_000_000
CHUNKS = (1, 7, 30, 1)   # steps a call: the node's one a step (a trajectory) and its chunks


def _arm():
    return ArticulatedSimulator(*hanging_arm(3, effort_limit=50.0), timestep_ns=STEP_NS)


def test_steps_and_motors_give_the_bits_of_numbas_dispatcher(monkeypatch):
    ours, twin = _arm(), _arm()
    model, work = twin.kernel_arrays()
    x = twin._x   # the twin's state, stepped here through the dispatchers as before

    targets = [(0, {'position': 0.6, 'time_constant_s': 0.05}), (2, {'effort': -1.5})]
    ours.set_motors(targets)
    twin.set_motors(targets, refresh=False)
    jk.refresh_dynamics(model, x, work)   # through the dispatcher
    time_ns = 0
    for n in CHUNKS:
        ours.step(n)
        work.stats[jk.S_TIME] = work.stats[jk.S_TSTAGE] = time_ns * 1e-9
        assert jk.step(model, x, work, STEP_NS * 1e-9, n, PROJECTION_TOL,
                       PROJECTION_MAX_ITER) == 0
        time_ns += n * STEP_NS
        # the same machine code on the same arrays: equal bits, not close values
        assert ours.state_rows() == x.tolist()
        assert ours.constraint_wrenches_w() == work.wrench[:3].tolist()
        assert ours.joint_efforts().tolist() == twin.joint_efforts().tolist()

    # typed once a simulator: later calls do not go through the dispatcher at all
    def through_the_dispatcher(*args):
        raise AssertionError('the dispatcher was called')
    monkeypatch.setattr(jk, 'step', through_the_dispatcher)
    monkeypatch.setattr(jk, 'refresh_dynamics', through_the_dispatcher)
    ours.step(3)
    ours.set_motor(1, velocity=0.2)
    assert ours.time_ns == (sum(CHUNKS) + 3) * STEP_NS


def test_reference_rates_as_plain_floats_or_any_sequence_give_the_same_bits():
    # a trajectory's rates, set at every step, are taken as floats without numpy; any other
    # sequence goes through the one vector rule: the same numbers either way
    runs = []
    for rates in ((0.7, -1.25), np.array([0.7, -1.25]), [np.float64(0.7), -1.25]):
        sim = _arm()
        for _ in range(5):
            sim.set_motor(0, position=0.2, time_constant_s=0.05, reference_rates=rates)
            sim.step(1)
        runs.append(sim.state_rows())
    assert runs[0] == runs[1] == runs[2]


@pytest.mark.parametrize('rates, message', [
    ((math.nan, 0.0), r"joint 'j0'.reference_rates: \[nan, 0.0\] rad/s and rad/s² must be "
                      'finite'),
    ((1.0,), "joint 'j0'.reference_rates: expected 2 numbers in rad/s and rad/s²"),
    (('fast', 0.0), "joint 'j0'.reference_rates: expected 2 numbers in rad/s and rad/s²"),
])
def test_bad_reference_rates_are_refused_naming_the_field(rates, message):
    sim = _arm()
    with pytest.raises(ConfigError, match=message):
        sim.set_motor(0, position=0.2, time_constant_s=0.05, reference_rates=rates)


def test_joint_error_through_the_machine_code_is_the_dispatchers():
    sim = _arm()
    sim.set_motor(1, velocity=3.0)
    sim.step(20)
    model, work = sim.kernel_arrays()
    ours = sim.joint_error()
    assert ours == joint_error(model, work, sim._x)   # rows through numba's dispatcher
    # plain floats, within the bound (1e-12 m and rad after every step)
    assert all(type(v) is float for v in ours) and max(ours) <= 1e-12
