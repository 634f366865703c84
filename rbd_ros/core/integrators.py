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
The integrators, selected by name.

Every integrator keeps ``ω`` in BODY coordinates in the state (``ω_w = R ω_b``), holds the
applied loads constant over the step (zero-order hold), reproduces damping alone exactly
(``v ← e^{−c_v h} v``, ``ω_b ← e^{−c_ω h} ω_b``) and renormalises the orientation quaternion
after every step. Damping enters the symplectic Euler variants and ``midpoint_cayley`` as its
exact flow split half before and half after the step (Strang splitting, which keeps their
order), and ``rk4`` as an integrating factor inside the step (``v̇ = F/M − c_v v``,
``ω̇_b = I⁻¹(τ_b − ω_b × I ω_b) − c_ω ω_b``; Lawson's RK4), which keeps it fourth order; the
flow split around an RK4 step would make it second order. None clamps anything; a non-finite
result is refused by the kernel, which leaves the state at its last finite value.

The registry :data:`INTEGRATORS` is the one source of what each integrator is: its order
(measured by ``tests/core/test_convergence.py``: a tumbling body under a force and a torque,
undamped and with ``c_v = c_ω = 0.5`` 1/s, against an independent numpy reference; the same
with and without damping), how it takes damping, what it conserves, the frame of ``ω`` and its
orientation update. The integrator table of ``doc/physics.md`` is generated from it by
:func:`markdown_table` (``tests/core/test_integrators.py`` checks that it is up to date), and
the list at the end of this docstring likewise.

``midpoint_cayley`` is second order for loads that depend on the configuration (held wrenches,
gravity, spring stiffness) and with the body's linear and angular damping; with
velocity-dependent loads (a spring's damping term) its second kick uses the velocity before
that kick, which makes it first order in the damping term (measured: error ratio 2.0 per
halving on a damped spring, 4.0 without damping). Its implicit solve converges reliably for
``h|ω| < 2`` rad; a step whose solve does not converge is refused with
:class:`rbd_ros.core.ConvergenceError` naming ``h|ω|``.
"""

from dataclasses import dataclass

from rbd_ros.core import kernels
from rbd_ros.core.errors import ConfigError


@dataclass(frozen=True)
class IntegratorInfo:
    """
    What an integrator is: the one record the docs and their table are made from.

    :ivar name: the name users select it by.
    :ivar kernel_id: its method id in :mod:`rbd_ros.core.kernels`.
    :ivar order: convergence order, measured, with and without damping.
    :ivar damping: how the exact damping flow enters the step.
    :ivar conserves: what it conserves for a torque-free body.
    :ivar omega_frame: the coordinates ``ω`` is stored and integrated in.
    :ivar orientation: its orientation update, as an equation.
    :ivar doc: the method in full, with references.
    """

    name: str
    kernel_id: int
    order: int
    damping: str
    conserves: str
    omega_frame: str
    orientation: str
    doc: str


_SE_COMMON = (
    'Symplectic Euler as in the lecture: F, τ at the start of the step; '
    'v ← v + h F/M; ω ← ω + h I⁻¹(τ − ω × Iω) (evaluated in body coordinates, '
    'identical to the world form with I⁻¹ = R I_b⁻¹ Rᵀ); p ← p + h v_new; then ')
_SPLIT = 'exact flow, split around the step'

INTEGRATORS = {
    info.name: info for info in (
        IntegratorInfo(
            'symplectic_euler_matrix', kernels.SE_MATRIX, 1, _SPLIT,
            'nothing exactly; gains energy on fast asymmetric spin', 'body',
            'R ← (𝟙 + h[ω_w]) R, then Gram–Schmidt',
            _SE_COMMON + 'R ← (𝟙 + h[ω_w])R and Gram–Schmidt orthonormalisation.'),
        IntegratorInfo(
            'symplectic_euler_axis_angle', kernels.SE_AXIS_ANGLE, 1, _SPLIT,
            'nothing exactly; R stays a rotation to round-off', 'body',
            'R ← Rot(h|ω_w|, ω_w/|ω_w|) R',
            _SE_COMMON + 'R ← Rot(h|ω_w|, ω_w/|ω_w|) R (Rodrigues).'),
        IntegratorInfo(
            'symplectic_euler_quat_exp', kernels.SE_QUAT_EXP, 1, _SPLIT,
            'nothing exactly; |q| = 1', 'body',
            'q ← exp(h ω_w / 2) ⊗ q',
            _SE_COMMON + 'q ← exp(h ω_w / 2) ⊗ q (quaternion exponential map).'),
        IntegratorInfo(
            'symplectic_euler_quat_linear', kernels.SE_QUAT_LINEAR, 1, _SPLIT,
            'nothing exactly; |q| = 1 by normalisation', 'body',
            'q ← normalise(q + h ½ (0, ω_w) ⊗ q)',
            _SE_COMMON + 'q ← normalise(q + h ½ (0, ω_w) ⊗ q) (first-order update).'),
        IntegratorInfo(
            'rk4', kernels.RK4, 4,
            'inside the step, as an integrating factor (Lawson RK4)',
            'nothing exactly; slow secular drift of energy and momentum', 'body',
            'RK4 on q̇ = ½ q ⊗ (0, ω_b), renormalised',
            'Classical Runge–Kutta 4 on (p, q, v, ω_b) with q̇ = ½ q ⊗ (0, ω_b), forces '
            're-evaluated at every stage, q renormalised at the end of the step; the damping '
            '−c_v v, −c_ω ω_b enters as an integrating factor (Lawson RK4: classical RK4 on '
            'e^{cτ}·(v, ω_b)), fourth order with damping and exact for damping alone.'),
        IntegratorInfo(
            'midpoint_cayley', kernels.MIDPOINT_CAYLEY, 2,
            'exact flow, split symmetrically around the step',
            'kinetic energy and the world angular momentum vector L = R Π to round-off; '
            'linear momentum exactly (force-free)', 'body',
            'implicit midpoint on Π = I_b ω_b, then Cayley R ← R cay(h ω_mid)',
            'Kick–drift–kick (Strang) splitting: half a step of force and torque as impulses '
            'on v and on the body angular momentum Π = I_b ω_b; exact free translation; the '
            "torque-free rotation by the implicit midpoint rule on Euler's equations "
            'Π_{n+1} = Π_n + h Π_mid × I⁻¹Π_mid, solved by Newton to round-off (a step '
            'whose solve does not converge, from h|ω| ≈ 3 rad on, is refused with '
            'ConvergenceError), with the matching Cayley orientation update '
            'R ← R cay(h ω_mid), which makes R Π invariant exactly; then the second half '
            'kick. Implicit midpoint preserves the quadratic invariants |Π|² and ΠᵀI⁻¹Π '
            '(Hairer, Lubich, Wanner, Geometric Numerical Integration, 2nd ed. 2006, '
            'Thm IV.2.2 and §VII.5; energy–momentum methods: Simo & Wong, Int. J. Numer. '
            'Meth. Eng. 31 (1991) 19–52). Second order for configuration-dependent loads and '
            'with the body damping (its exact flow split symmetrically around the step), '
            'first order in velocity-dependent loads (spring damping).'),
    )
}

DEFAULT_INTEGRATOR = 'midpoint_cayley'


def integrator_info(name: str) -> IntegratorInfo:
    """Return the :class:`IntegratorInfo` called ``name`` or raise :class:`ConfigError`."""
    try:
        return INTEGRATORS[name]
    except (KeyError, TypeError):
        raise ConfigError(
            f'integrator: {name!r} is not one of {", ".join(INTEGRATORS)}') from None


def markdown_table() -> str:
    """Return the integrator table of ``doc/physics.md``, generated from :data:`INTEGRATORS`."""
    def cell(text):
        return text.replace('|', '\\|')

    lines = ['| name | order (measured, with and without damping) | damping | conserves '
             '(torque-free body) | ω stored in | orientation update |',
             '| --- | --- | --- | --- | --- | --- |']
    for info in INTEGRATORS.values():
        name = f'`{info.name}`'
        if info.name == DEFAULT_INTEGRATOR:
            name = f'**{name}** (default)'
        lines.append(f'| {name} | {info.order} | {cell(info.damping)} | {cell(info.conserves)} '
                     f'| {info.omega_frame} coordinates | `{cell(info.orientation)}` |')
    return '\n'.join(lines) + '\n'


def _rest_list():
    """Return the registry as a reST definition list (appended to this module's docstring)."""
    return ''.join(
        f'\n``{info.name}`` (order {info.order}; ω in {info.omega_frame} coordinates)\n'
        f'    Conserves: {info.conserves}. Damping: {info.damping}. {info.doc}\n'
        for info in INTEGRATORS.values())


if __doc__:   # None under python -OO
    __doc__ += '\nThe integrators (generated from :data:`INTEGRATORS`):\n' + _rest_list()
