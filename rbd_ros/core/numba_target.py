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
numba's CPU target without its probe for scipy's BLAS, for rbd_ros's own processes.

The first kernel a process compiles or loads from the cache makes numba import
``numba.np.arraymath``, which imports ``scipy.linalg.cython_blas`` only to see whether
``np.correlate`` and ``np.convolve`` may call BLAS: with scipy installed that is ~0.25 s of CPU
in every node, replay and warm-up process that loads a kernel. No rbd_ros kernel
calls either function, and rbd_ros does not depend on scipy, so its executables
(``rigid_body_node``, ``replay``, ``plot``, ``python -m rbd_ros.core.warmup``) load numba as
it is without scipy: :func:`skip_blas_probe`. The compiled kernels are the same either way
(the numba cache is shared with processes that did import scipy). Only for those
executables: a program that imports rbd_ros as a library keeps numba as it finds it. Nothing
here runs at import.

Those executables also load a cached kernel without numba's registry refresh
(:func:`load_without_refresh`): numba refreshes its typing and lowering registries (imports every
module of its own that implements a Python or numpy function, and installs them all) before it
even looks in the cache, ~0.17 s of CPU in each process that loads a kernel (a node start takes
~1 s), although loading machine code from the cache needs only numba's runtime. A compile
refreshes them itself first, as before.
"""

import sys

#: What ``numba.np.arraymath`` imports to probe for BLAS.
BLAS_PROBE = 'scipy.linalg.cython_blas'


def skip_blas_probe():
    """
    Import ``numba.np.arraymath`` as without scipy, unless it or the probed module is loaded.

    The probed module reads as missing only during that import (``None`` in
    :data:`sys.modules`), so scipy stays importable afterwards, and numba's linear algebra
    (``np.dot``, ``np.linalg``) still finds its BLAS when a kernel needs it.
    """
    if 'numba.np.arraymath' in sys.modules or BLAS_PROBE in sys.modules:
        return
    sys.modules[BLAS_PROBE] = None
    try:
        import numba.np.arraymath  # noqa: F401 - the import is the point
    finally:
        if sys.modules.get(BLAS_PROBE, 0) is None:
            del sys.modules[BLAS_PROBE]


def _load_overload(self, sig, target_context):
    """Do what numba's ``Cache.load_overload`` does, with only the runtime set up first."""
    from numba.core.runtime import rtsys
    rtsys.initialize(target_context)  # the runtime's symbols, which the machine code calls
    with self._guard_against_spurious_io_errors():
        return self._load_overload(sig, target_context)


def load_without_refresh():
    """
    Make numba load a cached kernel without refreshing its registries first (once a process).

    numba's ``Cache.load_overload`` calls ``target_context.refresh()``, then loads. The refresh
    only matters to a compile, and numba's compiler refreshes both contexts itself before it
    compiles (``CompilerBase.__init__``), as its lowering does on a first miss; loading needs
    the runtime (``rtsys.initialize``: NRT's symbols, which the loaded machine code links
    against), which the refresh would have set up first. numba is pinned; another version's
    ``load_overload`` is left as it is. ``tests/core/test_import_effects.py`` checks that a
    kernel loaded this way steps to the same bits without numba's registry modules.
    """
    from numba.core import caching
    if caching.Cache.load_overload is _load_overload:
        return
    if caching.Cache.load_overload.__code__.co_names != _NUMBA_LOAD_NAMES:
        return  # not the pinned numba's: its own load, refresh included (slower, not wrong)
    caching.Cache.load_overload = _load_overload


#: The names numba 0.68's ``Cache.load_overload`` uses: what :func:`load_without_refresh`
#: replaces, and nothing else.
_NUMBA_LOAD_NAMES = ('refresh', '_guard_against_spurious_io_errors', '_load_overload')
