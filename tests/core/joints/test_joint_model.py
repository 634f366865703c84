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

"""Joint model: validation messages and the joint coordinate readout per kind."""

import math

import numpy as np
import pytest

from rbd_ros.core.errors import ModelError
from rbd_ros.core.joints import (cone_angle, Joint, joint_position, joint_velocity,
                                 unwrap_angle)
from rbd_ros.core.rotations import quat_from_axis_angle, quat_multiply, quat_to_matrix

# Readouts are closed-form trigonometry of one quaternion: round-off of a few ulp of 1 rad/m.
TOL = 1e-12


@pytest.mark.parametrize('fields, message', [
    ({'kind': 'revolute', 'lower': 1.0, 'upper': 0.5},
     "joint 'j'.lower: 1.0 rad must be <= upper"),
    ({'kind': 'prismatic', 'lower': 0.2, 'upper': -0.2},
     "joint 'j'.lower: 0.2 m must be <= upper"),
    ({'kind': 'revolute', 'axis_b': (0.0, 0.0, 0.0)},
     "joint 'j'.axis_b: [0.0, 0.0, 0.0] has zero"),
    ({'kind': 'revolute', 'origin_child_b': (0.0, math.nan, 0.0)},
     "joint 'j'.origin_child_b: [0.0, nan, 0.0] m must be finite"),
    ({'kind': 'revolute', 'upper': math.inf}, "joint 'j'.upper: inf rad must be finite"),
    ({'kind': 'hinge'}, "joint 'j'.kind: 'hinge' is not one of"),
    ({'kind': 'universal', 'axis2_b': (0.0, 0.0, 1.0)}, "joint 'j'.axis2_b: [0.0, 0.0, 1.0] must"),
    ({'kind': 'spherical', 'cone_rad': -0.1}, "joint 'j'.cone_rad: -0.1 rad must be > 0"),
    ({'kind': 'spherical', 'cone_rad': 0.0}, "joint 'j'.cone_rad: 0.0 rad must be > 0"),
    ({'kind': 'spherical', 'cone_rad': 3.5}, "joint 'j'.cone_rad: 3.5 rad must be <= pi"),
    ({'kind': 'spherical', 'cone_rad': math.nan}, "joint 'j'.cone_rad: nan rad must be finite"),
    ({'kind': 'revolute', 'cone_rad': 0.5}, "joint 'j'.cone_rad: 0.5; only a spherical joint"),
    ({'kind': 'continuous', 'lower': 0.0}, "joint 'j'.lower: 0.0; a continuous joint has no"),
    ({'kind': 'revolute', 'effort_limit': -1.0}, "joint 'j'.effort_limit: -1.0 N m must be >= 0"),
])
def test_bad_joint_is_refused_with_one_line_naming_the_field(fields, message):
    with pytest.raises(ModelError) as err:
        Joint(name='j', parent=None, child=0, **fields)
    assert str(err.value).startswith(message), str(err.value)
    assert '\n' not in str(err.value)


def test_parent_equal_to_child_is_refused():
    with pytest.raises(ModelError, match=r"joint 'j'.parent: 1 must be None"):
        Joint(name='j', kind='fixed', parent=1, child=1)


def test_revolute_readout_angle_and_rate():
    axis = np.array([0.0, 1.0, 1.0]) / math.sqrt(2.0)
    joint = Joint(name='j', kind='revolute', parent=0, child=1, axis_b=axis, lower=-1, upper=1)
    q_wp = quat_from_axis_angle([1.0, 0.0, 0.0], 0.3)
    q_wc = quat_multiply(q_wp, quat_from_axis_angle(axis, 0.7))
    got = joint_position(joint, np.zeros(3), q_wp, np.ones(3), q_wc)
    assert abs(got[0] - 0.7) < TOL
    rate = joint_velocity(joint, np.zeros(3), q_wp, np.zeros(3), np.zeros(3), np.ones(3), q_wc,
                          np.zeros(3), 2.0 * (quat_to_matrix(q_wp) @ axis))
    assert abs(rate[0] - 2.0) < TOL


