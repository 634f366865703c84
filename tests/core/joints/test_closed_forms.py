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

"""The joint closed forms (``closed_forms.py``) against independent numbers."""

import math

from closed_forms import (BABYBOOT, babyboot_accelerations, babyboot_energy, cartpole_omega,
                          chain_joint_forces, compound_pendulum_l_eq, cone_rim_torque,
                          cone_stop, coulomb_pendulum_turns, coulomb_stop,
                          cradle_rise_height, damped_oscillation, damped_rotor, ellipk,
                          heavy_top_precession, limit_stop, mimic_pendulum_period,
                          pendulum_period)
import numpy as np
import pytest

DEG = math.pi / 180.0
# Closed forms evaluated in double precision: a few ulp per operation, a few dozen operations.
ROUND_OFF = 1e-14


def test_ellipk_special_values():
    assert ellipk(0.0) == pytest.approx(math.pi / 2.0, rel=ROUND_OFF)
    # K(1/2) = Gamma(1/4)^2 / (4 sqrt(pi)) (Abramowitz and Stegun 17.3.30 with m = 1/2).
    exact = math.gamma(0.25) ** 2 / (4.0 * math.sqrt(math.pi))
    assert ellipk(0.5) == pytest.approx(exact, rel=ROUND_OFF)


@pytest.mark.parametrize('m', [0.0, 0.01, 0.1, 0.3, 0.5])
def test_ellipk_power_series(m):
    # K(m) = pi/2 sum_n ((2n)! / (2^2n n!^2))^2 m^n; 400 terms leave < 0.5^400 of the sum.
    total, coef = 0.0, 1.0
    for n in range(400):
        total += coef * coef * m ** n
        coef *= (2 * n + 1) / (2 * n + 2)
    assert ellipk(m) == pytest.approx(0.5 * math.pi * total, rel=ROUND_OFF)


@pytest.mark.parametrize('bad', [-0.1, 1.0, 2.0, math.nan])
def test_ellipk_refuses_bad_parameter(bad):
    with pytest.raises(ValueError, match=r'^m: .* must be in \[0, 1\)'):
        ellipk(bad)


@pytest.mark.parametrize('theta0_deg, period_s', [
    (10.0, 2.009892627), (90.0, 2.367841948), (170.0, 4.893524274)])
def test_pendulum_period_reference_values(theta0_deg, period_s):
    # The reference's computed periods for L_eq = 1 m are given to 10 digits: 5e-10 relative.
    assert pendulum_period(1.0, theta0_deg * DEG) == pytest.approx(period_s, rel=5e-10)


@pytest.mark.parametrize('theta0_deg', [10.0, 90.0, 170.0, 179.0])
def test_pendulum_period_quadrature(theta0_deg):
    # The period integral T = 4 sqrt(L/g) int_0^{pi/2} dphi / sqrt(1 - k^2 sin^2 phi) by the
    # trapezoidal rule: the integrand is smooth, even about 0 and pi/2 and pi-periodic, so the
    # rule is spectrally accurate; 20000 panels reach round-off even at 179 deg, where the
    # integrand's nearest complex singularity is sqrt(1 - k^2) ~ 0.009 from the real axis.
    length, g = 0.7, 9.81
    k = math.sin(0.5 * theta0_deg * DEG)
    phi = np.linspace(0.0, 0.5 * math.pi, 20001)
    f = 1.0 / np.sqrt(1.0 - (k * np.sin(phi)) ** 2)
    integral = (f.sum() - 0.5 * (f[0] + f[-1])) * (phi[1] - phi[0])
    exact = 4.0 * math.sqrt(length / g) * integral
    assert pendulum_period(length, theta0_deg * DEG, g) == pytest.approx(exact, rel=1e-13)


@pytest.mark.parametrize('theta0_deg', [1.0, 5.0, 10.0])
def test_pendulum_period_small_amplitude_series(theta0_deg):
    # T = 2 pi sqrt(L/g) (1 + t^2/16 + 11 t^4/3072 + 173 t^6/737280 + 22931 t^8/1321205760);
    # the next term, 1319183 t^10 / 951268147200, is < 4e-11 at 10 deg.
    t = theta0_deg * DEG
    series = 1.0 + t ** 2 / 16 + 11 * t ** 4 / 3072 + 173 * t ** 6 / 737280 \
        + 22931 * t ** 8 / 1321205760
    exact = 2.0 * math.pi * math.sqrt(2.0 / 9.81) * series
    assert pendulum_period(2.0, t) == pytest.approx(exact, rel=5e-11)


