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

"""World animation: a small GIF's frame count, size, frame time and motion; bad input."""

from matplotlib import animation
import numpy as np
from PIL import Image, ImageChops
import pytest
from rbd_ros.bag.animate import write_animation
from rbd_ros.core.contact import ground_plane, mesh_shape, obstacle, primitive_shape, StaticWorld
from rbd_ros.core.errors import ConfigError, InputError
from rbd_ros.core.rotations import quat_from_axis_angle
import trimesh

FRAMES = 6
STEP_NS = 100_000_000  # 10 samples a second: real time is 10 fps, 100 ms a frame
SIZE_PX = (200, 150)


def scene():
    """Return arrays of a box sliding along x while turning, a resting sphere and a ring mesh."""
    ring = trimesh.creation.annulus(r_min=0.1, r_max=0.2, height=0.1, sections=12)
    shapes = [primitive_shape('box', [0.4, 0.3, 0.2]), primitive_shape('sphere', [0.1]),
              mesh_shape(ring.vertices, ring.faces, cache_dir=False)]
    times = np.arange(FRAMES, dtype=np.int64) * STEP_NS
    positions = np.zeros((FRAMES, 3, 3))
    positions[:, 0] = [[0.2 * k, 0.0, 0.1] for k in range(FRAMES)]
    positions[:, 1] = [0.0, 0.6, 0.1]
    positions[:, 2] = [-0.5, -0.4, 0.05]
    quats = np.zeros((FRAMES, 3, 4))
    quats[:, 0] = [quat_from_axis_angle([0.0, 0.0, 1.0], 0.3 * k) for k in range(FRAMES)]
    quats[:, 1:, 0] = 1.0
    world = StaticWorld(ground_plane(), (obstacle('wall', 'box', [0.1, 1.0, 0.4],
                                                  position_w=(1.5, 0.0, 0.2)),))
    return times, positions, quats, shapes, world


def test_gif_has_one_frame_per_sample_at_the_asked_size(tmp_path):
    times, positions, quats, shapes, world = scene()
    path = tmp_path / 'world.gif'
    assert write_animation(path, times, positions, quats, shapes, world,
                           size_px=SIZE_PX) == FRAMES
    with Image.open(path) as gif:
        assert gif.n_frames == FRAMES
        assert gif.size == SIZE_PX
        frames = []
        for k in range(FRAMES):
            gif.seek(k)
            # GIF stores centiseconds: 1 s / 10 fps = 100 ms exactly.
            assert gif.info['duration'] == 1000 * STEP_NS // 1_000_000_000
            frames.append(gif.convert('RGB'))
    # The box moves: consecutive frames differ (Pillow would also merge identical frames).
    for first, second in zip(frames, frames[1:]):
        assert ImageChops.difference(first, second).getbbox() is not None


def test_bad_input_is_refused_with_the_field_named(tmp_path):
    times, positions, quats, shapes, world = scene()
    with pytest.raises(ConfigError, match="path: .*world.png' must end in .gif or .mp4"):
        write_animation(tmp_path / 'world.png', times, positions, quats, shapes, world)
    with pytest.raises(InputError, match=r'positions_w: shape \(6, 2, 3\)'):
        write_animation(tmp_path / 'w.gif', times, positions[:, :2], quats, shapes, world)
    with pytest.raises(InputError, match='times_ns: sample times'):
        write_animation(tmp_path / 'w.gif', times[::-1], positions, quats, shapes, world)
    with pytest.raises(InputError, match='fps: -1.0'):
        write_animation(tmp_path / 'w.gif', times, positions, quats, shapes, world, fps=-1.0)


def test_mp4_only_with_ffmpeg(tmp_path):
    times, positions, quats, shapes, world = scene()
    path = tmp_path / 'world.mp4'
    if animation.writers.is_available('ffmpeg'):
        assert write_animation(path, times, positions, quats, shapes, world,
                               size_px=SIZE_PX) == FRAMES
        assert path.stat().st_size > 0
    else:
        with pytest.raises(ConfigError, match='ffmpeg is not installed'):
            write_animation(path, times, positions, quats, shapes, world)
        assert not path.exists()
