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
Replay a recording and check that the simulator reproduces it (``ros2 run rbd_ros replay``).

The recording holds the node's parameters (MCAP metadata record ``rbd_ros``), every wrench as it
took effect (log time = sim time of the start of the step it was applied at) and the output
samples (``pose``, ``twist``, ``odom``, ``/clock``; log time = sim time of the sample).  Replay
rebuilds :class:`rbd_ros.config.NodeConfig` from the stored parameters, drives a fresh
:class:`rbd_ros.session.SimSession` to each recorded time, submits each recorded wrench so that
it takes effect at the step starting at its recorded time, recomputes every recorded output
through :mod:`rbd_ros.conversions` and compares it field by field with the recorded message.

The inputs are checked too: replay digests the wrenches that took effect
(:class:`rbd_ros.session.AppliedDigest`) and compares with the digest the node stored in the
``rbd_ros.run`` record, bit for bit.  A run that hit a non-finite step must fail again at the
same sim time with the same message (reproduced, a match).  Log times are checked against the
recorded configuration before any stepping (:func:`check_times`), so a crafted bag cannot make
replay step without bound.

By default the comparison is bit-exact (every float identical to the last bit, stamps and frame
ids equal).  ``--tolerance`` relaxes it to ``error <= tolerance`` for each of: position (m,
Euclidean norm of the difference), orientation (rad, geodesic angle between the quaternions),
linear velocity (m/s) and angular velocity (rad/s).  ``--integrator`` and ``--timestep`` replay
with another integrator or step and report how far the result moves from the recording (an
accuracy study from one recording); samples then fall on the first step end at or after their
recorded time.

