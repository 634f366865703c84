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

Panels over sim time (s): COM position (m, world); orientation as the rotation vector
``quat_log(q_wb)`` (rad, world); linear velocity ``v_w`` (m/s, world); angular velocity ``ω_b``
(rad/s, body); the applied wrenches (force N and torque N·m of each input, as received, held
from the step they took effect at until replaced or until ``wrench_timeout_s``); the kinetic
energy (J; and the total mechanical energy when there is gravity) and ``|L|`` about the COM
(kg·m²/s, ``|I_b ω_b|``).

A robot recording (``robot_names``) gets its own figure (:func:`draw_robots`): every moving
joint's position, velocity and motor effort from ``<robot>/joint_states`` (rad or m, rad/s or
m/s, N m or N, as the joint is revolute or prismatic), and the magnitude of every joint's
constraint force from ``<robot>/joint_wrenches`` (N). A world of several bodies gets
:func:`draw_world`, and with joints between its bodies (``joint_names``) the same four joint
panels below, from its ``joint_states`` and ``joint_wrenches`` (:func:`load_joints`).

The state comes from ``odom`` (pose in world, twist in body coordinates, REP 105), or from
``pose`` + ``twist`` when there is no odometry.  Energy and momentum need the body model, which
is rebuilt from the configuration stored in the recording.  Messages are decoded with the
schemas stored in the file; rclpy is not imported.
"""

import argparse
import os
import sys
from typing import Any, Dict, Iterator, List, NamedTuple, Optional, Tuple, Union

import numpy as np
from rbd_ros.bag.cli import open_bag_with_notes, run_on_bag
from rbd_ros.bag.reader import RawMessage, run_starts
from rbd_ros.bag.recording import Bag, open_bag
from rbd_ros.core import BodyState, RbdError
from rbd_ros.core.model import BodyModel
from rbd_ros.core.rotations import quat_log, quat_to_matrix
from rbd_ros.msgs import type_names as types
from rbd_ros.msgs.conversions import quaternion_from_msg as _quat, vector_from_msg as _vec
from rbd_ros.sim.params import NS_PER_S, recorded_parameters
from rbd_ros.sim.robots import joint_units

SAVE_DPI = 90


_ODOM = types.ODOMETRY
_POSE = types.POSE_STAMPED
_TWIST = types.TWIST_STAMPED
_WRENCH = types.WRENCH_STAMPED
_AXES = ('x', 'y', 'z')
_NAN3 = (np.nan,) * 3

#: One input's wrenches as recorded: ``(t_s, force (3,), torque (3,))`` per message.
WrenchSamples = List[Tuple[float, Tuple[float, ...], Tuple[float, ...]]]


def load_series(bag: Bag) -> Dict[str, Any]:
    """
    Return the time series of a recording as numpy arrays.

    Keys: ``t_s`` (N,), ``position_w`` (N, 3), ``orientation_wb`` (N, 4) w-first,
    ``velocity_w`` (N, 3), ``omega_b`` (N, 3) (NaN when not recorded), ``wrenches``
    (topic -> list of ``(t_s, force(3), torque(3))``), ``model`` (BodyModel or None),
    ``timeout_s``.

    :raises RbdError: the recording has no odom, pose or twist topic, or no sample on them.
    """
    state_topics, wrench_topics = _plotted_topics(bag)
    twist_frame = (bag.config or {}).get('twist_frame', 'world')
    rows, wrenches = _read_samples(bag, state_topics, wrench_topics, twist_frame)
    times = sorted(rows)
    _check_samples(bag, times, state_topics)
    series = _state_series(rows, times)
    model, timeout_s = _body_model(bag)
    return {'t_s': np.array(times, dtype=float) / NS_PER_S, **series,
            'wrenches': wrenches, 'model': model, 'timeout_s': timeout_s}


def last_run(bag: Bag, topics: List[str]) -> Iterator[Tuple[RawMessage, Any]]:
    """
    Yield ``(raw, decoded)`` of ``topics`` from the last run of the recording only.

    A plot keyed by sim time would otherwise draw the runs between ``~/reset`` calls over
    each other (a later run's samples in place of an earlier one's, the rest of that one
    after them); :func:`_finish` says how many runs there were.
    """
    start = ([0] + run_starts(bag.messages(topics)))[-1]  # a first pass: nothing kept
    for index, item in enumerate(bag.decoded_messages(topics)):
        if index >= start:
            yield item


def _check_samples(bag: Bag, times: List[int], topics: List[str]) -> None:
    """Refuse a recording without a sample to plot (an empty figure would say nothing)."""
    if not len(times):
        raise RbdError(f'{bag.mcap_path}: no recorded samples to plot on {sorted(topics)} '
                       '(a recording cut off before its first chunk was complete holds none)')


def _plotted_topics(bag: Bag) -> Tuple[List[str], List[str]]:
    """Return the state topics (``odom``, else ``pose`` + ``twist``) and the wrench topics."""
    by_type = {}
    for topic, info in bag.topics.items():
        by_type.setdefault(info.type_name, []).append(topic)
    state_topics = by_type.get(_ODOM, [])[:1] or (
        by_type.get(_POSE, [])[:1] + by_type.get(_TWIST, [])[:1])
    if not state_topics:
        raise RbdError(f'{bag.mcap_path}: no odom, pose or twist topic to plot '
                       f'(topics: {sorted(bag.topics)})')
    # contact_wrench is an output (the node's contact force), not an applied wrench.
    inputs = [t for t in by_type.get(_WRENCH, []) if t.rsplit('/', 1)[-1] != 'contact_wrench']
    return state_topics, inputs


def _read_samples(bag: Bag, state_topics: List[str], wrench_topics: List[str],
                  twist_frame: str) -> Tuple[Dict[int, dict], Dict[str, WrenchSamples]]:
    """
    Decode the recording into state rows by log time and wrench samples by topic.

    A row holds what was recorded at that time: ``p``, ``q`` (w-first) and velocities keyed by
    their frame, ``v_w``/``w_w`` (world) or ``v_b``/``w_b`` (body).
    """
    rows = {}
    wrenches = {topic: [] for topic in wrench_topics}
    velocity_frame = 'b' if twist_frame == 'body' else 'w'
    for raw, msg in last_run(bag, state_topics + wrench_topics):
        t = raw.log_time_ns
        if raw.topic in wrenches:
            wrenches[raw.topic].append(
                (t / NS_PER_S, _vec(msg.wrench.force), _vec(msg.wrench.torque)))
            continue
        row = rows.setdefault(t, {})
        type_name = bag.topics[raw.topic].type_name
        if type_name == _ODOM:
            row['p'] = _vec(msg.pose.pose.position)
            row['q'] = _quat(msg.pose.pose.orientation)
            row['v_b'] = _vec(msg.twist.twist.linear)
            row['w_b'] = _vec(msg.twist.twist.angular)
        elif type_name == _POSE:
            row['p'] = _vec(msg.pose.position)
            row['q'] = _quat(msg.pose.orientation)
        else:
            row['v_' + velocity_frame] = _vec(msg.twist.linear)
            row['w_' + velocity_frame] = _vec(msg.twist.angular)
    return rows, wrenches


def _state_series(rows: Dict[int, dict], times: List[int]) -> Dict[str, np.ndarray]:
    """Return position, orientation, ``v_w`` and ``ω_b`` arrays, each velocity in its frame."""
    p = np.array([rows[t].get('p', _NAN3) for t in times], dtype=float).reshape(-1, 3)
    q = np.array([rows[t].get('q', (1.0, 0.0, 0.0, 0.0)) for t in times],
                 dtype=float).reshape(-1, 4)
    rot = quat_to_matrix(q) if len(q) else np.zeros((0, 3, 3))
    rot_t = np.swapaxes(rot, -1, -2)

    def world_and_body(prefix):
        # v_w = R v_b and v_b = R^T v_w fill whichever frame was not recorded.
        world = np.array([rows[t].get(prefix + '_w', _NAN3) for t in times],
                         float).reshape(-1, 3)
        body = np.array([rows[t].get(prefix + '_b', _NAN3) for t in times], float).reshape(-1, 3)
        from_body = np.einsum('nij,nj->ni', rot, body)
        from_world = np.einsum('nij,nj->ni', rot_t, world)
        return (np.where(np.isnan(world), from_body, world),
                np.where(np.isnan(body), from_world, body))

    velocity_w, _ = world_and_body('v')
    _, omega_b = world_and_body('w')
    return {'position_w': p, 'orientation_wb': q, 'velocity_w': velocity_w, 'omega_b': omega_b}


def _body_model(bag: Bag) -> Tuple[Optional[BodyModel], float]:
    """
    Return the body model and the wrench timeout (s) of the stored configuration.

    :raises RbdError: the stored configuration is invalid or names a mesh it does not hold
        (a crafted bag is refused, as by replay, not plotted without its model).
    """
    if bag.config is None:
        return None, 0.0
    from rbd_ros.bag.replay_setup import config_from_bag  # the stored config, its meshes attached
    config = config_from_bag(bag)
    model = config.bodies[0].model if len(config.bodies) == 1 else None
    return model, config.wrench_timeout_ns / NS_PER_S


def _held(samples: WrenchSamples, timeout_s: float,
          t_end: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Zero-order-hold step lines of one input's wrenches: (t, force (n,3), torque (n,3))."""
    ts, forces, torques = [], [], []
    for index, (t, force, torque) in enumerate(samples):
        next_t = samples[index + 1][0] if index + 1 < len(samples) else t_end
        end = min(next_t, t + timeout_s) if timeout_s > 0 else next_t
        ts += [t, end]
        forces += [force, force]
        torques += [torque, torque]
        if end < next_t:
            ts += [end, next_t]
            forces += [(0.0,) * 3] * 2
            torques += [(0.0,) * 3] * 2
    return np.array(ts), np.array(forces).reshape(-1, 3), np.array(torques).reshape(-1, 3)


