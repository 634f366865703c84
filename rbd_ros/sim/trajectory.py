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
Joint trajectories followed in sim time as joint_trajectory_controller follows them (no rclpy).

A ``trajectory_msgs/JointTrajectory`` arrives as plain values (:func:`parse_trajectory`): joint
names, a start stamp and points, each with ``time_from_start``, positions and optionally
velocities and accelerations. It is checked whole, then :meth:`Trajectory.sample` gives the
reference ``(q, q̇, q̈)`` of every joint of the group at any sim time:

- **Start.** A zero ``header.stamp`` starts the trajectory when it takes effect (the start of
  the next step); a non-zero stamp is a sim time (the node's clock is sim time), which may lie
  in the past: points already passed are then skipped, as the controller does.
- **First segment** from the joints' state when the trajectory took effect (positions and
  velocities, zero acceleration) to the first point; a first point at ``time_from_start = 0``
  is reached at once.
- **Segments** between consecutive points are the controller's splines, chosen by what both
  ends give: positions only → **linear**; positions and velocities → **cubic** (Hermite);
  positions, velocities and accelerations → **quintic**. Each matches its ends' values exactly.
- **After the last point** the last positions are held (``q̇ = q̈ = 0``).
- **Limits.** Where a spline overshoots a joint limit between points within it, the node
  holds the reference at the limit (:func:`rbd_ros.sim.joint_commands.in_range`).

