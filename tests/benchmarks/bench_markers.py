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
Benchmark of the ``markers`` topic of a meshed world (issue 31 item 7; not collected by pytest).

``.venv/bin/python tests/benchmarks/bench_markers.py [--bodies 200] [--runs 3] [--repo DIR]
[--spheres]``

N bodies of one 1,280-face mesh (a trimesh icosphere, subdivisions 3, radius 0.05 m, written
to a temporary STL), 0.2 m apart in a square grid 1 m above a floor, no gravity (so no contacts:
the contact markers are the one DELETEALL marker and every sample is the same size), h = 5 ms,
``publish_rate_hz`` 100, real time.  The node runs as a user runs it (``python -m
rbd_ros.node`` with a params file) from ``--repo`` (default this checkout; pass another
checkout, e.g. the main one, to measure its code); this process subscribes to ``markers``
through real DDS (raw CDR, so our own deserialisation costs nothing) and reports, medians over
``--runs`` node runs:

- the serialized size of one ``markers`` message (``rclpy.serialization.serialize_message`` of
  the received message; equal to the CDR bytes received);
- the rate the messages arrive at over ``--window-s`` wall seconds, after the first one.

``--spheres`` puts SPHERE primitives of the same radius in place of the mesh: the reference of
what the rest of the node (physics, the per-body topics) leaves for the markers.
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


def world_params(count, mesh_path):
    """Return the params of ``count`` bodies of the mesh at ``mesh_path`` (or balls) in a grid."""
    side = int(count ** 0.5 + 0.999)
    names = [f'b{i}' for i in range(count)]
    params = {'gravity': [0.0, 0.0, 0.0], 'ground.enabled': True, 'body_names': names,
              'publish_rate_hz': 100.0, 'timestep_s': 0.005, 'real_time_factor': 1.0}
    for i, name in enumerate(names):
        if mesh_path:
            params[f'bodies.{name}.mesh_path'] = mesh_path
        else:
            params[f'bodies.{name}.shape'] = 'sphere'
            params[f'bodies.{name}.dimensions_m'] = [0.05]
        params[f'bodies.{name}.initial_position'] = [0.2 * (i % side), 0.2 * (i // side), 1.0]
    return params


def run(repo, params_file, namespace, window_s, start_timeout_s):
    """Return (size in bytes, rate in Hz) of one node run, counting every arrival."""
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.serialization import deserialize_message, serialize_message
    from visualization_msgs.msg import MarkerArray

    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [repo] + [p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep) if p]))
    node = subprocess.Popen(
        [sys.executable, '-m', 'rbd_ros.node', '--ros-args', '-r', f'__ns:={namespace}',
         '--params-file', params_file],
        cwd=repo, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    context = rclpy.Context()
    rclpy.init(context=context)
    probe = rclpy.create_node(f'bench_markers_{os.getpid()}', namespace=namespace,
                              context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(probe)
    times, last = [], []

    def on_markers(data):
        times.append(time.monotonic())
        last[:] = [data]

    probe.create_subscription(MarkerArray, 'markers', on_markers, 10, raw=True)
    try:
        deadline = time.monotonic() + start_timeout_s
        while not times:
            if node.poll() is not None or time.monotonic() > deadline:
                raise SystemExit(f'no markers message from the node: {node.stderr.read()}')
            executor.spin_once(timeout_sec=0.05)
        while time.monotonic() < times[0] + window_s:
            executor.spin_once(timeout_sec=0.05)
        size = len(serialize_message(deserialize_message(last[0], MarkerArray)))
        rate = (len(times) - 1) / (times[-1] - times[0]) if len(times) > 1 else 0.0
    finally:
        executor.shutdown()
        probe.destroy_node()
        rclpy.try_shutdown(context=context)
        node.terminate()
        node.wait(timeout=60)
    return size, rate


def main(argv=None):
    """Run the benchmark; print the figures."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--bodies', type=int, default=200)
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--window-s', type=float, default=10.0)
    parser.add_argument('--start-timeout-s', type=float, default=900.0)
    parser.add_argument('--repo', default=REPO, help='the checkout whose node to run')
    parser.add_argument('--spheres', action='store_true',
                        help='SPHERE primitives of the same radius instead of the mesh (the '
                        'reference: what the rest of the node costs)')
    args = parser.parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    os.environ.setdefault('ROS_DOMAIN_ID', str(90 + os.getpid() % 10))
    import trimesh
    repo = os.path.abspath(args.repo)
    print(f'code {repo}; load average {os.getloadavg()}')
    with tempfile.TemporaryDirectory() as tmp:
        mesh = trimesh.creation.icosphere(subdivisions=3, radius=0.05)
        mesh_path = os.path.join(tmp, 'icosphere_1280.stl')
        mesh.export(mesh_path)
        params_file = os.path.join(tmp, 'params.yaml')
        with open(params_file, 'w') as f:
            params = world_params(args.bodies, None if args.spheres else mesh_path)
            yaml.safe_dump({'/**': {'ros__parameters': params}}, f)
        sizes, rates = [], []
        for k in range(args.runs):
            size, rate = run(repo, params_file, f'/bench_markers_{os.getpid()}_{k}',
                             args.window_s, args.start_timeout_s)
            sizes.append(size)
            rates.append(rate)
            print(f'run {k}: {size} bytes, {rate:.2f} Hz', flush=True)
    shape = 'spheres' if args.spheres else f'mesh faces {len(mesh.faces)}'
    print(f'bodies {args.bodies}, {shape}: markers message '
          f'{statistics.median(sizes)} bytes ({statistics.median(sizes) / 1e6:.3f} MB), '
          f'received {statistics.median(rates):.2f} Hz (publish_rate_hz 100; medians of '
          f'{args.runs})')
    print(f'load average {os.getloadavg()}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
