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
[--publishers 2] [--runs 3] [--quick] [--world] [--kind KIND]``

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

``--world`` (or ``--kind click|drag|world_wrench``) floods a world instead (issue 30, item 3):
the node runs ``msg_config/stack.yaml`` (three boxes stacked on the floor and a striker box,
contact at 1 kHz, 100 Hz publishing, real time) and each kind floods one input at ``--rate``
from ``--publishers`` processes (``tests/ros/world_flood_publisher.py``): ``/clicked_point``,
``middle/drag`` or ``striker/wrench``, each a mix of valid, random, NaN and out-of-frame
messages (a quarter each). Measured as above, and:

- pose rate of the world's ``poses`` (``geometry_msgs/PoseArray``) during the flood against the
  ``BEFORE_S`` s before it;
- the state finite throughout: every pose of ``poses`` and every body's ``twist`` taken during
  the run, and ``kinetic_energy_j`` of every ``/diagnostics``;
- counting: ``drags_received``/``drags_rejected`` (clicks and drags) or ``wrenches_received``/
  ``wrenches_rejected``. Which messages are bad follows from their values alone (see the
  publisher), so the publishers say how many of those sent must be rejected if taken; DDS
  drops some before the node takes them, by arrival time, not content, and the categories take
  turns message by message, so "every rejection counted" means: the rejected share of what the
  node received (less those released because a step they acted in would be non-finite,
  ``non_finite_step``: taken for their values, then released) equals the bad share of what was
  sent, within ``SHARE_TOL`` (statistics: a difference of one message in a window of keep-last
  10 is 10 %, but over ~1e5 messages taken the shares agree to ~0.5 %), and for wrenches the
  reasons add up to the total.
