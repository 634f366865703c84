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
Loads applied to a body from outside: wrenches at body points and springs to world anchors.

These are values the user (or the node's inputs) hand to the simulator; they are held constant
(zero-order hold) over each step they are set for. Gravity belongs to the model. All of them are
summed into one net force and torque about the centre of mass in one place,
:func:`rbd_ros.core.kernels.net_wrench_w`.
"""

from dataclasses import dataclass, field

import numpy as np

from rbd_ros.core.errors import finite_vector as _vector, InputError, non_negative

FRAMES = ('world', 'body')


@dataclass(frozen=True)
class AppliedWrench:
    """
    A force applied at a body point plus a pure couple, in world or body coordinates.

    :param force: ``f`` in N, in the coordinates named by ``frame``.
    :param torque: a pure couple ``τ_c`` in N·m, same coordinates.
    :param frame: ``'world'`` or ``'body'``: the coordinates of ``force`` and ``torque``.
    :param point_b: the application point of ``force`` in body coordinates relative to the
        centre of mass, m. The wrench about the centre of mass is
        ``F = f_w``, ``τ = r_w × f_w + τ_c,w`` with ``r_w = R point_b``.
    """

    force: np.ndarray = field(default=(0.0, 0.0, 0.0))
    torque: np.ndarray = field(default=(0.0, 0.0, 0.0))
    frame: str = 'world'
    point_b: np.ndarray = field(default=(0.0, 0.0, 0.0))

    def __post_init__(self):
        if self.frame not in FRAMES:
            raise InputError(f'frame: {self.frame!r} must be one of {FRAMES}')
        object.__setattr__(self, 'force', _vector(self.force, 'force', 'N'))
        object.__setattr__(self, 'torque', _vector(self.torque, 'torque', 'N·m'))
        object.__setattr__(self, 'point_b', _vector(self.point_b, 'point_b', 'm'))


@dataclass(frozen=True)
class Spring:
    """
    A damped spring from a body point to a world anchor (the lecture's "drag with the mouse").

    With ``x = p + R point_b``, ``d = x - anchor_w``, ``n = d / |d|`` and the point velocity
    ``ẋ = v + ω × (x - p)``, the force on the body at ``x`` is
    ``f = -(k (|d| - l0) + c (ẋ·n)) n`` for a rest length ``l0 > 0``, and
    ``f = -k d - c ẋ`` for ``l0 = 0`` (zero-length spring, the usual drag handle).

    :param point_b: attachment point, body coordinates relative to the centre of mass, m.
    :param anchor_w: anchor, world coordinates, m.
    :param stiffness_n_per_m: ``k`` >= 0, N/m.
    :param damping_n_s_per_m: ``c`` >= 0, N·s/m.
    :param rest_length_m: ``l0`` >= 0, m.
    """

    point_b: np.ndarray
    anchor_w: np.ndarray
    stiffness_n_per_m: float
    damping_n_s_per_m: float = 0.0
    rest_length_m: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, 'point_b', _vector(self.point_b, 'point_b', 'm'))
        object.__setattr__(self, 'anchor_w', _vector(self.anchor_w, 'anchor_w', 'm'))
        object.__setattr__(self, 'stiffness_n_per_m', non_negative(
            self.stiffness_n_per_m, 'stiffness_n_per_m', 'N/m'))
        object.__setattr__(self, 'damping_n_s_per_m', non_negative(
            self.damping_n_s_per_m, 'damping_n_s_per_m', 'N·s/m'))
        object.__setattr__(self, 'rest_length_m', non_negative(
            self.rest_length_m, 'rest_length_m', 'm'))