def _conserved_scale(ax) -> None:
    """Show a quantity constant to round-off as flat, and say how constant it is."""
    ax.ticklabel_format(axis='y', useOffset=False)
    values = np.concatenate([line.get_ydata() for line in ax.get_lines()] or [np.zeros(0)])
    values = values[np.isfinite(values)]
    if not len(values):
        return
    scale = max(abs(float(values.mean())), 1e-300)
    spread = float(values.max() - values.min()) / scale
    if spread <= 1e-9:
        mean = float(values.mean())
        ax.set_ylim(mean - 0.05 * scale - 1e-12, mean + 0.05 * scale + 1e-12)
        ax.text(0.02, 0.06, f'constant to {spread:.1e} (relative)', transform=ax.transAxes,
                fontsize=8)


def _note(ax, text: str) -> str:
    """Write ``text`` in the middle of an empty panel; return it."""
    ax.text(0.5, 0.5, text, ha='center', va='center', transform=ax.transAxes)
    return text


def _draw_vectors(ax, t: np.ndarray, values: np.ndarray, title: str, unit: str) -> None:
    """Draw the x, y, z components of ``values`` (N, 3) over sim time ``t``."""
    for k, name in enumerate(_AXES):
        ax.plot(t, values[:, k], label=name, linewidth=1.0)
    ax.set_title(title, fontsize=10)
    ax.set_ylabel(unit)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc='best')


