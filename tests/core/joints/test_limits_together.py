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

"""Two joints of a chain reaching their limits together: held in one impact, never refused."""

import dataclasses
import os
import sys

from rbd_ros.core.joints import ArticulatedSimulator
from rbd_ros.sim.build import make_simulator
from rbd_ros.sim.config import NodeConfig

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__)))), 'benchmarks'))
from bench_robot_node import arm_urdf  # noqa: E402,I100,I202 (the benchmarks' 7-link arm)

JOINT_TOL = 1e-12
LIMIT_TOL = 1e-12


def arm_core(links=7):
    """Return the benchmarks' arm's core: 1 ms steps, released bent 0.3 rad at every joint."""
    params = {'robot_names': ['arm'], 'robots.arm.robot_description': arm_urdf(links),
              'robots.arm.initial_joint_positions': [0.3] * links,
              'gravity': [0.0, 0.0, -9.81], 'timestep_s': 0.001, 'publish_rate_hz': 100.0}
    return make_simulator(NodeConfig.from_parameters(params))._sim


def check_limits(sim):
    """Assert no limited joint is beyond its bound by more than LIMIT_TOL."""
    for joint, q in zip(sim.joints, sim.joint_positions()):
        if joint.lower is not None:
            assert q[0] >= joint.lower - LIMIT_TOL, (joint.name, q[0])
        if joint.upper is not None:
            assert q[0] <= joint.upper + LIMIT_TOL, (joint.name, q[0])


def test_arm_with_two_joints_on_their_lower_limits_goes_on():
    # the free arm swings until, at t = 70 s, joints j3 and j5 reach their lower limits inside
    # one step; each stop alone was released at once and the other's impulse drove its joint
    # back into its bound, until a sub-step began 1e-14 rad past one and the search put the
    # crossing before it: the step was refused ("the position projection did not converge")
    sim = arm_core()
    sim.step(69_900)
    energy, stops = sim.energy(), 0
    for _ in range(1_100):
        sim.step()
        stops += sim.last_stop is not None
        assert max(sim.joint_error()) <= JOINT_TOL
        check_limits(sim)
        # no motor, no damping: the stops only take energy out (inelastic), and between them
        # the energy is kept to RK4's error
        assert sim.energy() - energy <= 1e-9
        energy = sim.energy()
    assert stops >= 1


def test_arm_with_motors_and_friction_goes_on():
    # the same arm with damping, friction and three motors: refused at step 1625 the same way
    core = arm_core()
    joints = [dataclasses.replace(j, damping=0.05 * (i % 3), friction=0.2 * (i % 2))
              for i, j in enumerate(core.joints)]
    sim = ArticulatedSimulator(core.models, core.states, joints, timestep_ns=1_000_000)
    sim.set_motor(0, position=0.5, time_constant_s=0.05)
    sim.set_motor(2, velocity=1.0)
    sim.set_motor(4, effort=2.0)
    stops = 0
    for _ in range(2_500):
        sim.step()
        stops += sim.last_stop is not None
        assert max(sim.joint_error()) <= JOINT_TOL
        check_limits(sim)
    assert stops >= 1
