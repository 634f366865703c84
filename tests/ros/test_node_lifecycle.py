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
The node as a process.

Start-up errors, exit paths, recording hook, /clock, namespaces, diagnostics and
wall-clock pacing.
"""

import os
import signal
import time

from conftest import wait_until
import pytest
from rbd_ros.bag.recording import open_bag
from ros_probe import Probe

INVALID = [
    ({'mass_kg': -1.0}, 'mass_kg', '-1.0', 'must be > 0'),
    ({'inertia': [1.0, 2.0, 3.0, 0.0, 0.0, 5.0]}, 'inertia', '[1.0, 2.0, 3.0, 0.0, 0.0, 5.0]',
     'positive definite'),
    # The value with its unit (was a start of its own: test_inertia_error_names_the_unit).
    ({'inertia': [1.0, 1.0, 3.0, 0.0, 0.0, 0.0]}, 'inertia',
     '[1.0, 1.0, 3.0, 0.0, 0.0, 0.0] kg·m²', 'triangle inequality'),
    ({'integrator': 'euler'}, 'integrator', "'euler'", 'must be one of'),
    ({'timestep_s': 0.0}, 'timestep_s', '0.0 s', 'must be > 0'),
    ({'timestep_s': -0.001}, 'timestep_s', '-0.001 s', 'must be > 0'),
    ({'inertia': [0.1, 0.1, 0.1, 0.0, 0.0, 0.0], 'shape': 'sphere', 'dimensions_m': [0.1]},
     'inertia', 'shape', 'not both'),
    ({'initial_orientation': [0.0, 0.0, 0.0, 2.0]}, 'initial_orientation',
     '[0.0, 0.0, 0.0, 2.0]', 'norm'),
]


@pytest.mark.parametrize('params, name, value, rule', INVALID,
                         ids=[f'{case[1]}-{i}' for i, case in enumerate(INVALID)])
def test_invalid_parameters_stop_the_node_with_one_clear_line(
        start_node, params, name, value, rule):
    node = start_node(params)
    assert node.wait(60) == 2
    lines = [line for line in node.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, lines
    line = lines[0]
    assert line.startswith(f'rigid_body_node: parameter {name}'), line
    assert value in line and rule in line, line


def test_duration_exits_0_and_records_a_finalised_bag(start_node, tmp_path):
    bag = tmp_path / 'run'
    node = start_node({'duration_s': 0.3, 'record_path': str(bag), 'publish_rate_hz': 100.0},
                      namespace=True)
    assert node.wait(60) == 0, node.stderr
    recording = open_bag(bag)
    assert recording.finalised, recording.notes
    # Samples at t = 0, 10, ..., 300 ms: the schedule is a function of sim time only.
    times = [m.log_time_ns for m in recording.messages([node.namespace + '/pose'])]
    assert times == [i * 10_000_000 for i in range(31)]
    assert recording.end_ns == 300_000_000
    assert recording.config['duration_s'] == 0.3


@pytest.mark.parametrize('sig', [signal.SIGINT, signal.SIGTERM], ids=['SIGINT', 'SIGTERM'])
def test_signals_shut_down_cleanly_and_finalise_the_recording(start_node, tmp_path, sig):
    bag = tmp_path / 'run'
    node = start_node({'record_path': str(bag)}, namespace=True)
    probe = Probe(node.namespace)
    try:
        probe.wait_connected(services=False)
        probe.wait(lambda: probe.samples['pose'] and max(probe.samples['pose']) > 0,
                   what='the node to run')
    finally:
        probe.close()
    assert node.stop(sig) == 0, node.stderr
    assert open_bag(bag).finalised


def test_existing_record_path_is_refused_with_status_2(start_node, tmp_path):
    bag = tmp_path / 'run'
    first = start_node({'duration_s': 0.01, 'record_path': str(bag)})
    assert first.wait(60) == 0, first.stderr
    second = start_node({'duration_s': 0.01, 'record_path': str(bag)})
    assert second.wait(60) == 2
    assert 'already exists' in second.stderr


def test_clock_namespace_and_diagnostics(start_node):
    ns = f'/robot_{os.getpid()}'
    node = start_node({'publish_clock': True, 'real_time_factor': 1.0}, namespace=ns)
    probe = Probe(node.namespace)
    try:
        # Relative names: everything lives under the namespace.
        probe.wait(lambda: probe.node.count_publishers(f'{ns}/pose') == 1
                   and probe.node.count_subscribers(f'{ns}/wrench') == 1
                   and probe.node.count_publishers('/clock') == 1,
                   what=f'{ns}/pose, {ns}/wrench and /clock')
        assert probe.node.count_publishers('/pose') == 0
        services = dict(probe.node.get_service_names_and_types())
        for name in ('reset', 'pause', 'step'):
            assert f'{ns}/rigid_body_node/{name}' in services
        # /clock carries the sim time of the samples.
        probe.wait(lambda: len(probe.samples['clock']) >= 3, what='/clock samples')
        assert all(stamp % 10_000_000 == 0 for stamp in probe.samples['clock'])
        values = probe.diagnostic_values()
        for key in ('sim_time_s', 'real_time_factor', 'steps_taken', 'wrenches_received',
                    'wrenches_rejected', 'kinetic_energy_j', 'angular_momentum_norm_nms'):
            assert key in values
        assert float(values['kinetic_energy_j']) == 0.0
    finally:
        probe.close()


@pytest.mark.parametrize('factor', [1.0, 3.0])
def test_wall_clock_pacing(start_node, factor):
    # Sim time over wall time between the first and the last pose received in ~2 s of wall
    # time. The node paces against an absolute wall anchor, so the only error is the delivery
    # jitter of the two samples (ms on an idle machine, tens of ms on the shared 2-core CI
    # machine): 0.1 s on ~2 s allows that and still fails a wrong factor or an accumulating
    # pacing error of more than 5 %. (The 60 s figure is in tests/benchmarks/bench_node.py.)
    # Never ahead of the wall clock. Behind it only as far as the node says: a CI run with two
    # test workers and the kernel warm-up (three busy processes on two cores) once left a 3x
    # node 0.6 s short in 2 s; the node then reports its lag (/diagnostics' pacing_lag_max_ms)
    # or that it dropped wall time (its warning), and the shortfall must be within that. Each
    # end of a window is its promptest sample (ENDS_S), and a window short by more is
    # measured again (WINDOWS).
    node = start_node({'real_time_factor': factor, 'publish_rate_hz': 100.0}, namespace=True)
    probe = Probe(node.namespace, outputs=('pose', 'diagnostics'))
    try:
        probe.wait_connected(services=False)
        probe.wait(lambda: len(probe.arrivals) >= 2, what='pose samples')
        # Let any backlog of samples queued before we were spinning drain for 0.5 s first.
        start = time.monotonic_ns()
        wait_until(lambda: time.monotonic_ns() - start > 500_000_000, 10, probe.spin)
        for window in range(WINDOWS):
            short_s, lag_s = _pacing_window(probe, factor)
            assert short_s >= -0.1 * factor, (window, short_s)   # never ahead, in any window
            if short_s <= 0.1 * factor:
                break
    finally:
        probe.close()
    # Behind in every window: only as far as the node said.
    assert short_s <= lag_s + 0.1 * factor or 'falling behind the wall clock' in node.stderr, \
        (short_s, lag_s)


#: Windows of ~2 s the pacing test may take, and the part of each window's start and end in
#: which the promptest sample is taken (s). A late sample makes the node look behind (a CI
#: run's probe: 1.06 s of sim short at 3x while the node's own lag stayed 0.1 s), and a late
#: first sample ahead. Each sample's lateness is its arrival time minus its sim stamp over the
#: factor, plus a constant; the least of it over ~50 samples at each end is within a few ms of
#: that constant unless every one of them was late. A wrong factor or an accumulating error is
#: short in every window; a starved probe is not.
WINDOWS = 3
ENDS_S = 0.5


def _pacing_window(probe, factor):
    """Return (sim seconds short of factor x wall, the node's largest reported lag in s)."""
    start = len(probe.arrivals)
    probe.diagnostics.clear()
    began = time.monotonic_ns()
    wait_until(lambda: time.monotonic_ns() - began > 2_500_000_000, 10, probe.spin)
    window = probe.arrivals[start:]
    seen = len(probe.diagnostics)  # one more: the lag up to the window's end
    probe.wait(lambda: len(probe.diagnostics) > seen, 10.0, 'a /diagnostics after the window')
    first_ns, last_ns = window[0][0], window[-1][0]
    ends_ns = ENDS_S * 1e9

    def least_lateness(samples):  # in sim seconds: factor x arrival - stamp
        return min(factor * wall_ns * 1e-9 - sim_ns * 1e-9 for wall_ns, sim_ns in samples)
    head = [a for a in window if a[0] - first_ns <= ends_ns]
    tail = [a for a in window if last_ns - a[0] <= ends_ns]
    short_s = least_lateness(tail) - least_lateness(head)
    lag_s = max([float(kv.value) * 1e-3 for m in probe.diagnostics for status in m.status
                 for kv in status.values if kv.key == 'pacing_lag_max_ms'], default=0.0)
    print(f'pacing at {factor}x: {len(window)} samples in {(last_ns - first_ns) * 1e-9:.3f} s '
          f"of wall, short by {short_s:.3f} s of sim, the node's largest lag {lag_s:.3f} s")
    return short_s, lag_s