def test_pendulum_period_from_an_ode_integration():
    # An independent route: RK4 of theta'' = -(g/L) sin theta from rest at 90 deg, until theta
    # crosses 0 (a quarter period), the crossing found by cubic Hermite interpolation. RK4's
    # error at h = 1e-4 s is ~ (h omega)^4 ~ 1e-14 per period; the interpolation ~ h^4.
    length, g, theta0 = 1.0, 9.81, 90.0 * DEG

    def f(y):
        return np.array([y[1], -g / length * math.sin(y[0])])

    h, t, y = 1e-4, 0.0, np.array([theta0, 0.0])
    while True:
        k1 = f(y)
        k2 = f(y + 0.5 * h * k1)
        k3 = f(y + 0.5 * h * k2)
        k4 = f(y + h * k3)
        y_new = y + h / 6.0 * (k1 + 2 * k2 + 2 * k3 + k4)
        if y_new[0] <= 0.0:
            break
        t, y = t + h, y_new
    # Newton on the Hermite cubic through (y, y') at both ends for theta = 0.
    p0, m0, p1, m1 = y[0], y[1] * h, y_new[0], f(y_new)[0] * h
    s = p0 / (p0 - p1)
    for _ in range(20):
        h00, h10 = 2 * s ** 3 - 3 * s ** 2 + 1, s ** 3 - 2 * s ** 2 + s
        h01, h11 = -2 * s ** 3 + 3 * s ** 2, s ** 3 - s ** 2
        value = h00 * p0 + h10 * m0 + h01 * p1 + h11 * m1
        slope = ((6 * s ** 2 - 6 * s) * p0 + (3 * s ** 2 - 4 * s + 1) * m0
                 + (-6 * s ** 2 + 6 * s) * p1 + (3 * s ** 2 - 2 * s) * m1)
        s -= value / slope
    period = 4.0 * (t + s * h)
    assert pendulum_period(length, theta0, g) == pytest.approx(period, rel=1e-10)


def test_compound_pendulum_l_eq():
    length, mass = 1.3, 2.0
    i_pivot = mass * length ** 2 / 12.0 + mass * (length / 2.0) ** 2   # parallel axes
    assert compound_pendulum_l_eq(length) == pytest.approx(
        i_pivot / (mass * length / 2.0), rel=ROUND_OFF)


def test_cartpole_omega_against_the_linearised_equations():
    # Linearised Lagrangian of (cart x, pole angle phi from hanging): mass matrix
    # [[M + m, m l], [m l, I_pivot]] with I_pivot = 4 m l^2 / 3, stiffness diag(0, m g l);
    # the nonzero generalised eigenvalue is omega^2.
    big, small, half, g = 1.5, 0.3, 0.4, 9.81
    mass = np.array([[big + small, small * half], [small * half, 4.0 * small * half ** 2 / 3.0]])
    stiff = np.diag([0.0, small * g * half])
    eig = np.sort(np.linalg.eigvals(np.linalg.solve(mass, stiff)).real)
    assert abs(eig[0]) < 1e-12   # the free translation
    assert cartpole_omega(big, small, half, g) == pytest.approx(math.sqrt(eig[1]), rel=1e-13)


def test_heavy_top_roots():
    m, g, r, i1, i3, w3, theta = 0.5, 9.81, 0.04, 1.2e-3, 4e-4, 150.0, 0.6
    slow, fast = heavy_top_precession(m, g, r, i1, i3, w3, theta)
    roots = np.sort(np.roots([-i1 * math.cos(theta), i3 * w3, -m * g * r]).real)
    assert slow == pytest.approx(roots[0], rel=1e-12)
    assert fast == pytest.approx(roots[1], rel=1e-12)
    for omega in (slow, fast):   # each satisfies m g r = Omega (I3 w3 - I1 Omega cos theta)
        assert omega * (i3 * w3 - i1 * omega * math.cos(theta)) == pytest.approx(
            m * g * r, rel=1e-12)
    # A fast top: the slow root is the gyroscope's m g r / (I3 w3) times (1 + eps), eps =
    # I1 cos theta m g r / (I3 w3)^2 = 1.2e-7 here; the next term, 2 eps^2, is 3e-14.
    slow_fast_top, _ = heavy_top_precession(m, g, r, i1, i3, 1e5, theta)
    eps = i1 * math.cos(theta) * m * g * r / (i3 * 1e5) ** 2
    assert slow_fast_top == pytest.approx(m * g * r / (i3 * 1e5) * (1 + eps), rel=1e-12)
    # Horizontal axis: only the slow root exists.
    assert heavy_top_precession(m, g, r, i1, i3, w3, 0.5 * math.pi)[0] == pytest.approx(
        m * g * r / (i3 * w3), rel=1e-12)
    with pytest.raises(ValueError, match=r'^omega3: 1.0 rad/s is too slow'):
        heavy_top_precession(m, g, r, i1, i3, 1.0, theta)


