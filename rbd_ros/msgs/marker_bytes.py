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
The node's ``markers`` sample as CDR bytes, without rclpy's serialiser.

rclpy serialises a ``MarkerArray`` from its Python objects, reading each field and each
``Point`` through Python: a world of 100 resting boxes (1,200 contact rows a step, 3,600
points on its two contact markers) took ~12 ms a sample, and building the points ~2 ms more,
ten times the physics of the 10 steps between samples. :class:`MarkerArrayBytes` writes the
markers that keep their layout from sample to sample (the bodies', their caps', the robots'
links') once, as a template, and at each sample writes the stamp and the poses into a copy of
it at their offsets, then the contact markers (templates too) with their points from numpy
arrays. The bytes
are what rclpy deserialises into the same ``MarkerArray`` (a test checks it, and the length
rclpy's serialiser gives it); padding bytes are zeros.

CDR is XCDR1 little endian as :mod:`rbd_ros.msgs.cdr` writes it (encapsulation ``00 01 00 00``,
alignment counted after it): ``visualization_msgs/Marker`` field by field, in its order.
"""

import struct

import numpy as np
from rbd_ros.msgs.body_bytes import Scatter, stamp_word

_ENCAPSULATION = b'\x00\x01\x00\x00'
_STAMP = struct.Struct('<iI')
_POSE_BYTES = 7 * 8


class _Writer:
    """A CDR stream in a bytearray; offsets count from after the encapsulation header."""

    def __init__(self, buf=None):
        self.buf = bytearray(_ENCAPSULATION) if buf is None else buf

    def align(self, size):
        pad = -(len(self.buf) - 4) % size
        if pad:
            self.buf += bytes(pad)

    def pack(self, fmt, size, *values):
        self.align(size)
        self.buf += struct.pack('<' + fmt, *values)

    def string(self, text):
        data = text.encode('utf-8') + b'\x00'
        self.pack('I', 4, len(data))
        self.buf += data

    def octets(self, data):
        self.pack('I', 4, len(data))
        self.buf += bytes(data)

    def header(self, header):
        """Write a ``std_msgs/Header``; return the offset of its stamp in ``buf``."""
        self.align(4)
        offset = len(self.buf)
        self.buf += _STAMP.pack(header.stamp.sec, header.stamp.nanosec)
        self.string(header.frame_id)
        return offset

    def marker(self, m, points=None):
        """
        Write a ``visualization_msgs/Marker``; return where its stamp, pose, points start.

        The three are offsets in ``buf``: the stamp's, the pose's and the points' count's.

        :param points: an (n, 3) float64 array written as ``points`` (``m.points`` is then
            not read), or None to write ``m.points``.
        """
        stamp = self.header(m.header)
        self.string(m.ns)
        self.pack('iii', 4, m.id, m.type, m.action)
        p, q = m.pose.position, m.pose.orientation
        self.align(8)
        pose = len(self.buf)
        self.buf += struct.pack('<7d', p.x, p.y, p.z, q.x, q.y, q.z, q.w)
        self.pack('3d', 8, m.scale.x, m.scale.y, m.scale.z)
        c = m.color
        self.pack('4f', 4, c.r, c.g, c.b, c.a)
        self.pack('iI?', 4, m.lifetime.sec, m.lifetime.nanosec, m.frame_locked)
        if points is None:
            points = np.array([(v.x, v.y, v.z) for v in m.points], dtype=np.float64)
        points = np.ascontiguousarray(points, dtype='<f8').reshape(-1, 3)
        self.align(4)
        count = len(self.buf)
        self.pack('I', 4, len(points))
        if len(points):
            self.align(8)
            self.buf += points.tobytes()
        self.pack('I', 4, len(m.colors))
        for c in m.colors:
            self.pack('4f', 4, c.r, c.g, c.b, c.a)
        self.string(m.texture_resource)
        self.header(m.texture.header)
        self.string(m.texture.format)
        self.octets(m.texture.data)
        self.pack('I', 4, len(m.uv_coordinates))
        for uv in m.uv_coordinates:
            self.pack('2f', 4, uv.u, uv.v)
        self.string(m.text)
        self.string(m.mesh_resource)
        self.string(m.mesh_file.filename)
        self.octets(m.mesh_file.data)
        self.pack('?', 1, m.mesh_use_embedded_materials)
        return stamp, pose, count


class MarkerArrayBytes:
    """
    The CDR bytes of a ``MarkerArray``: fixed markers first, then some of the tail's.

    :param fixed: the markers whose fields other than the header stamp and the pose do not
        change (written once, as a template; the objects are not kept).
    :param posed: how many of the first ``fixed`` markers :meth:`serialize` poses.
    :param tail: markers that follow, of which each sample sends the first few with points of
        its own and its stamp (the contact markers, :func:`rbd_ros.msgs.markers.
        contact_prototypes`): written once without points, their points put in each sample.
    """

    def __init__(self, fixed, posed, tail=()):
        writer = _Writer()
        writer.pack('I', 4, len(fixed))
        offsets = [writer.marker(m) for m in fixed]
        self._template = bytes(writer.buf)
        self._count = len(fixed)
        self._posed = int(posed)
        # Where every stamp goes, and the posed markers' poses (7 doubles, 8-aligned each).
        self._stamps = Scatter([s for s, _, _ in offsets], '<u8')
        self._poses = Scatter([p + 8 * k for _, p, _ in offsets[:posed]
                               for k in range(_POSE_BYTES // 8)], '<f8')
        # Each tail marker as (bytes up to and with its points' count, the rest, offset of its
        # stamp). Points are 24 bytes each and start 8-aligned, so a marker's points move
        # nothing after them off their alignment.
        self._tail = []
        for m in tail:
            start = len(writer.buf)
            stamp, _, count = writer.marker(m, np.zeros((0, 3)))
            if (count + 4 - 4) % 8:
                raise ValueError('a tail marker whose points would not start 8-aligned')
            piece = bytes(writer.buf[start:])
            self._tail.append((piece[:count + 4 - start], piece[count + 4 - start:],
                               stamp - start))

    def serialize(self, stamp_ns, poses, points=()):
        """
        Return the bytes at ``stamp_ns`` (int ns): the fixed markers, then the tail's first.

        :param poses: (posed, 7) float64, each posed marker's ``x, y, z, qx, qy, qz, qw``.
        :param points: for each of the first tail markers sent, its points, (n, 3) float64.
        """
        buf = bytearray(self._template)
        stamp = _STAMP.pack(*divmod(int(stamp_ns), 1_000_000_000))
        if self._count:
            self._stamps.write(buf, stamp_word(int(stamp_ns)))
        if self._posed:
            self._poses.write(buf, np.ascontiguousarray(poses, dtype='<f8').reshape(-1))
        struct.pack_into('<I', buf, 4, self._count + len(points))
        for (head, rest, at), array in zip(self._tail, points):
            array = np.ascontiguousarray(array, dtype='<f8')
            start = len(buf)
            buf += head
            buf[start + at:start + at + _STAMP.size] = stamp
            struct.pack_into('<I', buf, len(buf) - 4, len(array))
            buf += array.tobytes()
            buf += rest
        return bytes(buf)
