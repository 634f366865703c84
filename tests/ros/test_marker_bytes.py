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
The node's ``markers`` bytes (:mod:`rbd_ros.msgs.marker_bytes`) against rclpy's serialiser.

The reference is the ``MarkerArray`` the message objects make (:class:`BodyMarkers`,
:func:`contact_markers`): rclpy deserialises our bytes into exactly it, and rclpy's own
serialisation of it has our length (its padding bytes are not initialised, so the bytes are
compared through what they decode to, as :mod:`rbd_ros.msgs.outputs`' are).
"""

from geometry_msgs.msg import Point
import numpy as np
from rbd_ros.core.contact import mesh_shape, primitive_shape
from rbd_ros.core.contact.simulator import Contacts
from rbd_ros.core.rotations import quat_from_axis_angle
from rbd_ros.msgs import markers
from rbd_ros.msgs.conversions import time_to_msg
from rbd_ros.msgs.marker_bytes import MarkerArrayBytes
from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import ColorRGBA
import trimesh
from visualization_msgs.msg import Marker, MarkerArray, UVCoordinate


def random_contacts(seed, count):
    """Return ``count`` contact rows of random points, unit normals and impulses."""
    rng = np.random.default_rng(seed)
    normal = rng.normal(size=(count, 3))
    normal /= np.linalg.norm(normal, axis=1)[:, None]
    return Contacts(np.zeros(count, dtype=np.int64), np.full(count, -1, dtype=np.int64),
                    rng.normal(size=(count, 3)), normal, rng.normal(size=(count, 3)) * 1e-3,
                    np.ones(count, dtype=np.int64))


def every_field_marker():
    """Return a marker with every field set (sequences non-empty, odd string lengths)."""
    marker = Marker(ns='all_fields', id=-3, type=Marker.POINTS, action=Marker.MODIFY,
                    frame_locked=True, texture_resource='package://p/t.png', text='abcde',
                    mesh_resource='file:///m.dae', mesh_use_embedded_materials=True)
    marker.header.frame_id = 'link_7'
    marker.pose.position = Point(x=1.5, y=-2.25, z=3.0)
    marker.pose.orientation.z, marker.pose.orientation.w = 0.6, 0.8
    marker.scale.x, marker.scale.y, marker.scale.z = 0.1, 0.2, 0.3
    marker.color = ColorRGBA(r=0.25, g=0.5, b=0.75, a=1.0)
    marker.lifetime.sec, marker.lifetime.nanosec = 2, 500
    marker.points = [Point(x=0.1 * i, y=-0.2 * i, z=0.3) for i in range(3)]
    marker.colors = [ColorRGBA(r=0.5, g=0.25, b=0.125, a=1.0)] * 2
    marker.texture.header.frame_id = 'tex'
    marker.texture.format = 'png'
    marker.texture.data = [1, 2, 3]
    marker.uv_coordinates = [UVCoordinate(u=0.5, v=0.25)]
    marker.mesh_file.filename = 'mesh.dae'
    marker.mesh_file.data = [9, 8, 7, 6, 5]
    return marker


def test_marker_bytes_decode_to_the_marker_array_of_the_message_objects(tmp_path):
    ring = trimesh.creation.annulus(r_min=0.2, r_max=0.5, height=0.3, sections=8)
    path = tmp_path / 'ring.stl'
    ring.export(path)
    names = ['box', 'capsule_body', 'ring_file', 'ring']
    shapes = [primitive_shape('box', [0.2, 0.3, 0.4]), primitive_shape('capsule', [0.05, 0.3]),
              mesh_shape(ring.vertices, ring.faces, cache_dir=False),
              mesh_shape(ring.vertices, ring.faces, cache_dir=False)]
    bodies = markers.BodyMarkers(names, shapes, 'world_frame',
                                 [None, None, (path.as_uri(), (1.0, 2.0, 0.5)), None])
    extra = every_field_marker()
    cdr = MarkerArrayBytes(bodies.markers + [extra], len(bodies.markers),
                           markers.contact_prototypes('world_frame', 0))
    contacts = random_contacts(1, 37)
    empty = Contacts(*(np.zeros((0,) + s) for s in ((), (), (3,), (3,), (3,), ())))
    for k, shown in enumerate((contacts, empty, contacts)):
        stamp_ns = 1_000_000_000 * k + 123_456_789
        positions = np.array([[0.1 * k, 0.0, 0.2], [1.0, -0.5 * k, 0.3], [0.0, 0.0, 1.0],
                              [2.0, 1.0, 0.5]])
        quats = np.array([quat_from_axis_angle([1.0, 2.0, 3.0], 0.4 * k + 0.1 * i)
                          for i in range(4)])
        points = markers.contact_points(shown, 7.5)
        data = cdr.serialize(stamp_ns, bodies.poses(positions, quats, normalise=False), points)
        extra.header.stamp = time_to_msg(stamp_ns)
        expected = MarkerArray(markers=list(
            bodies.array(positions, quats, stamp_ns, normalise=False).markers) + [extra]
            + list(markers.contact_markers(shown, 'world_frame', stamp_ns, 7.5).markers))
        assert len(expected.markers) == 4 + 2 + 1 + (3 if len(shown) else 1)  # caps: 2
        assert deserialize_message(data, MarkerArray) == expected
        assert len(data) == len(serialize_message(expected))
        # Zero padding: the same sample gives the same bytes.
        assert data == cdr.serialize(stamp_ns, bodies.poses(positions, quats, normalise=False),
                                     points)


def test_no_fixed_markers_and_no_posed_ones():
    cdr = MarkerArrayBytes([], 0, markers.contact_prototypes('w', 0))
    data = cdr.serialize(5, np.zeros((0, 7)), markers.contact_points(random_contacts(2, 5), 1.0))
    assert deserialize_message(data, MarkerArray) == markers.contact_markers(
        random_contacts(2, 5), 'w', 5, 1.0)
