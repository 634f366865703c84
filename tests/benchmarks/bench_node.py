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
Benchmark of ``rigid_body_node`` through real DDS (not collected by pytest).

``.venv/bin/python tests/benchmarks/bench_node.py [--seconds 60] [--runs 3] [--trials 200]``

1. latency: 1 kHz physics, 1 kHz publishing, real time. Each trial resets the body (at rest, no
   wrench, so x stays exactly 0), waits a random 5-25 ms, publishes a 1 N world force and times
   until the first ``pose`` with x != 0 arrives (the first pose that reflects the wrench), p50
   and p99 (targets: 2 ms and 5 ms).
2. pacing: real time for ``--seconds`` (60): the node's own largest lag of sim time behind the
   wall clock at a timer tick (``pacing_lag_max_ms`` of /diagnostics), and the drift of the sim
   stamps of received poses against their wall arrival times (end minus start, medians over
   1 s windows, so delivery jitter averages out); target: within 2 steps (2 ms).
3. as fast as possible: ``real_time_factor`` 0, 100 Hz publishing: the achieved factor (median
   of /diagnostics ``real_time_factor``), without and with a (Python, same machine) subscriber
   to ``pose``; target >= 100. Then an in-process breakdown of where
   the time goes per sim second (physics, state snapshot, message building, rclpy publish).

Prints the median over ``--runs`` runs of each figure.
"""

import argparse
import os
import random
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, REPO)
sys.path.insert(0, os.path.join(REPO, 'tests'))
sys.path.insert(0, os.path.join(REPO, 'tests', 'ros'))
os.environ.setdefault('ROS_DOMAIN_ID', str(1 + os.getpid() % 101))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['PYTHONPATH'] = REPO

from conftest import NodeProcess  # noqa: E402, I100
from ros_probe import Probe  # noqa: E402


def percentile(values, q):
    values = sorted(values)
    return values[min(len(values) - 1, int(round(q / 100.0 * (len(values) - 1))))]


def bench_latency(tmp, trials):
    node = NodeProcess(tmp, {'timestep_s': 0.001, 'publish_rate_hz': 1000.0,
                             'real_time_factor': 1.0}, namespace=True)
    probe = Probe(node.namespace, outputs=('pose',))
    latencies = []
    try:
        probe.wait_connected()
        first_moving = {}

        def moving_after(t_pub):
            for wall, stamp in probe.arrivals:
                if wall >= t_pub and probe.samples['pose'][stamp].pose.position.x != 0.0:
                    return wall
            return None

        for _ in range(trials):
            probe.reset()
            probe.arrivals.clear()
            start = time.monotonic_ns() + random.randint(5, 25) * 1_000_000
            probe.wait(lambda: time.monotonic_ns() >= start, 5)
            t_pub = time.monotonic_ns()
            probe.publish('wrench', 'world', (1.0, 0.0, 0.0))
            wall = probe.wait(lambda: moving_after(t_pub), 5, 'a moving pose')
            latencies.append((wall - t_pub) * 1e-6)
            first_moving[t_pub] = wall
    finally:
        probe.close()
        node.stop()
    return percentile(latencies, 50), percentile(latencies, 99)


ECHO = """
import rclpy
from geometry_msgs.msg import PoseStamped, WrenchStamped
rclpy.init()
node = rclpy.create_node('echo')
pub = node.create_publisher(PoseStamped, 'pose', 10)
def echo(msg):
    out = PoseStamped()
    out.header.stamp.nanosec = 1
    out.pose.position.x = 1.0
    pub.publish(out)
