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
Also prints the core's µs per step for the same robot (no node, ``bench_world_node``'s timer).
Prints medians over ``--runs`` runs and the machine's load average.
"""

import argparse
import os
import statistics
import sys
import tempfile

from bench_world_node import core_step_us, node_wall_s  # noqa: I100 (source tree on sys.path)
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
        sim = args.long_s - args.short_s
        for run in range(args.runs):
            record = [[f'record_path:={os.path.join(tmp, f"run{run}_{length}")}']
                      if args.record else [] for length in ('short', 'long')]
            short = node_wall_s(params_file, args.short_s, record[0])
            long = node_wall_s(params_file, args.long_s, record[1])
            core_us.append(core_step_us(params, 2000))
            if long - short < 0.25 * long:  # start-up noise as large as the run: no figure
                print(f'run {run}: long {long:.2f} s - short {short:.2f} s is within start-up '
                      'noise; left out (raise --long-s)')
                continue
            factors.append(sim / (long - short))
            node_us.append((long - short) / (sim * 1000) * 1e6)
    if not factors:
        print('no run gave a figure above start-up noise; raise --long-s')
        return 1
    factor, node, core = (statistics.median(v) for v in (factors, node_us, core_us))
    verdict = 'PASS' if factor >= TARGET else 'SHORT'
    print(f'as-fast factor {factor:.1f} (target >= {TARGET:.0f}: {verdict}); node '
          f'{node:.1f} µs/step, core {core:.1f} µs/step; runs {[round(f, 1) for f in factors]}')
    print(f'load average {os.getloadavg()}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
