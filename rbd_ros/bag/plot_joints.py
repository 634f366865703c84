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
The joint panels of a recording: a robot's (:func:`draw_robots`), or a world's joints'.

Four panels: every moving joint's position, velocity and motor effort from its
``joint_states`` (rad or m, rad/s or m/s, N m or N, as the joint is revolute or prismatic), and
the magnitude of every joint's constraint force from its ``joint_wrenches`` (N). A robot's
come from ``<robot>/joint_states`` and ``<robot>/joint_wrenches``; a world with joints between
its bodies (``joint_names``) has its own ``joint_states`` and ``joint_wrenches``
(:func:`load_joints` reads both kinds).

Neighbours: :mod:`rbd_ros.bag.plot_common` (what every figure shares),
:mod:`rbd_ros.bag.plot_world` (draws a jointed world's joints with these panels), the command
:mod:`rbd_ros.bag.plot`.
"""

from typing import Any, Dict, List, NamedTuple, Optional, Tuple

import numpy as np
from rbd_ros.bag.plot_common import (agg_pyplot, check_samples, finish_figure, last_run,
                                     note_panel, panel_summaries)
from rbd_ros.bag.recording import Bag
from rbd_ros.core import RbdError
from rbd_ros.core.joints.model import coordinate_units
from rbd_ros.msgs import type_names as types
from rbd_ros.msgs.conversions import vector_from_msg as _vec
from rbd_ros.sim.params import NS_PER_S


class JointGroup(NamedTuple):
    """
    Joints that publish their own ``joint_states`` and ``joint_wrenches``: a robot's, a world's.

    :ivar topic_end: how their topics' names end before ``joint_states``: ``/<robot>/`` for a
        robot's, ``/`` for a world's (at the node's namespace).
    :ivar prefix: their curves' label prefix: ``<robot>/``, or none for a world's.
    :ivar moving: the one-coordinate joints, in ``joint_states`` order.
    :ivar units: ``(position, velocity, effort)`` units of each of ``moving``.
    :ivar every: every joint, in ``joint_wrenches`` order.
    """

    topic_end: str
    prefix: str
    moving: List[str]
    units: List[Tuple[str, str, str]]
    every: List[str]


def _joint_groups(config) -> List[JointGroup]:
    """Return the robots' joint groups (``robot_names`` order), then a world's joints'."""
    groups = [JointGroup(f'/{robot.name}/', f'{robot.name}/', list(robot.joint_names),
                         [robot.units(joint) for joint in robot.joint_names],
                         [joint.name for joint in robot.robot.joints])
              for robot in config.robots]
    if config.world_joints:
        entries = [(entry, coordinate_units(j.joint, k or 0)) for j in config.world_joints
                   for entry, k in j.entries]
        groups.append(JointGroup('/', '', [entry for entry, _ in entries],
                                 [units for _, units in entries],
                                 [j.name for j in config.world_joints]))
    return groups


def load_joints(bag: Bag) -> Dict[str, Any]:
    """
    Return a recording's joint series (a robot's, or a world's joints), recorded samples only.

    ``{'t_s' (N,), 'joints' [label], 'units' [(position, velocity, effort)], 'position',
    'velocity', 'effort' (N, n_joints), 'wrench_t_s' (M,), 'wrench_joints' [label],
    'force_n' (M, n_wrench_joints)}``; a label is ``<robot>/<joint>`` for a robot's joint (in
    its ``joint_states`` order, robots in ``robot_names`` order), ``<joint>`` for a world's
    (``joint_names`` order); NaN where a sample lacks a value (the forces are NaN at t = 0,
    before the first step has solved them).

    :raises RbdError: the recording holds no ``joint_states`` of its joints, or no sample on them.
    """
    from rbd_ros.bag.replay_setup import config_from_bag  # the stored config, its URDFs inside
    config = config_from_bag(bag)
    groups = _joint_groups(config)
    states, wrenches = {}, {}
    for topic, info in bag.topics.items():
        # the first group whose end the topic has: a robot's before the world's '/'
        for r, group in enumerate(groups):
            end = group.topic_end
            if topic.endswith(end + 'joint_states') and info.type_name == types.JOINT_STATE:
                states[topic] = r
                break
            if topic.endswith(end + 'joint_wrenches') and \
                    info.type_name == types.MULTI_DOF_JOINT_STATE:
                wrenches[topic] = r
                break
    if not states:
        raise RbdError(f'{bag.mcap_path}: no joint_states recorded for the joints of '
                       f'{[robot.name for robot in config.robots] or "the world"} (topics: '
                       f'{sorted(bag.topics)})')
    labels = [group.prefix + joint for group in groups for joint in group.moving]
    units = [u for group in groups for u in group.units]
    first = np.cumsum([0] + [len(group.moving) for group in groups])
    wrench_labels = [group.prefix + joint for group in groups for joint in group.every]
    wrench_first = np.cumsum([0] + [len(group.every) for group in groups])
    rows, force_rows = {}, {}
    n, m = len(labels), len(wrench_labels)
    for raw, msg in last_run(bag, list(states) + list(wrenches)):
        t = raw.log_time_ns
        if raw.topic in states:
            r = states[raw.topic]
            row = rows.setdefault(t, np.full((3, n), np.nan))
            index = {name: first[r] + k for k, name in enumerate(groups[r].moving)}
            for field, values in enumerate((msg.position, msg.velocity, msg.effort)):
                for name, value in zip(msg.name, values):
                    if name in index:
                        row[field, index[name]] = value
        else:
            r = wrenches[raw.topic]
            row = force_rows.setdefault(t, np.full(m, np.nan))
            index = {name: wrench_first[r] + k for k, name in enumerate(groups[r].every)}
            for name, wrench in zip(msg.joint_names, msg.wrench):
                if name in index:
                    row[index[name]] = np.linalg.norm(_vec(wrench.force))
    times, force_times = sorted(rows), sorted(force_rows)
    check_samples(bag, times, list(states))
    table = np.array([rows[t] for t in times]).reshape(-1, 3, n)
    return {'t_s': np.array(times, dtype=float) / NS_PER_S, 'joints': labels, 'units': units,
            'position': table[:, 0], 'velocity': table[:, 1], 'effort': table[:, 2],
            'wrench_t_s': np.array(force_times, dtype=float) / NS_PER_S,
            'wrench_joints': wrench_labels,
            'force_n': np.array([force_rows[t] for t in force_times]).reshape(-1, m)}


def draw_joints(axes: Any, data: Dict[str, Any], notes: List[Optional[str]]) -> None:
    """Four panels: joint positions, velocities, efforts, and joint force magnitudes."""
    t = data['t_s']
    for k, label in enumerate(data['joints']):
        for panel, field in enumerate(('position', 'velocity', 'effort')):
            axes[panel].plot(t, data[field][:, k], label=label, linewidth=1.0)
    titles = ('joint positions', 'joint velocities',
              'joint efforts (each motor over the last step)')
    for panel, what in enumerate(titles):
        axes[panel].set_title(what, fontsize=10)
        axes[panel].set_ylabel(' or '.join(sorted({u[panel] for u in data['units']})))
        if not data['joints']:
            notes[panel] = note_panel(axes[panel], 'no moving joint')
    drawn = False
    for k, label in enumerate(data['wrench_joints']):
        force = data['force_n'][:, k]
        if np.isfinite(force).any():  # NaN at t = 0 only: a one-sample run draws none
            axes[3].plot(data['wrench_t_s'], force, label=label, linewidth=1.0)
            drawn = True
    axes[3].set_title('|constraint force| the parent exerts on the child, per joint',
                      fontsize=10)
    axes[3].set_ylabel('N')
    if not drawn:
        notes[3] = note_panel(axes[3], 'no joint wrench recorded')
    for ax in axes:
        ax.grid(True, alpha=0.3)
        if ax.get_lines() and len(ax.get_lines()) <= 12:
            ax.legend(fontsize=8, loc='best')
    for ax in axes[2:]:
        ax.set_xlabel('sim time (s)')


def draw_robots(bag: Bag, title: Optional[str] = None) -> Tuple[Any, List[Dict[str, Any]]]:
    """
    Draw a robot recording: joint positions, velocities, efforts, and joint force magnitudes.

    :returns: ``(figure, panels)`` as :func:`draw` (four panels, reading order); a curve's
        label is ``<robot>/<joint>``.
    """
    data = load_joints(bag)  # a bag refused is refused before matplotlib's ~0.5 s import
    plt = agg_pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(13, 9), sharex=True)
    axes = axes.ravel()
    notes = [None] * len(axes)
    draw_joints(axes, data, notes)
    finish_figure(fig, bag, title)
    return fig, panel_summaries(axes, notes)
