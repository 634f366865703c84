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
The run's settings: integrator and times, frames, wrench limits and recording; motor constants.

A stage of :meth:`rbd_ros.sim.config.NodeConfig.from_parameters`: :func:`_time_settings`,
:func:`_frame_settings` and :func:`_limits_and_recording` check their values and return the
:class:`~rbd_ros.sim.config.NodeConfig` fields they become; :func:`_check_contact_integrator`
and :func:`_check_time_constants` refuse an integrator or a motor the step cannot take.

Times are converted to integer nanoseconds here, rounded to the nearest nanosecond:
``timestep_s`` must be a whole number of nanoseconds (to 0.001 ns, which absorbs the binary
representation of decimal values such as 0.001), so that sim time is exact; the publish period
is ``round(1e9 / publish_rate_hz)`` ns. A positive time that rounds to 0 ns is refused (it would
silently mean "off"), naming the parameter (:func:`rbd_ros.sim.params.to_ns`).
"""

from dataclasses import replace as dataclass_replace

from rbd_ros.core import INTEGRATORS
from rbd_ros.core.contact.simulator import CONTACT_INTEGRATORS
from rbd_ros.sim import robots as robot_params
from rbd_ros.sim.params import (check_real_time_factor, fail, frame_id_problem, FRAME_KEYWORDS,
                                NS_PER_S, PARAMETERS_BY_NAME, to_ns, vector3)


def _check_time_constants(robots, world_joints, timestep_ns):
    """
    Refuse a joint's ``position_time_constant_s`` below the step.

    The motor's response is the critically damped one only while the step resolves it
    (``ω h <= 1``, ``ω = 1 / τ``). Measured on the gripper's finger at h = 1 ms with an
    effort limit out of reach: τ = h moves it as the closed form does (its error within 5 %
    over the move's first five steps), never past the target; τ = h/2 overshoots by a third of
    the move; τ = h/2.5 rings for ~20 steps; τ = h/2.9 overshoots to the joint's limit and
    stays held there; τ = h/3.3 stops the world (the projection did not converge). A time
    constant the step cannot resolve is a setting to refuse, not a response to approximate.
    """
    step_s = timestep_ns / NS_PER_S
    given = [(spec, constant) for robot in robots
             for spec, constant in zip(
                 [s for s in robot.specs if s.name.endswith('.position_time_constant_s')],
                 robot.time_constants_s)]
    given += [(next(s for s in joint.specs if s.name.endswith('.position_time_constant_s')),
               joint.time_constant_s) for joint in world_joints]
    for spec, constant in given:
        if constant < step_s:
            fail(spec, constant, f'must be >= the step, timestep_s = {step_s:g} s: a motor '
                 'faster than a step overshoots, and below ~timestep_s / 3 drives the joint '
                 'to its limit or stops the world')


def _check_contact_integrator(integrator, what):
    """Refuse an integrator that cannot take contact (``what`` says which world needs it)."""
    if integrator not in CONTACT_INTEGRATORS:
        fail(PARAMETERS_BY_NAME['integrator'], integrator,
             f'cannot take contact ({what}): use one of ' + ', '.join(CONTACT_INTEGRATORS))


def _time_settings(values):
    """Check integrator, step, publish period, real-time factor, duration, wrench timeout."""
    p = PARAMETERS_BY_NAME
    if values['integrator'] not in INTEGRATORS:
        fail(p['integrator'], values['integrator'], 'must be one of ' + ', '.join(INTEGRATORS))
    timestep_ns = to_ns(p['timestep_s'], values['timestep_s'])
    check_real_time_factor(values['real_time_factor'])
    return {'integrator': values['integrator'], 'timestep_ns': timestep_ns,
            'publish_period_ns': max(1, round(NS_PER_S / values['publish_rate_hz'])),
            'real_time_factor': values['real_time_factor'],
            'duration_ns': to_ns(p['duration_s'], values['duration_s']),
            'start_paused': values['start_paused'],
            'wrench_timeout_ns': to_ns(p['wrench_timeout_s'], values['wrench_timeout_s'])}


def _frame_settings(values, bodies=(), robots=(), accepted_frames=None):
    """
    Check the frame ids and keywords; the optional outputs (``/clock``, ``/tf``).

    Every frame is the node's one: the world's, each body's, each robot link's
    (:func:`rbd_ros.sim.robots.check_link_frames`, after the others; ``accepted_frames``: see
    :meth:`NodeConfig.from_parameters`).
    """
    p = PARAMETERS_BY_NAME
    seen = {values['world_frame']: 'world_frame'}
    for body in bodies:
        if not body.parameter_prefix:
            continue  # the top-level body_frame: checked below
        spec = PARAMETERS_BY_NAME['body_frame']
        where = f'{body.parameter_prefix}body_frame'
        problem = frame_id_problem(body.body_frame)
        if problem:
            fail(dataclass_replace(spec, name=where), body.body_frame, problem)
        if body.body_frame in seen:
            fail(dataclass_replace(spec, name=where), body.body_frame,
                 f'is already the frame of {seen[body.body_frame]}')
        seen[body.body_frame] = where
    for name in ('world_frame', 'body_frame'):
        problem = frame_id_problem(values[name])
        if problem:
            fail(p[name], values[name], problem)
    if values['world_frame'] == values['body_frame']:
        fail(p['body_frame'], values['body_frame'], 'must differ from world_frame')
    for name in ('twist_frame', 'default_wrench_frame'):
        if values[name] not in FRAME_KEYWORDS:
            fail(p[name], values[name], "must be 'world' or 'body'")
    robot_params.check_link_frames(values['world_frame'], seen, robots, accepted_frames)
    return {name: values[name] for name in (
        'world_frame', 'twist_frame', 'default_wrench_frame', 'publish_clock', 'publish_tf',
        'publish_markers')}


def _limits_and_recording(values):
    """Check the wrench limits and the ``record_*`` settings."""
    p = PARAMETERS_BY_NAME
    if values['record_on_error'] not in ('continue', 'stop'):
        fail(p['record_on_error'], values['record_on_error'], "must be 'continue' or 'stop'")
    vector3(p['drag_point_b'], values['drag_point_b'])
    return {name: values[name] for name in (
        'max_force_n', 'max_torque_nm', 'record_path', 'record_overwrite', 'record_on_error')}
