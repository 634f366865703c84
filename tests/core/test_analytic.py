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
Analytic references for the integrators of :mod:`rbd_ros.core`.

Where an integrator's discrete map has a closed form (symplectic Euler under a constant force,
any update of a rotation about a fixed principal axis, the linear precession of a symmetric
top) the test checks that exact discrete formula to round-off; the continuum solution is then
checked with a tolerance from the method's known truncation error.

Round-off bound used throughout: a run of ``n`` steps performs a bounded number ``c`` of
roundings (each <= ``EPS`` = 1.1e-16 relative) per step on every state component, so the
accumulated relative error is <= ``c n EPS``. ``round_off(n)`` takes ``c = 20`` (more than the
roundings of one step touching one component: a few products and sums), i.e. a bound that a
wrong coefficient or sign (errors of order 1e-3 or more here) cannot meet.
"""

import math

import numpy as np
import pytest

from rbd_ros.core import (AppliedWrench, BodyModel, BodyState, INTEGRATORS, net_wrench_w,
                          Simulator, Spring)
from rbd_ros.core.inertia import point_masses
from rbd_ros.core.layout import S_OMEGA, S_POS, S_VEL
from rbd_ros.core.rotations import (quat_conjugate, quat_from_axis_angle, quat_log,
                                    quat_multiply, quat_rotate, quat_to_matrix)

EPS = np.finfo(float).eps / 2.0
SE_NAMES = [name for name in INTEGRATORS if name.startswith('symplectic_euler')]
# Integrators whose force/velocity update is exact for a constant force (continuum formula).
EXACT_CONSTANT_FORCE = ['midpoint_cayley', 'rk4']
INERTIA_B = np.diag([0.1, 0.2, 0.25])


def round_off(n_steps, c=20):
    """Relative round-off bound after ``n_steps`` steps (see the module docstring)."""
    return c * max(n_steps, 1) * EPS


def test_every_integrator_is_classified():
    assert set(SE_NAMES) | set(EXACT_CONSTANT_FORCE) == set(INTEGRATORS)
    assert len(SE_NAMES) == 4


# --- constant force and free fall ------------------------------------------------------------

def _constant_force_run(integrator, v0, dt_ns=1_000_000, n=1000):
    model = BodyModel(2.0, INERTIA_B, gravity_w=(0.0, 0.0, -9.81))
    p0 = np.array([0.5, -1.0, 3.0])
    force_w = np.array([3.0, -1.0, 2.0])
    sim = Simulator(model, BodyState(position_w=p0, linear_velocity_w=v0,
                                     orientation_wb=quat_from_axis_angle((1, 1, 0), 0.4)),
                    integrator=integrator, timestep_ns=dt_ns)
    sim.set_loads([AppliedWrench(force=force_w, frame='world')])
    sim.step(n)
    accel = model.gravity_w + force_w / model.mass_kg
    return sim.state, p0, np.asarray(v0, dtype=float), accel, dt_ns * 1e-9, n


@pytest.mark.parametrize('v0', [(0.0, 0.0, 0.0), (1.0, 2.0, -0.5)], ids=['rest', 'v0'])
@pytest.mark.parametrize('integrator', SE_NAMES)
def test_constant_force_symplectic_euler_exact_discrete(integrator, v0):
    state, p0, v0, a, h, n = _constant_force_run(integrator, v0)
    t = n * h
    # v ← v + h a; p ← p + h v_new  =>  p_n = p0 + v0 t + a h² n(n+1)/2 exactly.
    p_discrete = p0 + v0 * t + a * h * h * n * (n + 1) / 2.0
    scale = np.abs(p_discrete).max() + np.abs(v0).max() * t + np.abs(a).max() * t * t
    assert np.allclose(state.position_w, p_discrete, rtol=0.0, atol=round_off(n) * scale)
    assert np.allclose(state.linear_velocity_w, v0 + a * t, rtol=0.0,
                       atol=round_off(n) * (np.abs(v0).max() + np.abs(a).max() * t))
    # The known O(h) position error of SE against the continuum: exactly a h t / 2.
    p_continuum = p0 + v0 * t + 0.5 * a * t * t
    assert np.allclose(state.position_w - p_continuum, 0.5 * a * h * t, rtol=1e-9, atol=1e-12)
    # No torque, no spin: the orientation is untouched.
    assert np.array_equal(state.angular_velocity_b, np.zeros(3))


@pytest.mark.parametrize('v0', [(0.0, 0.0, 0.0), (1.0, 2.0, -0.5)], ids=['rest', 'v0'])
@pytest.mark.parametrize('integrator', EXACT_CONSTANT_FORCE)
def test_constant_force_exact_continuum(integrator, v0):
    # Kick–drift–kick and RK4 are both exact for a quadratic p(t): only round-off remains.
    state, p0, v0, a, h, n = _constant_force_run(integrator, v0)
    t = n * h
    p_continuum = p0 + v0 * t + 0.5 * a * t * t
    scale = np.abs(p_continuum).max() + np.abs(v0).max() * t + np.abs(a).max() * t * t
    assert np.allclose(state.position_w, p_continuum, rtol=0.0, atol=round_off(n) * scale)
    assert np.allclose(state.linear_velocity_w, v0 + a * t, rtol=0.0,
                       atol=round_off(n) * (np.abs(v0).max() + np.abs(a).max() * t))


# --- spin-up about a principal axis ----------------------------------------------------------

def _discrete_angle(integrator, alpha, h, n):
    """Exact rotation angle of each integrator's discrete map for ω(t) spun up by ``alpha``."""
    k = np.arange(n, dtype=float)
    if integrator in ('symplectic_euler_quat_exp', 'symplectic_euler_axis_angle'):
        # ω updated first, then an exact rotation by h ω_{k+1}.
        return float(np.sum(h * alpha * h * (k + 1)))
    if integrator == 'symplectic_euler_quat_linear':
        # normalise(q + h/2 q ⊗ (0, ω)) turns the half angle by atan(h ω / 2).
        return float(np.sum(2.0 * np.arctan(0.5 * h * alpha * h * (k + 1))))
    if integrator == 'symplectic_euler_matrix':
        # Gram–Schmidt of (𝟙 + h[ω])R turns the first column by atan(h ω).
        return float(np.sum(np.arctan(h * alpha * h * (k + 1))))
    if integrator == 'midpoint_cayley':
        # Half kick, Cayley rotation by 2 atan(h ω_mid / 2) with ω_mid = α h (k + ½), half kick.
        return float(np.sum(2.0 * np.arctan(0.5 * h * alpha * h * (k + 0.5))))
    return 0.5 * alpha * (n * h) ** 2   # rk4: compared with the continuum below


