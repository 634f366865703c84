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
``colcon build`` of a copy of the package, then start the installed executable.

This is what a Jazzy user does (``colcon build``; ``source install/setup.bash``;
``ros2 run rbd_ros rigid_body_node``): ``ros2 run`` executes
``<prefix>/lib/rbd_ros/rigid_body_node`` with the install's site-packages on PYTHONPATH, which is
what the test reproduces without ros2cli (not in the PyPI wheels).
"""

import os
from pathlib import Path
import shutil
import subprocess
import sys

from conftest import FIRST_START_S

REPO = Path(__file__).resolve().parents[1]
PACKAGE_FILES = ('package.xml', 'setup.py', 'setup.cfg', 'resource', 'rbd_ros', 'msg_config')


def test_colcon_build_installs_a_runnable_rigid_body_node(tmp_path):
    source = tmp_path / 'src' / 'rbd_ros'
    source.mkdir(parents=True)
    for name in PACKAGE_FILES:
        path = REPO / name
        if path.is_dir():
            shutil.copytree(path, source / name,
                            ignore=shutil.ignore_patterns('__pycache__', '*.pyc'))
        else:
            shutil.copy2(path, source / name)
    colcon = Path(sys.executable).parent / 'colcon'
    env = {k: v for k, v in os.environ.items() if k != 'PYTHONPATH'}
    build = subprocess.run([str(colcon), 'build', '--base-paths', 'src'], cwd=tmp_path,
                           env=env, capture_output=True, text=True, timeout=600)
    assert build.returncode == 0, build.stdout + build.stderr
    prefix = tmp_path / 'install' / 'rbd_ros'
    executable = prefix / 'lib' / 'rbd_ros' / 'rigid_body_node'
    assert executable.is_file() and os.access(executable, os.X_OK)
    for name in ('replay', 'plot'):
        assert (prefix / 'lib' / 'rbd_ros' / name).is_file()
    assert (prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' / 'rbd_ros').is_file()
    assert (prefix / 'share' / 'rbd_ros' / 'package.xml').is_file()
    installed_config = prefix / 'share' / 'rbd_ros' / 'msg_config' / 'default.yaml'
    assert installed_config.is_file()

    site = next(prefix.glob('lib/python3*/site-packages'))
    run_env = dict(env, PYTHONPATH=str(site))
    which = subprocess.run([sys.executable, '-c', 'import rbd_ros; print(rbd_ros.__file__)'],
                           cwd=tmp_path, env=run_env, capture_output=True, text=True, timeout=60)
    assert which.stdout.startswith(str(site)), which.stdout + which.stderr
    run = subprocess.run(
        [str(executable), '--ros-args', '--params-file', str(installed_config),
         '-p', 'duration_s:=0.05', '-p', 'real_time_factor:=0.0'],
        cwd=tmp_path, env=run_env, capture_output=True, text=True, timeout=FIRST_START_S)
    assert run.returncode == 0, run.stdout + run.stderr
    assert 'duration_s reached at t = 50000000 ns' in run.stderr
    # A world with a mesh: installed with its mesh, which its relative mesh_path finds; and a
    # package:// URI found through the ament index (AMENT_PREFIX_PATH, as setup.bash sets it).
    mesh_world = prefix / 'share' / 'rbd_ros' / 'msg_config' / 'l_block_bin.yaml'
    assert (prefix / 'share' / 'rbd_ros' / 'msg_config' / 'meshes' / 'l_block.stl').is_file()
    for extra in ([], ['-p', 'mesh_path:=package://rbd_ros/msg_config/meshes/l_block.stl']):
        run = subprocess.run(
            [str(executable), '--ros-args', '--params-file', str(mesh_world),
             '-p', 'duration_s:=0.05', '-p', 'real_time_factor:=0.0', *extra],
            cwd=tmp_path, env=dict(run_env, AMENT_PREFIX_PATH=str(prefix)),
            capture_output=True, text=True, timeout=FIRST_START_S)
        assert run.returncode == 0, run.stdout + run.stderr
