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
Benchmark of ``rigid_body_node`` under a wrench flood, through real DDS (not collected by pytest).

``.venv/bin/python tests/benchmarks/bench_flood.py [--duration 60] [--rate 15000]
[--publishers 2] [--runs 3] [--quick]``

For each kind of flood (valid wrenches in ``world``; wrenches with a bad ``frame_id``) and each
run: a fresh node (1 kHz physics, 100 Hz publishing, real time, a namespace of its own) is
flooded for ``--duration`` s of wall time at ``--rate`` wrenches/s in total from
``--publishers`` processes (``tests/ros/flood_publisher.py``: a pre-built message published in
a tight loop; one Python process tops out around 10-20 kHz). Measured:

- pose rate: distinct ``pose`` stamps received per wall second by this (separate) process
  during the flood; and the real-time factor (sim stamp advance / wall time) of those poses;
- the node's RSS (``VmRSS`` of ``/proc/<pid>/status``) when the flood starts and ends;
- counting: ``wrenches_received`` and ``wrenches_rejected`` of ``/diagnostics`` (deltas over the
  flood, read once the counters settle after it) against the number the publishers sent.
  The node's subscription is reliable with keep-last 10 (as is every publisher): when the node
  falls behind, DDS overwrites the oldest samples in the history *before* the node takes them,
  so ``received <= sent`` and the difference is what DDS dropped by design. "Every rejection
  counted" means: for the bad-frame flood ``rejected == received`` (each wrench the node took
  is counted as rejected), for the valid flood ``rejected == 0``.

Targets (issue 7, item 16): pose rate >= 99 Hz, RSS growth <= 5 MB, every rejection counted.
Figures are medians over ``--runs``; the 1-minute load average is printed with each run (the
machine is shared; a load above the core count means the figures are pessimistic).
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time

from bench_env import REPO  # noqa: I100 (first: puts the test helpers on sys.path)
from conftest import NodeProcess  # noqa: E402, I100
from ros_probe import Probe, rss_mb  # noqa: E402

PUBLISHER = os.path.join(REPO, 'tests', 'ros', 'flood_publisher.py')
PARAMS = {'timestep_s': 0.001, 'publish_rate_hz': 100.0, 'real_time_factor': 1.0}
POSE_RATE_HZ = 99.0
RSS_GROWTH_MB = 5.0


def flood_run(tmp, frame_id, rate_hz, seconds, n_publishers):
    """One node, one flood; return a dict of figures."""
    node = NodeProcess(tmp, PARAMS, namespace=True)
    probe = Probe(node.namespace, outputs=('pose', 'diagnostics'))
    pubs = []
    try:
        probe.wait_connected(services=False)
        probe.wait(lambda: len(probe.arrivals) > 10, 30, 'poses before the flood')
        before = probe.settled_wrench_counters(30.0)
        pubs = [subprocess.Popen(
            [sys.executable, PUBLISHER, node.namespace, frame_id, str(rate_hz / n_publishers),
             str(seconds)], stdout=subprocess.PIPE, text=True) for _ in range(n_publishers)]
        lines = [[] for _ in pubs]  # each publisher's stdout, read by a thread
        readers = [threading.Thread(target=lambda p=pub, o=out: o.extend(p.stdout), daemon=True)
                   for pub, out in zip(pubs, lines)]
        for reader in readers:
            reader.start()
        # Keep taking poses while the publishers connect, so none queue up in this process.
        probe.wait(lambda: all(out or pub.poll() is not None for pub, out in zip(pubs, lines)),
                   60, 'the publishers to be ready')
        assert all(out and out[0].strip() == 'ready' for out in lines), lines
        rss_start = rss_mb(node.process.pid)
        rss_max = rss_start
        load_start = os.getloadavg()[0]
        probe.arrivals.clear()
        wall0 = time.monotonic()
        next_rss = wall0 + 1.0
        while any(pub.poll() is None for pub in pubs):
            probe.spin()
            if time.monotonic() >= next_rss:
                rss_max = max(rss_max, rss_mb(node.process.pid))
                next_rss += 1.0
        wall1 = time.monotonic()
        rss_end = rss_mb(node.process.pid)
        # Poses that arrived from 1 s into the flood to its end (the first second may still
        # carry poses published before the flood).
        arrivals = [(w, s) for w, s in probe.arrivals if (wall0 + 1.0) * 1e9 <= w <= wall1 * 1e9]
        for reader in readers:
            reader.join(10.0)
        sent = sum(int(out[-1].split()[-1]) for out in lines)
        load_end = os.getloadavg()[0]
        after = probe.settled_wrench_counters(30.0)
        rss_settled = rss_mb(node.process.pid)
        stamps = sorted({s for _, s in arrivals})
        window_s = wall1 - wall0 - 1.0
        rtf = (stamps[-1] - stamps[0]) * 1e-9 / window_s if len(stamps) > 1 else 0.0
    finally:
        for pub in pubs:
            if pub.poll() is None:
                pub.kill()
            pub.wait()
        probe.close()
        status = node.stop()
    received = after['wrenches_received'] - before['wrenches_received']
    rejected = after['wrenches_rejected'] - before['wrenches_rejected']
    return {'sent': sent, 'send_rate_hz': sent / (wall1 - wall0), 'received': received,
            'rejected': rejected, 'pose_rate_hz': len(stamps) / window_s, 'rtf': rtf,
            'rss_start_mb': rss_start, 'rss_growth_mb': rss_end - rss_start,
            'rss_max_growth_mb': rss_max - rss_start, 'rss_settled_mb': rss_settled,
            'load': (load_start, load_end), 'exit': status}


