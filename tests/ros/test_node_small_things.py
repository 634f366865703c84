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
Issue 25 item 7: the small things a newcomer trips on, through real DDS and real processes.

Each ``ros2`` verb is done the way ros2cli does it (the CLI is not installed): ``ros2 param
set`` = ``set_parameters`` with the type the CLI infers from the text (``2`` is an INTEGER),
``ros2 param describe`` = ``describe_parameters``.
"""

import os
import signal
import subprocess
import sys
import time

from conftest import NodeProcess, REPO, wait_until
import pytest
from rbd_ros.core import ConfigError, jitcache
from rbd_ros.sim.config import NodeConfig
from rcl_interfaces.msg import Parameter as ParameterMsg, ParameterType, ParameterValue
from rcl_interfaces.srv import DescribeParameters, GetParameters, SetParameters
from rclpy.qos import ReliabilityPolicy
from ros_probe import call, Probe


def set_parameter(probe, name, value):
    """``ros2 param set <node> name value``: the CLI's type for ``value``; the result."""
    if isinstance(value, bool):
        value = ParameterValue(type=ParameterType.PARAMETER_BOOL, bool_value=value)
    else:
        value = ParameterValue(type=ParameterType.PARAMETER_INTEGER, integer_value=value)
    request = SetParameters.Request(parameters=[ParameterMsg(name=name, value=value)])
    return call(probe, SetParameters, 'set_parameters', request).results[0]


def test_parameters_qos_overrides_and_force_messages_of_a_single_body(start_node):
    node = start_node({'qos_overrides./clicked_point.subscription.reliability': 'best_effort',
                       'qos_overrides./rbd_small/drag.subscription.reliability': 'best_effort'},
                      namespace='/rbd_small')
    probe = Probe(node.namespace, outputs=('diagnostics',))
    try:
        # ros2 param set <node> real_time_factor 2: an INTEGER, accepted as 2.0 (as a params
        # file's real_time_factor: 2 is).
        result = set_parameter(probe, 'real_time_factor', 2)
        assert result.successful, result.reason
        (value,) = call(probe, GetParameters, 'get_parameters',
                        GetParameters.Request(names=['real_time_factor'])).values
        assert (value.type, value.double_value) == (ParameterType.PARAMETER_DOUBLE, 2.0)
        assert probe.diagnostic_values(
            lambda v: v['real_time_factor_target'] == '2.0', 30.0)
        assert not set_parameter(probe, 'real_time_factor', -3).successful

        # use_sim_time cannot change anything at run time: refused, with the reason.
        result = set_parameter(probe, 'use_sim_time', True)
        assert not result.successful
        assert 'parameter use_sim_time = True: read-only at run time' in result.reason

        # ros2 param describe: every double's range with its upper bound. A '> 0' one from the
        # smallest positive double (not 0.0, which is refused); it had no range at all, so no
        # upper bound either.
        names = ['mass_kg', 'timestep_s', 'max_force_n', 'restitution', 'publish_rate_hz']
        descriptors = call(probe, DescribeParameters, 'describe_parameters',
                           DescribeParameters.Request(names=names)).descriptors
        ranges = {name: [(r.from_value, r.to_value) for r in d.floating_point_range]
                  for name, d in zip(names, descriptors)}
        assert ranges == {'mass_kg': [(5e-324, 1e12)], 'timestep_s': [(5e-324, 1.0)],
                          'max_force_n': [(5e-324, 1e12)], 'restitution': [(0.0, 1.0)],
                          'publish_rate_hz': [(1e-6, 1e9)]}, ranges
        assert descriptors[0].additional_constraints == '> 0'
        # the range is what rclpy enforces on a set: beyond the upper bound is refused
        result = call(probe, SetParameters, 'set_parameters', SetParameters.Request(parameters=[
            ParameterMsg(name='real_time_factor', value=ParameterValue(
                type=ParameterType.PARAMETER_DOUBLE, double_value=2e6))])).results[0]
        assert not result.successful

        # Both overrides were applied to the drag and /clicked_point subscriptions ...
        for topic in ('/rbd_small/drag', '/clicked_point'):
            infos = probe.wait(lambda: [
                i for i in probe.node.get_subscriptions_info_by_topic(topic)
                if i.node_namespace == '/rbd_small' and i.node_name == 'rigid_body_node'],
                20.0, f'the node subscription on {topic}')
            assert infos[0].qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT, topic

        # A force of 1e300 N is reported as its magnitude, not inf.
        probe.wait(lambda: probe.publishers['wrench'].get_subscription_count() >= 1, 20.0,
                   'the wrench subscription')
        probe.publish('wrench', '', force=(1e300, 1e300, 0.0))
        wait_until(lambda: 'wrench rejected' in node.stderr, 20.0, what='the rejection log')
    finally:
        probe.close()
    assert node.stop() == 0, node.stderr
    # ... so neither is warned about as matching no endpoint.
    assert 'ignoring qos_overrides' not in node.stderr, node.stderr
    assert '|force| = 1.41421e+300 N exceeds max_force_n' in node.stderr, node.stderr
    assert 'inf N' not in node.stderr, node.stderr


