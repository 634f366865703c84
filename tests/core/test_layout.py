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
The named layouts of the kernel's packed arrays (:mod:`rbd_ros.core.layout`).

The names must tile each array exactly (no gap, no overlap, the stated sizes), pack and unpack
must round-trip bit for bit, and no module of the core may address a packed array by a bare
row number any more.
"""

import os
import pathlib
import re
import subprocess
import sys

import numpy as np
import pytest
from rbd_ros.core import (AppliedWrench, BatchSimulator, BodyModel, BodyState, jitcache,
                          layout, Spring)

CORE = pathlib.Path(layout.__file__).parent


def _spans(prefix, sizes):
    names = sorted((getattr(layout, n), n) for n in dir(layout)
                   if n.startswith(prefix) and isinstance(getattr(layout, n), int))
    return [(start, start + sizes[name], name) for start, name in names]


def _assert_tiles(spans, total):
    position = 0
    for start, end, name in spans:
        assert start == position, f'{name} starts at {start}, expected {position}'
        position = end
    assert position == total


def test_state_rows_tile_the_state_column():
    _assert_tiles(_spans('S_', {'S_POS': 3, 'S_QUAT': 4, 'S_VEL': 3, 'S_OMEGA': 3}),
                  layout.N_STATE)


def test_parameter_rows_tile_the_parameter_column():
    sizes = {'P_MASS': 1, 'P_INV_MASS': 1, 'P_INERTIA': 9, 'P_INV_INERTIA': 9, 'P_GRAVITY': 3,
             'P_LIN_DAMPING': 1, 'P_ANG_DAMPING': 1, 'P_DIAGONAL': 1}
    _assert_tiles(_spans('P_', sizes), layout.N_PARAM)


def test_load_fields_fit_the_load_row():
    spans = _spans('L_', {'L_KIND': 1, 'L_POINT': 3, 'L_A': 3, 'L_B': 3})
    _assert_tiles(spans, spans[-1][1])
    assert spans[-1][1] <= layout.N_LOAD


def test_layout_docstring_states_the_real_sizes():
    # The kernel's old comment said 25 parameter rows where there were 26.
    for name in ('N_STATE', 'N_PARAM', 'N_LOAD'):
        assert f'``{name}`` = {getattr(layout, name)}' in layout.__doc__


def test_state_packs_and_unpacks_bit_for_bit():
    rng = np.random.default_rng(8)
    state = BodyState(rng.normal(size=3), rng.normal(size=4), rng.normal(size=3),
                      rng.normal(size=3), time_ns=7)
    column = layout.pack_state(state)
    assert column.shape == (layout.N_STATE,)
    assert BodyState(**layout.unpack_state(column), time_ns=7) == state
    assert np.array_equal(column[layout.S_QUAT:layout.S_QUAT + 4], state.orientation_wb)


def test_simulator_arrays_follow_the_layout():
    rng = np.random.default_rng(9)
    model = BodyModel(2.0, np.diag([1.0, 2.0, 2.5]), gravity_w=(0.0, 0.0, -9.81))
    states = [BodyState(rng.normal(size=3), rng.normal(size=4), rng.normal(size=3),
                        rng.normal(size=3)) for _ in range(3)]
    batch = BatchSimulator(model, states)
    x, _ = batch.arrays
    for i, state in enumerate(states):
        assert np.array_equal(x[:, i], layout.pack_state(state))
        assert batch.body_state(i) == state


def test_params_pack_every_field_by_name():
    inertia = np.array([[2.0, 0.1, 0.0], [0.1, 3.0, 0.0], [0.0, 0.0, 4.0]])
    model = BodyModel(2.0, inertia, gravity_w=(1.0, 2.0, 3.0), linear_damping_per_s=0.5,
                      angular_damping_per_s=0.25)
    column = layout.pack_params(model)
    assert column.shape == (layout.N_PARAM,)
    assert column[layout.P_MASS] == 2.0 and column[layout.P_INV_MASS] == 0.5
    assert np.array_equal(column[layout.P_INERTIA:layout.P_INERTIA + 9].reshape(3, 3),
                          model.inertia_b)
    assert np.array_equal(column[layout.P_INV_INERTIA:layout.P_INV_INERTIA + 9].reshape(3, 3),
                          model.inertia_inv_b)
    assert np.array_equal(column[layout.P_GRAVITY:layout.P_GRAVITY + 3], [1.0, 2.0, 3.0])
    assert column[layout.P_LIN_DAMPING] == 0.5 and column[layout.P_ANG_DAMPING] == 0.25
    assert column[layout.P_DIAGONAL] == 0.0
    assert layout.pack_params(BodyModel(1.0, np.eye(3)))[layout.P_DIAGONAL] == 1.0


def test_load_rows_pack_and_unpack():
    rows = np.zeros((2, layout.N_LOAD))
    wrench = AppliedWrench((1.0, 2.0, 3.0), (4.0, 5.0, 6.0), 'body', (0.1, 0.2, 0.3))
    spring = Spring((0.0, 0.1, 0.0), (1.0, 1.0, 1.0), 30.0, 0.5, 0.25)
    layout.pack_wrench(rows[0], layout.LOAD_BODY, wrench.point_b, wrench.force, wrench.torque)
    layout.pack_spring(rows[1], spring.point_b, spring.anchor_w, 30.0, 0.5, 0.25)
    first, second = layout.unpack_load(rows[0]), layout.unpack_load(rows[1])
    assert first['kind'] == layout.LOAD_BODY
    assert np.array_equal(first['point_b'], wrench.point_b)
    assert np.array_equal(first['a'], wrench.force) and np.array_equal(first['b'], wrench.torque)
    assert second['kind'] == layout.LOAD_SPRING
    assert np.array_equal(second['a'], spring.anchor_w)
    assert np.array_equal(second['b'], [30.0, 0.5, 0.25])
    # Vectorised over bodies: one wrench row per body, the kind broadcast.
    batch = np.zeros((4, layout.N_LOAD))
    layout.pack_wrench(batch, layout.LOAD_WORLD, 0.0, np.ones((4, 3)), 2 * np.ones((4, 3)))
    assert np.all(batch[:, layout.L_KIND] == layout.LOAD_WORLD)
    assert np.all(batch[:, layout.L_B:layout.L_B + 3] == 2.0)


# A packed array indexed by a literal row number: prm[3, j], x[0, i], ld[i, k, 4], [7:10, ...
BARE_INDEX = re.compile(r'\b(?:prm|x|ld|column|row|rows|loads)\[(?:i, k, |:, 0, )?\d')


def test_core_modules_address_packed_arrays_by_name_only():
    offenders = []
    for name in ('kernels.py', 'kernel_rotations.py', 'kernel_forces.py',
                 'kernel_integrators.py', 'simulator.py'):
        for number, line in enumerate((CORE / name).read_text().splitlines(), 1):
            if BARE_INDEX.search(line):
                offenders.append(f'{name}:{number}: {line.strip()}')
    assert not offenders, '\n'.join(offenders)


def test_fingerprint_lists_every_constant_and_names_the_kernel_cache():
    # numba caches the kernel by its own file, not by the layout values it imports; the cache
    # directory is therefore one per layout fingerprint, so a changed offset recompiles.
    constants = {name for name in dir(layout) if name.isupper() and name != 'FINGERPRINT'
                 and isinstance(getattr(layout, name), int)}
    assert len(layout.FINGERPRINT) == len(constants)
    assert sorted(layout.FINGERPRINT) == sorted(getattr(layout, name) for name in constants)
    cache_dir = jitcache.configured()
    if cache_dir is not None:
        assert os.path.basename(cache_dir) == f'layout-{layout.fingerprint_hash()}'


#: A function compiled through one of the kernel decorators (rbd_ros.core.jitcache.kernel).
KERNEL_DECORATOR = re.compile(r'^@_(jit|inl|raw)\b', re.MULTILINE)


def test_every_compiled_source_is_in_the_kernel_cache_name():
    # A compiled function embeds what it calls, but numba checks only the caller's file before
    # loading it from the cache: a module of compiled functions left out of KERNEL_SOURCES
    # could be edited and the step would still run its old machine code from the cache.
    compiled = {path.relative_to(CORE).as_posix() for path in CORE.rglob('*.py')
                if 'njit(' in path.read_text() or KERNEL_DECORATOR.search(path.read_text())}
    assert compiled, 'no compiled module found: the scan is broken'
    assert compiled <= set(layout.KERNEL_SOURCES), compiled - set(layout.KERNEL_SOURCES)


@pytest.mark.parametrize('inherited', [False, True], ids=['set_by_the_user', 'inherited'])
def test_a_child_process_keeps_the_kernel_cache_it_inherits(tmp_path, inherited):
    # What a process sees that a Python parent (a test, a launch script) started after
    # importing rbd_ros: NUMBA_CACHE_DIR already names the fingerprint's directory, and the
    # child must use that one, not one nested below it (a second cache, compiled cold).
    leaf = f'layout-{layout.fingerprint_hash()}'
    given = tmp_path / leaf if inherited else tmp_path / 'mine'
    env = dict(os.environ, NUMBA_CACHE_DIR=str(given))
    out = subprocess.run([sys.executable, '-c', 'from rbd_ros.core import jitcache; '
                          'print(jitcache.configured())'], env=env, capture_output=True, text=True,
                         check=True, timeout=120).stdout.strip()
    assert out == str(given if inherited else given / leaf)
