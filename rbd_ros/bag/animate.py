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
Animate a world from arrays: a GIF, or an MP4 when ffmpeg is installed.

For people without RViz or Foxglove: :func:`write_animation` draws one frame per sample with
matplotlib's 3-D axes (Agg, no window): every body's surface
(:func:`rbd_ros.sim.tessellation.shape_triangles`) as a shaded ``Poly3DCollection`` in its colour
(:func:`rbd_ros.sim.tessellation.body_color`, as its marker), the obstacles in brown and the
ground plane as a grey square under the scene.  No ROS and no
messages here: the caller reads poses from wherever (a bag, a simulator) into arrays.
"""

import math
import os
from pathlib import Path
from typing import Optional, Sequence, Tuple, TYPE_CHECKING, Union

import numpy as np
from rbd_ros.core.errors import ConfigError, InputError
from rbd_ros.core.rotations import quat_to_matrix
from rbd_ros.sim.params import NS_PER_S
from rbd_ros.sim.tessellation import body_color, plane_frame, shape_triangles

if TYPE_CHECKING:  # pragma: no cover - annotations only
    from rbd_ros.core.contact import CollisionShape, StaticWorld

__all__ = ['write_animation']

_OBSTACLE_COLOR = (0.45, 0.35, 0.25, 1.0)
_GROUND_COLOR = (0.6, 0.6, 0.6, 0.5)
# Light direction for the flat shading of faces (world frame, towards the light).
_LIGHT_W = np.array([0.3, -0.5, 0.8]) / math.sqrt(0.3 ** 2 + 0.5 ** 2 + 0.8 ** 2)
# Round shapes are drawn coarser than the markers: an animation frame redraws every triangle.
_SEGMENTS = 16
_RINGS = 8


def _shaded(tris_w, color):
    """Face colours: ``color`` darkened to 45 % on faces turned away from the light."""
    normal = np.cross(tris_w[:, 1] - tris_w[:, 0], tris_w[:, 2] - tris_w[:, 0])
    length = np.linalg.norm(normal, axis=1)
    length[length == 0.0] = 1.0
    light = np.clip((normal / length[:, None]) @ _LIGHT_W, 0.0, 1.0)
    rgba = np.tile(np.asarray(color, dtype=np.float64), (tris_w.shape[0], 1))
    rgba[:, :3] *= (0.45 + 0.55 * light)[:, None]
    return rgba


def _posed(tris_b, position_w, quat_wxyz):
    return tris_b @ quat_to_matrix(quat_wxyz).T + position_w


def _arrays(times_ns, positions_w, quats_wxyz, shapes):
    times = np.asarray(times_ns, dtype=np.int64).reshape(-1)
    frames = times.shape[0]
    count = len(shapes)
    positions = _per_body(positions_w, 'positions_w', frames, count, 3, 'm')
    quats = _per_body(quats_wxyz, 'quats_wxyz', frames, count, 4, '(w, x, y, z)')
    if frames == 0:
        raise InputError('times_ns: no samples to animate')
    if frames > 1 and np.any(np.diff(times) <= 0):
        raise InputError('times_ns: sample times (ns) must increase')
    for name, array in (('positions_w', positions), ('quats_wxyz', quats)):
        if not np.all(np.isfinite(array)):
            raise InputError(f'{name}: holds non-finite values')
    return times, positions, quats


def _limits(points_w):
    """Cube around the points (equal scale on the three axes), 10 % margin."""
    low, high = points_w.min(axis=0), points_w.max(axis=0)
    centre = 0.5 * (low + high)
    half = max(0.55 * float((high - low).max()), 1e-3)
    return centre - half, centre + half


def _per_body(values, name, frames, count, width, unit):
    """Return ``values`` as a (frames, count, width) float array, or raise naming ``name``."""
    try:
        return np.asarray(values, dtype=np.float64).reshape(frames, count, width)
    except ValueError:
        raise InputError(f'{name}: shape {np.shape(values)} is not ({frames} samples, {count} '
                         f'bodies, {width}) {unit}') from None


def write_animation(path: Union[str, os.PathLike], times_ns: Sequence[int],
                    positions_w: np.ndarray, quats_wxyz: np.ndarray,
                    shapes: Sequence['CollisionShape'],
                    static_world: Optional['StaticWorld'] = None, *,
                    fps: Optional[float] = None, size_px: Tuple[int, int] = (640, 480),
                    dpi: int = 80, elevation_deg: float = 25.0,
                    azimuth_deg: float = -60.0) -> int:
    """
    Write an animation of a world to ``path``: a GIF, or an MP4 when ffmpeg is installed.

    :param path: output file; ``.gif`` (matplotlib's ``PillowWriter``) or ``.mp4``
        (``FFMpegWriter``, only if ffmpeg is on the PATH).
    :param times_ns: (F,) increasing sample times, integer ns; one frame per sample.
    :param positions_w: (F, N, 3) body COM positions, m.
    :param quats_wxyz: (F, N, 4) body orientations ``q_wb`` (w, x, y, z).
    :param shapes: the N bodies' :class:`rbd_ros.core.contact.CollisionShape` values.
    :param static_world: a :class:`rbd_ros.core.contact.StaticWorld`, or None.
    :param fps: frames per second of the file; None plays in real time (the median sample
        interval; 10 fps for a single sample).
    :param size_px: (width, height) of every frame in pixels.
    :param dpi: dots per inch of the matplotlib figure (the frame is ``size_px`` at any dpi).
    :returns: the number of frames written.
    :raises InputError: naming ``times_ns``, ``positions_w`` or ``quats_wxyz`` when they do
        not match or are not finite, ``fps`` or ``size_px`` when not positive.
    :raises ConfigError: naming ``path`` when its suffix is neither ``.gif`` nor ``.mp4``, or
        MP4 is asked for without ffmpeg.
    """
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import animation
    from matplotlib.figure import Figure
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    path = Path(path)
    suffix = path.suffix.lower()
    if suffix == '.gif':
        writer_class = animation.PillowWriter
    elif suffix == '.mp4':
        if not animation.writers.is_available('ffmpeg'):
            raise ConfigError(
                f'path: {str(path)!r} asks for MP4 but ffmpeg is not installed; write a .gif')
        writer_class = animation.FFMpegWriter
    else:
        raise ConfigError(f'path: {str(path)!r} must end in .gif or .mp4')
    shapes = list(shapes)
    times, positions, quats = _arrays(times_ns, positions_w, quats_wxyz, shapes)
    if fps is None:
        step_s = float(np.median(np.diff(times))) / NS_PER_S if times.size > 1 else 0.1
        fps = 1.0 / step_s
    if not (isinstance(fps, (int, float)) and math.isfinite(fps) and fps > 0.0):
        raise InputError(f'fps: {fps!r} frames/s must be finite and > 0')
    width, height = (int(v) for v in size_px)
    if width <= 0 or height <= 0:
        raise InputError(f'size_px: {tuple(size_px)!r} pixels must be two integers > 0')

    body_tris = [shape_triangles(s, _SEGMENTS, _RINGS) for s in shapes]
    static_tris = []
    ground = None
    if static_world is not None:
        ground = static_world.ground
        for item in static_world.obstacles:
            tris = _posed(shape_triangles(item.shape, _SEGMENTS, _RINGS), item.position_w,
                          item.orientation_wb)
            static_tris.append(tris)
    extent = [positions.reshape(-1, 3)]
    for index, tris in enumerate(body_tris):  # reach of each body about its COM
        radius = float(np.linalg.norm(tris.reshape(-1, 3), axis=1).max())
        extent.append(positions[:, index] + radius)
        extent.append(positions[:, index] - radius)
    extent += [t.reshape(-1, 3) for t in static_tris]
    low, high = _limits(np.concatenate(extent))

    fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi)
    ax = fig.add_subplot(projection='3d')
    fig.subplots_adjust(left=0.0, right=1.0, bottom=0.02, top=1.0)
    ax.set_xlim(low[0], high[0])
    ax.set_ylim(low[1], high[1])
    ax.set_zlim(low[2], high[2])
    ax.set_box_aspect((1.0, 1.0, 1.0))
    ax.view_init(elev=elevation_deg, azim=azimuth_deg)
    ax.set_xlabel('x (m)')
    ax.set_ylabel('y (m)')
    ax.set_zlabel('z (m)')
    if ground is not None:
        centre, q_bp = plane_frame(ground.shape.params[:3], ground.shape.params[3])
        rot = quat_to_matrix(q_bp)
        n = rot[:, 2]
        middle = 0.5 * (low + high)
        foot = middle - (float(middle @ n) - float(ground.shape.params[3])) * n
        half = 0.5 * float((high - low).max())
        square = np.array([[-1, -1, 0], [1, -1, 0], [1, 1, 0], [-1, 1, 0]]) * half
        ax.add_collection3d(Poly3DCollection([square @ rot.T + foot], facecolors=_GROUND_COLOR,
                                             edgecolors='none'))
    for tris in static_tris:
        ax.add_collection3d(Poly3DCollection(tris, facecolors=_shaded(tris, _OBSTACLE_COLOR),
                                             edgecolors='none'))
    collections = []
    for index, tris in enumerate(body_tris):
        posed = _posed(tris, positions[0, index], quats[0, index])
        collection = Poly3DCollection(posed, facecolors=_shaded(posed, body_color(index)),
                                      edgecolors='none')
        ax.add_collection3d(collection)
        collections.append(collection)
    label = ax.text2D(0.02, 0.95, '', transform=ax.transAxes)

    writer = writer_class(fps=fps)
    with writer.saving(fig, str(path), dpi):
        for frame in range(times.shape[0]):
            for index, (tris, collection) in enumerate(zip(body_tris, collections)):
                posed = _posed(tris, positions[frame, index], quats[frame, index])
                collection.set_verts(posed)
                collection.set_facecolor(_shaded(posed, body_color(index)))
            label.set_text(f't = {times[frame] / NS_PER_S:.3f} s')
            writer.grab_frame()
    return int(times.shape[0])
