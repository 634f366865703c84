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

"""Output samples and message conversions: field order, frames, REP 105, time, CDR bytes."""

import time
import types

import numpy as np
import pytest
from rbd_ros.core import BodyState, rotations
from rbd_ros.msgs import conversions as conv
from rbd_ros.msgs import outputs
from rbd_ros.sim.config import NodeConfig, xyzw_to_wxyz
from rclpy.serialization import deserialize_message, serialize_message

# A generic state: rotated about a skew axis, moving and spinning.
Q_WB = rotations.quat_from_axis_angle([1.0, 2.0, 3.0], 0.7)
STATE = BodyState(position_w=(1.0, -2.0, 3.0), orientation_wb=Q_WB,
                  linear_velocity_w=(0.5, 0.25, -1.0), angular_velocity_b=(0.1, -0.2, 0.3),
                  time_ns=12_345_678_901)
R_WB = rotations.quat_to_matrix(Q_WB)


def builder(twist_frame='world', world='world', body='base_link', clock=True, tf=True,
            contact=True):
    return outputs.BodyOutputs(types.SimpleNamespace(
        world_frame=world, body_frame=body, twist_frame=twist_frame, publish_clock=clock,
        publish_tf=tf, contact=contact))


def xyz(v):
    return np.array([v.x, v.y, v.z])


def test_time_round_trip():
    for ns in (0, 1, 999_999_999, 1_000_000_000, 12_345_678_901, 2**62):
        msg = conv.time_to_msg(ns)
        assert 0 <= msg.nanosec < 1_000_000_000
        assert conv.time_from_msg(msg) == ns


def test_pose_uses_field_names_for_the_quaternion():
    msg = builder().message('pose', STATE)
    assert msg.header.frame_id == 'world'
    assert conv.time_from_msg(msg.header.stamp) == STATE.time_ns
    q = msg.pose.orientation
    assert (q.w, q.x, q.y, q.z) == tuple(Q_WB)
    assert np.array_equal(xyz(msg.pose.position), STATE.position_w)


def test_plain_reordering_helper():
    assert xyzw_to_wxyz([1, 2, 3, 4]) == (4, 1, 2, 3)


def test_twist_in_world_and_body_frames():
    world = builder('world').message('twist', STATE)
    body = builder('body').message('twist', STATE)
    assert world.header.frame_id == 'world' and body.header.frame_id == 'base_link'
    # Round-off of one 3x3 product: 1e-15 is a few ε of these O(1) values.
    np.testing.assert_allclose(xyz(world.twist.linear), STATE.linear_velocity_w, atol=0)
    np.testing.assert_allclose(xyz(world.twist.angular), R_WB @ STATE.angular_velocity_b,
                               atol=1e-15)
    np.testing.assert_allclose(xyz(body.twist.linear), R_WB.T @ STATE.linear_velocity_w,
                               atol=1e-15)
    np.testing.assert_allclose(xyz(body.twist.angular), STATE.angular_velocity_b, atol=0)
    with pytest.raises(ValueError, match='twist_frame'):
        builder('odom')


def test_odometry_follows_rep_105():
    msg = builder().message('odom', STATE)
    assert msg.header.frame_id == 'world' and msg.child_frame_id == 'base_link'
    assert np.array_equal(xyz(msg.pose.pose.position), STATE.position_w)
    np.testing.assert_allclose(xyz(msg.twist.twist.linear), R_WB.T @ STATE.linear_velocity_w,
                               atol=1e-15)
    assert np.array_equal(xyz(msg.twist.twist.angular), STATE.angular_velocity_b)


def test_transform_world_to_body():
    (msg,) = builder().message('tf', STATE).transforms
    assert (msg.header.frame_id, msg.child_frame_id) == ('world', 'base_link')
    r = msg.transform.rotation
    assert (r.w, r.x, r.y, r.z) == tuple(Q_WB)
    assert np.array_equal(xyz(msg.transform.translation), STATE.position_w)
    assert conv.time_from_msg(builder().message('clock', STATE).clock) == STATE.time_ns