Messages are decoded with the schemas stored in the file (``mcap-ros2-support``); rclpy is not
imported.  Exit status: 0 match, 1 mismatch, 2 the bag cannot be replayed (missing, empty,
truncated before any data, corrupt, foreign: one line on stderr, never a traceback).
"""

import argparse
import dataclasses
import json
import math
import sys

import numpy as np
from rbd_ros import conversions
from rbd_ros import outputs
from rbd_ros.config import NodeConfig
from rbd_ros.core import NonFiniteError
from rbd_ros.core.errors import RecordingError
from rbd_ros.core.rotations import quat_angle_between
from rbd_ros.inputs import WrenchRejected
from rbd_ros.recording import open_bag, run_on_bag
from rbd_ros.session import AppliedDigest, SimSession

WRENCH_TYPE = 'geometry_msgs/msg/WrenchStamped'
#: Output topic kinds by message type.
OUTPUT_KINDS = {
    'geometry_msgs/msg/PoseStamped': 'pose',
    'geometry_msgs/msg/TwistStamped': 'twist',
    'nav_msgs/msg/Odometry': 'odom',
    'rosgraph_msgs/msg/Clock': 'clock',
}
_NS_PER_S = 1_000_000_000
_BIG_STEPS = 1 << 62  # "as many steps as needed": SimSession.advance stops at until_ns


class ReplayError(RecordingError):
    """The recording cannot be replayed (no configuration, unknown wrench topic, ...)."""


@dataclasses.dataclass
class TopicResult:
    """
    Comparison results of one recorded topic.

    Errors are maxima over the samples: position in m, orientation in rad, linear velocity in
    m/s, angular velocity in rad/s (None when the topic has no such field).
    """

    topic: str
    kind: str
    samples: int = 0
    mismatches: int = 0
    bit_exact: bool = True
    max_position_error_m: float = None
    max_orientation_error_rad: float = None
    max_linear_velocity_error_m_s: float = None
    max_angular_velocity_error_rad_s: float = None
    first_mismatch: str = None

    def _update(self, name, value):
        current = getattr(self, name)
        setattr(self, name, value if current is None else max(current, value))


@dataclasses.dataclass
class ReplayResult:
    """The outcome of :func:`replay_bag`; ``match`` decides the exit status."""

    bag: str
    finalised: bool
    notes: list
    integrator: str
    timestep_ns: int
    recorded_integrator: str
    recorded_timestep_ns: int
    tolerance: float
    topics: dict
    wrenches: int = 0
    wrench_mismatches: int = 0
    wrench_digest_checked: bool = False
    failure_reproduced: str = None
    remarks: list = dataclasses.field(default_factory=list)
    problems: list = dataclasses.field(default_factory=list)

    @property
    def compared(self):
        """Return the number of output samples compared."""
        return sum(t.samples for t in self.topics.values())

    @property
    def match(self):
        """Return True when every sample and wrench matched and nothing else went wrong."""
        return (not self.problems and self.wrench_mismatches == 0
                and all(t.mismatches == 0 for t in self.topics.values()))

    def to_dict(self):
        """Return a JSON-ready dict."""
        return {
            'bag': self.bag,
            'match': self.match,
            'finalised': self.finalised,
            'notes': list(self.notes),
            'integrator': self.integrator,
            'timestep_ns': self.timestep_ns,
            'recorded_integrator': self.recorded_integrator,
            'recorded_timestep_ns': self.recorded_timestep_ns,
            'tolerance': self.tolerance,
            'samples_compared': self.compared,
            'wrenches': self.wrenches,
            'wrench_mismatches': self.wrench_mismatches,
            'wrench_digest_checked': self.wrench_digest_checked,
            'failure_reproduced': self.failure_reproduced,
            'remarks': list(self.remarks),
            'problems': list(self.problems),
            'topics': {name: dataclasses.asdict(t) for name, t in self.topics.items()},
        }


def config_from_bag(bag, integrator=None, timestep_s=None):
    """
    Rebuild the :class:`NodeConfig` of a recording, optionally with another integrator/step.

    :raises ReplayError: the bag holds no rbd_ros configuration.
    :raises ConfigError, ModelError: the stored (or overridden) parameters are invalid.
    """
    if bag.config is None:
        raise ReplayError(
            f'{bag.mcap_path}: no rbd_ros configuration record in the file (not recorded by '
            'rbd_ros, or cut off before it); cannot rebuild the simulator')
    params = dict(bag.config)
    if integrator is not None:
        params['integrator'] = integrator
    if timestep_s is not None:
        params['timestep_s'] = float(timestep_s)
    params['record_path'] = ''
    params['start_paused'] = False
    return NodeConfig.from_parameters(params)


def _input_for_topic(config, topic):
    """Map an absolute recorded wrench topic to the input whose (relative) topic it ends with."""
    best = None
    for spec in config.wrench_inputs:
        name = spec.topic
        if name.startswith('/'):
            ok = topic == name
        else:
            ok = topic == '/' + name or topic.endswith('/' + name)
        if ok and (best is None or len(name) > len(best.topic)):
            best = spec
    if best is None:
        raise ReplayError(
            f'recorded wrench topic {topic!r} matches no wrench input of the recorded '
            f'configuration (inputs: {[s.topic for s in config.wrench_inputs]})')
    return best.name


def check_times(bag, config, messages, output_topics):
    """
    Refuse a recording whose log times cannot come from one run of ``config`` (before stepping).

    The node records an output sample at every publish period of sim time (the first at 0) and
    a wrench at the step it took effect at, so no message lies more than one publish period
    plus one step after the previous sample, nor more than one step past ``duration_s``.
    Replay steps to each message's time, so this bounds its work by the recording itself (a
    crafted log time of 2**62 ns would otherwise be stepped to).

    :param messages: :class:`rbd_ros.recording.RawMessage` sorted by log time.
    :raises ReplayError: one line naming the message, its time and the bound.
    """
    h = config.timestep_ns
    gap = config.publish_period_ns + h
    last_sample = 0
    for raw in messages:
        t = raw.log_time_ns
        if config.duration_ns and t > config.duration_ns + h:
            raise ReplayError(
                f'{bag.mcap_path}: {raw.topic} message at log time {t} ns is past the recorded '
                f'duration_s = {config.duration_ns / 1e9:g} s (+ one {h} ns step); not a '
                'recording of this run')
        if t > last_sample + gap:
            raise ReplayError(
                f'{bag.mcap_path}: {raw.topic} message at log time {t} ns comes more than one '
                f'publish period + one step ({gap} ns) after the previous output sample at '
                f'{last_sample} ns; not a recording of one continuous run')
        if raw.topic in output_topics:
            last_sample = t


def recorded_failure(bag):
    """Return ``(time_ns, message)`` of the recorded run's non-finite step, or None."""
    run = bag.run_metadata or {}
    text = run.get('failure_time_ns', '')
    if not text:
        return None
    try:
        return int(text), run.get('failure', '')
    except ValueError:
        raise ReplayError(f'{bag.mcap_path}: the rbd_ros.run record has failure_time_ns '
                          f'{text!r}, not an integer (ns)') from None


