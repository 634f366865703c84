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

"""Message conversions: quaternion order by field name, frames of twists, REP 105, time."""

import numpy as np
import pytest
from rbd_ros import conversions as conv
from rbd_ros.core import BodyState, rotations

# A generic state: rotated about a skew axis, moving and spinning.
Q_WB = rotations.quat_from_axis_angle([1.0, 2.0, 3.0], 0.7)
STATE = BodyState(position_w=(1.0, -2.0, 3.0), orientation_wb=Q_WB,
                  linear_velocity_w=(0.5, 0.25, -1.0), angular_velocity_b=(0.1, -0.2, 0.3),
                  time_ns=12_345_678_901)
R_WB = rotations.quat_to_matrix(Q_WB)


def xyz(v):
    return np.array([v.x, v.y, v.z])


def test_time_round_trip():
    for ns in (0, 1, 999_999_999, 1_000_000_000, 12_345_678_901, 2**62):
        msg = conv.time_to_msg(ns)
        assert 0 <= msg.nanosec < 1_000_000_000
        assert conv.time_from_msg(msg) == ns


def test_pose_uses_field_names_for_the_quaternion():
    msg = conv.state_to_pose(STATE, 'world')
    assert msg.header.frame_id == 'world'
    assert conv.time_from_msg(msg.header.stamp) == STATE.time_ns
    q = msg.pose.orientation
    assert (q.w, q.x, q.y, q.z) == tuple(Q_WB)
    assert np.array_equal(xyz(msg.pose.position), STATE.position_w)


def test_plain_reordering_helpers():
    assert conv.xyzw_to_wxyz([1, 2, 3, 4]) == (4, 1, 2, 3)
    assert conv.wxyz_to_xyzw((4, 1, 2, 3)) == (1, 2, 3, 4)


def test_twist_in_world_and_body_frames():
    world = conv.state_to_twist(STATE, 'world', 'world', 'base_link')
    body = conv.state_to_twist(STATE, 'body', 'world', 'base_link')
    assert world.header.frame_id == 'world' and body.header.frame_id == 'base_link'
    # Round-off of one 3x3 product: 1e-15 is a few ε of these O(1) values.
    np.testing.assert_allclose(xyz(world.twist.linear), STATE.linear_velocity_w, atol=0)
    np.testing.assert_allclose(xyz(world.twist.angular), R_WB @ STATE.angular_velocity_b,
                               atol=1e-15)
    np.testing.assert_allclose(xyz(body.twist.linear), R_WB.T @ STATE.linear_velocity_w,
                               atol=1e-15)
    np.testing.assert_allclose(xyz(body.twist.angular), STATE.angular_velocity_b, atol=0)
    with pytest.raises(ValueError):
        conv.state_to_twist(STATE, 'odom', 'world', 'base_link')


def test_odometry_follows_rep_105():
    msg = conv.state_to_odometry(STATE, 'world', 'base_link')
    assert msg.header.frame_id == 'world' and msg.child_frame_id == 'base_link'
    assert np.array_equal(xyz(msg.pose.pose.position), STATE.position_w)
    np.testing.assert_allclose(xyz(msg.twist.twist.linear), R_WB.T @ STATE.linear_velocity_w,
                               atol=1e-15)
    assert np.array_equal(xyz(msg.twist.twist.angular), STATE.angular_velocity_b)


def test_transform_world_to_body():
    msg = conv.state_to_transform(STATE, 'world', 'base_link')
    assert (msg.header.frame_id, msg.child_frame_id) == ('world', 'base_link')
    r = msg.transform.rotation
    assert (r.w, r.x, r.y, r.z) == tuple(Q_WB)
    assert np.array_equal(xyz(msg.transform.translation), STATE.position_w)


def test_wrench_round_trip():
    msg = conv.wrench_to_msg('base_link', (1.0, 2.0, 3.0), (4.0, 5.0, 6.0), stamp_ns=7)
    assert conv.wrench_from_msg(msg) == ('base_link', (1.0, 2.0, 3.0), (4.0, 5.0, 6.0))


def test_diagnostics_message():
    msg = conv.diagnostics_to_msg(5, 'n', 'base_link', 'warn', 'running',
                                  {'a': 0.1, 'b': 3, 'c': True})
    status = msg.status[0]
    assert status.level == status.WARN and status.hardware_id == 'base_link'
    assert {kv.key: kv.value for kv in status.values} == {'a': '0.1', 'b': '3', 'c': 'True'}
