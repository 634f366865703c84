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
The body model: constant physical properties of one rigid body (MuJoCo's ``mjModel`` idea).

The model is immutable and validated when built; the state (:mod:`rbd_ros.core.state`) is a
separate value, and the simulator is the one mutable object.
"""

from dataclasses import dataclass, field

import numpy as np

from rbd_ros.core.errors import finite_vector, ModelError, non_negative
from rbd_ros.core.inertia import validate_inertia, validate_mass


@dataclass(frozen=True)
class BodyModel:
    """
    Mass properties, gravity and damping of one rigid body.

    :param mass_kg: total mass ``M`` in kg, finite and > 0.
    :param inertia_b: inertia tensor ``I_b`` about the centre of mass in body coordinates,
        kg·m², symmetric positive definite with principal moments satisfying the triangle
        inequality. The world inertia is ``I_w = R I_b Rᵀ``.
    :param gravity_w: uniform gravitational acceleration ``g`` in world coordinates, m/s².
        Its force ``M g`` acts at the centre of mass and so produces no torque.
    :param linear_damping_per_s: ``c_v`` in 1/s; the linear velocity obeys
        ``v̇ = -c_v v`` (besides the forces), applied as its exact flow ``v ← v·exp(-c_v h)``.
    :param angular_damping_per_s: ``c_ω`` in 1/s; likewise ``ω̇_b = -c_ω ω_b`` (besides the
        torques), ``ω_b ← ω_b·exp(-c_ω h)``.

    Every integrator reproduces damping alone exactly, so a body under damping alone decays as
    ``exp(-c t)`` at every step boundary whatever the step size: the first-order and the
    midpoint integrators split the exact flow symmetrically around each step (half before,
    half after; this keeps their order, 1 and 2), ``rk4`` takes it as an integrating factor
    inside its step (Lawson's RK4; fourth order with damping). There is no other, hidden
    damping.
    """

    mass_kg: float
    inertia_b: np.ndarray
    gravity_w: np.ndarray = field(default=(0.0, 0.0, 0.0))
    linear_damping_per_s: float = 0.0
    angular_damping_per_s: float = 0.0
    inertia_inv_b: np.ndarray = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        validate_mass(self.mass_kg, 'mass_kg')
        inertia = np.array(self.inertia_b, dtype=np.float64)
        validate_inertia(inertia, 'inertia_b')
        # Symmetrise exactly: validation allows a round-off asymmetry; the dynamics use the
        # symmetric part, which is what the kinetic energy ½ωᵀIω sees anyway.
        inertia = 0.5 * (inertia + inertia.T)
        inertia.flags.writeable = False
        inverse = np.linalg.inv(inertia)
        inverse = 0.5 * (inverse + inverse.T)
        inverse.flags.writeable = False
        for name in ('linear_damping_per_s', 'angular_damping_per_s'):
            object.__setattr__(self, name, non_negative(getattr(self, name), name, '1/s',
                                                        error=ModelError))
        object.__setattr__(self, 'mass_kg', float(self.mass_kg))
        object.__setattr__(self, 'inertia_b', inertia)
        object.__setattr__(self, 'inertia_inv_b', inverse)
        object.__setattr__(self, 'gravity_w', finite_vector(
            self.gravity_w, 'gravity_w', 'm/s²', error=ModelError))

    def __eq__(self, other):
        if not isinstance(other, BodyModel):
            return NotImplemented
        return (self.mass_kg == other.mass_kg
                and np.array_equal(self.inertia_b, other.inertia_b)
                and np.array_equal(self.gravity_w, other.gravity_w)
                and self.linear_damping_per_s == other.linear_damping_per_s
                and self.angular_damping_per_s == other.angular_damping_per_s)

    __hash__ = None
