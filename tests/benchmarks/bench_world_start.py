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
Start-up of big worlds (issue 30 item 1): time and memory against the number of bodies.

``.venv/bin/python tests/benchmarks/bench_world_start.py [--bodies 500 1000 2000 5000]
[--runs 3] [--set per_body_topics:=false]``

For each N: ``bench_world_node.world_params(N)`` (N resting 0.1 m boxes on a floor, h = 1 ms,
100 Hz publishing, every body's own topics unless ``--set`` says otherwise) run by the node
as a user runs it (``python -m rbd_ros.node --ros-args --params-file``) for ``duration_s`` =
10 ms of sim at ``real_time_factor`` 0, the case issue 30 measured (2,000 boxes: 158 s and
974 MB; 5,000: 896 s and 2.1 GB). Measured per run: the wall time from the process start to
its exit (start-up, 10 steps, shut-down; kernels loaded from a warm cache) and its peak RSS
(``ru_maxrss`` from ``wait4``). Prints medians over ``--runs``, the cost per body between the
smallest and largest N (the slope: what one more body costs), and the load average.

Target: near-linear (the per-body slope between consecutive N within 2x of each other) and
the memory per body stated.
"""

import argparse
import os
import statistics
import tempfile

from bench_world_node import node_run, world_params  # noqa: I100
import yaml


def run_once(count, settings):
    """Return ``(wall_s, peak_rss_mb)`` of one 10 ms run of ``count`` boxes."""
    with tempfile.NamedTemporaryFile('w', suffix='.yaml') as f:
        yaml.safe_dump({'/**': {'ros__parameters': world_params(count)}}, f)
        f.flush()
        return node_run(f.name, 0.01, settings)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[1])
    parser.add_argument('--bodies', type=int, nargs='+', default=[500, 1000, 2000, 5000])
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--set', action='append', default=[], metavar='NAME:=VALUE')
    args = parser.parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    os.environ.setdefault('ROS_DOMAIN_ID', str(1 + os.getpid() % 101))
    print(f'{os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f}; 10 ms of sim, '
          f'real_time_factor 0{"; " + ", ".join(args.set) if args.set else ""}', flush=True)
    figures = {}
    for count in args.bodies:
        runs = [run_once(count, args.set) for _ in range(args.runs)]
        wall = statistics.median(r[0] for r in runs)
        rss = statistics.median(r[1] for r in runs)
        figures[count] = (wall, rss)
        print(f'{count:6d} bodies: {wall:7.1f} s wall, peak RSS {rss:7.0f} MB (runs: '
              f'{", ".join(f"{w:.1f} s {m:.0f} MB" for w, m in runs)}; load '
              f'{os.getloadavg()[0]:.2f})', flush=True)
    counts = sorted(figures)
    for a, b in zip(counts, counts[1:]):
        (wa, ma), (wb, mb) = figures[a], figures[b]
        print(f'  {a} -> {b} bodies: {1e3 * (wb - wa) / (b - a):.2f} ms and '
              f'{1e3 * (mb - ma) / (b - a):.0f} kB per added body', flush=True)
    if len(counts) > 1:
        (wa, ma), (wb, mb) = figures[counts[0]], figures[counts[-1]]
        added = counts[-1] - counts[0]
        print(f'per body ({counts[0]} -> {counts[-1]}): {1e3 * (wb - wa) / added:.2f} ms of '
              f'start-up, {1e3 * (mb - ma) / added:.0f} kB of memory', flush=True)


if __name__ == '__main__':
    main()