def random_states(seed, count):
    rng = np.random.default_rng(seed)
    for _ in range(count):
        yield BodyState(rng.normal(size=3) * 10.0, rng.normal(size=4),
                        rng.normal(size=3) * 5.0, rng.normal(size=3) * 10.0 ** rng.uniform(-3, 3),
                        int(rng.integers(0, 2**40)))


def test_values_are_the_core_arithmetic_bit_for_bit():
    # The recorded reference: ω_w = state.angular_velocity_w() (quat_rotate) and
    # v_b = Rᵀ v_w summed left to right from state.rotation_wb() (quat_to_matrix). Equality of
    # the float64 bytes, no tolerance: replay compares bit for bit.
    world, body = builder('world'), builder('body')
    for state in random_states(1, 3000):
        r, v = state.rotation_wb(), state.linear_velocity_w
        v_b = [r[0, i] * v[0] + r[1, i] * v[1] + r[2, i] * v[2] for i in range(3)]
        twist_b = (*v_b, *state.angular_velocity_b)
        p, q, twist, odom_twist = world.values(state)
        assert np.array(twist).tobytes() == np.concatenate(
            (v, state.angular_velocity_w())).tobytes()
        assert np.array(odom_twist).tobytes() == np.array(twist_b).tobytes()
        assert np.array(p + q).tobytes() == np.concatenate(
            (state.position_w, state.orientation_wb)).tobytes()
        assert body.values(state)[2] == body.values(state)[3]
        assert np.array(body.values(state)[2]).tobytes() == np.array(twist_b).tobytes()


def test_column_values_equal_the_body_state_values():
    b = builder('body')
    for state in random_states(2, 500):
        column = np.concatenate((state.position_w, state.orientation_wb,
                                 state.linear_velocity_w, state.angular_velocity_b))
        assert b.column_values(column) == b.values(state)
    # Not unit to round-off: normalised as BodyState normalises it.
    column = np.array([1.0, 2.0, 3.0, 2.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0])
    assert b.column_values(column)[1] == [1.0, 0.0, 0.0, 0.0]
    assert b.column_values(column) == b.values(BodyState(
        column[0:3], column[3:7], column[7:10], column[10:13]))


@pytest.mark.parametrize('twist_frame', ['world', 'body'])
def test_cdr_bytes_are_rclpy_serialisations_of_the_messages(twist_frame):
    # Frame ids of every length mod 8 move the padding before the float64 fields. rclpy leaves
    # padding bytes uninitialised, so the bytes are compared through rclpy's deserialiser
    # (repr shows every float exactly, -0.0 included) and by length; ours pads with zeros.
    for n, state in enumerate(random_states(3, 64)):
        b = builder(twist_frame, world='w' * (n % 9), body='body'[:n % 5] + 'x' * (n % 3))
        wrench = (state.linear_velocity_w.tolist(), state.angular_velocity_b.tolist())
        samples = b.serialize(state.time_ns, b.values(state), wrench)
        assert [kind for kind, _ in samples] == list(b.kinds) == list(outputs.KINDS)
        for kind, data in samples:
            msg = b.message(kind, state, wrench)
            assert len(data) == len(serialize_message(msg))
            assert repr(deserialize_message(data, outputs.MESSAGE_TYPES[kind])) == repr(msg)


@pytest.mark.parametrize('params', [
    {'publish_clock': True},  # a single body: SampleBuilder's one-call path
    {'ground.enabled': True, 'initial_position': [0.0, 0.0, 1.0]},  # and with contact
    {'publish_clock': True, 'body_names': ['a'], 'bodies.a.initial_position': [0.0, 0.0, 1.0]},
])
def test_a_sample_is_the_rclpy_serialisation_of_its_messages(params):
    """Every kind of a whole sample (a single body, and a world of one named body)."""
    config = NodeConfig.from_parameters(params)
    sample = outputs.SampleBuilder(config)
    for state in random_states(4, 16):
        column = np.concatenate((state.position_w, state.orientation_wb,
                                 state.linear_velocity_w, state.angular_velocity_b))
        wrench = np.concatenate((state.linear_velocity_w, state.angular_velocity_b))
        data = dict(sample.serialize(state.time_ns, column.reshape(13, 1),
                                     wrench.reshape(1, 6) if config.contact else None))
        assert list(data) == list(sample.kinds)
        for kind in sample.kinds:
            if kind in ('tf', 'poses'):
                continue  # many bodies' messages: test_node_outputs reads them off DDS
            msg = sample.message(kind, state, (wrench[:3].tolist(), wrench[3:].tolist()))
            assert len(data[kind]) == len(serialize_message(msg)), kind
            assert repr(deserialize_message(data[kind], type(msg))) == repr(msg), kind


