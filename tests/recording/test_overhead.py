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
Recording must not cut the node's as-fast-as-possible rate by more than 2x.

Measured on the node's own loop without DDS: SimSession stepping at 1 kHz with 100 Hz samples
built by the conversions, with and without serialising and writing them (what recording adds
per sample).  Leaving out the DDS publish makes the un-recorded loop cheaper than the node's,
so the ratio here is an upper bound on the node's slowdown.
"""

import time

from rbd_ros import conversions
from rbd_ros.config import NodeConfig
from rbd_ros.recording import BagWriter
from rbd_ros.session import SimSession
from rclpy.serialization import serialize_message

SIM_NS = 20_000_000_000  # 20 s of sim time: 20000 steps, 2001 samples


def _run(writer):
    config = NodeConfig.from_parameters({'initial_angular_velocity': [0.3, 2.0, 0.1]})
    session = SimSession(config)
    session.warm_up()
    session.paused = False
    if writer is not None:
        for topic, type_name in (('/pose', 'geometry_msgs/msg/PoseStamped'),
                                 ('/twist', 'geometry_msgs/msg/TwistStamped'),
                                 ('/odom', 'nav_msgs/msg/Odometry')):
            writer.add_topic(topic, type_name, {'depth': 10})
    start = time.perf_counter()
    while session.time_ns < SIM_NS:
        report = session.advance(1000, until_ns=SIM_NS)
        if report.sample_due:
            state, t = session.state, session.time_ns
            msgs = (('/pose', conversions.state_to_pose(state, 'world')),
                    ('/twist', conversions.state_to_twist(state, 'world', 'world', 'base_link')),
                    ('/odom', conversions.state_to_odometry(state, 'world', 'base_link')))
            if writer is not None:
                for topic, msg in msgs:
                    writer.write(topic, serialize_message(msg), t)
    return time.perf_counter() - start


def test_recording_overhead_is_below_2x(tmp_path):
    _run(None)  # warm caches and the kernel
    plain = min(_run(None) for _ in range(3))
    recorded = []
    for k in range(3):
        writer = BagWriter(str(tmp_path / f'bag{k}'))
        recorded.append(_run(writer))
        writer.close()
    ratio = min(recorded) / plain
    print(f'as-fast-as-possible loop: {SIM_NS / 1e9 / plain:.0f}x real time plain, '
          f'{SIM_NS / 1e9 / min(recorded):.0f}x recorded; slowdown {ratio:.2f}x')
    # The bound: recording may not halve the rate. Best-of-3 on each side damps the
    # noise of the shared 2-core machine.
    assert ratio < 2.0
