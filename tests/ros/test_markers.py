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
World markers: type, scale and pose per shape, triangle lists, ids, contacts, CDR round trips.

The last tests start the node and read its ``markers`` through real DDS: a mesh body is sent
as the URI of its file, so a sample's size does not depend on the mesh's triangles.

The references are computed here from the shapes' definitions (closed-form surfaces, the
source mesh and its analytic centre of mass, the plane's normal and offset) and the poses are
read back by message field name, never through rbd_ros's own conversion.
"""

import math
import os
from urllib.parse import unquote, urlparse

from conftest import FIRST_START_S, REPO
import numpy as np
import pytest
from rbd_ros.core.contact import (ground_plane, load_mesh, Material, mesh_shape, obstacle,
                                  primitive_shape, StaticWorld)
from rbd_ros.core.contact.simulator import Contacts, WorldBody, WorldSimulator
from rbd_ros.core.errors import InputError
from rbd_ros.core.model import BodyModel
from rbd_ros.core.rotations import quat_from_axis_angle, quat_to_matrix
from rbd_ros.core.state import BodyState
from rbd_ros.msgs import markers
from rbd_ros.sim.meshes import resolve_mesh_path
from rclpy.serialization import deserialize_message, serialize_message
from ros_probe import Probe
import trimesh
from visualization_msgs.msg import Marker, MarkerArray

POSITION_W = np.array([0.5, -1.25, 2.0])
Q_WB = quat_from_axis_angle([1.0, -2.0, 0.5], 0.9)
R_WB = quat_to_matrix(Q_WB)
STAMP_NS = 12_345_678_901
COLOR = (0.2, 0.4, 0.6, 0.8)
# Float64 round-off on coordinates of a few metres, through a rotation and a sum: ~10 ulp of
# 1 m is 2e-15 m; 1e-12 m leaves room and is still far below any visible size.
TOL_M = 1e-12
# The mesh's centre of mass comes from the polyhedral integrals, exact up to round-off of
# sums over its faces: 1e-12 m for a shape of size ~1 m.
COM_TOL_M = 1e-12


def xyz(v):
    return np.array([v.x, v.y, v.z])


def wxyz(q):
    return np.array([q.w, q.x, q.y, q.z])


def points_of(marker):
    return np.array([[p.x, p.y, p.z] for p in marker.points]).reshape(-1, 3)


def posed(marker):
    """Marker points in the world frame, placed by the marker's own pose fields."""
    rot = quat_to_matrix(wxyz(marker.pose.orientation))
    return points_of(marker) @ rot.T + xyz(marker.pose.position)


def round_trip(msg):
    """
    Serialise, deserialise and serialise again: the message must survive both trips.

    The bytes are compared by length and by what they decode to, not byte for byte: rclpy's
    serialiser leaves CDR padding bytes uninitialised (see :mod:`rbd_ros.msgs.outputs`).
    """
    data = serialize_message(msg)
    back = deserialize_message(data, type(msg))
    assert back == msg
    again = serialize_message(back)
    assert len(again) == len(data)
    assert deserialize_message(again, type(msg)) == msg
    return back


def make(shape, **kw):
    return markers.shape_marker(shape, 'test', 7, 'world', POSITION_W, Q_WB, COLOR, STAMP_NS,
                                **kw)


def check_common(marker, marker_type):
    assert marker.type == marker_type
    assert marker.action == Marker.ADD
    assert marker.ns == 'test' and marker.id == 7
    assert marker.header.frame_id == 'world'
    assert marker.header.stamp.sec * 1_000_000_000 + marker.header.stamp.nanosec == STAMP_NS
    assert marker.frame_locked is False
    assert (marker.lifetime.sec, marker.lifetime.nanosec) == (0, 0)
    assert (marker.color.r, marker.color.g, marker.color.b, marker.color.a) == pytest.approx(
        COLOR, abs=1e-7)  # float32 fields: 2^-24 relative
    round_trip(marker)


