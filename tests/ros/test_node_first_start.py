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
First start: the node says it compiles, and numba's cache goes to a private per-user directory.

numba loads its cache with pickle, so the cache must never sit in the installed package or in a
directory that other users can write (see :mod:`rbd_ros.core.jitcache`). A cold compile costs
~20-60 s of CPU, so one test does the cold start and the warm one after it.
"""

import os
import pathlib
import shutil
import stat
import subprocess
import sys

from conftest import NodeProcess, REPO
from geometry_msgs.msg import PoseArray
import numpy as np
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import replay_bag
from rbd_ros.core import layout
from rclpy.qos import DurabilityPolicy, qos_profile_sensor_data, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
import yaml

PACKAGE = REPO / 'rbd_ros'


def numba_files(root):
    """Return ``{path: mtime_ns}`` of numba's cache files (index .nbi, data .nbc) under root."""
    return {p: p.stat().st_mtime_ns for p in pathlib.Path(root).rglob('*')
            if p.suffix in ('.nbi', '.nbc')}


def _cold_start_serving_t0(tmp_path, probe_for):
    """Run a cold start (the caller empties the cache); return its NodeProcess, ended."""
    # Issue 25: a cold start of a body or a world is on the graph within seconds. While its
    # kernels compile (in the background) it publishes t = 0, refuses ~/step, and holds a wrench
    # sent meanwhile; once compiled, sim time starts and the wrench acts from the first step:
    # v(t) = F t / m to round-off (a constant force, no gravity: every integrator's velocity
    # update is exact for it; 1e-12 relative is a few thousand steps of float64 sums).
    mass_kg, force_n = 2.0, 3.0
    bag = tmp_path / 'cold_run'
    node = NodeProcess(tmp_path, {'mass_kg': mass_kg, 'duration_s': 3.0, 'start_paused': False,
                                  'wrench_timeout_s': 0.0, 'record_path': str(bag)},
                       namespace=True)
    probe = probe_for(node)
    probe.wait_connected(120.0)
    probe.wait(lambda: 0 in probe.samples['pose'], 60.0, what='the pose at t = 0')
    refused = probe.call('step')
    probe.publish('wrench', 'world', force=(force_n, 0.0, 0.0))
    probe.wait(lambda: any(kv.key == 'wrenches_received' and int(kv.value) == 1
                           for m in probe.diagnostics for kv in m.status[0].values),
               60.0, what='the wrench received')
    compiled_then = 'physics kernels compiled in' in node.stderr
    assert not compiled_then, 'the kernels compiled before the test could see the node ' \
        f'serve t = 0 (a machine far faster than this one?): {node.stderr}'
    assert set(probe.samples['pose']) == {0}, sorted(probe.samples['pose'])
    assert probe.diagnostics[-1].status[0].message.startswith('compiling the physics kernels')
    assert not refused.success and 'compiling' in refused.message, refused.message
    assert node.wait(600) == 0, node.stderr
    assert 'physics kernels compiled in' in node.stderr, node.stderr
    probe.wait(lambda: max(probe.samples['twist']) >= 2_900_000_000, 20.0, what='the last twists')
    for t_ns, twist in probe.samples['twist'].items():
        expected = force_n * t_ns * 1e-9 / mass_kg
        assert abs(twist.twist.linear.x - expected) <= 1e-12 * max(1.0, expected), (t_ns, twist)
    # The recording holds the wrench at the first step, and replays bit for bit.
    result = replay_bag(str(bag))
    assert result.wrenches == 1 and result.match, result.problems
    return node


