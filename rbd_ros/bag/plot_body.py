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
The figure of a single body's recording: eight panels over sim time (:func:`draw`).

Panels over sim time (s): COM position (m, world); orientation as the rotation vector
``quat_log(q_wb)`` (rad, world); linear velocity ``v_w`` (m/s, world); angular velocity ``ω_b``
(rad/s, body); the applied wrenches (force N and torque N·m of each input, as received, held
from the step they took effect at until replaced or until ``wrench_timeout_s``); the kinetic
energy (J; and the total mechanical energy when there is gravity) and ``|L|`` about the COM
(kg·m²/s, ``|I_b ω_b|``).

The state comes from ``odom`` (pose in world, twist in body coordinates, REP 105), or from
``pose`` + ``twist`` when there is no odometry.  Energy and momentum need the body model, which
is rebuilt from the configuration stored in the recording.

Neighbours: :mod:`rbd_ros.bag.plot_common` (what every figure shares), the other figures
:mod:`rbd_ros.bag.plot_world` and :mod:`rbd_ros.bag.plot_joints`, the command
:mod:`rbd_ros.bag.plot`.
"""

import os
from typing import Any, Dict, List, Optional, Tuple, Union

import numpy as np
from rbd_ros.bag.plot_common import (agg_pyplot, check_samples, finish_figure, last_run,
                                     note_panel, panel_summaries)
from rbd_ros.bag.recording import Bag, open_bag
from rbd_ros.core import BodyState, RbdError
from rbd_ros.core.model import BodyModel
from rbd_ros.core.rotations import quat_log, quat_to_matrix
from rbd_ros.msgs import type_names as types
from rbd_ros.msgs.conversions import quaternion_from_msg as _quat, vector_from_msg as _vec
from rbd_ros.sim.params import NS_PER_S


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
    check_samples(bag, times, state_topics)
    series = _state_series(rows, times)
    model, timeout_s = _body_model(bag)
    return {'t_s': np.array(times, dtype=float) / NS_PER_S, **series,
            'wrenches': wrenches, 'model': model, 'timeout_s': timeout_s}


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
            notes[panel] = note_panel(ax, 'no wrench recorded')


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
            notes[k] = note_panel(ax, 'no body model in the recording')
    for ax in axes[6:]:
        _conserved_scale(ax)
    axes[6].set_title('energy', fontsize=10)
    axes[6].set_ylabel('J')
    axes[7].set_title('|angular momentum| about the COM, |I_b ω_b|', fontsize=10)
    axes[7].set_ylabel('kg·m²/s')
    for ax in axes[6:]:
        ax.grid(True, alpha=0.3)
        ax.set_xlabel('sim time (s)')


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
    plt = agg_pyplot()
    fig, axes = plt.subplots(4, 2, figsize=(13, 12), sharex=True)
    axes = axes.ravel()
    notes = [None] * len(axes)
    _draw_state(axes, data)
    _draw_wrenches(axes, data, notes)
    _draw_invariants(axes, data, notes)
    finish_figure(fig, bag, title)
    return fig, panel_summaries(axes, notes)
