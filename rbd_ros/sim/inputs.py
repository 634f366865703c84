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
Wrench inputs: validation, frame resolution, zero-order hold and sim-time expiry (no rclpy).

A wrench arrives as plain values ``(frame_id, force, torque)`` on a named input. It is read by
its ``frame_id``:

- the body frame id → force and torque in body coordinates;
- the world frame id → world coordinates;
- ``''`` → the input's default frame (``default_wrench_frame`` for the main input, the
  ``.frame`` parameter for an extra input);
- anything else → rejected (reason ``'frame'``).

It must be finite (reason ``'non_finite'``), with ``|force| <= max_force_n`` (``'force_limit'``)
and ``|torque| <= max_torque_nm`` (``'torque_limit'``); a name that is not an input is
``'unknown_input'``. The force acts at the input's ``point_b`` (the COM for the main input), so it
adds the torque ``r × f`` with ``r = R point_b`` (see :class:`rbd_ros.core.AppliedWrench`).

An accepted wrench is *pending* until :meth:`WrenchInputs.apply_pending` is called at the start of
a physics step; from then on it is *held* (zero-order hold) until replaced by the next wrench on
the same input, or, when ``timeout_ns > 0``, until the first step that starts at or after
``t_effect + timeout_ns`` (so it acts for ``ceil(timeout / h)`` steps). All held wrenches add up.
"""

from dataclasses import dataclass
import math

from rbd_ros.core import AppliedWrench, InputError

#: The reason of an input released because the step it acted in would be non-finite
#: (:meth:`rbd_ros.sim.session.SimSession.advance`).
NON_FINITE_STEP = 'non_finite_step'
#: Rejection reasons, in the order they are checked; the last is a held wrench released.
REJECT_REASONS = ('unknown_input', 'frame', 'non_finite', 'force_limit', 'torque_limit',
                  NON_FINITE_STEP)


class WrenchRejected(InputError):
    """A wrench was rejected; :attr:`reason` is one of :data:`REJECT_REASONS`."""

    def __init__(self, reason, message):
        super().__init__(message)
        self.reason = reason


def check_limits(topic, force, torque, max_force_n, max_torque_nm):
    """
    Raise unless ``|force| <= max_force_n`` and ``|torque| <= max_torque_nm``.

    The one load limit of every input: wrenches, drags and clicks (see :mod:`rbd_ros.sim.drag`).

    :param topic: the input, named in the message.
    :param force: 3 finite numbers, N.
    :param torque: 3 finite numbers, N·m (for a drag: ``r × f`` about the COM).
    :raises WrenchRejected: reason ``'force_limit'`` or ``'torque_limit'``.
    """
    # math.hypot scales: |(1e300, 1e300, 0)| is 1.41e300, where a sum of squares is inf.
    force_n = math.hypot(*(float(v) for v in force))
    if force_n > max_force_n:
        raise WrenchRejected(
            'force_limit', f'{topic}: |force| = {force_n:g} N exceeds max_force_n = '
            f'{max_force_n:g} N')
    torque_nm = math.hypot(*(float(v) for v in torque))
    if torque_nm > max_torque_nm:
        raise WrenchRejected(
            'torque_limit', f'{topic}: |torque| = {torque_nm:g} N·m exceeds '
            f'max_torque_nm = {max_torque_nm:g} N·m')


@dataclass(frozen=True)
class AppliedEvent:
    """
    A wrench that took effect: at the start of the step beginning at ``time_ns``.

    :ivar time_ns: sim time of the start of the step the wrench took effect at, int ns.
    :ivar input_name: the input it arrived on.
    :ivar frame_id: the ``frame_id`` as received (before resolution).
    :ivar force: the received force, N (3-tuple), in the coordinates ``frame_id`` names.
    :ivar torque: the received torque, N·m (3-tuple).
    :ivar wrench: the resolved :class:`AppliedWrench` (frame keyword and ``point_b``).
    :ivar tag: whatever the caller passed to ``submit`` (the node passes the message).
    """

    time_ns: int
    input_name: str
    frame_id: str
    force: tuple
    torque: tuple
    wrench: AppliedWrench
    tag: object = None


def _vector3(value):
    try:
        out = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        return None
    return out if len(out) == 3 else None


class WrenchInputs:
    """
    The wrench inputs of one body: pending and held wrenches and their counters.

    :param specs: :class:`rbd_ros.sim.config.WrenchInputSpec` sequence (name, topic, frame,
        point_b).
    :param world_frame: the world frame id.
    :param body_frame: the body frame id.
    :param timeout_ns: hold time in sim ns; 0 = hold until replaced.
    :param max_force_n: largest accepted ``|force|``, N.
    :param max_torque_nm: largest accepted ``|torque|``, N·m.
    """

    def __init__(self, specs, *, world_frame, body_frame, timeout_ns, max_force_n,
                 max_torque_nm):
        self._specs = {spec.name: spec for spec in specs}
        self._world_frame = world_frame
        self._body_frame = body_frame
        self._timeout_ns = int(timeout_ns)
        self._max_force_n = float(max_force_n)
        self._max_torque_nm = float(max_torque_nm)
        self.received = dict.fromkeys(self._specs, 0)
        self.rejected = dict.fromkeys(REJECT_REASONS, 0)
        self._pending = {}  # name -> (frame_id, force, torque, wrench, tag)
        self._held = {}  # name -> (t_effect_ns, AppliedWrench)
        self._loads = ()

    @property
    def received_total(self):
        """Return the number of wrenches received on all inputs (accepted or not)."""
        return sum(self.received.values())

    @property
    def rejected_total(self):
        """Return the number of wrenches rejected, all reasons."""
        return sum(self.rejected.values())

    @property
    def has_pending(self):
        """Return True when a wrench waits for the start of the next step."""
        return bool(self._pending)

    @property
    def held(self):
        """Return ``{input_name: (t_effect_ns, AppliedWrench)}`` of the wrenches acting now."""
        return dict(self._held)

    def validate(self, input_name, frame_id, force, torque):
        """
        Return the :class:`AppliedWrench` for these received values, or raise.

        Does not count or queue anything (see :meth:`submit`).

        :raises WrenchRejected: with a ``reason`` from :data:`REJECT_REASONS`.
        """
        spec = self._specs.get(input_name)
        if spec is None:
            raise WrenchRejected('unknown_input', f'input {input_name!r}: not a wrench input '
                                 f'(inputs: {", ".join(self._specs)})')
        if frame_id == self._body_frame:
            frame = 'body'
        elif frame_id == self._world_frame:
            frame = 'world'
        elif frame_id == '':
            frame = spec.frame
        else:
            raise WrenchRejected(
                'frame', f'{spec.topic}: header.frame_id {frame_id!r} is neither the body frame '
                f'{self._body_frame!r}, the world frame {self._world_frame!r} nor empty')
        force = _vector3(force)
        torque = _vector3(torque)
        if force is None or torque is None or not all(
                math.isfinite(v) for v in force + torque):
            raise WrenchRejected(
                'non_finite', f'{spec.topic}: force {force} N / torque {torque} N·m is not '
                'three finite numbers each')
        check_limits(spec.topic, force, torque, self._max_force_n, self._max_torque_nm)
        return AppliedWrench(force=force, torque=torque, frame=frame, point_b=spec.point_b)

    def submit(self, input_name, frame_id, force, torque, tag=None):
        """
        Count, validate and queue a received wrench; it takes effect at the next step start.

        A later submit on the same input before that step replaces it (it never acted).

        :returns: the :class:`AppliedWrench` it will apply.
        :raises WrenchRejected: counted under its ``reason``; nothing is queued.
        """
        if input_name in self.received:
            self.received[input_name] += 1
        try:
            wrench = self.validate(input_name, frame_id, force, torque)
        except WrenchRejected as exc:
            self.rejected[exc.reason] += 1
            raise
        self._pending[input_name] = (frame_id, tuple(float(v) for v in force),
                                     tuple(float(v) for v in torque), wrench, tag)
        return wrench

    def apply_pending(self, time_ns):
        """
        At the start of the step beginning at ``time_ns``: expire, then hold the pending ones.

        :returns: an :class:`AppliedEvent` list (the wrenches that took effect now), in input
            order.
        """
        events = []
        changed = self.expire(time_ns)
        if self._pending:
            for name in self._specs:
                if name in self._pending:
                    frame_id, force, torque, wrench, tag = self._pending.pop(name)
                    self._held[name] = (time_ns, wrench)
                    events.append(AppliedEvent(time_ns, name, frame_id, force, torque, wrench,
                                               tag))
            changed = True
        if changed:
            self._loads = tuple(w for _, w in self._held.values())
        return events

    def expire(self, time_ns):
        """Drop held wrenches whose hold ended at or before ``time_ns``; True if any did."""
        if not self._timeout_ns or not self._held:
            return False
        expired = [name for name, (t_effect, _) in self._held.items()
                   if time_ns - t_effect >= self._timeout_ns]
        for name in expired:
            del self._held[name]
        if expired:
            self._loads = tuple(w for _, w in self._held.values())
        return bool(expired)

    def next_expiry_ns(self):
        """Sim time at which the next held wrench expires, or None."""
        if not self._timeout_ns or not self._held:
            return None
        return min(t for t, _ in self._held.values()) + self._timeout_ns

    def loads(self):
        """Return the held wrenches, a tuple of :class:`AppliedWrench` for ``set_loads``."""
        return self._loads

    def release_held(self):
        """Drop every held wrench, each counted as rejected (``'non_finite_step'``); names."""
        names = list(self._held)
        self.rejected[NON_FINITE_STEP] += len(names)
        self._held.clear()
        self._loads = ()
        return names

    def clear(self):
        """Drop pending and held wrenches (counters are kept)."""
        self._pending.clear()
        self._held.clear()
        self._loads = ()


class WorldInputs:
    """
    The wrench inputs of a world: one :class:`WrenchInputs` per body, routed by input name.

    Input names are ``<body>/wrench`` and ``<body>/<input>`` (``wrench`` and ``<input>`` for the
    body of a single-body file)
    (:attr:`rbd_ros.sim.config.BodyConfig.wrench_inputs`); the interface is that of
    :class:`WrenchInputs`, with :meth:`body_loads` for each body's held wrenches.

    :param bodies: the :class:`rbd_ros.sim.config.BodyConfig` sequence, in world order.
    :param world_frame: the world frame id. The other keywords are :class:`WrenchInputs`'s.
    """

    def __init__(self, bodies, *, world_frame, timeout_ns, max_force_n, max_torque_nm):
        self._bodies = [WrenchInputs(body.wrench_inputs, world_frame=world_frame,
                                     body_frame=body.body_frame, timeout_ns=timeout_ns,
                                     max_force_n=max_force_n, max_torque_nm=max_torque_nm)
                        for body in bodies]
        self._route = {spec.name: i for i, body in enumerate(bodies)
                       for spec in body.wrench_inputs}
        self.unknown = 0  # wrenches on a name that is no body's input
        # The bodies with a wrench pending or held, the only ones a step start looks at (a
        # world of 1,000 bodies paid ~0.5 ms a call looking at all of them).
        self._active = set()

    @property
    def received_total(self):
        """Return the number of wrenches received on all inputs (accepted or not)."""
        return sum(b.received_total for b in self._bodies) + self.unknown

    @property
    def rejected_total(self):
        """Return the number of wrenches rejected, all reasons."""
        return sum(b.rejected_total for b in self._bodies) + self.unknown

    @property
    def rejected(self):
        """Return the rejections by reason, summed over the bodies."""
        out = dict.fromkeys(REJECT_REASONS, 0)
        for body in self._bodies:
            for reason, count in body.rejected.items():
                out[reason] += count
        out['unknown_input'] += self.unknown
        return out

    @property
    def has_pending(self):
        """Return True when a wrench waits for the start of the next step."""
        return any(b.has_pending for b in self._bodies)

    @property
    def held(self):
        """Return ``{input_name: (t_effect_ns, AppliedWrench)}`` of every body, acting now."""
        return {name: held for body in self._bodies for name, held in body.held.items()}

    def submit(self, input_name, frame_id, force, torque, tag=None):
        """Route to the body owning ``input_name`` (see :meth:`WrenchInputs.submit`)."""
        index = self._route.get(input_name)
        if index is None:
            self.unknown += 1
            raise WrenchRejected('unknown_input', f'input {input_name!r}: not a wrench input '
                                 f'(inputs: {", ".join(self._route)})')
        wrench = self._bodies[index].submit(input_name, frame_id, force, torque, tag)
        self._active.add(index)
        return wrench

    def _idle(self, index):
        """Forget body ``index`` as active once it holds and awaits nothing."""
        body = self._bodies[index]
        if not body.has_pending and not body.loads():
            self._active.discard(index)

    def apply_pending(self, time_ns):
        """Expire and apply on every body; return the events in body order, then input order."""
        events = []
        for index in sorted(self._active):
            events.extend(self._bodies[index].apply_pending(time_ns))
            self._idle(index)
        return events

    def expire(self, time_ns):
        """Drop expired held wrenches on every body; True if any did."""
        changed = False
        for index in sorted(self._active):
            changed = self._bodies[index].expire(time_ns) or changed
            self._idle(index)
        return changed

    def next_expiry_ns(self):
        """Sim time at which the next held wrench of any body expires, or None."""
        times = [t for t in (self._bodies[i].next_expiry_ns() for i in self._active)
                 if t is not None]
        return min(times) if times else None

    def body_loads(self, index):
        """Return the held wrenches of body ``index`` (a tuple of :class:`AppliedWrench`)."""
        return self._bodies[index].loads()

    def release_held(self):
        """Drop every body's held wrenches, counted (``'non_finite_step'``); their names."""
        names = [name for body in self._bodies for name in body.release_held()]
        for index in list(self._active):
            self._idle(index)
        return names

    def clear(self):
        """Drop pending and held wrenches of every body (counters are kept)."""
        for body in self._bodies:
            body.clear()
        self._active.clear()
