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

"""The simulator calls its kernels' machine code directly: the bits of a dispatcher's call."""

from rbd_ros.core.joints import ArticulatedSimulator
from rbd_ros.core.joints import kernels as jk
from rbd_ros.core.joints.simulator import PROJECTION_MAX_ITER, PROJECTION_TOL
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
