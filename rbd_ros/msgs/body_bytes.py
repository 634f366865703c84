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
Every body's sample values and per-body messages at once, with numpy (a part of SampleBuilder).

:func:`twists` is the sample's arithmetic, on one body's floats (the scalar path,
:func:`rbd_ros.msgs.outputs._values`) or on arrays of every body (:class:`BodiesBytes`): the
same operations in the same order (IEEE-754 double arithmetic, each operation rounded once,
as Python's floats do; numpy fuses none of them), so every bit is the scalar path's. A body
whose quaternion is not unit to round-off takes the scalar path
(:meth:`rbd_ros.msgs.outputs.BodyOutputs.list_values`), as there. The per-body messages
(``pose``, ``twist``, ``odom``, ``contact_wrench``) keep their layout from sample to sample
(their frame strings are fixed), so they are written once as a template of every body's
messages end to end (each starting at 4 mod 8, so that its stamp and doubles are whole 8-byte
words); each sample writes its stamp and values in at their offsets (read off each message's
``struct`` format) and cuts the messages out. A world of 100 bodies: ~5 µs a
body by the scalar path, ~1 µs here.
"""

import re
import struct

import numpy as np
from rbd_ros.core import layout

_U8 = np.uint8
_TOKEN = re.compile(r'(\d*)([a-zA-Z?])')


def _argument_offsets(fmt):
    """Return ``(byte offset, code)`` of each argument a ``struct`` format packs, in order."""
    offsets, offset = [], 0
    for count, code in _TOKEN.findall(fmt.lstrip('<')):
        n = int(count) if count else 1
        if code == 'x':
            offset += n
        elif code == 's':
            offsets.append((offset, code))
            offset += n
        else:
            size = struct.calcsize('<' + code)
            offsets += [(offset + k * size, code) for k in range(n)]
            offset += n * size
    return offsets


def twists(q, v, omega_b, twist_world, sqrt):
    """
    Return ``(twist, twist_b)``, 6 components each, of ``q = (w, x, y, z)``, ``v_w``, ``ω_b``.

    The sample's arithmetic (:mod:`rbd_ros.msgs.outputs`' docstring: why each sum so), on
    floats (``sqrt`` :func:`math.sqrt`) or on arrays of every body (``sqrt`` :func:`np.sqrt`);
    ``twist`` is in the world frame with ``twist_world``, else it is ``twist_b``.
    """
    qw, qx, qy, qz = q
    norm = sqrt(((qw * qw + qx * qx) + qy * qy) + qz * qz)
    s = 2.0 / (norm * norm)
    # R = quat_to_matrix(q): xx = s x x, xy = s x y, ...
    sx, sy, sz, sw = s * qx, s * qy, s * qz, s * qw
    xx, yy, zz = sx * qx, sy * qy, sz * qz
    xy, xz, yz = sx * qy, sx * qz, sy * qz
    wx, wy, wz = sw * qx, sw * qy, sw * qz
    r00, r01, r02 = 1.0 - (yy + zz), xy - wz, xz + wy
    r10, r11, r12 = xy + wz, 1.0 - (xx + zz), yz - wx
    r20, r21, r22 = xz - wy, yz + wx, 1.0 - (xx + yy)
    v0, v1, v2 = v
    twist_b = (r00 * v0 + r10 * v1 + r20 * v2, r01 * v0 + r11 * v1 + r21 * v2,
               r02 * v0 + r12 * v1 + r22 * v2, *omega_b)
    if not twist_world:
        return twist_b, twist_b
    # ω_w = quat_rotate(q, ω_b) = ω + w t + u × t with t = s (u × ω), u = (x, y, z).
    o0, o1, o2 = omega_b
    t0, t1, t2 = s * (qy * o2 - qz * o1), s * (qz * o0 - qx * o2), s * (qx * o1 - qy * o0)
    omega_w = ((o0 + qw * t0) + (qy * t2 - qz * t1), (o1 + qw * t1) + (qz * t0 - qx * t2),
               (o2 + qw * t2) + (qx * t1 - qy * t0))
    return (v0, v1, v2, *omega_w), twist_b


def values(columns, twist_world):
    """
    Return ``p (N, 3), q (N, 4) w first, twist (N, 6), twist_b (N, 6), |q|² (N,)``.

    :func:`twists` of packed states, every column at once; ``|q|²`` summed as the scalar
    path's unit check sums it.
    """
    q = columns[layout.QUAT]
    qw, qx, qy, qz = q
    twist, twist_b = (np.stack(t, axis=1) for t in twists(
        q, columns[layout.VEL], columns[layout.OMEGA], twist_world, np.sqrt))
    return (columns[layout.POS].T.copy(), q.T.copy(), twist, twist_b,
            ((qw * qw + qx * qx) + qy * qy) + qz * qz)


class Scatter:
    """
    8-byte values written at fixed offsets of a buffer (stamps, doubles): a template's slots.

    Where every offset is the same mod 8 (the templates here are laid out so), as 8-byte
    words of the buffer, one index a value; else byte by byte.

    :param dtype: the values' type (``'<f8'`` doubles, ``'<u8'`` a stamp's 8 bytes).
    """

    def __init__(self, offsets, dtype):
        offsets = np.array(offsets, dtype=np.int64)
        shifts = set((offsets % 8).tolist())
        self._dtype = np.dtype(dtype)
        self._shift = shifts.pop() if len(shifts) == 1 else None
        self._index = offsets.reshape(-1, 1) + np.arange(8) if self._shift is None \
            else (offsets - self._shift) // 8

    def write(self, buf, values):
        """Write ``values`` (one for all, or one an offset) in ``buf`` (a bytearray)."""
        values = np.asarray(values, dtype=self._dtype)
        shift = self._shift
        if shift is None:
            np.frombuffer(buf, dtype=_U8)[self._index] = values.reshape(-1).view(_U8) \
                .reshape(-1, 8)
        else:
            np.frombuffer(buf, dtype=self._dtype, count=(len(buf) - shift) // 8,
                          offset=shift)[self._index] = values.reshape(-1)


def stamp_word(time_ns):
    """Return a header stamp's 8 bytes (``sec``, ``nanosec``) at ``time_ns`` as one ``<u8``."""
    return np.frombuffer(struct.pack('<iI', *divmod(time_ns, 1_000_000_000)), dtype='<u8')[0]


