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
What the node writes to its recording, without ROS: topics, meshes, inputs, samples, run record.

:class:`RunRecorder` wraps a :class:`rbd_ros.bag.recording.BagWriter`: the node (and the test
helper that records scripted runs without DDS) declare their topics on it, record every input
that takes effect at the start of the step it applies to (digesting it, for replay to compare),
write each sample's CDR bytes, and close it with the ``rbd_ros.run`` record, whose keys are the
``RUN_*`` constants below (replay reads them by the same names).
"""

import json

from rbd_ros.bag.recording import BagWriter
from rbd_ros.core import RbdError
from rbd_ros.sim import meshes
from rbd_ros.sim.session import AppliedDigest

# The keys of the rbd_ros.run record (every value is stored as a string).
RUN_FAILURE_TIME_NS = 'failure_time_ns'  # sim time of the last non-finite step ('' if none)
RUN_FAILURE = 'failure'  # its message ('' if none)
#: Every non-finite step, in order: a JSON list of {"run": runs before it, "time_ns", "message"}
#: ('run' counts the ~/reset calls before it: 0 = the first run); absent in older recordings.
RUN_FAILURES = 'failures'
RUN_ENDED_BY = 'ended_by'  # how the run ended: one of ENDINGS
RUN_ENDED_AT_NS = 'ended_at_ns'  # sim time at the end
RUN_EXCEPTION_TIME_NS = 'exception_time_ns'  # sim time of an exception out of the loop
RUN_EXCEPTION = 'exception'  # 'Type: message' of that exception ('' if none)
RUN_WRENCHES_APPLIED = 'wrenches_applied'  # how many inputs took effect
RUN_WRENCH_DIGEST = 'wrench_digest'  # their SHA-256 (rbd_ros.sim.session.AppliedDigest)
RUN_KEYS = (RUN_FAILURE_TIME_NS, RUN_FAILURE, RUN_FAILURES, RUN_ENDED_BY, RUN_ENDED_AT_NS,
            RUN_EXCEPTION_TIME_NS, RUN_EXCEPTION, RUN_WRENCHES_APPLIED, RUN_WRENCH_DIGEST)
#: The values of ``ended_by``: 'shutdown' is the ROS context shutting down, 'unknown' a close
#: without a reason given.
ENDINGS = ('duration_s', 'SIGINT', 'SIGTERM', 'non-finite step', 'exception', 'recording error',
           'start-up interrupted', 'shutdown', 'unknown')


def mesh_media_type(path):
    """Return the media type the recording gives the mesh file at ``path``."""
    return 'model/stl' if path.lower().endswith('.stl') else 'application/octet-stream'


def recorded_configuration(config):
    """
    Return the parameters a recording stores: ``config``'s, each robot's URDF inlined.

    A robot read from ``urdf_path`` is recorded with its XML as loaded (after xacro) in
    ``robot_description`` and ``urdf_path`` empty, so replay needs neither the file nor xacro.
    """
    params = config.to_parameters()
    for robot in config.robots:
        params[f'robots.{robot.name}.robot_description'] = robot.robot.urdf
        params[f'robots.{robot.name}.urdf_path'] = ''
    return params


class RunRecorder:
    """
    One run's recording: the bag writer, the digest of the applied inputs, the run record.

    :param serialize: message -> CDR bytes, for what is written as a message object (the node
        passes ``rclpy.serialization.serialize_message``); bytes are written as they are.
    """

    def __init__(self, config, serialize, path=None, **writer_options):
        """Open ``path`` (default ``config.record_path``) to record ``config``, a NodeConfig."""
        self.writer = BagWriter(config.record_path if path is None else path,
                                config=recorded_configuration(config), **writer_options)
        self._serialize = serialize
        self.digest = AppliedDigest()  # what the run applied, for replay to compare
        self.failures = []  # (run, sim time ns, message) of each non-finite step (note_failure)
        self.exception = None  # (sim time ns, 'Type: message') of an exception out of the loop
        self.input_topics = {}  # input name -> the topic its messages are recorded on

    @property
    def path(self):
        """Return the bag directory."""
        return self.writer.path

    @property
    def failed(self):
        """Return the error that stopped the writer mid-run, or None."""
        return self.writer.failed

    def add_topic(self, topic, type_name, qos, input_name=None):
        """Declare ``topic``; ``input_name``: the input whose applied messages go there."""
        self.writer.add_topic(topic, type_name, qos)
        if input_name is not None:
            self.input_topics[input_name] = topic

    def start(self, parameters):
        """
        Attach the mesh files of ``parameters`` (so replay needs no files) and flush.

        A full disk fails here, at start, not mid-run; on an error the writer is closed.
        """
        try:
            for name, value in sorted(parameters.items()):
                if name.endswith('mesh_path') and value:
                    # a regular file within MAX_MESH_FILE_BYTES, as config checked it
                    self.writer.add_file(value, meshes.read_mesh_file(value, name),
                                         mesh_media_type(value))
            self.writer.flush()
        except RbdError:
            self.writer.close()
            raise

    def write(self, topic, msg, time_ns):
        """Record ``msg`` (a message, or its CDR bytes) on ``topic`` at ``time_ns``."""
        self.writer.write(topic, msg if isinstance(msg, bytes) else self._serialize(msg),
                          time_ns)

    def write_sample(self, messages, time_ns):
        """Record a sample's ``[(topic, CDR bytes)]`` at ``time_ns`` (one call, in order)."""
        self.writer.write_many(messages, time_ns)

    def record_events(self, events, message_of=None):
        """
        Digest and record the inputs that take effect at a step start (before that step).

        :param message_of: event -> its message (default: the event's tag, the message the
            node received).
        """
        for event in events:
            self.digest.update(event)
            self.write(self.input_topics[event.input_name],
                       event.tag if message_of is None else message_of(event), event.time_ns)

    def note_failure(self, run, time_ns, message):
        """
        Note a non-finite step of run ``run`` (the ``~/reset`` calls before it) at ``time_ns``.

        The same step failing again (``~/pause`` off or ``~/step`` with nothing changed) is
        noted once: the first failure of a step is the one replay reproduces.
        """
        if self.failures and self.failures[-1][:2] == (run, time_ns):
            return
        self.failures.append((run, time_ns, message))

    def run_record(self, ended_by, ended_at_ns):
        """Return the ``rbd_ros.run`` record of a run that ended so (keys :data:`RUN_KEYS`)."""
        _, failure_ns, failure = self.failures[-1] if self.failures else ('', '', '')
        crash_ns, crash = self.exception or ('', '')
        failures = [{'run': run, 'time_ns': time_ns, 'message': message}
                    for run, time_ns, message in self.failures]
        return {RUN_FAILURE_TIME_NS: failure_ns, RUN_FAILURE: failure,
                RUN_FAILURES: json.dumps(failures),
                RUN_ENDED_BY: ended_by or 'unknown', RUN_ENDED_AT_NS: ended_at_ns,
                RUN_EXCEPTION_TIME_NS: crash_ns, RUN_EXCEPTION: crash,
                RUN_WRENCHES_APPLIED: self.digest.count,
                RUN_WRENCH_DIGEST: self.digest.hexdigest()}

    def close(self, ended_by=None, ended_at_ns=None):
        """
        Finalise the recording with its run record; without ``ended_at_ns``, without one.

        A writer that failed mid-run is closed without a record (its error was reported).

        :raises RecordingError: the recording could not be finalised.
        """
        if self.failed is not None or ended_at_ns is None:
            self.writer.close()
            return
        self.writer.close(run_metadata=self.run_record(ended_by, ended_at_ns))
