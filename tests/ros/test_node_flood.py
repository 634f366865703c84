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
A flood of bad wrenches: every one counted, the simulation goes on, memory stays put.

The speed figures (pose rate and RSS at 15 kHz for 60 s) are measured by
``tests/benchmarks/bench_flood.py``; here a few seconds of flood, as fast as one publisher
process goes, check what does not depend on the machine's speed.
"""

import pathlib
import subprocess
import sys
import time

from conftest import wait_until
from geometry_msgs.msg import WrenchStamped
from rbd_ros.ros.node import RigidBodyNode
import rclpy
from rclpy.context import Context
from ros_probe import Probe, rss_mb

PUBLISHER = pathlib.Path(__file__).with_name('flood_publisher.py')
FLOOD_S = 4.0
PARAMS = {'timestep_s': 0.001, 'publish_rate_hz': 100.0, 'real_time_factor': 1.0}


def test_a_flood_of_bad_wrenches_is_counted_and_the_simulation_goes_on(start_node):
    node = start_node(PARAMS, namespace=True)
    probe = Probe(node.namespace, outputs=('pose', 'diagnostics'))
    try:
        probe.wait_connected(services=False)
        probe.wait(lambda: len(probe.arrivals) > 10, 30, 'poses before the flood')
        before = probe.settled_wrench_counters()
        flood = subprocess.Popen(
            [sys.executable, str(PUBLISHER), node.namespace, 'not_a_frame', '0', str(FLOOD_S)],
            stdout=subprocess.PIPE, text=True)
        assert flood.stdout.readline().strip() == 'ready'
        rss_start = rss_mb(node.process.pid)
        probe.arrivals.clear()
        wall0 = time.monotonic_ns()
        probe.wait(lambda: flood.poll() is not None, FLOOD_S + 60, 'the flood to end')
        wall1 = time.monotonic_ns()
        rss_end = rss_mb(node.process.pid)
        sent = int(flood.stdout.read().split()[-1])
        after = probe.settled_wrench_counters()
        arrivals = list(probe.arrivals)
    finally:
        probe.close()
    assert node.stop() == 0, node.stderr
    received = after['wrenches_received'] - before['wrenches_received']
    rejected = {k: after[k] - before[k] for k in after if k.startswith('wrenches_rejected')}
    # Every wrench the node took was counted as rejected, for its frame. DDS keep-last 10 drops
    # what the node cannot take in time, so received <= sent.
    assert 0 < received <= sent, (received, sent)
    assert rejected['wrenches_rejected'] == received, (rejected, received)
    assert rejected['wrenches_rejected_frame'] == received, (rejected, received)
    # Poses kept coming with advancing stamps during the flood: in every whole second of it the
    # newest stamp is later than in the second before (a stall would repeat the same stamp).
    newest = [max((s for w, s in arrivals if wall0 + k * 10**9 <= w < wall0 + (k + 1) * 10**9),
                  default=-1) for k in range(int((wall1 - wall0) // 10**9))]
    assert len(newest) >= int(FLOOD_S) and all(b > a >= 0 for a, b in zip(newest, newest[1:])), \
        newest
    # Memory stays put: measured -0.3 .. +0.3 MB over 10 s floods at ~14 kHz with the
    # SingleThreadedExecutor; rclpy's experimental EventsExecutor queued one event per message
    # and grew ~1.4 MB/s under the same flood (issue 7: +34 MB/min at 15 kHz). 3 MB leaves room
    # for allocator noise yet is below what even a 3 s stall of an unbounded queue adds.
    assert rss_end - rss_start < 3.0, (rss_start, rss_end)
    # The warning is throttled by the node (one a second, saying how many it did not print).
    warnings = [line for line in node.stderr.splitlines() if 'wrench rejected (frame)' in line]
    assert 1 <= len(warnings) <= FLOOD_S + 3, warnings
    assert any('more since the last warning' in line for line in warnings), warnings


class _CountingLogger:
    def __init__(self):
        self.calls = []

    def warning(self, message, **kwargs):
        self.calls.append(message)

    info = error = warning


def test_the_rejection_path_logs_at_most_once_a_second(tmp_path):
    """
    A burst of bad wrenches calls the logger once per second, not once per message.

    (rclpy's ``throttle_duration_sec`` does its throttling after inspecting the caller's frame
    and source line, ~0.1-1 ms a call: that made a bad-wrench flood stall the simulation.)
    """
    context = Context()
    rclpy.init(context=context)
    try:
        node = RigidBodyNode(context=context, cli_args=['--ros-args', '-p', 'start_paused:=true',
                                                        '-r', '__ns:=/flood_inproc'])
        logger = _CountingLogger()
        node.get_logger = lambda: logger
        msg = WrenchStamped()
        msg.header.frame_id = 'not_a_frame'
        n = 5000
        start = time.monotonic()
        for _ in range(n):
            node._on_wrench('wrench', msg)
        elapsed_s = time.monotonic() - start
        assert node.session.inputs.rejected['frame'] == n
        assert node.session.inputs.received_total == n
        assert 1 <= len(logger.calls) <= 1 + int(elapsed_s), (len(logger.calls), elapsed_s)
        assert "header.frame_id 'not_a_frame'" in logger.calls[0]
        # After a second, the next rejection is logged again, with the count it did not print.
        wait_until(lambda: time.monotonic() - start > elapsed_s + 1.0, 5)
        node._on_wrench('wrench', msg)
        assert 'more since the last warning' in logger.calls[-1], logger.calls[-1]
        node.destroy_node()
    finally:
        rclpy.try_shutdown(context=context)
