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
No input crashes the compiled step: extreme finite values end finite or in NonFiniteError.

The kernels follow numpy's float semantics (``error_model='numpy'``, see
:mod:`rbd_ros.core.jitcache`): a division by zero gives ±inf or nan, and the step's finiteness
check turns that into :class:`NonFiniteError` with the world left at its last finite state.
numba's default error model raised ``ZeroDivisionError`` out of the middle of the contact step
instead (a drag anchor at (1e300, 1e300, 0) on the bottom box of a stack did it; the node died).

Every input kind the node feeds the core is driven with the issue's values and a seeded fuzz
of extreme finite ones (±1e300, ±1e16, the largest double, denormals, zero): a wrench (force,
couple, application point), a drag (the spring's world anchor, stiffness, damping), a click
(the spring's body point), the initial state and the body's parameters. Each case ends in one
of three ways and no other: the values are refused when the value is built (an
:class:`RbdError`), the step is finite, or it raises :class:`NonFiniteError` leaving every
body exactly at the state before it (compared bit for bit).
"""

import math

from contact_scenes import body, ground, world
import numpy as np
import pytest
from rbd_ros.core.contact import primitive_shape
from rbd_ros.core.contact.simulator import WorldBody
from rbd_ros.core.errors import NonFiniteError, RbdError
from rbd_ros.core.loads import AppliedWrench, Spring
from rbd_ros.core.model import BodyModel
from rbd_ros.core.simulator import Simulator
from rbd_ros.core.state import BodyState

#: Finite values at the edges of float64: huge, past where squares overflow (1e154), past
#: where a float has no fraction (1e16), the largest double, denormals and zero.
EXTREMES = (1e300, -1e300, 1.7976931348623157e308, -1.7976931348623157e308, 1e154, -1e154,
            1e16, -1e16, 5e-324, -5e-324, 1e-310, 2.2250738585072014e-308, 0.0)
SIDE_M = 0.2
#: Cases per input kind and world (seeded): enough to hit every component with every kind of
#: extreme several times, few enough for the test pass (a step of these worlds is ~0.1 ms).
CASES = 40
STEPS = 3


def stack():
    """Return the scene that crashed: three boxes in a column and a striker (stack.yaml)."""
    names = ('bottom', 'middle', 'top', 'striker')
    bodies = [body(n, 'box', [SIDE_M] * 3, mass_kg=2.0 if n == 'striker' else 1.0)
              for n in names]
    centres = ((0.0, 0.0, 0.1), (0.0, 0.0, 0.3), (0.0, 0.0, 0.5), (-0.8, 0.0, 0.1))
    return bodies, [BodyState(position_w=c) for c in centres]


def contact_world(bodies=None, states=None):
    default_bodies, default_states = stack()
    return world(bodies or default_bodies, states or default_states, ground(), 1_000_000)


def free_body(model=None, state=None):
    model = model or BodyModel(1.0, np.diag([0.1, 0.2, 0.3]) / 6.0)
    return Simulator(model, state or BodyState(), integrator='midpoint_cayley',
                     timestep_ns=1_000_000)


def states_of(sim):
    if isinstance(sim, Simulator):
        return np.concatenate([np.atleast_1d(v) for v in _fields(sim.state)])
    return np.concatenate([np.concatenate([np.atleast_1d(v) for v in _fields(sim.body_state(i))])
                           for i in range(sim.size)])


def _fields(state):
    return (state.position_w, state.orientation_wb, state.linear_velocity_w,
            state.angular_velocity_b)


def step_and_judge(sim):
    """Step ``sim`` a few times; return 'finite' or 'refused', asserting the state is kept."""
    for _ in range(STEPS):
        before = states_of(sim)
        try:
            sim.step(1)
        except NonFiniteError:
            after = states_of(sim)
            assert np.all(np.isfinite(after))
            assert np.array_equal(before, after)  # left at the last finite state, bit for bit
            return 'refused'
        assert np.all(np.isfinite(states_of(sim)))
    return 'finite'


def extreme_vector(rng):
    """Three components, each an extreme value or an ordinary one (so one axis can be huge)."""
    return [float(rng.choice(EXTREMES)) if rng.random() < 0.6 else float(rng.normal())
            for _ in range(3)]


def set_loads(sim, index, wrenches=(), springs=()):
    if isinstance(sim, Simulator):
        sim.set_loads(wrenches, springs)
    else:
        sim.set_body_loads(index, wrenches, springs)


def test_the_drag_that_crashed_a_stack_ends_in_non_finite_error_or_a_finite_step():
    # Issue 31's first case: bottom/drag to (1e300, 1e300, 0) and any (v, v, 0), v >= 1e16.
    for v in (1e300, 1e100, 1e16, 1e14):
        sim = contact_world()
        drag = Spring((0.0, 0.0, 0.0), (v, v, 0.0), 100.0, 20.0)
        sim.set_body_loads(0, springs=[drag])
        assert step_and_judge(sim) in ('finite', 'refused')


def test_a_click_far_away_then_near_ends_in_non_finite_error_or_a_finite_step():
    # /clicked_point (0, 0, 0.1) then (1e16, 1e16, 0): the spring's body point goes far away.
    sim = contact_world()
    sim.set_body_loads(0, springs=[Spring((0.0, 0.0, 0.0), (0.0, 0.0, 0.1), 100.0, 20.0)])
    assert step_and_judge(sim) == 'finite'
    sim.set_body_loads(0, springs=[Spring((1e16, 1e16, 0.0), (1e16, 1e16, 0.0), 100.0, 20.0)])
    assert step_and_judge(sim) in ('finite', 'refused')


def _wrench(rng):
    return AppliedWrench(extreme_vector(rng), extreme_vector(rng),
                         str(rng.choice(['world', 'body'])), extreme_vector(rng))


def _drag(rng):
    return Spring(rng.normal(size=3) * 0.1, extreme_vector(rng),
                  abs(float(rng.choice(EXTREMES))), abs(float(rng.choice(EXTREMES))))


def _click(rng):
    return Spring(extreme_vector(rng), extreme_vector(rng), 100.0, 20.0)


@pytest.mark.parametrize('where', ['contact', 'free'])
@pytest.mark.parametrize('kind, make', [('wrench', _wrench), ('drag', _drag),
                                        ('click', _click)])
def test_extreme_loads_never_crash_the_step(where, kind, make):
    rng = np.random.default_rng(31 + len(kind) + (where == 'free'))
    outcomes = {'finite': 0, 'refused': 0, 'invalid': 0}
    for _ in range(CASES):
        sim = contact_world() if where == 'contact' else free_body()
        try:
            load = make(rng)
        except RbdError:
            outcomes['invalid'] += 1
            continue
        index = int(rng.integers(0, sim.size))
        wrenches, springs = ([load], []) if kind == 'wrench' else ([], [load])
        set_loads(sim, index, wrenches, springs)
        outcomes[step_and_judge(sim)] += 1
    print(where, kind, outcomes)
    assert outcomes['finite'] + outcomes['refused'] > CASES // 2  # the fuzz reached the step


@pytest.mark.parametrize('where', ['contact', 'free'])
def test_extreme_initial_states_never_crash_the_step(where):
    rng = np.random.default_rng(7 if where == 'contact' else 8)
    outcomes = {'finite': 0, 'refused': 0, 'invalid': 0}
    for _ in range(CASES):
        quat = rng.normal(size=4)
        try:
            # In a world, a start far away or inside the floor is refused when it is built:
            # the body starts clear of the others and the velocities are extreme.
            position = extreme_vector(rng) if where == 'free' else (0.0, 2.0, 1.0)
            state = BodyState(position_w=position,
                              orientation_wb=quat / np.linalg.norm(quat),
                              linear_velocity_w=extreme_vector(rng),
                              angular_velocity_b=extreme_vector(rng))
            if where == 'free':
                sim = free_body(state=state)
            else:
                bodies, states = stack()
                states[int(rng.integers(0, len(states)))] = state
                sim = contact_world(bodies, states)  # a start inside the floor is refused
        except RbdError:
            outcomes['invalid'] += 1
            continue
        outcomes[step_and_judge(sim)] += 1
    print(where, outcomes)
    assert outcomes['finite'] + outcomes['refused'] > CASES // 2


@pytest.mark.parametrize('where', ['contact', 'free'])
def test_extreme_body_parameters_never_crash_the_step(where):
    rng = np.random.default_rng(11 if where == 'contact' else 12)
    outcomes = {'finite': 0, 'refused': 0, 'invalid': 0}
    for _ in range(CASES):
        # Shape dimensions are bounded where they are parsed (a 1e300 m box has no finite
        # inertia): the step sees ordinary boxes of extreme mass, gravity and damping.
        mass = abs(float(rng.choice(EXTREMES))) if rng.random() < 0.5 else 1.0
        try:
            geometry = primitive_shape('box', [SIDE_M] * 3)
            model = BodyModel(mass, geometry.mass_properties(mass).inertia_b,
                              gravity_w=extreme_vector(rng),
                              linear_damping_per_s=abs(float(rng.choice(EXTREMES))),
                              angular_damping_per_s=abs(float(rng.choice(EXTREMES))))
            if where == 'free':
                sim = free_body(model=model)
            else:
                bodies, states = stack()
                bodies[3] = WorldBody('striker', model, geometry, bodies[3].material)
                sim = contact_world(bodies, states)
        except RbdError:
            outcomes['invalid'] += 1
            continue
        outcomes[step_and_judge(sim)] += 1
    print(where, outcomes)
    assert outcomes['finite'] + outcomes['refused'] + outcomes['invalid'] == CASES
    assert outcomes['finite'] + outcomes['refused'] > 0


def test_a_division_by_zero_in_a_kernel_gives_inf_not_an_exception():
    # The compile option itself: the same kernels module, a float division by zero.
    from rbd_ros.core import jitcache

    @jitcache.kernel()
    def divide(a, b):
        return a / b

    assert divide(1.0, 0.0) == math.inf
    assert math.isnan(divide(0.0, 0.0))
