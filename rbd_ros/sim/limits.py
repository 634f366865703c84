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
The documented limits of a run and of a recording, in one place, and the checks against them.

A recording is data from outside: a crafted or damaged bag must not make ``replay`` or
``plot`` work for hours or grow to gigabytes before saying anything.  Both tools check a bag
against these limits before doing the work (:func:`check_mcap_chunks` on the raw file before it
is parsed, :func:`check_bag` once its header and summary are read) and refuse it with one line
naming the field, its value and the limit (exit status 2).

The node steps its world in chunks of at most :func:`step_chunk` steps, so a signal is seen
between chunks (numba's compiled step does not run Python signal handlers).

The parameters' bounds on sizes, positions and counts (:data:`MAX_BODIES`, :data:`MAX_SIZE`,
:data:`MAX_POSITION_M`, ...) are here too; :mod:`rbd_ros.sim.param_rules` and the configuration
check values against them (:mod:`rbd_ros.sim.params`, their old home, still gives them).
"""

import os
import struct

from rbd_ros.core.errors import RecordingError

#: Largest number of physics steps a recording may ask ``replay`` to take (its last log time
#: over its step): 1e8 steps of one body take about 2 min here.
MAX_REPLAY_STEPS = 100_000_000
#: Largest number of body-steps (steps x bodies) a recording may ask ``replay`` to take.
MAX_REPLAY_BODY_STEPS = 1_000_000_000
#: Largest uncompressed size a chunk of a recording may declare, bytes (the node writes chunks
#: of 1 MiB of message data; 64 MiB leaves room for big worlds' samples).
MAX_CHUNK_BYTES = 64 << 20
#: Largest attached mesh, bytes: the largest mesh file the node reads
#: (:data:`MAX_MESH_FILE_BYTES`; an ASCII STL of 200,000 triangles is ~50 MB),
#: checked in the attachment's record header before its bytes are read.
MAX_MESH_BYTES = 64 << 20
#: Largest number of triangles of a mesh file or an attached mesh, counted in its bytes before
#: it is built (building costs ~0.6 ms a triangle here: ~2 min at the limit, then cached).
MAX_MESH_TRIANGLES = 200_000
#: A node with more endpoints (publishers, subscriptions, services) than this leaves without
#: deleting them one by one once its recording is final (Fast DDS deletes them in superlinear
#: time: 1,500 publishers 0.4 s, 6,000 publishers 3.6 s).
TEARDOWN_ENDPOINTS = 1000
#: Body-steps per compiled call of the node and of replay (~0.1 s at 1 us per body-step).
STEP_CHUNK_BODY_STEPS = 100_000

# The bounds of the parameters (rbd_ros.sim.params), on sizes, positions and counts.

#: Most bodies a world may have (``bodies``): start-up checks and the contact step are measured
#: up to 1000 bodies; far more makes start-up take minutes.
MAX_BODIES = 5000

#: Most threads ``threads`` may ask for.
MAX_THREADS = 1024

#: Most items an array parameter may hold (10 x MAX_BODIES): more than any list a world needs
#: (``body_names`` holds at most MAX_BODIES). A recording's configuration is read with the same
#: bound, so a bag claiming 10^5 bodies is refused while it is parsed.
MAX_ARRAY_ITEMS = 10 * MAX_BODIES

#: Largest ``dimensions_m`` value and ``mesh_scale`` factor accepted (m, and 1): beyond it the
#: inertia (``m d²``) and contact tolerances leave double precision's useful range.
MAX_SIZE = 1e6

#: Smallest ``dimensions_m`` value accepted, m: over 500 times the float64 spacing of
#: coordinates at :data:`MAX_POSITION_M` (1.9e-9 m), so a body's faces stay apart after
#: ``R x_b + p``; a size of 1e-300 m would put both faces of a plate on one coordinate.
MIN_SIZE = 1e-6

#: Largest ``|initial_position|`` and obstacle ``position`` component accepted, m: there
#: float64 coordinates are 1.9e-9 m apart, six orders below the 1 mm start-overlap tolerance;
#: at 1e300 m a body's surface points all round to its centre.
MAX_POSITION_M = 1e7

#: Largest ``|initial joint position|`` of a robot's joint, rad or m: a continuous joint has
#: no limits to hold it, and at 1e7 rad float64 still resolves 1.9e-9 rad (at 1e300 rad a
#: whole turn is below its spacing); the same number as :data:`MAX_POSITION_M`.
MAX_JOINT_POSITION = 1e7

#: Largest ``|initial joint velocity|`` of a robot's joint, rad/s or m/s: a joint at it covers
#: :data:`MAX_JOINT_POSITION` in 1 s, the longest ``timestep_s``; a rate of 1e200 made the
#: first step non-finite.
MAX_JOINT_RATE = 1e7

#: Largest ``*mesh_path`` file accepted (read to build the shape, and embedded in a recording).
MAX_MESH_FILE_BYTES = 64 * 1024 * 1024

_MAGIC = b'\x89MCAP0\r\n'
_CHUNK = 0x06
_ATTACHMENT = 0x09
_RECORD = struct.Struct('<BQ')
_CHUNK_HEAD = struct.Struct('<QQQ')  # message start, message end, uncompressed size


def step_chunk(n_bodies):
    """Return the most steps one compiled call may take for a world of ``n_bodies`` bodies."""
    return max(1, STEP_CHUNK_BODY_STEPS // max(1, int(n_bodies)))


def mcap_files(path):
    """Return the ``.mcap`` files of a bag directory or the file itself."""
    if os.path.isdir(path):
        return sorted(os.path.join(path, name) for name in os.listdir(path)
                      if name.endswith('.mcap'))
    return [path]


def check_mcap_chunks(path):
    """
    Refuse an MCAP file with a chunk or an attachment over the limits, from its record headers.

    A chunk may declare at most :data:`MAX_CHUNK_BYTES` uncompressed, an attachment hold at
    most :data:`MAX_MESH_BYTES`.

    Reads only the record headers (opcode, length, a chunk's first 24 bytes, an attachment's
    name and data length), seeking over the contents, so it costs a few reads per record
    whatever the records declare, and nothing is decompressed or read whole.

    :raises RecordingError: naming the file, the record's offset and its declared size.
    """
    for name in mcap_files(path):
        try:
            size = os.path.getsize(name)
            stream = open(name, 'rb')
        except OSError:
            continue  # the reader reports an unreadable file in its own words
        with stream:
            _check_chunks(stream, name, size)


def _check_chunks(f, name, size):
    if f.read(len(_MAGIC)) != _MAGIC:
        return  # not MCAP: the reader says so in its own words
    offset = len(_MAGIC)
    while offset + _RECORD.size <= size:
        f.seek(offset)
        opcode, length = _RECORD.unpack(f.read(_RECORD.size))
        if opcode == _CHUNK and length >= _CHUNK_HEAD.size:
            _, _, uncompressed = _CHUNK_HEAD.unpack(f.read(_CHUNK_HEAD.size))
            if uncompressed > MAX_CHUNK_BYTES:
                raise RecordingError(
                    f'{name}: the chunk at byte {offset} declares an uncompressed size of '
                    f'{uncompressed} bytes, more than the limit of {MAX_CHUNK_BYTES} bytes '
                    '(rbd_ros.sim.limits.MAX_CHUNK_BYTES)')
        if opcode == _ATTACHMENT and length > MAX_MESH_BYTES:
            _check_attachment(f, name, offset, length)
        if opcode == 0x02 or length > size:  # the footer, or a length past the end
            return
        offset += _RECORD.size + length


def _check_attachment(f, name, offset, length):
    """Refuse the attachment record of ``length`` bytes at ``offset`` if its data is too big."""
    f.seek(offset + _RECORD.size + 16)  # past the log and create times
    try:
        (name_len,) = struct.unpack('<I', f.read(4))
        shown = f.read(min(name_len, 200)).decode('utf-8', 'replace')
        f.seek(offset + _RECORD.size + 20 + name_len)
        (media_len,) = struct.unpack('<I', f.read(4))
        f.seek(offset + _RECORD.size + 24 + name_len + media_len)
        (size,) = struct.unpack('<Q', f.read(8))
    except struct.error:
        return  # cut off: the reader reports it in its own words
    if size > MAX_MESH_BYTES:
        raise RecordingError(
            f'{name}: attached mesh {shown!r} (the record at byte {offset}) is {size} bytes, '
            f'more than the limit of {MAX_MESH_BYTES} bytes (rbd_ros.sim.limits.MAX_MESH_BYTES)')


def check_steps(bag, end_ns=None):
    """
    Refuse a recording whose replay would take more steps than the limits allow.

    The steps: the last log time (or ``end_ns``: the last log times of the runs between
    ``~/reset`` calls, summed) over the recorded step, times the bodies.

    :param bag: an opened :class:`rbd_ros.bag.recording.Bag`.
    :raises RecordingError: naming ``timestep_s``, its value, the steps and the limits.
    """
    from rbd_ros.sim.params import recorded_parameters  # today's names, also for an old bag
    config = recorded_parameters(bag.config or {})
    timestep_s = config.get('timestep_s')
    end_ns = bag.end_ns if end_ns is None else end_ns
    if isinstance(timestep_s, (int, float)) and timestep_s > 0 and end_ns:
        steps = end_ns / (timestep_s * 1e9)
        bodies = max(1, len(config.get('body_names') or ()))
        if steps > MAX_REPLAY_STEPS or steps * bodies > MAX_REPLAY_BODY_STEPS:
            raise RecordingError(
                f'{bag.mcap_path}: timestep_s = {timestep_s:g} s up to the last message at '
                f'{end_ns} ns is {steps:.3g} steps of {bodies} bodies, more than the limit '
                f'of {MAX_REPLAY_STEPS} steps and {MAX_REPLAY_BODY_STEPS} body-steps '
                '(rbd_ros.sim.limits.MAX_REPLAY_STEPS, MAX_REPLAY_BODY_STEPS)')


def check_bag(bag, steps=True):
    """
    Refuse a recording that asks for more work than the limits allow, before doing any.

    Checks every attachment: a mesh (:func:`rbd_ros.sim.meshes.mesh_data_problem`: STL or
    OBJ, not compressed, finite, at most :data:`MAX_MESH_TRIANGLES`) of at most
    :data:`MAX_MESH_BYTES`; and, with ``steps``, the steps to
    replay (:func:`check_steps`; replay checks them after its own time checks, which say more
    precisely what is wrong with a log time).

    :param bag: an opened :class:`rbd_ros.bag.recording.Bag`.
    :raises RecordingError: naming the field, its value and unit, and the limit.
    """
    if steps:
        check_steps(bag)
    from rbd_ros.sim.meshes import mesh_data_problem  # meshes imports this module
    for name, data in bag.attachments().items():
        if len(data) > MAX_MESH_BYTES:
            raise RecordingError(
                f'{bag.mcap_path}: attached mesh {name!r} is {len(data)} bytes, more than the '
                f'limit of {MAX_MESH_BYTES} bytes (rbd_ros.sim.limits.MAX_MESH_BYTES)')
        problem = mesh_data_problem(name, data)
        if problem is not None:
            raise RecordingError(f'{bag.mcap_path}: attached mesh {name!r} {problem}')
