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

"""WrenchInputs and SimSession (no ROS): frames, limits, hold, expiry, schedule, determinism."""

import math
import pathlib

import numpy as np
import pytest
from rbd_ros.core import AppliedWrench, BodyState, ConvergenceError, Simulator
from rbd_ros.sim.config import NodeConfig
from rbd_ros.sim.inputs import WrenchRejected
from rbd_ros.sim.session import SimSession
import yaml

H_NS = 1_000_000


def session(**params):
    s = SimSession(NodeConfig.from_parameters(params))
    s.paused = False
    return s


def run_until(s, t_ns):
    samples = []
    while s.time_ns < t_ns:
        report = s.advance(10_000, until_ns=t_ns)
        if report.sample_due:
            samples.append(s.time_ns)
    return samples


@pytest.mark.parametrize('frame_id, default, expected', [
    ('base_link', 'world', 'body'), ('world', 'body', 'world'), ('', 'world', 'world'),
    ('', 'body', 'body')])
def test_frame_resolution(frame_id, default, expected):
    s = session(default_wrench_frame=default)
    wrench = s.submit('wrench', frame_id, (1.0, 2.0, 3.0), (0.0, 0.0, 0.5))
    assert wrench.frame == expected
    assert np.array_equal(wrench.point_b, [0.0, 0.0, 0.0])


@pytest.mark.parametrize('frame_id, force, torque, reason', [
    ('odom', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0), 'frame'),
    ('world', (math.nan, 0.0, 0.0), (0.0, 0.0, 0.0), 'non_finite'),
    ('world', (0.0, 0.0, 0.0), (0.0, -math.inf, 0.0), 'non_finite'),
    ('world', (0.0, 0.0, 0.0), (0.0, 0.0), 'non_finite'),
    ('world', (6.0, 8.0, 0.0), (0.0, 0.0, 0.0), 'force_limit'),  # |f| = 10 > 9.9
    ('world', (0.0, 0.0, 0.0), (0.0, 3.0, 4.0), 'torque_limit'),  # |τ| = 5 > 4.9
])
def test_rejections_are_counted_by_reason_and_change_nothing(frame_id, force, torque, reason):
    s = session(max_force_n=9.9, max_torque_nm=4.9)
    with pytest.raises(WrenchRejected) as info:
        s.submit('wrench', frame_id, force, torque)
    assert info.value.reason == reason
    assert s.inputs.rejected[reason] == 1 and s.inputs.rejected_total == 1
    assert s.inputs.received_total == 1 and not s.inputs.has_pending
    s.advance(10)
    assert np.array_equal(s.state.linear_velocity_w, [0.0, 0.0, 0.0])


@pytest.mark.parametrize('max_force_n, max_torque_nm', [(10.0, 5.0), (9.9, 4.9), (1e-3, 3e-3)])
def test_limits_are_inclusive(max_force_n, max_torque_nm):
    s = session(max_force_n=max_force_n, max_torque_nm=max_torque_nm)
    # |(0, -f, 0)| is f exactly, so these are exactly at the limits: accepted, and applied.
    force, torque = (0.0, -max_force_n, 0.0), (0.0, 0.0, max_torque_nm)
    wrench = s.submit('wrench', 'world', force, torque)
    assert np.array_equal(wrench.force, force) and np.array_equal(wrench.torque, torque)
    assert s.inputs.rejected_total == 0 and s.inputs.has_pending
    s.advance(1)
    assert s.inputs.held['wrench'][1].force[1] == -max_force_n   # (t_effect_ns, wrench)
    assert s.state.linear_velocity_w[1] < 0.0   # it pushed (m = 1 kg, one step)
    # The next float beyond either limit is refused, by the reason of that limit.
    for reason, force, torque in (
            ('force_limit', (0.0, -np.nextafter(max_force_n, np.inf), 0.0), (0.0, 0.0, 0.0)),
            ('torque_limit', (0.0, 0.0, 0.0), (0.0, 0.0, np.nextafter(max_torque_nm, np.inf)))):
        with pytest.raises(WrenchRejected) as info:
            s.submit('wrench', 'world', force, torque)
        assert info.value.reason == reason
        assert s.inputs.rejected[reason] == 1
    assert s.inputs.rejected_total == 2 and s.inputs.received_total == 3
    # (6, 8, 0) has the norm 10 exactly in floating point too: on the limit, accepted.
    s = session(max_force_n=10.0, max_torque_nm=5.0)
    s.submit('wrench', 'world', (6.0, 8.0, 0.0), (0.0, 3.0, 4.0))
    assert s.inputs.rejected_total == 0 and s.inputs.has_pending


