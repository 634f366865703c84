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
A flood of mixed inputs on one input of a world node, from its own process (``bench_flood.py``).

``python world_flood_publisher.py NAMESPACE KIND BODY RATE_HZ SECONDS SEED``: ``KIND`` is
``click`` (``/clicked_point``), ``drag`` (``<BODY>/drag``) or ``wrench`` (``<BODY>/wrench``).
Waits (with a deadline) until the node's subscription is matched, prints ``ready``, then
publishes, in a tight loop paced to ``RATE_HZ`` for ``SECONDS`` of wall time, a cycle of 400
messages pre-built from ``SEED``, taking turns among four categories:

- *valid*: in the ``world`` frame; a point within 0.6 m of the stack of ``msg_config/stack.yaml``
  (a click there may grab a body, a drag pulls one with at most ~50 N), a wrench of at most
  ~9 N and 0.9 N·m;
- *random*: every component ``±10^u`` with ``u`` uniform in ``[-3, 9]``, in ``world`` or
  ``''``: some within the limits, most not
  (``max_drag_point_m`` = 1e3 m, ``max_force_n`` = ``max_torque_nm`` = 1e6 by default);
- *NaN*: a valid message with its x component NaN (never all NaN: that releases a drag);
- *out of frame*: a valid message whose ``header.frame_id`` is ``not_a_frame``.

Which messages the node's defaults must reject is known from the values alone for wrenches
(frame, non-finite, ``|force|``, ``|torque|``) and for the frame, NaN and distance checks of
points; a drag's spring-force check depends on the state (with the default ``k`` = 50 N/m a
point within 1e3 m pulls with at most ~5e4 N, under the limit). On exit it prints
``sent N expected_rejections R``: ``R`` of the ``N`` sent are rejected if the node takes them.
QoS: reliable, keep last 10 (rclpy's default, what ``ros2 topic pub`` uses).
"""

import math
import random
import sys
import time

from geometry_msgs.msg import PointStamped, WrenchStamped
import rclpy

CYCLE = 400
MAX_POINT_M = 1e3  # the node's default max_drag_point_m
MAX_LOAD = 1e6  # the node's default max_force_n and max_torque_nm
CATEGORIES = ('valid', 'random', 'nan', 'frame')


def _huge(rng):
    return rng.choice((-1.0, 1.0)) * 10.0 ** rng.uniform(-3.0, 9.0)


def _point(rng, category):
    msg = PointStamped()
    msg.header.frame_id = 'world'
    if category == 'random':
        msg.header.frame_id = rng.choice(('world', ''))
        values = [_huge(rng) for _ in range(3)]
    else:  # around the stack: x, y within 0.6 m of the column, z from the floor to 0.9 m
        values = [rng.uniform(-0.6, 0.6), rng.uniform(-0.6, 0.6), rng.uniform(0.0, 0.9)]
    if category == 'nan':
        values[0] = math.nan
    if category == 'frame':
        msg.header.frame_id = 'not_a_frame'
    msg.point.x, msg.point.y, msg.point.z = values
    bad = category != 'valid' and (category != 'random' or math.hypot(*values) > MAX_POINT_M)
    return msg, bad


def _wrench(rng, category):
    msg = WrenchStamped()
    msg.header.frame_id = 'world'
    if category == 'random':
        msg.header.frame_id = rng.choice(('world', ''))
        force, torque = [_huge(rng) for _ in range(3)], [_huge(rng) for _ in range(3)]
    else:
        force = [rng.uniform(-5.0, 5.0) for _ in range(3)]
        torque = [rng.uniform(-0.5, 0.5) for _ in range(3)]
    if category == 'nan':
        force[0] = math.nan
    if category == 'frame':
        msg.header.frame_id = 'not_a_frame'
    f, t = msg.wrench.force, msg.wrench.torque
    f.x, f.y, f.z = force
    t.x, t.y, t.z = torque
    bad = category != 'valid' and (
        category != 'random' or math.hypot(*force) > MAX_LOAD or math.hypot(*torque) > MAX_LOAD)
    return msg, bad


def messages(kind, seed):
    """Return the cycle of ``(message, rejected_if_taken)`` pairs of ``kind``."""
    rng = random.Random(seed)
    build = _wrench if kind == 'wrench' else _point
    return [build(rng, CATEGORIES[i % len(CATEGORIES)]) for i in range(CYCLE)]


def main(namespace, kind, body, rate_hz, seconds, seed):
    rclpy.init()
    node = rclpy.create_node('world_flood', namespace=namespace)
    topic = {'click': '/clicked_point', 'drag': f'{body}/drag', 'wrench': f'{body}/wrench'}[kind]
    pub = node.create_publisher(WrenchStamped if kind == 'wrench' else PointStamped, topic, 10)
    deadline = time.monotonic() + 60.0
    while pub.get_subscription_count() < 1:
        if time.monotonic() > deadline:
            print(f'no subscriber on {topic} after 60 s', flush=True)
            return 1
        time.sleep(0.01)  # polling a match count, not waiting for discovery blindly
    cycle = messages(kind, seed)
    msgs = [m for m, _ in cycle]
    bad = [b for _, b in cycle]
    bad_per_cycle = sum(bad)
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
        for i in range(sent, sent + min(due - sent, 1000)):
            publish(msgs[i % CYCLE])
        sent += min(due - sent, 1000)
    expected = (sent // CYCLE) * bad_per_cycle + sum(bad[:sent % CYCLE])
    print(f'sent {sent} expected_rejections {expected}', flush=True)
    node.destroy_node()
    rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4]), float(sys.argv[5]),
                  int(sys.argv[6])))
