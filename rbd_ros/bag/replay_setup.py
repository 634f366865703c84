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
What a recording says before replay steps anything: its configuration, its topics, its times.

:func:`config_from_bag` rebuilds the :class:`rbd_ros.sim.config.NodeConfig` stored in the
recording (its meshes from the recording's own attachments; ``plot`` draws from it too); the
topic helpers say which recorded topic is a compared output (by kind) and which an input (a
wrench, a drag point, a robot command); :func:`check_times` and :func:`recorded_failures` vet
the log times and the ``rbd_ros.run`` record (its non-finite steps, by run), so a crafted bag
cannot make replay step without bound.  Everything wrong here is a :class:`ReplayError`.

Neighbours: :mod:`rbd_ros.bag.replayer` drives the replay with these,
:mod:`rbd_ros.bag.replay_compare` judges what it recomputes, :mod:`rbd_ros.bag.replay` is the
``replay`` command.
"""

import dataclasses
import hashlib
import json
import os
from pathlib import Path
import tempfile
from typing import Collection, Dict, Iterable, List, Optional, Tuple, Union
import warnings

from rbd_ros.bag import recorder as run_record
from rbd_ros.bag.recording import Bag, RawMessage
from rbd_ros.core import cachedir
from rbd_ros.core.errors import RbdError
from rbd_ros.msgs import conversions
from rbd_ros.msgs import outputs
from rbd_ros.msgs import type_names as types
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.params import recorded_parameters
from rbd_ros.sim.session import SimSession


WRENCH_TYPE = types.WRENCH_STAMPED


POINT_TYPE = types.POINT_STAMPED


#: Output topic kinds by message type.
OUTPUT_KINDS = {types.POSE_STAMPED: 'pose', types.TWIST_STAMPED: 'twist',
                types.ODOMETRY: 'odom', types.CLOCK: 'clock'}


class ReplayError(RbdError):
    """
    The recording cannot be replayed (no configuration, unknown wrench topic, crafted times, ...).

    An :class:`RbdError`, not an :class:`OSError`: the file was read; what it holds is wrong.
    """


def config_from_bag(bag: Bag, integrator: Optional[str] = None,
                    timestep_s: Optional[float] = None,
                    accepted: Optional[List[str]] = None) -> NodeConfig:
    """
    Rebuild the :class:`NodeConfig` of a recording, optionally with another integrator/step.

    Through the checks of a start, but for the robot link frame rules (two robots of one URDF
    without ``frame_prefix``, a link name that is no TF frame id: refused at start since,
    :func:`rbd_ros.sim.robots.check_link_frames`): they name TF frames only, the physics and
    the recorded samples are the same, so a recording made before them still replays.

    :param accepted: a list to receive each such refusal's line (for the replay's remarks).
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
    params.pop('threads', None)  # this machine's: the steps' bits do not depend on it
    _use_attached_meshes(bag, params)
    return NodeConfig.from_parameters(params, accepted_frames=[] if accepted is None
                                      else accepted)


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


def compared_kinds(config: NodeConfig, builder: outputs.SampleBuilder) -> Dict[str, str]:
    """
    Return ``{kind: type name}`` of the compared outputs: each body's, and ``clock``.

    The ``clock`` of named bodies is not compared (their per-body samples are); ``poses`` and
    ``tf`` repeat the poses, so ``poses`` is compared only when there are no per-body topics
    (``per_body_topics: false``): every body's pose, its only record of them.
    """
    kinds = [kind for kind in builder.kinds if builder.body_index(kind) is not None]
    if 'clock' in builder.kinds and not config.named and not config.robots:
        kinds.append('clock')
    compared = {kind: outputs.TYPE_NAMES[kind.rsplit('/', 1)[-1]] for kind in kinds}
    if 'poses' in builder.kinds and not builder.per_body:
        compared['poses'] = types.POSE_ARRAY
    for robot in builder.robots:
        compared[robot.kind] = types.JOINT_STATE
        compared[robot.wrench_kind] = types.MULTI_DOF_JOINT_STATE
        if robot.odom_kind:
            compared[robot.odom_kind] = types.ODOMETRY
    return compared


#: The message types of the robots' command inputs.
COMMAND_TYPES = (types.JOINT_STATE, types.FLOAT64_MULTI_ARRAY, types.JOINT_TRAJECTORY)


def command_for_topic(session: SimSession, topic: str) -> Optional[str]:
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


def output_kind(kinds: Dict[str, str], topic: str, type_name: str) -> Optional[str]:
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


def drag_for_topic(session: SimSession, topic: str) -> str:
    """Map a recorded drag topic (``drag``, ``<body>/drag``, ``/clicked_point``) to its input."""
    if topic == '/clicked_point':
        return 'clicked_point'
    for name in sorted(session.drags.input_names, key=len, reverse=True):
        if topic.endswith('/' + name):
            return name
    raise ReplayError(f'recorded drag topic {topic!r} matches no drag input of the recorded '
                      f'configuration (inputs: {list(session.drags.input_names)})')


