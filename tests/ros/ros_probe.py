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
A test-side rclpy node that talks to ``rigid_body_node`` through real DDS.

It subscribes to the node's outputs (keeping every sample by stamp), publishes wrenches and
calls the services; all waits poll with a deadline (no fixed sleeps).
"""

import itertools
import os
import time

from conftest import wait_until
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PointStamped, PoseStamped, TwistStamped, WrenchStamped
from nav_msgs.msg import Odometry
from rbd_ros.msgs import conversions
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rosgraph_msgs.msg import Clock
from std_srvs.srv import SetBool, Trigger

_COUNTER = itertools.count()


def rss_mb(pid):
    """Return the resident set size of process ``pid`` in MB (VmRSS of /proc/<pid>/status)."""
    with open(f'/proc/{pid}/status') as status:
        for line in status:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) / 1024.0
    raise RuntimeError(f'no VmRSS for pid {pid}')


class Probe:
    """
    Outputs in, wrenches and service calls out, for the ``rigid_body_node`` in ``namespace``.

    Relative topic names resolve in the probe's namespace, the node's; /diagnostics from
    other nodes are ignored by their status name.
    """

    def __init__(self, namespace, inputs=('wrench',), depth=1000,
                 outputs=('pose', 'twist', 'odom', 'clock', 'diagnostics')):
        self.context = Context()
        rclpy.init(context=self.context)
        self.node_name = namespace.rstrip('/') + '/rigid_body_node'
        self.node = rclpy.create_node(f'probe_{os.getpid()}_{next(_COUNTER)}',
                                      namespace=namespace, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.samples = {name: {} for name in ('pose', 'twist', 'odom', 'clock')}
        self.diagnostics = []
        self.arrivals = []  # (wall monotonic ns, pose stamp ns)
        table = {
            'pose': (PoseStamped, 'pose', self._on_pose),
            'twist': (TwistStamped, 'twist', lambda m: self._keep('twist', m)),
            'odom': (Odometry, 'odom', lambda m: self._keep('odom', m)),
            'clock': (Clock, '/clock', self._on_clock),
            'diagnostics': (DiagnosticArray, '/diagnostics', self._on_diagnostics),
        }
        self._subs = {name: self.node.create_subscription(*table[name][:2], table[name][2], depth)
                      for name in outputs}
        self.publishers = {topic: self.node.create_publisher(WrenchStamped, topic, 10)
                           for topic in inputs}
        self.clients = {
            'reset': self.node.create_client(Trigger, self.node_name + '/reset'),
            'pause': self.node.create_client(SetBool, self.node_name + '/pause'),
            'step': self.node.create_client(Trigger, self.node_name + '/step'),
        }

    def _keep(self, kind, msg):
        self.samples[kind][conversions.time_from_msg(msg.header.stamp)] = msg

    def _on_pose(self, msg):
        self.arrivals.append((time.monotonic_ns(), conversions.time_from_msg(msg.header.stamp)))
        self._keep('pose', msg)

    def _on_diagnostics(self, msg):
        if msg.status and msg.status[0].name.startswith(self.node_name + ':'):
            self.diagnostics.append(msg)

    def _on_clock(self, msg):
        self.samples['clock'][conversions.time_from_msg(msg.clock)] = msg

    def spin(self):
        """Process whatever has arrived (waits at most 10 ms)."""
        self.executor.spin_once(timeout_sec=0.01)

    def wait(self, predicate, timeout_s=20.0, what='condition'):
        """Spin until ``predicate()`` is truthy (see :func:`conftest.wait_until`)."""
        return wait_until(predicate, timeout_s, self.spin, what)

    def settled_wrench_counters(self, timeout_s=60.0):
        """
        Return the ``wrenches_*`` counters of ``/diagnostics`` once they stop changing.

        Waits for two consecutive diagnostics (~1 s apart) with equal counters (the node has
        worked off its backlog); needs ``'diagnostics'`` among the probe's outputs.
        """
        self.diagnostics.clear()

        def same():
            if len(self.diagnostics) < 2:
                return None
            last = [{kv.key: int(kv.value) for kv in m.status[0].values
                     if kv.key.startswith('wrenches_')} for m in self.diagnostics[-2:]]
            return last[1] if last[0] == last[1] else None
        return self.wait(same, timeout_s, 'the wrench counters to settle')

    def wait_connected(self, timeout_s=60.0, services=True):
        """Wait until the node's outputs, our wrench publishers and its services are matched."""
        self.wait(lambda: all(s.get_publisher_count() >= 1 for name, s in self._subs.items()
                              if name in ('pose', 'twist', 'odom')),
                  timeout_s, 'the node publishers (pose, twist, odom)')
        self.wait(lambda: all(p.get_subscription_count() >= 1
                              for p in self.publishers.values()),
                  timeout_s, 'the node wrench subscriptions')
        if services:
            self.wait(lambda: all(c.service_is_ready() for c in self.clients.values()),
                      timeout_s, 'the node services')

    def publish(self, topic, frame_id, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0)):
        """Publish one ``WrenchStamped`` on ``topic``."""
        self.publishers[topic].publish(conversions.wrench_to_msg(frame_id, force, torque))

    def call(self, name, request=None, timeout_s=20.0):
        """Call service ``name`` ('reset', 'pause', 'step') and return the response."""
        client = self.clients[name]
        if request is None:
            request = client.srv_type.Request()
        future = client.call_async(request)
        self.wait(future.done, timeout_s, f'the {name} service response')
        return future.result()

    def pause(self, paused):
        """Call ``~/pause``; assert it succeeded."""
        response = self.call('pause', SetBool.Request(data=paused))
        assert response.success, response.message

    def sample(self, kind, time_ns, timeout_s=20.0):
        """Wait for and return the ``kind`` sample stamped ``time_ns``."""
        return self.wait(lambda: self.samples[kind].get(time_ns), timeout_s,
                         f'a {kind} sample at t = {time_ns} ns')

    def step(self, n=1):
        """Call ``~/step`` ``n`` times; wait for the pose/twist/odom samples; return the time."""
        for _ in range(n):
            response = self.call('step')
            assert response.success, response.message
        time_ns = int(response.message.split()[2])
        for kind in ('pose', 'twist', 'odom'):
            self.sample(kind, time_ns)
        return time_ns

    def reset(self):
        """Call ``~/reset``, wait for the t = 0 sample after it, forget older samples."""
        for kind in self.samples:
            self.samples[kind].clear()
        response = self.call('reset')
        assert response.success, response.message
        self.sample('pose', 0)

    def diagnostic_values(self, predicate=None, timeout_s=20.0):
        """Wait for a ``/diagnostics`` message whose values satisfy ``predicate``; return them."""
        def find():
            for msg in reversed(self.diagnostics):
                values = {kv.key: kv.value for kv in msg.status[0].values}
                if predicate is None or predicate(values):
                    return values
            return None
        return self.wait(find, timeout_s, 'matching /diagnostics')

    def close(self):
        """Destroy the node and shut the context down."""
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.try_shutdown(context=self.context)


