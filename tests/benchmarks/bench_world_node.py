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
Benchmark of a world in ``rigid_body_node`` (issue 10's speed targets; not collected by pytest).

``.venv/bin/python tests/benchmarks/bench_world_node.py [--bodies 100 1000] [--runs 3]
[--set per_body_topics:=false]``

N boxes (side 0.1 m, 1 kg, 0.2 m apart in a square grid) resting on a floor, h = 1 ms, 100 Hz
publishing (every body's pose, twist, odom and contact wrench, ``poses``, ``/tf``), as the
issue sets it. For each N:

- as fast as possible: ``real_time_factor`` 0; the wall time of a long run minus that of a
  short one (start-up, kernel loading and shut-down cancel) gives the as-fast factor
  (sim s per wall s), target >= 1 for 100 boxes;
- the core's step time for the same world (``WorldSimulator.step``, no node), µs per step and
  per body-step, so the node's own share shows.

Prints medians over ``--runs`` runs and the machine's load average.
"""

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

import yaml

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, REPO)


def world_params(count):
    """Return the params of ``count`` resting boxes on a floor (a square grid)."""
    side = int(count ** 0.5 + 0.999)
    names = [f'b{i}' for i in range(count)]
    params = {'gravity': [0.0, 0.0, -9.81], 'ground.enabled': True, 'body_names': names,
              'publish_rate_hz': 100.0, 'timestep_s': 0.001}
    for i, name in enumerate(names):
        params[f'bodies.{name}.shape'] = 'box'
        params[f'bodies.{name}.dimensions_m'] = [0.1, 0.1, 0.1]
        params[f'bodies.{name}.initial_position'] = [0.2 * (i % side), 0.2 * (i // side), 0.05]
    return params


def node_run(params_file, sim_s, extra=()):
    """
    Run the node as fast as possible for ``sim_s``; return ``(wall s, peak RSS MB)``.

    ``extra``: ``NAME:=VALUE`` parameter settings. The peak RSS is the process's own
    (``ru_maxrss`` from ``wait4``), not the largest of this process's children so far.
    """
    with tempfile.TemporaryFile() as err:
        start = time.monotonic()
        proc = subprocess.Popen(
            [sys.executable, '-m', 'rbd_ros.node', '--ros-args', '--params-file', params_file,
             '-p', f'duration_s:={sim_s}', '-p', 'real_time_factor:=0.0']
            + [arg for setting in extra for arg in ('-p', setting)],
            stdout=subprocess.DEVNULL, stderr=err, cwd=REPO)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.monotonic() - start
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            err.seek(0)
            raise SystemExit(err.read().decode(errors='replace'))
    return wall, usage.ru_maxrss / 1024.0


def node_wall_s(params_file, sim_s, extra=()):
    """Run the node as fast as possible for ``sim_s``; return the wall seconds it took."""
    return node_run(params_file, sim_s, extra)[0]


def core_step_us(params, steps):
    """Return µs per step of the core world of ``params`` (no node, no publishing)."""
    from rbd_ros.sim.build import make_simulator
    from rbd_ros.sim.config import NodeConfig
    sim = make_simulator(NodeConfig.from_parameters(params))
    sim.step(10)
    start = time.perf_counter()
    sim.step(steps)
    return (time.perf_counter() - start) / steps * 1e6


def main(argv=None):
    """Run the benchmark; print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--bodies', type=int, nargs='+', default=[100, 1000])
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--short-s', type=float, default=0.2)
    parser.add_argument('--long-s', type=float, default=2.2)
    parser.add_argument('--set', action='append', default=[], metavar='NAME:=VALUE',
                        help='a node parameter for every run (per_body_topics:=false)')
    args = parser.parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    os.environ.setdefault('ROS_DOMAIN_ID', str(90 + os.getpid() % 10))
    print(f'load average {os.getloadavg()}; parameters {args.set}; nobody subscribed')
    print('bodies  as-fast factor (target >= 1 at 100)  node µs/step  core µs/step  '
          'core µs/body-step')
    for count in args.bodies:
        params = world_params(count)
        with tempfile.NamedTemporaryFile('w', suffix='.yaml', delete=False) as f:
            yaml.safe_dump({'/**': {'ros__parameters': params}}, f)
        factors, node_us, core_us = [], [], []
        for _ in range(args.runs):
            short = node_wall_s(f.name, args.short_s, args.set)
            long = node_wall_s(f.name, args.long_s, args.set)
            sim = args.long_s - args.short_s
            factors.append(sim / max(long - short, 1e-9))
            node_us.append((long - short) / (sim * 1000) * 1e6)
            core_us.append(core_step_us(params, 200 if count <= 1000 else 20))
        os.unlink(f.name)
        factor, node, core = (statistics.median(v) for v in (factors, node_us, core_us))
        verdict = 'report' if count != 100 else ('PASS' if factor >= 1 else 'SHORT')
        print(f'{count:6d}  {factor:8.3f} ({verdict})'
              f'{"":22s}{node:10.0f}  {core:12.0f}  {core / count:12.2f}', flush=True)
    print(f'load average {os.getloadavg()}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