node.create_subscription(WrenchStamped, 'wrench', echo, 10)
rclpy.spin(node)
"""


def bench_floor(trials):
    """Latency of a bare rclpy echo (wrench in -> pose out) measured the same way."""
    echo = subprocess.Popen([sys.executable, '-c', ECHO, '--ros-args', '-r', '__ns:=/echo'])
    probe = Probe('/echo', outputs=('pose',))
    latencies = []
    try:
        probe.wait_connected(services=False)
        for _ in range(trials):
            probe.arrivals.clear()
            start = time.monotonic_ns() + random.randint(5, 25) * 1_000_000
            probe.wait(lambda: time.monotonic_ns() >= start, 5)
            t_pub = time.monotonic_ns()
            probe.publish('wrench', 'world', (1.0, 0.0, 0.0))
            wall = probe.wait(lambda: probe.arrivals and probe.arrivals[-1][0], 5, 'the echo')
            latencies.append((wall - t_pub) * 1e-6)
    finally:
        probe.close()
        echo.terminate()
        echo.wait()
    return percentile(latencies, 50), percentile(latencies, 99)


def bench_pacing(tmp, seconds):
    node = NodeProcess(tmp, {'timestep_s': 0.001, 'publish_rate_hz': 100.0,
                             'real_time_factor': 1.0}, namespace=True)
    probe = Probe(node.namespace, outputs=('pose', 'diagnostics'))
    try:
        probe.wait_connected(services=False)
        probe.wait(lambda: len(probe.arrivals) > 10, 30, 'poses')
        probe.diagnostics.clear()
        probe.arrivals.clear()
        start = time.monotonic_ns()
        probe.wait(lambda: time.monotonic_ns() - start > seconds * 1e9, seconds + 30)
        arrivals = list(probe.arrivals)
        lags = [float(kv.value) for msg in probe.diagnostics for kv in msg.status[0].values
                if kv.key == 'pacing_lag_max_ms']
        dropped = [float(kv.value) for msg in probe.diagnostics for kv in msg.status[0].values
                   if kv.key == 'wall_time_dropped_s']
    finally:
        probe.close()
        node.stop()
    wall0, sim0 = arrivals[0]
    offsets = [((w - wall0) - (s - sim0)) * 1e-6 for w, s in arrivals]  # ms, wall ahead of sim
    window = max(1, len(offsets) * 1_000_000_000 // max(1, arrivals[-1][1] - sim0))
    drift = statistics.median(offsets[-window:]) - statistics.median(offsets[:window])
    return max(lags), drift, max(dropped or [0.0])


def bench_fast(tmp, sim_seconds, subscribe_pose):
    node = NodeProcess(tmp, {'timestep_s': 0.001, 'publish_rate_hz': 100.0,
                             'real_time_factor': 0.0, 'duration_s': float(sim_seconds)},
                       namespace=True)
    probe = Probe(node.namespace,
                  outputs=('pose', 'diagnostics') if subscribe_pose else ('diagnostics',))
    try:
        probe.wait_connected(services=False)
        probe.wait(lambda: node.process.poll() is not None, 600, 'the node to finish')
        factors = [float(kv.value) for msg in probe.diagnostics[1:]
                   for kv in msg.status[0].values if kv.key == 'real_time_factor']
    finally:
        probe.close()
        node.stop()
    return statistics.median(factors) if factors else float('nan')


def breakdown(sim_seconds=20):
    """Time per sim second of each part of the node's work, in-process (no DDS peer)."""
    from rbd_ros import conversions as conv
    from rbd_ros.config import NodeConfig
    from rbd_ros.session import SimSession
    import rclpy
    c = NodeConfig.from_parameters({'publish_rate_hz': 100.0, 'real_time_factor': 0.0})
    session = SimSession(c)
    session.warm_up()
    n = sim_seconds * 1000
    t = time.perf_counter()
    steps = 0
    samples = 0
    while steps < n:
        report = session.advance(n - steps)
        steps += report.steps
        samples += report.sample_due
    physics = time.perf_counter() - t
    state = session.state
    t = time.perf_counter()
    for _ in range(samples):
        state = session.state
    snapshot = time.perf_counter() - t
    t = time.perf_counter()
    for _ in range(samples):
        msgs = conv.state_to_messages(state, 'world', 'world', 'base_link')
    build = time.perf_counter() - t
    rclpy.init()
    node = rclpy.create_node('bench_breakdown')
    pubs = [node.create_publisher(type(m), f'bench_{i}', 10) for i, m in enumerate(msgs)]
    t = time.perf_counter()
    for _ in range(samples):
        for pub, msg in zip(pubs, msgs):
            pub.publish(msg)
    publish = time.perf_counter() - t
    node.destroy_node()
    rclpy.try_shutdown()
    per_s = 1.0 / sim_seconds * 1e3
    return {'physics (1000 steps)': physics * per_s, 'state snapshot (100x)': snapshot * per_s,
            'message building (300x)': build * per_s, 'rclpy publish (300x)': publish * per_s}