def test_limit_stop_reference_values():
    omega, impulse, lost = limit_stop(1.0, 1.0)
    # The reference gives 5.4249 rad/s, 1.8083 N m s, 4.905 J: 5 digits, so 1e-4 relative
    # (half a unit in the last digit); m g L / 2 = 4.905 J is exact.
    assert omega == pytest.approx(5.4249, rel=1e-4)
    assert impulse == pytest.approx(1.8083, rel=1e-4)
    assert lost == pytest.approx(4.905, rel=ROUND_OFF)
    omega2, _, lost2 = limit_stop(0.5, 3.0, 9.0)
    assert 0.5 * (3.0 * 0.25 / 3.0) * omega2 ** 2 == pytest.approx(3.0 * 9.0 * 0.25, rel=1e-14)
    assert lost2 == pytest.approx(3.0 * 9.0 * 0.25, rel=ROUND_OFF)


def test_cone_stop_and_rim_torque_against_a_planar_fall_and_a_conical_pendulum():
    # No azimuth rate: a planar fall, so the energy to the rim is all normal and is lost, as
    # limit_stop's from horizontal to vertical (axis up, alpha = 90 deg from theta0 = 0).
    omega_n, omega_t, _, lost = cone_stop(1.0 / 3.0, 0.5 * 9.81, 0.0, 0.0, 0.5 * math.pi)
    omega, _, lost_ref = limit_stop(1.0, 1.0)
    assert omega_t == 0.0
    assert omega_n == pytest.approx(omega, rel=ROUND_OFF)
    assert lost == pytest.approx(lost_ref, rel=ROUND_OFF)
    # L_z: the azimuth rate at the rim is phidot0 sin^2 theta0 / sin^2 alpha.
    _, omega_t, phidot_a, _ = cone_stop(2.0, 3.0, 0.5, 3.0, 1.0)
    assert phidot_a == pytest.approx(3.0 * math.sin(0.5) ** 2 / math.sin(1.0) ** 2,
                                     rel=ROUND_OFF)
    assert omega_t == pytest.approx(phidot_a * math.sin(1.0), rel=ROUND_OFF)
    # A rate in theta at the start adds its kinetic energy to the normal part: with no
    # gravity and no azimuth rate the rod reaches the rim at that rate and loses all of it.
    omega_n, omega_t, _, lost = cone_stop(2.0, 0.0, 0.2, 0.0, 0.7, up=False, thetadot0=1.5)
    assert (omega_n, omega_t) == (pytest.approx(1.5, rel=ROUND_OFF), 0.0)
    assert lost == pytest.approx(0.5 * 2.0 * 1.5 ** 2, rel=ROUND_OFF)
    # Hanging, at the free conical pendulum's rate phidot^2 = m g d / (I1 cos alpha) (the
    # textbook rigid conical pendulum), the rim carries nothing; faster, it pushes (< 0).
    i1, mgd, alpha = 1.0 / 3.0, 0.5 * 9.81, 0.6
    free = math.sqrt(mgd / (i1 * math.cos(alpha)))
    assert abs(cone_rim_torque(i1, mgd, alpha, free, up=False)) <= ROUND_OFF * mgd
    assert cone_rim_torque(i1, mgd, alpha, 1.5 * free, up=False) < 0.0
    assert cone_rim_torque(i1, mgd, alpha, 0.0, up=True) == pytest.approx(
        -mgd * math.sin(alpha), rel=ROUND_OFF)


def test_chain_joint_forces_statics():
    n, m, g = 10, 0.2, 9.81
    forces = chain_joint_forces(n, m, g)
    # Free-body diagram of each link from the bottom up: the joint above a link holds that
    # link's weight plus what the joint below it holds.
    below = 0.0
    for j in range(n - 1, -1, -1):
        below += m * g
        assert forces[j] == pytest.approx(below, rel=ROUND_OFF)
    assert forces[0] == pytest.approx(n * m * g, rel=ROUND_OFF)
    with pytest.raises(ValueError, match='^n_links: 0 must be an int >= 1'):
        chain_joint_forces(0, m)


