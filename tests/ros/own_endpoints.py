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
Does a node hear its own publisher? ``python own_endpoints.py profile|plain`` (its own process).

Creates one rclpy node, with the node's participant profile (``profile``: as
``rbd_ros.ros.process.main`` creates it) or without (``plain``), a publisher and a subscription
on one topic in it, and a second node in another context (another participant) subscribed to
the same topic. Publishes for up to 5 s and prints ``own N other M``: the messages each
subscription received. Fast DDS with ``fastdds.ignore_local_endpoints`` gives ``own 0``.
"""

import sys
import time

from rbd_ros.ros import participant
import rclpy
from rclpy.context import Context
from std_msgs.msg import String


def main(mode):
    received = {'own': 0, 'other': 0}
    # The node first: Fast DDS reads its profiles once a process, at the first participant.
    if mode == 'profile':
        with participant.node_profile() as applied:
            assert applied
            rclpy.init()
            node = rclpy.create_node('own')
    else:
        rclpy.init()
        node = rclpy.create_node('own')
    node.create_subscription(String, '/own_endpoints', lambda m: received.__setitem__(
        'own', received['own'] + 1), 10)
    other_context = Context()
    rclpy.init(context=other_context)
    other = rclpy.create_node('other', context=other_context)
    other.create_subscription(String, '/own_endpoints', lambda m: received.__setitem__(
        'other', received['other'] + 1), 10)
    pub = node.create_publisher(String, '/own_endpoints', 10)
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and not (received['other'] >= 5 and (
            received['own'] >= 5 or mode == 'profile')):
        pub.publish(String(data='x'))
        rclpy.spin_once(node, timeout_sec=0.02)
        rclpy.spin_once(other, timeout_sec=0.02)
    print(f'own {received["own"]} other {received["other"]}', flush=True)


if __name__ == '__main__':
    main(sys.argv[1])
