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
The contact step on threads (``contact.parallel``) is the serial step, bit for bit.

A world of many islands (a column, a grid of boxes dropped, a striker sliding into the
column, two balls that collide and bounce apart, a box landing on another) is stepped with
``threads`` 1, 2 and 3, and every state, contact-wrench and contact-row bit and the solve
counters must be the same at every step; the parallel path must have been taken for most
calls (else the comparison would be of the serial step with itself).
"""

import os

from contact_scenes import body, ground, steps
import numpy as np
import pytest
from rbd_ros.core.contact.simulator import WorldSimulator
from rbd_ros.core.errors import ConfigError
from rbd_ros.core.joints.model import Joint
from rbd_ros.core.loads import Spring
from rbd_ros.core.state import BodyState

SIDE_M = 0.2


def _scene():
    """Return ``(bodies, states, index of the striker, of the column's base, of the balls)``."""
    bodies, states = [], []

    def add(name, shape, dims, position, velocity=(0.0, 0.0, 0.0), omega=(0.0, 0.0, 0.0),
            material=(0.5, 0.0)):
        bodies.append(body(name, shape, dims, material=material))
        states.append(BodyState(position_w=position, linear_velocity_w=velocity,
                                angular_velocity_b=omega))
        return len(bodies) - 1

    base = add('c0', 'box', [SIDE_M] * 3, (0.0, 0.0, 0.1))
    for i in (1, 2):
        add(f'c{i}', 'box', [SIDE_M] * 3, (0.0, 0.0, SIDE_M * (i + 0.5)))
    for i in range(15):   # dropped from different heights, spinning a little
        add(f'g{i}', 'box', [SIDE_M] * 3, (2.0 + 0.5 * (i % 5), 0.5 * (i // 5), 0.12 + 0.01 * i),
            omega=(0.0, 0.0, 0.5 * (i % 3)))
    # 0.8 m from the column at 3 m/s, mu 0.5: it reaches the column after ~0.36 s.
    striker = add('striker', 'box', [SIDE_M] * 3, (-1.0, 0.0, 0.1), velocity=(3.0, 0.0, 0.0))
    # Two balls 0.4 m apart closing at 4 m/s, restitution 0.9: they meet and part.
    balls = (add('ball0', 'sphere', [0.1], (0.0, 2.0, 0.1), velocity=(2.0, 0.0, 0.0),
                 material=(0.5, 0.9)),
             add('ball1', 'sphere', [0.1], (0.6, 2.0, 0.1), velocity=(-2.0, 0.0, 0.0),
                 material=(0.5, 0.9)))
    add('low', 'box', [SIDE_M] * 3, (-1.0, 2.0, 0.1))
    add('high', 'box', [SIDE_M] * 3, (-1.02, 2.0, 0.5))   # lands on 'low'
    return bodies, states, striker, base, balls


def _world(threads, h_ns=1_000_000, integrator='midpoint_cayley'):
    bodies, states, *_ = _scene()
    return WorldSimulator(bodies, states, ground(), integrator=integrator, timestep_ns=h_ns,
                          threads=threads)


def _bits(a):
    return np.ascontiguousarray(a).view(np.uint64)


def _snapshot(sim):
    c = sim.contacts
    return (sim.arrays[0].copy(), sim.contact_wrench_w,
            np.column_stack([c.body_a, c.body_b, c.stage]),
            np.column_stack([c.point_w, c.normal_w, c.impulse_w]), sim.solve_stats())


@pytest.mark.parametrize('h_ns, integrator', [(1_000_000, 'midpoint_cayley'),
                                              (10_000_000, 'midpoint_cayley'),
                                              (1_000_000, 'symplectic_euler_quat_exp')])
def test_the_parallel_step_is_the_serial_step_bit_for_bit(h_ns, integrator):
    sims = {t: _world(t, h_ns, integrator) for t in (1, 2, 3)}
    assert sims[1]._parallel is None and sims[2].threads == 2
    _, _, striker, base, balls = _scene()
    count = steps(0.8, h_ns)
    touched_column = False
    balls_touched = False
    k = 0
    while k < count:
        chunk = 1 if k % 7 else 3   # calls of one step and of several
        for sim in sims.values():
            sim.step(chunk)
        k += chunk
        want = _snapshot(sims[1])
        for t in (2, 3):
            got = _snapshot(sims[t])
            for name, a, b in zip(('state', 'wrench', 'pairs', 'rows'), got[:4], want[:4]):
                assert a.shape == b.shape and np.array_equal(_bits(a), _bits(b)), (
                    f'threads {t}: {name} differs at step {k}')
            assert got[4] == want[4], f'threads {t}: solve counters differ at step {k}'
        pairs = want[2]
        touched_column |= bool(np.any((pairs[:, 0] == base) & (pairs[:, 1] == striker)))
        balls_touched |= bool(np.any((pairs[:, 0] == balls[0]) & (pairs[:, 1] == balls[1])))
    # The islands met and parted: the striker reached the column, the balls had a contact and
    # then flew apart.
    x = sims[1].arrays[0]
    assert touched_column and balls_touched
    assert np.linalg.norm(x[0:3, balls[0]] - x[0:3, balls[1]]) > 0.5
    # Most calls were stepped in parts (a failed check falls back to the serial step).
    for t in (2, 3):
        par = sims[t]._parallel
        assert par.calls_parallel > 0.8 * (par.calls_parallel + par.calls_serial), (
            t, par.calls_parallel, par.calls_serial)


def test_a_call_in_which_two_parts_meet_is_stepped_again_serially():
    # A box at rest pulled by a stiff spring (1e3 N/m, 0.5 m: ~500 m/s²) into another 0.5 m
    # away within one call of 100 steps: the parts, made from the bodies at rest, are wrong
    # for that call; its check fails, and the call is stepped again serially from its start.
    bodies = [body(f'g{i}', 'box', [SIDE_M] * 3) for i in range(17)]
    states = [BodyState(position_w=(1.0 * (i % 4), 1.0 * (i // 4), 0.1)) for i in range(16)]
    states.append(BodyState(position_w=(-0.5, 0.0, 0.1)))
    sims = [WorldSimulator(bodies, states, ground(), threads=t) for t in (1, 2)]
    for sim in sims:
        sim.step(5)
        sim.set_body_loads(16, springs=[Spring((0.0, 0.0, 0.0), (0.0, 0.0, 0.1), 1e3, 0.0)])
    for k in range(4):
        for sim in sims:
            sim.step(100)
        assert np.array_equal(_bits(sims[0].arrays[0]), _bits(sims[1].arrays[0])), k
        assert np.array_equal(_bits(sims[0].contact_wrench_w), _bits(sims[1].contact_wrench_w))
    assert sims[1]._parallel.misses >= 1
    assert abs(sims[0].contact_wrench_w[0, 0]) > 1.0   # the pulled box pushes on g0


def test_a_world_with_joints_steps_on_one_thread_the_same():
    # A jointed world's stages are one group (joint visits alternate with sweeps of every
    # patch): it is stepped serially whatever ``threads`` says, to the same bits.
    bodies, states, *_ = _scene()
    hinge = Joint('hinge', 'revolute', 3, 4, origin_parent_b=(0.25, 0.0, 0.0),
                  origin_child_b=(-0.25, 0.0, 0.0), axis_b=(0.0, 1.0, 0.0))
    one, two = (WorldSimulator(bodies, states, ground(), joints=[hinge], threads=t)
                for t in (1, 2))
    assert two.threads == 2 and two._parallel is None
    for _ in range(20):
        one.step(5)
        two.step(5)
        assert np.array_equal(_bits(one.arrays[0]), _bits(two.arrays[0]))


@pytest.mark.parametrize('value', [0, -1, 1.5, 'two', True])
def test_a_bad_thread_count_is_refused_naming_it(value):
    bodies, states, *_ = _scene()
    with pytest.raises(ConfigError, match=r'^threads') as info:
        WorldSimulator(bodies, states, ground(), threads=value)
    assert '\n' not in str(info.value)


def _world_params(**extra):
    params = {'ground.enabled': True, 'body_names': ['a', 'b'], 'bodies.a.shape': 'box',
              'bodies.a.dimensions_m': [0.2, 0.2, 0.2], 'bodies.a.initial_position':
              [0.0, 0.0, 0.1], 'bodies.b.shape': 'box', 'bodies.b.dimensions_m':
              [0.2, 0.2, 0.2], 'bodies.b.initial_position': [1.0, 0.0, 0.1]}
    params.update(extra)
    return params


def test_the_threads_parameter_reaches_the_world():
    from rbd_ros.sim.build import make_simulator
    from rbd_ros.sim.config import NodeConfig
    sim = make_simulator(NodeConfig.from_parameters(_world_params()))
    assert sim.threads == len(os.sched_getaffinity(0))   # the default: the CPUs we may use
    assert make_simulator(NodeConfig.from_parameters(_world_params(threads=3))).threads == 3


@pytest.mark.parametrize('value, rule', [(0, 'must be >= 1'), (-2, 'must be >= 1'),
                                         (1.5, 'must be an integer'),
                                         (2000, 'must be >= 1 and <= 1024')])
def test_a_bad_threads_parameter_is_refused_in_one_line(value, rule):
    from rbd_ros.sim.config import NodeConfig
    with pytest.raises(ConfigError) as info:
        NodeConfig.from_parameters(_world_params(threads=value))
    assert str(info.value) == f'parameter threads = {value}: {rule}'
