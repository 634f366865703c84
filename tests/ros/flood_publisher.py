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
A wrench flood from its own process (used by ``test_node_flood.py`` and ``bench_flood.py``).

``python flood_publisher.py NAMESPACE FRAME_ID RATE_HZ SECONDS``: waits (with a deadline) until
the node's ``wrench`` subscription is matched, prints ``ready``, then publishes one pre-built
``WrenchStamped`` (force ``(1e-9, 0, 0)`` N in ``FRAME_ID``) in a tight loop, paced to
``RATE_HZ`` (0 = as fast as it can), for ``SECONDS`` of wall time; prints ``sent N`` and exits.
QoS: reliable, keep last 10 (rclpy's default, what ``ros2 topic pub`` uses).
"""

import sys
import time

from geometry_msgs.msg import WrenchStamped
import rclpy


def main(namespace, frame_id, rate_hz, seconds):
    rclpy.init()
    node = rclpy.create_node('flood', namespace=namespace)
    pub = node.create_publisher(WrenchStamped, 'wrench', 10)
    deadline = time.monotonic() + 60.0
    while pub.get_subscription_count() < 1:
        if time.monotonic() > deadline:
            print('no subscriber on wrench after 60 s', flush=True)
            return 1
        time.sleep(0.01)  # polling a match count, not waiting for discovery blindly
    msg = WrenchStamped()
    msg.header.frame_id = frame_id
    msg.wrench.force.x = 1e-9
    print('ready', flush=True)
    sent = 0
    publish = pub.publish
    start = time.monotonic()
    end = start + seconds
    while True:
        now = time.monotonic()
        if now >= end:
            break
        due = int((now - start) * rate_hz) if rate_hz > 0 else sent + 100
        if sent >= due:
            time.sleep(0.0002)
            continue
        for _ in range(min(due - sent, 1000)):
            publish(msg)
        sent += min(due - sent, 1000)
    print(f'sent {sent}', flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1], sys.argv[2], float(sys.argv[3]), float(sys.argv[4])))