@pytest.mark.parametrize('shape, dims, marker_type, scale', [
    ('box', [0.4, 0.3, 0.2], Marker.CUBE, [0.4, 0.3, 0.2]),
    ('sphere', [0.25], Marker.SPHERE, [0.5, 0.5, 0.5]),
    ('ellipsoid', [0.3, 0.2, 0.1], Marker.SPHERE, [0.6, 0.4, 0.2]),
    ('cylinder', [0.1, 0.5], Marker.CYLINDER, [0.2, 0.2, 0.5]),
])
def test_primitive_marker_type_scale_and_pose(shape, dims, marker_type, scale):
    marker = make(primitive_shape(shape, dims))
    check_common(marker, marker_type)
    assert np.array_equal(xyz(marker.scale), scale)
    assert np.array_equal(xyz(marker.pose.position), POSITION_W)
    assert np.allclose(wxyz(marker.pose.orientation), Q_WB, rtol=0.0, atol=1e-15)
    assert marker.points == []


def test_cylinder_marker_axis_is_the_shape_axis():
    # RViz draws a CYLINDER along its own z with height scale.z; ours runs along body z.
    # A point of the top cap of the shape (φ = 0 at (0, 0, L/2)) must be the marker's top.
    shape = primitive_shape('cylinder', [0.1, 0.5])
    marker = make(shape)
    phi, _ = shape.signed_distance([0.0, 0.0, 0.5 * marker.scale.z])
    assert abs(phi) <= TOL_M
    assert marker.scale.x == marker.scale.y == 2.0 * shape.params[0]


def closed_and_outward(tris):
    """Each directed edge once and its reverse once (closed, consistent); volume > 0."""
    edges = {}
    for tri in tris:
        for m in range(3):
            key = (tuple(tri[m]), tuple(tri[(m + 1) % 3]))
            edges[key] = edges.get(key, 0) + 1
    assert all(count == 1 for count in edges.values())
    assert all((b, a) in edges for a, b in edges)
    volume = np.einsum('ij,ij->', tris[:, 0], np.cross(tris[:, 1], tris[:, 2])) / 6.0
    assert volume > 0.0
    return volume


def test_capsule_is_a_closed_triangle_list_on_the_capsule_surface():
    radius, length = 0.1, 0.4
    shape = primitive_shape('capsule', [radius, length])
    segments, rings = 16, 8
    marker = make(shape, segments=segments, rings=rings)
    check_common(marker, Marker.TRIANGLE_LIST)
    assert np.array_equal(xyz(marker.scale), [1.0, 1.0, 1.0])
    pts = points_of(marker)
    # Each of the `rings + 1` bands between `rings + 2` circles has 2 triangles per segment,
    # except the two bands at the poles (one): 2 segments (rings + 1) - 2 segments.
    assert pts.shape[0] == 3 * (2 * segments * (rings + 1) - 2 * segments)
    # On the surface: distance to the axis segment z in [-L/2, L/2] is the radius.
    nearest_z = np.clip(pts[:, 2], -0.5 * length, 0.5 * length)
    distance = np.hypot(np.hypot(pts[:, 0], pts[:, 1]), pts[:, 2] - nearest_z)
    assert np.max(np.abs(distance - radius)) <= TOL_M
    volume = closed_and_outward(pts.reshape(-1, 3, 3))
    exact = math.pi * radius ** 2 * length + 4.0 / 3.0 * math.pi * radius ** 3
    # Inscribed: below the exact volume; with 16 segments the polygon area alone is
    # sin(2π/16) 16 / (2π) = 97.4 % of the circle's, so at least 90 % overall.
    assert 0.9 * exact < volume < exact
    assert np.allclose(posed(marker), pts @ R_WB.T + POSITION_W, rtol=0.0, atol=TOL_M)


