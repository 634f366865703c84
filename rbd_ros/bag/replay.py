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
samples (``pose``, ``twist``, ``odom``, ``/clock``, a robot's ``joint_states``, ``odom`` and
``joint_wrenches``, a world's ``joint_states`` and ``joint_wrenches``; log time = sim time of
the sample).  Replay
rebuilds :class:`rbd_ros.sim.config.NodeConfig` from the stored parameters; a :class:`Replayer`
drives a fresh :class:`rbd_ros.sim.session.SimSession` to each recorded time, submits each recorded
wrench so that it takes effect at the step starting at its recorded time, recomputes every
recorded output through :mod:`rbd_ros.msgs.conversions` and compares it field by field with the
recorded message.

The inputs are checked too: replay digests the wrenches that took effect
(:class:`rbd_ros.sim.session.AppliedDigest`) and compares with the digest the node stored in the
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
truncated before any data, corrupt, foreign, over the limits of :mod:`rbd_ros.sim.limits`: one line
on stderr, never a traceback), 3 the replay matches a recorded run that failed (a non-finite
step reproduced, or the node's process ended with an exception): never ``MATCH`` for a run
that did not end as it should; 141 the reader closed the pipe (``replay --json bag | head``:
no traceback).
"""

import argparse
import hashlib
import json
import math
import os
from pathlib import Path
import sys
import tempfile
from typing import Collection, Iterable, List, Optional, Tuple, Union
import warnings

import numpy as np
from rbd_ros.bag import recorder as run_record
from rbd_ros.bag.cli import open_bag_with_notes, run_on_bag
from rbd_ros.bag.reader import split_runs
from rbd_ros.bag.recording import Bag, open_bag, RawMessage
from rbd_ros.bag.replay_result import format_summary, ReplayResult, TopicResult  # noqa: F401
from rbd_ros.core import cachedir, NonFiniteError
from rbd_ros.core.errors import InputError, RbdError
from rbd_ros.core.rotations import quat_angle_between
from rbd_ros.msgs import conversions
from rbd_ros.msgs import outputs
from rbd_ros.msgs import type_names as types
from rbd_ros.sim import limits
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.inputs import AppliedEvent, WrenchRejected
from rbd_ros.sim.params import recorded_parameters
from rbd_ros.sim.session import AppliedDigest, SimSession

WRENCH_TYPE = types.WRENCH_STAMPED
POINT_TYPE = types.POINT_STAMPED
#: Output topic kinds by message type.
OUTPUT_KINDS = {types.POSE_STAMPED: 'pose', types.TWIST_STAMPED: 'twist',
                types.ODOMETRY: 'odom', types.CLOCK: 'clock'}
#: Exit status: every sample and wrench matched.
EXIT_MATCH = 0
#: Exit status: something differs (:attr:`ReplayResult.problems`).
EXIT_MISMATCH = 1
#: Exit status: the replay matches, but the recorded run failed (:attr:`ReplayResult.run_failed`).
EXIT_RUN_FAILED = 3
_BIG_STEPS = 1 << 62  # "as many steps as needed": SimSession.advance stops at until_ns


class ReplayError(RbdError):
    """
    The recording cannot be replayed (no configuration, unknown wrench topic, crafted times, ...).

    An :class:`RbdError`, not an :class:`OSError`: the file was read; what it holds is wrong.
    """


def config_from_bag(bag: Bag, integrator: Optional[str] = None,
                    timestep_s: Optional[float] = None) -> NodeConfig:
    """
    Rebuild the :class:`NodeConfig` of a recording, optionally with another integrator/step.

    :raises ReplayError: the bag holds no rbd_ros configuration.
    :raises ConfigError, ModelError: the stored (or overridden) parameters are invalid.
    """
    if bag.config is None:
        raise ReplayError(
            f'{bag.mcap_path}: no rbd_ros configuration record in the file (not recorded by '
            'rbd_ros, or cut off before it); cannot rebuild the simulator')
    params = recorded_parameters(bag.config)  # a bag of old parameter names replays too
    if integrator is not None:
        params['integrator'] = integrator
    if timestep_s is not None:
        params['timestep_s'] = float(timestep_s)
    params['record_path'] = ''
    params['start_paused'] = False
    params.pop('threads', None)   # this machine's: the steps' bits do not depend on it
    _use_attached_meshes(bag, params)
    return NodeConfig.from_parameters(params)


def _use_attached_meshes(bag, params):
    """
    Point every ``*mesh_path`` at the copy of the mesh the node attached to the recording.

    The copies go to ``bag_meshes/<sha256>`` in the cache folder (:mod:`rbd_ros.core.cachedir`:
    content-addressed, so shared and never stale; a temporary folder if the cache folder is not
    this user's alone). A recording is replayed from its own attachments only, never from a
    local file it names: a mesh path with no attachment of that name is refused.

    :raises ReplayError: naming the parameter and the path that has no attachment.
    """
    names = [k for k, v in params.items() if k.endswith('mesh_path') and v]
    if not names:
        return
    attached = bag.attachments()
    folder, problem = cachedir.private_dir('bag_meshes')
    if problem is not None:  # not safe to share: this replay's own copies
        warnings.warn(f'{problem}; the meshes go to a temporary folder', RuntimeWarning,
                      stacklevel=2)
        folder = tempfile.mkdtemp(prefix='rbd_ros_bag_meshes_')
    folder = Path(folder)
    for name in names:
        data = attached.get(params[name])
        if data is None:
            raise ReplayError(
                f'{bag.mcap_path}: parameter {name} = {params[name]!r}: the recording has no '
                'attachment of that name; a recording is replayed from its own attachments, '
                'never from a local file it names')
        suffix = Path(params[name]).suffix
        target = folder / (hashlib.sha256(data).hexdigest() + suffix)
        if not target.is_file():
            partial = target.with_suffix(target.suffix + f'.{os.getpid()}')
            partial.write_bytes(data)
            os.replace(partial, target)
        params[name] = str(target)


def _compared_kinds(config, builder):
    """
    Return ``{kind: type name}`` of the compared outputs: each body's, and ``clock``.

    The ``clock`` of named bodies is not compared (their per-body samples are); ``poses`` and
    ``tf`` repeat the poses.
    """
    kinds = [kind for kind in builder.kinds if builder.body_index(kind) is not None]
    if 'clock' in builder.kinds and not config.named and not config.robots:
        kinds.append('clock')
    compared = {kind: outputs.TYPE_NAMES[kind.rsplit('/', 1)[-1]] for kind in kinds}
    for robot in builder.robots:
        compared[robot.kind] = types.JOINT_STATE
        compared[robot.wrench_kind] = types.MULTI_DOF_JOINT_STATE
        if robot.odom_kind:
            compared[robot.odom_kind] = types.ODOMETRY
    return compared


#: The message types of the robots' command inputs.
COMMAND_TYPES = (types.JOINT_STATE, types.FLOAT64_MULTI_ARRAY, types.JOINT_TRAJECTORY)


def _command_for_topic(session, topic):
    """Map a recorded command topic to its input (``<robot>/joint_command``, ...), or None."""
    if session.commands is None:
        return None
    for name in sorted(session.commands.inputs, key=len, reverse=True):
        if topic == '/' + name or topic.endswith('/' + name):
            return name
    return None


def command_payload(msg) -> Union[list, tuple]:
    """Return the :meth:`SimSession.submit_command` payload of a decoded command message."""
    if hasattr(msg, 'points'):  # trajectory_msgs/JointTrajectory
        return conversions.trajectory_from_msg(msg)
    if hasattr(msg, 'data'):  # std_msgs/Float64MultiArray
        return list(msg.data)
    return conversions.joint_command_from_msg(msg)


def _output_kind(kinds, topic, type_name):
    """
    Return the compared kind of a recorded topic, or None (an input, or not compared).

    The kind whose relative topic the recorded ``topic`` ends with (the longest), of the same
    type; else, for a topic remapped elsewhere, the kind of its type when that is a compared
    kind (``pose``, ``twist``, ``odom``, ``clock`` of a single-body file).
    """
    best = None
    for kind, kind_type in kinds.items():
        relative = outputs.topic_of(kind).lstrip('/')
        if type_name == kind_type and (topic == '/' + relative
                                       or topic.endswith('/' + relative)):
            if best is None or len(kind) > len(best):
                best = kind
    if best is None and OUTPUT_KINDS.get(type_name) in kinds:
        best = OUTPUT_KINDS[type_name]
    return best


def _drag_for_topic(session, topic):
    """Map a recorded drag topic (``drag``, ``<body>/drag``, ``/clicked_point``) to its input."""
    if topic == '/clicked_point':
        return 'clicked_point'
    for name in sorted(session.drags.input_names, key=len, reverse=True):
        if topic.endswith('/' + name):
            return name
    raise ReplayError(f'recorded drag topic {topic!r} matches no drag input of the recorded '
                      f'configuration (inputs: {list(session.drags.input_names)})')


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


def check_times(bag: Bag, config: NodeConfig, messages: Iterable[RawMessage],
                output_topics: Collection[str]) -> None:
    """
    Refuse a recording whose log times cannot come from one run of ``config`` (before stepping).

    The node records an output sample at every publish period of sim time (the first at 0) and
    a wrench at the step it took effect at, so no message lies more than one publish period
    plus one step after the previous sample, nor more than one step past ``duration_s``.
    Replay steps to each message's time, so this bounds its work by the recording itself (a
    crafted log time of 2**62 ns would otherwise be stepped to).

    :param messages: :class:`rbd_ros.bag.recording.RawMessage` sorted by log time.
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


def recorded_failure(bag: Bag) -> Optional[Tuple[int, str]]:
    """Return ``(time_ns, message)`` of the recorded run's non-finite step, or None."""
    run = bag.run_metadata or {}
    text = run.get(run_record.RUN_FAILURE_TIME_NS, '')
    if not text:
        return None
    try:
        return int(text), run.get(run_record.RUN_FAILURE, '')
    except ValueError:
        raise ReplayError(f'{bag.mcap_path}: the rbd_ros.run record has failure_time_ns '
                          f'{text!r}, not an integer (ns)') from None


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
    if kind == 'contact_wrench':
        return stamp, (msg.header.frame_id,), {
            'force': vec(msg.wrench.force), 'torque': vec(msg.wrench.torque)}
    if kind == 'joint_states':
        return stamp, (msg.header.frame_id, tuple(msg.name)), {
            'joint_position': tuple(msg.position), 'joint_velocity': tuple(msg.velocity),
            'joint_effort': tuple(msg.effort)}
    if kind == 'joint_wrenches':
        return stamp, (msg.header.frame_id, tuple(msg.joint_names), len(msg.transforms),
                       len(msg.twist)), {
            'joint_force': tuple(v for w in msg.wrench for v in vec(w.force)),
            'joint_torque': tuple(v for w in msg.wrench for v in vec(w.torque))}
    return stamp, (msg.header.frame_id, msg.child_frame_id), {
        'position': vec(msg.pose.pose.position), 'orientation': quat(msg.pose.pose.orientation),
        'linear': vec(msg.twist.twist.linear), 'angular': vec(msg.twist.twist.angular)}


def expected_message(kind, state, config, contact_wrench=None):
    """Recompute the output message of ``kind`` for ``state``: the node's own builder."""
    return outputs.sample_builder(config).message(kind, state, contact_wrench)


#: The compared fields of each output kind (see :func:`_fields`).
_KIND_FIELDS = {'pose': ('position', 'orientation'), 'twist': ('linear', 'angular'),
                'odom': ('position', 'orientation', 'linear', 'angular'),
                'contact_wrench': ('force', 'torque'), 'clock': (),
                'joint_states': ('joint_position', 'joint_velocity', 'joint_effort'),
                'joint_wrenches': ('joint_force', 'joint_torque')}
_ERROR_FIELDS = {
    'position': 'max_position_error_m',
    'orientation': 'max_orientation_error_rad',
    'linear': 'max_linear_velocity_error_m_s',
    'angular': 'max_angular_velocity_error_rad_s',
    'force': 'max_force_error_n',
    'torque': 'max_torque_error_nm',
    'joint_position': 'max_joint_position_error',
    'joint_velocity': 'max_joint_velocity_error',
    'joint_effort': 'max_joint_effort_error',
    'joint_force': 'max_force_error_n',
    'joint_torque': 'max_torque_error_nm',
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
        elif np.shape(e_value) != np.shape(r_value):
            error = math.inf  # another number of joints
        elif name == 'orientation':
            error = float(quat_angle_between(np.array(e_value), np.array(r_value)))
        else:
            error = float(np.linalg.norm(np.subtract(e_value, r_value)))
        if not math.isfinite(error):
            error = math.inf
        result.take_error(_ERROR_FIELDS[name], error)
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


def replay_bag(bag: Union[str, os.PathLike, Bag], *, tolerance: Optional[float] = None,
               integrator: Optional[str] = None, timestep_s: Optional[float] = None,
               progress: bool = False) -> ReplayResult:
    """
    Replay ``bag`` (a path or an opened :class:`rbd_ros.bag.recording.Bag`) and compare.

    :param tolerance: None = bit-exact; else the largest accepted error (m, rad, m/s, rad/s).
    :param integrator: replay with this integrator instead of the recorded one.
    :param timestep_s: replay with this physics step instead of the recorded one, s.
    :param progress: draw a progress bar on stderr.
    :returns: a :class:`ReplayResult`.
    :raises RbdError: the bag cannot be read (:class:`RecordingError`) or replayed at all
        (:class:`ReplayError`, or the stored configuration is invalid).
    """
    if not isinstance(bag, Bag):
        limits.check_mcap_chunks(bag)
        bag = open_bag(bag)
        limits.check_bag(bag, steps=False)
    replayer = Replayer(bag, tolerance=tolerance, integrator=integrator, timestep_s=timestep_s)
    messages = replayer.recorded_messages()
    if messages is not None:
        replayer.run(messages, progress)
    return replayer.result


class Replayer:
    """
    Re-drive one recording through a fresh :class:`SimSession`: advance, check events, compare.

    :meth:`recorded_messages` reads and vets what is to be replayed; :meth:`run` then steps to
    each message, submits each recorded wrench (:meth:`replay_wrench`), compares each recorded
    sample (:meth:`compare_sample`), checks after each advance that exactly the recorded
    wrenches took effect (:meth:`check_events`), and judges a recorded failure and the wrench
    digest at the end.  Everything found goes into :attr:`result`.

    :param bag: the opened recording.
    :param tolerance: None = bit-exact; else the largest accepted error (m, rad, m/s, rad/s).
    :param integrator: replay with this integrator instead of the recorded one (a study).
    :param timestep_s: replay with this physics step in s instead of the recorded one (a study).
    :raises ReplayError: no configuration, or a wrench topic that matches no input.
    """

    def __init__(self, bag: Bag, *, tolerance: Optional[float] = None,
                 integrator: Optional[str] = None, timestep_s: Optional[float] = None):
        self.bag = bag
        self.recorded = config_from_bag(bag)
        self.config = config_from_bag(bag, integrator, timestep_s)
        #: Another integrator or step: report how far the result moves, do not judge wrenches.
        self.study = integrator is not None or timestep_s is not None
        self.tolerance = tolerance
        self.session = SimSession(self.config)
        self.session.paused = False
        self.kinds = {}  # output topic -> kind ('pose', 'twist', 'odom', 'clock')
        self.inputs = {}  # wrench topic -> input name
        self._builder = outputs.sample_builder(self.config)
        compared = _compared_kinds(self.config, self._builder)
        for topic, info in bag.topics.items():
            kind = _output_kind(compared, topic, info.type_name)  # 'pose', '<body>/pose', ...
            if kind is not None:
                self.kinds[topic] = kind  # contact_wrench too: the node refuses it as input
            elif info.type_name in OUTPUT_KINDS:
                continue  # the /clock of named bodies: their per-body samples are compared
            elif info.type_name == WRENCH_TYPE:
                self.inputs[topic] = _input_for_topic(self.config, topic)
            elif info.type_name == POINT_TYPE:
                self.inputs[topic] = _drag_for_topic(self.session, topic)
            elif info.type_name in COMMAND_TYPES and _command_for_topic(self.session, topic):
                self.inputs[topic] = _command_for_topic(self.session, topic)
        self.result = ReplayResult(
            bag=str(bag.path), finalised=bag.finalised, notes=[],
            integrator=self.config.integrator, timestep_ns=self.config.timestep_ns,
            recorded_integrator=self.recorded.integrator,
            recorded_timestep_ns=self.recorded.timestep_ns, tolerance=tolerance,
            topics={topic: TopicResult(topic, kind) for topic, kind in sorted(self.kinds.items())})
        self.failure = recorded_failure(bag)
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
        last = runs[-1][-1].log_time_ns if runs[-1] else 0
        if self.failure is not None and self.failure[0] > (
                last + self.recorded.timestep_ns + self.recorded.publish_period_ns):
            raise ReplayError(
                f'{bag.mcap_path}: the rbd_ros.run record puts the failure at '
                f'{self.failure[0]} ns, more than one publish period + one step after the last '
                f'recorded message at {last} ns')
        self._decoders = {topic: bag.decoder(topic) for topic in wanted}
        return messages

    def run(self, messages: List[RawMessage], progress: bool = False) -> ReplayResult:
        """Replay ``messages`` (from :meth:`recorded_messages`); return :attr:`result`."""
        session, result = self.session, self.result
        bar = _Progress(len(messages), progress)
        replay_failure = None
        index = -1
        resets = set(self.resets)
        try:
            for index, raw in enumerate(messages):
                if index in resets:
                    self.end_run()
                    session.reset()
                    self._expected_time_ns = None  # its samples were of the run before
                if not self.advance_to(raw.log_time_ns):
                    result.problems.append(
                        f'the recording goes on to {raw.log_time_ns} ns, past the end of the '
                        f'replayed run ({session.time_ns} ns; duration_s = '
                        f'{self.config.duration_ns / 1e9:g} s)')
                    break
                self.check_events()
                if raw.topic in self.inputs:
                    self.replay_wrench(raw, self._decoders[raw.topic](raw.data))
                elif not self.same_bytes(raw):
                    self.compare_sample(raw, self._decoders[raw.topic](raw.data))
                bar.update(index + 1)
            if self.failure is not None and not self.study:
                # The recorded failing step: it must fail again.
                self.advance_to(self.failure[0] + self.config.timestep_ns)
            self.end_run()
        except NonFiniteError as exc:
            self.took_effect(getattr(exc, 'events', ()))
            self.check_events()
            replay_failure = (session.time_ns, str(exc))
            left = len(messages) - index - 1
            if left:
                result.remarks.append(f'{left} recorded messages after the failing step were '
                                      'not replayed')
        finally:
            bar.close()
        _judge_failure(result, self.failure, replay_failure, self.study)
        _judge_digest(result, self.bag, self.digest, self.study)
        run = self.bag.run_metadata or {}
        if run.get(run_record.RUN_EXCEPTION):
            when = run.get(run_record.RUN_EXCEPTION_TIME_NS, '?')
            result.run_crashed = (f'the node stopped on an exception at t = {when} ns: '
                                  f'{run[run_record.RUN_EXCEPTION]}')
        return result

    def end_run(self) -> None:
        """Confirm the wrenches recorded at the last time of a run (to its end or a reset)."""
        if self._pending and not self.session.finished:
            # The node records an input at the start of the step it acts in: that step ran.
            self.took_effect(self.session.advance(1).events)
        self.check_events()

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
        if self._expected_time_ns != t:
            robots = self.session.simulator if self.config.robots or self.config.world_joints \
                else None
            self._expected = dict(self._builder.serialize(
                t, self.session.columns, self.session.contact_wrenches_w, robots))
            self._expected_time_ns = t
        kind = self.kinds[raw.topic]
        if self._expected.get(kind) != raw.data:
            return False
        result = self.result.topics[raw.topic]
        result.samples += 1
        for name in _KIND_FIELDS[kind.rsplit('/', 1)[-1]]:
            result.take_error(_ERROR_FIELDS[name], 0.0)
        return True

    def compare_sample(self, raw: RawMessage, msg) -> bool:
        """Compare the recorded output sample ``msg`` with the one recomputed now."""
        kind, t = self.kinds[raw.topic], raw.log_time_ns
        if any(kind in robot.kinds for robot in self._builder.robots):
            expected = self._builder.robot_message(kind, self.session.time_ns,
                                                   self.session.simulator)
            if self.session.time_ns != t:
                expected.header.stamp = conversions.time_to_msg(t)
            return _compare(self.result.topics[raw.topic], kind.rsplit('/', 1)[-1], t,
                            expected, msg, self.tolerance)
        index = self._builder.body_index(kind) or 0  # clock: body 0's time
        wrenches = self.session.contact_wrenches_w
        wrench = None if wrenches is None else (wrenches[index][:3].tolist(),
                                                wrenches[index][3:].tolist())
        expected = self._builder.message(kind, self.session.body_state(index), wrench)
        kind = kind.rsplit('/', 1)[-1]
        if self.session.time_ns != t:
            # Replayed with another step: compare the values at the first step end at or after
            # t (the stamp is not what is being studied).
            expected = _restamp(kind, expected, t)
        return _compare(self.result.topics[raw.topic], kind, t, expected, msg, self.tolerance)


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
    if run_record.RUN_WRENCH_DIGEST not in run:
        result.remarks.append(
            'no rbd_ros.run record (bag not finalised, or not recorded by the node): the '
            'applied wrenches were checked against the recorded messages only')
        return
    result.wrench_digest_checked = True
    count = run.get(run_record.RUN_WRENCHES_APPLIED, '')
    recorded = run[run_record.RUN_WRENCH_DIGEST]
    if recorded != digest.hexdigest() or count != str(digest.count):
        result.wrench_mismatches += 1
        result.problems.append(
            f'the wrenches applied on replay ({digest.count}, SHA-256 '
            f'{digest.hexdigest()[:16]}...) are not bit for bit those the node applied '
            f'({count}, SHA-256 {recorded[:16]}...): the recorded wrench messages differ from '
            'what the node applied')


def _restamp(kind, msg, t_ns):
    stamp = conversions.time_to_msg(t_ns)
    if kind == 'clock':
        msg.clock = stamp
    else:
        msg.header.stamp = stamp
    return msg


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of the ``replay`` executable."""
    parser = argparse.ArgumentParser(
        prog='replay',
        description='Replay an rbd_ros recording and compare the recomputed outputs with the '
                    'recorded ones (exit 0 match, 1 mismatch, 2 unreadable bag or over the limits '
                    'of rbd_ros.sim.limits, 3 the replay matches but the recorded run failed: a '
                    'non-finite step or an exception).')
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


def main(argv: Optional[List[str]] = None) -> int:
    """Run the ``replay`` executable; return the exit status."""
    args = build_parser().parse_args(argv)
    progress = args.progress if args.progress is not None else sys.stderr.isatty()

    def run():
        if args.tolerance is not None and not args.tolerance >= 0.0:
            raise ReplayError(f'--tolerance {args.tolerance}: must be >= 0')
        bag = open_bag_with_notes('replay', args.bag, steps=False)
        return replay_bag(bag, tolerance=args.tolerance, integrator=args.integrator,
                          timestep_s=args.timestep, progress=progress)

    status, result = run_on_bag('replay', args.bag, 'replayed', run)
    if status:
        return status
    try:
        print(json.dumps(result.to_dict(), indent=2) if args.json else format_summary(result),
              flush=True)
    except BrokenPipeError:
        # `replay --json bag | head` closed the pipe: the Python recipe (stdout to devnull,
        # so the flush at exit cannot raise again), and 141 = 128 + SIGPIPE, the status of a
        # C tool the closed pipe ended (what `set -o pipefail` users see from `cat`).
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    if not result.match:
        return EXIT_MISMATCH
    return EXIT_RUN_FAILED if result.run_failed else EXIT_MATCH


def entry_point() -> None:
    """Console-script entry point: exit with :func:`main`'s status."""
    sys.exit(main())


if __name__ == '__main__':
    entry_point()
