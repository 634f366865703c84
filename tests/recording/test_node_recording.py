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
The real node records through real DDS; its bags replay; signals leave usable bags.

The node runs as a subprocess started the way a user starts it (``conftest.start_node``), in
this process's own ``ROS_DOMAIN_ID``; wrenches come from an rclpy publisher in the test.
"""

from pathlib import Path
import shutil
import signal

from conftest import wait_until
import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import main, replay_bag
from rbd_ros.msgs import conversions
from ros_context import ros_fixture  # noqa: F401 - the fixture ros
from rosbags.rosbag2 import Reader as RosbagsReader
from std_srvs.srv import SetBool, Trigger

S = 1_000_000_000
STACK = Path(__file__).resolve().parents[2] / 'msg_config' / 'stack.yaml'


def _recorded_until(path, t_ns):
    """Return True once the live recording at ``path`` holds a message at or after t_ns."""
    if not Path(path).is_dir() or not list(Path(path).glob('*.mcap')):
        return False
    try:
        bag = open_bag(str(path))
    except Exception:  # noqa: B902 - the file may not even have its header yet
        return False
    return bag.end_ns is not None and bag.end_ns >= t_ns


def test_node_recording_reads_back_and_replays(start_node, ros, tmp_path, capsys):
    node, executor = ros
    bag_path = tmp_path / 'node_run'
    proc = start_node(params={
        'record_path': str(bag_path), 'duration_s': 2.0, 'real_time_factor': 1.0,
        'start_paused': True, 'publish_clock': True})
    pub = node.create_publisher(conversions.WrenchStamped, 'wrench', 10)
    pause = node.create_client(SetBool, '/rigid_body_node/pause')
    spin = lambda: executor.spin_once(timeout_sec=0.05)  # noqa: E731
    wait_until(lambda: pub.get_subscription_count() > 0 and pause.service_is_ready(), 60.0,
               spin=spin, what='the node to subscribe and offer ~/pause')
    future = pause.call_async(SetBool.Request(data=False))
    wait_until(future.done, 30.0, spin=spin, what='~/pause to answer')
    pub.publish(conversions.wrench_to_msg('world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    wait_until(lambda: _recorded_until(bag_path, S // 2), 60.0, what='0.5 s recorded')
    pub.publish(conversions.wrench_to_msg('base_link', (0.0, 1.0, 0.0), (0.0, 0.0, 0.05)))
    assert proc.wait(120.0) == 0, proc.stderr

    bag = open_bag(str(bag_path))
    assert bag.finalised, bag.notes
    types = {topic: info.type_name for topic, info in bag.topics.items()}
    assert types['/pose'] == 'geometry_msgs/msg/PoseStamped'
    assert types['/odom'] == 'nav_msgs/msg/Odometry'
    assert types['/wrench'] == 'geometry_msgs/msg/WrenchStamped'
    assert types['/clock'] == 'rosgraph_msgs/msg/Clock'
    assert bag.topics['/wrench'].message_count == 2
    assert bag.topics['/pose'].message_count == 201  # 2 s at 100 Hz, plus t = 0
    assert bag.topics['/pose'].qos[0]['depth'] == 1  # transient local, latest sample only
    with RosbagsReader(bag_path) as reader:
        counts = {c.topic: c.msgcount for c in reader.connections}
    assert counts == {topic: info.message_count for topic, info in bag.topics.items()}

    assert main([str(bag_path), '--no-progress']) == 0
    assert capsys.readouterr().out.strip().endswith('MATCH')
    result = replay_bag(str(bag_path))
    assert result.wrenches == 2 and result.match
    # The same bag replayed with another integrator must be reported as different.
    assert main([str(bag_path), '--integrator', 'rk4', '--no-progress']) == 1
    assert 'MISMATCH' in capsys.readouterr().out


def _samples(path, topic):
    """Return how many messages on ``topic`` the live recording at ``path`` holds so far."""
    try:
        return sum(1 for _ in open_bag(str(path)).messages([topic]))
    except Exception:  # noqa: B902 - the file may not even have its header yet
        return 0


def test_a_world_reset_twice_while_recording_replays_every_run(start_node, ros, tmp_path,
                                                               capsys):
    # A ~/reset sends sim time back to 0: replay said MISMATCH ("log time goes back ... replay
    # covers runs without resets") for any recording with one. Now each run after a reset is
    # replayed from the initial state: the striker is pushed in the first two runs.
    node, executor = ros
    bag_path = tmp_path / 'reset_world'
    proc = start_node(params={'record_path': str(bag_path)}, params_file=STACK)
    pub = node.create_publisher(conversions.WrenchStamped, 'striker/wrench', 10)
    reset = node.create_client(Trigger, '/rigid_body_node/reset')
    spin = lambda: executor.spin_once(timeout_sec=0.05)  # noqa: E731
    wait_until(lambda: pub.get_subscription_count() > 0 and reset.service_is_ready(), 120.0,
               spin=spin, what='the node to subscribe and offer ~/reset')
    for force in (40.0, 30.0, None):
        if force is not None:
            pub.publish(conversions.wrench_to_msg('world', (force, 0.0, 0.0), (0.0, 0.0, 0.0)))
        before = _samples(bag_path, '/striker/pose')
        # 0.3 s of sim time more (100 Hz samples), seen in the chunks closed so far
        wait_until(lambda: _samples(bag_path, '/striker/pose') > before + 30, 120.0,
                   spin=spin, what='0.3 s more recorded')
        if force is not None:
            future = reset.call_async(Trigger.Request())
            wait_until(future.done, 30.0, spin=spin, what='~/reset to answer')
            assert future.result().success
    assert proc.stop(signal.SIGINT) == 0, proc.stderr

    result = replay_bag(str(bag_path))
    assert result.match, result.problems
    assert result.remarks == ['2 ~/reset during the run: each run after one was replayed '
                              'from the initial state at t = 0']
    assert result.wrenches == 2 and result.compared > 3 * 30 * 16  # 4 bodies x 4 topics
    assert main([str(bag_path), '--no-progress']) == 0
    assert capsys.readouterr().out.strip().endswith('MATCH')


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM])
def test_sigint_sigterm_finalise_the_bag(start_node, tmp_path, sig):
    bag_path = tmp_path / f'run_{sig.name}'
    proc = start_node(params={'record_path': str(bag_path), 'real_time_factor': 1.0,
                              'initial_angular_velocity': [0.3, 2.0, 0.1]})
    wait_until(lambda: _recorded_until(bag_path, 3 * S // 2), 60.0, what='1.5 s recorded')
    assert proc.stop(sig, timeout_s=30.0) == 0, proc.stderr
    bag = open_bag(str(bag_path))
    assert bag.finalised, bag.notes
    assert bag.notes == []
    assert bag.statistics.message_count == bag.message_count
    assert bag.end_ns >= 3 * S // 2
    result = replay_bag(bag)
    assert result.match, result.problems


def test_sigkill_leaves_a_readable_prefix_that_replays(start_node, tmp_path, capsys):
    bag_path = tmp_path / 'killed'
    proc = start_node(params={'record_path': str(bag_path), 'real_time_factor': 1.0,
                              'initial_angular_velocity': [0.3, 2.0, 0.1]})
    wait_until(lambda: _recorded_until(bag_path, 5 * S // 2), 60.0, what='2.5 s recorded')
    proc.stop(signal.SIGKILL)
    assert not (bag_path / 'metadata.yaml').exists()
    bag = open_bag(str(bag_path))
    assert not bag.finalised
    # Chunks cover < 1 s of sim time and are flushed as they close: >= 1.5 s survived.
    assert bag.end_ns >= 3 * S // 2
    assert main([str(bag_path), '--no-progress']) == 0
    out, err = capsys.readouterr()
    assert 'not finalised' in err
    assert out.strip().endswith('MATCH')
    # A copy without the directory around it (a bare .mcap file) replays the same way.
    bare = tmp_path / 'bare.mcap'
    shutil.copy(bag.mcap_path, bare)
    assert replay_bag(str(bare)).match