def test_mesh_marker_is_its_faces_about_the_centre_of_mass():
    # A ring (nonconvex) moved off the origin: its centre of mass is the moved centre.
    centre = np.array([1.0, 2.0, 3.0])
    ring = trimesh.creation.annulus(r_min=0.2, r_max=0.5, height=0.3, sections=24)
    source = np.asarray(ring.vertices) + centre
    faces = np.asarray(ring.faces)
    shape = mesh_shape(source, faces, cache_dir=False)
    assert np.allclose(shape.mesh_offset_m, centre, rtol=0.0, atol=COM_TOL_M)
    marker = make(shape)
    check_common(marker, Marker.TRIANGLE_LIST)
    assert np.array_equal(xyz(marker.scale), [1.0, 1.0, 1.0])
    assert len(marker.points) == 3 * faces.shape[0]
    expected_b = (source - centre)[faces].reshape(-1, 3)
    assert np.allclose(points_of(marker), expected_b, rtol=0.0, atol=COM_TOL_M)
    assert np.allclose(posed(marker), expected_b @ R_WB.T + POSITION_W, rtol=0.0,
                       atol=COM_TOL_M + TOL_M)


@pytest.mark.parametrize('normal, offset', [((0.0, 0.0, 1.0), 0.0),
                                            ((0.3, -0.2, 1.0), 0.25),
                                            ((0.0, 0.0, -1.0), -1.0)])
def test_plane_marker_is_a_slab_whose_top_is_the_plane(normal, offset):
    ground = ground_plane(normal, offset)
    size = 8.0
    marker = markers.shape_marker(ground.shape, 'ground', 0, 'world', ground.position_w,
                                  ground.orientation_wb, COLOR, STAMP_NS, plane_size_m=size)
    assert marker.type == Marker.CUBE
    assert np.array_equal(xyz(marker.scale), [size, size, markers.GROUND_THICKNESS_M])
    n = np.array(normal) / np.linalg.norm(normal)
    rot = quat_to_matrix(wxyz(marker.pose.orientation))
    assert np.allclose(rot[:, 2], n, rtol=0.0, atol=1e-15)
    # The slab's top face centre is on the plane, at its point nearest the origin.
    top = xyz(marker.pose.position) + 0.5 * marker.scale.z * rot[:, 2]
    assert np.allclose(top, offset * n, rtol=0.0, atol=TOL_M)
    round_trip(marker)


def test_static_markers_ground_and_obstacles_with_stable_ids():
    world = StaticWorld(ground_plane((0.0, 0.0, 1.0), 0.0), (
        obstacle('wall', 'box', [0.1, 2.0, 1.0], position_w=(2.0, 0.0, 0.5)),
        obstacle('post', 'cylinder', [0.1, 1.0], position_w=(-1.0, 1.0, 0.5),
                 orientation_wb=quat_from_axis_angle([1.0, 0.0, 0.0], 0.3))))
    array = markers.static_markers(world, 'map', STAMP_NS)
    assert [(m.ns, m.id, m.text) for m in array.markers] == [
        ('ground', 0, 'ground'), ('obstacles', 0, 'wall'), ('obstacles', 1, 'post')]
    assert [m.type for m in array.markers] == [Marker.CUBE, Marker.CUBE, Marker.CYLINDER]
    assert all(m.header.frame_id == 'map' and m.action == Marker.ADD for m in array.markers)
    post = array.markers[2]
    assert np.array_equal(xyz(post.pose.position), world.obstacles[1].position_w)
    assert np.allclose(wxyz(post.pose.orientation), world.obstacles[1].orientation_wb,
                       rtol=0.0, atol=1e-15)
    assert round_trip(array) == markers.static_markers(world, 'map', STAMP_NS)
    assert markers.static_markers(None, 'map', 0).markers == []