@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_spin_up_about_principal_axis(integrator):
    torque_b = 0.5
    inertia_y = INERTIA_B[1, 1]
    alpha = torque_b / inertia_y
    q0 = quat_from_axis_angle((0.3, -1.0, 2.0), 1.1)
    dt_ns, n = 1_000_000, 1000
    h = dt_ns * 1e-9
    sim = Simulator(BodyModel(1.5, INERTIA_B), BodyState(orientation_wb=q0),
                    integrator=integrator, timestep_ns=dt_ns)
    sim.set_loads([AppliedWrench(torque=(0.0, torque_b, 0.0), frame='body')])
    sim.step(n)
    t = n * h
    state = sim.state
    # ω = τ t / I for every integrator (constant ω̇, no gyroscopic term about a principal axis).
    assert np.allclose(state.angular_velocity_b, (0.0, alpha * t, 0.0), rtol=0.0,
                       atol=round_off(n) * alpha * t)
    rotvec = quat_log(quat_multiply(quat_conjugate(q0), state.orientation_wb))
    angle_continuum = 0.5 * alpha * t * t
    angle_discrete = _discrete_angle(integrator, alpha, h, n)
    # The discrete closed form to round-off (angle magnitude ~1.25 rad).
    atol = round_off(n) * angle_continuum
    if integrator == 'rk4':
        # RK4 on q̇ = ½ q ⊗ (0, ω(t)): global error O(h⁴); with h ω ≤ 2.5e-3 the bound
        # t ω (h ω)⁴ / 120 is ~1e-13 rad; 1e-11 rad leaves round-off room.
        atol = 1e-11
    assert np.allclose(rotvec, (0.0, angle_discrete, 0.0), rtol=0.0, atol=atol)
    # Against the continuum: first/second-order methods differ by at most the per-step
    # truncation of atan, n (h ω_max)³ / 3 ≤ 1000 · (2.5e-3)³ / 3 = 5.2e-6 rad, and SE's O(h)
    # lag of ½ α h t = 1.25e-3 rad.
    assert abs(rotvec[1] - angle_continuum) <= 0.5 * alpha * h * t + 5.3e-6
    if integrator in EXACT_CONSTANT_FORCE:
        # Second order and better: no O(h) lag; the Cayley map's cubic truncation only.
        assert abs(rotvec[1] - angle_continuum) <= 5.3e-6


