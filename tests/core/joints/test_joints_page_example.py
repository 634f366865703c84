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

"""The joints page's example runs as printed and does what its comments promise."""

import math
import pathlib
import re

PAGE = pathlib.Path(__file__).resolve().parents[3] / 'doc' / 'joints.md'


def joints_example():
    """Return the first Python block of doc/joints.md."""
    return re.search(r'```python\n(.*?)```', PAGE.read_text(encoding='utf-8'), re.S).group(1)


def test_the_joints_page_example_reaches_its_target_critically_damped_with_no_sag():
    namespace = {}
    exec(compile(joints_example(), 'doc/joints.md', 'exec'), namespace)  # noqa: S102
    sim = namespace['sim']
    assert sim.time_ns == 1_000_000_000
    # The target 0.5 rad from rest at 0 with time constant 0.1 s (omega = 10 /s): the exact
    # critically damped response e(t) = e0 (1 + omega t) exp(-omega t), e0 = -0.5 rad, at
    # t = 1 s. RK4 follows the row to ~1e-10 rad (tests/core/joints/test_articulated.py
    # measures 7e-11); gravity must not bend it (no sag), so 1e-9 rad bounds both.
    expected = 0.5 - 0.5 * (1.0 + 10.0) * math.exp(-10.0)
    angle = float(sim.joint_positions()[0][0])
    assert abs(angle - expected) <= 1e-9, (angle, expected)
    # Under its effort limit: gravity on the rod, m g (L/2) sin(angle), well below 20 N m.
    effort = float(sim.joint_efforts()[0])
    assert abs(effort) < 20.0 and not sim.motor_saturated()[0], effort
    distance_m, angle_rad = sim.joint_error()
    assert distance_m <= 1e-12 and angle_rad <= 1e-12  # the bound, after every step