def test_body_markers_one_per_body_distinct_colours_stable_ids():
    names = [f'b{i}' for i in range(12)]
    kinds = [('box', [0.2, 0.2, 0.2]), ('sphere', [0.1]), ('capsule', [0.05, 0.2])]
    shapes = [primitive_shape(*kinds[i % 3]) for i in range(12)]
    positions = np.arange(36, dtype=np.float64).reshape(12, 3) * 0.1
    quats = np.array([quat_from_axis_angle([0.0, 1.0, 1.0], 0.1 * i) for i in range(12)])
    array = markers.body_markers(names, shapes, positions, quats, 'world', STAMP_NS)
    # The 12 bodies first, then the two caps of each of the 4 capsules (bodies 2, 5, 8, 11).
    capsules = [i for i in range(12) if i % 3 == 2]
    assert [(m.ns, m.id, m.text) for m in array.markers] == [
        ('bodies', i, name) for i, name in enumerate(names)] + [
        ('body_caps', 2 * i + k, names[i]) for i in capsules for k in (0, 1)]
    for i, marker in enumerate(array.markers[:12]):
        assert np.array_equal(xyz(marker.pose.position), positions[i])
        assert np.allclose(wxyz(marker.pose.orientation), quats[i], rtol=0.0, atol=1e-15)
    colours = {(m.color.r, m.color.g, m.color.b) for m in array.markers[:12]}
    assert len(colours) == len(names)
    again = markers.body_markers(names[:3], shapes[:3], positions[:3] + 1.0, quats[:3],
                                 'world', STAMP_NS + 1)
    assert [m.color for m in again.markers[:3]] == [m.color for m in array.markers[:3]]
    round_trip(array)
    with pytest.raises(InputError, match=r'positions_w: shape \(11, 3\) for 12 bodies'):
        markers.body_markers(names, shapes, positions[:11], quats, 'world', 0)
    with pytest.raises(InputError, match='bodies.b3: position_w .* quat_wxyz'):
        bad = quats.copy()
        bad[3] = 0.0
        markers.body_markers(names, shapes, positions, bad, 'world', 0)


def test_reused_body_markers_equal_fresh_ones():
    names = ['box', 'ring']
    ring = trimesh.creation.annulus(r_min=0.2, r_max=0.5, height=0.3, sections=12)
    shapes = [primitive_shape('box', [0.2, 0.3, 0.4]),
              mesh_shape(ring.vertices, ring.faces, cache_dir=False)]
    cached = markers.BodyMarkers(names, shapes, 'world')
    for k in range(3):
        positions = np.array([[0.1 * k, 0.0, 0.2], [1.0, -0.5 * k, 0.3]])
        # Not normalised on purpose: both paths normalise.
        quats = np.array([quat_from_axis_angle([1.0, 2.0, 3.0], 0.4 * k) * 2.0,
                          quat_from_axis_angle([0.0, 1.0, 0.0], -0.3 * k)])
        fresh = markers.body_markers(names, shapes, positions, quats, 'world', STAMP_NS + k)
        reused = cached.array(positions, quats, STAMP_NS + k)
        for a, b in zip(reused.markers, fresh.markers):
            assert a.header == b.header and a.points == b.points and a.color == b.color
            assert np.array_equal(xyz(a.pose.position), xyz(b.pose.position))
            # Both divide by numpy's norm of the same 4 numbers: equal, or 1 ulp apart.
            assert np.allclose(wxyz(a.pose.orientation), wxyz(b.pose.orientation), rtol=0.0,
                               atol=2.3e-16)
        round_trip(reused)
    with pytest.raises(InputError, match='bodies.floor.shape: a plane is static'):
        markers.BodyMarkers(['floor'], [ground_plane().shape], 'world')