def test_a_huge_quaternion_is_reported_by_its_norm_not_inf():
    with pytest.raises(ConfigError, match=r'^parameter initial_orientation = \[1e\+300, 0\.0, '
                                          r'0\.0, 1e\+300\]: norm 1\.41421e\+300 must be'):
        NodeConfig.from_parameters({'initial_orientation': [1e300, 0.0, 0.0, 1e300]})


def test_world_diagnostics_name_the_node_not_base_link(start_node):
    node = start_node({'body_names': ['a']}, namespace='/rbd_small_world')
    probe = Probe(node.namespace, outputs=('diagnostics',))
    try:
        probe.diagnostic_values(timeout_s=120.0)
        status = probe.diagnostics[-1].status[0]
        assert status.hardware_id == '/rbd_small_world/rigid_body_node', status
    finally:
        probe.close()
    assert node.stop() == 0, node.stderr


def test_two_identical_bodies_at_the_same_pose_are_refused(start_node):
    node = start_node({'body_names': ['a', 'b']})  # both at the origin, the same default box
    assert node.wait(120) == 2, node.stderr
    lines = node.stderr.strip().splitlines()
    assert len(lines) == 1, lines
    assert 'parameter bodies.a.initial_position = [0.0, 0.0, 0.0] m puts the body' in lines[0]
    assert 'deep inside bodies.b' in lines[0], lines[0]


def test_replay_json_into_a_closed_pipe_exits_141_without_a_traceback(tmp_path):
    # `replay --json bag | head -1`: the reader is gone before the result is written.
    replay = subprocess.Popen(
        [sys.executable, '-m', 'rbd_ros.bag.replay', str(REPO / 'bags' / 'box_pushed'), '--json',
         '--no-progress'], stdout=subprocess.PIPE, stderr=subprocess.PIPE, cwd=str(tmp_path))
    replay.stdout.close()
    _, stderr = replay.communicate(timeout=300)
    assert replay.returncode == 141, stderr  # 128 + SIGPIPE, what `head` users expect
    assert stderr == b'', stderr


def test_sigint_during_a_cold_compile_exits_at_once(tmp_path, monkeypatch):
    # A fresh, empty cache (as tests/ros/test_node_first_start.py forces a cold start): the
    # free-body kernels take ~25 s to compile.
    monkeypatch.setenv('XDG_CACHE_HOME', str(tmp_path / 'xdg_cache'))
    monkeypatch.delenv('NUMBA_CACHE_DIR', raising=False)
    node = NodeProcess(tmp_path, {'duration_s': 0.01}, namespace=True)
    try:
        wait_until(lambda: 'compiling the physics kernels' in node.stderr, 120.0,
                   what='the compile notice')
        time.sleep(1.0)  # well inside the compile
        start = time.monotonic()
        node.process.send_signal(signal.SIGINT)
        status = node.process.wait(timeout=60)
        # 2 s: the handler runs within the 50 ms wait of the main thread; the rest is slack for
        # a loaded 2-core machine. Waiting for the compile would take ~25 s.
        assert time.monotonic() - start < 2.0, node.stderr
        assert status == 0, node.stderr
        assert 'Traceback' not in node.stderr, node.stderr
        # The compile did not finish: no compile mark, so the next start still says it
        # compiles (a warm start, which says nothing, is tested in test_node_first_start).
        marks = [p.name for p in (tmp_path / 'xdg_cache').rglob(
            jitcache.MARK.format(kind='free'))]
        assert marks == [], marks
    finally:
        if node.process.poll() is None:
            os.kill(node.process.pid, signal.SIGKILL)
            node.process.wait()


def imported_modules(stderr):
    """Return the modules a ``python -X importtime`` process imported, read from its stderr."""
    return {line.rsplit('|', 1)[-1].strip() for line in stderr.splitlines()
            if line.startswith('import time:')}


def test_a_node_loads_its_kernels_without_numbas_scipy_probe_and_coverage(tmp_path):
    # A node start skips numba's probe for scipy's BLAS (~0.25 s of CPU a start; no kernel
    # calls BLAS): rbd_ros.core.numba_target. The node ran its steps, so numba's target is up.
    node = NodeProcess(tmp_path, params_file=REPO / 'msg_config' / 'default.yaml',
                       extra_args=['-p', 'duration_s:=0.05'], namespace=True,
                       command=[sys.executable, '-X', 'importtime', '-m', 'rbd_ros.node'])
    assert node.wait(120) == 0, node.stderr
    imported = imported_modules(node.stderr)
    assert 'numba.np.arraymath' in imported and 'rbd_ros.core.contact.simulator' in imported
    assert 'scipy.linalg' not in imported  # (the probe itself is listed: it is refused)
    # Nor does numba import coverage.py (~0.05 s of CPU; listed too: refused), unless a
    # measurement runs already.
    assert 'coverage.control' not in imported or os.environ.get('COVERAGE_PROCESS_START')
