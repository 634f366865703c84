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
``rigid_body_node``: the simulator's rclpy node. Parameters in, wrenches in, state out.

Time is sim time. (:mod:`rbd_ros.ros.demo` is the other rclpy code: a client of this node.)
Everything else lives in rclpy-free modules: :mod:`rbd_ros.sim.config` (parameters),
:mod:`rbd_ros.sim.session` (stepping, wrench hold and expiry, publish schedule),
:mod:`rbd_ros.msgs.outputs` (a sample's messages as CDR bytes, published and recorded alike),
:mod:`rbd_ros.msgs.conversions` (the other messages) and :mod:`rbd_ros.ros.ros_args` (the parameter
overrides in the ROS arguments), :mod:`rbd_ros.sim.pacing` (the wall clock pacing the fixed
physics step), :mod:`rbd_ros.sim.diagnostics` (the ``/diagnostics`` values) and
:mod:`rbd_ros.bag.recorder` (what the run records). A tick steps for at most
:data:`rbd_ros.sim.pacing.TICK_BUDGET_NS` of wall time and then returns to the spin loop, so a
node behind the wall clock (a slow world, a high factor) still takes wrenches and service calls
within about that time; the steps left due run in the next tick. Timers run on a
steady clock, so ``use_sim_time`` (which launch files set on every node) cannot freeze the
node: its stamps are always its own sim time.
"""

import dataclasses
from operator import itemgetter
import sys
import threading
import time

from geometry_msgs.msg import PointStamped
import numpy as np
from rbd_ros.core import ConfigError, jitcache, NonFiniteError, RbdError, RecordingError
from rbd_ros.msgs import conversions as conv
from rbd_ros.msgs import markers
from rbd_ros.msgs import outputs
from rbd_ros.msgs import type_names as types
from rbd_ros.msgs.marker_bytes import MarkerArrayBytes
from rbd_ros.ros import endpoints
from rbd_ros.ros import parameters
from rbd_ros.ros import ros_args
from rbd_ros.sim import build
from rbd_ros.sim import config as cfg
from rbd_ros.sim import meshes as mesh_files
from rbd_ros.sim import pacing
from rbd_ros.sim import params as sim_params
from rbd_ros.sim.diagnostics import Diagnostics
from rbd_ros.sim.diagnostics import status as diagnostics_status
from rbd_ros.sim.drag import CLICKED_POINT
from rbd_ros.sim.inputs import WrenchRejected
from rbd_ros.sim.session import SimSession
from rcl_interfaces.msg import SetParametersResult
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import NameValidationException
from rclpy.node import Node
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray, String
from std_srvs.srv import SetBool, Trigger
from trajectory_msgs.msg import JointTrajectory
from visualization_msgs.msg import MarkerArray

#: At most this share of the wall time goes to the spin loop's wake-ups as fast as possible:
#: one costs ~0.6 µs per subscription (rbd_ros.ros.wakeups; a world of 1,000 bodies: ~2.5 ms),
#: so the tick budget grows to that many wake-ups' worth, up to MAX_TICK_BUDGET_NS (the latency
#: of an input then). Not less: a wake-up serves one callback, so a tick budget longer than
#: needed delays a burst of inputs on many topics (tests/ros/test_node_behind.py).
SPIN_SHARE = 0.1
MAX_TICK_BUDGET_NS = 100_000_000
#: The outputs' subscribers are looked at no more often than this (wall ns), and so that the
#: looks take at most LOOK_SHARE of the wall time (see RigidBodyNode.look_at_subscribers).
LOOK_PERIOD_NS = 5_000_000
LOOK_SHARE = 0.01
#: Set once the node has loaded its meshes and run its first step (see RigidBodyNode).
PAST_SLOW_START_UP = threading.Event()


def _world_markers(config):
    """
    Return the :class:`markers.BodyMarkers` of the body (bodies) of ``config``.

    A body read from a mesh file is drawn from that file (``mesh_resource``: the
    ``package://`` URI as given, else the ``file://`` URI of the file loaded), so each sample
    carries its URI and pose, not its triangles.
    """
    meshes = []
    for prefix in (b.parameter_prefix for b in config.bodies):
        path = config.parameters.get(prefix + 'mesh_path', '')
        uri = markers.mesh_uri(path, mesh_files.resolve_mesh_path(path, prefix + 'mesh_path')) \
            if path else None
        meshes.append((uri, config.parameters.get(prefix + 'mesh_scale', (1.0, 1.0, 1.0)))
                      if path else None)
    return markers.BodyMarkers([b.label for b in config.bodies],
                               [b.collision_shape for b in config.bodies], config.world_frame,
                               meshes)


def say(what):
    """Print the one line of a refusal or an ending at start-up: ``rigid_body_node: <what>``."""
    print(f'rigid_body_node: {what}', file=sys.stderr, flush=True)


class _FirstStepCheck(threading.Thread):
    """
    The first-step check of a cold start, off the spin loop: it compiles the physics kernels.

    The node serves meanwhile: it is on the graph, publishes its state at t = 0 (to a late
    subscriber too), takes parameters, services and inputs (held until the first step), and
    steps once the check passed. ``error`` is what the check raised, or None.
    """

    def __init__(self, config, kind):
        super().__init__(name='rigid_body_node compile', daemon=True)
        self.config, self.kind, self.error, self.took_s = config, kind, None, None

    def run(self):
        start = time.monotonic()
        try:
            build.check_first_step(self.config)
        except BaseException as exc:  # handed to the spin loop (RigidBodyNode._poll_compile)
            self.error = exc
        self.took_s = time.monotonic() - start


class RigidBodyNode(Node):
    """Simulate one rigid body; see doc/ for parameters, topics and services."""

    def __init__(self, global_args=None, **kwargs):
        """
        Create the node; ``global_args`` are the arguments given to ``rclpy.init`` (None: argv).

        The other keyword arguments are :class:`rclpy.node.Node`'s.
        """
        try:
            super().__init__('rigid_body_node', **kwargs)
        except NameValidationException as exc:  # a namespace too long for rclpy's services
            lines = str(exc).splitlines()  # 'Invalid <what>: <why>:', '  <name>', '  ^'
            name = lines[1].strip().strip("'") if len(lines) > 1 else ''
            reason = lines[0].rstrip(':')
            raise ConfigError(f"the node's name or namespace (-r __ns:=...) makes "
                              f'{endpoints.shown_name(name)} ({len(name)} characters): '
                              f"{reason}; rcl's limit is "
                              f'{endpoints.TOPIC_NAME_MAX_CHARS} characters') from None
        # Validate the overrides ourselves first so that a bad value gives our one-line message
        # (rclpy would reject an out-of-range value with its own), then declare the validated
        # values. rclpy has no public accessor for the overrides before declaration: they are
        # read from the same arguments, as rcl and rclpy read them (rbd_ros.ros.ros_args).
        overrides = self._read_overrides(global_args, kwargs)
        # What the endpoints look at (each looks at every one): the qos_overrides.* ones.
        self._overrides = {name: value for name, value in overrides.items()
                           if name.startswith('qos_overrides.')}
        params = {}
        for name, value in overrides.items():
            if parameters.is_ours(name):
                params[name] = value
            elif not parameters.is_rclpys(name):
                self.get_logger().warning(f'ignoring unknown parameter {name} = {value!r}')
        self.config = config = cfg.NodeConfig.from_parameters(params)
        endpoints.check_names(self, config)  # before any endpoint: a name past rcl's limit
        endpoints.check_input_topics(self, config)
        self._warm_up()
        # The slow part of start-up is over (meshes loaded, kernels compiled and run once): from
        # here on a signal lets the node finish starting (linear in the bodies) and then stops
        # it as usual, so that a node seen on the graph always leaves a finalised recording.
        PAST_SLOW_START_UP.set()
        for spec in config.all_specs():
            parameters.declare(self, spec, config.parameters[spec.name])
        self.add_pre_set_parameters_callback(parameters.coerce_parameters)
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.session = SimSession(config)
        self.done = False
        self.exit_status = 0
        #: How the run ended, for the rbd_ros.run record: 'duration_s', 'SIGINT', 'SIGTERM',
        #: 'non-finite step', 'exception', 'recording error', 'start-up interrupted' or
        #: 'shutdown' (the ROS context shut down); '' while it runs.
        self.ended_by = ''
        self._crash = None  # (sim time ns, 'Type: message') of an exception out of the loop
        self._pacer = pacing.Pacer(config.real_time_factor)

        self._recorder = None
        self._create_outputs()
        self._create_inputs()
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.create_service(Trigger, '~/step', self._on_step)
        if config.record_path:
            self._open_recording()
        try:
            self._start()
        except BaseException:  # a signal or an error after the recording opened: finalise it
            self.ended_by = self.ended_by or 'start-up interrupted'
            self._close_recording()
            raise
        if self._compiling is not None:
            # A subscriber that comes during the compile gets t = 0 (_poll_compile).
            self._unpublished = {kind for kind, count in self._subscribed if not count()}
            self._unpublished_of = None
            self._compiling.start()

    def _create_outputs(self):
        """Create a publisher per output kind, diagnostics and, with contact, markers."""
        config = self.config
        self._builder = outputs.SampleBuilder(config)
        self._columns = self.session.columns
        # One publisher per output kind: pose, twist, odom (per body in a world: <body>/pose,
        # ...), contact_wrench with contact, poses in a world, /clock and /tf when on.
        depth = {'clock': 10, 'tf': 100}
        self._pubs = {kind: self._publisher(outputs.type_of(kind), outputs.topic_of(kind),
                                            depth.get(kind, endpoints.STATE_QOS),
                                            light=self._per_body(kind))
                      for kind in self._builder.kinds}
        self._pubs['diagnostics'] = self._publisher(conv.DiagnosticArray, '/diagnostics', 10)
        self._markers = None
        if config.contact and config.publish_markers:
            # Shapes for RViz and Foxglove: bodies, moving links and the last step's contacts at
            # every sample on markers; the static world (a robot's links fixed to the world too)
            # once on static_markers (transient local, so a late subscriber gets it).
            self._markers = _world_markers(config)
            self._link_markers = markers.LinkMarkers(config.robots, config.world_frame,
                                                     len(config.bodies))
            self._markers_cdr = MarkerArrayBytes(
                self._markers.markers + self._link_markers.stamped(0),
                len(self._markers.markers), markers.contact_prototypes(config.world_frame, 0))
            self._pubs['markers'] = self._publisher(MarkerArray, 'markers', 10)
            self._pubs['static_markers'] = self._publisher(MarkerArray, 'static_markers',
                                                           endpoints.STATE_QOS)
        # The samples' CDR bytes go straight to each publisher's rcl handle (rclpy's public
        # ``Publisher.handle``), as ``Publisher.publish`` and ``get_subscription_count`` do
        # after a type check and a ``with handle`` guard against a concurrent destroy (this
        # node destroys its publishers only after its last tick): 0.3 µs a call instead of
        # 1.3-2.3 µs, which a world of 100 bodies (400 per-body topics) paid at every sample
        # (20 % of a node stepping flat out).
        self._sample_pubs = {kind: (self._pubs[kind].handle.publish_raw,
                                    self._pubs[kind].topic_name)
                             for kind in self._builder.kinds}
        self._sample_topics = [self._sample_pubs[kind][1] for kind in self._builder.kinds]
        self._subscribed = [(kind, self._pubs[kind].handle.get_subscription_count)
                            for kind in self._builder.kinds]
        self._counted = self._subscribed + ([
            ('markers', self._pubs['markers'].handle.get_subscription_count)]
            if self._markers is not None else [])
        if self._markers is not None:
            self._markers_publish = self._pubs['markers'].handle.publish_raw
        self._unpublished = set()  # kinds whose latest sample was not built (nobody listened)
        self.look_at_subscribers(force=True)
        self._robots = self.session.simulator if config.robots or config.world_joints else None
        # Each robot's URDF as loaded (after xacro), once, transient local: RViz's RobotModel
        # and every late subscriber get it.
        for robot in config.robots:
            self._pubs[f'{robot.name}/robot_description'] = self._publisher(
                String, f'{robot.name}/robot_description', endpoints.STATE_QOS)
        if config.publish_tf and 'tf' not in self._builder.kinds:
            self.get_logger().info('tf2_msgs is not importable: not broadcasting /tf')

    def _per_body(self, kind):
        """Return whether the output ``kind`` is a body's of a world (a light endpoint)."""
        return self.config.named and kind not in ('poses', 'clock', 'tf')

    def _create_inputs(self):
        """Subscribe the wrench inputs, the drags and /clicked_point; check qos_overrides."""
        config, overrides = self.config, self._overrides
        light = config.named  # each body's inputs of a world: light endpoints
        self._input_subs = [endpoints.subscription(
            self, overrides, conv.WrenchStamped, spec.topic,
            lambda msg, name=spec.name: self._on_wrench(name, msg), light=light)
            for spec in config.wrench_inputs]
        # Drags: drag (<body>/drag in a world) and /clicked_point (RViz, Foxglove).
        drag_topics = {name: name for name in self.session.drags.input_names}
        drag_topics[CLICKED_POINT] = '/clicked_point'
        point_subs = [endpoints.subscription(
            self, overrides, PointStamped, topic, lambda msg, name=name: self._on_point(name, msg),
            light=light and name != CLICKED_POINT)
            for name, topic in drag_topics.items()]
        self._input_topics = {spec.name: sub.topic_name
                              for spec, sub in zip(config.wrench_inputs, self._input_subs)}
        self._input_topics.update({name: sub.topic_name
                                   for name, sub in zip(drag_topics, point_subs)})
        self._input_subs += point_subs
        self._create_command_inputs()
        # After every endpoint (the drag and /clicked_point subscriptions included): an
        # override that rclpy declared as a parameter was applied to one of them.
        for name in overrides:
            if name.startswith('qos_overrides.') and not self.has_parameter(name):
                self.get_logger().warning(
                    f'ignoring {name}: no endpoint of this node has that topic and policy '
                    '(qos_overrides.<absolute topic>.publisher|subscription.history|depth|'
                    'reliability|durability)')

    def _create_command_inputs(self):
        """Subscribe each robot's joint_command and each group's commands and trajectory."""
        commands = self.session.commands
        if commands is None:
            return
        kinds = {'joint_command': JointState, 'commands': Float64MultiArray,
                 'joint_trajectory': JointTrajectory}
        for name, spec in commands.inputs.items():
            sub = endpoints.subscription(
                self, self._overrides, kinds[spec.kind], name,
                lambda msg, name=name: self._on_command(name, msg))
            self._input_subs.append(sub)
            self._input_topics[name] = sub.topic_name

    def _on_command(self, name, msg):
        kind = self.session.commands.inputs[name].kind
        if kind == 'joint_trajectory':
            payload = conv.trajectory_from_msg(msg)
        elif kind == 'commands':
            payload = list(msg.data)
        else:
            payload = conv.joint_command_from_msg(msg)
        self._on_input(name, msg, lambda: self.session.submit_command(name, payload, tag=msg),
                       'command')

    def _start(self):
        config = self.config
        # Physics ticks come from the spin loop in main() (seconds_to_next_step, then tick);
        # the diagnostics timer runs on a steady clock, whatever use_sim_time says.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(1.0, self._publish_diagnostics, clock=steady)
        if self._markers is not None:  # with the robots' links fixed to the world
            static = markers.static_markers(config.static_world, config.world_frame, 0)
            static.markers.extend(self._link_markers.static)
            self._publish('static_markers', static, 0)
        for robot in config.robots:
            self._publish(f'{robot.name}/robot_description', String(data=robot.robot.urdf), 0)
        self._publish_sample()
        self._anchor()  # sim time 0 = now: pacing starts when the node is ready
        self._diagnostics = Diagnostics(self.session, self._pacer)

    def _publisher(self, msg_type, topic, qos, light=False):
        return endpoints.publisher(self, self._overrides, msg_type, topic, qos, light)

    def _read_overrides(self, global_args, kwargs):
        """Return name → value of this node's parameter overrides (rclpy's precedence)."""
        try:
            return ros_args.node_overrides(
                self.get_fully_qualified_name(), global_args, kwargs.get('cli_args'),
                kwargs.get('use_global_arguments', True),
                {p.name: p.value for p in kwargs.get('parameter_overrides') or ()})
        except ros_args.RosArgsError as exc:  # rcl read the same moments ago
            raise ConfigError(str(exc)) from None

    def _on_set_parameters(self, params):
        for param in params:
            if param.name == 'use_sim_time':
                # The node's stamps are its own sim time and its timers run on a steady clock:
                # use_sim_time changes nothing, so a live change that claims to is refused.
                return SetParametersResult(successful=False, reason=(
                    f'parameter use_sim_time = {param.value!r}: read-only at run time (the '
                    'node stamps everything with its own sim time whatever it says; set it '
                    'at start, as launch files do)'))
            if param.name == 'real_time_factor':
                try:
                    sim_params.check_real_time_factor(param.value)
                except RbdError as exc:
                    return SetParametersResult(successful=False, reason=str(exc))
        for param in params:
            if param.name == 'real_time_factor':
                self._pacer.set_factor(param.value, self.session.time_ns)
        return SetParametersResult(successful=True)

    def _open_recording(self):
        from rbd_ros.bag.recorder import RunRecorder
        recorder = RunRecorder(self.config, serialize_message,
                               overwrite=self.config.record_overwrite)
        inputs = {topic: name for name, topic in self._input_topics.items()}
        try:
            for pub in list(self._pubs.values()) + self._input_subs:
                qos = pub.qos_profile  # what the endpoint really offers (qos_overrides included)
                recorder.add_topic(pub.topic_name, types.type_name(pub.msg_type), {
                    'history': qos.history.name.lower(), 'depth': qos.depth,
                    'reliability': qos.reliability.name.lower(),
                    'durability': qos.durability.name.lower()}, inputs.get(pub.topic_name))
        except RbdError:
            recorder.close()
            raise
        recorder.start(self.config.parameters)
        self._recorder = recorder
        # Every input that takes effect is recorded at its step start, before that step runs.
        self.session.on_applied = self._record_events
        self.get_logger().info(f'recording to {recorder.path}')

    def _record_events(self, events):
        """Record the inputs that take effect at a step start (called before that step)."""
        if self._recorder is not None:
            self._guarded(self._recorder.record_events, events)

    def _record(self, topic, msg, time_ns):
        """Record ``msg`` (a message, or its CDR bytes) if recording."""
        if self._recorder is not None:
            self._guarded(self._recorder.write, topic, msg, time_ns)

    def _guarded(self, write, *args):
        try:
            write(*args)
        except RecordingError as exc:
            stop = self.config.record_on_error == 'stop'
            then = 'stopping the node (record_on_error: stop)' if stop else 'simulating on'
            self.get_logger().error(f'recording stopped: {exc}; {then}')
            self.exit_status = 1
            self.ended_by = self.ended_by or 'recording error'
            self._close_recording()
            self.done = self.done or stop

    def _publish(self, key, msg, time_ns):
        pub = self._pubs[key]
        pub.publish(msg)
        self._record(pub.topic_name, msg, time_ns)

    def _anchor(self):
        self._pacer.anchor(self.session.time_ns)

    def seconds_to_next_step(self, longest_s=0.1):
        """
        Wall seconds until the step that ends at the next sample is due (``longest_s`` cap).

        The steps before it publish nothing, so the spin loop sleeps through them and
        :meth:`tick` runs them when it wakes (an input wakes it earlier; ``process.spin_once``
        then runs the steps due before the input's callback): one wake-up a sample, not one a
        step, at the same sim times and the same bits. 0 at RTF 0.
        """
        session = self.session
        if session.paused or self.done or self._compiling is not None:
            return longest_s
        return self._pacer.seconds_to_next_step(session.time_ns, session.timestep_ns, longest_s,
                                                session.steps_to_next_output())

    def tick(self):
        """Run the steps due by the wall clock (at RTF 0: steps) for at most the tick budget."""
        session = self.session
        if self._compiling is not None and self._poll_compile():
            return
        if session.paused and self._unpublished and not self.done:
            self._publish_late()
        if session.paused or self.done:
            return
        deadline_ns = time.monotonic_ns() + self._tick_budget_ns
        if self._pacer.real_time_factor == 0:
            self._run(sys.maxsize, deadline_ns=deadline_ns)
            return
        due, dropped = self._pacer.due_steps(
            session.time_ns, session.timestep_ns,
            (session.steps_to_next_output() - 1) * session.timestep_ns)
        if dropped:  # too far behind: the cap kept, the rest dropped
            self.get_logger().warning('falling behind the wall clock: dropping wall time',
                                      throttle_duration_sec=5.0)
        if due > 0:
            self._run(due, deadline_ns=deadline_ns)

    _tick_budget_ns = pacing.TICK_BUDGET_NS

    def note_wake_up(self, wall_ns):
        """
        Note that a wake-up of the spin loop that waited for nothing took ``wall_ns``.

        The tick budget becomes what keeps those wake-ups at :data:`SPIN_SHARE` of the wall
        time (never below :data:`rbd_ros.sim.pacing.TICK_BUDGET_NS`, at most
        :data:`MAX_TICK_BUDGET_NS`), so the spin loop's share does not grow with the
        endpoints; a mean over the last ~8 wake-ups.
        """
        self._wake_up_ns = wall_ns if self._wake_up_ns is None else \
            (7 * self._wake_up_ns + wall_ns) // 8
        self._tick_budget_ns = min(MAX_TICK_BUDGET_NS, max(
            pacing.TICK_BUDGET_NS, int(self._wake_up_ns * (1 - SPIN_SHARE) / SPIN_SHARE)))

    _wake_up_ns = None

    def _run(self, n_steps, manual=False, deadline_ns=None):
        """
        Take ``n_steps`` (one when ``manual``), publishing the samples that fall due.

        With ``deadline_ns`` (monotonic), stop once it has passed; each call into the session
        asks for as many steps as the last call's wall time per step says still fit. While no
        sample would be built (nobody listens to any output, nothing is recorded), the steps
        up to the sample time at or after those go in as few compiled calls as the session
        allows (:meth:`SimSession.advance` ``through_samples``: the same bits; each call has a
        cost of its own, the threads' hand-off and the parts' check among it), and the samples
        before it are skipped, as they would be anyway; the subscribers are looked at there.
        """
        session = self.session
        while n_steps > 0 and not self.done:
            ask = n_steps
            if deadline_ns is not None:
                start_ns = time.monotonic_ns()
                if start_ns >= deadline_ns:
                    return
                ask = self._pacer.steps_that_fit(n_steps, start_ns, deadline_ns)
            quiet = not (manual or self._listened or self._recorder is not None)
            if quiet:  # to the sample time at or after the steps asked for
                ask = min(n_steps, ask - 1 + session.steps_to_next_sample(
                    session.time_ns + (ask - 1) * session.timestep_ns))
            try:
                report = session.step() if manual else session.advance(
                    ask, through_samples=quiet)
            except NonFiniteError as exc:
                self._warn_releases()
                # The inputs of the failing step, the one that caused it included, are in the
                # bag already (session.on_applied); the failure goes to the run record, with
                # the run it ended (the ~/reset calls before it), for replay to judge each run.
                if self._recorder is not None:
                    self._recorder.note_failure(self.session.resets, self.session.time_ns,
                                                str(exc))
                if self.config.duration_ns and not manual:
                    # A run with an end: it cannot reach it, so it ends now, with status 1.
                    self.get_logger().error(f'{exc}; stopping (duration_s is set): exit 1')
                    self.ended_by = 'non-finite step'
                    self.exit_status = 1
                    self.done = True
                else:
                    self.get_logger().error(
                        f'{exc}; paused (call ~/reset, then ~/pause with data false to run on)')
                return
            self._warn_releases()
            if deadline_ns is not None and report.steps:
                self._pacer.measured(start_ns, report.steps)
            rejected, self.session.drags.last_rejection = self.session.drags.last_rejection, None
            if rejected is not None:  # a point over max_force_n / max_torque_nm at its step
                self._warn_rejected('drag point', rejected)
            if report.sample_due:
                self._publish_sample()
            if self.session.finished and not manual:
                self.get_logger().info(f'duration_s reached at t = {self.session.time_ns} ns')
                self.ended_by = 'duration_s'
                self.done = True
            if report.steps == 0 or manual:
                return
            n_steps -= report.steps

    def look_at_subscribers(self, force=False):
        """
        Note which outputs have subscribers now; before a sample is published.

        Not at every sample: a ``get_subscription_count`` call costs ~0.5 µs, and a world of
        100 bodies has 400 per-body topics, which at every sample cost as much as 20 % of the
        physics. The look is taken at a sample at least :data:`LOOK_PERIOD_NS` after the
        last one, and later if the looks would take more than :data:`LOOK_SHARE` of the wall
        time (100 times the last look's wall time: ~20-50 ms for 400 topics, more for
        thousands); ``force``: now. A subscriber that appears gets the samples from the next
        look on.
        """
        start_ns = time.monotonic_ns()
        if start_ns < self._next_look_ns and not force:
            return
        listened = {kind for kind, count in self._counted if count()}
        if listened != self._listened:  # the same set object while nothing changes
            self._listened = listened
        now_ns = time.monotonic_ns()
        self._next_look_ns = start_ns + max(LOOK_PERIOD_NS,
                                            int((now_ns - start_ns) / LOOK_SHARE))

    _next_look_ns = 0

    _listened = frozenset()
    _unpublished_of = None  # the set of wanted kinds _unpublished was computed from

    def _publish_sample(self):
        """
        Publish the current sample; record the same CDR bytes.

        A kind nobody subscribed to at the last look (:meth:`look_at_subscribers`) is not
        published, and not recording, not even built: a subscriber that appears gets the
        samples from the next look on, or while paused the current one
        (:meth:`_publish_late`). Paused (a ~/step, a ~/reset) every kind is published: a
        transient-local subscriber that comes later must get this sample, not an older one
        still held by the publisher.
        """
        self.look_at_subscribers()
        t = self.session.time_ns
        recording = self._recorder is not None
        published = None if self.session.paused else self._listened
        samples = self._builder.serialize(t, self._columns, self.session.contact_wrenches_w,
                                          self._robots, None if recording else published)
        pubs = self._sample_pubs
        if published is None:
            for kind, data in samples:
                pubs[kind][0](data)
        elif published:  # (none while nobody listens, as when only recording)
            for kind, data in samples:
                if kind in published:
                    pubs[kind][0](data)
        if recording:  # every kind, in the builder's kinds order (serialize's)
            self._guarded(self._recorder.write_sample,
                          list(zip(self._sample_topics, map(itemgetter(1), samples))), t)
        if published is None:
            self._unpublished, self._unpublished_of = set(), None
        elif published is not self._unpublished_of:
            self._unpublished, self._unpublished_of = set(pubs).difference(published), published
        if self._markers is not None and (recording or 'markers' in self._listened):
            # Serialised once: the subscribers and the recording get the same bytes.
            data = self._marker_bytes(t)
            if 'markers' in self._listened:
                self._markers_publish(data)
            self._record(self._pubs['markers'].topic_name, data, t)

    def _publish_late(self):
        """While paused: give a subscriber that appeared the sample its topic skipped."""
        late = {kind for kind in self._unpublished if self._pubs[kind].get_subscription_count()}
        if late:
            self._unpublished -= late
            self._unpublished_of = None
            t = self.session.time_ns
            for kind, data in self._builder.serialize(
                    t, self._columns, self.session.contact_wrenches_w, self._robots, late):
                self._sample_pubs[kind][0](data)

    def _marker_bytes(self, t):
        """Return the ``markers`` CDR bytes: the bodies at their poses, the links, the contacts."""
        # The poses exactly as the pose topics carry them (the sample builder's values).
        positions, quats = self._builder.poses_wxyz(self._columns)
        contacts = self.session.simulator.contacts
        if len(contacts):
            last = contacts.stage == contacts.stage.max()
            count = int(np.count_nonzero(last))
            if last[-count:].all():  # the last stage's rows are the tail (they are sorted so)
                last = slice(-count, None)  # views, not copies
            contacts = type(contacts)(*(getattr(contacts, f.name)[last]
                                        for f in dataclasses.fields(contacts)))
        # Lines of 1 cm per N: the last stage's impulse over the step.
        return self._markers_cdr.serialize(
            t, self._markers.poses(positions, quats, normalise=False), markers.contact_points(
                contacts, 0.01 / (self.config.timestep_ns * 1e-9)))

    def _publish_diagnostics(self):
        s = self.session
        values = self._diagnostics.values()
        level, message = diagnostics_status(s, values)
        if self._compiling is not None:
            message = 'compiling the physics kernels: sim time starts when they are compiled'
        self._publish('diagnostics', conv.diagnostics_to_msg(
            s.time_ns, f'{self.get_fully_qualified_name()}: rigid body',
            self.get_fully_qualified_name() if self.config.named or self.config.robots else
            self.config.body.body_frame,
            level, message, values), s.time_ns)

    _compiling = None  # the _FirstStepCheck of a cold start while it runs

    def _warm_up(self):
        """
        Take the first physics step on a throw-away simulator (:func:`build.check_first_step`).

        That compiles the physics kernels (or loads them from numba's cache): logged when it
        compiles, so the check comes after the look into the cache. A cold start runs the check
        in the background (:class:`_FirstStepCheck`, started once the node is up), so the node
        is on the graph and publishes t = 0 within seconds (a robot's session projects its
        placement onto the joints at its first step, so building it compiles nothing).
        """
        config = self.config
        kind = build.kernel_kind(config)
        on_disk = jitcache.kernels_on_disk(kind)
        if not on_disk:
            self.get_logger().info(jitcache.compile_notice(kind))
            self._compiling = _FirstStepCheck(config, kind)
            return
        start = time.monotonic()
        build.check_first_step(config)  # in main()'s start-up thread: a signal is seen
        if not on_disk:
            self._compiled(kind, time.monotonic() - start)

    def _compiled(self, kind, took_s):
        """Mark the kernels of ``kind`` compiled in the cache, and say how long it took."""
        jitcache.mark_compiled(kind)
        self.get_logger().info(f'physics kernels compiled in {took_s:.1f} s')

    def _poll_compile(self):
        """
        While the first-step check of a cold start runs: serve t = 0; return True until it ends.

        Then: a refusal ends the node as at start-up (one line, exit status 2), an exception
        out of it is raised (exit status 1); otherwise sim time starts now.
        """
        job = self._compiling
        if job.is_alive():
            if self._unpublished and not self.done:
                self._publish_late()
            return True
        self._compiling = None
        if isinstance(job.error, RbdError):
            say(job.error)
            self.exit_status, self.done = 2, True
            self.ended_by = self.ended_by or 'start-up interrupted'
            return True
        if job.error is not None:
            raise job.error
        self._compiled(job.kind, job.took_s)
        self._anchor()  # sim time 0 = now
        return False

    def compiling(self):
        """Return whether the first-step check of a cold start is still running."""
        return self._compiling is not None and self._compiling.is_alive()

    REJECT_WARN_PERIOD_NS = 1_000_000_000  # at most one 'wrench rejected' warning per second
    _warn_after_ns = 0  # no rejection warning before this monotonic time
    _unwarned = 0  # rejections since the last warning

    def _on_point(self, name, msg):
        point = (msg.point.x, msg.point.y, msg.point.z)
        self._on_input(name, msg, lambda: self.session.submit_point(
            name, msg.header.frame_id, point, tag=msg), 'drag point')

    def _on_wrench(self, name, msg):
        frame_id, force, torque = conv.wrench_from_msg(msg)
        self._on_input(name, msg, lambda: self.session.submit(
            name, frame_id, force, torque, tag=msg), 'wrench')

    def _on_input(self, name, msg, submit, what):
        try:
            submit()
        except WrenchRejected as exc:  # a wrench, drag or robot command (CommandRejected)
            self._warn_rejected(what, exc)
            return

    def _warn_releases(self):
        """Warn of the inputs the session released from a step that would be non-finite."""
        for line in self.session.pop_releases():
            self._warn_throttled(line)

    def _warn_rejected(self, what, exc):
        """Warn of a rejected input (already counted by the session), at most once a second."""
        self._warn_throttled(f'{what} rejected ({exc.reason}): {exc}')

    def _warn_throttled(self, text):
        """Log ``text`` as a warning, at most once a second (the rest are counted)."""
        # Throttled here with one clock read: rclpy's own throttle inspects the caller's frame
        # and reads its source file on every call, even when it drops the message, so a flood
        # of bad wrenches used to stall the node.
        now = time.monotonic_ns()
        if now < self._warn_after_ns:
            self._unwarned += 1
            return
        self._warn_after_ns = now + self.REJECT_WARN_PERIOD_NS
        more = f' ({self._unwarned} more since the last warning, see /diagnostics)' \
            if self._unwarned else ''
        self._unwarned = 0
        self.get_logger().warning(f'{text}{more}')

    def _on_reset(self, request, response):
        self.session.reset()
        self._anchor()
        self._publish_sample()
        response.success, response.message = True, 'reset to the initial state at t = 0'
        return response

    def _on_pause(self, request, response):
        self.session.paused = bool(request.data)
        self._anchor()
        response.success = True
        response.message = f'{"paused" if request.data else "running"} at t = ' \
                           f'{self.session.time_ns} ns'
        return response

    def _on_step(self, request, response):
        if self._compiling is not None:
            response.success, response.message = False, 'compiling the physics kernels: try ' \
                'again when the log says they are compiled'
            return response
        if not self.session.paused:
            response.success, response.message = False, 'not paused: call ~/pause first'
            return response
        self._run(1, manual=True)
        response.success, response.message = True, f't = {self.session.time_ns} ns'
        return response

    def _close_recording(self):
        recorder, self._recorder = self._recorder, None
        if recorder is None:
            return
        if recorder.failed is not None:  # already reported where it failed
            recorder.close()
            return
        recorder.exception = self._crash
        try:
            recorder.close(self.ended_by, self.session.time_ns)
            self.get_logger().info(f'recording closed: {recorder.path}')
        except RecordingError as exc:
            self.get_logger().error(f'recording not finalised: {exc}')
            self.exit_status = 1

    def endpoint_count(self):
        """Return the number of publishers, subscriptions and services of this node."""
        return sum(1 for group in (self.publishers, self.subscriptions, self.services)
                   for _ in group)

    def crashed(self, exc):
        """Note an exception out of the step loop: logged, recorded at close, exit status 1."""
        self._crash = (self.session.time_ns, f'{type(exc).__name__}: {exc}')
        self.ended_by = 'exception'
        self.exit_status = 1
        self.get_logger().error(
            f'stopping on an exception at t = {self.session.time_ns} ns: {self._crash[1]}')

    def finish(self, ended_by=None):
        """Finalise the recording (idempotent) and return the exit status."""
        if ended_by and not self.ended_by:
            self.ended_by = ended_by
        self._close_recording()
        return self.exit_status
