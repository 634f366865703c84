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
Regenerate the reference recordings in ``bags/`` with the real node, on purpose only.

Usage (from the repository root)::

    .venv/bin/python tests/recording/make_reference_bags.py            # makes missing bags
    .venv/bin/python tests/recording/make_reference_bags.py --force    # replaces them all
    .venv/bin/python tests/recording/make_reference_bags.py --only box_pushed --force

Each bag is recorded by ``rigid_body_node`` started as a user starts it (``python -m
rbd_ros.node``, which is what ``ros2 run rbd_ros rigid_body_node`` runs) with a
``msg_config/*.yaml`` file plus a few overrides (``record_path``, ``duration_s``,
``real_time_factor``); a test-side rclpy publisher sends the scripted wrenches through real DDS
(own ``ROS_DOMAIN_ID``, localhost only) on the node's sim time: each goes out once a sample at
or past its time has arrived, and lands on whatever later step DDS delivers it at; the
recording captures that step, so the replay stays bit-exact.  Existing
bags are never replaced without ``--force``.  After writing, every bag is replayed and must
match bit for bit.
"""

import argparse
import os
import pathlib
import shutil
import sys

HERE = pathlib.Path(__file__).resolve().parent
REPO = HERE.parents[1]
sys.path.insert(0, str(HERE.parent))  # tests/conftest.py: domain id, NodeProcess, wait_until
sys.path.insert(0, str(REPO))

from conftest import FIRST_START_S, NodeProcess, wait_until  # noqa: E402

BAGS = REPO / 'bags'

#: name -> (config file, overrides, script [(offset s, topic, frame_id, force, torque)]); a
#: ``<robot>/joint_command`` entry is ``(offset s, topic, joint names, positions, None)``, a
#: ``<group>/joint_trajectory`` entry ``(offset s, topic, joint names, [(time_from_start s,
#: positions), ...], None)`` (zero velocities at every point; header stamp zero: it starts on
#: the step it is taken at).
REFERENCE_BAGS = {
    'box_pushed': (
        'msg_config/free_body.yaml',
        {'duration_s': 5.0, 'real_time_factor': 1.0, 'publish_clock': True,
         'start_paused': True},
        [
            (0.5, 'wrench', 'world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
            (1.5, 'wrench', 'base_link', (0.0, 0.5, 0.0), (0.0, 0.0, 0.02)),
            (2.5, 'wrench', '', (0.0, 0.0, 0.0), (0.01, 0.0, 0.0)),
            (3.5, 'wrench', 'world', (-1.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
            (4.0, 'wrench', 'world', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        ],
    ),
    'floor_world_push': (
        'msg_config/floor_world.yaml',
        {'duration_s': 3.0, 'real_time_factor': 1.0, 'start_paused': True},
        [
            (0.5, 'pushed/wrench', 'world', (10.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
            (1.0, 'pushed/wrench', 'world', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        ],
    ),
    'door_world': (
        # The door pushed shut: -10 N m about the hinge for 0.5 s, then -1 N m holding it on
        # the post it reaches at ~1.7 s.
        'msg_config/door_world.yaml',
        {'duration_s': 3.0, 'real_time_factor': 1.0, 'start_paused': True},
        [
            (0.2, 'door/wrench', 'world', (0.0, 0.0, 0.0), (0.0, 0.0, -10.0)),
            (0.7, 'door/wrench', 'world', (0.0, 0.0, 0.0), (0.0, 0.0, -1.0)),
        ],
    ),
    'l_block_bin': (
        'msg_config/l_block_bin.yaml',
        {'duration_s': 3.0, 'real_time_factor': 0.0},
        [],
    ),
    'stack_knocked': (
        'msg_config/stack.yaml',
        {'duration_s': 3.0, 'real_time_factor': 1.0, 'start_paused': True},
        [
            (0.2, 'striker/wrench', 'world', (40.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
            (0.6, 'striker/wrench', 'world', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
        ],
    ),
    'arm_table_sweep': (
        # The 3-link arm beside the table: at 0.3 s a joint_command swings the shoulder to
        # -0.6 rad (the other joints held at 0) and the hand sweeps the box off the table.
        'msg_config/arm_table.yaml',
        {'duration_s': 2.0, 'real_time_factor': 1.0, 'start_paused': True},
        [(0.3, 'arm/joint_command', ['shoulder', 'elbow', 'wrist'], (-0.6, 0.0, 0.0), None)],
    ),
    'arm_trajectory': (
        # The same arm and table driven the way a MoveIt-style client drives it: at 0.2 s a
        # JointTrajectory on arm_group/joint_trajectory draws the arm back and up under gravity
        # (0.5 s), then swings it through the box (0.4 s) and holds the last point.
        'msg_config/arm_table.yaml',
        {'duration_s': 3.0, 'real_time_factor': 1.0, 'start_paused': True},
        [(0.2, 'arm_group/joint_trajectory', ['shoulder', 'elbow', 'wrist'],
          [(0.6, (0.5, 0.0, 0.0)), (1.6, (-0.8, 0.0, 0.0))], None)],
    ),
    'robot_pendulum': (
        # The URDF pendulum let go at 0.5 rad: a little over two periods (2.0375 s each).
        'msg_config/robot_pendulum.yaml',
        {'duration_s': 4.5, 'real_time_factor': 0.0},
        [],
    ),
    't_handle_flip': (
        'msg_config/t_handle.yaml',
        {'duration_s': 6.0, 'real_time_factor': 0.0},
        [],
    ),
    'thrusters_gravity': (
        'msg_config/thrusters_gravity.yaml',
        {'duration_s': 4.0, 'real_time_factor': 1.0, 'start_paused': True},
        [(0.1 * k, 'wrench_left', '', (0.0, 0.0, 10.0), (0.0, 0.0, 0.0)) for k in range(30)]
        + [(0.1 * k + 0.05, 'wrench_right', '', (0.0, 0.0, 9.7), (0.0, 0.0, 0.0))
           for k in range(30)],
    ),
}


def _command_line(name, config_file, overrides):
    over = ' '.join(f'-p {k}:={v}' for k, v in overrides.items())
    return (f'ros2 run rbd_ros rigid_body_node --ros-args --params-file {config_file} '
            f'-p record_path:=bags/{name} {over}')


def record(name, workdir):
    """Record ``bags/<name>`` with the node and the scripted wrenches; return the bag path."""
    from geometry_msgs.msg import PoseArray, PoseStamped
    import rclpy
    from rbd_ros.msgs import conversions
    from builtin_interfaces.msg import Duration
    from sensor_msgs.msg import JointState
    from std_srvs.srv import SetBool
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint

    config_file, overrides, script = REFERENCE_BAGS[name]
    params = dict(overrides, record_path=str(BAGS / name))
    node = NodeProcess(workdir, params=params, params_file=REPO / config_file)
    topics = sorted({topic for _, topic, *_ in script})
    rclpy.init()
    try:
        talker = rclpy.create_node(f'bag_maker_{os.getpid()}')
        spin = lambda: rclpy.spin_once(talker, timeout_sec=0.01)  # noqa: E731
        kinds = {'joint_command': JointState, 'joint_trajectory': JointTrajectory}
        pubs = {topic: talker.create_publisher(
            kinds.get(topic.rsplit('/', 1)[-1], conversions.WrenchStamped), topic, 10)
            for topic in topics}
        wait_until(lambda: all(p.get_subscription_count() > 0 for p in pubs.values())
                   or node.process.poll() is not None, FIRST_START_S,
                   what='the node to subscribe')
        if overrides.get('start_paused'):
            # Sim time starts when the wrench publishers are connected: unpause now.
            pause = talker.create_client(SetBool, '/rigid_body_node/pause')
            wait_until(lambda: pause.service_is_ready(), 60.0, what='~/pause', spin=spin)
            future = pause.call_async(SetBool.Request(data=False))
            rclpy.spin_until_future_complete(talker, future, timeout_sec=30.0)
            assert future.done() and future.result().success, 'could not unpause the node'
        # The script runs on the node's sim time: each wrench goes out once a sample at or
        # past its offset has arrived (a world publishes `poses`, a single body `pose`).
        newest = [-1]

        def on_sample(msg):
            newest[0] = max(newest[0], conversions.time_from_msg(msg.header.stamp))
        talker.create_subscription(PoseStamped, 'pose', on_sample, 10)
        talker.create_subscription(PoseArray, 'poses', on_sample, 10)
        for offset, topic, frame_id, force, torque in sorted(script, key=lambda s: s[0]):
            wait_until(lambda: newest[0] >= round(offset * 1e9), 300.0,
                       what=f'sim time {offset} s', spin=spin)
            if topic.endswith('joint_command'):  # frame_id: the joints, force: positions
                pubs[topic].publish(JointState(name=list(frame_id), position=list(force)))
                continue
            if topic.endswith('joint_trajectory'):  # frame_id: the joints, force: the points
                pubs[topic].publish(JointTrajectory(joint_names=list(frame_id), points=[
                    JointTrajectoryPoint(positions=list(q), velocities=[0.0] * len(q),
                                         time_from_start=Duration(sec=int(t), nanosec=round(
                                             (t - int(t)) * 1e9)))
                    for t, q in force]))
                continue
            pubs[topic].publish(conversions.wrench_to_msg(frame_id, force, torque))
        status = node.wait(120.0)
        talker.destroy_node()
    finally:
        rclpy.try_shutdown()
    if status != 0:
        raise SystemExit(f'{name}: the node exited with status {status}:\n{node.stderr}')
    return BAGS / name


def main(argv=None):
    """Regenerate the reference bags (only missing ones unless ``--force``)."""
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--force', action='store_true', help='replace existing bags')
    parser.add_argument('--only', action='append', choices=sorted(REFERENCE_BAGS))
    args = parser.parse_args(argv)
    from rbd_ros.bag.replay import replay_bag

    workdir = pathlib.Path(os.environ.get('TMPDIR', '/tmp')) / f'rbd_bags_{os.getpid()}'
    workdir.mkdir(parents=True, exist_ok=True)
    for name in args.only or sorted(REFERENCE_BAGS):
        target = BAGS / name
        if target.exists():
            if not args.force:
                print(f'{name}: exists, kept (use --force to replace it)')
                continue
            shutil.rmtree(target)
        path = record(name, workdir)
        size = sum(f.stat().st_size for f in path.iterdir())
        result = replay_bag(str(path))
        print(f'{name}: {size} bytes, {result.compared} samples, {result.wrenches} wrenches, '
              f'replay {"MATCH" if result.match else "MISMATCH"}')
        print(f'  made with: {_command_line(name, *REFERENCE_BAGS[name][:2])}')
        if not result.match or size >= 1_000_000:
            raise SystemExit(f'{name}: not a usable reference bag')
    shutil.rmtree(workdir, ignore_errors=True)
    return 0


if __name__ == '__main__':
    sys.exit(main())
