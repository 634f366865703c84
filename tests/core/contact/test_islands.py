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

A body alone in its island has a lone patch (friction per patch) where a stack beside it made
it coupled (friction per point): the striker of ``msg_config/stack.yaml`` flung to 1e303 m/s
by a drag went non-finite once its patch centre, in world coordinates, was an ulp (1e285 m)
off the box.  The last two tests step it, in the stack and alone, and require it finite.
"""

from contact_scenes import body, ground, STEP_IDS, steps, STEPS_NS, world
import numpy as np
import pytest
from rbd_ros.core.errors import NonFiniteError
from rbd_ros.core.loads import Spring
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


# Groups 0.6 m apart (0.4 m gaps: none reaches another in 0.5 s), each an island or several: a
# column of three, a box falling onto the floor, a box sliding to a stop (1 m/s: 0.10 m at
# mu 0.5), a box falling onto a column of two (its patch joins their island mid-run).
PARTS_GROUPS = (
    [((0.0, 0.0, SIDE_M * (i + 0.5)), (0.0, 0.0, 0.0)) for i in range(3)],
    [((0.6, 0.0, 0.3), (0.0, 0.0, 0.0))],
    [((0.0, 0.6, 0.1), (1.0, 0.0, 0.0))],
    [((0.6, 0.6, SIDE_M * (i + 0.5)), (0.0, 0.0, 0.0)) for i in range(2)]
    + [((0.62, 0.6, 0.55), (0.0, 0.0, -1.0))],
)


def _interleaved():
    """Return the groups' bodies taken round-robin: ``[(group, centre, velocity)]``."""
    queues = [list(group) for group in PARTS_GROUPS]
    out = []
    while any(queues):
        for g, queue in enumerate(queues):
            if queue:
                out.append((g, *queue.pop(0)))
    return out


def _contact_rows(sim, index):
    """Return the last step's contact rows, body indices mapped through ``index``, as bits."""
    c = sim.contacts
    b = np.where(c.body_b >= 0, index[np.maximum(c.body_b, 0)], c.body_b)
    return np.column_stack([c.stage, index[c.body_a], b]), np.column_stack(
        [c.point_w, c.normal_w, c.impulse_w])


@pytest.mark.parametrize('h_ns', STEPS_NS, ids=STEP_IDS)
def test_a_world_steps_to_the_bits_of_its_interleaved_parts(h_ns):
    # What stepping islands on threads rests on (issue 29 item 2): a world whose groups never
    # meet steps to the bits of its parts stepped as worlds of their own, even with the parts'
    # bodies interleaved in the world's order, and its contact rows are the parts' rows put in
    # the order of the world's pairs: by stage, body pairs before body-static pairs, then by
    # (a, b) (the broad phase's order), each pair's points in their order (a stable sort).
    bodies_all = _interleaved()
    parts = [np.array([k for k, (g, _, _) in enumerate(bodies_all) if g in members])
             for members in ((0, 3), (1, 2))]
    assert list(parts[1]) == [1, 2] and parts[0][1] == 3   # interleaved in the world's order

    def make(index):
        picked = [bodies_all[k] for k in index]
        bodies = [body(f'b{k}', 'box', [SIDE_M] * 3) for k in index]
        states = [BodyState(position_w=c, linear_velocity_w=v) for _, c, v in picked]
        return world(bodies, states, ground(), h_ns)

    whole = make(np.arange(len(bodies_all)))
    subs = [make(index) for index in parts]
    for k in range(steps(0.5, h_ns)):
        for sim in (whole, *subs):
            sim.step(1)
        x = np.empty_like(whole.arrays[0])
        wrench = np.empty_like(whole.contact_wrench_w)
        keys, values = [], []
        for index, sim in zip(parts, subs):
            x[:, index] = sim.arrays[0]
            wrench[index] = sim.contact_wrench_w
            key, value = _contact_rows(sim, index)
            keys.append(key)
            values.append(value)
        key, value = np.concatenate(keys), np.concatenate(values)
        static = key[:, 2] < 0   # body B of a static object s is -1 - s
        order = np.lexsort((np.where(static, -1 - key[:, 2], key[:, 2]), key[:, 1], static,
                            key[:, 0]))
        whole_key, whole_value = _contact_rows(whole, np.arange(whole.size))
        assert np.array_equal(_bits(x), _bits(whole.arrays[0])), f'state differs at step {k + 1}'
        assert np.array_equal(_bits(wrench), _bits(whole.contact_wrench_w)), f'step {k + 1}'
        assert np.array_equal(key[order], whole_key), f'contact pairs differ at step {k + 1}'
        assert np.array_equal(_bits(value[order]), _bits(whole_value)), f'step {k + 1}'
    # Not trivial: body-body contacts (the columns, the landing box) and friction at the end,
    # and the slider slid.
    assert (whole_key[:, 2] >= 0).sum() > 0
    assert whole.body_state(int(parts[1][1])).position_w[0] > 0.05


