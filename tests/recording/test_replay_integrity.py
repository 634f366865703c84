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
Replay checks the recorded inputs bit for bit and refuses crafted bags quickly, in one line.

Crafted bags are written with our BagWriter (message by message, :func:`rewrite_bag`) or with
the ``mcap`` writer directly; ``replay`` runs as a subprocess (``python -m rbd_ros.bag.replay``)
with a timeout, so a hang fails the test instead of stalling it.
"""

import math
import os
from pathlib import Path
import shutil
import subprocess
import sys

from geometry_msgs.msg import PoseStamped, WrenchStamped
from mcap.writer import Writer
import pytest
from rbd_ros.bag.recording import load_yaml, MAX_YAML_BYTES, open_bag
from rbd_ros.bag.replay import main
from rbd_ros.core.errors import RecordingError
from rclpy.serialization import deserialize_message, serialize_message
from sim_recorder import record_scripted_run, rewrite_bag

REPO = Path(__file__).resolve().parents[2]
MS = 1_000_000
SCRIPT = [
    (0, 'wrench', 'world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.01)),
    (300 * MS, 'wrench', 'base_link', (0.0, 0.5, 0.0), (0.02, 0.0, 0.0)),
    (700 * MS, 'wrench', 'world', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
]
# A bag the old replay needed minutes and GBs for; a healthy refusal takes ~1 s of Python start
# plus the import: 60 s only separates "refused" from "hangs".
HANG_TIMEOUT_S = 60
# 9 nested levels of 9 aliases: 9**9 = 387 million strings once expanded.
ALIAS_BOMB = ''.join(
    [f'l0: &l0 [{", ".join(["x"] * 9)}]\n']
    + [f'l{k}: &l{k} [{", ".join([f"*l{k - 1}"] * 9)}]\n' for k in range(1, 9)])


@pytest.fixture(scope='module')
def bag(tmp_path_factory):
    path = tmp_path_factory.mktemp('integrity') / 'box'
    record_scripted_run(str(path), {'publish_clock': True}, SCRIPT, 1000 * MS)
    return str(path)


def run_replay(path, *args):
    """Run the replay executable; return ``(status, stdout, stderr lines)``."""
    proc = subprocess.run([sys.executable, '-m', 'rbd_ros.bag.replay', str(path), '--no-progress',
                           *args], capture_output=True, text=True, cwd=REPO,
                          timeout=HANG_TIMEOUT_S)
    lines = [line for line in proc.stderr.splitlines() if not line.startswith('replay: note:')]
    return proc.returncode, proc.stdout, lines


def assert_refused(path, needle):
    status, out, lines = run_replay(path)
    assert status == 2, (out, lines)
    assert len(lines) == 1, lines
    assert lines[0].startswith('replay: error: ') and needle in lines[0], lines
    assert len(lines[0]) < 1000, lines[0][:2000]


def _alter_wrench(at_ns, change):
    def edit(index, raw):
        if raw.topic == '/wrench' and raw.log_time_ns == at_ns:
            msg = deserialize_message(raw.data, WrenchStamped)
            msg.wrench.force.x = change(msg.wrench.force.x)
            return serialize_message(msg)
        return None
    return edit


def test_faithful_copy_still_matches(bag, tmp_path, capsys):
    """The rewriting itself changes nothing: the digest check passes on an exact copy."""
    copy = rewrite_bag(bag, str(tmp_path / 'copy'))
    assert main([copy, '--no-progress']) == 0
    out = capsys.readouterr().out
    assert 'checked bit for bit' in out and out.strip().endswith('MATCH')


@pytest.mark.parametrize('at_ns, change', [
    (0, lambda x: math.nextafter(x, math.inf)),  # 1.0 N -> 1 ulp more
    (700 * MS, lambda x: x + 1e-30),  # 0 N -> 1e-30 N: far below the outputs' last bit
], ids=['one_ulp', 'below_output_precision'])
def test_altered_recorded_wrench_is_a_mismatch(bag, tmp_path, capsys, at_ns, change):
    altered = rewrite_bag(bag, str(tmp_path / 'altered'), edit=_alter_wrench(at_ns, change))
    assert main([altered, '--no-progress']) == 1
    out = capsys.readouterr().out
    assert 'not bit for bit those the node applied' in out
    assert out.strip().endswith('MISMATCH')


def test_bag_without_run_record_says_so(bag, tmp_path, capsys):
    """A bag cut off by SIGKILL has no rbd_ros.run record: a note, not a mismatch."""
    copy = rewrite_bag(bag, str(tmp_path / 'no_run'), keep_run=False)
    assert open_bag(copy).run_metadata is None
    assert main([copy, '--no-progress']) == 0
    out = capsys.readouterr().out
    assert 'note: no rbd_ros.run record' in out and out.strip().endswith('MATCH')


def _pose_at(t_ns):
    msg = PoseStamped()
    msg.header.frame_id = 'world'
    msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(t_ns, 1_000_000_000)
    return serialize_message(msg)


def _wrench():
    msg = WrenchStamped()
    msg.header.frame_id = 'world'
    return serialize_message(msg)


@pytest.mark.parametrize('topic', ['/pose', '/wrench'])
def test_far_future_log_time_is_refused_fast(bag, tmp_path, topic):
    data = _pose_at(2 ** 62) if topic == '/pose' else _wrench()
    crafted = rewrite_bag(bag, str(tmp_path / 'far'), extra=[(topic, data, 2 ** 62)])
    assert_refused(crafted, f'{topic} message at log time {2 ** 62} ns')


def test_message_past_the_duration_is_refused(bag, tmp_path):
    crafted = rewrite_bag(bag, str(tmp_path / 'short'), config_edit={'duration_s': 0.5})
    assert_refused(crafted, 'past the recorded duration_s = 0.5 s')


FAR = 2 ** 62


@pytest.mark.parametrize('run_edit, run_drop, needle', [
    # the record of today's node: each failure with its run
    ({'failure_time_ns': str(FAR), 'failure': 'x',
      'failures': f'[{{"run": 0, "time_ns": {FAR}, "message": "x"}}]'}, (),
     f'puts the failure at {FAR} ns'),
    # an older node's record: its last failure only
    ({'failure_time_ns': str(FAR), 'failure': 'x'}, ('failures',),
     f'puts the failure at {FAR} ns'),
    ({'failures': '[{"run": 1, "time_ns": 0, "message": "x"}]', 'failure_time_ns': '0'}, (),
     'puts a failure in run 2 but the recording holds 1 run(s)'),
    ({'failure_time_ns': str(FAR), 'failure': 'x'}, (),
     f"has failure_time_ns '{FAR}' but its failures end with 'none'"),
    ({'failures': '[' * 100_000}, (), 'not a JSON list of'),
    ({'failures': '{"run": 0}'}, (), 'not a JSON list of'),
    ({'failures': '[{"run": true, "time_ns": 0, "message": "x"}]'}, (),
     'run and time_ns must be integers >= 0'),
])
def test_failure_record_that_cannot_be_of_this_run_is_refused(bag, tmp_path, run_edit,
                                                              run_drop, needle):
    crafted = rewrite_bag(bag, str(tmp_path / 'fail_far'), run_edit=run_edit,
                          run_drop=run_drop)
    assert_refused(crafted, needle)


def _mcap_with_config(path, config_yaml):
    with open(path, 'wb') as f:
        writer = Writer(f)
        writer.start(profile='ros2', library='crafted')
        writer.add_metadata('rbd_ros', {'format': 'rbd_ros.recording/1',
                                        'config_yaml': config_yaml})
        writer.finish()
    return path


def test_alias_bomb_in_the_config_record_is_refused_fast(tmp_path):
    crafted = _mcap_with_config(tmp_path / 'bomb.mcap', ALIAS_BOMB + 'mass_kg: *l8\n')
    assert_refused(crafted, 'anchors and aliases are not accepted')


def test_oversize_config_record_is_refused(tmp_path):
    text = 'mass_kg: 1.0\n' + '#' * MAX_YAML_BYTES
    crafted = _mcap_with_config(tmp_path / 'huge.mcap', text)
    assert_refused(crafted, f'more than the {MAX_YAML_BYTES} bytes accepted')


def test_alias_bomb_in_metadata_yaml_is_refused(bag, tmp_path):
    crafted = tmp_path / 'meta_bomb'
    shutil.copytree(bag, crafted)
    (crafted / 'metadata.yaml').write_text(
        ALIAS_BOMB + 'rosbag2_bagfile_information:\n  relative_file_paths: *l8\n')
    assert_refused(crafted, 'anchors and aliases are not accepted')


def test_yaml_loader_refuses_anchors_and_size():
    assert load_yaml('a: [1, 2]\nb: {c: x}\n', 'doc') == {'a': [1, 2], 'b': {'c': 'x'}}
    for text in ('a: &x 1\nb: *x\n', 'a: &x [1]\n', ALIAS_BOMB):
        with pytest.raises(RecordingError, match='anchors and aliases are not accepted'):
            load_yaml(text, 'doc')
    with pytest.raises(RecordingError, match=f'doc: {MAX_YAML_BYTES + 1} bytes of YAML'):
        load_yaml('x' * (MAX_YAML_BYTES + 1), 'doc')


@pytest.mark.parametrize('how', ['absolute', 'dotdot', 'symlink'])
def test_metadata_yaml_paths_stay_inside_the_bag(bag, tmp_path, how):
    """A metadata.yaml naming a file outside its directory is refused, not followed."""
    outside = open_bag(bag).mcap_path  # a valid recording elsewhere: the old code replayed it
    crafted = tmp_path / 'crafted'
    crafted.mkdir()
    name = {'absolute': outside,
            'dotdot': os.path.relpath(outside, crafted),
            'symlink': 'crafted_0.mcap'}[how]
    if how == 'symlink':
        os.symlink(outside, crafted / 'crafted_0.mcap')
    meta = (Path(bag) / 'metadata.yaml').read_text()
    meta = meta.replace(os.path.basename(outside), name)
    (crafted / 'metadata.yaml').write_text(meta)
    needle = {'absolute': 'leaves the bag directory', 'dotdot': 'leaves the bag directory',
              'symlink': 'resolves outside the bag directory'}[how]
    assert_refused(crafted, needle)
