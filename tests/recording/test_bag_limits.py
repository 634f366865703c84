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
``replay`` and ``plot`` refuse a crafted recording over the limits of :mod:`rbd_ros.sim.limits`.

Each bag is written here with the ``mcap`` writer (or, for the unfinalised one, byte by byte):
a step of 1e-9 s up to a sample at 30 s (3e10 steps, ~30 h of replay), an unfinalised file
with one small zstd chunk declaring 2 GiB, and an attached STL mesh of 250,000 triangles. The
tools run as subprocesses with a 1 GiB address-space limit (so today's code that allocates
the declared chunk cannot take the machine's memory) and must refuse each bag with exit status
2 and one line naming the field, its value and the limit, within seconds.
"""

import os
from pathlib import Path
import resource
import signal
import struct
import subprocess
import sys
import time

from geometry_msgs.msg import PoseStamped
from mcap.writer import Writer
import pytest
from rbd_ros.bag.recording import CONFIG_FORMAT, CONFIG_METADATA_NAME, MCAP_MAGIC
from rbd_ros.msgs import conversions
from rbd_ros.msgs.schemas import message_definition
from rbd_ros.sim import limits
from rclpy.serialization import serialize_message
import yaml
import zstandard

REPO = Path(__file__).resolve().parents[2]
#: A refusal reads record headers and the summary only: well under a second alone; 20 s
#: covers the interpreter start (~2 s) and imports on a loaded 2-core machine (load ~6).
REFUSE_WITHIN_S = 20.0


def _config(**params):
    base = {'timestep_s': 0.001, 'publish_rate_hz': 100.0, 'integrator': 'midpoint_cayley'}
    base.update(params)
    return {'format': CONFIG_FORMAT, 'config_yaml': yaml.safe_dump(base, sort_keys=True),
            'integrator': base['integrator'], 'timestep_ns': str(round(base['timestep_s'] * 1e9))}


def _write_bag(path, config, log_times_ns, attachments=()):
    """Write a finalised MCAP file with a pose channel and messages at ``log_times_ns``."""
    with open(path, 'wb') as stream:
        writer = Writer(stream)
        writer.start(profile='ros2', library='test_bag_limits')
        writer.add_metadata(CONFIG_METADATA_NAME, config)
        schema = writer.register_schema('geometry_msgs/msg/PoseStamped', 'ros2msg',
                                        message_definition('geometry_msgs/msg/PoseStamped'))
        channel = writer.register_channel('/pose', 'cdr', schema)
        for t in log_times_ns:
            pose = PoseStamped()
            pose.header.frame_id = 'world'
            pose.header.stamp = conversions.time_to_msg(t)
            pose.pose.orientation.w = 1.0
            writer.add_message(channel, t, serialize_message(pose), t)
        for name, data in attachments:
            writer.add_attachment(0, 0, name, 'model/stl', data)
        writer.finish()
    return path


def _tiny_step_bag(tmp_path):
    # 30 s at 1e-9 s: 3e10 steps; a sample every 10 ms (the publish period, a multiple of the
    # step), so the bag passes the time checks and only the step count can refuse it.
    return _write_bag(tmp_path / 'tiny_step.mcap', _config(timestep_s=1e-9),
                      range(0, 30_000_000_001, 10_000_000))


def _big_chunk_bag(tmp_path):
    """Write an unfinalised file: a header, then one chunk of 1 MiB of zstd zeros said 2 GiB."""
    path = tmp_path / 'big_chunk.mcap'
    _write_bag(path, _config(), [0])
    head = path.read_bytes()
    # Keep the magic and the header record (opcode 1); drop the rest.
    (length,) = struct.unpack_from('<Q', head, len(MCAP_MAGIC) + 1)
    keep = head[:len(MCAP_MAGIC) + 9 + length]
    data = zstandard.ZstdCompressor().compress(bytes(1 << 20))
    compression = b'zstd'
    body = (struct.pack('<QQQI', 0, 0, 2 << 30, 0)
            + struct.pack('<I', len(compression)) + compression
            + struct.pack('<Q', len(data)) + data)
    path.write_bytes(keep + struct.pack('<BQ', 0x06, len(body)) + body)
    return path


def _big_mesh_bag(tmp_path):
    triangles = 250_000  # over MAX_MESH_TRIANGLES, under MAX_MESH_BYTES: the count decides
    stl = bytes(80) + struct.pack('<I', triangles) + bytes(50 * triangles)
    config = _config(**{'bodies': ['hull'], 'bodies.hull.shape': 'mesh',
                        'bodies.hull.mesh_path': 'hull.stl'})
    return _write_bag(tmp_path / 'big_mesh.mcap', config, [0], [('hull.stl', stl)])


CASES = [
    (_tiny_step_bag, ['timestep_s = 1e-09 s', 'MAX_REPLAY_STEPS']),
    (_big_chunk_bag, ['declares an uncompressed size of 2147483648 bytes', 'MAX_CHUNK_BYTES']),
    (_big_mesh_bag, ["'hull.stl' has 250000 triangles", 'MAX_MESH_TRIANGLES']),
]


def _limited():
    resource.setrlimit(resource.RLIMIT_AS, (1 << 30, 1 << 30))


@pytest.mark.parametrize('tool', ['replay', 'plot'])
@pytest.mark.parametrize('make, words', CASES, ids=['tiny-step', 'big-chunk', 'big-mesh'])
def test_tools_refuse_a_bag_over_the_limits_before_the_work(tmp_path, tool, make, words):
    bag = make(tmp_path)
    start = time.monotonic()
    proc = subprocess.run(
        [sys.executable, '-m', f'rbd_ros.bag.{tool}', str(bag)]
        + (['--no-progress'] if tool == 'replay' else ['-o', str(tmp_path / 'out.png')]),
        capture_output=True, text=True, timeout=60, preexec_fn=_limited, cwd=str(tmp_path),
        env=dict(os.environ, PYTHONPATH=str(REPO)))
    took = time.monotonic() - start
    print(f'{tool} refused {bag.name} in {took:.2f} s')
    assert proc.returncode == 2, (proc.returncode, proc.stdout, proc.stderr)
    lines = [line for line in proc.stderr.splitlines() if line.startswith(f'{tool}: error:')]
    assert len(lines) == 1, proc.stderr
    assert all(word in lines[0] for word in words), lines[0]
    assert took < REFUSE_WITHIN_S


def test_limits_are_the_documented_constants():
    """The numbers the notes give; the chunks the node writes stay far below the chunk limit."""
    assert limits.MAX_REPLAY_STEPS == 100_000_000
    assert limits.MAX_CHUNK_BYTES == 64 << 20
    assert limits.MAX_MESH_TRIANGLES == 200_000
    assert limits.step_chunk(1) == limits.STEP_CHUNK_BODY_STEPS
    assert limits.step_chunk(10 ** 9) == 1


def _cpu_s(pid):
    """Return the CPU time (user + system, s) process ``pid`` has used."""
    with open(f'/proc/{pid}/stat') as f:
        fields = f.read().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf('SC_CLK_TCK')


def _default_sigint():
    # SIGINT as a terminal's Ctrl-C finds it: a pytest-xdist worker ignores SIGINT, and an
    # ignored signal stays ignored in its children, so the replay never saw the interrupt.
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def test_sigint_during_compiled_stepping_ends_replay_within_a_second(tmp_path):
    """A bag within the limits whose replay steps 1e8 times between two samples."""
    # Step 1e-7 s, a sample every 10 s: exactly MAX_REPLAY_STEPS steps, all between the two
    # samples, that is one compiled call of many seconds without the step chunks. rk4 (four
    # force evaluations a step): with midpoint_cayley a warm replay could finish all 1e8 steps
    # (~3 s) before the 4 s of CPU the test waits for, imports included.
    bag = _write_bag(tmp_path / 'long.mcap', _config(timestep_s=1e-7, publish_rate_hz=0.1,
                                                     integrator='rk4'),
                     [0, 10_000_000_000])
    proc = subprocess.Popen(
        [sys.executable, '-m', 'rbd_ros.bag.replay', str(bag), '--no-progress'],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, cwd=str(tmp_path),
        env=dict(os.environ, PYTHONPATH=str(REPO)), preexec_fn=_default_sigint)
    try:
        # Imports and the first sample take ~2 s of CPU; 4 s is inside the stepping.
        deadline = time.monotonic() + 120.0
        while _cpu_s(proc.pid) < 4.0 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert proc.poll() is None, proc.communicate()
        start = time.monotonic()
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=120.0)
        took = time.monotonic() - start
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    print(f'SIGINT during replay stepping: exit {proc.returncode} after {took:.2f} s')
    assert proc.returncode == 130, (out, err)
    assert 'replay: interrupted' in err
    # One second, plus the same slack as the node's signal tests (a loaded 2-core machine:
    # scheduler slices and the interpreter's exit).
    assert took < 2.0
