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

"""Replay of recordings made through SimSession + BagWriter: bit-exact, detection, bad input."""

import json
import math
import os
from pathlib import Path
import shutil
import subprocess
import sys

import pytest
from rbd_ros.bag.recording import BagWriter, open_bag
from rbd_ros.bag.replay import main, replay_bag
from rosbags.rosbag2 import StoragePlugin, Writer as RosbagsWriter
from rosbags.typesys import get_typestore, Stores
from sim_recorder import record_scripted_run, rewrite_bag

REPO = Path(__file__).resolve().parents[2]
S = 1_000_000_000
MS = 1_000_000

BOX_SCRIPT = [
    (0, 'wrench', 'world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.01)),
    (300 * MS, 'wrench', 'base_link', (0.0, 0.5, 0.0), (0.02, 0.0, 0.0)),
    (700 * MS, 'wrench', '', (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)),
    (1100 * MS, 'wrench', 'world', (-0.3, 0.2, 0.1), (0.0, 0.0, 0.0)),
]
THRUSTERS = {
    'mass_kg': 2.0, 'shape': 'box', 'dimensions_m': [0.5, 0.5, 0.02],
    'gravity': [0.0, 0.0, -9.81], 'wrench_input_names': ['left', 'right'],
    'wrench_inputs.left.topic': 'wrench_left', 'wrench_inputs.left.frame': 'body',
    'wrench_inputs.left.point_b': [0.0, 0.25, 0.0],
    'wrench_inputs.right.topic': 'wrench_right', 'wrench_inputs.right.frame': 'body',
    'wrench_inputs.right.point_b': [0.0, -0.25, 0.0],
    'wrench_timeout_s': 0.25, 'twist_frame': 'body', 'publish_clock': True,
}
THRUSTER_SCRIPT = [
    (0, 'left', '', (0.0, 0.0, 10.0), (0.0, 0.0, 0.0)),
    (0, 'right', '', (0.0, 0.0, 9.0), (0.0, 0.0, 0.0)),
    (400 * MS, 'left', 'world', (1.0, 0.0, 12.0), (0.0, 0.0, 0.0)),
]


@pytest.fixture(scope='module')
def box_bag(tmp_path_factory):
    path = tmp_path_factory.mktemp('replay') / 'box'
    record_scripted_run(str(path), {'publish_clock': True}, BOX_SCRIPT, 1500 * MS)
    return str(path)


@pytest.fixture(scope='module')
def thruster_bag(tmp_path_factory):
    path = tmp_path_factory.mktemp('replay') / 'thrusters'
    record_scripted_run(str(path), THRUSTERS, THRUSTER_SCRIPT, 1200 * MS)
    return str(path)


def copy_bag(src, dst, config_edit=None, drop=None):
    """Rewrite ``src`` into ``dst`` with an edited config and/or messages dropped."""
    return rewrite_bag(src, dst, config_edit=config_edit, drop=drop)


def run_main(capsys, *args):
    status = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return status, out, err


def test_fresh_recording_replays_bit_exact(box_bag, capsys):
    status, out, err = run_main(capsys, box_bag, '--no-progress')
    assert status == 0, out + err
    assert out.strip().endswith('MATCH') and 'MISMATCH' not in out
    result = replay_bag(box_bag)
    assert result.match
    assert result.wrenches == len(BOX_SCRIPT)
    assert set(result.topics) == {'/pose', '/twist', '/odom', '/clock'}
    for topic in result.topics.values():
        assert topic.samples == 151  # 1.5 s at 100 Hz, plus the sample at t = 0
        assert topic.bit_exact and topic.mismatches == 0
    assert result.topics['/odom'].max_position_error_m == 0.0


def test_thrusters_with_timeout_replay_bit_exact(thruster_bag):
    result = replay_bag(thruster_bag)
    assert result.match, result.problems
    assert result.wrenches == len(THRUSTER_SCRIPT)
    assert result.topics['/odom'].samples == 121


@pytest.mark.parametrize('edit', [
    {'mass_kg': 1.0 + 2 ** -52},  # one ulp: bit-exact replay must notice
    {'integrator': 'rk4'},
    {'default_wrench_frame': 'body'},  # the '' frame wrench at 0.7 s is zero: no effect alone
    {'twist_frame': 'body'},
])
def test_changed_parameter_is_detected(box_bag, tmp_path, capsys, edit):
    changed = copy_bag(box_bag, str(tmp_path / 'changed'), config_edit=edit)
    status, out, err = run_main(capsys, changed, '--no-progress')
    if edit == {'default_wrench_frame': 'body'}:
        # A zero wrench reads the same in any frame: this edit must NOT be reported.
        assert status == 0, out
        return
    assert status == 1, out
    assert 'MISMATCH' in out
    assert 'first mismatch' in out


def test_dropped_or_extra_wrench_is_detected(box_bag, tmp_path):
    dropped = copy_bag(box_bag, str(tmp_path / 'dropped'),
                       drop=lambda i, raw: raw.topic == '/wrench' and raw.log_time_ns == 300 * MS)
    result = replay_bag(dropped)
    assert not result.match
    assert result.topics['/pose'].mismatches > 0


def test_tolerance_and_accuracy_study(box_bag, capsys):
    status, out, err = run_main(capsys, box_bag, '--integrator', 'rk4', '--json')
    assert status == 1
    report = json.loads(out)
    assert report['integrator'] == 'rk4'
    assert report['recorded_integrator'] == 'midpoint_cayley'
    moved = report['topics']['/pose']['max_position_error_m']
    # rk4 and midpoint differ by O(h^2) per unit time: small but not zero over 1.5 s.
    assert 0.0 < moved < 1e-3
    status, out, err = run_main(capsys, box_bag, '--integrator', 'rk4', '--tolerance', '1e-3',
                                '--no-progress')
    assert status == 0, out
    status, out, err = run_main(capsys, box_bag, '--timestep', '0.002', '--json')
    report = json.loads(out)
    assert report['timestep_ns'] == 2 * MS and report['recorded_timestep_ns'] == MS
    assert report['samples_compared'] == 4 * 151


def test_progress_bar_on_request(box_bag, capsys):
    status, out, err = run_main(capsys, box_bag, '--progress')
    assert status == 0
    assert '100%' in err and '\r' in err


def test_unfinalised_prefix_replays(tmp_path, capsys):
    # A long run, copied while the writer is still open: what a SIGKILL leaves behind.
    src = tmp_path / 'live'
    writer = BagWriter(str(src))
    bag_path = record_scripted_run(str(tmp_path / 'full'), {}, BOX_SCRIPT, 2500 * MS).path
    full = open_bag(bag_path)
    writer._config = full.config
    writer = BagWriter(str(tmp_path / 'live2'), config=full.config)
    for topic, info in full.topics.items():
        writer.add_topic(topic, info.type_name, info.qos[0])
    for raw in full.messages():
        writer.write(raw.topic, raw.data, raw.log_time_ns)
    killed = tmp_path / 'killed'
    killed.mkdir()
    shutil.copy(writer.mcap_path, killed / 'killed_0.mcap')
    status, out, err = run_main(capsys, killed, '--no-progress')
    assert status == 0, out + err
    assert 'not finalised' in err
    assert 'NOTE: the bag was not finalised' in out
    result = replay_bag(str(killed))
    assert 0 < result.topics['/pose'].samples < 251
    writer.close()


def _rosbags_bag(path):
    store = get_typestore(Stores.ROS2_JAZZY)
    pose = store.types['geometry_msgs/msg/PoseStamped']
    header = store.types['std_msgs/msg/Header']
    stamp = store.types['builtin_interfaces/msg/Time']
    point = store.types['geometry_msgs/msg/Point']
    quat = store.types['geometry_msgs/msg/Quaternion']
    pose_t = store.types['geometry_msgs/msg/Pose']
    with RosbagsWriter(path, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection('/pose', pose.__msgtype__, typestore=store)
        msg = pose(header(stamp(0, 0), 'world'),
                   pose_t(point(1.0, 2.0, 3.0), quat(0.0, 0.0, 0.0, 1.0)))
        writer.write(conn, 0, store.serialize_cdr(msg, pose.__msgtype__))


@pytest.fixture
def bad_inputs(tmp_path, box_bag):
    empty = tmp_path / 'empty.mcap'
    empty.write_bytes(b'')
    data = open(open_bag(box_bag).mcap_path, 'rb').read()
    truncated = tmp_path / 'truncated.mcap'
    truncated.write_bytes(data[:200])  # inside the first records: no config, no chunk
    noise = tmp_path / 'noise.mcap'
    noise.write_bytes(os.urandom(4096))
    corrupt = tmp_path / 'corrupt.mcap'
    # MCAP magic, then garbage: passes the magic check, fails in the records.
    corrupt.write_bytes(data[:8] + os.urandom(4096))
    foreign = tmp_path / 'foreign'
    _rosbags_bag(foreign)
    no_mcap = tmp_path / 'no_mcap'
    no_mcap.mkdir()
    return {
        'missing': (tmp_path / 'nope', 'does not exist'),
        'empty': (empty, 'empty'),
        'truncated': (truncated, 'no rbd_ros configuration'),
        'random bytes': (noise, 'not an MCAP file'),
        'corrupt': (corrupt, ''),
        'foreign rosbags bag': (foreign, 'no rbd_ros configuration'),
        'directory without mcap': (no_mcap, 'no .mcap file'),
    }


def test_bad_inputs_one_line_exit_2(bad_inputs, capsys):
    for name, (path, needle) in bad_inputs.items():
        status, out, err = run_main(capsys, path, '--no-progress')
        assert status == 2, (name, out, err)
        lines = [line for line in err.splitlines() if not line.startswith('replay: note:')]
        assert len(lines) == 1, (name, err)
        assert lines[0].startswith('replay: error: '), (name, err)
        assert 'Traceback' not in err
        assert needle in lines[0], (name, err)


def test_console_entry_point_no_traceback(bad_inputs):
    """The real executable (python -m) on a missing and a random file: one line, status 2."""
    for key in ('missing', 'random bytes'):
        path = bad_inputs[key][0]
        proc = subprocess.run([sys.executable, '-m', 'rbd_ros.bag.replay', str(path)],
                              capture_output=True, text=True, cwd=REPO, timeout=120)
        assert proc.returncode == 2, proc.stderr
        assert len(proc.stderr.strip().splitlines()) == 1, proc.stderr
        assert 'Traceback' not in proc.stderr


def test_replay_error_is_an_rbd_error_not_an_os_error():
    """A bag whose content cannot be replayed is not an I/O failure: ReplayError is an RbdError."""
    from types import SimpleNamespace

    from rbd_ros.bag.replay import recorded_failure, ReplayError
    from rbd_ros.core.errors import RbdError
    bag = SimpleNamespace(mcap_path='b_0.mcap', run_metadata={'failure_time_ns': '1.5'})
    with pytest.raises(ReplayError, match="failure_time_ns '1.5', not an integer") as info:
        recorded_failure(bag)
    assert isinstance(info.value, RbdError)
    assert not isinstance(info.value, OSError)


def test_a_reset_within_the_first_publish_period_starts_a_new_run(tmp_path):
    """
    A ~/reset before the first sample after a wrench at t = 0 starts a run too.

    Time never went back there, but the t = 0 samples come again. As one run, replay held the
    wrench through the second run (MISMATCH); the repeated t = 0 sample starts a run from the
    initial state.
    """
    first = record_scripted_run(str(tmp_path / 'first'), {'publish_clock': True},
                                BOX_SCRIPT[:1], MS).path  # samples and the wrench at 0
    quiet = record_scripted_run(str(tmp_path / 'quiet'), {'publish_clock': True}, [],
                                300 * MS).path  # the run after the reset: no wrench
    again = [(raw.topic, raw.data, raw.log_time_ns) for raw in open_bag(quiet).messages()]
    bag = rewrite_bag(first, str(tmp_path / 'reset'), drop=lambda i, raw: raw.log_time_ns > 0,
                      extra=again)  # the run record: the one wrench's digest
    result = replay_bag(bag)
    assert result.match, result.problems
    assert result.remarks == ['1 ~/reset during the run: each run after one was replayed '
                              'from the initial state at t = 0']
    assert result.wrenches == 1 and result.compared == 4 + 4 * 31  # 4 topics, 0 and 0-0.3 s


def test_a_recording_made_before_the_link_frame_rules_still_replays(tmp_path):
    """
    Two robots of one URDF without frame_prefix: refused at start since, yet replayable.

    Their link frames collide on /tf only (the rule came in after such recordings were made):
    replay went through the start-up checks and refused the recording (exit 2); the physics is
    the same, so it replays bit for bit and says what it accepted.
    """
    from rbd_ros.core import ConfigError
    from rbd_ros.sim.config import NodeConfig
    arm = str(REPO / 'msg_config' / 'urdf' / 'arm3.urdf')
    params = {'robot_names': ['a', 'b'], 'robots.a.urdf_path': arm,
              'robots.b.urdf_path': arm, 'robots.b.initial_position': [0.0, 1.0, 0.0],
              'robots.a.initial_joint_positions': [0.3, -0.2, 0.1]}  # a swings
    with pytest.raises(ConfigError, match="would be TF frame 'mount', already the frame"):
        NodeConfig.from_parameters(params)  # a start today
    path = record_scripted_run(str(tmp_path / 'two_arms'), params, [], 200 * MS,
                               before_frame_rules=True).path
    result = replay_bag(path)
    assert result.match, result.problems
    assert result.compared >= 2 * 21  # each arm's joint_states at 0, 10, ..., 200 ms at least
    accepted = [r for r in result.remarks if r.startswith('replayed although a start today')]
    assert len(accepted) == 1 and "link 'mount' of robot 'b' would be TF frame 'mount'" in \
        accepted[0] and accepted[0].endswith('TF frame ids only, the physics is the same')
    # The last joint_states of robot a altered in its last bit is a mismatch: really compared.
    from rclpy.serialization import deserialize_message, serialize_message
    from sensor_msgs.msg import JointState
    last = max(i for i, raw in enumerate(open_bag(path).messages())
               if raw.topic == '/a/joint_states')

    def nudge(index, raw):
        if index != last:
            return None
        msg = deserialize_message(raw.data, JointState)
        msg.position[0] = math.nextafter(msg.position[0], math.inf)
        return serialize_message(msg)
    result = replay_bag(rewrite_bag(path, str(tmp_path / 'nudged'), edit=nudge))
    assert not result.match and result.topics['/a/joint_states'].mismatches == 1


def test_replayer_steps_in_named_parts():
    """The Replayer's steps, driven one by one, replay a reference bag to the same MATCH."""
    from rbd_ros.bag.replay import Replayer, TopicResult
    bag = open_bag(str(REPO / 'bags' / 'box_pushed'))
    replayer = Replayer(bag)
    messages = replayer.recorded_messages()
    wrenches = [m for m in messages if m.topic in replayer.inputs]
    assert wrenches and [m.log_time_ns for m in messages] == sorted(
        m.log_time_ns for m in messages)
    # Stepping to the first wrench, submitting it and stepping one step: it took effect there.
    first = wrenches[0]
    assert replayer.advance_to(first.log_time_ns)
    replayer.replay_wrench(first, bag.decoder(first.topic)(first.data))
    assert replayer.advance_to(first.log_time_ns + replayer.config.timestep_ns)
    replayer.check_events()
    assert replayer.result.problems == [] and replayer.digest.count == 1
    # The whole run, on a fresh replayer.
    replayer = Replayer(bag)
    result = replayer.run(replayer.recorded_messages())
    assert result.match and result.compared > 0 and result.wrenches == len(wrenches)
    # Errors are kept as maxima through the public method.
    topic = TopicResult('/pose', 'pose')
    for value in (2.0, 5.0, 3.0):
        topic.take_error('max_position_error_m', value)
    assert topic.max_position_error_m == 5.0 and topic.max_orientation_error_rad is None


def test_the_replay_executable_loads_its_kernels_without_numbas_scipy_probe(box_bag):
    # Like the node, replay skips numba's probe for scipy's BLAS (~0.25 s of CPU a run; no
    # kernel calls BLAS): rbd_ros.core.numba_target. The replay stepped, so numba's target is up.
    proc = subprocess.run([sys.executable, '-X', 'importtime', '-m', 'rbd_ros.bag.replay',
                           box_bag, '--no-progress'], capture_output=True, text=True, cwd=REPO,
                          timeout=120)
    assert proc.returncode == 0 and proc.stdout.strip().endswith('MATCH'), proc.stdout
    imported = {line.rsplit('|', 1)[-1].strip() for line in proc.stderr.splitlines()
                if line.startswith('import time:')}
    assert 'numba.np.arraymath' in imported and 'rbd_ros.core.simulator' in imported
    assert 'scipy.linalg' not in imported  # (the probe itself is listed: it is refused)