@pytest.mark.parametrize('twist_frame, ground', [('world', True), ('body', False)])
def test_a_world_sample_is_each_body_s_scalar_sample_bit_for_bit(twist_frame, ground):
    """
    A world's per-body messages, all bodies at once (BodiesBytes), are each body's own.

    Bit for bit against :meth:`BodyOutputs.serialize` of :meth:`BodyOutputs.list_values`
    (the scalar path, the reference bags' arithmetic); names of every length mod 8 move the
    padding; random states, some quaternions not unit to round-off (the scalar path's
    normalising branch); ``poses`` and ``/tf`` decode to those values.
    """
    names = ['b' * (1 + n % 9) + str(n) for n in range(23)]
    params = {'body_names': names, 'twist_frame': twist_frame, 'ground.enabled': ground}
    for i, name in enumerate(names):
        params[f'bodies.{name}.initial_position'] = [float(i), 0.0, 1.0]
    config = NodeConfig.from_parameters(params)
    sample = outputs.SampleBuilder(config)
    rng = np.random.default_rng(7)
    for time_ns in (0, 1_999_999_999, 12_345_678_901):
        columns = rng.normal(size=(13, len(names))) * 3.0
        columns[3:7] /= np.linalg.norm(columns[3:7], axis=0)
        columns[3:7, ::5] *= 1.5  # not unit: normalised by the scalar path
        wrenches = rng.normal(size=(len(names), 6))
        data = dict(sample.serialize(time_ns, columns, wrenches if config.contact else None))
        assert list(data) == list(sample.kinds)
        for i, (name, body) in enumerate(zip(names, sample.bodies)):
            values = body.list_values(columns[:, i].tolist())
            wrench = (wrenches[i, :3].tolist(), wrenches[i, 3:].tolist())
            for kind, expected in body.serialize(time_ns, values, wrench):
                assert data[f'{name}/{kind}'] == expected, (name, kind)
            poses = deserialize_message(data['poses'], outputs.type_of('poses')).poses[i]
            transform = deserialize_message(data['tf'], outputs.type_of('tf')).transforms[i]
            (px, py, pz), (qw, qx, qy, qz) = values[:2]
            for got in (poses.position, transform.transform.translation):
                assert (got.x, got.y, got.z) == (px, py, pz)
            for got in (poses.orientation, transform.transform.rotation):
                assert (got.x, got.y, got.z, got.w) == (qx, qy, qz, qw)
        wanted = {f'{names[3]}/odom', 'poses'}
        assert dict(sample.serialize(time_ns, columns, wrenches if config.contact else None,
                                     wanted=wanted)) == {k: data[k] for k in wanted}


def _padding(fmt):
    """Return the offsets of the padding bytes (``x``) of a ``struct`` format."""
    import struct
    pads, offset = [], 0
    for count, code in __import__('re').findall(r'(\d*)([a-zA-Z?])', fmt.lstrip('<')):
        size = (int(count) if count else 1) * (1 if code in 'xs' else struct.calcsize(code))
        if code == 'x':
            pads += range(offset, offset + size)
        offset += size
    return pads


