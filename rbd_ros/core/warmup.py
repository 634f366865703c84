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
Compile every physics kernel once, or load it from the cache: ``python -m rbd_ros.core.warmup``.

What a first step compiles, without a node or a parameter file: the free-body step
(:class:`~rbd_ros.core.Simulator`), the contact step (a box on a ground plane, the same compiled
specialisation every world uses), the joints step (a hinged rod: the same specialisation every
robot uses), the contact step with joints (a ball hinged above the ground: the specialisation of
every world with ``joint_names``) and, with ``--batch``, the threaded batch kernel. Each kind is
marked in the cache (:func:`jitcache.mark_compiled`) once it compiled, as the node does, so a
node started afterwards loads them and says nothing about compiling. The test suite runs this in
a background process while it runs the tests that need no kernel (``tests/conftest.py``); a
packager can run it after installing, so the first ``ros2 run`` starts warm.
"""

import argparse
import sys
import time

import numpy as np

from rbd_ros.core import jitcache, numba_target
from rbd_ros.core.inertia import box
from rbd_ros.core.model import BodyModel
from rbd_ros.core.simulator import BatchSimulator, Simulator
from rbd_ros.core.state import BodyState

#: The kinds of kernel, in the order :func:`compile_kernels` compiles them.
KINDS = ('free', 'contact', 'joints', 'world_joints', 'batch')


def _model():
    body = box(1.0, (0.2, 0.1, 0.05))
    return BodyModel(body.mass_kg, body.inertia_b)


def _free():
    Simulator(_model(), BodyState()).step(1)


def _contact():
    from rbd_ros.core.contact import ground_plane, Material, primitive_shape, StaticWorld
    from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
    shape = primitive_shape('box', [0.2, 0.2, 0.2])
    model = BodyModel(1.0, shape.mass_properties(1.0).inertia_b, gravity_w=(0, 0, -9.81))
    WorldSimulator([WorldBody('box', model, shape, Material(friction=0.5))],
                   [BodyState(position_w=(0, 0, 0.1))],
                   StaticWorld(ground_plane(material=Material(friction=0.5)))).step(1)


def _joints():
    from rbd_ros.core.joints import ArticulatedSimulator, Joint
    rod = BodyModel(1.0, np.diag([1 / 12, 1 / 12, 1e-3]), gravity_w=(0, 0, -9.81))
    hinge = Joint('pivot', 'revolute', None, 0, origin_child_b=(0, 0, 0.5), axis_b=(0, 1, 0),
                  lower=-1.0, upper=1.0, effort_limit=20.0)
    ArticulatedSimulator([rod], [BodyState(position_w=(0, 0, -0.5))], [hinge],
                         timestep_ns=1_000_000).step(1)


def _world_joints():
    from rbd_ros.core.contact import ground_plane, Material, primitive_shape, StaticWorld
    from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
    from rbd_ros.core.joints import Joint
    shape = primitive_shape('sphere', [0.1])
    model = BodyModel(1.0, shape.mass_properties(1.0).inertia_b, gravity_w=(0, 0, -9.81))
    hinge = Joint('pivot', 'revolute', None, 0, origin_parent_b=(0, 0, 0.7),
                  origin_child_b=(0, 0, 0.5), axis_b=(0, 1, 0))
    WorldSimulator([WorldBody('ball', model, shape, Material(friction=0.5))],
                   [BodyState(position_w=(0, 0, 0.2))],
                   StaticWorld(ground_plane(material=Material(friction=0.5))),
                   joints=[hinge]).step(1)


def _batch():
    model = _model()
    BatchSimulator([model, model], [BodyState(), BodyState()], threads=2).step(1)


COMPILERS = {'free': _free, 'contact': _contact, 'joints': _joints,
             'world_joints': _world_joints, 'batch': _batch}


def compile_kernels(kinds=KINDS, log=print):
    """
    Take one step of each kind in ``kinds``, compiling what the cache does not hold.

    :param log: called with one line per kind that had to compile (what, how long it took in
        wall and CPU seconds: on a loaded machine the wall time says little).
    :returns: wall seconds per kind.
    """
    jitcache.configured()
    taken = {}
    for kind in kinds:
        marked = kind in jitcache.KIND_MODULES
        cold = not (marked and jitcache.kernels_on_disk(kind))
        start, cpu = time.monotonic(), time.process_time()
        COMPILERS[kind]()
        taken[kind] = time.monotonic() - start
        if marked and cold:
            jitcache.mark_compiled(kind)
        if cold:
            log(f'{kind} kernels ready in {taken[kind]:.1f} s ({time.process_time() - cpu:.1f} '
                f'CPU-s; cache: {jitcache.CACHE_DIR})')
    return taken


def main(argv=None):
    """Compile every kernel kind but the threaded batch one (``--batch``: that one too)."""
    parser = argparse.ArgumentParser(prog='python -m rbd_ros.core.warmup',
                                     description=main.__doc__)
    parser.add_argument('--batch', action='store_true', help='also the threaded batch kernel')
    parser.add_argument('--only', choices=KINDS, action='append',
                        help='compile only this kind (repeatable)')
    parser.add_argument('--status-file', metavar='PATH',
                        help='write the exit status there at the end (for a process that '
                             'follows this one without being its parent: .ci/setup, the tests)')
    args = parser.parse_args(argv)
    status = 1
    try:
        numba_target.skip_blas_probe()
        numba_target.load_without_refresh()
        compile_kernels(args.only or (KINDS if args.batch else KINDS[:-1]))
        status = 0
    finally:
        if args.status_file:
            with open(args.status_file, 'w') as out:
                out.write(f'{status}\n')
    return status


if __name__ == '__main__':
    sys.exit(main())