def test_capsule_body_is_a_cylinder_and_two_sphere_caps():
    # A capsule of radius r and cylindrical length L along body z is the union of the
    # cylinder (2r, 2r, L) and two balls of radius r centred on the axis at z = +-L/2.
    radius, length = 0.05, 0.3
    shape = primitive_shape('capsule', [radius, length])
    array = markers.body_markers(['cap'], [shape], POSITION_W[None], Q_WB[None], 'world',
                                 STAMP_NS)
    body, top, bottom = array.markers
    assert (body.ns, body.id, body.type) == ('bodies', 0, Marker.CYLINDER)
    assert np.array_equal(xyz(body.scale), [2 * radius, 2 * radius, length])
    assert np.array_equal(xyz(body.pose.position), POSITION_W)
    assert body.points == []
    for cap, marker_id, sign in ((top, 0, 1.0), (bottom, 1, -1.0)):
        assert (cap.ns, cap.id, cap.type, cap.text) == ('body_caps', marker_id, Marker.SPHERE,
                                                        'cap')
        assert np.array_equal(xyz(cap.scale), [2 * radius] * 3)
        assert cap.color == body.color
        centre = POSITION_W + R_WB @ np.array([0.0, 0.0, sign * 0.5 * length])
        assert np.allclose(xyz(cap.pose.position), centre, rtol=0.0, atol=TOL_M)
        # The pole of the cap is on the capsule's surface: phi = 0 there.
        pole_b = np.array([0.0, 0.0, sign * (0.5 * length + radius)])
        assert abs(shape.signed_distance(pole_b)[0]) <= TOL_M
    round_trip(array)


def test_mesh_body_with_a_file_is_a_mesh_resource_drawn_where_the_body_is(tmp_path):
    # The viewer draws the file's vertices v as R(q_m) (s * v) + p_m (scale, then pose).
    # They must land on the body's own vertices at the body pose, R(q_wb) x_b + p_w.
    ring = trimesh.creation.annulus(r_min=0.2, r_max=0.5, height=0.3, sections=24)
    ring.apply_translation([1.0, 2.0, 3.0])  # the COM is off the file's origin
    path = tmp_path / 'ring.stl'
    ring.export(path)
    scale = (2.0, 0.5, 1.5)
    shape = load_mesh(str(path), scale, cache_dir=False)
    uri = markers.mesh_uri(str(path), str(path))
    assert uri == path.as_uri()
    assert markers.mesh_uri('package://rbd_ros/m.stl', '/x/m.stl') == 'package://rbd_ros/m.stl'
    array = markers.body_markers(['ring'], [shape], POSITION_W[None], Q_WB[None], 'world',
                                 STAMP_NS, meshes=[(uri, scale)])
    (marker,) = array.markers
    assert (marker.ns, marker.id, marker.type) == ('bodies', 0, Marker.MESH_RESOURCE)
    assert marker.mesh_resource == uri and marker.mesh_use_embedded_materials is False
    assert np.array_equal(xyz(marker.scale), scale)
    assert marker.points == []
    drawn = trimesh.load(str(path), force='mesh').vertices * np.array(scale)
    drawn_w = drawn @ quat_to_matrix(wxyz(marker.pose.orientation)).T + xyz(marker.pose.position)
    # Same vertices, same order (the loader merges duplicates the same way both times).
    body_w = np.asarray(shape.vertices_b) @ R_WB.T + POSITION_W
    assert np.allclose(drawn_w, body_w, rtol=0.0, atol=COM_TOL_M + TOL_M)
    round_trip(array)
    with pytest.raises(InputError, match=r'bodies.ring.mesh_scale: \(1.0, -1.0, 1.0\)'):
        markers.BodyMarkers(['ring'], [shape], 'world', [(uri, (1.0, -1.0, 1.0))])
    with pytest.raises(InputError, match="bodies.ring.mesh_path: 'ring.stl' must be"):
        markers.BodyMarkers(['ring'], [shape], 'world', [('ring.stl', scale)])
    with pytest.raises(InputError, match="bodies.box.shape: 'box' with a mesh URI"):
        markers.BodyMarkers(['box'], [primitive_shape('box', [0.1, 0.1, 0.1])], 'world',
                            [(uri, scale)])


