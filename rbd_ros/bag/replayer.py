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
The :class:`Replayer`: re-drive one recording through a fresh session, run by run.

It steps a :class:`rbd_ros.sim.session.SimSession` to each recorded message's log time, submits
each recorded input at the step it took effect at, compares each recorded output sample (the
CDR bytes first, then field by field), checks that exactly the recorded inputs took effect,
and starts the session again at each ``~/reset`` the recording holds (:meth:`Replayer.run`),
judging each run's failure on its own (:meth:`Replayer.replay_run`).

Neighbours: :mod:`rbd_ros.bag.replay_setup` (the configuration and topics it replays),
:mod:`rbd_ros.bag.replay_compare` (how a sample, a failure and the wrench digest are judged),
:mod:`rbd_ros.bag.replay_result` (what it found), :mod:`rbd_ros.bag.replay` (``replay_bag`` and
the command).
"""

import sys
from typing import Dict, Iterable, List, Optional

from rbd_ros.bag import recorder as run_record
from rbd_ros.bag.reader import split_runs
from rbd_ros.bag.recording import Bag, RawMessage
from rbd_ros.bag.replay_compare import (compare_fields, ERROR_FIELDS, judge_digest,
                                        judge_failure, KIND_FIELDS, restamp)
from rbd_ros.bag.replay_result import ReplayResult, TopicResult
from rbd_ros.bag.replay_setup import (check_times, command_for_topic, command_payload,
                                      COMMAND_TYPES, compared_kinds, config_from_bag,
                                      drag_for_topic, input_for_topic, output_kind,
                                      OUTPUT_KINDS, POINT_TYPE, recorded_failures,
                                      RecordedFailures, ReplayError, WRENCH_TYPE)
from rbd_ros.core import NonFiniteError
from rbd_ros.core.errors import InputError
from rbd_ros.msgs import conversions
from rbd_ros.msgs import outputs
from rbd_ros.sim import limits
from rbd_ros.sim.inputs import AppliedEvent, WrenchRejected
from rbd_ros.sim.session import AppliedDigest, SimSession


_BIG_STEPS = 1 << 62  # "as many steps as needed": SimSession.advance stops at until_ns


class _Progress:
    """A one-line progress bar on stderr."""

    def __init__(self, total, enabled, stream=None):
        self.total = max(total, 1)
        self.enabled = enabled
        self.stream = sys.stderr if stream is None else stream
        self._last = -1

    def update(self, done):
        if not self.enabled:
            return
        percent = int(100 * done / self.total)
        if percent != self._last:
            self._last = percent
            bar = '#' * (percent // 4)
            self.stream.write(f'\rreplay: [{bar:<25}] {percent:3d}% ({done}/{self.total})')
            self.stream.flush()

    def close(self):
        if self.enabled and self._last >= 0:
            self.stream.write('\n')
            self.stream.flush()


class Replayer:
    """
    Re-drive one recording through a fresh :class:`SimSession`: advance, check events, compare.

    :meth:`recorded_messages` reads and vets what is to be replayed; :meth:`run` then replays
    each run (:meth:`replay_run`): steps to each message, submits each recorded wrench
    (:meth:`replay_wrench`), compares each recorded sample (:meth:`compare_sample`), checks
    after each advance that exactly the recorded wrenches took effect (:meth:`check_events`)
    and judges the run's recorded failure; the wrench digest is judged at the end.  Everything
    found goes into :attr:`result`.

    :param bag: the opened recording.
    :param tolerance: None = bit-exact; else the largest accepted error (m, rad, m/s, rad/s).
    :param integrator: replay with this integrator instead of the recorded one (a study).
    :param timestep_s: replay with this physics step in s instead of the recorded one (a study).
    :raises ReplayError: no configuration, or a wrench topic that matches no input.
    """

    def __init__(self, bag: Bag, *, tolerance: Optional[float] = None,
                 integrator: Optional[str] = None, timestep_s: Optional[float] = None):
        self.bag = bag
        accepted = []  # the link frame refusals of today's start-up, accepted
        self.recorded = config_from_bag(bag, accepted=accepted)
        self.config = config_from_bag(bag, integrator, timestep_s)
        #: Another integrator or step: report how far the result moves, do not judge wrenches.
        self.study = integrator is not None or timestep_s is not None
        self.tolerance = tolerance
        self.session = SimSession(self.config)
        self.session.paused = False
        self.kinds = {}  # output topic -> kind ('pose', 'twist', 'odom', 'clock')
        self.inputs = {}  # wrench topic -> input name
        self._builder = outputs.sample_builder(self.config)
        compared = compared_kinds(self.config, self._builder)
        for topic, info in bag.topics.items():
            kind = output_kind(compared, topic, info.type_name)  # 'pose', '<body>/pose', ...
            if kind is not None:
                self.kinds[topic] = kind  # contact_wrench too: the node refuses it as input
            elif info.type_name in OUTPUT_KINDS:
                continue  # the /clock of named bodies: their per-body samples are compared
            elif info.type_name == WRENCH_TYPE:
                self.inputs[topic] = input_for_topic(self.config, topic)
            elif info.type_name == POINT_TYPE:
                self.inputs[topic] = drag_for_topic(self.session, topic)
            elif info.type_name in COMMAND_TYPES and command_for_topic(self.session, topic):
                self.inputs[topic] = command_for_topic(self.session, topic)
        self.result = ReplayResult(
            bag=str(bag.path), finalised=bag.finalised, notes=[],
            integrator=self.config.integrator, timestep_ns=self.config.timestep_ns,
            recorded_integrator=self.recorded.integrator,
            recorded_timestep_ns=self.recorded.timestep_ns, tolerance=tolerance,
            topics={topic: TopicResult(topic, kind) for topic, kind in sorted(self.kinds.items())})
        if accepted:
            self.result.remarks.append(
                f'replayed although a start today refuses its configuration ({len(accepted)} '
                f'robot link frame refusal(s); the first: {accepted[0]}): TF frame ids only, '
                'the physics is the same')
        #: The recorded non-finite steps by run (:meth:`recorded_messages` reads them).
        self.failures = RecordedFailures({}, [])
        self.digest = AppliedDigest()  # over every wrench that took effect on replay, in order
        self._pending = []  # (time_ns, input_name) of submitted wrenches not yet taking effect
        self._applied = []  # AppliedEvent reported by the session, not yet checked
        self._decoders = {}
        self._expected_time_ns = None  # sim time of the sample bytes in _expected
        self._expected = {}  # kind -> CDR bytes the node would have recorded at that time
        self.resets = []  # index of the first message of each run after a ~/reset

    def recorded_messages(self) -> Optional[List[RawMessage]]:
        """
        Return the messages to replay, each run between ``~/reset`` calls in log time order.

        The node writes in sim time order, so a message earlier than one before it in the file
        starts a run after a reset (from the initial state at t = 0); :attr:`resets` keeps the
        index of each such first message, where :meth:`run` resets the session.

        :raises ReplayError: no output sample, or log times (or the recorded failure time) that
            cannot come from runs of the recorded configuration (:func:`check_times`).
        :raises RecordingError: more steps to replay than :func:`rbd_ros.sim.limits.check_steps`
            allows (the runs' steps summed).
        """
        bag, result = self.bag, self.result
        wanted = list(self.kinds) + list(self.inputs)
        runs = split_runs(bag.messages(wanted))
        result.notes = list(bag.notes)
        messages, self.resets = [], []
        for run in runs:
            run.sort(key=lambda m: m.log_time_ns)  # stable: keeps file order at equal times
            check_times(bag, self.recorded, run, self.kinds)
            if messages:
                self.resets.append(len(messages))
            messages += run
        if not any(m.topic in self.kinds for m in messages):
            raise ReplayError(f'{bag.mcap_path}: no recorded output samples to compare '
                              f'({len(messages)} messages on the replayed topics)')
        if self.resets:
            result.remarks.append(f'{len(self.resets)} ~/reset during the run: each run after '
                                  'one was replayed from the initial state at t = 0')
        # after the time checks: they say more about a log time
        limits.check_steps(bag, sum(run[-1].log_time_ns for run in runs if run))
        self.failures = recorded_failures(
            bag, [run[-1].log_time_ns if run else 0 for run in runs],
            self.recorded.timestep_ns + self.recorded.publish_period_ns)
        if self.failures.remark:
            result.remarks.append(self.failures.remark)
        self._decoders = {topic: bag.decoder(topic) for topic in wanted}
        return messages

    def run(self, messages: List[RawMessage], progress: bool = False) -> ReplayResult:
        """
        Replay ``messages`` (from :meth:`recorded_messages`) run by run; return :attr:`result`.

        Each run (the first, then one per ``~/reset``) is replayed from the initial state and
        judged on its own (:meth:`replay_run`): a run that failed must fail again at its
        recorded step, and the runs after it are replayed all the same.
        """
        result = self.result
        bar = _Progress(len(messages), progress)
        bounds = [0] + list(self.resets) + [len(messages)]
        count = len(bounds) - 1
        try:
            for number, (start, end) in enumerate(zip(bounds, bounds[1:])):
                if number:
                    self.session.reset()
                    self.session.paused = False  # a failure paused it
                    self._expected_time_ns = None  # its samples were of the run before
                self.replay_run(number, messages[start:end], bar, start,
                                f'run {number + 1} of {count}: ' if count > 1 else '')
        finally:
            bar.close()
        judge_digest(result, self.bag, self.digest, self.study)
        run = self.bag.run_metadata or {}
        if run.get(run_record.RUN_EXCEPTION):
            when = run.get(run_record.RUN_EXCEPTION_TIME_NS, '?')
            result.run_crashed = (f'the node stopped on an exception at t = {when} ns: '
                                  f'{run[run_record.RUN_EXCEPTION]}')
        return result

    def replay_run(self, number: int, messages: List[RawMessage], bar: _Progress, done: int,
                   label: str) -> None:
        """
        Replay run ``number`` (its ``messages``) from the session's state; judge its failure.

        The recorded failing step of the run is stepped after its last message, so it must fail
        again there; a failure on replay ends the run (what the recording holds after it in the
        same run, after ``~/pause``, is counted as not replayed).

        :param done: messages replayed before this run (the progress bar's count).
        :param label: how the texts name the run (``'run 2 of 3: '``; '' for the only run).
        """
        session, result = self.session, self.result
        recorded = self.failures.by_run.get(number)
        samples = result.compared
        replayed = None
        taken = 0  # messages replayed
        try:
            for raw in messages:
                if not self.advance_to(raw.log_time_ns):
                    result.problems.append(
                        f'{label}the recording goes on to {raw.log_time_ns} ns, past the end '
                        f'of the replayed run ({session.time_ns} ns; duration_s = '
                        f'{self.config.duration_ns / 1e9:g} s)')
                    break
                self.check_events()
                if raw.topic in self.inputs:
                    self.replay_wrench(raw, self._decoders[raw.topic](raw.data))
                elif not self.same_bytes(raw):
                    self.compare_sample(raw, self._decoders[raw.topic](raw.data))
                taken += 1
                bar.update(done + taken)
            if recorded is not None and not self.study:
                # The recorded failing step: it must fail again.
                self.advance_to(recorded[0] + self.config.timestep_ns)
            self.end_run()
        except NonFiniteError as exc:
            self.took_effect(getattr(exc, 'events', ()))
            self.check_events()
            replayed = (session.time_ns, str(exc))
        left = len(messages) - taken if replayed is not None else 0
        if left:
            result.remarks.append(f'{label}{left} recorded messages after the failing step '
                                  'were not replayed')
        self.drop_pending(label)
        later = [t for n, t in self.failures.later if n == number]
        if later:
            result.remarks.append(f'{label}the run went on after its failure and failed again '
                                  f'at t = {", ".join(map(str, later))} ns: not replayed')
        result.runs.append({'samples': result.compared - samples,
                            'failure_ns': None if replayed is None else replayed[0],
                            'not_replayed': left})
        if recorded is None and replayed is not None and number < self.failures.unchecked:
            result.remarks.append(
                f'{label}the replay failed at t = {replayed[0]} ns ({replayed[1]}); the '
                'rbd_ros.run record of an older node keeps only its last failure, so this one '
                'cannot be checked')
            return
        judge_failure(result, recorded, replayed, self.study, label)

    def end_run(self) -> None:
        """Confirm the wrenches recorded at the last time of a run (to its end or a reset)."""
        if self._pending and not self.session.finished:
            # The node records an input at the start of the step it acts in: that step ran.
            self.took_effect(self.session.advance(1).events)
        self.check_events()

    def drop_pending(self, label: str = '') -> None:
        """At a run's end: a wrench submitted but not applied (its step failed) did not act."""
        for time_ns, name in self._pending:
            if not self.study:
                self._wrench_mismatch(f'{label}the wrench on input {name!r} recorded at '
                                      f'{time_ns} ns did not take effect on replay')
        self._pending.clear()
        self._applied.clear()

    def took_effect(self, events: Iterable[AppliedEvent]) -> None:
        """Digest the wrenches the session reports as applied and keep them for checking."""
        for event in events:
            self.digest.update(event)
            self._applied.append(event)

    def advance_to(self, t_ns: int) -> bool:
        """Step the session to sim time ``t_ns``; return False if it ended before."""
        while self.session.time_ns < t_ns:
            report = self.session.advance(_BIG_STEPS, until_ns=t_ns)
            self.took_effect(report.events)
            if report.steps == 0:
                return False
        return True

    def check_events(self) -> None:
        """
        Check that each submitted wrench took effect at the step starting at its time.

        Nothing else may take effect either (exact replay only: a coarser step of a study may
        merge wrenches).
        """
        pending = self._pending
        for event in self._applied:
            key = (event.time_ns, event.input_name)
            if key in pending:
                pending.remove(key)
            elif not self.study:
                self._wrench_mismatch(f'a wrench on input {event.input_name!r} took effect at '
                                      f'{event.time_ns} ns where none was recorded')
        self._applied.clear()
        late = [key for key in pending if key[0] < self.session.time_ns]
        for key in late:
            pending.remove(key)
            if not self.study:
                self._wrench_mismatch(f'the wrench on input {key[1]!r} recorded at {key[0]} ns '
                                      'did not take effect on replay')

    def _wrench_mismatch(self, problem: str) -> None:
        self.result.wrench_mismatches += 1
        self.result.problems.append(problem)

    def replay_wrench(self, raw: RawMessage, msg) -> None:
        """Submit the recorded wrench ``msg`` now, to take effect at the step starting now."""
        t = raw.log_time_ns
        self.result.wrenches += 1
        if self.session.time_ns != t and not self.study:
            self._wrench_mismatch(f'the wrench recorded at {t} ns is not on the '
                                  f'{self.config.timestep_ns} ns step grid')
        name = self.inputs[raw.topic]
        if self.session.commands is not None and name in self.session.commands.inputs:
            try:
                self.session.submit_command(name, command_payload(msg))
            except InputError as exc:
                self._wrench_mismatch(f'the command recorded at {t} ns is rejected on replay: '
                                      f'{exc}')
            else:
                self._pending.append((self.session.time_ns, name))
            return
        try:
            if hasattr(msg, 'point'):  # a drag point (PointStamped)
                self.session.submit_point(self.inputs[raw.topic], msg.header.frame_id,
                                          (msg.point.x, msg.point.y, msg.point.z))
            else:
                frame_id, force, torque = conversions.wrench_from_msg(msg)
                self.session.submit(self.inputs[raw.topic], frame_id, force, torque)
        except WrenchRejected as exc:
            self._wrench_mismatch(f'the wrench recorded at {t} ns is rejected on replay: {exc}')
        else:
            self._pending.append((self.session.time_ns, self.inputs[raw.topic]))

    def same_bytes(self, raw: RawMessage) -> bool:
        """
        Count the recorded sample as an exact match if its CDR bytes are the ones built now.

        The node publishes and records the bytes of :class:`rbd_ros.msgs.outputs.SampleBuilder`, so
        identical bytes mean every stamp, frame id and float is identical, without decoding
        (the fast path). Anything else, e.g. a bag written by rclpy's serialiser, whose padding
        bytes are not zeroed, goes through :meth:`compare_sample`.
        """
        t = raw.log_time_ns
        if self.session.time_ns != t:
            return False
        kind = self.kinds[raw.topic]
        if self.expected_bytes().get(kind) != raw.data:
            return False
        result = self.result.topics[raw.topic]
        result.samples += 1
        for name in KIND_FIELDS[kind.rsplit('/', 1)[-1]]:
            result.take_error(ERROR_FIELDS[name], 0.0)
        return True

    def expected_bytes(self) -> Dict[str, bytes]:
        """Return ``{kind: CDR bytes}`` the node would record at the session's time (cached)."""
        t = self.session.time_ns
        if self._expected_time_ns != t:
            robots = self.session.simulator if self.config.robots or self.config.world_joints \
                else None
            self._expected = dict(self._builder.serialize(
                t, self.session.columns, self.session.contact_wrenches_w, robots))
            self._expected_time_ns = t
        return self._expected

    def compare_sample(self, raw: RawMessage, msg) -> bool:
        """Compare the recorded output sample ``msg`` with the one recomputed now."""
        kind, t = self.kinds[raw.topic], raw.log_time_ns
        if any(kind in robot.kinds for robot in self._builder.robots):
            expected = self._builder.robot_message(kind, self.session.time_ns,
                                                   self.session.simulator)
            if self.session.time_ns != t:
                expected.header.stamp = conversions.time_to_msg(t)
            return compare_fields(self.result.topics[raw.topic], kind.rsplit('/', 1)[-1], t,
                                  expected, msg, self.tolerance)
        if kind == 'poses':  # every body's pose: the node's bytes now, decoded as recorded
            expected = self._decoders[raw.topic](self.expected_bytes()['poses'])
            if self.session.time_ns != t:
                expected = restamp(kind, expected, t)
            return compare_fields(self.result.topics[raw.topic], kind, t, expected, msg,
                                  self.tolerance)
        index = self._builder.body_index(kind) or 0  # clock: body 0's time
        wrenches = self.session.contact_wrenches_w
        wrench = None if wrenches is None else (wrenches[index][:3].tolist(),
                                                wrenches[index][3:].tolist())
        expected = self._builder.message(kind, self.session.body_state(index), wrench)
        kind = kind.rsplit('/', 1)[-1]
        if self.session.time_ns != t:
            # Replayed with another step: compare the values at the first step end at or after
            # t (the stamp is not what is being studied).
            expected = restamp(kind, expected, t)
        return compare_fields(self.result.topics[raw.topic], kind, t, expected, msg,
                              self.tolerance)