def input_for_topic(config: NodeConfig, topic: str) -> str:
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
    """Return ``(time_ns, message)`` of the recorded run's last non-finite step, or None."""
    run = bag.run_metadata or {}
    text = run.get(run_record.RUN_FAILURE_TIME_NS, '')
    if not text:
        return None
    try:
        return int(text), run.get(run_record.RUN_FAILURE, '')
    except ValueError:
        raise ReplayError(f'{bag.mcap_path}: the rbd_ros.run record has failure_time_ns '
                          f'{text!r}, not an integer (ns)') from None


@dataclasses.dataclass
class RecordedFailures:
    """
    The non-finite steps of a recording, by run: what replay must reproduce.

    ``by_run`` maps a run's index (0 = before any ``~/reset``) to its first failure
    ``(time_ns, message)``; ``later`` lists ``(run, time_ns)`` of failures after a run's first
    (the run went on after ``~/pause``: not replayed). ``unchecked`` counts the first runs whose
    failures the record cannot tell: an older node kept only its last failure (with no run),
    so a failure replay finds in a run before that one cannot be checked against it.
    ``remark`` says in which run such a failure was placed.
    """

    by_run: Dict[int, Tuple[int, str]]
    later: List[Tuple[int, int]]
    unchecked: int = 0
    remark: Optional[str] = None


def recorded_failures(bag: Bag, run_ends: List[int], gap_ns: int) -> RecordedFailures:
    """
    Return the recording's failures by run, each checked against its run's recorded messages.

    :param run_ends: the last log time of each run (its messages on the replayed topics).
    :param gap_ns: one publish period + one step: a failing run's last sample is at most that
        before its failure, so replay steps no further than that past a run's recording.
    :raises ReplayError: a malformed ``failures`` entry, a run the recording does not hold, a
        failure more than ``gap_ns`` after its run's last message, or ``failure_time_ns``
        other than the last of ``failures``.
    """
    run = bag.run_metadata or {}
    where = f'{bag.mcap_path}: the rbd_ros.run record'
    text = run.get(run_record.RUN_FAILURES)
    if text is None:  # an older node's record: its last failure only, with no run
        return _legacy_failures(bag, run_ends, gap_ns)
    try:
        entries = json.loads(text)
        failures = [(e['run'], e['time_ns'], e['message']) for e in entries]
    except (ValueError, TypeError, KeyError, RecursionError):
        raise ReplayError(f'{where} has failures {text[:200]!r}, not a JSON list of '
                          '{"run", "time_ns", "message"}') from None
    by_run, later = {}, []
    for number, time_ns, message in failures:
        if not (type(number) is int and type(time_ns) is int  # not a bool, nor a float
                and isinstance(message, str)) or number < 0 or time_ns < 0:
            raise ReplayError(f'{where} has the failure entry {[number, time_ns, message]!r}: '
                              'run and time_ns must be integers >= 0, message a string')
        _check_failure_time(where, number, time_ns, run_ends, gap_ns)
        if number in by_run:
            later.append((number, time_ns))
        else:
            by_run[number] = (time_ns, message)
    last = str(failures[-1][1]) if failures else ''
    if run.get(run_record.RUN_FAILURE_TIME_NS, '') != last:
        raise ReplayError(f'{where} has failure_time_ns '
                          f'{run.get(run_record.RUN_FAILURE_TIME_NS, "")!r} but its failures '
                          f'end with {last or "none"!r}: not what the node writes')
    return RecordedFailures(by_run, later)


def _check_failure_time(where, number, time_ns, run_ends, gap_ns):
    if number >= len(run_ends):
        raise ReplayError(f'{where} puts a failure in run {number + 1} but the recording holds '
                          f'{len(run_ends)} run(s)')
    if time_ns > run_ends[number] + gap_ns:
        raise ReplayError(
            f'{where} puts the failure at {time_ns} ns, more than one publish period + one '
            f'step after the last recorded message at {run_ends[number]} ns'
            + (f' of run {number + 1}' if len(run_ends) > 1 else ''))


def _legacy_failures(bag, run_ends, gap_ns):
    """
    Place the one failure of an older node's record in a run.

    That node kept its last failure: the last run whose recording ends at most ``gap_ns``
    before it (a failing run records nothing after its failure).
    """
    failure = recorded_failure(bag)
    if failure is None:  # no failure (or no record: not finalised)
        return RecordedFailures({}, [])
    time_ns = failure[0]
    fits = [n for n, end in enumerate(run_ends) if end <= time_ns <= end + gap_ns]
    number = fits[-1] if fits else len(run_ends) - 1
    _check_failure_time(f'{bag.mcap_path}: the rbd_ros.run record', number, time_ns, run_ends,
                        gap_ns)
    remark = None
    if len(run_ends) > 1:
        remark = ('the rbd_ros.run record (of an older node) keeps one failure and not its run: '
                  f"taken to be run {number + 1}'s, the last run whose recording ends within "
                  'one publish period + one step before it')
    return RecordedFailures({number: failure}, [], unchecked=number, remark=remark)