def main():
    parser = argparse.ArgumentParser(description='rigid_body_node benchmark')
    parser.add_argument('--seconds', type=float, default=60.0, help='pacing run length (60)')
    parser.add_argument('--runs', type=int, default=3, help='runs per figure (3)')
    parser.add_argument('--trials', type=int, default=200, help='latency trials per run (200)')
    parser.add_argument('--fast-sim-seconds', type=int, default=600,
                        help='sim seconds of the as-fast-as-possible run (600)')
    parser.add_argument('--only', choices=('latency', 'pacing', 'fast', 'breakdown'),
                        action='append', help='run only these parts (repeatable)')
    args = parser.parse_args()
    parts = set(args.only or ('latency', 'pacing', 'fast', 'breakdown'))
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, '-c', 'import rbd_ros.node'], cwd=REPO, check=True)
        if 'latency' in parts:
            report_latency([bench_latency(tmp, args.trials) for _ in range(args.runs)])
            floor = [bench_floor(args.trials) for _ in range(args.runs)]
            print(f'  floor: a bare rclpy echo node, same measurement: p50 '
                  f'{statistics.median(a for a, _ in floor):.2f} ms, p99 '
                  f'{statistics.median(b for _, b in floor):.2f} ms', flush=True)
        if 'pacing' in parts:
            report_pacing(args, [bench_pacing(tmp, args.seconds) for _ in range(args.runs)])
        if 'fast' in parts:
            for subscribed in (False, True):
                report_fast(subscribed, [bench_fast(tmp, args.fast_sim_seconds, subscribed)
                                         for _ in range(args.runs)])
    if 'breakdown' in parts:
        report_breakdown(breakdown())


def report_latency(lat):
    print(f'latency wrench -> first pose reflecting it, 1 kHz physics + publishing: '
          f'p50 {statistics.median(a for a, _ in lat):.2f} ms, '
          f'p99 {statistics.median(b for _, b in lat):.2f} ms '
          f'(runs: {[(round(a, 2), round(b, 2)) for a, b in lat]})', flush=True)


def report_pacing(args, pace):
    print(f'pacing over {args.seconds:g} s at RTF 1, 1 kHz physics: max lag at a tick '
          f'{statistics.median(p[0] for p in pace):.2f} ms, drift of received stamps '
          f'{statistics.median(p[1] for p in pace):+.3f} ms, wall time dropped '
          f'{statistics.median(p[2] for p in pace):.3f} s (runs: '
          f'{[tuple(round(x, 3) for x in p) for p in pace]})', flush=True)


def report_fast(subscribed, fast):
    who = 'a Python subscriber on pose' if subscribed else 'no subscriber on the state topics'
    print(f'as fast as possible, 1 kHz physics, 100 Hz publishing, {who}: real-time factor '
          f'{statistics.median(fast):.1f}x (runs: {[round(f, 1) for f in fast]})', flush=True)


def report_breakdown(parts):
    total = sum(parts.values())
    print('where the wall time goes per sim second (in-process, ms): ' + ', '.join(
        f'{k} {v:.2f}' for k, v in parts.items()) + f'; total {total:.2f} ms '
        f'-> at most {1000.0 / total:.0f}x before executor and recording overhead')


if __name__ == '__main__':
    main()