def _draw_state(axes, data: Dict[str, Any]) -> None:
    """Panels 0-3: position, orientation (rotation vector), ``v_w`` and ``ω_b``."""
    t = data['t_s']
    _draw_vectors(axes[0], t, data['position_w'], 'COM position (world)', 'm')
    rotvec = quat_log(data['orientation_wb']) if len(t) else np.zeros((0, 3))
    _draw_vectors(axes[1], t, rotvec, 'orientation: rotation vector log(q_wb) (world)', 'rad')
    _draw_vectors(axes[2], t, data['velocity_w'], 'linear velocity v_w (world)', 'm/s')
    _draw_vectors(axes[3], t, data['omega_b'], 'angular velocity ω_b (body)', 'rad/s')


def _draw_wrenches(axes, data: Dict[str, Any], notes: List[Optional[str]]) -> None:
    """Panels 4-5: each input's force and torque, held as the node held them."""
    t = data['t_s']
    t_end = float(t[-1]) if len(t) else 0.0
    for panel, index, what, unit in ((4, 1, 'force', 'N'), (5, 2, 'torque', 'N·m')):
        ax = axes[panel]
        drawn = False
        for topic, samples in sorted(data['wrenches'].items()):
            if not samples:
                continue
            held = _held(samples, data['timeout_s'], t_end)
            for k, name in enumerate(_AXES):
                ax.plot(held[0], held[index][:, k], label=f'{topic} {name}', linewidth=1.0)
            drawn = True
        ax.set_title(f'applied wrenches: {what} (as received, in its frame_id)', fontsize=10)
        ax.set_ylabel(unit)
        ax.grid(True, alpha=0.3)
        if drawn:
            ax.legend(fontsize=7, loc='best', ncol=2)
        else:
            notes[panel] = _note(ax, 'no wrench recorded')


