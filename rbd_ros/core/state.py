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
The state of one rigid body, as a value.

``BodyState`` follows the lecture's state (position, orientation, linear velocity, angular
velocity) plus the sim time. Its methods are the lecture's kinematics: ``x = p + R x̄``,
``ẋ = v + ω × (x − p)``, the world inertia ``I = R I_b Rᵀ``, momenta and energies.
"""

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from rbd_ros.core.errors import finite_vector as _vector, InputError, whole_number
from rbd_ros.core.rotations import quat_normalize, quat_rotate, quat_to_matrix

if TYPE_CHECKING:
    from rbd_ros.core.model import BodyModel


# A quaternion whose |q|² is this close to 1 is unit to round-off (a few ulp, as the kernel's
# normalisation leaves it) and is kept bit for bit, so a state read from a simulator restarts
# it exactly; renormalising would change the last bits without making it more accurate.
_UNIT_NORM_SQ_TOL = 8 * np.finfo(np.float64).eps


@dataclass(frozen=True)
class BodyState:
    """
    Position, orientation, velocities and time of one rigid body.

    :param position_w: centre of mass ``p`` in world coordinates, m.
    :param orientation_wb: unit quaternion ``q_wb = (w, x, y, z)`` with ``v_w = R(q) v_b``;
        normalised on construction unless already unit to round-off (a zero or non-finite
        quaternion is refused).
    :param linear_velocity_w: COM velocity ``v = ṗ`` in world coordinates, m/s.
    :param angular_velocity_b: angular velocity ``ω_b`` in BODY coordinates, rad/s
        (``ω_w = R ω_b``).
    :param time_ns: sim time, integer nanoseconds.
    """

    position_w: np.ndarray = field(default=(0.0, 0.0, 0.0))
    orientation_wb: np.ndarray = field(default=(1.0, 0.0, 0.0, 0.0))
    linear_velocity_w: np.ndarray = field(default=(0.0, 0.0, 0.0))
    angular_velocity_b: np.ndarray = field(default=(0.0, 0.0, 0.0))
    time_ns: int = 0

    def __post_init__(self):
        set_ = object.__setattr__
        set_(self, 'position_w', _vector(self.position_w, 'position_w', 'm'))
        q = _vector(self.orientation_wb, 'orientation_wb', '(w, x, y, z)', 4)
        norm_sq = float(q @ q)
        if norm_sq == 0.0:
            raise InputError(f'orientation_wb: {q.tolist()} has zero norm, not a rotation')
        if abs(norm_sq - 1.0) > _UNIT_NORM_SQ_TOL:
            q = quat_normalize(q)
            q.flags.writeable = False
        set_(self, 'orientation_wb', q)
        set_(self, 'linear_velocity_w',
             _vector(self.linear_velocity_w, 'linear_velocity_w', 'm/s'))
        set_(self, 'angular_velocity_b',
             _vector(self.angular_velocity_b, 'angular_velocity_b', 'rad/s'))
        set_(self, 'time_ns', whole_number(self.time_ns, 'time_ns', 'ns'))

    def __eq__(self, other):
        if not isinstance(other, BodyState):
            return NotImplemented
        return (self.time_ns == other.time_ns
                and np.array_equal(self.position_w, other.position_w)
                and np.array_equal(self.orientation_wb, other.orientation_wb)
                and np.array_equal(self.linear_velocity_w, other.linear_velocity_w)
                and np.array_equal(self.angular_velocity_b, other.angular_velocity_b))

    __hash__ = None

    def rotation_wb(self) -> np.ndarray:
        """Return ``R`` (3, 3): columns are the body axes in world coordinates."""
        return quat_to_matrix(self.orientation_wb)

    def angular_velocity_w(self) -> np.ndarray:
        """Return ``ω_w = R ω_b``, rad/s."""
        return quat_rotate(self.orientation_wb, self.angular_velocity_b)

    def point_w(self, point_b) -> np.ndarray:
        """World coordinates of body point(s) ``x̄`` (..., 3): ``x = p + R x̄``, m."""
        return self.position_w + np.asarray(point_b, dtype=np.float64) @ self.rotation_wb().T

    def point_velocity_w(self, point_b) -> np.ndarray:
        """Velocity of body point(s): ``ẋ = v + ω_w × (x − p)``, m/s, world coordinates."""
        r_w = np.asarray(point_b, dtype=np.float64) @ self.rotation_wb().T
        return self.linear_velocity_w + np.cross(self.angular_velocity_w(), r_w)

    def point_acceleration_w(self, point_b, linear_acceleration_w,
                             angular_acceleration_w) -> np.ndarray:
        """
        Acceleration of body point(s): ``ẍ = a + α × r + ω × (ω × r)``, m/s², world.

        ``a`` and ``α`` (world coordinates) are the COM and angular accelerations, e.g. from
        :func:`rbd_ros.core.simulator.accelerations`.
        """
        r_w = np.asarray(point_b, dtype=np.float64) @ self.rotation_wb().T
        omega_w = self.angular_velocity_w()
        return (np.asarray(linear_acceleration_w) + np.cross(angular_acceleration_w, r_w)
                + np.cross(omega_w, np.cross(omega_w, r_w)))

    def inertia_w(self, model: 'BodyModel') -> np.ndarray:
        """World inertia about the COM, ``I = R I_b Rᵀ``, kg·m²."""
        rotation = self.rotation_wb()
        return rotation @ model.inertia_b @ rotation.T

    def linear_momentum_w(self, model: 'BodyModel') -> np.ndarray:
        """``P = M v``, kg·m/s, world coordinates."""
        return model.mass_kg * self.linear_velocity_w

    def angular_momentum_w(self, model: 'BodyModel') -> np.ndarray:
        """``L = I ω = R (I_b ω_b)``, about the COM, kg·m²/s, world coordinates."""
        return quat_rotate(self.orientation_wb, model.inertia_b @ self.angular_velocity_b)

    def kinetic_energy_linear(self, model: 'BodyModel') -> float:
        """``½ M vᵀv``, J."""
        return 0.5 * model.mass_kg * float(self.linear_velocity_w @ self.linear_velocity_w)

    def kinetic_energy_rotational(self, model: 'BodyModel') -> float:
        """``½ ωᵀ I ω = ½ ω_bᵀ I_b ω_b``, J."""
        omega_b = self.angular_velocity_b
        return 0.5 * float(omega_b @ model.inertia_b @ omega_b)

    def kinetic_energy(self, model: 'BodyModel') -> float:
        """Total kinetic energy, linear plus rotational, J."""
        return self.kinetic_energy_linear(model) + self.kinetic_energy_rotational(model)

    def potential_energy(self, model: 'BodyModel') -> float:
        """Potential energy in uniform gravity, ``−M g·p`` (zero at the world origin), J."""
        return -model.mass_kg * float(model.gravity_w @ self.position_w)
