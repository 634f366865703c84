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
The set-up every node benchmark needs before it imports the test helpers (import it first).

The source tree and the test helpers on ``sys.path`` (and ``PYTHONPATH`` for the node
subprocesses), a DDS domain of the benchmark's own and localhost discovery.
"""

import os
import sys

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
for path in (os.path.join(REPO, 'tests', 'ros'), os.path.join(REPO, 'tests'), REPO):
    if path not in sys.path:
        sys.path.insert(0, path)
os.environ.setdefault('ROS_DOMAIN_ID', str(1 + os.getpid() % 101))
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ['PYTHONPATH'] = REPO


def engine_arguments(what, g, cases, argv=None):
    """
    Parse the options every benchmark beside the anchors takes; print its header line.

    ``--quick`` (a smoke run), ``--only CASE`` (repeatable) and ``--pybullet-no-damping``;
    the header names ``what``, gravity ``g`` (m/s²), the machine's load and its CPUs.
    """
    import argparse
    parser = argparse.ArgumentParser(description=f'{what} benchmark: ours and the anchors')
    parser.add_argument('--quick', action='store_true', help='shorter runs (a smoke run)')
    parser.add_argument('--only', choices=list(cases), action='append',
                        help='run only these cases (repeatable)')
    parser.add_argument('--pybullet-no-damping', action='store_true',
                        help='add a PyBullet column with its default damping 0.04 set to 0')
    args = parser.parse_args(argv)
    load = os.getloadavg()
    print(f'{what} benchmark, g = {g} m/s^2; load average {load[0]:.2f} {load[1]:.2f} '
          f'{load[2]:.2f} on {os.cpu_count()} CPUs; one thread per engine'
          f'{"; --quick" if args.quick else ""}')
    return args
