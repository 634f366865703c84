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
Trajectory following as joint_trajectory_controller does it, against closed forms.

Every segment kind must meet its ends' values exactly (to round-off: the coefficients are
solved in closed form, so 1e-12 relative bounds the float error of a few dozen flops on values
of order 1), and the textbook profiles must come out: a linear segment's constant rate, a
cubic between rests' ``3s² − 2s³`` (peak rate ``1.5 Δ/T``), a quintic between rests'
``10s³ − 15s⁴ + 6s⁵`` (peak rate ``15/8 Δ/T``, zero acceleration at both ends).
"""

import numpy as np
import pytest

from rbd_ros.sim.trajectory import (CUBIC, LINEAR, parse_trajectory, QUINTIC,
                                    TrajectoryPoint, TrajectoryRejected)

S = 1_000_000_000
GROUP = ('shoulder', 'elbow')
TOL = 1e-12


def _parse(points, names=GROUP, stamp_ns=0, effect_ns=2 * S, q=(0.0, 0.0), qd=(0.0, 0.0)):
    return parse_trajectory('arm/joint_trajectory', GROUP, names, stamp_ns, points,
                            effect_ns, q, qd)


def test_linear_segments_have_constant_rate_and_hit_every_point():
    traj = _parse([TrajectoryPoint(S, (1.0, -2.0)), TrajectoryPoint(3 * S, (2.0, 0.0))])
    assert [traj.kind(i) for i in range(2)] == [LINEAR, LINEAR]
    for t_ns, q_want, qd_want in ((2 * S, (0, 0), (1, -2)), (2 * S + S // 2, (0.5, -1), (1, -2)),
                                  (3 * S, (1, -2), (0.5, 1)), (4 * S, (1.5, -1), (0.5, 1))):
        q, qd, qdd = traj.sample(t_ns)
        np.testing.assert_allclose(q, q_want, atol=TOL)
        np.testing.assert_allclose(qd, qd_want, atol=TOL)
        np.testing.assert_allclose(qdd, 0.0, atol=TOL)
    q, qd, qdd = traj.sample(10 * S)  # after the end: the last positions held
    np.testing.assert_allclose(q, (2.0, 0.0), atol=TOL)
    assert not qd.any() and not qdd.any()


def test_cubic_between_rests_is_the_smoothstep():
    delta, duration = 0.8, 2.0
    traj = _parse([TrajectoryPoint(2 * S, (delta, -delta), (0.0, 0.0))])
    assert traj.kind(0) == CUBIC
    for s in (0.0, 0.25, 0.5, 0.9, 1.0):
        q, qd, _ = traj.sample(2 * S + int(s * duration * S))
        np.testing.assert_allclose(q[0], delta * (3 * s ** 2 - 2 * s ** 3), atol=TOL)
        np.testing.assert_allclose(qd[0], delta * (6 * s - 6 * s ** 2) / duration, atol=TOL)
        np.testing.assert_allclose(q[1], -q[0], atol=TOL)
    _, qd_mid, _ = traj.sample(3 * S)
    np.testing.assert_allclose(qd_mid[0], 1.5 * delta / duration, atol=TOL)


def test_cubic_meets_given_velocities_at_the_points():
    traj = _parse([TrajectoryPoint(S, (1.0, 0.5), (2.0, -1.0)),
                   TrajectoryPoint(2 * S, (1.5, 0.0), (0.0, 0.0))], q=(0.2, 0.1), qd=(0.3, 0.0))
    for t_ns, q_want, qd_want in ((2 * S, (0.2, 0.1), (0.3, 0.0)),
                                  (3 * S, (1.0, 0.5), (2.0, -1.0)),
                                  (4 * S, (1.5, 0.0), (0.0, 0.0))):
        q, qd, _ = traj.sample(t_ns) if t_ns < 4 * S else traj.sample(t_ns - 1)
        np.testing.assert_allclose(q, q_want, atol=1e-8 if t_ns == 4 * S else TOL)
        np.testing.assert_allclose(qd, qd_want, atol=1e-8 if t_ns == 4 * S else TOL)


def test_quintic_between_rests_is_the_minimum_jerk_profile():
    delta, duration = 1.2, 0.5
    traj = _parse([TrajectoryPoint(S // 2, (delta, 0.0), (0.0, 0.0), (0.0, 0.0))])
    assert traj.kind(0) == QUINTIC
    for s in (0.0, 0.1, 0.5, 0.7):
        q, qd, qdd = traj.sample(2 * S + int(round(s * duration * S)))
        np.testing.assert_allclose(q[0], delta * (10 * s ** 3 - 15 * s ** 4 + 6 * s ** 5),
                                   atol=TOL)
        np.testing.assert_allclose(qd[0], delta * 30 * s ** 2 * (1 - s) ** 2 / duration,
                                   atol=TOL)
        np.testing.assert_allclose(qdd[0], delta * (60 * s - 180 * s ** 2 + 120 * s ** 3)
                                   / duration ** 2, atol=1e-10)
    _, qd_mid, qdd_mid = traj.sample(2 * S + S // 4)
    np.testing.assert_allclose(qd_mid[0], 15 / 8 * delta / duration, atol=TOL)
    np.testing.assert_allclose(qdd_mid[0], 0.0, atol=1e-10)


def test_quintic_meets_given_accelerations_at_both_ends():
    traj = _parse([TrajectoryPoint(S, (0.0, 0.0), (0.0, 0.0), (0.0, 0.0)),
                   TrajectoryPoint(2 * S, (1.0, 2.0), (0.5, 0.0), (-3.0, 4.0))])
    assert traj.kind(1) == QUINTIC
    _, _, qdd0 = traj.sample(3 * S)
    np.testing.assert_allclose(qdd0, 0.0, atol=1e-10)
    q, qd, qdd = traj.sample(4 * S - 1)  # 1 ns before the end: O(1e-9) away from the ends
    np.testing.assert_allclose(q, (1.0, 2.0), atol=1e-8)
    np.testing.assert_allclose(qd, (0.5, 0.0), atol=1e-7)
    np.testing.assert_allclose(qdd, (-3.0, 4.0), atol=1e-6)


def test_a_mix_falls_back_to_what_both_ends_give():
    traj = _parse([TrajectoryPoint(S, (1.0, 1.0), (0.0, 0.0), (0.0, 0.0)),
                   TrajectoryPoint(2 * S, (2.0, 2.0), (0.0, 0.0)),
                   TrajectoryPoint(3 * S, (3.0, 3.0))])
    assert [traj.kind(i) for i in range(3)] == [QUINTIC, CUBIC, LINEAR]


def test_joint_names_in_any_order_map_to_the_group_order():
    traj = _parse([TrajectoryPoint(0, (5.0, 7.0))], names=('elbow', 'shoulder'))
    q, _, _ = traj.sample(2 * S)
    np.testing.assert_allclose(q, (7.0, 5.0))


def test_a_stamp_starts_it_at_that_sim_time():
    traj = _parse([TrajectoryPoint(S, (1.0, 1.0))], stamp_ns=5 * S)
    assert traj.start_ns == 5 * S and traj.end_ns == 6 * S
    q, _, _ = traj.sample(4 * S)  # before the start: the start state held
    np.testing.assert_allclose(q, 0.0)
    q, _, _ = traj.sample(5 * S + S // 2)
    np.testing.assert_allclose(q, 0.5, atol=TOL)


@pytest.mark.parametrize('names, points, reason, words', [
    (GROUP, [], 'empty', 'points: empty'),
    (('shoulder', 'wrist'), [TrajectoryPoint(S, (0, 0))], 'unknown_joint',
     "joint_names[1]: 'wrist'"),
    (('shoulder', 'shoulder'), [TrajectoryPoint(S, (0, 0))], 'duplicate_joint', 'joint_names[1]'),
    (('shoulder',), [TrajectoryPoint(S, (0,))], 'missing_joint', "'elbow' is missing"),
    (GROUP, [TrajectoryPoint(S, (0.0,))], 'length', 'points[0].positions: 1 values for 2'),
    (GROUP, [TrajectoryPoint(S, (0, 0), (1, 2, 3))], 'length', 'points[0].velocities: 3'),
    (GROUP, [TrajectoryPoint(S, (0, 0), (), (1, 1))], 'length', 'velocities: empty while'),
    (GROUP, [TrajectoryPoint(S, (0, float('nan')))], 'non_finite', 'positions[1]: nan'),
    (GROUP, [TrajectoryPoint(S, (0, 0), (float('inf'), 0))], 'non_finite', 'velocities[0]: inf'),
    (GROUP, [TrajectoryPoint(-1, (0, 0))], 'time_order', 'time_from_start: -1 ns must be >= 0'),
    (GROUP, [TrajectoryPoint(S, (0, 0)), TrajectoryPoint(S, (1, 1))], 'time_order',
     'points[1].time_from_start: 1000000000 ns must be > points[0]'),
    (GROUP, [TrajectoryPoint(S, (0, 0), effort=(1, 1))], 'effort', 'points[0].effort'),
])
def test_bad_trajectories_are_refused_whole_naming_the_field(names, points, reason, words):
    with pytest.raises(TrajectoryRejected) as caught:
        _parse(points, names=names)
    assert caught.value.reason == reason
    assert str(caught.value).startswith('arm/joint_trajectory: ')
    assert words in str(caught.value)
    assert '\n' not in str(caught.value)