Rejected whole, with a reason (:data:`REJECT_REASONS`) and one line naming the field: no
points, a joint name that is not in the group or given twice, a group joint missing (the
controller's default ``allow_partial_joints_goal: false``), a positions, velocities or
accelerations array of the wrong length, accelerations without velocities, a non-finite
value, ``time_from_start`` negative or not strictly increasing, efforts (this follower commands
positions; an effort trajectory is not followed, so it is refused rather than ignored).
"""

import bisect
from dataclasses import dataclass
from typing import Sequence, Tuple

import numpy as np

from rbd_ros.sim.inputs import WrenchRejected

#: Rejection reasons, in the order they are checked.
REJECT_REASONS = ('empty', 'unknown_joint', 'duplicate_joint', 'missing_joint', 'length',
                  'non_finite', 'time_order', 'effort')
#: Segment kinds, by what both of its ends give.
LINEAR, CUBIC, QUINTIC = 1, 3, 5
_NS = 1e-9


class TrajectoryRejected(WrenchRejected):
    """A trajectory was rejected whole; :attr:`reason` is one of :data:`REJECT_REASONS`."""


@dataclass(frozen=True)
class TrajectoryPoint:
    """
    One point as received: ``time_from_start`` in int ns and the arrays (empty when absent).

    The order of the arrays is the message's ``joint_names`` order.
    """

    time_from_start_ns: int
    positions: Sequence[float] = ()
    velocities: Sequence[float] = ()
    accelerations: Sequence[float] = ()
    effort: Sequence[float] = ()


def _segment(kind, q0, v0, a0, q1, v1, a1, duration):
    """Return the polynomial coefficients (6, n_joints) of one segment, lowest power first."""
    n = q0.shape[0]
    c = np.zeros((6, n))
    c[0] = q0
    if kind == LINEAR:
        c[1] = (q1 - q0) / duration
        return c
    c[1] = v0
    d2, d3 = duration ** 2, duration ** 3
    if kind == CUBIC:
        c[2] = (3.0 * (q1 - q0) - (2.0 * v0 + v1) * duration) / d2
        c[3] = (2.0 * (q0 - q1) + (v0 + v1) * duration) / d3
        return c
    d4, d5 = d2 * d2, d2 * d3
    c[2] = 0.5 * a0
    c[3] = (20.0 * (q1 - q0) - (8.0 * v1 + 12.0 * v0) * duration
            - (3.0 * a0 - a1) * d2) / (2.0 * d3)
    c[4] = (30.0 * (q0 - q1) + (14.0 * v1 + 16.0 * v0) * duration
            + (3.0 * a0 - 2.0 * a1) * d2) / (2.0 * d4)
    c[5] = (12.0 * (q1 - q0) - 6.0 * (v1 + v0) * duration - (a0 - a1) * d2) / (2.0 * d5)
    return c


def _evaluate(c, s):
    """Return ``(q, q̇, q̈)`` of coefficients ``c`` at ``s`` seconds into the segment."""
    q = c[5]
    for k in range(4, -1, -1):
        q = q * s + c[k]
    qd = 5.0 * c[5]
    for k in range(4, 0, -1):
        qd = qd * s + k * c[k]
    qdd = 20.0 * c[5]
    for k in range(4, 1, -1):
        qdd = qdd * s + k * (k - 1) * c[k]
    return q, qd, qdd


class Trajectory:
    """
    A checked trajectory in the group's joint order, with absolute sim times.

    :ivar joint_names: the group's joints, the order of :meth:`sample`'s arrays.
    :ivar start_ns: sim time of ``time_from_start = 0``.
    :ivar times_ns: absolute sim time of each point (int ns).
    """

    def __init__(self, joint_names, start_ns, times_ns, knots, kinds):
        self.joint_names = tuple(joint_names)
        self.start_ns = int(start_ns)
        self.times_ns = tuple(int(t) for t in times_ns)
        self._knots = knots  # (n_points + 1) tuples (q, v, a): the start state, then the points
        self._kinds = kinds  # the kind of each of the n_points segments
        self._coefficients = {}

    @property
    def end_ns(self) -> int:
        """Return the sim time of the last point, after which its positions are held."""
        return self.times_ns[-1]

    def point_positions(self, point: int) -> np.ndarray:
        """Return the positions of point ``point`` in the group's order."""
        return self._knots[point + 1][0].copy()

    def kind(self, segment: int) -> int:
        """Return a segment's spline: :data:`LINEAR`, :data:`CUBIC` or :data:`QUINTIC`."""
        return self._kinds[segment]

    def _coefficients_of(self, i):
        if i not in self._coefficients:
            t0 = self.start_ns if i == 0 else self.times_ns[i - 1]
            (q0, v0, a0), (q1, v1, a1) = self._knots[i], self._knots[i + 1]
            kind = self._kinds[i]
            self._coefficients[i] = _segment(kind, q0, v0, a0, q1, v1, a1,
                                             (self.times_ns[i] - t0) * _NS)
        return self._coefficients[i]

    @property
    def knots(self):
        """Return the start state then each point, as ``(q, q̇, q̈)`` arrays (group order)."""
        return tuple(self._knots)

    def sample(self, time_ns: int) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """
        Return the reference ``(q, q̇, q̈)`` (rad or m, per s, per s²) at sim time ``time_ns``.

        Before the start: the start state held (zero rate); after the last point: its
        positions held.
        """
        n = len(self.joint_names)
        if time_ns >= self.end_ns:
            return self._knots[-1][0].copy(), np.zeros(n), np.zeros(n)
        if time_ns < self.start_ns:
            return self._knots[0][0].copy(), np.zeros(n), np.zeros(n)
        i = bisect.bisect_right(self.times_ns, time_ns)  # the first point after time_ns
        t0 = self.start_ns if i == 0 else self.times_ns[i - 1]
        return _evaluate(self._coefficients_of(i), (time_ns - t0) * _NS)


def _finite_array(topic, field, values, n):
    try:
        array = np.array([float(v) for v in values], dtype=np.float64)
    except (TypeError, ValueError):
        raise TrajectoryRejected('non_finite', f'{topic}: {field}: not numbers') from None
    if array.shape[0] != n:
        raise TrajectoryRejected('length', f'{topic}: {field}: {array.shape[0]} values for '
                                 f'{n} joints (one per joint_names entry)')
    bad = np.flatnonzero(~np.isfinite(array))
    if bad.size:
        raise TrajectoryRejected('non_finite', f'{topic}: {field}[{int(bad[0])}]: '
                                 f'{float(array[bad[0]])!r} is not finite')
    return array


def parse_trajectory(topic: str, group_joints: Sequence[str], joint_names: Sequence[str],
                     stamp_ns: int, points: Sequence[TrajectoryPoint], effect_ns: int,
                     state_q: Sequence[float], state_qd: Sequence[float]) -> Trajectory:
    """
    Check a received trajectory and return it as a :class:`Trajectory` of the group.

    :param topic: where it arrived, named in every rejection.
    :param group_joints: the joints the group commands, in its order.
    :param joint_names: the message's ``joint_names``.
    :param stamp_ns: ``header.stamp`` in ns (0: start at ``effect_ns``).
    :param points: the :class:`TrajectoryPoint` values.
    :param effect_ns: sim time the trajectory takes effect (the start of the next step).
    :param state_q: the group's joint positions at ``effect_ns`` (group order).
    :param state_qd: their velocities.
    :raises TrajectoryRejected: one line naming the field; :data:`REJECT_REASONS`.
    """
    if not points:
        raise TrajectoryRejected('empty', f'{topic}: points: empty; a trajectory needs at '
                                 'least one point')
    index = {name: k for k, name in enumerate(group_joints)}
    seen = {}
    for k, name in enumerate(joint_names):
        if name not in index:
            raise TrajectoryRejected('unknown_joint', f'{topic}: joint_names[{k}]: {name!r} '
                                     f'is not a joint of this group ({", ".join(group_joints)})')
        if name in seen:
            raise TrajectoryRejected('duplicate_joint', f'{topic}: joint_names[{k}]: {name!r} '
                                     f'is also joint_names[{seen[name]}]')
        seen[name] = k
    missing = [name for name in group_joints if name not in seen]
    if missing:
        raise TrajectoryRejected('missing_joint', f'{topic}: joint_names: {missing[0]!r} is '
                                 'missing; a trajectory must name every joint of the group')
    n = len(group_joints)
    order = np.array([seen[name] for name in group_joints], dtype=np.int64)
    q0 = np.array(state_q, dtype=np.float64)
    v0 = np.array(state_qd, dtype=np.float64)
    knots, kinds, times = [(q0, v0, np.zeros(n))], [], []
    start_ns = int(stamp_ns) if stamp_ns else int(effect_ns)
    previous = None
    given = [(True, True)]  # per knot: velocities, accelerations given
    for p, point in enumerate(points):
        where = f'points[{p}]'
        q = _finite_array(topic, f'{where}.positions', point.positions, n)[order]
        has_v, has_a = len(point.velocities) > 0, len(point.accelerations) > 0
        v = _finite_array(topic, f'{where}.velocities', point.velocities, n)[order] \
            if has_v else np.zeros(n)
        if has_a and not has_v:
            raise TrajectoryRejected('length', f'{topic}: {where}.velocities: empty while '
                                     'accelerations are given (a quintic needs both)')
        a = _finite_array(topic, f'{where}.accelerations', point.accelerations, n)[order] \
            if has_a else np.zeros(n)
        t = int(point.time_from_start_ns)
        if t < 0 or (previous is not None and t <= previous):
            rule = '>= 0' if t < 0 else f'> points[{p - 1}].time_from_start ({previous} ns)'
            raise TrajectoryRejected('time_order', f'{topic}: {where}.time_from_start: {t} ns '
                                     f'must be {rule}')
        if len(point.effort):
            raise TrajectoryRejected('effort', f'{topic}: {where}.effort: {len(point.effort)} '
                                     'values; this follower commands positions, so efforts are '
                                     'refused rather than ignored')
        previous = t
        # The start state gives all three, so the first segment is what the first point gives.
        has_v, has_a = has_v and given[-1][0], has_a and given[-1][1]
        kinds.append(QUINTIC if has_a else CUBIC if has_v else LINEAR)
        given.append((len(point.velocities) > 0, len(point.accelerations) > 0))
        knots.append((q, v, a))
        times.append(start_ns + t)
    return Trajectory(group_joints, start_ns, times, knots, kinds)
