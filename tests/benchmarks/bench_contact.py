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
Contact benchmark (issue 9): the analytic cases and the step cost, ours | MuJoCo | PyBullet.

``.venv/bin/python tests/benchmarks/bench_contact.py [--quick] [--only CASE]
[--pybullet-no-damping]`` (not collected by pytest; prints only).

One table per case (scenes, pair rules and what each figure means: ``contact_refs.py``), each
at h = 1 ms and 10 ms (the step costs at 1 ms), with the exact value where the physics has one
and a column per engine, all measured in this run. MuJoCo and PyBullet are benchmark-only
extras (``pip install -r tests/benchmarks/requirements.txt``); a column whose engine is not
installed says so. ``--quick``: 2 s instead of 10 s for the slope hold and the stacks, shorter
timing runs, and the cost per body at 100 and 1000 boxes only. Timings are medians of several
runs; the load average printed with them says how busy the shared machine was.
"""

import math
import os
import sys
import time

from bench_env import engine_arguments  # noqa: I100 (first: puts the source tree on sys.path)
import contact_refs  # noqa: I100
import numpy as np
from rbd_ros.core import layout
from rbd_ros.core.contact import ground_plane, Material, primitive_shape, StaticWorld
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.core.model import BodyModel
from rbd_ros.core.rotations import quat_to_matrix
from rbd_ros.core.state import BodyState


class OursWorld:
    """Our :class:`WorldSimulator` behind the interface of ``contact_refs.MujocoWorld``."""

    name = 'ours'
    notes = ('rbd_ros WorldSimulator, midpoint_cayley (kick-drift-kick), threads: the CPUs the '
             'process may use (the default)')

    def __init__(self, scene):
        self.scene = scene
        ground = ground_plane(material=Material(scene.mu, scene.restitution))
        bodies, states = [], []
        for k, b in enumerate(scene.bodies):
            dims = [b.size_m] * 3 if b.shape == 'box' else [b.size_m]
            shape = primitive_shape(b.shape, dims)
            model = BodyModel(b.mass_kg, shape.mass_properties(b.mass_kg).inertia_b,
                              gravity_w=scene.gravity_w)
            bodies.append(WorldBody(f'b{k}', model, shape,
                                    Material(scene.mu, scene.restitution)))
            states.append(BodyState(position_w=b.position_w))
        self.sim = WorldSimulator(bodies, states, StaticWorld(ground),
                                  timestep_ns=round(scene.h_s * 1e9))

    def step(self, n):
        self.sim.step(n)

    def state(self):
        x, _ = self.sim.arrays
        quat = x[layout.S_QUAT:layout.S_QUAT + 4].T
        return (x[layout.S_POS:layout.S_POS + 3].T.copy(),
                x[layout.S_VEL:layout.S_VEL + 3].T.copy(),
                contact_refs._rotate(quat, x[layout.S_OMEGA:layout.S_OMEGA + 3].T))

    def set_gravity(self, gravity_w):
        self.sim.set_gravity_w(gravity_w)

    def set_velocity(self, i, velocity_w, omega_w):
        states = [self.sim.body_state(k) for k in range(self.sim.size)]
        old = states[i]
        omega_b = contact_refs._rotate(old.orientation_wb[None], np.array([omega_w], float),
                                       True)[0]
        states[i] = BodyState(old.position_w, old.orientation_wb, velocity_w, omega_b,
                              old.time_ns)
        self.sim.reset(states)

    def penetration_m(self):
        x, _ = self.sim.arrays
        deepest = 0.0
        for k, b in enumerate(self.scene.bodies):
            shape = self.sim.bodies[k].shape
            rot = quat_to_matrix(x[layout.S_QUAT:layout.S_QUAT + 4, k])
            low = (shape.points_b @ rot.T)[:, 2].min() + x[layout.S_POS + 2, k]
            deepest = max(deepest, -low)
        return deepest

    def breakdown(self):
        """Sweeps per coupled island (collision / first contact / second) and cold restarts."""
        stats = self.sim.solve_stats()
        per = [s and w / s for s, w in zip(stats['stages'], stats['sweeps'])]
        return {'sweeps_per_stage': ' / '.join(f'{v:.3g}' for v in per),
                'cold_restarts': int(sum(stats['cold']))}

    def close(self):
        pass


# Our simulator's column: ``{case_name: fn(h_s, quick) -> dict}`` with the keys of the
# reference cases.
OURS = contact_refs.measurements(OursWorld)

VALUE_WIDTH = 17


def fmt(value):
    """Format a figure for a cell: 5 significant digits, exponent form when tiny or huge."""
    if isinstance(value, str):
        return value
    if value is None:
        return '-'
    if math.isnan(value):
        return 'nan'
    if value == 0.0 or 1e-3 <= abs(value) < 1e6:
        return f'{value:.5g}'
    return f'{value:.3e}'


def columns(no_damping):
    """``[(title, {case: fn} or a reason string)]``: ours, then each engine."""
    cols = [('ours', OURS)]
    engines = list(contact_refs.ENGINES.items())
    if no_damping:
        engines.append(('PyBullet, damping 0', ('pybullet', contact_refs.BulletWorldNoDamping)))
    for name, (module, world_cls) in engines:
        version = contact_refs.engine_version(module)
        if version is None:
            cols.append((name, 'not installed'))
        else:
            title = name if ',' in name else f'{name} {version}'
            cols.append((title, contact_refs.measurements(world_cls)))
    return cols


def measure(registry, case, h_s, quick):
    """One cell: the figures of ``case``, or a one-line reason instead of them."""
    if isinstance(registry, str):
        return registry
    if case not in registry:
        return 'not implemented'
    try:
        return registry[case](h_s, quick)
    except Exception as exc:  # one engine failing must not hide the others' figures
        return f'failed: {type(exc).__name__}: {exc}'.splitlines()[0][:60]


def print_case(case, cols, quick):
    """Measure ``case`` at each of its time steps in every column; print its table."""
    title = contact_refs.TITLES[case]
    load = os.getloadavg()
    print(f'\n{case}: {title} (load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f})',
          flush=True)
    exact = contact_refs.EXACT.get(case, {})
    head = ['h', 'figure', 'exact'] + [title for title, _ in cols]
    widths = [6, 24] + [VALUE_WIDTH] * (len(head) - 2)
    print('  ' + ''.join(h.ljust(w) for h, w in zip(head, widths)).rstrip())
    for h_s in contact_refs.STEPS_S[case]:
        t = time.perf_counter()
        cells = [measure(registry, case, h_s, quick) for _, registry in cols]
        keys = []
        for cell in cells + [exact]:
            if isinstance(cell, dict):
                keys += [k for k in cell if k not in keys]
        label = f'{h_s * 1e3:g} ms'
        if not keys:
            print('  ' + label.ljust(6) + '-'.ljust(24) + '-'.ljust(VALUE_WIDTH)
                  + ''.join(c.ljust(VALUE_WIDTH) for c in cells).rstrip())
        for key in keys:
            row = [label, key, fmt(exact.get(key))]
            row += [fmt(c.get(key)) if isinstance(c, dict) else c for c in cells]
            print('  ' + ''.join(v.ljust(w) for v, w in zip(row, widths)).rstrip())
            label = ''
        print(f'  ({time.perf_counter() - t:.1f} s)', flush=True)


def main():
    args = engine_arguments('contact', contact_refs.G, contact_refs.CASES)
    cols = columns(args.pybullet_no_damping)
    for name, (module, world_cls) in contact_refs.ENGINES.items():
        if contact_refs.installed(module):
            print(f'  {name}: {world_cls.notes}')
    for case in args.only or contact_refs.CASES:
        print_case(case, cols, args.quick)


if __name__ == '__main__':
    sys.exit(main())