# --- torque-free symmetric top ---------------------------------------------------------------

def _top_rate_per_step(integrator, h, rate):
    """Phase advance and growth factor of (ω1, ω2) per step, from each discrete map."""
    if integrator in SE_NAMES:
        # Explicit Euler on a rotation at rate Ω: (1 + i h Ω).
        z = 1.0 + 1j * h * rate
    elif integrator == 'midpoint_cayley':
        # Implicit midpoint on a linear rotation is its Cayley transform: unit modulus.
        z = (1.0 + 0.5j * h * rate) / (1.0 - 0.5j * h * rate)
    else:
        # RK4's stability polynomial at i h Ω.
        x = 1j * h * rate
        z = 1.0 + x + x * x / 2.0 + x ** 3 / 6.0 + x ** 4 / 24.0
    return np.angle(z), abs(z)


@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_symmetric_top_precession(integrator):
    i1, i3 = 1.0, 1.5
    omega_perp, omega_3 = 2.0, 10.0
    rate = (i3 - i1) / i1 * omega_3   # Ω = 5 rad/s
    dt_ns, n = 1_000_000, 2000
    h = dt_ns * 1e-9
    model = BodyModel(3.0, np.diag([i1, i1, i3]))
    sim = Simulator(model, BodyState(angular_velocity_b=(omega_perp, 0.0, omega_3),
                                     orientation_wb=quat_from_axis_angle((1, 0, 1), 0.3)),
                    integrator=integrator, timestep_ns=dt_ns)
    sim.step(n)
    omega_b = sim.state.angular_velocity_b
    # ω3 is constant: the gyroscopic term (I1 − I2) ω1 ω2 / I3 is exactly 0.
    assert omega_b[2] == omega_3
    phase_step, growth = _top_rate_per_step(integrator, h, rate)
    phase = n * phase_step
    amplitude = omega_perp * growth ** n
    expected = amplitude * np.array([math.cos(phase), math.sin(phase)])
    # The exact discrete precession, to round-off.
    assert np.allclose(omega_b[:2], expected, rtol=0.0, atol=round_off(n) * omega_3)
    # Against the analytic Ω t = 10 rad: the phase error per step is (h Ω)³ / 3 for SE
    # (atan's alternating series), (h Ω)³ / 12 for the Cayley map, (h Ω)⁵ / 120 for RK4
    # (bounded with /100 below, 20 % margin); times n steps.
    measured = math.atan2(omega_b[1], omega_b[0])
    error = abs((measured - rate * n * h + math.pi) % (2.0 * math.pi) - math.pi)
    bound = {'midpoint_cayley': n * (h * rate) ** 3 / 12.0, 'rk4': n * (h * rate) ** 5 / 100.0}
    assert error <= 1.01 * bound.get(integrator, n * (h * rate) ** 3 / 3.0) + 1e-12
    print(f'\n{integrator}: symmetric top phase error after {n * h:g} s: {error:.3e} rad')


