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
World → ``visualization_msgs/MarkerArray``: shapes of bodies and obstacles, and contacts.

No rclpy here: the node, replay and plot call these builders and publish, record or draw the
messages.  Every marker is in ``frame_id`` (the world frame; a robot link's: its link frame),
in metres, ``frame_locked`` false (a link's: true), ``lifetime`` 0 (kept until replaced or
deleted), ``action`` ADD unless said.

Namespaces and ids (stable, so a marker is replaced in place sample after sample):

* ``ground`` id 0: the ground plane, a thin CUBE (see :func:`shape_marker`).
* ``obstacles`` id ``i``: obstacle ``i`` of ``StaticWorld.obstacles`` (``text`` = its name).
* ``bodies`` id ``i``: body ``i`` (``text`` = its name), colour
  :func:`rbd_ros.sim.tessellation.body_color` (shared with :mod:`rbd_ros.bag.animate`).  A mesh
  body whose mesh file is known is a MESH_RESOURCE (the viewer loads the file once and the
  message carries its URI, not its triangles); a capsule body is a CYLINDER here and two
  SPHERE caps in ``body_caps`` (ids ``2 i`` and ``2 i + 1``), so a body's marker costs the
  same few hundred bytes a sample whatever its shape (see :class:`BodyMarkers`).
* ``contacts`` id 0: the contact points (SPHERE_LIST); id 1: the normals (LINE_LIST).
* ``links`` id ``i``: the ``i``-th ``<collision>`` of the robots' links (robots, links and
  elements in order; ``text`` = ``<robot>/<link>``), in the link's own frame (the frame
  ``/tf`` carries), ``frame_locked`` true, posed by the element's ``<origin>``; a link fixed
  to the world's in the world frame at its placed pose, published with the static ones
  (:class:`LinkMarkers`).

The ``text`` field is ignored by viewers for these types; it lets a bag reader tell the
markers apart by name.  Static markers (:func:`static_markers`) are meant to be published
once on a transient-local topic; :func:`body_markers` and :func:`contact_markers` every
sample.  Every marker of :func:`static_markers` and :func:`body_markers` has an ADD action,
so the static and moving markers may share one topic: nothing here ever deletes outside the
``contacts`` namespace.