def test_continuous_is_not_wrapped_by_unwrap_angle():
    joint = Joint(name='c', kind='continuous', parent=None, child=0)
    running = 0.0
    for k in range(1, 40):  # 39 steps of 0.5 rad: 19.5 rad, three turns past pi
        reading = joint_position(joint, None, None, np.zeros(3),
                                 quat_from_axis_angle([0, 0, 1], 0.5 * k))[0]
        assert -math.pi <= reading <= math.pi
        running = unwrap_angle(running, reading)
    assert abs(running - 19.5) < 1e-11  # 39 additions of a ~1e-16 error


def test_prismatic_readout_offset_along_axis():
    joint = Joint(name='p', kind='prismatic', parent=None, child=0, axis_b=(1.0, 0.0, 0.0),
                  origin_parent_b=(0.0, 0.0, 1.0), origin_child_b=(0.0, 0.0, 0.5))
    q = np.array([1.0, 0.0, 0.0, 0.0])
    got = joint_position(joint, None, None, np.array([0.25, 0.0, 0.5]), q)
    assert abs(got[0] - 0.25) < TOL
    rate = joint_velocity(joint, None, None, None, None, np.array([0.25, 0.0, 0.5]), q,
                          np.array([3.0, 0.0, 0.0]), np.zeros(3))
    assert abs(rate[0] - 3.0) < TOL


def test_spherical_universal_planar_fixed_readouts():
    q_wc = quat_from_axis_angle([0.0, 0.0, 1.0], 0.4)
    sph = Joint(name='s', kind='spherical', parent=None, child=0, cone_rad=1.0)
    assert np.allclose(joint_position(sph, None, None, np.zeros(3), q_wc), [0, 0, 0.4],
                       atol=TOL, rtol=0)
    uni = Joint(name='u', kind='universal', parent=None, child=0, axis_b=(1, 0, 0),
                axis2_b=(0, 1, 0))
    q = quat_multiply(quat_from_axis_angle([1, 0, 0], 0.3), quat_from_axis_angle([0, 1, 0], -0.5))
    assert np.allclose(joint_position(uni, None, None, np.zeros(3), q), [0.3, -0.5],
                       atol=TOL, rtol=0)
    pla = Joint(name='pl', kind='planar', parent=None, child=0, axis_b=(0, 0, 1),
                axis2_b=(1, 0, 0))
    assert np.allclose(joint_position(pla, None, None, np.array([0.1, -0.2, 0.0]), q_wc),
                       [0.1, -0.2, 0.4], atol=TOL, rtol=0)
    fix = Joint(name='f', kind='fixed', parent=None, child=0)
    assert joint_position(fix, None, None, np.zeros(3), q_wc).shape == (0,)


def test_cone_angle_is_the_swing_off_the_axis_and_ignores_the_twist():
    # axis_b = z; a swing of 0.7 rad about x then any twist about the child's axis: the
    # child's axis is 0.7 rad off the parent's. A parent turned with the child reads 0.
    sph = Joint(name='s', kind='spherical', parent=0, child=1, cone_rad=1.0)
    swing = quat_from_axis_angle([1.0, 0.0, 0.0], 0.7)
    q_wc = quat_multiply(swing, quat_from_axis_angle([0.0, 0.0, 1.0], 2.0))
    assert abs(cone_angle(sph, None, q_wc) - 0.7) <= TOL
    assert abs(cone_angle(sph, swing, swing)) <= TOL
    # q_rest carries the axis into the child: at the rest pose the angle is 0
    rest = quat_from_axis_angle([0.0, 1.0, 0.0], 0.4)
    tilted = Joint(name='t', kind='spherical', parent=None, child=0, q_rest=rest)
    assert abs(cone_angle(tilted, None, rest)) <= TOL
    assert abs(cone_angle(tilted, None, quat_multiply(quat_from_axis_angle(
        [0.0, 1.0, 0.0], 3.0), rest)) - 3.0) <= TOL