def _stamp_ns(msg):
    return int(msg.sec) * _NS_PER_S + int(msg.nanosec)


def _vec(msg):
    return np.array((msg.x, msg.y, msg.z), dtype=np.float64)


def _quat(msg):
    return np.array(conversions.quaternion_from_msg(msg), dtype=np.float64)


def _fields(kind, msg):
    """Return ``(stamp_ns, frame_ids, {field: array})`` of an output message, by field name."""
    vec, quat = conversions.vector_from_msg, conversions.quaternion_from_msg
    if kind == 'clock':
        return conversions.time_from_msg(msg.clock), (), {}
    stamp = conversions.time_from_msg(msg.header.stamp)
    if kind == 'pose':
        return stamp, (msg.header.frame_id,), {
            'position': vec(msg.pose.position), 'orientation': quat(msg.pose.orientation)}
    if kind == 'twist':
        return stamp, (msg.header.frame_id,), {
            'linear': vec(msg.twist.linear), 'angular': vec(msg.twist.angular)}
    return stamp, (msg.header.frame_id, msg.child_frame_id), {
        'position': vec(msg.pose.pose.position), 'orientation': quat(msg.pose.pose.orientation),
        'linear': vec(msg.twist.twist.linear), 'angular': vec(msg.twist.twist.angular)}


def expected_message(kind, state, config):
    """Recompute the output message of ``kind`` for ``state``: the node's own builder."""
    return outputs.sample_builder(config).message(kind, state)


_ERROR_FIELDS = {
    'position': 'max_position_error_m',
    'orientation': 'max_orientation_error_rad',
    'linear': 'max_linear_velocity_error_m_s',
    'angular': 'max_angular_velocity_error_rad_s',
}


def _compare(result, kind, t_ns, expected, recorded, tolerance):
    """Compare one sample; update ``result``; return True on match."""
    e_stamp, e_frames, e_fields = _fields(kind, expected)
    r_stamp, r_frames, r_fields = _fields(kind, recorded)
    result.samples += 1
    reasons = []
    if e_stamp != r_stamp:
        reasons.append(f'stamp {r_stamp} ns recorded, {e_stamp} ns recomputed')
    if e_frames != r_frames:
        reasons.append(f'frame ids {r_frames} recorded, {e_frames} recomputed')
    for name, e_value in e_fields.items():
        r_value = r_fields[name]
        # Bit for bit (tuples of floats: 0.0 == -0.0, so compare the float64 bytes).
        exact = np.array(e_value).tobytes() == np.array(r_value).tobytes()
        if exact:
            error = 0.0
        elif name == 'orientation':
            error = float(quat_angle_between(np.array(e_value), np.array(r_value)))
        else:
            error = float(np.linalg.norm(np.subtract(e_value, r_value)))
        if not math.isfinite(error):
            error = math.inf
        result._update(_ERROR_FIELDS[name], error)
        if not exact:
            result.bit_exact = False
        if (not exact) if tolerance is None else not error <= tolerance:
            reasons.append(f'{name} differs by {error:.3g} ({list(r_value)} recorded, '
                           f'{list(e_value)} recomputed)')
    if reasons:
        result.mismatches += 1
        if result.first_mismatch is None:
            result.first_mismatch = f't = {t_ns} ns: ' + '; '.join(reasons)
        return False
    return True


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


