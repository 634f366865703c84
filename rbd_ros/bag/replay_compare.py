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
Replay's judgements: a recomputed output sample against the recorded one, and the run's end.

:func:`compare_fields` holds one sample to the recorded message field by field
(:func:`message_fields`): bit-exact by default, else ``error <= tolerance`` in each field's unit
(position m as the Euclidean norm of the difference, orientation rad as the geodesic angle,
velocities m/s and rad/s, forces N, torques N m, joint values in their joint's unit), errors
kept as maxima in :class:`rbd_ros.bag.replay_result.TopicResult`.  :func:`judge_failure` judges
a non-finite step (reproduced, or a mismatch) and :func:`judge_digest` the applied wrenches
against the digest the node stored, bit for bit.

Neighbours: :mod:`rbd_ros.bag.replayer` calls these as it steps,
:mod:`rbd_ros.bag.replay_result` holds what they find.
"""

import math
from typing import Any, Dict, Optional, Tuple

import numpy as np
from rbd_ros.bag import recorder as run_record
from rbd_ros.bag.recording import Bag
from rbd_ros.bag.replay_result import ReplayResult, TopicResult
from rbd_ros.core.rotations import quat_angle_between
from rbd_ros.msgs import conversions
from rbd_ros.msgs import outputs
from rbd_ros.sim.session import AppliedDigest


def message_fields(kind: str, msg) -> Tuple[int, tuple, Dict[str, Any]]:
    """Return ``(stamp_ns, frame_ids, {field: array})`` of an output message, by field name."""
    vec, quat = conversions.vector_from_msg, conversions.quaternion_from_msg
    if kind == 'clock':
        return conversions.time_from_msg(msg.clock), (), {}
    stamp = conversions.time_from_msg(msg.header.stamp)
    if kind == 'pose':
        return stamp, (msg.header.frame_id,), {
            'position': vec(msg.pose.position), 'orientation': quat(msg.pose.orientation)}
    if kind == 'twist':
        return stamp, (msg.header.frame_id,), {
            'linear': vec(msg.twist.linear), 'angular': vec(msg.twist.angular)}
    if kind == 'contact_wrench':
        return stamp, (msg.header.frame_id,), {
            'force': vec(msg.wrench.force), 'torque': vec(msg.wrench.torque)}
    if kind == 'poses':  # every body's pose, one row each (geometry_msgs/PoseArray)
        return stamp, (msg.header.frame_id, len(msg.poses)), {
            'position': tuple(vec(p.position) for p in msg.poses),
            'orientation': tuple(quat(p.orientation) for p in msg.poses)}
    if kind == 'joint_states':
        return stamp, (msg.header.frame_id, tuple(msg.name)), {
            'joint_position': tuple(msg.position), 'joint_velocity': tuple(msg.velocity),
            'joint_effort': tuple(msg.effort)}
    if kind == 'joint_wrenches':
        return stamp, (msg.header.frame_id, tuple(msg.joint_names), len(msg.transforms),
                       len(msg.twist)), {
            'joint_force': tuple(v for w in msg.wrench for v in vec(w.force)),
            'joint_torque': tuple(v for w in msg.wrench for v in vec(w.torque))}
    return stamp, (msg.header.frame_id, msg.child_frame_id), {
        'position': vec(msg.pose.pose.position), 'orientation': quat(msg.pose.pose.orientation),
        'linear': vec(msg.twist.twist.linear), 'angular': vec(msg.twist.twist.angular)}


def expected_message(kind, state, config, contact_wrench=None):
    """Recompute the output message of ``kind`` for ``state``: the node's own builder."""
    return outputs.sample_builder(config).message(kind, state, contact_wrench)


#: The compared fields of each output kind (see :func:`message_fields`).
KIND_FIELDS = {'pose': ('position', 'orientation'), 'poses': ('position', 'orientation'),
               'twist': ('linear', 'angular'),
               'odom': ('position', 'orientation', 'linear', 'angular'),
               'contact_wrench': ('force', 'torque'), 'clock': (),
               'joint_states': ('joint_position', 'joint_velocity', 'joint_effort'),
               'joint_wrenches': ('joint_force', 'joint_torque')}


ERROR_FIELDS = {
    'position': 'max_position_error_m',
    'orientation': 'max_orientation_error_rad',
    'linear': 'max_linear_velocity_error_m_s',
    'angular': 'max_angular_velocity_error_rad_s',
    'force': 'max_force_error_n',
    'torque': 'max_torque_error_nm',
    'joint_position': 'max_joint_position_error',
    'joint_velocity': 'max_joint_velocity_error',
    'joint_effort': 'max_joint_effort_error',
    'joint_force': 'max_force_error_n',
    'joint_torque': 'max_torque_error_nm',
}


def compare_fields(result: TopicResult, kind: str, t_ns: int, expected: Any, recorded: Any,
                   tolerance: Optional[float]) -> bool:
    """Compare one sample; update ``result``; return True on match."""
    e_stamp, e_frames, e_fields = message_fields(kind, expected)
    r_stamp, r_frames, r_fields = message_fields(kind, recorded)
    result.samples += 1
    reasons = []
    if e_stamp != r_stamp:
        reasons.append(f'stamp {r_stamp} ns recorded, {e_stamp} ns recomputed')
    if e_frames != r_frames:
        reasons.append(f'frame ids {r_frames} recorded, {e_frames} recomputed')
    for name, e_value in e_fields.items():
        r_value = r_fields[name]
        # Bit for bit (tuples of floats: 0.0 == -0.0, so compare the float64 bytes).
        exact = np.array(e_value).tobytes() == np.array(r_value).tobytes()
        if exact:
            error = 0.0
        elif np.shape(e_value) != np.shape(r_value):
            error = math.inf  # another number of joints
        elif name == 'orientation':  # poses: the largest of its bodies' angles
            error = float(np.max(quat_angle_between(np.array(e_value), np.array(r_value)),
                                 initial=0.0))
        elif np.ndim(e_value) == 2:  # poses: the largest of its bodies' distances
            error = float(np.max(np.linalg.norm(np.subtract(e_value, r_value), axis=-1),
                                 initial=0.0))
        else:
            error = float(np.linalg.norm(np.subtract(e_value, r_value)))
        if not math.isfinite(error):
            error = math.inf
        result.take_error(ERROR_FIELDS[name], error)
        if not exact:
            result.bit_exact = False
        if (not exact) if tolerance is None else not error <= tolerance:
            reasons.append(f'{name} differs by {error:.3g} ({list(r_value)} recorded, '
                           f'{list(e_value)} recomputed)')
    if reasons:
        result.mismatches += 1
        if result.first_mismatch is None:
            result.first_mismatch = f't = {t_ns} ns: ' + '; '.join(reasons)
        return False
    return True


def judge_failure(result: ReplayResult, recorded: Optional[Tuple[int, str]],
                  replayed: Optional[Tuple[int, str]], study: bool, run: str = '') -> None:
    """
    Judge a run's non-finite step: reproduced (same sim time, same cause) or a mismatch.

    :param run: the run it is, as the text says it (``'run 1 of 2: '``), or '' for the only one.
    """
    if recorded is None and replayed is None:
        return
    if recorded is not None and replayed == recorded and not study:
        reproduced = (f'{run}the recorded run failed at t = {recorded[0]} ns and the replay '
                      f'fails at the same step with the same cause: {recorded[1]}')
        result.failure_reproduced = '; '.join(filter(None, (result.failure_reproduced,
                                                            reproduced)))
    elif replayed is None:
        what = (f'{run}the recorded run failed at t = {recorded[0]} ns ({recorded[1]}) but the '
                'replay did not')
        if study:
            result.remarks.append(what)
        else:
            result.problems.append(what)
    elif recorded is None:
        result.problems.append(f'{run}the replay diverged at t = {replayed[0]} ns but the '
                               f'recorded run did not (or its bag was not finalised): '
                               f'{replayed[1]}')
    else:
        result.problems.append(
            f'{run}the recorded run failed at t = {recorded[0]} ns ({recorded[1]}); the replay '
            f'failed at t = {replayed[0]} ns ({replayed[1]})')


def judge_digest(result: ReplayResult, bag: Bag, digest: AppliedDigest, study: bool) -> None:
    """Compare the wrenches applied on replay with what the node applied, bit for bit."""
    run = bag.run_metadata or {}
    if study:
        return
    if run_record.RUN_WRENCH_DIGEST not in run:
        result.remarks.append(
            'no rbd_ros.run record (bag not finalised, or not recorded by the node): the '
            'applied wrenches were checked against the recorded messages only')
        return
    result.wrench_digest_checked = True
    count = run.get(run_record.RUN_WRENCHES_APPLIED, '')
    recorded = run[run_record.RUN_WRENCH_DIGEST]
    if recorded != digest.hexdigest() or count != str(digest.count):
        result.wrench_mismatches += 1
        result.problems.append(
            f'the wrenches applied on replay ({digest.count}, SHA-256 '
            f'{digest.hexdigest()[:16]}...) are not bit for bit those the node applied '
            f'({count}, SHA-256 {recorded[:16]}...): the recorded wrench messages differ from '
            'what the node applied')


def restamp(kind: str, msg, t_ns: int) -> Any:
    """Set the stamp of the output message ``msg`` of ``kind`` to ``t_ns``; return ``msg``."""
    stamp = conversions.time_to_msg(t_ns)
    if kind == 'clock':
        msg.clock = stamp
    else:
        msg.header.stamp = stamp
    return msg