def test_unknown_input_is_rejected():
    with pytest.raises(WrenchRejected) as info:
        session().submit('nope', 'world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    assert info.value.reason == 'unknown_input'


def test_a_wrench_takes_effect_at_the_start_of_the_next_step_and_is_reported_there():
    s = session(publish_rate_hz=1000.0)
    run_until(s, 3 * H_NS)
    s.submit('wrench', 'world', (2.0, 0.0, 0.0), (0.0, 0.0, 0.0), tag='msg')
    report = s.advance(1)
    assert [(e.time_ns, e.input_name, e.frame_id, e.tag) for e in report.events] == [
        (3 * H_NS, 'wrench', 'world', 'msg')]
    assert s.state.linear_velocity_w[0] == 2.0 * 1e-3  # one step of F h / m, m = 1 kg


def test_a_later_wrench_before_the_step_replaces_the_pending_one():
    s = session()
    s.submit('wrench', 'world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    s.submit('wrench', 'world', (0.0, 1.0, 0.0), (0.0, 0.0, 0.0))
    report = s.advance(1)
    assert len(report.events) == 1 and report.events[0].force == (0.0, 1.0, 0.0)
    assert s.state.linear_velocity_w[0] == 0.0


def test_zero_order_hold_until_replaced_and_inputs_add_up():
    s = session(wrench_input_names=['left'], **{'wrench_inputs.left.point_b': [0.0, 0.5, 0.0]})
    s.submit('wrench', 'world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    s.submit('left', '', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # body frame, at (0, 0.5, 0)
    run_until(s, 100 * H_NS)
    held = s.inputs.held
    assert set(held) == {'wrench', 'left'}
    # Same loads in a bare core simulator give the same state bit for bit.
    c = s.config
    sim = Simulator(c.model, c.initial_state, integrator=c.integrator, timestep_ns=H_NS)
    sim.set_loads([AppliedWrench((1.0, 0.0, 0.0), frame='world'),
                   AppliedWrench((1.0, 0.0, 0.0), frame='body', point_b=(0.0, 0.5, 0.0))])
    sim.step(100)
    assert sim.state == s.state
    # r × f = (0, 0.5, 0) × (1, 0, 0) = (0, 0, -0.5): it spins clockwise about z.
    assert s.state.angular_velocity_b[2] < 0.0


def test_hold_timeout_expires_at_the_exact_step_in_sim_time():
    s = session(wrench_timeout_s=0.0035, publish_rate_hz=1000.0)  # 3.5 steps: 4 steps act
    s.submit('wrench', 'world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    velocities = []
    for _ in range(8):
        s.advance(1)
        velocities.append(s.state.linear_velocity_w[0])
    assert velocities == pytest.approx([1e-3, 2e-3, 3e-3, 4e-3, 4e-3, 4e-3, 4e-3, 4e-3],
                                       abs=1e-15)
    assert s.inputs.held == {}


def test_sample_schedule_is_a_function_of_sim_time_only():
    a = session(publish_rate_hz=300.0, timestep_s=0.001)  # period 3333333 ns
    samples_a = run_until(a, 100 * H_NS)
    b = session(publish_rate_hz=300.0, timestep_s=0.001)
    samples_b = []
    while b.time_ns < 100 * H_NS:  # one step per call
        if b.advance(1).sample_due:
            samples_b.append(b.time_ns)
    assert samples_a == samples_b
    period = a.config.publish_period_ns
    # Exactly one sample per period: the first step end at or after each multiple of P.
    expected = [-(-k * period // H_NS) * H_NS for k in range(1, 100 * H_NS // period + 1)]
    assert samples_a == expected
    assert a.sample_due(0)


def test_duration_stops_advance_exactly():
    s = session(duration_s=0.0105)
    while not s.finished:
        assert s.advance(10_000).steps > 0
    assert s.finished and s.time_ns == 11 * H_NS
    assert s.advance(5).steps == 0


def test_pause_stops_advance_but_not_step():
    s = session()
    s.paused = True
    assert s.advance(10).steps == 0 and s.time_ns == 0
    assert s.step().steps == 1 and s.time_ns == H_NS


def test_reset_returns_to_the_initial_state_and_drops_wrenches():
    s = session(initial_position=[1.0, 2.0, 3.0])
    s.submit('wrench', 'world', (1.0, 0.0, 0.0), (0.0, 0.0, 0.0))
    s.advance(50)
    s.submit('wrench', 'world', (0.0, 1.0, 0.0), (0.0, 0.0, 0.0))
    s.reset()
    assert s.time_ns == 0 and s.state == s.config.initial_state
    s.advance(10)
    assert np.array_equal(s.state.linear_velocity_w, [0.0, 0.0, 0.0])


def test_same_wrenches_at_the_same_steps_give_bit_identical_states_whatever_the_chunking():
    rng = np.random.default_rng(7)
    events = sorted((int(rng.integers(0, 2000)) * H_NS, tuple(rng.normal(size=3)),
                     tuple(rng.normal(size=3) * 0.01), str(rng.choice(['world', 'base_link'])))
                    for _ in range(30))
    params = dict(initial_angular_velocity=[0.3, 5.0, 0.1], wrench_timeout_s=0.05,
                  wrench_input_names=['t'], **{'wrench_inputs.t.point_b': [0.1, 0.0, 0.0]})

    def run(max_steps):
        s = session(**params)
        states = []
        for i, (t, force, torque, frame) in enumerate(events):
            while s.time_ns < t:
                if s.advance(max_steps, until_ns=t).sample_due:
                    states.append(s.state)
            s.submit('t' if i % 2 else 'wrench', frame, force, torque)
        while s.time_ns < 2500 * H_NS:
            if s.advance(max_steps, until_ns=2500 * H_NS).sample_due:
                states.append(s.state)
        return states

    one, many = run(1), run(100_000)
    assert len(one) == len(many) == 250  # 10 ms .. 2.5 s
    assert all(a == b for a, b in zip(one, many))
    assert isinstance(one[-1], BodyState) and one[-1].time_ns == 2500 * H_NS


def test_through_samples_takes_the_same_steps_to_the_same_bits_and_ends_at_a_sample():
    # What the node does while nobody listens: no stop at the sample times between, so the
    # steps go in longer compiled calls. The stack (contact, 4 bodies, resting and sliding) at
    # every 10th sample must be bit for bit the stack stepped sample by sample, the wrench
    # timeout still cut where it falls, and the duration end there as a due sample.
    def run(through):
        s = _stack_session(duration_s=0.4055, wrench_timeout_s=0.0333, publish_rate_hz=100.0)
        s.submit('striker/wrench', 'world', (30.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        ends = []
        while not s.finished:
            report = s.advance(100 if through else 10, through_samples=through)
            ends.append((s.time_ns, report.steps, report.sample_due))
        return s, ends
    (by_sample, ends_a), (through, ends_b) = run(False), run(True)
    for i in range(4):
        assert by_sample.body_state(i) == through.body_state(i)
    assert np.array_equal(by_sample.contact_wrenches_w, through.contact_wrenches_w)
    assert all(due for _, _, due in ends_a[:-1])  # each call stopped at its sample
    # 100 steps a call (the compiled calls inside cut at the timeout, 34 ms: the states
    # above), each ending at a sample; the last at the duration (406 ms, the step end at or
    # past 405.5 ms: no sample there).
    assert [(t // H_NS, steps) for t, steps, _ in ends_b] == [
        (100, 100), (200, 100), (300, 100), (400, 100), (406, 6)]
    assert [due for _, _, due in ends_b] == [True, True, True, True, False]


def test_non_finite_step_pauses_the_session_with_a_message():
    # Inputs are bounded by max_force_n, but the model may still overflow: g = 1e308 m/s².
    s = session(gravity=[1e308, 0.0, 0.0], timestep_s=1.0)
    with pytest.raises(Exception) as info:
        for _ in range(10):
            s.advance(1)
    assert type(info.value).__name__ == 'NonFiniteError'
    assert s.paused and s.error
    state = s.state
    parts = (state.position_w, state.orientation_wb, state.linear_velocity_w,
             state.angular_velocity_b)
    assert all(np.isfinite(v).all() for v in parts)


def test_a_too_large_step_for_the_spin_pauses_the_session_and_names_h_omega():
    # The T-handle spun at 10 rad/s with 1 s steps: h|ω| ≈ 10 rad, beyond what the implicit
    # midpoint solve of the default integrator converges for. The step is refused, the session
    # pauses, and its error (what /diagnostics and the log show) says why and what to change.
    s = session(inertia=[0.0010, 0.0030, 0.0038, 0.0, 0.0, 0.0], timestep_s=1.0,
                initial_angular_velocity=[0.1, 10.0, 0.2])
    with pytest.raises(ConvergenceError):
        s.advance(1)
    assert s.paused and s.time_ns == 0
    assert 'did not converge' in s.error and 'h|ω| = 10 rad' in s.error
    assert 'smaller timestep_s' in s.error
    assert np.array_equal(s.state.angular_velocity_b, [0.1, 10.0, 0.2])


def test_a_wrench_whose_step_would_be_non_finite_is_released_and_the_step_taken_without_it():
    # Isotropic inertia 1e-300 kg m^2: 1e6 N m (within max_torque_nm) gives |ω| ~ 1e303 rad/s
    # in one step, so the first step with the wrench would be non-finite.
    params = {'inertia': [1e-300, 1e-300, 1e-300, 0.0, 0.0, 0.0]}
    s, undisturbed = session(**params), session(**params)
    s.advance(5)
    s.submit('wrench', 'world', (0.0, 0.0, 0.0), (1e6, 0.0, 0.0))
    run_until(s, 15 * H_NS)
    assert s.time_ns == 15 * H_NS and not s.paused and s.error is None
    assert s.inputs.rejected['non_finite_step'] == 1 and s.inputs.rejected_total == 1
    assert s.inputs.body_loads(0) == ()
    (line,) = s.pop_releases()
    assert line.startswith(f'wrench: released at t = {5 * H_NS} ns') and 'would be' in line
    assert s.pop_releases() == []
    # Released before any step took it: the run is the undisturbed one, bit for bit.
    run_until(undisturbed, 15 * H_NS)
    assert s.state == undisturbed.state


def _stack_session(**overrides):
    path = pathlib.Path(__file__).resolve().parents[2] / 'msg_config' / 'stack.yaml'
    params = yaml.safe_load(path.read_text())['/**']['ros__parameters']
    return session(**{**params, **overrides})


def test_a_drag_released_inside_a_chunk_gives_the_states_of_one_step_at_a_time():
    # A 1e12 N/m drag on the 2 kg striker grows ~(h ω)² = 5e5 a step until the step at ~53 ms
    # would overflow: inside a chunk of many steps. The release and the retry must give what
    # stepping one at a time gives, bit for bit (replay steps in other chunks than the node).
    def run(max_steps):
        s = _stack_session(drag_stiffness_n_per_m=1e12)
        s.submit_point('striker/drag', 'world', (-0.8 + 1e-7, 0.0, 0.1))
        while s.time_ns < 200 * H_NS:
            s.advance(max_steps, until_ns=200 * H_NS)
        return s
    one, many = run(1), run(100_000)
    assert one.drags.rejected['non_finite_step'] == many.drags.rejected['non_finite_step'] == 1
    assert one.pop_releases() == many.pop_releases() != []
    assert not one.paused and not many.paused
    for i in range(4):
        assert one.body_state(i) == many.body_state(i)
        assert np.isfinite(one.body_state(i).linear_velocity_w).all()