def replay_bag(bag, *, tolerance=None, integrator=None, timestep_s=None, progress=False):
    """
    Replay ``bag`` (a path or an opened :class:`rbd_ros.recording.Bag`) and compare.

    :param tolerance: None = bit-exact; else the largest accepted error (m, rad, m/s, rad/s).
    :param integrator: replay with this integrator instead of the recorded one.
    :param timestep_s: replay with this physics step instead of the recorded one, s.
    :param progress: draw a progress bar on stderr.
    :returns: a :class:`ReplayResult`.
    :raises RecordingError: the bag cannot be read or replayed at all.
    """
    if not hasattr(bag, 'messages'):
        bag = open_bag(bag)
    recorded = config_from_bag(bag)
    config = config_from_bag(bag, integrator, timestep_s)
    session = SimSession(config)
    session.paused = False
    h = config.timestep_ns

    kinds = {}
    inputs = {}
    for topic, info in bag.topics.items():
        if info.type_name in OUTPUT_KINDS:
            kinds[topic] = OUTPUT_KINDS[info.type_name]
        elif info.type_name == WRENCH_TYPE:
            inputs[topic] = _input_for_topic(config, topic)
    result = ReplayResult(
        bag=str(bag.path), finalised=bag.finalised, notes=[], integrator=config.integrator,
        timestep_ns=h, recorded_integrator=recorded.integrator,
        recorded_timestep_ns=recorded.timestep_ns, tolerance=tolerance,
        topics={topic: TopicResult(topic, kind) for topic, kind in sorted(kinds.items())})

    wanted = list(kinds) + list(inputs)
    messages = list(bag.messages(wanted))
    result.notes = list(bag.notes)
    last_time = {}
    for raw in messages:
        if raw.log_time_ns < last_time.get(raw.topic, -1):
            result.problems.append(
                f'{raw.topic}: log time goes back from {last_time[raw.topic]} ns to '
                f'{raw.log_time_ns} ns (a ~/reset during the run?); replay covers runs '
                'without resets')
            return result
        last_time[raw.topic] = raw.log_time_ns
    messages.sort(key=lambda m: m.log_time_ns)  # stable: keeps file order at equal times
    if not any(m.topic in kinds for m in messages):
        raise ReplayError(f'{bag.mcap_path}: no recorded output samples to compare '
                          f'({len(messages)} messages on the replayed topics)')
    check_times(bag, recorded, messages, kinds)
    failure = recorded_failure(bag)
    if failure is not None and failure[0] > (messages[-1].log_time_ns + recorded.timestep_ns
                                             + recorded.publish_period_ns):
        raise ReplayError(
            f'{bag.mcap_path}: the rbd_ros.run record puts the failure at {failure[0]} ns, more '
            'than one publish period + one step after the last recorded message at '
            f'{messages[-1].log_time_ns} ns')

    decoders = {topic: bag.decoder(topic) for topic in wanted}
    study = integrator is not None or timestep_s is not None
    bar = _Progress(len(messages), progress)
    pending = []  # (time_ns, input_name) of submitted wrenches not yet seen taking effect
    applied = []  # AppliedEvent reported by the session
    digest = AppliedDigest()  # over every wrench that took effect on replay, in order

    def took_effect(events):
        for event in events:
            digest.update(event)
        applied.extend(events)

    def advance_to(t_ns):
        while session.time_ns < t_ns:
            report = session.advance(_BIG_STEPS, until_ns=t_ns)
            took_effect(report.events)
            if report.steps == 0:
                return False
        return True

    def check_events():
        # Every wrench submitted at time t must take effect at the step starting at t, and
        # nothing else may take effect (exact replay only: a coarser step may merge wrenches).
        for event in applied:
            key = (event.time_ns, event.input_name)
            if key in pending:
                pending.remove(key)
            elif not study:
                result.wrench_mismatches += 1
                result.problems.append(
                    f'a wrench on input {event.input_name!r} took effect at {event.time_ns} ns '
                    'where none was recorded')
        applied.clear()
        late = [key for key in pending if key[0] < session.time_ns]
        for key in late:
            pending.remove(key)
            if not study:
                result.wrench_mismatches += 1
                result.problems.append(
                    f'the wrench on input {key[1]!r} recorded at {key[0]} ns did not take '
                    'effect on replay')

    replay_failure = None
    index = -1
    try:
        for index, raw in enumerate(messages):
            t = raw.log_time_ns
            if not advance_to(t):
                result.problems.append(
                    f'the recording goes on to {t} ns, past the end of the replayed run '
                    f'({session.time_ns} ns; duration_s = {config.duration_ns / 1e9:g} s)')
                break
            check_events()
            msg = decoders[raw.topic](raw.data)
            if raw.topic in inputs:
                frame_id, force, torque = conversions.wrench_from_msg(msg)
                result.wrenches += 1
                if session.time_ns != t and not study:
                    result.wrench_mismatches += 1
                    result.problems.append(
                        f'the wrench recorded at {t} ns is not on the {h} ns step grid')
                try:
                    session.submit(inputs[raw.topic], frame_id, force, torque)
                except WrenchRejected as exc:
                    result.wrench_mismatches += 1
                    result.problems.append(
                        f'the wrench recorded at {t} ns is rejected on replay: {exc}')
                else:
                    pending.append((session.time_ns, inputs[raw.topic]))
            else:
                kind = kinds[raw.topic]
                expected = expected_message(kind, session.state, config)
                if session.time_ns != t:
                    # Replayed with another step: compare the values at the first step end at
                    # or after t (the stamp is not what is being studied).
                    expected = _restamp(kind, expected, t)
                _compare(result.topics[raw.topic], kind, t, expected, msg, tolerance)
            bar.update(index + 1)
        if failure is not None and not study:
            advance_to(failure[0] + h)  # the recorded failing step: it must fail again
        if pending and not session.finished:
            # Let the wrenches recorded at the last time take effect, to confirm them.
            took_effect(session.advance(1).events)
        check_events()
    except NonFiniteError as exc:
        took_effect(getattr(exc, 'events', ()))
        check_events()
        replay_failure = (session.time_ns, str(exc))
        left = len(messages) - index - 1
        if left:
            result.remarks.append(f'{left} recorded messages after the failing step were not '
                                  'replayed')
    finally:
        bar.close()
    _judge_failure(result, failure, replay_failure, study)
    _judge_digest(result, bag, digest, study)
    return result