@pytest.mark.parametrize('theta0_deg', [1e-4, 30.0, 90.0, 180.0])
def test_cradle_rise_height(theta0_deg):
    t = theta0_deg * DEG
    # 1 - cos loses digits for small angles: compare to its series there.
    exact = 0.8 * (t * t / 2 - t ** 4 / 24) if theta0_deg < 1 else 0.8 * (1.0 - math.cos(t))
    assert cradle_rise_height(0.8, t) == pytest.approx(exact, rel=1e-13)


def test_bad_inputs_name_the_parameter():
    with pytest.raises(ValueError, match='^l_eq_m: -1.0 m must be finite and > 0'):
        pendulum_period(-1.0, 0.1)
    with pytest.raises(ValueError, match=r'^theta0_rad: 3.5 rad must satisfy'):
        pendulum_period(1.0, 3.5)
    with pytest.raises(ValueError, match='^cart_kg: 0.0 kg must be'):
        cartpole_omega(0.0, 1.0, 1.0)


def _babyboot_rk4(h_s):
    """RK4 of the babyboot's reduced equations to t_final; returns (q, qd, max |E - E0|)."""
    y = list(BABYBOOT.q0_rad) + list(BABYBOOT.qd0_rad_s)

    def f(s):
        a, b = babyboot_accelerations((s[0], s[1]), (s[2], s[3]))
        return (s[2], s[3], a, b)

    e0 = babyboot_energy(y[:2], y[2:])
    drift = 0.0
    for k in range(round(BABYBOOT.t_final_s / h_s)):
        k1 = f(y)
        k2 = f([y[i] + 0.5 * h_s * k1[i] for i in range(4)])
        k3 = f([y[i] + 0.5 * h_s * k2[i] for i in range(4)])
        k4 = f([y[i] + h_s * k3[i] for i in range(4)])
        y = [y[i] + h_s / 6.0 * (k1[i] + 2 * k2[i] + 2 * k3[i] + k4[i]) for i in range(4)]
        if k % 100 == 0:
            drift = max(drift, abs(babyboot_energy(y[:2], y[2:]) - e0))
    return y[:2], y[2:], drift


def test_babyboot_transcription_reaches_the_published_state():
    # An independent integration of the transcribed equations (RK4, h = 0.1 ms) must land on
    # the published state at 10 s. Tolerance: the published runs themselves differ by up to
    # q_spread_rad (their integrators' error grown by the chaos); RK4 at 0.1 ms adds far less
    # (halving h moves qA by 1.5e-9 deg and qB by 1.2e-8 deg), so 2 x the spread.
    # (cos of pi/2 rounded to a double is 6.1e-17, times g (mA lA + mB lB) = 0.204 J)
    assert babyboot_energy(BABYBOOT.q0_rad, BABYBOOT.qd0_rad_s) == pytest.approx(
        BABYBOOT.energy_ref_j, abs=2e-17)
    q, qd, drift = _babyboot_rk4(1e-4)
    for i in range(2):
        assert abs(q[i] - BABYBOOT.q_ref_rad[i]) <= 2.0 * BABYBOOT.q_spread_rad[i], i
        # rates: the published runs agree to 6 significant digits
        assert qd[i] == pytest.approx(BABYBOOT.qd_ref_rad_s[i], rel=2e-6), i
    qdd = babyboot_accelerations(q, qd)
    for i in range(2):   # accelerations: 7 significant digits among the published runs
        assert qdd[i] == pytest.approx(BABYBOOT.qdd_ref_rad_s2[i], rel=2e-6), i
    # The energy scale is g (mA lA + mB lB) = 0.204 J; RK4's drift at 0.1 ms stays below 1e-12.
    assert drift < 1e-12


