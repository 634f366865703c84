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
One output path through real DDS: the node publishes the very bytes it records.

Raw subscriptions receive the CDR bytes of pose, twist, odom, /clock and /tf; each must equal,
byte for byte, what the recording holds for that topic and sim time, and replay of the
recording must rebuild the samples bit for bit.
"""

from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import replay_bag
from rbd_ros.msgs import outputs
from rbd_ros.sim.params import NS_PER_S
from rclpy.serialization import deserialize_message
from ros_probe import Probe

TIMESTEP_NS = 10_000_000
TOPICS = {'pose': 'pose', 'twist': 'twist', 'odom': 'odom', 'clock': '/clock', 'tf': '/tf'}
# A tumbling, drifting body, twist in the body frame, frame names of odd lengths (padding).
PARAMS = {
    'timestep_s': TIMESTEP_NS / NS_PER_S, 'publish_rate_hz': 100.0, 'start_paused': True,
    'publish_clock': True, 'twist_frame': 'body', 'world_frame': 'map', 'body_frame': 'hull_1',
    'initial_orientation': [0.0, 0.0, 0.6, 0.8], 'initial_linear_velocity': [0.3, 0.2, -0.1],
    'initial_angular_velocity': [0.1, -0.2, 1.5], 'inertia': [0.1, 0.2, 0.25, 0.0, 0.0, 0.0],
}


def stamp_ns(kind, data):
    """Return the sim time stamp of the CDR bytes of a ``kind`` sample."""
    msg = deserialize_message(data, outputs.MESSAGE_TYPES[kind])
    stamp = msg.clock if kind == 'clock' else (
        msg.transforms[0].header.stamp if kind == 'tf' else msg.header.stamp)
    return stamp.sec * NS_PER_S + stamp.nanosec


def test_the_node_publishes_the_bytes_it_records(start_node, tmp_path):
    path = tmp_path / 'run'
    node = start_node(dict(PARAMS, record_path=str(path)), namespace=True)
    probe = Probe(node.namespace, outputs=())
    received = {kind: {} for kind in TOPICS}

    def keep(kind, data):
        received[kind][stamp_ns(kind, data)] = data

    subs = [probe.node.create_subscription(
        outputs.MESSAGE_TYPES[kind], topic, lambda data, kind=kind: keep(kind, data), 1000,
        raw=True) for kind, topic in TOPICS.items()]
    expected = [k * TIMESTEP_NS for k in range(1, 11)]
    try:
        probe.wait_connected()
        probe.wait(lambda: all(sub.get_publisher_count() == 1 for sub in subs), 60.0,
                   'the raw subscriptions to match')
        for _ in expected:
            response = probe.call('step')
            assert response.success, response.message
        probe.wait(lambda: all(t in received[kind] for kind in TOPICS for t in expected), 20.0,
                   'every sample on every output topic')
    finally:
        probe.close()
    assert node.stop() == 0, node.stderr

    bag = open_bag(path)
    recorded = {(raw.topic, raw.log_time_ns): raw.data for raw in bag.messages()}
    names = {kind: topic if topic.startswith('/') else f'{node.namespace}/{topic}'
             for kind, topic in TOPICS.items()}
    for kind in TOPICS:
        for t in expected:
            assert received[kind][t] == recorded[names[kind], t], (kind, t)
    # The samples are not all alike (the body moves): the comparison is not of constants.
    assert len({received['odom'][t][-400:] for t in expected}) == len(expected)
    result = replay_bag(bag)
    assert result.match, result
    assert len(result.topics) == 4 and all(
        topic.bit_exact and topic.samples == len(expected) + 1 for topic in result.topics.values())
