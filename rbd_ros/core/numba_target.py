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