def test_a_cold_start_logs_the_compile_and_caches_in_the_users_cache_dir(tmp_path, monkeypatch,
                                                                         probe_for):
    cache_home = tmp_path / 'xdg_cache'
    monkeypatch.setenv('XDG_CACHE_HOME', str(cache_home))
    monkeypatch.delenv('NUMBA_CACHE_DIR', raising=False)  # set by this process's own import
    in_package = numba_files(PACKAGE)
    params = {'duration_s': 0.01, 'start_paused': False}

    cold = _cold_start_serving_t0(tmp_path, probe_for)
    cache_dir = cache_home / 'rbd_ros' / 'numba' / f'layout-{layout.fingerprint_hash()}'
    assert 'compiling the physics kernels (the free-body step: about ' in cold.stderr, \
        cold.stderr
    assert f'once per version; cached in {cache_dir})' in cold.stderr, cold.stderr
    assert 'physics kernels compiled in' in cold.stderr, cold.stderr
    written = numba_files(cache_dir)
    assert any(p.suffix == '.nbi' for p in written) and any(p.suffix == '.nbc' for p in written)
    for directory in (cache_dir, cache_dir.parent, cache_dir.parent.parent):
        assert stat.S_IMODE(directory.stat().st_mode) == 0o700, directory
    assert numba_files(PACKAGE) == in_package  # nothing written or rewritten in the package

    # Index files older than the sources, as a copy that keeps times or a clock behind the
    # checkout's leaves them (a CI run saw that): numba still loads them (it compares the
    # source's time and size stored in the index), so the node must not claim to compile.
    past = min(p.stat().st_mtime_ns for p in PACKAGE.rglob('*.py')) - 3600 * 10**9
    for path in written:
        if path.suffix == '.nbi':
            os.utime(path, ns=(past, past))
    written = numba_files(cache_dir)

    warm = NodeProcess(tmp_path, params, namespace=True)
    assert warm.wait(300) == 0, warm.stderr
    assert 'compiling the physics kernels' not in warm.stderr, warm.stderr
    assert numba_files(cache_dir) == written  # loaded, not compiled again

    # A copy of the same sources somewhere else, with new file times (as `colcon build` or
    # `pip install` leave an installed copy): the same cache serves it, nothing is compiled.
    copy = tmp_path / 'elsewhere' / 'site-packages'
    shutil.copytree(PACKAGE, copy / 'rbd_ros', ignore=shutil.ignore_patterns('__pycache__'))
    for path in (copy / 'rbd_ros').rglob('*.py'):
        path.touch()
    monkeypatch.setenv('PYTHONPATH', str(copy))
    moved = NodeProcess(tmp_path, params, namespace=True)
    assert moved.wait(300) == 0, moved.stderr
    assert 'compiling the physics kernels' not in moved.stderr, moved.stderr
    assert numba_files(cache_dir) == written