Quaternions are ``(w, x, y, z)`` here as everywhere inside rbd_ros; the messages' ``x, y, z,
w`` fields are written by :func:`rbd_ros.msgs.conversions.quaternion_to_msg`.
"""

import math
import os
from pathlib import Path
from typing import List, Optional, Sequence, Tuple, TYPE_CHECKING

from geometry_msgs.msg import Point
import numpy as np
from rbd_ros.core.errors import finite_vector, InputError
from rbd_ros.core.rotations import (quat_multiply, quat_normalize, quat_rotate,
                                    quat_to_matrix)
from rbd_ros.msgs import conversions as conv
from rbd_ros.sim.tessellation import (body_color, DEFAULT_PLANE_SIZE_M, DEFAULT_RINGS,
                                      DEFAULT_SEGMENTS, plane_frame, shape_triangles)
from std_msgs.msg import ColorRGBA
from visualization_msgs.msg import Marker, MarkerArray

if TYPE_CHECKING:  # pragma: no cover - annotations only
    from rbd_ros.core.contact import CollisionShape, StaticWorld
    from rbd_ros.core.contact.simulator import Contacts
    from rbd_ros.sim.robots import RobotConfig

__all__ = [
    'BODIES_NS', 'BODY_CAPS_NS', 'BodyMarkers', 'CONTACT_NORMALS_ID', 'CONTACT_POINTS_ID',
    'CONTACTS_NS', 'DEFAULT_ARROW_SCALE_M_PER_N_S', 'GROUND_NS', 'GROUND_THICKNESS_M',
    'LINKS_NS', 'LinkMarkers', 'OBSTACLES_NS', 'body_color', 'body_markers', 'contact_markers',
    'contact_points', 'contact_prototypes', 'mesh_uri', 'shape_marker', 'static_markers',
]

GROUND_NS = 'ground'
OBSTACLES_NS = 'obstacles'
BODIES_NS = 'bodies'
#: The two end caps of capsule bodies (SPHERE markers beside the body's CYLINDER).
BODY_CAPS_NS = 'body_caps'
CONTACTS_NS = 'contacts'
LINKS_NS = 'links'
#: Ids in ``contacts``: the points and the normals.
CONTACT_POINTS_ID = 0
CONTACT_NORMALS_ID = 1
#: Thickness of the slab drawn for a plane, m; its top face is the plane.
GROUND_THICKNESS_M = 0.01
#: Normal line length per N·s of normal impulse, m/(N·s).  A box of mass m resting on its
#: 4 corners gets m g h / 8 per corner in each of the 2 contact stages of a step (measured:
#: 2.4525 mN·s for 2 kg at h = 1 ms), so a 1 kg box at 1 ms draws 1.2 cm lines.
DEFAULT_ARROW_SCALE_M_PER_N_S = 10.0
#: Diameter of a contact point's sphere and width of a normal line, m.
CONTACT_POINT_DIAMETER_M = 0.02
CONTACT_LINE_WIDTH_M = 0.005
GROUND_COLOR = (0.55, 0.55, 0.55, 1.0)
OBSTACLE_COLOR = (0.45, 0.35, 0.25, 1.0)
CONTACT_POINT_COLOR = (1.0, 0.1, 0.1, 1.0)
CONTACT_NORMAL_COLOR = (1.0, 0.85, 0.0, 1.0)

_MARKER_TYPES = {'box': Marker.CUBE, 'sphere': Marker.SPHERE,
                 'spherical_shell': Marker.SPHERE, 'ellipsoid': Marker.SPHERE,
                 'cylinder': Marker.CYLINDER, 'plane': Marker.CUBE,
                 'capsule': Marker.TRIANGLE_LIST, 'mesh': Marker.TRIANGLE_LIST,
                 'compound': Marker.TRIANGLE_LIST}
_INT32 = 2 ** 31
# Triangle points per shape, built once: (shape, tessellation options) -> (shape, points).
# The Point objects are shared by every marker of that shape: never mutate a marker's points.
_POINTS_CACHE = {}
_POINTS_CACHE_SIZE = 1024


def _color(color_rgba):
    rgba = finite_vector(color_rgba, 'color_rgba', '(r, g, b, a in [0, 1])', size=4,
                         frozen=False)
    if np.any(rgba < 0.0) or np.any(rgba > 1.0):
        raise InputError(f'color_rgba: {rgba.tolist()} must be 4 values in [0, 1] (r, g, b, a)')
    # float32 fields: rounded here, so the message holds what it serialises to.
    r, g, b, a = (float(c) for c in rgba.astype(np.float32))
    return ColorRGBA(r=r, g=g, b=b, a=a)


def _marker_id(marker_id):
    if (isinstance(marker_id, bool) or not isinstance(marker_id, (int, np.integer))
            or not -_INT32 <= int(marker_id) < _INT32):
        raise InputError(f'marker_id: {marker_id!r} must be an int32 integer')
    return int(marker_id)


def _points(array):
    """(n, 3) array → list of ``geometry_msgs/Point``."""
    return [Point(x=x, y=y, z=z) for x, y, z in np.asarray(array, dtype=np.float64).tolist()]


def _triangle_points(shape, segments, rings):
    key = (id(shape), segments, rings)
    hit = _POINTS_CACHE.get(key)
    if hit is not None and hit[0] is shape:
        return list(hit[1])
    points = tuple(_points(shape_triangles(shape, segments, rings).reshape(-1, 3)))
    if len(_POINTS_CACHE) >= _POINTS_CACHE_SIZE:
        _POINTS_CACHE.clear()
    _POINTS_CACHE[key] = (shape, points)  # holding the shape keeps its id from being reused
    return list(points)


def _header(marker, frame_id, stamp_ns):
    marker.header.frame_id = str(frame_id)
    marker.header.stamp = conv.time_to_msg(stamp_ns)


def _body_marker(ns, marker_id, frame_id, marker_type, color_rgba, scale):
    """Return an ADD marker at the identity pose, stamp 0 (:class:`BodyMarkers` poses it)."""
    marker = Marker()
    _header(marker, frame_id, 0)
    marker.ns = ns
    marker.id = _marker_id(marker_id)
    marker.type = marker_type
    marker.action = Marker.ADD
    marker.color = _color(color_rgba)
    marker.frame_locked = False
    marker.scale.x, marker.scale.y, marker.scale.z = (float(v) for v in scale)
    marker.pose.orientation.w = 1.0
    return marker


def shape_marker(shape: 'CollisionShape', ns: str, marker_id: int, frame_id: str,
                 position_w: Sequence[float], quat_wxyz: Sequence[float],
                 color_rgba: Sequence[float], stamp_ns: int,
                 plane_size_m: float = DEFAULT_PLANE_SIZE_M, segments: int = DEFAULT_SEGMENTS,
                 rings: int = DEFAULT_RINGS) -> Marker:
    """
    Return the ``visualization_msgs/Marker`` of a collision shape at a pose.

    The shape's body frame is at ``position_w`` (m) turned by ``quat_wxyz`` (``q_wb``, w
    first; normalised here): ``x_w = R(q_wb) x_b + position_w``.  Per ``shape.shape``:

    * ``box``: CUBE, scale = the full edge lengths.
    * ``sphere``: SPHERE, scale = the diameter on every axis; ``ellipsoid``: SPHERE, scale =
      twice the semi-axes.
    * ``cylinder``: CYLINDER, scale = (2 r, 2 r, length).  RViz and Foxglove cylinders run
      along their z axis, as ours do (``from_shape``: cylinders and capsules along body z),
      so the pose is the body's.
    * ``capsule``: TRIANGLE_LIST of its tessellation (:func:`rbd_ros.sim.tessellation.
      shape_triangles`: ``segments`` per ring, ``rings`` over both caps), scale 1.
    * ``mesh``: TRIANGLE_LIST of its faces, in the body frame (the vertices are already moved
      by ``mesh_offset_m`` so the COM is the body origin), scale 1; a ``compound``'s faces
      (its parts' surfaces) likewise.
    * ``plane``: a CUBE slab ``plane_size_m`` × ``plane_size_m`` × :data:`GROUND_THICKNESS_M`
      whose top face lies on the plane, centred under the plane point nearest the origin.

    :param ns: the marker namespace; ``marker_id`` an int32 id.
    :param color_rgba: 4 numbers in [0, 1].
    :param stamp_ns: the header stamp, integer ns.
    :raises InputError: naming ``position_w``, ``quat_wxyz``, ``color_rgba`` or
        ``marker_id`` with the value and unit.
    """
    position = finite_vector(position_w, 'position_w', 'm', frozen=False)
    quat = quat_normalize(finite_vector(quat_wxyz, 'quat_wxyz', '(w, x, y, z)', size=4),
                          'quat_wxyz')
    marker = Marker()
    _header(marker, frame_id, stamp_ns)
    marker.ns = str(ns)
    marker.id = _marker_id(marker_id)
    marker.action = Marker.ADD
    marker.color = _color(color_rgba)
    marker.frame_locked = False
    kind = shape.shape
    if kind not in _MARKER_TYPES:
        raise InputError(f'shape: {kind!r} has no marker type')
    marker.type = _MARKER_TYPES[kind]
    dims = np.asarray(shape.dimensions_m, dtype=np.float64)
    scale = (1.0, 1.0, 1.0)
    if kind == 'box':
        scale = tuple(dims)
    elif kind in ('sphere', 'spherical_shell'):
        scale = (2.0 * dims[0],) * 3
    elif kind == 'ellipsoid':
        scale = tuple(2.0 * dims)
    elif kind == 'cylinder':
        scale = (2.0 * dims[0], 2.0 * dims[0], dims[1])
    elif kind == 'plane':
        scale = (float(plane_size_m), float(plane_size_m), GROUND_THICKNESS_M)
        centre_b, q_bp = plane_frame(shape.params[:3], shape.params[3])
        # The slab's centre is half its thickness below the plane, along the normal.
        centre_b = centre_b - 0.5 * GROUND_THICKNESS_M * shape.params[:3]
        position = position + quat_to_matrix(quat) @ centre_b
        quat = quat_multiply(quat, q_bp)
    else:
        marker.points = _triangle_points(shape, segments, rings)
    marker.scale.x, marker.scale.y, marker.scale.z = (float(s) for s in scale)
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (
        float(p) for p in position)
    conv.quaternion_to_msg(quat, marker.pose.orientation)
    return marker


def static_markers(static_world: Optional['StaticWorld'], frame_id: str, stamp_ns: int,
                   plane_size_m: float = DEFAULT_PLANE_SIZE_M) -> MarkerArray:
    """
    Return the ``MarkerArray`` of a :class:`StaticWorld`: ns ``ground`` id 0, ``obstacles``.

    Obstacle ``i`` of ``static_world.obstacles`` gets id ``i`` and ``text`` its name.  Meant to
    be published once on a transient-local topic (late subscribers get it) and recorded once.
    An empty world (or None) gives an empty array.
    """
    out = MarkerArray()
    if static_world is None:
        return out
    ground = static_world.ground
    if ground is not None:
        marker = shape_marker(ground.shape, GROUND_NS, 0, frame_id, ground.position_w,
                              ground.orientation_wb, GROUND_COLOR, stamp_ns, plane_size_m)
        marker.text = ground.name
        out.markers.append(marker)
    for index, item in enumerate(static_world.obstacles):
        marker = shape_marker(item.shape, OBSTACLES_NS, index, frame_id, item.position_w,
                              item.orientation_wb, OBSTACLE_COLOR, stamp_ns)
        marker.text = item.name
        out.markers.append(marker)
    return out


def mesh_uri(mesh_path: str, file_path: str) -> str:
    """
    Return the URI a viewer loads a mesh marker from (``Marker.mesh_resource``).

    ``mesh_path`` is the parameter as given: a ``package://`` URI is kept, since RViz and
    Foxglove resolve it against the package's share directory as
    :func:`rbd_ros.sim.meshes.resolve_mesh_path` does; any other path becomes the ``file://`` URI
    of ``file_path`` (the file the node loaded), made absolute against the working directory.

    :raises InputError: naming ``mesh_path`` when it is empty or not a string.
    """
    if not isinstance(mesh_path, str) or not mesh_path:
        raise InputError(f'mesh_path: {mesh_path!r} is not a mesh file path or package:// URI')
    if mesh_path.startswith('package://'):
        return mesh_path
    return Path(os.path.abspath(file_path)).as_uri()


def _mesh_resource(name, entry):
    """Check one ``meshes`` entry ``(uri, scale)``; return ``(uri, scale tuple)``."""
    try:
        uri, scale = entry
    except (TypeError, ValueError):
        raise InputError(f'bodies.{name}.mesh_path: {entry!r} is not a (uri, mesh_scale) '
                         'pair') from None
    if not isinstance(uri, str) or not uri.startswith(('package://', 'file://')):
        raise InputError(f'bodies.{name}.mesh_path: {uri!r} must be a package:// or file:// '
                         'URI')
    try:
        factors = np.array(scale, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        factors = np.zeros(0)
    if factors.size != 3 or not np.all(np.isfinite(factors) & (factors > 0.0)):
        raise InputError(f'bodies.{name}.mesh_scale: {scale!r} must be 3 finite factors > 0 '
                         '(x, y, z)')
    return uri, tuple(float(f) for f in factors)


class BodyMarkers:
    """
    The bodies' markers, built once and re-posed every sample (the publishing fast path).

    Everything but the header stamp and the pose is fixed per body (type, scale, colour,
    mesh URI), so :meth:`array` only writes those: about 1 µs a marker where building one
    takes about 100 µs.  The returned array and its markers are reused by the next call:
    publish or serialise it first.

    Per shape, body ``i`` is (all in ns ``bodies``, id ``i``, unless said):

    * a mesh with an entry in ``meshes``: a MESH_RESOURCE marker, ``mesh_resource`` the URI,
      ``mesh_use_embedded_materials`` false (the body colour), scale the ``mesh_scale``.  The
      viewer draws the file's coordinates ``v`` scaled, ``x_w = R(q) (s ∘ v) + p_m``; the body
      frame is at the centre of mass, ``x_b = s ∘ v - mesh_offset_m``, so the marker position
      is ``p_m = p_w - R(q_wb) mesh_offset_m`` (the orientation is the body's).  The message
      carries the URI, not the triangles: its size does not depend on the mesh's face count.
    * a capsule: a CYLINDER (2 r, 2 r, length) at the body pose and two SPHERE caps of
      diameter 2 r at ``p_w ± R(q_wb) (0, 0, length / 2)``, ns :data:`BODY_CAPS_NS`, ids
      ``2 i`` (+z) and ``2 i + 1`` (-z), after every ``bodies`` marker: the exact capsule in
      three primitives, where its tessellation would be some 800 points a sample.
    * any other shape: :func:`shape_marker` at the body pose (a primitive type; a mesh
      without a file, given as arrays, stays a TRIANGLE_LIST of its faces).

    :param names: the body names (``text`` of each marker), in index order.
    :param shapes: their :class:`CollisionShape` values.
    :param frame_id: the world frame.
    :param meshes: None, or one entry per body: None, or ``(uri, mesh_scale)`` of its mesh
        file (:func:`mesh_uri`; 3 factors > 0).
    :raises InputError: naming ``shapes`` or ``meshes`` when its length differs from
        ``names``, ``bodies.<name>.shape`` for a plane or for a URI given to a shape that is
        not a mesh, ``bodies.<name>.mesh_path`` / ``mesh_scale`` for a bad entry.
    """

    def __init__(self, names: Sequence[str], shapes: Sequence['CollisionShape'],
                 frame_id: str,
                 meshes: Optional[Sequence[Optional[Tuple[str, Sequence[float]]]]] = None):
        self._names = [str(name) for name in names]
        shapes = list(shapes)
        count = len(self._names)
        if len(shapes) != count:
            raise InputError(f'shapes: {len(shapes)} entries for {count} bodies')
        meshes = [None] * count if meshes is None else list(meshes)
        if len(meshes) != count:
            raise InputError(f'meshes: {len(meshes)} entries for {count} bodies')
        self._array = MarkerArray()
        caps = []
        # Per marker: the body it follows and the body-frame vector from the body origin to
        # the marker origin (None: the body origin itself, so the pose is copied unchanged).
        sources, offsets = [], []
        for index, name in enumerate(self._names):
            shape = shapes[index]
            if shape.shape == 'plane':  # its marker pose is not the body pose
                raise InputError(
                    f'bodies.{name}.shape: a plane is static; a body needs a solid shape')
            if meshes[index] is not None and shape.shape != 'mesh':
                raise InputError(f'bodies.{name}.shape: {shape.shape!r} with a mesh URI; '
                                 'only a mesh shape has a mesh file')
            color = body_color(index)
            offset = None
            if meshes[index] is not None:
                uri, scale = _mesh_resource(name, meshes[index])
                marker = _body_marker(BODIES_NS, index, frame_id, Marker.MESH_RESOURCE, color,
                                      scale)
                marker.mesh_resource = uri
                marker.mesh_use_embedded_materials = False
                offset = -np.asarray(shape.mesh_offset_m, dtype=np.float64)
            elif shape.shape == 'capsule':
                radius, length = (float(d) for d in shape.dimensions_m)
                marker = _body_marker(BODIES_NS, index, frame_id, Marker.CYLINDER, color,
                                      (2.0 * radius, 2.0 * radius, length))
                for k, sign in enumerate((1.0, -1.0)):
                    cap = _body_marker(BODY_CAPS_NS, 2 * index + k, frame_id, Marker.SPHERE,
                                       color, (2.0 * radius,) * 3)
                    cap.text = name
                    caps.append((cap, index, np.array([0.0, 0.0, sign * 0.5 * length])))
            else:
                marker = shape_marker(shape, BODIES_NS, index, frame_id, (0.0, 0.0, 0.0),
                                      (1.0, 0.0, 0.0, 0.0), color, 0)
            marker.text = name
            self._array.markers.append(marker)
            sources.append(index)
            offsets.append(offset)
        for cap, index, offset in caps:
            self._array.markers.append(cap)
            sources.append(index)
            offsets.append(offset)
        self._sources = np.array(sources, dtype=np.int64)
        self._shifted = np.array([o is not None for o in offsets], dtype=bool)
        self._offsets_b = np.array([o for o in offsets if o is not None],
                                   dtype=np.float64).reshape(-1, 3)

    @property
    def names(self) -> List[str]:
        """Return the body names, in index order."""
        return list(self._names)

    def array(self, positions_w: np.ndarray, quats_wxyz: np.ndarray,
              stamp_ns: int, normalise: bool = True) -> MarkerArray:
        """
        Return the ``MarkerArray`` at these poses: ns ``bodies``, id = body index.

        The capsules' caps (ns ``body_caps``) follow the ``bodies`` markers.

        :param positions_w: (N, 3) COM positions, m.
        :param quats_wxyz: (N, 4) ``q_wb`` (w, x, y, z); normalised here unless ``normalise``
            is False (the node passes its pose samples' quaternions, so the markers carry
            exactly the published poses).
        :raises InputError: naming ``positions_w`` or ``quats_wxyz`` when the count differs
            from the bodies', or ``bodies.<name>.position_w`` / ``quat_wxyz`` when not finite
            (or a zero quaternion).
        """
        stamp = conv.time_to_msg(stamp_ns)
        for marker, (px, py, pz, qx, qy, qz, qw) in zip(
                self._array.markers, self.poses(positions_w, quats_wxyz, normalise).tolist()):
            marker.header.stamp = stamp
            point = marker.pose.position
            point.x, point.y, point.z = px, py, pz
            conv.quaternion_to_msg((qw, qx, qy, qz), marker.pose.orientation)
        return self._array

    @property
    def markers(self) -> List[Marker]:
        """Return the list of the markers :meth:`array` poses (the same objects), in order."""
        return list(self._array.markers)

    def poses(self, positions_w: np.ndarray, quats_wxyz: np.ndarray,
              normalise: bool = True) -> np.ndarray:
        """
        Return each marker's pose as :meth:`array` writes it: (M, 7) ``x, y, z, qx, qy, qz, qw``.

        In the order of :attr:`markers`; the arguments and errors are :meth:`array`'s.
        """
        count = len(self._names)
        positions = np.asarray(positions_w, dtype=np.float64)
        quats = np.asarray(quats_wxyz, dtype=np.float64)
        for field, array, width in (('positions_w', positions, 3), ('quats_wxyz', quats, 4)):
            if array.shape != (count, width):
                raise InputError(
                    f'{field}: shape {array.shape} for {count} bodies (expected ({count}, '
                    f'{width}))')
        norm = np.linalg.norm(quats, axis=1)
        bad = ~(np.isfinite(positions).all(axis=1) & np.isfinite(quats).all(axis=1)
                & (norm > 0.0))
        if bad.any():
            index = int(np.flatnonzero(bad)[0])
            raise InputError(
                f'bodies.{self._names[index]}: position_w {positions[index].tolist()} m, '
                f'quat_wxyz {quats[index].tolist()}: must be finite, the quaternion non-zero')
        if normalise:
            quats = quats / norm[:, None]
        positions = positions[self._sources]
        quats = quats[self._sources]
        if self._offsets_b.size:
            # x_w = R(q_wb) x_b + p_w at the marker origin x_b (the unshifted rows stay bit
            # for bit the body pose).
            positions[self._shifted] += quat_rotate(quats[self._shifted], self._offsets_b)
        return np.concatenate([positions, quats[:, 1:], quats[:, :1]], axis=1)


def body_markers(names: Sequence[str], shapes: Sequence['CollisionShape'],
                 positions_w: np.ndarray, quats_wxyz: np.ndarray, frame_id: str,
                 stamp_ns: int,
                 meshes: Optional[Sequence[Optional[Tuple[str, Sequence[float]]]]] = None
                 ) -> MarkerArray:
    """
    Return the ``MarkerArray`` of the bodies at their poses: ns ``bodies``, id = body index.

    A new array each call; a node publishing every sample should keep a
    :class:`BodyMarkers` and call its :meth:`BodyMarkers.array` (same markers, faster).

    :param names: the body names (``text`` of each marker), in index order.
    :param shapes: their :class:`CollisionShape` values.
    :param positions_w: (N, 3) COM positions, m.
    :param quats_wxyz: (N, 4) ``q_wb`` (w, x, y, z).
    :param meshes: the mesh files' ``(uri, mesh_scale)`` per body, as :class:`BodyMarkers`.
    :raises InputError: as :class:`BodyMarkers` and :meth:`BodyMarkers.array`.
    """
    return BodyMarkers(names, shapes, frame_id, meshes).array(positions_w, quats_wxyz,
                                                              stamp_ns)


def _contact_list(frame_id, stamp_ns, marker_id, marker_type, color_rgba, points):
    """Return one list marker of ns ``contacts`` (identity pose; the caller sets its scale)."""
    marker = Marker()
    _header(marker, frame_id, stamp_ns)
    marker.ns = CONTACTS_NS
    marker.id = marker_id
    marker.type = marker_type
    marker.action = Marker.ADD
    marker.pose.orientation.w = 1.0
    marker.color = _color(color_rgba)
    marker.points = points
    return marker


def contact_markers(contacts: 'Contacts', frame_id: str, stamp_ns: int,
                    arrow_scale_m_per_n_s: float = DEFAULT_ARROW_SCALE_M_PER_N_S
                    ) -> MarkerArray:
    """
    Return the ``MarkerArray`` of one step's contacts, ns ``contacts``.

    The array starts with a DELETEALL marker in ns ``contacts``, which removes the previous
    sample's contact markers and nothing else; then, when there are contacts, a SPHERE_LIST
    (id 0) of the points and a LINE_LIST (id 1) of the normals: from each point ``p`` to ``p
    + arrow_scale_m_per_n_s (J·n) n``, with ``J`` the impulse on body A (N·s) and ``n`` the
    unit normal (one row per contact and stage of the step, as :class:`Contacts`).

    Why a namespaced DELETEALL: both viewers delete only that namespace when ``ns`` is not
    empty (rviz2 ``MarkerCommon::processMessage`` since ros2/rviz#685, in Humble and Jazzy;
    Foxglove ``TopicMarkers._deleteAllMarkers(ns)``), and everything on the topic when it is
    empty, so the body and static markers beside them survive; the markers of one array are
    applied in order, so the new contacts appear after the deletion.  Why no empty lists: an
    empty POINTS/SPHERE_LIST/LINE_LIST is an error in Foxglove, so a step without contacts
    sends the DELETEALL alone.  Why one LINE_LIST and not an ARROW per contact: a resting
    world has many contact rows per body (measured: a box resting on the ground gives 12 a
    step at h = 1 ms, its 4 corners in each of the 3 stages), so 1000 boxes would be 12 000
    ARROW markers and scene objects a sample; one LINE_LIST costs 48 bytes a row, and the
    sphere at a line's foot shows which end is the contact point.

    :param contacts: a :class:`rbd_ros.core.contact.simulator.Contacts`.
    :param arrow_scale_m_per_n_s: line length per N·s of normal impulse, m/(N·s), finite >= 0.
        To draw forces instead, pass ``k / h`` for ``k`` m per N at the step ``h`` in s.
    :raises InputError: naming ``arrow_scale_m_per_n_s`` and its value.
    """
    points = contact_points(contacts, arrow_scale_m_per_n_s)
    markers = contact_prototypes(frame_id, stamp_ns)[:len(points)]
    for marker, array in zip(markers, points):
        marker.points = _points(array)
    return MarkerArray(markers=markers)


def contact_prototypes(frame_id: str, stamp_ns: int) -> List[Marker]:
    """
    Return :func:`contact_markers`' three markers (DELETEALL, points, lines) without points.

    :func:`contact_points` gives their points (the first one's, or all three's).
    """
    clear = Marker()
    _header(clear, frame_id, stamp_ns)
    clear.ns = CONTACTS_NS
    clear.id = 0
    clear.action = Marker.DELETEALL
    points = _contact_list(frame_id, stamp_ns, CONTACT_POINTS_ID, Marker.SPHERE_LIST,
                           CONTACT_POINT_COLOR, [])
    points.scale.x = points.scale.y = points.scale.z = CONTACT_POINT_DIAMETER_M
    # LINE_LIST: only scale.x is used, the line width.
    lines = _contact_list(frame_id, stamp_ns, CONTACT_NORMALS_ID, Marker.LINE_LIST,
                          CONTACT_NORMAL_COLOR, [])
    lines.scale.x = CONTACT_LINE_WIDTH_M
    return [clear, points, lines]


def contact_points(contacts: 'Contacts',
                   arrow_scale_m_per_n_s: float = DEFAULT_ARROW_SCALE_M_PER_N_S
                   ) -> List[np.ndarray]:
    """
    Return the points of :func:`contact_markers`' markers, (n, 3) float64 arrays.

    One (empty, the DELETEALL's) without contacts; three with: none, the contact points and
    the normals' ends two by two. Errors as :func:`contact_markers`.
    """
    scale = float(arrow_scale_m_per_n_s)
    if not (math.isfinite(scale) and scale >= 0.0):
        raise InputError(
            f'arrow_scale_m_per_n_s: {arrow_scale_m_per_n_s!r} m/(N·s) must be finite and >= 0')
    count = len(contacts)
    if count == 0:
        return [np.zeros((0, 3))]
    point_w = np.asarray(contacts.point_w, dtype=np.float64).reshape(count, 3)
    normal_w = np.asarray(contacts.normal_w, dtype=np.float64).reshape(count, 3)
    impulse_w = np.asarray(contacts.impulse_w, dtype=np.float64).reshape(count, 3)
    normal_impulse = np.einsum('ij,ij->i', impulse_w, normal_w)
    ends = point_w + (scale * normal_impulse)[:, None] * normal_w
    return [np.zeros((0, 3)), point_w, np.stack([point_w, ends], axis=1).reshape(-1, 3)]


def _link_marker(collision, index, frame, position, orientation, color):
    """Return the marker of one link ``<collision>`` element at ``position``, ``orientation``."""
    if collision.mesh_file is None:
        return shape_marker(collision.shape, LINKS_NS, index, frame, position, orientation,
                            color, 0)
    # the file, as a body's: x_l = R(q) (s ∘ v) + p, not re-centred
    filename, path, scale = collision.mesh_file
    marker = _body_marker(LINKS_NS, index, frame, Marker.MESH_RESOURCE, color, scale)
    marker.mesh_resource = mesh_uri(filename, path)
    marker.mesh_use_embedded_materials = False
    marker.pose.position.x, marker.pose.position.y, marker.pose.position.z = (
        float(v) for v in position)
    conv.quaternion_to_msg(orientation, marker.pose.orientation)
    return marker


class LinkMarkers:
    """
    Every robot link's collision shapes: built once, stamped a sample or published once.

    One marker per ``<collision>`` element (ns :data:`LINKS_NS`, ids in order of the robots,
    their URDF links and each link's elements; ``text`` = ``<robot>/<link>``), the element's
    shape as :func:`shape_marker` gives it; a mesh a MESH_RESOURCE of its file (:func:`mesh_uri`
    of the URDF's filename: ``package://`` kept, else the ``file://`` URI of the file loaded),
    scale the URDF's ``scale`` (the file's coordinates scaled are the element frame's: a link
    mesh is not re-centred), so a sample carries its URI, not its triangles.

    - A moving link's (:meth:`stamped`, on ``markers`` every sample): ``header.frame_id`` the
      link's frame as ``/tf`` names it (its URDF name), ``frame_locked`` true (a viewer moves
      it with the frame), the pose the element's ``<origin>`` in the link frame, its body's
      colour (:func:`body_color` of its index in the world, the free bodies first).
    - A link fixed to the world (:attr:`static`, on ``static_markers`` once, as the obstacles
      it collides as): in the world frame at its placed pose (the link's pose at time 0 times
      the element's ``<origin>``), ``frame_locked`` false, the obstacles' colour. It is not on
      ``markers`` (drawn once, where it is static).

    :param robots: the :class:`rbd_ros.sim.robots.RobotConfig` values.
    :param world_frame: the node's world frame id.
    :param first_body: the world index of the first robot's first link body (the free bodies'
        count).
    """

    def __init__(self, robots: Sequence['RobotConfig'], world_frame: str, first_body: int = 0):
        self._array = MarkerArray()
        #: The markers of the links fixed to the world (stamp 0), for ``static_markers``.
        self.static: List[Marker] = []
        body = first_body
        index = 0
        for robot in robots:
            urdf = robot.robot
            for link in urdf.links:
                fixed = link.body is None
                if fixed:
                    link_p, link_q = (np.asarray(v, dtype=np.float64) for v in
                                      robot.placement.link_poses_w[link.name])
                color = OBSTACLE_COLOR if fixed else body_color(body + link.body)
                for collision in link.collisions:
                    position, orientation = collision.position_l, collision.orientation_l
                    if fixed:  # its pose in the world: x_w = R(q_link) x_l + p_link
                        position = quat_to_matrix(link_q) @ position + link_p
                        orientation = quat_multiply(link_q, orientation)
                    marker = _link_marker(collision, index, world_frame if fixed else
                                          robot.link_frame(link.name, world_frame),
                                          position, orientation, color)
                    marker.frame_locked = not fixed
                    marker.text = f'{robot.name}/{link.name}'
                    (self.static if fixed else self._array.markers).append(marker)
                    index += 1
            body += len(urdf.body_links)

    def stamped(self, stamp_ns: int) -> List[Marker]:
        """Return the moving links' markers stamped ``stamp_ns`` (the same objects)."""
        stamp = conv.time_to_msg(stamp_ns)
        for marker in self._array.markers:
            marker.header.stamp = stamp
        return list(self._array.markers)
