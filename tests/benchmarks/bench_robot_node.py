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
Benchmark of a URDF robot in ``rigid_body_node`` (issue 28 speed target; not collected by pytest).

``.venv/bin/python tests/benchmarks/bench_robot_node.py [--links 7] [--runs 3] [--record]``

A ``--links``-link arm (1 kg, 0.3 m links on revolute joints about y and z in turn, fixed to the
world, written to a temporary URDF) released from a bent pose under gravity, h = 1 ms,
``joint_states`` and ``/tf`` (every link) at 100 Hz, as fast as possible (``real_time_factor``
0, nobody subscribed: the node builds no sample then; ``--record``: every run recorded to a
temporary MCAP file, so every sample's ``joint_states``, ``joint_wrenches`` and ``/tf`` are built,
published and written). The wall time of a long run minus that of a short one (start-up, kernel
loading and shut-down cancel) gives the as-fast factor (sim s per wall s); target >= 50.
Also prints the core's µs per step for the same robot (no node), and the same figures by CPU
time (the node process's, every thread; the core's thread), which a loaded machine inflates
less: on a quiet one the two agree. Prints medians over ``--runs`` runs and the machine's load
average.
"""

import argparse
import os
import resource
import statistics
import sys
import tempfile
import time

from bench_world_node import node_wall_s  # noqa: I100 (source tree on sys.path)
import yaml  # noqa: I201 (after the sys.path import)

TARGET = 50.0


def arm_urdf(links):
    """Return the URDF of a ``links``-link arm fixed to the world, axes y, z, y, ..."""
    out = ['<?xml version="1.0"?>', '<robot name="arm">', '  <link name="world"/>',
           '  <joint name="mount_joint" type="fixed"><parent link="world"/>'
           '<child link="base"/><origin xyz="0 0 3"/></joint>', '  <link name="base"/>']
    parent = 'base'
    for k in range(links):
        axis = '0 1 0' if k % 2 == 0 else '0 0 1'
        origin = '0 0 0' if k == 0 else '0 0 -0.3'
        out += [f'  <joint name="j{k}" type="revolute"><parent link="{parent}"/>'
                f'<child link="l{k}"/><origin xyz="{origin}"/><axis xyz="{axis}"/>'
                '<limit lower="-3" upper="3" effort="100" velocity="10"/></joint>',
                f'  <link name="l{k}"><inertial><origin xyz="0 0 -0.15"/><mass value="1"/>'
                '<inertia ixx="0.0075" ixy="0" ixz="0" iyy="0.0075" iyz="0" izz="0.0002"/>'
                '</inertial></link>']
        parent = f'l{k}'
    return '\n'.join(out + ['</robot>', ''])


def node_times(params_file, sim_s, extra=()):
    """
    Run the node as fast as possible for ``sim_s``; return its ``(wall s, CPU s)``.

    The CPU time is the node process's, every thread, user and system (``RUSAGE_CHILDREN``
    across its run: the node is this process's only child then). On a loaded machine it
    grows less than the wall time, which also counts the time the node waits for a core.
    """
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    wall = node_wall_s(params_file, sim_s, extra)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)


def core_step_times(params, steps):
    """Return the core's ``(wall µs, thread CPU µs)`` a step for ``params`` (no node)."""
    from rbd_ros.sim.build import make_simulator
    from rbd_ros.sim.config import NodeConfig
    sim = make_simulator(NodeConfig.from_parameters(params))
    sim.step(10)
    start, cpu = time.perf_counter(), time.thread_time()
    sim.step(steps)
    return ((time.perf_counter() - start) / steps * 1e6,
            (time.thread_time() - cpu) / steps * 1e6)


def robot_params(urdf_path, links):
    """Return the node parameters of the arm at ``urdf_path``, bent 0.3 rad at every joint."""
    return {'robot_names': ['arm'], 'robots.arm.urdf_path': urdf_path,
            'robots.arm.initial_joint_positions': [0.3] * links,
            'gravity': [0.0, 0.0, -9.81], 'timestep_s': 0.001, 'publish_rate_hz': 100.0}


def main(argv=None):
    """Run the benchmark; print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--links', type=int, default=7)
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--short-s', type=float, default=1.0)
    # 121 s: at ~13x real time the long run takes ~9 s of wall time, well above the
    # seconds of start-up noise the short run cancels (21 s gave one run of 2e10x).
    parser.add_argument('--long-s', type=float, default=121.0)
    parser.add_argument('--record', action='store_true',
                        help='record every run (every sample built and written)')
    args = parser.parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    os.environ.setdefault('ROS_DOMAIN_ID', str(90 + os.getpid() % 10))
    how = 'recorded' if args.record else 'nobody subscribed'
    print(f'load average {os.getloadavg()}; {args.links}-link arm; {how}')
    with tempfile.TemporaryDirectory() as tmp:
        urdf = os.path.join(tmp, 'arm.urdf')
        with open(urdf, 'w') as f:
            f.write(arm_urdf(args.links))
        params = robot_params(urdf, args.links)
        params_file = os.path.join(tmp, 'arm.yaml')
        with open(params_file, 'w') as f:
            yaml.safe_dump({'/**': {'ros__parameters': params}}, f)
        factors, node_us, core_us = [], [], []
        cpu_factors, node_cpu_us, core_cpu_us = [], [], []
        sim = args.long_s - args.short_s
        for run in range(args.runs):
            record = [[f'record_path:={os.path.join(tmp, f"run{run}_{length}")}']
                      if args.record else [] for length in ('short', 'long')]
            short, short_cpu = node_times(params_file, args.short_s, record[0])
            long, long_cpu = node_times(params_file, args.long_s, record[1])
            core_wall, core_cpu = core_step_times(params, 2000)
            core_us.append(core_wall)
            core_cpu_us.append(core_cpu)
            if long - short < 0.25 * long:  # start-up noise as large as the run: no figure
                print(f'run {run}: long {long:.2f} s - short {short:.2f} s is within start-up '
                      'noise; left out (raise --long-s)')
                continue
            factors.append(sim / (long - short))
            node_us.append((long - short) / (sim * 1000) * 1e6)
            cpu_factors.append(sim / max(long_cpu - short_cpu, 1e-9))
            node_cpu_us.append((long_cpu - short_cpu) / (sim * 1000) * 1e6)
    if not factors:
        print('no run gave a figure above start-up noise; raise --long-s')
        return 1
    factor, node, core = (statistics.median(v) for v in (factors, node_us, core_us))
    verdict = 'PASS' if factor >= TARGET else 'SHORT'
    print(f'as-fast factor {factor:.1f} (target >= {TARGET:.0f}: {verdict}); node '
          f'{node:.1f} µs/step, core {core:.1f} µs/step; runs {[round(f, 1) for f in factors]}')
    cpu_factor, node_cpu, core_cpu = (statistics.median(v)
                                      for v in (cpu_factors, node_cpu_us, core_cpu_us))
    print(f'by CPU time: factor {cpu_factor:.1f} (sim s per CPU s of the node, all threads); '
          f'node {node_cpu:.1f} CPU µs/step, core {core_cpu:.1f} thread CPU µs/step; runs '
          f'{[round(f, 1) for f in cpu_factors]}')
    print(f'load average {os.getloadavg()}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