def _body_states(data: Dict[str, Any]) -> List[Optional[BodyState]]:
    """Return the recorded samples as :class:`BodyState` (None where a field is missing)."""
    states = []
    for p, q, v, w in zip(data['position_w'], data['orientation_wb'], data['velocity_w'],
                          data['omega_b']):
        finite = all(np.all(np.isfinite(x)) for x in (p, q, v, w))
        states.append(BodyState(position_w=p, orientation_wb=q, linear_velocity_w=v,
                                angular_velocity_b=w) if finite else None)
    return states


def _draw_invariants(axes, data: Dict[str, Any], notes: List[Optional[str]]) -> None:
    """
    Panels 6-7: energy and ``|L|`` about the COM, flat when constant to round-off.

    Asked of :class:`BodyState` per sample: ``kinetic_energy`` (plus ``potential_energy`` under
    gravity) and ``|angular_momentum_w|``.
    """
    t, model = data['t_s'], data['model']
    if model is not None and len(t):
        states = _body_states(data)
        kinetic = np.array([s.kinetic_energy(model) if s else np.nan for s in states])
        axes[6].plot(t, kinetic, label='kinetic', linewidth=1.2)
        if np.any(np.asarray(model.gravity_w) != 0.0):
            potential = np.array([s.potential_energy(model) if s else np.nan for s in states])
            axes[6].plot(t, kinetic + potential, label='kinetic + potential', linewidth=1.2)
        axes[6].legend(fontsize=8, loc='best')
        momentum = np.array([np.linalg.norm(s.angular_momentum_w(model)) if s else np.nan
                             for s in states])
        axes[7].plot(t, momentum, color='tab:purple', linewidth=1.2, label='|L|')
    else:
        for k, ax in enumerate(axes[6:], 6):
            notes[k] = _note(ax, 'no body model in the recording')
    for ax in axes[6:]:
        _conserved_scale(ax)
    axes[6].set_title('energy', fontsize=10)
    axes[6].set_ylabel('J')
    axes[7].set_title('|angular momentum| about the COM, |I_b ω_b|', fontsize=10)
    axes[7].set_ylabel('kg·m²/s')
    for ax in axes[6:]:
        ax.grid(True, alpha=0.3)
        ax.set_xlabel('sim time (s)')


def _panel_summaries(axes, notes: List[Optional[str]]) -> List[Dict[str, Any]]:
    """Describe each laid-out panel: title, box, every curve's data, note."""
    return [{'title': ax.get_title(), 'box': tuple(ax.get_position().extents),
             'lines': {line.get_label(): (np.asarray(line.get_xdata(), dtype=float),
                                          np.asarray(line.get_ydata(), dtype=float))
                       for line in ax.get_lines()},
             'note': note} for ax, note in zip(axes, notes)]


