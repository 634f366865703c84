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
Plot a recording to one PNG (``ros2 run rbd_ros plot <bag> [-o out.png]``), headless.

:func:`render` draws the figure the stored configuration asks for: a robot recording
(``robot_names``) the joint panels of :func:`rbd_ros.bag.plot_joints.draw_robots`; a world of
several bodies (``body_names``) :func:`rbd_ros.bag.plot_world.draw_world`, with the same joint
panels below when it has joints; else a single body's eight panels,
:func:`rbd_ros.bag.plot_body.draw`. Each figure draws the recording's last run
(:mod:`rbd_ros.bag.plot_common`: after ``~/reset`` calls the title says of how many).
``--animate`` also writes an animation of the bodies (:func:`animate_bag`, drawn by
:mod:`rbd_ros.bag.animate`). Messages are decoded with the schemas stored in the file; rclpy is
not imported. The figures' public names are importable from here too.
"""

import argparse
import os
import sys
from typing import List, Optional, Union

import numpy as np
from rbd_ros.bag.cli import open_bag_with_notes, run_on_bag
from rbd_ros.bag.plot_body import draw, load_series, WrenchSamples  # noqa: F401
from rbd_ros.bag.plot_common import last_run
from rbd_ros.bag.plot_joints import draw_robots, JointGroup, load_joints  # noqa: F401
from rbd_ros.bag.plot_world import draw_world, load_world  # noqa: F401
from rbd_ros.bag.recording import Bag, open_bag
from rbd_ros.core import RbdError
from rbd_ros.msgs import type_names as types
from rbd_ros.msgs.conversions import quaternion_from_msg as _quat, vector_from_msg as _vec
from rbd_ros.sim.params import NS_PER_S, recorded_parameters

SAVE_DPI = 90


#: Frames per second of an animation from a bag (every k-th recorded sample, real time).
ANIMATION_FPS = 20


def animate_bag(bag: Union[str, os.PathLike, Bag], out_path: str) -> int:
    """
    Write an animation (GIF; MP4 with ffmpeg) of a recording with contact; return its frames.

    Every body at its recorded poses (``<body>/pose`` of a world, or ``pose``), drawn with its
    collision shape from the stored configuration (meshes from the bag's attachments), with
    the ground and obstacles; one frame per recorded sample, subsampled to about
    :data:`ANIMATION_FPS` frames per sim second, played in real time.
    """
    from rbd_ros.bag.animate import write_animation
    from rbd_ros.bag.replay_setup import config_from_bag
    if not isinstance(bag, Bag):
        bag = open_bag(bag)
    config = config_from_bag(bag)
    shapes = [b.collision_shape for b in config.bodies]
    if None in shapes:
        raise RbdError(f'{bag.mcap_path}: the body has no collision shape to draw (given '
                       'by inertia only)')
    # Body i's poses: the PoseStamped topic ending in /<prefix>pose (the longest prefix).
    ends = sorted(((f'/{b.prefix}pose', i) for i, b in enumerate(config.bodies)),
                  key=lambda end: -len(end[0]))
    topics = {}
    for t, info in bag.topics.items():
        index = next((i for end, i in ends if t.endswith(end)), None)
        if info.type_name == types.POSE_STAMPED and index is not None:
            topics[t] = index
    poses = {}
    for raw, msg in last_run(bag, list(topics)):
        row = poses.setdefault(raw.log_time_ns, [None] * len(shapes))
        row[topics[raw.topic]] = (_vec(msg.pose.position), _quat(msg.pose.orientation))
    times = [t for t in sorted(poses) if all(v is not None for v in poses[t])]
    if not times:
        raise RbdError(f'{bag.mcap_path}: no recorded poses to animate')
    step = max(1, round(NS_PER_S / ANIMATION_FPS / max(config.publish_period_ns, 1)))
    times = times[::step]
    positions = np.array([[p for p, _ in poses[t]] for t in times])
    quats = np.array([[q for _, q in poses[t]] for t in times])
    return write_animation(out_path, times, positions, quats, shapes, config.static_world)


def render(bag: Union[str, os.PathLike, Bag], out_path: str,
           title: Optional[str] = None) -> str:
    """Render the recording ``bag`` (opened or a path) to the PNG ``out_path``; return it."""
    if not isinstance(bag, Bag):
        bag = open_bag(bag)
    stored = recorded_parameters(bag.config) if bag.config else {}
    if stored.get('robot_names'):
        fig, _ = draw_robots(bag, title)
    elif stored.get('body_names'):
        fig, _ = draw_world(bag, title)
    else:
        fig, _ = draw(bag, title)
    from matplotlib import pyplot as plt   # after draw() selected the Agg backend
    try:
        fig.savefig(out_path, dpi=SAVE_DPI)
    finally:
        plt.close(fig)
    return out_path


def main(argv: Optional[List[str]] = None) -> int:
    """Run the ``plot`` executable; return the exit status."""
    parser = argparse.ArgumentParser(
        prog='plot', description='Plot an rbd_ros recording to one PNG.')
    parser.add_argument('bag', help='bag directory or .mcap file')
    parser.add_argument('-o', '--output', default=None,
                        help='output PNG (default: <bag name>.png in the current directory)')
    parser.add_argument('--title', default=None, help='figure title')
    parser.add_argument('--animate', default=None, metavar='OUT.gif',
                        help='also write an animation of the run (.gif, or .mp4 with ffmpeg)')
    args = parser.parse_args(argv)
    out = args.output or os.path.basename(os.path.normpath(args.bag)).split('.')[0] + '.png'

    def run():
        bag = open_bag_with_notes('plot', args.bag)
        render(bag, out, args.title)
        if args.animate:
            return animate_bag(bag, args.animate)
        return None

    status, frames = run_on_bag('plot', args.bag, 'plotted', run)
    if status:
        return status
    print(f'plot: wrote {out}')
    if args.animate:
        print(f'plot: wrote {args.animate} ({frames} frames)')
    return 0


if __name__ == '__main__':
    sys.exit(main())