def test_the_warm_up_module_compiles_ahead_and_the_node_then_starts_warm(tmp_path, monkeypatch):
    # What doc/getting-started.md promises a packager: `python -m rbd_ros.core.warmup` after an
    # install compiles what a first start would, and the first `ros2 run` after it says nothing
    # about compiling. The free-body kind alone keeps this test to one ~20 s compile.
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path / 'xdg_cache'))
    monkeypatch.delenv('NUMBA_CACHE_DIR', raising=False)
    ahead = subprocess.run([sys.executable, '-m', 'rbd_ros.core.warmup', '--only', 'free'],
                           cwd=REPO, capture_output=True, text=True, timeout=900)
    assert ahead.returncode == 0, ahead.stderr
    assert ahead.stdout.startswith('free kernels ready in '), ahead.stdout
    node = NodeProcess(tmp_path, {'duration_s': 0.01, 'start_paused': False}, namespace=True)
    assert node.wait(300) == 0, node.stderr
    assert 'compiling the physics kernels' not in node.stderr, node.stderr
    again = subprocess.run([sys.executable, '-m', 'rbd_ros.core.warmup', '--only', 'free'],
                           cwd=REPO, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and again.stdout == '', again.stdout  # nothing left to compile


def test_a_cache_dir_that_others_can_write_is_refused(tmp_path, monkeypatch):
    cache_dir = tmp_path / 'rbd_ros' / 'numba'
    cache_dir.mkdir(parents=True)
    cache_dir.parent.chmod(0o700)
    cache_dir.chmod(0o775)  # group-writable: someone else could plant a pickle in it
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path))
    monkeypatch.delenv('NUMBA_CACHE_DIR', raising=False)
    in_package = numba_files(PACKAGE)
    # Choose the cache as a simulator does, then compile one small kernel of the core (what a
    # first step does for every kernel, in ~1 s instead of the free step's ~20 s of CPU) and
    # use it, with the refused directory.
    probe = ('from rbd_ros.core import jitcache, kernels; '
             'jitcache.configured(); '
             'assert kernels._quat_to_matrix(1.0, 0.0, 0.0, 0.0)[2, 2] == 1.0; '
             'print(jitcache.CACHE_DIR, jitcache.kernels_on_disk())')
    result = subprocess.run([sys.executable, '-c', probe], capture_output=True, text=True,
                            env=dict(os.environ), timeout=600, cwd=str(tmp_path))
    assert result.returncode == 0, result.stderr
    # No cache directory in use, and nothing written: not there, not next to the package.
    assert result.stdout.split() == ['None', 'False'], result.stdout
    assert numba_files(tmp_path) == {}
    assert numba_files(PACKAGE) == in_package
    assert f'numba cache directory {cache_dir}: writable by group or others (mode 0775); ' \
           'compiling the physics kernels in memory at every start' in result.stderr, \
        result.stderr
    assert not list(cache_dir.iterdir())


def test_a_cold_robot_start_publishes_its_placement_while_the_joints_compile(
        tmp_path, monkeypatch, probe_for):
    # Issue 25 item 2: a robot file too is on the graph and publishes t = 0 within seconds of a
    # cold start (the joints kernels compile for ~50 s of CPU in the background). Its t = 0
    # joint states are the URDF placement at initial_joint_positions, read back from the link
    # poses built by forward kinematics: equal to round-off (1e-15 rad is a few ulps of the
    # angles, from composing three quaternions). Stopped while compiling, it exits at once
    # (status 0) and leaves a readable recording holding that sample.
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path / 'xdg_cache'))
    monkeypatch.delenv('NUMBA_CACHE_DIR', raising=False)
    initial = [0.4, -0.7, 1.1]
    bag = tmp_path / 'cold_robot'
    node = NodeProcess(tmp_path, {
        'robot_names': ['arm'], 'robots.arm.urdf_path': str(REPO / 'msg_config/urdf/arm3.urdf'),
        'robots.arm.initial_joint_positions': initial, 'gravity': [0.0, 0.0, -9.81],
        'start_paused': False, 'record_path': str(bag)}, namespace=True)
    try:
        probe = probe_for(node, inputs=(), outputs=('diagnostics',))
        got = []
        qos = QoSProfile(depth=100, durability=DurabilityPolicy.VOLATILE,
                         reliability=ReliabilityPolicy.RELIABLE)
        probe.node.create_subscription(JointState, 'arm/joint_states', got.append, qos)
        probe.wait(lambda: got, 60.0, 'the joint states at t = 0')
        probe.wait(lambda: probe.diagnostics, 10.0, 'the diagnostics while compiling')
        refused = probe.call('step')
        assert 'physics kernels compiled in' not in node.stderr, 'compiled before the test ' \
            f'saw t = 0 served (a machine far faster than this one?): {node.stderr}'
        notice = 'compiling the physics kernels (the joints and robots step: about '
        assert notice in node.stderr, node.stderr
        assert {(m.header.stamp.sec, m.header.stamp.nanosec) for m in got} == {(0, 0)}
        assert list(got[0].name) == ['shoulder', 'elbow', 'wrist'], got[0].name
        assert np.allclose(got[0].position, initial, rtol=0.0, atol=1e-15), got[0].position
        assert list(got[0].velocity) == [0.0] * 3 and list(got[0].effort) == [0.0] * 3
        diag = probe.diagnostics[-1].status[0]
        assert diag.message.startswith('compiling the physics kernels'), diag.message
        # Joint errors are measured from the first step on (the placement is not projected yet).
        assert not any(kv.key.startswith('joint_error') for kv in diag.values)
        assert not refused.success and 'compiling' in refused.message, refused.message
    finally:  # never leave a node running (it has no duration)
        status = node.stop()
    assert status == 0, node.stderr
    assert _recorded_stamps(bag, f'{node.namespace}/arm/joint_states') == [(0, 0)]


