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
The contact step is separable: a group of bodies steps to the same bits beside any other.

Each island of a stage's contact graph is solved alone (``sweeps.solve_islands``): its sweeps
stop when its own points converge, its warm start and cold retry are its own, its patches
are coupled or not by themselves.  Before, the sweeps of every patch of the world ran until
the slowest island converged and one stack anywhere made every lone box's patch "coupled"
(per-point friction, warm start): a 5-box column stepped beside a pyramid 10 m away differed
from the column alone by 1e-12 m after 9 steps, a lone box beside a column after 7.  So each
scene here steps a group ``A`` alone and ``A`` with a group ``B`` far away, and requires every
state and contact-wrench bit of ``A`` (and of ``B``) to be the same at every step.
"""

from contact_scenes import body, ground, STEP_IDS, steps, STEPS_NS, world
import numpy as np
import pytest
from rbd_ros.core.state import BodyState

SIDE_M = 0.2
FAR_M = 10.0


def column(count, x_m=0.0):
    return [(x_m, 0.0, SIDE_M * (i + 0.5)) for i in range(count)]


def pyramid(layers, x_m=0.0, gap_m=0.02):
    pitch = SIDE_M + gap_m
    out = []
    for layer in range(layers):
        count = layers - layer
        x0 = x_m - 0.5 * (count - 1) * pitch
        out += [(x0 + i * pitch, 0.0, SIDE_M * (layer + 0.5)) for i in range(count)]
    return out


def boxes(centres, first=0, velocity_w=(0.0, 0.0, 0.0)):
    bodies = [body(f'b{first + i}', 'box', [SIDE_M] * 3) for i in range(len(centres))]
    states = [BodyState(position_w=c, linear_velocity_w=velocity_w) for c in centres]
    return bodies, states


SCENES = {
    # two coupled islands that converge in different numbers of sweeps
    'column_beside_pyramid': (column(5), pyramid(4, FAR_M)),
    # an uncoupled patch (one box on the floor) beside a coupled island
    'lone_box_beside_column': ([(0.0, 0.0, 0.1)], column(5, FAR_M)),
    # a column beside a box that falls and lands on the floor (its patch appears mid-run)
    'column_beside_falling_box': (column(5), [(FAR_M, 0.0, 0.5)]),
}


def _run(groups, h_ns, count, moving=None):
    """Step the world of ``groups`` (lists of centres); return per step (x, wrench) copies."""
    bodies, states = [], []
    for k, centres in enumerate(groups):
        velocity = moving if (moving is not None and k == 0) else (0.0, 0.0, 0.0)
        b, s = boxes(centres, len(bodies), velocity)
        bodies += b
        states += s
    sim = world(bodies, states, ground(), h_ns)
    out = []
    for _ in range(count):
        sim.step(1)
        x, _ = sim.arrays
        out.append((x.copy(), sim.contact_wrench_w))
    return out


def _bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
@pytest.mark.parametrize('scene', sorted(SCENES))
def test_a_group_steps_to_the_same_bits_beside_another(scene, h_ns):
    group_a, group_b = SCENES[scene]
    count = steps(0.5, h_ns)
    alone_a = _run([group_a], h_ns, count)
    alone_b = _run([group_b], h_ns, count)
    both = _run([group_a, group_b], h_ns, count)
    na = len(group_a)
    for k, ((xa, wa), (xb, wb), (x, w)) in enumerate(zip(alone_a, alone_b, both)):
        assert np.array_equal(_bits(x[:, :na]), _bits(xa)), f'A differs at step {k + 1}'
        assert np.array_equal(_bits(x[:, na:]), _bits(xb)), f'B differs at step {k + 1}'
        assert np.array_equal(_bits(w[:na]), _bits(wa)), f'A wrench differs at step {k + 1}'
        assert np.array_equal(_bits(w[na:]), _bits(wb)), f'B wrench differs at step {k + 1}'
    # The scenes are not trivial: A's bodies carry weight through contact at the end.
    assert np.abs(both[-1][1][:, 2]).max() > 1.0


def test_a_sliding_box_stops_the_same_beside_a_column():
    """A box sliding to a stop (per-patch friction) is not turned per-point by a stack."""
    h_ns = 1_000_000
    count = steps(0.5, h_ns)
    alone = _run([[(0.0, 0.0, 0.1)]], h_ns, count, moving=(1.0, 0.0, 0.0))
    both = _run([[(0.0, 0.0, 0.1)], column(5, FAR_M)], h_ns, count, moving=(1.0, 0.0, 0.0))
    for k, ((xa, _), (x, _)) in enumerate(zip(alone, both)):
        assert np.array_equal(_bits(x[:, :1]), _bits(xa)), f'the box differs at step {k + 1}'
    assert alone[-1][0][0, 0] > 0.05   # it slid
