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
Start-up benchmark (issue 25): how long until the node publishes its first pose (not collected).

``.venv/bin/python tests/benchmarks/bench_start.py [--runs 3] [--only FILE ...] [--warm-only]``

For every parameter file in ``msg_config/`` (or those named), the node is started the way a
user starts it (``python -m rbd_ros.node --ros-args --params-file FILE``, its own namespace)
and timed from the process start to the first ``pose`` (one body), ``poses`` (a world) or
``<robot>/joint_states`` (a file with robots) message received through DDS:

- cold: with an empty kernel cache (``XDG_CACHE_HOME`` a new empty directory, no
  ``NUMBA_CACHE_DIR``), so the node compiles its physics kernels;
- warm: started again on the cache the cold start left.

Targets (issue 25): first pose cold ≤ 30 s, warm ≤ 3 s, on this 2-core machine; the first
step (a pose stamped after t = 0) is printed beside the cold start's first pose. Prints the
median of ``--runs`` runs of each (the machine is shared: the load average is printed with
them). A cold run of a contact file compiles for about a minute and a half: ``--only`` and
``--runs 1`` keep a run short.
"""

import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

from bench_env import REPO  # noqa: I100 (first: puts the test helpers on sys.path)
from geometry_msgs.msg import PoseArray, PoseStamped  # noqa: I100
import rclpy
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState
import yaml

TARGET_COLD_S = 30.0
TARGET_WARM_S = 3.0
TIMEOUT_S = 1200.0


def robot_names(params_file):
    """Return the file's ``robot_names`` (a robot's first sample is its ``joint_states``)."""
    for section in yaml.safe_load(pathlib.Path(params_file).read_text()).values():
        names = (section.get('ros__parameters') or {}).get('robot_names')
        if names:
            return names
    return []


def first_pose_s(node, params_file, cache_home, namespace):
    """
    Start the node on ``params_file``; return seconds until its first pose, and until one at t > 0.

    A cold start publishes t = 0 while its kernels compile, so the first pose and the first step
    are two figures.
    """
    env = {k: v for k, v in os.environ.items() if k != 'NUMBA_CACHE_DIR'}
    env['XDG_CACHE_HOME'] = str(cache_home)
    got = []
    topics = [(PoseStamped, 'pose'), (PoseArray, 'poses')]
    topics += [(JointState, f'{robot}/joint_states') for robot in robot_names(params_file)]
    subs = [node.create_subscription(
        kind, f'{namespace}/{topic}',
        lambda m: got.append((time.monotonic(), m.header.stamp.sec or m.header.stamp.nanosec)),
        qos_profile_sensor_data)
            for kind, topic in topics]
    start = time.monotonic()
    process = subprocess.Popen(
        [sys.executable, '-m', 'rbd_ros.node', '--ros-args', '-r', f'__ns:={namespace}',
         '--params-file', str(params_file)], env=env, cwd=str(cache_home),
        stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        while not any(stamp for _, stamp in got):
            rclpy.spin_once(node, timeout_sec=0.05)
            if process.poll() is not None:
                raise RuntimeError(f'{params_file.name}: the node exited with '
                                   f'{process.returncode}: {process.stderr.read()[-2000:]!r}')
            if time.monotonic() - start > TIMEOUT_S:
                raise RuntimeError(f'{params_file.name}: no pose within {TIMEOUT_S} s')
        return got[0][0] - start, next(t for t, stamp in got if stamp) - start
    finally:
        process.send_signal(2)
        try:
            process.wait(timeout=30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        for sub in subs:
            node.destroy_subscription(sub)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--only', action='append', help='msg_config file name (repeatable)')
    parser.add_argument('--warm-only', action='store_true',
                        help='time warm starts only (one cache, filled by an untimed start)')
    args = parser.parse_args(argv)
    files = sorted(pathlib.Path(REPO, 'msg_config').glob('*.yaml'))
    if args.only:
        files = [f for f in files if f.name in args.only or f.stem in args.only]
    rclpy.init()
    node = rclpy.create_node('bench_start')
    load = os.getloadavg()
    print(f'start-up benchmark: medians of {args.runs}; load average {load[0]:.2f} '
          f'{load[1]:.2f} {load[2]:.2f} on {os.cpu_count()} CPUs; targets cold <= '
          f'{TARGET_COLD_S:g} s, warm <= {TARGET_WARM_S:g} s')
    print(f'  {"file":24s} {"cold s":>8s} {"step s":>8s} {"warm s":>8s}   (cold: first pose; '
          'step: the first pose after t = 0 of that cold start)')
    try:
        shared = tempfile.TemporaryDirectory(prefix='rbd_start_warm_') if args.warm_only \
            else None
        for k, params_file in enumerate(files):
            cold, stepping, warm = [], [], []
            if shared is not None:  # fill the one cache of the warm-only runs, untimed
                first_pose_s(node, params_file, pathlib.Path(shared.name),
                             f'/bench_start_{os.getpid()}_{k}_fill')
            for run in range(args.runs):
                with tempfile.TemporaryDirectory(prefix='rbd_start_') as fresh:
                    cache_home = pathlib.Path(shared.name if shared else fresh)
                    ns = f'/bench_start_{os.getpid()}_{k}_{run}'
                    if not args.warm_only:
                        first, step = first_pose_s(node, params_file, cache_home, ns)
                        cold.append(first)
                        stepping.append(step)
                    warm.append(first_pose_s(node, params_file, cache_home, ns + '_warm')[0])
            cold_s = f'{statistics.median(cold):8.1f} {statistics.median(stepping):8.1f}' \
                if cold else f'{"-":>8s} {"-":>8s}'
            verdict = ''
            if cold:
                verdict += ' cold ' + ('PASS' if statistics.median(cold) <= TARGET_COLD_S
                                       else 'SHORT')
            verdict += ' warm ' + ('PASS' if statistics.median(warm) <= TARGET_WARM_S
                                   else 'SHORT')
            print(f'  {params_file.name:24s} {cold_s} {statistics.median(warm):8.1f} {verdict}',
                  flush=True)
    finally:
        node.destroy_node()
        rclpy.shutdown()


if __name__ == '__main__':
    sys.exit(main())