# --- a 90° turn of the basis vectors ---------------------------------------------------------

@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_quarter_turn_about_z(integrator):
    dt_ns, n = 1_000_000, 1000
    h = dt_ns * 1e-9
    omega = 0.5 * math.pi / (n * h)
    sim = Simulator(BodyModel(1.0, INERTIA_B), BodyState(angular_velocity_b=(0.0, 0.0, omega)),
                    integrator=integrator, timestep_ns=dt_ns)
    sim.step(n)
    rotation = quat_to_matrix(sim.state.orientation_wb)
    # Per-step angle truncation: atan(hω) (matrix), 2 atan(hω/2) (linear quaternion, Cayley);
    # exact maps (exponential, Rodrigues) and RK4 (O((hω)⁵) per step) are at round-off.
    per_step = {'symplectic_euler_matrix': (h * omega) ** 3 / 3.0,
                'symplectic_euler_quat_linear': (h * omega) ** 3 / 12.0,
                'midpoint_cayley': (h * omega) ** 3 / 12.0}.get(integrator, 0.0)
    tol = 1.01 * n * per_step + round_off(n)
    assert np.allclose(rotation @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], rtol=0.0, atol=tol)
    assert np.allclose(rotation @ [0.0, 1.0, 0.0], [-1.0, 0.0, 0.0], rtol=0.0, atol=tol)
    assert np.allclose(rotation @ [0.0, 0.0, 1.0], [0.0, 0.0, 1.0], rtol=0.0, atol=tol)


# --- kinetic energy of a point-mass body -----------------------------------------------------

def test_kinetic_energy_equals_sum_over_particles():
    rng = np.random.default_rng(20260122)
    masses = rng.uniform(0.1, 2.0, size=17)
    points = rng.normal(size=(17, 3))
    props = point_masses(masses, points)
    model = BodyModel(props.mass_kg, props.inertia_b)
    state = BodyState(position_w=rng.normal(size=3), orientation_wb=rng.normal(size=4),
                      linear_velocity_w=rng.normal(size=3), angular_velocity_b=rng.normal(size=3))
    r_w = (points - props.com_b) @ quat_to_matrix(state.orientation_wb).T
    omega_w = state.angular_velocity_w()
    spin_w = np.cross(omega_w, r_w)
    particle_rot = 0.5 * np.sum(masses * np.sum(spin_w * spin_w, axis=1))
    velocity_w = state.linear_velocity_w + spin_w
    particle_total = 0.5 * np.sum(masses * np.sum(velocity_w * velocity_w, axis=1))
    # ~100 float operations on O(1) numbers per side: 1e-12 relative is ~100× round-off.
    assert state.kinetic_energy_rotational(model) == pytest.approx(particle_rot, rel=1e-12)
    # Σ m r = 0 about the COM, so the cross term vanishes and KE splits exactly.
    assert state.kinetic_energy(model) == pytest.approx(particle_total, rel=1e-12)
    particle_l = np.sum(masses[:, None] * np.cross(r_w, spin_w), axis=0)
    assert np.allclose(state.angular_momentum_w(model), particle_l, rtol=0.0,
                       atol=1e-12 * np.abs(particle_l).max())


# --- loads: body-frame force, offset point, gravity ------------------------------------------

@pytest.mark.parametrize('integrator', EXACT_CONSTANT_FORCE)
def test_body_frame_force_moves_along_rotated_axis(integrator):
    q = quat_from_axis_angle((0.0, 0.0, 1.0), 0.5 * math.pi)   # body x → world y
    model = BodyModel(2.0, INERTIA_B)
    force_b = np.array([4.0, 0.0, 0.0])
    sim = Simulator(model, BodyState(orientation_wb=q), integrator=integrator)
    sim.set_loads([AppliedWrench(force=force_b, frame='body')])
    n = 500
    sim.step(n)
    t = n * 1e-3
    expected = 0.5 * quat_rotate(q, force_b) / model.mass_kg * t * t
    assert expected[1] > 0.0 and abs(expected[0]) < 1e-15   # it is the world y axis
    assert np.allclose(sim.state.position_w, expected, rtol=0.0, atol=round_off(n))