def _striker_world():
    """Return stack.yaml's world: a column of three 1 kg boxes and a 2 kg striker 0.8 m away."""
    bodies, states = boxes(column(3))
    bodies.append(body('striker', 'box', [SIDE_M] * 3, mass_kg=2.0))
    states.append(BodyState(position_w=(-0.8, 0.0, 0.1)))
    return world(bodies, states, ground(), 1_000_000)


def _step_finite(sim, count):
    """Step ``sim`` ``count`` times one at a time, requiring every step finite."""
    for k in range(count):
        try:
            sim.step(1)
        except NonFiniteError as exc:
            raise AssertionError(f'step {k + 1} of {count} was not finite: {exc}') from exc
        assert np.all(np.isfinite(sim.arrays[0]))


def test_a_striker_flung_by_a_drag_goes_on_finite_once_the_drag_is_released():
    # The node's hard-push case, on the simulator: a 1e12 N/m drag on the 2 kg striker grows
    # its oscillation ~(h ω)² = 5e5 a step until a step would overflow (at ~53 ms); the drag
    # is then dropped (as the session releases it) and the striker, alone on the floor (a
    # lone patch: friction per patch), slides off at ~1e303 m/s.  Its patch centre in world
    # coordinates is off by an ulp, ~1e285 m: as its lever arm the friction went NaN 6 ms
    # later, where the serial step, solving it per point with the column, stayed finite.
    sim = _striker_world()
    sim.set_body_loads(3, springs=[Spring((0.0, 0.0, 0.0), (-0.8 + 1e-7, 0.0, 0.1), 1e12, 5.0)])
    with pytest.raises(NonFiniteError):
        sim.step(200)
    assert 40 * 1_000_000 < sim.time_ns < 200 * 1_000_000
    sim.set_body_loads(3)
    _step_finite(sim, 1000)
    assert abs(sim.body_state(3).linear_velocity_w[0]) > 1e290   # it did fly
    assert np.all(np.isfinite(sim.contact_wrench_w))


def test_a_box_sliding_at_1e303_m_s_1e300_m_out_stays_finite():
    # The striker of the test above at the step that went non-finite, alone: one point on the
    # floor, whose world coordinates round the patch centre an ulp (1e285 m) off the box.
    state = BodyState(
        position_w=(-8.0577885043813601e+300, 1.0969064312894512e+277, 0.12972260691939191),
        orientation_wb=(-0.35157329149617050, 0.41365012971498877, -0.82033127284921348,
                        -0.17985103190949703),
        linear_velocity_w=(-1.3429656460442343e+303, 1.8281786042730237e+279, 0.1),
        angular_velocity_b=(1.3179354636976957e+07, -1.4155414913353818e+07,
                            -1.3984459361417823e+07))
    sim = world([body('striker', 'box', [SIDE_M] * 3, mass_kg=2.0)],
                [BodyState(position_w=(0.0, 0.0, 0.1))], ground(), 1_000_000)
    sim.reset([state])   # 13 mm deep in the floor: past the constructor's overlap check
    _step_finite(sim, 100)
