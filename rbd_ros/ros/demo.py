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
A scripted run of ``rigid_body_node``: ``python -m rbd_ros.demo``.

Starts the node as a subprocess on ``msg_config/default.yaml`` (a 1 kg box resting on a floor,
μ = 0.5, g = 9.81 m/s²; paused, recording into ``./runs/demo_<UTC stamp>``), waits for
discovery by polling, un-pauses it and, keyed on the sim time of the poses it receives,
pushes the box with 10 N along world +x from 0.5 s and lets go (a zero wrench) at 1 s: it
slides, then friction stops it. The node stops itself at ``duration_s`` = 3 s; the demo prints
where the box stopped beside the closed form for the push it really got (each wrench takes
effect at the first step after it arrives; the times are read back from the recording) and
where the bag went.
"""

import argparse
import os
from pathlib import Path
import subprocess
import sys
import time

from rbd_ros.msgs import conversions

PUSH_N = 10.0
SCRIPT = (  # (sim time ns, frame_id, force N, torque N·m, what)
    (500_000_000, 'world', (PUSH_N, 0.0, 0.0), (0.0, 0.0, 0.0),
     f'push {PUSH_N:g} N along world +x'),
    (1_000_000_000, 'world', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), 'let go (zero wrench)'),
)


def slide_distance_m(push_n, pushed_s, mass_kg=1.0, mu=0.5, g=9.81):
    """
    Return how far a box at rest slides when pushed with ``push_n`` for ``pushed_s``, then let go.

    Pushed: ``a = F/m − μ g`` (kinetic friction) for ``T``, reaching ``v = a T`` after
    ``a T² / 2``; let go: it decelerates at ``μ g`` over ``v² / (2 μ g)``.  (0 if the push does
    not overcome friction.)
    """
    a = push_n / mass_kg - mu * g
    if a <= 0.0:
        return 0.0
    v = a * pushed_s
    return 0.5 * a * pushed_s ** 2 + v * v / (2.0 * mu * g)


def default_config():
    """Return msg_config/default.yaml from the source tree, or from the install's share."""
    source = Path(__file__).resolve().parents[2] / 'msg_config' / 'default.yaml'
    if source.is_file():
        return source
    from ament_index_python.packages import get_package_share_directory
    return Path(get_package_share_directory('rbd_ros')) / 'msg_config' / 'default.yaml'


def _wait(predicate, timeout_s, spin, what):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        if time.monotonic() > deadline:
            raise TimeoutError(f'timed out after {timeout_s} s waiting for {what}')
        spin()


def main(argv=None):
    """Run the demo; return the node's exit status."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--runs', default='runs', help='directory for the recording (runs)')
    parser.add_argument('--duration', type=float, default=3.0, help='sim seconds (3.0)')
    args = parser.parse_args(argv)
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    bag = Path(args.runs).resolve() / time.strftime('demo_%Y%m%d-%H%M%S', time.gmtime())
    bag.parent.mkdir(parents=True, exist_ok=True)
    config = default_config()
    print(f'starting rigid_body_node on {config}, recording to {bag}', flush=True)
    node = subprocess.Popen([
        sys.executable, '-m', 'rbd_ros.node', '--ros-args', '--params-file', str(config),
        '-p', f'duration_s:={args.duration}', '-p', 'start_paused:=true',
        '-p', f'record_path:={bag}'])

    import rclpy
    from geometry_msgs.msg import PoseStamped, WrenchStamped
    from std_srvs.srv import SetBool
    rclpy.init()
    client = rclpy.create_node('rbd_ros_demo')
    poses = []
    client.create_subscription(PoseStamped, 'pose', poses.append, 100)
    wrench = client.create_publisher(WrenchStamped, 'wrench', 10)
    pause = client.create_client(SetBool, 'rigid_body_node/pause')

    def spin():
        rclpy.spin_once(client, timeout_sec=0.05)
        if node.poll() is not None and not poses:
            raise RuntimeError(f'rigid_body_node exited with status {node.returncode}')

    try:
        # On a first start the node compiles the contact step (about 2 min here, longer on a
        # slower machine; it logs that it does) while it already serves t = 0: sim time starts
        # when it is compiled, so the first wait for a sim time is as long as a compile.
        _wait(lambda: wrench.get_subscription_count() > 0 and pause.service_is_ready(), 900,
              spin, 'rigid_body_node (discovery)')
        future = pause.call_async(SetBool.Request(data=False))
        _wait(future.done, 30, spin, 'the ~/pause service')
        for t_ns, frame_id, force, torque, what in SCRIPT:
            _wait(lambda: poses and conversions.time_from_msg(poses[-1].header.stamp) >= t_ns,
                  900, spin, f'sim time {t_ns * 1e-9} s (after compiling, on a first start)')
            wrench.publish(conversions.wrench_to_msg(frame_id, force, torque))
            print(f't = {t_ns * 1e-9:.1f} s: {what}', flush=True)
        end_ns = round(args.duration * 1e9)
        _wait(lambda: conversions.time_from_msg(poses[-1].header.stamp) >= end_ns, 60, spin,
              'the pose at duration_s')
        _wait(lambda: node.poll() is not None, 60, spin, 'the node to exit')
    finally:
        if node.poll() is None:
            node.terminate()
            node.wait(30)
        client.destroy_node()
        rclpy.try_shutdown()
    last = poses[-1]
    p, q = last.pose.position, last.pose.orientation
    print(f'final pose at t = {conversions.time_from_msg(last.header.stamp) * 1e-9:.3f} s '
          f'in {last.header.frame_id}: position [{p.x:.6f}, {p.y:.6f}, {p.z:.6f}] m, '
          f'orientation [x, y, z, w] = [{q.x:.6f}, {q.y:.6f}, {q.z:.6f}, {q.w:.6f}]')
    x0 = 0.0
    try:
        from rbd_ros.bag.recording import open_bag
        times = [raw.log_time_ns for raw in open_bag(str(bag)).messages(['/wrench'])]
        if len(times) == 2:
            exact = x0 + slide_distance_m(PUSH_N, (times[1] - times[0]) * 1e-9)
            print(f'the push took effect at {times[0] * 1e-9:.3f} s and ended at '
                  f'{times[1] * 1e-9:.3f} s: the box should stop at x = {exact:.6f} m '
                  f'(closed form); it stopped at x = {p.x:.6f} m')
    except Exception as exc:  # noqa: B902 - the comparison is a courtesy; the bag is the result
        print(f'(could not read the push times back from the recording: {exc})')
    print(f'node exit status {node.returncode}; recording: {bag}')
    return node.returncode


if __name__ == '__main__':
    sys.exit(main())