def test_offset_force_gives_r_cross_f_and_spins_that_way():
    model = BodyModel(1.0, INERTIA_B)
    q = quat_from_axis_angle((1.0, 2.0, -1.0), 0.8)
    state = BodyState(orientation_wb=q)
    point_b = np.array([1.0, 0.0, 0.0])
    force_w = np.array([0.0, 1.0, 0.0])
    force, torque = net_wrench_w(model, state, [AppliedWrench(force=force_w, point_b=point_b)])
    r_w = quat_rotate(q, point_b)
    assert np.array_equal(force, force_w)
    # ~10 operations per component: 1e-15 absolute on unit numbers.
    assert np.allclose(torque, np.cross(r_w, force_w), rtol=0.0, atol=1e-15)
    # Identity orientation: x̂ × ŷ = +ẑ, so a push along +y at +x spins the body about +z.
    sim = Simulator(model, BodyState())
    sim.set_loads([AppliedWrench(force=force_w, point_b=point_b)])
    sim.step(10)
    omega_w = sim.state.angular_velocity_w()
    assert omega_w[2] > 0.0
    assert abs(omega_w[2]) > 1e3 * max(abs(omega_w[0]), abs(omega_w[1]))


@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_gravity_gives_no_torque(integrator):
    gravity_w = (0.0, 0.0, -9.81)
    with_g = BodyModel(2.0, np.diag([1.0, 2.0, 2.5]), gravity_w=gravity_w)
    without_g = BodyModel(2.0, np.diag([1.0, 2.0, 2.5]))
    state = BodyState(orientation_wb=(0.9, 0.1, -0.3, 0.2), angular_velocity_b=(1.0, 2.0, -0.5))
    force, torque = net_wrench_w(with_g, state)
    assert np.array_equal(torque, np.zeros(3))
    assert np.array_equal(force, 2.0 * np.asarray(gravity_w))
    runs = []
    for model in (with_g, without_g):
        sim = Simulator(model, state, integrator=integrator)
        sim.step(300)
        runs.append(sim.state)
    # The rotational motion does not see gravity at all: bit-identical.
    assert np.array_equal(runs[0].orientation_wb, runs[1].orientation_wb)
    assert np.array_equal(runs[0].angular_velocity_b, runs[1].angular_velocity_b)
    assert runs[0].position_w[2] < runs[1].position_w[2] - 0.4   # ½ g t² = 0.44 m at 0.3 s


# --- springs ----------------------------------------------------------------------------------

SPRING_MASS, SPRING_K, SPRING_X0 = 2.0, 50.0, 0.3   # ω0 = 5 rad/s, period 1.2566 s


def _spring_trajectory(integrator, damping, dt_ns, duration_ns=3_000_000_000):
    model = BodyModel(SPRING_MASS, INERTIA_B)
    sim = Simulator(model, BodyState(position_w=(SPRING_X0, 0.0, 0.0)), integrator=integrator,
                    timestep_ns=dt_ns)
    sim.set_loads(springs=[Spring((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), SPRING_K, damping)])
    x, _ = sim.arrays
    n = duration_ns // dt_ns
    out = np.empty(n)
    for k in range(n):
        sim.step()
        out[k] = x[S_POS, 0]
    # Stays on the line through the anchor.
    assert np.array_equal(x[S_POS + 1:S_POS + 3, 0], np.zeros(2))
    return (np.arange(1, n + 1) * dt_ns) * 1e-9, out