"""

import argparse
import math
import os
import statistics
import subprocess
import sys
import tempfile
import threading
import time

from bench_env import REPO  # noqa: I100 (first: puts the test helpers on sys.path)
from conftest import FIRST_START_S, NodeProcess  # noqa: E402, I100
from geometry_msgs.msg import PoseArray, TwistStamped  # noqa: E402
from rbd_ros.msgs import conversions  # noqa: E402
from ros_probe import Probe, rss_mb  # noqa: E402

PUBLISHER = os.path.join(REPO, 'tests', 'ros', 'flood_publisher.py')
WORLD_PUBLISHER = os.path.join(REPO, 'tests', 'ros', 'world_flood_publisher.py')
STACK = os.path.join(REPO, 'msg_config', 'stack.yaml')
STACK_BODIES = ('bottom', 'middle', 'top', 'striker')
#: World kinds: (publisher kind, body, /diagnostics counter prefix).
WORLD_KINDS = {'click': ('click', '-', 'drags_'), 'drag': ('drag', 'middle', 'drags_'),
               'world_wrench': ('wrench', 'striker', 'wrenches_')}
BEFORE_S = 5.0  # of poses before a world flood, for the pose rate it is compared with
SHARE_TOL = 0.02  # rejected share of received vs bad share of sent (see the docstring)
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


class _WorldWatch:
    """The world's ``poses`` (arrival, stamp) and each body's ``twist``, checked finite."""

    def __init__(self, probe):
        self.arrivals, self.checked, self.non_finite = [], 0, []
        node = probe.node
        self._subs = [node.create_subscription(PoseArray, 'poses', self._on_poses, 1000)]
        self._subs += [node.create_subscription(TwistStamped, f'{body}/twist', self._on_twist,
                                                1000) for body in STACK_BODIES]

    def _check(self, what, values):
        self.checked += 1
        if not all(math.isfinite(v) for v in values):
            self.non_finite.append((what, values))

    def _on_poses(self, msg):
        self.arrivals.append((time.monotonic_ns(), conversions.time_from_msg(msg.header.stamp)))
        for pose in msg.poses:
            p, q = pose.position, pose.orientation
            self._check('pose', (p.x, p.y, p.z, q.x, q.y, q.z, q.w))

    def _on_twist(self, msg):
        v, w = msg.twist.linear, msg.twist.angular
        self._check('twist', (v.x, v.y, v.z, w.x, w.y, w.z))

    def connected(self):
        return all(sub.get_publisher_count() >= 1 for sub in self._subs)


def settled_counters(probe, prefix, timeout_s=30.0):
    """Return the ``prefix*`` counters of ``/diagnostics`` once two in a row are equal."""
    probe.diagnostics.clear()

    def same():
        if len(probe.diagnostics) < 2:
            return None
        last = [{kv.key: int(float(kv.value)) for kv in m.status[0].values
                 if kv.key.startswith(prefix)} for m in probe.diagnostics[-2:]]
        return last[1] if last[0] == last[1] else None
    return probe.wait(same, timeout_s, f'the {prefix}* counters to settle')


def _pose_rate(arrivals, start_ns, end_ns):
    """Return (distinct stamps per wall second, real-time factor) of arrivals in the window."""
    stamps = sorted({s for w, s in arrivals if start_ns <= w <= end_ns})
    window_s = (end_ns - start_ns) * 1e-9
    rtf = (stamps[-1] - stamps[0]) * 1e-9 / window_s if len(stamps) > 1 else 0.0
    return len(stamps) / window_s, rtf


def world_flood_run(tmp, key, rate_hz, seconds, n_publishers, run):
    """One world node (``msg_config/stack.yaml``), one flood of kind ``key``; return figures."""
    kind, body, prefix = WORLD_KINDS[key]
    node = NodeProcess(tmp, {'real_time_factor': 1.0}, params_file=STACK, namespace=True)
    probe = Probe(node.namespace, inputs=(), outputs=('diagnostics',))
    watch = _WorldWatch(probe)
    energies = []
    pubs = []
    try:
        probe.wait(watch.connected, FIRST_START_S, 'the world node outputs')
        probe.wait(lambda: len(watch.arrivals) > 10, 60, 'poses before the flood')
        before = settled_counters(probe, prefix)
        watch.arrivals.clear()
        wall_b = time.monotonic_ns()
        probe.wait(lambda: time.monotonic_ns() - wall_b >= BEFORE_S * 1e9, BEFORE_S + 5)
        rate_before, _ = _pose_rate(watch.arrivals, wall_b, time.monotonic_ns())
        pubs = [subprocess.Popen(
            [sys.executable, WORLD_PUBLISHER, node.namespace, kind, body,
             str(rate_hz / n_publishers), str(seconds), str(1000 * run + i)],
            stdout=subprocess.PIPE, text=True) for i in range(n_publishers)]
        lines = [[] for _ in pubs]
        readers = [threading.Thread(target=lambda p=pub, o=out: o.extend(p.stdout), daemon=True)
                   for pub, out in zip(pubs, lines)]
        for reader in readers:
            reader.start()
        probe.wait(lambda: all(out or pub.poll() is not None for pub, out in zip(pubs, lines)),
                   60, 'the publishers to be ready')
        assert all(out and out[0].strip() == 'ready' for out in lines), lines
        rss_start = rss_mb(node.process.pid)
        rss_max = rss_start
        load_start = os.getloadavg()[0]
        probe.diagnostics.clear()
        wall0 = time.monotonic()
        next_rss = wall0 + 1.0
        while any(pub.poll() is None for pub in pubs):
            probe.spin()
            if time.monotonic() >= next_rss:
                rss_max = max(rss_max, rss_mb(node.process.pid))
                next_rss += 1.0
        wall1 = time.monotonic()
        rss_end = rss_mb(node.process.pid)
        energies += [float(kv.value) for m in probe.diagnostics for kv in m.status[0].values
                     if kv.key == 'kinetic_energy_j']
        rate, rtf = _pose_rate(watch.arrivals, int((wall0 + 1.0) * 1e9), int(wall1 * 1e9))
        for reader in readers:
            reader.join(10.0)
        totals = [out[-1].split() for out in lines]  # 'sent N expected_rejections R'
        sent = sum(int(t[1]) for t in totals)
        expected = sum(int(t[3]) for t in totals)
        load_end = os.getloadavg()[0]
        after = settled_counters(probe, prefix)
        energies += [float(kv.value) for m in probe.diagnostics for kv in m.status[0].values
                     if kv.key == 'kinetic_energy_j']
        rss_settled = rss_mb(node.process.pid)
        alive = node.process.poll() is None
    finally:
        for pub in pubs:
            if pub.poll() is None:
                pub.kill()
            pub.wait()
        probe.close()
        status = node.stop()
    received = after[prefix + 'received'] - before[prefix + 'received']
    rejected = after[prefix + 'rejected'] - before[prefix + 'rejected']
    reasons = {k[len(prefix + 'rejected_'):]: after[k] - before[k] for k in after
               if k.startswith(prefix + 'rejected_')}
    # Taken, then released because the step it acted in would be non-finite: rejected, but not
    # for its values, so not in the publishers' bad share.
    released = reasons.get('non_finite_step', 0)
    share = (rejected - released) / max(1, received)
    expected_share = expected / max(1, sent)
    counted = abs(share - expected_share) <= SHARE_TOL and (
        not reasons or sum(reasons.values()) == rejected) and 0 <= rejected <= received <= sent
    finite = not watch.non_finite and all(math.isfinite(e) for e in energies)
    return {'sent': sent, 'send_rate_hz': sent / (wall1 - wall0), 'received': received,
            'rejected': rejected, 'released': released, 'expected_rejected': expected,
            'rejected_share': share,
            'expected_share': expected_share, 'reasons': reasons, 'counted': counted,
            'pose_rate_before_hz': rate_before, 'pose_rate_hz': rate, 'rtf': rtf,
            'rss_start_mb': rss_start, 'rss_growth_mb': rss_end - rss_start,
            'rss_max_growth_mb': rss_max - rss_start, 'rss_settled_mb': rss_settled,
            'finite': finite, 'checked': watch.checked, 'non_finite': watch.non_finite[:3],
            'energy_max_j': max(energies, default=math.nan), 'alive': alive,
            'load': (load_start, load_end), 'exit': status}


def world_report(key, runs):
    med = {k: statistics.median(r[k] for r in runs) for k in runs[0]
           if isinstance(runs[0][k], (int, float)) and not isinstance(runs[0][k], bool)}
    topic = {'click': '/clicked_point', 'drag': 'middle/drag',
             'world_wrench': 'striker/wrench'}[key]
    print(f'world {key} flood ({topic}, stack.yaml), {len(runs)} run(s), medians: sent '
          f'{med["sent"]:.0f} ({med["send_rate_hz"] / 1e3:.1f} kHz), node received '
          f'{med["received"]:.0f} ({100.0 * med["received"] / max(1, med["sent"]):.0f} %; the '
          f'rest dropped by DDS keep-last), rejected {med["rejected"]:.0f} (of which released '
          f'from a step that would be non-finite: {med["released"]:.0f})', flush=True)
    counted = all(r['counted'] for r in runs)
    finite = all(r['finite'] and r['alive'] for r in runs)
    print(f'  pose rate {med["pose_rate_hz"]:.1f} Hz during, {med["pose_rate_before_hz"]:.1f} '
          f'Hz before [{verdict(med["pose_rate_hz"] >= POSE_RATE_HZ)} >= {POSE_RATE_HZ:g}], '
          f'real-time factor {med["rtf"]:.3f}; RSS growth {med["rss_growth_mb"]:+.1f} MB (max '
          f'{med["rss_max_growth_mb"]:+.1f}, from {med["rss_start_mb"]:.0f} MB) '
          f'[{verdict(med["rss_growth_mb"] <= RSS_GROWTH_MB)} <= {RSS_GROWTH_MB:g}]; rejected '
          f'share {100 * med["rejected_share"]:.2f} % of received vs bad share '
          f'{100 * med["expected_share"]:.2f} % of sent [{verdict(counted)} within '
          f'{100 * SHARE_TOL:g} points]; state finite, node up [{verdict(finite)}]', flush=True)
    for r in runs:
        reasons = ', '.join(f'{k} {v}' for k, v in r['reasons'].items() if v)
        print(f'    run: sent {r["sent"]} (bad {r["expected_rejected"]}), received '
              f'{r["received"]}, rejected {r["rejected"]}{f" ({reasons})" if reasons else ""}, '
              f'pose {r["pose_rate_before_hz"]:.1f} -> {r["pose_rate_hz"]:.1f} Hz, RTF '
              f'{r["rtf"]:.3f}, RSS {r["rss_start_mb"]:.1f} -> '
              f'{r["rss_start_mb"] + r["rss_growth_mb"]:.1f} MB (settled '
              f'{r["rss_settled_mb"]:.1f}), {r["checked"]} poses and twists checked, non-finite '
              f'{r["non_finite"] or "none"}, kinetic energy max {r["energy_max_j"]:.3g} J, load '
              f'{r["load"][0]:.2f} -> {r["load"][1]:.2f}, node exit {r["exit"]}', flush=True)


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
    parser.add_argument('--kind', choices=('valid', 'bad') + tuple(WORLD_KINDS),
                        action='append', help='only these floods (repeatable; default valid '
                        'and bad)')
    parser.add_argument('--world', action='store_true',
                        help='the world floods: --kind click, drag and world_wrench')
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
        for key in args.kind or (tuple(WORLD_KINDS) if args.world else ('valid', 'bad')):
            if key in WORLD_KINDS:
                world_report(key, [world_flood_run(tmp, key, args.rate, args.duration,
                                                   args.publishers, run)
                                   for run in range(args.runs)])
                continue
            kind, frame_id = kinds[key]
            report(kind, [flood_run(tmp, frame_id, args.rate, args.duration, args.publishers)
                          for _ in range(args.runs)])


if __name__ == '__main__':
    main()