@pytest.mark.parametrize('frames', [1, 8])
def test_poses_and_tf_are_rclpy_s_serialisations_with_odd_values(frames):
    """
    A world's ``poses`` and ``/tf`` (templates written at once) are rclpy's bytes of them.

    Every byte but the alignment padding (rclpy's serialiser leaves it uninitialised; ours are
    zeros) against ``serialize_message`` of the PoseArray and TFMessage built from each body's
    values; names of every length mod 8 move that padding; odd values: -0.0, huge, tiny
    (subnormal) and negative coordinates, a quaternion of -0.0 components, stamps of 0, of
    a whole second and just under one.
    """
    from geometry_msgs.msg import Pose, PoseArray, TransformStamped
    from tf2_msgs.msg import TFMessage
    names = ['b' * (frames * n % 9 + 1) + str(n) for n in range(11)]
    params = {'body_names': names, 'world_frame': 'w' * frames}
    for i, name in enumerate(names):
        params[f'bodies.{name}.initial_position'] = [float(i), 0.0, 1.0]
    sample = outputs.SampleBuilder(NodeConfig.from_parameters(params))
    columns = np.zeros((13, len(names)))
    columns[0:3] = np.array([[-0.0, 1e300, -5e-324], [1.5e-310, -1e308, 2.0 ** 70],
                             [np.pi, -0.0, 0.0]]).repeat(4, axis=1)[:, :len(names)]
    columns[0, 5:] = -np.arange(len(names) - 5) * 1e-17
    columns[3:7] = np.array([[1.0, 0.0, 0.0, 0.0], [-0.0, -0.0, -0.0, 1.0],
                             [0.5, -0.5, 0.5, -0.5]]).T.repeat(4, axis=1)[:, :len(names)]
    for time_ns in (0, 1_000_000_000, 1_999_999_999):
        data = dict(sample.serialize(time_ns, columns, np.zeros((len(names), 6))))
        stamp = conv.time_to_msg(time_ns)
        values = [body.list_values(columns[:, i].tolist()) for i, body in enumerate(
            sample.bodies)]
        poses = PoseArray(poses=[Pose() for _ in names])
        poses.header.stamp, poses.header.frame_id = stamp, 'w' * frames
        tf = TFMessage()
        for pose, name, ((px, py, pz), (qw, qx, qy, qz), _, _) in zip(poses.poses, names,
                                                                      values):
            pose.position.x, pose.position.y, pose.position.z = px, py, pz
            o = pose.orientation
            o.x, o.y, o.z, o.w = qx, qy, qz, qw
            t = TransformStamped(child_frame_id=name)
            t.header.stamp, t.header.frame_id = stamp, 'w' * frames
            t.transform.translation.x, t.transform.translation.y = px, py
            t.transform.translation.z = pz
            r = t.transform.rotation
            r.x, r.y, r.z, r.w = qx, qy, qz, qw
            tf.transforms.append(t)
        for kind, msg, packer in (('poses', poses, sample._poses), ('tf', tf, sample._tf)):
            expected, got = bytearray(serialize_message(msg)), bytearray(data[kind])
            assert len(got) == len(expected) == packer.size, kind
            for offset in _padding(packer.format):
                assert got[offset] == 0, (kind, offset)
                expected[offset] = 0
            assert got == expected, kind
            assert repr(deserialize_message(data[kind], type(msg))) == repr(msg), kind


def _two_link_urdf(root, joint):
    """Return a floating two-link robot's URDF, its root link and joint named as given."""
    return f"""<robot name="r">
  <link name="{root}"><inertial><origin xyz="0.1 0 0.05"/><mass value="2.0"/>
    <inertia ixx="0.02" ixy="0" ixz="0" iyy="0.03" iyz="0" izz="0.04"/></inertial></link>
  <joint name="{joint}" type="continuous"><parent link="{root}"/><child link="arm"/>
    <origin xyz="0.3 0 0"/><axis xyz="0 0 1"/></joint>
  <link name="arm"><inertial><origin xyz="0.25 0 0"/><mass value="1.0"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.02" iyz="0" izz="0.02"/></inertial></link>
  <joint name="tip_joint" type="fixed"><parent link="arm"/><child link="tip"/></joint>
  <link name="tip"/>
</robot>"""


