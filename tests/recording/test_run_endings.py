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
Every way a run of the real node ends is in its bag, and replay reports a failed run as failed.

Issue 31: a world on ``msg_config/stack.yaml`` whose step goes non-finite (a drag to
(1e300, 1e300) m did it; the drag limits now refuse that, a body thrown at 1.7e308 m/s is
refused at start since its kinetic energy overflows, and a step that fails while a wrench or
drag acts releases them and goes on (tests/ros/test_node_world_hard_push.py), so here a torque
spins a slender striker up until the step fails, and fails again without the torque): the
``rbd_ros.run`` record must say how the run ended, and replay must exit non-zero (3: the
replay matches, but the recorded run failed), never ``MATCH``. With ``duration_s`` set the
node cannot reach its end: it stops with status 1 instead of pausing for ever.
"""

import json
import math
from pathlib import Path
import signal

from conftest import wait_until
from geometry_msgs.msg import PoseStamped, WrenchStamped
from rbd_ros.bag.reader import split_runs
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import EXIT_RUN_FAILED, main, replay_bag
from rclpy.serialization import deserialize_message, serialize_message
from ros_context import ros_fixture  # noqa: F401 (the ros fixture)
from sim_recorder import record_scripted_run, rewrite_bag
from std_srvs.srv import SetBool, Trigger

REPO = Path(__file__).resolve().parents[2]
STACK = REPO / 'msg_config' / 'stack.yaml'


#: The striker made a slender plate (0.6 x 0.2 x 0.05 m, 2 kg: principal moments 0.0071, 0.0604
#: and 0.0667 kg m^2) and spun by 1 kN m about (1, 1, 1) (under max_torque_nm = 1e6 N m): about
#: its weak axis alone that is 1.4e5 rad/s^2, so h|w| passes 1 rad within ~10 steps of 1 ms and
#: the implicit midpoint solve stops converging for so anisotropic a body (measured: the step at
#: 30 ms). That step is tried again without the torque (released, non_finite_step) and fails
#: again, for the spin is the state's now, not the torque's: nothing acts, so the world pauses.
#: Every start-up check passes (the body is at rest in the air at start; the torque comes later).
SLENDER = {'bodies.striker.dimensions_m': [0.6, 0.2, 0.05]}
TORQUE_NM = (1e3, 1e3, 1e3)


def _blow_up(ros, ns, proc, until):
    """Spin the striker up with a torque until ``until()`` (the step went non-finite)."""
    node, executor = ros
    pub = node.create_publisher(WrenchStamped, f'{ns}/striker/wrench', 10)

    def spun():
        if pub.get_subscription_count():
            msg = WrenchStamped()
            msg.header.frame_id = 'world'
            msg.wrench.torque.x, msg.wrench.torque.y, msg.wrench.torque.z = TORQUE_NM
            pub.publish(msg)
        executor.spin_once(timeout_sec=0.05)
        return until()
    wait_until(spun, 120.0, what='the step to go non-finite under the spin')


def _check_bag_and_replay(bag_path, ended_by, capsys):
    bag = open_bag(str(bag_path))
    assert bag.finalised, bag.notes
    run = bag.run_metadata
    assert int(run['failure_time_ns']) > 0
    assert 'would be non-finite' in run['failure']
    assert run['ended_by'] == ended_by
    assert main([str(bag_path), '--no-progress']) == EXIT_RUN_FAILED
    out = capsys.readouterr().out.strip()
    assert 'would be non-finite' in out
    assert out.splitlines()[-1].startswith('RUN FAILED'), out
    assert 'MATCH' not in out.splitlines()[-1]


def test_a_non_finite_run_is_in_the_bag_and_replay_reports_the_failure(
        ros, start_node, tmp_path, capsys):
    bag_path = tmp_path / 'thrown'
    proc = start_node(params={'record_path': str(bag_path), 'real_time_factor': 1.0,
                              **SLENDER}, params_file=STACK, namespace=True)
    _blow_up(ros, proc.namespace, proc,
             lambda: 'paused (call ~/reset, then ~/pause' in proc.stderr)
    assert 'would be non-finite' in proc.stderr
    # The torque was released first (the step failed with it acting), and said so.
    assert 'striker/wrench: released at t = ' in proc.stderr, proc.stderr
    assert '(non_finite_step)' in proc.stderr
    assert proc.stop(signal.SIGINT, timeout_s=30.0) == 0, proc.stderr
    _check_bag_and_replay(bag_path, 'SIGINT', capsys)


def test_non_finite_step_with_duration_exits_1_and_says_why(ros, start_node, tmp_path,
                                                            capsys):
    bag_path = tmp_path / 'thrown_duration'
    # 600 s of sim time: the step fails long before the end, which the run can never reach.
    proc = start_node(params={'record_path': str(bag_path), 'duration_s': 600.0,
                              'real_time_factor': 1.0, **SLENDER},
                      params_file=STACK, namespace=True)
    _blow_up(ros, proc.namespace, proc, lambda: proc.process.poll() is not None)
    assert proc.process.returncode == 1, proc.stderr
    assert 'stopping (duration_s is set): exit 1' in proc.stderr
    _check_bag_and_replay(bag_path, 'non-finite step', capsys)


def test_replay_reports_a_run_that_ended_with_an_exception(tmp_path, capsys):
    """The node records an exception out of its step loop; replay must not call that MATCH."""
    bag_path = tmp_path / 'crashed'
    record_scripted_run(str(bag_path), {}, [], 100_000_000, ended_by='exception',
                        exception=(100_000_000, 'RuntimeError: publisher destroyed'))
    assert main([str(bag_path), '--no-progress']) == EXIT_RUN_FAILED
    out = capsys.readouterr().out.strip()
    assert 'run crashed: the node stopped on an exception at t = 100000000 ns: RuntimeError: ' \
        'publisher destroyed' in out, out
    assert out.splitlines()[-1].startswith('RUN FAILED'), out


def _call(ros, client, request):
    """Call ``client`` (waiting for it) and return the response."""
    node, executor = ros
    spin = lambda: executor.spin_once(timeout_sec=0.05)  # noqa: E731
    wait_until(client.service_is_ready, 30.0, spin=spin, what=f'{client.srv_name} to be offered')
    future = client.call_async(request)
    wait_until(future.done, 30.0, spin=spin, what=f'{client.srv_name} to answer')
    return future.result()


def test_runs_reset_after_their_failures_replay_every_run(ros, start_node, tmp_path):
    """
    Runs that failed, each then ~/reset and run on: each run is replayed and judged on its own.

    Replay judged the one failure the run record held (the last) against the last run only and
    said MISMATCH ("the recorded run failed ... but the replay did not"); the record now lists
    each failure with its run. Run 1 also retries its failing step once (~/pause off): the same
    step failing again is one failure.
    """
    node, executor = ros
    spin = lambda: executor.spin_once(timeout_sec=0.05)  # noqa: E731
    bag_path = tmp_path / 'thrown_reset'
    proc = start_node(params={'record_path': str(bag_path), 'real_time_factor': 1.0,
                              **SLENDER}, params_file=STACK, namespace=True)
    ns = proc.namespace
    reset = node.create_client(Trigger, f'{ns}/rigid_body_node/reset')
    pause = node.create_client(SetBool, f'{ns}/rigid_body_node/pause')

    def paused(times):
        return lambda: proc.stderr.count('paused (call ~/reset, then ~/pause') >= times
    _blow_up(ros, ns, proc, paused(1))
    assert _call(ros, pause, SetBool.Request(data=False)).success  # the same step fails again
    wait_until(paused(2), 30.0, spin=spin, what='the failing step to fail again')
    for run, blow_up in ((2, True), (3, False)):
        assert _call(ros, reset, Trigger.Request()).success
        assert _call(ros, pause, SetBool.Request(data=False)).success  # a failure paused it
        if blow_up:
            _blow_up(ros, ns, proc, paused(3))
    # 0.3 s of run 3 (the stack at rest, nothing acting), seen in the closed chunks
    wait_until(lambda: _run_ns(bag_path, 2) >= 300_000_000, 60.0, spin=spin,
               what='0.3 s of run 3')
    assert proc.stop(signal.SIGINT, timeout_s=30.0) == 0, proc.stderr

    bag = open_bag(str(bag_path))
    topic = f'{ns}/striker/pose'
    runs = split_runs(bag.messages([topic]))
    assert len(runs) == 3 and runs[2][-1].log_time_ns >= 300_000_000
    failures = json.loads(bag.run_metadata['failures'])
    assert [f['run'] for f in failures] == [0, 1], failures
    assert failures[-1]['time_ns'] == int(bag.run_metadata['failure_time_ns'])
    result = replay_bag(str(bag_path))
    assert result.match, result.problems
    assert result.failure_reproduced.count('the replay fails at the same step') == 2
    assert 'run 1 of 3: ' in result.failure_reproduced
    assert 'run 2 of 3: ' in result.failure_reproduced
    assert [run['failure_ns'] for run in result.runs] == [
        failures[0]['time_ns'], failures[1]['time_ns'], None]
    # Every run compared: run 3's samples too (16 topics of 4 bodies at 100 Hz, >= 0.3 s).
    assert all(run['samples'] > 0 for run in result.runs), result.runs
    assert result.runs[2]['samples'] >= 30 * 16
    assert sum(run['samples'] for run in result.runs) == result.compared

    # The last pose of run 3 altered in its last bit is a mismatch: run 3 is really compared.
    last = max(i for i, raw in enumerate(bag.messages()) if raw.topic == topic)

    def nudge(index, raw):
        if index != last:
            return None
        msg = deserialize_message(raw.data, PoseStamped)
        msg.pose.position.x = math.nextafter(msg.pose.position.x, math.inf)
        return serialize_message(msg)
    tampered = rewrite_bag(str(bag_path), str(tmp_path / 'tampered'), edit=nudge)
    result = replay_bag(tampered)
    assert not result.match
    assert result.topics[topic].mismatches == 1, result.topics[topic]
    assert result.topics[topic].first_mismatch.startswith(f't = {runs[2][-1].log_time_ns} ns')
    assert result.failure_reproduced.count('the replay fails at the same step') == 2

    # The bag as an older node wrote it (its last failure only, no run: failure_time_ns is run
    # 2's) still replays: the failure is placed in run 2, run 1's cannot be checked.
    legacy = rewrite_bag(str(bag_path), str(tmp_path / 'legacy'), run_drop=('failures',))
    result = replay_bag(legacy)
    assert result.match, result.problems
    assert "taken to be run 2's" in ' '.join(result.remarks), result.remarks
    assert result.failure_reproduced.startswith('run 2 of 3: ')
    assert [run['failure_ns'] for run in result.runs][1:] == [failures[1]['time_ns'], None]
    # Run 1 is not stepped to a failure that record does not hold: it fails on replay only if
    # the torque's last message took effect in the failing step (DDS timing), and then a note
    # says it cannot be checked.
    first = result.runs[0]['failure_ns']
    assert first in (None, failures[0]['time_ns'])
    assert (first is not None) == ('run 1 of 3: the replay failed at t = '
                                   in ' '.join(result.remarks)), result.remarks


def _run_ns(path, index):
    """Return the sim time run ``index`` (0: the first) of the recording at ``path`` is at."""
    try:
        bag = open_bag(str(path))
        runs = split_runs(bag.messages([t for t in bag.topics if t.endswith('striker/pose')]))
    except Exception:  # noqa: B902 - the file may be mid-chunk
        return 0
    return runs[index][-1].log_time_ns if len(runs) > index and runs[index] else 0
