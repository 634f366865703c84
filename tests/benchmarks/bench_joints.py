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
Joint benchmark (issue 27): closed forms and step cost, ours | MuJoCo | PyBullet | Drake.

``.venv/bin/python tests/benchmarks/bench_joints.py [--quick] [--only CASE]
[--pybullet-no-damping]`` (not collected by pytest; prints only).

One table per case (mechanisms and what each figure means: ``joint_anchors.py``), each at
h = 1 ms and 10 ms (the step costs and the upright arm at 1 ms), with the exact value where the
physics has one, the issue's target for our column, and a column per engine, all measured in
this run: ours (:class:`ArticulatedSimulator`), MuJoCo (Euler, its default, and RK4), PyBullet,
Drake (discrete, its default, and continuous with RK3). The engines are benchmark-only extras
(``pip install -r tests/benchmarks/requirements.txt``); a column whose engine does not import
says ``n/a`` and why. The cost tables add each engine's ratio to MuJoCo's (Euler) time.
``--quick``: shorter runs (a smoke run; the figures are not the issue's).
"""

import math
import os
import time

from bench_env import engine_arguments  # noqa: I100 (first: puts the source tree on sys.path)
import joint_anchors  # noqa: I100
import numpy as np
from rbd_ros.core.model import BodyModel
from rbd_ros.core.rotations import matrix_to_quat
from rbd_ros.core.state import BodyState


def _ours_unavailable():
    """Why our column cannot run, or None."""
    try:
        from rbd_ros.core.joints import ArticulatedSimulator  # noqa: F401
    except ImportError as exc:
        return f'n/a: {exc}'.splitlines()[0][:100]
    return None


class OursWorld:
    """Our :class:`ArticulatedSimulator` behind the interface of ``joint_anchors.MujocoWorld``."""

    name = 'ours'
    notes = 'rbd_ros ArticulatedSimulator (maximal coordinates, joint impulses), one thread'

    def __init__(self, mech):
        from rbd_ros.core.joints import ArticulatedSimulator, Joint
        self.mech = mech
        models, states, joints = [], [], []
        frames = joint_anchors.forward_kinematics(mech)
        for k, link in enumerate(mech.links):
            _, rot, com_w = frames[k]
            models.append(BodyModel(link.mass_kg, np.diag(link.inertia),
                                    gravity_w=mech.gravity_w))
            states.append(BodyState(position_w=com_w, orientation_wb=matrix_to_quat(rot)))
            # Body frames sit at the centres of mass, parallel to the link frames.
            if link.parent < 0:
                origin_parent = np.asarray(link.origin_m, float)
            else:
                origin_parent = (np.asarray(link.origin_m, float)
                                 - np.asarray(mech.links[link.parent].com_m, float))
            # an unlimited hinge is 'continuous' (as in URDF): its angle is read unwrapped
            kind = ('continuous' if link.kind == 'revolute' and link.lower is None
                    else link.kind)
            joints.append(Joint(link.name, kind, None if link.parent < 0 else link.parent,
                                k, origin_parent_b=tuple(origin_parent),
                                origin_child_b=tuple(-np.asarray(link.com_m, float)),
                                axis_b=link.axis, lower=link.lower, upper=link.upper))
        self.sim = ArticulatedSimulator(models, states, joints,
                                        timestep_ns=round(mech.h_s * 1e9))

    def step(self, n):
        self.sim.step(n)

    def q(self):
        return np.concatenate(self.sim.joint_positions())

    def qd(self):
        return np.concatenate(self.sim.joint_velocities())

    def energy(self):
        return float(self.sim.energy())

    def joint_forces(self):
        return np.linalg.norm(np.asarray(self.sim.joint_wrenches())[:, :3], axis=1)

    def joint_error(self):
        return self.sim.joint_error()

    def close(self):
        pass


VALUE_WIDTH = 18
COST_REFERENCE = 'MuJoCo'   # the cost tables' ratios are to this column


def fmt(value):
    """Format a figure for a cell: 5 significant digits, exponent form when tiny or huge."""
    if isinstance(value, str):
        return value
    if value is None:
        return '-'
    value = float(value)
    if math.isnan(value):
        return 'nan'
    if value == 0.0 or 1e-3 <= abs(value) < 1e6:
        return f'{value:.5g}'
    return f'{value:.3e}'


def columns(no_damping):
    """``[(title, {case: fn} or a reason string)]``: ours, then each engine."""
    # the reason in full is printed above the tables
    cols = [('ours', 'n/a (see top)' if _ours_unavailable()
             else joint_anchors.measurements(OursWorld))]
    engines = list(joint_anchors.ENGINES.items())
    if no_damping:
        engines.insert(3, ('PyBullet, damping 0',
                           ('pybullet', joint_anchors.BulletWorldNoDamping)))
    for name, (module, world_cls) in engines:
        version = joint_anchors.engine_version(module)
        if version is None:
            cols.append((name, f'n/a: no module {module}'))
        else:
            title = name if ',' in name else f'{name} {version}'
            cols.append((title, joint_anchors.measurements(world_cls)))
    return cols


def measure(registry, case, h_s, quick):
    """One cell: the figures of ``case``, or a one-line reason instead of them."""
    if isinstance(registry, str):
        return registry
    try:
        return registry[case](h_s, quick)
    except Exception as exc:  # one engine failing must not hide the others' figures
        print(f'  {case} at {h_s * 1e3:g} ms failed: {type(exc).__name__}: {exc}'.splitlines()[0])
        return 'failed (above)'


def print_case(case, cols, quick):
    """Measure ``case`` at each of its time steps in every column; print its table."""
    load = os.getloadavg()
    print(f'\n{case}: {joint_anchors.TITLES[case]} (load average {load[0]:.2f} {load[1]:.2f} '
          f'{load[2]:.2f})', flush=True)
    exact = joint_anchors.EXACT.get(case, {})
    targets = joint_anchors.TARGETS.get(case, {})
    head = ['h', 'figure', 'exact', 'target'] + [title for title, _ in cols]
    widths = [6, 22] + [VALUE_WIDTH] * (len(head) - 2)
    print('  ' + ''.join(h.ljust(w) for h, w in zip(head, widths)).rstrip())
    for h_s in joint_anchors.STEPS_S[case]:
        t = time.perf_counter()
        cells = [measure(registry, case, h_s, quick) for _, registry in cols]
        keys = []
        for cell in cells + [exact]:
            if isinstance(cell, dict):
                keys += [k for k in cell if k not in keys]
        label = f'{h_s * 1e3:g} ms'
        if not keys:
            print('  ' + label.ljust(6) + '-'.ljust(22) + '-'.ljust(VALUE_WIDTH) * 2
                  + ''.join(c.ljust(VALUE_WIDTH) for c in cells).rstrip())
        for key in keys:
            row = [label, key, fmt(exact.get(key)), fmt(targets.get(key, {}).get(h_s))]
            row += [fmt(c.get(key)) if isinstance(c, dict) else c for c in cells]
            print('  ' + ''.join(v.ljust(w) for v, w in zip(row, widths)).rstrip())
            label = ''
        if case.startswith('cost'):
            ref = [c for (title, _), c in zip(cols, cells) if title.startswith(COST_REFERENCE)
                   and not title.startswith(COST_REFERENCE + ' RK4')]
            for key, name in (('us_per_step', 'ratio'), ('cpu_us_per_step', 'cpu_ratio')):
                base = ref[0].get(key) if ref and isinstance(ref[0], dict) else None
                row = ['', f'{name}_to_{COST_REFERENCE}', '-', '1']
                row += [fmt(c[key] / base) if base and isinstance(c, dict) else '-'
                        for c in cells]
                print('  ' + ''.join(v.ljust(w) for v, w in zip(row, widths)).rstrip())
        print(f'  ({time.perf_counter() - t:.1f} s)', flush=True)


def main():
    args = engine_arguments('joint', joint_anchors.G, joint_anchors.CASES)
    cols = columns(args.pybullet_no_damping)
    reason = _ours_unavailable()
    print(f'  ours: {reason or OursWorld.notes}')
    for name, (module, world_cls) in joint_anchors.ENGINES.items():
        if joint_anchors.installed(module):
            print(f'  {name}: {world_cls.notes}')
        else:
            print(f'  {name}: n/a (no module {module}; pip install -r '
                  'tests/benchmarks/requirements.txt)')
    for case in args.only or joint_anchors.CASES:
        print_case(case, cols, args.quick)


if __name__ == '__main__':
    main()