def _judge_failure(result, recorded, replayed, study):
    """Judge a non-finite step: reproduced (same sim time, same cause) or a mismatch."""
    if recorded is None and replayed is None:
        return
    if recorded is not None and replayed == recorded and not study:
        result.failure_reproduced = (f'the recorded run failed at t = {recorded[0]} ns and the '
                                     f'replay fails at the same step with the same cause: '
                                     f'{recorded[1]}')
    elif replayed is None:
        what = (f'the recorded run failed at t = {recorded[0]} ns ({recorded[1]}) but the '
                'replay did not')
        if study:
            result.remarks.append(what)
        else:
            result.problems.append(what)
    elif recorded is None:
        result.problems.append(f'the replay diverged at t = {replayed[0]} ns but the recorded '
                               f'run did not (or its bag was not finalised): {replayed[1]}')
    else:
        result.problems.append(
            f'the recorded run failed at t = {recorded[0]} ns ({recorded[1]}); the replay '
            f'failed at t = {replayed[0]} ns ({replayed[1]})')


def _judge_digest(result, bag, digest, study):
    """Compare the wrenches applied on replay with what the node applied, bit for bit."""
    run = bag.run_metadata or {}
    if study:
        return
    if 'wrench_digest' not in run:
        result.remarks.append(
            'no rbd_ros.run record (bag not finalised, or not recorded by the node): the '
            'applied wrenches were checked against the recorded messages only')
        return
    result.wrench_digest_checked = True
    count = run.get('wrenches_applied', '')
    if run['wrench_digest'] != digest.hexdigest() or count != str(digest.count):
        result.wrench_mismatches += 1
        result.problems.append(
            f'the wrenches applied on replay ({digest.count}, SHA-256 '
            f'{digest.hexdigest()[:16]}...) are not bit for bit those the node applied '
            f'({count}, SHA-256 {run["wrench_digest"][:16]}...): the recorded wrench messages '
            'differ from what the node applied')


def _restamp(kind, msg, t_ns):
    stamp = conversions.time_to_msg(t_ns)
    if kind == 'clock':
        msg.clock = stamp
    else:
        msg.header.stamp = stamp
    return msg


def _fmt_error(value):
    return '-' if value is None else f'{value:.3g}'


