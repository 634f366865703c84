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
Dragging bodies with the mouse: the lecture's zero-length damped spring to an anchor (no rclpy).

Two inputs, both ``geometry_msgs/PointStamped`` in the world frame (``header.frame_id`` the
world frame id or empty; anything else is rejected and counted, reason ``'frame'``):

- ``drag`` (``<body>/drag`` in a world) moves the anchor of the body's drag spring to the
  point; a body not yet held is grabbed at its ``drag_point_b`` (body frame, from the COM). A
  point with NaN coordinates releases it; other non-finite values are rejected
  (``'non_finite'``), and a point farther than ``max_drag_point_m`` from the world origin
  (``|point| > max_drag_point_m``) is rejected (``'distance'``).
- ``/clicked_point``, what the Publish Point tools of RViz and Foxglove send. Clicks alternate:
  a click on or near a body (its surface within ``drag_click_radius_m``) grabs it exactly
  there (the spring starts at zero length); the next click, anywhere, moves the anchor there;
  after that, a click near a body grabs that body there (releasing the one held) and a click
  far from every body releases. A first click far from every body does nothing.

The spring is :class:`rbd_ros.core.Spring` with rest length 0: ``f = −k d − c ẋ`` at the
attachment point (``k = drag_stiffness_n_per_m``, ``c = drag_damping_n_s_per_m``). Like
wrenches, drags are events: queued when received, applied at the start of the next physics step
(where a click is resolved against the state at that time), and reported as
:class:`rbd_ros.sim.inputs.AppliedEvent` (the point in ``force``, ``torque`` zero) so the node
records them and replay re-drives them bit for bit.

Between two step starts only the latest point of each input is kept (a later one replaces it,
as a later wrench replaces a pending one), so a paused node holds at most one point per input.

