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
``rigid_body_node``: the only rclpy code. Parameters in, wrenches in, state out; time is sim time.

Everything else lives in ROS-free modules: :mod:`rbd_ros.config` (parameters),
:mod:`rbd_ros.session` (stepping, wrench hold and expiry, publish schedule) and
:mod:`rbd_ros.conversions` (messages). The wall clock only paces the fixed physics step: the
sim time due is ``sim_anchor + (wall_now - wall_anchor) * real_time_factor`` against an absolute
wall anchor (re-anchored on pause, reset and a change of the factor), so pacing error does not
accumulate; at most :data:`MAX_STEPS_PER_TICK` steps run per tick, and a larger backlog is
dropped (counted in ``/diagnostics`` as ``wall_time_dropped_s``).
"""

import signal
import sys
import time

from rbd_ros import config as cfg
from rbd_ros import conversions as conv
from rbd_ros.core import jitcache, NonFiniteError, RbdError, RecordingError
from rbd_ros.inputs import WrenchRejected
from rbd_ros.session import SimSession
from rcl_interfaces.msg import (FloatingPointRange, IntegerRange, ParameterDescriptor,
                                ParameterType, SetParametersResult)
import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from rclpy.signals import SignalHandlerOptions
from std_srvs.srv import SetBool, Trigger

try:  # tf2_msgs is on every Jazzy install but not in the PyPI wheels.
    from tf2_msgs.msg import TFMessage
except ImportError:  # pragma: no cover - depends on the install
    TFMessage = None

MAX_STEPS_PER_TICK = 1000  # the catch-up cap
AS_FAST_BUDGET_NS = 10_000_000  # wall time per tick at real_time_factor 0 (then serve callbacks)
MIN_TICK_S = 0.0005  # rclpy cannot run timers much faster; several steps per tick instead
_TYPES = {cfg.BOOL: ParameterType.PARAMETER_BOOL, cfg.INTEGER: ParameterType.PARAMETER_INTEGER,
          cfg.DOUBLE: ParameterType.PARAMETER_DOUBLE, cfg.STRING: ParameterType.PARAMETER_STRING,
          cfg.DOUBLE_ARRAY: ParameterType.PARAMETER_DOUBLE_ARRAY,
          cfg.STRING_ARRAY: ParameterType.PARAMETER_STRING_ARRAY}
_ARRAY_TYPES = {cfg.DOUBLE_ARRAY: Parameter.Type.DOUBLE_ARRAY,
                cfg.STRING_ARRAY: Parameter.Type.STRING_ARRAY}
_IGNORED = ('use_sim_time', 'start_type_description_service')


class RigidBodyNode(Node):
    """Simulate one rigid body; see the README for parameters, topics and services."""

    def __init__(self, **kwargs):
        super().__init__('rigid_body_node', **kwargs)
        # Validate the overrides ourselves first so that a bad value gives our one-line message
        # (rclpy would reject an out-of-range value with its own), then declare the validated
        # values. rclpy has no public accessor for the overrides before declaration.
        overrides = {name: p.value for name, p in self._parameter_overrides.items()}
        params = {}
        for name, value in overrides.items():
            if name in cfg.PARAMETERS_BY_NAME or name.startswith('wrench_inputs.'):
                params[name] = value
            elif name not in _IGNORED and not name.startswith('qos_overrides.'):
                self.get_logger().warning(f'ignoring unknown parameter {name} = {value!r}')
        self.config = config = cfg.NodeConfig.from_parameters(params)
        for spec in config.all_specs():
            self._declare(spec, config.parameters[spec.name])
        self.add_on_set_parameters_callback(self._on_set_parameters)
        self.session = SimSession(config)
        self._warm_up()
        self.done = False
        self.exit_status = 0
        self._rtf = config.real_time_factor
        self._dropped_ns = 0
        self._lag_max_ns = 0  # largest wall-minus-sim lag seen at a tick, since the last diag

        self._recorder = None
        self._pubs = {'pose': self.create_publisher(conv.PoseStamped, 'pose', 10),
                      'twist': self.create_publisher(conv.TwistStamped, 'twist', 10),
                      'odom': self.create_publisher(conv.Odometry, 'odom', 10),
                      'diagnostics': self.create_publisher(
                          conv.DiagnosticArray, '/diagnostics', 10)}
        if config.publish_clock:
            self._pubs['clock'] = self.create_publisher(conv.Clock, '/clock', 10)
        if config.publish_tf and TFMessage is None:
            self.get_logger().info('tf2_msgs is not importable: not broadcasting /tf')
        elif config.publish_tf:
            self._pubs['tf'] = self.create_publisher(TFMessage, '/tf', 100)
        self._input_subs = [
            self.create_subscription(conv.WrenchStamped, spec.topic,
                                     lambda msg, name=spec.name: self._on_wrench(name, msg), 10)
            for spec in config.wrench_inputs]
        self._input_topics = {spec.name: sub.topic_name
                              for spec, sub in zip(config.wrench_inputs, self._input_subs)}
        self.create_service(Trigger, '~/reset', self._on_reset)
        self.create_service(SetBool, '~/pause', self._on_pause)
        self.create_service(Trigger, '~/step', self._on_step)
        if config.record_path:
            self._open_recording()
        period = MIN_TICK_S if self._rtf == 0 else config.timestep_ns * 0.5e-9 / self._rtf
        self._timer = self.create_timer(max(MIN_TICK_S, period), self._tick)
        self.create_timer(1.0, self._publish_diagnostics)
        self._publish_sample()
        self._anchor()  # sim time 0 = now: pacing starts when the node is ready
        self._diag_last = (time.monotonic_ns(), 0, 0)

    def _declare(self, spec, value):
        descriptor = ParameterDescriptor(
            name=spec.name, type=_TYPES[spec.kind], read_only=spec.read_only,
            description=spec.description + (f' [{spec.unit}]' if spec.unit else ''),
            additional_constraints=spec.rule)
        if spec.bounds is not None and spec.kind == cfg.DOUBLE:
            descriptor.floating_point_range = [FloatingPointRange(
                from_value=float(spec.bounds[0]), to_value=float(spec.bounds[1]))]
        elif spec.bounds is not None and spec.kind == cfg.INTEGER:
            descriptor.integer_range = [IntegerRange(
                from_value=int(spec.bounds[0]), to_value=int(spec.bounds[1]))]
        if isinstance(value, tuple):
            # rclpy infers the type of [] as a byte array: declare an empty array by type only
            # (its value then reads as not set, which is what [] means here).
            value = list(value) or _ARRAY_TYPES[spec.kind]
        self.declare_parameter(spec.name, value, descriptor, ignore_override=True)

    def _on_set_parameters(self, params):
        for param in params:
            if param.name == 'real_time_factor':
                self._rtf = float(param.value)
                self._anchor()
        return SetParametersResult(successful=True)

    def _open_recording(self):
        from rbd_ros.recording import BagWriter
        self._recorder = BagWriter(self.config.record_path, config=self.config.to_parameters(),
                                   overwrite=self.config.record_overwrite)
        self.get_logger().info(f'recording to {self._recorder.path}')
        for pub in list(self._pubs.values()) + self._input_subs:
            msg_type = pub.msg_type
            type_name = f'{msg_type.__module__.split(".")[0]}/msg/{msg_type.__name__}'
            self._recorder.add_topic(pub.topic_name, type_name, {'depth': pub.qos_profile.depth})

    def _record(self, topic, msg, time_ns):
        if self._recorder is not None:
            try:
                self._recorder.write(topic, serialize_message(msg), time_ns)
            except RecordingError as exc:
                stop = self.config.record_on_error == 'stop'
                then = 'stopping the node (record_on_error: stop)' if stop else 'simulating on'
                self.get_logger().error(f'recording stopped: {exc}; {then}')
                self.exit_status = 1
                self._close_recording()
                self.done = self.done or stop

    def _publish(self, key, msg, time_ns):
        pub = self._pubs[key]
        pub.publish(msg)
        self._record(pub.topic_name, msg, time_ns)

    def _anchor(self):
        self._wall_anchor_ns = time.monotonic_ns()
        self._sim_anchor_ns = self.session.time_ns

    def _tick(self):
        session = self.session
        if session.paused or self.done:
            return
        if self._rtf == 0:
            deadline = time.monotonic_ns() + AS_FAST_BUDGET_NS
            while time.monotonic_ns() < deadline and not (self.done or session.paused):
                self._run(MAX_STEPS_PER_TICK)
            return
        elapsed_ns = time.monotonic_ns() - self._wall_anchor_ns
        target_ns = self._sim_anchor_ns + (
            elapsed_ns if self._rtf == 1.0 else int(elapsed_ns * self._rtf))
        self._lag_max_ns = max(self._lag_max_ns, target_ns - session.time_ns)
        due = (target_ns - session.time_ns) // session.timestep_ns
        if due > MAX_STEPS_PER_TICK:  # too far behind: run the cap, drop the rest
            self._dropped_ns += (due - MAX_STEPS_PER_TICK) * session.timestep_ns
            self._sim_anchor_ns -= (due - MAX_STEPS_PER_TICK) * session.timestep_ns
            self.get_logger().warning('falling behind the wall clock: dropping wall time',
                                      throttle_duration_sec=5.0)
            due = MAX_STEPS_PER_TICK
        if due > 0:
            self._run(due)

    def _run(self, n_steps, manual=False):
        while n_steps > 0 and not self.done:
            try:
                report = self.session.step() if manual else self.session.advance(n_steps)
            except NonFiniteError as exc:
                self.get_logger().error(f'{exc}; paused (call ~/reset)')
                return
            for event in report.events:
                self._record(self._input_topics[event.input_name], event.tag, event.time_ns)
            if report.sample_due:
                self._publish_sample()
            if self.session.finished and not manual:
                self.get_logger().info(f'duration_s reached at t = {self.session.time_ns} ns')
                self.done = True
            if report.steps == 0 or manual:
                return
            n_steps -= report.steps

    def _publish_sample(self):
        state, c = self.session.state, self.config
        t = state.time_ns
        pose, twist, odom = conv.state_to_messages(state, c.twist_frame, c.world_frame,
                                                   c.body_frame)
        self._publish('pose', pose, t)
        self._publish('twist', twist, t)
        self._publish('odom', odom, t)
        if 'clock' in self._pubs:
            self._publish('clock', conv.clock_to_msg(t), t)
        if 'tf' in self._pubs:
            self._publish('tf', TFMessage(transforms=[conv.state_to_transform(
                state, c.world_frame, c.body_frame)]), t)

    def _publish_diagnostics(self):
        s, now = self.session, time.monotonic_ns()
        wall0, sim0, steps0 = self._diag_last
        self._diag_last = (now, s.time_ns, s.steps_total)
        state, model = s.state, s.config.model
        values = {
            'sim_time_s': s.time_ns * 1e-9,
            'real_time_factor': (s.time_ns - sim0) / max(1, now - wall0),
            'real_time_factor_target': self._rtf, 'steps_taken': s.steps_total,
            'paused': s.paused, 'wrenches_received': s.inputs.received_total,
            'wrenches_rejected': s.inputs.rejected_total,
            **{f'wrenches_rejected_{k}': v for k, v in s.inputs.rejected.items()},
            'kinetic_energy_j': float(state.kinetic_energy(model)),
            'angular_momentum_norm_nms': float(
                sum(x * x for x in state.angular_momentum_w(model)) ** 0.5),
            'wall_time_dropped_s': self._dropped_ns * 1e-9, 'resets': s.resets,
            'pacing_lag_max_ms': self._lag_max_ns * 1e-6}
        self._lag_max_ns = 0
        level = 'error' if s.error else ('warn' if s.inputs.rejected_total else 'ok')
        self._publish('diagnostics', conv.diagnostics_to_msg(
            s.time_ns, f'{self.get_fully_qualified_name()}: rigid body', self.config.body_frame,
            level,
            s.error or ('paused' if s.paused else 'running'), values), s.time_ns)

    def _warm_up(self):
        """Compile (or load from numba's cache) the physics kernel; log it when it compiles."""
        on_disk = jitcache.kernels_on_disk()
        if not on_disk:
            where = (f'first start, can take a minute; cached in {jitcache.CACHE_DIR}'
                     if jitcache.CACHE_DIR else f'can take a minute; {jitcache.PROBLEM}')
            self.get_logger().info(f'compiling the physics kernels ({where})')
        start = time.monotonic()
        self.session.warm_up()
        if not on_disk:
            self.get_logger().info(
                f'physics kernels compiled in {time.monotonic() - start:.1f} s')

    REJECT_WARN_PERIOD_NS = 1_000_000_000  # at most one 'wrench rejected' warning per second
    _warn_after_ns = 0  # no rejection warning before this monotonic time
    _unwarned = 0  # rejections since the last warning

    def _on_wrench(self, name, msg):
        frame_id, force, torque = conv.wrench_from_msg(msg)
        try:
            self.session.submit(name, frame_id, force, torque, tag=msg)
        except WrenchRejected as exc:
            # Counted by the session; warned at most once a second, throttled here with one
            # clock read: rclpy's own throttle inspects the caller's frame and reads its source
            # file on every call, even when it drops the message, so a flood of bad wrenches
            # used to stall the node.
            now = time.monotonic_ns()
            if now < self._warn_after_ns:
                self._unwarned += 1
                return
            self._warn_after_ns = now + self.REJECT_WARN_PERIOD_NS
            more = f' ({self._unwarned} more since the last warning, see /diagnostics)' \
                if self._unwarned else ''
            self._unwarned = 0
            self.get_logger().warning(f'wrench rejected ({exc.reason}): {exc}{more}')
            return
        if self._rtf > 0:  # run a step that became due since the last tick now: less latency
            self._tick()

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
        if not self.session.paused:
            response.success, response.message = False, 'not paused: call ~/pause first'
            return response
        self._run(1, manual=True)
        response.success, response.message = True, f't = {self.session.time_ns} ns'
        return response

    def _close_recording(self):
        recorder, self._recorder = self._recorder, None
        if recorder is not None:
            try:
                recorder.close()
                self.get_logger().info(f'recording closed: {recorder.path}')
            except RecordingError as exc:
                self.get_logger().error(f'recording not finalised: {exc}')
                self.exit_status = 1

    def finish(self):
        """Finalise the recording (idempotent) and return the exit status."""
        self._close_recording()
        return self.exit_status


def _seconds_to_next_step(node, longest_s=0.1):
    """Wall seconds until the node's next physics step is due (0 at RTF 0, ``longest_s`` cap)."""
    session, rtf = node.session, node._rtf
    if session.paused or node.done:
        return longest_s
    if rtf == 0:
        return 0.0
    due_ns = node._wall_anchor_ns + (
        session.time_ns + session.timestep_ns - node._sim_anchor_ns) / rtf
    return min(longest_s, max(0.0, (due_ns - time.monotonic_ns()) * 1e-9))


def main(args=None):
    """Run the node until ``duration_s`` passes or SIGINT/SIGTERM; exit 0, or 2 on bad input."""
    # Our own signal handlers: stop between callbacks, then finalise. (rclpy's would shut the
    # context down under a running callback, whose next publish then fails.)
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    stop = []
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda *_: stop.append(True))
    try:
        node = RigidBodyNode()
    except RbdError as exc:
        print(f'rigid_body_node: {exc}', file=sys.stderr, flush=True)
        rclpy.try_shutdown()
        sys.exit(2)
    # Not rclpy's experimental EventsExecutor: its event queue is unbounded, so a wrench flood
    # faster than the node grew memory without limit. This one takes at most one message per
    # subscription per wait; what it cannot take, DDS keep-last drops. It rebuilds its wait set
    # at every wake-up, so instead of the half-step tick timer (2 kHz of wake-ups, half a core)
    # the loop waits until the next step is due, or a message or request comes, and then ticks.
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    node._timer.cancel()
    try:
        while rclpy.ok() and not node.done and not stop:
            executor.spin_once(timeout_sec=_seconds_to_next_step(node))
            node._tick()
    except ExternalShutdownException:
        pass
    finally:
        status = node.finish()
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    sys.exit(status)


if __name__ == '__main__':
    main()