@pytest.mark.parametrize('n', range(4))
def test_a_robot_sample_is_the_rclpy_serialisation_of_its_messages(n):
    """joint_states, odom and joint_wrenches: names of every length mod 8 move the padding."""
    from rbd_ros.sim.session import SimSession
    name = 'r' * (n + 1)
    config = NodeConfig.from_parameters({
        'robot_names': [name],
        f'robots.{name}.robot_description': _two_link_urdf('b' * (n + 1), 'j' * (2 * n + 1)),
        f'robots.{name}.initial_joint_velocities': [3.0],
        'gravity': [0.0, 0.0, -9.81], 'world_frame': 'w' * (3 * n + 1)})
    session = SimSession(config)
    session.paused = False
    sample = outputs.SampleBuilder(config)
    robot = sample.robots[0]
    assert robot.kinds == (f'{"r" * (n + 1)}/joint_states', f'{"r" * (n + 1)}/odom',
                           f'{"r" * (n + 1)}/joint_wrenches')
    for steps in (0, 1, 7):  # t = 0 (NaN wrenches) and two later samples
        session.advance(steps)
        data = dict(sample.serialize(session.time_ns, session.columns, None, session.simulator))
        for kind in robot.kinds:
            msg = sample.robot_message(kind, session.time_ns, session.simulator)
            assert len(data[kind]) == len(serialize_message(msg)), kind
            assert repr(deserialize_message(data[kind], type(msg))) == repr(msg), kind
        odom = deserialize_message(data[robot.odom_kind], outputs.type_of(robot.odom_kind))
        assert (odom.header.frame_id, odom.child_frame_id) == ('w' * (3 * n + 1), 'b' * (n + 1))


def test_kinds_follow_the_configuration():
    assert builder(clock=False, tf=False, contact=False).kinds == ('pose', 'twist', 'odom')
    assert builder(clock=False, tf=False).kinds == ('pose', 'twist', 'odom', 'contact_wrench')
    config = NodeConfig.from_parameters({'publish_clock': True})
    assert outputs.SampleBuilder(config, tf=False).kinds == ('pose', 'twist', 'odom', 'clock')
    assert outputs.sample_builder(config) is outputs.sample_builder(
        NodeConfig.from_parameters({'publish_clock': True}))


def test_wrench_round_trip():
    msg = conv.wrench_to_msg('base_link', (1.0, 2.0, 3.0), (4.0, 5.0, 6.0), stamp_ns=7)
    assert conv.wrench_from_msg(msg) == ('base_link', (1.0, 2.0, 3.0), (4.0, 5.0, 6.0))


def test_diagnostics_message():
    msg = conv.diagnostics_to_msg(5, 'n', 'base_link', 'warn', 'running',
                                  {'a': 0.1, 'b': 3, 'c': True})
    status = msg.status[0]
    assert status.level == status.WARN and status.hardware_id == 'base_link'
    assert {kv.key: kv.value for kv in status.values} == {'a': '0.1', 'b': '3', 'c': 'True'}


def test_a_trajectory_s_points_are_converted_when_read():
    # A JointTrajectory's points are made TrajectoryPoint values only when read, so a
    # trajectory refused from its count (MAX_TRAJECTORY_POINTS) costs no conversion: 100 000
    # points took 0.9 s to convert before the refusal.
    from builtin_interfaces.msg import Duration
    from trajectory_msgs.msg import JointTrajectory, JointTrajectoryPoint
    from rbd_ros.sim.trajectory import TrajectoryPoint
    msg = JointTrajectory(joint_names=['a', 'b'], points=[
        JointTrajectoryPoint(positions=[1.0, 2.0], time_from_start=Duration(sec=1, nanosec=5)),
        JointTrajectoryPoint(positions=[3.0, 4.0], velocities=[0.5, 0.25],
                             accelerations=[0.0, 1.0], time_from_start=Duration(sec=2))])
    msg.header.stamp.sec = 7
    names, stamp_ns, points = conv.trajectory_from_msg(msg)
    assert (names, stamp_ns, len(points)) == (['a', 'b'], 7_000_000_000, 2)
    expected = [TrajectoryPoint(1_000_000_005, (1.0, 2.0)),
                TrajectoryPoint(2_000_000_000, (3.0, 4.0), (0.5, 0.25), (0.0, 1.0))]
    assert list(points) == expected and points[-1] == expected[1]
    assert points[0:2] == expected
    many = JointTrajectory(joint_names=['a'], points=[
        JointTrajectoryPoint(positions=[0.0]) for _ in range(100_000)])
    start = time.perf_counter()
    assert len(conv.trajectory_from_msg(many)[2]) == 100_000
    # Nothing converted: microseconds; converting every point took 0.9 s on the 2-core CI
    # machine under load, so 0.1 s tells the two apart with room for a loaded machine.
    assert time.perf_counter() - start < 0.1
