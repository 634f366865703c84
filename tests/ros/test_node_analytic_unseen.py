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
Closed forms the other tests do not use, through the real node, read from its own recording.

Each node runs as a user runs it (a params file, ``real_time_factor: 0``, ``duration_s``,
``record_path``); nothing is read through DDS, only the bag the node wrote:

- an incline made by tilting gravity by θ = 20° over a flat ground (no ramp obstacle): a box
  at μ = 0.2 < tan θ slides at ``g (sin θ − μ cos θ)``, one at μ = 0.5 > tan θ sticks, and a
  ball rolls at ``5/7 g sin θ`` (a pair's μ is ``sqrt(μ_body μ_ground)``);
- a URDF double pendulum (two uniform rods on continuous joints) keeps the energy its initial
  joint positions and velocities give, from ``joint_states``;
- a chain of three balls hanging from the world by a spherical, a revolute and a fixed joint
  reads the weight below each joint, ``(m_a + m_b + m_c) g``, ``(m_b + m_c) g``, ``m_c g``,
  in ``joint_wrenches``; and a joint point 1e300 m away is refused in one line (exit 2).
"""

import math

from conftest import NodeProcess
import numpy as np
import pytest
from rbd_ros.bag.recording import open_bag

G = 9.81
THETA = math.radians(20.0)
# A box in the tilted gravity: the ground's normal force is m g cos θ, gravity's pull along it
# m g sin θ, so the sliding acceleration is constant and kick-drift-kick integrates it
# exactly (doc/parameters.md): the travel is a t²/2 to round-off (measured 0 and 2e-14
# relative); 1e-9 leaves room for the sum of 1000 steps' round-off, and a first-order error
# of a 1 ms step would be ~1e-3.
SLIDE_TOL = 1e-9
# The ball's rolling acceleration with spin: 2e-14 relative measured; the same bound.
ROLL_TOL = 1e-9
# The double pendulum's energy: midpoint_cayley is second order and symplectic, its energy
# error a bounded oscillation of order (ω h)²/24 with ω up to ~5 rad/s here: 1e-6 of the
# largest kinetic energy (measured 3.4e-10).
ENERGY_TOL = 1e-6
# A chain at rest: the joint forces are the weights below, sums of three products (1.4e-16
# relative measured): 1e-12.
CHAIN_TOL = 1e-12


def _run(tmp_path, name, params, duration_s):
    """Run the node on ``params`` for ``duration_s`` of sim time; return its bag's path."""
    bag = tmp_path / name
    params = dict(params, duration_s=duration_s, real_time_factor=0.0, record_path=str(bag))
    node = NodeProcess(tmp_path, params, namespace=True)
    try:
        assert node.wait(900) == 0, node.stderr  # a first start may compile the kernels
    finally:
        node.stop()
    return bag


def _messages(bag, suffix):
    """Return ``[(log time s, message)]`` of the bag's one topic ending in ``suffix``."""
    reader = open_bag(bag)
    (topic,) = [t for t in reader.topics if t.endswith(suffix)]
    return [(raw.log_time_ns * 1e-9, msg) for raw, msg in reader.decoded_messages([topic])]


def test_tilted_gravity_incline_slides_sticks_and_rolls(tmp_path):
    gravity = [G * math.sin(THETA), 0.0, -G * math.cos(THETA)]
    params = {'gravity': gravity, 'ground.enabled': True, 'ground.friction': 1.0,
              'body_names': ['slider', 'sticker', 'ball'],
              'bodies.ball.shape': 'sphere', 'bodies.ball.dimensions_m': [0.1],
              'bodies.ball.friction': 0.25,  # pair 0.5 >= 2/7 tan θ: rolls without slip
              'bodies.ball.initial_position': [0.0, -1.0, 0.1],
              'publish_rate_hz': 100.0}
    for name, mu, y in (('slider', 0.2, 0.0), ('sticker', 0.5, 1.0)):
        params[f'bodies.{name}.shape'] = 'box'
        params[f'bodies.{name}.dimensions_m'] = [0.2, 0.2, 0.2]  # not shared: no YAML alias
        params[f'bodies.{name}.friction'] = mu * mu  # the pair's sqrt(mu_body * 1.0) = mu
        params[f'bodies.{name}.initial_position'] = [0.0, y, 0.1]
    bag = _run(tmp_path, 'incline', params, 1.0)
    accelerations = {'slider': G * (math.sin(THETA) - 0.2 * math.cos(THETA)),
                     'sticker': 0.0, 'ball': 5.0 / 7.0 * G * math.sin(THETA)}
    for name, accel in accelerations.items():
        samples = _messages(bag, f'/{name}/pose')
        assert len(samples) == 101 and samples[-1][0] == pytest.approx(1.0, abs=1e-12)
        start = samples[0][1].pose.position
        for t, msg in samples:
            p = msg.pose.position
            expected = 0.5 * accel * t * t
            if accel:
                tol = SLIDE_TOL if name == 'slider' else ROLL_TOL
                assert p.x - start.x == pytest.approx(expected, rel=tol), (name, t)
            else:
                assert abs(p.x - start.x) < 1e-12, (name, t, p.x)
            assert abs(p.z - start.z) < 1e-12, (name, t, p.z)  # on the ground, not in it


def _rod(parent, name, mass_kg, length_m, origin_z):
    """Return a uniform rod ``name`` (its COM half way down) on a continuous joint about y."""
    i_across = mass_kg * length_m ** 2 / 12.0
    return (f'<joint name="j_{name}" type="continuous"><parent link="{parent}"/>'
            f'<child link="{name}"/><origin xyz="0 0 {origin_z!r}"/><axis xyz="0 1 0"/>'
            f'</joint><link name="{name}"><inertial><origin xyz="0 0 {-length_m / 2.0!r}"/>'
            f'<mass value="{mass_kg!r}"/><inertia ixx="{i_across!r}" iyy="{i_across!r}" '
            'izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>')


# Two rods hanging from a pivot 3 m up: joints j_l1 (2 kg, 1 m) and j_l2 (1 kg, 0.7 m).
DOUBLE_PENDULUM = ('<?xml version="1.0"?>\n<robot name="dp"><link name="world"/>'
                   + _rod('world', 'l1', 2.0, 1.0, 3.0) + _rod('l1', 'l2', 1.0, 0.7, -1.0)
                   + '</robot>\n')


def _double_pendulum_energy(q, qd):
    """
    Return ``(E, T)`` of the two rods: m1 = 2 kg, 1 m; m2 = 1 kg, 0.7 m; pivot fixed.

    A turn by ``a`` about +y carries the rod's direction (0, 0, −1) to (−sin a, 0, −cos a);
    the second rod's absolute angle is ``q1 + q2``.
    """
    m1, l1, c1, i1 = 2.0, 1.0, 0.5, 2.0 / 12.0
    m2, c2, i2 = 1.0, 0.35, 0.49 / 12.0
    a1, a2, w1, w2 = q[0], q[0] + q[1], qd[0], qd[0] + qd[1]
    vx2 = -l1 * math.cos(a1) * w1 - c2 * math.cos(a2) * w2
    vz2 = l1 * math.sin(a1) * w1 + c2 * math.sin(a2) * w2
    kinetic = (0.5 * m1 * (c1 * w1) ** 2 + 0.5 * i1 * w1 ** 2
               + 0.5 * m2 * (vx2 ** 2 + vz2 ** 2) + 0.5 * i2 * w2 ** 2)
    potential = G * (-m1 * c1 * math.cos(a1) + m2 * (-l1 * math.cos(a1) - c2 * math.cos(a2)))
    return kinetic + potential, kinetic


def test_urdf_double_pendulum_keeps_its_energy(tmp_path):
    urdf = tmp_path / 'double_pendulum.urdf'
    urdf.write_text(DOUBLE_PENDULUM)
    q0, qd0 = [1.2, -0.8], [0.0, 1.5]
    bag = _run(tmp_path, 'double_pendulum', {
        'robot_names': ['dp'], 'robots.dp.urdf_path': str(urdf),
        'robots.dp.initial_joint_positions': q0, 'robots.dp.initial_joint_velocities': qd0,
        'gravity': [0.0, 0.0, -G], 'publish_rate_hz': 100.0}, 4.0)
    samples = _messages(bag, '/dp/joint_states')
    assert len(samples) == 401
    e0, _ = _double_pendulum_energy(q0, qd0)
    energies = [_double_pendulum_energy(list(m.position), list(m.velocity)) for _, m in samples]
    kinetic_max = max(k for _, k in energies)
    assert kinetic_max > 10.0  # it swings (12.9 J at most)
    drift = max(abs(e - e0) for e, _ in energies)
    assert drift <= ENERGY_TOL * kinetic_max, drift


CHAIN = {'gravity': [0.0, 0.0, -G], 'body_names': ['a', 'b', 'c'],
         'joint_names': ['top', 'mid', 'bot'],
         'joints.top.type': 'spherical', 'joints.top.child': 'a',
         'joints.top.position': [0.0, 0.0, 1.15],
         'joints.mid.type': 'revolute', 'joints.mid.parent': 'a', 'joints.mid.child': 'b',
         'joints.mid.position': [0.0, 0.0, 0.85], 'joints.mid.axis': [1.0, 0.0, 0.0],
         'joints.bot.type': 'fixed', 'joints.bot.parent': 'b', 'joints.bot.child': 'c',
         'joints.bot.position': [0.0, 0.0, 0.55], 'publish_rate_hz': 100.0}
for _body, _mass, _z in (('a', 1.0, 1.0), ('b', 2.0, 0.7), ('c', 3.0, 0.4)):
    CHAIN.update({f'bodies.{_body}.mass_kg': _mass, f'bodies.{_body}.shape': 'sphere',
                  f'bodies.{_body}.dimensions_m': [0.1],
                  f'bodies.{_body}.initial_position': [0.0, 0.0, _z]})


def test_hanging_chain_of_three_joint_kinds_carries_the_weight_below(tmp_path):
    bag = _run(tmp_path, 'chain', CHAIN, 0.5)
    samples = _messages(bag, '/joint_wrenches')
    assert len(samples) == 51
    below = {'top': 6.0 * G, 'mid': 5.0 * G, 'bot': 3.0 * G}
    for t, msg in samples[1:]:  # NaN at t = 0
        assert list(msg.joint_names) == ['top', 'mid', 'bot']
        for name, wrench in zip(msg.joint_names, msg.wrench):
            force = np.array([wrench.force.x, wrench.force.y, wrench.force.z])
            torque = np.array([wrench.torque.x, wrench.torque.y, wrench.torque.z])
            # the chain does not turn: each child's frame is the world's, the force straight up
            np.testing.assert_allclose(force, [0.0, 0.0, below[name]], rtol=0,
                                       atol=CHAIN_TOL * below[name], err_msg=f'{name} {t}')
            assert np.abs(torque).max() <= CHAIN_TOL * below[name], (name, t, torque)


def test_a_joint_point_far_away_stops_the_node_with_one_line(tmp_path):
    node = NodeProcess(tmp_path, dict(CHAIN, **{'joints.mid.position': [1e300, 0.0, 0.85]}))
    try:
        assert node.wait(120) == 2, node.stderr
    finally:
        node.stop()
    lines = [line for line in node.stderr.splitlines() if line.strip()]
    assert lines == ['rigid_body_node: parameter joints.mid.position = [1e+300, 0.0, 0.85] m: '
                     'every component must be within ±1e+07 m (float64 coordinates keep '
                     'sub-micrometre resolution there)'], lines
