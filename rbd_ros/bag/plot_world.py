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
The figure of a world's recording: top view, heights, kinetic energy, contact (:func:`draw_world`).

A world with joints gets the joint panels of :mod:`rbd_ros.bag.plot_joints` below. Neighbours:
:mod:`rbd_ros.bag.plot_common` (what every figure shares), :mod:`rbd_ros.bag.plot_body` (one
body's figure), the command :mod:`rbd_ros.bag.plot`.
"""

from typing import Any, Dict, Optional, Tuple

import numpy as np
from rbd_ros.bag.plot_common import (agg_pyplot, check_samples, finish_figure, last_run,
                                     panel_summaries)
from rbd_ros.bag.plot_joints import draw_joints, load_joints
from rbd_ros.bag.recording import Bag
from rbd_ros.msgs.conversions import vector_from_msg as _vec
from rbd_ros.sim.params import NS_PER_S, recorded_parameters


def load_world(bag: Bag) -> Dict[str, Any]:
    """
    Return a world recording's per-body series, from the recorded samples only.

    ``{'names', 't_s' (N,), 'position_w' {name: (N, 3)}, 'kinetic_j' {name: (N,)},
    'in_contact' (N,) number of bodies with a non-zero contact wrench}``; the kinetic energy
    ``m v²/2 + ω_bᵀ I_b ω_b / 2`` from each body's odometry (twist in its body frame) and its
    stored mass model.
    """
    from rbd_ros.bag.replay_setup import config_from_bag  # the stored config, its meshes attached
    config = config_from_bag(bag)
    names = [body.name for body in config.bodies]
    topics = {}
    for topic in bag.topics:
        head, _, kind = topic.rpartition('/')
        body = head.rpartition('/')[2]
        if body in names and kind in ('odom', 'contact_wrench'):
            topics[topic] = (body, kind)
    odom = {name: {} for name in names}
    contact = {name: {} for name in names}
    for raw, msg in last_run(bag, list(topics)):
        body, kind = topics[raw.topic]
        if kind == 'odom':
            odom[body][raw.log_time_ns] = (_vec(msg.pose.pose.position),
                                           _vec(msg.twist.twist.linear),
                                           _vec(msg.twist.twist.angular))
        else:
            contact[body][raw.log_time_ns] = np.linalg.norm(
                _vec(msg.wrench.force) + _vec(msg.wrench.torque))
    times = sorted(set.intersection(*(set(v) for v in odom.values()))) if names else []
    check_samples(bag, times, [t for t, (_, kind) in topics.items() if kind == 'odom'])
    out = {'names': names, 't_s': np.array(times) / NS_PER_S, 'position_w': {},
           'kinetic_j': {}, 'in_contact': np.zeros(len(times))}
    for body in config.bodies:
        rows = [odom[body.name][t] for t in times]
        out['position_w'][body.name] = np.array([r[0] for r in rows]).reshape(-1, 3)
        v = np.array([r[1] for r in rows]).reshape(-1, 3)
        w = np.array([r[2] for r in rows]).reshape(-1, 3)
        inertia = body.model.inertia_b
        out['kinetic_j'][body.name] = 0.5 * body.model.mass_kg * (v * v).sum(axis=1) \
            + 0.5 * np.einsum('ni,ij,nj->n', w, inertia, w)
        out['in_contact'] += np.array([contact[body.name].get(t, 0.0) > 0.0 for t in times])
    return out


def draw_world(bag: Bag, title: Optional[str] = None) -> Tuple[Any, Dict[str, Any]]:
    """
    Draw a world recording: top view, heights, kinetic energy, bodies in contact.

    A world with joints (``joint_names``) gets four panels more below, as a robot's
    (:func:`draw_robots`): its joints' positions, velocities, efforts and force magnitudes,
    labelled by joint name.

    :returns: ``(figure, data)``: :func:`load_world`'s dict, with ``'joints'`` (the joints'
        :func:`load_joints` dict, None without joints) and ``'panels'`` (every panel in reading
        order, as :func:`draw` describes them).
    """
    data = load_world(bag)  # a bag refused is refused before matplotlib's ~0.5 s import
    joints = load_joints(bag) if recorded_parameters(bag.config).get('joint_names') else None
    plt = agg_pyplot()
    rows = 2 if joints is None else 4
    fig, axes = plt.subplots(rows, 2, figsize=(13, 4.5 * rows))
    axes = axes.ravel()
    top, height, energy, contact = axes[:4]
    notes = [None] * len(axes)
    if joints is not None:
        for ax in axes[4:]:
            ax.sharex(height)
        below = notes[4:]
        draw_joints(axes[4:], joints, below)
        notes[4:] = below
    t = data['t_s']
    for name in data['names']:
        p = data['position_w'][name]
        top.plot(p[:, 0], p[:, 1], label=name)
        if len(p):
            top.plot(p[-1:, 0], p[-1:, 1], 'o', color=top.get_lines()[-1].get_color())
        height.plot(t, p[:, 2], label=name)
        energy.plot(t, data['kinetic_j'][name], label=name)
    energy.plot(t, sum(data['kinetic_j'].values()), 'k--', label='total')
    contact.step(t, data['in_contact'], where='post', label='bodies touching')
    top.set_title('top view: COM paths (m), dot = last sample', fontsize=10)
    top.set_aspect('equal', adjustable='datalim')
    height.set_title('COM height z (m)', fontsize=10)
    energy.set_title('kinetic energy (J)', fontsize=10)
    contact.set_title('bodies with a non-zero contact wrench', fontsize=10)
    for ax in (height, energy, contact):
        ax.set_xlabel('sim time (s)')
    for ax in axes[:4]:
        ax.grid(True, alpha=0.3)
        if len(data['names']) <= 12:
            ax.legend(fontsize=8)
    finish_figure(fig, bag, title)
    return fig, {**data, 'joints': joints, 'panels': panel_summaries(axes, notes)}
