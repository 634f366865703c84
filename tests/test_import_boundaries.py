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

"""Dependencies point one way: core, recording, replay and plot never import rclpy."""

from pathlib import Path
import subprocess
import sys

import pytest

REPO = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize('modules', [
    ('rbd_ros.core',),
    ('rbd_ros.core', 'rbd_ros.recording', 'rbd_ros.replay'),
    ('rbd_ros.schemas', 'rbd_ros.recording'),
    ('rbd_ros.plot',),
])
def test_no_rclpy_in_a_fresh_interpreter(modules):
    code = (
        'import importlib, sys\n'
        f'for name in {modules!r}:\n'
        '    importlib.import_module(name)\n'
        'print(sorted(m for m in sys.modules if m == "rclpy" or m.startswith("rclpy.")))\n'
    )
    proc = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          cwd=REPO, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == '[]', f'{modules} imported {proc.stdout.strip()}'