def test_robot_link_markers_are_in_their_link_frames_a_mesh_by_its_uri():
    # A robot fixed to the world: a `base` link (fixed to `world`) with a box, and a moving
    # `arm` link with a package:// mesh scaled 2x at an origin turned 1.2 rad about z. Each
    # element is one marker in its link's frame at the URDF's <origin> (the quaternion of
    # rpy (0, 0, 1.2) is (cos 0.6, 0, 0, sin 0.6)); the mesh is its file's URI and scale.
    from rbd_ros.sim.config import NodeConfig
    uri = 'package://rbd_ros/msg_config/meshes/l_block.stl'
    urdf = f"""<?xml version="1.0"?>
<robot name="r"><link name="world"/>
<joint name="fix" type="fixed"><parent link="world"/><child link="base"/>
<origin xyz="0 0 1"/></joint>
<link name="base"><collision><origin xyz="0 0 0.05"/><geometry><box size="0.3 0.3 0.1"/>
</geometry></collision></link>
<joint name="j" type="revolute"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
<limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
<link name="arm"><inertial><origin xyz="0 0 0.5"/><mass value="1"/><inertia ixx="0.1" ixy="0"
ixz="0" iyy="0.1" iyz="0" izz="0.1"/></inertial><collision><origin xyz="0.1 0.2 0.3"
rpy="0 0 1.2"/><geometry><mesh filename="{uri}" scale="2 2 2"/></geometry></collision>
</link></robot>"""
    config = NodeConfig.from_parameters({'robot_names': ['r'],
                                         'robots.r.robot_description': urdf,
                                         'robots.r.initial_position': [0.5, -0.25, 0.0]})
    built = markers.LinkMarkers(config.robots, 'odom', first_body=3)
    # The base is fixed to the world: a static marker (published once with the obstacles), in
    # the world frame at its placed pose (world link at (0.5, -0.25, 0), base 1 m up, box
    # 0.05 m above it: 1 + 0.05 rounds to 1.05), not among the moving links' markers.
    (arm,) = built.stamped(STAMP_NS)
    (base,) = built.static
    assert (base.ns, base.id, base.type) == ('links', 0, Marker.CUBE)
    assert base.header.frame_id == 'odom' and not base.frame_locked
    assert base.header.stamp.sec == 0 and base.header.stamp.nanosec == 0
    assert np.array_equal(xyz(base.scale), (0.3, 0.3, 0.1))
    assert np.array_equal(xyz(base.pose.position), (0.5, -0.25, 1.05))
    assert np.array_equal(wxyz(base.pose.orientation), (1.0, 0.0, 0.0, 0.0))
    assert base.text == 'r/base'
    assert (arm.ns, arm.id, arm.type, arm.header.frame_id) == ('links', 1,
                                                               Marker.MESH_RESOURCE, 'arm')
    assert arm.mesh_resource == uri and arm.mesh_use_embedded_materials is False
    assert np.array_equal(xyz(arm.scale), (2.0, 2.0, 2.0)) and arm.points == []
    # rpy -> rotation matrix -> quaternion (the URDF reader's path): round-off, ~1e-16.
    assert np.allclose(xyz(arm.pose.position), (0.1, 0.2, 0.3), rtol=0.0, atol=1e-15)
    want = (math.cos(0.6), 0.0, 0.0, math.sin(0.6))
    assert np.allclose(wxyz(arm.pose.orientation), want, rtol=0.0, atol=1e-15)
    assert arm.frame_locked and arm.header.stamp.sec == STAMP_NS // 10 ** 9
    assert arm.text == 'r/arm'
    # the moving link in its body's colour (body 3: the free bodies first), the base in the
    # obstacles'
    color = [(m.color.r, m.color.g, m.color.b, m.color.a) for m in (arm, base)]
    # ColorRGBA holds float32: 1e-7 is its rounding of values in [0, 1].
    assert np.allclose(color, [markers.body_color(3), markers.OBSTACLE_COLOR], atol=1e-7)
    round_trip(MarkerArray(markers=[base, arm]))