def run_paused_node(probe, node, subs, done, timeout_s=120):
    """
    Run a node started paused to its end: return ``(topics on the graph, exit status)``.

    Waits for the subscriptions ``subs`` to match and the pause service, reads the graph,
    unpauses, waits until ``done()`` (the last sample received) and for the node to exit
    (its ``duration_s``); closes the probe and stops the node whatever happens.
    """
    try:
        probe.wait(lambda: all(s.get_publisher_count() >= 1 for s in subs)
                   and probe.clients['pause'].service_is_ready(), timeout_s,
                   'the node on the graph')
        topics = dict(probe.node.get_topic_names_and_types())
        probe.pause(False)
        probe.wait(done, timeout_s, 'the last sample')
        status = node.wait(60)
    finally:
        probe.close()
        node.stop()
    return topics, status


def step_until_moving(probe, max_steps=100):
    """
    Step a paused node until the twist shows a velocity; return ``(t_effect_ns, t_now_ns)``.

    ``t_effect_ns`` is the start of the step the wrench took effect at (the previous sample
    time): the node applies a received wrench at the start of the next physics step, and the
    DDS delivery of the wrench is not ordered with the ``~/step`` service calls.
    """
    previous = max(probe.samples['twist'])
    for _ in range(max_steps):
        now = probe.step()
        twist = probe.samples['twist'][now].twist
        if any(getattr(v, a) != 0.0 for v in (twist.linear, twist.angular) for a in 'xyz'):
            return previous, now
        previous = now
    raise AssertionError(f'no motion after {max_steps} steps')


def point(x, y, z, frame='world'):
    """Return a ``geometry_msgs/PointStamped`` at ``(x, y, z)`` m in ``frame`` (drag, click)."""
    msg = PointStamped()
    msg.header.frame_id = frame
    msg.point.x, msg.point.y, msg.point.z = x, y, z
    return msg


def call(probe, srv_type, service, request):
    """Call ``<node>/<service>`` like ros2cli does and return the response."""
    client = probe.node.create_client(srv_type, f'{probe.node_name}/{service}')
    probe.wait(client.service_is_ready, 60.0, f'the {service} service')
    future = client.call_async(request)
    probe.wait(future.done, 20.0, f'the {service} response')
    return future.result()