A drag obeys the wrench limits (:func:`rbd_ros.sim.inputs.check_limits`): when a point takes
effect, the spring force it would exert at that step start, ``f = −k d − c ẋ``, and its torque
about the COM, ``r × f``, must satisfy ``|f| <= max_force_n`` and ``|r × f| <= max_torque_nm``;
otherwise the point is rejected and counted (``'force_limit'``, ``'torque_limit'``) and the drag
stays as it was. Like a wrench, it is checked once, when it takes effect; the spring then pulls
the body towards the anchor, so its force falls. A drag acting in a step that would be
non-finite is released and counted (``'non_finite_step'``), as wrenches are
(:class:`rbd_ros.sim.session.SimSession`).
"""

import math

import numpy as np
from rbd_ros.core import Spring
from rbd_ros.core.rotations import quat_to_matrix
from rbd_ros.sim.inputs import AppliedEvent, check_limits, NON_FINITE_STEP, WrenchRejected

#: The input name of ``/clicked_point``.
CLICKED_POINT = 'clicked_point'
#: Rejection reasons of drag inputs.
DRAG_REJECT_REASONS = ('unknown_input', 'frame', 'non_finite', 'distance', 'force_limit',
                       'torque_limit', NON_FINITE_STEP)


class DragInputs:
    """
    The drag handles of one node: at most one spring per body.

    :param bodies: ``(input name, point_b, shape)`` per body in world order: the body's drag
        input (``'drag'`` or ``'<body>/drag'``), its default attachment point (m, body frame,
        from the COM) and its collision shape (or None: the COM stands in for the surface).
    :param world_frame: the world frame id.
    :param stiffness_n_per_m: ``k`` >= 0, N/m.
    :param damping_n_s_per_m: ``c`` >= 0, N·s/m.
    :param click_radius_m: how near a body's surface a click must be to grab it, m.
    :param max_point_m: largest accepted ``|point|``, m (world frame, from the origin).
    :param max_force_n: largest accepted spring force ``|f|``, N.
    :param max_torque_nm: largest accepted spring torque ``|r × f|`` about the COM, N·m.
    """

    def __init__(self, bodies, *, world_frame, stiffness_n_per_m, damping_n_s_per_m,
                 click_radius_m, max_point_m=math.inf, max_force_n=math.inf,
                 max_torque_nm=math.inf):
        self._inputs = {name: i for i, (name, _, _) in enumerate(bodies)}
        self._points = [tuple(float(v) for v in point_b) for _, point_b, _ in bodies]
        self._shapes = [shape for _, _, shape in bodies]
        self._world_frame = world_frame
        self._k = float(stiffness_n_per_m)
        self._c = float(damping_n_s_per_m)
        self._radius = float(click_radius_m)
        self._max_point_m = float(max_point_m)
        self._max_force_n = float(max_force_n)
        self._max_torque_nm = float(max_torque_nm)
        self.received = 0
        self.rejected = dict.fromkeys(DRAG_REJECT_REASONS, 0)
        self._pending = {}  # input_name -> (frame_id, point, tag): the latest, arrival order
        self.last_rejection = None  # the last WrenchRejected raised when a point took effect
        self._held = {}  # body index -> Spring
        self._click = ('idle', None)  # ('grabbed', i) after a grab, ('moved', i) after a move

    @property
    def rejected_total(self):
        """Return the number of drag points rejected, all reasons."""
        return sum(self.rejected.values())

    @property
    def input_names(self):
        """Return every input name: the bodies' drag inputs, then ``clicked_point``."""
        return tuple(self._inputs) + (CLICKED_POINT,)

    def held(self):
        """Return ``{body index: Spring}`` of the drags acting now."""
        return dict(self._held)

    def submit(self, input_name, frame_id, point, tag=None):
        """
        Count, check and queue a received point; it takes effect at the next step start.

        :raises WrenchRejected: counted under its reason; nothing is queued.
        """
        self.received += 1
        try:
            if input_name not in self._inputs and input_name != CLICKED_POINT:
                raise WrenchRejected('unknown_input', f'input {input_name!r}: not a drag input '
                                     f'(inputs: {", ".join(self.input_names)})')
            if frame_id not in ('', self._world_frame):
                raise WrenchRejected(
                    'frame', f'{input_name}: header.frame_id {frame_id!r} is neither the world '
                    f'frame {self._world_frame!r} nor empty (points are world coordinates, m)')
            point = tuple(float(v) for v in point)
            release = all(math.isnan(v) for v in point) and input_name != CLICKED_POINT
            if not release and not all(math.isfinite(v) for v in point):
                raise WrenchRejected(
                    'non_finite', f'{input_name}: point {list(point)} m is not three finite '
                    'numbers (all NaN releases a drag)')
            distance_m = 0.0 if release else math.hypot(*point)  # no overflow at 1e300
            if distance_m > self._max_point_m:
                raise WrenchRejected(
                    'distance', f'{input_name}: |point| = {distance_m:g} m exceeds '
                    f'max_drag_point_m = {self._max_point_m:g} m')
        except WrenchRejected as exc:
            self.rejected[exc.reason] += 1
            raise
        self._pending.pop(input_name, None)  # the latest point of an input replaces a queued one
        self._pending[input_name] = (frame_id, point, tag)

    def apply_pending(self, time_ns, states):
        """
        At the start of the step beginning at ``time_ns``, apply the queued points in order.

        A point whose spring would exceed the load limits is rejected here and counted
        (:attr:`last_rejection` holds the :class:`WrenchRejected`); it is not an event.

        :param states: a callable ``i -> (position_w, orientation_wb, velocity_w, omega_b)`` of
            body ``i`` now (m, ``(w, x, y, z)``, m/s, rad/s in body coordinates).
        :returns: ``(events, changed body indices)``.
        """
        events, changed = [], set()
        pending, self._pending = self._pending, {}
        for input_name, (frame_id, point, tag) in pending.items():
            try:
                if input_name == CLICKED_POINT:
                    changed |= self._on_click(input_name, np.array(point), states)
                else:
                    index = self._inputs[input_name]
                    if math.isnan(point[0]):
                        self._held.pop(index, None)
                    else:
                        spring = self._held.get(index)
                        point_b = self._points[index] if spring is None else spring.point_b
                        self._held[index] = self._checked(input_name, index, point_b, point,
                                                          states)
                    changed.add(index)
            except WrenchRejected as exc:
                self.rejected[exc.reason] += 1
                self.last_rejection = exc
                continue
            events.append(AppliedEvent(time_ns, input_name, frame_id, point, (0.0, 0.0, 0.0),
                                       None, tag))
        return events, changed

    def springs(self, index):
        """Return the springs acting on body ``index`` (a tuple of 0 or 1)."""
        spring = self._held.get(index)
        return () if spring is None else (spring,)

    def release_held(self):
        """
        Drop every drag acting now, each counted as rejected (``'non_finite_step'``).

        The click cycle starts again (the next click grabs). Queued points are kept.

        :returns: the drag input names of the bodies released, in body order.
        """
        names = [name for name, i in self._inputs.items() if i in self._held]
        self.rejected[NON_FINITE_STEP] += len(names)
        self._held.clear()
        self._click = ('idle', None)
        return names

    def clear(self):
        """Drop queued points and every drag (counters are kept)."""
        self._pending.clear()
        self._held.clear()
        self._click = ('idle', None)

    def _spring(self, point_b, anchor_w):
        return Spring(point_b, anchor_w, self._k, self._c)

    def _checked(self, input_name, index, point_b, anchor_w, states):
        """
        Return the spring of body ``index`` from ``point_b`` to ``anchor_w``, within the limits.

        Its force now is ``f = −k (x − anchor) − c ẋ`` with ``x = p + r``, ``r = R point_b``,
        ``ẋ = v + R (ω_b × point_b)``; its torque about the COM is ``r × f``.

        :raises WrenchRejected: ``'force_limit'`` or ``'torque_limit'`` (not counted here).
        """
        position, orientation, velocity_w, omega_b = states(index)
        rotation = quat_to_matrix(np.asarray(orientation))
        point_b = np.asarray(point_b, dtype=float)
        r_w = rotation @ point_b
        x_dot = np.asarray(velocity_w) + rotation @ np.cross(np.asarray(omega_b), point_b)
        force = -self._k * (np.asarray(position) + r_w - np.asarray(anchor_w)) - self._c * x_dot
        check_limits(input_name, force, np.cross(r_w, force), self._max_force_n,
                     self._max_torque_nm)
        return self._spring(point_b, anchor_w)

    def _nearest(self, point_w, states):
        """Return ``(body index, point in its body frame)`` of the body nearest the click."""
        best, best_phi, best_b = None, math.inf, None
        for i in range(len(self._points)):
            position, orientation = states(i)[:2]
            point_b = quat_to_matrix(np.asarray(orientation)).T @ (point_w
                                                                   - np.asarray(position))
            shape = self._shapes[i]
            phi = float(np.linalg.norm(point_b)) if shape is None else float(
                shape.signed_distance(point_b)[0])
            if phi <= self._radius and phi < best_phi:
                best, best_phi, best_b = i, phi, point_b
        return best, best_b

    def _on_click(self, input_name, point_w, states):
        """Apply one click; a rejected one (limits) changes nothing and raises."""
        state, held = self._click
        if held is not None and held not in self._held:  # released on its drag topic
            state, held = 'idle', None
        changed = set()
        if state == 'grabbed':  # the click after a grab moves the anchor, wherever it is
            self._held[held] = self._checked(input_name, held, self._held[held].point_b,
                                             point_w, states)
            self._click = ('moved', held)
            return {held}
        index, point_b = self._nearest(point_w, states)
        grab = None if index is None else self._checked(input_name, index, point_b, point_w,
                                                        states)
        if state == 'moved':
            self._held.pop(held, None)
            changed.add(held)
            self._click = ('idle', None)
        if grab is not None:
            self._held[index] = grab
            self._click = ('grabbed', index)
            changed.add(index)
        return changed
