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
The far side of ``test_node_across_hosts.py``: a controller and recorder on another "machine".

A plain rclpy program, run in the other network namespace (``ip netns exec``), which reaches
the node only through one veth link: it waits (with deadlines) until it has discovered the
node's ``pose``, ``twist``, ``wrench`` and ``~/pause``, publishes a push of ``FORCE_N`` along
world x while the node is paused (so it takes effect at the first step, t = 0), unpauses it,
publishes a zero wrench once a pose stamped at or after ``STOP_S`` of sim time has arrived,
and keeps every ``pose`` and ``twist`` it receives, as the CDR bytes that arrived, until the
pose at ``END_S``. Meanwhile a packet socket on ``IFACE`` captures every UDP datagram on the
link, so the program can say, for each sample it received and each wrench it sent, whether
those exact bytes crossed the link (the node's namespace has no other way here, and shared
memory is off through ``FASTDDS_BUILTIN_TRANSPORTS=UDPv4``, but this shows it).

``python far_side.py NAMESPACE IFACE NODE_IP FORCE_N STOP_S END_S OUT_JSON`` writes its record
to ``OUT_JSON`` (the checks against the closed form are the test's) and exits 0; 1 when a
deadline passed (the reason on stdout). Needs root (the packet socket).
"""

import json
import socket
import sys
import threading
import time

from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import PoseStamped, TwistStamped, WrenchStamped
import rclpy
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message, serialize_message
from std_srvs.srv import SetBool

#: How long discovery across the link, and each later wait, may take (s of wall time).
DEADLINE_S = 30.0
ETH_P_ALL = 0x0003  # every protocol, from <linux/if_ether.h>
ETH_P_IP = 0x0800


class Capture:
    """Every UDP payload on ``iface`` (both directions), with its IPv4 source and destination."""

    def __init__(self, iface):
        self.sock = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
        self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 24)
        self.sock.bind((iface, 0))
        self.sock.settimeout(0.1)
        self.datagrams = []  # (source ip, destination ip, UDP payload)
        self.frames = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        while not self._stop.is_set():
            try:
                frame = self.sock.recv(1 << 16)
            except socket.timeout:
                continue
            self.frames += 1
            if int.from_bytes(frame[12:14], 'big') != ETH_P_IP:
                continue
            ip = frame[14:]
            if ip[9] != socket.IPPROTO_UDP:
                continue
            udp = ip[(ip[0] & 0x0F) * 4:]
            self.datagrams.append((socket.inet_ntoa(ip[12:16]), socket.inet_ntoa(ip[16:20]),
                                   bytes(udp[8:])))

    def stop(self):
        """Stop capturing (after a last 0.1 s for frames still in the socket buffer)."""
        time.sleep(0.1)
        self._stop.set()
        self._thread.join()
        self.sock.close()

    def carried(self, data, source=None, destination=None):
        """Return True if one captured datagram (``source`` to ``destination``) held ``data``."""
        return any(data in payload for src, dst, payload in self.datagrams
                   if source in (None, src) and destination in (None, dst))


def stamp_ns(msg):
    """Return a header stamp in integer nanoseconds."""
    return msg.header.stamp.sec * 1_000_000_000 + msg.header.stamp.nanosec


def main(namespace, iface, node_ip, force_n, stop_s, end_s, out_path):
    capture = Capture(iface)
    rclpy.init()
    node = rclpy.create_node('far_side', namespace=namespace)
    latched = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.TRANSIENT_LOCAL)
    received = {'pose': {}, 'twist': {}}  # stamp ns -> CDR bytes as they arrived
    diagnostics = []

    def keep(kind, msg_type):
        return lambda data: received[kind].setdefault(
            stamp_ns(deserialize_message(data, msg_type)), data)
    subs = [node.create_subscription(PoseStamped, 'pose', keep('pose', PoseStamped), latched,
                                     raw=True),
            node.create_subscription(TwistStamped, 'twist', keep('twist', TwistStamped),
                                     latched, raw=True)]
    node.create_subscription(DiagnosticArray, '/diagnostics', diagnostics.append, 10)
    wrench_pub = node.create_publisher(WrenchStamped, 'wrench', 10)
    pause = node.create_client(SetBool, 'rigid_body_node/pause')

    def spin_until(predicate, what):
        deadline = time.monotonic() + DEADLINE_S
        while not predicate():
            if time.monotonic() > deadline:
                raise TimeoutError(f'timed out after {DEADLINE_S} s waiting for {what}')
            rclpy.spin_once(node, timeout_sec=0.01)

    def wrenches_received():
        for msg in diagnostics:
            for status in msg.status:
                for kv in status.values:
                    if kv.key == 'wrenches_received' and int(kv.value) >= 1:
                        return True
        return False

    sent = []

    def push(fx):
        msg = WrenchStamped()
        msg.header.frame_id = 'world'
        msg.wrench.force.x = fx
        data = serialize_message(msg)  # published as these bytes, to find them on the link
        wrench_pub.publish(data)
        sent.append(data)

    started = time.monotonic()
    try:
        spin_until(lambda: all(s.get_publisher_count() >= 1 for s in subs)
                   and wrench_pub.get_subscription_count() >= 1 and pause.service_is_ready(),
                   "the node's pose, twist, wrench and ~/pause across the link")
        discovery_s = time.monotonic() - started
        spin_until(lambda: 0 in received['pose'], 'the t = 0 pose (transient local)')
        push(force_n)  # while paused: takes effect at the step starting at t = 0
        spin_until(wrenches_received, 'wrenches_received >= 1 in /diagnostics')
        future = pause.call_async(SetBool.Request(data=False))
        spin_until(future.done, 'the ~/pause response')
        assert future.result().success, future.result().message
        spin_until(lambda: max(received['pose']) >= stop_s * 1e9, f'a pose at {stop_s} s')
        push(0.0)
        spin_until(lambda: max(received['pose']) >= end_s * 1e9
                   and max(received['twist']) >= end_s * 1e9, f'the samples at {end_s} s')
    except TimeoutError as exc:
        print(exc, flush=True)
        return 1
    finally:
        capture.stop()
        node.destroy_node()
        rclpy.try_shutdown()
    record = {
        'discovery_s': discovery_s,
        'captured_frames': capture.frames,
        'captured_datagrams': len(capture.datagrams),
        'wrenches_sent': [data.hex() for data in sent],
        'wrenches_on_the_link': sum(capture.carried(data, destination=node_ip)
                                    for data in sent),
    }
    for kind, samples in received.items():
        record[kind] = {str(t): data.hex() for t, data in sorted(samples.items())}
        record[f'{kind}_on_the_link'] = sum(capture.carried(data, source=node_ip)
                                            for data in samples.values())
    with open(out_path, 'w') as out:
        json.dump(record, out)
    return 0


if __name__ == '__main__':
    args = sys.argv[1:]
    sys.exit(main(args[0], args[1], args[2], float(args[3]), float(args[4]), float(args[5]),
                  args[6]))
