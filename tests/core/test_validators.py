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
One validator family (:mod:`rbd_ros.core.errors`) for every scalar and vector of the core.

The same rule gives the same message wherever it is applied (name, value, unit, rule), and the
same inputs are accepted everywhere: numpy scalars as well as Python numbers, never booleans.
"""

import math

import numpy as np
import pytest

from rbd_ros.core import AppliedWrench, BodyModel, BodyState, ModelError, Simulator, Spring
from rbd_ros.core.errors import ConfigError, InputError
from rbd_ros.core.inertia import box, solid_sphere

EYE = np.eye(3)


@pytest.mark.parametrize('make, error, message', [
    (lambda: BodyModel(1.0, EYE, linear_damping_per_s=math.nan), ModelError,
     'linear_damping_per_s: nan 1/s must be finite'),
    (lambda: BodyModel(1.0, EYE, angular_damping_per_s=-0.5), ModelError,
     'angular_damping_per_s: -0.5 1/s must be >= 0'),
    (lambda: BodyModel(-2.0, EYE), ModelError, 'mass_kg: -2.0 kg must be > 0'),
    (lambda: BodyModel(1.0, EYE, gravity_w=(0.0, math.inf, 0.0)), ModelError,
     'gravity_w: [0.0, inf, 0.0] m/s² must be finite'),
    (lambda: Spring((0, 0, 0), (0, 0, 0), -1.0), InputError,
     'stiffness_n_per_m: -1.0 N/m must be >= 0'),
    (lambda: Spring((0, 0, 0), (0, 0, 0), 1.0, math.nan), InputError,
     'damping_n_s_per_m: nan N·s/m must be finite'),
    (lambda: Spring((0, 0, 0), (0, 0, 0), True), InputError,
     'stiffness_n_per_m: True is not a number in N/m'),
    (lambda: AppliedWrench(force=(math.nan, 0, 0)), InputError,
     'force: [nan, 0.0, 0.0] N must be finite'),
    (lambda: BodyState(linear_velocity_w=(1.0, 2.0)), InputError,
     'linear_velocity_w: expected 3 numbers in m/s, got (1.0, 2.0)'),
    (lambda: BodyState(time_ns=1.5), InputError, 'time_ns: 1.5 ns must be an integer'),
    (lambda: Simulator(BodyModel(1.0, EYE), timestep_ns=0), ConfigError,
     'timestep_ns: 0 ns must be a positive integer'),
    (lambda: solid_sphere(1.0, -0.1), ModelError, 'radius_m: -0.1 m must be > 0'),
    (lambda: box(1.0, (0.1, math.nan, 0.1)), ModelError,
     'size_m: [0.1, nan, 0.1] m must be finite'),
])
def test_one_message_per_rule(make, error, message):
    with pytest.raises(error) as info:
        make()
    assert str(info.value) == message


def test_numpy_scalars_are_accepted_everywhere():
    # The loads and the damping once took only Python int/float, the inertia any real number.
    spring = Spring((0, 0, 0), (1, 0, 0), np.float32(2.0), np.int64(1), np.float64(0.5))
    assert (spring.stiffness_n_per_m, spring.damping_n_s_per_m, spring.rest_length_m) == \
        (2.0, 1.0, 0.5)
    assert type(spring.stiffness_n_per_m) is float
    model = BodyModel(np.float32(2.0), EYE, linear_damping_per_s=np.float32(0.25),
                      angular_damping_per_s=np.array(0.5))
    assert (model.mass_kg, model.linear_damping_per_s, model.angular_damping_per_s) == \
        (2.0, 0.25, 0.5)
    assert BodyState(time_ns=np.int64(7)).time_ns == 7


def test_errors_carry_their_field_value_unit_and_detail():
    """What an error is about travels as attributes: a re-labeller reads them, not the text."""
    from rbd_ros.core.contact.world import check_overlaps, ground_plane, StaticWorld
    from rbd_ros.core.contact.shapes import primitive_shape
    from rbd_ros.sim.config import NodeConfig
    with pytest.raises(ModelError) as caught:
        BodyModel(-2.0, EYE)
    exc = caught.value
    assert (exc.field, exc.value, exc.unit) == ('mass_kg', -2.0, 'kg')
    assert exc.detail == '-2.0 kg must be > 0'
    assert str(exc) == f'{exc.field}: {exc.detail}'
    renamed = exc.renamed('bodies.a.mass_kg')
    assert type(renamed) is ModelError and renamed.field == 'bodies.a.mass_kg'
    assert str(renamed) == 'bodies.a.mass_kg: -2.0 kg must be > 0'
    box = primitive_shape('box', (1.0, 1.0, 1.0))
    with pytest.raises(ModelError) as caught:
        check_overlaps([('b', box, (0.0, 0.0, 0.0), (1.0, 0.0, 0.0, 0.0))],
                       StaticWorld(ground=ground_plane()))
    exc = caught.value
    assert exc.field == 'bodies.b.position_w' and exc.unit == 'm'
    assert exc.rule.startswith('puts the body 0.5 m deep inside ground'), exc.rule
    # The parameter layer names the parameter from the attributes, for a world body too.
    with pytest.raises(ModelError) as caught:
        NodeConfig.from_parameters({'body_names': ['a'], 'bodies.a.mass_kg': 0.0})
    exc = caught.value
    assert (exc.field, exc.value, exc.unit) == ('bodies.a.mass_kg', 0.0, 'kg'), vars(exc)
    assert str(exc) == 'parameter bodies.a.mass_kg = 0.0 kg: must be > 0'
