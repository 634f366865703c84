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
Small contact worlds for the contact-step tests: boxes and spheres on a (tilted) ground.

Every scene uses g = 9.81 m/s² along −z and the default integrator unless told.  A slope of
angle θ is the plane ``n·x = 0`` with ``n = (sin θ, 0, cos θ)``: it goes down along
``DOWNHILL(θ) = (cos θ, 0, −sin θ)``; a body resting flat on it is turned by θ about y.
"""

import math

import numpy as np

from rbd_ros.core.contact import ground_plane, Material, primitive_shape, StaticWorld
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.core.model import BodyModel
from rbd_ros.core.state import BodyState

G = 9.81
GRAVITY_W = (0.0, 0.0, -G)
STEPS_NS = [1_000_000, 10_000_000]
STEP_IDS = ['h1ms', 'h10ms']


def body(name, shape, dims, mass_kg=1.0, material=(0.5, 0.0), gravity_w=GRAVITY_W):
    """Return a :class:`WorldBody` of a uniform primitive, its inertia from the shape."""
    geometry = primitive_shape(shape, dims)
    model = BodyModel(mass_kg, geometry.mass_properties(mass_kg).inertia_b,
                      gravity_w=gravity_w)
    return WorldBody(name, model, geometry, Material(*material))


def slope_normal(theta_rad):
    return np.array([math.sin(theta_rad), 0.0, math.cos(theta_rad)])


def downhill(theta_rad):
    return np.array([math.cos(theta_rad), 0.0, -math.sin(theta_rad)])


def tilt_quat(theta_rad):
    """``q_wb`` turning the body by θ about y: its z axis becomes :func:`slope_normal`."""
    return np.array([math.cos(0.5 * theta_rad), 0.0, math.sin(0.5 * theta_rad), 0.0])


def ground(theta_rad=0.0, material=(0.5, 0.0)):
    return StaticWorld(ground_plane(slope_normal(theta_rad), 0.0, Material(*material)))


def world(bodies, states, static, h_ns, integrator='midpoint_cayley'):
    return WorldSimulator(bodies, states, static, integrator=integrator, timestep_ns=h_ns)


def on_slope(theta_rad, height_m, along_m=0.0, **state):
    """Return a state resting on the slope: COM ``height_m`` above it, ``along_m`` downhill."""
    position = height_m * slope_normal(theta_rad) + along_m * downhill(theta_rad)
    return BodyState(position_w=position, orientation_wb=tilt_quat(theta_rad), **state)


def steps(seconds, h_ns):
    """Return the whole number of steps in ``seconds`` (exact for the steps used)."""
    return round(seconds * 1e9 / h_ns)


def tilt_rad(state):
    """Angle between the body's z axis and the world's z axis."""
    return math.acos(min(1.0, float(state.rotation_wb()[2, 2])))


def kinetic_energy(sim):
    return sum(sim.body_state(i).kinetic_energy(b.model) for i, b in enumerate(sim.bodies))


def momentum_w(sim):
    return sum(b.model.mass_kg * sim.body_state(i).linear_velocity_w
               for i, b in enumerate(sim.bodies))