@pytest.fixture(scope='module')
def resting_box_contacts():
    """Settle a 2 kg box on the ground for 50 steps of 1 ms; return its last step's contacts."""
    geometry = primitive_shape('box', [0.4, 0.3, 0.2])
    model = BodyModel(2.0, geometry.mass_properties(2.0).inertia_b, gravity_w=(0, 0, -9.81))
    world = StaticWorld(ground_plane((0.0, 0.0, 1.0), 0.0, Material(0.5, 0.0)))
    sim = WorldSimulator([WorldBody('box', model, geometry, Material(0.5, 0.0))],
                         [BodyState(position_w=(0.0, 0.0, 0.1))], world,
                         timestep_ns=1_000_000)
    sim.step(50)
    return sim.contacts


def test_contact_markers_match_a_resting_box_step(resting_box_contacts):
    contacts = resting_box_contacts
    assert len(contacts) >= 4  # four corners on the ground, at least one stage
    scale = 20.0
    array = markers.contact_markers(contacts, 'world', STAMP_NS, arrow_scale_m_per_n_s=scale)
    clear, points, lines = array.markers
    assert (clear.ns, clear.action) == ('contacts', Marker.DELETEALL)
    assert (points.ns, points.id, points.type) == ('contacts', 0, Marker.SPHERE_LIST)
    assert (lines.ns, lines.id, lines.type) == ('contacts', 1, Marker.LINE_LIST)
    assert np.array_equal(points_of(points), contacts.point_w)
    segments = points_of(lines).reshape(-1, 2, 3)
    assert np.array_equal(segments[:, 0], contacts.point_w)
    for row in range(len(contacts)):
        along = float(np.dot(contacts.impulse_w[row], contacts.normal_w[row]))
        expected = contacts.point_w[row] + scale * along * contacts.normal_w[row]
        assert np.allclose(segments[row, 1], expected, rtol=0.0, atol=TOL_M)
    # The box pushes on the ground: the supporting normals point up and carry impulse.
    assert np.all(segments[:, 1, 2] >= segments[:, 0, 2])
    assert np.any(segments[:, 1, 2] > segments[:, 0, 2])
    round_trip(array)


def test_contact_markers_without_contacts_only_clear_their_namespace():
    empty = Contacts(*(np.zeros((0,) + s) for s in ((), (), (3,), (3,), (3,), ())))
    array = markers.contact_markers(empty, 'world', STAMP_NS)
    assert len(array.markers) == 1
    assert (array.markers[0].ns, array.markers[0].action) == ('contacts', Marker.DELETEALL)
    round_trip(array)
    with pytest.raises(InputError, match='arrow_scale_m_per_n_s: -1.0'):
        markers.contact_markers(empty, 'world', 0, arrow_scale_m_per_n_s=-1.0)


def test_bad_inputs_name_the_field():
    shape = primitive_shape('sphere', [0.1])
    with pytest.raises(InputError, match=r'color_rgba: \[1.0, 0.0, 0.0, 2.0\]'):
        markers.shape_marker(shape, 'x', 0, 'w', (0, 0, 0), (1, 0, 0, 0), (1, 0, 0, 2), 0)
    with pytest.raises(InputError, match='position_w'):
        markers.shape_marker(shape, 'x', 0, 'w', (0, math.nan, 0), (1, 0, 0, 0), COLOR, 0)
    with pytest.raises(InputError, match='marker_id: 4294967296'):
        markers.shape_marker(shape, 'x', 2 ** 32, 'w', (0, 0, 0), (1, 0, 0, 0), COLOR, 0)