@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_undamped_spring_period(integrator):
    times, x = _spring_trajectory(integrator, 0.0, 1_000_000)
    crossings = np.flatnonzero((x[:-1] > 0.0) & (x[1:] <= 0.0))
    # Linear interpolation of the downward zero crossings.
    t_cross = times[crossings] + (times[crossings + 1] - times[crossings]) * (
        x[crossings] / (x[crossings] - x[crossings + 1]))
    period = np.diff(t_cross)
    assert period.size >= 1
    expected = 2.0 * math.pi * math.sqrt(SPRING_MASS / SPRING_K)
    # SE and Störmer–Verlet (kick–drift–kick) turn by θ with cos θ = 1 − (hω)²/2: period
    # error (hω)²/24 = 1e-6 relative at hω = 5e-3; interpolation at a zero crossing (no
    # curvature there) adds O((hω)³). 1e-5 is 10× that.
    assert np.allclose(period, expected, rtol=1e-5, atol=0.0)
    # Bounded amplitude: SE's invariant ellipse is tilted by O(hω).
    assert np.abs(x).max() <= SPRING_X0 * (1.0 + 5e-3)


def _damped_analytic(times, damping):
    omega0 = math.sqrt(SPRING_K / SPRING_MASS)
    gamma = damping / (2.0 * SPRING_MASS)
    omega_d = math.sqrt(omega0 ** 2 - gamma ** 2)
    return SPRING_X0 * np.exp(-gamma * times) * (
        np.cos(omega_d * times) + gamma / omega_d * np.sin(omega_d * times))


@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_damped_spring_against_analytic(integrator):
    damping = 0.4   # γ = 0.1 1/s: amplitude falls to e^{-0.3} = 0.74 over 3 s
    errors = []
    for dt_ns in (1_000_000, 500_000):
        times, x = _spring_trajectory(integrator, damping, dt_ns)
        errors.append(np.abs(x - _damped_analytic(times, damping)).max())
    order = math.log2(errors[0] / errors[1])
    print(f'\n{integrator}: damped spring max error {errors[0]:.3e} m at 1 ms, '
          f'{errors[1]:.3e} m at 0.5 ms, observed order {order:.2f}')
    if integrator == 'rk4':
        # Fourth order: t ω0 (h ω0)⁴ x0 / 120 ~ 1e-11 m at 1 ms; 1e-9 m leaves room.
        assert errors[0] <= 1e-9
        assert order >= 3.5
    else:
        # At least first order (the spring's damping force depends on the velocity, so the
        # kick–drift–kick's second kick is explicit in v), with an error constant below SE's
        # x0 ω0 (h ω0) = 7.5e-3 m.
        assert errors[0] <= SPRING_X0 * 5.0 * (1e-3 * 5.0)
        assert order >= 0.9


# --- exact exponential damping ----------------------------------------------------------------

@pytest.mark.parametrize('dt_ns', [1_000_000, 10_000_000, 125_000_000])
@pytest.mark.parametrize('integrator', INTEGRATORS)
def test_exponential_damping_is_step_size_independent(integrator, dt_ns):
    c_v, c_w = 0.7, 1.3
    model = BodyModel(1.0, np.diag([1.0, 2.0, 2.5]), linear_damping_per_s=c_v,
                      angular_damping_per_s=c_w)
    v0 = np.array([1.0, -2.0, 0.5])
    w0 = np.array([0.0, 3.0, 0.0])   # about a principal axis: no gyroscopic coupling
    sim = Simulator(model, BodyState(linear_velocity_w=v0, angular_velocity_b=w0),
                    integrator=integrator, timestep_ns=dt_ns)
    n = 2_000_000_000 // dt_ns
    x, _ = sim.arrays
    for k in range(1, n + 1):
        sim.step()
        t = k * dt_ns * 1e-9
        # Two multiplications by exp(-c h / 2) per step: 2k roundings plus exp's own ulp.
        assert np.allclose(x[S_VEL:S_VEL + 3, 0], v0 * math.exp(-c_v * t),
                           rtol=4 * k * EPS + 1e-15, atol=0.0)
        assert np.allclose(x[S_OMEGA:S_OMEGA + 3, 0], w0 * math.exp(-c_w * t),
                           rtol=4 * k * EPS + 1e-15, atol=0.0)
