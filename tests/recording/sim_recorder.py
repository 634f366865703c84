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
Record a scripted run by driving SimSession and the node's RunRecorder (the node's path minus DDS).

It records what the node records, through the same :class:`rbd_ros.bag.recorder.RunRecorder`:
each wrench as it took effect (``WrenchStamped`` on the input's absolute topic, log time = start
of the step it was applied at), the outputs ``/pose``, ``/twist``, ``/odom`` (and ``/clock``
when ``publish_clock``; no ``/tf``) at every sample the session reports, as the CDR bytes of the
node's own :class:`rbd_ros.msgs.outputs.SampleBuilder`, and at close the ``rbd_ros.run``
record. Only the loop that drives the session is this file's: a script instead of DDS.
"""

from rbd_ros.bag.recorder import RunRecorder
from rbd_ros.bag.recording import BagWriter, open_bag
from rbd_ros.msgs import conversions
from rbd_ros.msgs import type_names
from rbd_ros.msgs.outputs import SampleBuilder, type_of
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.session import SimSession
from rclpy.serialization import serialize_message


def record_scripted_run(path, params, script, duration_ns, ended_by='duration_s',
                        exception=None, before_frame_rules=False, **writer_options):
    """
    Run ``params`` for ``duration_ns`` of sim time, submitting ``script`` wrenches; record.

    :param script: ``(time_ns, input_name, frame_id, force, torque)`` tuples in time order;
        each is submitted when sim time has reached ``time_ns`` (so it takes effect at the
        first step starting at or after it).
    :param ended_by: how the run record says the run ended.
    :param exception: ``(sim time ns, 'Type: message')`` of an exception to record as the
        node records one out of its loop, or None.
    :param before_frame_rules: record what a node before the robot link frame rules started
        (:func:`rbd_ros.sim.robots.check_link_frames`; e.g. two robots of one URDF, no
        ``frame_prefix``).
    :returns: the closed :class:`RunRecorder`.
    """
    config = NodeConfig.from_parameters(params, accepted_frames=[] if before_frame_rules
                                        else None)
    session = SimSession(config)
    session.paused = False
    recorder = RunRecorder(config, serialize_message, path, **writer_options)
    builder = SampleBuilder(config, tf=False)
    topics = {kind: '/clock' if kind == 'clock' else '/' + kind for kind in builder.kinds}
    for kind in builder.kinds:  # a robot's kinds too (joint_states, odom, joint_wrenches)
        recorder.add_topic(topics[kind], type_names.type_name(type_of(kind)), {'depth': 10})
    for spec in config.wrench_inputs:
        recorder.add_topic('/' + spec.topic, type_names.WRENCH_STAMPED, {'depth': 10},
                           spec.name)
    recorder.start(config.parameters)

    def publish():
        t = session.time_ns
        robots = session.simulator if config.robots else None
        for kind, data in builder.serialize(t, session.columns, session.contact_wrenches_w,
                                            robots):
            recorder.write(topics[kind], data, t)

    def message_of(event):
        return conversions.wrench_to_msg(event.frame_id, event.force, event.torque,
                                         event.time_ns)

    publish()
    queue = list(script)
    while session.time_ns < duration_ns:
        while queue and queue[0][0] <= session.time_ns:
            _, name, frame_id, force, torque = queue.pop(0)
            session.submit(name, frame_id, force, torque)
        until = min(duration_ns, queue[0][0]) if queue else duration_ns
        report = session.advance(1 << 40, until_ns=until)
        recorder.record_events(report.events, message_of)
        if report.sample_due:
            publish()
    recorder.exception = exception
    recorder.close(ended_by, session.time_ns)
    return recorder


def rewrite_bag(src, dst, config_edit=None, drop=None, edit=None, extra=(), run_edit=None,
                keep_run=True, run_drop=()):
    """
    Rewrite the bag ``src`` into ``dst`` message by message (a crafted copy for tests).

    :param config_edit: parameters to change in the stored configuration.
    :param drop: ``(index, raw) -> bool``: leave that message out.
    :param edit: ``(index, raw) -> bytes or None``: new CDR data for that message.
    :param extra: ``(topic, cdr, log_time_ns)`` messages to append.
    :param run_edit: entries to change in the ``rbd_ros.run`` record (copied otherwise).
    :param keep_run: False leaves the ``rbd_ros.run`` record out (as after SIGKILL).
    :param run_drop: keys to leave out of the ``rbd_ros.run`` record (an older node's record).
    """
    bag = open_bag(src)
    config = dict(bag.config)
    config.update(config_edit or {})
    writer = BagWriter(dst, config=config)
    for topic, info in bag.topics.items():
        writer.add_topic(topic, info.type_name, info.qos[0])
    for index, raw in enumerate(bag.messages()):
        if drop is not None and drop(index, raw):
            continue
        data = edit(index, raw) if edit is not None else None
        writer.write(raw.topic, raw.data if data is None else data, raw.log_time_ns,
                     raw.publish_time_ns)
    for topic, data, t in extra:
        writer.write(topic, data, t)
    run = None
    if keep_run and bag.run_metadata is not None:
        run = dict(bag.run_metadata, **(run_edit or {}))
        for key in run_drop:
            run.pop(key, None)
    writer.close(run_metadata=run)
    return dst