def format_summary(result):
    """Return the human-readable per-topic summary as a string."""
    lines = []
    what = 'bit-exact' if result.tolerance is None else f'tolerance {result.tolerance:g}'
    lines.append(f'replay of {result.bag} ({what})')
    if (result.integrator, result.timestep_ns) != (result.recorded_integrator,
                                                   result.recorded_timestep_ns):
        lines.append(f'  recorded with {result.recorded_integrator}, '
                     f'{result.recorded_timestep_ns} ns step; replayed with '
                     f'{result.integrator}, {result.timestep_ns} ns step')
    else:
        lines.append(f'  integrator {result.integrator}, step {result.timestep_ns} ns')
    if not result.finalised:
        lines.append('  NOTE: the bag was not finalised; replaying what it holds')
    lines.append(f'  wrenches: {result.wrenches} recorded, {result.wrench_mismatches} '
                 'mismatched' + ('; applied wrenches checked bit for bit against the digest '
                                 'of the node' if result.wrench_digest_checked else ''))
    if result.failure_reproduced:
        lines.append(f'  failure reproduced: {result.failure_reproduced}')
    header = (f'  {"topic":<16} {"samples":>8} {"mismatch":>8} {"pos m":>9} {"ori rad":>9} '
              f'{"lin m/s":>9} {"ang rad/s":>9}')
    lines.append(header)
    for t in result.topics.values():
        lines.append(
            f'  {t.topic:<16} {t.samples:>8} {t.mismatches:>8} '
            f'{_fmt_error(t.max_position_error_m):>9} '
            f'{_fmt_error(t.max_orientation_error_rad):>9} '
            f'{_fmt_error(t.max_linear_velocity_error_m_s):>9} '
            f'{_fmt_error(t.max_angular_velocity_error_rad_s):>9}')
        if t.first_mismatch:
            lines.append(f'    first mismatch: {t.first_mismatch}')
    for remark in result.remarks:
        lines.append(f'  note: {remark}')
    for problem in result.problems:
        lines.append(f'  problem: {problem}')
    lines.append('MATCH' if result.match else 'MISMATCH')
    return '\n'.join(lines)


def build_parser():
    """Return the argument parser of the ``replay`` executable."""
    parser = argparse.ArgumentParser(
        prog='replay',
        description='Replay an rbd_ros recording and compare the recomputed outputs with the '
                    'recorded ones (exit 0 match, 1 mismatch, 2 unreadable bag).')
    parser.add_argument('bag', help='bag directory or .mcap file')
    parser.add_argument('--tolerance', type=float, default=None,
                        help='accept errors up to this (m, rad, m/s, rad/s); default bit-exact')
    parser.add_argument('--integrator', default=None,
                        help='replay with this integrator (accuracy study)')
    parser.add_argument('--timestep', type=float, default=None, metavar='SECONDS',
                        help='replay with this physics step in s (accuracy study)')
    parser.add_argument('--json', action='store_true', help='print the result as JSON')
    bar = parser.add_mutually_exclusive_group()
    bar.add_argument('--progress', dest='progress', action='store_true', default=None,
                     help='draw a progress bar on stderr (default: when stderr is a TTY)')
    bar.add_argument('--no-progress', dest='progress', action='store_false')
    return parser


def main(argv=None):
    """Run the ``replay`` executable; return the exit status."""
    args = build_parser().parse_args(argv)
    progress = args.progress if args.progress is not None else sys.stderr.isatty()

    def run():
        if args.tolerance is not None and not args.tolerance >= 0.0:
            raise ReplayError(f'--tolerance {args.tolerance}: must be >= 0')
        bag = open_bag(args.bag)
        for note in bag.notes:
            print(f'replay: note: {note}', file=sys.stderr)
        return replay_bag(bag, tolerance=args.tolerance, integrator=args.integrator,
                          timestep_s=args.timestep, progress=progress)

    status, result = run_on_bag('replay', args.bag, 'replayed', run)
    if status:
        return status
    if args.json:
        print(json.dumps(result.to_dict(), indent=2))
    else:
        print(format_summary(result))
    return 0 if result.match else 1


def entry_point():
    """Console-script entry point: exit with :func:`main`'s status."""
    sys.exit(main())


if __name__ == '__main__':
    entry_point()