class _Words:
    """A template's stamps and doubles (:class:`Scatter` each)."""

    def __init__(self, stamps, doubles):
        self._stamps, self._doubles = Scatter(stamps, '<u8'), Scatter(doubles, '<f8')

    def write(self, buf, time_ns, doubles):
        """Write the stamp of ``time_ns`` and ``doubles`` (the template's count) in ``buf``."""
        self._stamps.write(buf, stamp_word(time_ns))
        self._doubles.write(buf, doubles)


class FixedLayout:
    """
    A message whose layout is fixed (its strings and lengths): a template, stamps and doubles.

    :param packer: the message's ``struct`` format (:func:`rbd_ros.msgs.cdr.layout`: each
        ``i`` a header's ``sec``, its ``nanosec`` right after it).
    :param args: any arguments of that format with its strings (the doubles are written over).

    :meth:`serialize` writes every stamp and every double, in the order of the format, into a
    copy of the template: the bytes of ``packer.pack`` with those values.
    """

    def __init__(self, packer, args):
        self._template = packer.pack(*args)
        offsets = _argument_offsets(packer.format)
        self._words = _Words([o for o, code in offsets if code == 'i'],
                             [o for o, code in offsets if code == 'd'])

    def serialize(self, time_ns, doubles):
        """Return the bytes at ``time_ns`` with ``doubles`` (float64, as many as the format's)."""
        buf = bytearray(self._template)
        self._words.write(buf, time_ns, doubles)
        return bytes(buf)


class BodiesBytes:
    """
    The per-body messages of every body, written at once.

    :param bodies: the :class:`rbd_ros.msgs.outputs.BodyOutputs` of the bodies, in order (one
        ``twist_frame`` and one set of kinds for all, as a world has).
    :param kinds: per body, the names of its kinds (``<prefix>pose``, ...), in the order of
        its ``kinds``.
    :param unit_tol: the ``| |q|² - 1 |`` above which a body takes the scalar path.
    """

    def __init__(self, bodies, kinds, unit_tol):
        self.bodies, self._unit_tol = bodies, unit_tol
        self.twist_world = bodies[0].twist_frame == 'world'
        self._kinds = bodies[0].kinds
        template, stamps, doubles, self._spans = bytearray(), [], [], []
        zero = ((0.0,) * 3, (0.0,) * 4, (0.0,) * 6, (0.0,) * 6)
        for body, names in zip(bodies, kinds):
            assert body.kinds == self._kinds, (body.kinds, self._kinds)
            built = dict(body.serialize(0, zero, ((0.0,) * 3, (0.0,) * 3)))
            packers = {'pose': body._pose, 'twist': body._twist, 'odom': body._odom,
                       'contact_wrench': body._wrench}
            for kind, name in zip(body.kinds, names):
                offsets = _argument_offsets(packers[kind].format)
                # Each message starts at 4 mod 8, so its stamp and doubles (8-aligned after
                # its 4-byte encapsulation) are whole 8-byte words of the buffer.
                template += bytes(-(len(template) - 4) % 8)
                base = len(template)
                # Argument 0 is the encapsulation, then the header's sec (i) and nanosec (I).
                stamps.append(base + offsets[1][0])
                doubles += [base + offset for offset, code in offsets if code == 'd']
                template += built[kind]
                self._spans.append((name, base, len(template)))
        self._template = bytes(template)
        self._names = [name for name, _, _ in self._spans]
        self._slices = [slice(start, end) for _, start, end in self._spans]
        self._words = _Words(stamps, doubles)

    def values(self, columns):
        """Return ``p, q, twist, twist_b`` of every body (:func:`values`, checked unit)."""
        p, q, twist, twist_b, norm_sq = values(columns, self.twist_world)
        for i in np.flatnonzero(np.abs(norm_sq - 1.0) > self._unit_tol):
            p[i], q[i], twist[i], twist_b[i] = self.bodies[i].list_values(
                columns[:, i].tolist())
        return p, q, twist, twist_b

    def serialize(self, time_ns, sample, wrenches=None, wanted=None):
        """
        Return ``[(kind, CDR bytes)]`` of every body's kinds (those in ``wanted`` if given).

        :param sample: :meth:`values` now; ``wrenches`` (N, 6) with ``contact_wrench`` (more
            rows, a robot's links', are not read).
        """
        p, q, twist, twist_b = sample
        xyzw = q[:, [1, 2, 3, 0]]
        blocks = {'pose': (p, xyzw), 'twist': (twist,), 'odom': (p, xyzw, twist_b),
                  'contact_wrench': (None if wrenches is None else wrenches[:len(p)],)}
        rows = np.concatenate([b for kind in self._kinds for b in blocks[kind]], axis=1)
        buf = bytearray(self._template)
        self._words.write(buf, time_ns, rows)
        data = bytes(buf)
        if wanted is None:  # zip and map: no Python frame a message
            return list(zip(self._names, map(data.__getitem__, self._slices)))
        return [(name, data[start:end]) for name, start, end in self._spans if name in wanted]
