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
The ``rigid_body_node`` command: ``ros2 run rbd_ros rigid_body_node``, ``python -m rbd_ros.node``.

The node itself is :mod:`rbd_ros.ros.node`, its process :mod:`rbd_ros.ros.process`; this module
only starts it. Until the node's own signal handlers are in place (its imports take about a
second), SIGINT and SIGTERM end the process quietly with status 0: there is nothing to finalise
yet.
"""

import os
import signal
import sys


def _exit_quietly(signum, frame):
    os._exit(0)


def _import_numba_without_coverage():
    """
    Import numba as without coverage.py, unless coverage.py is loaded already.

    numba imports coverage.py, when installed, to report the lines of compiled code run under a
    running coverage measurement: ~0.05 s of CPU a start. A node measured by coverage.py has it
    loaded before this runs (``coverage run``, or its ``.pth`` hook for subprocesses), so
    numba sees it then; else nothing could have started a measurement yet. coverage.py reads as
    missing only during that import (``None`` in :data:`sys.modules`).
    """
    if 'numba' in sys.modules or 'coverage' in sys.modules:
        return
    sys.modules['coverage'] = None
    try:
        import numba  # noqa: F401 - the import is the point
    finally:
        if sys.modules.get('coverage', 0) is None:
            del sys.modules['coverage']


def main(args=None):
    """Start the node (see :func:`rbd_ros.ros.process.main`) and return its exit status."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _exit_quietly)
    _import_numba_without_coverage()
    from rbd_ros.ros import process
    return process.main(args)


if __name__ == '__main__':
    sys.exit(main())
