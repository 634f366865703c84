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
Recording overhead (not a test; prints only): ``python tests/benchmarks/bench_recording.py``.

Target (recording issue): recording must not cut the node's as-fast-as-possible rate by more
than 2x. Measured on the node's own loop without DDS: SimSession stepping at 1 kHz with
100 Hz samples serialised by the node's :class:`rbd_ros.msgs.outputs.SampleBuilder`, with and
without writing the bytes (what recording adds per sample). Leaving out the DDS publish
makes the un-recorded loop cheaper than the node's, so the ratio here is an upper bound on
the node's slowdown. Also
``BagWriter.write()`` in µs per message. Medians of several repeats, with the machine load.
"""

import argparse
import os
import pathlib
import statistics
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2]))

from nav_msgs.msg import Odometry  # noqa: E402
from rbd_ros.bag.recording import BagWriter  # noqa: E402
from rbd_ros.msgs.outputs import SampleBuilder, TYPE_NAMES  # noqa: E402
from rbd_ros.sim.build import check_first_step  # noqa: E402
from rbd_ros.sim.config import NodeConfig  # noqa: E402
from rbd_ros.sim.session import SimSession  # noqa: E402
from rclpy.serialization import serialize_message  # noqa: E402

SIM_NS = 20_000_000_000  # 20 s of sim time: 20000 steps, 2001 samples


def _run(writer):
    config = NodeConfig.from_parameters({'initial_angular_velocity': [0.3, 2.0, 0.1]})
    check_first_step(config)  # compiles the kernel: not part of the figures
    session = SimSession(config)
    session.paused = False
    builder = SampleBuilder(config, tf=False)  # the node's path
    if writer is not None:
        for kind in builder.kinds:
            writer.add_topic('/' + kind, TYPE_NAMES[kind], {'depth': 10})
    start = time.perf_counter()
    while session.time_ns < SIM_NS:
        report = session.advance(1000, until_ns=SIM_NS)
        if report.sample_due:
            t = session.time_ns
            samples = builder.serialize(t, session.columns)
            if writer is not None:
                for kind, data in samples:
                    writer.write('/' + kind, data, t)
    return time.perf_counter() - start


def _write_us(path, n=20_000):
    writer = BagWriter(str(path))
    writer.add_topic('/odom', 'nav_msgs/msg/Odometry')
    data = serialize_message(Odometry())
    t0 = time.perf_counter()
    for k in range(n):
        writer.write('/odom', data, k * 1_000_000)
    per_write_us = (time.perf_counter() - t0) / n * 1e6
    writer.close()
    return per_write_us


def main(argv=None):
    """Print the recording overhead (median of ``--repeats``) against the 2x target."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--repeats', type=int, default=5)
    args = parser.parse_args(argv)
    print(f'machine load (1, 5, 15 min): {os.getloadavg()}')
    _run(None)  # warm caches and the kernel
    with tempfile.TemporaryDirectory() as tmp:
        plain, recorded, writes = [], [], []
        for k in range(args.repeats):
            plain.append(_run(None))
            writer = BagWriter(os.path.join(tmp, f'bag{k}'))
            recorded.append(_run(writer))
            writer.close()
            writes.append(_write_us(pathlib.Path(tmp) / f'speed{k}'))
    plain_s, recorded_s = statistics.median(plain), statistics.median(recorded)
    ratio = recorded_s / plain_s
    print(f'as-fast-as-possible loop: {SIM_NS / 1e9 / plain_s:.0f}x real time plain, '
          f'{SIM_NS / 1e9 / recorded_s:.0f}x recorded; slowdown {ratio:.2f}x '
          f'(target < 2x): {"PASS" if ratio < 2.0 else "SHORT"}')
    print(f'BagWriter.write: {statistics.median(writes):.1f} us per message (median)')


if __name__ == '__main__':
    main()
