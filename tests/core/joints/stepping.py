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

"""Stepping a jointed contact world with the joints checked after every step."""

import numpy as np

#: The joints' error allowed after every step (m, rad): the issue's bound (the step's own is
#: ``PROJECTION_TOL = 1e-13`` per row; a distance over three rows is up to √3 of it).
JOINT_TOL = 1e-12


def run_checked(sim, n, each=None):
    """Step ``n`` times, checking the joints after every step; return the worst error."""
    worst = 0.0
    for k in range(n):
        sim.step()
        worst = max(worst, *sim.joint_error())
        if each is not None:
            each(k)
    assert worst <= JOINT_TOL, worst
    return worst


def momentum(sim):
    """Return a world's ``(P, L)``: linear (kg m/s), angular about the origin (kg m²/s)."""
    lin, ang = np.zeros(3), np.zeros(3)
    for i, body in enumerate(sim.bodies):
        s = sim.body_state(i)
        p = s.linear_momentum_w(body.model)
        lin += p
        ang += np.cross(s.position_w, p) + s.angular_momentum_w(body.model)
    return lin, ang
