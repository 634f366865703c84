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
Closed forms for jointed bodies (issue 27): the exact values the joint tests and benchmark use.

Pure numpy / math (scipy is not a dependency). Each function cites where its formula comes
from; ``/work/shared/reference/joints-weinstein.md`` collects them. SI units throughout, angles
in rad, g = 9.81 m/s^2 unless given. :data:`BABYBOOT` is Drake's chaotic babyboot benchmark
transcribed as data, with the model's geometry spelled out for building it from two bodies and
two revolute joints. ``test_closed_forms.py`` checks every function against independent numbers.
"""

import collections
import math

import numpy as np

G = 9.81


def _positive(name, value, unit):
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f'{name}: {value} {unit} must be finite and > 0')
    return float(value)


def _agm(a, b):
    """Arithmetic-geometric mean of two positive numbers (quadratic convergence)."""
    for _ in range(64):
        if abs(a - b) <= 1e-16 * a:
            break
        a, b = 0.5 * (a + b), math.sqrt(a * b)
    return 0.5 * (a + b)


def ellipk(m):
    """
    Complete elliptic integral of the first kind, ``K(m) = int_0^{pi/2} (1 - m sin^2 t)^-1/2 dt``.

    Parameter ``m = k^2`` (the convention of ``scipy.special.ellipk``). Computed by the
    arithmetic-geometric mean, ``K = pi / (2 agm(1, sqrt(1 - m)))`` (Abramowitz and Stegun,
    *Handbook of Mathematical Functions*, 17.6.1), accurate to round-off.

    :param m: the parameter, ``0 <= m < 1``
    :return: K(m)
    """
    if not (math.isfinite(m) and 0.0 <= m < 1.0):
        raise ValueError(f'm: {m} (= k^2, dimensionless) must be in [0, 1)')
    return math.pi / (2.0 * _agm(1.0, math.sqrt(1.0 - m)))


def pendulum_period(l_eq_m, theta0_rad, g=G):
    """
    Period (s) of a pendulum released from rest at ``theta0_rad`` from the downward vertical.

    ``T = 4 sqrt(L_eq / g) K(k^2)``, ``k = sin(theta0 / 2)`` (exact for any amplitude below pi;
    e.g. Landau and Lifshitz, *Mechanics*, section 11, problem 1; joints-weinstein.md).
    For a compound pendulum pass its equivalent length (:func:`compound_pendulum_l_eq`).

    :param l_eq_m: equivalent simple-pendulum length ``I_pivot / (m d)`` (m, > 0)
    :param theta0_rad: release angle (rad, 0 < |theta0| < pi)
    :param g: gravity (m/s^2, > 0)
    """
    l_eq_m = _positive('l_eq_m', l_eq_m, 'm')
    g = _positive('g', g, 'm/s^2')
    if not (math.isfinite(theta0_rad) and 0.0 < abs(theta0_rad) < math.pi):
        raise ValueError(f'theta0_rad: {theta0_rad} rad must satisfy 0 < |theta0| < pi')
    k = math.sin(0.5 * theta0_rad)
    return 4.0 * math.sqrt(l_eq_m / g) * ellipk(k * k)


def compound_pendulum_l_eq(length_m):
    """
    Equivalent length (m) of a uniform rod pivoted at one end: ``I_pivot / (m d) = 2 L / 3``.

    ``I_pivot = m L^2 / 3`` (parallel axes), ``d = L / 2`` (the centre of mass); any mechanics
    text, e.g. Goldstein, *Classical Mechanics*; joints-weinstein.md.
    """
    return 2.0 * _positive('length_m', length_m, 'm') / 3.0


def cartpole_omega(cart_kg, pole_kg, half_length_m, g=G):
    """
    Angular frequency (rad/s) of a cart-pole's small oscillations about hanging down.

    Free cart of mass M on a horizontal slider, pole a uniform rod of mass m and half-length l
    pivoted at one end on the cart: ``omega^2 = 3 g (M + m) / (l (4 M + m))`` (linearised
    Lagrange equations; joints-weinstein.md). Momentum along the slider is conserved, so the
    other mode has zero frequency.
    """
    big = _positive('cart_kg', cart_kg, 'kg')
    small = _positive('pole_kg', pole_kg, 'kg')
    half = _positive('half_length_m', half_length_m, 'm')
    g = _positive('g', g, 'm/s^2')
    return math.sqrt(3.0 * g * (big + small) / (half * (4.0 * big + small)))


def mimic_pendulum_period(i1, mgl1, i2, mgl2, k, theta0_rad, nodes=200):
    """
    Period (s) of two pendulums whose angles are tied, ``q2 = k q1``, released at ``theta0``.

    One degree of freedom: kinetic energy ``½ I_eff q̇1²``, ``I_eff = I1 + k² I2``, potential
    ``V(q1) = -mgl1 cos q1 - mgl2 cos(k q1)`` (each pendulum's ``m g l``, ``l`` pivot to centre
    of mass), so energy gives ``T = 4 ∫_0^θ0 dq / sqrt(2 (V(θ0) - V(q)) / I_eff)``. With
    ``q = θ0 sin φ`` the integrand is smooth on ``[0, π/2]`` (``V(θ0) - V(q)`` vanishes like
    ``cos² φ``); Gauss–Legendre with ``nodes`` points, every difference written without
    cancellation (``cos a - cos b = 2 sin((a + b)/2) sin((b - a)/2)``). Small amplitudes:
    ``T → 2π sqrt(I_eff / K_eff)``, ``K_eff = mgl1 + k² mgl2``.

    :param i1, i2: the pendulums' moments of inertia about their pivots (kg m², > 0)
    :param mgl1, mgl2: ``m g l`` of each (N m, > 0)
    :param k: the multiplier (any finite, nonzero)
    :param theta0_rad: release angle of pendulum 1 (rad, 0 < |θ0|, |k θ0| < π)
    """
    i1 = _positive('i1', i1, 'kg m^2')
    i2 = _positive('i2', i2, 'kg m^2')
    mgl1 = _positive('mgl1', mgl1, 'N m')
    mgl2 = _positive('mgl2', mgl2, 'N m')
    t0 = abs(theta0_rad)
    if not (math.isfinite(t0) and 0.0 < t0 < math.pi and abs(k * t0) < math.pi):
        raise ValueError(f'theta0_rad: {theta0_rad} rad must satisfy 0 < |theta0|, '
                         f'|k theta0| < pi (k = {k})')
    i_eff = i1 + k * k * i2
    x, w = np.polynomial.legendre.leggauss(nodes)
    phi = 0.25 * math.pi * (x + 1.0)
    q = t0 * np.sin(phi)
    gap = t0 * np.cos(phi) ** 2 / (1.0 + np.sin(phi))   # θ0 - q
    drop = (2.0 * mgl1 * np.sin(0.5 * (t0 + q)) * np.sin(0.5 * gap)
            + 2.0 * mgl2 * np.sin(0.5 * k * (t0 + q)) * np.sin(0.5 * k * gap))
    integrand = t0 * np.cos(phi) / np.sqrt(2.0 * drop / i_eff)
    return 4.0 * 0.25 * math.pi * float(integrand @ w)


def heavy_top_precession(mass_kg, g, r_m, i1, i3, omega3, theta_rad):
    """
    Steady precession rates (rad/s) of a heavy symmetric top on a fixed point: ``(slow, fast)``.

    The roots ``Omega`` of ``m g r = Omega (I3 omega3 - I1 Omega cos theta)`` (Goldstein,
    *Classical Mechanics*, 3rd ed., section 5.7, eq. 5.76 rewritten; joints-weinstein.md), with
    ``omega3`` the total spin, the angular velocity component along the symmetry axis. The slow
    root is computed as ``2 m g r / (I3 omega3 + sqrt(D))`` (no cancellation); the fast root is
    ``inf`` when ``cos theta = 0`` (the equation is then linear).

    :param mass_kg: mass (kg)
    :param g: gravity (m/s^2)
    :param r_m: distance from the fixed point to the centre of mass (m)
    :param i1: moment of inertia about a transverse axis through the fixed point (kg m^2)
    :param i3: moment of inertia about the symmetry axis (kg m^2)
    :param omega3: spin along the symmetry axis (rad/s, > 0)
    :param theta_rad: angle of the symmetry axis from the upward vertical (rad)
    :raises ValueError: when ``(I3 omega3)^2 < 4 I1 m g r cos theta``: no steady precession
    """
    mass_kg = _positive('mass_kg', mass_kg, 'kg')
    g = _positive('g', g, 'm/s^2')
    r_m = _positive('r_m', r_m, 'm')
    i1 = _positive('i1', i1, 'kg m^2')
    i3 = _positive('i3', i3, 'kg m^2')
    omega3 = _positive('omega3', omega3, 'rad/s')
    spin = i3 * omega3
    cos_t = math.cos(theta_rad)
    disc = spin * spin - 4.0 * i1 * cos_t * mass_kg * g * r_m
    if disc < 0.0:
        raise ValueError(f'omega3: {omega3} rad/s is too slow for steady precession at '
                         f'theta {theta_rad} rad (needs (I3 omega3)^2 >= 4 I1 m g r cos theta)')
    root = math.sqrt(disc)
    slow = 2.0 * mass_kg * g * r_m / (spin + root)
    fast = math.inf if cos_t == 0.0 else (spin + root) / (2.0 * i1 * cos_t)
    return slow, fast


def limit_stop(length_m, mass_kg, g=G):
    """
    Stop a uniform rod released from horizontal about one end with an inelastic stop at vertical.

    Energy: ``(1/2) (m L^2 / 3) omega^2 = m g L / 2`` gives ``omega = sqrt(3 g / L)`` at the
    vertical; a perfectly inelastic stop there takes the angular impulse ``I omega`` and removes
    all the kinetic energy ``(1/2) I omega^2 = m g L / 2`` (joints-weinstein.md).

    :return: ``(omega_rad_s, angular_impulse_n_m_s, energy_lost_j)``
    """
    length_m = _positive('length_m', length_m, 'm')
    mass_kg = _positive('mass_kg', mass_kg, 'kg')
    g = _positive('g', g, 'm/s^2')
    inertia = mass_kg * length_m * length_m / 3.0
    omega = math.sqrt(3.0 * g / length_m)
    return omega, inertia * omega, 0.5 * inertia * omega * omega


def cone_stop(i1, mgd, theta0, phidot0, alpha, up=True, thetadot0=0.0):
    """
    Return how a symmetric rod on a ball joint, no spin about its axis, meets a cone's rim.

    The rod (inertia ``i1`` kg m^2 across its axis about the pivot, ``mgd = m g d`` N m with
    ``d`` the pivot-COM distance) leaves angle ``theta0`` off the cone's axis at the rate
    ``thetadot0`` in ``theta`` (rad/s, 0 by default) and the azimuth rate ``phidot0``. The axis
    points up (``up``; gravity pulls the rod off it) or down. With no spin about its axis,
    ``omega = phidot (z - cos theta f)``: ``L_z = i1 phidot sin^2 theta`` and ``E = (1/2) i1
    (theta'^2 + phidot^2 sin^2 theta) +- mgd cos theta`` are kept (the Lagrangian of the
    symmetric top with ``omega_3 = 0``, Goldstein ch. 5). At ``theta = alpha`` the rod swings
    around the rim at ``omega_t = phidot_a sin alpha`` and into it at ``omega_n`` from the
    energy; an inelastic stop takes ``omega_n`` alone (its swing axis ``n`` is a principal axis
    of the rod about the pivot) and removes ``(1/2) i1 omega_n^2``.

    :return: ``(omega_n, omega_t, phidot_a, energy_lost_j)`` (rad/s, rad/s, rad/s, J)
    """
    i1 = _positive('i1', i1, 'kg m^2')
    sign = 1.0 if up else -1.0
    phidot_a = phidot0 * math.sin(theta0) ** 2 / math.sin(alpha) ** 2
    kinetic0 = 0.5 * i1 * ((phidot0 * math.sin(theta0)) ** 2 + thetadot0 ** 2)
    kinetic_a = kinetic0 + sign * mgd * (math.cos(theta0) - math.cos(alpha))
    omega_t = phidot_a * math.sin(alpha)
    omega_n2 = 2.0 * kinetic_a / i1 - omega_t * omega_t
    if not omega_n2 > 0.0:
        raise ValueError(f'cone_stop: the rod does not reach the rim (omega_n^2 = {omega_n2} '
                         'rad^2/s^2)')
    omega_n = math.sqrt(omega_n2)
    return omega_n, omega_t, phidot_a, 0.5 * i1 * omega_n2


def cone_rim_torque(i1, mgd, alpha, phidot, up=True):
    """
    Return the force (N m, along ``theta``) that holds the rod of :func:`cone_stop` on the rim.

    Running around the rim at ``theta = alpha`` at the azimuth rate ``phidot``, the rod's
    ``theta`` equation ``i1 theta'' = i1 phidot^2 sin theta cos theta +- mgd sin theta + tau``
    (``+`` with the axis up) with ``theta'' = 0`` gives
    ``tau = -(i1 phidot^2 cos alpha +- mgd) sin alpha``; a stop may only push, ``tau <= 0``.
    Hanging (axis down) it is 0 at the free conical pendulum's rate
    ``phidot^2 = mgd / (i1 cos alpha)``, below which the rim would have to pull.
    """
    i1 = _positive('i1', i1, 'kg m^2')
    sign = 1.0 if up else -1.0
    return -(i1 * phidot * phidot * math.cos(alpha) + sign * mgd) * math.sin(alpha)


def chain_joint_forces(n_links, link_kg, g=G):
    """
    Force (N) each joint of a chain of equal links hanging at rest carries, top joint first.

    Joint 0 holds link 0 to the world, joint j holds link j to link j - 1; joint j carries the
    weight of the links below it, ``(n - j) m g``, so the k-th joint from the bottom carries
    ``k m g`` and the top one the whole weight (statics; joints-weinstein.md).

    :return: ``np.ndarray`` of shape ``(n_links,)``
    """
    if isinstance(n_links, bool) or not isinstance(n_links, int) or n_links < 1:
        raise ValueError(f'n_links: {n_links!r} must be an int >= 1')
    link_kg = _positive('link_kg', link_kg, 'kg')
    g = _positive('g', g, 'm/s^2')
    return np.arange(n_links, 0, -1, dtype=float) * link_kg * g


def cradle_rise_height(length_m, theta0_rad):
    """
    Height (m) the last ball of Newton's cradle rises to: the striker's drop, ``L (1 - cos t0)``.

    With elastic (epsilon = 1) contact between equal balls the striker's velocity passes down
    the row and the last ball swings out with it, so energy gives the striker's release height
    (joints-weinstein.md). Written as ``2 L sin^2(theta0 / 2)`` to keep small angles exact.
    """
    length_m = _positive('length_m', length_m, 'm')
    if not (math.isfinite(theta0_rad) and abs(theta0_rad) <= math.pi):
        raise ValueError(f'theta0_rad: {theta0_rad} rad must be finite and |theta0| <= pi')
    s = math.sin(0.5 * theta0_rad)
    return 2.0 * length_m * s * s


#: Drake's chaotic babyboot as data (SI units). Fields: the model (``g`` m/s^2; ``mass_a_kg``,
#: ``mass_b_kg``; ``i_ax``, ``i_bx``, ``i_by``, ``i_bz`` kg m^2, central; ``l_a_m``, ``l_b_m``),
#: the initial state (``q0_rad``, ``qd0_rad_s``: (qA, qB)), the published state at
#: ``t_final_s`` (``q_ref_rad``, ``qd_ref_rad_s``, ``qdd_ref_rad_s2``; the spread of the four
#: published runs ``q_spread_rad``) and ``energy_ref_j`` (zero: it starts horizontal at rest),
#: and ``source``.
def critically_damped(e0, omega, t_s):
    """
    Return a position motor's error ``e(t) = e0 (1 + ω t) e^(-ω t)`` from rest.

    The exact critically damped response ``ë = -2ω ė - ω² e`` (``ω = 1/time_constant_s``)
    started at ``e0`` with ``ė = 0``: it never changes sign (no overshoot).
    """
    return e0 * (1.0 + omega * t_s) * math.exp(-omega * t_s)


def damped_rotor(rate0, damping, inertia, t_s):
    """
    Rate and travel of one joint under its viscous damping alone: ``(q̇(t), q(t) - q(0))``.

    ``I q̈ = -d q̇`` (no other load): ``q̇ = q̇0 exp(-d t / I)`` and
    ``q - q0 = q̇0 (I / d) (1 - exp(-d t / I))``. ``I`` is the inertia about the joint axis
    (kg m^2, ``d`` in N m s/rad) or, for a slider, the moving mass (kg, ``d`` in N s/m).
    """
    damping = _positive('damping', damping, 'N m s/rad or N s/m')
    inertia = _positive('inertia', inertia, 'kg m^2 or kg')
    rate = damping / inertia
    return rate0 * math.exp(-rate * t_s), rate0 / rate * -math.expm1(-rate * t_s)


def damped_oscillation(omega0, damping, inertia):
    """
    Decay rate and damped frequency ``(sigma, omega_d)`` (1/s, rad/s) of small oscillations.

    ``I x'' + d x' + I omega0^2 x = 0`` (a pendulum linearised about hanging down, ``omega0^2
    = m g l / I``): ``x = A exp(-sigma t) cos(omega_d t - phi)`` with ``sigma = zeta omega0 =
    d / (2 I)`` and ``omega_d = sqrt(omega0^2 - sigma^2)`` (underdamped; any mechanics text,
    e.g. Landau and Lifshitz, *Mechanics*, section 25).
    """
    omega0 = _positive('omega0', omega0, 'rad/s')
    inertia = _positive('inertia', inertia, 'kg m^2')
    sigma = _positive('damping', damping, 'N m s/rad') / (2.0 * inertia)
    if not sigma < omega0:
        raise ValueError(f'damping: {damping} N m s/rad is not underdamped (sigma {sigma} 1/s '
                         f'>= omega0 {omega0} rad/s)')
    return sigma, math.sqrt((omega0 - sigma) * (omega0 + sigma))


def coulomb_stop(rate0, friction, inertia):
    """
    Stop time and travel ``(t*, q(t*) - q(0))`` of one joint sliding against its friction alone.

    ``I q̈ = -f sign(q̇)`` decelerates at ``f / I``: ``t* = I |q̇0| / f``, travel
    ``q̇0 t* / 2 = I q̇0 |q̇0| / (2 f)``; then the joint sticks (nothing pushes it).
    """
    friction = _positive('friction', friction, 'N m or N')
    inertia = _positive('inertia', inertia, 'kg m^2 or kg')
    t_stop = inertia * abs(rate0) / friction
    return t_stop, 0.5 * rate0 * t_stop


def coulomb_pendulum_turns(mgl, friction, theta0_rad):
    """
    Return the turning angles (rad) of a pendulum with Coulomb pivot friction, from rest.

    ``I θ'' = -m g l sin θ - f sign(θ')``. Between two turns ``a`` and ``b`` the friction
    does the work ``-f |a - b|``, so ``m g l (cos b - cos a) = f |a - b|``, whatever ``I``:
    from ``a > 0`` it swings down to the root ``b`` of ``g(b) = m g l (cos b - cos a) - f (a -
    b)`` below the trivial one, in ``[-a, asin(f / m g l))`` (``g`` peaks there, and ``g(-a) =
    -2 f a < 0``): on the other side, or on the same side when the friction stops it first.
    At a turn where ``m g l |sin b| <= f`` the pivot holds it for good. Returns ``[θ0, θ1,
    ...]``, the last being where it stays.

    :param mgl: ``m g l``, the gravity torque at 90 degrees (N m, > 0)
    :param friction: ``f`` (N m, > 0)
    :param theta0_rad: release angle from hanging down (rad, 0 < |θ0| < pi/2)
    """
    mgl = _positive('mgl', mgl, 'N m')
    friction = _positive('friction', friction, 'N m')
    if not (math.isfinite(theta0_rad) and 0.0 < abs(theta0_rad) < 0.5 * math.pi):
        raise ValueError(f'theta0_rad: {theta0_rad} rad must satisfy 0 < |theta0| < pi/2')
    turns = [float(theta0_rad)]
    while mgl * abs(math.sin(turns[-1])) > friction:
        a = abs(turns[-1])   # by symmetry, as if from +a
        lo, hi = -a, math.asin(friction / mgl)   # g(lo) < 0 < g(hi); bisection to round-off
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            if mgl * (math.cos(mid) - math.cos(a)) - friction * (a - mid) > 0.0:
                hi = mid
            else:
                lo = mid
        turns.append(0.5 * (lo + hi) * math.copysign(1.0, turns[-1]))
    return turns


Babyboot = collections.namedtuple('Babyboot', [
    'g', 'mass_a_kg', 'mass_b_kg', 'i_ax', 'i_bx', 'i_by', 'i_bz', 'l_a_m', 'l_b_m',
    'q0_rad', 'qd0_rad_s', 't_final_s', 'q_ref_rad', 'qd_ref_rad_s', 'qdd_ref_rad_s2',
    'q_spread_rad', 'energy_ref_j', 'source'])

_DEG = math.pi / 180.0

BABYBOOT = Babyboot(
    g=9.81,
    mass_a_kg=10e-3, mass_b_kg=100e-3,                     # 10 g, 100 g
    i_ax=50e-7, i_bx=2500e-7, i_by=500e-7, i_bz=2000e-7,   # g cm^2 * 1e-7 = kg m^2
    l_a_m=7.5e-2, l_b_m=20e-2,                             # 7.5 cm, 20 cm
    q0_rad=(90.0 * _DEG, 1.0 * _DEG), qd0_rad_s=(0.0, 0.0),
    t_final_s=10.0,
    q_ref_rad=(-61.312983340691 * _DEG, -929.47789677244 * _DEG),
    qd_ref_rad_s=(-6.7440081040646, -2.7795690128833),
    qdd_ref_rad_s2=(41.137023263571, 19.483647096003),
    # the widest of the other three published runs (A, B, MATLAB ode45) from the reference
    q_spread_rad=(1.6e-6 * _DEG, 1.3e-5 * _DEG),
    energy_ref_j=0.0,
    source=('RobotLocomotion/drake be259df724b3b1e206dea95055f0537eae6ad8b9, '
            'multibody/benchmarks/chaotic_babyboot/MG/MG_chaotic_babyboot_auto_generated.cc '
            '(SetInputValues, CalculateQuantitiesThatDependOnTXEtc, CalculateOutput) and '
            'MG/test/MG_chaotic_babyboot_test.cc (ForwardDynamicsA)'))
"""
Drake's chaotic babyboot (T. R. Kane 1974), transcribed from :attr:`Babyboot.source`.

Geometry, as the source's equations imply: body A (a rod) hangs from a world revolute joint of
axis x through the origin; qA is A's rotation about +x, zero hanging straight down, so A's
centre of mass sits at ``R_x(qA) (0, 0, -l_a)``. Body B (a plate) is pinned to A by a revolute
joint along A's long axis (A's z, through both centres of mass); qB is B's rotation about it,
zero with B's principal axes along A's; B's centre of mass sits at ``R_x(qA) (0, 0, -l_b)``.
A's central inertia about x is ``i_ax`` (its other moments do not enter: A only turns about x);
B's central principal moments are ``i_bx, i_by, i_bz`` (z along the rod). The equations of
motion (source, reduced coordinates):
``qA'' = -(g (mA lA + mB lB) sin qA - 2 (IBx - IBy) sin qB cos qB qA' qB') /
(IAx + IBx + mA lA^2 + mB lB^2 - (IBx - IBy) sin^2 qB)``,
``qB'' = -(IBx - IBy) sin qB cos qB qA'^2 / IBz``; energy
``E = (1/2)(IAx + IBx + mA lA^2 + mB lB^2 - (IBx - IBy) sin^2 qB) qA'^2 + (1/2) IBz qB'^2
- g (mA lA + mB lB) cos qA``. Both equations are even in qB, so the sense chosen for B's axis
does not change the numbers as long as the initial state and the readout use the same one.
"""


def babyboot_accelerations(q, qd, model=BABYBOOT):
    """``(qA'', qB'')`` (rad/s^2) of the babyboot in reduced coordinates (see :data:`BABYBOOT`)."""
    qa, qb = q
    qad, qbd = qd
    m = model
    d = m.i_bx - m.i_by
    sb, cb = math.sin(qb), math.cos(qb)
    inertia = (m.i_ax + m.i_bx + m.mass_a_kg * m.l_a_m ** 2 + m.mass_b_kg * m.l_b_m ** 2
               - d * sb * sb)
    qadd = -(m.g * (m.mass_a_kg * m.l_a_m + m.mass_b_kg * m.l_b_m) * math.sin(qa)
             - 2.0 * d * sb * cb * qad * qbd) / inertia
    qbdd = -d * sb * cb * qad * qad / m.i_bz
    return qadd, qbdd


def babyboot_energy(q, qd, model=BABYBOOT):
    """Kinetic plus potential energy (J) of the babyboot (see :data:`BABYBOOT`), zero at q0."""
    qa, qb = q
    qad, qbd = qd
    m = model
    sb = math.sin(qb)
    inertia = (m.i_ax + m.i_bx + m.mass_a_kg * m.l_a_m ** 2 + m.mass_b_kg * m.l_b_m ** 2
               - (m.i_bx - m.i_by) * sb * sb)
    return (0.5 * inertia * qad * qad + 0.5 * m.i_bz * qbd * qbd
            - m.g * (m.mass_a_kg * m.l_a_m + m.mass_b_kg * m.l_b_m) * math.cos(qa))