def _finish(fig, bag: Bag, title: Optional[str]) -> None:
    """Title the figure (the bag's name, and whether it was finalised); lay it out."""
    status = '' if bag.finalised else '  [not finalised]'
    # /diagnostics comes by wall time: paused at t = 0 it repeats t = 0 without a reset
    runs = len(run_starts(bag.messages(
        [t for t, info in bag.topics.items() if info.type_name != types.DIAGNOSTIC_ARRAY]))) + 1
    if runs > 1:
        status += f'  [the last of {runs} runs: ~/reset]'
    fig.suptitle(title or f'{os.path.basename(os.path.normpath(bag.path))}{status}')
    fig.tight_layout()


def _pyplot():
    """Return ``matplotlib.pyplot`` on the Agg backend (no display needed)."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    return pyplot


def draw(bag: Union[str, os.PathLike, Bag],
         title: Optional[str] = None) -> Tuple[Any, List[Dict[str, Any]]]:
    """
    Draw the recording ``bag`` (opened or a path) into a new matplotlib figure.

    :returns: ``(figure, panels)``; ``panels`` lists the eight panels in reading order, each a
        dict with ``title``, ``box`` (its axes as figure fractions ``(x0, y0, x1, y1)``, origin
        bottom left, as laid out for saving), ``lines`` (label -> ``(x, y)`` arrays of every
        curve drawn, x in sim seconds) and ``note`` (the text drawn instead of curves, or None).
        The caller closes the figure (``matplotlib.pyplot.close``).
    """
    if not isinstance(bag, Bag):
        bag = open_bag(bag)
    data = load_series(bag)  # a bag refused is refused before matplotlib's ~0.5 s import
    plt = _pyplot()
    fig, axes = plt.subplots(4, 2, figsize=(13, 12), sharex=True)
    axes = axes.ravel()
    notes = [None] * len(axes)
    _draw_state(axes, data)
    _draw_wrenches(axes, data, notes)
    _draw_invariants(axes, data, notes)
    _finish(fig, bag, title)
    return fig, _panel_summaries(axes, notes)


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
    _check_samples(bag, times, [t for t, (_, kind) in topics.items() if kind == 'odom'])
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
    plt = _pyplot()
    rows = 2 if joints is None else 4
    fig, axes = plt.subplots(rows, 2, figsize=(13, 4.5 * rows))
    axes = axes.ravel()
    top, height, energy, contact = axes[:4]
    notes = [None] * len(axes)
    if joints is not None:
        for ax in axes[4:]:
            ax.sharex(height)
        below = notes[4:]
        _draw_joints(axes[4:], joints, below)
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
    _finish(fig, bag, title)
    return fig, {**data, 'joints': joints, 'panels': _panel_summaries(axes, notes)}


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
        moving = [j for j in config.world_joints if j.moving]
        groups.append(JointGroup('/', '', [j.name for j in moving],
                                 [joint_units(j.joint.kind) for j in moving],
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
    _check_samples(bag, times, list(states))
    table = np.array([rows[t] for t in times]).reshape(-1, 3, n)
    return {'t_s': np.array(times, dtype=float) / NS_PER_S, 'joints': labels, 'units': units,
            'position': table[:, 0], 'velocity': table[:, 1], 'effort': table[:, 2],
            'wrench_t_s': np.array(force_times, dtype=float) / NS_PER_S,
            'wrench_joints': wrench_labels,
            'force_n': np.array([force_rows[t] for t in force_times]).reshape(-1, m)}


def _draw_joints(axes, data: Dict[str, Any], notes: List[Optional[str]]) -> None:
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
            notes[panel] = _note(axes[panel], 'no moving joint')
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
        notes[3] = _note(axes[3], 'no joint wrench recorded')
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
    plt = _pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(13, 9), sharex=True)
    axes = axes.ravel()
    notes = [None] * len(axes)
    _draw_joints(axes, data, notes)
    _finish(fig, bag, title)
    return fig, _panel_summaries(axes, notes)


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
        if info.type_name == _POSE and index is not None:
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