def verdict(ok):
    return 'PASS' if ok else 'SHORT'


def report(kind, runs):
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]
           if isinstance(runs[0][k], (int, float))}
    counted = all((r['rejected'] == r['received']) if kind == 'bad frame' else
                  (r['rejected'] == 0) for r in runs)
    print(f'{kind} flood, {len(runs)} run(s), medians: sent {med["sent"]:.0f} '
          f'({med["send_rate_hz"] / 1e3:.1f} kHz), node received {med["received"]:.0f} '
          f'({100.0 * med["received"] / max(1, med["sent"]):.0f} %; the rest dropped by DDS '
          f'keep-last), rejected {med["rejected"]:.0f}', flush=True)
    pose_ok = verdict(med['pose_rate_hz'] >= POSE_RATE_HZ)
    print(f'  pose rate {med["pose_rate_hz"]:.1f} Hz [{pose_ok} >= {POSE_RATE_HZ:g}], '
          f'real-time factor {med["rtf"]:.3f}; RSS growth '
          f'{med["rss_growth_mb"]:+.1f} MB (max {med["rss_max_growth_mb"]:+.1f}, from '
          f'{med["rss_start_mb"]:.0f} MB) [{verdict(med["rss_growth_mb"] <= RSS_GROWTH_MB)} '
          f'<= {RSS_GROWTH_MB:g}]; every rejection counted '
          f'({"rejected == received" if kind == "bad frame" else "rejected == 0"}): '
          f'[{verdict(counted)}]', flush=True)
    for r in runs:
        print(f'    run: sent {r["sent"]}, received {r["received"]}, rejected {r["rejected"]}, '
              f'pose {r["pose_rate_hz"]:.1f} Hz, RTF {r["rtf"]:.3f}, RSS {r["rss_start_mb"]:.1f}'
              f' -> {r["rss_start_mb"] + r["rss_growth_mb"]:.1f} MB (settled '
              f'{r["rss_settled_mb"]:.1f}), load {r["load"][0]:.2f} -> {r["load"][1]:.2f}, '
              f'node exit {r["exit"]}', flush=True)


def main():
    parser = argparse.ArgumentParser(description='rigid_body_node wrench flood benchmark')
    parser.add_argument('--duration', type=float, default=60.0, help='flood length, s (60)')
    parser.add_argument('--rate', type=float, default=15000.0, help='wrenches/s in total (15000)')
    parser.add_argument('--publishers', type=int, default=2, help='publisher processes (2)')
    parser.add_argument('--runs', type=int, default=3, help='runs per kind (3)')
    parser.add_argument('--kind', choices=('valid', 'bad'), action='append',
                        help='only these floods (repeatable; default both)')
    parser.add_argument('--quick', action='store_true', help='10 s floods, one run each')
    args = parser.parse_args()
    if args.quick:
        args.duration, args.runs = 10.0, 1
    print(f'{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; flood '
          f'{args.rate:g} wrenches/s from {args.publishers} process(es) for {args.duration:g} s',
          flush=True)
    kinds = {'valid': ('valid', 'world'), 'bad': ('bad frame', 'not_a_frame')}
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([sys.executable, '-c', 'import rbd_ros.ros.node'], cwd=REPO, check=True)
        for key in args.kind or ('valid', 'bad'):
            kind, frame_id = kinds[key]
            report(kind, [flood_run(tmp, frame_id, args.rate, args.duration, args.publishers)
                          for _ in range(args.runs)])


if __name__ == '__main__':
    main()