def test_a_cold_jointed_world_start_publishes_its_placement_while_the_kernels_compile(
        tmp_path, monkeypatch, probe_for):
    # Issue 25 item 2: a world with joints (pendulum_world.yaml: a ball on a hinge above a box)
    # is on the graph and publishes t = 0 within seconds of a cold start too. Its projection
    # onto the joints waits for the first step (WorldSimulator(defer_projection=True)), so
    # building it compiles nothing: it took the joints kernels' whole compile (~85 s of CPU)
    # before the node was on the graph. At t = 0 the bob is where the file puts it (the
    # parameter's value, exactly: nothing has moved it) and the hinge reads 0 (its frames are
    # defined at the initial poses; 1e-15 rad is a few ulps of an angle from two quaternions).
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path / 'xdg_cache'))
    monkeypatch.delenv('NUMBA_CACHE_DIR', raising=False)
    params_file = REPO / 'msg_config/pendulum_world.yaml'
    bag = tmp_path / 'cold_world'
    node = NodeProcess(tmp_path, params_file=params_file,
                       extra_args=('-p', 'start_paused:=false', '-p', f'record_path:={bag}'),
                       namespace=True)
    try:
        probe = probe_for(node, inputs=(), outputs=('diagnostics',))
        poses, joints = [], []
        probe.node.create_subscription(PoseArray, 'poses', poses.append, qos_profile_sensor_data)
        probe.node.create_subscription(JointState, 'joint_states', joints.append,
                                       qos_profile_sensor_data)
        probe.wait(lambda: poses and joints, 60.0, 'the poses and joint states at t = 0')
        probe.wait(lambda: probe.diagnostics, 10.0, 'the diagnostics while compiling')
        assert 'physics kernels compiled in' not in node.stderr, 'compiled before the test ' \
            f'saw t = 0 served (a machine far faster than this one?): {node.stderr}'
        notice = 'compiling the physics kernels (the contact step with joints: about '
        assert notice in node.stderr, node.stderr
        assert {(m.header.stamp.sec, m.header.stamp.nanosec) for m in poses + joints} == {(0, 0)}
        bob = poses[0].poses[0].position
        given = yaml.safe_load(params_file.read_text())['/**']['ros__parameters'][
            'bodies.bob.initial_position']
        assert [bob.x, bob.y, bob.z] == given
        assert list(joints[0].name) == ['hinge'] and abs(joints[0].position[0]) <= 1e-15
        diag = probe.diagnostics[-1].status[0]
        assert diag.message.startswith('compiling the physics kernels'), diag.message
        assert not any(kv.key.startswith('joint_error') for kv in diag.values)
    finally:  # never leave a node running while it compiles for minutes
        status = node.stop()
    assert status == 0, node.stderr
    assert _recorded_stamps(bag, f'{node.namespace}/poses') == [(0, 0)]


def _recorded_stamps(bag, topic):
    """Return ``[(sec, nanosec)]``: the header stamps recorded on ``topic`` in ``bag``."""
    recorded = open_bag(bag)
    decode = recorded.decoder(topic)
    return [(m.header.stamp.sec, m.header.stamp.nanosec)
            for m in (decode(raw.data) for raw in recorded.messages([topic]))]