def test_damped_rotor_against_its_equation():
    # q̇ from its ODE by a fine RK4 (local error (k h)^5 / 120 ~ 1e-20 a step), and the travel
    # by the trapezoid sum with its Euler-Maclaurin end correction -h^2/12 (q̈(t) - q̈(0)),
    # which leaves O(h^4) ~ 1e-15
    rate0, damping, inertia, t = 2.0, 0.5, 1.0 / 3.0, 2.0
    n = 10_000
    h = t / n
    rate, travel, k = rate0, 0.0, -damping / inertia
    for _ in range(n):
        new = rate * (1 + k * h + (k * h) ** 2 / 2 + (k * h) ** 3 / 6 + (k * h) ** 4 / 24)
        travel += 0.5 * h * (rate + new)
        rate = new
    travel -= h * h / 12.0 * (k * rate - k * rate0)
    expected_rate, expected_travel = damped_rotor(rate0, damping, inertia, t)
    assert expected_rate == pytest.approx(rate, rel=1e-13)
    assert expected_travel == pytest.approx(travel, rel=1e-12)


def test_damped_oscillation_roots():
    # the roots -sigma ± i omega_d of I s^2 + d s + I omega0^2 = 0
    omega0, damping, inertia = 3.8, 0.13, 1.0 / 3.0
    sigma, omega_d = damped_oscillation(omega0, damping, inertia)
    root = complex(-sigma, omega_d)
    assert abs(inertia * root ** 2 + damping * root + inertia * omega0 ** 2) <= ROUND_OFF * 10
    with pytest.raises(ValueError, match='not underdamped'):
        damped_oscillation(1.0, 1.0, 0.4)


def test_coulomb_stop_is_uniform_deceleration():
    t_stop, travel = coulomb_stop(-3.0, 0.23, 0.5)
    assert t_stop == pytest.approx(0.5 * 3.0 / 0.23, rel=ROUND_OFF)
    # travel = q̇0 t* + a t*^2 / 2 with a = +f / I (decelerating a negative rate)
    assert travel == pytest.approx(-3.0 * t_stop + 0.5 * (0.23 / 0.5) * t_stop ** 2,
                                   rel=ROUND_OFF)


def test_coulomb_pendulum_turns_spend_the_friction_work():
    mgl, friction = 4.905, 0.8
    turns = coulomb_pendulum_turns(mgl, friction, 1.0)
    assert len(turns) >= 3
    for a, b in zip(turns, turns[1:]):
        # the potential energy lost is the friction's work f |a - b|, and it turned back
        lost = mgl * (math.cos(b) - math.cos(a))
        assert lost == pytest.approx(friction * abs(a - b), abs=ROUND_OFF)
        assert abs(a - b) > 1e-3
    # it moved at every turn but the last, where the pivot holds it
    assert all(mgl * abs(math.sin(t)) > friction for t in turns[:-1])
    assert mgl * abs(math.sin(turns[-1])) <= friction


@pytest.mark.parametrize('theta0', (0.1, 1.0, 2.5))
def test_mimic_pendulum_period_reduces_to_one_pendulum(theta0):
    # k = 1 with two equal rods is one rod of twice the mass: L_eq unchanged, pendulum_period;
    # k -> 0 (1e-9) leaves pendulum 1 alone (the second's share is k² ~ 1e-18). Both are
    # elliptic integrals by the AGM, the mimic's a 200-node Gauss-Legendre quadrature of a
    # smooth integrand: round-off, a few 1e-15 relative (5e-14 at 2.5 rad, the integrand
    # steeper near the turning point).
    i_rod, mgl = 1.0 / 3.0, 9.81 * 0.5
    expected = pendulum_period(compound_pendulum_l_eq(1.0), theta0)
    assert mimic_pendulum_period(i_rod, mgl, i_rod, mgl, 1.0, theta0) == pytest.approx(
        expected, rel=1e-13)
    assert mimic_pendulum_period(i_rod, mgl, 0.2, 1.0, 1e-9, theta0) == pytest.approx(
        expected, rel=1e-13)


def test_mimic_pendulum_period_small_amplitude():
    # T -> 2 pi sqrt(I_eff / K_eff) (1 + K4 t^2 / (16 K_eff)), K4 = mgl1 + k^4 mgl2: the next
    # term is O(t^4), ~1e-13 relative at t = 1e-3 rad
    i1, mgl1, i2, mgl2, k, t = 0.3, 4.0, 0.07, 1.5, -1.7, 1e-3
    k_eff = mgl1 + k * k * mgl2
    small = 2.0 * math.pi * math.sqrt((i1 + k * k * i2) / k_eff) * (
        1.0 + (mgl1 + k ** 4 * mgl2) * t * t / (16.0 * k_eff))
    assert mimic_pendulum_period(i1, mgl1, i2, mgl2, k, t) == pytest.approx(small, rel=1e-12)
