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
/tf through real DDS: the world → body transform of every sample, stamped with sim time.

There is no tf2_msgs wheel, so ``.ci/setup`` builds the package's two messages into the venv
(``.ci/build-tf2-msgs``). The broadcast test requires it: where tf2_msgs is not importable it
fails, naming the cause, instead of checking the other branch. That branch (the node without
tf2_msgs) is tested on its own, by hiding the package from the node process.
"""

import importlib.util
import json
import os
import pathlib
import signal
import sys

from conftest import wait_until
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import replay_bag
from rbd_ros.msgs import conversions
from ros_probe import Probe

TF2_MSGS_MISSING = (
    'tf2_msgs is not importable: .ci/setup builds it from .ci/tf2_msgs with the rosidl '
    "generators from PyPI and the machine's C/C++ compiler (log: .venv/tf2_msgs-build.log)")
# RIHS01 hash of tf2_msgs/msg/TFMessage in ROS 2 Jazzy (the rosbags Jazzy typestore gives the
# same): the type built by .ci/setup must be the real one on the wire and in bags.
JAZZY_TFMESSAGE_HASH = 'RIHS01_e369d0f05a23ae52508854b66f6aa0437f3449d652e8cbf22d5abe85d020f087'
TIMESTEP_NS = 10_000_000
# A free, torque-free, tumbling body (no gravity, no damping) with its own frame names.
PARAMS = {
    'timestep_s': TIMESTEP_NS * 1e-9, 'publish_rate_hz': 100.0, 'start_paused': True,
    'world_frame': 'map', 'body_frame': 'hull', 'mass_kg': 2.0,
    'inertia': [0.1, 0.2, 0.25, 0.0, 0.0, 0.0],
    'initial_position': [1.0, -2.0, 0.5], 'initial_orientation': [0.0, 0.0, 0.6, 0.8],
    'initial_linear_velocity': [0.3, 0.2, -0.1], 'initial_angular_velocity': [0.1, -0.2, 1.5],
}


def _count_tf_publishers(probe):
    """
    Return how many /tf publishers the probe's participant knows of.

    Called after :meth:`Probe.wait_connected`: the node creates its publishers, /tf last, before
    its services, and DDS announces a participant's writers in creation order, so once the
    probe is matched to the services' reply writers it has discovered any /tf writer. The test
    process has its own domain and stops each node before the next test.
    """
    return probe.node.count_publishers('/tf')


def _values(transform):
    """Frames and the seven numbers of a ``TransformStamped`` (live or decoded from a bag)."""
    translation, rotation = transform.transform.translation, transform.transform.rotation
    return (transform.header.frame_id, transform.child_frame_id, translation.x, translation.y,
            translation.z, rotation.x, rotation.y, rotation.z, rotation.w)


def test_tf_broadcasts_the_pose_stamped_with_sim_time(start_node, tmp_path):
    assert importlib.util.find_spec('tf2_msgs') is not None, TF2_MSGS_MISSING
    from tf2_msgs.msg import TFMessage
    built = json.loads((pathlib.Path(sys.prefix) / 'share' / 'tf2_msgs' / 'msg' /
                        'TFMessage.json').read_text())
    assert {'type_name': 'tf2_msgs/msg/TFMessage',
            'hash_string': JAZZY_TFMESSAGE_HASH} in built['type_hashes']

    bag = tmp_path / 'run'
    node = start_node(dict(PARAMS, record_path=str(bag)), namespace=True)
    probe = Probe(node.namespace)
    received = []
    subscription = probe.node.create_subscription(TFMessage, '/tf', received.append, 1000)
    try:
        probe.wait_connected()
        assert _count_tf_publishers(probe) == 1
        # Matched before the first step: the paused node has published nothing since t = 0.
        probe.wait(lambda: subscription.get_publisher_count() == 1, 60.0, 'the /tf match')
        for _ in range(3):
            t_end = probe.step(10)
        expected = [k * TIMESTEP_NS for k in range(1, 31)]
        assert t_end == expected[-1]
        tf = {}

        def all_received():
            for msg in received:
                assert len(msg.transforms) == 1, msg
                transform = msg.transforms[0]
                tf[conversions.time_from_msg(transform.header.stamp)] = transform
            received.clear()
            return all(t in tf for t in expected)

        probe.wait(all_received, 20.0, '/tf at every sample time')
        poses = {t: probe.sample('pose', t) for t in expected}
    finally:
        probe.close()
    assert 'not importable' not in node.stderr

    # Stamps are sim time (exact multiples of the step, nothing like wall time), one per sample.
    assert sorted(t for t in tf if t > 0) == expected
    p0 = PARAMS['initial_position']
    v0 = PARAMS['initial_linear_velocity']
    for t in expected:
        transform, pose = tf[t], poses[t]
        assert transform.header.frame_id == 'map' and transform.child_frame_id == 'hull'
        # The same state through the same conversions: bit-identical to the published pose.
        translation, rotation = transform.transform.translation, transform.transform.rotation
        position, orientation = pose.pose.position, pose.pose.orientation
        assert (translation.x, translation.y, translation.z) == (position.x, position.y,
                                                                 position.z)
        assert (rotation.x, rotation.y, rotation.z, rotation.w) == (
            orientation.x, orientation.y, orientation.z, orientation.w)
        # Free flight is p0 + v0 t: the default integrator's drift is exact, so the only error
        # is the round-off of 30 additions of <= 3e-3 m to values <= 2.1 m, < 30 * 2.1 * 2.2e-16
        # = 1.4e-14 m; 1e-12 m still fails any wrong position by far.
        for axis, (p, v) in enumerate(zip(p0, v0)):
            assert abs(getattr(translation, 'xyz'[axis]) - (p + v * t * 1e-9)) < 1e-12
    # The body turns ~0.44 rad about z between the first and the last sample (1.5 rad/s for
    # 0.29 s), so q_z goes from 0.606 to 0.763: the transform follows the body, it is not a
    # constant or the initial orientation.
    first, last = tf[expected[0]].transform.rotation, tf[expected[-1]].transform.rotation
    assert abs(first.z - last.z) > 0.1

    # The recording holds /tf (the node records every topic it publishes), with the Jazzy type,
    # and replays bit for bit (replay compares pose/twist/odom, /tf rides along).
    assert node.stop(signal.SIGINT) == 0, node.stderr
    recording = open_bag(bag)
    assert recording.finalised, recording.notes
    info = recording.topics['/tf']
    assert (info.type_name, info.type_hash) == ('tf2_msgs/msg/TFMessage', JAZZY_TFMESSAGE_HASH)
    recorded = {raw.log_time_ns: msg.transforms[0]
                for raw, msg in recording.decoded_messages(['/tf'])}
    assert set(expected) <= set(recorded)
    for t in expected:
        assert _values(recorded[t]) == _values(tf[t])
    assert replay_bag(str(bag)).match


def test_publish_tf_false_publishes_no_tf(start_node):
    node = start_node(dict(PARAMS, publish_tf=False), namespace=True)
    probe = Probe(node.namespace)
    try:
        probe.wait_connected()
        assert _count_tf_publishers(probe) == 0
    finally:
        probe.close()
    assert 'tf2_msgs is not importable' not in node.stderr


def test_without_tf2_msgs_the_node_says_so_and_publishes_no_tf(
        start_node, tmp_path, monkeypatch):
    # A tf2_msgs package first on the node's PYTHONPATH that fails to import, as on a plain
    # PyPI install without the package.
    shim = tmp_path / 'shim' / 'tf2_msgs'
    shim.mkdir(parents=True)
    (shim / '__init__.py').write_text("raise ImportError('tf2_msgs hidden by the test')\n")
    monkeypatch.setenv('PYTHONPATH', os.pathsep.join([str(shim.parent),
                                                      os.environ['PYTHONPATH']]))
    node = start_node(PARAMS, namespace=True)
    probe = Probe(node.namespace)
    try:
        probe.wait_connected()
        assert _count_tf_publishers(probe) == 0
        # It still simulates and publishes everything else.
        assert probe.step(10) == 10 * TIMESTEP_NS
    finally:
        probe.close()
    wait_until(lambda: 'tf2_msgs is not importable: not broadcasting /tf' in node.stderr, 10.0,
               what='the log line')