def _markers_received(start_node, params):
    """Start a node on ``params``; return the first ``markers`` message's CDR bytes over DDS."""
    node = start_node(params, namespace=True)
    probe = Probe(node.namespace, inputs=(), outputs=())
    try:
        got = []
        probe.node.create_subscription(MarkerArray, 'markers', got.append, 10, raw=True)
        # A first start may compile the contact step (FIRST_START_S); it is warm otherwise.
        probe.wait(lambda: got or node.process.poll() is not None, FIRST_START_S,
                   'a markers message')
    finally:
        probe.close()
    assert got, f'the node exited without a markers message: {node.stderr}'
    assert node.stop() == 0, node.stderr
    return got[0]


def _mesh_world(path, count=3):
    """``count`` bodies of the mesh at ``path`` floating 1 m above a floor (no gravity)."""
    names = [f'm{i}' for i in range(count)]
    params = {'ground.enabled': True, 'gravity': [0.0, 0.0, 0.0], 'body_names': names,
              'publish_rate_hz': 20.0, 'real_time_factor': 1.0}
    for i, name in enumerate(names):
        params[f'bodies.{name}.mesh_path'] = str(path)
        params[f'bodies.{name}.initial_position'] = [1.0 * i, 0.0, 1.0]
    return params


def test_a_mesh_world_markers_size_does_not_depend_on_the_triangle_count(tmp_path, start_node):
    # A cube (12 faces) and an icosphere (1,280 faces), in files whose names have the same
    # length, so the two URIs have the same length: the messages must be the same size to the
    # byte. Sending the triangles made them differ by (1280 - 12) faces x 3 points x 24 bytes
    # x 3 bodies = 274 kB.
    meshes = {12: trimesh.creation.box(extents=(0.2, 0.2, 0.2)),
              1280: trimesh.creation.icosphere(subdivisions=3, radius=0.1)}
    sizes, received = {}, {}
    for faces, mesh in meshes.items():
        assert len(mesh.faces) == faces
        path = tmp_path / f'mesh_{faces:04d}.stl'
        mesh.export(path)
        data = _markers_received(start_node, _mesh_world(path))
        sizes[faces] = len(data)
        received[path] = deserialize_message(data, MarkerArray)
    assert sizes[12] == sizes[1280], sizes
    # Bodies, not triangles: a few hundred bytes a body (the URI and the pose), where one
    # body's 12 cube triangles alone were 36 points x 24 bytes = 864 bytes.
    assert sizes[1280] < 3 * 600, sizes
    for path, array in received.items():
        bodies = [m for m in array.markers if m.ns == 'bodies']
        assert [m.text for m in bodies] == ['m0', 'm1', 'm2']
        for marker in bodies:
            assert marker.type == Marker.MESH_RESOURCE and marker.points == []
            uri = urlparse(marker.mesh_resource)
            assert uri.scheme == 'file'
            assert os.path.samefile(unquote(uri.path), path)  # the URI resolves to the file


def test_a_package_mesh_path_is_sent_as_that_package_uri(start_node):
    uri = 'package://rbd_ros/msg_config/meshes/l_block.stl'
    params = {'mesh_path': uri, 'ground.enabled': True, 'gravity': [0.0, 0.0, 0.0],
              'initial_position': [0.0, 0.0, 1.0], 'publish_rate_hz': 20.0}
    array = deserialize_message(_markers_received(start_node, params), MarkerArray)
    (body,) = [m for m in array.markers if m.ns == 'bodies']
    assert body.type == Marker.MESH_RESOURCE and body.mesh_resource == uri
    # RViz and Foxglove resolve package://rbd_ros/ against the package share; from the
    # source tree that is the repository root, which holds the same msg_config/.
    resolved = resolve_mesh_path(uri, 'mesh_path')
    assert os.path.samefile(resolved, REPO / 'msg_config' / 'meshes' / 'l_block.stl')
