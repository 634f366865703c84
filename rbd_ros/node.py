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


def main(args=None):
    """Start the node (see :func:`rbd_ros.ros.process.main`) and return its exit status."""
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, _exit_quietly)
    from rbd_ros.ros import process
    return process.main(args)


if __name__ == '__main__':
    sys.exit(main())
