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
The real node's recording when things go wrong: a non-finite step, a full disk, a bad path.

A full disk is simulated without root: the node subprocess runs with ``RLIMIT_FSIZE`` set low
and ``SIGXFSZ`` ignored, so a write past the limit fails with EFBIG ("File too large") exactly
where a full disk fails with ENOSPC.  Its stdout and stderr are pipes (not subject to the
limit), and ``--disable-external-lib-logs`` keeps rcl from writing a log file.
"""

import os
from pathlib import Path
import resource
import signal
import subprocess
import sys

from conftest import wait_until, write_params
from geometry_msgs.msg import PoseStamped
import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import EXIT_MATCH, main, replay_bag
from rbd_ros.msgs import conversions
from ros_context import ros_fixture  # noqa: F401 - the fixture ros

REPO = Path(__file__).resolve().parents[2]
S = 1_000_000_000


def test_a_wrench_whose_step_would_be_non_finite_is_released_recorded_and_replayed(
        start_node, ros, tmp_path, capsys):
    """
    The wrench that would make the step non-finite is released, not the run stopped.

    It is in the bag (it took effect: replay needs it to release it again at the same step),
    counted as rejected (``non_finite_step``), the body goes on from its last finite state
    without it, and replay reproduces the run: MATCH, no failure.
    """
    node, executor = ros
    bag_path = tmp_path / 'released'
    # Isotropic inertia 1e-300 kg m^2: a torque of 1e6 N m (within max_torque_nm) gives
    # omega ~ 1e303 rad/s after one 1 ms step, so the first step with the wrench is
    # non-finite; without it the step is.
    proc = start_node(params={
        'record_path': str(bag_path), 'inertia': [1e-300, 1e-300, 1e-300, 0.0, 0.0, 0.0],
        'real_time_factor': 1.0, 'publish_clock': True})
    poses = []
    node.create_subscription(PoseStamped, 'pose', poses.append, 10)
    pub = node.create_publisher(conversions.WrenchStamped, 'wrench', 10)
    spin = lambda: executor.spin_once(timeout_sec=0.05)  # noqa: E731
    wait_until(lambda: pub.get_subscription_count() > 0, 60.0, spin=spin,
               what='the node to subscribe')
    pub.publish(conversions.wrench_to_msg('world', (0.0, 0.0, 0.0), (1e6, 0.0, 0.0)))
    wait_until(lambda: 'released at t = ' in proc.stderr, 60.0, spin=spin,
               what='the node to release the wrench')
    line = next(t for t in proc.stderr.splitlines() if 'released at t = ' in t)
    released_ns = int(line.split('released at t = ')[1].split()[0])
    assert 'wrench: released' in line and '(non_finite_step)' in line, line
    # The run goes on: poses half a second of sim time past the release (it used to pause).
    wait_until(lambda: poses and conversions.time_from_msg(poses[-1].header.stamp)
               > released_ns + S // 2, 60.0, spin=spin, what='poses after the release')
    assert 'paused' not in proc.stderr, proc.stderr
    assert proc.stop(signal.SIGINT, timeout_s=30.0) == 0, proc.stderr

    bag = open_bag(str(bag_path))
    assert bag.finalised, bag.notes
    assert bag.topics['/wrench'].message_count == 1
    (wrench,) = bag.messages(['/wrench'])
    # It took effect at the step it was released from (recorded before that step ran).
    assert wrench.log_time_ns == released_ns
    run = bag.run_metadata
    assert run['failure_time_ns'] == '' and run['failure'] == ''
    assert run['wrenches_applied'] == '1'
    assert run['ended_by'] == 'SIGINT'
    # Replay releases it again at the same step: every sample bit for bit, no failure.
    assert main([str(bag_path), '--no-progress']) == EXIT_MATCH
    out = capsys.readouterr().out
    assert out.strip().splitlines()[-1].startswith('MATCH'), out


def _run_limited(tmp_path, params, fsize_bytes, timeout_s=120.0):
    """Run the node to its end with RLIMIT_FSIZE; return ``(status, stderr)``."""
    params_file = write_params(tmp_path / 'limited_params.yaml', params)

    def limit():
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (fsize_bytes, fsize_bytes))

    env = dict(os.environ, ROS_LOG_DIR=str(tmp_path / 'ros_log'))
    proc = subprocess.Popen(
        [sys.executable, '-m', 'rbd_ros.node', '--ros-args', '--params-file', str(params_file),
         '--disable-external-lib-logs'],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, preexec_fn=limit,
        cwd=str(tmp_path), env=env)
    try:
        out, err = proc.communicate(timeout=timeout_s)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return proc.returncode, err


def _not_info(text):
    """Return the non-empty stderr lines that are not INFO logs (e.g. 'not broadcasting /tf')."""
    return [line for line in text.splitlines() if line.strip() and not line.startswith('[INFO]')]


def test_full_disk_at_start_exits_2_in_one_line(tmp_path):
    """Header and configuration fit, the schemas do not: the bag cannot be opened."""
    bag_path = tmp_path / 'full'
    # ~1.4 kB of header + configuration + rosbag2 record fit in 4 kB; the message definitions
    # (Odometry alone is ~4 kB of text) do not.
    status, err = _run_limited(tmp_path, {
        'record_path': str(bag_path), 'duration_s': 3.0, 'real_time_factor': 0.0}, 4096)
    lines = _not_info(err)
    assert status == 2, lines
    assert len(lines) == 1, lines
    assert lines[0].startswith('rigid_body_node: recording to ')
    assert 'File too large' in lines[0] and str(bag_path) in lines[0]
    assert 'Traceback' not in lines[0]


def test_disk_full_mid_run_reports_once_and_exits_1(tmp_path):
    """A write failing mid-run: one error line, no 'recording closed', the prefix replays."""
    bag_path = tmp_path / 'midrun'
    status, err = _run_limited(tmp_path, {
        'record_path': str(bag_path), 'duration_s': 20.0, 'real_time_factor': 0.0,
        'initial_angular_velocity': [0.3, 2.0, 0.1]}, 64 * 1024)
    assert status == 1, err
    errors = [line for line in err.splitlines() if 'File too large' in line]
    assert len(errors) == 1, err
    assert 'recording stopped' in errors[0]
    assert 'recording to ' in err  # the INFO line at start
    assert 'recording closed' not in err
    assert replay_bag(str(bag_path)).match


@pytest.mark.parametrize('case', ['symlink', 'foreign_directory'])
def test_unusable_record_path_exits_2_in_one_line(start_node, tmp_path, case):
    target = tmp_path / 'target'
    target.mkdir()
    if case == 'symlink':
        record_path = tmp_path / 'link'
        os.symlink(target, record_path)
        needle = 'is a symbolic link'
    else:  # metadata.yaml plus a *directory* named like a bag file, holding a user file
        record_path = target
        (target / 'metadata.yaml').write_text('user file\n')
        (target / 'target.mcap').mkdir()
        (target / 'target.mcap' / 'notes.txt').write_text('keep me')
        needle = 'not a file of an rbd_ros bag'
    proc = start_node(params={'record_path': str(record_path), 'record_overwrite': True,
                              'duration_s': 1.0})
    assert proc.wait(120.0) == 2, proc.stderr
    lines = _not_info(proc.stderr)
    assert len(lines) == 1, lines
    assert needle in lines[0] and 'Traceback' not in proc.stderr
    if case == 'foreign_directory':
        assert (target / 'target.mcap' / 'notes.txt').read_text() == 'keep me'
        assert (target / 'metadata.yaml').read_text() == 'user file\n'
