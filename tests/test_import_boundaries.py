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
Dependencies point one way, checked in fresh interpreters.

Below the node (core, config, session, inputs, recording, schemas) no rclpy and no message
package: these layers work with plain values and CDR bytes. The message modules
(conversions, outputs) and the tools on top of them (replay, plot) use message classes but
never rclpy. Only the node and the demo import rclpy.
"""

from pathlib import Path
import subprocess
import sys

import pytest

REPO = Path(__file__).resolve().parents[1]
RCLPY = ('rclpy',)
MESSAGE_PACKAGES = ('geometry_msgs', 'nav_msgs', 'diagnostic_msgs', 'rosgraph_msgs',
                    'tf2_msgs', 'builtin_interfaces', 'std_msgs', 'visualization_msgs')


def imported(modules, packages):
    """Import ``modules`` in a fresh interpreter; return which of ``packages`` got loaded."""
    code = (
        'import importlib, sys\n'
        f'for name in {modules!r}:\n'
        '    importlib.import_module(name)\n'
        f'print(sorted({{m.split(".")[0] for m in sys.modules}} & set({packages!r})))\n'
    )
    proc = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          cwd=REPO, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.strip()


@pytest.mark.parametrize('modules', [
    ('rbd_ros.core',),
    ('rbd_ros.core.contact',),
    ('rbd_ros.sim.config', 'rbd_ros.sim.inputs', 'rbd_ros.sim.session'),
    ('rbd_ros.msgs.schemas', 'rbd_ros.bag.recording'),
    ('rbd_ros.sim.tessellation', 'rbd_ros.bag.animate'),
])
def test_no_rclpy_and_no_messages_below_the_message_modules(modules):
    found = imported(modules, RCLPY + MESSAGE_PACKAGES)
    assert found == '[]', f'{modules} imported {found}'


@pytest.mark.parametrize('modules', [
    ('rbd_ros.msgs.conversions', 'rbd_ros.msgs.outputs'),
    ('rbd_ros.core', 'rbd_ros.bag.recording', 'rbd_ros.bag.replay'),
    ('rbd_ros.bag.plot',),
    ('rbd_ros.msgs.markers',),
])
def test_no_rclpy_in_the_message_modules_and_tools(modules):
    found = imported(modules, RCLPY)
    assert found == '[]', f'{modules} imported {found}'
