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
Wrench inputs through real DDS: the sim-time hold timeout, and rejection of bad wrenches.

One paused node with ``wrench_timeout_s = 0.05`` and h = 10 ms: a wrench acts for exactly the
5 steps that start before ``t_effect + 0.05 s``. Velocities are compared with ``F · 5h / m`` to
1e-12 m/s: the kicks add ``F h / m`` exactly in exact arithmetic, so only round-off of a few
additions (~1e-16) remains; losing or gaining one step would be off by 5e-3 m/s.
"""

import math

from conftest import NodeProcess
import numpy as np
import pytest
from ros_probe import Probe, step_until_moving

H_NS = 10_000_000
MASS_KG = 0.5
PARAMS = {
    'mass_kg': MASS_KG, 'timestep_s': 0.01, 'publish_rate_hz': 100.0, 'start_paused': True,
    'wrench_timeout_s': 0.05, 'max_force_n': 100.0, 'max_torque_nm': 10.0,
}


@pytest.fixture(scope='module')
def rig(module_tmp):
    node = NodeProcess(module_tmp, PARAMS, namespace=True)
    probe = Probe(node.namespace)
    probe.wait_connected()
    yield node, probe
    probe.close()
    assert node.stop() == 0, node.stderr


def velocity(probe, t):
    v = probe.samples['twist'][t].twist.linear
    return np.array([v.x, v.y, v.z])


def test_hold_timeout_zeroes_the_wrench_after_its_sim_time(rig):
    _, probe = rig
    probe.reset()
    force_n = 2.0
    probe.publish('wrench', 'world', (force_n, 0.0, 0.0))
    t0, _ = step_until_moving(probe)
    t_end = probe.step(20)
    expected = force_n * 5 * H_NS * 1e-9 / MASS_KG  # 5 steps of F h / m
    for stamp in sorted(probe.samples['twist']):
        if stamp >= t0 + 5 * H_NS:  # from the end of the 5th step on: constant
            assert velocity(probe, stamp)[0] == pytest.approx(expected, abs=1e-12), stamp
        elif stamp >= t0:  # growing by F h / m per step until then
            ramp = force_n * (stamp - t0) * 1e-9 / MASS_KG
            assert velocity(probe, stamp)[0] == pytest.approx(ramp, abs=1e-12), stamp
    assert t_end >= t0 + 20 * H_NS


def counts(values):
    return {key: int(value) for key, value in values.items()
            if key.startswith('wrenches_')}


def test_bad_wrenches_are_rejected_counted_and_the_state_stays_finite(rig):
    node, probe = rig
    probe.reset()
    # Counters from a /diagnostics sent after the last test's wrench was counted (the newest
    # one received could predate it: 1 Hz, and a loaded CI run saw that).
    before = probe.settled_wrench_counters()
    t_start = probe.step()
    bad = [
        ('odom', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)),  # a frame that is neither body nor world
        ('world', (math.nan, 0.0, 0.0), (0.0, 0.0, 0.0)),
        ('', (0.0, 0.0, 0.0), (0.0, math.inf, 0.0)),
        ('world', (0.0, 0.0, 1e3), (0.0, 0.0, 0.0)),  # |f| = 1000 N > max_force_n = 100 N
        ('base_link', (0.0, 0.0, 0.0), (20.0, 0.0, 0.0)),  # 20 N·m > max_torque_nm = 10 N·m
        ('world', (0.0, 0.0, 1e308), (0.0, 0.0, 1e308)),  # finite but absurd
    ]
    for frame_id, force, torque in bad:
        probe.publish('wrench', frame_id, force, torque)
    expected = dict(before)
    for key, n in (('wrenches_received', 6), ('wrenches_rejected', 6),
                   ('wrenches_rejected_frame', 1), ('wrenches_rejected_non_finite', 2),
                   ('wrenches_rejected_force_limit', 2), ('wrenches_rejected_torque_limit', 1)):
        expected[key] = before[key] + n
    probe.diagnostic_values(lambda v: counts(v) == expected)
    t_end = probe.step(5)
    for t in (t_start, t_end):
        pose = probe.samples['pose'][t].pose
        values = [pose.position.x, pose.position.y, pose.position.z, pose.orientation.w]
        assert all(math.isfinite(v) for v in values)
        assert np.array_equal(velocity(probe, t), [0.0, 0.0, 0.0])
        assert [pose.position.x, pose.position.y, pose.position.z] == [0.0, 0.0, 0.0]
    # A throttled warning says why (at least the first one within the throttle period).
    assert 'wrench rejected (frame)' in node.stderr
