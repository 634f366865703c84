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
Importing :mod:`rbd_ros.core` does nothing a user did not ask for (issue 26, item 4).

Every module of the package is imported in a fresh process whose home and cache directories
are empty: no directory may appear and no environment variable may change. The kernel cache
is chosen only when it is needed (:func:`rbd_ros.core.jitcache.configured`, called when a
simulator is built), which the last part checks, so the test can tell the two apart.
"""

import json
import os
import subprocess
import sys

from rbd_ros.core import layout

PROBE = """
import importlib, json, os, pkgutil
import rbd_ros.core as core
before = dict(os.environ)
names = sorted(m.name for m in pkgutil.walk_packages(core.__path__, 'rbd_ros.core.'))
for name in names:
    importlib.import_module(name)
changed = sorted(k for k in set(os.environ) | set(before) if os.environ.get(k) != before.get(k))
after_import = sorted(os.listdir(os.environ['HOME']))
from rbd_ros.core import BodyModel, Simulator
Simulator(BodyModel(1.0, [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]))
print(json.dumps({'names': names, 'changed': changed, 'after_import': after_import,
                  'after_build': sorted(os.listdir(os.environ['HOME'])),
                  'numba_cache_dir': os.environ.get('NUMBA_CACHE_DIR')}))
"""


def test_importing_core_creates_no_directory_and_sets_no_environment(tmp_path):
    env = {k: v for k, v in os.environ.items() if k not in ('NUMBA_CACHE_DIR', 'XDG_CACHE_HOME')}
    env['HOME'] = str(tmp_path)
    out = subprocess.run([sys.executable, '-c', PROBE], env=env, capture_output=True,
                         text=True, check=True, timeout=120).stdout
    seen = json.loads(out.strip().splitlines()[-1])
    # Not vacuous: the walk found the contact stages and the kernel modules.
    assert {'rbd_ros.core.kernels', 'rbd_ros.core.jitcache', 'rbd_ros.core.contact.step',
            'rbd_ros.core.contact.sweeps'} <= set(seen['names'])
    assert seen['changed'] == []
    assert seen['after_import'] == []
    # Building a simulator chooses the cache: ~/.cache/rbd_ros/numba/layout-<hash>.
    assert seen['after_build'] == ['.cache']
    assert seen['numba_cache_dir'] == os.path.join(
        str(tmp_path), '.cache', 'rbd_ros', 'numba', f'layout-{layout.fingerprint_hash()}')


BLAS_PROBE = """
import importlib.util, json, sys
skip = sys.argv[1] == 'skip'
if skip:
    from rbd_ros.core import numba_target
    numba_target.skip_blas_probe()
import numba.np.arraymath as arraymath
seen = {'probed': 'scipy.linalg.cython_blas' in sys.modules, 'blas': arraymath._HAVE_BLAS,
        'scipy': importlib.util.find_spec('scipy') is not None}
if seen['scipy']:  # still importable afterwards: numba's linear algebra finds it when needed
    import scipy.linalg.cython_blas  # noqa: F401
    seen['importable'] = True
print(json.dumps(seen))
"""


def test_the_executables_load_numba_without_its_scipy_blas_probe():
    """
    Numba imports scipy.linalg (~0.25 s of CPU) only to see whether np.correlate may use BLAS.

    rbd_ros's executables skip that (rbd_ros.core.numba_target): without it the probe runs
    whenever scipy is installed, which is what makes this test able to fail.
    """
    def run(how):
        out = subprocess.run([sys.executable, '-c', BLAS_PROBE, how], capture_output=True,
                             text=True, check=True, timeout=120).stdout
        return json.loads(out.strip().splitlines()[-1])
    plain, skipped = run('plain'), run('skip')
    assert plain['probed'] == plain['blas'] == plain['scipy']
    assert not skipped['probed'] and not skipped['blas']
    assert skipped.get('importable', True)


LOAD_PROBE = """
import hashlib, json, sys
from rbd_ros.core import numba_target
if sys.argv[1] == 'without':
    numba_target.load_without_refresh()
from rbd_ros.core import BodyModel, BodyState, kernels, Simulator
from rbd_ros.core.inertia import box
body = box(2.0, (0.3, 0.2, 0.1))
simulator = Simulator(BodyModel(body.mass_kg, body.inertia_b, gravity_w=(0, 0, -9.81)),
                      BodyState(angular_velocity_b=(3.0, 0.2, -1.0)),
                      integrator='midpoint_cayley')
simulator.step(500)
state = simulator.state
bits = hashlib.sha256(b''.join(v.tobytes() for v in (
    state.position_w, state.orientation_wb, state.linear_velocity_w,
    state.angular_velocity_b))).hexdigest()
stats = kernels.advance.stats
print(json.dumps({'bits': bits, 'hits': sum(stats.cache_hits.values()),
                  'misses': sum(stats.cache_misses.values()),
                  'registries': sorted(m for m in REGISTRIES if m in sys.modules)}))
"""
#: Modules that only numba's registry refresh imports (numba.core.cpu.load_additional_registries).
REGISTRIES = ('numba.np.linalg', 'numba.np.polynomial.polynomial_core', 'numba.typed.typeddict',
              'numba.typed.typedlist', 'numba.experimental.function_type')


def test_the_executables_load_a_cached_kernel_without_refreshing_numbas_registries():
    """
    A cached kernel loaded without numba's registry refresh steps to the same bits (~0.17 s).

    rbd_ros's executables (node, replay, plot, warm-up) load their kernels that way
    (:func:`rbd_ros.core.numba_target.load_without_refresh`); numba's own load imports and
    installs every registry first, which is what makes this test able to fail.
    """
    def run(how):
        out = subprocess.run([sys.executable, '-c', f'REGISTRIES = {REGISTRIES!r}\n' + LOAD_PROBE,
                              how], capture_output=True, text=True, check=True,
                             timeout=600).stdout
        return json.loads(out.strip().splitlines()[-1])
    run('with')  # compiled into the cache, if it was not (the free-body tier: it is)
    plain, without = run('with'), run('without')
    assert plain['hits'] == without['hits'] > 0 and plain['misses'] == without['misses'] == 0
    assert without['bits'] == plain['bits']
    assert plain['registries'] == sorted(REGISTRIES)
    assert without['registries'] == []
